/* The octree of pf_mesh_octree (octree.c): leaves on the integer lattice of the finest level, and
 * the classification of whole leaves as inside or outside (octree_inside.c). Private to mesh/. */
#ifndef PF_MESH_OCTREE_INTERNAL_H
#define PF_MESH_OCTREE_INTERNAL_H

#include <pf/mesh.h>
#include <pf/split.h>

#include "mesh_internal.h"

typedef struct leaf {
    int32_t c[3];                  /* lowest corner, lattice units */
    int8_t level;                  /* depth */
    uint8_t crossing;              /* the surface comes near (then level == depth) */
    uint8_t inside;                /* a whole-cell element */
    int32_t first_piece, n_pieces; /* slice: pieces of a crossing leaf in octree.pieces */
} leaf;

typedef struct piece_list {
    piece *p;
    int32_t n, cap;
} piece_list;

typedef struct octree {
    const pf_surface *s;
    pf_octree_params p;
    double o[3];   /* root corner */
    double h;      /* finest cell edge */
    double tol;    /* cutting tolerance, model units */
    double margin; /* the surface counts as near a cell within this distance */
    int32_t n;     /* lattice units along the root edge, 2^depth */
    leaf *leaves;
    int32_t n_leaves, cap_leaves;
    uint64_t *keys; /* open-addressing map (level, corner) -> leaf, UINT64_MAX empty */
    int32_t *vals;
    int64_t slots;
    int32_t *tris; /* stack of triangle lists */
    int64_t n_tris, cap_tris;
    /* slice */
    pf_split_params split;
    piece *pieces; /* [n_pieces] final pieces of crossing leaves, snapped */
    int32_t n_pieces, cap_pieces;
    int32_t *remap;
    int32_t cap_remap;
    int64_t splits;
    double volume_done; /* fraction of the root cube in built leaves, for progress */
} octree;

static inline double coord(const octree *oc, int a, int64_t i)
{
    return oc->o[a] + (double)i * oc->h;
}

static inline int32_t cell_size(const octree *oc, int level)
{
    return oc->n >> level;
}

/* Sets leaves[].inside of every leaf by its centre: signed ray crossings along rows of leaf
 * centres in x, y and z, inside where at least two axes see a non-zero winding number (as
 * pf_surface_classify_cells). */
pf_status pf_octree_classify_by_rays(octree *oc, pf_error *err);
/* The same by the generalised winding number (open surfaces). */
void pf_octree_classify_by_winding(octree *oc);

/* The octree mesh of s over the bounding cube of the box [lo, hi] (the surface's own, or with a
 * replacement surface, the original's, so that the cells are the same). closed: s bounds a solid
 * that ray crossings can classify. */
pf_status pf_octree_mesh(pf_mesh *m, const pf_surface *s, const pf_octree_params *params,
                      pf_vec3 lo, pf_vec3 hi, bool closed, pf_octree_stats *stats,
                      pf_error *err);


#endif
