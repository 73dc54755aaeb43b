/* Sparse Cholesky through CHOLMOD (SuiteSparse_long interface). The block matrix already is
 * CHOLMOD's upper-triangular, sorted, packed compressed-column form, so it is wrapped, never
 * copied. The analysis (fill-reducing ordering, supernodal structure) is done once per pattern;
 * a factorisation only recomputes the values; solves reuse CHOLMOD's workspace. Every
 * factorisation and solve runs with the threads threads.c chooses. */
#include <pf/solve.h>

#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include <cholmod.h>

#include "../base/lanes.h"
#include "solve_threads.h"

struct pf_cholesky {
    cholmod_common cc;
    cholmod_factor *factor;
    cholmod_dense *x, *y, *e; /* solve2 results and workspace, kept between solves */
    int64_t n, nnz;
    double flops; /* of one numeric factorisation, from the analysis */
    solve_threads_forced forced;
    bool factored;
    /* the factor's values in single precision, for pf_cholesky_precondition */
    float *single;
    double *work; /* [n + the largest supernode's rows] */
    int64_t max_rows;
    bool single_current; /* single holds the last factorisation */
    bool single_usable;  /* ... and every value fitted (else the double solve stands in) */
};

/* CHOLMOD's view of the matrix: the same arrays, no copy. */
static cholmod_sparse wrap_matrix(const pf_block_matrix *a)
{
    cholmod_sparse s;
    memset(&s, 0, sizeof s);
    s.nrow = s.ncol = (size_t)a->n;
    s.nzmax = (size_t)a->col_ptr[a->n];
    s.p = a->col_ptr;
    s.i = a->row_idx;
    s.x = a->val;
    s.stype = 1; /* symmetric, upper triangle stored */
    s.itype = CHOLMOD_LONG;
    s.xtype = CHOLMOD_REAL;
    s.dtype = CHOLMOD_DOUBLE;
    s.sorted = 1;
    s.packed = 1;
    return s;
}

pf_status pf_cholesky_create(pf_cholesky **c, const pf_block_matrix *a, pf_error *err)
{
    *c = NULL;
    pf_cholesky *ch = pf_calloc(1, sizeof *ch);
    PF_CHECK(ch, err, PF_ERR_NOMEM, "cannot allocate a solver");
    cholmod_l_start(&ch->cc);
    ch->cc.print = 0;                      /* errors come back as pf_error, never on stderr */
    ch->cc.quick_return_if_not_posdef = 1; /* the penalty search expects failures: fail fast */
    /* Supernodal LL' always: CHOLMOD's simplicial LDL' would accept an indefinite matrix (negative
     * pivots in D), and definiteness is what the penalty search and the step tests rely on. The
     * block structure makes supernodes wide, so it is also the fast choice. */
    ch->cc.supernodal = CHOLMOD_SUPERNODAL;
    ch->n = a->n;
    ch->nnz = a->col_ptr[a->n];
    cholmod_sparse s = wrap_matrix(a);
    ch->factor = cholmod_l_analyze(&s, &ch->cc);
    if (!ch->factor) {
        int status = ch->cc.status;
        pf_cholesky_destroy(&ch);
        return pf_error_set(err, status == CHOLMOD_OUT_OF_MEMORY ? PF_ERR_NOMEM : PF_ERR_NUMERIC,
                            __FILE__, __LINE__,
                            "sparse Cholesky analysis of %lld unknowns failed (CHOLMOD status %d)",
                            (long long)a->n, status);
    }
    ch->flops = ch->cc.fl;
    *c = ch;
    return PF_OK;
}

pf_status pf_cholesky_factor(pf_cholesky *c, const pf_block_matrix *a, int64_t *failed_column,
                             pf_error *err)
{
    PF_CHECK(a->n == c->n && a->col_ptr[a->n] == c->nnz, err, PF_ERR_INVALID,
             "matrix pattern changed since the analysis (%lld unknowns, was %lld)", (long long)a->n,
             (long long)c->n);
    cholmod_sparse s = wrap_matrix(a);
    c->factored = false;
    solve_threads_saved threads = pf_solve_threads_enter(&c->forced);
    int ok = cholmod_l_factorize(&s, c->factor, &c->cc);
    pf_solve_threads_leave(threads);
    if (!ok || c->cc.status == CHOLMOD_OUT_OF_MEMORY)
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory factorising %lld unknowns", (long long)a->n);
    if (c->cc.status == CHOLMOD_NOT_POSDEF || c->factor->minor < c->factor->n) {
        /* CHOLMOD's minor is a position in the permuted order; report the original unknown. */
        int64_t k = (int64_t)c->factor->minor;
        const int64_t *perm = c->factor->Perm;
        int64_t column = perm && k < c->n ? perm[k] : k;
        if (failed_column)
            *failed_column = column;
        return pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                            "matrix not positive definite (pivot of unknown %lld)",
                            (long long)column);
    }
    c->factored = true;
    c->single_current = false;
    return PF_OK;
}

