/* contact: penalty contact with obstacles and the ground (DG paper sec. 8), at boundary nodes
 * and at embedded-surface vertices, against force balance, exact agreement between equivalent
 * obstacles, and the scene reader's messages. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
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
#include <unistd.h>

#include <pf/embed.h>
#include <pf/io.h>
#include <pf/sim.h>
#include <pf/solve.h>

#include "sim/contact.h"
#include "test_random.h"

static const double G = 9.81;

static void make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, lo, hi, nx, ny, nz, &err), PF_OK);
}

static void parse(pf_scene *sc, const char *text, const char *name)
{
    pf_error err = {0};
    pf_status st = pf_scene_parse(sc, text, strlen(text), name, &err);
    if (st != PF_OK)
        fprintf(stderr, "%s\n", err.msg);
    assert_int_equal(st, PF_OK);
}

static double mesh_mass(const pf_mesh *m, double density)
{
    return density * pf_mesh_volume(m);
}

/* Stitched nodal positions x + u of the simulator's current state. */
static double *positions(const pf_sim *sim, const pf_mesh *m)
{
    double *x = malloc(3 * (size_t)m->n_nodes * sizeof *x);
    pf_sim_nodal_displacements(sim, x);
    for (int64_t q = 0; q < 3 * (int64_t)m->n_nodes; ++q)
        x[q] += m->x[q];
    return x;
}

/* A box resting on a plane obstacle. At rest the penalty forces carry the weight: with N points
 * in contact, each pressed to depth d_i with stiffness k, sum k d_i = m g, so the mean depth is
 * exactly m g / (N k) (the stiffness-predicted depth of the whole contact, k_c = N k). The
 * residual after 3 s of damped settling (alpha = 10 / s: the rigid bounce decays as e^{-5 t},
 * 3e-7 of the impact velocity) is far below the 1 % allowed; no point may sink deeper than 1.5
 * times the mean (the elastic sag of a stiff box under its own weight spreads the depths by
 * rho g H^2 / E relative terms, here under 10 %). No contact work without ground or obstacles. */
static void box_rests_on_plane_obstacle(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0.02}, (pf_vec3){1, 1, 0.52}, 4, 4, 2);
    pf_scene sc;
    parse(&sc,
          "{\"material\": {\"E\": 1e7, \"density\": 1000}, \"ground\": false,"
          " \"damping\": {\"alpha\": 10, \"beta\": 0.001},"
          " \"obstacles\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 1]},"
          " \"stiffness\": 1e6}], \"time\": {\"dt\": 0.05, \"substeps\": 5}}",
          "plane.json");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    assert_int_equal(pf_sim_get_stats(sim)->contact_points,
                     5 * 5 * 3 - 3 * 3 * 1); /* boundary nodes */
    for (int k = 0; k < 60; ++k)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    double *x = positions(sim, &m);
    double sum = 0, deepest = 0;
    int n = 0;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        if (x[3 * i + 2] < 0) {
            sum += -x[3 * i + 2];
            deepest = fmax(deepest, -x[3 * i + 2]);
            ++n;
        }
    double predicted = mesh_mass(&m, 1000) * G / (n * 1e6);
    printf("plane obstacle: %d points in contact, mean depth %.6e (m g / k_c = %.6e), deepest "
           "%.3e\n",
           n, sum / n, predicted, deepest);
    assert_int_equal(n, 25);
    assert_true(fabs(sum / n / predicted - 1) < 0.01);
    assert_true(deepest < 1.5 * predicted);
    free(x);
    pf_sim_destroy(&sim);

    /* no ground, no obstacles: no contact points, no contact time */
    sc.n_obstacles = 0;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    assert_int_equal(pf_sim_get_stats(sim)->contact_points, 0);
    assert_true(pf_sim_get_stats(sim)->contact_seconds == 0);
    assert_true(pf_sim_get_stats(sim)->embed_seconds == 0);
    pf_sim_destroy(&sim);
    sc.n_obstacles = 1;
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A closed box surface [lo, hi], each face split into n x n squares of two triangles,
 * counter-clockwise seen from outside. */
