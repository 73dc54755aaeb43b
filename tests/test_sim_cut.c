/* sim_cut: cutting while the simulation runs (pf_sim_cut, the scene's "cuts"): the state carried
 * across a cut (DG exactly, CG exactly for the affine fields every element reproduces), a clamped
 * bar cut through whose free piece falls with gravity's acceleration, a blade that stops half way
 * (one body, a crack), an embedded surface cut with the mesh, a blade through the sliced bunny
 * (no surface triangle joins the two pieces), the solver policy after a cut (auto keeps pcg;
 * frames equal direct's), and the scene's errors. */
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

#include <pf/cut.h>
#include <pf/embed.h>
#include <pf/sim.h>
#include <pf/io.h>

#include "test_bodies.h"
#include "test_cut_requests.h"
#include "test_sim_changes.h"

/* A cut surface after frame f: closed, manifold, the box's volume 3.8 x 0.8 x 0.8. */
#define CHECK_SURFACE(ss, f)                                                                       \
    do {                                                                                           \
        if (!(ss).closed || !(ss).manifold || fabs((ss).volume - 2.432) > 1e-12 * 2.432)           \
            fail_msg("frame %d: the cut surface: closed %d, manifold %d, volume %.17g", (f),       \
                     (ss).closed, (ss).manifold, (ss).volume);                                     \
    } while (0)

/* A free 2 x 1 x 1 box of 4 x 2 x 2 hexes, deformed by an affine displacement and moving with an
 * affine velocity, cut through by a plane: both methods hold affine fields exactly on any
 * element, so kinetic energy and linear and angular momentum agree before and after the cut to
 * round-off (1e-12: sums over some dozens of elements of exact integrals); CG's harmonic pieces
 * (an oblique plane) reproduce affine fields to their linear precision, 1e-9 is asked. */
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

static void affine_state_survives_cut(const char *json, pf_vec3 normal, double tol)
{
    pf_mesh m = {0};
    pf_scene sc;
    make_box(&m, pf_v3(2, 1, 1), 4, 2, 2);
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    double a[9] = {0.01, 0.02, 0, 0, -0.01, 0.03, 0.02, 0, 0.015}, b[3] = {0.1, -0.2, 0.05};
    pf_sim_set_affine_displacement(sim, a, b);
    pf_sim_set_rigid_velocity(sim, pf_v3(0.3, -0.2, 0.5), pf_v3(1, 0.5, 0.5), pf_v3(1, 2, -3));
    double k0, k1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &k0, &p0, &l0);
    pf_cut_request req[16];
    int32_t k =
        requests_meeting(&m, pf_plane_from_point_normal(pf_v3(1.1, 0.5, 0.5), normal), 0, req);
    assert_true(k > 0);
    pf_error err = {0};
    pf_cut_result r;
    if (pf_sim_cut(sim, req, k, &r, &err) < 0)
        fail_msg("cut: %s", err.msg);
    assert_int_equal(r.n_bodies, 2);
    pf_cut_result_release(&r);
    pf_sim_momentum(sim, &k1, &p1, &l1);
    assert_true(rel(k1, k0) < tol);
    assert_true(vec_rel(p1, p0) < tol);
    assert_true(vec_rel(l1, l0) < tol);
    assert_int_equal(pf_sim_get_stats(sim)->cuts, 1);
    assert_int_equal(pf_sim_get_stats(sim)->bodies, 2);
    run_frames(sim, 1);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static const char FREE_BODY[] =
    "{\"gravity\": [0, 0, 0], \"ground\": false, \"time\": {\"dt\": 0.01}";

static void test_affine_state_survives_cut(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s}", FREE_BODY);
    affine_state_survives_cut(json, pf_v3(1, 0, 0), 1e-12);
    affine_state_survives_cut(json, pf_v3(1, 0.3, 0.2), 1e-12);
    snprintf(json, sizeof json, "%s, \"method\": {\"degree\": 2}}", FREE_BODY);
    affine_state_survives_cut(json, pf_v3(1, 0.3, 0.2), 1e-12);
    snprintf(json, sizeof json, "%s, \"method\": \"cg\"}", FREE_BODY);
    affine_state_survives_cut(json, pf_v3(1, 0, 0), 1e-12);
    affine_state_survives_cut(json, pf_v3(1, 0.3, 0.2), 1e-9);
}

/* Mean z displacement of the nodes whose rest x lies in [x0, x1]. */
static double mean_z(const pf_sim *sim, double x0, double x1)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    double *u = malloc(3 * (size_t)m->n_nodes * sizeof *u), sum = 0;
    assert_non_null(u);
    pf_sim_nodal_displacements(sim, u);
    int n = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (m->x[3 * i] >= x0 && m->x[3 * i] <= x1)
            sum += u[3 * i + 2], n++;
    free(u);
    return sum / n;
}

