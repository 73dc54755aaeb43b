/* Symmetric 3x3 eigen-decomposition by the cyclic Jacobi method. */
#include <pf/geom.h>

/* One Jacobi rotation J in the (p, q) plane, A <- J^T A J, V <- V J, chosen so a'_pq = 0.
 * With J_pp = J_qq = c, J_pq = s, J_qp = -s the off-diagonal entry becomes
 * (c^2 - s^2) a_pq + c s (a_pp - a_qq); it vanishes for t = s / c solving
 * t^2 + 2 theta t - 1 = 0, theta = (a_qq - a_pp) / (2 a_pq), and the root of smaller magnitude
 * (|angle| <= pi/4) gives a_pp' = a_pp - t a_pq, a_qq' = a_qq + t a_pq and the usual quadratic
 * convergence of the cyclic sweeps (Golub & Van Loan, sec. 8.5). */
static void jacobi_rotate(double a[3][3], double v[3][3], int p, int q)
{
    double apq = a[p][q];
    double theta = (a[q][q] - a[p][p]) / (2 * apq);
    double t = fabs(theta) > 1e150 ? 0.5 / theta
                                   : copysign(1.0, theta) / (fabs(theta) + sqrt(1 + theta * theta));
    double c = 1 / sqrt(1 + t * t), s = c * t;
    a[p][p] -= t * apq;
    a[q][q] += t * apq;
    a[p][q] = a[q][p] = 0;
    int r = 3 - p - q;
    double arp = a[r][p], arq = a[r][q];
    a[r][p] = a[p][r] = c * arp - s * arq;
    a[r][q] = a[q][r] = s * arp + c * arq;
    for (int k = 0; k < 3; ++k) {
        double vkp = v[k][p], vkq = v[k][q];
        v[k][p] = c * vkp - s * vkq;
        v[k][q] = s * vkp + c * vkq;
    }
}

/* An off-diagonal entry is negligible once adding it (times 100) to both diagonal entries of
 * its pair changes neither: the eigenvalues are then fixed to rounding of their own size. */
static int negligible(double app, double aqq, double apq)
{
    double g = 100 * fabs(apq);
    return g == 0 || (fabs(app) + g == fabs(app) && fabs(aqq) + g == fabs(aqq));
}

static void swap_pair(double a[3][3], double v[3][3], int i, int j)
{
    double t = a[i][i];
    a[i][i] = a[j][j];
    a[j][j] = t;
    for (int k = 0; k < 3; ++k) {
        t = v[k][i];
        v[k][i] = v[k][j];
        v[k][j] = t;
    }
}

void pf_mat3_sym_eigen(pf_mat3 s, double values[3], pf_mat3 *vectors)
{
    /* Scale by a power of two (exact) so the largest entry is near 1: theta and t stay in range
     * for every input magnitude. */
    double amax = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            amax = fmax(amax, fabs(s.m[i][j]));
    if (!isfinite(amax)) {
        values[0] = values[1] = values[2] = NAN;
        *vectors = pf_m3_identity();
        return;
    }
    int e = 0;
    if (amax > 0)
        (void)frexp(amax, &e);
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            a[i][j] = a[j][i] = ldexp(s.m[i][j], -e);
    static const int P[3] = {0, 0, 1}, Q[3] = {1, 2, 2};
    for (int sweep = 0; sweep < 50; ++sweep) {
        int rotated = 0;
        for (int k = 0; k < 3; ++k) {
            if (negligible(a[P[k]][P[k]], a[Q[k]][Q[k]], a[P[k]][Q[k]])) {
                a[P[k]][Q[k]] = a[Q[k]][P[k]] = 0;
                continue;
            }
            jacobi_rotate(a, v, P[k], Q[k]);
            rotated = 1;
        }
        if (!rotated)
            break;
    }
    for (int i = 0; i < 2; ++i)
        for (int j = 2; j > i; --j)
            if (a[j][j] < a[j - 1][j - 1])
                swap_pair(a, v, j, j - 1);
    /* Eigenvectors are defined up to sign: make the frame right-handed. */
    pf_mat3 vm;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            vm.m[i][j] = v[i][j];
    if (pf_m3_det(vm) < 0)
        for (int i = 0; i < 3; ++i)
            vm.m[i][2] = -vm.m[i][2];
    *vectors = vm;
    for (int i = 0; i < 3; ++i)
        values[i] = ldexp(a[i][i], e);
}
