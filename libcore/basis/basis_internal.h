/* Internal to libcore/basis: face functions, least squares, the exactness projection. */
#ifndef PF_BASIS_INTERNAL_H
#define PF_BASIS_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <string.h>

#include <pf/basis.h>

/* Element data layouts (doubles at data + data_offsets[e]):
 *   tet, hex:  x0[3], minv[9] (row-major inverse of the edge matrix [e1 e2 e3]); the reference
 *              coordinates are l = minv (x - x0); node_slot is the corner (tet: 0..3, hex: bits
 *              of (l0, l1, l2)).
 *   harmonic:  c[3], h, nk, ng, kern[3 nk], coef[(nk + N_POLY) ng] (row j over groups: kernels
 *              1/r, then y_x, y_y, y_z, 1, then harmonic_high), gpos[3 ng], q[4 ng], gcount[ng];
 *              in scaled coordinates
 *              y = (x - c) / h; node_slot is the merged group.
 * HDR doubles of header (harmonic: c[3], h, nk, ng) come first. */
enum { HDR = 6 };

/* Polynomial columns of a harmonic element after its nk kernels: y_x, y_y, y_z, 1 (eq. 11's
 * linear part), then N_HIGH harmonic polynomials of degrees 2 and 3 (harmonic_high). */
enum { N_LINEAR = 4, N_HIGH = 12, N_POLY = N_LINEAR + N_HIGH };

/* The harmonic polynomials of degree 2 and 3 at y (scaled coordinates): xy, yz, zx, x^2 - y^2,
 * y^2 - z^2; xyz, x^3 - 3xy^2, y^3 - 3x^2y, y^3 - 3yz^2, z^3 - 3y^2z, z^3 - 3x^2z, x^3 - 3xz^2
 * (each cubic holds a monomial no other has, so the 7 are independent: all of the cubics'
 * 7-dimensional harmonic space). With gradients when d is not NULL: d[3 a + k] = d v_a / d y_k. */
static inline void harmonic_high(const double *y, double *v, double *d)
{
    double x = y[0], yy = y[1], z = y[2];
    double x2 = x * x, y2 = yy * yy, z2 = z * z;
    v[0] = x * yy, v[1] = yy * z, v[2] = z * x, v[3] = x2 - y2, v[4] = y2 - z2;
    v[5] = x * yy * z;
    v[6] = x * (x2 - 3 * y2), v[7] = yy * (y2 - 3 * x2), v[8] = yy * (y2 - 3 * z2);
    v[9] = z * (z2 - 3 * y2), v[10] = z * (z2 - 3 * x2), v[11] = x * (x2 - 3 * z2);
    if (!d)
        return;
    const double g[N_HIGH][3] = {
        {yy, x, 0},
        {0, z, yy},
        {z, 0, x},
        {2 * x, -2 * yy, 0},
        {0, 2 * yy, -2 * z},
        {yy * z, x * z, x * yy},
        {3 * (x2 - y2), -6 * x * yy, 0},
        {-6 * x * yy, 3 * (y2 - x2), 0},
        {0, 3 * (y2 - z2), -6 * yy * z},
        {0, -6 * yy * z, 3 * (z2 - y2)},
        {-6 * x * z, 0, 3 * (z2 - x2)},
        {3 * (x2 - z2), 0, -6 * x * z},
    };
    memcpy(d, g, sizeof g);
}

/* Face (2D) counterpart: after the kernels, u, v, 1, then the harmonic polynomials
 * Re, Im (u + iv)^2 and (u + iv)^3 (face_high). */
enum { N_LINEAR2 = 3, N_HIGH2 = 4, N_POLY2 = N_LINEAR2 + N_HIGH2 };

static inline void face_high(double u, double v, double *h)
{
    double u2 = u * u, v2 = v * v;
    h[0] = u2 - v2, h[1] = u * v, h[2] = u * (u2 - 3 * v2), h[3] = v * (3 * u2 - v2);
}

/* Least-squares QR (pf_lsq_solve): column block, and the smallest system blocked. */
enum { QR_BLOCK = 32, QR_BLOCKED_MIN = 64 };

/* Growable scratch reused from element to element (setup allocates only when an element is
 * larger than every earlier one). */
