/* The solver policy (pf/solve.h): a direct factorisation whenever the matrix changes, or
 * conjugate gradients preconditioned by the most recent factor, which refactorises only when
 * that pays.
 *
 * Why PCG on an old factor works: a corotated step changes the matrix by the rotation of each
 * element's block, which is small from one step to the next, so the old factor is a spectrally
 * close preconditioner (one to a few iterations to 1e-10).
 *
 * The cost model (pcg): an iteration costs two triangular solves and a product with A,
 * 4 nnz(L) + 4 nnz(A) flops; a factorisation what CHOLMOD's analysis counted, divided by
 * FACTOR_RATE (its supernodal dense blocks run that much faster per flop than the
 * memory-bound triangular solves and products: measured 2.6 on an embedded CG bunny, 3.0 and 5.7
 * on the CG and DG beams of 1,911 hexes, CPU seconds of pf-sim's summary against its flops).
 *
 * When to refactorise: a factor and the solves on it until the next one form a cycle, whose cost
 * per solve is (factorisation + solves) / solves. While the solves cost less than that average,
 * keeping the factor lowers it; once the last solve cost more, the factor has aged past its best
 * and the next solve refactorises (the renewal rule: with costs that grow with age, the average
 * is smallest where the latest cost first exceeds it). A fresh factor solves exactly (one
 * iteration's cost); on an older one, PCG needs a few iterations to the tight tolerance however
 * young the factor is (3-4 on the beams from the second solve on), so while that count stays flat
 * the factor is kept: the earlier rule, which refactorised once the iterations beyond one added up
 * to a factorisation, renewed the CG beam's factor every 6 steps for no fewer iterations.
 * One solve stops iterating when it has spent a factorisation's worth, and refactorises: a factor
 * that needs more is worse than a new one. With the rotations of the unknowns' triples
 * (pf_solver_set_rotations), the old factor is applied in the frame they have turned to (the
 * warp), which keeps it a close preconditioner of a rotating body for longer. Flops, not
 * seconds: the same inputs make the same decisions, and so the same bits, on any machine and
 * under any load. */
#include <pf/solve.h>

#include <math.h>
#include <string.h>

#include "solve_petsc.h"

/* A known weakness: small or fragmented factors have small supernodes, whose dense calls run far
 * below FACTOR_RATE, so the model undervalues their factorisation. On the 1,200 Kuhn tets of
 * bench_cut steps, CG, a factorisation was modelled at 4.1 iterations and cost about 20 (2.4 ms
 * against 0.12 per iteration, load ~20): auto takes direct (3.9 ms per step) where pcg runs 2.1,
 * and 14.1 against 5.8 after the cuts. The surplus fits roughly a constant cost per supernode
 * (some 15-25 us); the model does not count it yet. */
enum { FACTOR_RATE = 4 };

/* A trial of the old factor on new terms (PF_MATRIX_TERMS) may spend this many factorisations'
 * worth of iterations: in the congruence such trials converge in 5-36 iterations on the
 * embedded CG torus and bunny of scripts/demo's pipeline (a factorisation is worth 17 and 14
 * there), and a trial that converges keeps the factor for the steps after it. With 2 against
 * 1, on those scenes (30 and 24 frames): 27 factorisations against 37, and 55 against 90;
 * factorisation and solves 14.8 against 18.4 and 15.8 against 19.9 CPU seconds. */
enum { TRIAL_WORTH = 2 };

/* auto takes direct when a factorisation costs at most this many iterations: a solve on an old
 * factor needs 3-6 (measured on the beams and bodies of bench/bench_solver.c), and the factor
 * still has to be renewed every few steps. */
enum { AUTO_DIRECT = 10 };

