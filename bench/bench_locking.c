/* Locking (DG paper sec. 9.5, fig. 9): the unit cube of n^3 cubes x 6 tets (Kuhn split), clamped
 * by weak u = 0 on its top face, sagging under its own weight (E = 1e5, rho = 1000, g = 9.81).
 * The sag is the mean vertical displacement of the bottom face. Every method and degree at
 * nu = 0.3 and 0.499 on 750 tets, IP degree 2 on 6000 tets, and (bench_locking reference 15:
 * 230 s of CPU and 12 GB each) the reference on 20,250 tets that tests/test_dg_convergence.c
 * compares with. The penalty is the smallest power of two from 1 at
 * which K is positive definite (sec. 9.1); BZ is definite for any eta, so it gets eta = 1 and is
 * shown for completeness only.
 *
 * bench_locking [table]: the runs above (bench/results/locking.csv);
 * bench_locking reference N: IP degree 2 on n = N (N^3 x 6 tets), both nu (N = 15: the last
 *   two rows of bench/results/locking.csv, run under a load average of about 10);
 * bench_locking bz: BZ of degree 1 and 2 on 750 tets, both nu, eta = 2^k, k = 0..12
 *   (bench/results/locking_bz.csv, measured before BZ's penalty grew under refinement: its eta
 *   are of the fixed weight of eq. 20 alone; on this mesh the growth (L / h_f)^p multiplies
 *   every face weight by a factor of order (5 sqrt(2))^p, so the new eta of a row is about the
 *   old one divided by that).
 *
 * CSV on stdout: method,degree,nu,tets,unknowns,eta,sag,seconds */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <pf/fem.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static pf_status make_cube_tets(pf_mesh *m, int n, pf_error *err)
{
    return pf_mesh_make_box_tets(m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), n, n, n, err);
}

/* Mean u_z over the bottom face: int_f u_z = sum_a S[0][0][a][0] u_z,a (phi_0 = 1). */
static double bottom_sag(const pf_dg *dg, const double *u)
{
    double total = 0, area = 0;
    int nb = dg->nb;
    for (int32_t q = dg->n_interior; q < dg->n_faces; ++q) {
        const pf_dg_face *fc = &dg->faces[q];
        if (fabs(fc->centroid.z) > 1e-12)
            continue;
        const double *ue = u + 3 * (size_t)fc->elem[0] * nb;
        for (int a = 0; a < nb; ++a)
            total += fc->S[(size_t)a * nb] * ue[3 * a + 2];
        area += fc->area;
    }
    return total / area;
}

/* One solve; eta > 0 is used as given, eta = 0 searches (sec. 9.1). */
static pf_status run(int n, int degree, int ip, double nu, double eta, pf_error *err)
{
    double t0 = now();
    pf_mesh m = {0};
    pf_dg dg = {0};
    pf_block_matrix k = {0};
    pf_cholesky *c = NULL;
    int32_t *fixed = NULL;
    double *rhs = NULL, *x = NULL;
    const double zero[12] = {0};
    pf_status s = make_cube_tets(&m, n, err);
    if (s >= 0)
        s = pf_dg_create(&dg, &m, degree, 1e5, nu, 1000, err);
    if (s >= 0)
        s = pf_dg_pattern(&dg, &k, err);
    if (s >= 0) {
        fixed = malloc((size_t)m.n_faces * sizeof *fixed);
        rhs = calloc((size_t)dg.n_dofs, sizeof *rhs);
        x = calloc((size_t)dg.n_dofs, sizeof *x);
        if (!fixed || !rhs || !x)
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    pf_dg_terms terms = {.ip = ip, .face_fixed = fixed, .fixed_disp = zero};
    if (s >= 0) {
        for (int32_t q = 0; q < dg.n_faces; ++q) {
            const pf_dg_face *fc = &dg.faces[q];
            fixed[fc->face] = (fc->elem[1] < 0 && fabs(fc->centroid.z - 1) < 1e-12) ? 0 : -1;
        }
        s = PF_ERR_NUMERIC;
        for (terms.eta = eta > 0 ? eta : 1; terms.eta < 1e6 && s == PF_ERR_NUMERIC;
             terms.eta *= 2) {
            pf_dg_assemble_stiffness(&dg, &terms, NULL, NULL, &k, rhs);
            s = c ? PF_OK : pf_cholesky_create(&c, &k, err);
            if (s >= 0)
                s = pf_cholesky_factor(c, &k, NULL, err);
            if (s >= 0)
                break;
        }
    }
    if (s >= 0) {
        for (int64_t q = 0; q < dg.n_dofs; ++q)
            rhs[q] = 0;
        pf_dg_add_body_force(&dg, (pf_vec3){0, 0, -1000 * 9.81}, rhs);
        s = pf_cholesky_solve(c, rhs, x, err);
    }
    if (s >= 0)
        printf("%s,%d,%g,%d,%lld,%g,%.6e,%.2f\n", ip ? "ip" : "bz", degree, nu,
               (int)m.n_elems, (long long)dg.n_dofs, terms.eta, bottom_sag(&dg, x), now() - t0);
    fflush(stdout);
    pf_cholesky_destroy(&c);
    free(fixed);
    free(rhs);
    free(x);
    pf_block_matrix_release(&k);
    pf_dg_release(&dg);
    pf_mesh_release(&m);
    return s;
}

int main(int argc, char **argv)
{
    pf_error err = {0};
    const double nus[2] = {0.3, 0.499};
    const char *what = argc > 1 ? argv[1] : "table";
    printf("method,degree,nu,tets,unknowns,eta,sag,seconds\n");
    pf_status s = PF_OK;
    if (strcmp(what, "table") == 0) {
        for (int ip = 1; ip >= 0 && s >= 0; --ip)
            for (int degree = 1; degree <= 2 && s >= 0; ++degree)
                for (int v = 0; v < 2 && s >= 0; ++v)
                    s = run(5, degree, ip, nus[v], 0, &err);
        for (int v = 0; v < 2 && s >= 0; ++v)
            s = run(10, 2, 1, nus[v], 0, &err);
    } else if (strcmp(what, "reference") == 0 && argc == 3 && atoi(argv[2]) > 0) {
        for (int v = 0; v < 2 && s >= 0; ++v)
            s = run(atoi(argv[2]), 2, 1, nus[v], 0, &err);
    } else if (strcmp(what, "bz") == 0) {
        for (int degree = 1; degree <= 2 && s >= 0; ++degree)
            for (int v = 0; v < 2 && s >= 0; ++v)
                for (int k = 0; k <= 12 && s >= 0; ++k)
                    s = run(5, degree, 0, nus[v], ldexp(1, k), &err);
    } else {
        fprintf(stderr, "usage: bench_locking [table | reference N | bz]\n");
        return 2;
    }
    if (s < 0) {
        fprintf(stderr, "bench_locking: %s\n", err.msg);
        return 1;
    }
    return 0;
}
