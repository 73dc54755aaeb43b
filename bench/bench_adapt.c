/* Changing the mesh while the simulation runs (pf_sim_refine, pf_sim_split).
 *
 *   bench_adapt events     CSV per bar, method and split kind: the bars of the harmonic paper's
 *                          table 1 (40 hexes, 10 x 2 x 2 cells of a 5 x 1 x 1 bar, 99 nodes):
 *                          "bending", clamped at both ends and sagging under gravity, and
 *                          "twisting", clamped at one end and set spinning about its axis. After
 *                          10 frames the bar is refined (threshold: a fraction of its largest
 *                          principal stress then) until nothing more splits (max_level 2), and
 *                          runs 10 frames more. Per case: elements and nodes before and after,
 *                          the changes, the elements split, milliseconds per split element (all
 *                          of it, and its parts: new mesh, method set-up, the rest of the set-up,
 *                          state transfer; the first factorisation on the new mesh), the
 *                          fraction of DG integrals copied instead of computed, and steps per CPU
 *                          second before and after:
 *                          case,method,split,elems_before,nodes_before,elems_after,nodes_after,
 *                          changes,split_elems,ms_per_split,mesh_ms,method_ms,setup_ms,
 *                          transfer_ms,factor_ms,reused,steps_per_s_before,steps_per_s_after
 *   bench_adapt accuracy   CSV: the static cantilever of bench_guidance (4 x 1 x 1, clamped at
 *                          x = 0, traction (0, 0, -1) on x = 4, E = 1e5, nu = 0.3), CG and DG IP
 *                          degree 1 and 2: its compliance (the work of the end load, f . u,
 *                          pf_sim_load_work: twice the elastic energy, the whole end face
 *                          weighed) against the 3-D limit, against unknowns. Uniform meshes of
 *                          4r x r x r hexes ("uniform", r up to 8, CG 16), and meshes refined by
 *                          stress from r = 2 and 4 ("stress"): each level splits (octs) where
 *                          the criterion's own stress (pf_sim_principal_stresses: the largest
 *                          principal stress at centroid and vertices) exceeds fraction (0.6 or
 *                          0.9) of its largest value on the last solution:
 *                          method,mesh,r,fraction,level,elems,dofs,compliance,error,cpu_s
 *   bench_adapt reuse      CSV: the CPU cost of the mesh changes of a CG run with the set-up
 *                          taking over the shape functions and matrices of unchanged elements
 *                          (mode "reuse", the default) and with every set-up from scratch
 *                          (scene key refine.rebuild: mode "rebuild"), on the bending bar of
 *                          "events" (40 hexes, closed forms) and on a sliced sphere (radius 1,
 *                          8 x 16 facets, sliced 5 across: harmonic boundary cells), fixed at
 *                          the bottom, sagging under gravity: after 5 frames refined until nothing
 *                          more splits (octs, threshold a fraction, 0.8 then 0.5, of the largest
 *                          von Mises stress, max_level 2), then 3 frames more. Per case, fraction
 *                          and mode: elements before and after, changes, split elements, CPU
 *                          seconds of all changes and of their method set-ups, per change, the
 *                          elements whose functions and matrices were copied and computed, and a
 *                          hash of the nodal displacements after the last frame (the same in
 *                          both modes: reuse changes no bit). The first row, "warm-up", is a
 *                          quick run that takes the process's start-up costs out of the others:
 *                          case,fraction,mode,elems_before,elems_after,changes,split_elems,
 *                          change_cpu_s,method_cpu_s,change_ms_per_change,basis_reused,
 *                          basis_built,matrices_reused,matrices_computed,hash
 *                          Before the table, a comment line: every element of the sphere split by
 *                          octs at once and a CG simulator built on the result (the harmonic
 *                          basis on every refined cell).
 *   bench_adapt reuse ... slice N  the sphere sliced N across (default 5). At 6 the
 *                          stress-driven runs once stopped at their third change ("nodes are
 *                          collinear": a face between the planes of neighbours split in successive
 *                          changes); the planes are now moved clear of such nodes
 *                          (PF_REFINE_SHIFT, pf/refine.h)
 *   bench_adapt embed      CSV: the embedded surface's MLS weights after each of three local
 *                          refinements (octs of the elements whose mean corner lies in the last
 *                          30 %, 15 %, 7.5 % of the mesh's extent in x), updated (pf_embed_update)
 *                          against computed afresh (pf_embed_compute_steps; checked to be the same
 *                          bits): a sphere (radius 0.95, 64 x 128 facets) in a sliced sphere
 *                          (radius 1, 8 x 16 facets, sliced 8 across, or N: slice N) and the bunny
 *                          in its own mesh sliced 8 across. CPU seconds of each (the fastest of
 *                          3 runs):
 *                          case,change,elems,nodes,nodes_changed,rows,rows_computed,full_cpu_s,
 *                          update_cpu_s,speedup
 *   bench_adapt ... quick  smaller cases (a check that the program runs)
 *
 * Timings are CPU seconds of the process (pf_sim_stats' refinement parts, the first
 * factorisation's CPU from the solver's statistics, steps per CPU second), so that a busy machine
 * biases them little; the first line says what machine and load they were taken on. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/embed.h>
#include <pf/io.h>
#include <pf/mesh.h>
#include <pf/refine.h>
#include <pf/sim.h>

#include "machine.h"

/* The static cantilever's compliance (the work of its end load, f . u) in the 3-D limit at
 * nu = 0.3: the Aitken extrapolation of DG IP degree 2 on the uniform meshes r = 2, 4, 8
 * (2.605771, 2.630603, 2.638146e-3). Its uncertainty is about 2e-4 relative: CG on r = 4, 8, 16
 * extrapolates to 2.640942e-3, and DG degree 2 on r = 8 with its clamp's elements refined twice
 * (2.640395e-3) gains another ~3e-7 from the clamp and ~1e-7 to 5e-7 from the rest. */
