/* pf/basis.h: nodal shape functions of the conforming (CG) method on arbitrary polyhedra.
 *
 * Harmonic paper sec. 4-5. Every element e of a mesh gets one shape function N_i per distinct node
 * i of the element, with
 *   sum_i N_i(x) = 1 and sum_i x_i N_i(x) = x  for every x (to round-off, ~1e-13 relative),
 *   N_i(x_j) = delta_ij                        (exactly for closed forms, to the MFS accuracy
 * else).
 *
 * Closed forms where they exist: barycentric (linear) functions on tetrahedra, trilinear
 * functions on parallelepiped hexahedra (opposite edges parallel and of equal length within a
 * relative tolerance). Every other element gets harmonic shape functions by the method of
 * fundamental solutions (paper eq. 11-14):
 *   1. per mesh face, once and shared by the two elements using it: the 2D harmonic coordinates of
 *      the face's nodes (linear on triangles, bilinear on parallelograms, where these are the
 *      exact harmonic or the neighbouring closed form's restriction; otherwise 2D MFS with log r
 *      kernels plus a polynomial, boundary values linear along the edges);
 *   2. per element: 3D MFS with 1/r kernels plus a polynomial, fitted in the least-squares sense
 *      (eq. 13) to the face functions on the element's boundary.
 * The polynomial part (a departure from eq. 11, which has only the linear polynomial): the linear
 * polynomial plus the harmonic polynomials of degrees 2 and 3 (12 in 3D, 4 in 2D). They are
 * harmonic, so N stays harmonic; they carry the smooth part of the boundary data, which the
 * kernels, placed close to the boundary, resolve only at a high count: the trilinear functions of
 * a box and the bilinear data on its faces are reproduced exactly (to round-off), a corner-cut
 * cube's boundary error falls from 1.4 % to 0.5 % at the same kernels, and half the kernels
 * (edge_samples 2 instead of 3) give 1.1 %, better than the linear polynomial with 3.
 * Samples (kernel positions before the offset, eq. 12): the nodes, points on the edges at one
 * spacing lmax / (edge_samples + 1) (lmax the element's longest edge; at least one inside every
 * edge), and a square grid of that spacing on every face (small faces: a grid of their own
 * scale). Kernels are the samples moved outward by xi * size (size the element diameter, scaled
 * down by local spacing / global spacing where the boundary has finer features, e.g. the
 * facets of a sliced surface); a kernel that lands inside the element or within 0.2 offsets of
 * its boundary (non-convex cells: ray parity against the element's faces) is moved back toward
 * the boundary by halves, then dropped. Collocation points are the same construction
 * collocation_density times denser (m ~ 3n). Faces use the 2D analogue with 2 edge_samples + 3
 * points per edge (2D systems are small, and the face data are the 3D boundary condition: their
 * median largest error along the edges is 0.2 %). The least-squares system is solved once for all
 * k right-hand sides by Householder QR (LAPACK dgeqrt / dgeqrf), by the SVD (dgelsd) when the QR
 * factor is numerically rank-deficient.
 *
 * Accuracy (measured, edge_samples 2, xi 0.1): boundary L2 error 0 (round-off) on a box with MFS
 * forced, 1.1 % on a corner-cut cube, 2.6 % on an octree cell with a split face, 4 % on an
 * L-shaped cell (its reflex edge makes the exact functions singular); 10-17 % on cells of a
 * sliced faceted sphere with uniform samples and per-facet data (pf_basis_params_uniform),
 * whose many small facets make boundary data (hats of the facets' size) the kernels do not
 * resolve: the sliced-cell settings below bring these under 1 %. More edge_samples lower all of
 * these at a cost (corner-cut cube: 0.38 % at 4, 0.18 % at 6, with 2.3x and 5x the kernels). Linear
 * reproduction and partition of unity are exact to round-off whatever the error.
 *
 * Sliced cells (the default, PF_BASIS_SLICED_AUTO). A sliced cell's boundary is partly the cut
 * surface: many small, nearly coplanar facets. Per-facet data (one hat per facet) have a kink
 * across each facet edge, and across an edge whose faces meet at 180 - theta degrees the
 * harmonic extension of a kink needs a gradient of order kink / sin(theta) into the cell, which
 * the kernels resolve only at a high count; short edges (where the surface crosses the grid)
 * make hats of their own small size. Three settings, on by default:
 *   - patch_angle: the element's faces on the mesh boundary (used by no other element) become
 *     one curved patch when their normals lie within patch_angle of their mean. Its data: the 2D
 *     harmonic coordinates of its boundary loop projected on the mean plane (the loop nodes),
 *     minus their values at the nodes inside the patch times those nodes' bumps (the smooth
 *     distance to the loop times a Gaussian, combined to be 1 at their own node and 0 at the
 *     others), then the exactness projection below, so that the data sum to 1 and reproduce x
 *     exactly on the facets. No kinks inside the patch; faces shared with a neighbour keep their
 *     face functions, so conformity is unchanged. A patch with a crease (patch_angle exceeded),
 *     more than one loop or more than 32 inner nodes keeps per-facet data. Cells with a patch
 *     get the kernel offset sliced_xi (0.2) instead of xi;
 *   - grading: samples (kernels and collocation points) of every harmonic cell graded by
 *     feature size, dense and close to the boundary at short edges and small facets, at the
 *     uniform spacing away from them (cells without small features keep about the uniform
 *     count: corner-cut cube 56 kernels either way). On a patch only the loop edges and the
 *     inner nodes' bump widths are features (the facets inside carry no kinks);
 *   - max_kernels: a cell whose graded samples exceed the budget (400) gets a faster grading
 *     rate, the spacing at its features kept, until they fit. Without it a cell of a finely
 *     faceted surface can take minutes (thousands of kernels).
 * Measured on every harmonic cell of the 8 x 16 sphere sliced 6 across (pf-slice --res 6, 128
 * cells; bench/bench_sliced.c): median boundary error 0.76 %, worst decile from 1.8 %, largest
 * 2.6 %, at most 385 kernels per cell; the uniform functions (pf_basis_params_uniform) 12 %;
 * pf_basis_params_accurate (grading on every cell at xi 0.2, no budget) 0.68 %, 1.6 %, 2.4 %.
 * The default 32 x 64 sphere sliced 6 across: 4.5 % median, 11 % worst decile (uniform: 13 %
 * and 19 %): its cells have 50-90 nodes, most with more than 32 inside the patch (per-facet
 * data). The CG simulator keeps the uniform functions: its quadrature degree was chosen so
 * that the quadrature error stays below the basis error of the uniform functions, which the
 * sliced-cell settings are well below (tests/test_cg.c, quadrature_order_converges).
 *
 * Exact partition of unity and linear reproduction. In exact arithmetic the least-squares
 * solution already has both (the data b_i sum to 1 and reproduce x on the boundary, and 1 and x
 * lie in the span of the linear polynomial columns), but an MFS matrix is ill-conditioned, so
 * round-off leaves errors of order cond * eps (1e-10 .. 1e-7). pf removes them by the smallest
 * correction of the k functions that restores both identities: with P the k x 4 matrix of rows (1,
 * x_i) and t(x) = (1, x), the values N(x) (a row of k) are replaced by N(x) + (t(x) - N(x) P) (P^T
 * P)^-1 P^T, which is the same as correcting the polynomial and kernel coefficients (the correction
 * is linear in the basis (kernels, x, 1)), so N stays harmonic and C^1. It moves N by the round-off
 * it removes and leaves sum_i N_i = 1, sum_i x_i N_i = x exact to round-off at every point; the
 * same holds for the gradients (sum grad N_i = 0, sum x_i grad N_i^T = I). Face functions get the
 * 2D analogue, so the 3D boundary data already satisfy both identities.
 *
 * Coincident nodes (closer than merge_tol * size) are merged as the paper says (sec. 5): one joint
 * function is fitted to the summed boundary data; each of the merged nodes gets an equal share of
 * it, so partition of unity and linear reproduction hold and the displacement is the joint one
 * when the nodes move together.
 *
 * Coordinates inside are centred at the element's node centroid and scaled by its radius.
 */
