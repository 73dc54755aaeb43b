/* The petsc method (pf/solve.h): pf's block matrix handed to PETSc as a distributed AIJ matrix
 * and solved by conjugate gradients preconditioned with smoothed-aggregation algebraic multigrid
 * (KSPCG + PCGAMG), GAMG given the rigid modes as its near-null space, as PETSc recommends for
 * elasticity.
 *
 * Who does what. Rank 0 owns the simulation and the whole block matrix; every other rank only
 * serves (pf_petsc_serve). Each solver operation on rank 0 first broadcasts a command (what,
 * which solver, sizes), then both sides run the same collective body: rank 0 supplies all the
 * data (matrix entries in COO form, whose off-process entries PETSc's MatSetValuesCOO moves to
 * their owners; vectors scattered from rank 0's whole copy with the scatter of
 * VecScatterCreateToZero run in reverse), the others none.
 *
 * Rows are distributed by a graph partition of the matrix's blocks (pf_block_matrix: a DG
 * element's unknowns, or a CG node's three), made by PETSc's MatPartitioning with PT-Scotch on
 * rank 0: rank r owns the blocks of part r, numbered in PETSc in pf's order within each part, so
 * its rows are one contiguous range as PETSc requires; rank 0 keeps the map between pf's and
 * PETSc's row numbers and applies it to the COO indices and the vectors it scatters and gathers.
 *
 * The pattern is set once (MatSetPreallocationCOO, both triangles of pf's upper-triangle storage
 * expanded); a solve whose matrix changed sends the values again (MatSetValuesCOO), which makes
 * PETSc rebuild GAMG on the next KSPSolve. */
#define _DEFAULT_SOURCE /* on_exit: the exit code for the serving ranks */
#include "solve_petsc.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef PF_HAVE_PETSC

#include <petscksp.h>

/* PT-Scotch's (scotch.h), which PETSc's MatPartitioning runs: restarts its random generator from
 * its fixed seed. Declared here: scotch.h wants its own integer types and MPI set up first. */
void SCOTCH_randomReset(void);

enum command { CMD_EXIT = 0, CMD_CREATE, CMD_NULL_SPACE, CMD_SOLVE, CMD_DESTROY, CMD_TASK };

/* What rank 0 broadcasts before each collective body. */
typedef struct message {
    int64_t command, id;
    int64_t n;        /* CMD_CREATE: unknowns; CMD_NULL_SPACE: vectors; CMD_EXIT: exit code */
    int64_t changed;  /* CMD_SOLVE: new values come */
    double tolerance; /* CMD_CREATE */
} message;

/* One solver's PETSc objects, the same on every rank. */
typedef struct engine {
    int64_t id;
    PetscInt n;
    const int64_t *row; /* rank 0: [n] PETSc's row of each of pf's rows; NULL elsewhere */
    Mat a;
    KSP ksp;
    Vec x, b;           /* distributed */
    Vec whole;          /* rank 0: all n entries; elsewhere empty */
    VecScatter to_zero; /* distributed -> whole (reverse: whole -> distributed) */
    struct engine *next;
} engine;

struct pf_petsc_solver {
    engine e;
    int64_t *row;   /* [n] PETSc's row of pf's row (pf_petsc_partition_rows) */
    int64_t *count; /* [ranks] rows per rank */
    PetscCount n_coo;
    PetscScalar *coo_values; /* [n_coo] */
    bool values_pending;     /* changed values not yet sent (a solve with b = 0 skipped them) */
};

static int comm_rank(void)
{
    int r = 0;
    MPI_Comm_rank(PETSC_COMM_WORLD, &r);
    return r;
}

static int comm_size(void)
{
    int s = 1;
    MPI_Comm_size(PETSC_COMM_WORLD, &s);
    return s;
}

