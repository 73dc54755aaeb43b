/* pf/geom.h: 3-vectors and 3x3 matrices as values, polar and symmetric eigen decompositions,
 * planar polygon utilities, and a view of a closed polyhedron.
 *
 * All lengths are in model units; nothing here allocates.
 */
#ifndef PF_GEOM_H
#define PF_GEOM_H

#include <math.h>
#include <stdbool.h>
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

/* Inverse of a by the adjugate, A^-1 = adj(A) / det(A). Stores det(A) in *det when det is not
 * NULL. A singular matrix (det exactly 0, or 1/det not finite) returns the zero matrix; the
 * caller decides from *det, relative to its own scale, whether the inverse is usable. */
static inline pf_mat3 pf_m3_inverse(pf_mat3 a, double *det)
{
    pf_mat3 c;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
            /* cyclic index order makes the cofactor sign implicit; c = adj(A) = cof(A)^T */
            c.m[j][i] = a.m[i1][j1] * a.m[i2][j2] - a.m[i1][j2] * a.m[i2][j1];
        }
    double d = a.m[0][0] * c.m[0][0] + a.m[0][1] * c.m[1][0] + a.m[0][2] * c.m[2][0];
    if (det)
        *det = d;
    double inv = 1.0 / d;
    if (d == 0 || !isfinite(inv))
        return (pf_mat3){{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}};
    return pf_m3_scale(c, inv);
}

/* Rotation part R of the polar decomposition A = R S (R proper orthogonal, det R = +1, S
 * symmetric). Defined for every finite A: for a reflection (det A < 0) R is the nearest proper
 * rotation (the singular vector of the smallest singular value is flipped); for a singular or
 * near-singular A the missing directions are completed to a right-handed frame; for A = 0 the
 * identity. Accurate to a few ulps of orthogonality. Non-finite input returns the identity. */
pf_mat3 pf_mat3_polar_rotation(pf_mat3 a);

/* The same rotation found from a guess close to it (the last time step's): Newton's method on
 * the rotation, R <- R Cay(w) (the Cayley rotation, exp([w]x) to second order) with w solving
 * sym(tr(M) I - M) w = axial(M - M^T), M = R^T A, quadratic from the guess's error: from a guess
 * 1e-3 rad off, three iterations, about 0.65 of the SVD's time. Falls back
 * to pf_mat3_polar_rotation when the guess is not finite, when Newton does not converge within 8
 * iterations, or when the rotation is ill-determined (A of rank 1 or about: the pairwise sums of
 * its singular values differ by more than 1e3). Agrees with pf_mat3_polar_rotation to about
 * 1e-15 times that condition. *iterations (may be NULL): Newton's iterations, -1 after a
 * fall-back. */
pf_mat3 pf_mat3_polar_rotation_near(pf_mat3 a, pf_mat3 guess, int32_t *iterations);

/* Eigen-decomposition of a symmetric matrix (only the upper triangle is read): eigenvalues in
 * ascending order in values[3], unit eigenvectors as the columns of *vectors (right-handed).
 * Jacobi rotations, accurate to a few ulps relative to the largest |eigenvalue|. Non-finite
 * input gives NaN values and the identity. */
void pf_mat3_sym_eigen(pf_mat3 s, double values[3], pf_mat3 *vectors);

/* Singular value decomposition A = U diag(sigma) V^T, sigma descending and non-negative, U and V
 * orthogonal (not necessarily proper). One-sided Jacobi: U diag(sigma) V^T reproduces A to a few
 * ulps of |A|, U and V are orthogonal to a few ulps, for any rank and any magnitude of A. Where
 * singular values vanish, the missing columns of U complete an orthonormal frame. Used by the
 * polar decomposition and as a test oracle. Non-finite input gives sigma = NaN, U = V = I. */
void pf_mat3_svd(pf_mat3 a, pf_mat3 *u, double sigma[3], pf_mat3 *v);