struct pf_solver {
    pf_solver_params params;
    pf_cholesky *chol;      /* NULL for petsc until pf_solver_factor needs one */
    pf_petsc_solver *petsc; /* the petsc method */
    int64_t n, nnz;
    double *r, *z, *d, *q;
    bool have_factor;        /* the factor is of a system matrix, not of pf_solver_factor's */
    bool factor_current;     /* ... of the current one */
    double cycle_flops;      /* the factorisation and the solves since, in iteration flops */
    int64_t cycle_solves;    /* solves since the factorisation */
    double factor_cost;      /* a factorisation in iteration flops (the cost model above) */
    int32_t iteration_limit; /* per solve: max_iterations, or a factorisation's worth */
    bool refactor_due;
    int32_t terms_backoff;   /* PF_MATRIX_TERMS: changes refactorised at once after the last
                                failed trial of the old factor (0: the last trial converged) */
    int32_t terms_skip;      /* ... of which still to come */
    double last_residual;
    /* the warp (pf_solver_set_rotations): the rotation of every unknown triple for the coming
     * solve, and those of the factor's matrix */
    double *rot, *rot_factor; /* [3 n] each, NULL until rotations are given */
    bool rot_given;           /* rot holds the coming solve's */
    bool rot_factor_valid;    /* rot_factor holds the factor's */
    /* the congruence (below): the 3 x 3 diagonal blocks of the factor's matrix, [3 n] row-major
     * per triple, and the lower triangles T of the coming solve's, [2 n] (t00 t10 t11 t20 t21
     * t22 per triple); NULL when the unknowns do not come in triples of one block */
    double *diag_factor, *congruence;
    bool congruence_valid; /* congruence holds the coming solve's */
    pf_solver_stats stats;
};

static const char *const METHOD_NAMES[] = {"auto", "direct", "pcg", "petsc"};
enum { METHODS = 4 };
static const char *const REASON_NAMES[] = {"first",      "changed", "cost",
                                           "pcg-failed", "other",   "new-terms"};

const char *pf_solver_method_name(pf_solver_method m)
{
    return (unsigned)m < METHODS ? METHOD_NAMES[m] : "?";
}

bool pf_solver_method_parse(const char *name, pf_solver_method *m)
{
    for (int k = 0; k < METHODS; ++k)
        if (name && strcmp(name, METHOD_NAMES[k]) == 0) {
            *m = (pf_solver_method)k;
            return true;
        }
    return false;
}

const char *pf_refactor_reason_name(pf_refactor_reason r)
{
    return (unsigned)r < PF_REFACTOR_REASONS ? REASON_NAMES[r] : "?";
}

pf_solver_params pf_solver_params_default(void)
{
    /* 1e-10: the frames of pcg then agree with direct to about 1e-9 of the largest
     * displacement (a relative residual bounds the relative error by the condition of the
     * step's matrix, which the mass term keeps near 1e1-1e2), well inside the 1e-6 the tests
     * ask for. 200 iterations: a factor so stale that it needs more is cheaper to replace. */
    return (pf_solver_params){.method = PF_SOLVER_AUTO, .tolerance = 1e-10, .max_iterations = 200};
}

/* The petsc method: PETSc's KSP instead of the factor; a factor only when pf_solver_factor
 * asks for one. */
static pf_status create_petsc(pf_solver **out, pf_solver *s, const pf_block_matrix *a,
                              pf_error *err)
{
    s->stats.method = PF_SOLVER_PETSC;
    s->stats.matrix_nnz = s->nnz;
    pf_status st = pf_petsc_solver_create(&s->petsc, a, s->params.tolerance, err);
    if (st < 0) {
        pf_solver_destroy(&s);
        return st;
    }
    *out = s;
    return PF_OK;
}

/* Whether the unknowns come in triples (3 t .. 3 t + 2) that each lie within one block, so that
 * every triple's 3 x 3 diagonal block is stored (the congruence below). */
static bool triples_in_blocks(const pf_block_matrix *a)
{
    if (a->n % 3 != 0)
        return false;
    for (int32_t b = 0; b <= a->n_blocks; ++b)
        if (a->block_start[b] % 3 != 0)
            return false;
    return true;
}

/* CHOLMOD's analysis (no progress of its own: the phase's start and end). */
static pf_status analyse(pf_solver *s, const pf_block_matrix *a, pf_error *err)
{
    pf_progress_post(&s->params.progress, "symbolic analysis", 0, 1);
    pf_status st = pf_cholesky_create(&s->chol, a, err);
    if (st >= 0)
        pf_progress_post(&s->params.progress, "symbolic analysis", 1, 1);
    return st;
}

