/* CG in the distributed static solve (sim_distrib.h): each rank sets up and assembles the CG
 * method on its own elements only (a CG element needs only its nodes: no halo), and sends PETSc
 * all of its entries, which MatSetValuesCOO sums where parts share nodes; the right-hand side the
 * same way (ADD_VALUES). What a part cannot see of the whole mesh comes from rank 0: which nodes
 * are fixed (a node of a face fixed in another part is fixed here too) and which of the part's
 * boundary faces lie between parts (no load acts there). The free nodes are numbered part by part
 * (each node owned by the lowest part that holds it), so each rank's rows are one contiguous
 * range. */
#include "sim_distrib.h"

#include <stdint.h>
#include <string.h>

#ifdef PF_HAVE_PETSC

/* Each used node's owner: the lowest part among its elements' (INT32_MAX for a node no element
 * uses). */
static void node_owners(const pf_mesh *m, const int64_t *owner, int32_t *node_owner)
{
    for (int32_t i = 0; i < m->n_nodes; ++i)
        node_owner[i] = INT32_MAX;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            uint32_t f = m->elem_faces[q] & ~PF_FACE_REVERSED;
            for (int64_t s = m->face_offsets[f]; s < m->face_offsets[f + 1]; ++s) {
                int32_t *o = &node_owner[m->face_nodes[s]];
                if (owner[e] < *o)
                    *o = (int32_t)owner[e];
            }
        }
}

pf_status pf_sim_distrib_cg_whole(const pf_scene *scene, const pf_mesh *m, const int64_t *owner,
                                  int32_t parts, cg_whole *w, pf_error *err)
{
    size_t nn = (size_t)m->n_nodes;
    memset(w, 0, sizeof *w);
    w->fixed = pf_calloc(nn + 1, sizeof *w->fixed);
    w->g = pf_calloc(3 * nn + 1, sizeof *w->g);
    w->node_owner = pf_alloc_array(nn + 1, sizeof *w->node_owner);
    w->pnode = pf_alloc_array(nn + 1, sizeof *w->pnode);
    w->wnode = pf_alloc_array(nn + 1, sizeof *w->wnode);
    int64_t *next = pf_calloc((size_t)parts + 1, sizeof *next);
    if (!w->fixed || !w->g || !w->node_owner || !w->pnode || !w->wnode || !next) {
        pf_free(next);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the CG nodes of %zu", nn);
    }
    w->fixed_faces = pf_sim_cg_fixed_nodes(scene, m, w->fixed, w->g, NULL);
    node_owners(m, owner, w->node_owner);
    for (size_t i = 0; i < nn; ++i)
        if (!w->fixed[i] && w->node_owner[i] < parts)
            next[w->node_owner[i] + 1]++;
    for (int32_t r = 0; r < parts; ++r)
        next[r + 1] += next[r];
    w->all_free = next[parts];
    int64_t whole = 0; /* the one-process order: free nodes by index (pf_cg_pattern) */
    for (size_t i = 0; i < nn; ++i) {
        bool is_free = !w->fixed[i] && w->node_owner[i] < parts;
        w->pnode[i] = is_free ? next[w->node_owner[i]]++ : -1;
        w->wnode[i] = is_free ? whole++ : -1;
    }
    pf_free(next);
    return PF_OK;
}

void pf_sim_distrib_cg_whole_release(cg_whole *w)
{
    pf_free(w->fixed), pf_free(w->g), pf_free(w->node_owner), pf_free(w->pnode);
    pf_free(w->wnode);
    memset(w, 0, sizeof *w);
}

/* Bytes per node in a part's message: PETSc block, ownership, displacement, whole-mesh block. */
enum { NODE_BYTES = 8 + 1 + 24 + 8 };

pf_status pf_sim_distrib_cg_pack(const pf_mesh *m, const cg_whole *w, const uint8_t *keep,
                                 const int32_t *node_id, int32_t r, pf_buffer *out, pf_error *err)
{
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        if (node_id[i] < 0)
            continue;
        unsigned char b[NODE_BYTES];
        memcpy(b, &w->pnode[i], 8);
        b[8] = w->node_owner[i] == r;
        memcpy(b + 9, w->g + 3 * (size_t)i, 24);
        memcpy(b + 33, &w->wnode[i], 8);
        PF_TRY(pf_buffer_append(out, b, sizeof b, err));
    }
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        bool ka = a >= 0 && keep[a], kb = b >= 0 && keep[b];
        uint8_t cut = a >= 0 && b >= 0 && ka != kb;
        if (ka || kb)
            PF_TRY(pf_buffer_append(out, &cut, 1, err));
    }
    return PF_OK;
}

