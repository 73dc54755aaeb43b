/* Penalty contact with the ground and the scene's obstacles, at boundary nodes or embedded-surface
 * vertices, for every method (contact.h; DG paper sec. 8).
 *
 * Broad phase: the points are ordered along a Morton curve of their rest positions and cut into
 * chunks of CHUNK consecutive points; each step bounds every chunk's predicted positions, and only
 * the points of chunks whose box meets an obstacle's box (a plane: whose box reaches below it) go
 * to the narrow phase. Predicting the positions is one pass over the points (the embedding
 * mat-vec); the narrow phase, the only part whose cost depends on the obstacles, follows the
 * number of points near them. Mesh obstacles answer closest-point queries through Embree.
 *
 * Assembly: the penalties are summed at node level first, C = sum_p k (w_p w_p^T) (x) n n^T and
 * F = sum_p k g w_p n, and only then mapped to the unknowns through the method's nodal map, S^T C S
 * and S^T F (DG paper sec. 8, K_ij = W_i A W_j with W = w S): contacts sharing nodes, as the
 * vertices of a fine surface do, share that work. The matrix pattern holds the couplings of the
 * points that have come near an obstacle only; it grows (and is analysed again) when new ones
 * touch, so a body touching the ground at one end pays fill there alone. */
#include "contact.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { CHUNK = 32 };

/* One obstacle as contact sees it (the ground is a plane among them). */
typedef struct shape {
    const pf_obstacle *o; /* NULL: the ground */
    pf_obstacle_kind kind;
    pf_vec3 n;            /* plane: unit normal */
    double d;             /* plane: n . x = d at rest */
    pf_vec3 lo, hi;       /* sphere, box, mesh: bounds at rest */
    double stiffness;     /* per point */
    double depth;         /* mesh: deepest penetration looked for */
    pf_rayscene *rs;      /* mesh */
} shape;

struct pf_contact {
    const pf_mesh *mesh;
    int64_t n_triples;
    const int64_t *map_offsets, *map_triple;
    const double *map_w;
    /* points: rest positions x0 [3 np] and rows into the nodes (offsets [np + 1], node, w) */
    int32_t np;
    double *x0;
    int64_t *row_offsets;
    int32_t *row_node;
    double *row_w;
    int32_t *order;       /* [np] points along the Morton curve */
    int32_t n_shapes;
    shape *shapes;
    pf_vec3 *shift;       /* [n_shapes] each shape's translation at the end of the step */
    pf_vec3 *velocity;    /* [n_shapes] and its velocity over the step */
    int32_t *triple_block; /* [n_triples] the matrix block of each triple (from the pattern) */
    /* per-step scratch, allocated once */
    double *pred;         /* [3 n_triples] u + h v */
    double *node_u;       /* [3 n_nodes] S (u + h v) */
    double *pos;          /* [3 np] predicted positions */
    int64_t max_row;      /* the longest combination of triples of one point */
    /* The node-level penalty C = sum_p k (w_p w_p^T) (x) n n^T over the contacts, one 3 x 3 block
     * per pair of nodes i <= j sharing a point row (np_offsets [n_nodes + 1], np_col, c_val
     * [9 pairs]), the pairs touched this step listed in used; and the node-level force. The
     * penalty on the unknowns is then S^T C S and S^T F (S the nodal map). */
    int64_t *np_offsets;
    int32_t *np_col;
    double *c_val;
    uint8_t *c_used;
    int64_t *used;
    int64_t n_used;
    double *node_f;       /* [3 n_nodes] */
    double damping_beta;  /* Rayleigh beta: damps contact relative to the obstacle's motion */
    /* the contacts found by pf_contact_detect: point, outward normal, right-hand side gap;
     * capacity np x n_shapes */
    int32_t *hit_point;
    pf_vec3 *hit_normal;
    double *hit_gap;
    double *hit_k;
    int64_t n_hits;
    /* points whose couplings are in the matrix pattern, and those to add at the next growth */
    uint8_t *in_pattern;
    bool grow;
    pf_contact_stats stats;
};

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status count_boundary_nodes(const pf_mesh *m, uint8_t *on, int32_t *count,
                                      pf_error *err);

