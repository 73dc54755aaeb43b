/* Which method for which job: the static cantilever of the tests (4 x 1 x 1, clamped at x = 0
 * by the scene's fixed region, traction (0, 0, -1) on the end x = 4, E = 1e5) on 4r x r x r
 * hexes, r = 2, 4, 8 (2, 4, 8 elements through the height), at nu = 0.3 and 0.499, for every method of pf-sim with its automatic
 * settings: cg (trilinear closed forms on these hexes), dg IP degree 1 and 2, dg BZ degree 1 and
 * 2. The tip is the mean u_z over the nodes of the end face (as tests/test_sim.c takes it).
 *
 * Errors are signed (> 0: softer than the reference, < 0: stiffer) against two references per
 * nu: error against the 3-D limit, the Aitken extrapolation of IP degree 2 over r = 2, 4, 8
 * where its differences shrink geometrically (case "cantilever"; at nu = 0.499 they do not:
 * case "cantilever-beam", error against beam theory)
 * (tests/test_sim.c extrapolates over r = 1, 2, 4 and checks that limit against beam theory
 * within 3 % at nu = 0.3; the two limits differ by 0.2 %), and
 * beam_error against Timoshenko's beam value P L^3 / (3 E I) + P L / (k G A) with the shear
 * coefficient of a rectangle k = 10 (1 + nu) / (12 + 11 nu) (Cowper 1966), which leaves out the
 * clamped end's 3-D effects (a few percent). cpu_s: CPU seconds of pf_sim_create +
 * pf_sim_solve_static (all threads; pf runs CHOLMOD on one), the best of up to REPEAT runs
 * (runs stop repeating after a second of CPU: the large ones run once).
 *
 * Then the hanging cube of the DG paper's fig. 9 (sec. 9.5): the unit cube of 750 tetrahedra
 * (5^3 cubes x 6, r = 5), clamped on its top face, sagging under its weight (E = 1e5, density
 * 1000, g = 9.81); value: the mean u_z over the bottom face (the integral of the linear
 * interpolant of the nodal displacements), error against IP degree 2 on 20,250 tets
 * (bench_locking reference 15; that sag is the exact face mean of the DG field; the nodal
 * interpolant's mean differs from it by up to 0.4 %: IP degree 2 on 750 tets reads -0.53 %
 * here, -0.13 % by the exact mean of bench/results/locking.csv).
 *
 * bench_guidance [--quick] > bench/results/guidance.csv; scripts/guidance writes
 * docs/guidance.md from it (about 3 minutes of CPU). --quick: r = 1, 2 only and a cube of 48
 * tets (a smoke test).
 * CSV: case,nu,method,flux,degree,r,elems,dofs,eta,value,error,beam_error,cpu_s (beam_error
 * empty for the cube) */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include <pf/mesh.h>
#include <pf/sim.h>

#include "machine.h"

enum { REPEAT = 3 };

typedef struct method {
    const char *name;
    pf_method method;
    pf_flux flux;
    int degree;
} method;

static const method METHODS[] = {
    {"cg", PF_METHOD_CG, PF_FLUX_IP, 1},  {"dg", PF_METHOD_DG, PF_FLUX_IP, 1},
    {"dg", PF_METHOD_DG, PF_FLUX_IP, 2},  {"dg", PF_METHOD_DG, PF_FLUX_BZ, 1},
    {"dg", PF_METHOD_DG, PF_FLUX_BZ, 2},
};

typedef struct run {
    double tip, cpu, eta;
    int32_t elems;
    int64_t dofs;
} run;

/* The hanging cube's sag: the mean u_z over its bottom face z = 0, the integral of the linear
 * interpolant of the nodal displacements over the face's triangles divided by its area. */
