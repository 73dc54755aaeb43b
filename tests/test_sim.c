/* sim: the DG simulator against conservation laws, invariances and beam theory. */
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

#include <pf/sim.h>

static void make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, lo, hi, nx, ny, nz, &err), PF_OK);
}

/* A free body: no gravity, no ground, no damping. */
static void free_scene(pf_scene *sc, int degree)
{
    pf_scene_default(sc);
    sc->degree = degree;
    sc->gravity = (pf_vec3){0, 0, 0};
    sc->ground = false;
    sc->damping_alpha = sc->damping_beta = 0;
}

static double norm3n(const double *v, int32_t n)
{
    double s = 0;
    for (int64_t k = 0; k < 3 * (int64_t)n; ++k)
        s += v[k] * v[k];
    return sqrt(s);
}

/* The nodal velocity after one step from rest in displacement state a x + b: (u1 - u0) / h. */
static double response_to_state(pf_mesh *m, pf_scene *sc, const double a[9], const double b[3])
{
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, sc, m, &err), PF_OK);
    pf_sim_set_affine_displacement(sim, a, b);
    double *u0 = malloc(3 * (size_t)m->n_nodes * sizeof *u0);
    double *u1 = malloc(3 * (size_t)m->n_nodes * sizeof *u1);
    pf_sim_nodal_displacements(sim, u0);
    assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    pf_sim_nodal_displacements(sim, u1);
    for (int64_t k = 0; k < 3 * (int64_t)m->n_nodes; ++k)
        u1[k] -= u0[k];
    double moved = norm3n(u1, m->n_nodes);
    free(u0);
    free(u1);
    pf_sim_destroy(&sim);
    return moved;
}

/* The rest shape turned rigidly by 90 degrees about z (around the box centre c) feels no elastic
 * force with corotation: one step moves it by less than 1e-10 of what a 1 % stretch moves it.
 * Without corotation, linear elasticity sees the rotation as a large strain (the test's check
 * that it can fail). */
static void corotation_has_no_ghost_forces(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){2, 1, 1}, 4, 2, 2);
    const double c[3] = {1, 0.5, 0.5};
    /* u = (Q - I)(x - c), Q = rotation by 90 degrees about z */
    const double q_minus_i[9] = {-1, -1, 0, 1, -1, 0, 0, 0, 0};
    double b[3];
    for (int i = 0; i < 3; ++i)
        b[i] = -(q_minus_i[3 * i] * c[0] + q_minus_i[3 * i + 1] * c[1] + q_minus_i[3 * i + 2] * c[2]);
    const double stretch[9] = {0.01, 0, 0, 0, 0, 0, 0, 0, 0};
    const double zero[3] = {0, 0, 0};
    for (int degree = 1; degree <= 2; ++degree) {
        pf_scene sc;
        free_scene(&sc, degree);
        sc.substeps = 1;
        sc.dt = 1e-3;
        double rotated = response_to_state(&m, &sc, q_minus_i, b);
        double strained = response_to_state(&m, &sc, stretch, zero);
        if (!(rotated <= 1e-10 * strained))
            fail_msg("degree %d: rotated rest shape moves %g, 1%% strain %g", degree, rotated,
                     strained);
        sc.corotation = false;
        double linear = response_to_state(&m, &sc, q_minus_i, b);
        assert_true(linear > 10 * strained);
        pf_scene_release(&sc);
    }
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A free body spinning at 1 rad/s for 1000 steps (1 s): linear momentum is kept exactly (internal
 * forces, warped or not, sum to zero), angular momentum and volume drift less than 1 %.
 * Semi-implicit Euler damps the spin slightly; the drifts are printed for the record. */