static pf_status make_shapes(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    const pf_scene *sc = s->scene;
    c->shapes = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->shapes);
    c->shift = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->shift);
    c->velocity = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->velocity);
    PF_CHECK(c->shapes && c->shift && c->velocity, err, PF_ERR_NOMEM, "cannot allocate %d obstacles", (int)sc->n_obstacles);
    /* the automatic stiffness spreads the nodal total over the points */
    double points_per_node = 1;
    if (s->weights) {
        int32_t boundary_nodes = 0;
        PF_TRY(count_boundary_nodes(s->mesh, NULL, &boundary_nodes, err));
        points_per_node = (double)c->np / (boundary_nodes > 0 ? boundary_nodes : 1);
    }
    double automatic = s->auto_stiffness / points_per_node;
    if (sc->ground) {
        shape *g = &c->shapes[c->n_shapes++];
        pf_plane pl = pf_plane_from_point_normal(sc->ground_point, sc->ground_normal);
        g->kind = PF_OBSTACLE_PLANE;
        g->n = pl.n;
        g->d = pl.d;
        g->stiffness = sc->ground_stiffness > 0 ? sc->ground_stiffness : automatic;
    }
    for (int32_t i = 0; i < sc->n_obstacles; ++i) {
        const pf_obstacle *o = &sc->obstacles[i];
        shape *g = &c->shapes[c->n_shapes++];
        g->o = o;
        g->kind = o->kind;
        g->stiffness = o->stiffness > 0 ? o->stiffness : automatic;
        if (o->kind == PF_OBSTACLE_PLANE) {
            pf_plane pl = pf_plane_from_point_normal(o->point, o->normal);
            g->n = pl.n;
            g->d = pl.d;
        } else if (o->kind == PF_OBSTACLE_SPHERE) {
            pf_vec3 r = pf_v3(o->radius, o->radius, o->radius);
            g->lo = pf_v3_sub(o->centre, r);
            g->hi = pf_v3_add(o->centre, r);
        } else if (o->kind == PF_OBSTACLE_BOX) {
            g->lo = o->lo;
            g->hi = o->hi;
        } else {
            const pf_surface *m = &o->surface;
            PF_CHECK(m->n_tris > 0, err, PF_ERR_INVALID,
                     "obstacles[%d].mesh: the surface of '%s' is not loaded", (int)i,
                     o->file ? o->file : "");
            g->depth = o->depth > 0 ? o->depth : 0.1 * s->model_size;
            pf_status st = pf_rayscene_create(&g->rs, m->x, m->n_verts, m->tri, m->n_tris, err);
            if (st < 0) {
                pf_error_prefix(err, "obstacles[%d].mesh", (int)i);
                return st;
            }
            for (int32_t v = 0; v < m->n_verts; ++v) {
                pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)v);
                g->lo = v ? pf_v3_min(g->lo, p) : p;
                g->hi = v ? pf_v3_max(g->hi, p) : p;
            }
            /* an open surface is solid down to depth behind it */
            pf_vec3 e = pf_v3(g->depth, g->depth, g->depth);
            g->lo = pf_v3_sub(g->lo, e);
            g->hi = pf_v3_add(g->hi, e);
        }
    }
    return PF_OK;
}

/* Flags the nodes of boundary faces (on [n_nodes], may be NULL) and counts them. */
static pf_status count_boundary_nodes(const pf_mesh *m, uint8_t *on, int32_t *count,
                                      pf_error *err)
{
    pf_boundary b = {0};
    PF_TRY(pf_boundary_extract(m, &b, err));
    uint8_t *flags = on ? on : pf_calloc((size_t)m->n_nodes + 1, 1);
    if (!flags) {
        pf_boundary_release(&b);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate node flags");
    }
    *count = 0;
    for (int64_t q = 0; q < 3 * b.tri_offsets[b.n_faces]; ++q)
        if (!flags[b.tri[q]]) {
            flags[b.tri[q]] = 1;
            ++*count;
        }
    if (!on)
        pf_free(flags);
    pf_boundary_release(&b);
    return PF_OK;
}

/* Points: the boundary nodes (each its own row), or the surface vertices (the WGHT rows). */
static pf_status make_points(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    const pf_mesh *m = s->mesh;
    if (s->weights) {
        const pf_weights *w = s->weights;
        PF_CHECK(s->surface && w->rows == s->surface->n_verts && w->cols == m->n_nodes, err,
                 PF_ERR_INVALID,
                 "embedding weights of %d x %d do not fit a surface of %d vertices on a mesh of "
                 "%d nodes",
                 (int)w->rows, (int)w->cols, s->surface ? (int)s->surface->n_verts : 0,
                 (int)m->n_nodes);
        c->np = w->rows;
        int64_t nnz = w->row_offsets[w->rows];
        c->x0 = pf_alloc_array(3 * (size_t)c->np + 1, sizeof *c->x0);
        c->row_offsets = pf_alloc_array((size_t)c->np + 1, sizeof *c->row_offsets);
        c->row_node = pf_alloc_array((size_t)nnz + 1, sizeof *c->row_node);
        c->row_w = pf_alloc_array((size_t)nnz + 1, sizeof *c->row_w);
        PF_CHECK(c->x0 && c->row_offsets && c->row_node && c->row_w, err, PF_ERR_NOMEM,
                 "cannot allocate %d contact points", (int)c->np);
        memcpy(c->x0, s->surface->x, 3 * (size_t)c->np * sizeof *c->x0);
        memcpy(c->row_offsets, w->row_offsets, ((size_t)c->np + 1) * sizeof *c->row_offsets);
        for (int64_t q = 0; q < nnz; ++q) {
            c->row_node[q] = (int32_t)w->col[q];
            c->row_w[q] = w->val[q];
        }
        return PF_OK;
    }
    uint8_t *on = pf_calloc((size_t)m->n_nodes + 1, 1);
    PF_CHECK(on, err, PF_ERR_NOMEM, "cannot allocate node flags");
    int32_t np = 0;
    pf_status st = count_boundary_nodes(m, on, &np, err);
    if (st < 0) {
        pf_free(on);
        return st;
    }
    c->np = np;
    c->x0 = pf_alloc_array(3 * (size_t)np + 1, sizeof *c->x0);
    c->row_offsets = pf_alloc_array((size_t)np + 1, sizeof *c->row_offsets);
    c->row_node = pf_alloc_array((size_t)np + 1, sizeof *c->row_node);
    c->row_w = pf_alloc_array((size_t)np + 1, sizeof *c->row_w);
    if (!c->x0 || !c->row_offsets || !c->row_node || !c->row_w) {
        pf_free(on);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %d contact points", (int)np);
    }
    int32_t p = 0;
    c->row_offsets[0] = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        if (!on[i])
            continue;
        memcpy(c->x0 + 3 * (size_t)p, m->x + 3 * (size_t)i, 3 * sizeof *c->x0);
        c->row_node[p] = i;
        c->row_w[p] = 1;
        c->row_offsets[p + 1] = p + 1;
        ++p;
    }
    pf_free(on);
    return PF_OK;
}

