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
 * Rows (contact.h): a boundary node moves with its element's own field (b = point_row), a
 * surface vertex by beta = W S, its embedding row through the stitching (eq. 32), which reaches
 * some sixty nodes and, through DG's stitching, hundreds of unknowns. The forces and the
 * predicted positions use beta; the step's matrix gets the vertex's stiffness through the compact
 * row b of the element it lies in (point_row: exact for every affine motion) instead of beta:
 * beta's term would couple all its unknowns pairwise and densify the factor (18x the fill on
 * the demo scene), b's couples one element's unknowns, which the pattern has. The step then
 * linearises the exact penalty force with a stiffness that agrees with it on every affine
 * motion of the body (all that a penalty layer resolves), so resting states are exact and the
 * matrix keeps the method's pattern, analysed once. */
#include "contact.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { CHUNK = 32 };

/* One obstacle as contact sees it (the ground is a plane among them). */
typedef struct shape {
    const pf_obstacle *o; /* NULL: the ground */
    pf_obstacle_kind kind;
    pf_vec3 n;        /* plane: unit normal */
    double d;         /* plane: n . x = d at rest */
    pf_vec3 lo, hi;   /* sphere, box, mesh: bounds at rest */
    double stiffness; /* per point */
    double depth;     /* mesh: deepest penetration looked for */
    pf_rayscene *rs;  /* mesh */
} shape;

