/* pf/refine.h: splitting elements of a mesh into children while keeping it conforming (the mesh
 * kernel of stress-based refinement: DG paper sec. 9.3, harmonic paper sec. 8).
 *
 * A request names an element and how to split it:
 *   - PF_SPLIT_OCTS: the three planes through the element's volume centroid whose normals are the
 *     principal axes of its second moments about the centroid, int (x - c)(x - c)^T dV, taken
 *     from the largest moment to the smallest (for an axis-aligned box: the box axes, the longest
 *     side cut first, giving the regular 1-to-8 subdivision of a hexahedron). Where moments are
 *     equal (within 1e-10 of the largest) the axes of that eigenspace are chosen toward x, then y,
 *     then z (a cube: x, y, z). Each plane splits every piece the earlier ones made
 *     (pf_poly_split).
 *   - PF_SPLIT_HALVES: one plane through the centroid with the request's normal (the direction of
 *     the largest principal stress, for the simulator).
 * Every connected piece is a child. A plane through a non-convex element may cut a piece into more
 * than two: an octs or halves plane that would leave more than twice the pieces there were before
 * it is not applied (octs: that plane only, the others still are), so an octs split makes at
 * most 8 children and a halves split at most 2, whatever the element's shape (the simulator's
 * max_elements counts on it). A plane request (below) makes the pieces the plane makes.
 *
 * Slivers are never made: a plane that would make a piece smaller than PF_REFINE_MIN_FRACTION
 * of the element's volume is not applied (octs: that plane only, the others still are). The
 * reason: a child that small gets a badly conditioned basis (DG mass matrix, harmonic MFS fit),
 * a stiffness far above its neighbours' and a stable time step to match, and would be merged
 * back at once by the slicer's sliver rule, which uses the same 5 %. A request none of whose
 * planes applies leaves its element as it is and is counted in n_skipped, not an error.
 *
 * Conformity: the result is a valid conforming mesh (pf_mesh_validate and pf_mesh_derive pass;
 * every face interior in src stays interior). A face an unsplit neighbour shares with a split
 * element is replaced by the children's polygons (reversed), and every new node on an edge of
 * the mesh is inserted into every face containing that edge, in every element, so no node hangs
 * (the harmonic basis needs it; DG accepts the collinear face vertices it makes). Requests are
 * applied one after the other, each on the mesh the earlier ones left, so neighbours split in
 * one call conform too.
 *
 * Numbering: every node of src keeps its index and its coordinates bit for bit; new nodes are
 * appended in the order the requests make them. A new node on an edge is placed by
 * pf_poly_split's formula, which depends only on the edge's end points, and nodes are merged by
 * exact coordinates. Elements: src's order, each split element replaced in place by its children
 * (consecutive, in pf_poly_split's piece order). Faces: the faces of src that survive in src's
 * order, then the new ones in the order they were made. dst->id = src->id + 1.
 *
 * Cost: O(size of src) to copy and index the mesh once, then work proportional to the split
 * elements and the elements around them.
 */
#ifndef PF_REFINE_H
#define PF_REFINE_H

#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Smallest child a plane may make, as a fraction of the split element's volume (the slicer's
 * default sliver threshold, pf_slice_params.merge). */
#define PF_REFINE_MIN_FRACTION 0.05

/* No node of a split element is left closer than this (relative to its bounding-box diagonal)
 * to an octs or halves plane without being on it, so a split makes no face narrower than this
 * fraction of the element. The nodes that near are put on the plane when they are coplanar:
 * the plane is turned and moved by the least change that passes through them (least squares),
 * and pf_poly_split's on-plane tolerance raised to twice what they stay off it, when that is at
 * most 1e-10 of the diagonal (caps stay planar well within pf_mesh_validate's 1e-9) and every
 * other node stays this far off; else the nodes within 1e-8 are tried the same way. Else the
 * plane is moved along its normal by the least multiple of PF_REFINE_SHIFT (at most
 * PF_REFINE_SHIFT_STEPS of them) that leaves every node this far off; else it stays as
 * computed. Planes no node lies off by more than 1e-11 of the diagonal (rounding) are kept bit
 * for bit (boxes: the exact planes); cut planes (PF_SPLIT_PLANE) are never moved: they are the
 * blade's, the same in every cell.
 * Why: a plane through the centroid passing a node just beyond pf_poly_split's tolerance (1e-10
 * of the piece) makes a node beside it. The octs planes of the nearly symmetric cells of a
 * sliced sphere pass ~1e-9 from their corners, and those of mirror-symmetric neighbours differ
 * by the rounding of their principal axes: edges of ~1e-11 of their face, which the harmonic
 * basis merges (pf_basis_params.merge_tol, 1e-9), leaving a face with collinear nodes. And
 * after a few stress-driven refinements of a sphere sliced 6 across, an element's plane passed
 * 1e-8 to 5e-8 of its diagonal from nodes that the planes of several neighbours had put on its
 * faces at slightly different places (no plane passes through all of them): faces 1e-9 wide
 * and 0.05 long, which the harmonic basis refuses as collinear (its exactness projection needs
 * a face's width relative to its size well above 3e-7). */
