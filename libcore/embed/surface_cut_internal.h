/* Private to libcore/embed/surface_cut*.c: the surface being cut, the planes of the opened faces
 * and the points made on them. */
#ifndef PF_SURFACE_CUT_INTERNAL_H
#define PF_SURFACE_CUT_INTERNAL_H

#include <stdbool.h>

#include <pf/cut.h>

#include "embed_internal.h"

/* The surface being built: grows by doubling. */
typedef struct sc_surface {
    int32_t n_verts, cap_verts;
    double *x;    /* [3 cap_verts] */
    double *side; /* [3 cap_verts] direction into the vertex's side of the cut (zero: none) */
    int32_t n_tris, cap_tris;
    uint32_t *tri;  /* [3 cap_tris] */
    uint8_t *part;  /* [cap_tris] */
    int32_t *src;   /* [cap_tris] the triangle of the input a triangle is part of, -1 for caps */
    double *normal; /* [3 cap_tris] a cap's outward normal (that of the cap it is part of once a
                       later plane splits it), zero for the others */
} sc_surface;

/* The opened faces on one plane. Sides are signs with respect to plane.n. */
typedef struct sc_group {
    pf_plane plane;
    double tol; /* on-plane and coincidence tolerance, model units */
    int ax[2];  /* the coordinates kept by the projection onto the plane */
    int32_t n_faces;
    int32_t *face;        /* [n_faces] mesh faces, increasing */
    int8_t *side;         /* [n_faces] the side of the face's element */
    int64_t *uv_offsets;  /* [n_faces + 1] */
    double *uv;           /* [2 uv_offsets[n_faces]] projected corners, stored order */
    int32_t *corner_edge; /* [uv_offsets[n_faces]] the edge from corner k to corner k + 1 */
    double *box;          /* [4 n_faces] projected boxes, padded by tol */
    int32_t n_edges;      /* distinct edges (by canonical nodes) */
    int32_t *edge_node;   /* [2 n_edges] canonical nodes */
    int32_t *canon;       /* [m->n_nodes] the lowest node at the same position among the nodes
                             of the group's faces, -1 for other nodes */
} sc_group;

/* A point on the plane of the group being processed: a vertex of the surface, a point made on
 * an edge of it or inside a triangle, or a node of an opened face. id[0] = id[1]: its vertex
 * (made on first use; surface_dup.c later gives each side of a slit its own). */
typedef struct sc_point {
    pf_vec3 x;
    pf_vec3 side; /* its side direction before this plane */
    int32_t orig; /* the surface vertex it is, or -1 */
    int32_t id[2];
    int32_t node[2]; /* corner of opened faces: the mesh node on each side, else -1 */
    uint8_t used;    /* ends the section of a triangle with a slit: its other triangles are
                        split there too */
} sc_point;

/* A piece of the section of a triangle lying on opened faces. */
typedef struct sc_section {
    int32_t p, q;    /* points */
    int32_t face[2]; /* the group's face holding it on each side, or -1 */
    pf_vec3 normal;  /* the triangle's normal: the surface's inside lies against it */
} sc_section;

typedef struct sc_state {
    const pf_mesh *m;
    sc_surface *s;
    sc_group *g;
    int32_t n_points, cap_points;
    sc_point *pt;
    int32_t n_sec, cap_sec;
    sc_section *sec;
    int64_t n_seg, cap_seg;
    double *seg;       /* [4 cap_seg] the whole section of the surface, projected, less that of
                          the caps made by earlier groups of this cut */
    int32_t *node_pt;  /* [m->n_nodes] point of a canonical node, -1 */
    int32_t *cap_pt;   /* [m->n_nodes] point of a node as a cap corner, -1 */
    int32_t *cap_vert; /* [m->n_nodes] vertex of a node as a cap corner (all planes), -1 */
    int64_t n_slit, cap_slit;
    uint64_t *slit; /* the slits: surface edges (lo << 32 | hi) on opened faces */
    bool closed;    /* the input surface is closed */
    const pf_surface *in; /* the input surface */
    int8_t *in_cls;       /* [in->n_verts] its vertices against the group's plane: -1, 0, +1 */
    int64_t n_iseg, cap_iseg;
    double *iseg; /* [4 cap_iseg] the section of the input surface by the group's plane,
                     projected: the inside test of the caps (the surface being built is open
                     where caps of the groups still to come are missing) */
    pf_surface_cut_stats *stats;
} sc_state;

pf_status pf_sc_add_vertex(sc_surface *s, pf_vec3 x, pf_vec3 side, int32_t *id, pf_error *err);
pf_status pf_sc_add_tri(sc_surface *s, uint32_t a, uint32_t b, uint32_t c, uint8_t part,
                        int32_t src, pf_vec3 normal, pf_error *err);
/* A new point (orig: the surface vertex it is, or -1). */
pf_status pf_sc_new_point(sc_state *c, pf_vec3 x, pf_vec3 side, int32_t orig, int32_t *out,
                          pf_error *err);
/* Splits every triangle of c->s crossing the group's faces and gives the corners on the plane
 * of the others their side's vertex; records the section. split_src[input triangles] marks the
 * input triangles split (counted in c->stats). */
pf_status pf_sc_split(sc_state *c, uint8_t *split_src, pf_error *err);
/* The vertex of point i (the same on both sides sigma; made on first use). */
pf_status pf_sc_point_id(sc_state *c, int32_t i, int sigma, int32_t *id, pf_error *err);
/* The point of the canonical node n (made on first use). */
pf_status pf_sc_node_point(sc_state *c, int32_t n, int32_t *out, pf_error *err);
/* The first face of the group on side sigma holding the projected point (within tol), or -1. */
int32_t pf_sc_face_at(const sc_group *g, double u, double v, int sigma);
/* Records the slit u-v. */
pf_status pf_sc_push_slit(sc_state *c, int32_t u, int32_t v, pf_error *err);
/* The point of mesh node n (of the group's faces) as a cap corner (made on first use). */
pf_status pf_sc_cap_point(sc_state *c, int32_t n, int32_t *out, pf_error *err);
/* After every plane: each vertex on a slit gets one vertex per group of its triangles joined
 * around it by edges that are not slits (cap triangles, src -1, take the copy on their side);
 * copies get the direction into their triangles as their side. */
pf_status pf_sc_duplicate(sc_state *c, pf_error *err);
/* After the duplication: each triangle with a border edge u -> v that a path of border edges
 * v -> ... -> u retraces through vertices on it (within tol: corners a later group made on an
 * earlier cap's edge) is split at those vertices (surface_tjunction.c). */
pf_status pf_sc_close_t_junctions(sc_state *c, double tol, pf_error *err);
/* Caps of every face of the group (after its triangles are split). */
pf_status pf_sc_caps(sc_state *c, pf_error *err);

#endif
