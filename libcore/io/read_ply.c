/* pf's own reader of PLY surfaces (ASCII, binary little- and big-endian), in double precision.
 *
 * The header declares elements with counts and typed properties. The "vertex" element's x, y, z
 * (any numeric type, read exactly into double) and the "face" element's list "vertex_indices" (or
 * "vertex_index") are used; every other element and property is read past. Before anything is
 * allocated, the counts are checked against the bytes after the header: every record takes at
 * least the sum of its fixed-size properties and list counts (binary) or one token per property
 * (ASCII, one record per line). */
#include "surface_soup.h"
#include "text_reader.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

enum { PLY_MAX_ELEMENTS = 32, PLY_MAX_PROPERTIES = 64, PLY_NAME_MAX = 48 };

typedef enum ply_type { T_NONE, T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64 } ply_type;
typedef enum ply_format { PLY_ASCII, PLY_LE, PLY_BE } ply_format;
typedef enum ply_role { ROLE_OTHER = -1, ROLE_X, ROLE_Y, ROLE_Z, ROLE_INDICES } ply_role;
typedef enum ply_kind { KIND_OTHER, KIND_VERTEX, KIND_FACE } ply_kind;

typedef struct ply_property {
    ply_type type;       /* of the value, or of a list's items */
    ply_type count_type; /* T_NONE for a scalar, the type of the item count for a list */
    ply_role role;
} ply_property;

typedef struct ply_element {
    char name[PLY_NAME_MAX];
    ply_kind kind;
    int64_t count;
    int64_t line; /* of its "element" line in the header */
    int n_props;
    ply_property props[PLY_MAX_PROPERTIES];
} ply_element;

typedef struct ply_header {
    ply_format format;
    int n_elements;
    ply_element elements[PLY_MAX_ELEMENTS];
    int64_t n_verts; /* count of the vertex element */
} ply_header;

static const struct {
    const char *name;
    ply_type type;
} TYPE_NAMES[] = {{"char", T_I8},     {"int8", T_I8},     {"uchar", T_U8},   {"uint8", T_U8},
                  {"short", T_I16},   {"int16", T_I16},   {"ushort", T_U16}, {"uint16", T_U16},
                  {"int", T_I32},     {"int32", T_I32},   {"uint", T_U32},   {"uint32", T_U32},
                  {"float", T_F32},   {"float32", T_F32}, {"double", T_F64}, {"float64", T_F64}};

