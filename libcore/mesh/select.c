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
    pf_free(face_map);
    return PF_OK;
}
