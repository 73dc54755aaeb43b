/* Payload codecs of the known chunks of the pf stream (docs/stream-format.md, one table per chunk).
 *
 * Decoding never trusts a count: each array is measured against the bytes left in the payload,
 * offsets are checked to start at 0 and never decrease straight from the payload bytes, and only
 * then is anything allocated. Values go through explicit little-endian loads, so neither host byte
 * order nor struct layout matters. */
#include <pf/io.h>

#include <math.h>
#include <string.h>

#include "stream_bytes.h"

/* The fixed leading fields of each payload, as on disk (byte arrays: no padding). */
typedef struct mesh_head {
    unsigned char id[8], n_nodes[4], n_faces[4], n_elems[4];
} mesh_head;
typedef struct surf_head {
    unsigned char id[8], n_verts[4], n_tris[4];
} surf_head;
typedef struct wght_head {
    unsigned char surface_id[8], mesh_id[8], rows[4], cols[4];
} wght_head;
typedef struct fram_head {
    unsigned char mesh_id[8], index[4], time[8], n_nodes[4];
} fram_head;
typedef struct strs_head {
    unsigned char mesh_id[8], frame[4], n_elems[4], components[4];
} strs_head;
typedef struct end_body {
    unsigned char chunk_count[8], frame_count[8];
} end_body;
_Static_assert(sizeof(mesh_head) == 20, "MESH header is 20 bytes");
_Static_assert(sizeof(surf_head) == 16, "SURF header is 16 bytes");
_Static_assert(sizeof(wght_head) == 24, "WGHT header is 24 bytes");
_Static_assert(sizeof(fram_head) == 24, "FRAM header is 24 bytes");
_Static_assert(sizeof(strs_head) == 20, "STRS header is 20 bytes");
_Static_assert(sizeof(end_body) == 16, "END_ payload is 16 bytes");

#define CHUNK_FAIL(c, err, code, ...)                                                              \
    pf_stream_chunk_error((err), (code), __FILE__, __LINE__, (c), __VA_ARGS__)
#define CHUNK_CHECK(cond, c, err, code, ...)                                                       \
    do {                                                                                           \
        if (!(cond))                                                                               \
            return CHUNK_FAIL(c, err, code, __VA_ARGS__);                                          \
    } while (0)

/* ---- reading payloads ------------------------------------------------------------------------ */

typedef struct cursor {
    const pf_chunk *c;
    const unsigned char *p; /* next unread byte */
    uint64_t left;          /* bytes after p */
} cursor;

static pf_status begin(const pf_chunk *c, const char *tag, cursor *k, pf_error *err)
{
    CHUNK_CHECK(strcmp(c->tag, tag) == 0, c, err, PF_ERR_INVALID, "not a %s chunk", tag);
    PF_TRY(pf_stream_check_version(c, err));
    CHUNK_CHECK(c->size == 0 || c->payload, c, err, PF_ERR_INVALID, "no payload bytes");
    k->c = c;
    k->p = c->payload;
    k->left = c->size;
    return PF_OK;
}

/* Takes count entries of width bytes, failing before any allocation when the payload is short. */
static pf_status take(cursor *k, uint64_t count, uint64_t width, const unsigned char **at,
                      const char *what, pf_error *err)
{
    if (count > k->left / width) {
        char need[48] = "more than 2^64 bytes";
        if (count <= UINT64_MAX / width)
            snprintf(need, sizeof need, "%llu bytes", (unsigned long long)(count * width));
        return CHUNK_FAIL(k->c, err, PF_ERR_FORMAT,
                          "payload of %llu bytes too short for %llu %s (%s from payload byte %llu)",
                          (unsigned long long)k->c->size, (unsigned long long)count, what, need,
                          (unsigned long long)(k->c->size - k->left));
    }
    *at = k->p;
    k->p += count * width;
    k->left -= count * width;
    return PF_OK;
}

static pf_status finish(const cursor *k, pf_error *err)
{
    CHUNK_CHECK(k->left == 0, k->c, err, PF_ERR_FORMAT,
                "%llu trailing bytes after the last field (payload of %llu bytes)",
                (unsigned long long)k->left, (unsigned long long)k->c->size);
    return PF_OK;
}

/* pf holds entity counts in int32_t. */
static pf_status check_count(const cursor *k, uint64_t n, const char *what, pf_error *err)
{
    CHUNK_CHECK(n <= INT32_MAX, k->c, err, PF_ERR_TOO_LARGE,
                "%llu %s, more than the %d this pf handles", (unsigned long long)n, what,
                (int)INT32_MAX);
    return PF_OK;
}

/* CSR offsets [n + 1] straight from the payload: first 0, never decreasing. *last is the length
 * of the array they index, to be measured against the bytes left before allocating it. */
static pf_status check_offsets(const cursor *k, const unsigned char *p, uint64_t n,
                               const char *name, uint64_t *last, pf_error *err)
{
    uint64_t prev = le_get_u64(p);
    CHUNK_CHECK(prev == 0, k->c, err, PF_ERR_FORMAT, "%s[0] is %llu, must be 0", name,
                (unsigned long long)prev);
    for (uint64_t i = 1; i <= n; ++i) {
        uint64_t v = le_get_u64(p + 8 * i);
        CHUNK_CHECK(v >= prev, k->c, err, PF_ERR_FORMAT,
                    "%s[%llu] = %llu is less than %s[%llu] = %llu (offsets must not decrease)",
                    name, (unsigned long long)i, (unsigned long long)v, name,
                    (unsigned long long)(i - 1), (unsigned long long)prev);
        prev = v;
    }
    *last = prev;
    return PF_OK;
}