static size_t type_size(ply_type t)
{
    static const size_t SIZE[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
    return SIZE[t];
}

static bool token_is(const char *tok, size_t len, const char *word)
{
    return tok && len == strlen(word) && memcmp(tok, word, len) == 0;
}

static pf_status read_type(text_reader *r, ply_type *t, pf_error *err)
{
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    for (size_t i = 0; tok && i < sizeof TYPE_NAMES / sizeof TYPE_NAMES[0]; ++i)
        if (token_is(tok, len, TYPE_NAMES[i].name)) {
            *t = TYPE_NAMES[i].type;
            return PF_OK;
        }
    return TEXT_FAIL(r, err, PF_ERR_FORMAT, "expected a property type (char, uchar, short, ushort, "
                                            "int, uint, float, double, int8 .. float64), found "
                                            "'%.*s'",
                     tok ? (int)(len < 24 ? len : 24) : 0, tok ? tok : "");
}

static pf_status read_property(text_reader *r, ply_element *e, pf_error *err)
{
    TEXT_CHECK(e, r, err, PF_ERR_FORMAT, "property before any element");
    TEXT_CHECK(e->n_props < PLY_MAX_PROPERTIES, r, err, PF_ERR_UNSUPPORTED,
               "element '%s' has more than %d properties", e->name, PLY_MAX_PROPERTIES);
    ply_property *p = &e->props[e->n_props++];
    p->count_type = T_NONE;
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    if (token_is(tok, len, "list")) {
        PF_TRY(read_type(r, &p->count_type, err));
        TEXT_CHECK(p->count_type != T_F32 && p->count_type != T_F64, r, err, PF_ERR_FORMAT,
                   "a list count must have an integer type");
        PF_TRY(read_type(r, &p->type, err));
    } else {
        r->cursor -= tok ? len : 0; /* the token was the type: read it again */
        PF_TRY(read_type(r, &p->type, err));
    }
    const char *name = pf_text_reader_token(r, &len);
    TEXT_CHECK(name, r, err, PF_ERR_FORMAT, "property without a name");
    p->role = ROLE_OTHER;
    if (e->kind == KIND_VERTEX && p->count_type == T_NONE && len == 1 && name[0] >= 'x' &&
        name[0] <= 'z')
        p->role = (ply_role)(name[0] - 'x');
    if (e->kind == KIND_FACE && p->count_type != T_NONE &&
        (token_is(name, len, "vertex_indices") || token_is(name, len, "vertex_index"))) {
        TEXT_CHECK(p->type != T_F32 && p->type != T_F64, r, err, PF_ERR_FORMAT,
                   "vertex indices must have an integer type");
        p->role = ROLE_INDICES;
    }
    return pf_text_reader_expect_line_end(r, "the property's name", err);
}

static pf_status read_element(text_reader *r, ply_header *h, pf_error *err)
{
    TEXT_CHECK(h->n_elements < PLY_MAX_ELEMENTS, r, err, PF_ERR_UNSUPPORTED,
               "more than %d elements", PLY_MAX_ELEMENTS);
    ply_element *e = &h->elements[h->n_elements++];
    memset(e, 0, sizeof *e);
    size_t len;
    const char *name = pf_text_reader_token(r, &len);
    TEXT_CHECK(name && len < PLY_NAME_MAX, r, err, PF_ERR_FORMAT, "element without a usable name");
    memcpy(e->name, name, len);
    e->line = r->line_no;
    e->kind = token_is(name, len, "vertex") ? KIND_VERTEX
              : token_is(name, len, "face") ? KIND_FACE
                                            : KIND_OTHER;
    PF_TRY(pf_text_reader_int(r, &e->count, "the element count", err));
    TEXT_CHECK(e->count >= 0, r, err, PF_ERR_FORMAT, "negative count of '%s'", e->name);
    TEXT_CHECK(e->count <= INT32_MAX, r, err, PF_ERR_TOO_LARGE, "%lld '%s': more than pf handles",
               (long long)e->count, e->name);
    return pf_text_reader_expect_line_end(r, "the element count", err);
}

static pf_status read_format(text_reader *r, ply_header *h, pf_error *err)
{
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    if (token_is(tok, len, "ascii"))
        h->format = PLY_ASCII;
    else if (token_is(tok, len, "binary_little_endian"))
        h->format = PLY_LE;
    else if (token_is(tok, len, "binary_big_endian"))
        h->format = PLY_BE;
    else
        return TEXT_FAIL(r, err, PF_ERR_FORMAT,
                         "unknown format (ascii, binary_little_endian or binary_big_endian)");
    tok = pf_text_reader_token(r, &len);
    TEXT_CHECK(token_is(tok, len, "1.0"), r, err, PF_ERR_UNSUPPORTED,
               "PLY version other than 1.0");
    return PF_OK;
}

/* The bytes after the header hold at least the smallest records of every element. */
static pf_status check_counts(const text_reader *r, const ply_header *h, pf_error *err)
{
    uint64_t need = 0, have = text_reader_bytes_left(r);
    for (int i = 0; i < h->n_elements; ++i) {
        const ply_element *e = &h->elements[i];
        uint64_t record = 0;
        for (int k = 0; k < e->n_props; ++k) {
            ply_type t = e->props[k].count_type != T_NONE ? e->props[k].count_type : e->props[k].type;
            record += h->format == PLY_ASCII ? 2 : type_size(t);
        }
        need += (uint64_t)e->count * record; /* < 2^31 * 64 * 8 each */
        PF_CHECK(need <= have + (h->format == PLY_ASCII), err, PF_ERR_FORMAT,
                 "%s:%lld: %lld '%s' announced, more than the rest of the file can hold (%llu "
                 "bytes after the header)",
                 r->path, (long long)e->line, (long long)e->count, e->name,
                 (unsigned long long)have);
    }
    return PF_OK;
}

static pf_status read_header(text_reader *r, ply_header *h, pf_error *err)
{
    TEXT_CHECK(pf_text_reader_next_line(r) && pf_text_reader_line_is(r, "ply"), r, err, PF_ERR_FORMAT,
               "not a PLY file: the first line is not 'ply'");
    bool have_format = false;
    for (;;) {
        TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "file ends inside the header");
        size_t len;
        const char *key = pf_text_reader_token(r, &len);
        if (token_is(key, len, "end_header"))
            break;
        if (token_is(key, len, "format")) {
            PF_TRY(read_format(r, h, err));
            have_format = true;
        } else if (token_is(key, len, "element")) {
            PF_TRY(read_element(r, h, err));
        } else if (token_is(key, len, "property")) {
            PF_TRY(read_property(r, h->n_elements ? &h->elements[h->n_elements - 1] : NULL, err));
        }
        /* Any other line ("comment", "obj_info", or free text such as old Blender exporters'
         * "Created by Blender3D 247 ...") is skipped as a comment, as other readers do: the
         * layout comes from the format, element and property lines alone. */
    }
    TEXT_CHECK(have_format, r, err, PF_ERR_FORMAT, "header without a format line");
    int roles = 0;
    for (int i = 0; i < h->n_elements; ++i) {
        const ply_element *e = &h->elements[i];
        if (e->kind != KIND_VERTEX)
            continue;
        h->n_verts = e->count;
        for (int k = 0; k < e->n_props; ++k)
            roles |= e->props[k].role >= ROLE_X && e->props[k].role <= ROLE_Z
                         ? 1 << e->props[k].role
                         : 0;
    }
    TEXT_CHECK(roles == 7, r, err, PF_ERR_FORMAT,
               "no 'vertex' element with properties x, y and z");
    return check_counts(r, h, err);
}