/* A bar clamped at x = 0 under gravity, cut through near x = 2.1 by a plane at t = 0.03 (the
 * world plane carried into the rest shape of the bent bar: the cap nodes lie near x = 2.1, not
 * on it, so the free piece is measured at x >= 2.2, its nodes of whole cells): the free piece
 * falls with gravity's acceleration (the mean z of those nodes, fitted by a parabola over the
 * frames after the cut: its second derivative within 0.1 % of -g; the nodes' mean is not the
 * centre of mass of a piece that turns as it falls: -9.8089 .. -9.8111 per node), while the
 * clamped piece stays (its mean sag a hundredth of the free piece's fall). */
static void clamped_bar_falls_apart(const char *method)
{
    char json[512];
    snprintf(json, sizeof json,
             "{\"material\": {\"E\": 1e8, \"nu\": 0.3, \"density\": 1000}, \"method\": %s,"
             " \"gravity\": [0, 0, -9.81], \"ground\": false, \"damping\": {\"alpha\": 0},"
             " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
             " \"time\": {\"dt\": 0.01, \"substeps\": 4},"
             " \"cuts\": [{\"plane\": {\"point\": [2.1, 0, 0], \"normal\": [1, 0, 0]},"
             " \"time\": 0.03}]}",
             method);
    pf_mesh m = {0};
    pf_scene sc;
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    run_frames(sim, 3);
    assert_int_equal(pf_sim_get_stats(sim)->cuts, 1);
    assert_int_equal(pf_sim_get_stats(sim)->bodies, 2);
    /* least-squares parabola z(t) = c0 + c1 t + c2 t^2 through 20 frames after the cut */
    double s[5] = {0}, r[3] = {0};
    for (int f = 0; f < 20; ++f) {
        run_frames(sim, 1);
        double t = pf_sim_time(sim), z = mean_z(sim, 2.2, 4), p = 1;
        for (int k = 0; k < 5; ++k, p *= t) {
            s[k] += p;
            if (k < 3)
                r[k] += p * z;
        }
    }
    double a[3][4] = {{s[0], s[1], s[2], r[0]}, {s[1], s[2], s[3], r[1]}, {s[2], s[3], s[4], r[2]}};
    for (int i = 0; i < 3; ++i) /* Gauss-Jordan without pivoting: the matrix is SPD */
        for (int j = 0; j < 3; ++j)
            if (j != i) {
                double q = a[j][i] / a[i][i];
                for (int k = 0; k < 4; ++k)
                    a[j][k] -= q * a[i][k];
            }
    double accel = 2 * a[2][3] / a[2][2];
    print_message("%s: the free piece falls with %.4f m/s^2\n", method, accel);
    assert_true(fabs(accel + 9.81) < 1e-3 * 9.81);
    double fall = mean_z(sim, 2.2, 4), sag = mean_z(sim, 0, 2.0);
    assert_true(fabs(sag) < 0.01 * fabs(fall));
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_clamped_bar_falls_apart(void **state)
{
    (void)state;
    clamped_bar_falls_apart("\"dg\"");
    clamped_bar_falls_apart("\"cg\"");
}

/* A blade comes down through a bar clamped at both ends and stops half way: several frames cut
 * (progressive), the bar stays one body and the mesh valid; the same blade going all the way
 * through makes two bodies. On hexes and on Kuhn tetrahedra, with both methods. */
static void blade_through_bar(double stop, int bodies, bool tets, const char *method)
{
    char json[768];
    snprintf(json, sizeof json,
             "{\"gravity\": [0, 0, -9.81], \"ground\": false, \"method\": \"%s\","
             " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}},"
             "             {\"plane\": {\"point\": [4, 0, 0], \"normal\": [1, 0, 0]}}],"
             " \"time\": {\"dt\": 0.01, \"substeps\": 2},"
             " \"cuts\": [{\"blade\": [[2.05, -1, 1.5], [2.05, 2, 1.5]],"
             "   \"path\": [{\"time\": 0, \"translation\": [0, 0, 0]},"
             "              {\"time\": 0.1, \"translation\": [0, 0, %.17g]}]}]}",
             method, stop - 1.5);
    pf_mesh m = {0};
    pf_scene sc;
    pf_error err = {0};
    make_box_mesh(&m, pf_v3(4, 1, 1), 8, 2, 4, tets);
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    run_frames(sim, 12);
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    print_message("%s on %s, blade to z = %g: %d cuts, %lld elements split, %d bodies\n", method,
                  tets ? "tets" : "hexes", stop, (int)st->cuts, (long long)st->elements_cut,
                  (int)st->bodies);
    assert_true(st->cuts >= 2); /* progressive: in more than one frame */
    assert_int_equal(st->bodies, bodies);
    pf_mesh_validate_params vp = pf_mesh_validate_params_default();
    if (pf_mesh_validate(pf_sim_mesh(sim), &vp, &err) < 0)
        fail_msg("the cut mesh: %s", err.msg);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_progressive_blade(void **state)
{
    (void)state;
    blade_through_bar(0.5, 1, false, "dg"); /* stops half way: 2 of the 4 layers */
    blade_through_bar(-0.5, 2, false, "dg");
    blade_through_bar(0.5, 1, true, "dg"); /* Kuhn tetrahedra */
    blade_through_bar(-0.5, 2, true, "dg");
    blade_through_bar(-0.5, 2, false, "cg");
    blade_through_bar(-0.5, 2, true, "cg");
}

/* The DG paper's pencil (fig. 10): a single hexahedron held at its foot, sharpened by four plane
 * cuts around its top at successive times: each cut shaves off a piece that falls away (a body of
 * its own), the mesh stays valid, and the volume of the pieces (and of any dropped as too small)
 * stays the pencil's to round-off. */
static void test_pencil(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_scene sc;
    make_box(&m, pf_v3(0.2, 0.2, 1), 1, 1, 1);
    parse(&sc, "{\"ground\": false, \"time\": {\"dt\": 0.02, \"frames\": 10},"
               " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 1]}}],"
               " \"cuts\": ["
               "  {\"plane\": {\"point\": [0.08, 0.1, 1], \"normal\": [-1, 0, 0.15]},"
               "   \"time\": 0.02},"
               "  {\"plane\": {\"point\": [0.12, 0.1, 1], \"normal\": [1, 0, 0.15]},"
               "   \"time\": 0.04},"
               "  {\"plane\": {\"point\": [0.1, 0.08, 1], \"normal\": [0, -1, 0.15]},"
               "   \"time\": 0.06},"
               "  {\"plane\": {\"point\": [0.1, 0.12, 1], \"normal\": [0, 1, 0.15]},"
               "   \"time\": 0.08}]}");
    pf_sim *sim = create(&sc, &m);
    run_frames(sim, 6);
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    const pf_mesh *now = pf_sim_mesh(sim);
    double v = st->dropped_volume + pf_mesh_volume(now);
    print_message("pencil: %d cuts, %d elements, %d bodies, dropped %g\n", (int)st->cuts,
                  (int)now->n_elems, (int)st->bodies, st->dropped_volume);
    assert_int_equal(st->cuts, 4);
    assert_true(st->bodies >= 5);
    assert_true(rel(v, 0.04) < 1e-12);
    pf_error err = {0};
    pf_mesh_validate_params vp = pf_mesh_validate_params_default();
    if (pf_mesh_validate(now, &vp, &err) < 0)
        fail_msg("the sharpened pencil: %s", err.msg);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* A box surface of 8 shared corners and 12 triangles, outward (pf_surface_make_box gives each
 * face its own corners, for flat shading: closed only geometrically). */
static void closed_box(pf_surface *s, pf_vec3 lo, pf_vec3 hi)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_alloc(s, 8, 12, &err), PF_OK);
    for (int i = 0; i < 8; ++i) {
        s->x[3 * i] = i & 1 ? hi.x : lo.x;
        s->x[3 * i + 1] = i & 2 ? hi.y : lo.y;
        s->x[3 * i + 2] = i & 4 ? hi.z : lo.z;
    }
    static const uint32_t tri[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    memcpy(s->tri, tri, sizeof tri);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(s, &st, &err), PF_OK);
    assert_true(st.closed && st.manifold && st.volume > 0);
}

/* A bar clamped at x = 0 under gravity, undamped, cut through by the plane x = 2.1 at cut_time
 * (resolved against m into *sc), and a simulator on m with s embedded by MLS weights (*w
 * computed here). */
static pf_sim *clamped_cut_sim(pf_scene *sc, double cut_time, const pf_mesh *m, const pf_surface *s,
                               pf_weights *w)
{
    pf_error err = {0};
    assert_int_equal(pf_embed_compute(m, s, NULL, w, NULL, &err), PF_OK);
    char json[512];
    snprintf(json, sizeof json,
             "{\"gravity\": [0, 0, -9.81], \"ground\": false, \"damping\": {\"alpha\": 0},"
             " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
             " \"time\": {\"dt\": 0.02, \"substeps\": 2},"
             " \"cuts\": [{\"plane\": {\"point\": [2.1, 0, 0], \"normal\": [1, 0, 0]},"
             " \"time\": %.17g}]}",
             cut_time);
    parse(sc, json);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(sc, lo, hi);
    pf_sim *sim = NULL;
    if (pf_sim_create_embedded(&sim, sc, m, s, w, &err) < 0)
        fail_msg("create: %s", err.msg);
    return sim;
}

/* An embedded box surface inside a bar clamped at one end, cut through: the surface is cut with
 * the mesh (caps added, still closed), its weights are on the new mesh, and after the free piece
 * has fallen no vertex of the clamped side moved with it. */
static void test_embedded_surface_cut(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_surface surf = {0};
    closed_box(&surf, pf_v3(0.1, 0.1, 0.1), pf_v3(3.9, 0.9, 0.9));
    pf_weights w = {0};
    pf_scene sc;
    pf_sim *sim = clamped_cut_sim(&sc, 0, &m, &surf, &w);
    run_frames(sim, 10);
    const pf_surface *cut = pf_sim_surface(sim);
    const pf_weights *nw = pf_sim_weights(sim);
    assert_true(cut != &surf && cut->n_verts > surf.n_verts);
    assert_non_null(cut->tri_part);
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(cut, &ss, &err), PF_OK);
    print_message("cut surface: %d verts, %d tris, closed %d, manifold %d, %lld boundary edges\n",
                  (int)ss.n_verts, (int)ss.n_tris, ss.closed, ss.manifold,
                  (long long)ss.n_boundary_edges);
    assert_true(ss.closed);
    assert_int_equal(nw->rows, cut->n_verts);
    assert_int_equal(nw->cols, pf_sim_mesh(sim)->n_nodes);
    /* every vertex: its weighted displacement; the clamped side's stay small */
    const pf_mesh *now = pf_sim_mesh(sim);
    double *u = calloc(3 * (size_t)now->n_nodes, sizeof *u), fallen = 0, stayed = 0;
    assert_non_null(u);
    pf_sim_nodal_displacements(sim, u);
    for (int32_t v = 0; v < cut->n_verts; ++v) {
        double z = 0;
        for (int64_t q = nw->row_offsets[v]; q < nw->row_offsets[v + 1]; ++q)
            z += nw->val[q] * u[3 * (size_t)nw->col[q] + 2];
        double x = cut->x[3 * v];
        if (x < 2.0) /* the cut lies near x = 2.1: the plane carried into the rest shape */
            stayed = fmax(stayed, fabs(z));
        else if (x > 2.2)
            fallen = fmax(fallen, fabs(z));
    }
    double clamped_nodes = 0; /* the clamped piece's own nodes (rest x below the cut) */
    for (int32_t i = 0; i < now->n_nodes; ++i)
        if (now->x[3 * i] < 2.05) {
            clamped_nodes = fmax(clamped_nodes, fabs(u[3 * (size_t)i + 2]));
        }
    free(u);
    print_message("surface: clamped side moved %.3g at most (its nodes %.3g), free side %.3g\n",
                  stayed, clamped_nodes, fallen);
    assert_true(fallen > 0.15); /* 0.2 s of free fall: 0.196 */
    /* a vertex weighted by a node across the cut would move more than the clamped piece does:
     * the weights are a partition of unity, each within about 1 of its nodes' motion */
    assert_true(stayed <= 1.001 * clamped_nodes);
    assert_true(stayed < 0.2 * fallen);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_surface_release(&surf);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* A blade going through a bar in several frames with an embedded box inside: each cut surface is
 * closed and manifold, and encloses the box's volume (the rest shape's: a cut moves nothing) to
 * 1e-12 relative. */
