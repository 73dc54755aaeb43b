/* The simulator core on its solver policy (pf/solve.h): steps against factorisations.
 *
 *   bench_solver beam       CSV per corotated beam (one end fixed, gravity, no contact; the
 *                           1,911- and 17,775-hex beams of SOFA's published benchmark, 39 x 7 x 7
 *                           and 79 x 15 x 15 cells), CG and DG degree 1, direct and pcg:
 *                           case,method,solver,elements,dofs,steps,factorisations,
 *                           factor_cpu_ms,step_cpu_ms,step_per_factor,steps_per_cpu_s,
 *                           pcg_mean,pcg_max
 *                           step_per_factor: CPU per step over the CPU of one factorisation of
 *                           the same case measured in this run: the direct row's mean (warm
 *                           refactorisations of the corotated matrix), the row's own when the
 *                           direct row did not run (a ROW selection)
 *   bench_solver spin       CSV per rotation speed of a free box (1, 5, 20 rad/s; 100 steps):
 *                           omega,factorisations_per_100,pcg_mean,pcg_max
 *   bench_solver contact    CSV: the demo's scene (data/scenes/drop.json, the torus sliced at res
 *                           12, 30 frames: falling, then on the ground) with contact at the
 *                           MLS-embedded surface and at the mesh nodes, CPU per step:
 *                           contact,steps,contacts_per_step,factorisations,step_cpu_ms,ratio
 *   bench_solver ... quick  smaller cases (a check that the program runs)
 *   bench_solver beam ROW   only the beam rows that begin with ROW (e.g. "39x7x7,cg,pcg"), for a
 *                           profiler
 *
 * CPU seconds (the process clock), so that a busy machine biases the figures little; the first
 * line says what machine and load they were taken on. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/embed.h>
#include <pf/sim.h>

#include "machine.h"

static int fail(const pf_error *err)
{
    fprintf(stderr, "bench_solver: %s\n", err->msg);
    return 1;
}

static pf_status parse(pf_scene *sc, const char *json, pf_error *err)
{
    return pf_scene_parse(sc, json, strlen(json), "bench.json", err);
}

/* Runs steps / substeps frames, returning CPU seconds and the statistics. */
/* A scene file read whole and parsed, as pf-sim reads one. */
static pf_status load_scene(pf_scene *sc, const char *path, pf_error *err)
{
    pf_buffer text = {0};
    pf_status st = pf_buffer_read_file(&text, path, PF_SCENE_MAX_BYTES, err);
    if (st == PF_OK)
        st = pf_scene_parse(sc, (const char *)text.data, text.size, path, err);
    pf_buffer_release(&text);
    return st;
}

static pf_status run(pf_scene *sc, const pf_mesh *m, const pf_surface *s, const pf_weights *w,
                     pf_vec3 spin, int frames, double *cpu, pf_sim_stats *stats, pf_error *err)
{
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(sc, lo, hi);
    pf_sim *sim = NULL;
    PF_TRY(pf_sim_create_embedded(&sim, sc, m, s, w, err));
    if (pf_v3_max_abs(spin) > 0)
        pf_sim_set_rigid_velocity(sim, spin, pf_v3_scale(pf_v3_add(lo, hi), 0.5), pf_v3(0, 0, 0));
    double c0 = bench_cpu_seconds();
    pf_status st = PF_OK;
    for (int f = 0; f < frames && st >= 0; ++f)
        st = pf_sim_frame(sim, err);
    *cpu = bench_cpu_seconds() - c0;
    *stats = *pf_sim_get_stats(sim);
    pf_sim_destroy(&sim);
    return st;
}

static double pcg_mean(const pf_sim_stats *st)
{
    return st->solver.pcg_solves ? (double)st->solver.iterations / (double)st->solver.pcg_solves
                                 : 0;
}

