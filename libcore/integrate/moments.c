/* Exact monomial moments over planar polygons and closed polyhedra.
 *
 * Mirtich (1996) and the DG paper's appendix A reduce a volume integral to face integrals by the
 * divergence theorem and a face integral to edge integrals by Green's theorem in a projection
 * plane, one axis per monomial. We use the same two reductions with a different vector field,
 * Euler's identity for homogeneous functions, which needs no projection axis and never raises
 * the degree (the derivation of Lasserre 1998 and Chin, Lasserre, Sukumar 2015):
 *
 * Let g = x^a y^b z^c with d = a + b + c, in local coordinates (the element frame), so
 * x . grad g = d g.
 *
 * Volume -> faces. div(x g) = 3 g + x . grad g = (d + 3) g. On the plane of face f,
 * x . n_f = h_f (unit outward normal n_f, signed offset h_f of the plane from the frame
 * centre), so the divergence theorem gives
 *     int_P g dV = 1/(d + 3) sum_f h_f int_f g dA.                                         (1)
 *
 * Face -> edges. Let o = h_f n_f, the foot of the centre on the plane; x - o is tangent to the
 * plane for x on f. The in-plane divergence of V = (x - o) g is
 *     div_f V = 2 g + (x - o) . grad g = (d + 2) g - h_f n_f . grad g,
 * and V . nu_e on edge e (outward in-plane normal nu_e) is the constant delta_e = (p - o) . nu_e
 * = p . nu_e for either end p of e. Green's theorem in the plane gives
 *     int_f g dA = 1/(d + 2) [ sum_e delta_e int_e g ds
 *                              + h_f (n_x a int_f x^(a-1) y^b z^c dA + n_y b ... + n_z c ...) ],
 * a recursion over the degree: face moments of degree d need the edge integrals of degree d and
 * the face moments of degree d - 1.                                                          (2)
 * For the edge from p to q of a face listed counter-clockwise about n_f, nu_e = (q - p) x n_f /
 * |q - p|, so delta_e |q - p| = p . ((q - p) x n_f) = n_f . (p x q): no square root, and
 *     delta_e int_e g ds = n_f . (p x q) * mean of g over the segment,                       (3)
 * the mean taken exactly by Gauss-Legendre with k points, exact for degree 2k - 1 >= d, so
 * k = ceil((d + 1) / 2) (5 points for degree 8).
 *
 * Neither reduction cares about convexity: Green's and the divergence theorem hold for any
 * simple polygon and any closed surface, folded fan triangles never appear. Reversing a polygon
 * flips n_f, h_f and the edge directions together, so (2) does not depend on the orientation.
 * All quantities are O(1) in the frame (|x| <= 1 for the polyhedron's own frame), nothing is
 * divided except by d + 2 and d + 3, so rounding stays at a few u of vol * max|x|^d. */
#include <math.h>

#include <pf/integrate.h>

/* Gauss-Legendre nodes and weights on [-1, 1] for k = 1..5 points (non-negative nodes; the rule
 * is symmetric), weights halved so that they sum to 1 and the rule returns the segment mean. */
static const double GL_NODE[5][3] = {
    {0.0},
    {0.57735026918962576451},
    {0.0, 0.77459666924148337704},
    {0.33998104358485626480, 0.86113631159405257522},
    {0.0, 0.53846931010568309104, 0.90617984593866399280},
};
static const double GL_HALF_WEIGHT[5][3] = {
    {1.0},
    {0.5},
    {0.44444444444444444444, 0.27777777777777777778},
    {0.32607257743127307131, 0.17392742256872692869},
    {0.28444444444444444444, 0.23931433524968323402, 0.11846344252809454376},
};

/* pf_moment_index, inlined for the recursion's inner loop (see monomial.c for the formula). */
static inline int index_of(int a, int b, int c)
{
    int d = a + b + c;
    return d * (d + 1) * (d + 2) / 6 + (d - a) * (d - a + 1) / 2 + c;
}

typedef struct local_map {
    pf_vec3 center;
    double inv_scale;
} local_map;

static pf_vec3 local_node(const double *x, uint32_t i, local_map map)
{
    return pf_v3_scale(pf_v3_sub(pf_v3_load(x + 3 * (size_t)i), map.center), map.inv_scale);
}

/* Adds coef * mean over the segment [p, q] of every monomial of degree <= degree to e. */
static void add_edge_means(pf_vec3 p, pf_vec3 q, double coef, int degree, int count, double *e)
{
    double v[PF_MOMENT_MAX_COUNT];
    int k = (degree + 2) / 2; /* ceil((degree + 1) / 2) points */
    pf_vec3 mid = pf_v3_scale(pf_v3_add(p, q), 0.5), half = pf_v3_scale(pf_v3_sub(q, p), 0.5);
    for (int j = 0; j < (k + 1) / 2; ++j) {
        double xi = GL_NODE[k - 1][j], w = coef * GL_HALF_WEIGHT[k - 1][j];
        int sides = (k % 2 == 1 && j == 0) ? 1 : 2; /* the middle node of an odd rule once */
        for (int s = 0; s < sides; ++s) {
            pf_vec3 pt = pf_v3_add(mid, pf_v3_scale(half, s == 0 ? xi : -xi));
            pf_moment_monomials(pt, degree, v);
            for (int i = 0; i < count; ++i)
                e[i] += w * v[i];
        }
    }
}

/* Face moments in local units (area in units of scale^2) by (2)-(3); returns h_f. A face without
 * area has all moments 0 (and h_f = 0); non-finite nodes give NaN. */
