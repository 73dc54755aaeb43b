/* Internal to libcore/mesh: clipping a mesh by a closed surface (clip.c), and the faces of an
 * element's part rebuilt on welded nodes (clip_faces.c). */
#ifndef PF_CLIP_INTERNAL_H
#define PF_CLIP_INTERNAL_H

#include <pf/mesh.h>

#include "mesh_internal.h"

/* Points welded within a tolerance: the first point inserted near a place stands for every later
 * one within tol of it (max norm), so the parts of two neighbouring elements meet at identical
 * nodes whatever order their planes were applied in. The src mesh's nodes are inserted first
 * (ids 0 .. n_fixed - 1), so a corner an element's part reaches is the mesh node itself. */
typedef struct pf_weld {
    double tol;
    int32_t n, cap, n_fixed;
    double *x;        /* [3 cap] */
    int64_t slots;    /* power of two */
    int32_t *table;   /* [slots] first point of a chain, -1 empty */
    int32_t *next;    /* [cap] next point in the same slot */
    int64_t *cell;    /* [3 cap] the point's grid cell */
} pf_weld;

/* *id: the welded point within tol of p (the first inserted), inserting p when there is none. */
pf_status pf_weld_point(pf_weld *w, const double *p, int32_t *id, pf_error *err);
/* *id: the welded point within tol of p, or -1. */
int32_t pf_weld_find(const pf_weld *w, const double *p);
void pf_weld_release(pf_weld *w);

/* The faces of one connected part of a clipped element, rebuilt: nodes welded, faces grouped by
 * what they lie on (key >= 0: the solid's triangle; key < 0: the element's face -key - 1), every
 * group's region traced again as polygons over welded nodes (pf_split_cap_polygons), so a region
 * that the planes of the kd tree or of the element cut into several faces is one face again and
 * nodes that only such cuts made, lying inside a straight edge between two regions, are dropped.
 * The region of an element face is traced in the orientation of its mesh face (face_ref[k],
 * reversed when face_rev[k]) so that both elements sharing it make the same polygons.
 * group_normal: the outward normal of each solid triangle (keys >= 0). */
typedef struct pf_part_faces {
    int32_t n_faces;
    int64_t *offsets;  /* [n_faces + 1] */
    uint32_t *nodes;   /* welded ids, outward */
    int32_t *key;      /* [n_faces] the group key */
} pf_part_faces;

pf_status pf_clip_rebuild_part(pf_weld *w, const piece *p, const int32_t *face_key,
                               const pf_mesh *m, const int32_t *face_ref, const uint8_t *face_rev,
                               const double *tri_normal, pf_part_faces *out, pf_error *err);
void pf_part_faces_release(pf_part_faces *f);

/* What became of each element of a clipped mesh, and the parts of the clipped ones. */
enum { PF_CLIP_DROPPED = 0, PF_CLIP_WHOLE = 1, PF_CLIP_CLIPPED = 2 };

typedef struct pf_clip_elem_parts {
    int32_t n;
    pf_part_faces *part; /* [n] */
} pf_clip_elem_parts;

/* dst (zeroed first, derived): the elements of m in order, each PF_CLIP_WHOLE one as it is (its
 * nodes are w's first ones), each PF_CLIP_CLIPPED one as its parts (over w's nodes), glued by node
 * sets; then every part below min_fraction of its element's volume merged into the neighbour
 * it shares the most face area with (pf_merge_slivers: *merged, *isolated). PF_ERR_INVALID when
 * nothing is kept, PF_ERR_NUMERIC naming the elements when two neighbours' parts on their shared
 * face do not match, and the glue's statuses. */
pf_status pf_clip_assemble(const pf_mesh *m, const uint8_t *state,
                           const pf_clip_elem_parts *parts, const pf_weld *w, double min_fraction,
                           pf_mesh *dst, int32_t *merged, int32_t *isolated, pf_error *err);

#endif
