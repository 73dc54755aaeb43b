/* integrate: exact monomial moments over polyhedra and polygons.
 *
 * Oracles, each independent of the divergence-theorem code under test: products of 1D integrals
 * for boxes; the simplex formula int_S xi^a eta^b zeta^c = a! b! c! / (a+b+c+3)! (and its 2D
 * and square analogues) pulled back through the affine map of a tet, triangle or parallelogram,
 * with the map's polynomial expanded in long double; sums of such convex pieces for non-convex
 * cells and faces; rotation invariants.
 *
 * Error measure: the error of a moment of degree d is taken relative to S_d = |measure| *
 * rho^d, rho = the largest |xhat|, |yhat| or |zhat| over the nodes. S_d bounds
 * int |xhat^a yhat^b zhat^c| for every monomial of degree d, and rounding errors of the sums
 * scale with those absolute integrals, not with the moment itself: odd moments of a symmetric
 * cell are 0 and a per-entry relative error would be meaningless there. The bounds are
 * 1e-13 S_d for d <= 4 and 1e-11 S_d up to degree 8 (the requirement); observed errors
 * are a few 1e-16. The rules for other integrands are tested in test_quadrature.c; the cells
 * and reference moments both use are in integrate_cells.h. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "integrate_cells.h"

/* ---- ordering and monomials ----------------------------------------------------------------- */

static void test_ordering(void **state)
{
    (void)state;
    const int counts[] = {1, 4, 10, 20, 35, 56, 84, 120, 165};
    for (int d = 0; d <= DMAX; ++d)
        assert_int_equal(pf_moment_count(d), counts[d]);
    assert_int_equal(pf_moment_count(-1), 0);
    /* degree 2 as the header spells it: xx xy xz yy yz zz */
    const int deg2[6][3] = {{2, 0, 0}, {1, 1, 0}, {1, 0, 1}, {0, 2, 0}, {0, 1, 1}, {0, 0, 2}};
    for (int k = 0; k < 6; ++k)
        assert_int_equal(pf_moment_index(deg2[k][0], deg2[k][1], deg2[k][2]), 4 + k);
    assert_int_equal(pf_moment_index(1, 0, 0), 1);
    assert_int_equal(pf_moment_index(0, 0, 1), 3);
    for (int i = 0; i < COUNT; ++i) {
        int a, b, c;
        pf_moment_exponents(i, &a, &b, &c);
        assert_true(a == EXPO[i][0] && b == EXPO[i][1] && c == EXPO[i][2]);
        assert_int_equal(pf_moment_index(a, b, c), i);
    }
    int a, b, c;
    pf_moment_exponents(COUNT, &a, &b, &c);
    assert_true(a == -1 && b == -1 && c == -1);
    pf_moment_exponents(-1, &a, &b, &c);
    assert_true(a == -1);
    assert_int_equal(pf_moment_index(-1, 2, 0), -1);
    no_leaks();
}

static void test_monomials(void **state)
{
    (void)state;
    rng r = {12345};
    for (int k = 0; k < 50; ++k) {
        pf_vec3 p = pf_v3(uniform(&r), uniform(&r), uniform(&r));
        double v[COUNT];
        pf_moment_monomials(p, DMAX, v);
        for (int i = 0; i < COUNT; ++i) {
            /* a product of at most 8 factors rounds at most 8 times either way */
            double want = pow(p.x, EXPO[i][0]) * pow(p.y, EXPO[i][1]) * pow(p.z, EXPO[i][2]);
            assert_true(fabs(v[i] - want) <= 16 * DBL_EPSILON * fabs(want));
        }
        double low[COUNT];
        pf_moment_monomials(p, 3, low);
        assert_memory_equal(low, v, sizeof(double) * 20);
    }
    no_leaks();
}

static void test_frame(void **state)
{
    (void)state;
    cell c;
    cell_box(&c, pf_v3(1, -2, 3), pf_v3(3, 0, 4));
    pf_polyhedron p = cell_view(&c);
    pf_frame f = pf_frame_of_polyhedron(&p);
    assert_true(f.center.x == 2 && f.center.y == -1 && f.center.z == 3.5);
    assert_true(f.scale == 1.5); /* half of |(2, 2, 1)| = 3 */
    /* no extent: scale 1 */
    cell_box(&c, pf_v3(1, 1, 1), pf_v3(1, 1, 1));
    p = cell_view(&c);
    f = pf_frame_of_polyhedron(&p);
    assert_true(f.scale == 1 && f.center.x == 1);
    no_leaks();
}