static const double CANTILEVER_COMPLIANCE = 2.641436e-3;

static int fail(const pf_error *err)
{
    fprintf(stderr, "bench_adapt: %s\n", err->msg);
    return 1;
}

static pf_status parse(pf_scene *sc, const char *json, pf_error *err)
{
    return pf_scene_parse(sc, json, strlen(json), "bench.json", err);
}

/* CPU seconds per step over frames frames. */
static pf_status time_frames(pf_sim *sim, int frames, int substeps, double *steps_per_s,
                             pf_error *err)
{
    double c0 = bench_cpu_seconds();
    for (int f = 0; f < frames; ++f)
        PF_TRY(pf_sim_frame(sim, err));
    double used = bench_cpu_seconds() - c0;
    *steps_per_s = used > 0 ? frames * substeps / used : INFINITY;
    return PF_OK;
}

/* The scene's refine parameters with the threshold at fraction of the largest von Mises stress
 * now, splits up to max_level deep, no coarsening. */
static pf_status set_threshold(pf_sim *sim, pf_scene *sc, pf_split_kind kind, double fraction,
                               int32_t max_level, pf_error *err)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    double *vm = pf_alloc_array((size_t)m->n_elems, sizeof *vm);
    PF_CHECK(vm, err, PF_ERR_NOMEM, "out of memory");
    pf_sim_von_mises(sim, vm);
    double largest = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        largest = fmax(largest, vm[e]);
    pf_free(vm);
    sc->refine = (pf_refine_params){.enabled = true,
                                    .threshold = fraction * largest,
                                    .split = kind,
                                    .max_level = max_level,
                                    .max_elements = 100000};
    return PF_OK;
}

/* Refines until nothing splits (max_level 2), with the threshold at fraction of the largest
 * stress now. */
static pf_status refine_fully(pf_sim *sim, pf_scene *sc, pf_split_kind kind, double fraction,
                              pf_error *err)
{
    PF_TRY(set_threshold(sim, sc, kind, fraction, 2, err));
    for (int32_t split = 1; split > 0;)
        PF_TRY(pf_sim_refine(sim, &split, err));
    sc->refine.enabled = false; /* the timed frames after do not refine */
    return PF_OK;
}