pf_status pf_solver_create(pf_solver **out, const pf_block_matrix *a,
                           const pf_solver_params *params, bool matrix_changes, pf_error *err)
{
    *out = NULL;
    pf_solver_params pr = params ? *params : pf_solver_params_default();
    PF_CHECK(pr.tolerance > 0 && pr.tolerance < 1, err, PF_ERR_INVALID,
             "solver tolerance must lie in (0, 1), got %g", pr.tolerance);
    PF_CHECK(pr.max_iterations >= 1, err, PF_ERR_INVALID,
             "solver max_iterations must be at least 1, got %d", (int)pr.max_iterations);
    PF_CHECK((unsigned)pr.method < METHODS, err, PF_ERR_INVALID, "unknown solver method %d",
             (int)pr.method);
    PF_CHECK(pr.method != PF_SOLVER_PETSC || pf_petsc_available(), err, PF_ERR_INVALID,
             "solver method petsc: this pf was built without PETSc (configure with "
             "-DPF_PETSC=ON after scripts/setup --petsc)");
    pf_solver *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate a solver");
    s->params = pr;
    s->n = a->n;
    s->nnz = a->col_ptr[a->n];
    if (pr.method == PF_SOLVER_PETSC)
        return create_petsc(out, s, a, err);
    pf_status st = analyse(s, a, err);
    if (st >= 0) {
        size_t n = (size_t)s->n + 1;
        s->r = pf_alloc_array(n, sizeof *s->r);
        s->z = pf_alloc_array(n, sizeof *s->z);
        s->d = pf_alloc_array(n, sizeof *s->d);
        s->q = pf_alloc_array(n, sizeof *s->q);
        bool triples = triples_in_blocks(a);
        if (triples) {
            s->diag_factor = pf_alloc_array(3 * (n - 1) + 1, sizeof *s->diag_factor);
            s->congruence = pf_alloc_array(2 * (n - 1) + 1, sizeof *s->congruence);
        }
        if (!s->r || !s->z || !s->d || !s->q || (triples && (!s->diag_factor || !s->congruence)))
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                              "cannot allocate the solver's vectors for %lld unknowns",
                              (long long)s->n);
    }
    if (st < 0) {
        pf_solver_destroy(&s);
        return st;
    }
    s->stats.factor_flops = pf_cholesky_factor_flops(s->chol);
    s->stats.factor_nnz = pf_cholesky_factor_nnz(s->chol);
    s->stats.matrix_nnz = s->nnz;
    s->stats.iteration_flops = 4.0 * (double)s->stats.factor_nnz + 4.0 * (double)s->nnz;
    s->factor_cost = s->stats.factor_flops / FACTOR_RATE;
    double worth = s->factor_cost / s->stats.iteration_flops;
    s->stats.factor_iterations = worth;
    s->iteration_limit = worth < 2 ? 2 : worth < pr.max_iterations ? (int32_t)worth : INT32_MAX;
    if (s->iteration_limit > pr.max_iterations)
        s->iteration_limit = pr.max_iterations;
    if (pr.method == PF_SOLVER_AUTO)
        pr.method = !matrix_changes || s->factor_cost <= AUTO_DIRECT * s->stats.iteration_flops
                        ? PF_SOLVER_DIRECT
                        : PF_SOLVER_PCG;
    s->params.method = pr.method;
    s->stats.method = pr.method;
    *out = s;
    return PF_OK;
}

void pf_solver_destroy(pf_solver **sp)
{
    pf_solver *s = *sp;
    if (!s)
        return;
    pf_cholesky_destroy(&s->chol);
    pf_petsc_solver_destroy(&s->petsc);
    void *arrays[] = {s->r, s->z, s->d, s->q, s->rot, s->rot_factor, s->diag_factor,
                      s->congruence};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; ++k)
        pf_free(arrays[k]);
    pf_free(s);
    *sp = NULL;
}

/* ---- factorisations ---------------------------------------------------------------------- */

static pf_status factor_timed(pf_solver *s, const pf_block_matrix *m, pf_refactor_reason why,
                              int64_t *failed, pf_error *err)
{
    double t0 = pf_time_seconds(), c0 = pf_cpu_seconds();
    pf_progress_post(&s->params.progress, "numeric factorisation", 0, 1);
    pf_status st = pf_cholesky_factor(s->chol, m, failed, err);
    pf_progress_post(&s->params.progress, "numeric factorisation", 1, 1); /* also a failed one */
    s->stats.factor_seconds += pf_time_seconds() - t0;
    s->stats.factor_cpu_seconds += pf_cpu_seconds() - c0;
    s->stats.factorisations++;
    s->stats.by_reason[why]++;
    return st;
}

