/* pf/split.h: splitting a closed polyhedron by a plane into closed pieces.
 *
 * The geometry kernel of meshing (pf-slice), refinement and cutting. The input is a closed
 * polyhedron with planar faces, convex or not, faces convex or not; the output is every connected
 * piece on each side of the plane, each a closed polyhedron again, with cap faces on the plane.
 *
 * Robustness: every node is classified once against the plane (-1 below, 0 on, +1 above) with a
 * tolerance relative to the polyhedron's size, and every later decision (which side a face goes
 * to, where a face is cut, which edges bound a cap) uses that classification only, so the pieces
 * always close. An input edge whose ends lie strictly on opposite sides gets one new node, placed
 * by a formula that depends only on the edge's two end points taken in lexicographic order of
 * their coordinates: the same edge split in two neighbouring cells gives bit-identical nodes.
 */
#ifndef PF_SPLIT_H
#define PF_SPLIT_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Zero values mean "default". */
typedef struct pf_split_params {
    /* Absolute on-plane tolerance in model units; <= 0: rel_tol times the bounding-box diagonal
     * of the polyhedron. A node closer than tol to the plane is on it (class 0). */
    double tol;
    /* Relative tolerance used when tol <= 0; <= 0: 1e-10 (far above the round-off of a signed
     * distance, ~1e-16 of the coordinates, far below any intended feature). */
    double rel_tol;
    /* The caller guarantees a closed input (a piece of an earlier split, a surface already checked):
     * skips the O(n log n) closedness check, which dominates repeated splits of large pieces. */
    bool assume_closed;
} pf_split_params;

pf_split_params pf_split_params_default(void);

/* The result of a split. All arrays are owned by the struct (pf_split_release frees them).
 * Nodes: the input's n_input_nodes nodes first, unchanged and with unchanged indices, then one new
 * node per input edge that crosses the plane. Pieces: connected components over shared edges
 * (pieces touching only at a vertex or along an edge are separate pieces), those below the plane
 * first, each in order of its first face; faces of a piece are consecutive, input faces (in input
 * order) before caps. */
typedef struct pf_split {
    double tol;                /* the on-plane tolerance used, model units */
    int32_t n_input_nodes;
    int32_t n_nodes;           /* n_input_nodes + new nodes */
    double *x;                 /* [3 n_nodes] node positions */
    int8_t *node_class;        /* [n_nodes] -1 below, 0 on the plane, +1 above (new nodes: 0;
                                  input nodes no face references: 0) */
    uint32_t *new_edge;        /* [2 (n_nodes - n_input_nodes)]: new node n_input_nodes + i lies on
                                  the input edge (new_edge[2i], new_edge[2i+1]), the first of the
                                  two having the lexicographically smaller coordinates */
    double *new_t;             /* [n_nodes - n_input_nodes]: its parameter, x = x_a + t (x_b - x_a)
                                  per coordinate (then clamped into [x_a, x_b]), 0 < t < 1 */
    int32_t n_pieces;
    int8_t *piece_side;        /* [n_pieces] -1: below (signed distance < 0), +1: above */
    int64_t *piece_faces;      /* [n_pieces + 1]: faces of piece k are piece_faces[k] ..
                                  piece_faces[k+1] - 1 */
    int32_t n_faces;           /* faces of all pieces */
    int64_t *face_offsets;     /* [n_faces + 1] */
    uint32_t *face_nodes;      /* [face_offsets[n_faces]] node indices, counter-clockwise seen
                                  from outside the piece (outward normal) */
    int32_t *face_source;      /* [n_faces] the input face a face is (part of), -1 for a cap */
} pf_split;

/* Splits the closed polyhedron p (nodes x[3 n_nodes], every face index < n_nodes) by the plane.
 * params may be NULL for the defaults. *out is overwritten (release it with pf_split_release; it
 * is zeroed on failure). A plane that misses the polyhedron or only touches it gives one piece
 * per connected component (one for a connected input) whose faces are the input's, unchanged.
 * Faces of the input lying on the plane stay faces of the piece on their element's side; caps
 * are only made where the solid lies on both sides of the plane. The caps above are those below
 * reversed about the same first node, so that a fan from the first node triangulates both alike
 * (on-plane nodes may lie up to tol off the plane: volumes of the pieces then still sum to the
 * input's to round-off). A cap region with holes (or
 * one that touches itself at a vertex) is decomposed into convex polygons without new vertices.
 * Statuses: PF_ERR_INVALID for a non-finite coordinate or plane, a face with fewer than 3
 * nodes, an index out of range, a polyhedron that is not closed (an edge a-b not matched by
 * b-a), or a polyhedron lying in the plane; PF_ERR_NUMERIC when the input is so degenerate at
 * the tolerance that the cut is inconsistent (e.g. a face whose vertices all lie within tol of a
 * line in the plane but not on it); PF_ERR_NOMEM. */
pf_status pf_poly_split(const pf_polyhedron *p, int32_t n_nodes, const pf_plane *plane,
                        const pf_split_params *params, pf_split *out, pf_error *err);

/* Frees every array and zeroes the struct. Safe on a zeroed struct. */
void pf_split_release(pf_split *s);

/* Decomposes a region of a plane into simple polygons without adding vertices (the caps of
 * pf_poly_split). The region is given by directed edges edges[2k] -> edges[2k+1] (k < n_edges)
 * into x, with the region on their left seen from the side normal points to: its boundary loops
 * (counter-clockwise outer loops, clockwise holes) plus, optionally, interior edges listed once
 * in each direction, along which the region is to be cut. Every node must be in the plane.
 * A loop without holes becomes one polygon (convex or not); a loop with holes, or one touching
 * itself at a vertex, is joined to its holes by bridges between existing vertices, ear-clipped
 * and merged back into convex polygons (Hertel-Mehlhorn). Every output edge is either an input
 * edge or used by two output polygons in opposite directions, so the polygons close any surface
 * the input edges came from. On success *offsets [*n_polys + 1] and *nodes [(*offsets)[n]] are
 * allocated with pf_alloc (the caller frees them), polygons counter-clockwise about normal.
 * PF_ERR_NUMERIC when the edges do not form closed loops or a hole cannot be joined. */
pf_status pf_split_cap_polygons(const double *x, pf_vec3 normal, const uint32_t *edges,
                                int64_t n_edges, int64_t **offsets, uint32_t **nodes,
                                int32_t *n_polys, pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
