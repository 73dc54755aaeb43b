/* pf's own readers of Wavefront OBJ and OFF surfaces, in double precision.
 *
 * OBJ: "v x y z [w | r g b]" positions, "f" polygons of "v", "v/t", "v//n" or "v/t/n" references
 * (1-based, negative counts back from the latest vertex); every other statement (vt, vn, g, o, s,
 * usemtl, mtllib, l, p, ...) is about things a solid's boundary does not need and is skipped.
 * OFF: an optional ST/C/N prefix on the keyword, then "nv nf ne", nv positions and nf polygons
 * "n i0 .. in-1" (0-based), colours after either ignored. The counts are checked against the
 * bytes left before anything is allocated. */
#include "surface_soup.h"
#include "text_reader.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

/* The statement keyword of the current line (its first token) compared with word. */
static bool keyword_is(const char *tok, size_t len, const char *word)
{
    return len == strlen(word) && memcmp(tok, word, len) == 0;
}

/* A position: three finite numbers, then whatever the line adds (w, a colour) ignored. */
static pf_status read_position(text_reader *r, surface_soup *soup, pf_error *err)
{
    double p[3];
    for (int c = 0; c < 3; ++c)
        PF_TRY(pf_text_reader_double(r, &p[c], "a vertex coordinate", err));
    return pf_surface_soup_vertex(soup, p, err);
}

/* The vertex of an OBJ face reference "v[/t[/n]]" as a 0-based index. */
static pf_status obj_reference(text_reader *r, const char *tok, size_t len, int64_t n_verts,
                               uint32_t *out, pf_error *err)
{
    char buf[32];
    size_t n = 0;
    while (n < len && tok[n] != '/')
        ++n;
    TEXT_CHECK(n > 0 && n < sizeof buf, r, err, PF_ERR_FORMAT,
               "expected a vertex reference, found '%.*s'", (int)(len < 24 ? len : 24), tok);
    memcpy(buf, tok, n);
    buf[n] = '\0';
    char *end;
    errno = 0;
    long long v = strtoll(buf, &end, 10);
    TEXT_CHECK(*end == '\0' && errno == 0, r, err, PF_ERR_FORMAT,
               "expected a vertex reference, found '%s'", buf);
    /* 1-based from the start, or negative: -1 is the latest vertex read. */
    long long index = v > 0 ? v - 1 : n_verts + v;
    TEXT_CHECK(v != 0 && index >= 0 && index < n_verts, r, err, PF_ERR_FORMAT,
               "face refers to vertex %lld, but %lld vertices are defined so far", v,
               (long long)n_verts);
    *out = (uint32_t)index;
    return PF_OK;
}

static pf_status obj_face(text_reader *r, surface_soup *soup, uint32_t *poly, pf_error *err)
{
    int64_t n = 0;
    size_t len;
    for (const char *tok; (tok = pf_text_reader_token(r, &len)) != NULL; ++n) {
        TEXT_CHECK(n < SURFACE_POLYGON_MAX, r, err, PF_ERR_TOO_LARGE,
                   "face of more than %d vertices: more than pf triangulates",
                   (int)SURFACE_POLYGON_MAX);
        PF_TRY(obj_reference(r, tok, len, soup->n_verts, &poly[n], err));
    }
    return pf_surface_soup_polygon(soup, poly, n, err);
}

pf_status pf_surface_read_obj(const char *path, surface_soup *soup, pf_error *err)
{
    text_reader r;
    PF_TRY(pf_text_reader_open(&r, path, '#', err));
    uint32_t *poly = pf_alloc_array(SURFACE_POLYGON_MAX, sizeof *poly);
    pf_status st = poly ? PF_OK
                        : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    while (st == PF_OK && pf_text_reader_next_line(&r)) {
        size_t len;
        const char *key = pf_text_reader_token(&r, &len);
        if (keyword_is(key, len, "v"))
            st = read_position(&r, soup, err);
        else if (keyword_is(key, len, "f"))
            st = obj_face(&r, soup, poly, err);
    }
    pf_free(poly);
    pf_text_reader_close(&r);
    return st;
}

