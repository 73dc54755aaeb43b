/* split_nonconvex: pf_poly_split on non-convex cells and planes through their vertices, against the
 * oracles of test_split.c (volume conservation; the cap area as the derivative of the volume below
 * with respect to the plane offset): random non-convex cells, diagonal planes through vertices,
 * pieces of neighbours bit-identical on their shared edges, slivers, the tolerance, and invalid
 * inputs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "test_check.h"
#include "test_random.h"
#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/split.h>

#include "test_split_cells.h"

/* ---- non-convex cells, planes through vertices -------------------------------------------------- */

static int plane_contains_face(const shape *s, pf_plane pl, double tol)
{
    for (int32_t f = 0; f < s->nf; ++f) {
        int all = 1;
        for (int64_t k = s->off[f]; k < s->off[f + 1] && all; ++k)
            all = fabs(pf_plane_signed_distance(pl, pf_v3_load(s->x + 3 * s->fn[k]))) <= tol;
        if (all)
            return 1;
    }
    return 0;
}

/* Cap area against the derivative of the volume below with respect to the plane's offset. */
static void check_cap_derivative(const shape *s, pf_plane pl, double cap, const char *what)
{
    pf_polyhedron p = view(s);
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(&p, &lo, &hi);
    double len = pf_v3_dist(lo, hi), h = 1e-6 * len;
    pf_plane up = pl, down = pl;
    up.d += h;
    down.d -= h;
    outcome a = check_split(s, up, NULL, what), b = check_split(s, down, NULL, what);
    double deriv = (a.volume[0] - b.volume[0]) / (2 * h);
    CHECKF(fabs(deriv - cap) <= 1e-5 * len * len, "%s: cap %.12g, dV/dd %.12g", what, cap, deriv);
}

static void test_random_nonconvex(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    rng r = {777};
    char what[128];
    int n = 0, derivs = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        for (int rotated = 0; rotated < 2; ++rotated) {
            static shape s;
            s = cells[i].s;
            if (rotated)
                transform(&s, random_rotation(&r), pf_v3(uniform_in(&r, -3, 3), 0.5, -2));
            pf_polyhedron p = view(&s);
            pf_vec3 lo, hi;
            pf_polyhedron_bounds(&p, &lo, &hi);
            double tol = 1e-10 * pf_v3_dist(lo, hi);
            for (int trial = 0; trial < 150; ++trial) {
                int ok;
                uint32_t a = (uint32_t)rand_int(&r, s.nn), b = (uint32_t)rand_int(&r, s.nn),
                         c = (uint32_t)rand_int(&r, s.nn);
                if (a == b || b == c || a == c)
                    continue;
                pf_plane pl = plane_through(&s, a, b, c, &ok);
                if (!ok)
                    continue;
                snprintf(what, sizeof what, "%s%s vertices %u %u %u", cells[i].name,
                         rotated ? " rotated" : "", a, b, c);
                outcome o = check_split(&s, pl, NULL, what);
                ++n;
                if (trial % 5 == 0 && !plane_contains_face(&s, pl, tol)) {
                    check_cap_derivative(&s, pl, o.cap[0], what);
                    ++derivs;
                }
            }
        }
    }
    assert_true(n > 1200);
    assert_true(derivs > 100);
}

/* Grid-aligned cells, diagonal planes through grid vertices: x + y = c, x - y = c, x + y + z = c,
 * x + z = c ... with every integer c that meets the cell. */
static void test_diagonal_vertex_planes(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    static const int dirs[][3] = {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {0, 1, -1}, {1, 1, 1},
                                  {1, -1, 1}, {1, 1, -1}, {2, 1, 0}, {1, 2, 1}};
    char what[128];
    int n = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        if (!cells[i].has_vox)
            continue;
        for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; ++d)
            for (int c = -6; c <= 10; ++c) {
                pf_vec3 nrm = pf_v3(dirs[d][0], dirs[d][1], dirs[d][2]);
                pf_plane pl = {pf_v3_normalize(nrm), c / pf_v3_norm(nrm)};
                int below = 0, above = 0;
                for (int32_t k = 0; k < cells[i].s.nn; ++k) {
                    double v = pf_plane_signed_distance(pl, pf_v3_load(cells[i].s.x + 3 * k));
                    below |= v < -1e-9;
                    above |= v > 1e-9;
                }
                if (!below || !above)
                    continue;
                snprintf(what, sizeof what, "%s plane %d %d %d = %d", cells[i].name, dirs[d][0],
                         dirs[d][1], dirs[d][2], c);
                outcome o = check_split(&cells[i].s, pl, NULL, what);
                if (!plane_contains_face(&cells[i].s, pl, 1e-9))
                    check_cap_derivative(&cells[i].s, pl, o.cap[0], what);
                ++n;
            }
    }
    assert_true(n > 60);
}

