/* geom: the polar rotation from a nearby guess (pf_mat3_polar_rotation_near) against the SVD's
 * (pf_mat3_polar_rotation), the oracle checked in test_geom.c.
 *
 * Tolerance 1e-12 on every entry: Newton stops when its step is below 1e-10 rad, so the error
 * left is about the square of that, and rounding is a few ulps times the condition of its
 * linear system, which the method bounds by 1e3 (ill-conditioned cases fall back to the SVD):
 * about 1e-13 at worst. Orthogonality and det = 1 to 1e-14, as for the SVD polar. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "test_random.h"
#include <pf/geom.h>

static double max_diff(pf_mat3 a, pf_mat3 b)
{
    double m = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            m = fmax(m, fabs(a.m[i][j] - b.m[i][j]));
    return m;
}

static pf_mat3 diag(double a, double b, double c)
{
    return (pf_mat3){{{a, 0, 0}, {0, b, 0}, {0, 0, c}}};
}

/* A rotation by at most max_angle radians about a random axis. */
static pf_mat3 small_rotation(rng *r, double max_angle)
{
    pf_vec3 axis = pf_v3_normalize(pf_v3(uniform(r), uniform(r), uniform(r) + 2));
    double t = max_angle * uniform01(r), c = cos(t), s = sin(t), x = axis.x, y = axis.y, z = axis.z;
    return (pf_mat3){{{c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s},
                      {y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s},
                      {z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)}}};
}

/* Checks near = SVD polar; returns Newton's iterations (-1: fell back). */
static int32_t check_near(pf_mat3 a, pf_mat3 guess)
{
    int32_t its = 0;
    pf_mat3 rot = pf_mat3_polar_rotation_near(a, guess, &its);
    assert_true(max_diff(rot, pf_mat3_polar_rotation(a)) <= 1e-12);
    assert_true(max_diff(pf_m3_mul(pf_m3_transpose(rot), rot), pf_m3_identity()) <= 1e-14);
    assert_true(fabs(pf_m3_det(rot) - 1) <= 1e-14);
    return its;
}

/* A = U diag(s) V^T with the given singular values, U and V random rotations. */
static pf_mat3 with_singular_values(rng *r, double s1, double s2, double s3, pf_mat3 *u_vt)
{
    pf_mat3 u = random_rotation(r), v = random_rotation(r);
    *u_vt = pf_m3_mul(u, pf_m3_transpose(v));
    return pf_m3_mul(pf_m3_mul(u, diag(s1, s2, s3)), pf_m3_transpose(v));
}

/* Singular values in [0.1, 2], or one time in four a reflection (det A < 0: one of them in
 * [-0.5, -0.1], the others in [1.1, 3]), the guess within 0.3 rad: Newton converges (never falls
 * back) and agrees. */
static void test_random_near_guess(void **state)
{
    (void)state;
    rng r = {31337};
    for (int k = 0; k < 2000; ++k) {
        double s[3] = {0.1 + 1.9 * uniform01(&r), 0.1 + 1.9 * uniform01(&r),
                       0.1 + 1.9 * uniform01(&r)};
        if (k % 4 == 3) /* the flipped one the smallest by a margin, as in a turned element */
            s[k % 3] = -0.1 - 0.4 * uniform01(&r), s[(k + 1) % 3] += 1, s[(k + 2) % 3] += 1;
        pf_mat3 uvt, a = with_singular_values(&r, s[0], s[1], s[2], &uvt);
        pf_mat3 truth = pf_mat3_polar_rotation(a);
        int32_t its = check_near(a, pf_m3_mul(truth, small_rotation(&r, 0.3)));
        assert_true(its >= 1 && its <= 8);
    }
}

/* Uniform random entries (any condition, reflections): near or far guesses, whatever path. */
static void test_random_matrices_any_guess(void **state)
{
    (void)state;
    rng r = {2718};
    for (int k = 0; k < 2000; ++k) {
        pf_mat3 a;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                a.m[i][j] = uniform(&r);
        pf_mat3 truth = pf_mat3_polar_rotation(a);
        check_near(a, pf_m3_mul(truth, small_rotation(&r, 0.5)));
        check_near(a, random_rotation(&r));
    }
}