static double bottom_sag(const pf_mesh *m, const double *u)
{
    double total = 0, area = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t a = m->face_offsets[f], b = m->face_offsets[f + 1];
        bool bottom = b - a == 3;
        for (int64_t q = a; q < b && bottom; ++q)
            bottom = fabs(m->x[3 * (size_t)m->face_nodes[q] + 2]) < 1e-12;
        if (!bottom)
            continue;
        const uint32_t *t = m->face_nodes + a;
        pf_vec3 p0 = pf_v3_load(m->x + 3 * (size_t)t[0]), p1 = pf_v3_load(m->x + 3 * (size_t)t[1]),
                p2 = pf_v3_load(m->x + 3 * (size_t)t[2]);
        double s = 0.5 * pf_v3_norm(pf_v3_cross(pf_v3_sub(p1, p0), pf_v3_sub(p2, p0)));
        total += s * (u[3 * (size_t)t[0] + 2] + u[3 * (size_t)t[1] + 2] + u[3 * (size_t)t[2] + 2]) / 3;
        area += s;
    }
    return total / area;
}

/* The cantilever (cube false) on 4r x r x r hexes, or the hanging cube of the DG paper's fig. 9
 * (cube true): the unit cube as r^3 cubes of 6 tetrahedra each, clamped on its top face, under
 * its weight (density 1000, g = 9.81). */
static int solve(const method *md, bool cube, double nu, int r, run *out)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_status made = cube ? pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), r, r, r, &err)
                        : pf_mesh_make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 4 * r, r,
                                           r, &err);
    if (made != PF_OK || pf_mesh_derive(&m, &err) != PF_OK) {
        fprintf(stderr, "bench_guidance: %s\n", err.msg);
        return 1;
    }
    pf_scene sc;
    pf_scene_default(&sc);
    sc.method = md->method;
    sc.flux = md->flux;
    sc.degree = md->degree;
    sc.E = 1e5;
    sc.nu = nu;
    sc.density = cube ? 1000 : 1;
    sc.gravity = (pf_vec3){0, 0, cube ? -9.81 : 0};
    sc.is_static = true;
    sc.ground = false;
    pf_fixed fixed = {
        .region = {.kind = PF_REGION_BOX, .lo = {-0.001, -1, -1}, .hi = {0.001, 2, 2}}};
    if (cube)
        fixed.region = (pf_region){.kind = PF_REGION_BOX, .lo = {-1, -1, 0.999}, .hi = {2, 2, 1.001}};
    pf_load load = {.region = {.kind = PF_REGION_BOX, .lo = {3.999, -1, -1}, .hi = {4.001, 2, 2}},
                    .traction = {0, 0, -1}};
    sc.fixed = &fixed;
    sc.n_fixed = 1;
    sc.loads = cube ? NULL : &load;
    sc.n_loads = cube ? 0 : 1;
    out->cpu = INFINITY;
    int status = 0;
    double spent = 0;
    for (int k = 0; k < REPEAT && !status && spent < 1; ++k) {
        pf_sim *sim = NULL;
        double c0 = bench_cpu_seconds();
        if (pf_sim_create(&sim, &sc, &m, &err) != PF_OK ||
            pf_sim_solve_static(sim, &err) != PF_OK) {
            fprintf(stderr, "bench_guidance: %s\n", err.msg);
            pf_sim_destroy(&sim);
            status = 1;
            break;
        }
        double used = bench_cpu_seconds() - c0;
        out->cpu = fmin(out->cpu, used);
        spent += used;
        double *u = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *u);
        if (!u) {
            pf_sim_destroy(&sim);
            status = 1;
            break;
        }
        pf_sim_nodal_displacements(sim, u);
        double w = 0;
        int count = 0;
        for (int32_t i = 0; i < m.n_nodes; ++i)
            if (fabs(m.x[3 * i] - 4) < 1e-12)
                w += u[3 * i + 2], ++count;
        out->tip = cube ? bottom_sag(&m, u) : w / count;
        const pf_sim_stats *st = pf_sim_get_stats(sim);
        out->dofs = st->dofs;
        out->eta = md->method == PF_METHOD_DG ? st->penalty : 0;
        out->elems = m.n_elems;
        pf_free(u);
        pf_sim_destroy(&sim);
    }
    sc.fixed = NULL, sc.loads = NULL, sc.n_fixed = sc.n_loads = 0; /* borrowed */
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return status;
}

