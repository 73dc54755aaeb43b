/* Contact on the per-rank path (sim_distrib.h): what a part needs of the whole mesh to test the
 * points it holds, the mesh obstacles' triangles sent with the parts, and the part's contact.
 *
 * Every point of the whole mesh (contact.c: one per element at a boundary node for DG, whose
 * fields disagree there; one per free boundary node for CG) is tested on one rank: DG on the
 * owner of the element it moves with, CG on the owner of its node. Such a point's row lies in its
 * element or node, which the part holds, so its force lands in rows the rank sends (DG: the owned
 * element's; CG: its share at the node, summed with the other parts' by PETSc) and its stiffness
 * in blocks it sends. What the part cannot see: whether a node of its own lies on the whole
 * mesh's boundary (a part's own boundary includes the faces between parts), how many elements of
 * the whole mesh share a DG node's penalty, and the whole mesh's mean element size for the
 * automatic stiffness; rank 0 sends the first two, the third is a sum over the ranks. */
#include "sim_distrib.h"

#include <string.h>

#ifdef PF_HAVE_PETSC

pf_status pf_sim_distrib_contact_whole(const pf_mesh *m, contact_whole *w, pf_error *err)
{
    size_t nn = (size_t)m->n_nodes + 1;
    w->boundary = pf_calloc(nn, 1);
    w->sharers = pf_calloc(nn, sizeof *w->sharers);
    int32_t *last = pf_alloc_array(nn, sizeof *last);
    if (!w->boundary || !w->sharers || !last) {
        pf_free(last);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the contact data of %d nodes", (int)m->n_nodes);
    }
    int32_t n_boundary;
    pf_status st = pf_contact_boundary_nodes(m, w->boundary, &n_boundary, err);
    if (st < 0) {
        pf_free(last);
        return st;
    }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        last[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
                if (last[m->face_nodes[q]] != e) {
                    last[m->face_nodes[q]] = e;
                    w->sharers[m->face_nodes[q]]++;
                }
        }
    pf_free(last);
    return PF_OK;
}

void pf_sim_distrib_contact_whole_release(contact_whole *w)
{
    pf_free(w->boundary), pf_free(w->sharers);
    *w = (contact_whole){0};
}

pf_status pf_sim_distrib_contact_pack(const pf_mesh *m, const contact_whole *w,
                                      const int32_t *node_id, pf_buffer *out, pf_error *err)
{
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (node_id[i] >= 0) {
            PF_TRY(pf_buffer_append(out, &w->boundary[i], 1, err));
            PF_TRY(pf_buffer_append(out, &w->sharers[i], sizeof *w->sharers, err));
        }
    return PF_OK;
}

pf_status pf_sim_distrib_contact_unpack(part *p, unsigned char **at, pf_error *err)
{
    size_t nn = (size_t)p->h.n_nodes;
    p->boundary = pf_alloc_array(nn + 1, 1);
    p->sharers = pf_alloc_array(nn + 1, sizeof *p->sharers);
    PF_CHECK(p->boundary && p->sharers, err, PF_ERR_NOMEM,
             "cannot allocate the contact data of %zu nodes", nn);
    for (size_t i = 0; i < nn; ++i, *at += 1 + sizeof *p->sharers) {
        p->boundary[i] = (*at)[0];
        memcpy(&p->sharers[i], *at + 1, sizeof *p->sharers);
    }
    return PF_OK;
}

/* Each mesh obstacle's surface as its SURF version (1 byte), payload size (8) and payload. */
pf_status pf_sim_distrib_obstacles_pack(const pf_scene *scene, pf_buffer *out, pf_error *err)
{
    pf_buffer one = {0};
    pf_status st = PF_OK;
    for (int32_t k = 0; st >= 0 && k < scene->n_obstacles; ++k) {
        const pf_obstacle *o = &scene->obstacles[k];
        if (o->kind != PF_OBSTACLE_MESH)
            continue;
        one.size = 0;
        st = pf_stream_encode_surface(&o->surface, &one, err);
        uint8_t version = (uint8_t)pf_stream_surface_version(&o->surface);
        int64_t size = (int64_t)one.size;
        if (st >= 0)
            st = pf_buffer_append(out, &version, 1, err);
        if (st >= 0)
            st = pf_buffer_append(out, &size, sizeof size, err);
        if (st >= 0)
            st = pf_buffer_append(out, one.data, one.size, err);
    }
    pf_buffer_release(&one);
    return st;
}

pf_status pf_sim_distrib_obstacles_unpack(pf_scene *scene, const unsigned char *bytes,
                                          int64_t size, pf_error *err)
{
    const unsigned char *at = bytes, *end = bytes + size;
    for (int32_t k = 0; k < scene->n_obstacles; ++k) {
        if (scene->obstacles[k].kind != PF_OBSTACLE_MESH)
            continue;
        int64_t n = 0;
        PF_CHECK(end - at >= 9, err, PF_ERR_INVALID, "obstacles[%d]: no surface from rank 0",
                 (int)k);
        memcpy(&n, at + 1, sizeof n);
        pf_chunk c = {.tag = "SURF",
                      .version = at[0],
                      .size = (uint64_t)n,
                      .payload = (unsigned char *)(at + 9)}; /* read, not written */
        PF_CHECK(n >= 0 && n <= end - at - 9, err, PF_ERR_INVALID,
                 "obstacles[%d]: a truncated surface from rank 0", (int)k);
        pf_surface s = {0};
        PF_TRY(pf_stream_decode_surface(&c, &s, err));
        pf_status st = pf_scene_set_obstacle_surface(scene, k, &s, err);
        pf_surface_release(&s);
        PF_TRY(st);
        at += 9 + n;
    }
    return PF_OK;
}

pf_status pf_sim_distrib_contact_create(part *p, double model_size, pf_contact_part *cp,
                                        pf_contact **c, pf_error *err)
{
    *c = NULL;
    if (!pf_scene_has_contact(&p->scene))
        return PF_OK;
    double mine[2] = {0, 0}, all[2] = {0, 0}; /* the owned elements' sizes and count */
    for (int32_t e = 0; p->method && e < p->h.n_elems; ++e)
        if (p->owned[e])
            mine[0] += p->ops->element_size(p->method, e), mine[1] += 1;
    MPI_Allreduce(mine, all, 2, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    if (!p->method)
        return PF_OK;
    bool cg = p->scene.method == PF_METHOD_CG;
    *cp = (pf_contact_part){.boundary = p->boundary,
                            .sharers = cg ? NULL : p->sharers,
                            .element_holds = cg ? NULL : p->owned,
                            .node_holds = cg ? p->node_owned : NULL};
    double size = all[1] > 0 ? all[0] / all[1] : 0;
    pf_contact_setup cs = {.scene = &p->scene,
                           .mesh = &p->mesh,
                           .n_triples = p->n_dofs / 3,
                           .ops = p->ops,
                           .method = p->method,
                           .auto_stiffness = p->ops->ground_stiffness(p->method, size),
                           .model_size = model_size,
                           .n_blocks = p->k.n_blocks,
                           .block_start = p->k.block_start,
                           .part = cp};
    return pf_contact_create(c, &cs, err);
}

#endif