static void box_surface(pf_surface *s, pf_vec3 lo, pf_vec3 hi, int n)
{
    pf_error err = {0};
    int per = (n + 1) * (n + 1);
    assert_int_equal(pf_surface_alloc(s, 6 * per, 6 * 2 * n * n, &err), PF_OK);
    int v = 0, t = 0;
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            int a = (axis + 1) % 3, b = (axis + 2) % 3, base = v;
            for (int j = 0; j <= n; ++j)
                for (int i = 0; i <= n; ++i, ++v) {
                    double p[3];
                    p[axis] = side ? pf_v3_get(hi, axis) : pf_v3_get(lo, axis);
                    p[a] = pf_v3_get(lo, a) + (pf_v3_get(hi, a) - pf_v3_get(lo, a)) * i / n;
                    p[b] = pf_v3_get(lo, b) + (pf_v3_get(hi, b) - pf_v3_get(lo, b)) * j / n;
                    memcpy(s->x + 3 * v, p, sizeof p);
                }
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    uint32_t q00 = (uint32_t)(base + j * (n + 1) + i), q10 = q00 + 1,
                             q01 = q00 + (uint32_t)(n + 1), q11 = q01 + 1;
                    /* (a, b, axis) is right-handed: counter-clockwise in (a, b) faces +axis */
                    uint32_t quad[2][3] = {{q00, q10, q11}, {q00, q11, q01}};
                    for (int k = 0; k < 2; ++k, ++t)
                        for (int c = 0; c < 3; ++c)
                            s->tri[3 * t + c] = side ? quad[k][c] : quad[k][2 - c];
                }
        }
}

static double lowest_z(const double *x, int32_t n)
{
    double z = INFINITY;
    for (int32_t i = 0; i < n; ++i)
        z = fmin(z, x[3 * i + 2]);
    return z;
}

/* A voxelized ball dropped from 0.3 onto a slab read from an OBJ file (a mesh obstacle, path
 * relative to the scene file) at the default dt: it must not pass through. Its flat bottom face
 * lands with speed v = sqrt(2 g z0) on N nodes of stiffness k each; a rigid body would sink
 * v sqrt(m / (N k)) before stopping, and the elastic body, which stores part of the energy in its
 * own deformation and meets more contact points as it sinks, less: that is the bound on the
 * lowest node (while the slab is 0.1 thick). And it must move exactly as on a plane obstacle at
 * the slab's top: every contact point lands inside the top face, where the closest point and its
 * normal are the plane's up to rounding (1e-9 of the size, over the 1/4 s after impact). */