static void spinning_body_keeps_momentum(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){-0.5, -0.5, -0.5}, (pf_vec3){0.5, 0.5, 0.5}, 3, 3, 3);
    pf_scene sc;
    free_scene(&sc, 1);
    sc.dt = 0.01;
    sc.substeps = 10;
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    pf_sim_set_rigid_velocity(sim, (pf_vec3){0, 0, 1}, (pf_vec3){0, 0, 0},
                              (pf_vec3){0.1, 0, 0});
    double ke0, ke1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &ke0, &p0, &l0);
    double v0 = pf_sim_deformed_volume(sim);
    for (int k = 0; k < 100; ++k)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    pf_sim_momentum(sim, &ke1, &p1, &l1);
    double v1 = pf_sim_deformed_volume(sim);
    double dp = pf_v3_norm(pf_v3_sub(p1, p0)) / pf_v3_norm(p0);
    double dl = fabs(l1.z - l0.z) / fabs(l0.z);
    double dv = fabs(v1 - v0) / v0;
    printf("spinning body, 1000 steps: linear momentum drift %.2e, angular %.2e, volume %.2e\n",
           dp, dl, dv);
    assert_true(dp < 1e-10);
    assert_true(dl < 0.01);
    assert_true(dv < 0.01);
    pf_sim_destroy(&sim);

    /* Linear elasticity under the same spin grows in volume (sec. 6): recorded, not required. */
    sc.corotation = false;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    pf_sim_set_rigid_velocity(sim, (pf_vec3){0, 0, 1}, (pf_vec3){0, 0, 0}, (pf_vec3){0, 0, 0});
    for (int k = 0; k < 100; ++k)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    printf("without corotation: volume change %.2e\n", pf_sim_deformed_volume(sim) / v0 - 1);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The static cantilever of the issue: 4 x 1 x 1, clamped at x = 0, under a traction (0, 0, -1)
 * on the end face x = 4 or, with gravity, under its weight (density 1, g = 1: a load of 1 per
 * unit length). Returns the vertical displacement of the tip: the mean over the nodes of the end
 * face x = 4 (the coarsest mesh has no node at the centre of that face). */
static double cantilever_tip(int refine, int degree, pf_flux flux, double penalty, bool gravity,
                             double *jump)
{
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 4 * refine, refine, refine);
    pf_scene sc;
    pf_scene_default(&sc);
    sc.E = 1e5;
    sc.nu = 0.3;
    sc.density = 1;
    sc.degree = degree;
    sc.flux = flux;
    sc.penalty = penalty;
    sc.gravity = (pf_vec3){0, 0, gravity ? -1 : 0};
    sc.is_static = true;
    sc.ground = false;
    pf_fixed fixed = {.region = {.kind = PF_REGION_BOX, .lo = {-0.001, -1, -1}, .hi = {0.001, 2, 2}}};
    pf_load load = {.region = {.kind = PF_REGION_BOX, .lo = {3.999, -1, -1}, .hi = {4.001, 2, 2}},
                    .traction = {0, 0, -1}};
    sc.fixed = &fixed;
    sc.n_fixed = 1;
    sc.loads = gravity ? NULL : &load;
    sc.n_loads = gravity ? 0 : 1;
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    assert_int_equal(pf_sim_solve_static(sim, &err), PF_OK);
    double *u = malloc(3 * (size_t)m.n_nodes * sizeof *u);
    pf_sim_nodal_displacements(sim, u);
    if (jump)
        *jump = pf_sim_max_node_jump(sim);
    double w = 0;
    int count = 0;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        if (fabs(m.x[3 * i] - 4) < 1e-12)
            w += u[3 * i + 2], ++count;
    assert_int_equal(count, (refine + 1) * (refine + 1));
    w /= count;
    free(u);
    pf_sim_destroy(&sim);
    sc.fixed = NULL, sc.loads = NULL, sc.n_fixed = sc.n_loads = 0; /* borrowed */
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return w;
}

