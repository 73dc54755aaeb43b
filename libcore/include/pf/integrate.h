/* pf/integrate.h: exact polynomial moments over closed polyhedra and planar polygons.
 *
 * The moments of an element are the integrals of every monomial xhat^a yhat^b zhat^c of total
 * degree a + b + c <= degree, in the element's local frame xhat = (x - center) / scale. They are
 * exact up to rounding for any planar faces, convex or not, and any closed polyhedron, convex
 * or not (divergence theorem, Mirtich 1996 and DG paper appendix A, reduced to edge terms).
 * Local coordinates keep the result accurate when the element sits far from the origin: only the
 * frame carries the offset. Nothing here allocates.
 */
#ifndef PF_INTEGRATE_H
#define PF_INTEGRATE_H

#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Highest total degree a moment vector holds: DG bases of degree 2 need 2p + 2 = 6, the rest is
 * headroom for degree-3 bases' mass matrices (2p = 6) plus derivatives. */
#define PF_MOMENT_MAX_DEGREE 8
/* Entries of a moment vector of degree PF_MOMENT_MAX_DEGREE: (8+1)(8+2)(8+3)/6. */
#define PF_MOMENT_MAX_COUNT 165

/* Number of monomials of total degree <= degree in 3 variables, (d+1)(d+2)(d+3)/6; 0 for a
 * negative degree. */
int pf_moment_count(int degree);

/* Index of x^a y^b z^c in the graded ordering: every monomial of degree 0, then degree 1
 * (x y z), then degree 2 (xx xy xz yy yz zz), ...; inside a degree, descending powers of x, then
 * of y. -1 when an exponent is negative. */
int pf_moment_index(int a, int b, int c);

/* Exponents of the monomial at index (0 <= index < pf_moment_count(PF_MOMENT_MAX_DEGREE)); all
 * three set to -1 for an index outside that range. */
void pf_moment_exponents(int index, int *a, int *b, int *c);

/* Values of every monomial of degree <= degree (0..PF_MOMENT_MAX_DEGREE) at the local point p,
 * in the graded ordering: v[pf_moment_index(a, b, c)] = p.x^a p.y^b p.z^c, v has
 * pf_moment_count(degree) entries. One multiplication per entry. */
void pf_moment_monomials(pf_vec3 p, int degree, double *v);

/* Local frame of an element: xhat = (x - center) / scale, scale > 0 (model units). */
typedef struct pf_frame {
    pf_vec3 center;
    double scale;
} pf_frame;

/* The polyhedron's frame: center = centre of the bounding box of its face nodes, scale = half
 * the box diagonal, so every node has |xhat| <= 1. Cheap (one pass over the nodes, no
 * integration) and, unlike the centroid, defined before any moment is known. A polyhedron with
 * no extent (no nodes, or all nodes equal) gets scale 1. */
pf_frame pf_frame_of_polyhedron(const pf_polyhedron *p);

/* Volume moments m[pf_moment_index(a, b, c)] = int_P xhat^a yhat^b zhat^c dV for all
 * a + b + c <= degree, where xhat is in the given frame and dV is the physical volume element
 * (m[0] is the volume in model units cubed). m has pf_moment_count(degree) entries.
 * The polyhedron is borrowed for the call; its faces must be planar and outward (a fully
 * reversed surface gives the negated moments). Exact up to rounding: the error is a few units
 * of 1e-16 times vol(P) * max|xhat|^d for the moments of degree d.
 * PF_ERR_INVALID for degree outside [0, PF_MOMENT_MAX_DEGREE], a NULL argument, a polyhedron
 * without faces, a face with fewer than 3 nodes, a scale that is not finite and positive, or
 * non-finite node coordinates (m is then unspecified). */
pf_status pf_polyhedron_moments(const pf_polyhedron *p, const pf_frame *frame, int degree,
                                double *m, pf_error *err);

/* Area moments m[pf_moment_index(a, b, c)] = int_F xhat^a yhat^b zhat^c dA of the planar
 * polygon with the n node indices idx into x[3 * n_nodes] (dA physical: m[0] is the area),
 * convex or not, either orientation (the value does not depend on it). A polygon with no area
 * (collinear nodes) has all moments 0. Same errors as pf_polyhedron_moments, plus n < 3. */
pf_status pf_polygon_moments(const double *x, const uint32_t *idx, int64_t n, const pf_frame *frame,
                             int degree, double *m, pf_error *err);

/* ==== quadrature for non-polynomial integrands ================================================ */

/* n-point Gauss-Legendre rule on [0, 1] (1 <= n <= 16): exact for polynomials of degree 2n - 1;
 * weights sum to 1. */
void pf_gauss_legendre(int n, double *nodes, double *weights);

/* Points x [3 n] and weights w [n] (model units cubed) of a rule over a polyhedron. */
typedef struct pf_quadrature {
    int64_t n;
    double *x;
    double *w;
} pf_quadrature;
void pf_quadrature_release(pf_quadrature *q);

/* A rule exact for polynomials of degree <= degree (0..29) over the closed polyhedron p (nodes
 * x[3 n_nodes]), convex or not: a cone of tetrahedra from a point that sees every face from
 * inside (the node average when p is convex), else p cut by the planes of its reflex faces into
 * pieces that have one; each tetrahedron a collapsed Gauss product rule. All weights positive. q
 * zeroed first; PF_ERR_INVALID for a bad degree or no faces, PF_ERR_NUMERIC when the convex
 * decomposition fails. */
pf_status pf_polyhedron_quadrature(const pf_polyhedron *p, int32_t n_nodes, int degree,
                                   pf_quadrature *q, pf_error *err);

/* The tetrahedra pf_polyhedron_quadrature integrates over: the same cones of p (convex, star-shaped
 * or cut into such pieces by its reflex face planes), a decomposition whose volumes sum to p's
 * (pf_polyhedron_volume) up to rounding. On success *tets [12 *n_tets] is allocated with pf_alloc
 * (the caller frees it): tetrahedron t has vertices tets[12 t ..], each vertex either a node of p
 * (coordinates copied bit for bit) or a new point inside p or on its boundary, ordered so that
 * det[v1 - v0, v2 - v0, v3 - v0] > 0 (VTK_TETRA's order). Flat ones (|det| at most 1e-12 d^3, d
 * the diagonal of p's bounding box: a zero volume's rounding) are left out. Statuses as
 * pf_polyhedron_quadrature. */
pf_status pf_polyhedron_tetrahedra(const pf_polyhedron *p, int32_t n_nodes, double **tets,
                                   int64_t *n_tets, pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
