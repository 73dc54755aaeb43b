/* Stresses shared by the methods (the corotated stress of pf-sim's output and of the refinement
 * criterion) and scalar measures of a symmetric stress, shared with the renderer (stress colours
 * from 6-component STRS chunks). */
#include <pf/geom.h>

#include <math.h>

/* sigma_vM = sqrt(3 J2), J2 = ((sxx-syy)^2 + (syy-szz)^2 + (szz-sxx)^2) / 6 + sxy^2 + syz^2 + szx^2
 */
double pf_von_mises(const double s[6])
{
    double a = s[0] - s[1], b = s[1] - s[2], c = s[2] - s[0];
    return sqrt(0.5 * (a * a + b * b + c * c) + 3 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
}

void pf_corotated_stress(pf_mat3 f, double lambda, double mu, double sigma[6])
{
    pf_mat3 rf = pf_m3_mul(pf_m3_transpose(pf_mat3_polar_rotation(f)), f);
    double eps[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            eps[i][j] = 0.5 * (rf.m[i][j] + rf.m[j][i]) - (i == j);
    double tr = eps[0][0] + eps[1][1] + eps[2][2];
    for (int i = 0; i < 3; ++i)
        sigma[i] = lambda * tr + 2 * mu * eps[i][i];
    sigma[3] = 2 * mu * eps[0][1];
    sigma[4] = 2 * mu * eps[1][2];
    sigma[5] = 2 * mu * eps[2][0];
}

double pf_principal_stress(const double s[6], pf_vec3 *direction)
{
    pf_mat3 m = {{{s[0], s[3], s[5]}, {s[3], s[1], s[4]}, {s[5], s[4], s[2]}}};
    double values[3];
    pf_mat3 vectors;
    pf_mat3_sym_eigen(m, values, &vectors);
    int k = fabs(values[0]) > fabs(values[2]) ? 0 : 2; /* ascending: the extremes */
    if (direction)
        *direction = (pf_vec3){vectors.m[0][k], vectors.m[1][k], vectors.m[2][k]};
    return values[k];
}