/* ---- binary records -------------------------------------------------------------------------- */

typedef struct bin_cursor {
    const unsigned char *data;
    size_t pos, size; /* pos: offset in the file */
    bool swap;        /* big-endian file */
    const char *path;
} bin_cursor;

static pf_status bin_value(bin_cursor *c, ply_type t, double *v, pf_error *err)
{
    size_t n = type_size(t);
    PF_CHECK(c->size - c->pos >= n, err, PF_ERR_FORMAT,
             "%s: byte %zu: file ends inside the data announced by the header", c->path, c->pos);
    unsigned char b[8];
    for (size_t i = 0; i < n; ++i)
        b[i] = c->data[c->pos + (c->swap ? n - 1 - i : i)];
    c->pos += n;
    /* Little-endian host assumed throughout pf (the stream format is little-endian too). */
    union {
        int8_t i8;
        uint8_t u8;
        int16_t i16;
        uint16_t u16;
        int32_t i32;
        uint32_t u32;
        float f32;
        double f64;
    } u;
    memcpy(&u, b, n);
    switch (t) {
    case T_I8: *v = u.i8; break;
    case T_U8: *v = u.u8; break;
    case T_I16: *v = u.i16; break;
    case T_U16: *v = u.u16; break;
    case T_I32: *v = u.i32; break;
    case T_U32: *v = u.u32; break;
    case T_F32: *v = u.f32; break;
    case T_F64: *v = u.f64; break;
    case T_NONE: *v = 0; break;
    }
    return PF_OK;
}

/* ---- records of either encoding --------------------------------------------------------------- */

typedef struct ply_reader {
    const ply_header *h;
    text_reader *text; /* ASCII */
    bin_cursor bin;    /* binary */
} ply_reader;

static pf_status value(ply_reader *pr, ply_type t, double *v, const char *what, pf_error *err)
{
    if (pr->h->format != PLY_ASCII)
        return bin_value(&pr->bin, t, v, err);
    PF_TRY(pf_text_reader_double(pr->text, v, what, err));
    TEXT_CHECK(t == T_F32 || t == T_F64 || *v == floor(*v), pr->text, err, PF_ERR_FORMAT,
               "%s %.17g is not an integer", what, *v);
    return PF_OK;
}