static void test_embedded_progressive(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 4);
    pf_surface surf = {0};
    closed_box(&surf, pf_v3(0.1, 0.1, 0.1), pf_v3(3.9, 0.9, 0.9));
    pf_weights w = {0};
    assert_int_equal(pf_embed_compute(&m, &surf, NULL, &w, NULL, &err), PF_OK);
    pf_scene sc;
    parse(&sc, "{\"gravity\": [0, 0, -9.81], \"ground\": false,"
               " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}},"
               "             {\"plane\": {\"point\": [4, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"time\": {\"dt\": 0.01, \"substeps\": 2},"
               " \"cuts\": [{\"blade\": [[2.05, -1, 1.5], [2.05, 2, 1.5]],"
               "   \"path\": [{\"time\": 0, \"translation\": [0, 0, 0]},"
               "              {\"time\": 0.1, \"translation\": [0, 0, -2]}]}]}");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create_embedded(&sim, &sc, &m, &surf, &w, &err), PF_OK);
    for (int f = 0; f < 12; ++f) {
        run_frames(sim, 1);
        const pf_surface *cut = pf_sim_surface(sim);
        pf_surface_stats ss;
        assert_int_equal(pf_surface_compute_stats(cut, &ss, &err), PF_OK);
        CHECK_SURFACE(ss, f);
    }
    assert_true(pf_sim_get_stats(sim)->cuts >= 2);
    assert_int_equal(pf_sim_get_stats(sim)->bodies, 2);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_surface_release(&surf);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* ---- the render surface follows its own piece ------------------------------------------------
 */