static void get_offsets(int64_t *dst, const unsigned char *p, uint64_t n)
{
    for (uint64_t i = 0; i <= n; ++i)
        dst[i] = (int64_t)le_get_u64(p + 8 * i);
}

/* Copies n doubles; returns the index of the first non-finite one, or -1. */
static int64_t get_finite(double *dst, const unsigned char *p, uint64_t n)
{
    for (uint64_t i = 0; i < n; ++i) {
        dst[i] = le_get_f64(p + 8 * i);
        if (!isfinite(dst[i]))
            return (int64_t)i;
    }
    return -1;
}

/* Copies n indices; returns the position of the first whose (entry & mask) >= limit, or -1. */
static int64_t get_indices(uint32_t *dst, const unsigned char *p, uint64_t n, uint64_t limit,
                           uint32_t mask)
{
    for (uint64_t i = 0; i < n; ++i) {
        dst[i] = le_get_u32(p + 4 * i);
        if ((dst[i] & mask) >= limit)
            return (int64_t)i;
    }
    return -1;
}

/* Which row of CSR offsets [n + 1] holds entry pos. */
static uint64_t row_of(const int64_t *offsets, uint64_t n, uint64_t pos)
{
    uint64_t lo = 0, hi = n;
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        if ((uint64_t)offsets[mid] <= pos)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* ---- writing payloads ------------------------------------------------------------------------ */

/* Adds count * width to *total; false on overflow. */
static bool add_bytes(uint64_t *total, uint64_t count, uint64_t width)
{
    if (count > (UINT64_MAX - *total) / width)
        return false;
    *total += count * width;
    return true;
}

/* Grows out by bytes and returns where they start. */
static pf_status extend(pf_buffer *out, uint64_t bytes, const char *label, unsigned char **at,
                        pf_error *err)
{
    PF_CHECK(bytes <= SIZE_MAX - out->size, err, PF_ERR_TOO_LARGE,
             "%s: %llu bytes do not fit in memory", label, (unsigned long long)bytes);
    PF_TRY(pf_buffer_reserve(out, out->size + (size_t)bytes, err));
    *at = out->data + out->size;
    out->size += (size_t)bytes;
    return PF_OK;
}

static unsigned char *put_f64s(unsigned char *p, const double *v, uint64_t n)
{
    for (uint64_t i = 0; i < n; ++i)
        le_put_f64(p + 8 * i, v[i]);
    return p + 8 * n;
}

static unsigned char *put_u32s(unsigned char *p, const uint32_t *v, uint64_t n)
{
    for (uint64_t i = 0; i < n; ++i)
        le_put_u32(p + 4 * i, v[i]);
    return p + 4 * n;
}

static unsigned char *put_offsets(unsigned char *p, const int64_t *v, uint64_t n)
{
    for (uint64_t i = 0; i <= n; ++i)
        le_put_u64(p + 8 * i, (uint64_t)v[i]);
    return p + 8 * (n + 1);
}

static pf_status enc_check_offsets(const int64_t *off, int64_t n, const char *name,
                                   const char *label, pf_error *err)
{
    PF_CHECK(off, err, PF_ERR_INVALID, "%s: no %s array", label, name);
    PF_CHECK(off[0] == 0, err, PF_ERR_INVALID, "%s: %s[0] is %lld, must be 0", label, name,
             (long long)off[0]);
    for (int64_t i = 1; i <= n; ++i)
        PF_CHECK(off[i] >= off[i - 1], err, PF_ERR_INVALID,
                 "%s: %s[%lld] = %lld is less than %s[%lld] = %lld", label, name, (long long)i,
                 (long long)off[i], name, (long long)(i - 1), (long long)off[i - 1]);
    return PF_OK;
}

/* n values, per of them for each entity: "LABEL: node 3 has a non-finite coordinate". */
static pf_status enc_check_finite(const double *v, int64_t n, int per, const char *entity,
                                  const char *quantity, const char *label, pf_error *err)
{
    PF_CHECK(v || n == 0, err, PF_ERR_INVALID, "%s: no %s array", label, quantity);
    for (int64_t i = 0; i < n; ++i)
        PF_CHECK(isfinite(v[i]), err, PF_ERR_INVALID, "%s: %s %lld has a non-finite %s", label,
                 entity, (long long)(i / per), quantity);
    return PF_OK;
}

static pf_status enc_check_indices(const uint32_t *v, int64_t n, int64_t limit, uint32_t mask,
                                   const char *what, const char *label, pf_error *err)
{
    PF_CHECK(v || n == 0, err, PF_ERR_INVALID, "%s: no %s array", label, what);
    for (int64_t i = 0; i < n; ++i)
        PF_CHECK((int64_t)(v[i] & mask) < limit, err, PF_ERR_INVALID,
                 "%s: %s entry %lld is %lu, beyond the %lld available", label, what, (long long)i,
                 (unsigned long)(v[i] & mask), (long long)limit);
    return PF_OK;
}

/* ---- MESH ------------------------------------------------------------------------------------ */

pf_status pf_stream_encode_mesh(const pf_mesh *m, pf_buffer *out, pf_error *err)
{
    char label[48];
    snprintf(label, sizeof label, "mesh %llu", (unsigned long long)m->id);
    PF_CHECK(m->n_nodes >= 0 && m->n_faces >= 0 && m->n_elems >= 0, err, PF_ERR_INVALID,
             "%s: negative counts", label);
    PF_TRY(enc_check_offsets(m->face_offsets, m->n_faces, "face_offsets", label, err));
    PF_TRY(enc_check_offsets(m->elem_offsets, m->n_elems, "elem_offsets", label, err));
    int64_t nfn = m->face_offsets[m->n_faces], nef = m->elem_offsets[m->n_elems];
    PF_TRY(enc_check_finite(m->x, 3 * (int64_t)m->n_nodes, 3, "node", "coordinate", label, err));
    PF_TRY(enc_check_indices(m->face_nodes, nfn, m->n_nodes, UINT32_MAX, "face_nodes", label, err));
    PF_TRY(enc_check_indices(m->elem_faces, nef, m->n_faces, ~PF_FACE_REVERSED, "elem_faces", label,
                             err));
    uint64_t total = sizeof(mesh_head);
    PF_CHECK(
        add_bytes(&total, (uint64_t)m->n_nodes, 24) &&
            add_bytes(&total, (uint64_t)m->n_faces + 1, 8) && add_bytes(&total, (uint64_t)nfn, 4) &&
            add_bytes(&total, (uint64_t)m->n_elems + 1, 8) && add_bytes(&total, (uint64_t)nef, 4),
        err, PF_ERR_TOO_LARGE, "%s: payload size overflows", label);
    unsigned char *p = NULL;
    PF_TRY(extend(out, total, label, &p, err));
    mesh_head h;
    le_put_u64(h.id, m->id);
    le_put_u32(h.n_nodes, (uint32_t)m->n_nodes);
    le_put_u32(h.n_faces, (uint32_t)m->n_faces);
    le_put_u32(h.n_elems, (uint32_t)m->n_elems);
    memcpy(p, &h, sizeof h);
    p = put_f64s(p + sizeof h, m->x, 3 * (uint64_t)m->n_nodes);
    p = put_offsets(p, m->face_offsets, (uint64_t)m->n_faces);
    p = put_u32s(p, m->face_nodes, (uint64_t)nfn);
    p = put_offsets(p, m->elem_offsets, (uint64_t)m->n_elems);
    put_u32s(p, m->elem_faces, (uint64_t)nef);
    return PF_OK;
}

typedef struct mesh_arrays {
    const unsigned char *x, *face_offsets, *face_nodes, *elem_offsets, *elem_faces;
} mesh_arrays;

/* Fills the allocated mesh, checking coordinates and index ranges on the way. */
static pf_status fill_mesh(const cursor *k, const mesh_arrays *a, pf_mesh *m, pf_error *err)
{
    uint64_t nn = (uint64_t)m->n_nodes, nf = (uint64_t)m->n_faces, ne = (uint64_t)m->n_elems;
    int64_t bad = get_finite(m->x, a->x, 3 * nn);
    CHUNK_CHECK(bad < 0, k->c, err, PF_ERR_FORMAT, "node %lld has a non-finite coordinate",
                (long long)(bad / 3));
    get_offsets(m->face_offsets, a->face_offsets, nf);
    get_offsets(m->elem_offsets, a->elem_offsets, ne);
    bad = get_indices(m->face_nodes, a->face_nodes, (uint64_t)m->face_offsets[nf], nn, UINT32_MAX);
    CHUNK_CHECK(bad < 0, k->c, err, PF_ERR_FORMAT,
                "face %llu lists node %lu, beyond the %llu nodes",
                (unsigned long long)row_of(m->face_offsets, nf, (uint64_t)bad),
                (unsigned long)m->face_nodes[bad], (unsigned long long)nn);
    bad = get_indices(m->elem_faces, a->elem_faces, (uint64_t)m->elem_offsets[ne], nf,
                      ~PF_FACE_REVERSED);
    CHUNK_CHECK(bad < 0, k->c, err, PF_ERR_FORMAT,
                "element %llu lists face %lu, beyond the %llu faces",
                (unsigned long long)row_of(m->elem_offsets, ne, (uint64_t)bad),
                (unsigned long)(m->elem_faces[bad] & ~PF_FACE_REVERSED), (unsigned long long)nf);
    return PF_OK;
}

pf_status pf_stream_decode_mesh(const pf_chunk *c, pf_mesh *m, pf_error *err)
{
    memset(m, 0, sizeof *m);
    cursor k;
    PF_TRY(begin(c, "MESH", &k, err));
    const unsigned char *hp = NULL;
    mesh_arrays a = {0};
    PF_TRY(take(&k, 1, sizeof(mesh_head), &hp, "header", err));
    mesh_head h;
    memcpy(&h, hp, sizeof h);
    uint64_t nn = le_get_u32(h.n_nodes), nf = le_get_u32(h.n_faces), ne = le_get_u32(h.n_elems);
    uint64_t nfn, nef;
    PF_TRY(take(&k, nn, 24, &a.x, "nodes", err));
    PF_TRY(take(&k, nf + 1, 8, &a.face_offsets, "face offsets", err));
    PF_TRY(check_offsets(&k, a.face_offsets, nf, "face_offsets", &nfn, err));
    PF_TRY(take(&k, nfn, 4, &a.face_nodes, "face node entries", err));
    PF_TRY(take(&k, ne + 1, 8, &a.elem_offsets, "element offsets", err));
    PF_TRY(check_offsets(&k, a.elem_offsets, ne, "elem_offsets", &nef, err));
    PF_TRY(take(&k, nef, 4, &a.elem_faces, "element face entries", err));
    PF_TRY(finish(&k, err));
    PF_TRY(check_count(&k, nn, "nodes", err));
    PF_TRY(check_count(&k, nf, "faces", err));
    PF_TRY(check_count(&k, ne, "elements", err));
    PF_TRY(
        pf_mesh_alloc(m, (int32_t)nn, (int32_t)nf, (int64_t)nfn, (int32_t)ne, (int64_t)nef, err));
    m->id = le_get_u64(h.id);
    pf_status s = fill_mesh(&k, &a, m, err);
    if (s < 0)
        pf_mesh_release(m);
    return s;
}

/* ---- SURF ------------------------------------------------------------------------------------ */

uint32_t pf_stream_surface_version(const pf_surface *s)
{
    return pf_surface_count_caps(s) > 0 ? 2 : 1;
}

pf_status pf_stream_encode_surface(const pf_surface *s, pf_buffer *out, pf_error *err)
{
    char label[48];
    snprintf(label, sizeof label, "surface %llu", (unsigned long long)s->id);
    PF_CHECK(s->n_verts >= 0 && s->n_tris >= 0, err, PF_ERR_INVALID, "%s: negative counts", label);
    PF_TRY(enc_check_finite(s->x, 3 * (int64_t)s->n_verts, 3, "vertex", "coordinate", label, err));
    PF_TRY(enc_check_indices(s->tri, 3 * (int64_t)s->n_tris, s->n_verts, UINT32_MAX, "tri", label,
                             err));
    for (int32_t t = 0; s->tri_part && t < s->n_tris; ++t)
        PF_CHECK(s->tri_part[t] <= PF_SURFACE_CAP, err, PF_ERR_INVALID,
                 "%s: triangle %d has part %u (0: model, 1: cap)", label, (int)t,
                 (unsigned)s->tri_part[t]);
    bool parts = pf_stream_surface_version(s) == 2;
    uint64_t total =
        sizeof(surf_head) + 24 * (uint64_t)s->n_verts + (parts ? 13 : 12) * (uint64_t)s->n_tris;
    unsigned char *p = NULL;
    PF_TRY(extend(out, total, label, &p, err));
    surf_head h;
    le_put_u64(h.id, s->id);
    le_put_u32(h.n_verts, (uint32_t)s->n_verts);
    le_put_u32(h.n_tris, (uint32_t)s->n_tris);
    memcpy(p, &h, sizeof h);
    p = put_f64s(p + sizeof h, s->x, 3 * (uint64_t)s->n_verts);
    p = put_u32s(p, s->tri, 3 * (uint64_t)s->n_tris);
    if (parts)
        memcpy(p, s->tri_part, (size_t)s->n_tris);
    return PF_OK;
}

pf_status pf_stream_decode_surface(const pf_chunk *c, pf_surface *s, pf_error *err)
{
    memset(s, 0, sizeof *s);
    cursor k;
    PF_TRY(begin(c, "SURF", &k, err));
    const unsigned char *hp = NULL, *px = NULL, *pt = NULL, *pp = NULL;
    PF_TRY(take(&k, 1, sizeof(surf_head), &hp, "header", err));
    surf_head h;
    memcpy(&h, hp, sizeof h);
    uint64_t nv = le_get_u32(h.n_verts), nt = le_get_u32(h.n_tris);
    PF_TRY(take(&k, nv, 24, &px, "vertices", err));
    PF_TRY(take(&k, nt, 12, &pt, "triangles", err));
    if (c->version >= 2) /* version 2: the part of each triangle */
        PF_TRY(take(&k, nt, 1, &pp, "triangle parts", err));
    PF_TRY(finish(&k, err));
    PF_TRY(check_count(&k, nv, "vertices", err));
    PF_TRY(check_count(&k, nt, "triangles", err));
    for (uint64_t t = 0; pp && t < nt; ++t)
        CHUNK_CHECK(pp[t] <= PF_SURFACE_CAP, c, err, PF_ERR_FORMAT,
                    "triangle %llu has part %u (0: model, 1: cap)", (unsigned long long)t,
                    (unsigned)pp[t]);
    PF_TRY(pf_surface_alloc(s, (int32_t)nv, (int32_t)nt, err));
    s->id = le_get_u64(h.id);
    if (pp) {
        s->tri_part = pf_alloc((size_t)nt + 1);
        if (!s->tri_part) {
            pf_surface_release(s);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                "cannot allocate the parts of %llu triangles",
                                (unsigned long long)nt);
        }
        memcpy(s->tri_part, pp, (size_t)nt);
    }
    int64_t bad = get_finite(s->x, px, 3 * nv);
    pf_status st = PF_OK;
    if (bad >= 0)
        st = CHUNK_FAIL(c, err, PF_ERR_FORMAT, "vertex %lld has a non-finite coordinate",
                        (long long)(bad / 3));
    else if ((bad = get_indices(s->tri, pt, 3 * nt, nv, UINT32_MAX)) >= 0)
        st = CHUNK_FAIL(c, err, PF_ERR_FORMAT,
                        "triangle %lld lists vertex %lu, beyond the %llu "
                        "vertices",
                        (long long)(bad / 3), (unsigned long)s->tri[bad], (unsigned long long)nv);
    if (st < 0)
        pf_surface_release(s);
    return st;
}