static int event_case(const char *name, const char *json, bool cg, pf_split_kind kind, bool spin,
                      bool quick)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_scene sc;
    int frames = quick ? 2 : 10;
    if (pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(5, 1, 1), 10, 2, 2, &err) < 0 ||
        pf_mesh_derive(&m, &err) < 0 || parse(&sc, json, &err) < 0)
        return fail(&err);
    sc.method = cg ? PF_METHOD_CG : PF_METHOD_DG;
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    double before = 0, after = 0;
    pf_status st = pf_sim_create(&sim, &sc, &m, &err);
    if (st >= 0 && spin)
        pf_sim_set_rigid_velocity(sim, pf_v3(4, 0, 0), pf_v3(2.5, 0.5, 0.5), pf_v3(0, 0, 0));
    if (st >= 0)
        st = time_frames(sim, frames, sc.substeps, &before, &err);
    pf_sim_stats s0 = st >= 0 ? *pf_sim_get_stats(sim) : (pf_sim_stats){0};
    if (st >= 0)
        st = refine_fully(sim, &sc, kind, 0.5, &err);
    pf_sim_stats s1 = st >= 0 ? *pf_sim_get_stats(sim) : (pf_sim_stats){0};
    /* the first step on the new mesh factorises it */
    if (st >= 0)
        st = pf_sim_frame(sim, &err);
    pf_sim_stats s2 = st >= 0 ? *pf_sim_get_stats(sim) : (pf_sim_stats){0};
    if (st >= 0)
        st = time_frames(sim, frames, sc.substeps, &after, &err);
    if (st < 0) {
        pf_sim_destroy(&sim);
        return fail(&err);
    }
    const pf_mesh *now = pf_sim_mesh(sim);
    double n_split = (double)(s1.elements_split > 0 ? s1.elements_split : 1);
    double ms = 1e3 / n_split;
    double factor_ms =
        1e3 * (s2.solver.factor_cpu_seconds - s1.solver.factor_cpu_seconds) / n_split;
    int64_t integrals = s1.integrals_reused + s1.integrals_computed;
    printf("%s,%s,%s,%d,%d,%d,%d,%d,%lld,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.1f,%.1f\n", name,
           cg ? "cg" : "dg", kind == PF_SPLIT_OCTS ? "octs" : "halves", (int)m.n_elems,
           (int)m.n_nodes, (int)now->n_elems, (int)now->n_nodes, (int)s1.refinements,
           (long long)s1.elements_split, ms * (s1.refine_seconds - s0.refine_seconds),
           ms * s1.refine_mesh_seconds, ms * s1.refine_method_seconds, ms * s1.refine_setup_seconds,
           ms * s1.refine_transfer_seconds, factor_ms,
           integrals > 0 ? (double)s1.integrals_reused / (double)integrals : 0.0, before, after);
    fflush(stdout);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return 0;
}

static int events(bool quick)
{
    static const char BENDING[] =
        "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}},"
        " {\"plane\": {\"point\": [5, 0, 0], \"normal\": [1, 0, 0]}}], \"ground\": false,"
        " \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.02}}";
    static const char TWISTING[] =
        "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
        " \"ground\": false, \"gravity\": [0, 0, 0], \"material\": {\"E\": 1e6},"
        " \"damping\": {\"beta\": 0.02}}";
    printf("case,method,split,elems_before,nodes_before,elems_after,nodes_after,changes,"
           "split_elems,ms_per_split,mesh_ms,method_ms,setup_ms,transfer_ms,factor_ms,reused,"
           "steps_per_s_before,steps_per_s_after\n");
    for (int cg = 0; cg < 2; ++cg)
        for (int kind = 0; kind < 2; ++kind) {
            if (event_case("bending", BENDING, cg, (pf_split_kind)kind, false, quick) ||
                event_case("twisting", TWISTING, cg, (pf_split_kind)kind, true, quick))
                return 1;
        }
    return 0;
}

