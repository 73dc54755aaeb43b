/* Sub-meshes of chosen elements, on the nodes of the whole mesh. */
#include <pf/mesh.h>

#include <string.h>

pf_status pf_mesh_select_elements(pf_mesh *dst, const pf_mesh *src, const uint8_t *keep,
                                  int32_t *elem_map, pf_error *err)
{
    memset(dst, 0, sizeof *dst);
    int32_t *face_map = NULL;
    PF_CHECK(PF_ALLOC_N(face_map, src->n_faces), err, PF_ERR_NOMEM,
             "out of memory selecting elements of a %d-face mesh", (int)src->n_faces);
    for (int32_t f = 0; f < src->n_faces; ++f)
        face_map[f] = -1;
    int32_t n_elems = 0;
    int64_t n_elem_faces = 0;
    for (int32_t e = 0; e < src->n_elems; ++e) {
        if (!keep[e])
            continue;
        ++n_elems;
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
            face_map[PF_FACE_INDEX(src->elem_faces[k])] = 0;
            ++n_elem_faces;
        }
    }
    /* kept faces numbered in src order */
    int32_t n_faces = 0;
    int64_t n_face_nodes = 0;
    for (int32_t f = 0; f < src->n_faces; ++f)
        if (face_map[f] == 0) {
            face_map[f] = n_faces++;
            n_face_nodes += src->face_offsets[f + 1] - src->face_offsets[f];
        }
    pf_status st =
        pf_mesh_alloc(dst, src->n_nodes, n_faces, n_face_nodes, n_elems, n_elem_faces, err);
    if (st < 0) {
        pf_free(face_map);
        return st;
    }
    dst->id = src->id;
    memcpy(dst->x, src->x, 3 * (size_t)src->n_nodes * sizeof *dst->x);
    for (int32_t f = 0, g = 0; f < src->n_faces; ++f) {
        if (face_map[f] < 0)
            continue;
        int64_t a = src->face_offsets[f], n = src->face_offsets[f + 1] - a;
        memcpy(dst->face_nodes + dst->face_offsets[g], src->face_nodes + a,
               (size_t)n * sizeof *dst->face_nodes);
        dst->face_offsets[g + 1] = dst->face_offsets[g] + n;
        ++g;
    }
    for (int32_t e = 0, d = 0; e < src->n_elems; ++e) {
        if (!keep[e])
            continue;
        int64_t out = dst->elem_offsets[d];
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
            uint32_t ref = src->elem_faces[k];
            dst->elem_faces[out++] =
                (uint32_t)face_map[PF_FACE_INDEX(ref)] | (ref & PF_FACE_REVERSED);
        }
        dst->elem_offsets[d + 1] = out;
        if (elem_map)
            elem_map[d] = e;
        ++d;
    }
    if (src->elem_group) {
        /* the groups travel with their elements and faces */
        st = pf_mesh_groups_copy(dst, src, err);
        for (int32_t e = 0, d = 0; st == PF_OK && e < src->n_elems; ++e)
            if (keep[e])
                dst->elem_group[d++] = src->elem_group[e];
        for (int32_t f = 0; st == PF_OK && f < src->n_faces; ++f)
            if (face_map[f] >= 0)
                dst->face_group[face_map[f]] = src->face_group[f];
    }
    pf_free(face_map);
    return st;
}

static int32_t find_root(int32_t *parent, int32_t e)
{
    while (parent[e] != e) {
        parent[e] = parent[parent[e]];
        e = parent[e];
    }
    return e;
}

void pf_mesh_compact_nodes(pf_mesh *m, int32_t *node_id)
{
    for (int32_t i = 0; i < m->n_nodes; ++i)
        node_id[i] = -1;
    int64_t n_face_nodes = m->face_offsets[m->n_faces];
    for (int64_t q = 0; q < n_face_nodes; ++q)
        node_id[m->face_nodes[q]] = 0;
    int32_t n = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (node_id[i] == 0) {
            node_id[i] = n;
            memmove(m->x + 3 * (size_t)n, m->x + 3 * (size_t)i, 3 * sizeof *m->x);
            ++n;
        }
    for (int64_t q = 0; q < n_face_nodes; ++q)
        m->face_nodes[q] = (uint32_t)node_id[m->face_nodes[q]];
    m->n_nodes = n;
}

pf_status pf_mesh_keep_largest_part(pf_mesh *m, int32_t *parts, int32_t *dropped, pf_error *err)
{
    *parts = 0, *dropped = 0;
    if (m->n_elems == 0)
        return PF_OK;
    PF_TRY(pf_mesh_derive(m, err));
    int32_t ne = m->n_elems;
    int32_t *parent = NULL, *node_id = NULL;
    double *volume = NULL;
    uint8_t *keep = NULL;
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(parent, ne) || !PF_ALLOC_N(volume, ne) || !PF_ALLOC_N(keep, ne) ||
        !PF_ALLOC_N(node_id, m->n_nodes)) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        goto done;
    }
    for (int32_t e = 0; e < ne; ++e)
        parent[e] = e, volume[e] = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        if (a >= 0 && b >= 0) {
            a = find_root(parent, a), b = find_root(parent, b);
            if (a != b)
                parent[a < b ? b : a] = a < b ? a : b;
        }
    }
    int32_t best = -1;
    for (int32_t e = 0; e < ne; ++e) {
        int32_t r = find_root(parent, e);
        *parts += r == e;
        volume[r] += pf_mesh_elem_volume(m, e);
    }
    for (int32_t e = 0; e < ne; ++e)
        if (parent[e] == e && (best < 0 || volume[e] > volume[best]))
            best = e;
    for (int32_t e = 0; e < ne; ++e) {
        keep[e] = find_root(parent, e) == best;
        *dropped += !keep[e];
    }
    if (*dropped > 0) {
        pf_mesh kept;
        st = pf_mesh_select_elements(&kept, m, keep, NULL, err);
        if (st < 0)
            goto done;
        pf_mesh_compact_nodes(&kept, node_id);
        pf_mesh_release(m);
        *m = kept;
        st = pf_mesh_derive(m, err);
    }
done:
    pf_free(parent), pf_free(volume), pf_free(keep), pf_free(node_id);
    return st;
}