enum {
    WS_A,
    WS_A0,
    WS_B,
    WS_B0,
    WS_WORK,
    WS_IWORK,
    WS_SING,
    WS_TFACTOR,
    WS_KERN,
    WS_FACEVAL,
    WS_EFACE,
    WS_EFOFF,
    WS_EREV,
    WS_ELOCAL,
    WS_EDGES,
    WS_PTS,
    WS_COUNT
};
typedef struct basis_ws {
    void *buf[WS_COUNT];
    size_t cap[WS_COUNT]; /* bytes */
} basis_ws;

/* count * size bytes of buffer `which`, its earlier contents lost; NULL on overflow / no memory. */
void *pf_ws_get(basis_ws *w, int which, size_t count, size_t size);
void pf_ws_release(basis_ws *w);

typedef enum face_kind { FACE_NONE = 0, FACE_LINEAR, FACE_BILINEAR, FACE_MFS } face_kind;

/* A mesh face in its own frame, with its 2D harmonic coordinates once solved. Points of the face
 * map to scaled 2D coordinates p = ((x - o).u, (x - o).v) / s; nrm = u x v is the normal of the
 * face as stored (counter-clockwise about nrm). */
typedef struct face_fn {
    int32_t n;             /* nodes */
    const uint32_t *nodes; /* [n] borrowed from the mesh */
    pf_vec3 o, u, v, nrm;
    double s;    /* largest node distance from o (model units) */
    double diam; /* largest node-to-node distance (model units) */
    double *p2;  /* [2 n] scaled 2D node coordinates */
    face_kind kind;
    /* closed forms: node a0 (2D) and the inverse of the 2x2 edge matrix; corner bits */
    double a0[2], minv[4];
    int32_t bits[4];
    /* MFS (FACE_MFS): merged groups, kernels, coefficients, exactness projection */
    int32_t n_groups;
    int32_t *slot;  /* [n] group of each node */
    double *gcount; /* [n_groups] nodes per group */
    double *gpos;   /* [2 n_groups] scaled group positions */
    double *q;      /* [3 n_groups] projection (P^T P)^-1 P^T, stored per group */
    int32_t nk;
    double *kern; /* [2 nk] scaled kernel centres */
    double *coef; /* [(nk + N_POLY2) n_groups], row j over groups: kernels, u, v, 1, face_high */
    double setup_ms;
} face_fn;

/* Frame and 2D coordinates of face f of m (no solve). PF_ERR_INVALID for a degenerate face. */
pf_status pf_face_init(face_fn *f, const pf_mesh *m, int32_t face, pf_error *err);
/* Solves the face's functions (closed form or 2D MFS). */
pf_status pf_face_solve(face_fn *f, const pf_mesh *m, int32_t face, const pf_basis_params *p,
                        basis_ws *w, pf_error *err);
void pf_face_release(face_fn *f);

/* Scaled 2D coordinates of a model point on (or projected onto) the face. */
static inline void face_coords(const face_fn *f, pf_vec3 x, double *pu, double *pv)
{
    pf_vec3 d = pf_v3_sub(x, f->o);
    *pu = pf_v3_dot(d, f->u) / f->s;
    *pv = pf_v3_dot(d, f->v) / f->s;
}

/* vals[a] = value of the face function of node a (face order) at the model point x. */
void pf_face_eval(const face_fn *f, pf_vec3 x, double *vals);

/* Crossing-number point-in-polygon test, polygon p[2 n]. */
bool pf_polygon_contains(const double *p, int32_t n, double x, double y);
/* Distance from (x, y) to the polygon's boundary. */
double pf_polygon_boundary_distance(const double *p, int32_t n, double x, double y);

/* Least squares min |A X - B| for g right-hand sides: A m x cols, B m x g (column-major, leading
 * dimension ldb >= max(m, cols)), both overwritten; X in B's first cols rows. Blocked QR (dgeqrt),
 * SVD (dgelsd) when the QR factor's reciprocal condition is below rcond. A0 / B0 are untouched
 * copies used for the SVD retry. */
pf_status pf_lsq_solve(basis_ws *w, int32_t m, int32_t cols, int32_t g, double rcond,
                       bool *used_svd, pf_error *err);