pf_status pf_petsc_error(pf_error *err, int pe, const char *call, const char *file, int line)
{
    pf_status st = pf_error_set(err, PF_ERR_NUMERIC, file, line, "PETSc error %d in %s", pe, call);
    if (comm_size() == 1)
        return st;
    fprintf(stderr, "pf: rank %d of %d: PETSc error %d in %s (%s:%d); ending every rank\n",
            comm_rank(), comm_size(), pe, call, file, line);
    fflush(stderr);
    MPI_Abort(PETSC_COMM_WORLD, 1);
    return st;
}

/* Rank 0 tells the serving ranks what comes. */
static void announce(message m)
{
    if (comm_size() > 1)
        MPI_Bcast(&m, (int)sizeof m, MPI_BYTE, 0, PETSC_COMM_WORLD);
}

/* ---- the collective bodies --------------------------------------------------------------- */

/* This rank's row count from rank 0's count [ranks] (unread elsewhere). */
static pf_status local_rows(const int64_t *count, PetscInt *local, pf_error *err)
{
    int64_t mine = count ? count[0] : 0;
    if (comm_size() > 1 && MPI_Scatter(count, 1, MPI_INT64_T, &mine, 1, MPI_INT64_T, 0,
                                       PETSC_COMM_WORLD) != MPI_SUCCESS)
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "MPI_Scatter of the row counts");
    *local = (PetscInt)mine;
    return PF_OK;
}

/* count: rank 0's rows per rank (NULL elsewhere); every count is a multiple of the block size
 * when n is (whole blocks of triples). */
static pf_status create_body(engine *e, PetscInt n, const int64_t *count, double tolerance,
                             PetscCount n_coo, PetscInt *coo_i, PetscInt *coo_j, pf_error *err)
{
    PetscInt bs = n % 3 == 0 ? 3 : 1, local = 0;
    PF_TRY(local_rows(count, &local, err));
    e->n = n;
    PF_PETSC_TRY(MatCreate(PETSC_COMM_WORLD, &e->a));
    PF_PETSC_TRY(MatSetSizes(e->a, local, local, n, n));
    PF_PETSC_TRY(MatSetType(e->a, MATAIJ));
    PF_PETSC_TRY(MatSetBlockSize(e->a, bs));
    PF_PETSC_TRY(MatSetFromOptions(e->a));
    PF_PETSC_TRY(MatSetPreallocationCOO(e->a, n_coo, coo_i, coo_j));
    PF_PETSC_TRY(MatCreateVecs(e->a, &e->x, &e->b));
    PF_PETSC_TRY(VecScatterCreateToZero(e->x, &e->to_zero, &e->whole));
    return pf_petsc_create_ksp(e->a, tolerance, &e->ksp, err);
}

pf_status pf_petsc_create_ksp(Mat a, double tolerance, KSP *ksp, pf_error *err)
{
    PF_PETSC_TRY(KSPCreate(PETSC_COMM_WORLD, ksp));
    PF_PETSC_TRY(KSPSetOperators(*ksp, a, a));
    PF_PETSC_TRY(KSPSetType(*ksp, KSPCG));
    PC pc;
    PF_PETSC_TRY(KSPGetPC(*ksp, &pc));
    PF_PETSC_TRY(PCSetType(pc, PCGAMG));
    /* the true residual, as the pcg method judges it; no absolute floor */
    PF_PETSC_TRY(KSPSetNormType(*ksp, KSP_NORM_UNPRECONDITIONED));
    PF_PETSC_TRY(KSPSetTolerances(*ksp, tolerance, 0.0, PETSC_DEFAULT, 10000));
    PF_PETSC_TRY(KSPSetInitialGuessNonzero(*ksp, PETSC_TRUE));
    PF_PETSC_TRY(KSPSetFromOptions(*ksp));
    return PF_OK;
}

static void destroy_body(engine *e)
{
    KSPDestroy(&e->ksp);
    MatDestroy(&e->a);
    VecDestroy(&e->x);
    VecDestroy(&e->b);
    VecDestroy(&e->whole);
    VecScatterDestroy(&e->to_zero);
}

