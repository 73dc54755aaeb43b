/* OpenBLAS's thread count around a stretch of BLAS / LAPACK calls (pf/base.h).
 *
 * OpenBLAS starts one thread per core and splits a product among them above a size threshold.
 * For pf's calls that is wrong twice over: the split changes the last bits of some results (a
 * Cholesky factor: tests/test_solve.c saw 1 and 2 threads differ; the CG set-up's element
 * matrices too), so output would depend on the machine's core count; and the products of the
 * harmonic basis and of element integration are small (tens to hundreds of rows), where the
 * threads cost more than they give (the bunny sliced at res 6: CG set-up 10.9 s with OpenBLAS's
 * default against 8.1 s on one thread, 2 cores). A count the user sets (OPENBLAS_NUM_THREADS,
 * GOTO_NUM_THREADS or OMP_NUM_THREADS, which OpenBLAS reads) is left alone unless forced.
 * The count is process-wide: pf calls the BLAS from one thread at a time. */
#define _GNU_SOURCE /* RTLD_DEFAULT */
#include <pf/base.h>

#include <dlfcn.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

typedef void (*set_threads_fn)(int);
typedef int (*get_threads_fn)(void);

typedef struct blas_environment {
    bool user_given; /* a variable OpenBLAS reads for its thread count is set */
    set_threads_fn set;
    get_threads_fn get;
} blas_environment;

static blas_environment environment;
static pthread_once_t environment_once = PTHREAD_ONCE_INIT;

static bool is_set(const char *name)
{
    const char *v = getenv(name);
    return v && *v;
}

/* OpenBLAS's entry points when it is the process's BLAS (libblas.so.3 is an alternatives link
 * on Debian), else NULL: then the BLAS is left as it is. */
static void read_environment(void)
{
    blas_environment *e = &environment;
    e->user_given =
        is_set("OPENBLAS_NUM_THREADS") || is_set("GOTO_NUM_THREADS") || is_set("OMP_NUM_THREADS");
    void *set = dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
    void *get = dlsym(RTLD_DEFAULT, "openblas_get_num_threads");
    if (set && get) { /* object to function pointer: POSIX guarantees dlsym's result converts */
        memcpy(&e->set, &set, sizeof set);
        memcpy(&e->get, &get, sizeof get);
    }
}

static const blas_environment *blas_env(void)
{
    pthread_once(&environment_once, read_environment);
    return &environment;
}

bool pf_blas_threads_settable(void)
{
    return blas_env()->set != NULL;
}

pf_blas_threads pf_blas_threads_set(int threads, bool force)
{
    const blas_environment *e = blas_env();
    pf_blas_threads saved = {0};
    if (!e->set || threads <= 0 || (e->user_given && !force))
        return saved;
    int before = e->get();
    if (before != threads) {
        saved.before = before;
        e->set(threads);
    }
    return saved;
}

void pf_blas_threads_restore(pf_blas_threads saved)
{
    if (saved.before > 0)
        blas_env()->set(saved.before);
}