/* Spreads the low 10 bits of v to every third bit. */
static uint32_t spread_bits(uint32_t v)
{
    v &= 0x3ff;
    v = (v | (v << 16)) & 0x030000ff;
    v = (v | (v << 8)) & 0x0300f00f;
    v = (v | (v << 4)) & 0x030c30c3;
    v = (v | (v << 2)) & 0x09249249;
    return v;
}

typedef struct keyed {
    uint32_t key;
    int32_t index;
} keyed;

static int compare_keyed(const void *pa, const void *pb)
{
    const keyed *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return (a->index > b->index) - (a->index < b->index);
}

/* The points along the Morton curve of a 1024^3 grid over their rest bounds. */
static pf_status order_points(pf_contact *c, pf_error *err)
{
    c->order = pf_alloc_array((size_t)c->np + 1, sizeof *c->order);
    keyed *k = pf_alloc_array((size_t)c->np + 1, sizeof *k);
    if (!c->order || !k) {
        pf_free(k);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot order %d points",
                            (int)c->np);
    }
    pf_vec3 lo = pf_v3(0, 0, 0), hi = lo;
    for (int32_t p = 0; p < c->np; ++p) {
        pf_vec3 x = pf_v3_load(c->x0 + 3 * (size_t)p);
        lo = p ? pf_v3_min(lo, x) : x;
        hi = p ? pf_v3_max(hi, x) : x;
    }
    double ext = fmax(pf_v3_max_abs(pf_v3_sub(hi, lo)), 1e-300);
    for (int32_t p = 0; p < c->np; ++p) {
        pf_vec3 x = pf_v3_sub(pf_v3_load(c->x0 + 3 * (size_t)p), lo);
        uint32_t i = (uint32_t)(1023 * (x.x / ext)), j = (uint32_t)(1023 * (x.y / ext)),
                 l = (uint32_t)(1023 * (x.z / ext));
        k[p] = (keyed){spread_bits(i) | spread_bits(j) << 1 | spread_bits(l) << 2, p};
    }
    qsort(k, (size_t)c->np, sizeof *k, compare_keyed);
    for (int32_t p = 0; p < c->np; ++p)
        c->order[p] = k[p].index;
    pf_free(k);
    return PF_OK;
}

/* The longest combination of triples any point can have (its nodes' map rows together). */
static int64_t longest_row(const pf_contact *c)
{
    int64_t longest = 0;
    for (int32_t p = 0; p < c->np; ++p) {
        int64_t n = 0;
        for (int64_t q = c->row_offsets[p]; q < c->row_offsets[p + 1]; ++q) {
            int32_t i = c->row_node[q];
            n += c->map_offsets[i + 1] - c->map_offsets[i];
        }
        longest = n > longest ? n : longest;
    }
    return longest;
}

static int compare_i32(const void *pa, const void *pb)
{
    int32_t a = *(const int32_t *)pa, b = *(const int32_t *)pb;
    return (a > b) - (a < b);
}

/* The pairs of nodes i <= j that share a point's row: node -> points, then per node i the
 * nodes j >= i of its points' rows, each once (stamp), sorted for the binary search. */