/* ---- WGHT ------------------------------------------------------------------------------------ */

pf_status pf_stream_encode_weights(const pf_weights *w, pf_buffer *out, pf_error *err)
{
    char label[80];
    snprintf(label, sizeof label, "weights of surface %llu on mesh %llu",
             (unsigned long long)w->surface_id, (unsigned long long)w->mesh_id);
    PF_CHECK(w->rows >= 0 && w->cols >= 0, err, PF_ERR_INVALID, "%s: negative counts", label);
    PF_TRY(enc_check_offsets(w->row_offsets, w->rows, "row_offsets", label, err));
    int64_t nnz = w->row_offsets[w->rows];
    PF_TRY(enc_check_indices(w->col, nnz, w->cols, UINT32_MAX, "col", label, err));
    PF_TRY(enc_check_finite(w->val, nnz, 1, "entry", "weight", label, err));
    uint64_t total = sizeof(wght_head);
    PF_CHECK(add_bytes(&total, (uint64_t)w->rows + 1, 8) && add_bytes(&total, (uint64_t)nnz, 12),
             err, PF_ERR_TOO_LARGE, "%s: payload size overflows", label);
    unsigned char *p = NULL;
    PF_TRY(extend(out, total, label, &p, err));
    wght_head h;
    le_put_u64(h.surface_id, w->surface_id);
    le_put_u64(h.mesh_id, w->mesh_id);
    le_put_u32(h.rows, (uint32_t)w->rows);
    le_put_u32(h.cols, (uint32_t)w->cols);
    memcpy(p, &h, sizeof h);
    p = put_offsets(p + sizeof h, w->row_offsets, (uint64_t)w->rows);
    p = put_u32s(p, w->col, (uint64_t)nnz);
    put_f64s(p, w->val, (uint64_t)nnz);
    return PF_OK;
}