static int beams(bool quick, const char *only)
{
    static const int cells[][3] = {{39, 7, 7}, {79, 15, 15}};
    printf("case,method,solver,elements,dofs,steps,factorisations,factor_cpu_ms,step_cpu_ms,"
           "step_per_factor,steps_per_cpu_s,pcg_mean,pcg_max\n");
    double direct_factor_ms = 0; /* of the case and method last run with direct */
    for (int c = 0; c < (quick ? 1 : 2); ++c)
        for (int method = 0; method < 2; ++method)
            for (int solver = PF_SOLVER_DIRECT; solver <= PF_SOLVER_PCG; ++solver) {
                if (c == 1 && method == 0)
                    continue; /* DG on the large beam: not one of the targets, and slow */
                const int *n = cells[c];
                char row[64];
                snprintf(row, sizeof row, "%dx%dx%d,%s,%s", n[0], n[1], n[2], method ? "cg" : "dg1",
                         pf_solver_method_name((pf_solver_method)solver));
                if (solver == PF_SOLVER_DIRECT)
                    direct_factor_ms = 0;
                if (only && strncmp(row, only, strlen(only)) != 0)
                    continue;
                pf_error err = {0};
                pf_mesh m = {0};
                double h = 0.1;
                pf_status st =
                    pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(n[0] * h, n[1] * h, n[2] * h), n[0],
                                     n[1], n[2], &err);
                pf_scene sc;
                if (st >= 0)
                    st = parse(&sc,
                               method ? "{\"method\": \"cg\", \"ground\": false, \"material\": "
                                        "{\"E\": 1e6}, \"fixed\": [{\"plane\": {\"point\": [0, "
                                        "0, 0], \"normal\": [1, 0, 0]}}]}"
                                      : "{\"ground\": false, \"material\": {\"E\": 1e6}, "
                                        "\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], "
                                        "\"normal\": [1, 0, 0]}}]}",
                               &err);
                if (st < 0)
                    return fail(&err);
                sc.solver.method = (pf_solver_method)solver;
                int frames = quick ? 2 : c == 1 && solver == PF_SOLVER_DIRECT ? 2 : 10;
                double cpu;
                pf_sim_stats s;
                if (run(&sc, &m, NULL, NULL, pf_v3(0, 0, 0), frames, &cpu, &s, &err) < 0)
                    return fail(&err);
                double steps = (double)s.steps;
                double factor_ms = 1e3 * s.solver.factor_cpu_seconds /
                                   (double)(s.factorisations > 0 ? s.factorisations : 1);
                /* the step's cost without the first factorisation (every policy pays it) */
                double step_ms = 1e3 * (cpu - factor_ms / 1e3) / steps;
                if (solver == PF_SOLVER_DIRECT)
                    direct_factor_ms = factor_ms;
                double per = direct_factor_ms > 0 ? direct_factor_ms : factor_ms;
                printf("%s,%d,%lld,%lld,%lld,%.1f,%.1f,%.3f,%.2f,%.2f,%d\n", row, (int)m.n_elems,
                       (long long)s.dofs, (long long)s.steps, (long long)s.factorisations,
                       factor_ms, step_ms, step_ms / per, 1e3 / step_ms, pcg_mean(&s),
                       (int)s.solver.max_iterations);
                fflush(stdout);
                pf_scene_release(&sc);
                pf_mesh_release(&m);
            }
    return 0;
}

static int spins(bool quick)
{
    printf("omega,factorisations_per_100,pcg_mean,pcg_max\n");
    static const double omega[] = {1, 5, 20};
    for (int k = 0; k < 3; ++k) {
        pf_error err = {0};
        pf_mesh m = {0};
        pf_scene sc;
        pf_status st = pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), quick ? 8 : 16,
                                        quick ? 4 : 8, quick ? 4 : 8, &err);
        if (st >= 0)
            st = parse(&sc,
                       "{\"gravity\": [0, 0, 0], \"ground\": false, \"material\": {\"E\": 1e6},"
                       " \"solver\": \"pcg\"}",
                       &err);
        double cpu;
        pf_sim_stats s;
        if (st >= 0)
            st = run(&sc, &m, NULL, NULL, pf_v3(0.2 * omega[k], 0.3 * omega[k], omega[k]), 10, &cpu,
                     &s, &err);
        if (st < 0)
            return fail(&err);
        printf("%g,%.1f,%.2f,%d\n", omega[k], 100.0 * (double)s.factorisations / (double)s.steps,
               pcg_mean(&s), (int)s.solver.max_iterations);
        fflush(stdout);
        pf_scene_release(&sc);
        pf_mesh_release(&m);
    }
    return 0;
}

static int contacts(bool quick)
{
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    pf_weights w = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = quick ? 6 : 12;
    pf_status st = pf_surface_make_torus(&s, 1, 0.4, 64, 32, &err);
    if (st >= 0)
        st = pf_mesh_slice(&m, &s, &sp, NULL, &err);
    if (st >= 0)
        st = pf_embed_compute(&m, &s, NULL, &w, NULL, &err);
    if (st < 0)
        return fail(&err);
    printf("contact,steps,contacts_per_step,factorisations,step_cpu_ms,ratio\n");
    double node_ms = 0;
    for (int embedded = 0; embedded < 2; ++embedded) {
        pf_scene sc; /* the demo's */
        if (load_scene(&sc, PF_MODELS_DIR "/../scenes/drop.json", &err) < 0)
            return fail(&err);
        double cpu;
        pf_sim_stats stats;
        if (run(&sc, &m, embedded ? &s : NULL, embedded ? &w : NULL, pf_v3(0, 0, 0), quick ? 3 : 30,
                &cpu, &stats, &err) < 0)
            return fail(&err);
        double ms = 1e3 * cpu / (double)stats.steps;
        if (!embedded)
            node_ms = ms;
        printf("%s,%lld,%.1f,%lld,%.2f,%.3f\n", embedded ? "embedded" : "nodes",
               (long long)stats.steps, (double)stats.contacts / (double)stats.steps,
               (long long)stats.factorisations, ms, ms / node_ms);
        fflush(stdout);
        pf_scene_release(&sc);
    }
    pf_weights_release(&w);
    pf_mesh_release(&m);
    pf_surface_release(&s);
    return 0;
}

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "beam";
    bool quick = argc > 2 && strcmp(argv[2], "quick") == 0;
    const char *only = argc > 2 && !quick ? argv[2] : NULL;
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# %s\n", machine);
    if (!strcmp(mode, "beam"))
        return beams(quick, only);
    if (!strcmp(mode, "spin"))
        return spins(quick);
    if (!strcmp(mode, "contact"))
        return contacts(quick);
    fprintf(stderr, "usage: bench_solver [beam|spin|contact] [quick], bench_solver beam ROW\n");
    return 2;
}
