/* solve: block-matrix assembly against a dense reference, CHOLMOD solves, and the solver's
 * warp preconditioner on an exactly rotated matrix.
 *
 * Assembly only adds numbers at positions, so stored entries must equal the dense reference
 * exactly (the same additions in the same order). Solves are checked by the residual
 * |A x - b| / (|A| |x|): a backward-stable Cholesky gives a few n u, so 1e-13 for these
 * well-conditioned systems (condition number below 100) leaves a margin of 10 over what
 * n = 200 unknowns need. The thread count must not change a bit of a solution: a matrix large
 * enough for CHOLMOD's OpenMP loops to split work is solved with the library's threads, with one
 * thread and with CHOLMOD's own team, and the solutions compared byte for byte. */
#define _POSIX_C_SOURCE 200809L /* unsetenv, opendir */
#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "solve/solve_threads.h"
#include "test_random.h"
#include <pf/solve.h>

static int32_t below(rng *r, int32_t n)
{
    int32_t k = (int32_t)((uniform(r) + 1) * 0.5 * n);
    return k < n ? k : n - 1;
}

/* A random block structure with a dense copy of everything added. */
typedef struct fixture {
    int32_t n_blocks;
    int32_t size[12];
    int32_t start[13];
    int32_t pairs[2 * 20];
    int64_t n_pairs;
    pf_block_matrix a;
    double *dense; /* [n * n] full symmetric */
    size_t live;
} fixture;

static void make_pattern(fixture *f, rng *r)
{
    f->n_blocks = 12;
    f->start[0] = 0;
    for (int32_t b = 0; b < f->n_blocks; ++b) {
        f->size[b] = 1 + below(r, 10);
        f->start[b + 1] = f->start[b] + f->size[b];
    }
    f->n_pairs = 20;
    for (int64_t k = 0; k < 2 * f->n_pairs; ++k)
        f->pairs[k] = below(r, f->n_blocks);
    pf_error err = {0};
    assert_int_equal(
        pf_block_matrix_create(&f->a, f->n_blocks, f->size, f->n_pairs, f->pairs, &err), PF_OK);
    int64_t n = f->a.n;
    f->dense = calloc((size_t)(n * n), sizeof *f->dense);
    assert_non_null(f->dense);
}

/* Adds a random block at (i, j) to both the block matrix and the dense copy. */
static void add_random_block(fixture *f, rng *r, int32_t i, int32_t j, double diag_boost)
{
    int32_t m = f->size[i], k = f->size[j];
    double b[100];
    for (int32_t p = 0; p < m; ++p)
        for (int32_t q = 0; q < k; ++q)
            b[p * 10 + q] = uniform(r);
    if (i == j) /* symmetric, diagonally dominant */
        for (int32_t p = 0; p < m; ++p) {
            for (int32_t q = 0; q < p; ++q)
                b[p * 10 + q] = b[q * 10 + p];
            b[p * 10 + p] += diag_boost;
        }
    int64_t slot = pf_block_matrix_slot(&f->a, i, j);
    assert_true(slot >= 0);
    pf_block_matrix_add(&f->a, slot, i, j, b, 10);
    int64_t n = f->a.n;
    for (int32_t p = 0; p < m; ++p)
        for (int32_t q = 0; q < k; ++q) {
            int64_t row = f->start[i] + p, col = f->start[j] + q;
            f->dense[row * n + col] += b[p * 10 + q];
            if (i != j)
                f->dense[col * n + row] += b[p * 10 + q];
        }
}

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    f->live = pf_alloc_live_bytes();
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    pf_block_matrix_release(&f->a);
    free(f->dense);
    assert_int_equal(pf_alloc_live_bytes(), f->live);
    free(f);
    return 0;
}

/* Every coupled pair, in both orders, repeatedly; then every entry equals the dense reference. */
static void fill_random(fixture *f, rng *r)
{
    for (int round = 0; round < 3; ++round) {
        for (int64_t k = 0; k < f->n_pairs; ++k) {
            int32_t i = f->pairs[2 * k], j = f->pairs[2 * k + 1];
            if (i != j)
                add_random_block(f, r, round % 2 ? j : i, round % 2 ? i : j, 0);
        }
        /* A row meets at most 20 pairs x 10 entries + 9 in its diagonal block per round, each
         * below 1 in magnitude: a boost of 250 per round keeps the matrix strictly diagonally
         * dominant, so positive definite. */
        for (int32_t b = 0; b < f->n_blocks; ++b)
            add_random_block(f, r, b, b, 250);
    }
}