#ifndef PF_BASIS_H
#define PF_BASIS_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Elements with more distinct nodes are refused (PF_ERR_TOO_LARGE): evaluation works on the
 * stack. Sliced and octree cells have at most a few dozen. */
#define PF_BASIS_MAX_NODES 256

typedef enum pf_basis_kind {
    PF_BASIS_TET = 0,      /* closed form: barycentric coordinates */
    PF_BASIS_HEX = 1,      /* closed form: trilinear on a parallelepiped */
    PF_BASIS_HARMONIC = 2, /* MFS harmonic coordinates */
    PF_BASIS_KIND_COUNT = 3
} pf_basis_kind;

const char *pf_basis_kind_name(pf_basis_kind k); /* "tet", "hex", "harmonic" */

/* Which harmonic cells get the sliced-cell settings (graded samples, smooth surface-patch data,
 * sliced_xi; "Sliced cells" above). */
typedef enum pf_basis_sliced {
    PF_BASIS_SLICED_AUTO = 0, /* cells whose mesh-boundary faces form a surface patch (the
                                 default) */
    PF_BASIS_SLICED_ALL = 1,  /* every harmonic cell graded; patch data where a patch forms */
    PF_BASIS_SLICED_OFF = 2   /* none: uniform samples and per-facet data on every cell */
} pf_basis_sliced;