/* FNV-1a over the bytes of n doubles. */
static uint64_t hash_doubles(const double *v, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    const unsigned char *b = (const unsigned char *)v;
    for (size_t i = 0; i < n * sizeof *v; ++i)
        h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* One CG run of "reuse" on mesh m (borrowed) with the scene json, refining with the set-up's
 * reuse on or off (rebuild). */
static int reuse_case(const char *name, const pf_mesh *m, const char *json, double fraction,
                      bool rebuild, bool quick)
{
    pf_error err = {0};
    pf_scene sc;
    if (parse(&sc, json, &err) < 0)
        return fail(&err);
    sc.method = PF_METHOD_CG;
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    pf_status st = pf_sim_create(&sim, &sc, m, &err);
    for (int f = 0; st >= 0 && f < (quick ? 2 : 5); ++f)
        st = pf_sim_frame(sim, &err);
    pf_sim_stats s0 = st >= 0 ? *pf_sim_get_stats(sim) : (pf_sim_stats){0};
    if (st >= 0)
        st = set_threshold(sim, &sc, PF_SPLIT_OCTS, fraction, quick ? 1 : 2, &err);
    sc.refine.rebuild = rebuild;
    for (int32_t split = 1; st >= 0 && split > 0;)
        st = pf_sim_refine(sim, &split, &err);
    sc.refine.enabled = false;
    pf_sim_stats s1 = st >= 0 ? *pf_sim_get_stats(sim) : (pf_sim_stats){0};
    for (int f = 0; st >= 0 && f < 3; ++f)
        st = pf_sim_frame(sim, &err);
    double *u = NULL;
    if (st >= 0) {
        u = pf_alloc_array(3 * (size_t)pf_sim_mesh(sim)->n_nodes, sizeof *u);
        st = u ? PF_OK : pf_error_set(&err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    if (st < 0) {
        pf_sim_destroy(&sim);
        pf_scene_release(&sc);
        return fail(&err);
    }
    pf_sim_nodal_displacements(sim, u);
    int32_t changes = s1.refinements - s0.refinements;
    double change = s1.refine_seconds - s0.refine_seconds;
    double method = s1.refine_method_seconds - s0.refine_method_seconds;
    printf("%s,%.2f,%s,%d,%d,%d,%lld,%.4f,%.4f,%.2f,%lld,%lld,%lld,%lld,%016llx\n", name, fraction,
           rebuild ? "rebuild" : "reuse", (int)m->n_elems, (int)pf_sim_mesh(sim)->n_elems,
           (int)changes, (long long)(s1.elements_split - s0.elements_split), change, method,
           changes > 0 ? 1e3 * change / changes : 0.0,
           (long long)(s1.basis_reused - s0.basis_reused),
           (long long)(s1.basis_computed - s0.basis_computed),
           (long long)(s1.integrals_reused - s0.integrals_reused),
           (long long)(s1.integrals_computed - s0.integrals_computed),
           (unsigned long long)hash_doubles(u, 3 * (size_t)pf_sim_mesh(sim)->n_nodes));
    fflush(stdout);
    pf_free(u);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    return 0;
}

/* Every element of the sphere by octs at once (pf_mesh_refine), then a CG simulator on the result:
 * the check that the harmonic basis builds on every refined element (a comment line). */
static int all_octs_check(const pf_mesh *sphere, int res, const char *json)
{
    pf_error err = {0};
    pf_refine_request *req = pf_calloc((size_t)sphere->n_elems, sizeof *req);
    if (!req)
        return fprintf(stderr, "bench_adapt: out of memory\n"), 1;
    for (int32_t e = 0; e < sphere->n_elems; ++e)
        req[e] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_OCTS};
    pf_mesh fine = {0};
    pf_refine_result rr;
    pf_scene sc;
    pf_sim *sim = NULL;
    double c0 = bench_cpu_seconds();
    pf_status st = pf_mesh_refine(sphere, req, sphere->n_elems, &fine, &rr, &err);
    pf_free(req);
    if (st >= 0) {
        pf_refine_result_release(&rr);
        st = parse(&sc, json, &err);
    }
    if (st >= 0) {
        sc.method = PF_METHOD_CG;
        pf_vec3 lo, hi;
        pf_mesh_bounds(&fine, &lo, &hi);
        pf_scene_resolve(&sc, lo, hi);
        st = pf_sim_create(&sim, &sc, &fine, &err);
        if (st >= 0)
            printf("# sphere sliced %d across, every element by octs: %d -> %d elements, CG built "
                   "(%.2f CPU s)\n",
                   res, (int)sphere->n_elems, (int)fine.n_elems, bench_cpu_seconds() - c0);
        pf_sim_destroy(&sim);
        pf_scene_release(&sc);
    }
    pf_mesh_release(&fine);
    return st < 0 ? fail(&err) : 0;
}

static int reuse(bool quick, int slice)
{
    static const char SAG[] =
        "{\"fixed\": [{\"box\": [[-9, -9, -9], [9, 9, -0.75]]}], \"ground\": false,"
        " \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.02}}";
    static const char BENDING[] =
        "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}},"
        " {\"plane\": {\"point\": [5, 0, 0], \"normal\": [1, 0, 0]}}], \"ground\": false,"
        " \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.02}}";
    pf_error err = {0};
    pf_mesh bar = {0}, sphere = {0};
    pf_surface s = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = slice > 0 ? slice : quick ? 3 : 5;
    if (pf_mesh_make_box(&bar, pf_v3(0, 0, 0), pf_v3(5, 1, 1), 10, 2, 2, &err) < 0 ||
        pf_mesh_derive(&bar, &err) < 0 || pf_surface_make_sphere(&s, 1, 8, 16, &err) < 0 ||
        pf_mesh_slice(&sphere, &s, &sp, NULL, &err) < 0 || pf_mesh_derive(&sphere, &err) < 0)
        return fail(&err);
    pf_surface_release(&s);
    printf(
        "case,fraction,mode,elems_before,elems_after,changes,split_elems,change_cpu_s,method_cpu_s,"
        "change_ms_per_change,basis_reused,basis_built,matrices_reused,matrices_computed,"
        "hash\n");
    /* a first run, not timed in the table: the process's first set-up pays page faults and
     * library start-up that would bias whichever mode ran first */
    int rc = reuse_case("warm-up", &bar, BENDING, 0.8, true, true);
    if (!rc)
        rc = all_octs_check(&sphere, sp.grid.res, SAG);
    const double fractions[2] = {0.8, 0.5};
    for (int k = 0; k < 2 && !rc; ++k)
        for (int rebuild = 0; rebuild < 2 && !rc; ++rebuild)
            rc = reuse_case("bending", &bar, BENDING, fractions[k], rebuild, quick) ||
                 reuse_case("sphere", &sphere, SAG, fractions[k], rebuild, quick);
    pf_mesh_release(&bar);
    pf_mesh_release(&sphere);
    return rc;
}

/* The largest magnitude of the refinement criterion's stress over the elements now. */
static pf_status largest_criterion_stress(const pf_sim *sim, double *largest, pf_error *err)
{
    int32_t n = pf_sim_mesh(sim)->n_elems;
    double *value = pf_alloc_array((size_t)n, sizeof *value);
    pf_vec3 *dir = pf_alloc_array((size_t)n, sizeof *dir);
    pf_status st = value && dir ? PF_OK
                                : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                               "out of memory for %d stresses", (int)n);
    *largest = 0;
    if (st >= 0)
        pf_sim_principal_stresses(sim, value, dir);
    for (int32_t e = 0; st >= 0 && e < n; ++e)
        *largest = fmax(*largest, fabs(value[e]));
    pf_free(value);
    pf_free(dir);
    return st;
}

static const char *const METHOD_NAMES[3] = {"cg", "dg1", "dg2"};

static void print_accuracy(int method, const char *mesh, int r, double fraction, int level,
                           const pf_sim *sim, double cpu)
{
    double c = pf_sim_load_work(sim);
    printf("%s,%s,%d,%.2f,%d,%d,%lld,%.8e,%.4e,%.4f\n", METHOD_NAMES[method], mesh, r, fraction,
           level, (int)pf_sim_mesh(sim)->n_elems, (long long)pf_sim_get_stats(sim)->dofs, c,
           1 - c / CANTILEVER_COMPLIANCE, cpu);
    fflush(stdout);
}

/* method 0: CG, 1 and 2: DG IP of that degree. fraction 0: the uniform mesh 4r x r x r alone;
 * else that mesh refined levels times, each time (octs) where the criterion's stress exceeds
 * fraction of its largest value on the last solution. */
static int accuracy_case(int method, int r, double fraction, int levels)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_scene sc;
    char json[512];
    snprintf(json, sizeof json,
             "{\"static\": true, \"material\": {\"E\": 1e5, \"density\": 1},"
             " \"gravity\": [0, 0, 0], \"method\": {\"degree\": %d},"
             " \"fixed\": [{\"box\": [[-0.001, -1, -1], [0.001, 2, 2]]}],"
             " \"loads\": [{\"box\": [[3.999, -1, -1], [4.001, 2, 2]],"
             " \"traction\": [0, 0, -1]}]}",
             method > 0 ? method : 1);
    if (pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(4, 1, 1), 4 * r, r, r, &err) < 0 ||
        pf_mesh_derive(&m, &err) < 0 || parse(&sc, json, &err) < 0)
        return fail(&err);
    sc.method = method == 0 ? PF_METHOD_CG : PF_METHOD_DG;
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    double c0 = bench_cpu_seconds();
    pf_status st = pf_sim_create(&sim, &sc, &m, &err);
    if (st >= 0)
        st = pf_sim_solve_static(sim, &err);
    const char *mesh = fraction > 0 ? "stress" : "uniform";
    if (st >= 0)
        print_accuracy(method, mesh, r, fraction, 0, sim, bench_cpu_seconds() - c0);
    for (int level = 1; st >= 0 && level <= levels; ++level) {
        double largest = 0;
        st = largest_criterion_stress(sim, &largest, &err);
        sc.refine = (pf_refine_params){.enabled = true,
                                       .threshold = fraction * largest,
                                       .split = PF_SPLIT_OCTS,
                                       .max_level = level,
                                       .max_elements = 1000000};
        if (st >= 0)
            st = pf_sim_refine(sim, NULL, &err);
        if (st >= 0)
            st = pf_sim_solve_static(sim, &err);
        if (st >= 0)
            print_accuracy(method, mesh, r, fraction, level, sim, bench_cpu_seconds() - c0);
    }
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return st < 0 ? fail(&err) : 0;
}

