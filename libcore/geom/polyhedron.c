/* Volume and bounds of a closed polyhedron given as outward-oriented planar faces. */
#include <pf/geom.h>

static pf_vec3 node(const pf_polyhedron *p, int64_t k)
{
    return pf_v3_load(p->x + 3 * (size_t)p->face_nodes[k]);
}

/* Divergence theorem with F = (x - r) / 3: V = sum_faces int_f (x - r) . n dA / 3. Fan each face
 * from its first node q_0 into triangles (q_0, q_i, q_{i+1}); every triangle with the reference
 * point r spans a signed tetrahedron det(q_0 - r, q_i - r, q_{i+1} - r) / 6. Triangles of a
 * non-convex face that fold back carry negative area and cancel exactly, so the sum is the
 * enclosed volume for any planar faces and any (also non-convex) closed surface. Taking r on the
 * polyhedron keeps the differences small at large coordinate offsets. */
double pf_polyhedron_volume(const pf_polyhedron *p)
{
    if (p->n_faces <= 0 || p->face_offsets[p->n_faces] == p->face_offsets[0])
        return 0;
    pf_vec3 r = node(p, p->face_offsets[0]);
    double six_v = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
        if (k1 - k0 < 3)
            continue;
        pf_vec3 q0 = pf_v3_sub(node(p, k0), r);
        pf_vec3 a = pf_v3_sub(node(p, k0 + 1), r);
        for (int64_t k = k0 + 2; k < k1; ++k) {
            pf_vec3 b = pf_v3_sub(node(p, k), r);
            six_v += pf_v3_dot(q0, pf_v3_cross(a, b));
            a = b;
        }
    }
    return six_v / 6.0;
}

void pf_polyhedron_bounds(const pf_polyhedron *p, pf_vec3 *lo, pf_vec3 *hi)
{
    *lo = *hi = pf_v3(0, 0, 0);
    if (p->n_faces <= 0)
        return;
    int64_t k0 = p->face_offsets[0], k1 = p->face_offsets[p->n_faces];
    for (int64_t k = k0; k < k1; ++k) {
        pf_vec3 q = node(p, k);
        *lo = k > k0 ? pf_v3_min(*lo, q) : q;
        *hi = k > k0 ? pf_v3_max(*hi, q) : q;
    }
}
