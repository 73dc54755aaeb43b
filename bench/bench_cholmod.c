/* CHOLMOD factorisation time on 3D Laplacians of growing size, and which BLAS is behind it.
 *
 * CSV on stdout: blas,n,unknowns,nnz_lower,analyse_s,factorise_s,solve_residual
 * The BLAS is the library that provides dgemm_ to this process (libblas.so.3 is an alternatives
 * link on Debian: OpenBLAS when libopenblas-dev is installed, else the reference BLAS). */
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cholmod.h>

#include <pf/base.h>

static void blas_name(char *out, size_t size)
{
    snprintf(out, size, "unknown");
    void *sym = dlsym(RTLD_DEFAULT, "dgemm_");
    Dl_info info;
    if (!sym || !dladdr(sym, &info) || !info.dli_fname)
        return;
    char *real = realpath(info.dli_fname, NULL);
    const char *path = real ? real : info.dli_fname;
    const char *kind = strstr(path, "openblas") ? "openblas" : strstr(path, "blis") ? "blis"
                       : strstr(path, "mkl")    ? "mkl"
                       : strstr(path, "atlas")  ? "atlas"
                                                : "reference";
    snprintf(out, size, "%s (%s)", kind, path);
    free(real);
}

/* Lower triangle of the 7-point Laplacian (+ identity shift) on an n^3 grid, as a CHOLMOD matrix. */
static cholmod_sparse *laplacian(int n, cholmod_common *cc)
{
    size_t N = (size_t)n * n * n;
    cholmod_triplet *t = cholmod_allocate_triplet(N, N, 4 * N, -1, CHOLMOD_REAL, cc);
    int *ri = t->i, *ci = t->j;
    double *v = t->x;
    size_t k = 0;
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                int i = (z * n + y) * n + x;
                ri[k] = i, ci[k] = i, v[k++] = 6.01;
                if (x + 1 < n)
                    ri[k] = i + 1, ci[k] = i, v[k++] = -1;
                if (y + 1 < n)
                    ri[k] = i + n, ci[k] = i, v[k++] = -1;
                if (z + 1 < n)
                    ri[k] = i + n * n, ci[k] = i, v[k++] = -1;
            }
    t->nnz = k;
    cholmod_sparse *a = cholmod_triplet_to_sparse(t, k, cc);
    cholmod_free_triplet(&t, cc);
    return a;
}

int main(void)
{
    char blas[512];
    blas_name(blas, sizeof blas);
    fprintf(stderr, "bench_cholmod: BLAS in use: %s\n", blas);
    printf("blas,n,unknowns,nnz_lower,analyse_s,factorise_s,solve_residual\n");
    cholmod_common cc;
    cholmod_start(&cc);
    cc.supernodal = CHOLMOD_SUPERNODAL;
    for (int n = 10; n <= 40; n += 10) {
        cholmod_sparse *a = laplacian(n, &cc);
        double t0 = pf_time_seconds();
        cholmod_factor *l = cholmod_analyze(a, &cc);
        double t1 = pf_time_seconds();
        cholmod_factorize(a, l, &cc);
        double t2 = pf_time_seconds();
        cholmod_dense *b = cholmod_ones(a->nrow, 1, CHOLMOD_REAL, &cc);
        cholmod_dense *x = cholmod_solve(CHOLMOD_A, l, b, &cc);
        /* residual |b - A x|_inf with A symmetric (lower stored) */
        double one[2] = {1, 0}, minus_one[2] = {-1, 0};
        cholmod_dense *r = cholmod_copy_dense(b, &cc);
        cholmod_sdmult(a, 0, minus_one, one, x, r, &cc);
        double res = cholmod_norm_dense(r, 0, &cc);
        char short_name[32]; /* the kind, without the path */
        snprintf(short_name, sizeof short_name, "%.*s", (int)strcspn(blas, " "), blas);
        printf("%s,%d,%zu,%zu,%.6f,%.6f,%.3g\n", short_name, n, a->nrow,
               (size_t)cholmod_nnz(a, &cc), t1 - t0, t2 - t1, res);
        cholmod_free_dense(&r, &cc);
        cholmod_free_dense(&x, &cc);
        cholmod_free_dense(&b, &cc);
        cholmod_free_factor(&l, &cc);
        cholmod_free_sparse(&a, &cc);
    }
    cholmod_finish(&cc);
    return 0;
}