/* Default kernel budget of a graded cell (pf_basis_params.max_kernels). */
#define PF_BASIS_DEFAULT_MAX_KERNELS 400

/* Zero values mean "default". */
typedef struct pf_basis_params {
    double xi;                  /* kernel offset as a fraction of the element (face) diameter,
                                   eq. 12; default 0.1 */
    int32_t edge_samples;       /* kernel samples inside each edge (3-5 in the paper, whose
                                   polynomial is linear only); the face grid uses the same
                                   spacing; default 2 */
    double face_spacing;        /* face grid spacing of kernels relative to the edge sample
                                   spacing (mean edge length / (edge_samples + 1)); default 1 */
    double collocation_density; /* collocation points per kernel (m ~ 3n in the paper); points
                                   per edge and per face area grow by this factor; default 3 */
    double parallel_tol;        /* parallelepiped / parallelogram test: corner mismatch relative
                                   to the diameter; default 1e-9 */
    double merge_tol;           /* coincident nodes: distance relative to the diameter; default
                                   1e-9 */
    double rank_rcond;          /* switch from QR to SVD when the reciprocal condition of the QR
                                   factor falls below this; also the SVD cut-off; default 1e-13 */
    pf_basis_sliced sliced;     /* which cells get the sliced-cell settings below ("Sliced
                                   cells" above); default PF_BASIS_SLICED_AUTO */
    double sliced_xi;           /* kernel offset (as xi) on the cells with the sliced-cell
                                   settings: the graded spacing lets kernels lie farther out;
                                   default 0.2 */
    double grading;             /* graded samples: the spacing at x is
                                   min(uniform, feat_i + grading |x - x_i|) over the nodes i
                                   (feat_i: the shortest edge at node i, or its distance to an
                                   edge of one of its faces when shorter; on a surface patch
                                   only the patch's loop edges and its inner nodes' bump widths
                                   count); default 0.2 */
    double patch_angle;         /* an element's mesh-boundary faces whose normals lie within
                                   this many degrees of their mean get smooth data as one
                                   curved patch; default 60 */
    int32_t max_kernels;        /* kernel budget of a graded cell: when its graded samples
                                   exceed it, the graded spacing is widened (by one factor over
                                   the cell) until they fit or the spacing is uniform; default
                                   PF_BASIS_DEFAULT_MAX_KERNELS, negative: no budget */
    bool force_mfs;             /* harmonic MFS also for tets and parallelepipeds (tests, study) */
    bool no_check_stats;        /* true: of the check-point statistics of pf_basis_elem_stats
                                   only the boundary error (linear and unity errors, min_value
                                   stay 0; counts and setup_ms are kept): the others cost about
                                   as much as the MFS solves and the simulator reads only the
                                   boundary error (its error indicator) */
    pf_progress_hook progress;  /* the phase "basis functions" (elements, taken ones counted),
                                   borrowed during pf_basis_create only; zero: none */
} pf_basis_params;

pf_basis_params pf_basis_params_default(void);
/* The defaults with the sliced-cell settings on every harmonic cell (PF_BASIS_SLICED_ALL), xi
 * 0.2 everywhere and no kernel budget: the settings "Sliced cells" above was first measured at
 * (a cell of a finely faceted surface can take minutes). */
