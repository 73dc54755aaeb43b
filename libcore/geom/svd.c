/* 3x3 singular value decomposition by one-sided Jacobi, and the polar rotation built on it. */
#include <pf/geom.h>

#include <float.h>

/* Columns of a 3x3 matrix as vectors: col[j] = A e_j. */
typedef struct cols3 {
    pf_vec3 c[3];
} cols3;

static cols3 cols_of(pf_mat3 a)
{
    cols3 k;
    for (int j = 0; j < 3; ++j)
        k.c[j] = pf_v3(a.m[0][j], a.m[1][j], a.m[2][j]);
    return k;
}

static pf_mat3 mat_of(cols3 k)
{
    pf_mat3 a;
    for (int j = 0; j < 3; ++j) {
        a.m[0][j] = k.c[j].x;
        a.m[1][j] = k.c[j].y;
        a.m[2][j] = k.c[j].z;
    }
    return a;
}

static int mat_isfinite(pf_mat3 a)
{
    for (int i = 0; i < 3; ++i)
        if (!pf_v3_isfinite(pf_v3(a.m[i][0], a.m[i][1], a.m[i][2])))
            return 0;
    return 1;
}

static double max_abs_entry(pf_mat3 a)
{
    double m = 0;
    for (int i = 0; i < 3; ++i)
        m = fmax(m, pf_v3_max_abs(pf_v3(a.m[i][0], a.m[i][1], a.m[i][2])));
    return m;
}

/* Hestenes' one-sided Jacobi on the column pair (p, q) of W = A V: the plane rotation
 * [c s; -s c] applied from the right makes w_p . w_q = 0. With alpha = |w_p|^2,
 * beta = |w_q|^2, gamma = w_p . w_q the tangent t = s / c solves t^2 + 2 zeta t - 1 = 0,
 * zeta = (beta - alpha) / (2 gamma); the root of smaller magnitude keeps |angle| <= pi/4, which
 * is what makes the sweeps converge (quadratically once the columns are nearly orthogonal).
 * Returns 1 when a rotation was applied. */
static int rotate_pair(cols3 *w, cols3 *v, int p, int q)
{
    double alpha = pf_v3_dot(w->c[p], w->c[p]);
    double beta = pf_v3_dot(w->c[q], w->c[q]);
    double gamma = pf_v3_dot(w->c[p], w->c[q]);
    /* Converged for this pair once the cosine between the columns is at rounding level. */
    if (!(fabs(gamma) > DBL_EPSILON * sqrt(alpha) * sqrt(beta)))
        return 0;
    double zeta = (beta - alpha) / (2 * gamma);
    double t = fabs(zeta) > 1e150 ? 0.5 / zeta
                                  : copysign(1.0, zeta) / (fabs(zeta) + sqrt(1 + zeta * zeta));
    double c = 1 / sqrt(1 + t * t), s = c * t;
    pf_vec3 wp = w->c[p], wq = w->c[q], vp = v->c[p], vq = v->c[q];
    w->c[p] = pf_v3_sub(pf_v3_scale(wp, c), pf_v3_scale(wq, s));
    w->c[q] = pf_v3_add(pf_v3_scale(wp, s), pf_v3_scale(wq, c));
    v->c[p] = pf_v3_sub(pf_v3_scale(vp, c), pf_v3_scale(vq, s));
    v->c[q] = pf_v3_add(pf_v3_scale(vp, s), pf_v3_scale(vq, c));
    return 1;
}

static void swap_cols(cols3 *k, int i, int j)
{
    pf_vec3 t = k->c[i];
    k->c[i] = k->c[j];
    k->c[j] = t;
}

/* A unit vector orthogonal to the unit vector u: cross with the axis u is least aligned to. */
static pf_vec3 any_perpendicular(pf_vec3 u)
{
    double ax = fabs(u.x), ay = fabs(u.y), az = fabs(u.z);
    pf_vec3 e = ax <= ay && ax <= az ? pf_v3(1, 0, 0) : ay <= az ? pf_v3(0, 1, 0) : pf_v3(0, 0, 1);
    return pf_v3_normalize(pf_v3_cross(u, e));
}

/* Below this (relative to the largest entry of A, which is scaled to [0.5, 1)) a column of
 * W = A V carries no usable direction; the singular value is kept, the direction completed. */