static void ball_dropped_on_mesh_obstacle(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface ball = {0}, slab = {0};
    assert_int_equal(pf_surface_make_sphere(&ball, 0.25, 12, 24, &err), PF_OK);
    for (int32_t i = 0; i < ball.n_verts; ++i)
        ball.x[3 * i + 2] += 0.55;
    pf_mesh m = {0};
    pf_voxelize_params vp = pf_voxelize_params_default();
    vp.res = 4;
    assert_int_equal(pf_mesh_voxelize(&m, &ball, &vp, NULL, NULL, &err), PF_OK);
    box_surface(&slab, (pf_vec3){-1, -1, -0.1}, (pf_vec3){1, 1, 0}, 2);
    char dir[] = "/tmp/pf_contact_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char obj[64], scene_path[64];
    snprintf(obj, sizeof obj, "%s/slab.obj", dir);
    snprintf(scene_path, sizeof scene_path, "%s/scene.json", dir);
    assert_int_equal(pf_export_obj(obj, &slab, NULL, &err), PF_OK);
    static const char common[] = "\"material\": {\"E\": 1e6}, \"ground\": false,"
                                 " \"damping\": {\"alpha\": 2, \"beta\": 0.001},"
                                 " \"time\": {\"frames\": 15}";
    char text[512];
    snprintf(text, sizeof text,
             "{%s, \"obstacles\": [{\"mesh\": {\"file\": \"slab.obj\"}, \"stiffness\": 2e5}]}",
             common);
    pf_scene on_mesh, on_plane;
    parse(&on_mesh, text, scene_path);
    assert_string_equal(on_mesh.obstacles[0].file, obj);
    /* the caller reads the file and hands the triangles over (libcore/sim reads no files) */
    pf_surface read = {0};
    assert_int_equal(pf_import_surface(obj, &read, &err), PF_OK);
    assert_int_equal(pf_scene_set_obstacle_surface(&on_mesh, 0, &read, &err), PF_OK);
    assert_null(read.x);
    assert_int_equal(on_mesh.obstacles[0].surface.n_tris, slab.n_tris);
    snprintf(text, sizeof text,
             "{%s, \"obstacles\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 1]},"
             " \"stiffness\": 2e5}]}",
             common);
    parse(&on_plane, text, "plane.json");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&on_mesh, lo, hi);
    pf_scene_resolve(&on_plane, lo, hi);
    pf_sim *a = NULL, *b = NULL;
    assert_int_equal(pf_sim_create(&a, &on_mesh, &m, &err), PF_OK);
    assert_int_equal(pf_sim_create(&b, &on_plane, &m, &err), PF_OK);
    int32_t bottom = 0;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        bottom += m.x[3 * i + 2] == lo.z;
    double sink = sqrt(2 * G * lo.z) * sqrt(mesh_mass(&m, 1000) / (bottom * 2e5));
    double lowest = INFINITY, largest_gap = 0;
    for (int f = 0; f < on_mesh.frames; ++f) {
        assert_int_equal(pf_sim_frame(a, &err), PF_OK);
        assert_int_equal(pf_sim_frame(b, &err), PF_OK);
        double *xa = positions(a, &m), *xb = positions(b, &m);
        lowest = fmin(lowest, lowest_z(xa, m.n_nodes));
        for (int64_t q = 0; q < 3 * (int64_t)m.n_nodes; ++q)
            largest_gap = fmax(largest_gap, fabs(xa[q] - xb[q]));
        free(xa);
        free(xb);
    }
    printf("ball on a mesh slab: lowest node %.3e (rigid sink %.3e), largest difference to "
           "the plane %.3e, %lld contacts\n",
           lowest, sink, largest_gap, (long long)pf_sim_get_stats(a)->contacts);
    const pf_sim_stats *st = pf_sim_get_stats(a);
    printf("  %d elements, %lld unknowns, factor %lld, %lld steps: assembly %.3f s, contact "
           "%.3f s, factorisation %.3f s, solves %.3f s\n",
           (int)m.n_elems, (long long)st->dofs, (long long)st->factor_nnz, (long long)st->steps,
           st->assemble_seconds, st->contact_seconds, st->factor_seconds, st->solve_seconds);
    assert_true(pf_sim_get_stats(a)->contacts > 0);
    assert_true(lowest > -sink);
    assert_true(largest_gap < 1e-9);
    pf_sim_destroy(&a);
    pf_sim_destroy(&b);
    unlink(obj);
    rmdir(dir);
    pf_scene_release(&on_mesh);
    pf_scene_release(&on_plane);
    pf_surface_release(&ball);
    pf_surface_release(&slab);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Contact at the embedded surface: a unit cube of 3^3 hexes (cell h = 1/3) embeds a box surface
 * inset by 0.3 h on every side, as a voxel mesh's nodes lie outside the true surface. Dropped on
 * the ground, the surface's lowest vertex comes to rest at the ground (within 3 stiffness-
 * predicted depths) while the mesh's bottom nodes hang 0.3 h below it (they go through the
 * ground: at least 0.25 h below); with nodal contact the nodes would rest there instead. */
