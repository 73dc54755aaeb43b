/* What a mesh carries across a change of its elements (refinement, coarsening, cutting): the
 * groups of elements and faces (Gmsh physical groups: materials, fixed and loaded faces), and any
 * other per-face label of the boundary, such as the faces a cut opened. A new face that is an old
 * one node for node takes its label; a new boundary face that is only part of an old one (a split
 * face), or a union of old ones, takes the label of the old boundary face it lies in. */
#include <pf/mesh.h>

#include "mesh_internal.h"

#include <math.h>

/* Whether faces f of a and g of b lie in one plane: unit normals within 1e-9 of each other (or of
 * opposite ones) and g's centroid within 1e-9 of f's size from f's plane. */
static bool coplanar(const pf_mesh *a, int32_t f, const pf_mesh *b, int32_t g)
{
    const uint32_t *fi = a->face_nodes + a->face_offsets[f],
                   *gi = b->face_nodes + b->face_offsets[g];
    int64_t fn = a->face_offsets[f + 1] - a->face_offsets[f];
    int64_t gn = b->face_offsets[g + 1] - b->face_offsets[g];
    pf_vec3 na = pf_v3_normalize(pf_polygon_area_vector(a->x, fi, fn));
    pf_vec3 nb = pf_v3_normalize(pf_polygon_area_vector(b->x, gi, gn));
    pf_vec3 ca = pf_polygon_centroid(a->x, fi, fn), cb = pf_polygon_centroid(b->x, gi, gn);
    double size = sqrt(pf_v3_norm(pf_polygon_area_vector(a->x, fi, fn)));
    bool parallel = pf_v3_norm(pf_v3_sub(na, nb)) < 1e-9 || pf_v3_norm(pf_v3_add(na, nb)) < 1e-9;
    return parallel && fabs(pf_v3_dot(na, pf_v3_sub(cb, ca))) <= 1e-9 * size;
}

int32_t pf_mesh_label_under(const pf_mesh *next, int32_t f, const pf_mesh *old, const int32_t *olds,
                            int32_t n_olds, const int32_t *label)
{
    for (int32_t k = 0; k < n_olds; ++k)
        for (int64_t q = old->elem_offsets[olds[k]]; q < old->elem_offsets[olds[k] + 1]; ++q) {
            int32_t g = PF_FACE_INDEX(old->elem_faces[q]);
            bool boundary = old->face_elems[2 * g] < 0 || old->face_elems[2 * g + 1] < 0;
            if (boundary && label[g] != 0 && coplanar(next, f, old, g))
                return label[g];
        }
    return 0;
}

pf_status pf_mesh_carry_face_label(const pf_mesh *next, const pf_mesh *old, const int32_t *parent,
                                   const int32_t *merged_into, const int32_t *face_src,
                                   const int32_t *label, int32_t *out, pf_error *err)
{
    int32_t n_old = old->n_elems, *olds = pf_alloc_array((size_t)n_old + 1, sizeof *olds);
    PF_CHECK(olds, err, PF_ERR_NOMEM, "cannot allocate %d element slots", (int)n_old);
    for (int32_t f = 0; f < next->n_faces; ++f) {
        int32_t g = face_src ? face_src[f] : -1;
        int32_t e =
            next->face_elems[2 * f] >= 0 ? next->face_elems[2 * f] : next->face_elems[2 * f + 1];
        bool boundary = next->face_elems[2 * f] < 0 || next->face_elems[2 * f + 1] < 0;
        out[f] = g >= 0 ? label[g] : 0;
        if (g >= 0 || !boundary || e < 0)
            continue;
        int32_t n = 0; /* e's old element, or the elements merged into it */
        for (int32_t q = 0; merged_into && q < n_old; ++q)
            if (merged_into[q] == e)
                olds[n++] = q;
        if (n == 0)
            olds[n++] = parent[e];
        out[f] = pf_mesh_label_under(next, f, old, olds, n, label);
    }
    pf_free(olds);
    return PF_OK;
}

pf_status pf_mesh_carry_groups(pf_mesh *next, const pf_mesh *old, const int32_t *parent,
                               const int32_t *merged_into, const int32_t *face_src, pf_error *err)
{
    if (!old->elem_group && !old->face_group)
        return PF_OK;
    PF_TRY(pf_mesh_groups_copy(next, old, err));
    for (int32_t e = 0; e < next->n_elems && next->elem_group; ++e)
        next->elem_group[e] = old->elem_group[parent[e]];
    if (!next->face_group)
        return PF_OK;
    return pf_mesh_carry_face_label(next, old, parent, merged_into, face_src, old->face_group,
                                    next->face_group, err);
}
