/* geom: SVD, polar rotation, symmetric eigen, inverse, planes, polygons, polyhedron volume.
 *
 * Tolerances are in units of the double epsilon u = 2.2e-16 relative to the natural scale of the
 * quantity (|A| for matrix identities, the largest eigenvalue for spectra, the model size for
 * geometry). A 3x3 product accumulates at most a few u per entry, so "1e-14" means "about 45 u":
 * room for the rotations of a Jacobi sweep, far below any real defect. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>

#include "test_random.h"
#include <pf/geom.h>
#include <pf/mesh.h>

#define PI 3.14159265358979323846

/* ---- deterministic random numbers and matrix helpers ---------------------------------------- */

static pf_mat3 random_matrix(rng *r)
{
    pf_mat3 a;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            a.m[i][j] = uniform(r);
    return a;
}

static pf_mat3 diag(double a, double b, double c)
{
    return (pf_mat3){{{a, 0, 0}, {0, b, 0}, {0, 0, c}}};
}

/* Q diag(d) W^T */
static pf_mat3 compose(pf_mat3 q, pf_mat3 d, pf_mat3 w)
{
    return pf_m3_mul(pf_m3_mul(q, d), pf_m3_transpose(w));
}

static double max_diff(pf_mat3 a, pf_mat3 b)
{
    double m = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            m = fmax(m, fabs(a.m[i][j] - b.m[i][j]));
    return m;
}

static double orthogonality_error(pf_mat3 q)
{
    return max_diff(pf_m3_mul(pf_m3_transpose(q), q), pf_m3_identity());
}

static double asymmetry(pf_mat3 s)
{
    return max_diff(s, pf_m3_transpose(s));
}