static void contact_at_embedded_surface(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double h = 1.0 / 3, inset = 0.3 * h, z0 = 0.05;
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, z0}, (pf_vec3){1, 1, z0 + 1}, 3, 3, 3);
    pf_surface s = {0};
    box_surface(&s, (pf_vec3){inset, inset, z0 + inset},
                (pf_vec3){1 - inset, 1 - inset, z0 + 1 - inset}, 4);
    s.id = 7;
    pf_weights w = {0};
    pf_embed_params ep = pf_embed_params_default();
    ep.method = PF_EMBED_BARY; /* 8 nodes a vertex: MLS rows reach 30 and cost 10 times more */
    assert_int_equal(pf_embed_compute(&m, &s, &ep, &w, NULL, &err), PF_OK);
    pf_scene sc;
    parse(&sc,
          "{\"material\": {\"E\": 1e6}, \"ground\": {\"point\": [0, 0, 0], \"stiffness\": 1e5},"
          " \"damping\": {\"alpha\": 4, \"beta\": 0.002},"
          " \"time\": {\"frames\": 30, \"substeps\": 5}}",
          "embedded.json");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create_embedded(&sim, &sc, &m, &s, &w, &err), PF_OK);
    assert_int_equal(pf_sim_get_stats(sim)->contact_points, s.n_verts);
    for (int f = 0; f < sc.frames; ++f)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    double *u = malloc(3 * (size_t)m.n_nodes * sizeof *u);
    double *xs = malloc(3 * (size_t)s.n_verts * sizeof *xs);
    pf_sim_nodal_displacements(sim, u);
    pf_weights_apply(&w, s.x, u, xs);
    double lowest_vertex = lowest_z(xs, s.n_verts);
    for (int64_t q = 0; q < 3 * (int64_t)m.n_nodes; ++q)
        u[q] += m.x[q];
    double lowest_node = lowest_z(u, m.n_nodes);
    int32_t bottom = (4 + 1) * (4 + 1);
    double depth = mesh_mass(&m, 1000) * G / (bottom * 1e5);
    printf("embedded contact: lowest surface vertex %.3e (3 m g / k_c = %.3e), lowest node "
           "%.3e (-0.3 h = %.3e)\n",
           lowest_vertex, 3 * depth, lowest_node, -inset);
    assert_true(lowest_vertex > -3 * depth && lowest_vertex < 0.01 * h);
    assert_true(lowest_node < -0.25 * h);
    free(u);
    free(xs);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A free body (no gravity) and a box obstacle moving +x at 1 unit/s from x = -0.3 (its face)
 * for 1 s: the wall reaches the body at t = 0.3 and pushes it; at t = 1 the body's trailing
 * face is ahead of the wall's final face 0.7 (minus a few penetration depths: the contact force
 * that accelerates a 1000 kg body is a few k d), the body moves at least as fast as the wall did,
 * and nothing moved before the wall arrived. */
static void moving_obstacle_pushes_body(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 2, 2, 2);
    pf_scene sc;
    parse(&sc,
          "{\"material\": {\"E\": 1e6}, \"gravity\": [0, 0, 0], \"ground\": false,"
          " \"obstacles\": [{\"box\": [[-1.3, -1, -1], [-0.3, 2, 2]], \"stiffness\": 1e7,"
          " \"path\": [{\"time\": 0, \"translation\": [0, 0, 0]},"
          " {\"time\": 1, \"translation\": [1, 0, 0]}]}],"
          " \"time\": {\"dt\": 0.05, \"frames\": 20}}",
          "push.json");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_error err = {0};
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    double trailing = 0;
    for (int f = 1; f <= sc.frames; ++f) {
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
        double *x = positions(sim, &m);
        trailing = INFINITY;
        for (int32_t i = 0; i < m.n_nodes; ++i)
            trailing = fmin(trailing, x[3 * i]);
        if (f * sc.dt < 0.3 - 1e-9)
            assert_true(fabs(trailing) < 1e-12);
        if (getenv("PF_TEST_VERBOSE"))
            printf("  t = %.2f: trailing face %.5f\n", f * sc.dt, trailing);
        free(x);
    }
    double kinetic;
    pf_vec3 p, l;
    pf_sim_momentum(sim, &kinetic, &p, &l);
    double mass = mesh_mass(&m, 1000);
    printf("pushed body: trailing face at x = %.4f (wall at 0.7), velocity %.3f\n", trailing,
           p.x / mass);
    assert_true(trailing > 0.7 - 0.01);
    assert_true(p.x / mass >= 1 - 1e-3);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Every bad obstacle is refused with the key's path and the reason; obstacles survive the SCEN
 * round trip. */