static void triple_block(const pf_block_matrix *a, int64_t t, double m[9]);

static pf_status factor_system(pf_solver *s, const pf_block_matrix *a, pf_refactor_reason why,
                               int64_t *failed, pf_error *err)
{
    s->have_factor = s->factor_current = false;
    PF_TRY(factor_timed(s, a, why, failed, err));
    s->have_factor = s->factor_current = true;
    s->rot_factor_valid = s->rot_given;
    if (s->rot_given)
        memcpy(s->rot_factor, s->rot, 3 * (size_t)s->n * sizeof *s->rot);
    if (s->diag_factor)
        for (int64_t t = 0; t < s->n / 3; ++t)
            triple_block(a, t, s->diag_factor + 9 * t);
    s->cycle_flops = s->factor_cost;
    s->cycle_solves = 0;
    s->refactor_due = false;
    return PF_OK;
}

pf_status pf_solver_factor(pf_solver *s, const pf_block_matrix *a, int64_t *failed_column,
                           pf_error *err)
{
    if (!s->chol) /* petsc: a definiteness test factorises on this rank */
        PF_TRY(analyse(s, a, err));
    s->have_factor = s->factor_current = false;
    return factor_timed(s, a, PF_REFACTOR_OTHER, failed_column, err);
}

void pf_solver_set_progress(pf_solver *s, const pf_progress_hook *progress)
{
    s->params.progress = progress ? *progress : (pf_progress_hook){0};
}

void pf_solver_reset(pf_solver *s)
{
    s->have_factor = s->factor_current = false;
    s->terms_backoff = s->terms_skip = 0; /* history too: a reset is a restart point */
}

/* ---- conjugate gradients ----------------------------------------------------------------- */

static double dot(const double *x, const double *y, int64_t n)
{
    double s = 0;
    for (int64_t k = 0; k < n; ++k)
        s += x[k] * y[k];
    return s;
}

/* r = b - A x; returns ||r||. */
static double residual(pf_solver *s, const pf_block_matrix *a, const double *b, const double *x)
{
    pf_block_matrix_mul(a, 1, x, 0, s->q);
    for (int64_t k = 0; k < s->n; ++k)
        s->r[k] = b[k] - s->q[k];
    return sqrt(dot(s->r, s->r, s->n));
}

pf_status pf_solver_set_rotations(pf_solver *s, const double *rot, pf_error *err)
{
    s->rot_given = false;
    if (!rot || s->n % 3 != 0)
        return PF_OK;
    size_t size = 3 * (size_t)s->n;
    if (!s->rot) {
        s->rot = pf_alloc_array(size + 1, sizeof *s->rot);
        s->rot_factor = pf_alloc_array(size + 1, sizeof *s->rot_factor);
        PF_CHECK(s->rot && s->rot_factor, err, PF_ERR_NOMEM,
                 "cannot allocate the rotations of %lld unknowns", (long long)s->n);
    }
    memcpy(s->rot, rot, size * sizeof *s->rot);
    s->rot_given = true;
    return PF_OK;
}

/* y = A x for every triple: A = R_now R_factor^T (transpose: R_factor R_now^T), R row-major. */
static void rotate_triples(const pf_solver *s, bool transpose, const double *x, double *y)
{
    for (int64_t t = 0; t < s->n / 3; ++t) {
        const double *rn = s->rot + 9 * t, *rf = s->rot_factor + 9 * t;
        const double *first = transpose ? rn : rf, *second = transpose ? rf : rn;
        double w[3]; /* first^T x */
        for (int i = 0; i < 3; ++i)
            w[i] = first[i] * x[3 * t] + first[3 + i] * x[3 * t + 1] + first[6 + i] * x[3 * t + 2];
        for (int i = 0; i < 3; ++i)
            y[3 * t + i] =
                second[3 * i] * w[0] + second[3 * i + 1] * w[1] + second[3 * i + 2] * w[2];
    }
}

