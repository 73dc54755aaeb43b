/* Block-structured symmetric sparse matrices: the pattern is built once from the coupled block
 * pairs, and dense blocks are added at positions found once (the scatter map). In each column of
 * block column j the stored rows are the coupled blocks in ascending order with the diagonal block
 * last and trimmed to the upper triangle, so a block's rows start at the same offset (adj_row) in
 * every column of j and one dense column is one contiguous add. */
#include <pf/solve.h>

#include <stdlib.h>
#include <string.h>

static int compare_int32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

void pf_block_matrix_release(pf_block_matrix *a)
{
    pf_free(a->block_start);
    pf_free(a->adj_offsets);
    pf_free(a->adj);
    pf_free(a->adj_row);
    pf_free(a->col_ptr);
    pf_free(a->row_idx);
    pf_free(a->val);
    memset(a, 0, sizeof *a);
}

static pf_status set_block_sizes(pf_block_matrix *a, const int32_t *block_size, pf_error *err)
{
    a->block_start = pf_alloc_array((size_t)a->n_blocks + 1, sizeof *a->block_start);
    PF_CHECK(a->block_start, err, PF_ERR_NOMEM, "cannot allocate %d blocks", (int)a->n_blocks);
    a->block_start[0] = 0;
    for (int32_t b = 0; b < a->n_blocks; ++b) {
        PF_CHECK(block_size[b] > 0, err, PF_ERR_INVALID, "block %d has size %d (must be > 0)",
                 (int)b, (int)block_size[b]);
        a->block_start[b + 1] = a->block_start[b] + block_size[b];
        PF_CHECK(a->block_start[b + 1] <= INT32_MAX, err, PF_ERR_TOO_LARGE,
                 "more than 2^31 unknowns");
    }
    a->n = a->block_start[a->n_blocks];
    return PF_OK;
}

/* Sorted, duplicate-free adjacency of every block column: the coupled blocks <= j, j last. */
static pf_status build_adjacency(pf_block_matrix *a, int64_t n_pairs, const int32_t *pairs,
                                 pf_error *err)
{
    int32_t nb = a->n_blocks;
    for (int64_t k = 0; k < 2 * n_pairs; ++k)
        PF_CHECK(pairs[k] >= 0 && pairs[k] < nb, err, PF_ERR_INVALID,
                 "pair %lld refers to block %d of %d", (long long)(k / 2), (int)pairs[k], (int)nb);
    a->adj_offsets = pf_alloc_array((size_t)nb + 1, sizeof *a->adj_offsets);
    int64_t *fill = pf_alloc_array((size_t)nb + 1, sizeof *fill);
    a->adj = pf_alloc_array((size_t)(n_pairs + nb), sizeof *a->adj);
    if (!a->adj_offsets || !fill || !a->adj) {
        pf_free(fill);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the coupling of %d blocks", (int)nb);
    }
    memset(a->adj_offsets, 0, ((size_t)nb + 1) * sizeof *a->adj_offsets);
    for (int32_t j = 0; j < nb; ++j)
        a->adj_offsets[j + 1] = 1;
    for (int64_t k = 0; k < n_pairs; ++k) {
        int32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        if (i != j)
            a->adj_offsets[(i > j ? i : j) + 1]++;
    }
    for (int32_t j = 0; j < nb; ++j)
        a->adj_offsets[j + 1] += a->adj_offsets[j];
    memcpy(fill, a->adj_offsets, ((size_t)nb + 1) * sizeof *fill);
    for (int32_t j = 0; j < nb; ++j)
        a->adj[fill[j]++] = j;
    for (int64_t k = 0; k < n_pairs; ++k) {
        int32_t i = pairs[2 * k], j = pairs[2 * k + 1];
        if (i != j)
            a->adj[fill[i > j ? i : j]++] = i < j ? i : j;
    }
    pf_free(fill);
    /* Sort and compact in place: every list shrinks to its distinct blocks. */
    int64_t out = 0;
    for (int32_t j = 0; j < nb; ++j) {
        int64_t begin = a->adj_offsets[j], end = a->adj_offsets[j + 1];
        qsort(a->adj + begin, (size_t)(end - begin), sizeof *a->adj, compare_int32);
        a->adj_offsets[j] = out;
        for (int64_t k = begin; k < end; ++k)
            if (k == begin || a->adj[k] != a->adj[k - 1])
                a->adj[out++] = a->adj[k];
    }
    a->adj_offsets[nb] = out;
    return PF_OK;
}

static int64_t block_size_of(const pf_block_matrix *a, int32_t b)
{
    return a->block_start[b + 1] - a->block_start[b];
}