struct pf_contact {
    const pf_mesh *mesh;
    int64_t n_triples;
    /* points: rest positions x0 [3 np], the element each moves with, its share of the penalty
     * (a node of DG splits it among its elements, method.h); sources: the nodes or surface
     * vertices they stand for */
    int32_t np;
    double *x0;
    int32_t *point_elem;
    double *share;
    int32_t sources;
    /* surface vertices: their WGHT rows (borrowed) and the method's nodal map S, with node-level
     * scratch: S (u + h v) or S u, and the forces before S^T */
    const pf_weights *weights;
    int32_t n_weighted; /* points [0, n_weighted) are the vertices, the rest samples */
    int32_t samples;
    const int64_t *map_offsets, *map_triple;
    const double *map_w;
    double *node_u, *node_f;
    double *acc;      /* [n_triples] a vertex's beta - b, zero between vertices */
    uint8_t *mark;    /* [n_triples] triples in touched */
    int64_t *touched; /* [n_triples] */
    int32_t *order;   /* [np] points along the Morton curve */
    int32_t n_shapes;
    shape *shapes;
    pf_vec3 *shift;        /* [n_shapes] each shape's translation at the end of the step */
    pf_vec3 *velocity;     /* [n_shapes] and its velocity over the step */
    int32_t *triple_block; /* [n_triples] the matrix block of each triple */
    /* per-step scratch, allocated once */
    double *pos; /* [3 np] predicted positions */
    /* every point's compact row (method.h, point_row), triples ascending: crow_offsets [np + 1],
     * crow_triple, crow_w */
    int64_t *crow_offsets;
    int64_t *crow_triple;
    double *crow_w;
    double damping_beta; /* Rayleigh beta: damps contact relative to the obstacle's motion */
    /* the contacts found by pf_contact_detect: shape << 32 | point, outward normal, right-hand
     * side gap; capacity np x n_shapes; prev_hit: the previous detection's, and whether the set
     * differs from it */
    int64_t *hit_point;
    int64_t *prev_hit;
    bool set_changed;
    double power; /* of the last forces on the body, through the obstacles' velocities */
    pf_vec3 *hit_normal;
    double *hit_gap;
    double *hit_k;
    int64_t n_hits;
    pf_contact_stats stats;
};

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status make_shapes(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    const pf_scene *sc = s->scene;
    c->shapes = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->shapes);
    c->shift = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->shift);
    c->velocity = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *c->velocity);
    PF_CHECK(c->shapes && c->shift && c->velocity, err, PF_ERR_NOMEM,
             "cannot allocate %d obstacles", (int)sc->n_obstacles);
    /* the automatic stiffness spreads the nodal total over the points */
    double points_per_node = 1;
    if (s->weights) {
        int32_t boundary_nodes = 0;
        PF_TRY(pf_contact_boundary_nodes(s->mesh, NULL, &boundary_nodes, err));
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

pf_status pf_contact_boundary_nodes(const pf_mesh *m, uint8_t *on, int32_t *count, pf_error *err)
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

static pf_status allocate_points(pf_contact *c, int32_t np, pf_error *err)
{
    c->np = np;
    c->x0 = pf_alloc_array(3 * (size_t)np + 1, sizeof *c->x0);
    c->point_elem = pf_alloc_array((size_t)np + 1, sizeof *c->point_elem);
    c->share = pf_alloc_array((size_t)np + 1, sizeof *c->share);
    PF_CHECK(c->x0 && c->point_elem && c->share, err, PF_ERR_NOMEM,
             "cannot allocate %d contact points", (int)np);
    return PF_OK;
}

/* The mean element size: the cube root of the mean element volume. */
static double element_size(const pf_mesh *m)
{
    double v = pf_mesh_volume(m);
    return m->n_elems > 0 ? cbrt(fabs(v) / m->n_elems) : 0;
}

/* Subdivisions of a triangle for samples about h apart: none (1) up to twice h, where the
 * vertices and their neighbours' hold the surface within about an element; at most
 * MAX_SUBDIVISION. */
enum { MAX_SUBDIVISION = 64 };
static int32_t subdivisions(const double *x, const uint32_t *t, double h)
{
    double longest = 0;
    for (int k = 0; k < 3; ++k)
        longest = fmax(longest, pf_v3_norm(pf_v3_sub(pf_v3_load(x + 3 * (size_t)t[k]),
                                                     pf_v3_load(x + 3 * (size_t)t[(k + 1) % 3]))));
    double n = h > 0 && longest > 2 * h ? ceil(longest / h) : 1;
    return n < 1 ? 1 : n > MAX_SUBDIVISION ? MAX_SUBDIVISION : (int32_t)n;
}

/* The element of the boundary node nearest to x (an element at the surface near x). */
static int32_t nearest_element(const pf_contact_setup *s, const int32_t *bnodes, int32_t nb,
                               pf_vec3 x)
{
    int32_t best = -1;
    double dist = INFINITY;
    for (int32_t k = 0; k < nb; ++k) {
        double d = pf_v3_norm(pf_v3_sub(pf_v3_load(s->mesh->x + 3 * (size_t)bnodes[k]), x));
        if (d < dist)
            dist = d, best = bnodes[k];
    }
    const int32_t *elems = NULL;
    return best >= 0 && s->ops->node_elements(s->method, best, &elems) > 0 ? elems[0] : -1;
}

/* Samples on the surface's triangles larger than the mesh's elements: the centroids of the n^2
 * sub-triangles of a triangle cut n times along each edge, n = its longest edge over the
 * element size. A vertex holds the surface up where it is, and a coarse surface (a box of 8
 * vertices over a fine mesh) has none where the mesh would sink through the ground: the samples
 * are points of the body there, moving with the element at them (compact rows). */
static pf_status count_samples(const pf_contact_setup *s, int64_t *count, pf_error *err)
{
    const pf_surface *sf = s->surface;
    double h = element_size(s->mesh);
    *count = 0;
    for (int32_t t = 0; t < sf->n_tris; ++t) {
        int32_t n = subdivisions(sf->x, sf->tri + 3 * (size_t)t, h);
        *count += n > 1 ? (int64_t)n * n : 0;
    }
    PF_CHECK(*count + sf->n_verts <= INT32_MAX, err, PF_ERR_TOO_LARGE,
             "%lld contact samples are too many", (long long)*count);
    return PF_OK;
}

static pf_status place_samples(pf_contact *c, const pf_contact_setup *s, int32_t first,
                               pf_error *err)
{
    const pf_surface *sf = s->surface;
    double h = element_size(s->mesh);
    uint8_t *on = pf_calloc((size_t)s->mesh->n_nodes + 1, 1);
    int32_t nb = 0;
    PF_CHECK(on, err, PF_ERR_NOMEM, "cannot allocate node flags");
    pf_status st = pf_contact_boundary_nodes(s->mesh, on, &nb, err);
    int32_t *bnodes = st >= 0 ? pf_alloc_array((size_t)nb + 1, sizeof *bnodes) : NULL;
    if (st >= 0 && !bnodes)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot list boundary nodes");
    for (int32_t i = 0, k = 0; st >= 0 && i < s->mesh->n_nodes; ++i)
        if (on[i])
            bnodes[k++] = i;
    int32_t p = first;
    for (int32_t t = 0; st >= 0 && t < sf->n_tris; ++t) {
        const uint32_t *tri = sf->tri + 3 * (size_t)t;
        int32_t n = subdivisions(sf->x, tri, h);
        if (n == 1)
            continue;
        pf_vec3 a = pf_v3_load(sf->x + 3 * (size_t)tri[0]);
        pf_vec3 ab = pf_v3_sub(pf_v3_load(sf->x + 3 * (size_t)tri[1]), a);
        pf_vec3 ac = pf_v3_sub(pf_v3_load(sf->x + 3 * (size_t)tri[2]), a);
        /* sub-triangle centroids: (i + 1/3, j + 1/3) and (i + 2/3, j + 2/3) in units of 1/n */
        for (int32_t i = 0; i < n; ++i)
            for (int32_t j = 0; i + j < n; ++j)
                for (int up = 0; up < 2 && (up == 0 || i + j + 1 < n); ++up) {
                    double u = (i + (up ? 2.0 : 1.0) / 3) / n, v = (j + (up ? 2.0 : 1.0) / 3) / n;
                    pf_vec3 x = pf_v3_add(a, pf_v3_add(pf_v3_scale(ab, u), pf_v3_scale(ac, v)));
                    memcpy(c->x0 + 3 * (size_t)p, &x, sizeof x);
                    c->point_elem[p] = nearest_element(s, bnodes, nb, x);
                    c->share[p] = 1;
                    ++p;
                }
    }
    pf_free(bnodes);
    pf_free(on);
    return st;
}

/* The surface vertices: each moves with an element using its largest-weight node (the element
 * it lies in, or a neighbour of it: the compact row is exact for affine motions either way); then
 * the samples of the triangles larger than the elements. */
static pf_status surface_points(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    const pf_weights *w = s->weights;
    const pf_mesh *m = s->mesh;
    PF_CHECK(
        s->surface && w->rows == s->surface->n_verts && w->cols == m->n_nodes, err, PF_ERR_INVALID,
        "embedding weights of %d x %d do not fit a surface of %d vertices on a mesh of "
        "%d nodes",
        (int)w->rows, (int)w->cols, s->surface ? (int)s->surface->n_verts : 0, (int)m->n_nodes);
    int64_t samples = 0;
    PF_TRY(count_samples(s, &samples, err));
    PF_TRY(allocate_points(c, (int32_t)(w->rows + samples), err));
    c->n_weighted = w->rows;
    memcpy(c->x0, s->surface->x, 3 * (size_t)w->rows * sizeof *c->x0);
    c->weights = w;
    s->ops->nodal_map(s->method, &c->map_offsets, &c->map_triple, &c->map_w);
    size_t nn = 3 * (size_t)m->n_nodes + 1;
    c->node_u = pf_alloc_array(nn, sizeof *c->node_u);
    c->node_f = pf_calloc(nn, sizeof *c->node_f);
    size_t nt = (size_t)s->n_triples + 1;
    c->acc = pf_calloc(nt, sizeof *c->acc);
    c->mark = pf_calloc(nt, sizeof *c->mark);
    c->touched = pf_alloc_array(nt, sizeof *c->touched);
    PF_CHECK(c->node_u && c->node_f && c->acc && c->mark && c->touched, err, PF_ERR_NOMEM,
             "cannot allocate contact scratch");
    for (int32_t p = 0; p < c->n_weighted; ++p) {
        int64_t dominant = -1;
        double best = -1;
        for (int64_t q = w->row_offsets[p]; q < w->row_offsets[p + 1]; ++q)
            if (fabs(w->val[q]) > best)
                best = fabs(w->val[q]), dominant = w->col[q];
        const int32_t *elems = NULL;
        int32_t n = dominant >= 0 ? s->ops->node_elements(s->method, (int32_t)dominant, &elems) : 0;
        c->point_elem[p] = n > 0 ? elems[0] : -1;
        c->share[p] = 1;
    }
    c->sources = c->n_weighted;
    c->samples = (int32_t)samples;
    return place_samples(c, s, c->n_weighted, err);
}

/* Whether the part holds the point of node i moved by element e (always on one process). */
static bool part_holds(const pf_contact_part *part, int32_t i, int32_t e)
{
    return !part || ((!part->element_holds || part->element_holds[e]) &&
                     (!part->node_holds || part->node_holds[i]));
}

/* The boundary nodes: one point per element moving a node's contact, each with its share (on a
 * part: the whole mesh's boundary nodes, the points it holds, shares of the whole mesh). */
static pf_status node_points(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    const pf_mesh *m = s->mesh;
    const pf_contact_part *part = s->part;
    uint8_t *on = pf_calloc((size_t)m->n_nodes + 1, 1);
    PF_CHECK(on, err, PF_ERR_NOMEM, "cannot allocate node flags");
    int32_t nodes = 0; /* a part's own boundary includes the faces between parts */
    pf_status st = part ? PF_OK : pf_contact_boundary_nodes(m, on, &nodes, err);
    for (int32_t i = 0; part && i < m->n_nodes; ++i)
        on[i] = part->boundary[i];
    int64_t np = 0;
    for (int pass = 0; pass < 2 && st >= 0; ++pass) {
        if (pass == 1 && np > INT32_MAX)
            st = pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__,
                              "%lld contact points are too many", (long long)np);
        if (pass == 1 && st >= 0)
            st = allocate_points(c, (int32_t)np, err);
        int64_t p = 0;
        int32_t held = 0; /* nodes with a point here */
        for (int32_t i = 0; st >= 0 && i < m->n_nodes; ++i) {
            if (!on[i])
                continue;
            int64_t first = p;
            const int32_t *elems;
            int32_t n = s->ops->node_elements(s->method, i, &elems);
            int32_t sharers = part && part->sharers ? part->sharers[i] : n;
            for (int32_t k = 0; k < n; ++k) {
                if (!part_holds(part, i, elems[k]))
                    continue;
                if (pass == 1) {
                    memcpy(c->x0 + 3 * (size_t)p, m->x + 3 * (size_t)i, 3 * sizeof *c->x0);
                    c->point_elem[p] = elems[k];
                    c->share[p] = 1.0 / sharers;
                }
                ++p;
            }
            held += p > first;
        }
        np = p;
        nodes = held;
    }
    c->sources = nodes;
    pf_free(on);
    return st;
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

/* Every point's compact row, triples sorted ascending (for the pairs of pf_contact_add_compact). */
static pf_status compact_rows(pf_contact *c, const pf_contact_setup *s, pf_error *err)
{
    int32_t longest = s->ops->max_point_row(s->method);
    size_t cap = (size_t)c->np * (size_t)longest + 1;
    c->crow_offsets = pf_calloc((size_t)c->np + 1, sizeof *c->crow_offsets);
    c->crow_triple = pf_alloc_array(cap, sizeof *c->crow_triple);
    c->crow_w = pf_alloc_array(cap, sizeof *c->crow_w);
    PF_CHECK(c->crow_offsets && c->crow_triple && c->crow_w, err, PF_ERR_NOMEM,
             "cannot allocate the compact rows of %d contact points", (int)c->np);
    int64_t q = 0;
    for (int32_t p = 0; p < c->np; ++p) {
        int32_t e = c->point_elem[p];
        int32_t n = e >= 0 ? s->ops->point_row(s->method, e, pf_v3_load(c->x0 + 3 * (size_t)p),
                                               c->crow_triple + q, c->crow_w + q)
                           : 0;
        sort_row(c->crow_triple + q, c->crow_w + q, n);
        q += n;
        c->crow_offsets[p + 1] = q;
    }
    return PF_OK;
}

pf_status pf_contact_create(pf_contact **out, const pf_contact_setup *s, pf_error *err)
{
    *out = NULL;
    if (!s->scene->ground && s->scene->n_obstacles == 0)
        return PF_OK;
    PF_CHECK(!(s->part && s->weights), err, PF_ERR_INVALID,
             "contact on a part of a distributed mesh is at boundary nodes only, not at an "
             "embedded surface");
    pf_contact *c = pf_calloc(1, sizeof *c);
    PF_CHECK(c, err, PF_ERR_NOMEM, "cannot allocate contact");
    c->mesh = s->mesh;
    c->n_triples = s->n_triples;
    pf_status st = s->weights ? surface_points(c, s, err) : node_points(c, s, err);
    if (st >= 0)
        st = make_shapes(c, s, err);
    if (st >= 0)
        st = order_points(c, err);
    if (st >= 0) {
        size_t nt = (size_t)c->n_triples + 1;
        c->pos = pf_alloc_array(3 * (size_t)c->np + 1, sizeof *c->pos);
        c->triple_block = pf_calloc(nt, sizeof *c->triple_block);
        size_t cap = (size_t)c->np * (size_t)c->n_shapes + 1;
        c->hit_point = pf_alloc_array(cap, sizeof *c->hit_point);
        c->prev_hit = pf_alloc_array(cap, sizeof *c->prev_hit);
        c->hit_normal = pf_alloc_array(cap, sizeof *c->hit_normal);
        c->hit_gap = pf_alloc_array(cap, sizeof *c->hit_gap);
        c->hit_k = pf_alloc_array(cap, sizeof *c->hit_k);
        if (!c->pos || !c->triple_block || !c->hit_point || !c->prev_hit || !c->hit_normal ||
            !c->hit_gap || !c->hit_k)
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                              "cannot allocate contact scratch for %lld unknowns",
                              (long long)(3 * c->n_triples));
    }
    if (st >= 0)
        st = compact_rows(c, s, err);
    if (st < 0) {
        pf_contact_destroy(&c);
        return st;
    }
    c->damping_beta = s->scene->damping_beta;
    for (int32_t b = 0; b < s->n_blocks; ++b)
        for (int64_t u = s->block_start[b]; u < s->block_start[b + 1]; u += 3)
            c->triple_block[u / 3] = b;
    c->stats.points = c->sources;
    c->stats.samples = c->samples;
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
    void *arrays[] = {c->x0,     c->point_elem,   c->share,       c->order,      c->triple_block,
                      c->pos,    c->hit_point,    c->prev_hit,    c->hit_normal, c->hit_gap,
                      c->hit_k,  c->crow_offsets, c->crow_triple, c->crow_w,     c->node_u,
                      c->node_f, c->acc,          c->mark,        c->touched};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; ++k)
        pf_free(arrays[k]);
    pf_free(c);
    *cp = NULL;
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
        pf_vec3 low =
            pf_v3(g->n.x > 0 ? lo.x : hi.x, g->n.y > 0 ? lo.y : hi.y, g->n.z > 0 ? lo.z : hi.z);
        return pf_v3_dot(g->n, low) < g->d + pf_v3_dot(g->n, t);
    }
    pf_vec3 glo = pf_v3_add(g->lo, t), ghi = pf_v3_add(g->hi, t);
    return lo.x <= ghi.x && hi.x >= glo.x && lo.y <= ghi.y && hi.y >= glo.y && lo.z <= ghi.z &&
           hi.z >= glo.z;
}