static int accuracy(bool quick)
{
    static const int uniform_r[3][8] = {
        {1, 2, 3, 4, 5, 6, 8, 16}, {1, 2, 3, 4, 5, 6, 8, 0}, {1, 2, 3, 4, 5, 6, 8, 0}};
    printf("method,mesh,r,fraction,level,elems,dofs,compliance,error,cpu_s\n");
    for (int method = 0; method < 3; ++method) {
        for (int k = 0; k < 8 && uniform_r[method][k] > 0; ++k)
            if ((!quick || uniform_r[method][k] <= 2) &&
                accuracy_case(method, uniform_r[method][k], 0, 0))
                return 1;
        if (accuracy_case(method, 2, 0.6, quick ? 1 : 2) ||
            accuracy_case(method, 2, 0.9, quick ? 1 : 3) ||
            (!quick && accuracy_case(method, 4, 0.9, 3)))
            return 1;
    }
    return 0;
}

/* The mean x of element e's face corners (each face's own). */
static double elem_mean_x(const pf_mesh *m, int32_t e)
{
    double sum = 0;
    int64_t n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q, ++n)
            sum += m->x[3 * (size_t)m->face_nodes[q]];
    }
    return sum / (double)n;
}

/* Octs of the elements of *m whose mean corner x exceeds cut; *m becomes the refined mesh. */
static pf_status refine_beyond(pf_mesh *m, double cut, pf_error *err)
{
    pf_refine_request *req = pf_alloc_array((size_t)m->n_elems, sizeof *req);
    PF_CHECK(req, err, PF_ERR_NOMEM, "out of memory for %d requests", (int)m->n_elems);
    int32_t n = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        if (elem_mean_x(m, e) > cut)
            req[n++] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_OCTS};
    pf_mesh next = {0};
    pf_refine_result res;
    pf_status st = pf_mesh_refine(m, req, n, &next, &res, err);
    pf_free(req);
    if (st < 0)
        return st;
    pf_refine_result_release(&res);
    next.id = m->id + 1;
    pf_mesh_release(m);
    *m = next;
    return PF_OK;
}