pf_status pf_stream_decode_weights(const pf_chunk *c, pf_weights *w, pf_error *err)
{
    memset(w, 0, sizeof *w);
    cursor k;
    PF_TRY(begin(c, "WGHT", &k, err));
    const unsigned char *hp = NULL, *po = NULL, *pc = NULL, *pv = NULL;
    PF_TRY(take(&k, 1, sizeof(wght_head), &hp, "header", err));
    wght_head h;
    memcpy(&h, hp, sizeof h);
    uint64_t rows = le_get_u32(h.rows), cols = le_get_u32(h.cols), nnz;
    PF_TRY(take(&k, rows + 1, 8, &po, "row offsets", err));
    PF_TRY(check_offsets(&k, po, rows, "row_offsets", &nnz, err));
    PF_TRY(take(&k, nnz, 4, &pc, "column indices", err));
    PF_TRY(take(&k, nnz, 8, &pv, "weights", err));
    PF_TRY(finish(&k, err));
    PF_TRY(check_count(&k, rows, "rows", err));
    PF_TRY(check_count(&k, cols, "columns", err));
    PF_TRY(pf_weights_alloc(w, (int32_t)rows, (int32_t)cols, (int64_t)nnz, err));
    w->surface_id = le_get_u64(h.surface_id);
    w->mesh_id = le_get_u64(h.mesh_id);
    get_offsets(w->row_offsets, po, rows);
    pf_status st = PF_OK;
    int64_t bad = get_indices(w->col, pc, nnz, cols, UINT32_MAX);
    if (bad >= 0)
        st = CHUNK_FAIL(c, err, PF_ERR_FORMAT, "row %llu lists node %lu, beyond the %llu nodes",
                        (unsigned long long)row_of(w->row_offsets, rows, (uint64_t)bad),
                        (unsigned long)w->col[bad], (unsigned long long)cols);
    else if ((bad = get_finite(w->val, pv, nnz)) >= 0)
        st = CHUNK_FAIL(c, err, PF_ERR_FORMAT, "row %llu has a non-finite weight",
                        (unsigned long long)row_of(w->row_offsets, rows, (uint64_t)bad));
    if (st < 0)
        pf_weights_release(w);
    return st;
}

