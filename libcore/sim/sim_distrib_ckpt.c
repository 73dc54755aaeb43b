/* Checkpoints of the runs where every MPI rank assembles its own elements (sim_distrib.h): the
 * state a one-process simulator stores (sim_state.c, the CKPT payload), gathered on rank 0 in the
 * whole mesh's unknown order, and scattered back from it to the parts, so that a checkpoint of
 * either kind of run continues on either.
 *
 * The one-process order: DG element e's unknowns at e nb3 (a part's elements know their index in
 * the whole mesh, p->gelem); CG the free nodes in node order, 3 unknowns each (a part's nodes
 * carry their block in that order from rank 0, p->wnode, besides their PETSc block, which
 * numbers them part by part). Each unknown is gathered from the rank that owns its row (DG: the
 * element's owner; CG: the lowest part holding the node) and scattered to every part holding it
 * (DG's halo, CG's shared nodes): each rank sends rank 0 the whole-mesh indices it wants, and
 * rank 0 answers with the values, so that no rank but rank 0 holds the whole state. */
#include "sim_distrib.h"

#include <string.h>

#ifdef PF_HAVE_PETSC

pf_status pf_sim_distrib_whole_dofs(part *p, pf_error *err)
{
    p->wdof = pf_alloc_array((size_t)p->n_dofs + 1, sizeof *p->wdof);
    PF_CHECK(p->wdof, err, PF_ERR_NOMEM, "cannot allocate %lld unknowns", (long long)p->n_dofs);
    if (p->scene.method != PF_METHOD_CG) {
        for (int64_t i = 0; i < p->n_dofs; ++i)
            p->wdof[i] = (int64_t)p->gelem[i / p->nb3] * p->nb3 + i % p->nb3;
        return PF_OK;
    }
    if (!p->method)
        return PF_OK;
    const int64_t *off, *triple;
    const double *w;
    p->ops->nodal_map(p->method, &off, &triple, &w);
    for (int32_t i = 0; i < p->h.n_nodes; ++i)
        for (int d = 0; off[i + 1] > off[i] && d < 3; ++d)
            p->wdof[3 * triple[off[i]] + d] = 3 * p->wnode[i] + d;
    return PF_OK;
}

bool pf_sim_distrib_checkpoint_due(const part *p, int32_t index)
{
    int32_t every = p->h.checkpoint_every;
    bool last = p->scene.is_static || index == p->scene.frames;
    return every > 0 && (index % every == 0 || last);
}

/* Rank 0's displacements and offsets of every rank's count (counts, displs [ranks]). */
static int64_t offsets(const int *counts, int *displs, int n)
{
    int64_t at = 0;
    for (int r = 0; r < n; ++r) {
        displs[r] = (int)at;
        at += counts[r];
    }
    return at;
}

/* Rank 0's view of every rank's indices: per rank their count and place (counts2, displs2: of
 * their value pairs), and all of them with 2 values each. */
typedef struct exchange {
    int n, *counts, *displs, *counts2, *displs2;
    int64_t total, *idx;
    double *vals;
} exchange;

static void exchange_release(exchange *x)
{
    pf_free(x->counts), pf_free(x->displs), pf_free(x->counts2), pf_free(x->displs2);
    pf_free(x->idx), pf_free(x->vals);
    memset(x, 0, sizeof *x);
}

/* The indices idx [m] of every rank on rank 0 (x->idx, in rank order), with room for their
 * values (x->vals, 2 each); with vals [2 m] (NULL: none sent) their values too. Collective. */