static void assembly_matches_dense(void **state)
{
    fixture *f = *state;
    rng r = {0x9e3779b97f4a7c15u};
    make_pattern(f, &r);
    fill_random(f, &r);
    int64_t n = f->a.n;
    assert_int_equal(n, f->start[f->n_blocks]);
    for (int64_t row = 0; row < n; ++row)
        for (int64_t col = 0; col < n; ++col)
            assert_true(pf_block_matrix_get(&f->a, row, col) == f->dense[row * n + col]);
    /* Stored entries are the upper triangle, sorted, diagonal last in each column. */
    for (int64_t c = 0; c < n; ++c) {
        assert_int_equal(f->a.row_idx[f->a.col_ptr[c + 1] - 1], c);
        for (int64_t p = f->a.col_ptr[c] + 1; p < f->a.col_ptr[c + 1]; ++p)
            assert_true(f->a.row_idx[p - 1] < f->a.row_idx[p]);
    }
}

static void uncoupled_pairs_have_no_slot(void **state)
{
    fixture *f = *state;
    rng r = {12345};
    make_pattern(f, &r);
    for (int32_t i = 0; i < f->n_blocks; ++i)
        for (int32_t j = 0; j < f->n_blocks; ++j) {
            bool coupled = i == j;
            for (int64_t k = 0; k < f->n_pairs; ++k)
                coupled |= (f->pairs[2 * k] == i && f->pairs[2 * k + 1] == j) ||
                           (f->pairs[2 * k] == j && f->pairs[2 * k + 1] == i);
            assert_int_equal(pf_block_matrix_slot(&f->a, i, j) >= 0, coupled);
        }
    assert_int_equal(pf_block_matrix_slot(&f->a, -1, 0), -1);
    assert_int_equal(pf_block_matrix_slot(&f->a, 0, f->n_blocks), -1);
}

static void product_matches_dense(void **state)
{
    fixture *f = *state;
    rng r = {777};
    make_pattern(f, &r);
    fill_random(f, &r);
    int64_t n = f->a.n;
    double x[120], y[120], ref[120];
    for (int64_t k = 0; k < n; ++k)
        x[k] = uniform(&r), y[k] = uniform(&r);
    for (int64_t row = 0; row < n; ++row) {
        ref[row] = 0.5 * y[row];
        for (int64_t col = 0; col < n; ++col)
            ref[row] += 2 * f->dense[row * n + col] * x[col];
    }
    pf_block_matrix_mul(&f->a, 2, x, 0.5, y);
    /* Different summation orders: entries are below 1e3, sums of 120 terms, so 1e-10 absolute
     * is 1e-13 relative to the largest product. */
    for (int64_t k = 0; k < n; ++k)
        assert_true(fabs(y[k] - ref[k]) <= 1e-10);
}

/* The product one stored column at a time, through the row indices: the summation order the
 * block product must keep bit for bit. */
static void column_product(const pf_block_matrix *a, double alpha, const double *x, double beta,
                           double *y)
{
    for (int64_t r = 0; r < a->n; ++r)
        y[r] = beta == 0 ? 0 : beta * y[r];
    for (int64_t c = 0; c < a->n; ++c) {
        double xc = alpha * x[c], yc = 0;
        for (int64_t p = a->col_ptr[c]; p < a->col_ptr[c + 1]; ++p) {
            int64_t r = a->row_idx[p];
            y[r] += a->val[p] * xc;
            if (r != c)
                yc += a->val[p] * x[r];
        }
        y[c] += alpha * yc;
    }
}

/* Random block sizes 1 .. 10 (remainders of the three-column groups), then blocks of 3 (CG's
 * nodes): the block product equals the column product byte for byte. */
static void product_is_bit_identical(void **state)
{
    fixture *f = *state;
    rng r = {4242};
    for (int pass = 0; pass < 2; ++pass) {
        make_pattern(f, &r);
        if (pass == 1) { /* the same pairs on blocks of 3 */
            pf_block_matrix_release(&f->a);
            for (int32_t b = 0; b < f->n_blocks; ++b)
                f->size[b] = 3, f->start[b + 1] = f->start[b] + 3;
            pf_error err = {0};
            assert_int_equal(
                pf_block_matrix_create(&f->a, f->n_blocks, f->size, f->n_pairs, f->pairs, &err),
                PF_OK);
            free(f->dense);
            f->dense = calloc((size_t)(f->a.n * f->a.n), sizeof *f->dense);
            assert_non_null(f->dense);
        }
        fill_random(f, &r);
        double x[120], y[120], ref[120];
        for (int64_t k = 0; k < f->a.n; ++k)
            x[k] = uniform(&r), y[k] = ref[k] = uniform(&r);
        pf_block_matrix_mul(&f->a, 1.7, x, 0.3, y);
        column_product(&f->a, 1.7, x, 0.3, ref);
        assert_memory_equal(y, ref, (size_t)f->a.n * sizeof *y);
        pf_block_matrix_mul(&f->a, 1, x, 0, y);
        column_product(&f->a, 1, x, 0, ref);
        assert_memory_equal(y, ref, (size_t)f->a.n * sizeof *y);
        pf_block_matrix_release(&f->a);
        free(f->dense);
        f->dense = NULL;
    }
}

