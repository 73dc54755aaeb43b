/* Planes in Hessian normal form. */
#include <pf/geom.h>

pf_plane pf_plane_from_point_normal(pf_vec3 p, pf_vec3 n)
{
    /* Divide by the largest component first: |n|^2 can then neither overflow nor underflow. */
    double m = pf_v3_max_abs(n);
    pf_vec3 u = m > 0 && isfinite(m) ? pf_v3_normalize(pf_v3_scale(n, 1.0 / m)) : pf_v3(0, 0, 0);
    return (pf_plane){.n = u, .d = pf_v3_dot(u, p)};
}