static pf_status gather_indices(exchange *x, const int64_t *idx, const double *vals, int m,
                                bool root, pf_error *err)
{
    MPI_Comm_size(PETSC_COMM_WORLD, &x->n);
    size_t n = (size_t)x->n;
    if (root) {
        x->counts = pf_calloc(n, sizeof *x->counts);
        x->displs = pf_calloc(n, sizeof *x->displs);
        x->counts2 = pf_calloc(n, sizeof *x->counts2);
        x->displs2 = pf_calloc(n, sizeof *x->displs2);
    }
    pf_status st = !root || (x->counts && x->displs && x->counts2 && x->displs2)
                       ? PF_OK
                       : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                      "cannot allocate the counts of %zu ranks", n);
    MPI_Gather(&m, 1, MPI_INT, x->counts, 1, MPI_INT, 0, PETSC_COMM_WORLD);
    if (root && st >= 0) {
        x->total = offsets(x->counts, x->displs, x->n);
        for (int r = 0; r < x->n; ++r)
            x->counts2[r] = 2 * x->counts[r], x->displs2[r] = 2 * x->displs[r];
        x->idx = pf_alloc_array((size_t)x->total + 1, sizeof *x->idx);
        x->vals = pf_alloc_array(2 * (size_t)x->total + 1, sizeof *x->vals);
        if (!x->idx || !x->vals)
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                              "cannot allocate the state of %lld unknowns", (long long)x->total);
    }
    PF_TRY(pf_sim_distrib_agree(st, err));
    MPI_Gatherv(idx, m, MPI_INT64_T, x->idx, x->counts, x->displs, MPI_INT64_T, 0,
                PETSC_COMM_WORLD);
    if (vals)
        MPI_Gatherv(vals, 2 * m, MPI_DOUBLE, x->vals, x->counts2, x->displs2, MPI_DOUBLE, 0,
                    PETSC_COMM_WORLD);
    return PF_OK;
}

/* This rank's owned unknowns: their whole-mesh indices idx and (u, v) pairs vals [2 m]. */
static pf_status owned_state(const part *p, const double *v, int64_t **idx, double **vals, int *m,
                             pf_error *err)
{
    int64_t count = 0;
    for (int64_t i = 0; i < p->n_dofs; ++i)
        count += p->row_owned[i];
    *idx = pf_alloc_array((size_t)count + 1, sizeof **idx);
    *vals = pf_alloc_array(2 * (size_t)count + 1, sizeof **vals);
    PF_CHECK(*idx && *vals, err, PF_ERR_NOMEM, "cannot allocate %lld unknowns", (long long)count);
    int64_t k = 0;
    for (int64_t i = 0; i < p->n_dofs; ++i) {
        if (!p->row_owned[i])
            continue;
        (*idx)[k] = p->wdof[i];
        (*vals)[2 * k] = p->u[i];
        (*vals)[2 * k + 1] = v ? v[i] : 0;
        ++k;
    }
    *m = (int)count;
    return PF_OK;
}

/* Rank 0: the payload of the gathered state and the checkpoint function's hearing of it. */
static pf_status write_state(const part *p, const exchange *x, pf_sim_saved st,
                             const distrib_out *o, pf_error *err)
{
    size_t n = (size_t)p->all_rows;
    double *u = pf_calloc(2 * n + 1, sizeof *u);
    PF_CHECK(u, err, PF_ERR_NOMEM, "cannot allocate the state of %zu unknowns", n);
    for (int64_t k = 0; k < x->total; ++k) {
        u[x->idx[k]] = x->vals[2 * k];
        u[n + (size_t)x->idx[k]] = x->vals[2 * k + 1];
    }
    st.mesh_id = o->mesh->id;
    st.n = (int64_t)n;
    pf_buffer bytes = {0};
    pf_status s = pf_sim_state_fingerprint(o->scene, o->mesh, &st.print, err);
    if (s >= 0)
        s = pf_sim_state_encode(&st, u, u + n, &bytes, err);
    pf_free(u);
    if (s >= 0 && o->opt && o->opt->checkpoint)
        s = o->opt->checkpoint(o->opt->ctx, o->res, bytes.data, bytes.size, err);
    pf_buffer_release(&bytes);
    return s;
}