static pf_status node_pairs(pf_contact *c, pf_error *err)
{
    int32_t nn = c->mesh->n_nodes;
    int64_t nnz = c->row_offsets[c->np];
    int64_t *inv_offsets = pf_calloc((size_t)nn + 2, sizeof *inv_offsets);
    int32_t *inv = pf_alloc_array((size_t)nnz + 1, sizeof *inv);
    int32_t *stamp = pf_alloc_array((size_t)nn + 1, sizeof *stamp);
    c->np_offsets = pf_calloc((size_t)nn + 1, sizeof *c->np_offsets);
    pf_status st = PF_OK;
    if (!inv_offsets || !inv || !stamp || !c->np_offsets) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate node pairs");
        goto done;
    }
    for (int64_t q = 0; q < nnz; ++q)
        inv_offsets[c->row_node[q] + 2]++;
    for (int32_t i = 0; i < nn; ++i)
        inv_offsets[i + 2] += inv_offsets[i + 1];
    for (int32_t p = 0; p < c->np; ++p)
        for (int64_t q = c->row_offsets[p]; q < c->row_offsets[p + 1]; ++q)
            inv[inv_offsets[c->row_node[q] + 1]++] = p;
    for (int pass = 0; pass < 2; ++pass) {
        for (int32_t i = 0; i < nn; ++i)
            stamp[i] = -1;
        int64_t w = 0;
        for (int32_t i = 0; i < nn; ++i) {
            int64_t first = w;
            for (int64_t q = inv_offsets[i]; q < inv_offsets[i + 1]; ++q) {
                int32_t p = inv[q];
                for (int64_t r = c->row_offsets[p]; r < c->row_offsets[p + 1]; ++r) {
                    int32_t j = c->row_node[r];
                    if (j < i || stamp[j] == i)
                        continue;
                    stamp[j] = i;
                    if (pass == 1)
                        c->np_col[w] = j;
                    ++w;
                }
            }
            if (pass == 0)
                c->np_offsets[i + 1] = w;
            else
                qsort(c->np_col + first, (size_t)(w - first), sizeof *c->np_col, compare_i32);
        }
        if (pass == 0) {
            c->np_col = pf_alloc_array((size_t)w + 1, sizeof *c->np_col);
            c->c_val = pf_calloc(9 * (size_t)w + 1, sizeof *c->c_val);
            c->c_used = pf_calloc((size_t)w + 1, 1);
            c->used = pf_alloc_array((size_t)w + 1, sizeof *c->used);
            if (!c->np_col || !c->c_val || !c->c_used || !c->used) {
                st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                  "cannot allocate %lld node pairs", (long long)w);
                goto done;
            }
        }
    }
done:
    pf_free(inv_offsets);
    pf_free(inv);
    pf_free(stamp);
    return st;
}

pf_status pf_contact_create(pf_contact **out, const pf_contact_setup *s, pf_error *err)
{
    *out = NULL;
    if (!s->scene->ground && s->scene->n_obstacles == 0)
        return PF_OK;
    pf_contact *c = pf_calloc(1, sizeof *c);
    PF_CHECK(c, err, PF_ERR_NOMEM, "cannot allocate contact");
    c->mesh = s->mesh;
    c->n_triples = s->n_triples;
    c->map_offsets = s->map_offsets;
    c->map_triple = s->map_triple;
    c->map_w = s->map_w;
    pf_status st = make_points(c, s, err);
    if (st >= 0)
        st = make_shapes(c, s, err);
    if (st >= 0)
        st = order_points(c, err);
    if (st >= 0) {
        size_t nt = (size_t)c->n_triples + 1;
        c->max_row = longest_row(c);
        c->pred = pf_alloc_array(3 * nt, sizeof *c->pred);
        c->node_u = pf_alloc_array(3 * (size_t)s->mesh->n_nodes + 1, sizeof *c->node_u);
        c->pos = pf_alloc_array(3 * (size_t)c->np + 1, sizeof *c->pos);
        c->node_f = pf_calloc(3 * (size_t)s->mesh->n_nodes + 1, sizeof *c->node_f);
        c->triple_block = pf_calloc(nt, sizeof *c->triple_block);
        size_t cap = (size_t)c->np * (size_t)c->n_shapes + 1;
        c->hit_point = pf_alloc_array(cap, sizeof *c->hit_point);
        c->hit_normal = pf_alloc_array(cap, sizeof *c->hit_normal);
        c->hit_gap = pf_alloc_array(cap, sizeof *c->hit_gap);
        c->hit_k = pf_alloc_array(cap, sizeof *c->hit_k);
        c->in_pattern = pf_calloc((size_t)c->np + 1, 1);
        if (!c->pred || !c->node_u || !c->pos || !c->node_f || !c->triple_block ||
            !c->hit_point || !c->hit_normal || !c->hit_gap || !c->hit_k || !c->in_pattern)
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                              "cannot allocate contact scratch for %lld unknowns",
                              (long long)(3 * c->n_triples));
    }
    if (st >= 0)
        st = node_pairs(c, err);
    if (st < 0) {
        pf_contact_destroy(&c);
        return st;
    }
    c->damping_beta = s->scene->damping_beta;
    for (int32_t b = 0; b < s->n_blocks; ++b)
        for (int64_t u = s->block_start[b]; u < s->block_start[b + 1]; u += 3)
            c->triple_block[u / 3] = b;
    c->stats.points = c->np;
    *out = c;
    return PF_OK;
}

void pf_contact_destroy(pf_contact **cp)
{
    pf_contact *c = *cp;
    if (!c)
        return;
    for (int32_t i = 0; i < c->n_shapes; ++i)
        pf_rayscene_destroy(&c->shapes[i].rs);
    pf_free(c->shapes);
    pf_free(c->shift);
    pf_free(c->velocity);
    void *arrays[] = {c->x0, c->row_offsets, c->row_node, c->row_w, c->order,
                      c->triple_block, c->pred, c->node_u, c->pos, c->np_offsets,
                      c->np_col, c->c_val, c->c_used, c->used, c->node_f,
                      c->hit_point, c->hit_normal, c->hit_gap, c->hit_k, c->in_pattern};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; ++k)
        pf_free(arrays[k]);
    pf_free(c);
    *cp = NULL;
}

/* ---- pattern ----------------------------------------------------------------------------- */

/* The blocks of point p's combination into blocks[] (distinct, unsorted), with stamp[b] == tag
 * marking those seen; returns their number. */