/* dst (distributed) = src [n] on rank 0 (src unread elsewhere). */
static pf_status scatter_in(engine *e, const double *src, Vec dst, pf_error *err)
{
    if (comm_rank() == 0) {
        PetscScalar *w;
        PF_PETSC_TRY(VecGetArray(e->whole, &w));
        for (PetscInt i = 0; i < e->n; ++i)
            w[e->row[i]] = src[i];
        PF_PETSC_TRY(VecRestoreArray(e->whole, &w));
    }
    PF_PETSC_TRY(VecScatterBegin(e->to_zero, e->whole, dst, INSERT_VALUES, SCATTER_REVERSE));
    PF_PETSC_TRY(VecScatterEnd(e->to_zero, e->whole, dst, INSERT_VALUES, SCATTER_REVERSE));
    return PF_OK;
}

/* dst [n] on rank 0 = src (distributed). */
static pf_status gather(engine *e, Vec src, double *dst, pf_error *err)
{
    PF_PETSC_TRY(VecScatterBegin(e->to_zero, src, e->whole, INSERT_VALUES, SCATTER_FORWARD));
    PF_PETSC_TRY(VecScatterEnd(e->to_zero, src, e->whole, INSERT_VALUES, SCATTER_FORWARD));
    if (comm_rank() == 0) {
        const PetscScalar *w;
        PF_PETSC_TRY(VecGetArrayRead(e->whole, &w));
        for (PetscInt i = 0; i < e->n; ++i)
            dst[i] = w[e->row[i]];
        PF_PETSC_TRY(VecRestoreArrayRead(e->whole, &w));
    }
    return PF_OK;
}

/* Modified Gram-Schmidt; a vector that loses all but 1e-10 of its norm is dependent. */
pf_status pf_petsc_orthonormalise(Vec *v, int32_t k, pf_error *err)
{
    for (int32_t i = 0; i < k; ++i) {
        PetscReal before, after;
        PF_PETSC_TRY(VecNorm(v[i], NORM_2, &before));
        for (int32_t j = 0; j < i; ++j) {
            PetscScalar d;
            PF_PETSC_TRY(VecDot(v[i], v[j], &d));
            PF_PETSC_TRY(VecAXPY(v[i], -d, v[j]));
        }
        PF_PETSC_TRY(VecNorm(v[i], NORM_2, &after));
        PF_CHECK(after > 1e-10 * before, err, PF_ERR_INVALID,
                 "near-null space vector %d is a combination of the ones before it", (int)i);
        PF_PETSC_TRY(VecScale(v[i], 1.0 / after));
    }
    return PF_OK;
}

static pf_status null_space_body(engine *e, int32_t k, const double *vectors, pf_error *err)
{
    Vec *v = calloc((size_t)k + 1, sizeof *v);
    PF_CHECK(v, err, PF_ERR_NOMEM, "cannot allocate %d vectors", (int)k);
    pf_status st = PF_OK;
    int32_t made = 0;
    for (; st >= 0 && made < k; ++made) {
        if (VecDuplicate(e->x, &v[made]))
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__, "PETSc: VecDuplicate");
        else
            st =
                scatter_in(e, vectors ? vectors + (size_t)made * (size_t)e->n : NULL, v[made], err);
    }
    if (st >= 0)
        st = pf_petsc_orthonormalise(v, k, err);
    MatNullSpace space = NULL;
    if (st >= 0 && MatNullSpaceCreate(PETSC_COMM_WORLD, PETSC_FALSE, k, v, &space))
        st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__, "PETSc: MatNullSpaceCreate");
    if (st >= 0 && MatSetNearNullSpace(e->a, space))
        st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__, "PETSc: MatSetNearNullSpace");
    MatNullSpaceDestroy(&space);
    for (int32_t i = 0; i < made; ++i)
        VecDestroy(&v[i]);
    free(v);
    return st;
}

/* One solve; values: rank 0's COO values when they changed (NULL: unchanged; elsewhere any
 * non-NULL pointer marks the change). */
