/* Planar polygon area vector, area, area centroid, planarity and diameter. */
#include <pf/geom.h>

static pf_vec3 node(const double *x, const uint32_t *idx, int64_t i)
{
    return pf_v3_load(x + 3 * (size_t)idx[i]);
}

/* Newell's area vector N = 1/2 sum_i p_i x p_{i+1} is invariant under translation; taken about
 * the first vertex p_0 the terms touching p_0 vanish and it is the fan sum
 * N = 1/2 sum_{i=1}^{n-2} (p_i - p_0) x (p_{i+1} - p_0). The differences are small where the
 * coordinates are large, so offsets (1e4 and more) cost no digits. */
pf_vec3 pf_polygon_area_vector(const double *x, const uint32_t *idx, int64_t n)
{
    pf_vec3 sum = pf_v3(0, 0, 0);
    if (n < 3)
        return sum;
    pf_vec3 p0 = node(x, idx, 0);
    pf_vec3 a = pf_v3_sub(node(x, idx, 1), p0);
    for (int64_t i = 2; i < n; ++i) {
        pf_vec3 b = pf_v3_sub(node(x, idx, i), p0);
        sum = pf_v3_add(sum, pf_v3_cross(a, b));
        a = b;
    }
    return pf_v3_scale(sum, 0.5);
}

double pf_polygon_area(const double *x, const uint32_t *idx, int64_t n)
{
    return pf_v3_norm(pf_polygon_area_vector(x, idx, n));
}

/* Area centroid relative to p_0, c - p_0. Fan triangles T_i = (p_0, p_i, p_{i+1}) cover a planar
 * polygon, convex or not, with signed areas a_i = n . ((p_i - p_0) x (p_{i+1} - p_0)) / 2 along
 * the unit normal n (negative where the fan folds back over a reflex vertex), so
 * c - p_0 = sum_i a_i (p_i - p_0 + p_{i+1} - p_0) / 3 / sum_i a_i. Falls back to the vertex
 * average when the polygon has no area. */
static pf_vec3 centroid_offset(const double *x, const uint32_t *idx, int64_t n)
{
    pf_vec3 p0 = node(x, idx, 0);
    pf_vec3 normal = pf_v3_normalize(pf_polygon_area_vector(x, idx, n));
    pf_vec3 moment = pf_v3(0, 0, 0);
    double area = 0;
    pf_vec3 a = pf_v3_sub(node(x, idx, 1), p0), mean = a;
    for (int64_t i = 2; i < n; ++i) {
        pf_vec3 b = pf_v3_sub(node(x, idx, i), p0);
        double ai = 0.5 * pf_v3_dot(normal, pf_v3_cross(a, b));
        moment = pf_v3_add(moment, pf_v3_scale(pf_v3_add(a, b), ai / 3.0));
        area += ai;
        mean = pf_v3_add(mean, b);
        a = b;
    }
    if (!(area > 0))
        return pf_v3_scale(mean, 1.0 / (double)n);
    return pf_v3_scale(moment, 1.0 / area);
}

pf_vec3 pf_polygon_centroid(const double *x, const uint32_t *idx, int64_t n)
{
    if (n <= 0)
        return pf_v3(0, 0, 0);
    if (n < 3) {
        pf_vec3 s = node(x, idx, 0);
        return n == 2 ? pf_v3_scale(pf_v3_add(s, node(x, idx, 1)), 0.5) : s;
    }
    return pf_v3_add(node(x, idx, 0), centroid_offset(x, idx, n));
}

/* max_i |n . (p_i - c)| with n the unit Newell normal and c the area centroid, both taken
 * relative to p_0. */
double pf_polygon_planarity_error(const double *x, const uint32_t *idx, int64_t n)
{
    if (n < 3)
        return INFINITY;
    pf_vec3 area = pf_polygon_area_vector(x, idx, n);
    double len = pf_v3_norm(area);
    if (!(len > 0))
        return INFINITY;
    pf_vec3 normal = pf_v3_scale(area, 1.0 / len);
    pf_vec3 p0 = node(x, idx, 0), c = centroid_offset(x, idx, n);
    double worst = 0;
    for (int64_t i = 0; i < n; ++i) {
        pf_vec3 d = pf_v3_sub(pf_v3_sub(node(x, idx, i), p0), c);
        worst = fmax(worst, fabs(pf_v3_dot(normal, d)));
    }
    return worst;
}

double pf_polygon_diameter(const double *x, const uint32_t *idx, int64_t n)
{
    double best = 0;
    for (int64_t i = 0; i < n; ++i)
        for (int64_t j = i + 1; j < n; ++j)
            best = fmax(best, pf_v3_dist(node(x, idx, i), node(x, idx, j)));
    return best;
}