/* ---- FRAM ------------------------------------------------------------------------------------ */

pf_status pf_frame_data_alloc(pf_frame_data *f, int32_t n_nodes, pf_error *err)
{
    memset(f, 0, sizeof *f);
    PF_CHECK(n_nodes >= 0, err, PF_ERR_INVALID, "frame node count must be non-negative");
    f->u = pf_alloc_array(3 * (size_t)n_nodes, sizeof *f->u);
    PF_CHECK(f->u || n_nodes == 0, err, PF_ERR_NOMEM, "cannot allocate a frame of %d nodes",
             (int)n_nodes);
    f->n_nodes = n_nodes;
    return PF_OK;
}

void pf_frame_data_release(pf_frame_data *f)
{
    pf_free(f->u);
    memset(f, 0, sizeof *f);
}

pf_status pf_stream_encode_frame(const pf_frame_data *f, pf_buffer *out, pf_error *err)
{
    char label[64];
    snprintf(label, sizeof label, "frame %lu of mesh %llu", (unsigned long)f->index,
             (unsigned long long)f->mesh_id);
    PF_CHECK(f->n_nodes >= 0, err, PF_ERR_INVALID, "%s: negative node count", label);
    PF_CHECK(isfinite(f->time), err, PF_ERR_INVALID, "%s: non-finite time", label);
    PF_TRY(enc_check_finite(f->u, 3 * (int64_t)f->n_nodes, 3, "node", "displacement", label, err));
    unsigned char *p = NULL;
    PF_TRY(extend(out, sizeof(fram_head) + 24 * (uint64_t)f->n_nodes, label, &p, err));
    fram_head h;
    le_put_u64(h.mesh_id, f->mesh_id);
    le_put_u32(h.index, f->index);
    le_put_f64(h.time, f->time);
    le_put_u32(h.n_nodes, (uint32_t)f->n_nodes);
    memcpy(p, &h, sizeof h);
    put_f64s(p + sizeof h, f->u, 3 * (uint64_t)f->n_nodes);
    return PF_OK;
}

