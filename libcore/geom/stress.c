/* Scalar measures of a symmetric stress, shared by the methods (stress output of pf-sim) and the
 * renderer (stress colours from 6-component STRS chunks). */
#include <pf/geom.h>

#include <math.h>

/* sigma_vM = sqrt(3 J2), J2 = ((sxx-syy)^2 + (syy-szz)^2 + (szz-sxx)^2) / 6 + sxy^2 + syz^2 + szx^2 */
double pf_von_mises(const double s[6])
{
    double a = s[0] - s[1], b = s[1] - s[2], c = s[2] - s[0];
    return sqrt(0.5 * (a * a + b * b + c * c) + 3 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
}
