/* pf's own reader of STL surfaces, ASCII and binary, in double precision.
 *
 * Binary STL: an 80-byte header, a u32 triangle count, then 50 bytes per triangle (normal and three
 * corners as little-endian float32, a u16 attribute). A file is taken as binary when its size is
 * exactly what its count announces, as ASCII when it starts with "solid" otherwise (binary headers
 * may start with "solid" too), as binary again when it does not; the count is checked against the
 * file size before anything is allocated. ASCII STL: "facet normal ... outer loop, vertex x y z
 * (three or more), endloop, endfacet" within "solid ... endsolid", several solids allowed. The
 * normals are ignored: the corners' order gives the orientation. Corners come one per triangle
 * and are joined by position afterwards. */
#include "surface_soup.h"
#include "text_reader.h"

#include <math.h>
#include <string.h>

enum { STL_HEADER = 80, STL_RECORD = 50 };

static uint32_t le_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static double le_f32(const unsigned char *p)
{
    uint32_t bits = le_u32(p);
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static pf_status read_binary(const text_reader *r, surface_soup *soup, pf_error *err)
{
    const unsigned char *d = (const unsigned char *)r->data;
    PF_CHECK(r->size >= STL_HEADER + 4, err, PF_ERR_FORMAT,
             "%s: %zu bytes: neither ASCII STL (no 'solid' at the start) nor binary STL (shorter "
             "than the 84-byte header)", r->path, r->size);
    const uint64_t n = le_u32(d + STL_HEADER);
    const uint64_t need = STL_HEADER + 4 + STL_RECORD * n;
    PF_CHECK(need <= r->size, err, PF_ERR_FORMAT,
             "%s: byte 80: %llu triangles announced, more than the file's %zu bytes hold (binary "
             "STL: 84 + 50 per triangle)", r->path, (unsigned long long)n, r->size);
    PF_CHECK(n <= INT32_MAX / 3, err, PF_ERR_TOO_LARGE, "%s: %llu triangles: more than pf handles",
             r->path, (unsigned long long)n);
    for (uint64_t t = 0; t < n; ++t) {
        const unsigned char *rec = d + STL_HEADER + 4 + STL_RECORD * t;
        uint32_t tri[3];
        for (int c = 0; c < 3; ++c) {
            double p[3];
            for (int k = 0; k < 3; ++k)
                p[k] = le_f32(rec + 12 + 12 * c + 4 * k);
            PF_CHECK(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]), err, PF_ERR_FORMAT,
                     "%s: byte %llu: triangle %llu has a non-finite corner", r->path,
                     (unsigned long long)(rec - d), (unsigned long long)t);
            tri[c] = (uint32_t)soup->n_verts;
            PF_TRY(pf_surface_soup_vertex(soup, p, err));
        }
        PF_TRY(pf_surface_soup_polygon(soup, tri, 3, err));
    }
    return PF_OK;
}

static bool is_keyword(const char *tok, size_t len, const char *word)
{
    return tok && len == strlen(word) && memcmp(tok, word, len) == 0;
}

/* One line of an ASCII STL; *corners is -1 outside a facet, the corners read so far inside. */
static pf_status ascii_line(text_reader *r, surface_soup *soup, uint32_t *poly, int64_t *corners,
                            pf_error *err)
{
    size_t len;
    const char *key = pf_text_reader_token(r, &len);
    const bool in_facet = *corners >= 0;
    if (is_keyword(key, len, "solid") || is_keyword(key, len, "endsolid")) {
        TEXT_CHECK(!in_facet, r, err, PF_ERR_FORMAT, "'%.*s' inside a facet", (int)len, key);
        return PF_OK; /* the rest of the line is the solid's name */
    }
    if (is_keyword(key, len, "facet")) {
        TEXT_CHECK(!in_facet, r, err, PF_ERR_FORMAT, "'facet' inside a facet (missing endfacet)");
        *corners = 0;
        return PF_OK; /* "normal nx ny nz": ignored */
    }
    if (is_keyword(key, len, "vertex")) {
        TEXT_CHECK(in_facet, r, err, PF_ERR_FORMAT, "'vertex' outside a facet");
        TEXT_CHECK(*corners < SURFACE_POLYGON_MAX, r, err, PF_ERR_TOO_LARGE,
                   "facet of more than %d corners: more than pf triangulates",
                   (int)SURFACE_POLYGON_MAX);
        double p[3];
        for (int c = 0; c < 3; ++c)
            PF_TRY(pf_text_reader_double(r, &p[c], "a vertex coordinate", err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the vertex", err));
        poly[(*corners)++] = (uint32_t)soup->n_verts;
        return pf_surface_soup_vertex(soup, p, err);
    }
    if (is_keyword(key, len, "endfacet")) {
        TEXT_CHECK(in_facet, r, err, PF_ERR_FORMAT, "'endfacet' outside a facet");
        int64_t n = *corners;
        *corners = -1;
        return pf_surface_soup_polygon(soup, poly, n, err);
    }
    if (is_keyword(key, len, "outer") || is_keyword(key, len, "endloop")) {
        TEXT_CHECK(in_facet, r, err, PF_ERR_FORMAT, "'%.*s' outside a facet", (int)len, key);
        return PF_OK;
    }
    return TEXT_FAIL(r, err, PF_ERR_FORMAT, "unexpected '%.*s' in an ASCII STL file",
                     (int)(len < 24 ? len : 24), key);
}

static pf_status read_ascii(text_reader *r, surface_soup *soup, pf_error *err)
{
    uint32_t *poly = pf_alloc_array(SURFACE_POLYGON_MAX, sizeof *poly);
    PF_CHECK(poly, err, PF_ERR_NOMEM, "out of memory");
    int64_t corners = -1;
    pf_status st = PF_OK;
    while (st == PF_OK && pf_text_reader_next_line(r))
        st = ascii_line(r, soup, poly, &corners, err);
    if (st == PF_OK && corners >= 0)
        st = TEXT_FAIL(r, err, PF_ERR_FORMAT, "file ends inside a facet");
    pf_free(poly);
    return st;
}

/* True when the file starts (after blanks) with the word "solid". */
static bool starts_with_solid(const text_reader *r)
{
    size_t i = 0;
    while (i < r->size && (r->data[i] == ' ' || r->data[i] == '\t' || r->data[i] == '\r' ||
                           r->data[i] == '\n'))
        ++i;
    return r->size - i >= 5 && memcmp(r->data + i, "solid", 5) == 0;
}

pf_status pf_surface_read_stl(const char *path, surface_soup *soup, pf_error *err)
{
    text_reader r;
    PF_TRY(pf_text_reader_open(&r, path, '\0', err));
    bool binary = !starts_with_solid(&r);
    if (r.size >= STL_HEADER + 4 &&
        STL_HEADER + 4 + STL_RECORD * (uint64_t)le_u32((const unsigned char *)r.data + STL_HEADER) ==
            r.size)
        binary = true;
    pf_status st = binary ? read_binary(&r, soup, err) : read_ascii(&r, soup, err);
    pf_text_reader_close(&r);
    return st;
}
