/* Threads of CHOLMOD calls. Debian's CHOLMOD 3 runs its OpenMP loops (copying the matrix into
 * the supernodes, scattering each update into its target) with num_threads(4) fixed when it was
 * built, whatever the machine, and does its flops in BLAS calls between those loops: OpenBLAS,
 * which starts one thread per core. libgomp's idle team keeps spinning after each loop while the
 * BLAS threads want the same cores: on 2 cores the demo scene's DG step factorises 2.7x slower
 * than on one thread, and with a team of 2 (OMP_THREAD_LIMIT=2) 7-60x slower.
 *
 * CHOLMOD's loops are memory-bound copies, worth nothing in parallel next to the BLAS calls, so
 * they run on the calling thread alone: omp_set_max_active_levels(0), which bounds even an
 * explicit num_threads clause and, like every ICV set through omp_set_*, holds for the calling
 * thread only; it is set around each call and restored after it, so OpenMP code of the caller
 * keeps its own settings. (omp_set_dynamic(1) bounds the team by the cores minus the load
 * average instead: a team of 2 on an idle 2-core machine, the slowest case above.)
 *
 * OpenBLAS runs on one thread inside CHOLMOD calls, for two reasons. Its threads change the last
 * bits of a factorisation (the test of test_solve.c saw it: 1 and 2 threads differ), so a result
 * would depend on the machine's core count. And a second thread pays off only on large
 * factors of an otherwise idle machine: on the shared 2-core machine (load average 1.6-2.8)
 * bench_dg table1 factorised the 12000-unknown DG matrix in 165 ms (minimum of 7) on one thread
 * and 190 ms on two, the 30000-unknown degree-2 one in 1.90 s and 1.77-2.05 s, and the bunny's
 * CG steps (18954 unknowns) and the demo's DG steps before contact (4704 unknowns) ran as fast
 * or faster on one at a fraction of the system time. At a load below 1.6 two threads were
 * 20-35% faster on the two table-1 matrices (bench/results/dg_table1.csv) and 20% on the demo's
 * steps once contact has grown their pattern (20 frames: 44.5 s of factorisation against 54.4 s).
 * OPENBLAS_NUM_THREADS gives that back to whoever prefers the speed to fixed bits. The count is set
 * around each call and restored, so other BLAS calls of the process (the harmonic basis) keep
 * OpenBLAS's own count. It is process-wide: two threads factorising at once would share whatever
 * the last one set (pf factorises on one thread).
 *
 * The user's environment wins: OMP_THREAD_LIMIT, OMP_DYNAMIC or OMP_MAX_ACTIVE_LEVELS leave
 * OpenMP as the runtime set it up; OMP_NUM_THREADS alone turns dynamic adjustment on, the only
 * way it can bound CHOLMOD's fixed team; OPENBLAS_NUM_THREADS, GOTO_NUM_THREADS or
 * OMP_NUM_THREADS (which OpenBLAS reads) leave OpenBLAS's count alone, at the price of results
 * that depend on it. */
#include "solve_threads.h"

#include <omp.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

/* The environment, looked at once per process (it does not change while it runs). */
typedef struct thread_environment {
    bool openmp_given;     /* a variable that bounds CHOLMOD's team is set */
    bool num_threads_only; /* OMP_NUM_THREADS is, alone among those */
} thread_environment;

static thread_environment environment;
static pthread_once_t environment_once = PTHREAD_ONCE_INIT;

static bool is_set(const char *name)
{
    const char *v = getenv(name);
    return v && *v;
}

static void read_environment(void)
{
    thread_environment *e = &environment;
    bool limits = is_set("OMP_THREAD_LIMIT") || is_set("OMP_DYNAMIC") ||
                  is_set("OMP_MAX_ACTIVE_LEVELS") || is_set("OMP_NESTED");
    e->num_threads_only = !limits && is_set("OMP_NUM_THREADS");
    e->openmp_given = limits || e->num_threads_only;
}

static const thread_environment *thread_env(void)
{
    pthread_once(&environment_once, read_environment);
    return &environment;
}

bool pf_solve_threads_blas_settable(void)
{
    return pf_blas_threads_settable();
}

static void serial_openmp(solve_threads_saved *saved)
{
    saved->max_active_levels = omp_get_max_active_levels();
    omp_set_max_active_levels(0);
}

solve_threads_saved pf_solve_threads_enter(const solve_threads_forced *forced)
{
    const thread_environment *e = thread_env();
    solve_threads_saved saved = {.max_active_levels = -1, .dynamic = -1, .blas = {0}};
    if (forced && forced->active) {
        if (forced->openmp_serial)
            serial_openmp(&saved);
        saved.blas = pf_blas_threads_set(forced->blas, true);
        return saved;
    }
    if (!e->openmp_given) {
        serial_openmp(&saved);
    } else if (e->num_threads_only) {
        saved.dynamic = omp_get_dynamic();
        omp_set_dynamic(1);
    }
    saved.blas = pf_blas_threads_set(1, false);
    return saved;
}

void pf_solve_threads_leave(solve_threads_saved saved)
{
    if (saved.max_active_levels >= 0)
        omp_set_max_active_levels(saved.max_active_levels);
    if (saved.dynamic >= 0)
        omp_set_dynamic(saved.dynamic);
    pf_blas_threads_restore(saved.blas);
}
