/* basis: nodal shape functions (harmonic paper sec. 4-5).
 *
 * Oracles:
 * - Closed forms (tet, parallelepiped hex) against barycentric / trilinear functions written out
 *   here independently, and central differences for the gradients.
 * - Every cell type: partition of unity and linear reproduction (values and gradients) to 1e-12
 *   at points inside the cell chosen here (convex combinations of the nodes of convex cells,
 *   points of the three cubes of the L-shaped cell). pf makes both exact by a projection, so what
 *   is left is round-off: the sums run over <= 30 terms of size <= ~10 after cancellation of the
 *   MFS coefficients, i.e. ~1e-14; 1e-12 leaves a factor of 100.
 * - MFS cells: N_i(x_j) = delta_ij and the boundary error, to bounds measured at the defaults
 *   (see each bound's comment); harmonicity by a finite-difference Laplacian.
 * - Forced MFS on a tet and a cube reproduces the closed forms to round-off (both lie in its
 *   trial space).
 * - C0: two harmonic cells sharing a face agree there to the boundary error.
 * The face functions alone: test_basis_face.c; the cells: basis_meshes.h.
 */
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

#include <pf/basis.h>
#include <pf/mesh.h>
#include <pf/split.h>

#include "basis_meshes.h"

/* ---- checks ------------------------------------------------------------------------------------
 */

static uint64_t rng = 88172645463325252ull;
static double urand(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A random point of a convex element: a convex combination of its nodes, squared weights
 * spreading the points toward the corners. */
static pf_vec3 convex_point(const pf_mesh *m, const int32_t *nodes, int32_t k)
{
    double w[64], s = 0;
    for (int32_t i = 0; i < k; ++i)
        s += w[i] = pow(urand(), 2);
    pf_vec3 x = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < k; ++i)
        x = pf_v3_add(x, pf_v3_scale(pf_v3_load(m->x + 3 * nodes[i]), w[i] / s));
    return x;
}

/* Largest |sum N_i - 1|, |sum x_i N_i - x| / diam, |sum grad N_i| diam, |sum x_i grad N_i - I|. */
static double exactness_error(const pf_basis *b, const pf_mesh *m, int32_t e, pf_vec3 x,
                              double diam)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(b, e, &nodes);
    double n[PF_BASIS_MAX_NODES], g[3 * PF_BASIS_MAX_NODES];
    pf_basis_eval(b, e, x, n, g);
    double su = -1, sx[3] = {-x.x, -x.y, -x.z}, sg[3] = {0},
           sxg[9] = {-1, 0, 0, 0, -1, 0, 0, 0, -1};
    for (int32_t i = 0; i < k; ++i) {
        const double *xi = m->x + 3 * nodes[i];
        su += n[i];
        for (int a = 0; a < 3; ++a) {
            sx[a] += xi[a] * n[i];
            sg[a] += g[3 * i + a];
            for (int c = 0; c < 3; ++c)
                sxg[3 * a + c] += xi[a] * g[3 * i + c];
        }
    }
    double err = fabs(su);
    for (int a = 0; a < 3; ++a)
        err = fmax(err, fmax(fabs(sx[a]) / diam, fabs(sg[a]) * diam));
    for (int a = 0; a < 9; ++a)
        err = fmax(err, fabs(sxg[a]));
    return err;
}

static double elem_diam(const pf_basis *b, const pf_mesh *m, int32_t e)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(b, e, &nodes);
    double d = 0;
    for (int32_t i = 0; i < k; ++i)
        for (int32_t j = 0; j < i; ++j)
            d = fmax(d,
                     pf_v3_dist(pf_v3_load(m->x + 3 * nodes[i]), pf_v3_load(m->x + 3 * nodes[j])));
    return d;
}

/* Largest |N_i(x_j) - delta_ij|. */
static double delta_error(const pf_basis *b, const pf_mesh *m, int32_t e)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(b, e, &nodes);
    double n[PF_BASIS_MAX_NODES], worst = 0;
    for (int32_t j = 0; j < k; ++j) {
        pf_basis_eval(b, e, pf_v3_load(m->x + 3 * nodes[j]), n, NULL);
        for (int32_t i = 0; i < k; ++i)
            worst = fmax(worst, fabs(n[i] - (i == j)));
    }
    return worst;
}

/* Gradients against central differences: relative to |grad| ~ 1 / diam, step 1e-5 diam gives a
 * truncation error ~ h^2 |N'''| ~ 1e-10 and a cancellation error ~ eps / h ~ 1e-11 (relative). */
