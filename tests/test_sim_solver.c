/* sim_solver: the simulator on its solver policy (pf/solve.h): pcg against direct on the scenes
 * where the matrix changes (corotation, contact, embedded contact), conservation under pcg, the
 * fallback when PCG cannot converge, and bit-for-bit determinism. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/embed.h>
#include <pf/sim.h>

/* One simulated case: a mesh, optionally an embedded surface, a scene, an initial spin. */
typedef struct sim_case {
    const char *name;
    pf_mesh mesh;
    pf_surface surface;
    pf_weights weights;
    bool embedded;
    pf_scene scene;
    pf_vec3 spin; /* angular velocity about the mesh's centre, rad per time unit */
    int frames;
} sim_case;

static void release_case(sim_case *c)
{
    pf_mesh_release(&c->mesh);
    pf_surface_release(&c->surface);
    pf_weights_release(&c->weights);
    pf_scene_release(&c->scene);
}

/* Runs c with the given solver and returns the nodal displacements of every frame
 * [frames][3 n_nodes] (malloc), and the simulator's statistics. */
static double *run_case(sim_case *c, pf_solver_params solver, pf_sim_stats *stats)
{
    pf_error err = {0};
    pf_scene *sc = &c->scene;
    sc->solver = solver;
    pf_vec3 lo, hi;
    pf_mesh_bounds(&c->mesh, &lo, &hi);
    pf_scene_resolve(sc, lo, hi);
    pf_sim *sim = NULL;
    pf_status st = pf_sim_create_embedded(&sim, sc, &c->mesh, c->embedded ? &c->surface : NULL,
                                          c->embedded ? &c->weights : NULL, &err);
    if (st < 0)
        fail_msg("%s: %s", c->name, err.msg);
    if (pf_v3_max_abs(c->spin) > 0)
        pf_sim_set_rigid_velocity(sim, c->spin, pf_v3_scale(pf_v3_add(lo, hi), 0.5),
                                  (pf_vec3){0, 0, 0});
    size_t nn = 3 * (size_t)c->mesh.n_nodes;
    double *u = malloc((size_t)c->frames * nn * sizeof *u);
    for (int f = 0; f < c->frames; ++f) {
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("%s, %s: %s", c->name, pf_solver_method_name(solver.method), err.msg);
        pf_sim_nodal_displacements(sim, u + (size_t)f * nn);
    }
    *stats = *pf_sim_get_stats(sim);
    pf_sim_destroy(&sim);
    return u;
}

static pf_solver_params method(pf_solver_method m)
{
    pf_solver_params p = pf_solver_params_default();
    p.method = m;
    return p;
}

/* pcg and direct give the same frames to 1e-6 of the largest displacement (the tolerance 1e-10
 * relative to the right-hand side bounds each step's error by 1e-10 times the step matrix's
 * condition, 1e1-1e3 here, and frames accumulate some hundred steps); and pcg refactorises less
 * (every case is large enough that a factorisation costs more than three iterations). */
static void compare_methods(sim_case *c)
{
    pf_sim_stats sd, sp;
    double *ud = run_case(c, method(PF_SOLVER_DIRECT), &sd);
    double *up = run_case(c, method(PF_SOLVER_PCG), &sp);
    size_t total = (size_t)c->frames * 3 * (size_t)c->mesh.n_nodes;
    double largest = 0, diff = 0;
    for (size_t q = 0; q < total; ++q) {
        largest = fmax(largest, fabs(ud[q]));
        diff = fmax(diff, fabs(ud[q] - up[q]));
    }
    printf("%s: largest displacement %.3e, pcg - direct %.2e (%.1e relative); factorisations "
           "direct %lld, pcg %lld; pcg iterations %.1f mean, %d max\n",
           c->name, largest, diff, diff / largest, (long long)sd.factorisations,
           (long long)sp.factorisations,
           sp.solver.pcg_solves ? (double)sp.solver.iterations / (double)sp.solver.pcg_solves : 0,
           (int)sp.solver.max_iterations);
    assert_true(largest > 0);
    assert_true(diff <= 1e-6 * largest);
    assert_true(sp.factorisations < sd.factorisations);
    free(ud);
    free(up);
}

static void make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, lo, hi, nx, ny, nz, &err), PF_OK);
}

static void parse(pf_scene *sc, const char *json)
{
    pf_error err = {0};
    if (pf_scene_parse(sc, json, strlen(json), "case.json", &err) < 0)
        fail_msg("%s", err.msg);
}