static pf_status solve_body(engine *e, const PetscScalar *values, const double *b, double *x,
                            KSPConvergedReason *reason, PetscInt *its, PetscReal *rnorm,
                            pf_error *err)
{
    if (values)
        PF_PETSC_TRY(MatSetValuesCOO(e->a, values, INSERT_VALUES));
    PF_TRY(scatter_in(e, b, e->b, err));
    PF_TRY(scatter_in(e, x, e->x, err));
    PF_PETSC_TRY(KSPSolve(e->ksp, e->b, e->x));
    PF_PETSC_TRY(KSPGetConvergedReason(e->ksp, reason));
    PF_PETSC_TRY(KSPGetIterationNumber(e->ksp, its));
    PF_PETSC_TRY(KSPGetResidualNorm(e->ksp, rnorm));
    return gather(e, e->x, x, err);
}

/* ---- the partition of the rows ------------------------------------------------------------ */

/* a's block graph, both directions and no self loops, in compressed rows allocated with
 * PetscMalloc (MatCreateMPIAdj takes them over). Rows come out sorted: block i receives its lower
 * neighbours from its own block column, then its higher ones in ascending column order. */
static pf_status block_graph(const pf_block_matrix *a, PetscInt **ia, PetscInt **ja, pf_error *err)
{
    PetscInt nb = a->n_blocks;
    PF_CHECK(2 * (a->adj_offsets[nb] - nb) < PETSC_MAX_INT, err, PF_ERR_TOO_LARGE,
             "%lld block couplings exceed PETSc's %d-bit indices",
             (long long)(a->adj_offsets[nb] - nb), (int)(8 * sizeof(PetscInt)));
    PetscInt edges = (PetscInt)(2 * (a->adj_offsets[nb] - nb)), *fill;
    PF_PETSC_TRY(PetscCalloc1(nb + 1, ia));
    PF_PETSC_TRY(PetscMalloc1(edges + 1, ja));
    PF_PETSC_TRY(PetscMalloc1(nb + 1, &fill));
    for (PetscInt j = 0; j < nb; ++j)
        for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1] - 1; ++k) {
            (*ia)[a->adj[k] + 1]++;
            (*ia)[j + 1]++;
        }
    for (PetscInt b = 0; b < nb; ++b)
        (*ia)[b + 1] += (*ia)[b];
    memcpy(fill, *ia, (size_t)nb * sizeof *fill);
    for (PetscInt j = 0; j < nb; ++j)
        for (int64_t k = a->adj_offsets[j]; k < a->adj_offsets[j + 1] - 1; ++k) {
            PetscInt i = a->adj[k];
            (*ja)[fill[j]++] = i;
            (*ja)[fill[i]++] = j;
        }
    PF_PETSC_TRY(PetscFree(fill));
    return PF_OK;
}

/* part[b] in [0, parts) for every vertex of the graph ia, ja (n vertices, PetscMalloc'd arrays
 * that this takes over): MatPartitioning on this process alone, PT-Scotch unless PETSc's options
 * (-mat_partitioning_type) say otherwise. Scotch's random generator is reset first, so the same
 * graph and part count give the same partition, whatever ran before. */
static pf_status graph_parts(PetscInt n, PetscInt *ia, PetscInt *ja, PetscInt parts, int64_t *part,
                             pf_error *err)
{
    Mat adj;
    MatPartitioning mp;
    IS is;
    const PetscInt *p;
    PF_PETSC_TRY(MatCreateMPIAdj(PETSC_COMM_SELF, n, n, ia, ja, NULL, &adj));
    PF_PETSC_TRY(MatPartitioningCreate(PETSC_COMM_SELF, &mp));
    PF_PETSC_TRY(MatPartitioningSetAdjacency(mp, adj));
    PF_PETSC_TRY(MatPartitioningSetNParts(mp, parts));
    PF_PETSC_TRY(MatPartitioningSetType(mp, MATPARTITIONINGPTSCOTCH));
    PF_PETSC_TRY(MatPartitioningSetFromOptions(mp));
    SCOTCH_randomReset();
    PF_PETSC_TRY(MatPartitioningApply(mp, &is));
    PF_PETSC_TRY(ISGetIndices(is, &p));
    pf_status st = PF_OK;
    for (PetscInt b = 0; b < n && st >= 0; ++b) {
        part[b] = p[b];
        if (p[b] < 0 || p[b] >= parts)
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the partitioner put vertex %d in part %d of %d", (int)b, (int)p[b],
                              (int)parts);
    }
    PF_PETSC_TRY(ISRestoreIndices(is, &p));
    PF_PETSC_TRY(ISDestroy(&is));
    PF_PETSC_TRY(MatPartitioningDestroy(&mp));
    PF_PETSC_TRY(MatDestroy(&adj)); /* frees ia and ja */
    return st;
}