static double residual(const fixture *f, const double *x, const double *b)
{
    int64_t n = f->a.n;
    double r2 = 0, a2 = 0, x2 = 0;
    for (int64_t row = 0; row < n; ++row) {
        double s = -b[row];
        for (int64_t col = 0; col < n; ++col) {
            s += f->dense[row * n + col] * x[col];
            a2 += f->dense[row * n + col] * f->dense[row * n + col];
        }
        r2 += s * s;
        x2 += x[row] * x[row];
    }
    return sqrt(r2) / (sqrt(a2) * sqrt(x2));
}

static void cholesky_solves_and_refactors(void **state)
{
    fixture *f = *state;
    rng r = {4242};
    make_pattern(f, &r);
    fill_random(f, &r);
    int64_t n = f->a.n;
    pf_error err = {0};
    pf_cholesky *c = NULL;
    assert_int_equal(pf_cholesky_create(&c, &f->a, &err), PF_OK);
    double b[120], x[120];
    for (int64_t k = 0; k < n; ++k)
        b[k] = uniform(&r);
    assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_ERR_INVALID);
    assert_int_equal(pf_cholesky_factor(c, &f->a, NULL, &err), PF_OK);
    assert_true(pf_cholesky_factor_nnz(c) >= f->a.col_ptr[n] / 2);
    assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_OK);
    assert_true(residual(f, x, b) < 1e-13);

    /* New values on the same pattern: refactor without a new analysis, solve in place. */
    fill_random(f, &r);
    assert_int_equal(pf_cholesky_factor(c, &f->a, NULL, &err), PF_OK);
    memcpy(x, b, sizeof b);
    assert_int_equal(pf_cholesky_solve(c, x, x, &err), PF_OK);
    assert_true(residual(f, x, b) < 1e-13);
    pf_cholesky_destroy(&c);
    assert_null(c);
}

/* The 3 x 3 node blocks of a g x g x g grid, each node coupled with its 26 neighbours: symmetric,
 * strictly diagonally dominant (so definite), values in (-1, 1) off the diagonal times scale. */
static void grid_matrix(pf_block_matrix *a, int g, double scale, rng *r)
{
    int32_t nb = g * g * g, *size = malloc((size_t)nb * sizeof *size);
    int32_t *pairs = malloc((size_t)nb * 26 * 2 * sizeof *pairs);
    int64_t np = 0;
    for (int32_t b = 0; b < nb; ++b) {
        size[b] = 3;
        int x = b % g, y = (b / g) % g, z = b / (g * g);
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    int u = x + dx, v = y + dy, w = z + dz;
                    int32_t o = (w * g + v) * g + u;
                    if (u < 0 || v < 0 || w < 0 || u >= g || v >= g || w >= g || o <= b)
                        continue;
                    pairs[2 * np] = b, pairs[2 * np + 1] = o, ++np;
                }
    }
    pf_error err = {0};
    assert_int_equal(pf_block_matrix_create(a, nb, size, np, pairs, &err), PF_OK);
    double *row_sum = calloc((size_t)a->n, sizeof *row_sum);
    for (int64_t k = 0; k < np; ++k) {
        double m[9];
        for (int q = 0; q < 9; ++q) {
            m[q] = scale * (2 * uniform(r) - 1);
            row_sum[3 * pairs[2 * k] + q / 3] += fabs(m[q]);
            row_sum[3 * pairs[2 * k + 1] + q % 3] += fabs(m[q]);
        }
        pf_block_matrix_add(a, pf_block_matrix_slot(a, pairs[2 * k], pairs[2 * k + 1]),
                            pairs[2 * k], pairs[2 * k + 1], m, 3);
    }
    for (int64_t k = 0; k < a->n; ++k)
        row_sum[k] += scale * (1 + uniform(r));
    pf_block_matrix_add_diagonal(a, row_sum);
    free(row_sum);
    free(size);
    free(pairs);
}

/* a's values: base plus a stiff contact-like term k n n^T (n = (1, 2, 2) / 3, k = 1e4 times the
 * diagonal's scale) on the diagonal block of each of the triples first, first + step, ... (count
 * of them). */