/* The bounding box of element e's nodes. */
static void elem_box(const pf_mesh *m, int32_t e, pf_vec3 *lo, pf_vec3 *hi)
{
    *lo = pf_v3(INFINITY, INFINITY, INFINITY), *hi = pf_v3_scale(*lo, -1);
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k) {
            pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)m->face_nodes[k]);
            *lo = pf_v3_min(*lo, x), *hi = pf_v3_max(*hi, x);
        }
    }
}

/* A channel bar [0, 4] x [0, 1.5] x [0, 1] of 0.5 hexes with a groove y 0.5 .. 1, z 0.5 .. 1
 * along it (a U cross-section; every node of the box is still a corner of a kept hex), derived. */
static void make_channel(pf_mesh *m)
{
    pf_error err = {0};
    pf_mesh box = {0};
    make_box(&box, pf_v3(4, 1.5, 1), 8, 3, 2);
    uint8_t keep[48];
    assert_int_equal(box.n_elems, 48);
    for (int32_t e = 0; e < box.n_elems; ++e) { /* the groove: hexes whose box is inside it */
        pf_vec3 lo, hi;
        elem_box(&box, e, &lo, &hi);
        keep[e] = !(lo.y >= 0.5 - 1e-12 && hi.y <= 1 + 1e-12 && lo.z >= 0.5 - 1e-12);
    }
    assert_int_equal(pf_mesh_select_elements(m, &box, keep, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
    pf_mesh_release(&box);
}

/* The mesh's boundary as a closed surface on its nodes (a sliced mesh's surface is its
 * boundary: the surface meets every cut's rim). */
static void boundary_surface(const pf_mesh *m, pf_surface *s)
{
    pf_error err = {0};
    pf_boundary b = {0};
    assert_int_equal(pf_boundary_extract(m, &b, &err), PF_OK);
    int32_t nt = (int32_t)b.tri_offsets[b.n_faces];
    assert_int_equal(pf_surface_alloc(s, m->n_nodes, nt, &err), PF_OK);
    memcpy(s->x, m->x, 3 * (size_t)m->n_nodes * sizeof *s->x);
    memcpy(s->tri, b.tri, 3 * (size_t)nt * sizeof *s->tri);
    pf_boundary_release(&b);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(s, &st, &err), PF_OK);
    assert_true(st.closed && st.manifold && st.volume > 0);
}

/* piece[v]: the body of each vertex of s: its connected part of s (through triangles) lies in
 * the body holding that part's vertex farthest from the plane x = cut_x (away from the cut: in
 * the elements of one body only). */
static void vertex_pieces(const pf_mesh *m, const int32_t *body, const pf_surface *s, double cut_x,
                          int32_t *piece)
{
    int32_t *part = malloc((size_t)s->n_verts * sizeof *part);
    int32_t *far = malloc((size_t)s->n_verts * sizeof *far);
    assert_true(part && far);
    for (int32_t v = 0; v < s->n_verts; ++v)
        part[v] = v, far[v] = -1;
    for (int32_t t = 0; t < s->n_tris; ++t)
        for (int q = 0; q < 2; ++q)
            part[root_of(part, (int32_t)s->tri[3 * t + q])] =
                root_of(part, (int32_t)s->tri[3 * t + q + 1]);
    for (int32_t v = 0; v < s->n_verts; ++v) {
        int32_t r = root_of(part, v);
        if (far[r] < 0 || fabs(s->x[3 * v] - cut_x) > fabs(s->x[3 * far[r]] - cut_x))
            far[r] = v;
    }
    for (int32_t v = 0; v < s->n_verts; ++v) {
        const double *p = s->x + 3 * far[root_of(part, v)];
        piece[v] = -1;
        for (int32_t e = 0; e < m->n_elems && piece[v] < 0; ++e) {
            pf_vec3 lo, hi;
            elem_box(m, e, &lo, &hi);
            if (p[0] >= lo.x - 1e-9 && p[0] <= hi.x + 1e-9 && p[1] >= lo.y - 1e-9 &&
                p[1] <= hi.y + 1e-9 && p[2] >= lo.z - 1e-9 && p[2] <= hi.z + 1e-9)
                piece[v] = body[e];
        }
        assert_true(piece[v] >= 0);
    }
    free(part);
    free(far);
}

/* The largest distance of a vertex of the simulator's surface (moved by its weights) from the
 * boundary of its own piece (moved by the nodal displacements); *cross: the largest sum of |W|
 * a vertex puts on nodes of other bodies. */
static double farthest_from_piece(const pf_sim *sim, double cut_x, double reach, double *away,
                                  double *cross)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    const pf_surface *s = pf_sim_surface(sim);
    const pf_weights *w = pf_sim_weights(sim);
    pf_error err = {0};
    int32_t *body = malloc((size_t)m->n_elems * sizeof *body);
    int32_t *piece = malloc((size_t)s->n_verts * sizeof *piece);
    int32_t *node_body = malloc((size_t)m->n_nodes * sizeof *node_body);
    double *y = malloc(3 * (size_t)m->n_nodes * sizeof *y);
    assert_true(body && piece && node_body && y);
    element_bodies(m, body);
    vertex_pieces(m, body, s, cut_x, piece);
    pf_sim_nodal_displacements(sim, y);
    for (int32_t i = 0; i < 3 * m->n_nodes; ++i)
        y[i] += m->x[i];
    pf_boundary b = {0};
    assert_int_equal(pf_boundary_extract(m, &b, &err), PF_OK);
    for (int32_t i = 0; i < b.n_faces; ++i)
        for (int64_t t = b.tri_offsets[i]; t < b.tri_offsets[i + 1]; ++t)
            for (int q = 0; q < 3; ++q)
                node_body[b.tri[3 * t + q]] = body[b.elem[i]];
    double worst = 0;
    *cross = *away = 0;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)v);
        double off = 0;
        for (int64_t q = w->row_offsets[v]; q < w->row_offsets[v + 1]; ++q) {
            uint32_t n = w->col[q];
            pf_vec3 u = pf_v3_sub(pf_v3_load(y + 3 * (size_t)n), pf_v3_load(m->x + 3 * (size_t)n));
            p = pf_v3_add(p, pf_v3_scale(u, w->val[q]));
            off += node_body[n] == piece[v] ? 0 : fabs(w->val[q]);
        }
        *cross = fmax(*cross, off);
        double d = INFINITY;
        for (int32_t i = 0; i < b.n_faces; ++i) {
            if (body[b.elem[i]] != piece[v])
                continue;
            for (int64_t t = b.tri_offsets[i]; t < b.tri_offsets[i + 1]; ++t) {
                const uint32_t *c = b.tri + 3 * t;
                pf_vec3 a = pf_v3_load(y + 3 * (size_t)c[0]), bb = pf_v3_load(y + 3 * (size_t)c[1]),
                        cc = pf_v3_load(y + 3 * (size_t)c[2]);
                d = fmin(d, pf_v3_dist(p, pf_triangle_closest_point(p, a, bb, cc)));
            }
        }
        if (fabs(s->x[3 * v] - cut_x) < reach)
            worst = fmax(worst, d);
        else
            *away = fmax(*away, d);
    }
    pf_boundary_release(&b);
    free(body), free(piece), free(node_body), free(y);
    return worst;
}

