/* pf/solve.h: sparse symmetric matrices assembled from dense blocks, and their Cholesky solves.
 *
 * Both methods produce a symmetric matrix made of dense blocks: DG couples the basis functions of
 * two elements sharing a face, CG the three components of two nodes sharing an element. The block
 * coupling is fixed by the topology, so it is analysed once (pf_block_matrix_create): the sparsity
 * pattern, the position of every block in the value array (the scatter map), and CHOLMOD's fill-
 * reducing ordering and symbolic factorisation (pf_cholesky_create). Each step then only zeroes the
 * values, adds dense blocks at precomputed positions and refactors numerically when the values
 * changed.
 *
 * Storage is the upper triangle in compressed columns, rows sorted, exactly as CHOLMOD's stype = 1
 * wants it, so the factorisation reads the values in place. */
#ifndef PF_SOLVE_H
#define PF_SOLVE_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== block matrices ========================================================================== */

/* A symmetric matrix of n_blocks x n_blocks dense blocks; block b covers unknowns
 * [block_start[b], block_start[b + 1]). Only coupled pairs (i, j) are stored: those given to
 * pf_block_matrix_create, and every diagonal block. */
typedef struct pf_block_matrix {
    int32_t n_blocks;
    int64_t n;            /* unknowns: block_start[n_blocks] */
    int64_t *block_start; /* [n_blocks + 1] */
    /* Block column j couples with the blocks adj[adj_offsets[j] .. adj_offsets[j + 1]), sorted
     * ascending, all <= j, the last one j itself. adj_row[k] is where block adj[k]'s rows start
     * within each column of block j (counted from the column's first stored entry). */
    int64_t *adj_offsets; /* [n_blocks + 1] */
    int32_t *adj;         /* [adj_offsets[n_blocks]] */
    int64_t *adj_row;     /* [adj_offsets[n_blocks]] */
    /* The upper triangle in compressed sparse columns (CHOLMOD's SuiteSparse_long indices). */
    int64_t *col_ptr; /* [n + 1] */
    int64_t *row_idx; /* [col_ptr[n]] */
    double *val;      /* [col_ptr[n]] */
} pf_block_matrix;

/* Builds the pattern: block sizes block_size[n_blocks] (> 0), and n_pairs coupled block pairs
 * pairs[2 k], pairs[2 k + 1] in any order, repeated or not (i = j is allowed and implied anyway).
 * Values are zero. A zeroed or released first. PF_ERR_INVALID for a bad size or block index,
 * PF_ERR_TOO_LARGE beyond 2^31 unknowns or 2^40 entries, PF_ERR_NOMEM. */
pf_status pf_block_matrix_create(pf_block_matrix *a, int32_t n_blocks, const int32_t *block_size,
                                 int64_t n_pairs, const int32_t *pairs, pf_error *err);
void pf_block_matrix_release(pf_block_matrix *a);

/* The adjacency slot of the pair (i, j) in any order (the k with adj[k] = min(i, j) within block
 * column max(i, j)), or -1 when the pair is not stored. A binary search: callers that add the same
 * block every step look the slot up once and keep it (the scatter map). */
int64_t pf_block_matrix_slot(const pf_block_matrix *a, int32_t i, int32_t j);

/* Sets every value to zero (the pattern stays). */
void pf_block_matrix_zero(pf_block_matrix *a);

/* Adds the dense block b (row-major, size(i) x size(j), row stride ld >= size(j)) to the block
 * (i, j) whose slot is given: the matrix gains b at (i, j) and b^T at (j, i). For i = j only the
 * upper triangle of b is read (b is taken as symmetric). */
void pf_block_matrix_add(pf_block_matrix *a, int64_t slot, int32_t i, int32_t j, const double *b,
                         int64_t ld);

/* Adds the 3 x 3 matrix m (row-major) at rows ri .. ri + 2 and columns cj .. cj + 2, ri <= cj,
 * rows in block bi, columns in a block coupled with bi at the given slot (its transpose at the
 * mirrored place comes with it: only the upper triangle is stored). For ri = cj, m is taken as
 * symmetric and its upper triangle read. */
void pf_block_matrix_add_3x3(pf_block_matrix *a, int64_t slot, int32_t bi, int64_t ri, int64_t cj,
                             const double m[9]);

/* Adds d[k] to the diagonal entry of every unknown k (d [n]); d = NULL adds nothing. */
void pf_block_matrix_add_diagonal(pf_block_matrix *a, const double *d);

/* y = alpha A x + beta y, with A the full symmetric matrix (x, y [n], not aliased). */
void pf_block_matrix_mul(const pf_block_matrix *a, double alpha, const double *x, double beta,
                         double *y);