/* q[(dim+1) g + c] = ((P^T P)^-1 P^T)[c][g] for P with rows (1, pos_g), g < ng. PF_ERR_NUMERIC
 * when the positions do not span dim dimensions. */
pf_status pf_exactness_projection(int dim, int32_t ng, const double *pos, double *q);

/* G (ng values) <- G + (t - G P) Q: the smallest change making sum_g G_g (1, pos_g) = t. Inline
 * and written out per dimension: it runs for every row of every evaluation (4 per point with
 * gradients), and the generic loops over dim + 1 terms were a sixth of the CG set-up. */
static inline void apply_projection(int dim, int32_t ng, const double *pos, const double *q,
                                    const double *t, double *G)
{
    if (dim == 3) {
        double r0 = t[0], r1 = t[1], r2 = t[2], r3 = t[3];
        for (int32_t g = 0; g < ng; ++g) {
            double v = G[g];
            r0 -= v;
            r1 -= v * pos[3 * g];
            r2 -= v * pos[3 * g + 1];
            r3 -= v * pos[3 * g + 2];
        }
        for (int32_t g = 0; g < ng; ++g)
            G[g] += r0 * q[4 * g] + r1 * q[4 * g + 1] + r2 * q[4 * g + 2] + r3 * q[4 * g + 3];
        return;
    }
    double r0 = t[0], r1 = t[1], r2 = t[2];
    for (int32_t g = 0; g < ng; ++g) {
        double v = G[g];
        r0 -= v;
        r1 -= v * pos[2 * g];
        r2 -= v * pos[2 * g + 1];
    }
    for (int32_t g = 0; g < ng; ++g)
        G[g] += r0 * q[3 * g] + r1 * q[3 * g + 1] + r2 * q[3 * g + 2];
}

/* ---- element context (basis.c), boundary samples and the surface patch (sample.c) ---------- */

typedef struct edge3 {
    int32_t a, b;   /* local nodes */
    int32_t f1, f2; /* local faces */
} edge3;

typedef struct pt3 {
    pf_vec3 x, nrm; /* position, outward direction for kernels */
    int32_t a, b;   /* node a (a == b) or edge a-b at parameter t; face point when face >= 0 */
    double t;
    int32_t face; /* local face index, -1 for node / edge points */
    double len;   /* local sample spacing: shortest edge at a node, the spacing along the edge
                     or of the face's grid */
} pt3;

typedef struct pt_list {
    pt3 *p;
    int32_t n, cap;
} pt_list;

/* Inner patch vertices (surface vertices inside a cell) handled by the smooth patch data; a
 * patch with more keeps the per-facet data. Faces of an element the patch test looks at. */
enum { PATCH_MAX_INNER = 32, PATCH_MAX_FACES = 512 };

typedef struct elem_ctx {
    const pf_mesh *m;
    face_fn *faces;           /* all mesh faces, frames made lazily */
    const uint8_t *face_uses; /* [n_faces] elements using each face (1: on the mesh boundary) */
    int32_t e, nf, k, ng, ne;
    int32_t *face_id;  /* [nf] */
    int8_t *face_rev;  /* [nf] */
    int64_t *floc_off; /* [nf + 1] into floc */
    int32_t *floc;     /* local index of each face node */
    int32_t nodes[PF_BASIS_MAX_NODES], slot[PF_BASIS_MAX_NODES];
    pf_vec3 pos[PF_BASIS_MAX_NODES], nnrm[PF_BASIS_MAX_NODES];
    double nlen[PF_BASIS_MAX_NODES];  /* shortest edge at each node */
    double nfeat[PF_BASIS_MAX_NODES]; /* feature size at each node: nlen, or less when the node
                                         is closer to an edge of one of its faces */
    double gcount[PF_BASIS_MAX_NODES];
    int32_t grep[PF_BASIS_MAX_NODES]; /* representative node of each group */
    edge3 *edges;
    double grade_scale; /* factor of the grading rate (1; more when over the kernel budget) */
    bool patch_grading; /* feature sizes from the patch (pf_basis_patch_features): edges inside
                           the patch need no samples of their own */
    pf_vec3 c;
    double h, diam, max_edge;
    /* group positions (scaled) and their exactness projection (pf_exactness_projection) */
    double gpos[3 * PF_BASIS_MAX_NODES], gq[4 * PF_BASIS_MAX_NODES];
    /* The surface patch (sample.c): the element's mesh-boundary faces as one curved face. */
    bool has_patch;
    int8_t in_patch[PATCH_MAX_FACES];      /* [nf] face belongs to the patch */
    face_fn patch;                         /* the loop, projected on the patch's mean plane */
    int32_t patch_loc[PF_BASIS_MAX_NODES]; /* element-local node of each loop vertex */
    uint32_t patch_nodes[PF_BASIS_MAX_NODES];
    int32_t n_inner, inner[PATCH_MAX_INNER];                /* patch nodes off the loop */
    double inner_q[2 * PATCH_MAX_INNER];                    /* their scaled 2D positions */
    double inner_sig[PATCH_MAX_INNER];                      /* bump widths */
    double inner_D[PATCH_MAX_INNER * PATCH_MAX_INNER];      /* bump combination: Kronecker */
    double inner_phi[PATCH_MAX_INNER * PF_BASIS_MAX_NODES]; /* loop functions at inner nodes */
} elem_ctx;