/* Runs IP degree 2 on 4r x r x r hexes (r = 1, 2, 4) and degree 1 on r = 2, 4, 8, and returns
 * the limit of the degree-2 tips t0, t1, t2: Aitken's extrapolation
 * t2 - (t2 - t1)^2 / (t2 - 2 t1 + t0), exact for a geometric sequence of differences (the
 * measured limits lie 0.6 % and 0.7 % beyond t2). Checks that both degrees converge toward it:
 * the degree-2 differences shrink by half or more, and the distance of degree 1 to that limit
 * shrinks by the factors given (a degree-1 sequence heading for another limit would stall at
 * the difference of the two). */
static double ip_cantilever_limit(bool gravity)
{
    double d1[3], d2[3];
    for (int r = 0; r < 3; ++r) {
        d1[r] = cantilever_tip(2 << r, 1, PF_FLUX_IP, 0, gravity, NULL);
        d2[r] = cantilever_tip(1 << r, 2, PF_FLUX_IP, 0, gravity, NULL);
    }
    assert_true(fabs(d2[2] - d2[1]) < 0.5 * fabs(d2[1] - d2[0]));
    double limit = d2[2] - (d2[2] - d2[1]) * (d2[2] - d2[1]) / (d2[2] - 2 * d2[1] + d2[0]);
    double e1[3];
    for (int r = 0; r < 3; ++r) {
        e1[r] = fabs(d1[r] / limit - 1);
        printf("cantilever (%s): IP degree 1 on %2d x %d x %d: %.6e (%.2f %% from the limit); "
               "degree 2 on %2d x %d x %d: %.6e\n",
               gravity ? "gravity" : "end traction", 8 << r, 2 << r, 2 << r, d1[r], 100 * e1[r],
               4 << r, 1 << r, 1 << r, d2[r]);
    }
    printf("cantilever (%s): IP limit %.6e, degree-1 error ratios %.3f %.3f\n",
           gravity ? "gravity" : "end traction", limit, e1[1] / e1[0], e1[2] / e1[1]);
    /* measured 0.55, 0.37 (traction) and 0.57, 0.38 (gravity): heading for the h^2 of the
     * asymptotic range (0.25); a limit of its own would drive the ratios up toward 1 */
    assert_true(e1[1] < 0.7 * e1[0]);
    assert_true(e1[2] < 0.5 * e1[1]);
    return limit;
}

/* IP converges under refinement toward one limit for degree 1 and 2 (sec. 3.3). For the end
 * traction, Timoshenko's beam value is P L^3 / (3 E I) + P L / (k G A) = 2.56e-3 + 1.25e-4
 * (k = 5/6); under gravity, q L^4 / (8 E I) + q L^2 / (2 k G A) = 3.84e-3 + 2.496e-4 (q = 1).
 * The 3-D limit approaches them within a few percent (the clamped end and the load's spread are
 * not in beam theory: 3 % covers them). Degree 1 is pre-asymptotic on these meshes (one linear
 * element cannot bend, so coarse degree-1 beams are stiff) but its distance to the degree-2
 * limit falls faster at every refinement. */
static void bz_against_ip_limit(double limit);
static void bz_converges(double limit);