pf_status pf_sim_distrib_checkpoint(part *p, const double *v, const pf_sim_saved *st,
                                    const rank_stats *rs, const distrib_out *o, pf_error *err)
{
    pf_sim_saved all = *st;
    MPI_Allreduce(&st->work, &all.work, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    int64_t *idx = NULL;
    double *vals = NULL;
    int m = 0;
    exchange x = {0};
    pf_status s = pf_sim_distrib_agree(owned_state(p, v, &idx, &vals, &m, err), err);
    if (s >= 0)
        s = gather_indices(&x, idx, vals, m, o != NULL, err);
    if (s >= 0 && o) {
        pf_sim_distrib_result_counts(p, rs, o->res);
        s = write_state(p, &x, all, o, err);
    }
    pf_free(idx), pf_free(vals);
    exchange_release(&x);
    return pf_sim_distrib_agree(s, err);
}

/* Rank 0: the checkpoint's values at the indices gathered in x (x->vals: u, v pairs). */
static pf_status read_state(const part *p, exchange *x, pf_sim_saved *st, const distrib_out *o,
                            pf_error *err)
{
    const unsigned char *values = NULL;
    PF_TRY(pf_sim_state_decode(o->opt->restore, o->opt->restore_size, o->scene, o->mesh,
                               (int64_t)p->all_rows, st, &values, err));
    for (int64_t k = 0; k < x->total; ++k) {
        int64_t q = x->idx[k];
        PF_CHECK(q >= 0 && q < (int64_t)p->all_rows, err, PF_ERR_INVALID,
                 "unknown %lld of a part outside the whole mesh's %lld", (long long)q,
                 (long long)p->all_rows);
        x->vals[2 * k] = pf_sim_state_value(values, q);
        x->vals[2 * k + 1] = pf_sim_state_value(values, (int64_t)p->all_rows + q);
    }
    return PF_OK;
}

pf_status pf_sim_distrib_restore(part *p, double *v, pf_sim_saved *st, const distrib_out *o,
                                 pf_error *err)
{
    int m = (int)p->n_dofs;
    double *mine = pf_alloc_array(2 * (size_t)m + 1, sizeof *mine);
    exchange x = {0};
    pf_status s = pf_sim_distrib_agree(mine ? PF_OK
                                            : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                           "cannot allocate %d unknowns", m),
                                       err);
    if (s >= 0)
        s = gather_indices(&x, p->wdof, NULL, m, o != NULL, err); /* agreed */
    if (s >= 0) /* rank 0's reading, agreed before the scatter */
        s = pf_sim_distrib_agree(o ? read_state(p, &x, st, o, err) : PF_OK, err);
    if (s >= 0) {
        MPI_Scatterv(x.vals, x.counts2, x.displs2, MPI_DOUBLE, mine, 2 * m, MPI_DOUBLE, 0,
                     PETSC_COMM_WORLD);
        MPI_Bcast(st, (int)sizeof *st, MPI_BYTE, 0, PETSC_COMM_WORLD);
        if (!o)
            st->work = 0; /* rank 0 carries the work done so far */
        for (int i = 0; i < m; ++i) {
            p->u[i] = mine[2 * i];
            if (v)
                v[i] = mine[2 * i + 1];
        }
    }
    pf_free(mine);
    exchange_release(&x);
    return s;
}

pf_status pf_sim_distrib_resume(part *p, double *v, pf_sim_saved *st, const distrib_out *o,
                                pf_error *err)
{
    PF_TRY(pf_sim_distrib_restore(p, v, st, o, err));
    distrib_out quiet = {0};
    if (o) {
        quiet = *o;
        quiet.frame = NULL;
        o->res->frame = p->scene.is_static ? 0 : st->frame; /* the FRAM index */
        o->res->time = st->time;
    }
    return pf_sim_distrib_agree(pf_sim_distrib_outputs(p, o ? &quiet : NULL, err), err);
}

#endif