static void with_terms(pf_block_matrix *a, const double *base, int32_t first, int32_t step,
                       int32_t count)
{
    memcpy(a->val, base, (size_t)a->col_ptr[a->n] * sizeof *base);
    const double n[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3};
    double m[9];
    for (int i = 0; i < 9; ++i)
        m[i] = 1e4 * n[i / 3] * n[i % 3];
    for (int32_t c = 0; c < count; ++c) {
        int32_t t = (first + c * step) % a->n_blocks;
        pf_block_matrix_add(a, pf_block_matrix_slot(a, t, t), t, t, m, 3);
    }
}

/* One PF_MATRIX_TERMS solve of a x = rhs to the solver's tolerance: returns the factorisations it
 * made and sets *iterated to the PCG iterations it spent. */
static int64_t terms_solve(pf_solver *s, const pf_block_matrix *a, const double *rhs, double *x,
                           int64_t *iterated)
{
    pf_error err = {0};
    const pf_solver_stats *st = pf_solver_get_stats(s);
    int64_t f0 = st->factorisations, i0 = st->iterations, n = a->n;
    assert_int_equal(pf_solver_solve(s, a, PF_MATRIX_TERMS, rhs, x, NULL, &err), PF_OK);
    double *ax = malloc((size_t)n * sizeof *ax), rn = 0, bn = 0;
    pf_block_matrix_mul(a, 1, x, 0, ax);
    for (int64_t k = 0; k < n; ++k)
        rn += (ax[k] - rhs[k]) * (ax[k] - rhs[k]), bn += rhs[k] * rhs[k];
    free(ax);
    assert_true(sqrt(rn) <= 1e-10 * sqrt(bn) * 1.0001); /* the solver's tolerance */
    *iterated = st->iterations - i0;
    return st->factorisations - f0;
}

/* PF_MATRIX_TERMS (contacts that came or went): one stiff rank-one term more than the factor's
 * matrix is absorbed by PCG on the old factor (its triple's diagonal block is exact in the
 * congruence of solver.c, which scales the triple's couplings, so the preconditioner differs
 * from the matrix in one block row and column only: rank 6 at most, 7 iterations in exact
 * arithmetic; 6 measured, where the plain old factor, off by the rank-one term, took 2); 60 of
 * them are more than the trial's two factorisations' worth, so the trial fails and
 * refactorises, counted as new terms, not as a PCG failure. Then the back-off: the next change
 * refactorises at once (no iteration), the one after is tried again, fails, and the next two
 * refactorise at once; a trial that converges ends the back-off, and so does a reset. The sets
 * of 60 are residue classes mod 7 (first + 7 c), so two with another first share no term. */
static void terms_tried_on_old_factor_with_back_off(void **state)
{
    (void)state;
    rng r = {8080};
    pf_block_matrix a;
    grid_matrix(&a, 8, 1.0, &r);
    int64_t n = a.n, nnz = a.col_ptr[a.n];
    double *base = malloc((size_t)nnz * sizeof *base);
    memcpy(base, a.val, (size_t)nnz * sizeof *base);
    double *rhs = malloc((size_t)n * sizeof *rhs), *x = calloc((size_t)n, sizeof *x);
    for (int64_t k = 0; k < n; ++k)
        rhs[k] = cos(0.29 * (double)k);
    pf_error err = {0};
    pf_solver_params p = pf_solver_params_default();
    p.method = PF_SOLVER_PCG;
    pf_solver *s = NULL;
    assert_int_equal(pf_solver_create(&s, &a, &p, true, &err), PF_OK);
    const pf_solver_stats *st = pf_solver_get_stats(s);
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_NEW, rhs, x, NULL, &err), PF_OK);
    int64_t its;

    with_terms(&a, base, 7, 1, 1); /* one contact came */
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 0);
    assert_true(its >= 1 && its <= 7);
    with_terms(&a, base, 3, 7, 60); /* sixty: the trial fails */
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
    assert_true(its > 4);
    assert_int_equal(st->by_reason[PF_REFACTOR_FAILED], 0);
    assert_int_equal(st->by_reason[PF_REFACTOR_NEW], 1);
    with_terms(&a, base, 5, 7, 60); /* back-off 1: at once */
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
    assert_int_equal(its, 0);
    with_terms(&a, base, 4, 7, 60); /* tried again, fails: back-off 2 */
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
    assert_true(its > 4);
    for (int k = 0; k < 2; ++k) {
        with_terms(&a, base, 6 - k, 7, 60);
        assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
        assert_int_equal(its, 0);
    }
    with_terms(&a, base, 5, 7, 60);
    a.val[0] += 1e-3; /* a small change of the factor's matrix (3 more terms would do too) */
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 0); /* tried, converges: back-off ends */
    with_terms(&a, base, 2, 7, 60);
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
    assert_true(its > 4); /* tried at once: no back-off left */
    assert_int_equal(st->by_reason[PF_REFACTOR_NEW], 6);

    pf_solver_reset(s); /* a restart point forgets the back-off (1 now) */
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_NEW, rhs, x, NULL, &err), PF_OK);
    with_terms(&a, base, 1, 7, 60);
    assert_int_equal(terms_solve(s, &a, rhs, x, &its), 1);
    assert_true(its > 4);
    assert_int_equal(st->by_reason[PF_REFACTOR_FAILED], 0);

    pf_solver_destroy(&s);
    pf_block_matrix_release(&a);
    free(base);
    free(rhs);
    free(x);
}