#define PF_REFINE_SNAP 1e-6
/* The step of the move above, relative to the diagonal, and the most steps: a moved plane is
 * off the centroid by at most 5e-4 of the diagonal (the children stay exact: any plane splits
 * exactly), and the faces it makes are about a step wide. */
#define PF_REFINE_SHIFT 1e-5
#define PF_REFINE_SHIFT_STEPS 50

typedef enum pf_split_kind {
    PF_SPLIT_OCTS = 0,
    PF_SPLIT_HALVES = 1,
    PF_SPLIT_PLANE = 2 /* one plane through point with normal (cutting, pf/cut.h) */
} pf_split_kind;

typedef struct pf_refine_request {
    int32_t elem; /* element of src to split (each at most once per call) */
    pf_split_kind kind;
    pf_vec3 normal; /* halves: the plane through the element's centroid with this normal
                       (need not be unit, must be finite and non-zero; the caller passes the
                       largest principal stress direction); plane: the plane's normal. Unused
                       for octs. */
    pf_vec3 point;  /* plane: a point of the plane (halves use the centroid) */
    double min_fraction; /* the sliver rule's smallest piece, a fraction of the element's volume;
                            <= 0: PF_REFINE_MIN_FRACTION */
    double min_volume;   /* and its smallest piece in model units cubed, whatever the element's
                            size (cutting, pf/cut.h: a floor relative to the whole mesh); 0: none */
} pf_refine_request;

typedef struct pf_refine_result {
    int32_t *parent;    /* [dst->n_elems] the src element each dst element comes from: a child's
                           split parent, or the unchanged element itself (pf_alloc; released by
                           pf_refine_result_release) */
    int32_t n_split;    /* requests that split their element */
    int32_t n_skipped;  /* requests none of whose planes applied (all would make slivers, or
                           too many pieces) */
    int32_t n_children; /* dst elements that are children of a split */
    int32_t n_neighbours_changed; /* unsplit elements whose faces were subdivided or got nodes
                                     inserted (CG must rebuild their basis; DG their faces) */
    uint8_t *changed; /* [dst->n_elems] 1 for children and for unsplit elements whose face list
                         changed; 0 exactly for elements whose face polygons are those of their
                         src element, node for node (their caches can be reused) */
    int32_t n_planes_skipped; /* planes not applied by the sliver rule or the bound on pieces,
                                 over all requests */
    int32_t *face_src; /* [dst->n_faces] the src face a dst face is, node for node, or -1 for a
                          face that is new or got nodes inserted */
} pf_refine_result;

/* A plane request (PF_SPLIT_PLANE) splits by the given plane, which need not pass through the
 * centroid; one that misses the element, or would make a piece below min_fraction, leaves it
 * whole (n_skipped).
 *
 * Splits the requested elements of src into dst (zeroed or released first; written derived) and
 * describes the change in *res (overwritten). src is read only and needs no derived arrays; it
 * must be a valid mesh (pf_mesh_validate). n_req may be 0 (dst is then a copy with a new id).
 * Statuses: PF_ERR_INVALID for a request naming an element out of range or twice, an unknown
 * kind, a halves normal that is zero or not finite, a face used by more than two elements or
 * twice the same way round, an index out of range, an element without positive volume;
 * PF_ERR_NUMERIC when the split of an element is inconsistent at pf_poly_split's tolerance
 * (degenerate geometry); PF_ERR_TOO_LARGE beyond 32-bit counts; PF_ERR_NOMEM. Every message
 * names the request and element. On failure dst is released and *res zeroed: nothing is
 * output. */
pf_status pf_mesh_refine(const pf_mesh *src, const pf_refine_request *req, int32_t n_req,
                         pf_mesh *dst, pf_refine_result *res, pf_error *err);