static double gradient_error(const pf_basis *b, int32_t e, pf_vec3 x, double diam)
{
    int32_t k = pf_basis_elem_nodes(b, e, NULL);
    double n[PF_BASIS_MAX_NODES], g[3 * PF_BASIS_MAX_NODES], np[PF_BASIS_MAX_NODES],
        nm[PF_BASIS_MAX_NODES];
    pf_basis_eval(b, e, x, n, g);
    double h = 1e-5 * diam, worst = 0;
    for (int c = 0; c < 3; ++c) {
        pf_vec3 d = pf_v3(c == 0 ? h : 0, c == 1 ? h : 0, c == 2 ? h : 0);
        pf_basis_eval(b, e, pf_v3_add(x, d), np, NULL);
        pf_basis_eval(b, e, pf_v3_sub(x, d), nm, NULL);
        for (int32_t i = 0; i < k; ++i)
            worst = fmax(worst, fabs((np[i] - nm[i]) / (2 * h) - g[3 * i + c]) * diam);
    }
    return worst;
}

/* Largest |h^2 Laplacian N_i| by the 7-point stencil with step h = 1e-3 diam, at points at
 * least ~0.1 diam from the boundary (kernels sit outside it): for a harmonic function the
 * stencil's error is h^4 |N''''| / 12 ~ (h / d)^4 ~ 1e-8 with d ~ 0.1 diam the distance to the
 * nearest kernel, the round-off ~1e-13 (values O(1) from cancelling kernel sums); a function of
 * the element's scale that is not harmonic (x^2 / diam^2) gives 2 h^2 / diam^2 = 2e-6. */
static double laplacian_error(const pf_basis *b, int32_t e, pf_vec3 x, double diam)
{
    int32_t k = pf_basis_elem_nodes(b, e, NULL);
    double n0[PF_BASIS_MAX_NODES], s[PF_BASIS_MAX_NODES] = {0}, t[PF_BASIS_MAX_NODES];
    double h = 1e-3 * diam;
    pf_basis_eval(b, e, x, n0, NULL);
    for (int c = 0; c < 3; ++c)
        for (int sg = -1; sg <= 1; sg += 2) {
            pf_vec3 d = pf_v3(c == 0 ? sg * h : 0, c == 1 ? sg * h : 0, c == 2 ? sg * h : 0);
            pf_basis_eval(b, e, pf_v3_add(x, d), t, NULL);
            for (int32_t i = 0; i < k; ++i)
                s[i] += t[i];
        }
    double worst = 0;
    for (int32_t i = 0; i < k; ++i)
        worst = fmax(worst, fabs(s[i] - 6 * n0[i]));
    return worst;
}

typedef pf_vec3 (*point_fn)(const pf_mesh *m, const int32_t *nodes, int32_t k);

/* Points of the L-shaped cell (the unit cubes at (0, 0), (1, 0), (0, 1) of a 2 x 2 x 1 block):
 * anywhere in the three cubes, or at least 0.1 from the L's boundary. */
static pf_vec3 l_point_at(double margin)
{
    static const double cubes[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    int c = (int)(3 * urand()) % 3;
    double w = 1 - 2 * margin;
    return pf_v3(cubes[c][0] + margin + w * urand(), cubes[c][1] + margin + w * urand(),
                 margin + w * urand());
}
static pf_vec3 l_point(const pf_mesh *m, const int32_t *nodes, int32_t k)
{
    (void)m, (void)nodes, (void)k;
    return l_point_at(0);
}
static pf_vec3 l_point_inner(const pf_mesh *m, const int32_t *nodes, int32_t k)
{
    (void)m, (void)nodes, (void)k;
    return l_point_at(0.1);
}

typedef struct cell_report {
    double exact, delta, grad, lap, boundary;
} cell_report;

static cell_report check_cell(const pf_basis *b, const pf_mesh *m, int32_t e, point_fn pts)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(b, e, &nodes);
    double diam = elem_diam(b, m, e);
    cell_report r = {0};
    pf_vec3 ctr = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < k; ++i)
        ctr = pf_v3_add(ctr, pf_v3_scale(pf_v3_load(m->x + 3 * nodes[i]), 1.0 / k));
    for (int s = 0; s < 200; ++s) {
        pf_vec3 x = pts(m, nodes, k);
        r.exact = fmax(r.exact, exactness_error(b, m, e, x, diam));
        if (s < 20) {
            r.grad = fmax(r.grad, gradient_error(b, e, x, diam));
            /* away from the boundary: half-way to the centroid (convex cells), or the L's own
             * interior points */
            pf_vec3 xi =
                pts == l_point ? l_point_inner(m, nodes, k) : pf_v3_scale(pf_v3_add(x, ctr), 0.5);
            r.lap = fmax(r.lap, laplacian_error(b, e, xi, diam));
        }
    }
    r.delta = delta_error(b, m, e);
    r.boundary = b->stats[e].boundary_error;
    return r;
}