pf_status pf_cholesky_solve(pf_cholesky *c, const double *b, double *x, pf_error *err)
{
    PF_CHECK(c->factored, err, PF_ERR_INVALID, "solve without a successful factorisation");
    cholmod_dense rhs;
    memset(&rhs, 0, sizeof rhs);
    rhs.nrow = rhs.d = rhs.nzmax = (size_t)c->n;
    rhs.ncol = 1;
    rhs.x = (void *)b; /* read only: CHOLMOD takes the right-hand side as non-const */
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    solve_threads_saved threads = pf_solve_threads_enter(&c->forced);
    int ok = cholmod_l_solve2(CHOLMOD_A, c->factor, &rhs, NULL, &c->x, NULL, &c->y, &c->e, &c->cc);
    pf_solve_threads_leave(threads);
    PF_CHECK(ok && c->x, err, PF_ERR_NOMEM, "out of memory solving %lld unknowns", (long long)c->n);
    memcpy(x, c->x->x, (size_t)c->n * sizeof *x);
    return PF_OK;
}

/* ---- the single-precision preconditioner ---------------------------------------------------
 * A solve reads the whole factor twice (forward and backward) and does two flops per value read:
 * CHOLMOD's runs near the memory's speed (13-18 GB/s of factor on the beams of bench_solver, one
 * thread). The values in single precision halve that traffic; this solve, which also converts
 * them, took 20-22% less CPU time than CHOLMOD's on the CG and DG beams of 1,911 hexes (minimum
 * of 30, 1.40 against 1.73 ms and 7.5 against 9.6 ms, load ~16). As PCG's preconditioner the
 * rounding is harmless: a factor of an earlier step differs from the current matrix by far more
 * (relative 1e-3 and up: PCG's 3-4 iterations to 1e-10) than single's 6e-8, and PCG's own
 * residual, in double, decides convergence. The solve runs supernode by supernode on CHOLMOD's
 * supernodal layout (supernode s: columns super[s] .. super[s + 1], rows s[pi[s] ..], values
 * column-major from px[s]), accumulating in double, on the calling thread in a fixed order. */

/* Copies the factor's values into single precision. False when one of them does not fit (the
 * double solve then stands in) or the factor is not the supernodal LL' this solve reads. */
static bool make_single(pf_cholesky *c)
{
    const cholmod_factor *l = c->factor;
    if (!l->is_super || !l->is_ll || l->xtype != CHOLMOD_REAL)
        return false;
    size_t size = l->xsize;
    if (!c->single) {
        const int64_t *pi = l->pi;
        c->max_rows = 0;
        for (size_t sn = 0; sn < l->nsuper; ++sn)
            if (pi[sn + 1] - pi[sn] > c->max_rows)
                c->max_rows = pi[sn + 1] - pi[sn];
        c->single = pf_alloc_array(size + 1, sizeof *c->single);
        c->work = pf_alloc_array((size_t)(c->n + c->max_rows) + 1, sizeof *c->work);
        if (!c->single || !c->work) {
            pf_free(c->single);
            pf_free(c->work);
            c->single = NULL;
            c->work = NULL;
            return false;
        }
    }
    const double *x = l->x;
    bool fits = true;
    for (size_t k = 0; k < size; ++k) {
        double v = x[k];
        fits &= fabs(v) <= FLT_MAX; /* values that underflow only lose digits */
        c->single[k] = (float)v;
    }
    const int64_t *super = l->super, *px = l->px, *pi = l->pi;
    for (size_t sn = 0; sn < l->nsuper && fits; ++sn) /* but a pivot must stay */
        for (int64_t col = 0; col < super[sn + 1] - super[sn]; ++col)
            fits &= c->single[px[sn] + col * (pi[sn + 1] - pi[sn]) + col] != 0;
    return fits;
}

/* Four lanes of floats beside lanes.h's doubles (the factor's values in single precision). */
typedef float lanes_f __attribute__((vector_size(16)));