/* ---- the congruence -----------------------------------------------------------------------
 * Penalty contact adds stiff terms in the world frame (an embedded surface vertex on the
 * ground: up to some 2,000 times the diagonal of the unknowns it reaches, on the demo's torus on
 * CG) and adds or drops them wherever contacts come or go. The old factor does not know them: a
 * trial of it on new contact terms took 300-500 PCG iterations there (a factorisation is worth
 * 17). The preconditioner is therefore taken in the congruence P = S W S^T (W the warped
 * factor's matrix Q A_f Q^T, S block-diagonal with a lower-triangular 3 x 3 block S_t per
 * triple) that gives P every triple's diagonal block N_t of the current matrix:
 * S_t = L(N_t) L(G_t)^-1, G_t = Q_t F_t Q_t^T the diagonal block of W (F_t that of the
 * factor's matrix), L() the Cholesky factor, so S_t G_t S_t^T = N_t; then P^-1 = T^T W^-1 T with
 * T = S^-1 = L(G_t) L(N_t)^-1, still symmetric positive definite. A stiff term on the diagonal
 * is then in P, its triple's couplings scaled with it: those trials took 5-16 iterations (the
 * simulator drops the warp under contact, sim.c). The price: a lone stiff rank-one term, which
 * the plain factor absorbs in 2 iterations, takes up to 7 (P is off in the triple's block row
 * and column). Without contact the diagonal blocks drift little and T stays near I. */

/* The triple t's diagonal block of a (row-major, full). */
static void triple_block(const pf_block_matrix *a, int64_t t, double m[9])
{
    for (int j = 0; j < 3; ++j) { /* column 3 t + j ends with rows 3 t .. 3 t + j */
        int64_t end = a->col_ptr[3 * t + j + 1];
        for (int i = 0; i <= j; ++i)
            m[3 * i + j] = m[3 * j + i] = a->val[end - 1 - (j - i)];
    }
}

/* The lower Cholesky factor l (l00 l10 l11 l20 l21 l22) of the symmetric m; false when m is
 * not positive definite. */
static bool cholesky3(const double m[9], double l[6])
{
    double d0 = m[0];
    if (!(d0 > 0))
        return false;
    l[0] = sqrt(d0);
    l[1] = m[3] / l[0];
    l[3] = m[6] / l[0];
    double d1 = m[4] - l[1] * l[1];
    if (!(d1 > 0))
        return false;
    l[2] = sqrt(d1);
    l[4] = (m[7] - l[3] * l[1]) / l[2];
    double d2 = m[8] - l[3] * l[3] - l[4] * l[4];
    if (!(d2 > 0))
        return false;
    l[5] = sqrt(d2);
    return true;
}

/* t = g n^-1 for lower triangles g, n (packed as cholesky3's). */
static void lower_over(const double g[6], const double n[6], double t[6])
{
    double i0 = 1 / n[0], i2 = 1 / n[2], i5 = 1 / n[5]; /* n^-1, lower */
    double i1 = -n[1] * i0 * i2, i4 = -n[4] * i2 * i5;
    double i3 = -(n[3] * i0 + n[4] * i1) * i5;
    t[0] = g[0] * i0;
    t[1] = g[1] * i0 + g[2] * i1;
    t[2] = g[2] * i2;
    t[3] = g[3] * i0 + g[4] * i1 + g[5] * i3;
    t[4] = g[4] * i2 + g[5] * i4;
    t[5] = g[5] * i5;
}

/* Prepares T for the coming solve on a (the factor's blocks, rotated by the warp when it
 * applies). A triple whose block is not positive definite keeps T = I. */
