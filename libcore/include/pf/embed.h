/* pf/embed.h: embedding weights of a fine triangle surface in a simulation mesh (the WGHT chunk).
 *
 * A row of the weight matrix (pf_weights, pf/mesh.h) maps the stitched nodal displacements of the
 * mesh (one 3-vector per node, DG paper eq. 30) to the displacement of one surface vertex, so a
 * frame of the embedded surface costs one sparse mat-vec (DG paper eq. 32). Two methods:
 *
 * - PF_EMBED_MLS (DG paper sec. 7): moving least squares with the linear basis (1, x, y, z) and a
 *   truncated Gaussian weight per node. The support radius of node i is R_i = support * h_i, h_i
 *   the node's spacing: the longest mesh edge at the node (its one-ring, as the paper suggests).
 *   A radius attached to the node, not to the evaluation point, keeps every weight as smooth as the
 *   kernel (a radius measured from the point, e.g. its k-th nearest node, jumps where the k-th
 *   neighbour changes). The kernel, with q = |x - x_i| / R_i,
 *       theta(q) = exp(-s q^2) - exp(-s) (1 + s (1 - q^2))   for q < 1, 0 beyond,
 *   is the Gaussian minus its first-order Taylor expansion in q^2 at the radius: it vanishes with
 *   its derivative at q = 1, so the truncation leaves the weights C1 (a plainly cut Gaussian jumps
 *   there); it is positive and decreasing on [0, 1). The weights reproduce every affine field
 *   exactly and use no node farther than its support radius. Where the support holds too few or
 *   nearly coplanar nodes (the weighted covariance of the support is rank-deficient), every radius
 *   is multiplied by `growth` for that vertex until it is well conditioned; such vertices are
 *   counted (there the weights are continuous only where the growth factor is the same). A row
 *   is a function of its support alone (its nodes, their positions and radii, summed in the order
 *   of their indices, offsets scaled by the largest radius among them), so a change of the mesh
 *   away from it leaves it bit for bit (pf_embed_update).
 * - PF_EMBED_BARY: each vertex is located in its element (a uniform grid over element bounding
 *   boxes, then the winding number over the element's triangulated faces) and weighted with the
 *   element's shape functions: barycentric for tets, trilinear for hexes (the trilinear map
 *   inverted by Newton's method), 3D mean value coordinates (Floater et al. 2005, Ju et al. 2005)
 *   over the element's triangulated faces for general polyhedra. Continuous (C0) across faces
 *   exactly, partition of unity, affine reproduction.
 * - PF_EMBED_HARMONIC: as PF_EMBED_BARY, but general polyhedra use the CG method's harmonic shape
 *   functions (pf/basis.h, MFS with the default pf_basis_params), built only for the elements that
 *   hold a vertex. The embedded surface then moves exactly with the CG method's displacement field.
 *   Partition of unity and affine reproduction stay exact; continuity across faces holds only to
 *   the functions' boundary error (pf-basis reports it: ~1 % on cube-like cells, more on cells of a
 *   finely faceted sliced surface), so bary is the better choice for a DG simulation.
 *
 * Vertices outside every element (a surface poking out of a voxel mesh) are attached to the
 * nearest element (bary: its shape functions extrapolated, still reproducing affine fields) or keep
 * their MLS weights (the affine fit extrapolates smoothly); both methods count them. A vertex
 * within 1e-9 of the mesh's bounding-box diagonal of an element is inside it.
 */
#ifndef PF_EMBED_H
#define PF_EMBED_H

#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pf_embed_method {
    PF_EMBED_MLS = 0,  /* moving least squares, C1 (the default) */
    PF_EMBED_BARY = 1, /* element shape functions, C0 */
    PF_EMBED_HARMONIC = 2, /* element shape functions, harmonic (CG) on general polyhedra */
} pf_embed_method;

const char *pf_embed_method_name(pf_embed_method m); /* "mls", "bary", "harmonic" */

