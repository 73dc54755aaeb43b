/* Private to libcore/embed: element boundaries, bucket grids, point location, row builder. */
#ifndef PF_EMBED_INTERNAL_H
#define PF_EMBED_INTERNAL_H

#include <stdbool.h>

#include <pf/embed.h>

/* The parameters with zero fields replaced by the defaults, checked. */
pf_status pf_embed_resolve_params(const pf_embed_params *in, pf_embed_params *out, pf_error *err);

/* A mesh with elements and finite coordinates of mesh and surface (PF_ERR_INVALID). */
pf_status pf_embed_check_inputs(const pf_mesh *m, const pf_surface *s, pf_error *err);

/* Every element's boundary as outward triangles on mesh nodes, and its distinct nodes. Each mesh
 * face is triangulated once, in its stored orientation, and flipped for the element using it
 * reversed, so two neighbours see the same triangles on their shared face (bary stays C0). */
typedef struct elem_geometry {
    int32_t n_elems;
    int64_t *tri_offsets;  /* [n_elems + 1] */
    uint32_t *tri;         /* [3 tri_offsets[n_elems]] mesh node indices, outward */
    int64_t *node_offsets; /* [n_elems + 1] */
    uint32_t *nodes;       /* [node_offsets[n_elems]] distinct, in order of first appearance */
    double *box;           /* [6 n_elems]: lo xyz, hi xyz */
    uint8_t *kind;         /* [n_elems] pf_elem_kind */
    int32_t max_nodes;     /* largest distinct node count of an element */
} elem_geometry;

pf_status pf_elem_geometry_build(const pf_mesh *m, elem_geometry *g, pf_error *err);
void pf_elem_geometry_release(elem_geometry *g);

/* Items (boxes) registered in every cell of a uniform grid their box overlaps. */
typedef struct bucket_grid {
    pf_vec3 origin;
    double h;       /* cell edge */
    int32_t n[3];   /* cells per axis, each >= 1 */
    int64_t *offsets; /* [cells + 1] */
    int32_t *items;   /* [offsets[cells]] item indices, increasing within a cell */
} bucket_grid;

/* box[6 i] = lo xyz, hi xyz of item i. Cells of about h (enlarged so that the grid has at most
 * about 8 cells per item) over the union of the boxes. */
pf_status pf_bucket_grid_build(bucket_grid *g, const double *box, int32_t n_items, double h,
                            pf_error *err);
void pf_bucket_grid_release(bucket_grid *g);
/* Cell coordinates of p, clamped to the grid. */
void pf_bucket_grid_cell(const bucket_grid *g, pf_vec3 p, int32_t c[3]);
static inline int64_t bucket_grid_index(const bucket_grid *g, int32_t i, int32_t j, int32_t k)
{
    return ((int64_t)k * g->n[1] + j) * g->n[0] + i;
}
/* Calls visit(ctx, item) for the items of every cell that the cube of half side reach around x
 * overlaps (clamped to the grid; reach 0: x's cell), cell by cell, an item once per cell it is
 * in. Stops at the first call that returns non-zero and returns its value; 0 when all returned
 * 0. Inline, so that a walk with a constant visit compiles to the plain loops. */
static inline int pf_bucket_grid_visit(const bucket_grid *g, pf_vec3 x, double reach,
                                       int (*visit)(void *ctx, int32_t item), void *ctx)
{
    int32_t lo[3], hi[3];
    pf_bucket_grid_cell(g, pf_v3_sub(x, pf_v3(reach, reach, reach)), lo);
    pf_bucket_grid_cell(g, pf_v3_add(x, pf_v3(reach, reach, reach)), hi);
    for (int32_t k = lo[2]; k <= hi[2]; ++k)
        for (int32_t j = lo[1]; j <= hi[1]; ++j)
            for (int32_t i = lo[0]; i <= hi[0]; ++i) {
                int64_t cell = bucket_grid_index(g, i, j, k);
                for (int64_t q = g->offsets[cell]; q < g->offsets[cell + 1]; ++q) {
                    int r = visit(ctx, g->items[q]);
                    if (r)
                        return r;
                }
            }
    return 0;
}

/* Point location in the elements of a mesh. */
typedef struct locator {
    const pf_mesh *mesh;
    elem_geometry geo;
    bucket_grid grid;
    double tol;      /* inside when this close to an element (model units) */
    uint32_t *stamp; /* [n_elems] visit marks of the nearest-element search */
    uint32_t now;
} locator;

pf_status pf_locator_build(locator *L, const pf_mesh *m, pf_error *err);
void pf_locator_release(locator *L);
/* The element containing p (winding number >= 1/2 over its boundary), else the nearest one;
 * *dist: 0 inside, else the distance to that element's boundary. */
int32_t pf_locator_find(locator *L, pf_vec3 p, double *dist);

/* Distance from p to the triangle (a, b, c). */
double pf_point_triangle_distance(pf_vec3 p, pf_vec3 a, pf_vec3 b, pf_vec3 c);

/* Weighted affine least squares at the origin: points d[3 n] (offsets from the evaluation point,
 * scaled to about unit size), weights theta[n] > 0. On success out[n] holds the W_i with
 * sum W_i = 1 and sum W_i d_i = 0 (affine reproduction) and the function returns true; it returns
 * false when the weighted covariance has smallest/largest eigenvalue below min_spread or n < 4. */