/* node_u = S (u + h v) (v NULL: S u). */
static void stitch(pf_contact *c, const double *u, const double *v, double h)
{
    for (int32_t i = 0; i < c->mesh->n_nodes; ++i) {
        double s[3] = {0, 0, 0};
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r) {
            const double *ut = u + 3 * c->map_triple[r], *vt = v ? v + 3 * c->map_triple[r] : NULL;
            for (int d = 0; d < 3; ++d)
                s[d] += c->map_w[r] * (vt ? ut[d] + h * vt[d] : ut[d]);
        }
        memcpy(c->node_u + 3 * (size_t)i, s, sizeof s);
    }
}

int64_t pf_contact_detect(pf_contact *c, double t, const double *u, const double *v, double h)
{
    double t0 = pf_time_seconds();
    /* every point's predicted position x0 + beta^T (u + h v) */
    if (c->weights)
        stitch(c, u, v, h);
    for (int32_t p = 0; p < c->np; ++p) {
        double x[3] = {c->x0[3 * p], c->x0[3 * p + 1], c->x0[3 * p + 2]};
        if (p < c->n_weighted) {
            const pf_weights *w = c->weights;
            for (int64_t q = w->row_offsets[p]; q < w->row_offsets[p + 1]; ++q)
                for (int d = 0; d < 3; ++d)
                    x[d] += w->val[q] * c->node_u[3 * (size_t)w->col[q] + d];
        } else {
            for (int64_t q = c->crow_offsets[p]; q < c->crow_offsets[p + 1]; ++q) {
                const double *ut = u + 3 * c->crow_triple[q], *vt = v + 3 * c->crow_triple[q];
                for (int d = 0; d < 3; ++d)
                    x[d] += c->crow_w[q] * (ut[d] + h * vt[d]);
            }
        }
        memcpy(c->pos + 3 * (size_t)p, x, sizeof x);
    }
    double t1 = pf_time_seconds();
    c->stats.embed_seconds += t1 - t0;

    for (int32_t g = 0; g < c->n_shapes; ++g) {
        const pf_obstacle *o = c->shapes[g].o;
        c->shift[g] = o ? pf_obstacle_translation(o, t) : pf_v3(0, 0, 0);
        /* the mean velocity over the step */
        c->velocity[g] =
            o && h > 0
                ? pf_v3_scale(pf_v3_sub(c->shift[g], pf_obstacle_translation(o, t - h)), 1 / h)
                : pf_v3(0, 0, 0);
    }
    /* the last step's contacts, to tell whether the set changed */
    int64_t *swap = c->prev_hit;
    c->prev_hit = c->hit_point;
    c->hit_point = swap;
    int64_t prev_hits = c->n_hits;
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
            for (int32_t q = c0; q < c1; ++q) {
                int32_t p = c->order[q];
                pf_vec3 x = pf_v3_load(c->pos + 3 * (size_t)p), at, n;
                if (!penetrates(sh, c->shift[g], x, &at, &n))
                    continue;
                /* f = k n (n . (c - x0) + beta n . v_obstacle) - k n n^T u~: the penalty,
                 * with the Rayleigh damping beta K the driver applies to it made relative to
                 * the obstacle's velocity */
                int64_t e = c->n_hits++;
                c->hit_point[e] = (int64_t)g << 32 | p;
                c->hit_normal[e] = n;
                c->hit_k[e] = sh->stiffness * c->share[p];
                c->hit_gap[e] = pf_v3_dot(n, pf_v3_sub(at, pf_v3_load(c->x0 + 3 * (size_t)p))) +
                                c->damping_beta * pf_v3_dot(n, c->velocity[g]);
            }
        }
    }
    c->set_changed = c->n_hits != prev_hits ||
                     memcmp(c->hit_point, c->prev_hit, (size_t)c->n_hits * sizeof *c->hit_point);
    c->stats.search_seconds += pf_time_seconds() - t1;
    return c->n_hits;
}