/* Zero values mean "default". */
typedef struct pf_embed_params {
    pf_embed_method method;
    double support;   /* MLS: support radius over node spacing; default 2. Inside a cube cell the
                         support then reaches the eight corners and the next shell of nodes, about
                         30 nodes on a regular grid */
    double sharpness; /* MLS: s of the kernel; default 3 (theta(1/2) ~ 0.43 theta(0)) */
    double min_spread;/* MLS: smallest over largest eigenvalue of the weighted node covariance that
                         counts as well conditioned; default 1e-3 */
    double growth;    /* MLS: radius factor per growth step; default 1.5 */
    int32_t max_growth; /* MLS: growth steps before giving up (PF_ERR_NUMERIC); default 20 */
    /* Cuts (pf/cut.h): [m->n_faces] nonzero for the faces a cut opened
     * (pf_cut_result.cut_face), or NULL (none: the weights are those without cuts, bit for bit).
     * MLS: the visibility rule, no node is in a vertex's support when the segment from the
     * vertex to the node strictly crosses such a face (both ends farther than 1e-10 of the
     * face's diameter from its plane, on opposite sides, and the crossing point in the face's
     * polygon or within that tolerance of its edges; an end point within 1e-5 of the diameter
     * of the plane, where the segment leaves the cut through its outer edge, counts when it lies
     * on the face). The copies of a node on a cut, a corner of blocking faces where segments only
     * touch them, are hidden from every point behind them (against the sum of the inward normals
     * of their blocking faces, beyond the tolerance), so each side sees its own copy; a node of
     * the crack front is a corner of both sides' faces and is seen from both. A vertex sees only
     * the nodes of its own body (the connected group of elements, through shared faces, holding
     * it seen from its side): a segment around the rim of a cut, through the air, crosses no
     * face. A vertex whose support lost nodes this way and is then too flat, or whose fit
     * extrapolates (sum |W_i| > 2), takes its element's own weights (as PF_EMBED_BARY). */
    const uint8_t *blocking_faces;
    /* [3 s->n_verts], or NULL: for a vertex on a cut, a direction (any length) into the side it
     * belongs to; the zero vector for the others. MLS sees the nodes from the vertex nudged
     * along it by 1e-6 of the nearest blocking face's diameter, bary and harmonic locate the
     * host element there; the weights themselves are those at the vertex (affine fields stay
     * reproduced exactly). Without it, a vertex on a cut belongs to no side. */
    const double *vertex_side;
} pf_embed_params;

pf_embed_params pf_embed_params_default(void);

typedef struct pf_embed_stats {
    int32_t n_verts;
    int32_t n_outside;       /* vertices outside every element (attached to the nearest) */
    double max_outside;      /* largest distance of such a vertex from its element, model units */
    int32_t n_grown;         /* MLS: vertices whose support had to grow */
    int32_t n_by_kind[PF_ELEM_KIND_COUNT]; /* vertices per kind of their element */
    int32_t n_fallback;      /* bary, harmonic: outside vertices weighted by the affine
                                least-squares fit of their element's nodes (Newton or mean value
                                coordinates failed; harmonic: farther outside than half the MFS
                                kernel offset); MLS with blocking faces: vertices near a cut
                                whose visible support was too flat or extrapolated, weighted by
                                their element's own functions */
    int32_t n_harmonic;      /* harmonic: elements whose harmonic functions were built */
    double basis_seconds;    /* harmonic: wall clock of building them */
    int64_t nnz;
    double mean_row;         /* mean non-zeros per row */
    double seconds;          /* wall clock of pf_embed_compute */
} pf_embed_stats;

/* Computes the weights of the vertices of s in m (validated; derived arrays not needed) into w
 * (zeroed or released; zero again after a failure): w->rows = s->n_verts, w->cols = m->n_nodes,
 * w->surface_id = s->id, w->mesh_id = m->id, columns sorted within each row. params NULL: the
 * defaults; stats may be NULL. Statuses: PF_ERR_INVALID for an empty mesh, non-finite
 * coordinates or bad parameters; PF_ERR_NUMERIC when an MLS support stays degenerate after
 * max_growth steps; harmonic: the statuses of pf_basis_create, naming the element; PF_ERR_NOMEM. Cost about linear in vertices plus elements. */
