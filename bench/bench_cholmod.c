/* CHOLMOD factorisation time on 3D Laplacians of growing size, and which BLAS is behind it.
 *
 * CSV on stdout: blas,n,unknowns,nnz_lower,analyse_s,factorise_s,solve_residual
 * The BLAS is the library that provides dgemm_ to this process (libblas.so.3 is an alternatives
 * link on Debian: OpenBLAS when libopenblas-dev is installed, else the reference BLAS). Every
 * factorisation and solve runs with the threads pf_cholesky gives CHOLMOD (libcore/solve/
 * threads.c: CHOLMOD's OpenMP loops and OpenBLAS on one thread unless the environment sets them).
 *
 * bench_cholmod dg [REPEAT]: the factorisation of K09 table 1's BZ degree-1 case (the matrix of
 * bench_dg table1: 10 x 10 x 10 hexes clamped at x = 0, 12000 unknowns) under every ordering
 * CHOLMOD offers and supernodal against simplicial LL': what limits factor + solve there.
 * Columns: ordering,factor,selected,lnz,flops,analyse_ms,factor_ms,factor_cpu_ms,solve_ms,
 * gflops,threads; the times are the minimum of REPEAT runs (default 15, as the machine is
 * shared; simplicial: one run), factor_cpu_ms the process's CPU time of that run (all threads),
 * gflops = flops / factor_ms.
 * ordering "block-*": the ordering of the element graph (one node per 12 x 12 block) expanded
 * to the unknowns and given to CHOLMOD. The committed bench/results/cholmod_dg.csv came from
 *   for s in "OMP_THREAD_LIMIT=1 OPENBLAS_NUM_THREADS=1" "OMP_THREAD_LIMIT=1 OPENBLAS_NUM_THREADS=2" ""; do
 *     env $s bench_cholmod dg; done   (header lines of the later runs dropped)
 * What it shows: CHOLMOD's default already keeps METIS (2.86 GFlop; AMD 3.98, NESDIS 2.88, the
 * element-graph orderings 2.92-3.98), and simplicial LL' is 30x slower than supernodal. The
 * issue's 60 ms for factor + solve thus needs about 48 GFlop/s; one core gives 27 (104 ms at a
 * load of 1.8, dg_table1.csv) and two OpenBLAS threads 35 (82 ms): CHOLMOD 3 parallelises only
 * inside each supernode's BLAS calls, and the small supernodes near the leaves run serially. */
#define _GNU_SOURCE /* dladdr */
#include <dlfcn.h>
#include <stdbool.h>
#include <time.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cholmod.h>

#include <pf/base.h>
#include <pf/fem.h>
#include <pf/mesh.h>
#include <pf/solve.h>

#include "solve/solve_threads.h"

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

/* ---- the DG matrix of table 1 --------------------------------------------------------------- */

static double cpu_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static const char *threads(void)
{
    static char out[128];
    const char *a = getenv("OMP_THREAD_LIMIT"), *b = getenv("OPENBLAS_NUM_THREADS");
    snprintf(out, sizeof out, "OMP_THREAD_LIMIT=%s OPENBLAS_NUM_THREADS=%s", a ? a : "unset",
             b ? b : "unset");
    return out;
}

/* The upper triangle of the block matrix as a CHOLMOD matrix (the arrays borrowed). */
static cholmod_sparse wrap(const pf_block_matrix *a)
{
    cholmod_sparse s;
    memset(&s, 0, sizeof s);
    s.nrow = s.ncol = (size_t)a->n;
    s.nzmax = (size_t)a->col_ptr[a->n];
    s.p = a->col_ptr;
    s.i = a->row_idx;
    s.x = a->val;
    s.stype = 1;
    s.itype = CHOLMOD_LONG;
    s.xtype = CHOLMOD_REAL;
    s.dtype = CHOLMOD_DOUBLE;
    s.sorted = 1;
    s.packed = 1;
    return s;
}

/* One row: analyse with the given ordering (perm: given, else CHOLMOD's own with nmethods /
 * method), then the minimum of repeat factorisations and solves. */