double pf_contact_obstacle_power(const pf_contact *c)
{
    return c->power;
}

bool pf_contact_set_changed(const pf_contact *c)
{
    return c->set_changed;
}

/* Surface vertices (the samples are compact points): the forces at node level, then S^T onto
 * the unknowns. */
static void surface_forces(pf_contact *c, const double *u, double *f)
{
    const pf_weights *w = c->weights;
    stitch(c, u, NULL, 0);
    for (int64_t e = 0; e < c->n_hits; ++e) {
        int32_t p = (int32_t)(c->hit_point[e] & 0xffffffff);
        if (p >= c->n_weighted)
            continue;
        pf_vec3 n = c->hit_normal[e];
        double d = 0; /* n . u~ */
        for (int64_t q = w->row_offsets[p]; q < w->row_offsets[p + 1]; ++q)
            d += w->val[q] * pf_v3_dot(n, pf_v3_load(c->node_u + 3 * (size_t)w->col[q]));
        pf_vec3 kn = pf_v3_scale(n, c->hit_k[e] * (c->hit_gap[e] - d));
        c->power += pf_v3_dot(kn, c->velocity[c->hit_point[e] >> 32]);
        for (int64_t q = w->row_offsets[p]; q < w->row_offsets[p + 1]; ++q) {
            double *fi = c->node_f + 3 * (size_t)w->col[q];
            fi[0] += w->val[q] * kn.x;
            fi[1] += w->val[q] * kn.y;
            fi[2] += w->val[q] * kn.z;
        }
    }
    for (int32_t i = 0; i < c->mesh->n_nodes; ++i) {
        double *fi = c->node_f + 3 * (size_t)i;
        if (fi[0] == 0 && fi[1] == 0 && fi[2] == 0)
            continue;
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r)
            for (int d = 0; d < 3; ++d)
                f[3 * c->map_triple[r] + d] += c->map_w[r] * fi[d];
        fi[0] = fi[1] = fi[2] = 0;
    }
}