static void no_leaks(void)
{
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

#define assert_close(a, b, tol)                                                                    \
    do {                                                                                           \
        double a_ = (a), b_ = (b), t_ = (tol);                                                     \
        if (!(fabs(a_ - b_) <= t_))                                                                \
            fail_msg("%s = %.17g, expected %.17g (tol %.3g)", #a, a_, b_, t_);                     \
    } while (0)

/* ---- SVD ------------------------------------------------------------------------------------- */

/* Every SVD must reproduce A and have orthogonal factors and sorted non-negative sigma. */
static void check_svd(pf_mat3 a, pf_mat3 *u, double sigma[3], pf_mat3 *v)
{
    pf_mat3_svd(a, u, sigma, v);
    double scale = pf_m3_norm(a);
    /* reconstruction: products of three factors, a few u of |A| each */
    pf_mat3 back = compose(*u, diag(sigma[0], sigma[1], sigma[2]), *v);
    assert_true(max_diff(back, a) <= 1e-13 * scale);
    assert_true(orthogonality_error(*u) <= 1e-14);
    assert_true(orthogonality_error(*v) <= 1e-14);
    assert_true(sigma[0] >= sigma[1] && sigma[1] >= sigma[2] && sigma[2] >= 0);
}

static void test_svd_random(void **state)
{
    (void)state;
    rng r = {0x9e3779b97f4a7c15u};
    pf_mat3 u, v;
    double s[3];
    for (int k = 0; k < 2000; ++k) {
        pf_mat3 a = random_matrix(&r);
        check_svd(a, &u, s, &v);
        /* invariants independent of the factors: sum sigma^2 = |A|_F^2, prod sigma = |det A|;
         * both computed to a few u of |A|^2 and |A|^3 (|A|_F <= 3 here) */
        double f = pf_m3_norm(a);
        assert_close(s[0] * s[0] + s[1] * s[1] + s[2] * s[2], f * f, 1e-14 * f * f);
        assert_close(s[0] * s[1] * s[2], fabs(pf_m3_det(a)), 1e-14 * f * f * f);
    }
    no_leaks();
}

static void test_svd_known_spectra(void **state)
{
    (void)state;
    rng r = {12345};
    pf_mat3 u, v;
    double s[3];
    for (int k = 0; k < 200; ++k) {
        pf_mat3 q = random_rotation(&r), w = random_rotation(&r);
        /* rank 2, near-singular and badly scaled spectra: the rounding of Q D W^T perturbs each
         * singular value by a few u of sigma_1 = 5 (Weyl), so 1e-14 * 5 absolute */
        const double spectra[][3] = {{5, 2, 0}, {5, 1e-8, 1e-15}, {5, 5, 1}, {5, 1, 1}};
        for (int t = 0; t < 4; ++t) {
            pf_mat3 a = compose(q, diag(spectra[t][0], spectra[t][1], spectra[t][2]), w);
            check_svd(a, &u, s, &v);
            for (int i = 0; i < 3; ++i)
                assert_close(s[i], spectra[t][i], 5e-14);
        }
        /* rank 1: A = x y^T, sigma = (|x| |y|, 0, 0) */
        pf_vec3 x = pf_v3(uniform(&r), uniform(&r), uniform(&r));
        pf_vec3 y = pf_v3(uniform(&r), uniform(&r), uniform(&r));
        pf_mat3 a;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                a.m[i][j] = pf_v3_get(x, i) * pf_v3_get(y, j);
        check_svd(a, &u, s, &v);
        double n = pf_v3_norm(x) * pf_v3_norm(y);
        assert_close(s[0], n, 1e-14 * n);
        assert_true(s[1] <= 1e-15 * n && s[2] <= 1e-15 * n);
    }
    no_leaks();
}

static void test_svd_special(void **state)
{
    (void)state;
    pf_mat3 u, v;
    double s[3];
    check_svd(diag(0, 0, 0), &u, s, &v);
    assert_true(s[0] == 0 && s[1] == 0 && s[2] == 0);
    assert_true(max_diff(u, pf_m3_identity()) == 0 && max_diff(v, pf_m3_identity()) == 0);
    /* diagonal with repeated magnitudes and a sign: sigma exactly (2, 2, 2) */
    check_svd(diag(2, -2, 2), &u, s, &v);
    assert_true(s[0] == 2 && s[1] == 2 && s[2] == 2);
    check_svd(diag(1, 3, 2), &u, s, &v);
    assert_true(s[0] == 3 && s[1] == 2 && s[2] == 1);
    /* scaling A scales sigma: the 1e-12 and 1e12 products round each entry by u */
    rng r = {777};
    const double scales[] = {1e-12, 1e12, 1e-150, 1e150};
    for (int k = 0; k < 50; ++k) {
        pf_mat3 a = random_matrix(&r);
        double s1[3];
        check_svd(a, &u, s1, &v);
        for (int t = 0; t < 4; ++t) {
            check_svd(pf_m3_scale(a, scales[t]), &u, s, &v);
            for (int i = 0; i < 3; ++i)
                assert_close(s[i] / scales[t], s1[i], 1e-14 * s1[0]);
        }
    }
    pf_mat3 bad = diag(1, 1, 1);
    bad.m[1][2] = NAN;
    pf_mat3_svd(bad, &u, s, &v);
    assert_true(isnan(s[0]) && isnan(s[1]) && isnan(s[2]));
    assert_true(max_diff(u, pf_m3_identity()) == 0 && max_diff(v, pf_m3_identity()) == 0);
    no_leaks();
}

/* ---- polar rotation -------------------------------------------------------------------------- */

/* Higham's Newton iteration X <- (X + X^-T) / 2 converges quadratically to the orthogonal polar
 * factor of a nonsingular A; run until the update stops shrinking. */
static pf_mat3 newton_polar(pf_mat3 a)
{
    pf_mat3 x = a;
    double last = INFINITY;
    for (int k = 0; k < 100; ++k) {
        pf_mat3 inv = pf_m3_inverse(x, NULL);
        pf_mat3 next = pf_m3_scale(pf_m3_add(x, pf_m3_transpose(inv)), 0.5);
        double step = max_diff(next, x);
        x = next;
        if (step == 0 || (step < 1e-10 && step >= last))
            break;
        last = step;
    }
    return x;
}

/* A proper rotation whose S = R^T A is symmetric: the defining properties of the polar factor. */
static pf_mat3 check_polar(pf_mat3 a)
{
    pf_mat3 rot = pf_mat3_polar_rotation(a);
    assert_true(orthogonality_error(rot) <= 1e-14);
    assert_close(pf_m3_det(rot), 1.0, 1e-14);
    assert_true(asymmetry(pf_m3_mul(pf_m3_transpose(rot), a)) <= 1e-14 * pf_m3_norm(a));
    return rot;
}

static void test_polar_matches_newton(void **state)
{
    (void)state;
    rng r = {2024};
    int compared = 0;
    while (compared < 500) {
        pf_mat3 a = random_matrix(&r);
        double det;
        pf_mat3 inv = pf_m3_inverse(a, &det);
        /* condition |A| |A^-1| < 50: the polar factor's sensitivity is about the condition
         * number, so 50 * few u < 1e-13 */
        if (det <= 0 || pf_m3_norm(a) * pf_m3_norm(inv) > 50)
            continue;
        pf_mat3 rot = check_polar(a);
        assert_true(max_diff(rot, newton_polar(a)) <= 1e-13);
        ++compared;
    }
    no_leaks();
}

static void test_polar_recovers_rotation(void **state)
{
    (void)state;
    rng r = {99};
    /* the 24 proper signed permutations are exactly orthogonal and come back exactly */
    for (int p = 0; p < 6; ++p)
        for (int sgn = 0; sgn < 8; ++sgn) {
            static const int PERM[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                           {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
            pf_mat3 q = diag(0, 0, 0);
            for (int j = 0; j < 3; ++j)
                q.m[PERM[p][j]][j] = sgn & (1 << j) ? -1 : 1;
            if (pf_m3_det(q) > 0)
                assert_true(max_diff(pf_mat3_polar_rotation(q), q) == 0);
        }
    for (int k = 0; k < 500; ++k) {
        pf_mat3 q = random_rotation(&r);
        /* a pure rotation is its own polar factor: 1e-15 (4.5 u) for the quaternion matrices
         * that are orthogonal to 2 u (most are); a rounder input would have a nearest rotation
         * farther away than the tolerance itself */
        if (orthogonality_error(q) <= 2 * DBL_EPSILON)
            assert_true(max_diff(pf_mat3_polar_rotation(q), q) <= 1e-15);
        /* rotation times SPD stretch with eigenvalues in [0.2, 3]: condition <= 15 */
        pf_mat3 w = random_rotation(&r);
        pf_mat3 s = compose(w, diag(0.2, 1.0 + uniform(&r), 3.0), w);
        pf_mat3 rot = check_polar(pf_m3_mul(q, s));
        assert_true(max_diff(rot, q) <= 1e-14);
    }
    no_leaks();
}

static void test_polar_degenerate(void **state)
{
    (void)state;
    rng r = {31337};
    for (int k = 0; k < 300; ++k) {
        pf_mat3 q = random_rotation(&r), w = random_rotation(&r);
        /* rank 2 (flattened along w3): R = Q exactly, the null direction by the cross product */
        pf_mat3 flat = pf_m3_mul(q, compose(w, diag(2, 0.5 + uniform(&r) * 0.25, 0), w));
        assert_true(max_diff(check_polar(flat), q) <= 1e-14);
        /* a column of a well-conditioned A scaled by 1e-14: within |dA| 2 / (sigma_2 + sigma_3)
         * of the rank-2 answer (perturbation bound of the polar factor) */
        pf_mat3 a = pf_m3_mul(q, compose(w, diag(0.5, 1, 2), w)), thin = a, zero = a;
        for (int i = 0; i < 3; ++i) {
            thin.m[i][2] *= 1e-14;
            zero.m[i][2] = 0;
        }
        pf_mat3 rt = check_polar(thin), rz = check_polar(zero);
        assert_true(max_diff(rt, rz) <= 1e-13);
        /* S = R^T A of the near-singular A is positive semi-definite up to rounding */
        double ev[3];
        pf_mat3 vecs;
        pf_mat3 st = pf_m3_mul(pf_m3_transpose(rt), thin);
        pf_mat3_sym_eigen(pf_m3_scale(pf_m3_add(st, pf_m3_transpose(st)), 0.5), ev, &vecs);
        assert_true(ev[0] >= -1e-14 * pf_m3_norm(thin));
        /* rank 1, A = Q (v v^T) * 3: R maps v onto Q v */
        pf_vec3 dir = pf_v3(w.m[0][0], w.m[1][0], w.m[2][0]);
        pf_mat3 one = pf_m3_mul(q, compose(w, diag(3, 0, 0), w));
        pf_mat3 r1 = check_polar(one);
        assert_true(pf_v3_dist(pf_m3_mulv(r1, dir), pf_m3_mulv(q, dir)) <= 1e-14);
    }
    assert_true(max_diff(pf_mat3_polar_rotation(diag(0, 0, 0)), pf_m3_identity()) == 0);
    pf_mat3 bad = random_matrix(&r);
    bad.m[2][1] = NAN;
    assert_true(max_diff(pf_mat3_polar_rotation(bad), pf_m3_identity()) == 0);
    bad.m[2][1] = INFINITY;
    assert_true(max_diff(pf_mat3_polar_rotation(bad), pf_m3_identity()) == 0);
    no_leaks();
}

static void test_polar_reflection(void **state)
{
    (void)state;
    rng r = {4242};
    /* A = Q diag(1, 2, -3): singular values 3, 2, 1; the nearest proper rotation flips the
     * direction of sigma = 1, R = Q diag(-1, 1, -1), S = diag(-1, 2, 3) */
    for (int k = 0; k < 100; ++k) {
        pf_mat3 q = random_rotation(&r);
        pf_mat3 rot = check_polar(pf_m3_mul(q, diag(1, 2, -3)));
        assert_true(max_diff(rot, pf_m3_mul(q, diag(-1, 1, -1))) <= 1e-14);
    }
    int checked = 0;
    while (checked < 500) {
        pf_mat3 a = random_matrix(&r);
        if (pf_m3_det(a) >= 0)
            continue;
        pf_mat3 rot = check_polar(a);
        /* S has exactly one negative eigenvalue, the smallest in magnitude (-sigma_3) */
        pf_mat3 s = pf_m3_mul(pf_m3_transpose(rot), a), vecs;
        double ev[3], sv[3];
        pf_mat3_sym_eigen(pf_m3_scale(pf_m3_add(s, pf_m3_transpose(s)), 0.5), ev, &vecs);
        assert_true(ev[0] < 0 && ev[1] >= 0);
        assert_true(fabs(ev[0]) <= ev[1]);
        /* closed form from the SVD: R = U diag(1, 1, -1) V^T */
        pf_mat3 u, v;
        pf_mat3_svd(a, &u, sv, &v);
        assert_close(ev[0], -sv[2], 1e-14 * sv[0]);
        assert_true(max_diff(rot, compose(u, diag(1, 1, -1), v)) <= 1e-14);
        ++checked;
    }
    no_leaks();
}

/* ---- symmetric eigen ------------------------------------------------------------------------- */

static void check_eigen(pf_mat3 s, double values[3], pf_mat3 *vecs)
{
    pf_mat3_sym_eigen(s, values, vecs);
    double scale = pf_m3_norm(s);
    assert_true(values[0] <= values[1] && values[1] <= values[2]);
    assert_true(orthogonality_error(*vecs) <= 1e-14);
    assert_close(pf_m3_det(*vecs), 1.0, 1e-14);
    /* V diag V^T = S to 1e-14 of |S| */
    assert_true(max_diff(compose(*vecs, diag(values[0], values[1], values[2]), *vecs), s) <=
                1e-14 * scale);
}

static void test_eigen_diagonal_and_repeated(void **state)
{
    (void)state;
    double ev[3];
    pf_mat3 v;
    check_eigen(diag(3, -1, 2), ev, &v);
    assert_true(ev[0] == -1 && ev[1] == 2 && ev[2] == 3);
    /* diagonal input needs no rotation: eigenvectors are exactly signed unit axes */
    assert_true(fabs(v.m[1][0]) == 1 && fabs(v.m[2][1]) == 1 && fabs(v.m[0][2]) == 1);
    check_eigen(diag(0, 0, 0), ev, &v);
    assert_true(ev[0] == 0 && ev[2] == 0);
    rng r = {5};
    for (int k = 0; k < 200; ++k) {
        pf_mat3 w = random_rotation(&r);
        check_eigen(compose(w, diag(2, 2, 5), w), ev, &v);
        assert_close(ev[0], 2, 1e-14 * 5);
        assert_close(ev[1], 2, 1e-14 * 5);
        assert_close(ev[2], 5, 1e-14 * 5);
        check_eigen(compose(w, diag(-7, -7, -7), w), ev, &v);
        assert_close(ev[0], -7, 1e-14 * 7);
        assert_close(ev[2], -7, 1e-14 * 7);
    }
    pf_mat3 bad = diag(1, 2, 3);
    bad.m[0][1] = NAN;
    pf_mat3_sym_eigen(bad, ev, &v);
    assert_true(isnan(ev[0]) && max_diff(v, pf_m3_identity()) == 0);
    no_leaks();
}

static void test_eigen_random_symmetric(void **state)
{
    (void)state;
    rng r = {0xdeadbeef};
    double ev[3];
    pf_mat3 v;
    for (int k = 0; k < 2000; ++k) {
        pf_mat3 a = random_matrix(&r);
        pf_mat3 s = pf_m3_scale(pf_m3_add(a, pf_m3_transpose(a)), 0.5);
        check_eigen(s, ev, &v);
        double f = pf_m3_norm(s);
        /* trace and Frobenius norm are spectral invariants */
        assert_close(ev[0] + ev[1] + ev[2], s.m[0][0] + s.m[1][1] + s.m[2][2], 1e-14 * f);
        assert_close(ev[0] * ev[0] + ev[1] * ev[1] + ev[2] * ev[2], f * f, 1e-14 * f * f);
    }
    /* only the upper triangle is read */
    pf_mat3 s = {{{1, 2, 3}, {-100, 4, 5}, {-100, -100, 6}}};
    pf_mat3 full = {{{1, 2, 3}, {2, 4, 5}, {3, 5, 6}}};
    double ev2[3];
    pf_mat3 v2;
    pf_mat3_sym_eigen(s, ev, &v);
    pf_mat3_sym_eigen(full, ev2, &v2);
    assert_true(ev[0] == ev2[0] && ev[1] == ev2[1] && ev[2] == ev2[2]);
    no_leaks();
}

static void test_eigen_stress_tensor(void **state)
{
    (void)state;
    rng r = {8};
    /* principal stresses in Pa, tension and compression, one near-repeated pair */
    const double principal[][3] = {{-50e6, 10e6, 120e6}, {-3e5, 1e-3, 2e5}, {1, 1 + 1e-10, 2}};
    double ev[3];
    pf_mat3 v;
    for (int k = 0; k < 200; ++k)
        for (int t = 0; t < 3; ++t) {
            pf_mat3 w = random_rotation(&r);
            const double *p = principal[t];
            double big = fmax(fabs(p[0]), fabs(p[2]));
            check_eigen(compose(w, diag(p[0], p[1], p[2]), w), ev, &v);
            for (int i = 0; i < 3; ++i)
                assert_close(ev[i], p[i], 1e-14 * big);
            /* a well-separated principal direction is recovered up to sign */
            double c = fabs(v.m[0][2] * w.m[0][2] + v.m[1][2] * w.m[1][2] + v.m[2][2] * w.m[2][2]);
            assert_close(c, 1.0, 1e-14);
        }
    no_leaks();
}

/* ---- inverse and planes ---------------------------------------------------------------------- */

static void test_inverse(void **state)
{
    (void)state;
    pf_mat3 a = {{{2, 1, 0}, {1, 3, 1}, {0, 1, 4}}};
    double det = 0;
    pf_mat3 inv = pf_m3_inverse(a, &det);
    assert_true(det == 18); /* integer arithmetic, exact */
    /* adjugate / 18 by hand, each entry rounded once */
    pf_mat3 want = {{{11, -4, 1}, {-4, 8, -2}, {1, -2, 5}}};
    assert_true(max_diff(inv, pf_m3_scale(want, 1.0 / 18)) <= 2 * DBL_EPSILON);
    rng r = {3};
    for (int k = 0; k < 200; ++k) {
        pf_mat3 b = pf_m3_add(pf_m3_scale(pf_m3_identity(), 2), random_matrix(&r));
        pf_mat3 bi = pf_m3_inverse(b, NULL);
        double cond = pf_m3_norm(b) * pf_m3_norm(bi);
        assert_true(max_diff(pf_m3_mul(b, bi), pf_m3_identity()) <= 1e-15 * cond);
    }
    pf_mat3 singular = {{{1, 2, 3}, {2, 4, 6}, {0, 1, 1}}};
    inv = pf_m3_inverse(singular, &det);
    assert_true(det == 0 && max_diff(inv, diag(0, 0, 0)) == 0);
    no_leaks();
}

static void test_plane(void **state)
{
    (void)state;
    pf_plane pl = pf_plane_from_point_normal(pf_v3(1, 2, 3), pf_v3(0, 0, 2));
    assert_true(pl.n.x == 0 && pl.n.y == 0 && pl.n.z == 1 && pl.d == 3);
    assert_true(pf_plane_signed_distance(pl, pf_v3(5, 5, 4)) == 1);
    assert_int_equal(pf_plane_classify(pl, pf_v3(5, 5, 4), 1e-9), 1);
    assert_int_equal(pf_plane_classify(pl, pf_v3(-5, 7, 2), 1e-9), -1);
    assert_int_equal(pf_plane_classify(pl, pf_v3(0, 0, 3 + 1e-12), 1e-9), 0);
    assert_int_equal(pf_plane_classify(pl, pf_v3(0, 0, 3 - 1e-12), 1e-9), 0);
    assert_int_equal(pf_plane_classify(pl, pf_v3(0, 0, 3 + 1e-12), 0), 1);
    /* tilted: normal (1, 1, 1) / sqrt 3 through the origin; (1, 1, 1) lies at sqrt 3 */
    pl = pf_plane_from_point_normal(pf_v3(0, 0, 0), pf_v3(1e-300, 1e-300, 1e-300));
    assert_close(pf_v3_norm(pl.n), 1, 2 * DBL_EPSILON);
    assert_close(pf_plane_signed_distance(pl, pf_v3(1, 1, 1)), sqrt(3.0), 4 * DBL_EPSILON);
    pl = pf_plane_from_point_normal(pf_v3(1, 1, 1), pf_v3(0, 0, 0));
    assert_true(pl.d == 0 && pf_plane_classify(pl, pf_v3(9, 9, 9), 0) == 0);
    no_leaks();
}

/* ---- polygons -------------------------------------------------------------------------------- */

static void test_polygon_square_and_L(void **state)
{
    (void)state;
    const double sq[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const uint32_t ccw[] = {0, 1, 2, 3}, cw[] = {3, 2, 1, 0};
    pf_vec3 n = pf_polygon_area_vector(sq, ccw, 4);
    assert_true(n.x == 0 && n.y == 0 && n.z == 1);
    assert_true(pf_polygon_area(sq, ccw, 4) == 1);
    assert_true(pf_polygon_area_vector(sq, cw, 4).z == -1);
    pf_vec3 c = pf_polygon_centroid(sq, cw, 4);
    assert_true(pf_v3_dist(c, pf_v3(0.5, 0.5, 0)) <= 2 * DBL_EPSILON); /* thirds round */
    assert_true(pf_polygon_planarity_error(sq, ccw, 4) == 0);
    assert_close(pf_polygon_diameter(sq, ccw, 4), sqrt(2.0), DBL_EPSILON);
    /* L: [0,2]x[0,1] (area 2, centroid (1, 1/2)) and [0,1]x[1,2] (area 1, centroid (1/2, 3/2)):
     * area 3, centroid (5/6, 5/6). Starting at (0,2) the fan triangle (0,2),(2,1),(1,1) has
     * negative area, so the signed fan is exercised. */
    const double l[] = {0, 0, 0, 2, 0, 0, 2, 1, 0, 1, 1, 0, 1, 2, 0, 0, 2, 0};
    const uint32_t from_origin[] = {0, 1, 2, 3, 4, 5}, from_top[] = {5, 0, 1, 2, 3, 4};
    const uint32_t *orders[] = {from_origin, from_top};
    rng r = {17};
    for (int o = 0; o < 2; ++o) {
        assert_close(pf_polygon_area(l, orders[o], 6), 3, 4 * DBL_EPSILON);
        c = pf_polygon_centroid(l, orders[o], 6);
        assert_close(c.x, 5.0 / 6, 4 * DBL_EPSILON);
        assert_close(c.y, 5.0 / 6, 4 * DBL_EPSILON);
        assert_true(c.z == 0);
        /* the same L rotated and moved: area invariant, centroid moves with it (1 + |t| = 4) */
        pf_mat3 q = random_rotation(&r);
        pf_vec3 t = pf_v3(1.5, -2, 3);
        double moved[18];
        for (int i = 0; i < 6; ++i)
            pf_v3_store(pf_v3_add(pf_m3_mulv(q, pf_v3_load(l + 3 * i)), t), moved + 3 * i);
        assert_close(pf_polygon_area(moved, orders[o], 6), 3, 1e-14 * 3);
        pf_vec3 want = pf_v3_add(pf_m3_mulv(q, pf_v3(5.0 / 6, 5.0 / 6, 0)), t);
        assert_true(pf_v3_dist(pf_polygon_centroid(moved, orders[o], 6), want) <= 1e-14 * 4);
        assert_true(pf_polygon_planarity_error(moved, orders[o], 6) <= 1e-14 * 4);
        pf_vec3 normal = pf_v3_normalize(pf_polygon_area_vector(moved, orders[o], 6));
        assert_true(pf_v3_dist(normal, pf_v3(q.m[0][2], q.m[1][2], q.m[2][2])) <= 1e-14);
    }
    no_leaks();
}

static void test_polygon_regular(void **state)
{
    (void)state;
    rng r = {271828};
    for (int n = 3; n <= 40; ++n) {
        pf_mat3 q = random_rotation(&r);
        pf_vec3 center = pf_v3(3, -1, 2);
        double radius = 2.5, x[3 * 40];
        uint32_t idx[40];
        for (int i = 0; i < n; ++i) {
            double a = 2 * PI * i / n;
            pf_vec3 p = pf_m3_mulv(q, pf_v3(radius * cos(a), radius * sin(a), 0));
            pf_v3_store(pf_v3_add(center, p), x + 3 * i);
            idx[i] = (uint32_t)i;
        }
        /* area n r^2 sin(2 pi / n) / 2; coordinates carry ~u * 6 of rounding */
        double area = 0.5 * n * radius * radius * sin(2 * PI / n);
        assert_close(pf_polygon_area(x, idx, n), area, 1e-14 * area);
        assert_true(pf_v3_dist(pf_polygon_centroid(x, idx, n), center) <= 1e-14 * 6);
        /* longest chord: between vertices floor(n/2) apart, 2 r sin(pi floor(n/2) / n) */
        assert_close(pf_polygon_diameter(x, idx, n), 2 * radius * sin(PI * (n / 2) / n),
                     1e-14 * radius);
    }
    no_leaks();
}

static void test_polygon_offset_and_planarity(void **state)
{
    (void)state;
    /* coordinates are multiples of 2^-20 below 2: adding the 1e4 offset is exact (34 bits), so
     * the moved triangle has exactly the same area. A Newell sum of raw coordinates would round
     * products of 68 bits near 1e8 and lose about 1e8 u = 2e-8 of the area. */
    double tri[9];
    const double frac[] = {0.1234, 0.2718, 0.5772, 1.7320, 0.3141, 0.6931, 0.4142, 1.4142, 0.8660};
    for (int i = 0; i < 9; ++i)
        tri[i] = ldexp(round(ldexp(frac[i], 20)), -20);
    const uint32_t idx[] = {0, 1, 2};
    double moved[9];
    for (int i = 0; i < 9; ++i)
        moved[i] = tri[i] + 1e4 + 0.5 * (i % 3);
    double a0 = pf_polygon_area(tri, idx, 3), a1 = pf_polygon_area(moved, idx, 3);
    assert_true(a0 > 0.1);
    assert_close(a1, a0, 1e-12 * a0);
    pf_vec3 c0 = pf_polygon_centroid(tri, idx, 3), c1 = pf_polygon_centroid(moved, idx, 3);
    assert_close(c1.x - 1e4, c0.x, 1e-11); /* c1 itself is 1e4 ulps wide: 2e-12 per coordinate */
    assert_close(c1.z - 1e4 - 1, c0.z, 1e-11);
    /* bent quad (0,0,0) (1,0,0) (1,1,h) (0,1,0): Newell normal (-h/2, -h/2, 1), centroid
     * (1/2, 1/2, h/3), vertex distances h/6, -h/3, h/6, -h/3 over sqrt(1 + h^2/2) */
    const double h = 0.1;
    const double quad[] = {0, 0, 0, 1, 0, 0, 1, 1, h, 0, 1, 0};
    const uint32_t q4[] = {0, 1, 2, 3};
    double want = h / (3 * sqrt(1 + h * h / 2));
    assert_close(pf_polygon_planarity_error(quad, q4, 4), want, 4 * DBL_EPSILON);
    pf_vec3 c = pf_polygon_centroid(quad, q4, 4);
    assert_true(pf_v3_dist(c, pf_v3(0.5, 0.5, h / 3)) <= 4 * DBL_EPSILON);
    /* collinear: no area, no plane */
    const double line[] = {0, 0, 0, 1, 1, 1, 3, 3, 3};
    assert_true(pf_polygon_area(line, idx, 3) == 0);
    assert_true(isinf(pf_polygon_planarity_error(line, idx, 3)));
    c = pf_polygon_centroid(line, idx, 3);
    assert_true(pf_v3_dist(c, pf_v3(4.0 / 3, 4.0 / 3, 4.0 / 3)) <= 4 * DBL_EPSILON);
    no_leaks();
}

/* ---- polyhedra ------------------------------------------------------------------------------- */

/* Axis box [o, o + size] as 8 nodes and 6 outward quads. */
static void box(pf_vec3 o, pf_vec3 size, double x[24])
{
    for (int i = 0; i < 8; ++i)
        pf_v3_store(pf_v3(o.x + (i & 1 ? size.x : 0), o.y + (i & 2 ? size.y : 0),
                          o.z + (i & 4 ? size.z : 0)),
                    x + 3 * i);
}
static const uint32_t BOX_FACES[] = {0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4,
                                     2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5};
static const int64_t BOX_OFFSETS[] = {0, 4, 8, 12, 16, 20, 24};

static void test_polyhedron_box_and_tet(void **state)
{
    (void)state;
    double x[24];
    box(pf_v3(0, 0, 0), pf_v3(1, 1, 1), x);
    pf_polyhedron p = {x, 6, BOX_OFFSETS, BOX_FACES};
    assert_true(pf_polyhedron_volume(&p) == 1);
    /* inside out: every face reversed */
    uint32_t rev[24];
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < 4; ++j)
            rev[4 * f + j] = BOX_FACES[4 * f + 3 - j];
    pf_polyhedron inside_out = {x, 6, BOX_OFFSETS, rev};
    assert_true(pf_polyhedron_volume(&inside_out) == -1);
    /* a box moved by 1e4 with corners on a 2^-20 grid: every coordinate is exact (34 bits), so
     * the volume is the product of the edge lengths (rounded twice, 2 u). Without a reference
     * point on the box the determinants would round products near 1e12 and lose ~1e12 u. */
    pf_vec3 o = pf_v3(1e4 + ldexp(131071, -20), -1e4 + ldexp(7, -20), 1e4);
    pf_vec3 size = pf_v3(ldexp(1572865, -20), ldexp(786431, -20), ldexp(2359297, -20));
    box(o, size, x);
    double want = size.x * size.y * size.z;
    assert_close(pf_polyhedron_volume(&p), want, 1e-12 * want);
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(&p, &lo, &hi);
    assert_true(lo.x == o.x && lo.y == o.y && lo.z == o.z);
    assert_true(hi.x == o.x + size.x && hi.y == o.y + size.y && hi.z == o.z + size.z);
    /* tetrahedron: det(b - a, c - a, d - a) / 6 for a random positively oriented one */
    rng r = {11};
    for (int k = 0; k < 100; ++k) {
        double t[12];
        for (int i = 0; i < 12; ++i)
            t[i] = uniform(&r);
        pf_vec3 a = pf_v3_load(t);
        pf_mat3 e;
        for (int j = 0; j < 3; ++j) {
            pf_vec3 d = pf_v3_sub(pf_v3_load(t + 3 * (j + 1)), a);
            e.m[0][j] = d.x, e.m[1][j] = d.y, e.m[2][j] = d.z;
        }
        double vol = pf_m3_det(e) / 6;
        if (vol < 0) { /* swap nodes 1 and 2 */
            for (int i = 0; i < 3; ++i) {
                double s = t[3 + i];
                t[3 + i] = t[6 + i];
                t[6 + i] = s;
            }
            vol = -vol;
        }
        /* faces of tet (0 1 2 3) with positive volume, outward */
        const uint32_t tf[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
        const int64_t to[] = {0, 3, 6, 9, 12};
        pf_polyhedron tet = {t, 4, to, tf};
        assert_close(pf_polyhedron_volume(&tet), vol, 1e-14);
    }
    pf_polyhedron empty = {x, 0, BOX_OFFSETS, BOX_FACES};
    assert_true(pf_polyhedron_volume(&empty) == 0);
    pf_polyhedron_bounds(&empty, &lo, &hi);
    assert_true(lo.x == 0 && hi.z == 0);
    no_leaks();
}

static void test_polyhedron_L_prism(void **state)
{
    (void)state;
    /* the L of area 3 extruded along z by 2: volume 6. Bottom and top are non-convex hexagons
     * (fanned from the corner (0,2), one fan triangle negative), the sides six quads. */
    const double l[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    double x[36];
    for (int i = 0; i < 6; ++i)
        for (int k = 0; k < 2; ++k)
            pf_v3_store(pf_v3(l[2 * i], l[2 * i + 1], 2.0 * k), x + 3 * (i + 6 * k));
    uint32_t faces[12 + 24];
    int64_t offsets[9] = {0, 6, 12};
    for (int i = 0; i < 6; ++i) {
        faces[i] = (uint32_t)((11 - i) % 6);        /* bottom, seen from below: 5 4 3 2 1 0 */
        faces[6 + i] = (uint32_t)(6 + (5 + i) % 6); /* top, counter-clockwise: 11 6 7 8 9 10 */
        uint32_t a = (uint32_t)i, b = (uint32_t)((i + 1) % 6);
        uint32_t side[4] = {a, b, b + 6, a + 6};
        for (int j = 0; j < 4; ++j)
            faces[12 + 4 * i + j] = side[j];
        offsets[3 + i] = 12 + 4 * (i + 1);
    }
    pf_polyhedron p = {x, 8, offsets, faces};
    assert_close(pf_polyhedron_volume(&p), 6, 8 * DBL_EPSILON);
    /* a closed surface: the face area vectors sum to zero (exact: all terms are integers) */
    pf_vec3 sum = pf_v3(0, 0, 0);
    for (int f = 0; f < 8; ++f)
        sum = pf_v3_add(sum,
                        pf_polygon_area_vector(x, faces + offsets[f], offsets[f + 1] - offsets[f]));
    assert_true(sum.x == 0 && sum.y == 0 && sum.z == 0);
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(&p, &lo, &hi);
    assert_true(lo.x == 0 && lo.y == 0 && lo.z == 0 && hi.x == 2 && hi.y == 2 && hi.z == 2);
    no_leaks();
}


/* ---- closest points ---------------------------------------------------------------------- */

/* The nearest point of a triangle against dense sampling: no sample is nearer (the exact minimum
 * is below every sample, up to rounding 1e-14), the best sample is at most the sampling spacing
 * (edge / 400) farther, and the point lies in the triangle (barycentric coordinates >= -1e-12). */
static void test_triangle_closest_point(void **state)
{
    (void)state;
    rng r = {4242};
    for (int trial = 0; trial < 200; ++trial) {
        pf_vec3 v[3], p;
        for (int k = 0; k < 3; ++k)
            v[k] = pf_v3(uniform(&r), uniform(&r), uniform(&r));
        p = pf_v3(2 * uniform(&r), 2 * uniform(&r), 2 * uniform(&r));
        pf_vec3 q = pf_triangle_closest_point(p, v[0], v[1], v[2]);
        double d = pf_v3_dist(p, q), best = INFINITY, edge = 0;
        for (int k = 0; k < 3; ++k)
            edge = fmax(edge, pf_v3_dist(v[k], v[(k + 1) % 3]));
        const int n = 400;
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                double a = (double)i / n, b = (double)j / n;
                pf_vec3 x = pf_v3_add(v[0], pf_v3_add(pf_v3_scale(pf_v3_sub(v[1], v[0]), a),
                                                      pf_v3_scale(pf_v3_sub(v[2], v[0]), b)));
                best = fmin(best, pf_v3_dist(p, x));
            }
        assert_true(d <= best + 1e-14);
        assert_true(best - d <= 2 * edge / n);
        /* barycentric coordinates of q: solve in the plane by normal equations */
        pf_vec3 e1 = pf_v3_sub(v[1], v[0]), e2 = pf_v3_sub(v[2], v[0]), w = pf_v3_sub(q, v[0]);
        double a11 = pf_v3_dot(e1, e1), a12 = pf_v3_dot(e1, e2), a22 = pf_v3_dot(e2, e2);
        double b1 = pf_v3_dot(w, e1), b2 = pf_v3_dot(w, e2), det = a11 * a22 - a12 * a12;
        double s = (b1 * a22 - b2 * a12) / det, t = (a11 * b2 - a12 * b1) / det;
        assert_true(s >= -1e-12 && t >= -1e-12 && s + t <= 1 + 1e-12);
    }
}

/* pf_rayscene_closest against every triangle by brute force on a sphere of 800 triangles: the
 * same distance (the BVH only prunes; equally near triangles tie within 1e-12 relative);
 * within max_dist only; and on a cube
 * of 12 triangles the sign of dot(p - point, normal) tells inside from outside for points near
 * its edges and corners, where several triangles are equally near. */
static void test_rayscene_closest(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 20, 20, &err), PF_OK);
    pf_rayscene *rs = NULL;
    assert_int_equal(pf_rayscene_create(&rs, s.x, s.n_verts, s.tri, s.n_tris, &err), PF_OK);
    rng r = {99};
    for (int trial = 0; trial < 300; ++trial) {
        pf_vec3 p = pf_v3(1.5 * uniform(&r), 1.5 * uniform(&r), 1.5 * uniform(&r));
        double brute = INFINITY;
        for (int32_t t = 0; t < s.n_tris; ++t) {
            pf_vec3 a = pf_v3_load(s.x + 3 * (size_t)s.tri[3 * t]);
            pf_vec3 b = pf_v3_load(s.x + 3 * (size_t)s.tri[3 * t + 1]);
            pf_vec3 c = pf_v3_load(s.x + 3 * (size_t)s.tri[3 * t + 2]);
            brute = fmin(brute, pf_v3_dist(p, pf_triangle_closest_point(p, a, b, c)));
        }
        pf_closest cl;
        assert_true(pf_rayscene_closest(rs, p, 10, &cl));
        /* equal, up to the relative 1e-12 within which equally near triangles tie */
        if (fabs(cl.dist - brute) > 1e-12 * brute)
            fail_msg("trial %d: closest %.17g, brute force %.17g", trial, cl.dist, brute);
        assert_true(pf_v3_dist(cl.point, p) == cl.dist);
        /* a radius below the distance finds nothing */
        if (brute > 1e-3)
            assert_false(pf_rayscene_closest(rs, p, 0.999 * brute, &cl));
    }
    pf_rayscene_destroy(&rs);
    pf_surface_release(&s);

    /* the cube [-1, 1]^3 */
    double x[24];
    for (int k = 0; k < 8; ++k) {
        x[3 * k] = k & 1 ? 1 : -1;
        x[3 * k + 1] = k & 2 ? 1 : -1;
        x[3 * k + 2] = k & 4 ? 1 : -1;
    }
    const uint32_t tri[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                              2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    assert_int_equal(pf_rayscene_create(&rs, x, 8, tri, 12, &err), PF_OK);
    for (int trial = 0; trial < 2000; ++trial) {
        /* near a corner or an edge: two or three coordinates close to +-1 */
        double c[3];
        int near = 2 + trial % 2;
        for (int k = 0; k < 3; ++k) {
            double sgn = uniform(&r) < 0 ? -1 : 1;
            c[k] = k < near ? sgn * (1 + 0.2 * uniform(&r)) : 0.9 * uniform(&r);
        }
        pf_vec3 p = pf_v3_load(c);
        bool inside = fabs(c[0]) < 1 && fabs(c[1]) < 1 && fabs(c[2]) < 1;
        pf_closest cl;
        assert_true(pf_rayscene_closest(rs, p, 10, &cl));
        if (cl.dist < 1e-9)
            continue;
        double side = pf_v3_dot(pf_v3_sub(p, cl.point), cl.normal);
        if (inside != (side < 0))
            fail_msg("point (%g, %g, %g): inside %d, side %g", c[0], c[1], c[2], inside, side);
    }
    pf_rayscene_destroy(&rs);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- stress ---------------------------------------------------------------------------------- */

/* Closed cases, and random stresses against the principal-stress form (an independent route: the
 * eigenvalues by Jacobi rotations). Tolerance 1e-12 relative to the largest |eigenvalue|: both
 * routes are accurate to a few ulps of it. */
static void test_von_mises(void **state)
{
    (void)state;
    const double uniaxial[6] = {-7, 0, 0, 0, 0, 0}, shear[6] = {0, 0, 0, 0, 2, 0};
    const double hydrostatic[6] = {5, 5, 5, 0, 0, 0};
    assert_true(fabs(pf_von_mises(uniaxial) - 7) < 1e-15);
    assert_true(fabs(pf_von_mises(shear) - 2 * sqrt(3.0)) < 1e-15);
    assert_true(pf_von_mises(hydrostatic) == 0);
    rng r = {0x2545f4914f6cdd1du};
    for (int k = 0; k < 100; ++k) {
        double s[6];
        for (int i = 0; i < 6; ++i)
            s[i] = 10 * uniform(&r);
        pf_mat3 m = {{{s[0], s[3], s[5]}, {s[3], s[1], s[4]}, {s[5], s[4], s[2]}}};
        double p[3];
        pf_mat3 v;
        pf_mat3_sym_eigen(m, p, &v);
        double a = p[0] - p[1], b = p[1] - p[2], c = p[2] - p[0];
        double want = sqrt(0.5 * (a * a + b * b + c * c));
        double scale = fmax(fabs(p[0]), fabs(p[2]));
        assert_true(fabs(pf_von_mises(s) - want) <= 1e-12 * scale);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_svd_random),
        cmocka_unit_test(test_svd_known_spectra),
        cmocka_unit_test(test_svd_special),
        cmocka_unit_test(test_polar_matches_newton),
        cmocka_unit_test(test_polar_recovers_rotation),
        cmocka_unit_test(test_polar_degenerate),
        cmocka_unit_test(test_polar_reflection),
        cmocka_unit_test(test_eigen_diagonal_and_repeated),
        cmocka_unit_test(test_eigen_random_symmetric),
        cmocka_unit_test(test_eigen_stress_tensor),
        cmocka_unit_test(test_inverse),
        cmocka_unit_test(test_plane),
        cmocka_unit_test(test_polygon_square_and_L),
        cmocka_unit_test(test_polygon_regular),
        cmocka_unit_test(test_polygon_offset_and_planarity),
        cmocka_unit_test(test_polyhedron_box_and_tet),
        cmocka_unit_test(test_polyhedron_L_prism),
        cmocka_unit_test(test_triangle_closest_point),
        cmocka_unit_test(test_rayscene_closest),
        cmocka_unit_test(test_von_mises),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