static void bad_obstacles_are_refused(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    static const struct {
        const char *text, *message;
    } cases[] = {
        {"{\"obstacles\": {}}", "s.json: obstacles: must be an array, got an object"},
        {"{\"obstacles\": [{}]}", "s.json: obstacles[0]: missing shape"},
        {"{\"obstacles\": [{\"sphere\": {\"centre\": [0, 0, 0], \"radius\": 1},"
         " \"box\": [[0, 0, 0], [1, 1, 1]]}]}",
         "s.json: obstacles[0]: give one shape"},
        {"{\"obstacles\": [{\"sphere\": {\"centre\": [0, 0, 0], \"radius\": 0}}]}",
         "s.json: obstacles[0].sphere.radius: must be > 0, got 0"},
        {"{\"obstacles\": [{\"sphere\": {\"center\": [0, 0, 0], \"radius\": 1}}]}",
         "s.json: obstacles[0].sphere.center: unknown key (expected one of: centre, radius)"},
        {"{\"obstacles\": [{\"sphere\": {\"radius\": 1}}]}",
         "s.json: obstacles[0].sphere: missing key \"centre\""},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, 0, 1]]}]}",
         "s.json: obstacles[0].box: the box is flat along y"},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, -1, 1]]}]}",
         "s.json: obstacles[0].box: lower corner above upper corner along y"},
        {"{\"obstacles\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 0]}}]}",
         "s.json: obstacles[0].plane.normal: must be a non-zero vector"},
        {"{\"obstacles\": [{\"mesh\": {\"depth\": 1}}]}",
         "s.json: obstacles[0].mesh: missing key \"file\""},
        {"{\"obstacles\": [{\"mesh\": {\"file\": 3}}]}",
         "s.json: obstacles[0].mesh.file: must be a non-empty file name, got 3"},
        {"{\"obstacles\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 1]},"
         " \"stiffness\": -1}]}",
         "s.json: obstacles[0].stiffness: must be >= 0, got -1"},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, 1, 1]], \"path\": []}]}",
         "s.json: obstacles[0].path: must be a non-empty array"},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, 1, 1]], \"path\": [{\"time\": 1,"
         " \"translation\": [0, 0, 0]}, {\"time\": 1, \"translation\": [1, 0, 0]}]}]}",
         "s.json: obstacles[0].path[1].time: times must increase strictly along the path"},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, 1, 1]], \"path\": [{\"time\": 1}]}]}",
         "s.json: obstacles[0].path[0]: missing key \"translation\""},
        {"{\"obstacles\": [{\"box\": [[0, 0, 0], [1, 1, 1]], \"spin\": 1}]}",
         "s.json: obstacles[0].spin: unknown key (expected one of: plane, sphere, box, mesh, "
         "stiffness, path)"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof *cases; ++k) {
        pf_scene sc;
        pf_error err = {0};
        assert_int_equal(pf_scene_parse(&sc, cases[k].text, strlen(cases[k].text), "s.json", &err),
                         PF_ERR_INVALID);
        if (strncmp(err.msg, cases[k].message, strlen(cases[k].message)) != 0)
            fail_msg("case %zu: got '%s', expected '%s...'", k, err.msg, cases[k].message);
        pf_scene_release(&sc);
    }

    /* surfaces handed over: none without triangles, none for an obstacle that is not a mesh */
    pf_scene sc;
    parse(&sc, "{\"obstacles\": [{\"mesh\": {\"file\": \"no_such.obj\"}}, {\"sphere\": "
               "{\"centre\": [0, 0, 0], \"radius\": 1}}]}",
          "dir/s.json");
    pf_error err = {0};
    pf_surface empty = {0};
    assert_int_equal(pf_scene_set_obstacle_surface(&sc, 0, &empty, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "obstacles[0].mesh: dir/no_such.obj: no triangles"));
    pf_surface one = {0};
    assert_int_equal(pf_surface_alloc(&one, 3, 1, &err), PF_OK);
    memset(one.x, 0, 9 * sizeof(double));
    one.tri[0] = 0, one.tri[1] = 1, one.tri[2] = 2;
    assert_int_equal(pf_scene_set_obstacle_surface(&sc, 1, &one, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "obstacles[1]: not a mesh obstacle"));
    assert_int_equal(pf_scene_set_obstacle_surface(&sc, 2, &one, &err), PF_ERR_INVALID);
    assert_non_null(one.x); /* refused: still the caller's */
    pf_surface_release(&one);
    /* and a simulator refuses an unloaded one */
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 1, 1, 1);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "obstacles[0].mesh"));
    pf_scene_release(&sc);
    pf_mesh_release(&m);

    /* round trip through the SCEN text */
    pf_scene a, b;
    parse(&a,
          "{\"obstacles\": [{\"sphere\": {\"centre\": [1, 2, 3], \"radius\": 0.5},"
          " \"stiffness\": 7, \"path\": [{\"time\": 0, \"translation\": [0, 0, 0]},"
          " {\"time\": 2, \"translation\": [0, 0, 4]}]},"
          " {\"mesh\": {\"file\": \"bowl.obj\", \"depth\": 0.2}}]}",
          "shots/a.json");
    char *json = NULL;
    assert_int_equal(pf_scene_to_json(&a, &json, &err), PF_OK);
    parse(&b, json, "SCEN");
    assert_int_equal(b.n_obstacles, 2);
    assert_true(b.obstacles[0].kind == PF_OBSTACLE_SPHERE && b.obstacles[0].radius == 0.5);
    assert_true(b.obstacles[0].centre.z == 3 && b.obstacles[0].stiffness == 7);
    assert_int_equal(b.obstacles[0].n_keys, 2);
    pf_vec3 t = pf_obstacle_translation(&b.obstacles[0], 0.5);
    assert_true(t.x == 0 && t.z == 1);
    t = pf_obstacle_translation(&b.obstacles[0], 5);
    assert_true(t.z == 4);
    assert_true(b.obstacles[1].kind == PF_OBSTACLE_MESH && b.obstacles[1].depth == 0.2);
    assert_string_equal(b.obstacles[1].file, "shots/bowl.obj");
    pf_free(json);
    pf_scene_release(&a);
    pf_scene_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A made-up method for the penalty test: 10 triples in 5 blocks of two; the nodal map S puts
 * each of the cube's 8 nodes on 3 random triples; point_row of element e at x: triples e, e + 1
 * and e + 3 with weights depending on x; node i's element is i. (The real methods' rows are
 * tested through them: test_sim, test_dg, test_cg.) */