int pf_affine_fit_weights(const double *d, const double *theta, int32_t n, double min_spread,
                       double *out);

/* The weights of p by element e's own functions (bary.c): barycentric on a tet, trilinear on a
 * hex, mean value coordinates on a general polyhedron; where those cannot be evaluated (*fallback
 * set), the affine least-squares fit of the element's nodes. col and val hold at least
 * max(8, L->geo.max_nodes) entries, scratch 4 times that. Returns 0 when no fit exists. */
int pf_embed_elem_weights(const pf_mesh *m, const locator *L, int32_t e, pf_vec3 p, uint32_t *col,
                          double *val, double *scratch, int32_t *n, bool *fallback);

/* The visibility rule (visibility.c): blocking faces of a mesh, each a plane and a polygon
 * projected on the coordinate plane most nearly parallel to it, in a bucket grid. */
typedef struct visibility {
    int32_t n_faces;      /* blocking faces */
    int32_t n_nodes;
    int32_t *face;        /* [n_faces] mesh face */
    pf_plane *plane;      /* [n_faces] */
    double *tol;          /* [n_faces] crossing tolerance, model units */
    uint8_t *axes;        /* [2 n_faces] the two coordinates of the projection */
    int64_t *uv_offsets;  /* [n_faces + 1] */
    double *uv;           /* [2 uv_offsets[n_faces]] projected polygons */
    double *box;          /* [6 n_faces] padded by tol */
    double *node_dir;     /* [3 n_nodes] unit sum of the inward normals of the blocking faces a
                             node is a corner of (zero: none, or cancelled at the crack front) */
    double *node_tol;     /* [n_nodes] the smallest tolerance of those faces */
    double min_diam;      /* smallest blocking face diameter */
    bucket_grid grid;
    uint32_t *stamp;      /* [n_faces] */
    uint32_t now;
    int32_t *cand;        /* [n_faces] the faces of the last gather, increasing */
    int32_t n_cand;
    int32_t *elem_body;   /* [n_elems] the body of each element: the connected groups of
                             elements through shared faces (the pieces a cut separated) */
    int32_t *node_body;   /* [n_nodes] the body of the elements using a node; -1: none uses it,
                             -2: elements of several bodies do (a mesh touching itself at a node) */
} visibility;

/* blocking[m->n_faces]: nonzero for blocking faces (may be none). PF_ERR_NOMEM. */
pf_status pf_visibility_build(visibility *v, const pf_mesh *m, const uint8_t *blocking,
                              pf_error *err);
void pf_visibility_release(visibility *v);
/* Whether a vertex of body `body` may take node: the node is of that body (or shared by
 * several). */
static inline bool pf_visibility_same_body(const visibility *v, int32_t body, int32_t node)
{
    int32_t b = v->node_body[node];
    return b == body || b == -2;
}
/* Gathers the blocking faces whose boxes meet the cube of half side reach around x (the
 * candidates of the next queries); returns their count. */
int32_t pf_visibility_gather(visibility *v, pf_vec3 x, double reach);
/* True when node (at b) is hidden from a: a lies behind the node's side of the cut (against
 * node_dir, beyond node_tol), or the segment a-b strictly crosses one of the gathered faces. */
bool pf_visibility_blocked(const visibility *v, pf_vec3 a, int32_t node, pf_vec3 b);
/* x nudged along dir (any length; zero: x unchanged) by 1e-6 of the smallest gathered face's
 * diameter: a vertex on a cut seen from its own side. */
pf_vec3 pf_visibility_nudge(const visibility *v, pf_vec3 x, pf_vec3 dir);
/* Point (px, py) in the 2D polygon uv[2 n] (crossing parity) or within tol of its edges. */
bool pf_polygon2_contains(const double *uv, int64_t n, double px, double py, double tol);

/* A weight matrix built row by row. */
typedef struct row_builder {
    pf_weights *w;
    int64_t nnz;
    int64_t cap;
} row_builder;

pf_status pf_row_builder_init(row_builder *b, pf_weights *w, int32_t rows, int32_t cols,
                           int64_t cap_hint, pf_error *err);
/* Appends row i (rows in order) with n entries, sorted by column here. */
pf_status pf_row_builder_add(row_builder *b, int32_t i, uint32_t *col, double *val, int32_t n,
                          pf_error *err);
/* Shrinks the arrays to the entries written. */
void pf_row_builder_finish(row_builder *b);

/* The two methods, filling b for every vertex and the method's statistics. */
/* With p->blocking_faces, the visibility rule; p->vertex_side nudges the vertices seen from. */
/* steps (may be NULL): [s->n_verts] each row's growth step (pf_embed_compute_steps). */
pf_status pf_embed_mls(const pf_mesh *m, const pf_surface *s, const pf_embed_params *p,
                       locator *L, row_builder *b, int32_t *steps, pf_embed_stats *stats,
                       pf_error *err);
/* harmonic: general polyhedra weighted by their harmonic (CG) functions, not mean value
 * coordinates. vertex_side: as pf_embed_params (may be NULL). */
pf_status pf_embed_bary(const pf_mesh *m, const pf_surface *s, const double *vertex_side,
                        locator *L, bool harmonic, row_builder *b, pf_embed_stats *stats,
                        pf_error *err);

#endif