static pf_status block_parts(const pf_block_matrix *a, PetscInt parts, int64_t *part, pf_error *err)
{
    PetscInt *ia = NULL, *ja = NULL;
    PF_TRY(block_graph(a, &ia, &ja, err));
    return graph_parts(a->n_blocks, ia, ja, parts, part, err);
}

pf_status pf_petsc_partition_graph(int32_t n, const int64_t *offsets, const int32_t *adj,
                                   int32_t parts, int64_t *part, pf_error *err)
{
    PF_CHECK(parts >= 1, err, PF_ERR_INVALID, "%d parts", (int)parts);
    if (parts == 1 || n == 0) {
        memset(part, 0, (size_t)n * sizeof *part);
        return PF_OK;
    }
    PF_CHECK(offsets[n] < PETSC_MAX_INT, err, PF_ERR_TOO_LARGE,
             "%lld graph edges exceed PETSc's %d-bit indices", (long long)offsets[n],
             (int)(8 * sizeof(PetscInt)));
    PetscInt *ia, *ja;
    PF_PETSC_TRY(PetscMalloc1(n + 1, &ia));
    PF_PETSC_TRY(PetscMalloc1(offsets[n] + 1, &ja));
    for (int32_t v = 0; v <= n; ++v)
        ia[v] = (PetscInt)offsets[v];
    for (int64_t q = 0; q < offsets[n]; ++q)
        ja[q] = adj[q];
    return graph_parts(n, ia, ja, parts, part, err);
}

pf_status pf_petsc_partition_rows(const pf_block_matrix *a, int32_t parts, int64_t *row,
                                  int64_t *count, pf_error *err)
{
    PF_CHECK(parts >= 1, err, PF_ERR_INVALID, "%d parts", (int)parts);
    int64_t *part = pf_alloc_array((size_t)a->n_blocks + 1, sizeof *part);
    int64_t *next = pf_alloc_array((size_t)parts, sizeof *next);
    pf_status st = part && next ? PF_OK
                                : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                               "cannot partition %d blocks", (int)a->n_blocks);
    if (st >= 0 && parts > 1)
        st = block_parts(a, parts, part, err);
    else if (st >= 0)
        memset(part, 0, (size_t)a->n_blocks * sizeof *part);
    if (st >= 0) {
        memset(count, 0, (size_t)parts * sizeof *count);
        for (int32_t b = 0; b < a->n_blocks; ++b)
            count[part[b]] += a->block_start[b + 1] - a->block_start[b];
        int64_t at = 0;
        for (int32_t r = 0; r < parts; at += count[r++])
            next[r] = at;
        for (int32_t b = 0; b < a->n_blocks; ++b)
            for (int64_t i = a->block_start[b]; i < a->block_start[b + 1]; ++i)
                row[i] = next[part[b]]++;
    }
    pf_free(part);
    pf_free(next);
    return st;
}

/* ---- rank 0's side ----------------------------------------------------------------------- */

/* The COO list of a's full symmetric matrix: each stored upper entry (r, c) as (r, c) and, off
 * the diagonal, (c, r), in storage order. */
static PetscCount coo_count(const pf_block_matrix *a)
{
    PetscCount n = 0;
    for (int64_t c = 0; c < a->n; ++c)
        for (int64_t p = a->col_ptr[c]; p < a->col_ptr[c + 1]; ++p)
            n += a->row_idx[p] == c ? 1 : 2;
    return n;
}