void pf_contact_forces(pf_contact *c, const double *u, double *f)
{
    c->power = 0;
    if (c->weights)
        surface_forces(c, u, f);
    for (int64_t e = 0; e < c->n_hits; ++e) {
        int32_t p = (int32_t)(c->hit_point[e] & 0xffffffff);
        if (p < c->n_weighted)
            continue;
        pf_vec3 n = c->hit_normal[e];
        int64_t begin = c->crow_offsets[p], end = c->crow_offsets[p + 1];
        double d = 0; /* n . u~ */
        for (int64_t q = begin; q < end; ++q)
            d += c->crow_w[q] * pf_v3_dot(n, pf_v3_load(u + 3 * c->crow_triple[q]));
        pf_vec3 kn = pf_v3_scale(n, c->hit_k[e] * (c->hit_gap[e] - d));
        c->power += pf_v3_dot(kn, c->velocity[c->hit_point[e] >> 32]);
        for (int64_t q = begin; q < end; ++q) {
            double *ft = f + 3 * c->crow_triple[q];
            ft[0] += c->crow_w[q] * kn.x;
            ft[1] += c->crow_w[q] * kn.y;
            ft[2] += c->crow_w[q] * kn.z;
        }
    }
}

void pf_contact_add_row(pf_block_matrix *k, const int32_t *triple_block, const int64_t *triple,
                        const double *w, int64_t n, pf_vec3 normal, double a)
{
    const double nn[3] = {normal.x, normal.y, normal.z};
    for (int64_t q1 = 0; q1 < n; ++q1) {
        int64_t t1 = triple[q1];
        int32_t b1 = triple_block[t1];
        for (int64_t q2 = q1; q2 < n; ++q2) {
            int64_t t2 = triple[q2];
            int32_t b2 = triple_block[t2];
            int64_t slot = b1 == b2 ? k->adj_offsets[b2 + 1] - 1 : pf_block_matrix_slot(k, b1, b2);
            if (slot < 0) /* one element's unknowns are always coupled */
                continue;
            double m[9], s = a * w[q1] * w[q2];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    m[3 * i + j] = s * nn[i] * nn[j];
            pf_block_matrix_add_3x3(k, slot, b1, 3 * t1, 3 * t2, m);
        }
    }
}