/* Two hexes sharing a (non-planar-free, randomly perturbed) face, numbered differently: every
 * new node on the shared face's edges is bit-identical in both splits. */
static void test_shared_edges_bit_identical(void **state)
{
    (void)state;
    rng r = {4242};
    int total_shared = 0;
    for (int trial = 0; trial < 200; ++trial) {
        double g[3][2][2][3]; /* grid points (i, j, k), i in 0..2 */
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) {
                    g[i][j][k][0] = i + (i == 1 ? 0 : uniform_in(&r, -0.1, 0.1)) + 1000.0;
                    g[i][j][k][1] = j + uniform_in(&r, -0.1, 0.1) - 77.0;
                    g[i][j][k][2] = k + uniform_in(&r, -0.1, 0.1);
                }
        /* the shared face i = 1 stays planar: x = 1001 */
        shape cell[2];
        for (int h = 0; h < 2; ++h) {
            shape *s = &cell[h];
            shape_init(s);
            uint32_t id[2][2][2];
            for (int q = 0; q < 8; ++q) {
                int qq = h ? 7 - q : q; /* reverse node numbering in the second cell */
                int i = qq & 1, j = (qq >> 1) & 1, k = qq >> 2;
                id[i][j][k] = add_node(s, g[h + i][j][k][0], g[h + i][j][k][1], g[h + i][j][k][2]);
            }
            pf_vec3 c = pf_v3(h + 1000.5, -76.5, 0.5);
            uint32_t faces[6][4] = {
                {id[0][0][0], id[0][1][0], id[0][1][1], id[0][0][1]},
                {id[1][0][0], id[1][1][0], id[1][1][1], id[1][0][1]},
                {id[0][0][0], id[1][0][0], id[1][0][1], id[0][0][1]},
                {id[0][1][0], id[1][1][0], id[1][1][1], id[0][1][1]},
                {id[0][0][0], id[1][0][0], id[1][1][0], id[0][1][0]},
                {id[0][0][1], id[1][0][1], id[1][1][1], id[0][1][1]},
            };
            for (int f = 0; f < 6; ++f) {
                /* non-planar perturbed side faces would fail validation: split them in two
                 * triangles */
                uint32_t t1[3] = {faces[f][0], faces[f][1], faces[f][2]};
                uint32_t t2[3] = {faces[f][0], faces[f][2], faces[f][3]};
                pf_vec3 m = pf_v3(0, 0, 0);
                for (int v = 0; v < 4; ++v)
                    m = pf_v3_add(m, pf_v3_load(s->x + 3 * faces[f][v]));
                pf_vec3 outw = pf_v3_sub(pf_v3_scale(m, 0.25), c);
                add_face(s, t1, 3, outw);
                add_face(s, t2, 3, outw);
            }
        }
        pf_plane pl = pf_plane_from_point_normal(
            pf_v3(1000.8 + uniform_in(&r, 0, 0.4), -76.5 + uniform_in(&r, -0.3, 0.3), 0.5),
            random_unit(&r));
        pf_split s[2];
        pf_error err = {0};
        for (int h = 0; h < 2; ++h) {
            pf_polyhedron p = view(&cell[h]);
            assert_int_equal(pf_poly_split(&p, cell[h].nn, &pl, NULL, &s[h], &err), PF_OK);
        }
        int shared = 0;
        for (int32_t a = s[0].n_input_nodes; a < s[0].n_nodes; ++a) {
            int32_t ia = a - s[0].n_input_nodes;
            const double *e0 = s[0].x + 3 * s[0].new_edge[2 * ia];
            const double *e1 = s[0].x + 3 * s[0].new_edge[2 * ia + 1];
            for (int32_t b = s[1].n_input_nodes; b < s[1].n_nodes; ++b) {
                int32_t ib = b - s[1].n_input_nodes;
                const double *f0 = s[1].x + 3 * s[1].new_edge[2 * ib];
                const double *f1 = s[1].x + 3 * s[1].new_edge[2 * ib + 1];
                if (memcmp(e0, f0, 3 * sizeof(double)) || memcmp(e1, f1, 3 * sizeof(double)))
                    continue;
                /* the same edge, its ends in the same (lexicographic) order in both cells */
                assert_memory_equal(s[0].x + 3 * a, s[1].x + 3 * b, 3 * sizeof(double));
                assert_true(s[0].new_t[ia] == s[1].new_t[ib]);
                ++shared;
            }
        }
        total_shared += shared;
        pf_split_release(&s[0]);
        pf_split_release(&s[1]);
        for (int h = 0; h < 2; ++h)
            check_split(&cell[h], pl, NULL, "shared-edge hex");
    }
    assert_true(total_shared > 100);
}