static void print_row(const char *what, double nu, const method *md, int r, const run *x,
                      double reference, double beam)
{
    printf("%s,%g,%s,%s,%d,%d,%d,%lld,%g,%.6e,%+.4e,", what, nu, md->name,
           md->method == PF_METHOD_CG ? "-" : md->flux == PF_FLUX_IP ? "ip" : "bz", md->degree, r,
           (int)x->elems, (long long)x->dofs, x->eta, x->tip, x->tip / reference - 1);
    if (beam != 0)
        printf("%+.4e", x->tip / beam - 1);
    printf(",%.4f\n", x->cpu);
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    if (argc > 1 && !quick) {
        fprintf(stderr, "usage: bench_guidance [--quick]\n");
        return 2;
    }
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# every method of pf-sim with its automatic settings on the cantilever and the hanging "
           "cube; %s\n",
           machine);
    printf("case,nu,method,flux,degree,r,elems,dofs,eta,value,error,beam_error,cpu_s\n");
    enum { N_METHODS = sizeof METHODS / sizeof *METHODS, N_R = 3 };
    static const double NUS[] = {0.3, 0.499};
    /* the hanging cube's reference sags: IP degree 2 on 20,250 tets (bench_locking reference
     * 15, bench/results/locking.csv) */
    static const double CUBE_REFERENCE[] = {-4.639558e-02, -4.043720e-02};
    int n_r = quick ? 2 : N_R, r0 = quick ? 1 : 2;
    for (size_t q = 0; q < sizeof NUS / sizeof *NUS; ++q) {
        double nu = NUS[q];
        run runs[N_METHODS][N_R];
        for (int k = 0; k < N_METHODS; ++k)
            for (int j = 0; j < n_r; ++j) {
                if (solve(&METHODS[k], false, nu, r0 << j, &runs[k][j]))
                    return 1;
                fprintf(stderr, "bench_guidance: nu %g %s %s %d r %d: %.3f s\n", nu,
                        METHODS[k].name, METHODS[k].flux == PF_FLUX_IP ? "ip" : "bz",
                        METHODS[k].degree, r0 << j, runs[k][j].cpu);
            }
        double G = 1e5 / (2 * (1 + nu)), kappa = 10 * (1 + nu) / (12 + 11 * nu);
        double beam = -(64.0 / (3 * 1e5 / 12.0) + 4.0 / (kappa * G));
        /* IP degree 2 (METHODS[2]): Aitken's limit of its three tips when their differences
         * shrink by half or more (a geometric tail, as tests/test_sim.c requires); else the
         * extrapolation means nothing and the reference is beam theory. */
        const run *ip2 = runs[2];
        double d1 = ip2[n_r - 1].tip - ip2[n_r - 2].tip, d0 = ip2[n_r - 2].tip - ip2[0].tip;
        bool aitken = n_r == 3 && fabs(d1) < 0.5 * fabs(d0);
        double limit = aitken ? ip2[2].tip - d1 * d1 / (d1 - d0) : beam;
        const char *name = aitken ? "cantilever" : "cantilever-beam";
        for (int k = 0; k < N_METHODS; ++k)
            for (int j = 0; j < n_r; ++j)
                print_row(name, nu, &METHODS[k], r0 << j, &runs[k][j], limit, beam);
        for (int k = 0; k < N_METHODS; ++k) {
            run x;
            if (solve(&METHODS[k], true, nu, quick ? 2 : 5, &x))
                return 1;
            print_row("cube", nu, &METHODS[k], quick ? 2 : 5, &x, CUBE_REFERENCE[q], 0);
        }
        fflush(stdout);
    }
    return 0;
}