pf_status pf_stream_frame_index(const pf_chunk *c, uint32_t *index, pf_error *err)
{
    cursor k;
    PF_TRY(begin(c, "FRAM", &k, err));
    const unsigned char *hp = NULL;
    PF_TRY(take(&k, 1, sizeof(fram_head), &hp, "header", err));
    fram_head h;
    memcpy(&h, hp, sizeof h);
    *index = le_get_u32(h.index);
    return PF_OK;
}

pf_status pf_stream_checkpoint_header(const pf_chunk *c, pf_checkpoint_header *h, pf_error *err)
{
    memset(h, 0, sizeof *h);
    cursor k;
    PF_TRY(begin(c, "CKPT", &k, err));
    const unsigned char *hp = NULL;
    h->have_counts = c->version >= 2;
    uint64_t bytes = h->have_counts ? PF_CHECKPOINT_HEADER_BYTES : PF_CHECKPOINT_HEADER_BYTES_V1;
    PF_TRY(take(&k, 1, bytes, &hp, "header", err));
    h->mesh_id = le_get_u64(hp);
    h->frame = le_get_u32(hp + 8);
    h->every = le_get_u32(hp + 12);
    if (h->have_counts) {
        h->counts.steps = le_get_u64(hp + 16);
        h->counts.factorisations = le_get_u64(hp + 24);
        h->counts.solves = le_get_u64(hp + 32);
        h->counts.pcg_iterations = le_get_u64(hp + 40);
    }
    h->state = hp + bytes;
    h->state_size = k.left;
    return PF_OK;
}

pf_status pf_stream_encode_checkpoint_header(const pf_checkpoint_header *h, pf_buffer *out,
                                             pf_error *err)
{
    unsigned char b[PF_CHECKPOINT_HEADER_BYTES];
    le_put_u64(b, h->mesh_id);
    le_put_u32(b + 8, h->frame);
    le_put_u32(b + 12, h->every);
    le_put_u64(b + 16, h->counts.steps);
    le_put_u64(b + 24, h->counts.factorisations);
    le_put_u64(b + 32, h->counts.solves);
    le_put_u64(b + 40, h->counts.pcg_iterations);
    return pf_buffer_append(out, b, sizeof b, err);
}

pf_status pf_stream_decode_frame(const pf_chunk *c, pf_frame_data *f, pf_error *err)
{
    memset(f, 0, sizeof *f);
    cursor k;
    PF_TRY(begin(c, "FRAM", &k, err));
    const unsigned char *hp = NULL, *pu = NULL;
    PF_TRY(take(&k, 1, sizeof(fram_head), &hp, "header", err));
    fram_head h;
    memcpy(&h, hp, sizeof h);
    uint32_t index = le_get_u32(h.index);
    double time = le_get_f64(h.time);
    uint64_t nn = le_get_u32(h.n_nodes);
    CHUNK_CHECK(isfinite(time), c, err, PF_ERR_FORMAT, "frame %lu has a non-finite time",
                (unsigned long)index);
    PF_TRY(take(&k, nn, 24, &pu, "node displacements", err));
    PF_TRY(finish(&k, err));
    PF_TRY(check_count(&k, nn, "nodes", err));
    PF_TRY(pf_frame_data_alloc(f, (int32_t)nn, err));
    f->mesh_id = le_get_u64(h.mesh_id);
    f->index = index;
    f->time = time;
    int64_t bad = get_finite(f->u, pu, 3 * nn);
    if (bad >= 0) {
        pf_frame_data_release(f);
        return CHUNK_FAIL(c, err, PF_ERR_FORMAT,
                          "frame %lu: node %lld has a non-finite "
                          "displacement",
                          (unsigned long)index, (long long)(bad / 3));
    }
    return PF_OK;
}