/* Row offsets of the blocks within a column, column pointers and row indices. */
static pf_status build_columns(pf_block_matrix *a, pf_error *err)
{
    int64_t n_adj = a->adj_offsets[a->n_blocks];
    a->adj_row = pf_alloc_array((size_t)n_adj, sizeof *a->adj_row);
    a->col_ptr = pf_alloc_array((size_t)a->n + 1, sizeof *a->col_ptr);
    PF_CHECK(a->adj_row && a->col_ptr, err, PF_ERR_NOMEM, "cannot allocate %lld columns",
             (long long)a->n);
    a->col_ptr[0] = 0;
    for (int32_t j = 0; j < a->n_blocks; ++j) {
        int64_t above = 0; /* rows of the off-diagonal blocks in each column of j */
        for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1]; ++k) {
            a->adj_row[k] = above;
            if (a->adj[k] != j)
                above += block_size_of(a, a->adj[k]);
        }
        for (int64_t c = a->block_start[j]; c < a->block_start[j + 1]; ++c)
            a->col_ptr[c + 1] = a->col_ptr[c] + above + (c - a->block_start[j] + 1);
        PF_CHECK(a->col_ptr[a->block_start[j + 1]] <= ((int64_t)1 << 40), err, PF_ERR_TOO_LARGE,
                 "more than 2^40 matrix entries");
    }
    int64_t nnz = a->col_ptr[a->n];
    a->row_idx = pf_alloc_array((size_t)nnz, sizeof *a->row_idx);
    a->val = pf_calloc((size_t)nnz, sizeof *a->val);
    PF_CHECK(a->row_idx && a->val, err, PF_ERR_NOMEM, "cannot allocate %lld matrix entries",
             (long long)nnz);
    for (int32_t j = 0; j < a->n_blocks; ++j)
        for (int64_t c = a->block_start[j]; c < a->block_start[j + 1]; ++c) {
            int64_t p = a->col_ptr[c];
            for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1]; ++k) {
                int32_t i = a->adj[k];
                int64_t last = i == j ? c : a->block_start[i + 1] - 1;
                for (int64_t r = a->block_start[i]; r <= last; ++r)
                    a->row_idx[p++] = r;
            }
        }
    return PF_OK;
}

pf_status pf_block_matrix_create(pf_block_matrix *a, int32_t n_blocks, const int32_t *block_size,
                                 int64_t n_pairs, const int32_t *pairs, pf_error *err)
{
    memset(a, 0, sizeof *a);
    PF_CHECK(n_blocks >= 0 && n_pairs >= 0, err, PF_ERR_INVALID,
             "negative block (%d) or pair (%lld) count", (int)n_blocks, (long long)n_pairs);
    a->n_blocks = n_blocks;
    pf_status s = set_block_sizes(a, block_size, err);
    if (s >= 0)
        s = build_adjacency(a, n_pairs, pairs, err);
    if (s >= 0)
        s = build_columns(a, err);
    if (s < 0)
        pf_block_matrix_release(a);
    return s;
}

int64_t pf_block_matrix_slot(const pf_block_matrix *a, int32_t i, int32_t j)
{
    if (i < 0 || j < 0 || i >= a->n_blocks || j >= a->n_blocks)
        return -1;
    int32_t lo = i < j ? i : j, hi = i < j ? j : i;
    int64_t begin = a->adj_offsets[hi], end = a->adj_offsets[hi + 1];
    while (begin < end) {
        int64_t mid = begin + (end - begin) / 2;
        if (a->adj[mid] < lo)
            begin = mid + 1;
        else
            end = mid;
    }
    return begin < a->adj_offsets[hi + 1] && a->adj[begin] == lo ? begin : -1;
}

void pf_block_matrix_zero(pf_block_matrix *a)
{
    if (a->val)
        memset(a->val, 0, (size_t)a->col_ptr[a->n] * sizeof *a->val);
}

void pf_block_matrix_add(pf_block_matrix *a, int64_t slot, int32_t i, int32_t j, const double *b,
                         int64_t ld)
{
    int64_t rows = block_size_of(a, i), cols = block_size_of(a, j);
    if (i < j) { /* b's rows are the stored rows, its columns the stored columns */
        for (int64_t c = 0; c < cols; ++c) {
            double *v = a->val + a->col_ptr[a->block_start[j] + c] + a->adj_row[slot];
            for (int64_t r = 0; r < rows; ++r)
                v[r] += b[r * ld + c];
        }
    } else if (i > j) { /* the stored block is (j, i) = b^T */
        for (int64_t r = 0; r < rows; ++r) {
            double *v = a->val + a->col_ptr[a->block_start[i] + r] + a->adj_row[slot];
            for (int64_t c = 0; c < cols; ++c)
                v[c] += b[r * ld + c];
        }
    } else {
        for (int64_t c = 0; c < cols; ++c) {
            double *v = a->val + a->col_ptr[a->block_start[j] + c] + a->adj_row[slot];
            for (int64_t r = 0; r <= c; ++r)
                v[r] += b[r * ld + c];
        }
    }
}

void pf_block_matrix_add_3x3(pf_block_matrix *a, int64_t slot, int32_t bi, int64_t ri, int64_t cj,
                             const double m[9])
{
    int64_t row0 = a->adj_row[slot] + (ri - a->block_start[bi]);
    for (int c = 0; c < 3; ++c) {
        double *v = a->val + a->col_ptr[cj + c] + row0;
        for (int r = 0; r < 3; ++r)
            if (ri != cj || r <= c)
                v[r] += m[3 * r + c];
    }
}