static int dg_row(const char *name, cholmod_sparse *a, int ordering, const SuiteSparse_long *perm,
                  bool simplicial, int repeat)
{
    cholmod_common cc;
    cholmod_l_start(&cc);
    cc.print = 0;
    cc.supernodal = simplicial ? CHOLMOD_SIMPLICIAL : CHOLMOD_SUPERNODAL;
    cc.final_ll = 1;
    if (ordering >= 0 || perm) {
        cc.nmethods = 1;
        cc.method[0].ordering = perm ? CHOLMOD_GIVEN : ordering;
    }
    double t0 = pf_time_seconds();
    cholmod_factor *l = perm ? cholmod_l_analyze_p(a, (SuiteSparse_long *)perm, NULL, 0, &cc)
                             : cholmod_l_analyze(a, &cc);
    double analyse = pf_time_seconds() - t0;
    if (!l) {
        fprintf(stderr, "bench_cholmod: analysis failed (status %d)\n", cc.status);
        cholmod_l_finish(&cc);
        return 1;
    }
    double factor = INFINITY, factor_cpu = 0, solve = INFINITY;
    cholmod_dense *b = cholmod_l_ones(a->nrow, 1, CHOLMOD_REAL, &cc);
    for (int k = 0; k < repeat; ++k) {
        double c0 = cpu_seconds();
        t0 = pf_time_seconds();
        solve_threads_saved threads = pf_solve_threads_enter(NULL);
        cholmod_l_factorize(a, l, &cc);
        pf_solve_threads_leave(threads);
        double t = pf_time_seconds() - t0;
        if (t < factor)
            factor = t, factor_cpu = cpu_seconds() - c0;
        t0 = pf_time_seconds();
        threads = pf_solve_threads_enter(NULL);
        cholmod_dense *x = cholmod_l_solve(CHOLMOD_A, l, b, &cc);
        pf_solve_threads_leave(threads);
        t = pf_time_seconds() - t0;
        solve = t < solve ? t : solve;
        cholmod_l_free_dense(&x, &cc);
    }
    int ok = cc.status == CHOLMOD_OK;
    printf("%s,%s,%d,%.4e,%.4e,%.1f,%.1f,%.1f,%.2f,%.1f,%s\n", name,
           simplicial ? "simplicial" : "supernodal", cc.selected, cc.lnz, cc.fl, 1e3 * analyse,
           1e3 * factor, 1e3 * factor_cpu, 1e3 * solve, 1e-9 * cc.fl / factor, threads());
    fflush(stdout);
    cholmod_l_free_dense(&b, &cc);
    cholmod_l_free_factor(&l, &cc);
    cholmod_l_finish(&cc);
    return ok ? 0 : 1;
}

