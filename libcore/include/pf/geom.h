/* pf/geom.h: 3-vectors and 3x3 matrices as values, polar and symmetric eigen decompositions,
 * planar polygon utilities, and a view of a closed polyhedron.
 *
 * All lengths are in model units; nothing here allocates.
 */
#ifndef PF_GEOM_H
#define PF_GEOM_H

#include <math.h>
#include <stdint.h>

#include <pf/base.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pf_vec3 {
    double x, y, z;
} pf_vec3;

/* Row-major: m[row][col]. */
typedef struct pf_mat3 {
    double m[3][3];
} pf_mat3;

static inline pf_vec3 pf_v3(double x, double y, double z) { return (pf_vec3){x, y, z}; }
static inline pf_vec3 pf_v3_load(const double *p) { return (pf_vec3){p[0], p[1], p[2]}; }
static inline void pf_v3_store(pf_vec3 v, double *p)
{
    p[0] = v.x;
    p[1] = v.y;
    p[2] = v.z;
}
static inline pf_vec3 pf_v3_add(pf_vec3 a, pf_vec3 b) { return pf_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline pf_vec3 pf_v3_sub(pf_vec3 a, pf_vec3 b) { return pf_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline pf_vec3 pf_v3_scale(pf_vec3 a, double s) { return pf_v3(a.x * s, a.y * s, a.z * s); }
static inline double pf_v3_dot(pf_vec3 a, pf_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline pf_vec3 pf_v3_cross(pf_vec3 a, pf_vec3 b)
{
    return pf_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double pf_v3_norm(pf_vec3 a) { return sqrt(pf_v3_dot(a, a)); }
static inline double pf_v3_dist(pf_vec3 a, pf_vec3 b) { return pf_v3_norm(pf_v3_sub(a, b)); }
static inline double pf_v3_max_abs(pf_vec3 a)
{
    return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z)));
}
static inline double pf_v3_get(pf_vec3 a, int i) { return i == 0 ? a.x : i == 1 ? a.y : a.z; }
static inline pf_vec3 pf_v3_min(pf_vec3 a, pf_vec3 b)
{
    return pf_v3(fmin(a.x, b.x), fmin(a.y, b.y), fmin(a.z, b.z));
}
static inline pf_vec3 pf_v3_max(pf_vec3 a, pf_vec3 b)
{
    return pf_v3(fmax(a.x, b.x), fmax(a.y, b.y), fmax(a.z, b.z));
}
/* Unit vector along a, or the zero vector when a is zero. */
static inline pf_vec3 pf_v3_normalize(pf_vec3 a)
{
    double n = pf_v3_norm(a);
    return n > 0 ? pf_v3_scale(a, 1.0 / n) : pf_v3(0, 0, 0);
}
static inline int pf_v3_isfinite(pf_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

static inline pf_mat3 pf_m3_identity(void)
{
    return (pf_mat3){{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
}
static inline pf_mat3 pf_m3_mul(pf_mat3 a, pf_mat3 b)
{
    pf_mat3 c;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            c.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
    return c;
}
static inline pf_vec3 pf_m3_mulv(pf_mat3 a, pf_vec3 v)
{
    return pf_v3(a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
                 a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
                 a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z);
}
static inline pf_mat3 pf_m3_transpose(pf_mat3 a)
{
    pf_mat3 t;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            t.m[i][j] = a.m[j][i];
    return t;
}
static inline pf_mat3 pf_m3_add(pf_mat3 a, pf_mat3 b)
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            a.m[i][j] += b.m[i][j];
    return a;
}
static inline pf_mat3 pf_m3_scale(pf_mat3 a, double s)
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            a.m[i][j] *= s;
    return a;
}
static inline double pf_m3_det(pf_mat3 a)
{
    return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
           a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
           a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}
/* Frobenius norm. */
static inline double pf_m3_norm(pf_mat3 a)
{
    double s = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            s += a.m[i][j] * a.m[i][j];
    return sqrt(s);
}

/* Rotation part R of the polar decomposition A = R S (R proper orthogonal, det R = +1, S
 * symmetric). Defined for every finite A: for a reflection (det A < 0) R is the nearest proper
 * rotation (the singular vector of the smallest singular value is flipped); for a singular or
 * near-singular A the missing directions are completed to a right-handed frame; for A = 0 the
 * identity. Accurate to a few ulps of orthogonality. Non-finite input returns the identity. */
pf_mat3 pf_mat3_polar_rotation(pf_mat3 a);

/* Eigen-decomposition of a symmetric matrix (only the upper triangle is read): eigenvalues in
 * ascending order in values[3], unit eigenvectors as the columns of *vectors (right-handed).
 * Jacobi rotations, accurate to a few ulps relative to the largest |eigenvalue|. */
void pf_mat3_sym_eigen(pf_mat3 s, double values[3], pf_mat3 *vectors);

/* Singular value decomposition A = U diag(sigma) V^T, sigma descending and non-negative, U and V
 * orthogonal (not necessarily proper). Used by the polar decomposition and as a test oracle. */
void pf_mat3_svd(pf_mat3 a, pf_mat3 *u, double sigma[3], pf_mat3 *v);

/* ---- planar polygons ------------------------------------------------------------------------
 * A polygon is n >= 3 indices into a node array x[3 * n_nodes], counter-clockwise seen from the
 * side its normal points to. Convex or not. */

/* Newell's area vector: the unit normal times the area (|N| = area for a planar polygon), robust
 * for non-convex and slightly non-planar polygons. */
pf_vec3 pf_polygon_area_vector(const double *x, const uint32_t *idx, int64_t n);
/* Area of the polygon (length of the area vector). */
double pf_polygon_area(const double *x, const uint32_t *idx, int64_t n);
/* Centroid of the polygon's area (not the vertex average); the vertex average if area is 0. */
pf_vec3 pf_polygon_centroid(const double *x, const uint32_t *idx, int64_t n);
/* Largest distance of a vertex from the plane through the area centroid with the Newell normal.
 * Returns INFINITY when the polygon has no area. */
double pf_polygon_planarity_error(const double *x, const uint32_t *idx, int64_t n);
/* Largest distance between two of the polygon's vertices. */
double pf_polygon_diameter(const double *x, const uint32_t *idx, int64_t n);

/* ---- closed polyhedra ------------------------------------------------------------------------
 * A borrowed view of one closed polyhedron with planar faces, every face listed with outward
 * orientation (counter-clockwise seen from outside). Face f has the nodes
 * face_nodes[face_offsets[f] .. face_offsets[f+1]) as indices into x. */
typedef struct pf_polyhedron {
    const double *x;             /* [3 * n_nodes] node coordinates (n_nodes implied by indices) */
    int32_t n_faces;
    const int64_t *face_offsets; /* [n_faces + 1] */
    const uint32_t *face_nodes;  /* [face_offsets[n_faces]] outward-oriented node indices */
} pf_polyhedron;

#ifdef __cplusplus
}
#endif
#endif
