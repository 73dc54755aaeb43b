/* The distributed matrix of the parts (sim_distrib.h): which entries each rank sends PETSc, the
 * matrix made from them, and the interior-penalty search on it.
 *
 * The automatic penalty (DG paper sec. 9.1, as pf_sim's one-process search: start at 1 and double
 * until the stiffness at rest plus the rigid-mode mass shift is positive definite) tests
 * definiteness on the distributed matrix: MUMPS factors it (LDL^T, symmetric indefinite, null
 * pivots detected) and its inertia counts the negative and zero pivots, the same on every rank.
 * The shift, which depends on the smallest element and the stiffest material, is agreed by a
 * maximum over the ranks, so every rank tests the matrix of the whole mesh with the shift a
 * one-process run uses, and finds the same penalty. */
#include "sim_distrib.h"

#include <string.h>

#ifdef PF_HAVE_PETSC

#include "../solve/solve_petsc.h"

/* Whether this rank sends the stored entry coupling unknowns r and c (see the top; CG: all). */
static bool sends(const part *p, int64_t r, int64_t c)
{
    if (p->scene.method == PF_METHOD_CG)
        return true;
    int32_t a = (int32_t)(r / p->nb3), b = (int32_t)(c / p->nb3);
    if (p->owned[a] && p->owned[b])
        return true;
    if (!p->owned[a] && !p->owned[b])
        return false;
    return p->owned[a] ? p->pelem[a] < p->pelem[b] : p->pelem[b] < p->pelem[a];
}

/* This rank's COO entries: their rows and columns into ci and cj, their values into v (each
 * NULL: not written); returns their count. */
static PetscCount coo_entries(const part *p, PetscInt *ci, PetscInt *cj, PetscScalar *v)
{
    const pf_block_matrix *k = &p->k;
    PetscCount q = 0;
    for (int64_t c = 0; c < k->n; ++c)
        for (int64_t s = k->col_ptr[c]; s < k->col_ptr[c + 1]; ++s) {
            int64_t r = k->row_idx[s];
            if (!sends(p, r, c))
                continue;
            for (int t = 0; t < (r == c ? 1 : 2); ++t, ++q) {
                if (ci) {
                    ci[q] = p->row[t ? c : r];
                    cj[q] = p->row[t ? r : c];
                }
                if (v)
                    v[q] = k->val[s];
            }
        }
    return q;
}

/* The part's entries as COO arrays (*ci, *cj, *v of *n entries), their allocation agreed by
 * every rank before the collective calls that follow: on failure every rank returns the error
 * and the arrays are NULL. */
static pf_status coo_arrays(part *p, PetscCount *n, PetscInt **ci, PetscInt **cj, PetscScalar **v,
                            pf_error *err)
{
    *n = coo_entries(p, NULL, NULL, NULL);
    *ci = pf_alloc_array((size_t)*n + 1, sizeof **ci);
    *cj = pf_alloc_array((size_t)*n + 1, sizeof **cj);
    *v = pf_alloc_array((size_t)*n + 1, sizeof **v);
    pf_status st = *ci && *cj && *v ? PF_OK
                                    : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                   "cannot allocate %lld entries", (long long)*n);
    st = pf_sim_distrib_agree(st, err);
    if (st < 0) {
        pf_free(*ci), pf_free(*cj), pf_free(*v);
        *ci = *cj = NULL;
        *v = NULL;
        return st;
    }
    coo_entries(p, *ci, *cj, *v);
    return PF_OK;
}

pf_status pf_sim_distrib_matrix(part *p, Mat *a, pf_error *err)
{
    PetscCount n_coo;
    PetscInt *ci, *cj;
    PetscScalar *v;
    pf_status st = coo_arrays(p, &n_coo, &ci, &cj, &v, err);
    if (st < 0)
        return st;
    PetscInt local = p->local_rows, all = p->all_rows;
    PF_PETSC_TRY_TO(st, MatCreate(PETSC_COMM_WORLD, a));
    PF_PETSC_TRY_TO(st, MatSetSizes(*a, local, local, all, all));
    PF_PETSC_TRY_TO(st, MatSetType(*a, MATAIJ));
    PF_PETSC_TRY_TO(st, MatSetBlockSize(*a, 3));
    PF_PETSC_TRY_TO(st, MatSetFromOptions(*a));
    PF_PETSC_TRY_TO(st, MatSetPreallocationCOO(*a, n_coo, ci, cj));
    PF_PETSC_TRY_TO(st, MatSetValuesCOO(*a, v, INSERT_VALUES));
    pf_free(ci), pf_free(cj), pf_free(v);
    return st;
}