static void cantilever_converges(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    double limit = ip_cantilever_limit(true);
    double timoshenko = -(3.84e-3 + 16.0 / (2 * 5.0 / 6.0 * 1e5 / 2.6));
    assert_true(fabs(limit / timoshenko - 1) < 0.03);
    limit = ip_cantilever_limit(false);
    timoshenko = -(2.56e-3 + 4.0 / (5.0 / 6.0 * 1e5 / 2.6));
    assert_true(fabs(limit / timoshenko - 1) < 0.03);
    bz_against_ip_limit(limit);
    bz_converges(limit);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* BZ is not consistent (sec. 3.3): on a fixed mesh its tip is recorded against the IP limit as
 * the penalty grows (degree 2, 8 x 2 x 2 hexes, where BZ's growth factor (L / h)^2 of
 * pf_dg_face_penalty is a constant 10.1). The error is signed, > 0 softer than the limit.
 * Asserted: (1) the jumps shrink at every step, to below 1 % of their size at the first eta;
 * (2) up to eta = 1, below the crossing (near 2), the error is positive and shrinks at every
 * doubling; (3) beyond the crossing BZ moves on toward the overly stiff limit of an infinite
 * penalty, so the error is negative, grows, and by ever smaller steps (it converges). That limit
 * is the Galerkin solution in the continuous fields of the DG space (continuous piecewise
 * quadratics): a conforming method without DG's extra freedom (fig. 3: for a large penalty DG
 * approximates CG, sec. 9.1: eta should not be too high), stiffer in bending on this coarse mesh
 * than the exact solution. On a fixed mesh BZ's error therefore shrinks with the penalty only up
 * to where it crosses the IP limit; it does not vanish as the penalty grows (sec. 3.3). What
 * makes it vanish is refinement with the growing penalty (bz_converges). */
static void bz_against_ip_limit(double limit)
{
    double first_jump = 0, previous_jump = INFINITY, previous = INFINITY, step = INFINITY;
    static const double ETAS[] = {1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1, 8, 32, 128, 512};
    for (size_t q = 0; q < sizeof ETAS / sizeof *ETAS; ++q) {
        double eta = ETAS[q], jump;
        double e = cantilever_tip(2, 2, PF_FLUX_BZ, eta, false, &jump) / limit - 1;
        printf("BZ degree 2 on 8 x 2 x 2, eta %g: tip error %+.3e against the IP limit, "
               "largest jump %.3e\n",
               eta, e, jump);
        assert_true(jump < previous_jump);
        previous_jump = jump;
        if (q == 0)
            first_jump = jump;
        if (eta <= 1) {
            assert_true(e > 0 && e < previous);
        } else {
            assert_true(e < 0);
            if (eta > 8) {
                assert_true(previous - e > 0 && previous - e < step);
                step = previous - e;
            }
        }
        previous = e;
    }
    assert_true(previous_jump < 0.01 * first_jump);
}

/* BZ converges under refinement (issue 17): with its penalty growing like h^-(p+1)
 * (pf_dg_face_penalty) and the automatic eta (3/16 at degree 1, 1/2 at degree 2), the tip error
 * against the IP limit falls at every refinement of 8 x 2 x 2, 16 x 4 x 4, 32 x 8 x 8 hexes.
 * Measured (bench_dg bzconverge): degree 1 +50, +15, +3.8 %; degree 2 +11, +1.4, -0.1 % (the
 * limit's own uncertainty is about 0.2 %: Aitken's limits from r = 1, 2, 4 and from r = 2, 4, 8
 * differ by that). Asserted: the error shrinks by at least the factor given at each pair
 * (degree 1: 0.45, for ratios 0.29 and 0.26 measured, theory 0.5; degree 2: 0.25, for 0.13
 * and 0.09 measured, theory 0.25), and the finest error is below 8 % (degree 1) and 0.5 % (degree 2). */
static void bz_converges(double limit)
{
    static const double RATIO[] = {0.45, 0.25}, FINEST[] = {0.08, 0.005};
    for (int degree = 1; degree <= 2; ++degree) {
        double e[3];
        for (int q = 0; q < 3; ++q) {
            int r = 2 << q;
            e[q] = cantilever_tip(r, degree, PF_FLUX_BZ, 0, false, NULL) / limit - 1;
            printf("BZ degree %d on %2d x %d x %d, automatic penalty: tip error %+.3e\n", degree,
                   4 * r, r, r, e[q]);
        }
        for (int q = 1; q < 3; ++q)
            assert_true(fabs(e[q]) < RATIO[degree - 1] * fabs(e[q - 1]));
        assert_true(fabs(e[2]) < FINEST[degree - 1]);
    }
}

