/* The threads CHOLMOD and the BLAS run with during one CHOLMOD call (threads.c): private to
 * libcore/solve; tests include it to pin the counts. */
#ifndef PF_SOLVE_THREADS_H
#define PF_SOLVE_THREADS_H

#include <stdbool.h>

#include <pf/solve.h>

/* Thread counts imposed on one call whatever the environment: openmp_serial runs CHOLMOD's
 * OpenMP loops on the calling thread alone (false: the team CHOLMOD was built with), blas > 0 is
 * OpenBLAS's thread count (0: OpenBLAS's own). */
typedef struct solve_threads_forced {
    bool active;
    bool openmp_serial;
    int blas;
} solve_threads_forced;

/* What pf_solve_threads_enter changed, for pf_solve_threads_leave to restore. */
typedef struct solve_threads_saved {
    int max_active_levels; /* the calling thread's OpenMP max-active-levels-var; -1: untouched */
    int dynamic;           /* its dyn-var; -1: untouched */
    pf_blas_threads blas;  /* OpenBLAS's thread count before (pf/base.h) */
} solve_threads_saved;

/* Configures the calling thread (OpenMP) and OpenBLAS for one CHOLMOD factorisation or solve,
 * by the policy of threads.c unless forced (NULL or inactive: the policy). Returns what it
 * changed. */
solve_threads_saved pf_solve_threads_enter(const solve_threads_forced *forced);

/* Restores what pf_solve_threads_enter changed, in the same thread. */
void pf_solve_threads_leave(solve_threads_saved saved);

/* True when the process's BLAS is OpenBLAS, whose thread count pf_solve_threads_enter can set. */
bool pf_solve_threads_blas_settable(void);

/* Makes every later factorisation and solve of c run with the given threads (tests: the same
 * bits with one thread and with several). Borrows nothing. */
void pf_cholesky_force_threads(pf_cholesky *c, bool openmp_serial, int blas);

#endif
