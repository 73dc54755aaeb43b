/* Summary statistics and the stable text view of a mesh. */
#include <pf/mesh.h>

#include <inttypes.h>
#include <math.h>

pf_status pf_mesh_compute_stats(const pf_mesh *m, pf_mesh_stats *out, pf_error *err)
{
    *out = (pf_mesh_stats){.n_nodes = m->n_nodes, .n_faces = m->n_faces, .n_elems = m->n_elems};
    pf_mesh_bounds(m, &out->lo, &out->hi);
    uint8_t *uses = pf_calloc((size_t)m->n_faces, 1);
    PF_CHECK(uses || m->n_faces == 0, err, PF_ERR_NOMEM, "cannot allocate face counts");
    out->min_volume = m->n_elems ? INFINITY : 0;
    out->max_volume = m->n_elems ? -INFINITY : 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
            uses[PF_FACE_INDEX(m->elem_faces[k])]++;
        pf_elem_kind kind = m->elem_kind ? (pf_elem_kind)m->elem_kind[e] : pf_mesh_classify_elem(m, e);
        out->n_by_kind[kind]++;
        double v = pf_mesh_elem_volume(m, e);
        out->volume += v;
        out->min_volume = fmin(out->min_volume, v);
        out->max_volume = fmax(out->max_volume, v);
    }
    for (int32_t f = 0; f < m->n_faces; ++f)
        out->n_boundary_faces += uses[f] == 1;
    pf_free(uses);
    return PF_OK;
}

void pf_mesh_print(const pf_mesh *m, FILE *out)
{
    fprintf(out, "mesh %" PRIu64 ": %d nodes, %d faces, %d elements\n", m->id, (int)m->n_nodes,
            (int)m->n_faces, (int)m->n_elems);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        fprintf(out, "node %d %.17g %.17g %.17g\n", (int)i, m->x[3 * i], m->x[3 * i + 1],
                m->x[3 * i + 2]);
    for (int32_t f = 0; f < m->n_faces; ++f) {
        fprintf(out, "face %d", (int)f);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j)
            fprintf(out, " %u", m->face_nodes[j]);
        fputc('\n', out);
    }
    for (int32_t e = 0; e < m->n_elems; ++e) {
        fprintf(out, "elem %d %s", (int)e, pf_elem_kind_name(pf_mesh_classify_elem(m, e)));
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
            fprintf(out, " %s%d", (m->elem_faces[k] & PF_FACE_REVERSED) ? "-" : "+",
                    (int)PF_FACE_INDEX(m->elem_faces[k]));
        fputc('\n', out);
    }
}