void pf_block_matrix_add_diagonal(pf_block_matrix *a, const double *d)
{
    if (!d)
        return;
    for (int64_t c = 0; c < a->n; ++c)
        a->val[a->col_ptr[c + 1] - 1] += d[c]; /* the diagonal closes each column */
}

/* The off-diagonal blocks of three columns c .. c + 2 of block column j: every stored row r
 * of a block above gets y[r] += a_rc alpha x_c for the three columns in turn, and each column's
 * sum yc[t] += a_rc x_r, in the same order as one column at a time (the bits do not change). */
static void mul_columns3(const pf_block_matrix *a, int32_t j, int64_t c, const double xc[3],
                         const double *x, double *y, double yc[3])
{
    const double *v0 = a->val + a->col_ptr[c], *v1 = a->val + a->col_ptr[c + 1],
                 *v2 = a->val + a->col_ptr[c + 2];
    double s0 = 0, s1 = 0, s2 = 0;
    for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1] - 1; ++k) {
        int64_t r0 = a->block_start[a->adj[k]], rows = a->block_start[a->adj[k] + 1] - r0;
        const double *w0 = v0 + a->adj_row[k], *w1 = v1 + a->adj_row[k], *w2 = v2 + a->adj_row[k];
        const double *xr = x + r0;
        double *yr = y + r0;
        for (int64_t t = 0; t < rows; ++t) {
            double yt = yr[t];
            yt += w0[t] * xc[0];
            yt += w1[t] * xc[1];
            yt += w2[t] * xc[2];
            yr[t] = yt;
            s0 += w0[t] * xr[t];
            s1 += w1[t] * xr[t];
            s2 += w2[t] * xr[t];
        }
    }
    yc[0] = s0, yc[1] = s1, yc[2] = s2;
}

/* The same for one column. */
static double mul_column(const pf_block_matrix *a, int32_t j, int64_t c, double xc, const double *x,
                         double *y)
{
    const double *v = a->val + a->col_ptr[c];
    double s = 0;
    for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1] - 1; ++k) {
        int64_t r0 = a->block_start[a->adj[k]], rows = a->block_start[a->adj[k] + 1] - r0;
        const double *w = v + a->adj_row[k];
        for (int64_t t = 0; t < rows; ++t) {
            y[r0 + t] += w[t] * xc;
            s += w[t] * x[r0 + t];
        }
    }
    return s;
}

/* Column c's part of the diagonal block (rows c0 .. c, the diagonal last), then its sum. */
static void mul_diagonal(const pf_block_matrix *a, int64_t c0, int64_t c, double alpha, double xc,
                         double yc, const double *x, double *y)
{
    const double *w = a->val + a->col_ptr[c + 1] - (c - c0 + 1);
    for (int64_t r = c0; r < c; ++r) {
        y[r] += w[r - c0] * xc;
        yc += w[r - c0] * x[r];
    }
    y[c] += w[c - c0] * xc;
    y[c] += alpha * yc;
}

void pf_block_matrix_mul(const pf_block_matrix *a, double alpha, const double *x, double beta,
                         double *y)
{
    for (int64_t r = 0; r < a->n; ++r)
        y[r] = beta == 0 ? 0 : beta * y[r];
    /* By block columns: the rows of a block above are contiguous, so no row index is read;
     * every y[r] receives its terms in ascending column order as a column-by-column product
     * does (bit-identical to it). */
    for (int32_t j = 0; j < a->n_blocks; ++j) {
        int64_t c0 = a->block_start[j], end = a->block_start[j + 1], c = c0;
        for (; c + 3 <= end; c += 3) {
            double xc[3] = {alpha * x[c], alpha * x[c + 1], alpha * x[c + 2]}, yc[3];
            mul_columns3(a, j, c, xc, x, y, yc);
            for (int t = 0; t < 3; ++t)
                mul_diagonal(a, c0, c + t, alpha, xc[t], yc[t], x, y);
        }
        for (; c < end; ++c) {
            double xc = alpha * x[c];
            mul_diagonal(a, c0, c, alpha, xc, mul_column(a, j, c, xc, x, y), x, y);
        }
    }
}

double pf_block_matrix_get(const pf_block_matrix *a, int64_t r, int64_t c)
{
    if (r < 0 || c < 0 || r >= a->n || c >= a->n)
        return 0;
    int64_t lo = r < c ? r : c, hi = r < c ? c : r;
    int64_t begin = a->col_ptr[hi], end = a->col_ptr[hi + 1];
    while (begin < end) {
        int64_t mid = begin + (end - begin) / 2;
        if (a->row_idx[mid] < lo)
            begin = mid + 1;
        else
            end = mid;
    }
    return begin < a->col_ptr[hi + 1] && a->row_idx[begin] == lo ? a->val[begin] : 0;
}
