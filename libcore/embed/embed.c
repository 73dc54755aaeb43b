/* Embedding weights: parameters, the shared affine least-squares fit, the row builder and the
 * entry point. */
#include "embed_internal.h"

#include <stdlib.h>
#include <string.h>

const char *pf_embed_method_name(pf_embed_method m)
{
    return m == PF_EMBED_HARMONIC ? "harmonic" : m == PF_EMBED_BARY ? "bary" : "mls";
}

pf_embed_params pf_embed_params_default(void)
{
    return (pf_embed_params){.method = PF_EMBED_MLS,
                             .support = 2.0,
                             .sharpness = 3.0,
                             .min_spread = 1e-3,
                             .growth = 1.5,
                             .max_growth = 20};
}

pf_status pf_embed_resolve_params(const pf_embed_params *in, pf_embed_params *out, pf_error *err)
{
    pf_embed_params d = pf_embed_params_default();
    *out = in ? *in : d;
    if (out->support == 0)
        out->support = d.support;
    if (out->sharpness == 0)
        out->sharpness = d.sharpness;
    if (out->min_spread == 0)
        out->min_spread = d.min_spread;
    if (out->growth == 0)
        out->growth = d.growth;
    if (out->max_growth == 0)
        out->max_growth = d.max_growth;
    PF_CHECK(out->method == PF_EMBED_MLS || out->method == PF_EMBED_BARY ||
                 out->method == PF_EMBED_HARMONIC,
             err, PF_ERR_INVALID,
             "unknown embedding method %d", (int)out->method);
    PF_CHECK(out->support > 0 && isfinite(out->support) && out->sharpness > 0 &&
                 isfinite(out->sharpness) && out->min_spread > 0 && out->min_spread < 1 &&
                 out->growth > 1 && isfinite(out->growth) && out->max_growth > 0,
             err, PF_ERR_INVALID,
             "embedding parameters out of range (support %g, sharpness %g, min_spread %g, "
             "growth %g, max_growth %d)",
             out->support, out->sharpness, out->min_spread, out->growth, (int)out->max_growth);
    return PF_OK;
}

/* ---- weighted affine least squares --------------------------------------------------------------
 * Minimising sum_i theta_i |alpha + g . (d_i - m) - u_i|^2 with the weighted mean m of the d_i
 * decouples alpha = sum theta_i u_i / Theta from g = C^-1 sum theta_i (d_i - m) u_i, C the
 * weighted scatter matrix sum theta_i (d_i - m)(d_i - m)^T. The fit at the origin,
 * alpha - g . m, is sum_i W_i u_i with
 *     W_i = theta_i (1 / Theta - (C^-1 m) . (d_i - m)),
 * the DG paper's A(x)^-1 b(x) (eq. 31) solved in centred coordinates: sum W_i = 1 and
 * sum W_i d_i = m - C^-1 m . C = 0 hold for any C, so affine fields are reproduced to round-off. */
int pf_affine_fit_weights(const double *d, const double *theta, int32_t n, double min_spread,
                       double *out)
{
    if (n < 4)
        return 0;
    double total = 0;
    pf_vec3 m = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < n; ++i) {
        total += theta[i];
        m = pf_v3_add(m, pf_v3_scale(pf_v3_load(d + 3 * (size_t)i), theta[i]));
    }
    if (!(total > 0))
        return 0;
    m = pf_v3_scale(m, 1.0 / total);
    pf_mat3 c = {{{0}}};
    for (int32_t i = 0; i < n; ++i) {
        pf_vec3 e = pf_v3_sub(pf_v3_load(d + 3 * (size_t)i), m);
        double ev[3] = {e.x, e.y, e.z};
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
                c.m[a][b] += theta[i] * ev[a] * ev[b];
    }
    c = pf_m3_scale(c, 1.0 / total); /* the weighted covariance */
    double lambda[3];
    pf_mat3 v;
    pf_mat3_sym_eigen(c, lambda, &v);
    if (!(lambda[0] > min_spread * lambda[2]))
        return 0;
    /* g = C^-1 m through the eigenvectors (C here is the covariance: scale back by Theta) */
    pf_vec3 vm = pf_m3_mulv(pf_m3_transpose(v), m);
    vm = pf_v3(vm.x / lambda[0], vm.y / lambda[1], vm.z / lambda[2]);
    pf_vec3 g = pf_v3_scale(pf_m3_mulv(v, vm), 1.0 / total);
    for (int32_t i = 0; i < n; ++i) {
        pf_vec3 e = pf_v3_sub(pf_v3_load(d + 3 * (size_t)i), m);
        out[i] = theta[i] * (1.0 / total - pf_v3_dot(g, e));
    }
    return 1;
}

/* ---- row builder ----------------------------------------------------------------------------- */

pf_status pf_row_builder_init(row_builder *b, pf_weights *w, int32_t rows, int32_t cols,
                           int64_t cap_hint, pf_error *err)
{
    b->w = w;
    b->nnz = 0;
    b->cap = cap_hint > 16 ? cap_hint : 16;
    PF_TRY(pf_weights_alloc(w, rows, cols, b->cap, err));
    return PF_OK;
}

typedef struct entry {
    uint32_t col;
    double val;
} entry;

static int compare_entries(const void *a, const void *b)
{
    uint32_t x = ((const entry *)a)->col, y = ((const entry *)b)->col;
    return (x > y) - (x < y);
}