/* Entry (r, c) of the full symmetric matrix, 0 when it is not stored (tests, debugging). */
double pf_block_matrix_get(const pf_block_matrix *a, int64_t r, int64_t c);

/* ==== sparse Cholesky (CHOLMOD) =============================================================== */

typedef struct pf_cholesky pf_cholesky;

/* Analyses the pattern of a (ordering and symbolic factorisation): once per topology. */
pf_status pf_cholesky_create(pf_cholesky **c, const pf_block_matrix *a, pf_error *err);

/* Numeric factorisation of a's current values (a must have the pattern c was created with).
 * PF_ERR_NUMERIC "not positive definite (pivot k)" when a is not, with *failed_column set to that
 * unknown when failed_column is not NULL; PF_ERR_NOMEM. */
pf_status pf_cholesky_factor(pf_cholesky *c, const pf_block_matrix *a, int64_t *failed_column,
                             pf_error *err);

/* Solves A x = b with the last successful factorisation (b, x [n]; may alias). PF_ERR_INVALID
 * before any factorisation succeeded. */
pf_status pf_cholesky_solve(pf_cholesky *c, const double *b, double *x, pf_error *err);

/* x ~ A^-1 b with the last successful factorisation in single precision (its values copied the
 * first time after each factorisation; b, x [n], may alias): a preconditioner's solve, about 20%
 * faster than pf_cholesky_solve on the beams of bench_solver (half the bytes of factor to read),
 * relative error about 1e-7 times A's condition. The double solve stands in when a value does
 * not fit in single precision or the factor is not supernodal. The copy costs half the factor's
 * memory again. PF_ERR_INVALID before any factorisation succeeded. */
pf_status pf_cholesky_precondition(pf_cholesky *c, const double *b, double *x, pf_error *err);

/* Non-zeros in the factor, for statistics. */
int64_t pf_cholesky_factor_nnz(const pf_cholesky *c);

/* Floating-point operations of one numeric factorisation, as CHOLMOD's analysis counts them
 * (deterministic: the solver policy compares costs with it, never with clocks). */
double pf_cholesky_factor_flops(const pf_cholesky *c);

void pf_cholesky_destroy(pf_cholesky **c);

/* ==== the solver policy ======================================================================
 * A sequence of symmetric positive definite systems A_k x = b_k on one pattern (a simulation's
 * steps; A's values may change between solves). Methods:
 *   direct  the reference: factorise whenever the caller says the matrix changed.
 *   pcg     conjugate gradients on the current A, preconditioned by the most recent factor
 *           (in the congruence that gives it the current A's 3 x 3 diagonal blocks when the
 *           unknowns come in triples of one block: solver.c), warm-started from x's value on
 *           entry. A new factorisation happens when the last
 *           solve cost more than the average solve since the last factorisation, that
 *           factorisation included (costs counted in flops from CHOLMOD's analysis, so the
 *           decision is deterministic), when the matrix gained or lost terms (PF_MATRIX_NEW: a
 *           contact set that changed), or when PCG fails.
 *   auto    direct when the matrix never changes or a factorisation costs at most ten
 *           iterations; pcg otherwise.
 *   petsc   PETSc (builds with -DPF_PETSC=ON): conjugate gradients preconditioned by smoothed-
 *           aggregation algebraic multigrid (KSPCG + PCGAMG) on a matrix distributed over the
 *           MPI ranks, given the near-null space pf_solver_set_near_null_space sets (the rigid
 *           modes); PETSc's options database (-ksp_*, -pc_*, PETSC_OPTIONS) tunes or replaces
 *           it (-pc_type lu -pc_factor_mat_solver_type mumps). The matrix and vectors live on
 *           rank 0 of the caller and are handed to PETSc whole (see pf_petsc_serve).
 * Every decision depends on the inputs only: the same sequence of systems gives the same bits. */

typedef enum pf_solver_method {
    PF_SOLVER_AUTO = 0,
    PF_SOLVER_DIRECT = 1,
    PF_SOLVER_PCG = 2,
    PF_SOLVER_PETSC = 3,
} pf_solver_method;

/* "auto", "direct", "pcg", "petsc"; pf_solver_method_parse returns false for another name
 * (petsc parses in every build; pf_solver_create refuses it without PETSc). */
const char *pf_solver_method_name(pf_solver_method m);
bool pf_solver_method_parse(const char *name, pf_solver_method *m);