static void coo_values(const pf_block_matrix *a, PetscScalar *v)
{
    PetscCount q = 0;
    for (int64_t c = 0; c < a->n; ++c)
        for (int64_t p = a->col_ptr[c]; p < a->col_ptr[c + 1]; ++p) {
            v[q++] = a->val[p];
            if (a->row_idx[p] != c)
                v[q++] = a->val[p];
        }
}

pf_status pf_petsc_solver_create(pf_petsc_solver **out, const pf_block_matrix *a, double tolerance,
                                 pf_error *err)
{
    *out = NULL;
    PetscBool up = PETSC_FALSE;
    PetscInitialized(&up);
    if (!up)
        PF_TRY(pf_petsc_initialize(NULL, NULL, NULL, NULL, err));
    PF_CHECK(comm_rank() == 0, err, PF_ERR_INVALID, "petsc solvers are made on rank 0 only");
    PF_CHECK(a->n < PETSC_MAX_INT, err, PF_ERR_TOO_LARGE,
             "%lld unknowns exceed PETSc's %d-bit indices", (long long)a->n,
             (int)(8 * sizeof(PetscInt)));
    pf_petsc_solver *p = pf_calloc(1, sizeof *p);
    PF_CHECK(p, err, PF_ERR_NOMEM, "cannot allocate a petsc solver");
    p->n_coo = coo_count(a);
    size_t m = (size_t)p->n_coo + 1;
    PetscInt *ci = pf_alloc_array(m, sizeof *ci), *cj = pf_alloc_array(m, sizeof *cj);
    p->coo_values = pf_alloc_array(m, sizeof *p->coo_values);
    p->row = pf_alloc_array((size_t)a->n + 1, sizeof *p->row);
    p->count = pf_alloc_array((size_t)comm_size(), sizeof *p->count);
    if (!ci || !cj || !p->coo_values || !p->row || !p->count) {
        pf_free(ci);
        pf_free(cj);
        pf_petsc_solver_destroy(&p);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %lld matrix entries for PETSc", (long long)m);
    }
    pf_status st = pf_petsc_partition_rows(a, comm_size(), p->row, p->count, err);
    if (st < 0) {
        pf_free(ci);
        pf_free(cj);
        pf_petsc_solver_destroy(&p);
        return st;
    }
    PetscCount q = 0;
    for (int64_t c = 0; c < a->n; ++c)
        for (int64_t k = a->col_ptr[c]; k < a->col_ptr[c + 1]; ++k) {
            PetscInt r = (PetscInt)p->row[a->row_idx[k]], pc = (PetscInt)p->row[c];
            ci[q] = r;
            cj[q++] = pc;
            if (r != pc) {
                ci[q] = pc;
                cj[q++] = r;
            }
        }
    p->e.id = (int64_t)(uintptr_t)p;
    p->e.row = p->row;
    announce((message){.command = CMD_CREATE, .id = p->e.id, .n = a->n, .tolerance = tolerance});
    st = create_body(&p->e, (PetscInt)a->n, p->count, tolerance, p->n_coo, ci, cj, err);
    pf_free(ci);
    pf_free(cj);
    if (st < 0)
        pf_petsc_solver_destroy(&p);
    *out = p;
    return st;
}

void pf_petsc_solver_destroy(pf_petsc_solver **pp)
{
    pf_petsc_solver *p = *pp;
    if (!p)
        return;
    if (p->e.id) { /* announced: the serving ranks hold its engine */
        announce((message){.command = CMD_DESTROY, .id = p->e.id});
        destroy_body(&p->e);
    }
    pf_free(p->coo_values);
    pf_free(p->row);
    pf_free(p->count);
    pf_free(p);
    *pp = NULL;
}

pf_status pf_petsc_solver_near_null_space(pf_petsc_solver *p, int32_t k, const double *vectors,
                                          pf_error *err)
{
    announce((message){.command = CMD_NULL_SPACE, .id = p->e.id, .n = k});
    return null_space_body(&p->e, k, vectors, err);
}

static const char *reason_text(KSPConvergedReason r)
{
    return r < 0 && r >= -11 ? KSPConvergedReasons[r] : "unknown";
}