static int64_t point_blocks(const pf_contact *c, int32_t p, int32_t *stamp, int32_t tag,
                            int32_t *blocks)
{
    int64_t n = 0;
    for (int64_t q = c->row_offsets[p]; q < c->row_offsets[p + 1]; ++q) {
        int32_t i = c->row_node[q];
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r) {
            int32_t b = c->triple_block[c->map_triple[r]];
            if (stamp[b] != tag) {
                stamp[b] = tag;
                blocks[n++] = b;
            }
        }
    }
    return n;
}

bool pf_contact_needs_pattern(const pf_contact *c) { return c->grow; }

pf_status pf_contact_grow_pattern(pf_contact *c, pf_block_matrix *k, pf_error *err)
{
    int32_t nb = k->n_blocks;
    c->grow = false;
    /* point -> blocks, then block -> points, then for each block j the blocks i < j that share
     * a point with it, each once (stamp per j) */
    size_t n = (size_t)nb + 1;
    int32_t *stamp = pf_alloc_array(n, sizeof *stamp);
    int32_t *blocks = pf_alloc_array((size_t)c->max_row + 1, sizeof *blocks);
    int64_t *pb_offsets = pf_calloc((size_t)c->np + 1, sizeof *pb_offsets);
    int64_t *inv_offsets = pf_calloc(n + 1, sizeof *inv_offsets);
    int32_t *pb = NULL, *inv = NULL, *pairs = NULL, *size = NULL;
    pf_status st = PF_OK;
    if (!stamp || !blocks || !pb_offsets || !inv_offsets) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate the pattern");
        goto done;
    }
    for (int32_t b = 0; b < nb; ++b)
        stamp[b] = -1;
    for (int32_t p = 0; p < c->np; ++p)
        pb_offsets[p + 1] =
            pb_offsets[p] + (c->in_pattern[p] ? point_blocks(c, p, stamp, p, blocks) : 0);
    pb = pf_alloc_array((size_t)pb_offsets[c->np] + 1, sizeof *pb);
    inv = pf_alloc_array((size_t)pb_offsets[c->np] + 1, sizeof *inv);
    if (!pb || !inv) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate the pattern");
        goto done;
    }
    for (int32_t b = 0; b < nb; ++b)
        stamp[b] = -1;
    for (int32_t p = 0; p < c->np; ++p) {
        if (c->in_pattern[p])
            point_blocks(c, p, stamp, p, pb + pb_offsets[p]);
        for (int64_t q = pb_offsets[p]; q < pb_offsets[p + 1]; ++q)
            inv_offsets[pb[q] + 1]++;
    }
    for (int32_t b = 0; b < nb; ++b)
        inv_offsets[b + 1] += inv_offsets[b];
    {
        int64_t *fill = pf_alloc_array(n, sizeof *fill);
        if (!fill) {
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate the pattern");
            goto done;
        }
        memcpy(fill, inv_offsets, n * sizeof *fill);
        for (int32_t p = 0; p < c->np; ++p)
            for (int64_t q = pb_offsets[p]; q < pb_offsets[p + 1]; ++q)
                inv[fill[pb[q]]++] = p;
        pf_free(fill);
    }
    /* two passes: count the pairs, then fill them after the existing ones */
    int64_t existing = k->adj_offsets[nb] - nb, added = 0;
    for (int pass = 0; pass < 2; ++pass) {
        for (int32_t b = 0; b < nb; ++b)
            stamp[b] = -1;
        int64_t w = existing;
        for (int32_t j = 0; j < nb; ++j) {
            /* the pairs already in the pattern need not be repeated */
            for (int64_t q = k->adj_offsets[j]; q < k->adj_offsets[j + 1]; ++q)
                stamp[k->adj[q]] = j;
            for (int64_t q = inv_offsets[j]; q < inv_offsets[j + 1]; ++q) {
                int32_t p = inv[q];
                for (int64_t r = pb_offsets[p]; r < pb_offsets[p + 1]; ++r) {
                    int32_t i = pb[r];
                    if (i >= j || stamp[i] == j)
                        continue;
                    stamp[i] = j;
                    if (pass == 1) {
                        pairs[2 * w] = i;
                        pairs[2 * w + 1] = j;
                    }
                    ++w;
                }
            }
        }
        if (pass == 0) {
            added = w - existing;
            pairs = pf_alloc_array(2 * (size_t)(existing + added) + 2, sizeof *pairs);
            size = pf_alloc_array(n, sizeof *size);
            if (!pairs || !size) {
                st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                  "cannot allocate %lld block pairs",
                                  (long long)(existing + added));
                goto done;
            }
            int64_t e = 0;
            for (int32_t j = 0; j < nb; ++j)
                for (int64_t q = k->adj_offsets[j]; q < k->adj_offsets[j + 1]; ++q)
                    if (k->adj[q] != j) {
                        pairs[2 * e] = k->adj[q];
                        pairs[2 * e + 1] = j;
                        ++e;
                    }
            for (int32_t b = 0; b < nb; ++b)
                size[b] = (int32_t)(k->block_start[b + 1] - k->block_start[b]);
        }
    }
    if (added > 0) {
        pf_block_matrix_release(k);
        st = pf_block_matrix_create(k, nb, size, existing + added, pairs, err);
    }