static bool same_weights(const pf_weights *a, const pf_weights *b)
{
    size_t nnz = (size_t)a->row_offsets[a->rows];
    return a->rows == b->rows && a->cols == b->cols && nnz == (size_t)b->row_offsets[b->rows] &&
           !memcmp(a->row_offsets, b->row_offsets, ((size_t)a->rows + 1) * sizeof(int64_t)) &&
           !memcmp(a->col, b->col, nnz * sizeof *a->col) &&
           !memcmp(a->val, b->val, nnz * sizeof *a->val);
}

/* One change from (old, w0, steps0): the fastest of 3 full computations and of 3 updates. */
static pf_status embed_change(const char *name, int change, const pf_mesh *old, const pf_mesh *m,
                              const pf_surface *s, pf_weights *w0, int32_t **steps0,
                              pf_error *err)
{
    int32_t *steps = pf_alloc_array((size_t)s->n_verts, sizeof *steps);
    PF_CHECK(steps, err, PF_ERR_NOMEM, "out of memory for %d steps", (int)s->n_verts);
    pf_weights full = {0}, up = {0};
    pf_embed_update_stats ust;
    double t_full = INFINITY, t_up = INFINITY;
    pf_status st = PF_OK;
    for (int r = 0; r < 3 && st >= 0; ++r) {
        pf_weights_release(&full);
        pf_weights_release(&up);
        double c0 = bench_cpu_seconds();
        st = pf_embed_compute_steps(m, s, NULL, &full, steps, NULL, err);
        double c1 = bench_cpu_seconds();
        if (st >= 0)
            st = pf_embed_update(old, w0, *steps0, m, NULL, s, NULL, &up, steps, &ust, err);
        t_full = fmin(t_full, c1 - c0);
        t_up = fmin(t_up, bench_cpu_seconds() - c1);
    }
    if (st >= 0 && !same_weights(&full, &up))
        st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                          "%s change %d: the updated weights differ from the computed ones", name,
                          change);
    if (st >= 0)
        printf("%s,%d,%d,%d,%d,%d,%d,%.6f,%.6f,%.2f\n", name, change, (int)m->n_elems,
               (int)m->n_nodes, (int)ust.nodes_changed, (int)ust.rows, (int)ust.rows_computed,
               t_full, t_up, t_full / t_up);
    pf_weights_release(&up);
    pf_weights_release(w0);
    *w0 = full;
    pf_free(*steps0);
    *steps0 = steps;
    return st;
}