/* A channel bar clamped at x = 0, sagging under gravity, cut through at x = 2.1 at t = 0.1, its
 * boundary the embedded surface (MLS weights). Across the groove a segment from one piece to the
 * other crosses no cut face, so visibility alone let vertices near the cut's rim take nodes of
 * the other piece (up to 0.43 of their weight) and stray 0.019 from their piece as it turned
 * away. 0.22 s after the cut (the free piece 0.52 below its rest): no vertex takes any weight
 * from another body, and no vertex within one support radius (1.0) of the cut lies farther from
 * the boundary of its own piece than the vertices out of the cut's reach do (0.011, all near
 * the clamp: MLS smooths the bending of the vibrating clamped piece over its support and does
 * not interpolate the nodes; that error is the method's, uncut, and the cut must add none to
 * it; the vertices near the cut: 0.0092). */
static void test_surface_follows_its_piece(void **state)
{
    (void)state;
    pf_mesh m = {0};
    make_channel(&m);
    pf_surface surf = {0};
    boundary_surface(&m, &surf);
    pf_weights w = {0};
    pf_scene sc;
    pf_sim *sim = clamped_cut_sim(&sc, 0.1, &m, &surf, &w);
    run_frames(sim, 16);
    assert_int_equal(pf_sim_get_stats(sim)->bodies, 2);
    double cross, away, near = farthest_from_piece(sim, 2.1, 1.0, &away, &cross);
    double fall = -mean_z(sim, 2.6, 4);
    print_message("channel: the free piece fell %.4f; a vertex near the cut %.3g at most from "
                  "its piece, away from it %.3g; %.3g of its weights on other bodies\n",
                  fall, near, away, cross);
    assert_true(fall > 0.45); /* the sag and its swing, then 0.22 s of free fall (0.24) */
    assert_true(cross == 0);
    assert_true(near <= away);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_surface_release(&surf);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* One run of the solver-after-cut case: a clamped bar of Kuhn tetrahedra (12 x 4 x 4 cells)
 * sagging under gravity, DG degree 1, 5 frames of 2 steps; then three oblique planes cut it into
 * four bodies (pf_sim_cut) and 10 frames (20 steps) follow, whose nodal displacements are
 * returned [10][3 n_nodes] (malloc) with the factorisations those 20 steps made and the solver
 * method they ran on. */
static double *run_after_cut(pf_solver_method method, int64_t *factorisations, int64_t *new_terms,
                             pf_solver_method *resolved, size_t *count)
{
    pf_mesh m = {0};
    pf_scene sc;
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(1.2, 0.4, 0.4), 12, 4, 4, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    parse(&sc, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"ground\": false, \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.02},"
               " \"time\": {\"dt\": 0.01, \"substeps\": 2}}");
    sc.solver.method = method;
    pf_sim *sim = create(&sc, &m);
    run_frames(sim, 5);
    const pf_vec3 point[3] = {{0.35, 0.2, 0.2}, {0.65, 0.2, 0.2}, {0.95, 0.2, 0.2}};
    const pf_vec3 normal[3] = {{1, 0.35, 0.25}, {1, -0.3, 0.4}, {1, 0.2, -0.3}};
    for (int c = 0; c < 3; ++c) {
        const pf_mesh *now = pf_sim_mesh(sim);
        pf_cut_request *req = malloc(((size_t)now->n_elems + 1) * sizeof *req);
        assert_non_null(req);
        int32_t k = requests_meeting(now, pf_plane_from_point_normal(point[c], normal[c]), 0, req);
        assert_true(k > 0);
        pf_cut_result r;
        if (pf_sim_cut(sim, req, k, &r, &err) < 0)
            fail_msg("cut: %s", err.msg);
        pf_cut_result_release(&r);
        free(req);
    }
    assert_int_equal(pf_sim_get_stats(sim)->bodies, 4);
    *count = 3 * (size_t)pf_sim_mesh(sim)->n_nodes;
    double *u = malloc(10 * *count * sizeof *u);
    assert_non_null(u);
    int64_t f0 = pf_sim_get_stats(sim)->factorisations;
    int64_t n0 = pf_sim_get_stats(sim)->solver.by_reason[PF_REFACTOR_NEW];
    for (int f = 0; f < 10; ++f) {
        run_frames(sim, 1);
        pf_sim_nodal_displacements(sim, u + (size_t)f * *count);
    }
    *factorisations = pf_sim_get_stats(sim)->factorisations - f0;
    *new_terms = pf_sim_get_stats(sim)->solver.by_reason[PF_REFACTOR_NEW] - n0;
    *resolved = pf_sim_get_stats(sim)->solver.method;
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return u;
}

/* After a cut, auto goes on with pcg, which it chose on the uncut bar (a factorisation there
 * is worth 15.7 iterations by the cost model; on the four pieces, 8.0, below auto's threshold
 * of 10 for direct: without the carried choice every step after the cuts refactorised). The 20
 * steps after the cuts factorise at most 4 times for the policy's own reasons (the first on the
 * new pattern, renewals by cost or failure), where direct factorises at each of them: measured 3
 * without crack contact, the bound leaving one renewal of margin. The pieces' crack faces press
 * on each other, and their contact set changes at almost every step (19 of 20), each change a
 * factorisation for the new terms (PF_REFACTOR_NEW), which the bound leaves out. The frames
 * agree with direct's to 1e-6 of the largest displacement (the solver's tolerance, 1e-10 of the
 * right-hand side, bounds each step's difference by that times the step matrix's condition,
 * 1e1-1e3; measured 7.6e-14 of 1.9e-2). */
static void test_solver_after_cut(void **state)
{
    (void)state;
    int64_t fa, fd, new_a, new_d;
    pf_solver_method ma, md;
    size_t na, nd;
    double *ua = run_after_cut(PF_SOLVER_AUTO, &fa, &new_a, &ma, &na);
    double *ud = run_after_cut(PF_SOLVER_DIRECT, &fd, &new_d, &md, &nd);
    assert_int_equal(na, nd);
    double largest = 0, diff = 0;
    for (size_t q = 0; q < 10 * na; ++q) {
        largest = fmax(largest, fabs(ud[q]));
        diff = fmax(diff, fabs(ua[q] - ud[q]));
    }
    print_message("after the cuts: auto ran %s, %lld factorisations in 20 steps (%lld for new "
                  "contact terms; direct %lld); largest displacement %.3e, auto - direct %.2e\n",
                  pf_solver_method_name(ma), (long long)fa, (long long)new_a, (long long)fd,
                  largest, diff);
    assert_int_equal(ma, PF_SOLVER_PCG);
    assert_int_equal(fd, 20);
    assert_true(fa - new_a >= 1 && fa - new_a <= 4);
    assert_true(largest > 0);
    assert_true(diff <= 1e-6 * largest);
    free(ua);
    free(ud);
}

/* The scene's "cuts": errors name the key. */
static void test_scene_errors(void **state)
{
    (void)state;
    static const char *const cases[][2] = {
        {"{\"cuts\": [{\"blade\": [[0, 0, 0], [1, 0, 0]]}]}", "cuts[0]: a blade needs a \"path\""},
        {"{\"cuts\": [{\"blade\": [[0, 0, 0], [0, 0, 0]], \"path\": []}]}",
         "cuts[0].blade: the blade's two end points must differ"},
        {"{\"cuts\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [0, 0, 0]}}]}",
         "cuts[0].plane.normal: must be a non-zero vector"},
        {"{\"cuts\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]},"
         " \"blade\": [[0, 0, 0], [1, 0, 0]]}]}",
         "cuts[0]: give one of"},
        {"{\"cuts\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]},"
         " \"path\": [{\"time\": 0, \"translation\": [0, 0, 0]}]}]}",
         "cuts[0]: \"path\" is for a blade"},
        {"{\"cuts\": {}}", "cuts: must be an array"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; ++i) {
        pf_scene sc;
        pf_error err = {0};
        pf_status st = pf_scene_parse(&sc, cases[i][0], strlen(cases[i][0]), "s.json", &err);
        if (st != PF_ERR_INVALID || !strstr(err.msg, cases[i][1]))
            fail_msg("case %d: status %d, message \"%s\", expected \"%s\"", (int)i, (int)st,
                     err.msg, cases[i][1]);
        pf_scene_release(&sc);
    }
}


/* ---- a blade through the sliced bunny -----------------------------------------------------
 */

/* The triangles of the simulator's surface whose corners are not all weighted by nodes of one
 * body (a corner weighted by two bodies counts as its own). */
static int32_t triangles_across_bodies(const pf_sim *sim)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    const pf_surface *s = pf_sim_surface(sim);
    const pf_weights *w = pf_sim_weights(sim);
    int32_t *eb = malloc((size_t)m->n_elems * sizeof *eb);
    int32_t *nb = malloc((size_t)m->n_nodes * sizeof *nb);
    int32_t *vb = malloc((size_t)s->n_verts * sizeof *vb);
    assert_true(eb && nb && vb);
    element_bodies(m, eb);
    node_bodies(m, eb, nb);
    for (int32_t v = 0; v < s->n_verts; ++v) {
        vb[v] = -1;
        for (int64_t q = w->row_offsets[v]; q < w->row_offsets[v + 1]; ++q)
            if (w->val[q] != 0)
                vb[v] = vb[v] == -1 || vb[v] == nb[w->col[q]] ? nb[w->col[q]] : -2 - v;
    }
    int32_t across = 0;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *c = s->tri + 3 * (size_t)t;
        across += vb[c[0]] != vb[c[1]] || vb[c[1]] != vb[c[2]] || vb[c[0]] < 0;
    }
    free(eb), free(nb), free(vb);
    return across;
}