static void congruence_prepare(pf_solver *s, const pf_block_matrix *a)
{
    s->congruence_valid = false;
    if (!s->diag_factor)
        return;
    bool warp = s->rot_given && s->rot_factor_valid;
    for (int64_t t = 0; t < s->n / 3; ++t) {
        double nb[9], g[9], ln[6], lg[6], *tt = s->congruence + 6 * t;
        triple_block(a, t, nb);
        const double *f = s->diag_factor + 9 * t;
        if (warp) { /* g = Q f Q^T, Q = R_now R_factor^T */
            const double *rn = s->rot + 9 * t, *rf = s->rot_factor + 9 * t;
            double q[9], qf[9];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    q[3 * i + j] = rn[3 * i] * rf[3 * j] + rn[3 * i + 1] * rf[3 * j + 1] +
                                   rn[3 * i + 2] * rf[3 * j + 2];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    qf[3 * i + j] =
                        q[3 * i] * f[j] + q[3 * i + 1] * f[3 + j] + q[3 * i + 2] * f[6 + j];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    g[3 * i + j] = qf[3 * i] * q[3 * j] + qf[3 * i + 1] * q[3 * j + 1] +
                                   qf[3 * i + 2] * q[3 * j + 2];
        } else
            memcpy(g, f, sizeof g);
        if (cholesky3(nb, ln) && cholesky3(g, lg))
            lower_over(lg, ln, tt);
        else
            tt[0] = tt[2] = tt[5] = 1, tt[1] = tt[3] = tt[4] = 0;
    }
    s->congruence_valid = true;
}

/* y = T x (transpose: T^T x) per triple; x and y may alias. */
static void congruence_apply(const pf_solver *s, bool transpose, const double *x, double *y)
{
    for (int64_t t = 0; t < s->n / 3; ++t) {
        const double *m = s->congruence + 6 * t;
        double x0 = x[3 * t], x1 = x[3 * t + 1], x2 = x[3 * t + 2];
        if (transpose) {
            y[3 * t] = m[0] * x0 + m[1] * x1 + m[3] * x2;
            y[3 * t + 1] = m[2] * x1 + m[4] * x2;
            y[3 * t + 2] = m[5] * x2;
        } else {
            y[3 * t] = m[0] * x0;
            y[3 * t + 1] = m[1] * x0 + m[2] * x1;
            y[3 * t + 2] = m[3] * x0 + m[4] * x1 + m[5] * x2;
        }
    }
}

/* z ~ A^-1 r on the factor of an earlier matrix. With rotations (the warp): a corotated matrix
 * is A ~ Q A_f Q^T, Q = R_now R_factor^T per triple, so z = Q A_f^-1 Q^T r, still symmetric
 * positive definite (Q is orthogonal). */
static pf_status warped(pf_solver *s, const double *r, double *z, pf_error *err)
{
    if (!s->rot_given || !s->rot_factor_valid)
        return pf_cholesky_precondition(s->chol, r, z, err);
    rotate_triples(s, true, r, z);
    PF_TRY(pf_cholesky_precondition(s->chol, z, z, err));
    rotate_triples(s, false, z, z);
    return PF_OK;
}

/* z = T^T W T r: the warped factor W (above) in the congruence T of the coming solve. */
static pf_status precondition(pf_solver *s, const double *r, double *z, pf_error *err)
{
    if (!s->congruence_valid)
        return warped(s, r, z, err);
    congruence_apply(s, false, r, z);
    PF_TRY(warped(s, z, z, err));
    congruence_apply(s, true, z, z);
    return PF_OK;
}

typedef enum pcg_result { PCG_CONVERGED, PCG_NOT_CONVERGED, PCG_BREAKDOWN } pcg_result;

/* Preconditioned conjugate gradients from x (Saad, Iterative Methods for Sparse Linear Systems,
 * alg. 9.1). Convergence is judged on the true residual: when the recurrence says converged, the
 * residual is recomputed and the iteration restarts from it if rounding has let them drift. */