static int dg_study(int repeat)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_dg dg = {0};
    pf_block_matrix k = {0};
    if (pf_mesh_make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 10, 10, 10, &err) != PF_OK ||
        pf_mesh_derive(&m, &err) != PF_OK ||
        pf_dg_create(&dg, &m, 1, 1e5, 0.3, 1000, &err) != PF_OK ||
        pf_dg_pattern(&dg, &k, &err) != PF_OK) {
        fprintf(stderr, "bench_cholmod: %s\n", err.msg);
        return 1;
    }
    int32_t *fixed = pf_alloc_array((size_t)m.n_faces, sizeof *fixed);
    double *f = pf_alloc_array((size_t)dg.n_dofs, sizeof *f);
    SuiteSparse_long *pb = pf_alloc_array((size_t)k.n_blocks, sizeof *pb);
    SuiteSparse_long *perm = pf_alloc_array((size_t)k.n, sizeof *perm);
    SuiteSparse_long *cp = pf_alloc_array((size_t)k.n_blocks, sizeof *cp);
    SuiteSparse_long *cm = pf_alloc_array((size_t)k.n_blocks, sizeof *cm);
    if (!fixed || !f || !pb || !perm || !cp || !cm) {
        fprintf(stderr, "bench_cholmod: out of memory\n");
        return 1;
    }
    for (int32_t q = 0; q < m.n_faces; ++q)
        fixed[q] = -1;
    for (int32_t q = dg.n_interior; q < dg.n_faces; ++q)
        if (fabs(dg.faces[q].centroid.x) < 1e-9)
            fixed[dg.faces[q].face] = 0;
    const double zero[12] = {0};
    pf_dg_terms terms = {.ip = false, .eta = 1, .face_fixed = fixed, .fixed_disp = zero};
    pf_dg_assemble_stiffness(&dg, &terms, NULL, NULL, &k, f);
    cholmod_sparse a = wrap(&k);
    printf("ordering,factor,selected,lnz,flops,analyse_ms,factor_ms,factor_cpu_ms,solve_ms,gflops,"
           "threads\n");
    int status = dg_row("default", &a, -1, NULL, false, repeat);
    status |= dg_row("amd", &a, CHOLMOD_AMD, NULL, false, repeat);
    status |= dg_row("metis", &a, CHOLMOD_METIS, NULL, false, repeat);
    status |= dg_row("nesdis", &a, CHOLMOD_NESDIS, NULL, false, repeat);
    /* the element graph: block column j's adjacency, the pattern of a matrix of blocks */
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_sparse g;
    memset(&g, 0, sizeof g);
    g.nrow = g.ncol = (size_t)k.n_blocks;
    g.nzmax = (size_t)k.adj_offsets[k.n_blocks];
    SuiteSparse_long *gp = pf_alloc_array((size_t)k.n_blocks + 1, sizeof *gp);
    SuiteSparse_long *gi = pf_alloc_array(g.nzmax, sizeof *gi);
    for (int32_t j = 0; j <= k.n_blocks; ++j)
        gp[j] = k.adj_offsets[j];
    for (size_t q = 0; q < g.nzmax; ++q)
        gi[q] = k.adj[q];
    g.p = gp;
    g.i = gi;
    g.stype = 1;
    g.itype = CHOLMOD_LONG;
    g.xtype = CHOLMOD_PATTERN;
    g.dtype = CHOLMOD_DOUBLE;
    g.sorted = 1;
    g.packed = 1;
    for (int method = 0; method < 3; ++method) {
        int ok = method == 0   ? cholmod_l_amd(&g, NULL, 0, pb, &cc)
                 : method == 1 ? cholmod_l_metis(&g, NULL, 0, 1, pb, &cc)
                               : cholmod_l_nested_dissection(&g, NULL, 0, pb, cp, cm, &cc) >= 0;
        if (!ok)
            continue;
        int64_t c = 0;
        for (int32_t q = 0; q < k.n_blocks; ++q)
            for (int64_t u = k.block_start[pb[q]]; u < k.block_start[pb[q] + 1]; ++u)
                perm[c++] = u;
        static const char *const NAMES[] = {"block-amd", "block-metis", "block-nesdis"};
        status |= dg_row(NAMES[method], &a, -1, perm, false, repeat);
    }
    cholmod_l_finish(&cc);
    status |= dg_row("default", &a, -1, NULL, true, 1); /* 30x slower: once */
    pf_free(gp);
    pf_free(gi);
    pf_free(fixed);
    pf_free(f);
    pf_free(pb);
    pf_free(perm);
    pf_free(cp);
    pf_free(cm);
    pf_block_matrix_release(&k);
    pf_dg_release(&dg);
    pf_mesh_release(&m);
    return status;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "dg") == 0)
        return dg_study(argc > 2 ? atoi(argv[2]) : 15);
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
        solve_threads_saved threads = pf_solve_threads_enter(NULL);
        cholmod_factorize(a, l, &cc);
        double t2 = pf_time_seconds();
        cholmod_dense *b = cholmod_ones(a->nrow, 1, CHOLMOD_REAL, &cc);
        cholmod_dense *x = cholmod_solve(CHOLMOD_A, l, b, &cc);
        pf_solve_threads_leave(threads);
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
