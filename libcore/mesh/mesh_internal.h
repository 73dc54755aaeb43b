/* Internal to libcore/mesh: the pieces, gluing and sliver merging of the slicer (slice.c), shared
 * with the octree builder (octree.c), the triangle-box test of the voxelizer (voxelize.c), and the
 * ray-vote inside test both use (ray_vote.c). */
#ifndef PF_MESH_INTERNAL_H
#define PF_MESH_INTERNAL_H

#include <pf/mesh.h>
#include <pf/split.h>

/* One closed polyhedron with its own nodes, all arrays owned (pf_alloc). */
typedef struct piece {
    int32_t n_nodes;
    double *x;           /* [3 n_nodes] */
    double lo[3], hi[3]; /* bounding box of the nodes (pf_update_bounds) */
    int32_t n_faces;
    int64_t *face_offsets; /* [n_faces + 1] */
    uint32_t *face_nodes;  /* outward, counter-clockwise seen from outside */
} piece;

void pf_piece_release(piece *p);
/* A borrowed pf_polyhedron view of p. */
pf_polyhedron pf_piece_view(const piece *p);
void pf_update_bounds(piece *p);
/* Piece k of a split with only the nodes its faces use; remap [s->n_nodes] must be all -1 and is
 * left so. */
pf_status pf_extract_piece(const pf_split *s, int32_t k, int32_t *remap, piece *out, pf_error *err);
/* The closed surface s as one piece (its triangles the faces). */
pf_status pf_surface_piece(const pf_surface *s, piece *p, pf_error *err);

/* Hash of a point's exact coordinates (-0 and +0 alike), for merging nodes by coordinates. */
uint64_t pf_hash_point(const double *p);
/* A 64-bit finaliser (MurmurHash3's): every input bit affects every output bit. */
uint64_t pf_hash_mix(uint64_t h);

/* Grows *remap (*cap entries, all -1) to at least n entries, the new ones -1. PF_ERR_NOMEM. */
pf_status pf_remap_reserve(int32_t **remap, int32_t *cap, int32_t n, pf_error *err);

/* Builds a mesh from closed pieces: nodes merged by exact coordinates (-0 = +0), faces by their
 * node sets; a face met a second time is used reversed, a third time is an error. Zero-initialise
 * before the first pf_glue_piece. */
typedef struct glue {
    /* nodes */
    int32_t n_nodes, cap_nodes;
    double *x;
    int64_t node_slots;  /* power of two */
    int32_t *node_table; /* -1 empty */
    /* faces: CSR, and a hash of their sorted node lists */
    int32_t n_faces, cap_faces;
    int64_t *face_offsets;
    pf_buffer face_nodes; /* uint32 */
    int64_t face_slots;
    int32_t *face_table;
    int32_t *face_uses; /* [cap_faces] elements using the face so far */
    /* elements */
    int32_t n_elems;
    pf_buffer elem_faces;   /* uint32 face | reversed */
    pf_buffer elem_offsets; /* int64 */
    int64_t longest_face;   /* nodes of the longest glued face */
    uint32_t *scratch;      /* [3 longest_face]: a face, its sorted copy, a compared face */
} glue;

/* Adds p (read only) as one element. PF_ERR_NUMERIC when a face would get a third user. */
pf_status pf_glue_piece(glue *g, const piece *p, pf_error *err);
void pf_glue_release(glue *g);
/* The glued mesh, derived. */
pf_status pf_glue_to_mesh(const glue *g, pf_mesh *m, pf_error *err);

/* Sliver merging (DG paper sec. 9.4) on a derived mesh: parent[n_elems] receives a union-find
 * forest in which every group below min_volume (model units cubed) is joined to the neighbouring
 * group sharing the most face area with it, groups in index order (sweeps repeated until none
 * below min_volume has a neighbour left); *merged counts the joins, *isolated the groups left
 * below min_volume because they touch no other element. elem_min, when not NULL, gives every
 * element its own threshold instead ([n_elems]; a group's is its first member's). */
pf_status pf_merge_slivers(const pf_mesh *m, double min_volume, const double *elem_min,
                           int32_t *parent, int32_t *merged, int32_t *isolated, pf_error *err);
/* out: m with every group of parent one element (faces inside a group dropped, nodes compacted),
 * derived. parent is path-compressed in place. */
pf_status pf_rebuild_merged(const pf_mesh *m, int32_t *parent, pf_mesh *out, pf_error *err);

/* Separating-axis test of the triangle (t0, t1, t2) against the cube of the given centre and half
 * edge, strict: touching is not overlapping. 1 when they overlap. */
int pf_triangle_overlaps_box(pf_vec3 t0, pf_vec3 t1, pf_vec3 t2, pf_vec3 centre, double half);

/* The ray-vote inside test (ray_vote.c), shared by the voxelizer and the octree: for each of the
 * three axes, cast one ray per row of points (pf_ray_voter_cast), then ask at each point's parameter
 * along it, in ascending order (pf_ray_voter_inside_at); a point is inside when RAY_VOTES_INSIDE of
 * its three rays say so. */
typedef struct ray_voter {
    pf_rayscene *rs;
    double merge_eps;  /* crossings of one sign closer than this along a ray are one */
    pf_crossing *buf;  /* [cap] the crossings of the latest ray, n of them, sorted by t */
    int64_t n, cap;
    int64_t next;      /* crossings before the latest point asked about */
    int winding;       /* winding number there */
} ray_voter;
enum { RAY_VOTES_INSIDE = 2 };

/* Builds the ray scene over s (closed triangle surface). merge_eps: see pf_rayscene_crossings. */
pf_status pf_ray_voter_create(ray_voter *v, const pf_surface *s, double merge_eps, pf_error *err);
/* The crossings of org + t dir, 0 <= t <= span, the scratch grown as needed. */
pf_status pf_ray_voter_cast(ray_voter *v, pf_vec3 org, pf_vec3 dir, double span, pf_error *err);
/* True when the latest ray's winding number at parameter t is non-zero; t must not decrease
 * between calls after a cast. */
bool pf_ray_voter_inside_at(ray_voter *v, double t);
void pf_ray_voter_release(ray_voter *v);

/* ---- carrying labels across a change of elements (carry.c) -------------------------------- */

/* The label of the boundary face of the old elements olds[n_olds] (derived old mesh) that face f
 * of next lies in (coplanar: unit normals within 1e-9, centroid within 1e-9 of f's size of its
 * plane), among faces with a non-zero label; 0 when none. */
int32_t pf_mesh_label_under(const pf_mesh *next, int32_t f, const pf_mesh *old,
                            const int32_t *olds, int32_t n_olds, const int32_t *label);

/* Union-find over element indices: the root (path halving), and the union keeping the smaller
 * root, so that roots are deterministic. */
static inline int32_t pf_uf_find(int32_t *p, int32_t i)
{
    while (p[i] != i)
        i = p[i] = p[p[i]];
    return i;
}

static inline void pf_uf_union(int32_t *p, int32_t a, int32_t b)
{
    a = pf_uf_find(p, a), b = pf_uf_find(p, b);
    if (a < b)
        p[b] = a;
    else if (b < a)
        p[a] = b;
}

#endif