static pcg_result pcg(pf_solver *s, const pf_block_matrix *a, const double *b, double *x,
                      int32_t *iterations, pf_error *err)
{
    int64_t n = s->n;
    double bnorm = sqrt(dot(b, b, n)), goal = s->params.tolerance * bnorm;
    *iterations = 0;
    if (bnorm == 0) {
        memset(x, 0, (size_t)n * sizeof *x);
        s->last_residual = 0;
        return PCG_CONVERGED;
    }
    double rnorm = residual(s, a, b, x);
    while (rnorm > goal) {
        if (!isfinite(rnorm) || *iterations >= s->iteration_limit)
            break;
        if (precondition(s, s->r, s->z, err) < 0)
            return PCG_BREAKDOWN;
        memcpy(s->d, s->z, (size_t)n * sizeof *s->d);
        double rz = dot(s->r, s->z, n);
        while (rnorm > goal && *iterations < s->iteration_limit) {
            pf_block_matrix_mul(a, 1, s->d, 0, s->q);
            double dq = dot(s->d, s->q, n);
            if (!(dq > 0) || !(rz > 0))
                return PCG_BREAKDOWN;
            double alpha = rz / dq;
            for (int64_t k = 0; k < n; ++k) {
                x[k] += alpha * s->d[k];
                s->r[k] -= alpha * s->q[k];
            }
            ++*iterations;
            rnorm = sqrt(dot(s->r, s->r, n));
            if (rnorm <= goal || !isfinite(rnorm))
                break;
            if (precondition(s, s->r, s->z, err) < 0)
                return PCG_BREAKDOWN;
            double rz_next = dot(s->r, s->z, n), beta = rz_next / rz;
            rz = rz_next;
            for (int64_t k = 0; k < n; ++k)
                s->d[k] = s->z[k] + beta * s->d[k];
        }
        rnorm = residual(s, a, b, x);
    }
    s->last_residual = rnorm / bnorm;
    if (!isfinite(rnorm))
        return PCG_BREAKDOWN;
    return rnorm <= goal ? PCG_CONVERGED : PCG_NOT_CONVERGED;
}

/* Adds a solve of the given cost to the factor's cycle and decides whether the next solve
 * refactorises (the renewal rule above). */
static void charge(pf_solver *s, double flops)
{
    s->cycle_flops += flops;
    s->cycle_solves++;
    if (s->params.method == PF_SOLVER_PCG && flops * (double)s->cycle_solves > s->cycle_flops)
        s->refactor_due = true;
}

/* Counts a PCG solve's iterations and charges them to the factor's cycle. */
static void account(pf_solver *s, int32_t iterations)
{
    s->stats.iterations += iterations;
    s->stats.pcg_solves++;
    if (iterations > s->stats.max_iterations)
        s->stats.max_iterations = iterations;
    charge(s, (double)iterations * s->stats.iteration_flops);
}

/* x = A^-1 b with the factor of exactly A. */
static pf_status solve_exact(pf_solver *s, const pf_block_matrix *a, const double *b, double *x,
                             pf_error *err)
{
    PF_TRY(pf_cholesky_solve(s->chol, b, x, err));
    double bnorm = sqrt(dot(b, b, s->n));
    double rnorm = residual(s, a, b, x);
    s->last_residual = bnorm > 0 ? rnorm / bnorm : 0;
    PF_CHECK(isfinite(rnorm), err, PF_ERR_NUMERIC,
             "the solve gave a non-finite result (matrix or right-hand side not finite)");
    return PF_OK;
}

/* PCG from x on the old factor; when it fails, the exact solve on a fresh one, the factorisation
 * counted for the reason given (the new terms of a trial, else a failure). *converged says
 * which. */
static pf_status iterate(pf_solver *s, const pf_block_matrix *a, const double *b, double *x,
                         int64_t *failed, pf_refactor_reason reason, bool *converged,
                         pf_error *err)
{
    int32_t its = 0;
    congruence_prepare(s, a);
    pcg_result res = pcg(s, a, b, x, &its, err);
    s->congruence_valid = false;
    *converged = res == PCG_CONVERGED;
    account(s, its); /* a failed attempt iterated too; its charge ends with the factorisation */
    if (res == PCG_CONVERGED)
        return PF_OK;
    PF_TRY(factor_system(s, a, reason, failed, err));
    PF_TRY(solve_exact(s, a, b, x, err));
    charge(s, s->stats.iteration_flops);
    return PF_OK;
}

/* The petsc method: every solve iterates (GAMG rebuilt when the values changed). */
static pf_status solve_petsc(pf_solver *s, const pf_block_matrix *a, pf_matrix_change change,
                             const double *b, double *x, pf_error *err)
{
    pf_cholesky_destroy(&s->chol); /* the definiteness tests' factor, not needed any more */
    double t0 = pf_time_seconds(), c0 = pf_cpu_seconds();
    int32_t its = 0;
    pf_status st = pf_petsc_solver_solve(s->petsc, a, change != PF_MATRIX_SAME || !s->have_factor,
                                         b, x, &its, &s->last_residual, err);
    s->have_factor = st >= 0;
    s->stats.solves++;
    s->stats.pcg_solves++;
    s->stats.iterations += its;
    if (its > s->stats.max_iterations)
        s->stats.max_iterations = its;
    s->stats.solve_seconds += pf_time_seconds() - t0;
    s->stats.solve_cpu_seconds += pf_cpu_seconds() - c0;
    return st;
}