pf_status pf_row_builder_add(row_builder *b, int32_t i, uint32_t *col, double *val, int32_t n,
                          pf_error *err)
{
    pf_weights *w = b->w;
    if (b->nnz + n > b->cap) {
        int64_t cap = b->cap * 2 > b->nnz + n ? b->cap * 2 : b->nnz + n;
        uint32_t *c = pf_realloc_array(w->col, (size_t)cap, sizeof *c);
        if (c)
            w->col = c;
        double *v = c ? pf_realloc_array(w->val, (size_t)cap, sizeof *v) : NULL;
        if (v)
            w->val = v;
        PF_CHECK(c && v, err, PF_ERR_NOMEM, "out of memory for %lld weights", (long long)cap);
        b->cap = cap;
    }
    int sorted = 1;
    for (int32_t k = 1; k < n; ++k)
        sorted &= col[k - 1] < col[k];
    if (!sorted) { /* small rows: through a local array of pairs */
        entry local[64];
        entry *e = n <= 64 ? local : pf_alloc_array((size_t)n, sizeof *e);
        PF_CHECK(e, err, PF_ERR_NOMEM, "out of memory sorting a row of %d weights", (int)n);
        for (int32_t k = 0; k < n; ++k)
            e[k] = (entry){col[k], val[k]};
        qsort(e, (size_t)n, sizeof *e, compare_entries);
        for (int32_t k = 0; k < n; ++k)
            col[k] = e[k].col, val[k] = e[k].val;
        if (e != local)
            pf_free(e);
    }
    memcpy(w->col + b->nnz, col, (size_t)n * sizeof *col);
    memcpy(w->val + b->nnz, val, (size_t)n * sizeof *val);
    b->nnz += n;
    w->row_offsets[i + 1] = b->nnz;
    return PF_OK;
}

void pf_row_builder_finish(row_builder *b)
{
    if (b->nnz == b->cap || b->nnz == 0)
        return;
    uint32_t *c = pf_realloc_array(b->w->col, (size_t)b->nnz, sizeof *c);
    if (c)
        b->w->col = c;
    double *v = pf_realloc_array(b->w->val, (size_t)b->nnz, sizeof *v);
    if (v)
        b->w->val = v;
}

/* ---- entry point ------------------------------------------------------------------------------- */

pf_status pf_embed_check_inputs(const pf_mesh *m, const pf_surface *s, pf_error *err)
{
    PF_CHECK(m->n_nodes > 0 && m->n_elems > 0, err, PF_ERR_INVALID,
             "embedding needs a mesh with elements (got %d nodes, %d elements)", (int)m->n_nodes,
             (int)m->n_elems);
    for (int64_t k = 0; k < 3 * (int64_t)m->n_nodes; ++k)
        PF_CHECK(isfinite(m->x[k]), err, PF_ERR_INVALID, "mesh node %lld is not finite",
                 (long long)(k / 3));
    for (int64_t k = 0; k < 3 * (int64_t)s->n_verts; ++k)
        PF_CHECK(isfinite(s->x[k]), err, PF_ERR_INVALID, "surface vertex %lld is not finite",
                 (long long)(k / 3));
    return PF_OK;
}

pf_status pf_embed_compute(const pf_mesh *m, const pf_surface *s, const pf_embed_params *params,
                           pf_weights *w, pf_embed_stats *stats, pf_error *err)
{
    return pf_embed_compute_steps(m, s, params, w, NULL, stats, err);
}

pf_status pf_embed_compute_steps(const pf_mesh *m, const pf_surface *s,
                                 const pf_embed_params *params, pf_weights *w, int32_t *steps,
                                 pf_embed_stats *stats, pf_error *err)
{
    double t0 = pf_time_seconds();
    memset(w, 0, sizeof *w);
    pf_embed_params p;
    pf_embed_stats local;
    pf_embed_stats *st_out = stats ? stats : &local;
    memset(st_out, 0, sizeof *st_out);
    PF_TRY(pf_embed_resolve_params(params, &p, err));
    PF_TRY(pf_embed_check_inputs(m, s, err));
    locator L;
    PF_TRY(pf_locator_build(&L, m, err));
    row_builder b;
    int64_t hint = (int64_t)s->n_verts * (p.method == PF_EMBED_MLS ? 32 : 8);
    pf_status st = pf_row_builder_init(&b, w, s->n_verts, m->n_nodes, hint, err);
    if (st >= 0) {
        st_out->n_verts = s->n_verts;
        if (steps && p.method != PF_EMBED_MLS)
            memset(steps, 0, (size_t)s->n_verts * sizeof *steps);
        st = p.method == PF_EMBED_MLS ? pf_embed_mls(m, s, &p, &L, &b, steps, st_out, err)
                                      : pf_embed_bary(m, s, p.vertex_side, &L,
                                                   p.method == PF_EMBED_HARMONIC, &b, st_out, err);
    }
    pf_locator_release(&L);
    if (st < 0) {
        pf_weights_release(w);
        return st;
    }
    pf_row_builder_finish(&b);
    w->surface_id = s->id;
    w->mesh_id = m->id;
    st_out->nnz = b.nnz;
    st_out->mean_row = s->n_verts ? (double)b.nnz / s->n_verts : 0;
    st_out->seconds = pf_time_seconds() - t0;
    return PF_OK;
}
