/* The GRPS chunk: the regions of a mesh (Gmsh physical groups), docs/stream-format.md.
 *
 *   u64 mesh_id | u32 ne | u32 nf | u32 ng
 *   ng x (u32 number | u32 dim | u32 len | u8 name[len])
 *   u32 elem_group[ne] | u32 face_group[nf]
 *
 * A separate, non-critical chunk after its MESH rather than a new MESH version: tools that do not
 * know it pass it on, and a reader that ignores it still reads the mesh. */
#include <pf/io.h>

#include <stdio.h>
#include <string.h>

#include "stream_bytes.h"

#define GROUPS_FAIL(c, err, ...)                                                                   \
    pf_stream_chunk_error((err), PF_ERR_FORMAT, __FILE__, __LINE__, (c), __VA_ARGS__)

/* A tag (0 or a group number) that no group of dimension dim has. */
static bool unknown_tag(const pf_mesh *m, int32_t dim, int64_t tag)
{
    return tag != 0 &&
           (tag < 0 || tag > INT32_MAX || !pf_mesh_find_group(m, dim, NULL, (int32_t)tag));
}

pf_status pf_stream_encode_groups(const pf_mesh *m, pf_buffer *out, pf_error *err)
{
    PF_CHECK(m->elem_group && m->face_group, err, PF_ERR_INVALID, "GRPS: mesh %llu has no groups",
             (unsigned long long)m->id);
    uint64_t bytes = 20 + 4 * ((uint64_t)m->n_elems + (uint64_t)m->n_faces);
    for (int32_t g = 0; g < m->n_groups; ++g) {
        const pf_mesh_group *p = &m->groups[g];
        size_t n = p->name ? strlen(p->name) : 0;
        PF_CHECK(p->number > 0 && (p->dim == 2 || p->dim == 3) && n <= UINT32_MAX, err,
                 PF_ERR_INVALID, "GRPS: group %d has number %d and dimension %d (need > 0, 2 or 3)",
                 (int)g, (int)p->number, (int)p->dim);
        PF_CHECK(pf_stream_utf8_invalid_at((const unsigned char *)p->name, n) == n, err,
                 PF_ERR_INVALID, "GRPS: the name of group %d is not valid UTF-8", (int)p->number);
        PF_CHECK(pf_mesh_find_group(m, p->dim, NULL, p->number) == p, err, PF_ERR_INVALID,
                 "GRPS: group %d of dimension %d is listed twice", (int)p->number, (int)p->dim);
        bytes += 12 + n;
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        PF_CHECK(!unknown_tag(m, 3, m->elem_group[e]), err, PF_ERR_INVALID,
                 "GRPS: element %d is in group %d, which the mesh does not list", (int)e,
                 (int)m->elem_group[e]);
    for (int32_t f = 0; f < m->n_faces; ++f)
        PF_CHECK(!unknown_tag(m, 2, m->face_group[f]), err, PF_ERR_INVALID,
                 "GRPS: face %d is in group %d, which the mesh does not list", (int)f,
                 (int)m->face_group[f]);
    PF_CHECK(bytes < SIZE_MAX - out->size, err, PF_ERR_TOO_LARGE, "GRPS: too large");
    PF_TRY(pf_buffer_reserve(out, out->size + (size_t)bytes, err));
    unsigned char *p = out->data + out->size;
    le_put_u64(p, m->id);
    le_put_u32(p + 8, (uint32_t)m->n_elems);
    le_put_u32(p + 12, (uint32_t)m->n_faces);
    le_put_u32(p + 16, (uint32_t)m->n_groups);
    p += 20;
    for (int32_t g = 0; g < m->n_groups; ++g) {
        size_t n = m->groups[g].name ? strlen(m->groups[g].name) : 0;
        le_put_u32(p, (uint32_t)m->groups[g].number);
        le_put_u32(p + 4, (uint32_t)m->groups[g].dim);
        le_put_u32(p + 8, (uint32_t)n);
        if (n)
            memcpy(p + 12, m->groups[g].name, n);
        p += 12 + n;
    }
    for (int32_t e = 0; e < m->n_elems; ++e, p += 4)
        le_put_u32(p, (uint32_t)m->elem_group[e]);
    for (int32_t f = 0; f < m->n_faces; ++f, p += 4)
        le_put_u32(p, (uint32_t)m->face_group[f]);
    out->size += (size_t)bytes;
    return PF_OK;
}

/* The group names of the payload at p (left bytes) into m->groups, checked. */
static pf_status read_names(const pf_chunk *c, const unsigned char **p, uint64_t *left, pf_mesh *m,
                            pf_error *err)
{
    for (int32_t g = 0; g < m->n_groups; ++g) {
        if (*left < 12)
            return GROUPS_FAIL(c, err, "truncated in group %d of %d", (int)g, (int)m->n_groups);
        uint32_t number = le_get_u32(*p), dim = le_get_u32(*p + 4), n = le_get_u32(*p + 8);
        *p += 12, *left -= 12;
        if (number == 0 || number > INT32_MAX || (dim != 2 && dim != 3))
            return GROUPS_FAIL(c, err, "group %d: number %lu and dimension %lu (need > 0, 2 or 3)",
                               (int)g, (unsigned long)number, (unsigned long)dim);
        if (n > *left)
            return GROUPS_FAIL(c, err, "group %lu: a name of %lu bytes runs past the payload",
                               (unsigned long)number, (unsigned long)n);
        if (pf_stream_utf8_invalid_at(*p, n) != n)
            return GROUPS_FAIL(c, err, "group %lu: the name is not UTF-8 without NUL",
                               (unsigned long)number);
        if (pf_mesh_find_group(m, (int32_t)dim, NULL, (int32_t)number))
            return GROUPS_FAIL(c, err, "group %lu of dimension %lu is listed twice",
                               (unsigned long)number, (unsigned long)dim);
        m->groups[g].name = pf_alloc((size_t)n + 1);
        PF_CHECK(m->groups[g].name, err, PF_ERR_NOMEM, "out of memory");
        memcpy(m->groups[g].name, *p, n);
        m->groups[g].name[n] = '\0';
        m->groups[g].number = (int32_t)number;
        m->groups[g].dim = (int32_t)dim;
        *p += n, *left -= n;
    }
    return PF_OK;
}

/* n tags of dimension dim from p into tags, each 0 or a listed group. */
static pf_status read_tags(const pf_chunk *c, const unsigned char *p, int32_t n, int32_t dim,
                           const char *what, pf_mesh *m, int32_t *tags, pf_error *err)
{
    for (int32_t i = 0; i < n; ++i) {
        uint32_t t = le_get_u32(p + 4 * (size_t)i);
        if (unknown_tag(m, dim, t))
            return GROUPS_FAIL(c, err, "%s %d is in group %lu, which the chunk does not list", what,
                               (int)i, (unsigned long)t);
        tags[i] = (int32_t)t;
    }
    return PF_OK;
}

pf_status pf_stream_decode_groups(const pf_chunk *c, pf_mesh *m, pf_error *err)
{
    PF_CHECK(strcmp(c->tag, "GRPS") == 0, err, PF_ERR_INVALID, "not a GRPS chunk");
    PF_TRY(pf_stream_check_version(c, err));
    if (c->size < 20)
        return GROUPS_FAIL(c, err, "payload of %llu bytes, shorter than its 20-byte header",
                           (unsigned long long)c->size);
    const unsigned char *p = c->payload;
    uint64_t id = le_get_u64(p), ne = le_get_u32(p + 8), nf = le_get_u32(p + 12);
    uint64_t ng = le_get_u32(p + 16), left = c->size - 20;
    if (id != m->id || ne != (uint64_t)m->n_elems || nf != (uint64_t)m->n_faces)
        return GROUPS_FAIL(c, err,
                           "groups of mesh %llu with %llu elements and %llu faces, but the latest "
                           "MESH is mesh %llu with %d elements and %d faces",
                           (unsigned long long)id, (unsigned long long)ne, (unsigned long long)nf,
                           (unsigned long long)m->id, (int)m->n_elems, (int)m->n_faces);
    if (ng > left / 12 || 4 * (ne + nf) > left - 12 * ng) /* before allocating anything */
        return GROUPS_FAIL(c, err, "%llu groups, %llu elements and %llu faces in %llu bytes",
                           (unsigned long long)ng, (unsigned long long)ne, (unsigned long long)nf,
                           (unsigned long long)left);
    pf_mesh_groups_release(m);
    PF_TRY(pf_mesh_groups_alloc(m, (int32_t)ng, err));
    p += 20;
    pf_status st = read_names(c, &p, &left, m, err);
    if (st == PF_OK && left != 4 * (ne + nf))
        st = GROUPS_FAIL(c, err, "%llu bytes of element and face groups, expected %llu",
                         (unsigned long long)left, (unsigned long long)(4 * (ne + nf)));
    if (st == PF_OK)
        st = read_tags(c, p, m->n_elems, 3, "element", m, m->elem_group, err);
    if (st == PF_OK)
        st = read_tags(c, p + 4 * ne, m->n_faces, 2, "face", m, m->face_group, err);
    if (st < 0)
        pf_mesh_groups_release(m);
    return st;
}