done:
    pf_free(stamp);
    pf_free(blocks);
    pf_free(pb_offsets);
    pf_free(inv_offsets);
    pf_free(pb);
    pf_free(inv);
    pf_free(pairs);
    pf_free(size);
    return st;
}

/* ---- narrow phase ------------------------------------------------------------------------ */

/* Whether point x lies inside shape g translated by t: then *c is the nearest point of its
 * surface and *n the unit normal pointing out of it there. */
static bool penetrates(const shape *g, pf_vec3 t, pf_vec3 x, pf_vec3 *c, pf_vec3 *n)
{
    switch (g->kind) {
    case PF_OBSTACLE_PLANE: {
        double gap = pf_v3_dot(g->n, x) - (g->d + pf_v3_dot(g->n, t));
        if (gap >= 0)
            return false;
        *n = g->n;
        *c = pf_v3_sub(x, pf_v3_scale(g->n, gap));
        return true;
    }
    case PF_OBSTACLE_SPHERE: {
        pf_vec3 centre = pf_v3_add(g->o->centre, t), q = pf_v3_sub(x, centre);
        double r = pf_v3_norm(q);
        if (r >= g->o->radius)
            return false;
        *n = r > 0 ? pf_v3_scale(q, 1 / r) : pf_v3(0, 0, 1);
        *c = pf_v3_add(centre, pf_v3_scale(*n, g->o->radius));
        return true;
    }
    case PF_OBSTACLE_BOX: {
        pf_vec3 lo = pf_v3_add(g->lo, t), hi = pf_v3_add(g->hi, t);
        double best = INFINITY;
        int axis = 0, side = 0;
        for (int i = 0; i < 3; ++i) {
            double below = pf_v3_get(x, i) - pf_v3_get(lo, i);
            double above = pf_v3_get(hi, i) - pf_v3_get(x, i);
            if (below <= 0 || above <= 0)
                return false;
            if (below < best)
                best = below, axis = i, side = -1;
            if (above < best)
                best = above, axis = i, side = 1;
        }
        /* the nearest face: its outward normal, and x moved onto it */
        double e[3] = {0, 0, 0}, p[3] = {x.x, x.y, x.z};
        e[axis] = side;
        p[axis] = side > 0 ? pf_v3_get(hi, axis) : pf_v3_get(lo, axis);
        *n = pf_v3_load(e);
        *c = pf_v3_load(p);
        return true;
    }
    case PF_OBSTACLE_MESH: {
        pf_vec3 q = pf_v3_sub(x, t);
        if (q.x < g->lo.x || q.y < g->lo.y || q.z < g->lo.z || q.x > g->hi.x || q.y > g->hi.y ||
            q.z > g->hi.z)
            return false;
        pf_closest cl;
        if (!pf_rayscene_closest(g->rs, q, g->depth, &cl))
            return false;
        /* inside: behind the nearest triangle (the best aligned one at edges and corners) */
        pf_vec3 d = pf_v3_sub(cl.point, q);
        if (pf_v3_dot(d, cl.normal) <= 0)
            return false;
        /* out along the distance gradient: the face normal inside a face, the direction to
         * the nearest edge or corner otherwise */
        *n = cl.dist > 0 ? pf_v3_scale(d, 1 / cl.dist) : cl.normal;
        *c = pf_v3_add(cl.point, t);
        return true;
    }
    }
    return false;
}

/* Whether the box lo..hi can hold a point inside shape g translated by t. */
static bool box_meets(const shape *g, pf_vec3 t, pf_vec3 lo, pf_vec3 hi)
{
    if (g->kind == PF_OBSTACLE_PLANE) {
        /* the corner lowest along n */
        pf_vec3 low = pf_v3(g->n.x > 0 ? lo.x : hi.x, g->n.y > 0 ? lo.y : hi.y,
                            g->n.z > 0 ? lo.z : hi.z);
        return pf_v3_dot(g->n, low) < g->d + pf_v3_dot(g->n, t);
    }
    pf_vec3 glo = pf_v3_add(g->lo, t), ghi = pf_v3_add(g->hi, t);
    return lo.x <= ghi.x && hi.x >= glo.x && lo.y <= ghi.y && hi.y >= glo.y && lo.z <= ghi.z &&
           hi.z >= glo.z;
}

/* ---- assembly ---------------------------------------------------------------------------- */

/* C_ij += k w_i w_j n n^T for the node pairs of point p's row, F_i += k w_i g n (DG paper sec. 8,
 * at node level: the point's displacement is sum_i w_i (S u)_i). */
