/* Sparse Cholesky through CHOLMOD (SuiteSparse_long interface). The block matrix already is
 * CHOLMOD's upper-triangular, sorted, packed compressed-column form, so it is wrapped, never
 * copied. The analysis (fill-reducing ordering, supernodal structure) is done once per pattern;
 * a factorisation only recomputes the values; solves reuse CHOLMOD's workspace. Every
 * factorisation and solve runs with the threads threads.c chooses. */
#include <pf/solve.h>

#include <stdbool.h>
#include <string.h>

#include <cholmod.h>

#include "solve_threads.h"

struct pf_cholesky {
    cholmod_common cc;
    cholmod_factor *factor;
    cholmod_dense *x, *y, *e; /* solve2 results and workspace, kept between solves */
    int64_t n, nnz;
    double flops; /* of one numeric factorisation, from the analysis */
    solve_threads_forced forced;
    bool factored;
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
    pf_free(ch);
    *c = NULL;
}