/* Planes at tiny distances: slivers cut off a corner or along a face, both above tol. */
static void test_slivers(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    char what[128];
    for (int e = 3; e <= 8; ++e) {
        double eps = pow(10.0, -e);
        /* corner tet of the box at the origin: volume eps^3 / 6 */
        pf_plane pl = pf_plane_from_point_normal(pf_v3(eps, 0, 0), pf_v3(1, 1, 1));
        snprintf(what, sizeof what, "corner sliver %g", eps);
        outcome o = check_split(&cells[0].s, pl, NULL, what);
        assert_int_equal(o.pieces[0], 1);
        assert_near(o.volume[0], eps * eps * eps / 6, 1e-9 * eps * eps * eps);
        /* thin slab along the bottom face of the L: volume 3 eps */
        pl = pf_plane_from_point_normal(pf_v3(0, 0, eps), pf_v3(0, 0, 1));
        snprintf(what, sizeof what, "slab sliver %g", eps);
        o = check_split(&cells[1].s, pl, NULL, what);
        assert_near(o.volume[0], 3 * eps, 1e-12);
        assert_near(o.cap[0], 3, 1e-12);
        /* nearly parallel to the frame's top: a wedge */
        pf_vec3 nrm = pf_v3_normalize(pf_v3(eps, 0, 1));
        pl = pf_plane_from_point_normal(pf_v3(1.5, 1.5, 2 - 2 * eps), nrm);
        snprintf(what, sizeof what, "frame wedge %g", eps);
        o = check_split(&cells[3].s, pl, NULL, what);
        assert_near(o.cap[1], 8 / nrm.z, 1e-9);
    }
}

/* The tolerance override decides what is on the plane. */
static void test_tolerance(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0, 0, 0.01), pf_v3(0, 0, 1));
    pf_split_params prm = pf_split_params_default();
    outcome o = check_split(&cells[0].s, pl, &prm, "default tol");
    assert_int_equal(o.pieces[0], 1);
    assert_near(o.volume[0], 6 * 0.01, 1e-12);
    prm.tol = 0.02; /* the bottom nodes are now on the plane: nothing below */
    o = check_split(&cells[0].s, pl, &prm, "coarse tol");
    assert_int_equal(o.pieces[0], 0);
    assert_int_equal(o.pieces[1], 1);
    prm.tol = 0;
    prm.rel_tol = 0.01 / sqrt(9 + 4 + 4) * 1.5; /* relative to the diagonal sqrt(17) */
    o = check_split(&cells[0].s, pl, &prm, "coarse rel tol");
    assert_int_equal(o.pieces[0], 0);
}

static void test_invalid_inputs(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    pf_split s;
    pf_error err = {0};
    pf_plane pl = pf_plane_from_point_normal(pf_v3(1, 1, 1), pf_v3(0, 0, 1));
    shape open = cells[1].s;
    open.nf--; /* drop the last side face */
    pf_polyhedron p = view(&open);
    assert_int_equal(pf_poly_split(&p, open.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "not closed"));
    assert_null(s.x);
    p = view(&cells[1].s);
    pf_plane bad = {pf_v3(NAN, 0, 1), 0};
    assert_int_equal(pf_poly_split(&p, cells[1].s.nn, &bad, NULL, &s, &err), PF_ERR_INVALID);
    bad = (pf_plane){pf_v3(0, 0, 0), 0};
    assert_int_equal(pf_poly_split(&p, cells[1].s.nn, &bad, NULL, &s, &err), PF_ERR_INVALID);
    assert_int_equal(pf_poly_split(&p, 3, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "references node"));
    shape flat = cells[1].s; /* squash the L into z = 0 */
    for (int32_t i = 0; i < flat.nn; ++i)
        flat.x[3 * i + 2] = 0;
    p = view(&flat);
    pl = pf_plane_from_point_normal(pf_v3(0, 0, 0), pf_v3(0, 0, 1));
    assert_int_equal(pf_poly_split(&p, flat.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    shape nan = cells[1].s;
    nan.x[4] = NAN;
    p = view(&nan);
    assert_int_equal(pf_poly_split(&p, nan.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "non-finite"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_random_nonconvex, setup, teardown),
        cmocka_unit_test_setup_teardown(test_diagonal_vertex_planes, setup, teardown),
        cmocka_unit_test_setup_teardown(test_shared_edges_bit_identical, setup, teardown),
        cmocka_unit_test_setup_teardown(test_slivers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_tolerance, setup, teardown),
        cmocka_unit_test_setup_teardown(test_invalid_inputs, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