static double face_moments(const double *x, const uint32_t *idx, int64_t n, local_map map,
                           int degree, double *fm)
{
    int count = pf_moment_count(degree);
    for (int i = 0; i < count; ++i)
        fm[i] = 0;
    /* Newell area vector, fanned from the first node (local coordinates are O(1)) */
    pf_vec3 q0 = local_node(x, idx[0], map), area = pf_v3(0, 0, 0);
    pf_vec3 a = pf_v3_sub(local_node(x, idx[1], map), q0);
    for (int64_t i = 2; i < n; ++i) {
        pf_vec3 b = pf_v3_sub(local_node(x, idx[i], map), q0);
        area = pf_v3_add(area, pf_v3_cross(a, b));
        a = b;
    }
    double len = pf_v3_norm(area);
    if (!isfinite(len)) { /* non-finite nodes: poison the result for the caller's check */
        fm[0] = NAN;
        return NAN;
    }
    if (!(len > 0))
        return 0;
    pf_vec3 nf = pf_v3_scale(area, 1.0 / len);
    /* h_f as the mean offset of the nodes: exact for a planar face, least squares otherwise */
    double h = 0;
    pf_vec3 p = local_node(x, idx[n - 1], map);
    for (int64_t i = 0; i < n; ++i) {
        pf_vec3 q = local_node(x, idx[i], map);
        h += pf_v3_dot(nf, q);
        add_edge_means(p, q, pf_v3_dot(nf, pf_v3_cross(p, q)), degree, count, fm);
        p = q;
    }
    h /= (double)n;
    /* (2), degree by degree: fm holds the edge sums, completed in place in graded order, so the
     * lower-degree face moments are final when a degree reads them */
    for (int d = 0; d <= degree; ++d) {
        double inv = 1.0 / (d + 2);
        for (int ex = d, i = pf_moment_count(d - 1); ex >= 0; --ex)
            for (int ey = d - ex; ey >= 0; --ey, ++i) {
                int ez = d - ex - ey;
                double grad = 0;
                if (ex > 0)
                    grad += nf.x * ex * fm[index_of(ex - 1, ey, ez)];
                if (ey > 0)
                    grad += nf.y * ey * fm[index_of(ex, ey - 1, ez)];
                if (ez > 0)
                    grad += nf.z * ez * fm[index_of(ex, ey, ez - 1)];
                fm[i] = (fm[i] + h * grad) * inv;
            }
    }
    return h;
}

static pf_status check_common(const pf_frame *frame, int degree, const double *m, pf_error *err)
{
    PF_CHECK(degree >= 0 && degree <= PF_MOMENT_MAX_DEGREE, err, PF_ERR_INVALID,
             "moment degree %d outside [0, %d]", degree, PF_MOMENT_MAX_DEGREE);
    PF_CHECK(frame && m, err, PF_ERR_INVALID, "moments: NULL frame or output");
    PF_CHECK(isfinite(frame->scale) && frame->scale > 0 && pf_v3_isfinite(frame->center), err,
             PF_ERR_INVALID, "moments: frame scale %g or centre not finite and positive",
             frame->scale);
    return PF_OK;
}

static pf_status check_finite(const double *m, int count, pf_error *err)
{
    for (int i = 0; i < count; ++i)
        PF_CHECK(isfinite(m[i]), err, PF_ERR_INVALID,
                 "moments: non-finite result (non-finite node coordinates?)");
    return PF_OK;
}

pf_status pf_polygon_moments(const double *x, const uint32_t *idx, int64_t n, const pf_frame *frame,
                             int degree, double *m, pf_error *err)
{
    PF_TRY(check_common(frame, degree, m, err));
    PF_CHECK(x && idx, err, PF_ERR_INVALID, "polygon moments: NULL nodes or indices");
    PF_CHECK(n >= 3, err, PF_ERR_INVALID, "polygon moments: %lld nodes, need 3", (long long)n);
    local_map map = {frame->center, 1.0 / frame->scale};
    face_moments(x, idx, n, map, degree, m);
    int count = pf_moment_count(degree);
    double area_unit = frame->scale * frame->scale;
    for (int i = 0; i < count; ++i)
        m[i] *= area_unit;
    return check_finite(m, count, err);
}

pf_status pf_polyhedron_moments(const pf_polyhedron *p, const pf_frame *frame, int degree,
                                double *m, pf_error *err)
{
    PF_TRY(check_common(frame, degree, m, err));
    PF_CHECK(p && p->x && p->face_offsets && p->face_nodes, err, PF_ERR_INVALID,
             "polyhedron moments: NULL polyhedron or arrays");
    PF_CHECK(p->n_faces > 0, err, PF_ERR_INVALID, "polyhedron moments: no faces");
    for (int32_t f = 0; f < p->n_faces; ++f)
        PF_CHECK(p->face_offsets[f + 1] - p->face_offsets[f] >= 3, err, PF_ERR_INVALID,
                 "polyhedron moments: face %d has %lld nodes", (int)f,
                 (long long)(p->face_offsets[f + 1] - p->face_offsets[f]));
    int count = pf_moment_count(degree);
    local_map map = {frame->center, 1.0 / frame->scale};
    double fm[PF_MOMENT_MAX_COUNT];
    for (int i = 0; i < count; ++i)
        m[i] = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f];
        double h =
            face_moments(p->x, p->face_nodes + k0, p->face_offsets[f + 1] - k0, map, degree, fm);
        for (int i = 0; i < count; ++i)
            m[i] += h * fm[i];
    }
    /* (1), and local volume units (scale^3) to physical ones */
    double volume_unit = frame->scale * frame->scale * frame->scale;
    for (int d = 0, i = 0; d <= degree; ++d) {
        double factor = volume_unit / (d + 3);
        for (int end = pf_moment_count(d); i < end; ++i)
            m[i] *= factor;
    }
    return check_finite(m, count, err);
}
