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

/* Non-zeros in the factor, for statistics. */
int64_t pf_cholesky_factor_nnz(const pf_cholesky *c);

void pf_cholesky_destroy(pf_cholesky **c);

#ifdef __cplusplus
}
#endif
#endif
