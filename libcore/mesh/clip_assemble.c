/* Assembling a clipped mesh (pf_mesh_clip_surface, clip.c): the elements kept whole and the
 * parts of the clipped ones glued by node sets in src order, checked for matching faces, then
 * slivers merged into neighbours by the slicer's rule. */
#include "clip_internal.h"

#include <string.h>

/* ---- assembling the clipped mesh ----------------------------------------------------------------
 */

typedef struct assembly {
    glue glue;
    pf_buffer parent;  /* int32 per glued element: its src element */
    pf_buffer min_vol; /* double per glued element: sliver threshold */
    pf_buffer origin;  /* int32 per glued element face: the src face it lies on, or -1 */
    int32_t *local;    /* [weld.n] -1 */
} assembly;

static void assembly_release(assembly *as)
{
    pf_glue_release(&as->glue);
    pf_buffer_release(&as->parent);
    pf_buffer_release(&as->min_vol);
    pf_buffer_release(&as->origin);
    pf_free(as->local);
}

/* Glues a piece whose face f lies on src face origin[f] (-1: none), part of src element e. */
static pf_status glue_with(assembly *as, const piece *p, const int32_t *origin, int32_t e,
                           double min_vol, pf_error *err)
{
    PF_TRY(pf_glue_piece(&as->glue, p, err));
    PF_TRY(pf_buffer_append(&as->parent, &e, sizeof e, err));
    PF_TRY(pf_buffer_append(&as->min_vol, &min_vol, sizeof min_vol, err));
    return pf_buffer_append(&as->origin, origin, (size_t)p->n_faces * sizeof *origin, err);
}