/* "OFF", "COFF", "NOFF", "STOFF", "STCNOFF", ...: the optional prefixes name per-vertex extras
 * (texture, colour, normal) that follow the position and are ignored. 4OFF and nOFF (other
 * dimensions) are refused. Returns the length of the keyword or 0. */
static size_t off_keyword(const char *tok, size_t len)
{
    size_t i = 0;
    if (len >= 2 && tok[0] == 'S' && tok[1] == 'T')
        i = 2;
    if (i < len && tok[i] == 'C')
        ++i;
    if (i < len && tok[i] == 'N')
        ++i;
    return len - i == 3 && memcmp(tok + i, "OFF", 3) == 0 ? len : 0;
}

static pf_status off_counts(text_reader *r, int64_t *nv, int64_t *nf, pf_error *err)
{
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    TEXT_CHECK(tok && off_keyword(tok, len), r, err, PF_ERR_FORMAT,
               "not an OFF file: expected OFF (or COFF, NOFF, STOFF, ...) first");
    if (pf_text_reader_at_line_end(r))
        TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
                   "file ends before the vertex and face counts");
    int64_t ne;
    PF_TRY(pf_text_reader_int(r, nv, "the vertex count", err));
    PF_TRY(pf_text_reader_int(r, nf, "the face count", err));
    PF_TRY(pf_text_reader_int(r, &ne, "the edge count", err));
    /* A vertex line holds at least 3 tokens, a face line at least 4. */
    PF_TRY(pf_text_reader_check_count(r, *nv, 3, "vertices", err));
    PF_TRY(pf_text_reader_check_count(r, *nf, 4, "faces", err));
    return PF_OK;
}

static pf_status off_face(text_reader *r, surface_soup *soup, uint32_t *poly, pf_error *err)
{
    int64_t n;
    PF_TRY(pf_text_reader_int(r, &n, "the face's vertex count", err));
    TEXT_CHECK(n >= 0 && n <= SURFACE_POLYGON_MAX, r, err, n < 0 ? PF_ERR_FORMAT : PF_ERR_TOO_LARGE,
               "face of %lld vertices (0 .. %d)", (long long)n, (int)SURFACE_POLYGON_MAX);
    for (int64_t i = 0; i < n; ++i) {
        int64_t v;
        PF_TRY(pf_text_reader_int(r, &v, "a vertex index", err));
        TEXT_CHECK(v >= 0 && v < soup->n_verts, r, err, PF_ERR_FORMAT,
                   "face refers to vertex %lld, but the file defines %lld (0-based)",
                   (long long)v, (long long)soup->n_verts);
        poly[i] = (uint32_t)v;
    }
    return pf_surface_soup_polygon(soup, poly, n, err);
}

pf_status pf_surface_read_off(const char *path, surface_soup *soup, pf_error *err)
{
    text_reader r;
    PF_TRY(pf_text_reader_open(&r, path, '#', err));
    uint32_t *poly = pf_alloc_array(SURFACE_POLYGON_MAX, sizeof *poly);
    pf_status st = poly ? PF_OK
                        : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    int64_t nv = 0, nf = 0;
    if (st == PF_OK && !pf_text_reader_next_line(&r))
        st = TEXT_FAIL(&r, err, PF_ERR_FORMAT, "no OFF header (only comments and blanks)");
    if (st == PF_OK)
        st = off_counts(&r, &nv, &nf, err);
    for (int64_t i = 0; st == PF_OK && i < nv + nf; ++i) {
        if (!pf_text_reader_next_line(&r))
            st = TEXT_FAIL(&r, err, PF_ERR_FORMAT, "file ends after %lld of %lld %s",
                           (long long)(i < nv ? i : i - nv), (long long)(i < nv ? nv : nf),
                           i < nv ? "vertices" : "faces");
        else
            st = i < nv ? read_position(&r, soup, err) : off_face(&r, soup, poly, err);
    }
    pf_free(poly);
    pf_text_reader_close(&r);
    return st;
}