pf_status pf_embed_compute(const pf_mesh *m, const pf_surface *s, const pf_embed_params *params,
                           pf_weights *w, pf_embed_stats *stats, pf_error *err);

/* pf_embed_compute, also giving each row's growth step: steps[s->n_verts] (may be NULL), the MLS
 * row of vertex v used the radii growth^steps[v] R_i (0 for bary, harmonic and the element
 * weights of a vertex near a cut). What pf_embed_update needs besides the weights. */
pf_status pf_embed_compute_steps(const pf_mesh *m, const pf_surface *s,
                                 const pf_embed_params *params, pf_weights *w, int32_t *steps,
                                 pf_embed_stats *stats, pf_error *err);

typedef struct pf_embed_update_stats {
    int32_t rows;          /* surface vertices */
    int32_t rows_computed; /* rows recomputed; the others were copied, their nodes renumbered */
    int32_t nodes_changed; /* nodes of the new mesh that are new, moved or of a new radius */
    double cpu_seconds;    /* of the update (process CPU time) */
} pf_embed_update_stats;

/* The weights of s on mesh m after a change of the mesh, from its weights old (and old_steps,
 * pf_embed_compute_steps) on old_mesh, bit for bit those pf_embed_compute_steps gives on m.
 * node_map[old_mesh->n_nodes]: the index in m of each old node, -1 when removed (NULL: every old
 * node keeps its index). An MLS row depends only on its support: the nodes within its radii,
 * their positions and radii, in the order of their indices. A row is recomputed when its
 * support (at its growth step) held a removed node or one whose position or radius changed, or
 * now reaches a node of m that is new, moved or of a new radius, or when the renumbering
 * reorders its nodes; every other row is copied with its nodes renumbered. bary, harmonic and
 * MLS with blocking faces (cuts) are recomputed in full. w zeroed or released (zero again after
 * a failure); steps[s->n_verts] receives the new steps; stats may be NULL. Statuses: those of
 * pf_embed_compute; PF_ERR_INVALID when old does not fit s and old_mesh. */
pf_status pf_embed_update(const pf_mesh *old_mesh, const pf_weights *old, const int32_t *old_steps,
                          const pf_mesh *m, const int32_t *node_map, const pf_surface *s,
                          const pf_embed_params *params, pf_weights *w, int32_t *steps,
                          pf_embed_update_stats *stats, pf_error *err);

/* The MLS support radius of every node (radius[n_nodes], model units) before any growth:
 * support * the longest edge at the node. Nodes on no edge get the mesh's longest edge. */
pf_status pf_embed_mls_radii(const pf_mesh *m, const pf_embed_params *params, double *radius,
                             pf_error *err);

/* 3D mean value coordinates of p with respect to the closed triangle mesh tri[3 nt] over the
 * nodes x (indices into x), for a point inside, on or outside it (Ju et al. 2005): w[k] for the
 * k-th of the distinct nodes listed in nodes[n] (every triangle corner must be one of them).
 * Reproduces affine functions; on the boundary, linear on the triangle holding p. Returns
 * PF_ERR_NUMERIC when the weights do not sum to a usable total (outside points far from the
 * mesh), PF_ERR_INVALID when a corner is not in nodes. Within 1e-8 of the element's size from a
 * triangle the weights are that triangle's linear functions (the formula loses digits there);
 * a final least-change correction makes sum w = 1 and sum w_k x_k = p exact to round-off. */
pf_status pf_embed_mean_value(const double *x, const uint32_t *tri, int32_t nt,
                              const uint32_t *nodes, int32_t n, pf_vec3 p, double *w,
                              pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