/* k += a (b b^T) (x) n n^T over point p's compact row. */
static void add_compact(const pf_contact *c, int32_t p, pf_vec3 n, double a, pf_block_matrix *k)
{
    int64_t begin = c->crow_offsets[p];
    pf_contact_add_row(k, c->triple_block, c->crow_triple + begin, c->crow_w + begin,
                       c->crow_offsets[p + 1] - begin, n, a);
}

/* For a surface vertex, r = beta - b over the triples (beta = W S, b its compact row) in the
 * scratch acc (touched triples listed in c->touched), returning ||r||_1 and ||b||_1. */
static int64_t remainder_row(const pf_contact *c, int32_t p, double *l1_r, double *l1_b)
{
    const pf_weights *w = c->weights;
    int64_t n = 0;
    for (int64_t q = w->row_offsets[p]; q < w->row_offsets[p + 1]; ++q) {
        int32_t i = (int32_t)w->col[q];
        for (int64_t r = c->map_offsets[i]; r < c->map_offsets[i + 1]; ++r) {
            int64_t t = c->map_triple[r];
            if (!c->mark[t]) {
                c->mark[t] = 1;
                c->touched[n++] = t;
            }
            c->acc[t] += w->val[q] * c->map_w[r];
        }
    }
    *l1_b = 0;
    for (int64_t q = c->crow_offsets[p]; q < c->crow_offsets[p + 1]; ++q) {
        int64_t t = c->crow_triple[q];
        if (!c->mark[t]) {
            c->mark[t] = 1;
            c->touched[n++] = t;
        }
        c->acc[t] -= c->crow_w[q];
        *l1_b += fabs(c->crow_w[q]);
    }
    *l1_r = 0;
    for (int64_t k = 0; k < n; ++k)
        *l1_r += fabs(c->acc[c->touched[k]]);
    return n;
}