typedef struct pf_solver_params {
    pf_solver_method method;   /* default auto */
    double tolerance;          /* PCG (and petsc's CG) stops at ||b - A x|| <= tolerance ||b||
                                  (default 1e-10) */
    int32_t max_iterations;    /* PCG iterations of one solve before it gives up on a factor and
                                  refactorises (default 200; fewer when a factorisation costs
                                  less than that many iterations) */
    pf_progress_hook progress; /* the phases "symbolic analysis" (in pf_solver_create) and
                                  "numeric factorisation" (each, also pf_solver_factor's),
                                  each reported at its start and end only (total 1); borrowed
                                  for the solver's life; zero: none */
} pf_solver_params;

pf_solver_params pf_solver_params_default(void);

/* How the matrix differs from the previous solve's: not at all; by a drift of its values (the
 * rotations of a corotated step); wholly (pcg refactorises); or by terms that appeared or
 * vanished (contacts came or went). For the last, pcg tries the old factor first while such
 * trials converge: in the congruence (pcg above) a contact's stiff terms on the diagonal cost
 * PCG a few iterations, whether rank one or spread over many unknowns (a surface vertex moved
 * by MLS weights); stiff couplings between many unknowns more. A trial may spend two
 * factorisations' worth of iterations (solver.c, TRIAL_WORTH). After a failed trial the next
 * changes of terms refactorise at once, 1, 2, 4 ... up to 32 of them, before the old factor is
 * tried again. */
typedef enum pf_matrix_change {
    PF_MATRIX_SAME = 0,
    PF_MATRIX_DRIFTED = 1,
    PF_MATRIX_NEW = 2,
    PF_MATRIX_TERMS = 3,
} pf_matrix_change;

/* Why a factorisation happened. */
typedef enum pf_refactor_reason {
    PF_REFACTOR_FIRST = 0,   /* no factor of the system yet */
    PF_REFACTOR_CHANGED = 1, /* direct: the matrix changed */
    PF_REFACTOR_COST = 2,    /* pcg: the iterations since the last one outweighed it */
    PF_REFACTOR_FAILED = 3,  /* pcg: no convergence (or breakdown) with the old factor */
    PF_REFACTOR_OTHER = 4,   /* a factorisation of another matrix (pf_solver_factor) */
    PF_REFACTOR_NEW = 5,     /* pcg: PF_MATRIX_NEW, or PF_MATRIX_TERMS at once or after the
                                old factor failed on the new terms */
    PF_REFACTOR_REASONS = 6,
} pf_refactor_reason;

/* "first", "changed", "cost", "pcg-failed", "other", "new-terms". */
const char *pf_refactor_reason_name(pf_refactor_reason r);

typedef struct pf_solver_stats {
    pf_solver_method method; /* as resolved (never auto) */
    int64_t solves;
    int64_t factorisations;
    int64_t by_reason[PF_REFACTOR_REASONS];
    int64_t pcg_solves;     /* solves that iterated (on a factor of an earlier matrix), also
                               those that gave up and refactorised */
    int64_t iterations;     /* PCG iterations, all solves */
    int32_t max_iterations; /* the most of one solve */
    int64_t matrix_nnz;     /* stored (upper) entries */
    int64_t factor_nnz;
    double factor_flops, iteration_flops; /* the cost model's units (solver.c) */
    double factor_iterations;             /* a factorisation's cost in iterations */
    double factor_seconds, solve_seconds; /* wall */
    double factor_cpu_seconds, solve_cpu_seconds;
} pf_solver_stats;

typedef struct pf_solver pf_solver;

/* Analyses a's pattern (values unused). matrix_changes: whether the caller's matrix will change
 * between solves (for auto). params NULL: the defaults. PF_ERR_INVALID for a tolerance outside
 * (0, 1) or max_iterations < 1; the statuses of pf_cholesky_create. */
pf_status pf_solver_create(pf_solver **s, const pf_block_matrix *a, const pf_solver_params *params,
                           bool matrix_changes, pf_error *err);
void pf_solver_destroy(pf_solver **s);

/* Solves A x = b, A = a's current values (a's pattern the analysed one). change: how a's values
 * differ from the previous solve's. x holds the initial guess on entry (PCG's warm start) and
 * the solution on return; b [n], not aliased with x. A PCG solve that fails on an old factor
 * (max_iterations, or a factorisation's worth of iterations, reached; or a breakdown) is redone
 * exactly on a fresh factor and counted as such (PF_REFACTOR_FAILED). Errors: PF_ERR_NUMERIC
 * "matrix not positive definite" with *failed_column (may be NULL) the unknown whose pivot
 * failed, or for a non-finite result; PF_ERR_NOMEM. */
pf_status pf_solver_solve(pf_solver *s, const pf_block_matrix *a, pf_matrix_change change,
                          const double *b, double *x, int64_t *failed_column, pf_error *err);

