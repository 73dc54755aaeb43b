/* Embedding weights: the sparse map from simulation-node displacements to surface vertices. */
#include <pf/mesh.h>

#include <string.h>

pf_status pf_weights_alloc(pf_weights *w, int32_t rows, int32_t cols, int64_t nnz, pf_error *err)
{
    memset(w, 0, sizeof *w);
    PF_CHECK(rows >= 0 && cols >= 0 && nnz >= 0, err, PF_ERR_INVALID,
             "weight matrix counts must be non-negative");
    w->row_offsets = pf_alloc_array((size_t)rows + 1, sizeof *w->row_offsets);
    w->col = pf_alloc_array((size_t)nnz, sizeof *w->col);
    w->val = pf_alloc_array((size_t)nnz, sizeof *w->val);
    if (!w->row_offsets || (nnz && (!w->col || !w->val))) {
        pf_weights_release(w);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate a %d x %d weight matrix with %lld entries", (int)rows,
                            (int)cols, (long long)nnz);
    }
    w->rows = rows;
    w->cols = cols;
    w->row_offsets[0] = 0;
    return PF_OK;
}

void pf_weights_release(pf_weights *w)
{
    pf_free(w->row_offsets);
    pf_free(w->col);
    pf_free(w->val);
    memset(w, 0, sizeof *w);
}

void pf_weights_apply(const pf_weights *w, const double *x0, const double *u, double *out)
{
    for (int32_t i = 0; i < w->rows; ++i) {
        double s[3] = {x0[3 * (size_t)i], x0[3 * (size_t)i + 1], x0[3 * (size_t)i + 2]};
        for (int64_t k = w->row_offsets[i]; k < w->row_offsets[i + 1]; ++k)
            for (int c = 0; c < 3; ++c)
                s[c] += w->val[k] * u[3 * (size_t)w->col[k] + (size_t)c];
        for (int c = 0; c < 3; ++c)
            out[3 * (size_t)i + (size_t)c] = s[c];
    }
}

void pf_weights_apply_scalar(const pf_weights *w, const double *v, double *out)
{
    for (int32_t i = 0; i < w->rows; ++i) {
        double s = 0;
        for (int64_t k = w->row_offsets[i]; k < w->row_offsets[i + 1]; ++k)
            s += w->val[k] * v[w->col[k]];
        out[i] = s;
    }
}
