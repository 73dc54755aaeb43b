/* The summary of a basis's per-element statistics (pf_basis_summarize): medians and maxima for
 * reports. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <pf/basis.h>

pf_status pf_basis_summarize(const pf_basis *b, pf_basis_summary *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    out->n_elems = b->n_elems;
    out->min_value = INFINITY;
    double *be = NULL, *ms = NULL;
    if (!PF_ALLOC_N(be, b->n_elems) || !PF_ALLOC_N(ms, b->n_elems)) {
        pf_free(be);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "basis summary: no memory");
    }
    int32_t nh = 0;
    for (int32_t e = 0; e < b->n_elems; ++e) {
        const pf_basis_elem_stats *st = &b->stats[e];
        out->n_by_kind[b->kind[e]]++;
        out->max_linear_error = fmax(out->max_linear_error, st->linear_error);
        out->max_unity_error = fmax(out->max_unity_error, st->unity_error);
        out->min_value = fmin(out->min_value, st->min_value);
        out->n_kernels += st->n_kernels;
        out->n_collocation += st->n_collocation;
        if (b->kind[e] == PF_BASIS_HARMONIC) {
            out->max_boundary_error = fmax(out->max_boundary_error, st->boundary_error);
            out->max_setup_ms = fmax(out->max_setup_ms, st->setup_ms);
            be[nh] = st->boundary_error;
            ms[nh] = st->setup_ms;
            ++nh;
        }
    }
    if (b->n_elems == 0)
        out->min_value = 0;
    out->median_boundary_error = pf_median(be, nh);
    out->median_setup_ms = pf_median(ms, nh);
    pf_free(be);
    pf_free(ms);
    return PF_OK;
}