pf_status pf_petsc_solver_solve(pf_petsc_solver *p, const pf_block_matrix *a, bool values_changed,
                                const double *b, double *x, int32_t *iterations, double *residual,
                                pf_error *err)
{
    *iterations = 0;
    double bnorm = 0;
    for (int64_t k = 0; k < a->n; ++k)
        bnorm += b[k] * b[k];
    if (bnorm == 0) { /* x = 0 exactly, without PETSc */
        memset(x, 0, (size_t)a->n * sizeof *x);
        *residual = 0;
        p->values_pending |= values_changed;
        return PF_OK;
    }
    values_changed |= p->values_pending;
    p->values_pending = false;
    if (values_changed)
        coo_values(a, p->coo_values);
    announce((message){.command = CMD_SOLVE, .id = p->e.id, .changed = values_changed});
    KSPConvergedReason reason = KSP_CONVERGED_ITERATING;
    PetscInt its = 0;
    PetscReal rnorm = 0;
    PF_TRY(
        solve_body(&p->e, values_changed ? p->coo_values : NULL, b, x, &reason, &its, &rnorm, err));
    *iterations = (int32_t)its;
    *residual = bnorm > 0 ? rnorm / sqrt(bnorm) : 0;
    PF_CHECK(reason > 0, err, PF_ERR_NUMERIC,
             "PETSc's KSP stopped without converging (%s) after %d iterations, residual %.3g "
             "relative to the right-hand side",
             reason_text(reason), (int)its, *residual);
    return PF_OK;
}

/* ---- initialisation, the serving ranks, the end ------------------------------------------ */

bool pf_petsc_available(void)
{
    return true;
}

void pf_petsc_start_task(void)
{
    announce((message){.command = CMD_TASK});
}

/* Rank 0 left without pf_petsc_finalize (an error ended the program): the others stop too, with
 * rank 0's exit code where the C library tells it (glibc's on_exit), else 1. */
#ifdef __GLIBC__
static void exit_handler(int code, void *unused)
{
    (void)unused;
    pf_petsc_finalize(code);
}
#else
static void exit_handler(void)
{
    pf_petsc_finalize(1);
}
#endif

pf_status pf_petsc_initialize(int *argc, char ***argv, int *rank, int *size, pf_error *err)
{
    PetscBool up = PETSC_FALSE;
    PetscInitialized(&up);
    if (!up) {
        PetscErrorCode pe =
            argc && argv ? PetscInitialize(argc, argv, NULL, NULL) : PetscInitializeNoArguments();
        PF_CHECK(pe == 0, err, PF_ERR_INVALID, "PETSc failed to initialise (error %d)", (int)pe);
        PETSC_STDOUT = stderr; /* stdout carries the pf stream */
        if (comm_rank() == 0) {
#ifdef __GLIBC__
            on_exit(exit_handler, NULL);
#else
            atexit(exit_handler);
#endif
        }
    }
    if (rank)
        *rank = comm_rank();
    if (size)
        *size = comm_size();
    return PF_OK;
}