pf_status pf_sim_distrib_matrix_values(part *p, Mat a, pf_error *err)
{
    pf_status st = PF_OK;
    if (!p->coo_v) {
        p->n_coo = coo_entries(p, NULL, NULL, NULL);
        p->coo_v = pf_alloc_array((size_t)p->n_coo + 1, sizeof *p->coo_v);
        st = p->coo_v ? PF_OK
                      : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                     "cannot allocate %lld entries", (long long)p->n_coo);
        st = pf_sim_distrib_agree(st, err); /* before the collective call */
    }
    if (st < 0)
        return st;
    coo_entries(p, NULL, NULL, p->coo_v);
    PF_PETSC_TRY(MatSetValuesCOO(a, p->coo_v, INSERT_VALUES));
    return PF_OK;
}

/* Whether a is positive definite: no negative and no zero pivot in MUMPS's LDL^T (collective;
 * ICNTL(13) = 1: the root front is not split over the ranks, so the inertia is known; ICNTL(24)
 * = 1: null pivots are detected rather than failing). A factorisation MUMPS gives up on counts as
 * not definite. */
static pf_status definite(Mat a, bool *yes, pf_error *err)
{
    Mat f;
    MatFactorInfo info;
    MatFactorError failed = MAT_FACTOR_NOERROR;
    PetscInt neg = 0, zero = 0, pos = 0;
    PF_PETSC_TRY(MatGetFactor(a, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &f));
    pf_status st = PF_OK;
    PF_PETSC_TRY_TO(st, MatMumpsSetIcntl(f, 13, 1));
    PF_PETSC_TRY_TO(st, MatMumpsSetIcntl(f, 24, 1));
    PF_PETSC_TRY_TO(st, MatFactorInfoInitialize(&info));
    PF_PETSC_TRY_TO(st, MatCholeskyFactorSymbolic(f, a, NULL, &info));
    PF_PETSC_TRY_TO(st, MatCholeskyFactorNumeric(f, a, &info));
    PF_PETSC_TRY_TO(st, MatFactorGetError(f, &failed));
    if (st >= 0 && failed == MAT_FACTOR_NOERROR)
        PF_PETSC_TRY_TO(st, MatGetInertia(f, &neg, &zero, &pos));
    MatDestroy(&f);
    long counts[2] = {failed != MAT_FACTOR_NOERROR || neg > 0, zero}, any[2] = {0, 0};
    MPI_Allreduce(counts, any, 2, MPI_LONG, MPI_MAX, PETSC_COMM_WORLD);
    *yes = any[0] == 0 && any[1] == 0;
    return st;
}

pf_status pf_sim_distrib_search_penalty(part *p, pf_error *err)
{
    double mine = p->method ? p->ops->rigid_mode_shift(p->method) : 0, shift = 0;
    MPI_Allreduce(&mine, &shift, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
    Mat a = NULL;
    pf_status st = PF_OK;
    bool yes = false;
    p->penalty = 0;
    for (double eta = 1; st >= 0 && !yes && eta <= 1048576; eta *= 2) {
        if (p->method) {
            p->ops->set_penalty(p->method, eta);
            memset(p->f, 0, (size_t)p->n_dofs * sizeof *p->f);
            p->ops->stiffness(p->method, p->u, false, &p->k, p->f); /* u: 0, at rest */
            p->ops->add_mass(p->method, shift, &p->k);
        }
        st = a ? pf_sim_distrib_matrix_values(p, a, err) : pf_sim_distrib_matrix(p, &a, err);
        if (st >= 0)
            st = definite(a, &yes, err);
        if (yes)
            p->penalty = eta;
        else
            p->doublings++;
    }
    MatDestroy(&a);
    if (p->f)
        memset(p->f, 0, (size_t)p->n_dofs * sizeof *p->f);
    PF_TRY(st);
    PF_CHECK(yes, err, PF_ERR_NUMERIC,
             "no penalty up to 2^20 makes the stiffness positive definite: the mesh has "
             "degenerate elements");
    return PF_OK;
}

#endif