/* The single-precision solve against the double one on a factor with real supernodes (panels of
 * four columns and their tails): relative difference of single's rounding, a few times 6e-8
 * times the condition (below 10 for this diagonally dominant matrix), so at most 1e-6 (8e-8
 * measured) and clearly not zero (it is the single path). Values too large for single
 * precision (the matrix scaled by 1e80) make it the double solve itself, bit for bit. */
static void single_precision_solve_matches(void **state)
{
    (void)state;
    rng r = {31337};
    for (int pass = 0; pass < 2; ++pass) {
        pf_block_matrix a;
        grid_matrix(&a, 9, pass == 0 ? 1 : 1e80, &r);
        int64_t n = a.n;
        pf_error err = {0};
        pf_cholesky *c = NULL;
        assert_int_equal(pf_cholesky_create(&c, &a, &err), PF_OK);
        double *b = malloc((size_t)n * sizeof *b), *x = malloc((size_t)n * sizeof *x);
        double *y = malloc((size_t)n * sizeof *y);
        for (int64_t k = 0; k < n; ++k)
            b[k] = 2 * uniform(&r) - 1;
        assert_int_equal(pf_cholesky_precondition(c, b, y, &err), PF_ERR_INVALID);
        assert_int_equal(pf_cholesky_factor(c, &a, NULL, &err), PF_OK);
        assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_OK);
        memcpy(y, b, (size_t)n * sizeof *y);
        assert_int_equal(pf_cholesky_precondition(c, y, y, &err), PF_OK); /* in place */
        double diff = 0, largest = 0;
        for (int64_t k = 0; k < n; ++k) {
            diff = fmax(diff, fabs(y[k] - x[k]));
            largest = fmax(largest, fabs(x[k]));
        }
        printf("single-precision solve, scale %g: %lld unknowns, relative difference %.2e\n",
               pass == 0 ? 1 : 1e80, (long long)n, diff / largest);
        if (pass == 0) {
            assert_true(diff <= 1e-6 * largest);
            assert_true(diff > 1e-12 * largest);
        } else {
            assert_true(diff == 0);
        }
        free(b);
        free(x);
        free(y);
        pf_cholesky_destroy(&c);
        pf_block_matrix_release(&a);
    }
}

/* out = Q_i m Q_j^T, Q_t = now_t factor_t^T (3 x 3, row-major). */
static void warp_3x3(const double *now, const double *factor, int32_t i, int32_t j, const double *m,
                     double *out)
{
    double qi[9] = {0}, qj[9] = {0}, t[9] = {0};
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c) {
                qi[3 * a + b] += now[9 * i + 3 * a + c] * factor[9 * i + 3 * b + c];
                qj[3 * a + b] += now[9 * j + 3 * a + c] * factor[9 * j + 3 * b + c];
            }
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c)
                t[3 * a + b] += qi[3 * a + c] * m[3 * c + b];
    for (int a = 0; a < 9; ++a)
        out[a] = 0;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c)
                out[3 * a + b] += t[3 * a + c] * qj[3 * b + c];
}

/* PCG iterations of one solve of b A x = rhs after a factorisation of a: with the rotations
 * given (warp) or not. */
