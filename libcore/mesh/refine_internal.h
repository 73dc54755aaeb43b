/* Internal to libcore/mesh: the working mesh of pf_mesh_refine (refine.c) and the split of one
 * element into its children in local node numbering (refine_split.c). */
#ifndef PF_REFINE_INTERNAL_H
#define PF_REFINE_INTERNAL_H

#include <pf/refine.h>
#include <pf/split.h>

/* Closed pieces of one element, faces in the local numbering of a refine_local. */
typedef struct refine_pieces {
    int32_t n; /* pieces */
    int64_t cap;
    int64_t *first_face; /* [n + 1] faces of piece k: first_face[k] .. first_face[k+1] - 1 */
    double *volume;      /* [n] */
    int32_t n_faces;
    int64_t cap_faces;
    int64_t *off;    /* [n_faces + 1] */
    int32_t *origin; /* [n_faces] index of the element face the face lies in, -1 inside */
    int64_t cap_nodes;
    uint32_t *nodes; /* [off[n_faces]] local node indices, outward */
} refine_pieces;

/* The element being split: its nodes (the first n_orig, in the element's order) and the nodes
 * the planes made, and its pieces (cur: the latest accepted, next: a plane's trial). */
typedef struct refine_local {
    int32_t n, n_orig;
    int64_t cap;
    double *x;     /* [3 n] */
    int32_t *glob; /* [n] node of the working mesh, -1 until assigned */
    refine_pieces cur, next;
} refine_local;

/* Grows the array *pp of *cap elements of size bytes to hold need (doubling; contents kept).
 * PF_ERR_TOO_LARGE beyond 2^31 entries of more than 4 bytes, PF_ERR_NOMEM. */
pf_status pf_refine_grow(void *pp, int64_t *cap, int64_t need, size_t size, pf_error *err);

void pf_refine_local_release(refine_local *L);
/* Room for n local nodes. */
pf_status pf_refine_local_reserve(refine_local *L, int64_t n, pf_error *err);
/* Appends node coordinates p (new node; merged with an earlier new node of equal coordinates).
 * *id receives its local index. */
pf_status pf_refine_local_node(refine_local *L, const double *p, int32_t *id, pf_error *err);
/* Starts a piece set empty. */
void pf_refine_pieces_clear(refine_pieces *ps);
/* Starts a new piece in ps; pf_refine_pieces_face appends a face to the last one. */
pf_status pf_refine_pieces_begin(refine_pieces *ps, pf_error *err);
pf_status pf_refine_pieces_face(refine_pieces *ps, const uint32_t *nodes, int64_t n, int32_t origin,
                                pf_error *err);
/* Piece k of ps as a polyhedron view into L->x. */
pf_polyhedron pf_refine_piece_view(const refine_local *L, const refine_pieces *ps, int32_t k);

/* Splits the single piece in L->cur (the element, volume vol > 0) by the request's planes,
 * leaving the children in L->cur. *planes_applied and *planes_skipped count the planes applied
 * and those skipped by the sliver rule or because they would more than double the pieces (octs
 * and halves: at most 8 and 2 children). */
pf_status pf_refine_split_local(refine_local *L, const pf_refine_request *req, double vol,
                                pf_vec3 centroid, const pf_vec3 axes[3], int32_t *planes_applied,
                                int32_t *planes_skipped, pf_error *err);

/* Volume, centroid and the octs plane normals (principal axes of the second moments about the
 * centroid, largest moment first, ties toward x, y, z) of the closed polyhedron p. */
pf_status pf_refine_element_axes(const pf_polyhedron *p, double *vol, pf_vec3 *centroid,
                                 pf_vec3 axes[3], pf_error *err);

#endif