/* A piece from faces over the nodes ids of x (src nodes or welded ones); rev[f] reverses face f. */
static pf_status make_piece(assembly *as, const double *x, int32_t n_faces, const int64_t *off,
                            const uint32_t *const *face, const uint8_t *rev, piece *out,
                            pf_error *err)
{
    memset(out, 0, sizeof *out);
    int64_t n_idx = 0;
    for (int32_t f = 0; f < n_faces; ++f)
        n_idx += off[2 * f + 1] - off[2 * f];
    out->face_offsets = pf_alloc_array((size_t)n_faces + 1, sizeof *out->face_offsets);
    out->face_nodes = pf_alloc_array((size_t)n_idx + 1, sizeof *out->face_nodes);
    out->x = pf_alloc_array(3 * (size_t)n_idx + 1, sizeof *out->x);
    uint32_t *ids = pf_alloc_array((size_t)n_idx + 1, sizeof *ids);
    if (!out->face_offsets || !out->face_nodes || !out->x || !ids) {
        pf_free(ids);
        pf_piece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    out->face_offsets[0] = 0;
    int64_t at = 0;
    for (int32_t f = 0; f < n_faces; ++f) {
        int64_t len = off[2 * f + 1] - off[2 * f];
        for (int64_t q = 0; q < len; ++q) {
            uint32_t id = face[f][rev && rev[f] ? (len - q) % len : q];
            if (as->local[id] < 0) {
                as->local[id] = out->n_nodes;
                ids[out->n_nodes] = id;
                memcpy(out->x + 3 * (size_t)out->n_nodes, x + 3 * (size_t)id, 3 * sizeof(double));
                out->n_nodes++;
            }
            out->face_nodes[at++] = (uint32_t)as->local[id];
        }
        out->face_offsets[++out->n_faces] = at;
    }
    for (int32_t i = 0; i < out->n_nodes; ++i)
        as->local[ids[i]] = -1;
    pf_free(ids);
    return PF_OK;
}

/* The elements in src order: whole ones as they are, clipped ones as their parts. */
static pf_status assemble(const pf_mesh *m, const uint8_t *state, const pf_clip_elem_parts *parts,
                          const pf_weld *w, assembly *as, double min_fraction, pf_error *err)
{
    as->local = pf_alloc_array((size_t)w->n + 1, sizeof *as->local);
    PF_CHECK(as->local, err, PF_ERR_NOMEM, "out of memory clipping");
    for (int32_t i = 0; i < w->n; ++i)
        as->local[i] = -1;
    pf_status st = PF_OK;
    for (int32_t e = 0; st >= 0 && e < m->n_elems; ++e) {
        if (state[e] == PF_CLIP_DROPPED)
            continue;
        int64_t e0 = m->elem_offsets[e];
        if (state[e] == PF_CLIP_WHOLE) {
            int32_t nk = (int32_t)(m->elem_offsets[e + 1] - e0);
            int64_t *off = pf_alloc_array(2 * (size_t)nk, sizeof *off);
            const uint32_t **face = pf_alloc_array((size_t)nk, sizeof *face);
            uint8_t *rev = pf_alloc_array((size_t)nk, sizeof *rev);
            int32_t *origin = pf_alloc_array((size_t)nk, sizeof *origin);
            if (!off || !face || !rev || !origin)
                st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
            for (int32_t k = 0; st >= 0 && k < nk; ++k) {
                int32_t f = PF_FACE_INDEX(m->elem_faces[e0 + k]);
                off[2 * k] = 0, off[2 * k + 1] = m->face_offsets[f + 1] - m->face_offsets[f];
                face[k] = m->face_nodes + m->face_offsets[f];
                rev[k] = (m->elem_faces[e0 + k] & PF_FACE_REVERSED) != 0;
                origin[k] = f;
            }
            piece p;
            if (st >= 0)
                st = make_piece(as, m->x, nk, off, face, rev, &p, err);
            if (st >= 0) {
                st = glue_with(as, &p, origin, e, 0, err);
                pf_piece_release(&p);
            }
            pf_free(off), pf_free(face), pf_free(rev), pf_free(origin);
            continue;
        }
        double min_vol = min_fraction * pf_mesh_elem_volume(m, e);
        for (int32_t q = 0; st >= 0 && q < parts[e].n; ++q) {
            const pf_part_faces *pf = &parts[e].part[q];
            int32_t nf = pf->n_faces;
            int64_t *off = pf_alloc_array(2 * (size_t)nf, sizeof *off);
            const uint32_t **face = pf_alloc_array((size_t)nf, sizeof *face);
            int32_t *origin = pf_alloc_array((size_t)nf, sizeof *origin);
            if (!off || !face || !origin)
                st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
            for (int32_t f = 0; st >= 0 && f < nf; ++f) {
                off[2 * f] = 0, off[2 * f + 1] = pf->offsets[f + 1] - pf->offsets[f];
                face[f] = pf->nodes + pf->offsets[f];
                origin[f] = pf->key[f] < 0 ? PF_FACE_INDEX(m->elem_faces[e0 - pf->key[f] - 1]) : -1;
            }
            piece p;
            if (st >= 0)
                st = make_piece(as, w->x, nf, off, face, NULL, &p, err);
            if (st >= 0) {
                st = glue_with(as, &p, origin, e, min_vol, err);
                pf_piece_release(&p);
            }
            pf_free(off), pf_free(face), pf_free(origin);
        }
    }
    return st;
}

/* Where the elements of both sides of a src face have parts on it, every glued face on it must
 * be shared: a face used once there would be a crack through the solid. */
static pf_status check_conforming(const pf_mesh *m, const assembly *as, pf_error *err)
{
    uint8_t *present = pf_calloc((size_t)m->n_faces + 1, 1);
    uint8_t *alone = pf_calloc((size_t)m->n_faces + 1, 1);
    if (!present || !alone) {
        pf_free(present), pf_free(alone);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    const glue *g = &as->glue;
    const int64_t *eo = (const int64_t *)g->elem_offsets.data;
    const uint32_t *ef = (const uint32_t *)g->elem_faces.data;
    const int32_t *origin = (const int32_t *)as->origin.data;
    const int32_t *parent = (const int32_t *)as->parent.data;
    for (int32_t e = 0; e < g->n_elems; ++e)
        for (int64_t j = eo[e]; j < eo[e + 1]; ++j) {
            int32_t f = origin[j];
            if (f < 0 || m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0)
                continue;
            uint8_t side = parent[e] == m->face_elems[2 * f] ? 1 : 2;
            present[f] |= side;
            if (g->face_uses[PF_FACE_INDEX(ef[j])] == 1)
                alone[f] |= side;
        }
    pf_status st = PF_OK;
    for (int32_t f = 0; f < m->n_faces && st >= 0; ++f)
        if (alone[f] && present[f] == 3)
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the parts of elements %d and %d do not match on their shared face "
                              "%d (geometry too degenerate at the clipping tolerance)",
                              (int)m->face_elems[2 * f], (int)m->face_elems[2 * f + 1], (int)f);
    pf_free(present), pf_free(alone);
    return st;
}

/* Glued, then slivers merged into neighbours, into dst. */
pf_status pf_clip_assemble(const pf_mesh *m, const uint8_t *state, const pf_clip_elem_parts *parts,
                           const pf_weld *w, double min_fraction, pf_mesh *dst, int32_t *merged,
                           int32_t *isolated, pf_error *err)
{
    memset(dst, 0, sizeof *dst);
    assembly as = {0};
    pf_mesh glued = {0};
    int32_t *parent = NULL;
    pf_status st = assemble(m, state, parts, w, &as, min_fraction, err);
    if (st >= 0 && as.glue.n_elems == 0)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "nothing of the mesh lies on the kept side of the surface");
    if (st >= 0)
        st = check_conforming(m, &as, err);
    if (st >= 0)
        st = pf_glue_to_mesh(&as.glue, &glued, err);
    if (st >= 0 && !(parent = pf_alloc_array((size_t)glued.n_elems, sizeof *parent)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    if (st >= 0)
        st = pf_merge_slivers(&glued, 0, (const double *)as.min_vol.data, parent, merged, isolated,
                              err);
    if (st >= 0)
        st = pf_rebuild_merged(&glued, parent, dst, err);
    /* dst's elements are the merge roots in order: each takes its root's src element's groups */
    int32_t *dst_parent = NULL;
    if (st >= 0 && (m->elem_group || m->face_group) &&
        !(dst_parent = pf_alloc_array((size_t)dst->n_elems + 1, sizeof *dst_parent)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    if (st >= 0 && dst_parent) {
        const int32_t *src_of = (const int32_t *)as.parent.data;
        for (int32_t e = 0, k = 0; e < glued.n_elems; ++e)
            if (parent[e] == e)
                dst_parent[k++] = src_of[e];
        st = pf_mesh_carry_groups(dst, m, dst_parent, NULL, NULL, err);
    }
    pf_free(dst_parent);
    pf_free(parent);
    pf_mesh_release(&glued);
    assembly_release(&as);
    return st;
}