static int64_t iterations_after(const pf_block_matrix *a, const pf_block_matrix *b,
                                const double *factor_rot, const double *now_rot, bool warp,
                                int64_t *factorisations)
{
    int64_t n = a->n;
    pf_error err = {0};
    pf_solver_params p = pf_solver_params_default();
    p.method = PF_SOLVER_PCG;
    pf_solver *s = NULL;
    assert_int_equal(pf_solver_create(&s, a, &p, true, &err), PF_OK);
    double *rhs = malloc((size_t)n * sizeof *rhs), *x = calloc((size_t)n, sizeof *x);
    double *ax = malloc((size_t)n * sizeof *ax);
    for (int64_t k = 0; k < n; ++k)
        rhs[k] = sin(0.37 * (double)k) + 0.5;
    assert_int_equal(pf_solver_set_rotations(s, warp ? factor_rot : NULL, &err), PF_OK);
    assert_int_equal(pf_solver_solve(s, a, PF_MATRIX_NEW, rhs, x, NULL, &err), PF_OK);
    int64_t before = pf_solver_get_stats(s)->iterations;
    assert_int_equal(pf_solver_set_rotations(s, warp ? now_rot : NULL, &err), PF_OK);
    assert_int_equal(pf_solver_solve(s, b, PF_MATRIX_DRIFTED, rhs, x, NULL, &err), PF_OK);
    pf_block_matrix_mul(b, 1, x, 0, ax);
    double rn = 0, bn = 0;
    for (int64_t k = 0; k < n; ++k)
        rn += (ax[k] - rhs[k]) * (ax[k] - rhs[k]), bn += rhs[k] * rhs[k];
    assert_true(sqrt(rn) <= 1e-10 * sqrt(bn) * 1.0001); /* the solver's tolerance */
    int64_t its = pf_solver_get_stats(s)->iterations - before;
    *factorisations = pf_solver_get_stats(s)->factorisations;
    free(rhs);
    free(x);
    free(ax);
    pf_solver_destroy(&s);
    return its;
}

/* The warp: B = Q A Q^T with Q = R_now R_f^T a random rotation per unknown triple, and the
 * factor of A made with the rotations R_f. Preconditioned by Q A^-1 Q^T = B^-1 exactly (up to
 * the single-precision factor's 1e-7 relative), PCG reaches the tolerance 1e-10 in at most 2
 * iterations on the factor of A; plain reuse of A's factor, which the rotations make a poor
 * preconditioner of B, needs more (or gives up and refactorises). */
static void warp_preconditions_rotated_matrix(void **state)
{
    (void)state;
    rng r = {4242};
    pf_block_matrix a, b;
    grid_matrix(&a, 8, 1, &r);
    grid_matrix(&b, 8, 1, &r); /* the same pattern; values replaced below */
    int32_t nb = a.n_blocks;
    double *rf = malloc(9 * (size_t)nb * sizeof *rf), *rn = malloc(9 * (size_t)nb * sizeof *rn);
    for (int32_t t = 0; t < nb; ++t) {
        pf_mat3 f = random_rotation(&r), w = random_rotation(&r);
        memcpy(rf + 9 * t, f.m, sizeof f.m);
        memcpy(rn + 9 * t, w.m, sizeof w.m);
    }
    pf_block_matrix_zero(&b);
    for (int32_t j = 0; j < nb; ++j)
        for (int64_t k = a.adj_offsets[j]; k < a.adj_offsets[j + 1]; ++k) {
            int32_t i = a.adj[k];
            double m[9], w[9];
            for (int q = 0; q < 9; ++q)
                m[q] = pf_block_matrix_get(&a, 3 * i + q / 3, 3 * j + q % 3);
            warp_3x3(rn, rf, i, j, m, w);
            pf_block_matrix_add(&b, k, i, j, w, 3);
        }
    int64_t fw, fp;
    int64_t warped = iterations_after(&a, &b, rf, rn, true, &fw);
    int64_t plain = iterations_after(&a, &b, rf, rn, false, &fp);
    printf("rotated matrix: %lld PCG iterations with the warp (%lld factorisations), %lld "
           "plain (%lld factorisations)\n",
           (long long)warped, (long long)fw, (long long)plain, (long long)fp);
    assert_true(warped >= 1 && warped <= 2);
    assert_int_equal(fw, 1);
    assert_true(plain > warped || fp > 1);
    free(rf);
    free(rn);
    pf_block_matrix_release(&a);
    pf_block_matrix_release(&b);
}

/* A diagonal matrix with one negative entry: the failure names that unknown whatever the
 * ordering did. */
