/* The polar rotation near a known one: Newton's method on the rotation itself, for rotations that
 * change little between calls (a time step's), with the SVD polar (svd.c) as the fall-back. */
#include <pf/geom.h>

/* Iterations before giving up, the step below which R is taken as converged (radians: the next
 * step would be about its square), and the bound on G's condition number (see below). */
enum { NEWTON_MAX_STEPS = 8 };
static const double CONVERGED_STEP = 1e-10;
static const double MAX_CONDITION = 1e3;

static bool finite9(pf_mat3 a)
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (!isfinite(a.m[i][j]))
                return false;
    return true;
}

/* One step of Bjorck's orthonormalisation, R (3 I - R^T R) / 2: a guess orthogonal to a few ulps
 * becomes orthogonal to about their square (rotations chained over many calls stay rotations). */
static pf_mat3 orthonormalize(pf_mat3 r)
{
    pf_mat3 e = pf_m3_mul(pf_m3_transpose(r), r);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            e.m[i][j] = 0.5 * ((i == j ? 3.0 : 0.0) - e.m[i][j]);
    return pf_m3_mul(r, e);
}

/* The rotation by about w (to second order: the Cayley transform of [w / 2]x, exactly
 * orthogonal), from the unit quaternion (1, w / 2) / |(1, w / 2)|: no trigonometry, and Newton's
 * quadratic convergence is kept (the rotation differs from exp([w]x) by O(|w|^3)). */
static pf_mat3 rotation_of(pf_vec3 w)
{
    double x = 0.5 * w.x, y = 0.5 * w.y, z = 0.5 * w.z, s = 2 / (1 + x * x + y * y + z * z);
    return (pf_mat3){{{1 - s * (y * y + z * z), s * (x * y - z), s * (x * z + y)},
                      {s * (x * y + z), 1 - s * (x * x + z * z), s * (y * z - x)},
                      {s * (x * z - y), s * (y * z + x), 1 - s * (x * x + y * y)}}};
}

/* The Newton step w of M = R^T A: with M ~ (I + [w]x) S, S symmetric, the skew part of M is
 * axial(M - M^T) = (tr(S) I - S) w, and G = tr(S) I - S is positive definite exactly when R is
 * the nearest proper rotation (S's eigenvalues sigma_i or, for det A < 0, the smallest negated:
 * G's are the pairwise sums; any other fixed point of the iteration negates a larger one and
 * makes a sum negative). Returns false when G is not positive definite or its condition (bounded
 * by tr(G)^3 / (4 det G)) exceeds MAX_CONDITION: a rotation too sensitive, or the wrong branch. */
static bool newton_step(pf_mat3 m, pf_vec3 *w)
{
    double tr = m.m[0][0] + m.m[1][1] + m.m[2][2];
    pf_mat3 g;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            g.m[i][j] = (i == j ? tr : 0) - 0.5 * (m.m[i][j] + m.m[j][i]);
    double gt = g.m[0][0] + g.m[1][1] + g.m[2][2], det;
    double m2 = g.m[0][0] * g.m[1][1] - g.m[0][1] * g.m[1][0];
    pf_mat3 inv = pf_m3_inverse(g, &det);
    if (!(g.m[0][0] > 0 && m2 > 0 && det > 0 && 4 * det * MAX_CONDITION >= gt * gt * gt))
        return false;
    pf_vec3 b = pf_v3(m.m[2][1] - m.m[1][2], m.m[0][2] - m.m[2][0], m.m[1][0] - m.m[0][1]);
    *w = pf_m3_mulv(inv, b);
    return true;
}

pf_mat3 pf_mat3_polar_rotation_near(pf_mat3 a, pf_mat3 guess, int32_t *iterations)
{
    double scale = pf_m3_norm(a);
    if (iterations)
        *iterations = -1;
    if (!(scale > 0) || !finite9(a) || !finite9(guess))
        return pf_mat3_polar_rotation(a);
    pf_mat3 an = pf_m3_scale(a, 1 / scale), r = orthonormalize(guess);
    for (int32_t k = 1; k <= NEWTON_MAX_STEPS; ++k) {
        pf_vec3 w;
        if (!newton_step(pf_m3_mul(pf_m3_transpose(r), an), &w) || !pf_v3_isfinite(w))
            break;
        r = pf_m3_mul(r, rotation_of(w));
        if (pf_v3_norm(w) <= CONVERGED_STEP) {
            if (iterations)
                *iterations = k;
            return r;
        }
    }
    return pf_mat3_polar_rotation(a);
}
