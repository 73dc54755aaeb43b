/* pf/cut.h: cutting a mesh and its embedded surface without remeshing (DG paper sec. 9.4,
 * harmonic paper sec. 8 "Progressive Cutting").
 *
 * A cut is a list of requests, each an element and a plane. Every requested element is split by
 * its plane into pieces on either side (pf_mesh_refine's exact split; pieces may be non-convex),
 * and the material is separated across the cut: a face between two elements of the cut that lie
 * on opposite sides of it (the caps between two pieces of one element, a face of the mesh the
 * plane runs along, the parts of a face between neighbouring cut elements) becomes two boundary
 * faces, one per side, and every node on such a face is duplicated, one copy per connected group
 * of the elements around it. A face between a cut element and one the cut did not reach stays
 * interior: that is where the crack ends, so a cut can stop half way (progressive cutting: the
 * caller requests the elements the blade has passed through).
 *
 * Element granularity: an element is cut through entirely by its plane, the blade's position
 * inside it is not tracked further (as in Wicke et al. 2007 and the harmonic paper).
 *
 * Slivers are never made (the sliver rules of DG paper sec. 9.4 and 9.6): a plane that would cut
 * off a piece smaller than min_fraction of its element, or than min_fraction of the median
 * element volume of the mesh being cut (the floor), is not applied to that element (the element
 * is "snapped": it stays whole, on the side of its centroid, and the crack follows its faces
 * toward the pieces on the other side). The floor keeps repeated cuts from making pieces of
 * pieces ever smaller: a cut makes no element below min_fraction of the median, so the ratio of
 * the largest to the smallest element, which drives the condition number of the system (DG paper
 * sec. 9.6, fig. 11), grows only as the mesh's median shrinks. A piece that ends up alone in a
 * body (a connected group of elements) below the floor is dropped, its volume reported.
 */
#ifndef PF_CUT_H
#define PF_CUT_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/embed.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pf_cut_request {
    int32_t elem;   /* element of src (each at most once per call) */
    pf_plane plane; /* side +1 where the signed distance is positive */
} pf_cut_request;

/* Zero values mean "default". */
typedef struct pf_cut_params {
    /* Smallest piece a plane may make, as a fraction of its element's volume and of src's median
     * element volume (the floor); <= 0: PF_REFINE_MIN_FRACTION (5 %, the slicer's and
     * refinement's sliver rule). Also the smallest new body kept. */
    double min_fraction;
    /* [src->n_faces] the faces earlier cuts opened (pf_cut_result.cut_face of the cut that made
     * src), or NULL: none. Carried into res->cut_face. */
    const uint8_t *src_cut_face;
} pf_cut_params;

typedef struct pf_cut_result {
    int32_t *parent;   /* [dst->n_elems] the src element each dst element comes from */
    uint8_t *split;    /* [src->n_elems] 1 for an element split into pieces */
    uint8_t *changed;  /* [dst->n_elems] 0 exactly for elements whose faces are those of their
                          parent node for node (pf_refine_result.changed, and also 1 for
                          elements that got a duplicated node) */
    int32_t *face_src; /* [dst->n_faces] the src face a dst face is, node for node through
                          node_map (same order, same orientation), or -1 */
    int32_t *node_map; /* [src->n_nodes] the dst index of each src node (its first copy when it
                          was duplicated), -1 when it was dropped with a dropped piece */
    int32_t *node_src; /* [dst->n_nodes] the src node a dst node is or is a copy of, -1 for the
                          nodes the planes made */
    uint8_t *cut_face; /* [dst->n_faces] 1 for boundary faces opened by this cut or earlier ones
                          (params.src_cut_face) */
    uint8_t *opened;   /* [dst->n_faces] 1 for the faces this cut opened (a subset of cut_face:
                          what a surface cut must cap now) */
    int32_t n_split;       /* requests that split their element */
    int32_t n_snapped;     /* requests whose plane was not applied by the sliver rule, or that
                              missed their element (the element then lies on one side) */
    int32_t n_opened;      /* faces opened by this cut (each counted once, as two dst faces) */
    int32_t n_duplicated;  /* node copies made */
    int32_t n_bodies;      /* connected groups of elements in dst (through shared faces) */
    int32_t n_dropped;     /* pieces dropped as too small alone */
    double dropped_volume; /* their volume, model units */
} pf_cut_result;

/* Cuts src into dst (zeroed or released first; written derived, with src's groups carried: an
 * element its parent's, a face its source face's or, for a part of a boundary face, that face's)
 * and describes the change in *res (overwritten; arrays from pf_alloc). src must be valid
 * (pf_mesh_validate) and derived. n_req may be 0 (dst is then a copy with a new id).
 * Volume: the elements of dst have src's volume to rounding, minus res->dropped_volume.
 * Numbering: src's nodes keep their indices (a duplicated node's first copy is the node itself,
 * the others are appended); elements in src order with each split element replaced by its
 * pieces; dst->id = src->id + 1.
 * Statuses: PF_ERR_INVALID for a request naming an element out of range or twice, a plane that
 * is not finite or has a zero normal; PF_ERR_NUMERIC when an element's split is inconsistent at
 * the split tolerance; PF_ERR_NOMEM. Messages name the request and element. On failure dst is
 * released and *res zeroed. */