/* Rank 2 and nearly so (sigma_3 = 0, 1e-9, 1e-6 of sigma_1), from near guesses: still Newton's
 * (its system stays well conditioned: sigma_2 + sigma_3 is not small). Rank 1 and nearly so
 * (sigma_2, sigma_3 <= 1e-9): the rotation is ill-determined and the SVD's is returned. */
static void test_near_singular(void **state)
{
    (void)state;
    rng r = {4711};
    static const double small[] = {0, 1e-9, 1e-6};
    for (int k = 0; k < 600; ++k) {
        double s3 = small[k % 3];
        pf_mat3 uvt, a = with_singular_values(&r, 1 + uniform01(&r), 0.5 + uniform01(&r), s3, &uvt);
        pf_mat3 truth = pf_mat3_polar_rotation(a);
        assert_true(check_near(a, pf_m3_mul(truth, small_rotation(&r, 0.2))) >= 1);
        a = with_singular_values(&r, 1, s3, s3 * 0.5, &uvt);
        truth = pf_mat3_polar_rotation(a);
        int32_t its = 0;
        pf_mat3 rot =
            pf_mat3_polar_rotation_near(a, pf_m3_mul(truth, small_rotation(&r, 0.2)), &its);
        assert_int_equal(its, -1);
        assert_memory_equal(&rot, &truth, sizeof rot);
    }
}

/* Degenerate inputs fall back: zero and non-finite matrices, a non-finite guess. */
static void test_fallbacks(void **state)
{
    (void)state;
    int32_t its = 0;
    pf_mat3 id = pf_m3_identity(), a = diag(1, 2, 3);
    pf_mat3 rot = pf_mat3_polar_rotation_near(diag(0, 0, 0), id, &its);
    assert_int_equal(its, -1);
    assert_true(max_diff(rot, id) == 0);
    a.m[1][2] = NAN;
    rot = pf_mat3_polar_rotation_near(a, id, &its);
    assert_int_equal(its, -1);
    assert_true(max_diff(rot, id) == 0);
    pf_mat3 guess = id;
    guess.m[0][0] = INFINITY;
    rot = pf_mat3_polar_rotation_near(diag(1, 2, 3), guess, &its);
    assert_int_equal(its, -1);
    assert_true(max_diff(rot, id) == 0);
    assert_true(max_diff(pf_mat3_polar_rotation_near(diag(1, 2, 3), id, NULL), id) == 0);
}

/* A time step's use: a body turning 0.01 rad a step while it stretches, each rotation started
 * from the last one for 5,000 steps. Chained products would drift from orthogonality; the
 * guess's orthonormalisation keeps every result within 1e-14, and each needs few iterations. */
static void test_chained_warm_starts(void **state)
{
    (void)state;
    rng r = {1234};
    pf_mat3 rot = pf_m3_identity(), turn = small_rotation(&r, 0.02), q = pf_m3_identity();
    for (int k = 0; k < 5000; ++k) {
        q = pf_m3_mul(turn, q);
        double t = 0.001 * k;
        pf_mat3 a = pf_m3_mul(q, diag(1 + 0.3 * sin(t), 1 - 0.2 * cos(3 * t), 0.8));
        int32_t its = 0;
        pf_mat3 guess = rot;
        rot = pf_mat3_polar_rotation_near(a, guess, &its);
        assert_true(its >= 1 && its <= 3);
        assert_true(max_diff(rot, pf_mat3_polar_rotation(a)) <= 1e-12);
        assert_true(max_diff(pf_m3_mul(pf_m3_transpose(rot), rot), pf_m3_identity()) <= 1e-14);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_near_guess),
        cmocka_unit_test(test_random_matrices_any_guess),
        cmocka_unit_test(test_near_singular),
        cmocka_unit_test(test_fallbacks),
        cmocka_unit_test(test_chained_warm_starts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