/* The demo's scene on a coarser torus: sliced, MLS-embedded, dropped on the ground. */
static void demo_scene_agrees(void **state)
{
    (void)state;
    pf_error err = {0};
    sim_case c = {.name = "embedded torus drop", .frames = 12, .embedded = true};
    assert_int_equal(pf_surface_make_torus(&c.surface, 1, 0.4, 32, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 8;
    assert_int_equal(pf_mesh_slice(&c.mesh, &c.surface, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_embed_compute(&c.mesh, &c.surface, NULL, &c.weights, NULL, &err), PF_OK);
    /* dropped from 0.1 above the ground, so that contact starts within the run */
    parse(&c.scene, "{\"ground\": {\"point\": [0, 0, -0.5]}, \"time\": {\"dt\": 0.02}}");
    compare_methods(&c);
    release_case(&c);
}

/* The demo's torus on CG (harmonic basis, nodal unknowns), MLS-embedded, dropped on the ground
 * from just above it: the contact set changes at most steps once it lands, and each change adds
 * or drops stiff terms over some sixty unknowns (contact.c). pcg tries the old factor on them in
 * the congruence that gives it the new matrix's diagonal blocks, unwarped under contact
 * (solver.c, sim.c): its frames agree with direct's to 1e-8 of the largest displacement (the
 * tolerance 1e-10 relative to the right-hand side, times the step matrix's condition, 1e1-1e2,
 * accumulated over 160 steps: 2.2e-10 measured, 1.7e-10 with the factor plain and warped), and
 * it factorises at most once per 16 steps: 7 times in the 160 (5 for new terms), where the
 * plain warped factor took 19 (9 for new terms, 9 for cost). */
static void cg_embedded_contact_reuses_factor(void **state)
{
    (void)state;
    pf_error err = {0};
    sim_case c = {.name = "embedded torus drop, cg", .frames = 16, .embedded = true};
    assert_int_equal(pf_surface_make_torus(&c.surface, 1, 0.4, 32, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 8;
    assert_int_equal(pf_mesh_slice(&c.mesh, &c.surface, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_embed_compute(&c.mesh, &c.surface, NULL, &c.weights, NULL, &err), PF_OK);
    parse(&c.scene, "{\"method\": \"cg\", \"ground\": {\"point\": [0, 0, -0.42]},"
                    " \"time\": {\"dt\": 0.02}}");
    pf_sim_stats sd, sp2;
    double *ud = run_case(&c, method(PF_SOLVER_DIRECT), &sd);
    double *up = run_case(&c, method(PF_SOLVER_PCG), &sp2);
    size_t total = (size_t)c.frames * 3 * (size_t)c.mesh.n_nodes;
    double largest = 0, diff = 0;
    for (size_t q = 0; q < total; ++q) {
        largest = fmax(largest, fabs(ud[q]));
        diff = fmax(diff, fabs(ud[q] - up[q]));
    }
    const int64_t *why = sp2.solver.by_reason;
    printf("%s: %lld steps, %lld contacts; pcg - direct %.2e of %.3e (%.1e relative); pcg "
           "factorisations %lld (%lld new-terms, %lld pcg-failed, %lld cost), iterations %.1f "
           "mean, %d max\n",
           c.name, (long long)sp2.steps, (long long)sp2.contacts, diff, largest, diff / largest,
           (long long)sp2.factorisations, (long long)why[PF_REFACTOR_NEW],
           (long long)why[PF_REFACTOR_FAILED], (long long)why[PF_REFACTOR_COST],
           sp2.solver.pcg_solves ? (double)sp2.solver.iterations / (double)sp2.solver.pcg_solves
                                 : 0,
           (int)sp2.solver.max_iterations);
    assert_true(sp2.contacts > 0);
    assert_true(largest > 0);
    assert_true(diff <= 1e-8 * largest);
    assert_true(16 * sp2.factorisations <= sp2.steps);
    free(ud);
    free(up);
    release_case(&c);
}

/* A free body spinning at 5 rad/s: pcg keeps linear momentum to 1e-10 (its solves are exact to
 * the tolerance; the momentum of a free body changes only by round-off and the residual). */
static void spinning_body_agrees(void **state)
{
    (void)state;
    sim_case c = {.name = "spinning body", .frames = 10, .spin = {0, 1, 5}};
    make_box(&c.mesh, (pf_vec3){0, 0, 0}, (pf_vec3){2, 1, 1}, 4, 2, 2);
    parse(&c.scene, "{\"gravity\": [0, 0, 0], \"ground\": false, \"damping\": {\"beta\": 0}}");
    compare_methods(&c);

    pf_error err = {0};
    c.scene.solver = method(PF_SOLVER_PCG);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &c.scene, &c.mesh, &err), PF_OK);
    pf_sim_set_rigid_velocity(sim, (pf_vec3){0, 1, 5}, (pf_vec3){1, 0.5, 0.5},
                              (pf_vec3){0.3, 0, 0});
    double ke;
    pf_vec3 p0, p1, l;
    pf_sim_momentum(sim, &ke, &p0, &l);
    for (int f = 0; f < 10; ++f)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    pf_sim_momentum(sim, &ke, &p1, &l);
    double drift = pf_v3_norm(pf_v3_sub(p1, p0)) / pf_v3_norm(p0);
    printf("spinning body under pcg: linear momentum drift %.2e\n", drift);
    assert_true(drift < 1e-10);
    pf_sim_destroy(&sim);
    release_case(&c);
}

/* Clamped cantilevers under gravity with corotation, DG and CG. */
static void cantilevers_agree(void **state)
{
    (void)state;
    static const char *const scenes[] = {
        "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
        " \"ground\": false, \"material\": {\"E\": 1e6}}",
        "{\"method\": \"cg\", \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, "
        "0]}}], \"ground\": false, \"material\": {\"E\": 1e6}}"};
    static const char *const names[] = {"dg cantilever", "cg cantilever"};
    for (int k = 0; k < 2; ++k) {
        sim_case c = {.name = names[k], .frames = 10};
        /* large enough that a factorisation costs more than a few iterations */
        make_box(&c.mesh, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 16, 4, 4);
        parse(&c.scene, scenes[k]);
        compare_methods(&c);
        release_case(&c);
    }
}

/* A box dropped onto a mesh obstacle (a slab of two triangles' closed box). */
static void resting_on_mesh_obstacle_agrees(void **state)
{
    (void)state;
    pf_error err = {0};
    sim_case c = {.name = "box on a mesh obstacle", .frames = 15};
    make_box(&c.mesh, (pf_vec3){0, 0, 0.01}, (pf_vec3){1, 1, 0.51}, 3, 3, 2);
    parse(&c.scene, "{\"ground\": false, \"obstacles\": [{\"box\": [[-1, -1, -1], [2, 2, 0]]}],"
                    " \"time\": {\"dt\": 0.02}}");
    /* the obstacle as a mesh: the box's surface */
    pf_mesh slab = {0};
    make_box(&slab, (pf_vec3){-1, -1, -1}, (pf_vec3){2, 2, 0}, 1, 1, 1);
    pf_boundary b = {0};
    assert_int_equal(pf_boundary_extract(&slab, &b, &err), PF_OK);
    pf_obstacle *o = &c.scene.obstacles[0];
    o->kind = PF_OBSTACLE_MESH;
    int32_t nt = (int32_t)b.tri_offsets[b.n_faces];
    assert_int_equal(pf_surface_alloc(&o->surface, slab.n_nodes, nt, &err), PF_OK);
    memcpy(o->surface.x, slab.x, 3 * (size_t)slab.n_nodes * sizeof *slab.x);
    memcpy(o->surface.tri, b.tri, 3 * (size_t)nt * sizeof *b.tri);
    pf_boundary_release(&b);
    pf_mesh_release(&slab);
    compare_methods(&c);
    release_case(&c);
}

/* A tolerance that max_iterations cannot reach: every solve on an old factor fails, refactorises
 * (counted as such) and solves exactly, so the frames are still direct's. */
static void failing_pcg_falls_back(void **state)
{
    (void)state;
    sim_case c = {.name = "spinning body, 1 iteration", .frames = 5, .spin = {0, 1, 5}};
    make_box(&c.mesh, (pf_vec3){0, 0, 0}, (pf_vec3){2, 1, 1}, 4, 2, 2);
    parse(&c.scene, "{\"gravity\": [0, 0, 0], \"ground\": false}");
    pf_solver_params p = method(PF_SOLVER_PCG);
    p.tolerance = 1e-15;
    p.max_iterations = 1;
    pf_sim_stats sp, sd;
    double *up = run_case(&c, p, &sp);
    double *ud = run_case(&c, method(PF_SOLVER_DIRECT), &sd);
    size_t total = (size_t)c.frames * 3 * (size_t)c.mesh.n_nodes;
    double diff = 0, largest = 0;
    for (size_t q = 0; q < total; ++q) {
        diff = fmax(diff, fabs(up[q] - ud[q]));
        largest = fmax(largest, fabs(ud[q]));
    }
    printf("forced failures: %lld of %lld factorisations, frames differ by %.1e of %.2e\n",
           (long long)sp.solver.by_reason[PF_REFACTOR_FAILED], (long long)sp.factorisations, diff,
           largest);
    assert_true(sp.solver.by_reason[PF_REFACTOR_FAILED] > 0);
    assert_true(diff <= 1e-9 * largest);
    free(up);
    free(ud);
    release_case(&c);
}

/* The same pcg run twice gives the same bits. */
static void pcg_is_deterministic(void **state)
{
    (void)state;
    sim_case c = {.name = "cantilever", .frames = 6, .spin = {0, 0, 0}};
    make_box(&c.mesh, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 8, 2, 2);
    parse(&c.scene, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
                    " \"ground\": false}");
    pf_sim_stats s1, s2;
    double *u1 = run_case(&c, method(PF_SOLVER_PCG), &s1);
    double *u2 = run_case(&c, method(PF_SOLVER_PCG), &s2);
    assert_memory_equal(u1, u2, (size_t)c.frames * 3 * (size_t)c.mesh.n_nodes * sizeof *u1);
    free(u1);
    free(u2);
    release_case(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(demo_scene_agrees),      cmocka_unit_test(spinning_body_agrees),
        cmocka_unit_test(cantilevers_agree),      cmocka_unit_test(resting_on_mesh_obstacle_agrees),
        cmocka_unit_test(failing_pcg_falls_back), cmocka_unit_test(pcg_is_deterministic),
        cmocka_unit_test(cg_embedded_contact_reuses_factor),
    };
    if (getenv("PF_TEST_FILTER"))
        cmocka_set_test_filter(getenv("PF_TEST_FILTER"));
    return cmocka_run_group_tests(tests, NULL, NULL);
}