static inline pf_vec3 face_out_normal(const elem_ctx *c, int32_t lf)
{
    pf_vec3 nn = c->faces[c->face_id[lf]].nrm;
    return c->face_rev[lf] ? pf_v3_scale(nn, -1) : nn;
}

pf_status pf_basis_pts_push(pt_list *l, pt3 v, pf_error *err);

/* Uniform boundary samples (sample.c): nodes (one per group); on each edge of length L,
 * n = max(edge_min, ceil(L / edge_spacing) - 1) points (edge_phase 0: t = j / (n + 1), j = 1..n;
 * 0.5: t = (j + 0.5) / (n + 1), j = 0..n); on each face a square grid of the given spacing
 * (offset by grid_phase cells) inside the face and at least margin from its boundary. */
pf_status pf_basis_uniform_samples(const elem_ctx *c, double edge_spacing, int32_t edge_min,
                                   double edge_phase, double spacing, double grid_phase,
                                   double margin, pt_list *out, pf_error *err);

/* Boundary samples graded by feature size (sample.c): nodes, points on every edge and a
 * quadtree sampling of every face, with the local spacing
 *   h(x) = min(h0, feat_i + s grading |x - x_i|) over the nodes i (s: c->grade_scale),
 * divided by div_edge on edges
 * and div_face on faces (h0 = h0_edge on edges, h0_face on faces); at least edge_min points
 * inside every edge (none needed inside a patch when c->patch_grading); face points at least
 * margin * (their cell size) inside the face. */
pf_status pf_basis_graded_samples(const elem_ctx *c, double h0_edge, double h0_face, double grading,
                                  double div_edge, double div_face, int32_t edge_min, double margin,
                                  pt_list *out, pf_error *err);

/* Sets c->has_patch and the patch of element c when its mesh-boundary faces form one patch
 * whose normals lie within angle_deg of their mean, bounded by one loop, with at most
 * PATCH_MAX_INNER nodes off the loop; needs c->gpos / c->gq. Statuses of pf_face_solve. */
pf_status pf_basis_patch_build(elem_ctx *c, double angle_deg, const pf_basis_params *p, basis_ws *w,
                               pf_error *err);
/* Feature sizes (c->nfeat) of the patch's nodes from what its data resolve: at a loop node the
 * shortest edge at it outside the patch's interior (a loop edge or an edge of a neighbour face)
 * and its distance to the edges of its non-patch faces; at an inner node its bump width. */
void pf_basis_patch_features(elem_ctx *c);
/* Node i's feature size lowered to its distance from local face lf's edges not touching it. */
void pf_basis_face_edge_feature(elem_ctx *c, int32_t lf, int32_t i);
/* Whether sample pt lies on the patch (a patch face, or an edge between two patch faces). */
bool pf_basis_patch_has(const elem_ctx *c, const pt3 *pt);
/* Patch data at pt (a row of c->ng group values, stride ldb). faceval: PF_BASIS_MAX_NODES
 * doubles of scratch. */
void pf_basis_patch_values(const elem_ctx *c, const pt3 *pt, double *faceval, double *B,
                           size_t ldb);

#endif