static void cholesky_reports_indefinite_column(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    int32_t size[5] = {3, 3, 3, 3, 3}, pairs[4] = {0, 1, 3, 4};
    pf_block_matrix a;
    pf_error err = {0};
    assert_int_equal(pf_block_matrix_create(&a, 5, size, 2, pairs, &err), PF_OK);
    double d[15];
    for (int k = 0; k < 15; ++k)
        d[k] = 1 + k;
    d[10] = -1;
    pf_block_matrix_add_diagonal(&a, d);
    pf_cholesky *c = NULL;
    assert_int_equal(pf_cholesky_create(&c, &a, &err), PF_OK);
    int64_t column = -1;
    assert_int_equal(pf_cholesky_factor(c, &a, &column, &err), PF_ERR_NUMERIC);
    assert_int_equal(column, 10);
    assert_non_null(strstr(err.msg, "not positive definite"));
    double b[15] = {0}, x[15];
    assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_ERR_INVALID);
    /* Fixed, it factors again on the same analysis. */
    pf_block_matrix_zero(&a);
    d[10] = 11;
    pf_block_matrix_add_diagonal(&a, d);
    assert_int_equal(pf_cholesky_factor(c, &a, NULL, &err), PF_OK);
    for (int k = 0; k < 15; ++k)
        b[k] = 1 + k;
    assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_OK);
    for (int k = 0; k < 15; ++k)
        assert_true(fabs(x[k] - 1) < 1e-15);
    pf_cholesky_destroy(&c);
    pf_block_matrix_release(&a);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void invalid_patterns_are_refused(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_block_matrix a;
    pf_error err = {0};
    int32_t size[3] = {2, 0, 2}, pairs[2] = {0, 2};
    assert_int_equal(pf_block_matrix_create(&a, 3, size, 1, pairs, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "block 1"));
    size[1] = 2;
    pairs[1] = 3;
    assert_int_equal(pf_block_matrix_create(&a, 3, size, 1, pairs, &err), PF_ERR_INVALID);
    assert_null(a.val);
    assert_int_equal(pf_block_matrix_create(&a, 0, size, 0, pairs, &err), PF_OK);
    assert_int_equal(a.n, 0);
    pf_block_matrix_release(&a);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The threads of this process (Linux: one entry per thread in /proc/self/task). */
static int process_threads(void)
{
    DIR *d = opendir("/proc/self/task");
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

/* Elasticity-like 3 x 3 blocks on an n^3 grid of nodes coupled to their 6 neighbours: random
 * off-diagonal blocks in [-1, 1), diagonal blocks boosted past the row sums (6 neighbours x 3
 * entries + 2 in the block < 21), so positive definite. The top separator (3 n^2 = 432 unknowns
 * for n = 12) makes supernodes wide enough for CHOLMOD's OpenMP loops (from 64 rows on). */
static void make_grid_matrix(pf_block_matrix *a, int32_t n, rng *r)
{
    int32_t nb = n * n * n;
    int32_t *size = malloc((size_t)nb * sizeof *size),
            *pairs = malloc(6 * (size_t)nb * sizeof *pairs);
    assert_non_null(size);
    assert_non_null(pairs);
    int64_t np = 0;
    for (int32_t b = 0; b < nb; ++b) {
        size[b] = 3;
        int32_t x = b % n, y = b / n % n, z = b / (n * n);
        if (x + 1 < n)
            pairs[2 * np] = b, pairs[2 * np++ + 1] = b + 1;
        if (y + 1 < n)
            pairs[2 * np] = b, pairs[2 * np++ + 1] = b + n;
        if (z + 1 < n)
            pairs[2 * np] = b, pairs[2 * np++ + 1] = b + n * n;
    }
    pf_error err = {0};
    assert_int_equal(pf_block_matrix_create(a, nb, size, np, pairs, &err), PF_OK);
    double blk[9];
    for (int64_t k = 0; k < np; ++k) {
        for (int q = 0; q < 9; ++q)
            blk[q] = uniform(r);
        pf_block_matrix_add(a, pf_block_matrix_slot(a, pairs[2 * k], pairs[2 * k + 1]),
                            pairs[2 * k], pairs[2 * k + 1], blk, 3);
    }
    for (int32_t b = 0; b < nb; ++b) {
        for (int q = 0; q < 9; ++q)
            blk[q] = uniform(r);
        for (int q = 0; q < 3; ++q)
            blk[4 * q] += 21;
        pf_block_matrix_add(a, pf_block_matrix_slot(a, b, b), b, b, blk, 3);
    }
    free(size);
    free(pairs);
}

/* Factor + solve with c's current threads into x. */
static void factor_and_solve(pf_cholesky *c, const pf_block_matrix *a, const double *b, double *x)
{
    pf_error err = {0};
    assert_int_equal(pf_cholesky_factor(c, a, NULL, &err), PF_OK);
    assert_int_equal(pf_cholesky_solve(c, b, x, &err), PF_OK);
}

static void cholesky_is_independent_of_threads(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    assert_true(pf_solve_threads_blas_settable()); /* OpenBLAS: the BLAS the project builds on */
    rng r = {0x5eed5eedu};
    pf_block_matrix a;
    make_grid_matrix(&a, 12, &r);
    size_t n = (size_t)a.n;
    double *b = malloc(n * sizeof *b), *x[3];
    assert_non_null(b);
    for (size_t k = 0; k < n; ++k)
        b[k] = uniform(&r);
    for (int k = 0; k < 3; ++k) {
        x[k] = malloc(n * sizeof *x[k]);
        assert_non_null(x[k]);
    }
    pf_error err = {0};
    pf_cholesky *c = NULL;
    assert_int_equal(pf_cholesky_create(&c, &a, &err), PF_OK);
    factor_and_solve(c, &a, b, x[0]); /* the library's own choice */
    pf_cholesky_force_threads(c, true, 1);
    factor_and_solve(c, &a, b, x[1]);
    int serial_threads = process_threads();
    /* CHOLMOD's own OpenMP team (4 threads, as built). OpenBLAS is not varied: its threads do
     * change the last bits (2 threads differ from 1 here), which is why threads.c keeps it on
     * one thread inside CHOLMOD. */
    pf_cholesky_force_threads(c, false, 1);
    factor_and_solve(c, &a, b, x[2]);
    assert_true(process_threads() > serial_threads); /* the team was started: threads did run */
    assert_memory_equal(x[0], x[1], n * sizeof *x[0]);
    assert_memory_equal(x[1], x[2], n * sizeof *x[1]);
    /* and it is the solution: the residual bound of the file's header, n = 5184 */
    double *ax = malloc(n * sizeof *ax);
    assert_non_null(ax);
    pf_block_matrix_mul(&a, 1, x[2], 0, ax);
    double r2 = 0, b2 = 0;
    for (size_t k = 0; k < n; ++k)
        r2 += (ax[k] - b[k]) * (ax[k] - b[k]), b2 += b[k] * b[k];
    assert_true(sqrt(r2 / b2) < 1e-13);
    free(ax);
    for (int k = 0; k < 3; ++k)
        free(x[k]);
    free(b);
    pf_cholesky_destroy(&c);
    pf_block_matrix_release(&a);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* pf_blas_threads_set reports the count it replaced and restore puts it back; forced, it acts
 * whatever the environment says. */
static void blas_threads_restore(void **state)
{
    (void)state;
    assert_true(pf_blas_threads_settable()); /* OpenBLAS: the BLAS the project builds on */
    pf_blas_threads a = pf_blas_threads_set(3, true);
    pf_blas_threads b = pf_blas_threads_set(1, true);
    assert_int_equal(b.before, 3);
    pf_blas_threads c = pf_blas_threads_set(1, true);
    assert_int_equal(c.before, 0); /* already 1: nothing to restore */
    pf_blas_threads_restore(c);
    pf_blas_threads_restore(b);
    pf_blas_threads d = pf_blas_threads_set(3, true);
    assert_int_equal(d.before, 0); /* b put 3 back */
    pf_blas_threads_restore(d);
    pf_blas_threads_restore(a);
    assert_int_equal(pf_blas_threads_set(0, true).before, 0); /* 0: no change */
}

int main(void)
{
    /* The library's thread choice is what is tested, not a setting of the caller's environment
     * (read once, on the first factorisation). */
    const char *const THREAD_VARIABLES[] = {
        "OMP_THREAD_LIMIT", "OMP_DYNAMIC",          "OMP_NUM_THREADS", "OMP_MAX_ACTIVE_LEVELS",
        "OMP_NESTED",       "OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS"};
    for (size_t k = 0; k < sizeof THREAD_VARIABLES / sizeof *THREAD_VARIABLES; ++k)
        unsetenv(THREAD_VARIABLES[k]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(assembly_matches_dense, setup, teardown),
        cmocka_unit_test_setup_teardown(uncoupled_pairs_have_no_slot, setup, teardown),
        cmocka_unit_test_setup_teardown(product_matches_dense, setup, teardown),
        cmocka_unit_test_setup_teardown(product_is_bit_identical, setup, teardown),
        cmocka_unit_test_setup_teardown(cholesky_solves_and_refactors, setup, teardown),
        cmocka_unit_test(blas_threads_restore),
        cmocka_unit_test(cholesky_reports_indefinite_column),
        cmocka_unit_test(single_precision_solve_matches),
        cmocka_unit_test(warp_preconditions_rotated_matrix),
        cmocka_unit_test(terms_tried_on_old_factor_with_back_off),
        cmocka_unit_test(invalid_patterns_are_refused),
        cmocka_unit_test(cholesky_is_independent_of_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