pf_status pf_sim_distrib_cg_unpack(part *p, const unsigned char *at, pf_error *err)
{
    size_t nn = (size_t)p->h.n_nodes, nf = (size_t)p->mesh.n_faces;
    p->pnode = pf_alloc_array(nn + 1, sizeof *p->pnode);
    p->wnode = pf_alloc_array(nn + 1, sizeof *p->wnode);
    p->node_owned = pf_alloc_array(nn + 1, sizeof *p->node_owned);
    p->g = pf_alloc_array(3 * nn + 1, sizeof *p->g);
    p->cut = pf_alloc_array(nf + 1, sizeof *p->cut);
    PF_CHECK(p->pnode && p->wnode && p->node_owned && p->g && p->cut, err, PF_ERR_NOMEM,
             "cannot allocate a part of %zu nodes", nn);
    for (size_t i = 0; i < nn; ++i, at += NODE_BYTES) {
        memcpy(&p->pnode[i], at, 8);
        p->node_owned[i] = at[8];
        memcpy(p->g + 3 * i, at + 9, 24);
        memcpy(&p->wnode[i], at + 33, 8);
    }
    memcpy(p->cut, at, nf);
    return PF_OK;
}

/* The PETSc rows of the part's unknowns: a free node's block is its PETSc block. */
static pf_status cg_rows(part *p, pf_error *err)
{
    const int64_t *off, *triple;
    const double *w;
    p->ops->nodal_map(p->method, &off, &triple, &w);
    p->n_dofs = p->ops->n_dofs(p->method);
    p->row = pf_alloc_array((size_t)p->n_dofs + 1, sizeof *p->row);
    p->row_owned = pf_alloc_array((size_t)p->n_dofs + 1, sizeof *p->row_owned);
    PF_CHECK(p->row && p->row_owned, err, PF_ERR_NOMEM, "cannot allocate %lld rows",
             (long long)p->n_dofs);
    for (int32_t i = 0; i < p->h.n_nodes; ++i) {
        if (off[i + 1] == off[i])
            continue;
        PF_CHECK(p->pnode[i] >= 0, err, PF_ERR_INVALID, "node %d of the part is not free", (int)i);
        for (int d = 0; d < 3; ++d) {
            p->row[3 * triple[off[i]] + d] = (PetscInt)(3 * p->pnode[i] + d);
            p->row_owned[3 * triple[off[i]] + d] = p->node_owned[i];
        }
        p->local_rows += 3 * p->node_owned[i];
    }
    return PF_OK;
}

pf_status pf_sim_distrib_cg_create(part *p, pf_error *err)
{
    p->all_rows = (PetscInt)(3 * p->h.all_free);
    if (p->h.n_elems == 0)
        return PF_OK;
    size_t nn = (size_t)p->h.n_nodes;
    uint8_t *fixed = pf_alloc_array(nn + 1, sizeof *fixed);
    PF_CHECK(fixed, err, PF_ERR_NOMEM, "cannot allocate %zu nodes", nn);
    for (size_t i = 0; i < nn; ++i)
        fixed[i] = p->pnode[i] < 0;
    pf_progress_hook none = {0};
    int32_t fixed_faces = 0, loaded = 0;
    pf_status st = pf_sim_cg_create(&p->scene, &p->mesh, NULL, &none, &p->ops, &p->method,
                                    &fixed_faces, &loaded, err);
    if (st >= 0)
        st = pf_sim_cg_set_part(p->method, fixed, p->g, p->cut, err);
    pf_free(fixed);
    return st >= 0 ? cg_rows(p, err) : st;
}

void pf_sim_distrib_cg_nodal(const part *p, double *sum, double *scratch)
{
    if (!p->method)
        return;
    p->ops->nodal_displacements(p->method, p->u, scratch);
    for (int32_t i = 0; i < p->h.n_nodes; ++i) {
        if (!p->node_owned[i])
            continue;
        double *s = sum + 4 * (size_t)p->gnode[i];
        for (int c = 0; c < 3; ++c)
            s[c] += scratch[3 * (size_t)i + c];
        s[3] += 1;
    }
}

void pf_sim_distrib_cg_release(part *p)
{
    pf_free(p->pnode), pf_free(p->node_owned), pf_free(p->g), pf_free(p->cut);
    pf_free(p->wnode);
}

#endif