pf_status pf_petsc_serve(pf_petsc_task_fn task, int *exit_code, pf_error *err)
{
    *exit_code = 1;
    PF_CHECK(PetscInitializeCalled && !PetscFinalizeCalled, err, PF_ERR_INVALID,
             "pf_petsc_serve before pf_petsc_initialize");
    PF_CHECK(comm_rank() != 0, err, PF_ERR_INVALID, "rank 0 drives the solvers, it cannot serve");
    engine *list = NULL;
    pf_status st = PF_OK;
    for (;;) {
        message m;
        if (MPI_Bcast(&m, (int)sizeof m, MPI_BYTE, 0, PETSC_COMM_WORLD) != MPI_SUCCESS) {
            st = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "lost rank 0");
            break;
        }
        if (m.command == CMD_EXIT) {
            *exit_code = (int)m.n;
            break;
        }
        pf_error ignored = {0};
        if (m.command == CMD_TASK) { /* its failure is rank 0's to report, like a body's */
            if (task)
                task(&ignored);
            continue;
        }
        engine **at = &list;
        while (*at && (*at)->id != m.id)
            at = &(*at)->next;
        engine *e = *at;
        /* A body that fails here fails alike on rank 0 (the same collective calls on the same
         * data), which reports it; this rank keeps serving. */
        if (m.command == CMD_CREATE) {
            e = calloc(1, sizeof *e);
            if (!e) {
                st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
                MPI_Abort(PETSC_COMM_WORLD, 1);
            }
            e->id = m.id;
            e->next = list;
            list = e;
            create_body(e, (PetscInt)m.n, NULL, m.tolerance, 0, NULL, NULL, &ignored);
        } else if (!e) {
            continue; /* a solver whose creation failed on rank 0 before it was announced */
        } else if (m.command == CMD_NULL_SPACE) {
            null_space_body(e, (int32_t)m.n, NULL, &ignored);
        } else if (m.command == CMD_SOLVE) {
            static const PetscScalar none = 0;
            KSPConvergedReason reason;
            PetscInt its;
            PetscReal rnorm;
            solve_body(e, m.changed ? &none : NULL, NULL, NULL, &reason, &its, &rnorm, &ignored);
        } else if (m.command == CMD_DESTROY) {
            *at = e->next;
            destroy_body(e);
            free(e);
        }
    }
    while (list) {
        engine *next = list->next;
        destroy_body(list);
        free(list);
        list = next;
    }
    PetscFinalize();
    return st;
}

void pf_petsc_finalize(int exit_code)
{
    if (!PetscInitializeCalled || PetscFinalizeCalled)
        return;
    if (comm_rank() == 0)
        announce((message){.command = CMD_EXIT, .n = exit_code});
    PetscFinalize();
}

#else /* without PETSc */

bool pf_petsc_available(void)
{
    return false;
}

pf_status pf_petsc_initialize(int *argc, char ***argv, int *rank, int *size, pf_error *err)
{
    (void)argc, (void)argv, (void)err;
    if (rank)
        *rank = 0;
    if (size)
        *size = 1;
    return PF_OK;
}

static pf_status not_built(pf_error *err)
{
    return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                        "this pf was built without PETSc: configure with -DPF_PETSC=ON after "
                        "scripts/setup --petsc");
}

pf_status pf_petsc_serve(pf_petsc_task_fn task, int *exit_code, pf_error *err)
{
    (void)task;
    *exit_code = 1;
    return not_built(err);
}

void pf_petsc_start_task(void) {}

pf_status pf_petsc_partition_graph(int32_t n, const int64_t *offsets, const int32_t *adj,
                                   int32_t parts, int64_t *part, pf_error *err)
{
    (void)n, (void)offsets, (void)adj, (void)parts, (void)part;
    return not_built(err);
}

void pf_petsc_finalize(int exit_code)
{
    (void)exit_code;
}

pf_status pf_petsc_partition_rows(const pf_block_matrix *a, int32_t parts, int64_t *row,
                                  int64_t *count, pf_error *err)
{
    (void)a, (void)parts, (void)row, (void)count;
    return not_built(err);
}

pf_status pf_petsc_solver_create(pf_petsc_solver **p, const pf_block_matrix *a, double tolerance,
                                 pf_error *err)
{
    (void)a, (void)tolerance;
    *p = NULL;
    return not_built(err);
}

void pf_petsc_solver_destroy(pf_petsc_solver **p)
{
    *p = NULL;
}

pf_status pf_petsc_solver_near_null_space(pf_petsc_solver *p, int32_t k, const double *vectors,
                                          pf_error *err)
{
    (void)p, (void)k, (void)vectors;
    return not_built(err);
}

pf_status pf_petsc_solver_solve(pf_petsc_solver *p, const pf_block_matrix *a, bool values_changed,
                                const double *b, double *x, int32_t *iterations, double *residual,
                                pf_error *err)
{
    (void)p, (void)a, (void)values_changed, (void)b, (void)x, (void)residual;
    *iterations = 0;
    return not_built(err);
}

#endif