/* ---- boxes and tets ----------------------------------------------------------------------- */

static void test_unit_cube(void **state)
{
    (void)state;
    cell c;
    cell_box(&c, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
    pf_frame fr = {pf_v3(0, 0, 0), 1};
    double m[COUNT];
    moments_of(&c, &fr, DMAX, m);
    /* 1 / ((a+1)(b+1)(c+1)): the face sums are of O(1) terms, a few u each */
    for (int i = 0; i < COUNT; ++i) {
        double want = 1.0 / ((EXPO[i][0] + 1) * (EXPO[i][1] + 1) * (EXPO[i][2] + 1));
        if (!(fabs(m[i] - want) <= 8 * DBL_EPSILON))
            fail_msg("x^%d y^%d z^%d: %.17g, want %.17g", EXPO[i][0], EXPO[i][1], EXPO[i][2], m[i],
                     want);
    }
    pf_polyhedron p = cell_view(&c);
    assert_true(fabs(m[0] - pf_polyhedron_volume(&p)) <= 2 * DBL_EPSILON);
    /* every lower degree is a prefix of the same computation */
    double m2[10];
    pf_error err = {0};
    assert_int_equal(pf_polyhedron_moments(&p, &fr, 2, m2, &err), PF_OK);
    for (int i = 0; i < 10; ++i)
        assert_true(fabs(m2[i] - m[i]) <= 4 * DBL_EPSILON);
    no_leaks();
}

static void test_box_offset(void **state)
{
    (void)state;
    rng r = {2024};
    for (int k = 0; k < 20; ++k) {
        double lo[3], hi[3];
        for (int i = 0; i < 3; ++i) {
            lo[i] = 1e4 + uniform(&r);
            hi[i] = lo[i] + 0.1 + fabs(uniform(&r));
        }
        cell c;
        cell_box(&c, pf_v3_load(lo), pf_v3_load(hi));
        pf_polyhedron p = cell_view(&c);
        pf_frame fr = pf_frame_of_polyhedron(&p);
        double m[COUNT];
        double rho = moments_of(&c, &fr, DMAX, m);
        real want[COUNT] = {0};
        add_box_moments(&fr, lo, hi, DMAX, 1, want);
        check_moments("box at 1e4", m, want, DMAX, (double)want[0], rho);
        /* inside out: every face reversed negates every moment */
        uint32_t rev[24];
        for (int f = 0; f < 6; ++f)
            for (int j = 0; j < 4; ++j)
                rev[4 * f + j] = c.face_nodes[4 * f + 3 - j];
        pf_polyhedron inside_out = {c.x, 6, c.offsets, rev};
        double mr[COUNT];
        pf_error err = {0};
        assert_int_equal(pf_polyhedron_moments(&inside_out, &fr, DMAX, mr, &err), PF_OK);
        for (int i = 0; i < COUNT; ++i)
            assert_true(fabs(mr[i] + m[i]) <= 1e-15 * m[0]);
    }
    no_leaks();
}

static void test_unit_simplex(void **state)
{
    (void)state;
    const pf_vec3 p[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    cell c;
    cell_tet(&c, p);
    pf_frame fr = {pf_v3(0, 0, 0), 1};
    double m[COUNT];
    moments_of(&c, &fr, DMAX, m);
    real want[COUNT];
    for (int i = 0; i < COUNT; ++i)
        want[i] = ref_simplex(EXPO[i]);
    check_moments("unit simplex", m, want, DMAX, 1.0 / 6, 1);
    /* the closed form itself, against the tighter few-u bound it actually meets */
    for (int i = 0; i < COUNT; ++i)
        assert_true(fabsl((real)m[i] - want[i]) <= 1e-15L);
    no_leaks();
}

static void test_tets_offset(void **state)
{
    (void)state;
    rng r = {777};
    double worst = 0;
    for (int k = 0; k < 30; ++k) {
        pf_vec3 p[4];
        for (int i = 0; i < 4; ++i)
            p[i] = pf_v3_add(OFFSET, pf_v3(uniform(&r), uniform(&r), uniform(&r)));
        pf_mat3 e;
        for (int j = 0; j < 3; ++j) {
            pf_vec3 d = pf_v3_sub(p[j + 1], p[0]);
            e.m[0][j] = d.x, e.m[1][j] = d.y, e.m[2][j] = d.z;
        }
        double det = pf_m3_det(e);
        if (fabs(det) < 0.05) /* keep the tets fat enough that S_d is not dominated by slivers */
            continue;
        if (det < 0) {
            pf_vec3 s = p[1];
            p[1] = p[2];
            p[2] = s;
        }
        cell c;
        cell_tet(&c, p);
        pf_polyhedron poly = cell_view(&c);
        pf_frame fr = pf_frame_of_polyhedron(&poly);
        double m[COUNT];
        double rho = moments_of(&c, &fr, DMAX, m);
        real want[COUNT] = {0};
        add_tet_moments(&fr, node_of(&c, 0), node_of(&c, 1), node_of(&c, 2), node_of(&c, 3), DMAX,
                        1, want);
        worst = fmax(worst, check_moments("tet at 1e4", m, want, DMAX, (double)want[0], rho));
    }
    print_message("tets at 1e4: worst error %.3g S_d\n", worst);
    no_leaks();
}

/* ---- non-convex cells against their convex pieces ------------------------------------------- */

static void test_L_prism(void **state)
{
    (void)state;
    cell c;
    cell_L_prism(&c, OFFSET);
    pf_polyhedron p = cell_view(&c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    double rho = moments_of(&c, &fr, DMAX, m);
    real want[COUNT] = {0};
    const double lo1[3] = {1e4, 1e4, 1e4}, hi1[3] = {1e4 + 2, 1e4 + 1, 1e4 + 2};
    const double lo2[3] = {1e4, 1e4 + 1, 1e4}, hi2[3] = {1e4 + 1, 1e4 + 2, 1e4 + 2};
    add_box_moments(&fr, lo1, hi1, DMAX, 1, want);
    add_box_moments(&fr, lo2, hi2, DMAX, 1, want);
    check_moments("L prism", m, want, DMAX, 6, rho);
    assert_true(fabs(m[0] - 6) <= 1e-14 * 6);
    no_leaks();
}

static void test_corner_cut_cube(void **state)
{
    (void)state;
    /* [0,1]^3 minus the corner tet at (1,1,1) cut by x + y + z = 2.5: three pentagons on
     * x = 1, y = 1, z = 1, three squares, one triangle. Reference: box minus tet. */
    cell c;
    cell_init(&c);
    for (int i = 0; i < 7; ++i) /* the cube corners but (1,1,1) */
        cell_node(&c, pf_v3_add(OFFSET, pf_v3(i & 1, (i >> 1) & 1, (i >> 2) & 1)));
    uint32_t cx = cell_node(&c, pf_v3_add(OFFSET, pf_v3(0.5, 1, 1)));
    uint32_t cy = cell_node(&c, pf_v3_add(OFFSET, pf_v3(1, 0.5, 1)));
    uint32_t cz = cell_node(&c, pf_v3_add(OFFSET, pf_v3(1, 1, 0.5)));
    const uint32_t x0[4] = {0, 4, 6, 2}, y0[4] = {0, 1, 5, 4}, z0[4] = {0, 2, 3, 1};
    const uint32_t x1[5] = {1, 3, cz, cy, 5}, y1[5] = {2, 6, cx, cz, 3};
    const uint32_t z1[5] = {4, 5, cy, cx, 6}, cut[3] = {cx, cy, cz};
    cell_face(&c, 4, x0);
    cell_face(&c, 4, y0);
    cell_face(&c, 4, z0);
    cell_face(&c, 5, x1);
    cell_face(&c, 5, y1);
    cell_face(&c, 5, z1);
    cell_face(&c, 3, cut);
    pf_polyhedron p = cell_view(&c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    double rho = moments_of(&c, &fr, DMAX, m);
    real want[COUNT] = {0};
    const double lo[3] = {1e4, 1e4, 1e4}, hi[3] = {1e4 + 1, 1e4 + 1, 1e4 + 1};
    add_box_moments(&fr, lo, hi, DMAX, 1, want);
    add_tet_moments(&fr, hi, node_of(&c, (int)cz), node_of(&c, (int)cy), node_of(&c, (int)cx), DMAX,
                    -1, want);
    assert_true(fabsl(want[0] - (1 - 1.0L / 48)) <= 1e-15L); /* the corner tet is 1/48 */
    check_moments("corner-cut cube", m, want, DMAX, 47.0 / 48, rho);
    no_leaks();
}

static void test_nonconvex_face(void **state)
{
    (void)state;
    cell c;
    cell_dart_pyramid(&c, OFFSET);
    pf_polyhedron p = cell_view(&c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    double rho = moments_of(&c, &fr, DMAX, m);
    /* the dart split along its reflex diagonal (0.7,1)-(2,1): two tets with the apex */
    real want[COUNT] = {0};
    add_tet_moments(&fr, node_of(&c, 0), node_of(&c, 1), node_of(&c, 3), node_of(&c, 4), DMAX, 1,
                    want);
    add_tet_moments(&fr, node_of(&c, 3), node_of(&c, 1), node_of(&c, 2), node_of(&c, 4), DMAX, 1,
                    want);
    assert_true(fabsl(want[0] - 0.65L) <= 1e-12L); /* base 1.3 (node rounding at 1e4) x 1.5 / 3 */
    check_moments("dart pyramid", m, want, DMAX, 0.65, rho);
    no_leaks();
}

static void test_coplanar_faces(void **state)
{
    (void)state;
    /* [0,2]x[0,1]^2 as two unit cubes glued at x = 1, seen from outside: the top is two coplanar
     * quads, the bottom and the y faces are hexagons with collinear (hanging) nodes at x = 1. */
    cell c;
    cell_init(&c);
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 3; ++i) /* node i + 3 j + 6 k */
                cell_node(&c, pf_v3_add(OFFSET, pf_v3(i, j, k)));
    const uint32_t bottom[6] = {0, 3, 4, 5, 2, 1};
    const uint32_t top1[4] = {6, 7, 10, 9}, top2[4] = {7, 8, 11, 10};
    const uint32_t ylo[6] = {0, 1, 2, 8, 7, 6}, yhi[6] = {3, 9, 10, 11, 5, 4};
    const uint32_t xlo[4] = {0, 6, 9, 3}, xhi[4] = {2, 5, 11, 8};
    cell_face(&c, 6, bottom);
    cell_face(&c, 4, top1);
    cell_face(&c, 4, top2);
    cell_face(&c, 6, ylo);
    cell_face(&c, 6, yhi);
    cell_face(&c, 4, xlo);
    cell_face(&c, 4, xhi);
    pf_polyhedron p = cell_view(&c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    double rho = moments_of(&c, &fr, DMAX, m);
    real want[COUNT] = {0};
    const double lo1[3] = {1e4, 1e4, 1e4}, hi1[3] = {1e4 + 1, 1e4 + 1, 1e4 + 1};
    const double lo2[3] = {1e4 + 1, 1e4, 1e4}, hi2[3] = {1e4 + 2, 1e4 + 1, 1e4 + 1};
    add_box_moments(&fr, lo1, hi1, DMAX, 1, want);
    add_box_moments(&fr, lo2, hi2, DMAX, 1, want);
    check_moments("coplanar faces", m, want, DMAX, 2, rho);
    no_leaks();
}

/* ---- invariance under rotation and translation ---------------------------------------------- */

/* int |xhat|^(2k) = sum_{i+j+l=k} k! / (i! j! l!) m[2i, 2j, 2l]. */
static double radial_moment(const double *m, int k)
{
    double s = 0;
    for (int i = 0; i <= k; ++i)
        for (int j = 0; i + j <= k; ++j) {
            int l = k - i - j;
            double mult = (double)(factorial(k) / (factorial(i) * factorial(j) * factorial(l)));
            s += mult * m[pf_moment_index(2 * i, 2 * j, 2 * l)];
        }
    return s;
}

static void test_rotation_translation(void **state)
{
    (void)state;
    rng r = {31415};
    for (int shape = 0; shape < 2; ++shape)
        for (int k = 0; k < 10; ++k) {
            cell c, q;
            if (shape == 0)
                cell_L_prism(&c, pf_v3(-1, -1, -1));
            else
                cell_dart_pyramid(&c, pf_v3(-1, -1, -0.5));
            q = c;
            pf_mat3 rot = random_rotation(&r);
            pf_vec3 t = pf_v3(3 * uniform(&r), 3 * uniform(&r), 3 * uniform(&r));
            for (int i = 0; i < c.n_nodes; ++i)
                pf_v3_store(pf_v3_add(pf_m3_mulv(rot, pf_v3_load(c.x + 3 * i)), t), q.x + 3 * i);
            /* frames that move with the cell: xhat_Q = R xhat_P */
            pf_polyhedron pc = cell_view(&c);
            pf_frame fc = pf_frame_of_polyhedron(&pc);
            pf_frame fq = {pf_v3_add(pf_m3_mulv(rot, fc.center), t), fc.scale};
            double mc[COUNT], mq[COUNT];
            double rho = moments_of(&c, &fc, DMAX, mc);
            moments_of(&q, &fq, DMAX, mq);
            /* rotated nodes carry a few u of rounding: 1e-14 of S_d leaves room for that */
            double vol = mc[0];
            assert_true(fabs(mq[0] - vol) <= 1e-14 * vol);
            /* first moments rotate as a vector, second as a tensor */
            pf_vec3 m1 = pf_m3_mulv(rot, pf_v3(mc[1], mc[2], mc[3]));
            assert_true(pf_v3_dist(m1, pf_v3(mq[1], mq[2], mq[3])) <= 1e-14 * vol * rho);
            pf_mat3 s;
            const int sym[3][3] = {{4, 5, 6}, {5, 7, 8}, {6, 8, 9}};
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    s.m[i][j] = mc[sym[i][j]];
            pf_mat3 sr = pf_m3_mul(pf_m3_mul(rot, s), pf_m3_transpose(rot));
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    assert_true(fabs(sr.m[i][j] - mq[sym[i][j]]) <= 1e-14 * vol * rho * rho);
            /* radial moments of degree 2k are invariant, up to degree 8 */
            for (int kk = 1; kk <= 4; ++kk) {
                double a = radial_moment(mc, kk), b = radial_moment(mq, kk);
                assert_true(fabs(a - b) <= 1e-13 * a);
            }
        }
    no_leaks();
}

/* ---- polygons ------------------------------------------------------------------------------ */

static void polygon_check(const char *what, const double *x, const uint32_t *idx, int n,
                          const pf_frame *fr, const real *want, double area)
{
    double m[COUNT], mr[COUNT];
    uint32_t rev[16];
    for (int i = 0; i < n; ++i)
        rev[i] = idx[n - 1 - i];
    pf_error err = {0};
    assert_int_equal(pf_polygon_moments(x, idx, n, fr, DMAX, m, &err), PF_OK);
    assert_int_equal(pf_polygon_moments(x, rev, n, fr, DMAX, mr, &err), PF_OK);
    double rho = local_radius(x, n, fr); /* idx is 0..n-1 in these tests */
    check_moments(what, m, want, DMAX, area, rho);
    check_moments(what, mr, want, DMAX, area, rho);
}

/* Tilted frames for polygons: the columns of a random rotation near the origin (node rounding a
 * few u), or, at the 1e4 offset, the exact orthogonal pair u = (1,-4,8)/16, v = (8,4,1)/16 (both of
 * length 9/16) whose multiples stay exact there, so the stored polygon is the exact one. */
static void tilted_axes(int k, rng *r, pf_vec3 *origin, pf_vec3 *u, pf_vec3 *v)
{
    if (k == 0) {
        *origin = pf_v3_add(OFFSET, pf_v3(0.25, -0.5, 0.125));
        *u = pf_v3(1.0 / 16, -4.0 / 16, 8.0 / 16);
        *v = pf_v3(8.0 / 16, 4.0 / 16, 1.0 / 16);
        return;
    }
    pf_mat3 rot = random_rotation(r);
    *origin = pf_v3(uniform(r), uniform(r), uniform(r));
    *u = pf_v3(rot.m[0][0], rot.m[1][0], rot.m[2][0]);
    *v = pf_v3(rot.m[0][1], rot.m[1][1], rot.m[2][1]);
}

static pf_vec3 plane_point(pf_vec3 o, pf_vec3 u, pf_vec3 v, double s, double t)
{
    return pf_v3_add(o, pf_v3_add(pf_v3_scale(u, s), pf_v3_scale(v, t)));
}

static void test_polygon_tilted_square(void **state)
{
    (void)state;
    rng r = {4242};
    for (int k = 0; k < 10; ++k) {
        pf_vec3 o, u, v;
        tilted_axes(k, &r, &o, &u, &v);
        double x[12];
        const double corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int i = 0; i < 4; ++i)
            pf_v3_store(plane_point(o, u, v, corner[i][0], corner[i][1]), x + 3 * i);
        const uint32_t idx[4] = {0, 1, 2, 3};
        pf_frame fr = {plane_point(o, u, v, 0.5, 0.5), 0.75 * pf_v3_norm(u)};
        double e1[3], e2[3];
        for (int i = 0; i < 3; ++i)
            e1[i] = x[3 + i] - x[i], e2[i] = x[9 + i] - x[i];
        real want[COUNT] = {0};
        add_planar_moments(&fr, x, e1, e2, ref_square, DMAX, want);
        double area = pf_v3_dot(u, u);
        assert_true(fabsl(want[0] - area) <= 1e-14L);
        polygon_check("tilted square", x, idx, 4, &fr, want, area);
    }
    no_leaks();
}

static void test_polygon_triangles(void **state)
{
    (void)state;
    rng r = {99};
    for (int k = 0; k < 30; ++k) {
        double x[9];
        for (int i = 0; i < 9; ++i)
            x[i] = (k % 2 ? 1e4 : 0) + uniform(&r);
        const uint32_t idx[3] = {0, 1, 2};
        double area = pf_polygon_area(x, idx, 3);
        if (area < 0.05)
            continue;
        /* frame: the vertex bounding box, as for a polyhedron */
        pf_vec3 lo = pf_v3_min(pf_v3_load(x), pf_v3_min(pf_v3_load(x + 3), pf_v3_load(x + 6)));
        pf_vec3 hi = pf_v3_max(pf_v3_load(x), pf_v3_max(pf_v3_load(x + 3), pf_v3_load(x + 6)));
        pf_frame fr = {pf_v3_scale(pf_v3_add(lo, hi), 0.5), 0.5 * pf_v3_dist(lo, hi)};
        double e1[3], e2[3];
        for (int i = 0; i < 3; ++i)
            e1[i] = x[3 + i] - x[i], e2[i] = x[6 + i] - x[i];
        real want[COUNT] = {0};
        add_planar_moments(&fr, x, e1, e2, ref_triangle, DMAX, want);
        polygon_check("triangle", x, idx, 3, &fr, want, area);
    }
    no_leaks();
}

static void test_polygon_nonconvex(void **state)
{
    (void)state;
    /* the L of area 3 (in units of |u|^2) in a tilted plane, against its two rectangles
     * [0,2]x[0,1] and [0,1]x[1,2] */
    rng r = {55};
    for (int k = 0; k < 10; ++k) {
        pf_vec3 o, u, v;
        tilted_axes(k, &r, &o, &u, &v);
        static const double l[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
        double x[18];
        for (int i = 0; i < 6; ++i)
            pf_v3_store(plane_point(o, u, v, l[2 * i], l[2 * i + 1]), x + 3 * i);
        const uint32_t idx[6] = {0, 1, 2, 3, 4, 5};
        pf_frame fr = {plane_point(o, u, v, 1, 1), sqrt(2.0) * pf_v3_norm(u)};
        double o2[3], e1[3], e2[3], e3[3];
        pf_v3_store(plane_point(o, u, v, 0, 1), o2);
        pf_v3_store(pf_v3_scale(u, 2), e1);
        pf_v3_store(v, e2);
        pf_v3_store(u, e3);
        real want[COUNT] = {0};
        add_planar_moments(&fr, x, e1, e2, ref_square, DMAX, want);
        add_planar_moments(&fr, o2, e3, e2, ref_square, DMAX, want);
        double area = 3 * pf_v3_dot(u, u);
        assert_true(fabsl(want[0] - area) <= 1e-14L);
        polygon_check("L polygon", x, idx, 6, &fr, want, area);
        /* the same polygon started at its reflex corner */
        const uint32_t from_reflex[6] = {3, 4, 5, 0, 1, 2};
        double m[COUNT], m0[COUNT];
        pf_error err = {0};
        assert_int_equal(pf_polygon_moments(x, from_reflex, 6, &fr, DMAX, m, &err), PF_OK);
        assert_int_equal(pf_polygon_moments(x, idx, 6, &fr, DMAX, m0, &err), PF_OK);
        for (int i = 0; i < COUNT; ++i)
            assert_true(fabs(m[i] - m0[i]) <= 1e-14 * area);
    }
    /* collinear nodes: no area, all moments 0 */
    const double line[] = {0, 0, 0, 1, 1, 1, 3, 3, 3};
    const uint32_t tri[3] = {0, 1, 2};
    pf_frame unit = {pf_v3(0, 0, 0), 1};
    double m[COUNT];
    pf_error err = {0};
    assert_int_equal(pf_polygon_moments(line, tri, 3, &unit, DMAX, m, &err), PF_OK);
    for (int i = 0; i < COUNT; ++i)
        assert_true(m[i] == 0);
    no_leaks();
}

/* ---- invalid arguments ---------------------------------------------------------------------- */

static void test_invalid_arguments(void **state)
{
    (void)state;
    cell c;
    cell_box(&c, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
    pf_polyhedron p = cell_view(&c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    pf_error err = {0};
    assert_int_equal(pf_polyhedron_moments(&p, &fr, -1, m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "degree"));
    assert_int_equal(pf_polyhedron_moments(&p, &fr, DMAX + 1, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polyhedron_moments(NULL, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polyhedron_moments(&p, NULL, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polyhedron_moments(&p, &fr, 2, NULL, &err), PF_ERR_INVALID);
    pf_frame bad = fr;
    bad.scale = 0;
    assert_int_equal(pf_polyhedron_moments(&p, &bad, 2, m, &err), PF_ERR_INVALID);
    bad.scale = -1;
    assert_int_equal(pf_polyhedron_moments(&p, &bad, 2, m, &err), PF_ERR_INVALID);
    bad.scale = NAN;
    assert_int_equal(pf_polyhedron_moments(&p, &bad, 2, m, &err), PF_ERR_INVALID);
    bad = fr;
    bad.center.y = INFINITY;
    assert_int_equal(pf_polyhedron_moments(&p, &bad, 2, m, &err), PF_ERR_INVALID);
    pf_polyhedron empty = p;
    empty.n_faces = 0;
    assert_int_equal(pf_polyhedron_moments(&empty, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "no faces"));
    int64_t short_offsets[7];
    memcpy(short_offsets, c.offsets, sizeof short_offsets);
    short_offsets[3] = short_offsets[2] + 2; /* face 2 has 2 nodes, face 3 has 6 */
    pf_polyhedron degenerate = {c.x, 6, short_offsets, c.face_nodes};
    assert_int_equal(pf_polyhedron_moments(&degenerate, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "face 2 has 2 nodes"));
    c.x[5] = NAN;
    assert_int_equal(pf_polyhedron_moments(&p, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "non-finite"));
    /* polygons */
    const double tri[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t idx[3] = {0, 1, 2};
    assert_int_equal(pf_polygon_moments(tri, idx, 2, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polygon_moments(NULL, idx, 3, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polygon_moments(tri, NULL, 3, &fr, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polygon_moments(tri, idx, 3, &fr, 9, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polygon_moments(tri, idx, 3, NULL, 2, m, &err), PF_ERR_INVALID);
    assert_int_equal(pf_polygon_moments(tri, idx, 3, &fr, 0, m, &err), PF_OK);
    assert_true(fabs(m[0] - 0.5) <= DBL_EPSILON);
    /* a NULL error context is allowed */
    assert_int_equal(pf_polygon_moments(tri, idx, 3, &fr, -2, m, NULL), PF_ERR_INVALID);
    no_leaks();
}

int main(void)
{
    build_tables();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ordering),
        cmocka_unit_test(test_monomials),
        cmocka_unit_test(test_frame),
        cmocka_unit_test(test_unit_cube),
        cmocka_unit_test(test_box_offset),
        cmocka_unit_test(test_unit_simplex),
        cmocka_unit_test(test_tets_offset),
        cmocka_unit_test(test_L_prism),
        cmocka_unit_test(test_corner_cut_cube),
        cmocka_unit_test(test_nonconvex_face),
        cmocka_unit_test(test_coplanar_faces),
        cmocka_unit_test(test_rotation_translation),
        cmocka_unit_test(test_polygon_tilted_square),
        cmocka_unit_test(test_polygon_triangles),
        cmocka_unit_test(test_polygon_nonconvex),
        cmocka_unit_test(test_invalid_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