pf_basis_params pf_basis_params_accurate(void);
/* The defaults without the sliced-cell settings (PF_BASIS_SLICED_OFF): uniform samples and
 * per-facet data everywhere. The CG simulator and the embedding weights use them. */
pf_basis_params pf_basis_params_uniform(void);

/* Numerical health of one element's functions. Errors are measured at check points distinct from
 * the collocation points: the nodes, boundary points (half-way between collocation points on
 * edges, a shifted grid on faces) and a 5 x 5 x 5 grid of points inside the element (closed
 * forms: nodes, centroid and midpoints). */
typedef struct pf_basis_elem_stats {
    int32_t n_nodes; /* distinct nodes of the element */
    int32_t n_faces;
    int32_t n_merged;          /* nodes merged into a coincident one */
    int32_t n_kernels;         /* 0 for closed forms */
    int32_t n_collocation;     /* 0 for closed forms */
    int32_t n_kernels_moved;   /* kernels moved back toward the boundary to lie outside */
    int32_t n_kernels_dropped; /* kernels dropped because no offset put them outside */
    bool used_svd;             /* the QR factor was rank-deficient: solved by dgelsd */
    double boundary_error;     /* relative L2 boundary error over all k functions, as a fraction:
                                  sqrt(sum (N_i - b_i)^2 / sum b_i^2) over a uniform grid of face
                                  points (the integral of eq. 13 with equal area per point),
                                  shifted against the collocation grid; b_i the face functions
                                  (0 for closed forms) */
    double linear_error;       /* max |sum_i x_i N_i(x) - x| / diameter and
                                  max |sum_i x_i grad N_i(x)^T - I| over the check points */
    double unity_error;        /* max |sum_i N_i(x) - 1| and max |sum_i grad N_i| * diameter */
    double min_value;          /* smallest N_i over the check points (undershoot when < 0) */
    double setup_ms;           /* wall-clock setup, including the face solves this element did
                                  first (check-point statistics excluded) */
} pf_basis_elem_stats;

/* Shape functions of every element of a mesh. Plain arrays, owned by the struct. */
typedef struct pf_basis {
    int32_t n_elems;
    int64_t *node_offsets;      /* [n_elems + 1]: nodes of element e are nodes[node_offsets[e] ..
                                   node_offsets[e+1]) */
    int32_t *nodes;             /* [node_offsets[n_elems]] mesh node indices, distinct, in order of
                                   first appearance in the element's faces; the order of the values
                                   pf_basis_eval returns */
    int32_t *node_slot;         /* same shape: the node's function inside the element data (corner
                                   bits for hexes, merged group for harmonic elements) */
    uint8_t *kind;              /* [n_elems] pf_basis_kind */
    int64_t *data_offsets;      /* [n_elems + 1] into data */
    double *data;               /* per-element coefficients; layout private to libcore/basis */
    pf_basis_elem_stats *stats; /* [n_elems] */
    int32_t *taken;             /* [n_elems] the element of an old basis whose functions e took
                                   over (pf_basis_create_reusing), -1 where they were built */
    int32_t n_taken;            /* elements whose functions were taken over */
    pf_basis_params params;     /* the parameters, defaults filled in */
    int32_t n_face_mfs;         /* faces solved by 2D MFS (each once, whatever uses it) */
    int32_t n_face_closed;      /* faces with closed-form functions (triangles, parallelograms) */
    double setup_seconds;       /* total wall clock of pf_basis_create */
} pf_basis;

/* Builds the shape functions of every element of m. params may be NULL for the defaults. m is
 * read only and not kept (b borrows nothing). b is overwritten; release it with pf_basis_release.
 * Statuses: PF_ERR_INVALID for an element with fewer than 4 distinct nodes, an index out of
 * range, a face with fewer than 3 nodes or of zero area, or an element whose nodes are coplanar;
 * PF_ERR_TOO_LARGE for more than PF_BASIS_MAX_NODES nodes in an element; PF_ERR_NUMERIC when a
 * least-squares solve fails or gives non-finite coefficients; PF_ERR_NOMEM. The message names the
 * element or face. On failure b is released. */
pf_status pf_basis_create(pf_basis *b, const pf_mesh *m, const pf_basis_params *params,
                          pf_error *err);