/* data/scenes/bunny_cut.json on the bunny sliced 10 across (pf-slice's defaults otherwise) with
 * the bunny embedded (MLS): the blade crosses it between frames 6 and 18 in 9 cuts and leaves two
 * bodies; the crack steps off the blade's plane onto element faces (the sliver rule), whose
 * planes split the caps made on the blade's. Such a split point of an edge both sides' caps had
 * was one vertex of both and of no side, so caps of the upper piece had corners moving with the
 * lower one (10 triangles: a spike in the render). After every frame: the surface is closed, and
 * every triangle's corners are weighted by nodes of one body only. */
static void test_bunny_blade(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    if (pf_import_surface(PF_TEST_DATA_DIR "/../../data/models/bunny.obj", &s, &err) != PF_OK)
        fail_msg("bunny.obj: %s", err.msg);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 10;
    assert_int_equal(pf_mesh_slice(&m, &s, &p, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    pf_weights w = {0};
    assert_int_equal(pf_embed_compute(&m, &s, NULL, &w, NULL, &err), PF_OK);
    pf_scene sc;
    if (load_scene(&sc, PF_TEST_DATA_DIR "/../../data/scenes/bunny_cut.json", &err) < 0)
        fail_msg("scene: %s", err.msg);
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create_embedded(&sim, &sc, &m, &s, &w, &err), PF_OK);
    for (int f = 0; f < 19; ++f) {
        run_frames(sim, 1);
        pf_surface_stats ss;
        assert_int_equal(pf_surface_compute_stats(pf_sim_surface(sim), &ss, &err), PF_OK);
        int32_t across = triangles_across_bodies(sim);
        if (!ss.closed || across)
            fail_msg("frame %d: the surface is closed %d, %d triangles across bodies", f,
                     ss.closed, (int)across);
    }
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    print_message("bunny: %d cuts, %d bodies, %d surface triangles\n", (int)st->cuts,
                  (int)st->bodies, (int)pf_sim_surface(sim)->n_tris);
    assert_int_equal(st->bodies, 2);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_scene_release(&sc);
    pf_surface_release(&s);
    pf_mesh_release(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_affine_state_survives_cut),
        cmocka_unit_test(test_clamped_bar_falls_apart),
        cmocka_unit_test(test_progressive_blade),
        cmocka_unit_test(test_pencil),
        cmocka_unit_test(test_embedded_surface_cut),
        cmocka_unit_test(test_embedded_progressive),
        cmocka_unit_test(test_surface_follows_its_piece),
        cmocka_unit_test(test_bunny_blade),
        cmocka_unit_test(test_solver_after_cut),
        cmocka_unit_test(test_scene_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