/* The stiffness of a contact at a surface vertex: beta = b + r, and for any e > 0
 *     beta beta^T <= (1 + e) b b^T + (1 + 1/e) r r^T,   r r^T <= diag(|r_t| ||r||_1)
 * (Young's inequality, then Gershgorin). With e = ||r||_1 / ||b||_1 the matrix gets
 * (1 + e) b b^T + diag(|r_t| (||r||_1 + ||b||_1)): at least the exact term, so that the step,
 * whose forces use beta exactly, stays as implicit as the exact one would be (a weaker matrix
 * would leave the difference explicit: an MLS-embedded bunny on CG blew up within five frames
 * with b b^T alone), and within the pattern: b within one element, the rest on the diagonal. */
static void add_surface_vertex(const pf_contact *c, int32_t p, pf_vec3 n, double a,
                               pf_block_matrix *k)
{
    double l1_r, l1_b;
    int64_t touched = remainder_row(c, p, &l1_r, &l1_b);
    double e = l1_b > 0 ? l1_r / l1_b : 0;
    add_compact(c, p, n, a * (1 + e), k);
    const double nn[3] = {n.x, n.y, n.z};
    for (int64_t q = 0; q < touched; ++q) {
        int64_t t = c->touched[q];
        double d = a * fabs(c->acc[t]) * (l1_r + l1_b), m[9];
        c->acc[t] = 0;
        c->mark[t] = 0;
        if (d == 0)
            continue;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                m[3 * i + j] = d * nn[i] * nn[j];
        int32_t b = c->triple_block[t];
        pf_block_matrix_add_3x3(k, k->adj_offsets[b + 1] - 1, b, 3 * t, 3 * t, m);
    }
}

void pf_contact_add_stiffness(pf_contact *c, double alpha, pf_block_matrix *k)
{
    for (int64_t e = 0; e < c->n_hits; ++e) {
        int32_t p = (int32_t)(c->hit_point[e] & 0xffffffff);
        double a = alpha * c->hit_k[e];
        if (p < c->n_weighted)
            add_surface_vertex(c, p, c->hit_normal[e], a, k);
        else
            add_compact(c, p, c->hit_normal[e], a, k);
    }
}

int64_t pf_contact_count(const pf_contact *c)
{
    return c->n_hits;
}

const pf_contact_stats *pf_contact_get_stats(const pf_contact *c)
{
    return &c->stats;
}