static void add_point(pf_contact *c, int32_t p, double k, pf_vec3 normal, double g)
{
    const double nn[3] = {normal.x, normal.y, normal.z};
    for (int64_t q = c->row_offsets[p]; q < c->row_offsets[p + 1]; ++q) {
        int32_t i = c->row_node[q];
        double wi = k * c->row_w[q];
        for (int r = 0; r < 3; ++r)
            c->node_f[3 * (size_t)i + r] += wi * g * nn[r];
        for (int64_t l = c->row_offsets[p]; l < c->row_offsets[p + 1]; ++l) {
            int32_t j = c->row_node[l];
            if (j < i)
                continue;
            /* the pair's slot: binary search in node i's sorted list */
            int64_t lo = c->np_offsets[i], hi = c->np_offsets[i + 1] - 1;
            while (lo < hi) {
                int64_t mid = lo + (hi - lo) / 2;
                if (c->np_col[mid] < j)
                    lo = mid + 1;
                else
                    hi = mid;
            }
            double s = wi * c->row_w[l];
            double *v = c->c_val + 9 * lo;
            for (int r = 0; r < 3; ++r)
                for (int cc = 0; cc < 3; ++cc)
                    v[3 * r + cc] += s * nn[r] * nn[cc];
            if (!c->c_used[lo]) {
                c->c_used[lo] = 1;
                c->used[c->n_used++] = lo;
            }
        }
    }
}

/* Adds S_i^T C_ij S_j (and its transpose for i < j) to the upper triangle of k, straight into
 * the stored columns (pf_block_matrix: a block's rows start at adj_row within each column of the
 * column block); with i = j only the entries on or above the diagonal of the symmetric term. */
static void add_node_pair(const pf_contact *c, int32_t i, int32_t j, const double *cij,
                          pf_block_matrix *k)
{
    const int64_t *ti = c->map_triple + c->map_offsets[i];
    const int64_t *tj = c->map_triple + c->map_offsets[j];
    const double *wi = c->map_w + c->map_offsets[i], *wj = c->map_w + c->map_offsets[j];
    int64_t ni = c->map_offsets[i + 1] - c->map_offsets[i];
    int64_t nj = c->map_offsets[j + 1] - c->map_offsets[j];
    for (int64_t a0 = 0; a0 < ni;) {
        int32_t ba = c->triple_block[ti[a0]];
        int64_t a1 = a0;
        while (a1 < ni && c->triple_block[ti[a1]] == ba)
            ++a1;
        for (int64_t b0 = 0; b0 < nj;) {
            int32_t bb = c->triple_block[tj[b0]];
            int64_t b1 = b0;
            while (b1 < nj && c->triple_block[tj[b1]] == bb)
                ++b1;
            int32_t bl = ba < bb ? ba : bb, bh = ba < bb ? bb : ba;
            int64_t slot = i == j && ba > bb ? -1 : pf_block_matrix_slot(k, bl, bh);
            if (slot >= 0) { /* always, with the grown pattern (or a mirrored i = j pair) */
                int64_t off = k->adj_row[slot] - k->block_start[bl];
                if (ba != bb) {
                    /* rows from the lower block, columns from the higher: all above the
                     * diagonal; C_ij itself, or transposed when i's triples are the columns */
                    bool swap = ba > bb;
                    const int64_t *tr = swap ? tj : ti, *tc = swap ? ti : tj;
                    const double *wr = swap ? wj : wi, *wc = swap ? wi : wj;
                    int64_t r0 = swap ? b0 : a0, r1 = swap ? b1 : a1;
                    int64_t q0 = swap ? a0 : b0, q1 = swap ? a1 : b1;
                    for (int64_t q = q0; q < q1; ++q)
                        for (int cc = 0; cc < 3; ++cc) {
                            int64_t col = k->col_ptr[3 * tc[q] + cc] + off;
                            double cw[3];
                            for (int r = 0; r < 3; ++r)
                                cw[r] = wc[q] * (swap ? cij[3 * cc + r] : cij[3 * r + cc]);
                            for (int64_t a = r0; a < r1; ++a) {
                                double *v = k->val + col + 3 * tr[a];
                                v[0] += wr[a] * cw[0];
                                v[1] += wr[a] * cw[1];
                                v[2] += wr[a] * cw[2];
                            }
                        }
                } else {
                    for (int64_t a = a0; a < a1; ++a)
                        for (int64_t b = b0; b < b1; ++b) {
                            double s = wi[a] * wj[b];
                            for (int r = 0; r < 3; ++r)
                                for (int cc = 0; cc < 3; ++cc) {
                                    int64_t row = 3 * ti[a] + r, col = 3 * tj[b] + cc;
                                    double v = s * cij[3 * r + cc];
                                    if (i == j) {
                                        if (row > col)
                                            continue;
                                    } else if (row == col) {
                                        v *= 2; /* the term and its transpose meet */
                                    }
                                    int64_t lo = row < col ? row : col, hi = row < col ? col : row;
                                    k->val[k->col_ptr[hi] + off + lo] += v;
                                }
                        }
                }
            }
            b0 = b1;
        }
        a0 = a1;
    }
}

/* The node-level terms of this step onto the unknowns (S^T C S, S^T F), then cleared. */
static void scatter(pf_contact *c, pf_block_matrix *k, double *f)
{
    for (int32_t i = 0; i < c->mesh->n_nodes; ++i) {
        const double *fi = c->node_f + 3 * (size_t)i;
        if (fi[0] == 0 && fi[1] == 0 && fi[2] == 0)
            continue;
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r)
            for (int d = 0; d < 3; ++d)
                f[3 * c->map_triple[r] + d] += c->map_w[r] * fi[d];
    }
    memset(c->node_f, 0, 3 * (size_t)c->mesh->n_nodes * sizeof *c->node_f);
    for (int64_t u = 0; u < c->n_used; ++u) {
        int64_t q = c->used[u];
        /* the pair's first node: the row of q in np_offsets */
        int64_t lo = 0, hi = c->mesh->n_nodes - 1;
        while (lo < hi) {
            int64_t mid = lo + (hi - lo + 1) / 2;
            if (c->np_offsets[mid] <= q)
                lo = mid;
            else
                hi = mid - 1;
        }
        add_node_pair(c, (int32_t)lo, c->np_col[q], c->c_val + 9 * q, k);
        memset(c->c_val + 9 * q, 0, 9 * sizeof *c->c_val);
        c->c_used[q] = 0;
    }
    c->n_used = 0;
}