/* A box dropped on the ground settles on it: after 2 s every node is above the plane minus the
 * penetration the contact stiffness predicts for the weight (times 3 for the dynamic overshoot
 * still ringing), and nothing fell through. */
static void dropped_box_rests_on_ground(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 1}, (pf_vec3){1, 1, 2}, 3, 3, 3);
    pf_scene sc;
    pf_scene_default(&sc);
    sc.ground_point = (pf_vec3){0, 0, 0};
    sc.ground_auto = false;
    sc.damping_beta = 0.01;
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    for (int k = 0; k < 60; ++k)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    double *u = malloc(3 * (size_t)m.n_nodes * sizeof *u);
    pf_sim_nodal_displacements(sim, u);
    double lowest = INFINITY;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        lowest = fmin(lowest, m.x[3 * i + 2] + u[3 * i + 2]);
    printf("dropped box: lowest node at z = %.3e after %.1f s\n", lowest, pf_sim_time(sim));
    assert_true(lowest < 0.01);   /* it reached the ground */
    assert_true(lowest > -0.01);  /* and did not sink into it */
    free(u);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The scene written back (SCEN) parses into the same scene: every field, overrides included. */
static void scene_round_trips_through_json(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    static const char text[] =
        "{\"material\": {\"E\": 1.5e5, \"nu\": 0.49, \"density\": 3},"
        " \"method\": {\"name\": \"dg\", \"degree\": 2, \"flux\": \"bz\", \"penalty\": 7},"
        " \"fixed\": [{\"plane\": {\"point\": [0, 0, 1], \"normal\": [0, 0, 2]},"
        " \"displacement\": [0.1, 0, 0]}],"
        " \"loads\": [{\"box\": [[0, 0, 0], [1, 1, 0.1]], \"traction\": [0, 0, -3]}],"
        " \"ground\": {\"point\": [0, 0, -0.1], \"stiffness\": 1e6},"
        " \"time\": {\"dt\": 0.1, \"frames\": 3, \"substeps\": 4}}";
    pf_scene a, b;
    pf_error err = {0};
    assert_int_equal(pf_scene_parse(&a, text, sizeof text - 1, "a.json", &err), PF_OK);
    assert_int_equal(pf_scene_override(&a, "nu", "0.25", &err), PF_OK);
    char *json = NULL;
    assert_int_equal(pf_scene_to_json(&a, &json, &err), PF_OK);
    assert_int_equal(pf_scene_parse(&b, json, strlen(json), "SCEN", &err), PF_OK);
    assert_true(a.E == b.E && b.nu == 0.25 && a.density == b.density);
    assert_true(a.method == b.method && a.degree == b.degree && a.flux == b.flux);
    assert_true(a.penalty == b.penalty && a.corotation == b.corotation);
    assert_int_equal(b.n_fixed, 1);
    assert_true(b.fixed[0].region.kind == PF_REGION_PLANE);
    assert_true(b.fixed[0].region.plane.d == a.fixed[0].region.plane.d);
    assert_true(b.fixed[0].displacement.x == 0.1);
    assert_int_equal(b.n_loads, 1);
    assert_true(b.loads[0].region.hi.z == 0.1 && b.loads[0].traction.z == -3);
    assert_true(b.ground && !b.ground_auto && b.ground_point.z == -0.1);
    assert_true(b.ground_stiffness == 1e6);
    assert_true(b.dt == 0.1 && b.frames == 3 && b.substeps == 4 && !b.is_static);
    pf_free(json);
    pf_scene_release(&a);
    pf_scene_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void bad_scenes_are_refused(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 1, 1, 1);
    pf_scene sc;
    pf_scene_default(&sc);
    pf_error err = {0};
    pf_sim *sim = NULL;
    sc.is_static = true; /* nothing fixed */
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_null(sim);
    sc.method = PF_METHOD_CG; /* the same for cg (tests/test_cg.c has the method itself) */
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_null(sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The error indicator (pf_sim_error_indicator) is round-off where the method is exact and
 * large where it is not. DG: an affine displacement on hexes (the patch test: every element
 * holds it exactly, so its nodal values agree) against the static cantilever of 4 hexes, degree
 * 1, under its end traction (bending that linear elements cannot hold, so neighbours disagree
 * at the nodes: 1.5 %, while its tip is about half the converged one: the indicator measures
 * non-conformity, not locking). CG: closed forms on a box (0) against the uniform shape functions of the 8 x 16
 * sphere sliced 3 across (boundary errors 7-19 %, pf/basis.h). */
static double indicator_of(pf_mesh *m, pf_scene *sc, bool affine, bool solve)
{
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, sc, m, &err), PF_OK);
    if (affine) {
        const double a[9] = {1e-3, 2e-4, -3e-4, 5e-4, -2e-3, 1e-4, 3e-4, -1e-4, 1.5e-3};
        const double b[3] = {1e-3, -2e-3, 5e-4};
        pf_sim_set_affine_displacement(sim, a, b);
    }
    if (solve)
        assert_int_equal(pf_sim_solve_static(sim, &err), PF_OK);
    double ind = pf_sim_error_indicator(sim);
    pf_sim_destroy(&sim);
    return ind;
}