enum { FAKE_NT = 10, FAKE_PER = 3 };

typedef struct fake_method {
    int64_t map_offsets[9], map_triple[8 * FAKE_PER];
    double map_w[8 * FAKE_PER];
} fake_method;

static void fake_nodal_map(const void *m, const int64_t **offsets, const int64_t **triple,
                           const double **w)
{
    const fake_method *f = m;
    *offsets = f->map_offsets;
    *triple = f->map_triple;
    *w = f->map_w;
}

static int32_t fake_point_row(const void *m, int32_t e, pf_vec3 x, int64_t *triple, double *w)
{
    (void)m;
    int64_t t = e % (FAKE_NT - 3);
    triple[0] = t, triple[1] = t + 1, triple[2] = t + 3;
    w[0] = 0.5 + 0.1 * x.x, w[1] = 0.3 - 0.2 * x.y, w[2] = 0.2 + 0.1 * x.z;
    return 3;
}

static int32_t fake_max_point_row(const void *m)
{
    (void)m;
    return 3;
}

static int32_t fake_node_elements(const void *m, int32_t i, const int32_t **elems)
{
    (void)m;
    static const int32_t ids[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    *elems = ids + i;
    return 1;
}

/* The penalty terms against a dense computation of DG paper sec. 8, 6 surface points on random
 * WGHT rows of 3 nodes, all below a tilted plane, at a random state u: the forces
 * F = sum_p k (n . (c_p - x_p) - n . beta_p^T u) beta_p (x) n with beta_p = W_p S, and the matrix
 * sum_p k ((1 + e) b_p b_p^T + diag(|r_t| (|r|_1 + |b|_1))) (x) n n^T with b_p the compact row of
 * the element of the point's largest-weight node, r = beta - b, e = |r|_1 / |b|_1, entry by entry
 * to 1e-13 (sums of a few products of numbers below 10); and that matrix majorises the exact
 * term sum_p k (beta_p beta_p^T) (x) n n^T. */
static void penalty_matches_dense_sum(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    rng r = {2024};
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 1, 1, 1);
    enum { NT = FAKE_NT, NB = 5, NP = 6, ROW = 3, PER = FAKE_PER };
    fake_method fm;
    for (int i = 0; i < 8; ++i) {
        fm.map_offsets[i] = PER * i;
        int64_t t0 = (int64_t)(uniform01(&r) * (NT - PER));
        for (int q = 0; q < PER; ++q) { /* ascending, distinct */
            fm.map_triple[PER * i + q] = t0 + q + (q == 2 && t0 + 3 < NT ? 1 : 0);
            fm.map_w[PER * i + q] = uniform(&r);
        }
    }
    fm.map_offsets[8] = 8 * PER;
    pf_surface s = {0};
    assert_int_equal(pf_surface_alloc(&s, NP, 0, &err), PF_OK);
    pf_weights w = {0};
    assert_int_equal(pf_weights_alloc(&w, NP, 8, NP * ROW, &err), PF_OK);
    int dominant[NP];
    for (int p = 0; p < NP; ++p) {
        s.x[3 * p] = uniform(&r);
        s.x[3 * p + 1] = uniform(&r);
        s.x[3 * p + 2] = -2 + uniform(&r); /* below the plane */
        int first = (int)(uniform01(&r) * (8 - ROW));
        double best = -1;
        for (int q = 0; q < ROW; ++q) {
            w.col[ROW * p + q] = (uint32_t)(first + q);
            w.val[ROW * p + q] = uniform(&r);
            if (fabs(w.val[ROW * p + q]) > best)
                best = fabs(w.val[ROW * p + q]), dominant[p] = first + q;
        }
        w.row_offsets[p + 1] = ROW * (p + 1);
    }
    pf_scene sc;
    parse(&sc,
          "{\"ground\": false, \"obstacles\": [{\"plane\": {\"point\": [0, 0, 1],"
          " \"normal\": [1, 2, 3]}, \"stiffness\": 3}]}",
          "dense.json");
    int32_t size[NB], pairs[NB * NB];
    int64_t start[NB + 1];
    int n_pairs = 0;
    for (int b = 0; b < NB; ++b) {
        size[b] = 6, start[b] = 6 * b;
        for (int c = 0; c < b; ++c)
            pairs[2 * n_pairs] = c, pairs[2 * n_pairs + 1] = b, ++n_pairs;
    }
    start[NB] = 6 * NB;
    pf_block_matrix k = {0};
    assert_int_equal(pf_block_matrix_create(&k, NB, size, n_pairs, pairs, &err), PF_OK);
    pf_method_ops ops = {.nodal_map = fake_nodal_map,
                         .point_row = fake_point_row,
                         .max_point_row = fake_max_point_row,
                         .node_elements = fake_node_elements};
    pf_contact_setup cs = {.scene = &sc,
                           .mesh = &m,
                           .n_triples = NT,
                           .ops = &ops,
                           .method = &fm,
                           .surface = &s,
                           .weights = &w,
                           .auto_stiffness = 1,
                           .model_size = 1,
                           .n_blocks = NB,
                           .block_start = start};
    pf_contact *c = NULL;
    assert_int_equal(pf_contact_create(&c, &cs, &err), PF_OK);
    double u[3 * NT], v[3 * NT] = {0}, f[3 * NT] = {0};
    for (int a = 0; a < 3 * NT; ++a)
        u[a] = 0.01 * uniform(&r); /* small: every point stays below the plane */
    assert_int_equal(pf_contact_detect(c, 0.1, u, v, 0.01), NP);
    assert_int_equal(pf_contact_count(c), NP);
    pf_contact_forces(c, u, f);
    pf_contact_add_stiffness(c, 0.5, &k);
    pf_vec3 n = pf_v3_normalize(pf_v3(1, 2, 3));
    double nn[3] = {n.x, n.y, n.z}, dense[3 * NT][3 * NT] = {{0}}, fd[3 * NT] = {0};
    double exact[3 * NT][3 * NT] = {{0}};
    for (int p = 0; p < NP; ++p) {
        double beta[NT] = {0}, b[NT] = {0}, nu = 0;
        for (int q = 0; q < ROW; ++q) {
            int i = (int)w.col[ROW * p + q];
            for (int64_t e = fm.map_offsets[i]; e < fm.map_offsets[i + 1]; ++e)
                beta[fm.map_triple[e]] += w.val[ROW * p + q] * fm.map_w[e];
        }
        for (int t = 0; t < NT; ++t)
            nu += beta[t] * (nn[0] * u[3 * t] + nn[1] * u[3 * t + 1] + nn[2] * u[3 * t + 2]);
        int64_t t3[3];
        double b3[3];
        pf_vec3 x = pf_v3_load(s.x + 3 * p);
        fake_point_row(NULL, dominant[p], x, t3, b3);
        for (int q = 0; q < 3; ++q)
            b[t3[q]] += b3[q];
        double gap = 1 * n.z - pf_v3_dot(n, x); /* n . (c - x) with c on the plane */
        double l1_r = 0, l1_b = 0;
        for (int t = 0; t < NT; ++t)
            l1_r += fabs(beta[t] - b[t]), l1_b += fabs(b[t]);
        double e = l1_r / l1_b;
        for (int a = 0; a < 3 * NT; ++a) {
            fd[a] += 3 * (gap - nu) * beta[a / 3] * nn[a % 3];
            for (int bb = 0; bb < 3 * NT; ++bb) {
                dense[a][bb] += 3 * (1 + e) * b[a / 3] * nn[a % 3] * b[bb / 3] * nn[bb % 3];
                if (a / 3 == bb / 3)
                    dense[a][bb] += 3 * fabs(beta[a / 3] - b[a / 3]) * (l1_r + l1_b) *
                                    nn[a % 3] * nn[bb % 3];
                exact[a][bb] += 3 * beta[a / 3] * nn[a % 3] * beta[bb / 3] * nn[bb % 3];
            }
        }
    }
    /* the matrix is at least the exact term: x^T (K - C) x >= 0 */
    for (int trial = 0; trial < 20; ++trial) {
        double x[3 * NT], excess = 0;
        for (int a = 0; a < 3 * NT; ++a)
            x[a] = uniform(&r);
        for (int a = 0; a < 3 * NT; ++a)
            for (int bb = 0; bb < 3 * NT; ++bb)
                excess += x[a] * (0.5 * dense[a][bb] - 0.5 * exact[a][bb]) * x[bb];
        assert_true(excess >= -1e-13);
    }
    for (int a = 0; a < 3 * NT; ++a) {
        if (fabs(f[a] - fd[a]) > 1e-13)
            fail_msg("force %d: %.17g, dense %.17g", a, f[a], fd[a]);
        for (int bb = 0; bb < 3 * NT; ++bb)
            if (fabs(pf_block_matrix_get(&k, a, bb) - 0.5 * dense[a][bb]) > 1e-13)
                fail_msg("entry (%d, %d): %.17g, dense %.17g", a, bb,
                         pf_block_matrix_get(&k, a, bb), 0.5 * dense[a][bb]);
    }
    pf_contact_destroy(&c);
    pf_block_matrix_release(&k);
    pf_scene_release(&sc);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(penalty_matches_dense_sum),
        cmocka_unit_test(box_rests_on_plane_obstacle),
        cmocka_unit_test(ball_dropped_on_mesh_obstacle),
        cmocka_unit_test(contact_at_embedded_surface),
        cmocka_unit_test(moving_obstacle_pushes_body),
        cmocka_unit_test(bad_obstacles_are_refused),
    };
    if (getenv("PF_TEST_FILTER"))
        cmocka_set_test_filter(getenv("PF_TEST_FILTER"));
    return cmocka_run_group_tests(tests, NULL, NULL);
}