/* Von Mises equivalent stress of a symmetric stress s = (xx yy zz xy yz zx), in the stress's unit:
 * sqrt(((sxx-syy)^2 + (syy-szz)^2 + (szz-sxx)^2) / 2 + 3 (sxy^2 + syz^2 + szx^2)), which is
 * sqrt(((s1-s2)^2 + (s2-s3)^2 + (s3-s1)^2) / 2) in the principal stresses s1, s2, s3. */
double pf_von_mises(const double s[6]);

/* The corotated linear stress of the deformation gradient f (Mueller and Gross 2004; DG paper
 * sec. 6.1): with R the rotation of f's polar decomposition, the strain sym(R^T f) - I and the
 * isotropic stress lambda tr(eps) I + 2 mu eps, as (xx yy zz xy yz zx). Expressed in the rest
 * frame: its principal directions are directions of the undeformed body. */
void pf_corotated_stress(pf_mat3 f, double lambda, double mu, double sigma[6]);

/* The principal stress of largest magnitude of s = (xx yy zz xy yz zx) (its sign kept), and its
 * unit direction (may be NULL). */
double pf_principal_stress(const double s[6], pf_vec3 *direction);

/* ---- planes ----------------------------------------------------------------------------------
 * The points p with dot(n, p) = d; n is a unit vector, so dot(n, p) - d is a signed distance in
 * model units, positive on the side n points to. */
typedef struct pf_plane {
    pf_vec3 n; /* unit normal */
    double d;  /* offset along n: dot(n, p) for every p on the plane */
} pf_plane;

/* The plane through p with normal direction n (normalised here, any finite length > 0). A zero or
 * non-finite n gives n = 0, d = 0: every point is then at distance 0. */
pf_plane pf_plane_from_point_normal(pf_vec3 p, pf_vec3 n);

/* Signed distance of q from the plane (model units, positive on the normal's side). Absolute
 * rounding error about |q| * 1e-16: centre coordinates first when |q| is far above the model
 * size. */
static inline double pf_plane_signed_distance(pf_plane pl, pf_vec3 q)
{
    return pf_v3_dot(pl.n, q) - pl.d;
}

/* Side of q: +1 when its signed distance exceeds tol, -1 when below -tol, 0 otherwise (on the
 * plane within tol, model units, tol >= 0). A NaN distance classifies as 0: check inputs for
 * finiteness first. Classify each vertex once and reuse the result in every later decision. */
static inline int pf_plane_classify(pf_plane pl, pf_vec3 q, double tol)
{
    double s = pf_plane_signed_distance(pl, q);
    return s > tol ? 1 : s < -tol ? -1 : 0;
}

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

/* Triangulates the planar polygon idx[0 .. n) into x (counter-clockwise about its Newell normal)
 * into n - 2 triangles tri[3 (n - 2)] of positions 0 .. n-1 within the polygon, each
 * counter-clockwise about the same normal: a fan when the polygon is convex, ear clipping in the
 * polygon's plane otherwise. edges[n - 2] (may be NULL) receives the polygon-edge bits as in
 * pf_boundary (pf/mesh.h). Needs n >= 3 and scratch for 2 n doubles and 2 n int32_t plus alignment (the arena
 * is reset afterwards). PF_ERR_INVALID for n < 3, PF_ERR_NOMEM when the arena is too small. */
pf_status pf_polygon_triangulate(const double *x, const uint32_t *idx, int32_t n, pf_arena *scratch,
                                uint32_t *tri, uint8_t *edges, pf_error *err);

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

/* Signed volume enclosed by the polyhedron (model units cubed): positive when every face is
 * oriented outward, negative when every face is reversed. Exact for planar faces, convex or not,
 * and non-convex polyhedra (divergence theorem over fan triangles of each face, relative to the
 * first node of the first face so coordinate offsets cost no digits). 0 when n_faces is 0. */
double pf_polyhedron_volume(const pf_polyhedron *p);

/* Axis-aligned bounding box of the nodes the faces reference, in *lo and *hi. Both are the zero
 * vector when the polyhedron has no face nodes. */
void pf_polyhedron_bounds(const pf_polyhedron *p, pf_vec3 *lo, pf_vec3 *hi);