pf_status pf_solver_set_near_null_space(pf_solver *s, int32_t k, const double *vectors,
                                        pf_error *err)
{
    PF_CHECK(k >= 0 && (k == 0 || vectors), err, PF_ERR_INVALID, "a near-null space of %d vectors",
             (int)k);
    return s->petsc ? pf_petsc_solver_near_null_space(s->petsc, k, vectors, err) : PF_OK;
}

/* The back-off of PF_MATRIX_TERMS trials (pf_matrix_change): a failure doubles the changes to
 * refactorise at once, up to 32 (a failed trial wastes about a factorisation's worth of
 * iterations, so at most 1 in 33 changes pays twice); a success ends it. */
static void note_terms_trial(pf_solver *s, bool converged)
{
    enum { MOST = 32 };
    s->terms_backoff = converged ? 0 : s->terms_backoff ? 2 * s->terms_backoff : 1;
    if (s->terms_backoff > MOST)
        s->terms_backoff = MOST;
    s->terms_skip = s->terms_backoff;
}

pf_status pf_solver_solve(pf_solver *s, const pf_block_matrix *a, pf_matrix_change change,
                          const double *b, double *x, int64_t *failed_column, pf_error *err)
{
    PF_CHECK(a->n == s->n && a->col_ptr[a->n] == s->nnz, err, PF_ERR_INVALID,
             "matrix pattern changed since the analysis (%lld unknowns, was %lld)", (long long)a->n,
             (long long)s->n);
    if (s->petsc)
        return solve_petsc(s, a, change, b, x, err);
    double t0 = pf_time_seconds(), c0 = pf_cpu_seconds();
    double f0 = s->stats.factor_seconds, fc0 = s->stats.factor_cpu_seconds;
    s->stats.solves++;
    if (change != PF_MATRIX_SAME)
        s->factor_current = false;
    bool direct = s->params.method == PF_SOLVER_DIRECT;
    bool trial = false; /* new terms on the old factor (PF_MATRIX_TERMS) */
    if (change == PF_MATRIX_TERMS) {
        trial = s->terms_skip == 0;
        s->terms_skip -= !trial;
        change = trial ? PF_MATRIX_DRIFTED : PF_MATRIX_NEW;
    }
    pf_status st = PF_OK;
    if (!s->have_factor || (direct && !s->factor_current) || s->refactor_due ||
        change == PF_MATRIX_NEW) {
        pf_refactor_reason why = !s->have_factor   ? PF_REFACTOR_FIRST
                                 : direct          ? PF_REFACTOR_CHANGED
                                 : s->refactor_due ? PF_REFACTOR_COST
                                                   : PF_REFACTOR_NEW;
        st = factor_system(s, a, why, failed_column, err);
    }
    if (st >= 0 && s->factor_current) {
        st = solve_exact(s, a, b, x, err);
        charge(s, s->stats.iteration_flops);
    } else if (st >= 0) {
        bool converged;
        int32_t limit = s->iteration_limit;
        if (trial) /* TRIAL_WORTH factorisations' worth (below), within max_iterations */
            s->iteration_limit = limit > s->params.max_iterations / TRIAL_WORTH
                                     ? s->params.max_iterations
                                     : TRIAL_WORTH * limit;
        st = iterate(s, a, b, x, failed_column, trial ? PF_REFACTOR_NEW : PF_REFACTOR_FAILED,
                     &converged, err);
        s->iteration_limit = limit;
        if (trial)
            note_terms_trial(s, converged);
    }
    /* solve time excludes the factorisations made on the way */
    s->stats.solve_seconds += pf_time_seconds() - t0 - (s->stats.factor_seconds - f0);
    s->stats.solve_cpu_seconds += pf_cpu_seconds() - c0 - (s->stats.factor_cpu_seconds - fc0);
    return st;
}

double pf_solver_last_residual(const pf_solver *s)
{
    return s->last_residual;
}

const pf_solver_stats *pf_solver_get_stats(const pf_solver *s)
{
    return &s->stats;
}
