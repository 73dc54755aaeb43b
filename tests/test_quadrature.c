/* quadrature: Gauss-Legendre rules and the rules over polyhedra for integrands that are not
 * polynomials (pf_polyhedron_quadrature), checked against the exact moments of the same cells
 * (the reference of test_integrate.c). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "integrate_cells.h"

/* ---- quadrature ------------------------------------------------------------------------------ */

/* Gauss-Legendre on [0, 1]: weights sum to 1 and int_0^1 t^k = 1 / (k + 1) for k <= 2n - 1. */
static void test_gauss_legendre(void **state)
{
    (void)state;
    for (int n = 1; n <= 16; ++n) {
        double t[16], w[16];
        pf_gauss_legendre(n, t, w);
        for (int k = 0; k <= 2 * n - 1; ++k) {
            double sum = 0;
            for (int i = 0; i < n; ++i)
                sum += w[i] * pow(t[i], k);
            if (!(fabs(sum - 1.0 / (k + 1)) <= 1e-15 * (n + 1)))
                fail_msg("%d points, t^%d: %.17g", n, k, sum);
        }
    }
}

/* Quadrature sum of every monomial of degree <= d against the exact moments, on convex and
 * non-convex cells (the reflex cut is exercised by the L, the dart pyramid and the corner-cut
 * cube): both are exact, so they agree to rounding, 1e-13 S_d. Weights are positive. The points
 * are returned in model coordinates, so a cell far from the origin carries their rounding: at
 * 1e4, an ulp is 2e-12, about 1e-12 of these cells' size, hence 1e-11 there. */
static void check_quadrature(const char *what, const cell *c, double tol)
{
    pf_polyhedron p = cell_view(c);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    double m[COUNT];
    double rho = moments_of(c, &fr, DMAX, m);
    for (int d = 0; d <= DMAX; ++d) {
        pf_quadrature q;
        pf_error err = {0};
        assert_int_equal(pf_polyhedron_quadrature(&p, c->n_nodes, d, &q, &err), PF_OK);
        double sum[COUNT] = {0};
        for (int64_t k = 0; k < q.n; ++k) {
            assert_true(q.w[k] > 0);
            pf_vec3 local =
                pf_v3_scale(pf_v3_sub(pf_v3_load(q.x + 3 * k), fr.center), 1 / fr.scale);
            double v[COUNT];
            pf_moment_monomials(local, d, v);
            for (int i = 0; i < count_of(d); ++i)
                sum[i] += q.w[k] * v[i];
        }
        for (int i = 0; i < count_of(d); ++i) {
            double scale = fabs(m[0]) * pow(rho, degree_of(i));
            if (!(fabs(sum[i] - m[i]) <= tol * scale))
                fail_msg("%s: degree-%d rule, monomial %d: %.17g, exact %.17g", what, d, i, sum[i],
                         m[i]);
        }
        pf_quadrature_release(&q);
    }
}

static void test_quadrature(void **state)
{
    (void)state;
    cell c;
    cell_box(&c, pf_v3(1, -2, 3), pf_v3(3, 0, 4));
    check_quadrature("box", &c, 1e-13);
    const pf_vec3 tet[4] = {pf_v3(0, 0, 0), pf_v3(1, 0.1, 0), pf_v3(0.2, 1, 0), pf_v3(0.3, 0.2, 1)};
    cell_tet(&c, tet);
    check_quadrature("tet", &c, 1e-13);
    cell_L_prism(&c, pf_v3(-1, 0.5, 2));
    check_quadrature("L prism", &c, 1e-13);
    cell_L_prism(&c, OFFSET);
    check_quadrature("L prism at 1e4", &c, 1e-11);
    cell_dart_pyramid(&c, pf_v3(-1, 2, 0.5));
    check_quadrature("dart pyramid", &c, 1e-13);
    cell_U_prism(&c, pf_v3(0.5, -1, 2));
    check_quadrature("U prism", &c, 1e-13);
    /* The L prism is integrated as one cone: its 20 triangles (2 x 4 of the L, 2 x 6 of the
     * sides), each a tetrahedron of n^3 points, n = (d + 4) / 2. */
    cell_L_prism(&c, pf_v3(-1, 0.5, 2));
    for (int d = 0; d <= 4; d += 2) {
        pf_quadrature lq;
        pf_error lerr = {0};
        pf_polyhedron lp = cell_view(&c);
        assert_int_equal(pf_polyhedron_quadrature(&lp, c.n_nodes, d, &lq, &lerr), PF_OK);
        int n = (d + 4) / 2;
        assert_int_equal(lq.n, 20 * n * n * n);
        pf_quadrature_release(&lq);
    }
    pf_quadrature q;
    pf_error err = {0};
    pf_polyhedron p = cell_view(&c);
    assert_int_equal(pf_polyhedron_quadrature(&p, c.n_nodes, 30, &q, &err), PF_ERR_INVALID);
    no_leaks();
}

int main(void)
{
    build_tables();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_gauss_legendre),
        cmocka_unit_test(test_quadrature),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