/* ---- ray queries against a triangle surface ----------------------------------------------------
 * An opaque engine over Embree 3 (single precision inside, coordinates taken relative to the
 * surface's bounding-box centre to keep the float error small). Thread-safe for queries. */
typedef struct pf_rayscene pf_rayscene;

/* One crossing of a line with the surface: parameter t along the line and the side it crosses
 * from: +1 when the line leaves the solid (dot(normal, dir) > 0), -1 when it enters. */
typedef struct pf_crossing {
    double t;
    int sign;
} pf_crossing;

/* Builds the scene over triangles tri[3 nt] into vertices x[3 nv] (copied; nothing borrowed).
 * PF_ERR_INVALID on an index out of range or a non-finite coordinate. */
pf_status pf_rayscene_create(pf_rayscene **rs, const double *x, int32_t nv, const uint32_t *tri,
                             int32_t nt, pf_error *err);
void pf_rayscene_destroy(pf_rayscene **rs);

/* Every crossing of the line org + t dir (dir need not be unit), 0 <= t <= t_max, sorted by t,
 * written to out[0 .. *n) (at most cap; when *n > cap nothing is sorted: call again with an array
 * of *n). Hits of the same sign whose t differ by at most merge_eps are one crossing (the line
 * passed through an edge or vertex shared by several triangles). */
pf_status pf_rayscene_crossings(const pf_rayscene *rs, pf_vec3 org, pf_vec3 dir, double t_max,
                                double merge_eps, pf_crossing *out, int64_t cap, int64_t *n,
                                pf_error *err);

/* The nearest point of a surface to a query point (pf_rayscene_closest). */
typedef struct pf_closest {
    pf_vec3 point;  /* on the surface, model units */
    pf_vec3 normal; /* unit normal of the triangle holding it (right-handed corner order: outward
                       for a counter-clockwise surface) */
    int32_t tri;    /* that triangle */
    double dist;    /* |query - point| */
} pf_closest;

/* The surface point nearest to p within max_dist (> 0), through Embree's point query over the
 * BVH (rtcPointQuery) with distances computed in double precision from the original vertices: the
 * float BVH only prunes, its radius widened beyond float rounding. Where several triangles are
 * equally near (p's nearest point is an edge or a vertex), the one whose normal is most nearly
 * parallel to p - point is kept, so the sign of dot(p - point, normal) tells the side of a closed
 * surface at convex and concave edges alike. Returns false (out untouched) when no triangle lies
 * within max_dist. Thread-safe. */
bool pf_rayscene_closest(const pf_rayscene *rs, pf_vec3 p, double max_dist, pf_closest *out);

/* The point of triangle (a, b, c) nearest to p (its Voronoi regions: a corner, an edge or the
 * interior). */
pf_vec3 pf_triangle_closest_point(pf_vec3 p, pf_vec3 a, pf_vec3 b, pf_vec3 c);

/* Generalised winding number of the triangles tri[3 nt] (into x) at p: the sum of their signed
 * solid angles over 4 pi (Van Oosterom-Strackee). 1 inside a closed outward surface, 0 outside,
 * and a smooth inside-ness for open surfaces (threshold 1/2). O(nt) per query. */
double pf_winding_number(const double *x, const uint32_t *tri, int32_t nt, pf_vec3 p);

/* The same number in O(log nt) per query: a tree over the triangles whose far clusters count by
 * their dipole (Barill et al. 2018, first order, clusters expanded beyond 4 times their radius).
 * Absolute error below 2e-2 of a full turn (1.4e-2 measured on spheres and tori), which is what an
 * inside test at 1/2 needs. x and tri are borrowed for the tree's lifetime. PF_ERR_INVALID on an
 * empty surface or an index out of range, PF_ERR_NOMEM. */
typedef struct pf_winding_tree pf_winding_tree;
pf_status pf_winding_tree_create(pf_winding_tree **wt, const double *x, int32_t nv,
                                 const uint32_t *tri, int32_t nt, pf_error *err);
void pf_winding_tree_destroy(pf_winding_tree **wt);
double pf_winding_tree_eval(const pf_winding_tree *wt, pf_vec3 p);

#ifdef __cplusplus
}
#endif
#endif