/* ---- STRS ------------------------------------------------------------------------------------ */

pf_status pf_stress_data_alloc(pf_stress_data *s, int32_t n_elems, int32_t components,
                               pf_error *err)
{
    memset(s, 0, sizeof *s);
    PF_CHECK(n_elems >= 0 && (components == 1 || components == 6), err, PF_ERR_INVALID,
             "stress of %d elements with %d components: need n >= 0 and 1 or 6 components",
             (int)n_elems, (int)components);
    s->values = pf_alloc_array((size_t)n_elems * (size_t)components, sizeof *s->values);
    PF_CHECK(s->values || n_elems == 0, err, PF_ERR_NOMEM,
             "cannot allocate the stress of %d elements", (int)n_elems);
    s->n_elems = n_elems;
    s->components = components;
    return PF_OK;
}

void pf_stress_data_release(pf_stress_data *s)
{
    pf_free(s->values);
    memset(s, 0, sizeof *s);
}

pf_status pf_stream_encode_stress(const pf_stress_data *s, pf_buffer *out, pf_error *err)
{
    char label[64];
    snprintf(label, sizeof label, "stress of frame %lu of mesh %llu", (unsigned long)s->frame,
             (unsigned long long)s->mesh_id);
    PF_CHECK(s->n_elems >= 0 && (s->components == 1 || s->components == 6), err, PF_ERR_INVALID,
             "%s: %d elements with %d components (need n >= 0 and 1 or 6 components)", label,
             (int)s->n_elems, (int)s->components);
    int64_t n = (int64_t)s->n_elems * s->components;
    PF_TRY(enc_check_finite(s->values, n, s->components, "element", "stress", label, err));
    unsigned char *p = NULL;
    PF_TRY(extend(out, sizeof(strs_head) + 8 * (uint64_t)n, label, &p, err));
    strs_head h;
    le_put_u64(h.mesh_id, s->mesh_id);
    le_put_u32(h.frame, s->frame);
    le_put_u32(h.n_elems, (uint32_t)s->n_elems);
    le_put_u32(h.components, (uint32_t)s->components);
    memcpy(p, &h, sizeof h);
    put_f64s(p + sizeof h, s->values, (uint64_t)n);
    return PF_OK;
}

pf_status pf_stream_decode_stress(const pf_chunk *c, pf_stress_data *s, pf_error *err)
{
    memset(s, 0, sizeof *s);
    cursor k;
    PF_TRY(begin(c, "STRS", &k, err));
    const unsigned char *hp = NULL, *pv = NULL;
    PF_TRY(take(&k, 1, sizeof(strs_head), &hp, "header", err));
    strs_head h;
    memcpy(&h, hp, sizeof h);
    uint64_t ne = le_get_u32(h.n_elems), nc = le_get_u32(h.components);
    CHUNK_CHECK(nc == 1 || nc == 6, c, err, PF_ERR_FORMAT,
                "%llu stress components, must be 1 (von Mises) or 6 (xx yy zz xy yz zx)",
                (unsigned long long)nc);
    PF_TRY(take(&k, ne * nc, 8, &pv, "stress values", err));
    PF_TRY(finish(&k, err));
    PF_TRY(check_count(&k, ne, "elements", err));
    PF_TRY(pf_stress_data_alloc(s, (int32_t)ne, (int32_t)nc, err));
    s->mesh_id = le_get_u64(h.mesh_id);
    s->frame = le_get_u32(h.frame);
    int64_t bad = get_finite(s->values, pv, ne * nc);
    if (bad >= 0) {
        pf_stress_data_release(s);
        return CHUNK_FAIL(c, err, PF_ERR_FORMAT, "element %lld has a non-finite stress",
                          (long long)bad / (long long)nc);
    }
    return PF_OK;
}

/* ---- INFO, SCEN, END_
 * ----------------------------------------------------------------------------- */

/* Index of the first byte that is NUL or breaks UTF-8 (RFC 3629: shortest form only, no surrogates,
 * nothing above U+10FFFF), or n when all n bytes are valid. */
size_t pf_stream_utf8_invalid_at(const unsigned char *s, size_t n)
{
    size_t i = 0;
    while (i < n) {
        unsigned char b = s[i];
        size_t len = b == 0               ? 0
                     : b < 0x80           ? 1
                     : (b & 0xe0) == 0xc0 ? 2
                     : (b & 0xf0) == 0xe0 ? 3
                     : (b & 0xf8) == 0xf0 ? 4
                                          : 0;
        if (len == 0 || len > n - i)
            return i;
        uint32_t cp = len == 1 ? b : (uint32_t)(b & (0x7f >> len));
        for (size_t j = 1; j < len; ++j) {
            if ((s[i + j] & 0xc0) != 0x80)
                return i;
            cp = cp << 6 | (s[i + j] & 0x3f);
        }
        static const uint32_t MIN_CP[5] = {0, 0, 0x80, 0x800, 0x10000};
        if (cp < MIN_CP[len] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff))
            return i;
        i += len;
    }
    return n;
}