int64_t pf_contact_detect(pf_contact *c, double t, const double *u, const double *v, double h)
{
    double t0 = pf_time_seconds();
    /* predicted nodal displacements S (u + h v), then every point's predicted position */
    for (int64_t q = 0; q < 3 * c->n_triples; ++q)
        c->pred[q] = u[q] + h * v[q];
    for (int32_t i = 0; i < c->mesh->n_nodes; ++i) {
        double s[3] = {0, 0, 0};
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r)
            for (int d = 0; d < 3; ++d)
                s[d] += c->map_w[r] * c->pred[3 * c->map_triple[r] + d];
        memcpy(c->node_u + 3 * (size_t)i, s, sizeof s);
    }
    for (int32_t p = 0; p < c->np; ++p) {
        double s[3] = {c->x0[3 * p], c->x0[3 * p + 1], c->x0[3 * p + 2]};
        for (int64_t q = c->row_offsets[p]; q < c->row_offsets[p + 1]; ++q)
            for (int d = 0; d < 3; ++d)
                s[d] += c->row_w[q] * c->node_u[3 * (size_t)c->row_node[q] + d];
        memcpy(c->pos + 3 * (size_t)p, s, sizeof s);
    }
    double t1 = pf_time_seconds();
    c->stats.embed_seconds += t1 - t0;

    for (int32_t g = 0; g < c->n_shapes; ++g) {
        const pf_obstacle *o = c->shapes[g].o;
        c->shift[g] = o ? pf_obstacle_translation(o, t) : pf_v3(0, 0, 0);
        /* the mean velocity over the step */
        c->velocity[g] = o && h > 0 ? pf_v3_scale(pf_v3_sub(c->shift[g],
                                                            pf_obstacle_translation(o, t - h)),
                                                  1 / h)
                                    : pf_v3(0, 0, 0);
    }
    c->n_hits = 0;
    for (int32_t c0 = 0; c0 < c->np; c0 += CHUNK) {
        int32_t c1 = c0 + CHUNK < c->np ? c0 + CHUNK : c->np;
        pf_vec3 lo = pf_v3_load(c->pos + 3 * (size_t)c->order[c0]), hi = lo;
        for (int32_t q = c0 + 1; q < c1; ++q) {
            pf_vec3 x = pf_v3_load(c->pos + 3 * (size_t)c->order[q]);
            lo = pf_v3_min(lo, x);
            hi = pf_v3_max(hi, x);
        }
        for (int32_t g = 0; g < c->n_shapes; ++g) {
            const shape *sh = &c->shapes[g];
            if (!box_meets(sh, c->shift[g], lo, hi))
                continue;
            bool chunk_in_pattern = true;
            for (int32_t q = c0; q < c1; ++q) {
                int32_t p = c->order[q];
                chunk_in_pattern &= c->in_pattern[p] != 0;
                pf_vec3 x = pf_v3_load(c->pos + 3 * (size_t)p), at, n;
                if (!penetrates(sh, c->shift[g], x, &at, &n))
                    continue;
                /* f = k n (n . (c - x0) + beta n . v_obstacle) - k n n^T u~: the penalty,
                 * with the Rayleigh damping beta K the driver applies to it made relative to
                 * the obstacle's velocity */
                int64_t e = c->n_hits++;
                c->hit_point[e] = p;
                c->hit_normal[e] = n;
                c->hit_k[e] = sh->stiffness;
                c->hit_gap[e] =
                    pf_v3_dot(n, pf_v3_sub(at, pf_v3_load(c->x0 + 3 * (size_t)p))) +
                    c->damping_beta * pf_v3_dot(n, c->velocity[g]);
                if (!c->in_pattern[p])
                    c->grow = true;
            }
            /* a chunk near an obstacle joins the pattern whole when one of its points touches:
             * its neighbours will touch next */
            if (c->grow && !chunk_in_pattern)
                for (int32_t q = c0; q < c1; ++q)
                    c->in_pattern[c->order[q]] = 1;
        }
    }
    c->stats.search_seconds += pf_time_seconds() - t1;
    return c->n_hits;
}

void pf_contact_assemble(pf_contact *c, pf_block_matrix *k, double *f)
{
    double t0 = pf_time_seconds();
    for (int64_t e = 0; e < c->n_hits; ++e)
        add_point(c, c->hit_point[e], c->hit_k[e], c->hit_normal[e], c->hit_gap[e]);
    scatter(c, k, f);
    c->stats.search_seconds += pf_time_seconds() - t0;
}

const pf_contact_stats *pf_contact_get_stats(const pf_contact *c) { return &c->stats; }