/* PF_ERR_FORMAT "path:LINE: reason" (ASCII) or "path: byte B: reason" (binary). */
static pf_status fail_at(const ply_reader *pr, pf_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static pf_status fail_at(const ply_reader *pr, pf_error *err, const char *fmt, ...)
{
    char msg[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (pr->h->format == PLY_ASCII)
        return TEXT_FAIL(pr->text, err, PF_ERR_FORMAT, "%s", msg);
    return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: byte %zu: %s", pr->bin.path,
                        pr->bin.pos, msg);
}

static pf_status read_record(ply_reader *pr, const ply_element *e, int64_t index,
                             surface_soup *soup, uint32_t *poly, pf_error *err)
{
    if (pr->h->format == PLY_ASCII && !pf_text_reader_next_line(pr->text))
        return TEXT_FAIL(pr->text, err, PF_ERR_FORMAT, "file ends after %lld of %lld '%s'",
                         (long long)index, (long long)e->count, e->name);
    double p[3] = {0, 0, 0};
    int64_t n_poly = -1;
    for (int k = 0; k < e->n_props; ++k) {
        const ply_property *prop = &e->props[k];
        double v;
        if (prop->count_type == T_NONE) {
            PF_TRY(value(pr, prop->type, &v, "a property value", err));
            if (prop->role >= ROLE_X && prop->role <= ROLE_Z)
                p[prop->role] = v;
            continue;
        }
        PF_TRY(value(pr, prop->count_type, &v, "a list count", err));
        if (v < 0 || v > 4294967295.0)
            return fail_at(pr, err, "list count %.17g of record %lld is out of range", v,
                           (long long)index);
        const uint64_t count = (uint64_t)v;
        if (pr->h->format != PLY_ASCII && count * type_size(prop->type) > pr->bin.size - pr->bin.pos)
            return fail_at(pr, err, "list of %lld items in record %lld runs past the end of the "
                                    "file", (long long)count, (long long)index);
        if (prop->role == ROLE_INDICES && count > SURFACE_POLYGON_MAX)
            return fail_at(pr, err, "face %lld has %lld vertices: more than pf triangulates",
                           (long long)index, (long long)count);
        for (uint64_t i = 0; i < count; ++i) {
            PF_TRY(value(pr, prop->type, &v, "a list item", err));
            if (prop->role != ROLE_INDICES)
                continue;
            if (v < 0 || v >= (double)pr->h->n_verts)
                return fail_at(pr, err, "face refers to vertex %.17g, but the file has %lld", v,
                               (long long)pr->h->n_verts);
            poly[i] = (uint32_t)v;
        }
        if (prop->role == ROLE_INDICES)
            n_poly = (int64_t)count;
    }
    if (pr->h->format == PLY_ASCII)
        PF_TRY(pf_text_reader_expect_line_end(pr->text, "the record", err));
    if (e->kind == KIND_VERTEX) {
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return fail_at(pr, err, "vertex %lld has a non-finite coordinate", (long long)index);
        return pf_surface_soup_vertex(soup, p, err);
    }
    return n_poly >= 0 ? pf_surface_soup_polygon(soup, poly, n_poly, err) : PF_OK;
}

pf_status pf_surface_read_ply(const char *path, surface_soup *soup, pf_error *err)
{
    text_reader r;
    PF_TRY(pf_text_reader_open(&r, path, '\0', err));
    ply_header *h = pf_alloc_array(1, sizeof *h);
    uint32_t *poly = pf_alloc_array(SURFACE_POLYGON_MAX, sizeof *poly);
    pf_status st = h && poly ? PF_OK
                             : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    if (st == PF_OK) {
        memset(h, 0, sizeof *h);
        st = read_header(&r, h, err);
    }
    ply_reader pr = {h, &r, {(const unsigned char *)r.data, r.next, r.size, false, path}};
    if (st == PF_OK)
        pr.bin.swap = h->format == PLY_BE;
    for (int i = 0; st == PF_OK && i < h->n_elements; ++i)
        for (int64_t k = 0; st == PF_OK && k < h->elements[i].count; ++k)
            st = read_record(&pr, &h->elements[i], k, soup, poly, err);
    pf_free(poly);
    pf_free(h);
    pf_text_reader_close(&r);
    return st;
}