static pf_status put_string(const char *s, const char *what, pf_buffer *out, pf_error *err)
{
    size_t n = s ? strlen(s) : 0;
    PF_CHECK(n <= UINT32_MAX, err, PF_ERR_TOO_LARGE, "INFO %s string of %zu bytes", what, n);
    size_t bad = pf_stream_utf8_invalid_at((const unsigned char *)s, n);
    PF_CHECK(bad == n, err, PF_ERR_INVALID, "INFO %s string is not valid UTF-8 (byte %zu)", what,
             bad);
    unsigned char *p = NULL;
    PF_TRY(extend(out, 4 + (uint64_t)n, "INFO", &p, err));
    le_put_u32(p, (uint32_t)n);
    if (n)
        memcpy(p + 4, s, n);
    return PF_OK;
}

pf_status pf_stream_encode_info(const char *producer, const char *version, const char *command,
                                pf_buffer *out, pf_error *err)
{
    PF_TRY(put_string(producer, "producer", out, err));
    PF_TRY(put_string(version, "version", out, err));
    return put_string(command, "command", out, err);
}

static pf_status get_string(cursor *k, const char *what, char **dst, pf_error *err)
{
    const unsigned char *pl = NULL, *ps = NULL;
    char bytes_of[48];
    snprintf(bytes_of, sizeof bytes_of, "%s string bytes", what);
    PF_TRY(take(k, 1, 4, &pl, "string length", err));
    uint64_t n = le_get_u32(pl);
    PF_TRY(take(k, n, 1, &ps, bytes_of, err));
    size_t bad = pf_stream_utf8_invalid_at(ps, (size_t)n);
    CHUNK_CHECK(bad == n, k->c, err, PF_ERR_FORMAT,
                "the %s string is not valid UTF-8 without NUL (byte %zu of %llu)", what, bad,
                (unsigned long long)n);
    *dst = pf_alloc((size_t)n + 1);
    PF_CHECK(*dst, err, PF_ERR_NOMEM, "out of memory");
    memcpy(*dst, ps, (size_t)n);
    (*dst)[n] = '\0';
    return PF_OK;
}

void pf_info_data_release(pf_info_data *d)
{
    pf_free(d->producer);
    pf_free(d->version);
    pf_free(d->command);
    memset(d, 0, sizeof *d);
}

pf_status pf_stream_decode_info(const pf_chunk *c, pf_info_data *d, pf_error *err)
{
    memset(d, 0, sizeof *d);
    cursor k;
    PF_TRY(begin(c, "INFO", &k, err));
    pf_status s = get_string(&k, "producer", &d->producer, err);
    if (s >= 0)
        s = get_string(&k, "version", &d->version, err);
    if (s >= 0)
        s = get_string(&k, "command", &d->command, err);
    if (s >= 0)
        s = finish(&k, err);
    if (s < 0)
        pf_info_data_release(d);
    return s;
}

pf_status pf_stream_encode_scene(const char *json, size_t size, pf_buffer *out, pf_error *err)
{
    PF_CHECK(json || size == 0, err, PF_ERR_INVALID, "scene: no text");
    PF_CHECK(!size || !memchr(json, 0, size), err, PF_ERR_INVALID, "scene: contains a NUL byte");
    return pf_buffer_append(out, json, size, err);
}

pf_status pf_stream_decode_scene(const pf_chunk *c, char **json, size_t *size, pf_error *err)
{
    *json = NULL;
    *size = 0;
    cursor k;
    PF_TRY(begin(c, "SCEN", &k, err));
    const unsigned char *nul = c->size ? memchr(c->payload, 0, (size_t)c->size) : NULL;
    CHUNK_CHECK(!nul, c, err, PF_ERR_FORMAT, "NUL byte at payload byte %lld of the scene text",
                nul ? (long long)(nul - c->payload) : 0LL);
    *json = pf_alloc((size_t)c->size + 1);
    PF_CHECK(*json, err, PF_ERR_NOMEM, "out of memory");
    if (c->size)
        memcpy(*json, c->payload, (size_t)c->size);
    (*json)[c->size] = '\0';
    *size = (size_t)c->size;
    return PF_OK;
}

pf_status pf_stream_encode_end(const pf_end_data *d, pf_buffer *out, pf_error *err)
{
    unsigned char *p = NULL;
    PF_TRY(extend(out, sizeof(end_body), "END_", &p, err));
    end_body b;
    le_put_u64(b.chunk_count, d->chunk_count);
    le_put_u64(b.frame_count, d->frame_count);
    memcpy(p, &b, sizeof b);
    return PF_OK;
}

pf_status pf_stream_decode_end(const pf_chunk *c, pf_end_data *d, pf_error *err)
{
    memset(d, 0, sizeof *d);
    cursor k;
    PF_TRY(begin(c, "END_", &k, err));
    const unsigned char *p = NULL;
    PF_TRY(take(&k, 1, sizeof(end_body), &p, "counts", err));
    PF_TRY(finish(&k, err));
    end_body b;
    memcpy(&b, p, sizeof b);
    d->chunk_count = le_get_u64(b.chunk_count);
    d->frame_count = le_get_u64(b.frame_count);
    return PF_OK;
}