static void error_indicator_small_and_large(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    pf_scene sc;
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){2, 1, 1}, 2, 2, 2);
    free_scene(&sc, 1);
    double dg_patch = indicator_of(&m, &sc, true, false);
    sc.method = PF_METHOD_CG;
    double cg_box = indicator_of(&m, &sc, true, false);
    pf_scene_release(&sc);
    pf_mesh_release(&m);

    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 4, 1, 1);
    pf_scene_default(&sc);
    sc.E = 1e5;
    sc.degree = 1;
    sc.gravity = (pf_vec3){0, 0, 0};
    sc.is_static = true;
    sc.ground = false;
    pf_fixed fixed = {.region = {.kind = PF_REGION_BOX, .lo = {-0.001, -1, -1}, .hi = {0.001, 2, 2}}};
    pf_load load = {.region = {.kind = PF_REGION_BOX, .lo = {3.999, -1, -1}, .hi = {4.001, 2, 2}},
                    .traction = {0, 0, -1}};
    sc.fixed = &fixed, sc.n_fixed = 1;
    sc.loads = &load, sc.n_loads = 1;
    double dg_beam = indicator_of(&m, &sc, false, true);
    sc.fixed = NULL, sc.loads = NULL, sc.n_fixed = sc.n_loads = 0; /* borrowed */
    pf_scene_release(&sc);
    pf_mesh_release(&m);

    pf_error err = {0};
    pf_surface sphere = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 1, 8, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 3;
    assert_int_equal(pf_mesh_slice(&m, &sphere, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    free_scene(&sc, 1);
    sc.method = PF_METHOD_CG;
    double cg_sliced = indicator_of(&m, &sc, false, false);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    pf_surface_release(&sphere);
    printf("error indicator: dg patch %.2e, dg coarse beam %.3f; cg box %.2e, cg sliced sphere "
           "%.3f\n",
           dg_patch, dg_beam, cg_box, cg_sliced);
    assert_true(dg_patch < 1e-12);
    assert_true(cg_box == 0);
    assert_true(dg_beam > 0.01); /* measured 0.015: 1e13 times the patch test's */
    assert_true(cg_sliced > 0.05);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(corotation_has_no_ghost_forces),
        cmocka_unit_test(spinning_body_keeps_momentum),
        cmocka_unit_test(cantilever_converges),
        cmocka_unit_test(dropped_box_rests_on_ground),
        cmocka_unit_test(scene_round_trips_through_json),
        cmocka_unit_test(bad_scenes_are_refused),
        cmocka_unit_test(error_indicator_small_and_large),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