/* Frees the arrays and zeroes *r. Safe on a zeroed result. */
void pf_refine_result_release(pf_refine_result *r);

/* ---- coarsening: the inverse of pf_mesh_refine ----------------------------------------------
 *
 * group[e] >= 0 names the group of element e of src (any non-negative ids, not necessarily
 * consecutive); group[e] = -1: the element stays as it is. The elements of a group become one
 * element. A group must be face-connected (PF_ERR_INVALID naming the group otherwise); a group of
 * one element stays as it is (so the refine result's parent array can be passed whole).
 *
 * Merging: the faces between two elements of one group disappear; the merged element has the
 * other faces of its elements, in element order, then each element's face order.
 *
 * Cleaning, so that a refine-then-coarsen cycle gives back the mesh that was refined:
 *   - United faces: faces of a merged element that lie between it and the same element (or on
 *     the boundary), that are coplanar and meet along an edge of a face the merge removed become
 *     one face, the union of their polygons, when that union is one simple polygon (its boundary
 *     one cycle through distinct nodes) planar within PF_COARSEN_TOL of its size; else they are
 *     left as they are. The cut edges are what tells a refinement's pieces from faces that were
 *     separate before (two coplanar boundary triangles of one element stay two). Coplanar: every
 *     node of either face within PF_COARSEN_TOL times the diameter (bounding box diagonal) of
 *     the two from the other's plane, normals the same way. Orientation does not matter: the
 *     union takes the place (index and orientation) of the lowest-numbered face.
 *   - Unneeded nodes: a node of a removed or united face is dropped from every face when no face
 *     uses it any more, or when in every face that has it, it lies between its two neighbours
 *     within PF_COARSEN_TOL of their distance (a straight part of the face boundary) and the face
 *     keeps at least 3 nodes. Removing such a node from all faces at once keeps every element
 *     closed and the mesh conforming: a node some face has as a corner stays (where a neighbour
 *     was refined later, its nodes on the merged element's faces stay). Nodes are examined in
 *     ascending order, each on the faces as the earlier removals left them.
 * Cost: O(size of src) to read, scan the faces once and copy, the rest proportional to the
 * groups' faces.
 *
 * Numbering: the kept nodes in src order, compactly (res->node_map), coordinates bit for bit.
 * Faces: src's surviving faces in src order (a union at its lowest face's place), nodes mapped.
 * Elements: src order, each group at the place of its first (lowest) element. dst->id =
 * src->id + 1. dst is valid, conforming and derived (pf_mesh_validate, pf_mesh_derive). */

/* Relative tolerance of coplanar faces and of nodes on a straight part of a face boundary:
 * refinement places its nodes on the plane and the edge they split to rounding (1e-16 of the
 * coordinates), a face must be planar to 1e-9 of its size (pf_mesh_validate). */
#define PF_COARSEN_TOL 1e-10

typedef struct pf_coarsen_result {
    int32_t *parent;   /* [dst->n_elems] the src element each dst element comes from: for a merged
                          group its first element (lowest index), else the element itself */
    int32_t *node_map; /* [src->n_nodes] the dst index of each src node, -1 for a removed node */
    uint8_t *changed;  /* [dst->n_elems] 0 exactly when the dst element's faces are those of
                          src element parent[e], node for node through node_map, in the same
                          order (its caches can be reused); 1 for merged elements and for
                          neighbours whose faces were united or lost nodes */
    int32_t n_merged;  /* groups of two or more elements merged */
    int32_t n_removed_nodes;
    int32_t *face_src; /* [dst->n_faces] the src face each dst face is, node for node through
                          node_map (same order, same orientation), or -1 for a face that was
                          united or lost nodes */
} pf_coarsen_result;

/* Merges the groups of src into dst (zeroed or released first; written derived) and describes
 * the change in *res (overwritten; arrays from pf_alloc). src is read only, needs no derived
 * arrays and must be valid (pf_mesh_validate). Statuses: PF_ERR_INVALID for a group that is not
 * face-connected (naming it), a group below -1, a face used by more than two elements or twice
 * the same way round, an index out of range; PF_ERR_NOMEM. On failure dst is released and *res
 * zeroed: nothing is output. */
pf_status pf_mesh_coarsen(const pf_mesh *src, const int32_t *group, pf_mesh *dst,
                          pf_coarsen_result *res, pf_error *err);

/* Frees the arrays and zeroes *r. Safe on a zeroed result. */
void pf_coarsen_result_release(pf_coarsen_result *r);

#ifdef __cplusplus
}
#endif
#endif