/* Factorises a itself (a matrix on the analysed pattern that is not the system's, e.g. a
 * definiteness test): the next solve factorises again. Statuses as pf_cholesky_factor. */
pf_status pf_solver_factor(pf_solver *s, const pf_block_matrix *a, int64_t *failed_column,
                           pf_error *err);

/* The near-null space of the systems to come: k vectors [k][n] (row-major; copied), for the
 * petsc method's multigrid (the simulator gives the six rigid modes of its unknowns); ignored by
 * the others. Any k >= 0 linearly independent vectors; they are orthonormalised. PF_ERR_INVALID
 * for k < 0 or dependent vectors, PETSc's failures as PF_ERR_NUMERIC. */
pf_status pf_solver_set_near_null_space(pf_solver *s, int32_t k, const double *vectors,
                                        pf_error *err);

/* The rotation of every unknown triple (unknowns 3 t .. 3 t + 2 a 3-vector) in the coming
 * solve's matrix, rot [n / 3][9] row-major (copied), or NULL for none: a corotated matrix whose
 * triples turned by R since the factor's were at R_f is close to Q A_f Q^T, Q = R R_f^T per
 * triple, so pcg preconditions with Q A_f^-1 Q^T (the warp). Solves without rotations, and
 * factors made without them, precondition with A_f^-1 alone: give none while terms that do not
 * turn with the body (contact with an obstacle) are stiff in the matrix. PF_ERR_NOMEM. */
pf_status pf_solver_set_rotations(pf_solver *s, const double *rot, pf_error *err);

/* Forgets the factor (the next solve factorises) and the back-off of PF_MATRIX_TERMS: after a
 * failed step whose state was undone, and at a checkpoint's restart point. */
void pf_solver_reset(pf_solver *s);
/* Replaces the progress hook of the params (NULL or zero: none; borrowed, as there). */
void pf_solver_set_progress(pf_solver *s, const pf_progress_hook *progress);

/* The residual ||b - A x|| / ||b|| of the last solve (0 for b = 0). */
double pf_solver_last_residual(const pf_solver *s);

const pf_solver_stats *pf_solver_get_stats(const pf_solver *s);

/* ==== PETSc and MPI ==========================================================================
 * An MPI run (mpirun -n N prog) where one process, rank 0, does everything but the linear
 * algebra: it reads, assembles and writes as a one-process run does, and its petsc solvers hand
 * each matrix and right-hand side to PETSc, which distributes them over all ranks (whole blocks
 * of the pf_block_matrix, grouped by a PT-Scotch partition of their couplings) and solves there.
 * The other ranks only serve: pf_petsc_serve runs the collective half of every solver call rank 0
 * makes, until rank 0 finalises. */

/* Whether this libpf was built with PETSc (-DPF_PETSC=ON). */
bool pf_petsc_available(void);

/* Initialises MPI and PETSc once per process (argc and argv may be NULL; PETSc reads its
 * options from them and from PETSC_OPTIONS) and gives this process's rank and the number of
 * ranks. PETSc's standard output goes to stderr (stdout carries pf streams). Rank 0 registers
 * an exit handler that stops the other ranks with its exit code if the process exits before
 * pf_petsc_finalize. Without PETSc: rank 0 of 1, nothing else. PF_ERR_INVALID when PETSc
 * cannot start. */
pf_status pf_petsc_initialize(int *argc, char ***argv, int *rank, int *size, pf_error *err);

/* A collective task besides the solvers (the distributed assembly, pf_sim_distrib_static), run
 * by the serving ranks when rank 0 calls pf_petsc_start_task. Its status is rank 0's to report:
 * the task must fail alike on every rank. */
typedef pf_status (*pf_petsc_task_fn)(pf_error *err);

/* Ranks > 0: serves rank 0's petsc solvers and tasks (task: NULL for none) until rank 0 calls
 * pf_petsc_finalize (or exits), then finalises PETSc and returns with *exit_code the code rank 0
 * gave. PF_ERR_INVALID on rank 0, or without PETSc. */
pf_status pf_petsc_serve(pf_petsc_task_fn task, int *exit_code, pf_error *err);

/* Rank 0 (or a one-process run): tells the serving ranks to stop with exit_code and finalises
 * PETSc and MPI. Every petsc solver must be destroyed first. Nothing when PETSc was not
 * initialised. */
void pf_petsc_finalize(int exit_code);

/* Rank 0: the serving ranks run their task (pf_petsc_serve) now. Nothing without PETSc. */
void pf_petsc_start_task(void);

#ifdef __cplusplus
}
#endif
#endif