pf_status pf_mesh_cut(const pf_mesh *src, const pf_cut_request *req, int32_t n_req,
                      const pf_cut_params *params, pf_mesh *dst, pf_cut_result *res,
                      pf_error *err);

/* Frees the arrays and zeroes *r. Safe on a zeroed result. */
void pf_cut_result_release(pf_cut_result *r);

/* ---- clipping by a closed surface (DG paper sec. 9.4, fig. 10: a bunny cut out of a cube) ------
 *
 * Every element of src becomes its intersection with the inside (or the outside) of the solid a
 * closed surface bounds: elements wholly on the kept side stay as they are, elements wholly on the
 * other side are dropped, and every element the surface crosses is replaced by its part(s) there,
 * one element per connected part, exact (the surface's own triangles become faces). The mesh stays
 * conforming: the parts of two neighbours meet on identical faces (their regions on the shared face
 * are rebuilt from welded nodes in the shared face's orientation), and a part smaller than
 * min_fraction of its element is merged into the neighbour it shares the most face area with (the
 * slicer's rule, pf_mesh_slice), so the merged element may be non-convex.
 * The elements the surface crosses must be convex with no node inside a straight edge of a face
 * (tets, hexes, convex polyhedra); elements it misses may be anything. */
typedef enum pf_clip_keep {
    PF_CLIP_INSIDE = 0, /* keep what lies inside the surface */
    PF_CLIP_OUTSIDE = 1 /* keep what lies outside */
} pf_clip_keep;

/* Zero values mean "default". */
typedef struct pf_clip_params {
    pf_clip_keep keep;
    /* Parts below min_fraction of their element's volume are merged into a neighbour; <= 0:
     * PF_REFINE_MIN_FRACTION (5 %). */
    double min_fraction;
} pf_clip_params;

typedef struct pf_clip_stats {
    int32_t n_kept;     /* elements kept whole */
    int32_t n_dropped;  /* elements dropped whole */
    int32_t n_clipped;  /* elements the surface crosses */
    int32_t n_parts;    /* their parts, before merging */
    int32_t n_merged;   /* parts merged into a neighbour */
    int32_t n_isolated; /* parts below min_fraction with no neighbour (kept) */
    int64_t n_splits;   /* plane splits */
    double volume;      /* of dst, model units cubed */
    double seconds;
} pf_clip_stats;

/* Clips src (valid and derived) by the closed surface s into dst (zeroed or released first;
 * derived; nodes numbered in order of first use by dst's elements, elements in the order of their
 * src elements; dst->id = src->id + 1; src's groups carried: an element takes its src element's,
 * a boundary face the label of the src boundary face it lies in, pf_mesh_carry_groups). stats
 * may be NULL.
 * Statuses: PF_ERR_INVALID for a surface that is not closed, manifold and outward (its open,
 * non-manifold and flipped edge counts in the message) or a non-finite coordinate, and for
 * nothing left (every element on the dropped side); PF_ERR_UNSUPPORTED naming the element for a
 * crossed element that is not convex or has a node inside a straight edge, for a part that
 * would hold a whole shell of the surface (a cavity) inside it, and for two src nodes at one
 * position (a mesh already cut: clip first, then cut); PF_ERR_NUMERIC naming the elements when the
 * geometry is too degenerate at the tolerance (1e-10 of the model's size) for matching faces;
 * PF_ERR_NOMEM. On failure dst is released. */
pf_status pf_mesh_clip_surface(const pf_mesh *src, const pf_surface *s,
                               const pf_clip_params *params, pf_mesh *dst, pf_clip_stats *stats,
                               pf_error *err);

/* ---- the embedded render surface ------------------------------------------------------------
 *
 * The surface a user sees is cut where the mesh was: s (rest positions, as it was before the
 * cut; it may hold earlier caps) is split along the faces the cut opened (cut->opened on m, the
 * mesh after the cut): a triangle crossing such a face is split exactly by the face's plane, and
 * the vertices made on an opened face are duplicated, one copy per side, so that nothing of the
 * surface moves with material across the cut. Where the cut ends inside a triangle (the crack
 * front) its vertices are shared. The cut is capped: each opened face, clipped to the inside of
 * s when s is closed, is triangulated into cap triangles (tri_part PF_SURFACE_CAP). The weights
 * of every vertex of out over m's nodes are computed with pf_embed_compute's parameters (embed,
 * NULL: defaults) and the visibility rule: no vertex takes a node whose segment to it crosses a
 * face in cut->cut_face; a vertex on a cut takes only nodes of its own side.
 * out (zeroed or released) gets id s->id + 1 and w (zeroed or released) rows for out's vertices,
 * columns m's nodes, surface_id out->id, mesh_id m->id. */
typedef struct pf_surface_cut_stats {
    int32_t n_split_tris;  /* triangles of s split by opened faces */
    int32_t n_duplicated;  /* vertex copies made on the cut */
    int32_t n_cap_tris;    /* cap triangles added */
    double cap_area;       /* their area, model units */
    int32_t n_uncapped;    /* opened faces left without a cap: the pieces of their boundary
                              inside the surface did not close (the surface has a hole there) */
} pf_surface_cut_stats;

pf_status pf_surface_cut(const pf_surface *s, const pf_mesh *m, const pf_cut_result *cut,
                         const pf_embed_params *embed, pf_surface *out, pf_weights *w,
                         pf_surface_cut_stats *stats, pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
