/* The petsc method of the solver policy (petsc.c), private to libcore/solve: one distributed
 * system on PETSc, driven from rank 0 (pf/solve.h, "PETSc and MPI"). */
#ifndef PF_SOLVE_PETSC_H
#define PF_SOLVE_PETSC_H

#include <pf/solve.h>

typedef struct pf_petsc_solver pf_petsc_solver;

/* The distributed matrix with a's pattern (both triangles, COO), its vectors and the KSP:
 * conjugate gradients on the true residual to ||b - A x|| <= tolerance ||b||, GAMG, then
 * PETSc's options. Collective (rank 0 tells the serving ranks). PF_ERR_INVALID without PETSc. */
pf_status pf_petsc_solver_create(pf_petsc_solver **p, const pf_block_matrix *a, double tolerance,
                                 pf_error *err);
void pf_petsc_solver_destroy(pf_petsc_solver **p);

/* How the rows are distributed over parts ranks: a's blocks (pf_block_matrix) partitioned by
 * PETSc's MatPartitioning (PT-Scotch) on their coupling graph, whole blocks per part; count[r]
 * rows for part r, and row[i] the PETSc row of a's row i: part r's rows in a's order from
 * count[0] + ... + count[r - 1]. One part: the identity. Deterministic for a given matrix pattern
 * and parts. PF_ERR_INVALID without PETSc or for parts < 1. */
pf_status pf_petsc_partition_rows(const pf_block_matrix *a, int32_t parts, int64_t *row,
                                  int64_t *count, pf_error *err);

/* part[v] in [0, parts) for each of the n vertices of a graph (adjacency offsets [n + 1], adj:
 * both directions, no self loops), as pf_petsc_partition_rows partitions blocks: PT-Scotch on
 * this process alone, deterministic. */
pf_status pf_petsc_partition_graph(int32_t n, const int64_t *offsets, const int32_t *adj,
                                   int32_t parts, int64_t *part, pf_error *err);

#ifdef PF_HAVE_PETSC
#include <petscksp.h>
/* A PETSc call that failed (code pe, the call's text and where it is), collective or not: on one
 * rank the pf_error PF_ERR_NUMERIC naming it; on several, where the other ranks may be waiting
 * inside the same collective call (a failure on one rank would hang them), this rank prints that
 * message on stderr ("pf: rank r of n: ...") and ends every rank by MPI_Abort with code 1. */
pf_status pf_petsc_error(pf_error *err, int pe, const char *call, const char *file, int line);
/* A PETSc call in a function returning pf_status with a pf_error *err in scope: a nonzero
 * PetscErrorCode goes to pf_petsc_error and returns. PF_PETSC_TRY_TO: the same into st, skipping
 * the call once st is an error (the caller frees what it holds, then returns st). */
#define PF_PETSC_TRY(call)                                                                         \
    do {                                                                                           \
        PetscErrorCode pe_ = (call);                                                               \
        if (pe_)                                                                                   \
            return pf_petsc_error(err, (int)pe_, #call, __FILE__, __LINE__);                       \
    } while (0)
#define PF_PETSC_TRY_TO(st, call)                                                                  \
    do {                                                                                           \
        PetscErrorCode pe_ = (st) >= 0 ? (call) : 0;                                               \
        if (pe_)                                                                                   \
            (st) = pf_petsc_error(err, (int)pe_, #call, __FILE__, __LINE__);                       \
    } while (0)
/* The KSP every petsc solve uses on matrix a (collective): CG on the true residual to
 * tolerance, GAMG, nonzero initial guess, then PETSc's options. */
pf_status pf_petsc_create_ksp(Mat a, double tolerance, KSP *ksp, pf_error *err);
/* Modified Gram-Schmidt on k vectors (collective); PF_ERR_INVALID for a dependent one. */
pf_status pf_petsc_orthonormalise(Vec *v, int32_t k, pf_error *err);
#endif

/* GAMG's near-null space: k vectors [k][n], orthonormalised on the way. */
pf_status pf_petsc_solver_near_null_space(pf_petsc_solver *p, int32_t k, const double *vectors,
                                          pf_error *err);

/* Solves A x = b from the guess in x; values_changed: a's values differ from the last solve's
 * (they are sent again and the preconditioner rebuilt). *iterations and *residual (relative)
 * of the solve. PF_ERR_NUMERIC when the KSP diverged or stopped short, naming PETSc's reason. */
pf_status pf_petsc_solver_solve(pf_petsc_solver *p, const pf_block_matrix *a, bool values_changed,
                                const double *b, double *x, int32_t *iterations, double *residual,
                                pf_error *err);

#endif