static pf_status embed_case(const char *name, pf_mesh *m, const pf_surface *s, pf_error *err)
{
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    int32_t *steps = pf_alloc_array((size_t)s->n_verts, sizeof *steps);
    PF_CHECK(steps, err, PF_ERR_NOMEM, "out of memory for %d steps", (int)s->n_verts);
    pf_weights w = {0};
    pf_mesh old = {0};
    m->id = 1;
    pf_status st = pf_embed_compute_steps(m, s, NULL, &w, steps, NULL, err);
    double band = 0.3;
    for (int change = 1; change <= 3 && st >= 0; ++change, band /= 2) {
        pf_mesh_release(&old);
        st = pf_mesh_copy(&old, m, err);
        if (st >= 0)
            st = refine_beyond(m, hi.x - band * (hi.x - lo.x), err);
        if (st >= 0)
            st = embed_change(name, change, &old, m, s, &w, &steps, err);
    }
    pf_mesh_release(&old);
    pf_weights_release(&w);
    pf_free(steps);
    return st;
}

static int embed(bool quick, int slice)
{
    pf_error err = {0};
    pf_surface outer = {0}, inner = {0}, bunny = {0};
    pf_mesh sphere = {0}, bunny_mesh = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = slice > 0 ? slice : quick ? 4 : 8;
    if (pf_surface_make_sphere(&outer, 1, 8, 16, &err) < 0 ||
        pf_surface_make_sphere(&inner, 0.95, quick ? 16 : 64, quick ? 32 : 128, &err) < 0 ||
        pf_mesh_slice(&sphere, &outer, &sp, NULL, &err) < 0 ||
        pf_import_surface(PF_MODELS_DIR "/bunny.obj", &bunny, &err) < 0 ||
        pf_mesh_slice(&bunny_mesh, &bunny, &sp, NULL, &err) < 0)
        return fail(&err);
    printf("case,change,elems,nodes,nodes_changed,rows,rows_computed,full_cpu_s,update_cpu_s,"
           "speedup\n");
    pf_status st = embed_case("sphere", &sphere, &inner, &err);
    if (st >= 0)
        st = embed_case("bunny", &bunny_mesh, &bunny, &err);
    pf_mesh_release(&sphere);
    pf_mesh_release(&bunny_mesh);
    pf_surface_release(&outer);
    pf_surface_release(&inner);
    pf_surface_release(&bunny);
    return st < 0 ? fail(&err) : 0;
}

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "events";
    bool quick = false;
    int slice = 0;
    for (int i = 2; i < argc; ++i) {
        if (!strcmp(argv[i], "quick"))
            quick = true;
        else if (!strcmp(argv[i], "slice") && i + 1 < argc && atoi(argv[i + 1]) >= 2)
            slice = atoi(argv[++i]);
        else
            mode = "";
    }
    char machine[256];
    bench_describe_machine(machine, sizeof machine);
    printf("# mesh changes while the simulation runs; %s\n", machine);
    if (!strcmp(mode, "events"))
        return events(quick);
    if (!strcmp(mode, "accuracy"))
        return accuracy(quick);
    if (!strcmp(mode, "reuse"))
        return reuse(quick, slice);
    if (!strcmp(mode, "embed"))
        return embed(quick, slice);
    fprintf(stderr, "usage: bench_adapt events|accuracy|reuse|embed [quick] [slice N]\n");
    return 2;
}