/* What a changed mesh (refinement, coarsening, cutting) takes over from the functions of the
 * mesh before: element e of m may take old element source[e]'s functions (-1: build them) when
 * the two are the same element node for node (pf_mesh_elem_same through node_map) and old was
 * built with the same parameters. An element's functions depend only on its faces, their nodes
 * and coordinates (harmonic paper: only the cut elements are computed again), so what is taken
 * is bit for bit what a build would give. */
typedef struct pf_basis_reuse {
    const pf_basis *old;
    const pf_mesh *old_mesh; /* the mesh old was built on */
    const int32_t *source;   /* [m->n_elems] candidate old element of each element, or -1 */
    const int32_t *node_map; /* [old_mesh->n_nodes] the m index of each old node, -1 for one
                                removed; NULL: the same indices */
} pf_basis_reuse;

/* pf_basis_create, copying from reuse->old (NULL: nothing) the functions, node slots and
 * statistics (setup_ms 0) of every element whose candidate is the same element (b->taken,
 * b->n_taken). m
 * must be derived. Statuses as pf_basis_create. */
pf_status pf_basis_create_reusing(pf_basis *b, const pf_mesh *m, const pf_basis_params *params,
                                  const pf_basis_reuse *reuse, pf_error *err);

/* Frees every array and zeroes the struct. Safe on a zeroed struct. */
void pf_basis_release(pf_basis *b);

/* Number of nodes (functions) of element e; its mesh node indices in *nodes (borrowed from b). */
static inline int32_t pf_basis_elem_nodes(const pf_basis *b, int32_t e, const int32_t **nodes)
{
    if (nodes)
        *nodes = b->nodes + b->node_offsets[e];
    return (int32_t)(b->node_offsets[e + 1] - b->node_offsets[e]);
}

static inline pf_basis_kind pf_basis_elem_kind(const pf_basis *b, int32_t e)
{
    return (pf_basis_kind)b->kind[e];
}

/* Values and gradients of element e's functions at x (model coordinates): n[i] = N_i(x),
 * grad[3 i + d] = dN_i/dx_d (1 / model length), i over the element's nodes in the order of
 * pf_basis_elem_nodes. Either output may be NULL. Defined everywhere (the closed forms extend
 * linearly / trilinearly, harmonic functions away from the kernels), meaningful inside the
 * element. Reentrant; allocates nothing. */
void pf_basis_eval(const pf_basis *b, int32_t e, pf_vec3 x, double *n, double *grad);

/* Points per pf_basis_eval_block call at most. */
#define PF_BASIS_EVAL_BLOCK 64

/* Doubles of scratch pf_basis_eval_block needs for element e (0 for closed forms). */
size_t pf_basis_eval_block_scratch(const pf_basis *b, int32_t e);

/* pf_basis_eval at n <= PF_BASIS_EVAL_BLOCK points x [3 n] (model coordinates) at once:
 * vals [n k] with vals[p k + i] = N_i(x_p), grads [n 3 k] with grads[3 (p k + i) + d] =
 * dN_i/dx_d at x_p (k = pf_basis_elem_nodes); grads may be NULL (values only, a quarter of
 * the work). For harmonic elements one dense product (BLAS
 * dgemm) evaluates every kernel at every point: the same values as pf_basis_eval up to
 * round-off (summation order). scratch: pf_basis_eval_block_scratch(b, e) doubles, caller
 * owned. Allocates nothing. */
void pf_basis_eval_block(const pf_basis *b, int32_t e, int32_t n, const double *x, double *vals,
                         double *grads, double *scratch);

/* Median and maximum of the per-element statistics over elements of the given kind (or every
 * kind for kind < 0): a summary for reports. Medians of an empty selection are 0. */
typedef struct pf_basis_summary {
    int32_t n_elems;
    int32_t n_by_kind[PF_BASIS_KIND_COUNT];
    double max_linear_error, max_unity_error;
    double median_boundary_error, max_boundary_error; /* over harmonic elements */
    double min_value;
    double median_setup_ms, max_setup_ms; /* over harmonic elements */
    int64_t n_kernels, n_collocation;     /* totals */
} pf_basis_summary;

/* Summary of b's statistics. Needs scratch for the medians: PF_ERR_NOMEM if it cannot get it. */
pf_status pf_basis_summarize(const pf_basis *b, pf_basis_summary *out, pf_error *err);

#ifdef __cplusplus
}
#endif

#endif