static inline lanes_d load4(const float *p)
{
    lanes_f v;
    memcpy(&v, p, sizeof v);
    return __builtin_convertvector(v, lanes_d);
}

static inline lanes_d load4d(const double *p)
{
    lanes_d v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline double lane_sum(lanes_d v)
{
    return (v[0] + v[1]) + (v[2] + v[3]);
}

/* w[r] -= sum_j B[r, j] x[j] for r < m, B's columns j < k (k = 4 or 1) at stride ld. */
PF_KERNEL_CLONES
static void panel_update(const float *b, int64_t ld, int64_t m, int k, const double *x, double *w)
{
    int64_t r = 0, m4 = m & ~(int64_t)3;
    if (k == 4) {
        const float *b0 = b, *b1 = b0 + ld, *b2 = b1 + ld, *b3 = b2 + ld;
        double x0 = x[0], x1 = x[1], x2 = x[2], x3 = x[3];
        for (; r < m4; r += 4) {
            lanes_d v = load4d(w + r) - ((load4(b0 + r) * x0 + load4(b1 + r) * x1) +
                                         (load4(b2 + r) * x2 + load4(b3 + r) * x3));
            memcpy(w + r, &v, sizeof v);
        }
        for (; r < m; ++r)
            w[r] -= ((double)b0[r] * x0 + (double)b1[r] * x1) +
                    ((double)b2[r] * x2 + (double)b3[r] * x3);
        return;
    }
    double x0 = x[0];
    for (; r < m4; r += 4) {
        lanes_d v = load4d(w + r) - load4(b + r) * x0;
        memcpy(w + r, &v, sizeof v);
    }
    for (; r < m; ++r)
        w[r] -= (double)b[r] * x0;
}

/* s[j] = sum_r B[r, j] w[r] for r < m, B's columns j < k (k = 4 or 1) at stride ld. */
PF_KERNEL_CLONES
static void panel_dots(const float *b, int64_t ld, int64_t m, int k, const double *w, double *s)
{
    int64_t m4 = m & ~(int64_t)3;
    if (k == 4) {
        const float *b0 = b, *b1 = b0 + ld, *b2 = b1 + ld, *b3 = b2 + ld;
        lanes_d s0 = {0, 0, 0, 0}, s1 = s0, s2 = s0, s3 = s0;
        for (int64_t r = 0; r < m4; r += 4) {
            lanes_d wr = load4d(w + r);
            s0 += load4(b0 + r) * wr;
            s1 += load4(b1 + r) * wr;
            s2 += load4(b2 + r) * wr;
            s3 += load4(b3 + r) * wr;
        }
        double u0 = lane_sum(s0), u1 = lane_sum(s1), u2 = lane_sum(s2), u3 = lane_sum(s3);
        for (int64_t r = m4; r < m; ++r) {
            u0 += (double)b0[r] * w[r];
            u1 += (double)b1[r] * w[r];
            u2 += (double)b2[r] * w[r];
            u3 += (double)b3[r] * w[r];
        }
        s[0] = u0, s[1] = u1, s[2] = u2, s[3] = u3;
        return;
    }
    lanes_d s0 = {0, 0, 0, 0};
    for (int64_t r = 0; r < m4; r += 4)
        s0 += load4(b + r) * load4d(w + r);
    double u0 = lane_sum(s0);
    for (int64_t r = m4; r < m; ++r)
        u0 += (double)b[r] * w[r];
    s[0] = u0;
}

/* y = L^-1 y, supernode by supernode: in w [nrow] the supernode's columns of y, then the updates
 * of its rows below, four columns at a time (panels). */
static void forward_single(const cholmod_factor *l, const float *lx, double *y, double *w)
{
    const int64_t *super = l->super, *pi = l->pi, *px = l->px, *ls = l->s;
    for (size_t sn = 0; sn < l->nsuper; ++sn) {
        int64_t k1 = super[sn], ncol = super[sn + 1] - k1, nrow = pi[sn + 1] - pi[sn];
        const float *v = lx + px[sn];
        memcpy(w, y + k1, (size_t)ncol * sizeof *w);
        memset(w + ncol, 0, (size_t)(nrow - ncol) * sizeof *w);
        for (int64_t c = 0; c < ncol; c += 4) {
            int k = ncol - c >= 4 ? 4 : 1;
            for (int j = 0; j < k; ++j) { /* the panel's own triangle */
                const float *lc = v + (c + j) * nrow;
                double x = w[c + j] / (double)lc[c + j];
                w[c + j] = x;
                for (int q = j + 1; q < k; ++q)
                    w[c + q] -= (double)lc[c + q] * x;
            }
            panel_update(v + c * nrow + c + k, nrow, nrow - c - k, k, w + c, w + c + k);
            if (k == 1)
                c -= 3;
        }
        memcpy(y + k1, w, (size_t)ncol * sizeof *w);
        const int64_t *rows = ls + pi[sn];
        for (int64_t r = ncol; r < nrow; ++r)
            y[rows[r]] += w[r];
    }
}

/* y = L^-T y, supernode by supernode in reverse, panels from the last. */
static void backward_single(const cholmod_factor *l, const float *lx, double *y, double *w)
{
    const int64_t *super = l->super, *pi = l->pi, *px = l->px, *ls = l->s;
    for (size_t sn = l->nsuper; sn-- > 0;) {
        int64_t k1 = super[sn], ncol = super[sn + 1] - k1, nrow = pi[sn + 1] - pi[sn];
        const float *v = lx + px[sn];
        const int64_t *rows = ls + pi[sn];
        memcpy(w, y + k1, (size_t)ncol * sizeof *w);
        for (int64_t r = ncol; r < nrow; ++r)
            w[r] = y[rows[r]];
        int64_t tail = ncol % 4; /* single columns last in the forward order, first here */
        for (int64_t c = ncol - 1; c >= 0;) {
            int k = c >= ncol - tail ? 1 : 4;
            int64_t c0 = c - k + 1;
            double sums[4];
            panel_dots(v + c0 * nrow + c0 + k, nrow, nrow - c0 - k, k, w + c0 + k, sums);
            for (int j = k - 1; j >= 0; --j) {
                const float *lc = v + (c0 + j) * nrow;
                double x = w[c0 + j] - sums[j];
                for (int q = j + 1; q < k; ++q)
                    x -= (double)lc[c0 + q] * w[c0 + q];
                w[c0 + j] = x / (double)lc[c0 + j];
            }
            c = c0 - 1;
        }
        memcpy(y + k1, w, (size_t)ncol * sizeof *w);
    }
}

pf_status pf_cholesky_precondition(pf_cholesky *c, const double *b, double *x, pf_error *err)
{
    PF_CHECK(c->factored, err, PF_ERR_INVALID, "solve without a successful factorisation");
    if (!c->single_current) {
        c->single_usable = make_single(c);
        c->single_current = true;
    }
    if (!c->single_usable)
        return pf_cholesky_solve(c, b, x, err);
    const cholmod_factor *l = c->factor;
    const int64_t *perm = l->Perm;
    double *y = c->work, *w = c->work + c->n;
    for (int64_t k = 0; k < c->n; ++k)
        y[k] = b[perm ? perm[k] : k];
    forward_single(l, c->single, y, w);
    backward_single(l, c->single, y, w);
    for (int64_t k = 0; k < c->n; ++k)
        x[perm ? perm[k] : k] = y[k];
    return PF_OK;
}

int64_t pf_cholesky_factor_nnz(const pf_cholesky *c)
{
    if (!c->factor)
        return 0;
    if (c->factor->is_super) {
        /* Supernodal storage counts the dense supernode blocks, padding included. */
        return (int64_t)c->factor->xsize;
    }
    const int64_t *colcount = c->factor->ColCount;
    int64_t nnz = 0;
    for (int64_t k = 0; k < c->n; ++k)
        nnz += colcount[k];
    return nnz;
}

double pf_cholesky_factor_flops(const pf_cholesky *c)
{
    return c->flops;
}

void pf_cholesky_force_threads(pf_cholesky *c, bool openmp_serial, int blas)
{
    c->forced =
        (solve_threads_forced){.active = true, .openmp_serial = openmp_serial, .blas = blas};
}

void pf_cholesky_destroy(pf_cholesky **c)
{
    pf_cholesky *ch = *c;
    if (!ch)
        return;
    cholmod_l_free_factor(&ch->factor, &ch->cc);
    cholmod_l_free_dense(&ch->x, &ch->cc);
    cholmod_l_free_dense(&ch->y, &ch->cc);
    cholmod_l_free_dense(&ch->e, &ch->cc);
    cholmod_l_finish(&ch->cc);
    pf_free(ch->single);
    pf_free(ch->work);
    pf_free(ch);
    *c = NULL;
}