static const double NULL_COLUMN = 1e-150;

/* Left singular vectors from the orthogonal columns of W = U diag(sigma): u1 = w1 / |w1|,
 * u2 from w2 re-orthogonalised against u1 (Gram-Schmidt), u3 = +-u1 x u2 with the sign of w3,
 * so U is orthogonal to rounding even when w3 (or w2) is tiny and its direction is noise. */
static cols3 left_vectors(const cols3 *w, const double sigma[3])
{
    cols3 u;
    if (!(sigma[0] > NULL_COLUMN))
        return cols_of(pf_m3_identity());
    u.c[0] = pf_v3_normalize(w->c[0]);
    pf_vec3 r = pf_v3_sub(w->c[1], pf_v3_scale(u.c[0], pf_v3_dot(u.c[0], w->c[1])));
    u.c[1] = sigma[1] > NULL_COLUMN && pf_v3_norm(r) > 0 ? pf_v3_normalize(r)
                                                         : any_perpendicular(u.c[0]);
    u.c[2] = pf_v3_cross(u.c[0], u.c[1]);
    if (sigma[2] > NULL_COLUMN && pf_v3_dot(u.c[2], w->c[2]) < 0)
        u.c[2] = pf_v3_scale(u.c[2], -1);
    return u;
}

void pf_mat3_svd(pf_mat3 a, pf_mat3 *u, double sigma[3], pf_mat3 *v)
{
    if (!mat_isfinite(a)) {
        *u = *v = pf_m3_identity();
        sigma[0] = sigma[1] = sigma[2] = NAN;
        return;
    }
    /* Scale by a power of two (exact) so the largest entry lies in [0.5, 1): the squared column
     * norms below can neither overflow nor lose the small columns to underflow. */
    double amax = max_abs_entry(a);
    int e = 0;
    if (amax > 0)
        (void)frexp(amax, &e);
    cols3 w = cols_of(pf_m3_scale(a, ldexp(1.0, -e)));
    cols3 vv = cols_of(pf_m3_identity());
    for (int sweep = 0; sweep < 60; ++sweep) {
        int rotated = rotate_pair(&w, &vv, 0, 1);
        rotated |= rotate_pair(&w, &vv, 0, 2);
        rotated |= rotate_pair(&w, &vv, 1, 2);
        if (!rotated)
            break;
    }
    /* A V = W with orthogonal columns: sigma_j = |w_j|, sorted descending with V's columns. */
    double s[3];
    for (int j = 0; j < 3; ++j)
        s[j] = pf_v3_norm(w.c[j]);
    for (int i = 0; i < 2; ++i)
        for (int j = 2; j > i; --j)
            if (s[j] > s[j - 1]) {
                double t = s[j];
                s[j] = s[j - 1];
                s[j - 1] = t;
                swap_cols(&w, j, j - 1);
                swap_cols(&vv, j, j - 1);
            }
    *u = mat_of(left_vectors(&w, s));
    *v = mat_of(vv);
    for (int j = 0; j < 3; ++j)
        sigma[j] = ldexp(s[j], e);
}

/* A = U diag(sigma) V^T gives A = (U V^T)(V diag(sigma) V^T): R = U V^T, S symmetric positive
 * semi-definite. For det(U V^T) < 0 (reflections) the nearest proper rotation flips u3, the
 * direction of the smallest singular value (S then has one negative eigenvalue, -sigma_3):
 * u3 = det(V) u1 x u2 gives det R = det(U) det(V) = +1 in every case. Since u1 and u2 come
 * from the two largest singular values only, R is exact for rank-2 A and any noise in the null
 * direction of a near-singular A never reaches R. */
pf_mat3 pf_mat3_polar_rotation(pf_mat3 a)
{
    if (!mat_isfinite(a))
        return pf_m3_identity();
    pf_mat3 um, vm;
    double sigma[3];
    pf_mat3_svd(a, &um, sigma, &vm);
    cols3 u = cols_of(um);
    double sign = pf_m3_det(vm) < 0 ? -1.0 : 1.0;
    u.c[2] = pf_v3_scale(pf_v3_cross(u.c[0], u.c[1]), sign);
    return pf_m3_mul(mat_of(u), pf_m3_transpose(vm));
}