/* ---- closed forms -------------------------------------------------------------------------- */

static void test_tet_closed_form(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double x[12] = {0.1, 0.2, 0.3, 1.4, 0.1, 0.2, 0.3, 1.1, 0.1, 0.5, 0.4, 0.9};
    const uint32_t tet[4] = {0, 1, 2, 3};
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_from_tets(&m, x, 4, tet, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_elem_kind(&b, 0), PF_BASIS_TET);
    assert_int_equal(b.stats[0].n_kernels, 0);
    const int32_t *nodes;
    assert_int_equal(pf_basis_elem_nodes(&b, 0, &nodes), 4);
    /* Independent oracle: barycentric coordinates by Cramer's rule (signed sub-volumes). */
    for (int s = 0; s < 50; ++s) {
        pf_vec3 p = convex_point(&m, nodes, 4);
        double n[4];
        pf_basis_eval(&b, 0, p, n, NULL);
        pf_vec3 v[4];
        for (int i = 0; i < 4; ++i)
            v[i] = pf_v3_load(m.x + 3 * nodes[i]);
        double vol = pf_v3_dot(pf_v3_sub(v[1], v[0]),
                               pf_v3_cross(pf_v3_sub(v[2], v[0]), pf_v3_sub(v[3], v[0])));
        for (int i = 0; i < 4; ++i) {
            pf_vec3 w[4] = {v[0], v[1], v[2], v[3]};
            w[i] = p;
            double vi = pf_v3_dot(pf_v3_sub(w[1], w[0]),
                                  pf_v3_cross(pf_v3_sub(w[2], w[0]), pf_v3_sub(w[3], w[0])));
            assert_true(fabs(n[i] - vi / vol) < 1e-14); /* both O(1), a few roundings each */
        }
        assert_true(exactness_error(&b, &m, 0, p, 1.5) < 1e-14);
        assert_true(gradient_error(&b, 0, p, 1.5) < 1e-8);
    }
    assert_true(delta_error(&b, &m, 0) < 1e-14);
    assert_true(b.stats[0].linear_error < 1e-14 && b.stats[0].unity_error < 1e-14);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_hex_closed_form(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    /* A sheared parallelepiped: corner x0 + i e1 + j e2 + k e3 in Gmsh order. */
    pf_vec3 x0 = pf_v3(0.3, -0.2, 0.1), e1 = pf_v3(1.2, 0.1, 0), e2 = pf_v3(0.3, 0.9, 0.1),
            e3 = pf_v3(0.2, 0.3, 1.1);
    double x[24];
    const int ij[8][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int v = 0; v < 8; ++v) {
        pf_vec3 p =
            pf_v3_add(x0, pf_v3_add(pf_v3_scale(e1, ij[v][0]),
                                    pf_v3_add(pf_v3_scale(e2, ij[v][1]), pf_v3_scale(e3, v >= 4))));
        pf_v3_store(p, x + 3 * v);
    }
    const uint32_t hex[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_from_hexes(&m, x, 8, hex, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_elem_kind(&b, 0), PF_BASIS_HEX);
    const int32_t *nodes;
    assert_int_equal(pf_basis_elem_nodes(&b, 0, &nodes), 8);
    /* Independent oracle: reference coordinates (s, t, u) chosen here, the point x0 + s e1 + t e2
     * + u e3, and the trilinear product of the node's corner. */
    for (int s = 0; s < 50; ++s) {
        double r[3] = {urand(), urand(), urand()};
        pf_vec3 p =
            pf_v3_add(x0, pf_v3_add(pf_v3_scale(e1, r[0]),
                                    pf_v3_add(pf_v3_scale(e2, r[1]), pf_v3_scale(e3, r[2]))));
        double n[8];
        pf_basis_eval(&b, 0, p, n, NULL);
        for (int i = 0; i < 8; ++i) {
            int v = nodes[i];
            double want = (ij[v][0] ? r[0] : 1 - r[0]) * (ij[v][1] ? r[1] : 1 - r[1]) *
                          (v >= 4 ? r[2] : 1 - r[2]);
            assert_true(fabs(n[i] - want) < 1e-14);
        }
        assert_true(exactness_error(&b, &m, 0, p, 2) < 1e-14);
        assert_true(gradient_error(&b, 0, p, 2) < 1e-8);
    }
    assert_true(delta_error(&b, &m, 0) < 1e-14);
    pf_basis_release(&b);

    /* Move one corner: no longer a parallelepiped, so harmonic. */
    m.x[3 * 6] += 0.2;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_elem_kind(&b, 0), PF_BASIS_HARMONIC);
    assert_true(b.stats[0].n_kernels > 0);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- harmonic cells
 * ------------------------------------------------------------------------------ */

static void report(const char *name, cell_report r, const pf_basis_elem_stats *st)
{
    printf("  %-12s nodes %2d kernels %3d colloc %4d exact %.1e delta %.1e grad %.1e lap %.1e "
           "boundary %.2e min %.3f ms %.2f%s\n",
           name, st->n_nodes, st->n_kernels, st->n_collocation, r.exact, r.delta, r.grad, r.lap,
           r.boundary, st->min_value, st->setup_ms, st->used_svd ? " svd" : "");
    printf("               faces %d moved %d dropped %d\n", st->n_faces, st->n_kernels_moved,
           st->n_kernels_dropped);
}

/* Bounds for MFS cells at the default settings (edge_samples 2, xi 0.1, linear plus harmonic
 * polynomials of degree 2 and 3), measured on the cells of this file with a margin of about 1.5
 * (the paper, with a linear polynomial only, reports 2-3 % boundary error at 5 edge samples).
 * They are accuracy regression guards, not exactness claims:
 * - the corner-cut cube: boundary error 1.1 %, node values 1.1 % (nodes are the worst boundary
 *   points: the face data have kinks at every edge, which smooth kernels outside only
 *   approximate; a box has none the polynomials miss, test_forced_mfs_matches_closed_forms);
 * - the octree cell: 2.6 % and 5.0 % (its split face and the edge-midpoint nodes put hats of
 *   half the cell's size into the data);
 * - the L-shaped cell: 4.0 % and 5.7 % (the reflex edge x = y = 1 makes the exact harmonic
 *   functions singular there, r^(2/3)); pointwise on the faces through that edge 15 %;
 * - cells of a coarsely sliced sphere (8 x 16 facets, 3 cells across, up to 37 nodes, 5 of
 *   them inside the surface patch), with pf_basis_params_accurate: up to 1.9 % and 0.10 per
 *   node, 0.023 between the two sides of a shared face (at the defaults: 19 %, 0.11 and 0.19);
 * - every harmonic cell of that sphere sliced 6 across (the accuracy target of pf/basis.h): at
 *   the defaults (sliced-cell settings on patch cells, 400 kernels at most) median 0.76 %,
 *   worst decile from 1.78 %, largest 2.63 %; pf_basis_params_accurate (no budget) 0.68 %,
 *   1.6 % and 2.4 %; the uniform functions median 12 % (test_sliced_sphere_res6).
 * The sliced-sphere bounds are the measured values plus about 10 %. */
static const double CORNER_DELTA = 0.017, CORNER_BOUNDARY = 0.017;
static const double OCTREE_DELTA = 0.075, OCTREE_BOUNDARY = 0.04;
static const double L_DELTA = 0.085, L_BOUNDARY = 0.06, L_SHARED = 0.23;
static const double SPHERE_DELTA = 0.11, SPHERE_BOUNDARY = 0.021, SPHERE_SHARED = 0.025;
static const double RES6_MEDIAN = 0.0084, RES6_DECILE = 0.0196, RES6_MAX = 0.029;
static const double ACC6_MEDIAN = 0.0075, ACC6_DECILE = 0.018, ACC6_MAX = 0.027;
static const double LAPLACE_BOUND = 2e-7;
/* C0 across a face: the two sides differ by at most both their boundary errors (pointwise: the
 * node errors), so the larger of the cells' node bounds. */

static void assert_harmonic_cell(const pf_basis *b, const pf_mesh *m, int32_t e, point_fn pts,
                                 const char *name, double delta_bound, double boundary_bound)
{
    assert_int_equal(pf_basis_elem_kind(b, e), PF_BASIS_HARMONIC);
    cell_report r = check_cell(b, m, e, pts);
    report(name, r, &b->stats[e]);
    assert_true(r.exact < 1e-12);
    assert_true(b->stats[e].linear_error < 1e-12 && b->stats[e].unity_error < 1e-12);
    assert_true(r.grad < 1e-6);
    assert_true(r.lap < LAPLACE_BOUND);
    assert_true(r.delta < delta_bound);
    assert_true(r.boundary < boundary_bound);
    assert_true(b->stats[e].n_kernels > 0 && b->stats[e].n_collocation > 2 * b->stats[e].n_kernels);
}

static void test_l_shaped_cell(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_l_mesh(&m);
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_elem_kind(&b, 1), PF_BASIS_HEX);
    assert_harmonic_cell(&b, &m, 0, l_point, "L-shape", L_DELTA, L_BOUNDARY);
    /* The non-convex L keeps kernels outside: its reflex edge x = y = 1 pushes some back. */
    assert_int_equal(b.stats[0].n_nodes, 16);
    /* C0 with the closed-form hex on the shared faces x = 1 (y in [1, 2]) and y = 1 (x in
     * [1, 2]): the L's functions match the hex's bilinear face functions to the boundary error. */
    const int32_t *nl, *nh;
    int32_t kl = pf_basis_elem_nodes(&b, 0, &nl), kh = pf_basis_elem_nodes(&b, 1, &nh);
    double worst = 0;
    for (int s = 0; s < 100; ++s) {
        double a = 1 + urand(), z = urand();
        pf_vec3 p = s % 2 ? pf_v3(1, a, z) : pf_v3(a, 1, z);
        double vl[PF_BASIS_MAX_NODES], vh[8];
        pf_basis_eval(&b, 0, p, vl, NULL);
        pf_basis_eval(&b, 1, p, vh, NULL);
        for (int32_t i = 0; i < kl; ++i) {
            double other = 0;
            for (int32_t j = 0; j < kh; ++j)
                if (nh[j] == nl[i])
                    other = vh[j];
            worst = fmax(worst, fabs(vl[i] - other));
        }
    }
    printf("  L/hex shared faces: largest difference %.2e\n", worst);
    assert_true(worst < L_SHARED);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_corner_cut_and_octree_cells(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    pf_basis b;
    make_corner_cut(&m);
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(b.stats[0].n_nodes, 10);
    assert_harmonic_cell(&b, &m, 0, convex_point, "corner-cut", CORNER_DELTA, CORNER_BOUNDARY);
    pf_basis_release(&b);
    pf_mesh_release(&m);

    make_octree_cell(&m);
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    assert_int_equal(b.stats[0].n_nodes, 13);
    assert_harmonic_cell(&b, &m, 0, convex_point, "octree", OCTREE_DELTA, OCTREE_BOUNDARY);
    /* Faces: 4 split top quads and the bottom are squares (closed form), 4 pentagons MFS. */
    assert_int_equal(b.n_face_closed, 5);
    assert_int_equal(b.n_face_mfs, 4);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_sliced_sphere_cells(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_sphere_mesh(&m);
    pf_basis_params acc = pf_basis_params_accurate();
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, &acc, &err), PF_OK);
    int32_t nh = 0;
    for (int32_t e = 0; e < m.n_elems; ++e)
        if (pf_basis_elem_kind(&b, e) == PF_BASIS_HARMONIC) {
            char name[32];
            snprintf(name, sizeof name, "sphere %d", (int)e);
            assert_harmonic_cell(&b, &m, e, convex_point, name, SPHERE_DELTA, SPHERE_BOUNDARY);
            ++nh;
        }
    assert_true(nh >= 8);
    /* C0 between harmonic neighbours: on each shared face, both elements' functions of the
     * face's nodes agree (and vanish for the others) to the boundary error. */
    double worst = 0;
    for (int32_t f = 0; f < m.n_faces; ++f) {
        int32_t e1 = m.face_elems[2 * f], e2 = m.face_elems[2 * f + 1];
        if (e1 < 0 || e2 < 0)
            continue;
        const int32_t *n1, *n2;
        int32_t k1 = pf_basis_elem_nodes(&b, e1, &n1), k2 = pf_basis_elem_nodes(&b, e2, &n2);
        int64_t a = m.face_offsets[f];
        int32_t fnn = (int32_t)(m.face_offsets[f + 1] - a);
        for (int s = 0; s < 5; ++s) {
            pf_vec3 p = convex_point(&m, (const int32_t *)(m.face_nodes + a), fnn);
            double v1[PF_BASIS_MAX_NODES], v2[PF_BASIS_MAX_NODES];
            pf_basis_eval(&b, e1, p, v1, NULL);
            pf_basis_eval(&b, e2, p, v2, NULL);
            for (int32_t i = 0; i < k1; ++i) {
                double other = 0;
                for (int32_t j = 0; j < k2; ++j)
                    if (n2[j] == n1[i])
                        other = v2[j];
                worst = fmax(worst, fabs(v1[i] - other));
            }
        }
    }
    printf("  sphere shared faces: largest difference %.2e\n", worst);
    assert_true(worst < SPHERE_SHARED);
    pf_basis_summary sum;
    assert_int_equal(pf_basis_summarize(&b, &sum, &err), PF_OK);
    printf("  sphere: %d elements (%d hex, %d harmonic), median boundary %.2e max %.2e, median "
           "setup %.3f ms, faces %d MFS %d closed\n",
           (int)sum.n_elems, (int)sum.n_by_kind[PF_BASIS_HEX],
           (int)sum.n_by_kind[PF_BASIS_HARMONIC], sum.median_boundary_error, sum.max_boundary_error,
           sum.median_setup_ms, (int)b.n_face_mfs, (int)b.n_face_closed);
    assert_true(sum.max_linear_error < 1e-12 && sum.max_unity_error < 1e-12);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static int cmp_dbl(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Boundary errors of the harmonic cells of b, sorted, in be (at most cap); checks linear
 * reproduction and partition of unity on every cell. Returns their number. */
static int32_t sorted_errors(const pf_basis *b, double *be, int32_t cap)
{
    int32_t n = 0;
    for (int32_t e = 0; e < b->n_elems && n < cap; ++e)
        if (pf_basis_elem_kind(b, e) == PF_BASIS_HARMONIC) {
            be[n++] = b->stats[e].boundary_error;
            assert_true(b->stats[e].linear_error < 1e-12 && b->stats[e].unity_error < 1e-12);
        }
    qsort(be, (size_t)n, sizeof *be, cmp_dbl);
    return n;
}

/* The accuracy target: every harmonic cell of the 8 x 16 sphere sliced 6 across (what
 * `pf-slice sphere.obj --res 6 | pf-basis` reports) at the defaults: median boundary error
 * under 1 % and worst decile under 2 % within the kernel budget, and the surface-patch data keep
 * linear reproduction and partition of unity exact. The accurate preset keeps its own bounds
 * (no budget); the uniform functions are what the sliced-cell settings remove. */
static void test_sliced_sphere_res6(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_sphere_mesh_res(&m, 6);
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    double be[1024];
    int32_t n = sorted_errors(&b, be, 1024);
    int32_t kmax = 0;
    for (int32_t e = 0; e < m.n_elems; ++e)
        kmax = b.stats[e].n_kernels > kmax ? b.stats[e].n_kernels : kmax;
    printf("  sphere res 6, defaults: %d harmonic cells, boundary error median %.4f, worst decile "
           "from %.4f, largest %.4f; kernels at most %d\n",
           (int)n, be[n / 2], be[(9 * n) / 10], be[n - 1], (int)kmax);
    assert_true(n >= 100);
    assert_true(be[n / 2] < RES6_MEDIAN);
    assert_true(be[(9 * n) / 10] < RES6_DECILE);
    assert_true(be[n - 1] < RES6_MAX);
    assert_true(kmax <= PF_BASIS_DEFAULT_MAX_KERNELS);
    pf_basis_release(&b);

    pf_basis_params acc = pf_basis_params_accurate();
    assert_int_equal(pf_basis_create(&b, &m, &acc, &err), PF_OK);
    n = sorted_errors(&b, be, 1024);
    printf("  accurate: median %.4f, worst decile from %.4f, largest %.4f\n", be[n / 2],
           be[(9 * n) / 10], be[n - 1]);
    assert_true(be[n / 2] < ACC6_MEDIAN);
    assert_true(be[(9 * n) / 10] < ACC6_DECILE);
    assert_true(be[n - 1] < ACC6_MAX);
    pf_basis_release(&b);

    pf_basis_params up = pf_basis_params_uniform();
    pf_basis old;
    assert_int_equal(pf_basis_create(&old, &m, &up, &err), PF_OK);
    pf_basis_summary so;
    assert_int_equal(pf_basis_summarize(&old, &so, &err), PF_OK);
    printf("  uniform: median %.4f\n", so.median_boundary_error);
    assert_true(so.median_boundary_error > 10 * RES6_MEDIAN);
    pf_basis_release(&old);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Block evaluation (one dgemm) against pointwise evaluation on every cell of the sliced sphere,
 * at a full block, a partial one and a partial one without gradients, at points inside each
 * cell: they differ in summation order only. Values are O(1) sums of ~200 kernel terms whose
 * coefficients cancel by up to ~1e3, so reordering them moves the result by at most ~1e3 * 200 *
 * 1e-16 = 2e-11 in the worst case and by ~1e-15 typically (measured: 9e-16 for values, 4e-15 for
 * gradients times the cell diameter); the bound 1e-13 leaves room for the typical case only, so a
 * wrong row or column (an O(1) error) fails. The check-point statistics, when skipped, leave the
 * functions bit for bit unchanged. */
static void test_block_eval_matches_pointwise(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_sphere_mesh(&m);
    pf_basis b, quick;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_OK);
    pf_basis_params p = pf_basis_params_default();
    p.no_check_stats = true;
    assert_int_equal(pf_basis_create(&quick, &m, &p, &err), PF_OK);
    assert_int_equal(quick.data_offsets[m.n_elems], b.data_offsets[m.n_elems]);
    assert_memory_equal(quick.data, b.data, (size_t)b.data_offsets[m.n_elems] * sizeof *b.data);
    double *x = malloc(3 * PF_BASIS_EVAL_BLOCK * sizeof *x);
    double *val = malloc(PF_BASIS_EVAL_BLOCK * PF_BASIS_MAX_NODES * sizeof *val);
    double *grad = malloc(3 * PF_BASIS_EVAL_BLOCK * PF_BASIS_MAX_NODES * sizeof *grad);
    double worst_v = 0, worst_g = 0;
    int32_t harmonic = 0;
    for (int32_t e = 0; e < m.n_elems; ++e) {
        harmonic += pf_basis_elem_kind(&b, e) == PF_BASIS_HARMONIC;
        /* skipped: all but the boundary error, which is the full statistics' */
        assert_true(quick.stats[e].boundary_error == b.stats[e].boundary_error &&
                    quick.stats[e].linear_error == 0);
        assert_int_equal(quick.stats[e].n_kernels, b.stats[e].n_kernels);
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&b, e, &nodes);
        double diam = elem_diam(&b, &m, e);
        double *scratch = malloc((pf_basis_eval_block_scratch(&b, e) + 1) * sizeof *scratch);
        for (int pass = 0; pass < 3; ++pass) { /* full block, partial, values only */
            int32_t n = pass ? 5 : PF_BASIS_EVAL_BLOCK;
            for (int32_t q = 0; q < n; ++q)
                pf_v3_store(convex_point(&m, nodes, k), x + 3 * q);
            pf_basis_eval_block(&b, e, n, x, val, pass == 2 ? NULL : grad, scratch);
            for (int32_t q = 0; q < n; ++q) {
                double v[PF_BASIS_MAX_NODES], g[3 * PF_BASIS_MAX_NODES];
                pf_basis_eval(&b, e, pf_v3_load(x + 3 * q), v, g);
                for (int32_t i = 0; i < k; ++i) {
                    worst_v = fmax(worst_v, fabs(val[(size_t)q * k + i] - v[i]));
                    for (int d = 0; d < 3 * (pass < 2); ++d)
                        worst_g = fmax(
                            worst_g, diam * fabs(grad[3 * ((size_t)q * k + i) + d] - g[3 * i + d]));
                }
            }
        }
        free(scratch);
    }
    printf("  block evaluation on %d harmonic cells: largest difference %.2e (values), %.2e "
           "(gradients times diameter)\n",
           (int)harmonic, worst_v, worst_g);
    assert_true(harmonic >= 8);
    assert_true(worst_v < 1e-13 && worst_g < 1e-13);
    free(x);
    free(val);
    free(grad);
    pf_basis_release(&quick);
    pf_basis_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- forced MFS against closed forms ----------------------------------------------------------
 */

static void test_forced_mfs_matches_closed_forms(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    double x[24];
    cube_nodes(x, pf_v3(0, 0, 0), 1);
    mesh_from_poly(&m, x, 8, CUBE_OFF, CUBE_FACES, 6);
    pf_basis_params p = pf_basis_params_default();
    p.force_mfs = true;
    pf_basis closed, mfs;
    assert_int_equal(pf_basis_create(&closed, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_create(&mfs, &m, &p, &err), PF_OK);
    assert_int_equal(pf_basis_elem_kind(&closed, 0), PF_BASIS_HEX);
    assert_int_equal(pf_basis_elem_kind(&mfs, 0), PF_BASIS_HARMONIC);
    /* The trilinear functions of a cube are harmonic with bilinear (exact) face data, and they
     * lie in the MFS trial space (1, x, y, z and the harmonic xy, yz, zx, xyz are among its
     * polynomials), so the least-squares fit recovers them: the kernels' coefficients vanish up
     * to the QR's round-off, cond * eps on an O(1) solution (measured 3e-16 for the values and
     * the boundary error; 1e-12 leaves a factor 1e4 for the condition number). Without the
     * higher polynomials the difference was the boundary error, 1 %. */
    double worst = 0;
    for (int s = 0; s < 200; ++s) {
        pf_vec3 q = pf_v3(urand(), urand(), urand());
        double a[8], c[8];
        pf_basis_eval(&closed, 0, q, a, NULL);
        pf_basis_eval(&mfs, 0, q, c, NULL);
        for (int i = 0; i < 8; ++i)
            worst = fmax(worst, fabs(a[i] - c[i]));
    }
    printf("  cube: MFS vs trilinear %.2e (boundary error %.2e)\n", worst,
           mfs.stats[0].boundary_error);
    assert_true(worst < 1e-12);
    assert_true(mfs.stats[0].boundary_error < 1e-12);
    pf_basis_release(&closed);
    pf_basis_release(&mfs);
    pf_mesh_release(&m);

    const double tx[12] = {0, 0, 0, 1, 0, 0, 0.2, 1, 0, 0.3, 0.2, 0.9};
    const uint32_t tet[4] = {0, 1, 2, 3};
    assert_int_equal(pf_mesh_from_tets(&m, tx, 4, tet, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    assert_int_equal(pf_basis_create(&closed, &m, NULL, &err), PF_OK);
    assert_int_equal(pf_basis_create(&mfs, &m, &p, &err), PF_OK);
    /* Linear data on triangles: the linear functions themselves are in the MFS space (the
     * polynomial part), so the least-squares fit recovers them up to round-off. */
    const int32_t *nodes;
    pf_basis_elem_nodes(&mfs, 0, &nodes);
    worst = 0;
    for (int s = 0; s < 200; ++s) {
        pf_vec3 q = convex_point(&m, nodes, 4);
        double a[4], c[4];
        pf_basis_eval(&closed, 0, q, a, NULL);
        pf_basis_eval(&mfs, 0, q, c, NULL);
        for (int i = 0; i < 4; ++i)
            worst = fmax(worst, fabs(a[i] - c[i]));
    }
    printf("  tet: MFS vs linear %.2e (boundary error %.2e)\n", worst, mfs.stats[0].boundary_error);
    assert_true(worst < 1e-8);
    pf_basis_release(&closed);
    pf_basis_release(&mfs);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* More kernels, smaller boundary error (the paper's convergence claim). */
static void test_boundary_error_decreases(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_corner_cut(&m);
    double prev = INFINITY;
    for (int32_t s = 2; s <= 6; s += 2) {
        pf_basis_params p = pf_basis_params_default();
        p.edge_samples = s;
        pf_basis b;
        assert_int_equal(pf_basis_create(&b, &m, &p, &err), PF_OK);
        printf("  edge samples %d: kernels %d boundary error %.2e setup %.2f ms\n", (int)s,
               b.stats[0].n_kernels, b.stats[0].boundary_error, b.stats[0].setup_ms);
        assert_true(b.stats[0].boundary_error < prev);
        prev = b.stats[0].boundary_error;
        pf_basis_release(&b);
    }
    pf_mesh_release(&m);
}

static void test_bad_input(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    double x[24];
    cube_nodes(x, pf_v3(0, 0, 0), 1);
    mesh_from_poly(&m, x, 8, CUBE_OFF, CUBE_FACES, 6);
    m.face_nodes[5] = 99; /* out of range */
    pf_basis b;
    assert_int_equal(pf_basis_create(&b, &m, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "out of range"));
    assert_null(b.stats);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tet_closed_form),
        cmocka_unit_test(test_hex_closed_form),
        cmocka_unit_test(test_l_shaped_cell),
        cmocka_unit_test(test_corner_cut_and_octree_cells),
        cmocka_unit_test(test_sliced_sphere_cells),
        cmocka_unit_test(test_sliced_sphere_res6),
        cmocka_unit_test(test_forced_mfs_matches_closed_forms),
        cmocka_unit_test(test_boundary_error_decreases),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_block_eval_matches_pointwise),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
