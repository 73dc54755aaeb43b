/* Cap polygons of a plane split: a planar region given by directed boundary edges, decomposed into
 * simple polygons without new vertices.
 *
 * 1. Loops. At each vertex the region's boundary edges alternate around the vertex: a region
 *    sector starts at an outgoing edge and ends, counter-clockwise, at an incoming one. Following
 *    an incoming edge by the first outgoing edge clockwise from its reverse direction (the
 *    sharpest left turn) keeps every sector separate, so regions touching at a vertex give
 *    separate loops, and an interior edge given both ways cuts the region along it.
 * 2. Holes. Loops of negative area are holes; each belongs to the smallest outer loop around it.
 * 3. An outer loop with holes cannot be one simple face. Each hole is joined to the outer loop by
 *    a bridge between two existing vertices that sees both ends from inside the region and crosses
 *    no edge (holes in order of decreasing largest u, so that one always exists: nothing lies to
 *    the right of the rightmost hole but the outer loop, Eberly's argument). The weakly simple
 *    polygon is ear-clipped (pf_polygon_triangulate) and triangles are merged back across
 *    diagonals while the union stays convex (Hertel-Mehlhorn: at most four times the minimum
 *    number of convex pieces). Only existing vertices are used, so no cap edge gets a vertex its
 *    neighbouring side face does not have (no T-junctions).
 */
#include <pf/split.h>

#include <stdlib.h>
#include <string.h>

#define TWO_PI 6.28318530717958647692

typedef struct cap {
    int64_t ne;
    int32_t nv;
    uint32_t *node;   /* [nv] node id of local vertex */
    double *uv;       /* [2 nv] in-plane coordinates, (e1, e2, normal) right-handed */
    int32_t *from;    /* [ne] local vertex */
    int32_t *to;      /* [ne] */
    double *angle;    /* [ne] direction of the edge at its start */
    int64_t *out_off; /* [nv + 1] outgoing edges of v: out_he[out_off[v] .. out_off[v+1]) */
    int64_t *out_he;  /* [ne] */
    int64_t *next;    /* [ne] the edge that follows in the region's boundary */
} cap;

typedef struct loop {
    int32_t *v; /* local vertices */
    int64_t n;
    double area; /* signed, uv units */
    int32_t owner; /* holes: the outer loop they belong to */
} loop;

typedef struct poly_out {
    pf_buffer off;   /* int64_t */
    pf_buffer nodes; /* uint32_t */
    int32_t n;
} poly_out;

static double orient2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

static int sign_of(double v) { return (v > 0) - (v < 0); }

static int compare_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static int32_t local_index(const cap *c, uint32_t node)
{
    const uint32_t *hit = bsearch(&node, c->node, (size_t)c->nv, sizeof node, compare_u32);
    return (int32_t)(hit - c->node);
}

/* Angle swept counter-clockwise from direction a to direction b, in [0, 2 pi). */
static double ccw_sweep(double a, double b)
{
    double d = fmod(b - a, TWO_PI);
    return d < 0 ? d + TWO_PI : d;
}

static double direction(const cap *c, int32_t from, int32_t to)
{
    return atan2(c->uv[2 * to + 1] - c->uv[2 * from + 1], c->uv[2 * to] - c->uv[2 * from]);
}

static void cap_release(cap *c)
{
    pf_free(c->node);
    pf_free(c->uv);
    pf_free(c->from);
    pf_free(c->to);
    pf_free(c->angle);
    pf_free(c->out_off);
    pf_free(c->out_he);
    pf_free(c->next);
    memset(c, 0, sizeof *c);
}

/* Local vertices, plane coordinates, and the outgoing edges of every vertex. */
static pf_status cap_build(cap *c, const double *x, pf_vec3 normal, const uint32_t *edges,
                           int64_t ne, pf_error *err)
{
    c->ne = ne;
    PF_CHECK(PF_ALLOC_N(c->node, 2 * ne), err, PF_ERR_NOMEM, "cannot allocate cap vertices");
    memcpy(c->node, edges, 2 * (size_t)ne * sizeof *edges);
    qsort(c->node, 2 * (size_t)ne, sizeof *c->node, compare_u32);
    int32_t nv = 0;
    for (int64_t i = 0; i < 2 * ne; ++i)
        if (i == 0 || c->node[i] != c->node[i - 1])
            c->node[nv++] = c->node[i];
    c->nv = nv;
    PF_CHECK(PF_ALLOC_N(c->uv, 2 * (int64_t)nv) && PF_ALLOC_N(c->from, ne) &&
                 PF_ALLOC_N(c->to, ne) && PF_ALLOC_N(c->angle, ne) &&
                 PF_ALLOC_N(c->out_off, (int64_t)nv + 1) && PF_ALLOC_N(c->out_he, ne) &&
                 PF_ALLOC_N(c->next, ne),
             err, PF_ERR_NOMEM, "cannot allocate a cap of %lld edges", (long long)ne);
    pf_vec3 n = pf_v3_normalize(normal);
    pf_vec3 helper = fabs(n.x) <= fabs(n.y) && fabs(n.x) <= fabs(n.z) ? pf_v3(1, 0, 0)
                     : fabs(n.y) <= fabs(n.z)                         ? pf_v3(0, 1, 0)
                                                                      : pf_v3(0, 0, 1);
    pf_vec3 e1 = pf_v3_normalize(pf_v3_cross(helper, n));
    pf_vec3 e2 = pf_v3_cross(n, e1);
    pf_vec3 origin = pf_v3_load(x + 3 * (size_t)c->node[0]);
    for (int32_t v = 0; v < nv; ++v) {
        pf_vec3 d = pf_v3_sub(pf_v3_load(x + 3 * (size_t)c->node[v]), origin);
        c->uv[2 * v] = pf_v3_dot(d, e1);
        c->uv[2 * v + 1] = pf_v3_dot(d, e2);
    }
    memset(c->out_off, 0, ((size_t)nv + 1) * sizeof *c->out_off);
    for (int64_t h = 0; h < ne; ++h) {
        c->from[h] = local_index(c, edges[2 * h]);
        c->to[h] = local_index(c, edges[2 * h + 1]);
        PF_CHECK(c->from[h] != c->to[h], err, PF_ERR_NUMERIC, "cap edge %u-%u has no length",
                 edges[2 * h], edges[2 * h + 1]);
        c->angle[h] = direction(c, c->from[h], c->to[h]);
        c->out_off[c->from[h] + 1]++;
    }
    for (int32_t v = 0; v < nv; ++v)
        c->out_off[v + 1] += c->out_off[v];
    int64_t *fill = pf_alloc_array((size_t)nv, sizeof *fill);
    PF_CHECK(fill, err, PF_ERR_NOMEM, "cannot allocate a cap of %lld edges", (long long)ne);
    memcpy(fill, c->out_off, (size_t)nv * sizeof *fill);
    for (int64_t h = 0; h < ne; ++h)
        c->out_he[fill[c->from[h]]++] = h;
    pf_free(fill);
    return PF_OK;
}

/* Successor of every edge: at its end, the outgoing edge reached first turning clockwise from
 * the direction back along it (the edge straight back comes last). */
static pf_status cap_link(cap *c, pf_error *err)
{
    for (int64_t h = 0; h < c->ne; ++h) {
        int32_t v = c->to[h];
        double back = direction(c, v, c->from[h]);
        int64_t best = -1;
        double best_turn = INFINITY;
        for (int64_t k = c->out_off[v]; k < c->out_off[v + 1]; ++k) {
            int64_t g = c->out_he[k];
            double turn = ccw_sweep(c->angle[g], back);
            if (turn == 0)
                turn = TWO_PI;
            if (turn < best_turn) {
                best_turn = turn;
                best = g;
            }
        }
        PF_CHECK(best >= 0, err, PF_ERR_NUMERIC, "cap boundary is open at node %u",
                 c->node[v]);
        c->next[h] = best;
    }
    return PF_OK;
}

static double loop_area(const cap *c, const int32_t *v, int64_t n)
{
    double s = 0;
    for (int64_t i = 0; i < n; ++i) {
        const double *a = c->uv + 2 * v[i], *b = c->uv + 2 * v[(i + 1) % n];
        s += a[0] * b[1] - a[1] * b[0];
    }
    return 0.5 * s;
}

static void loops_release(loop *l, int64_t n)
{
    for (int64_t i = 0; i < n; ++i)
        pf_free(l[i].v);
    pf_free(l);
}

static pf_status trace_loops(const cap *c, loop **out, int64_t *n_out, pf_error *err)
{
    *out = NULL;
    *n_out = 0;
    uint8_t *used = pf_calloc((size_t)c->ne, 1);
    loop *loops = pf_alloc_array((size_t)c->ne, sizeof *loops); /* at most one per edge */
    int32_t *tmp = pf_alloc_array((size_t)c->ne, sizeof *tmp);
    if (!used || !loops || !tmp) {
        pf_free(used), pf_free(loops), pf_free(tmp);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate cap loops");
    }
    int64_t nl = 0;
    pf_status s = PF_OK;
    for (int64_t start = 0; start < c->ne && s == PF_OK; ++start) {
        if (used[start])
            continue;
        int64_t n = 0, h = start;
        do {
            if (used[h]) {
                s = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                                 "cap boundary crosses itself at node %u", c->node[c->from[h]]);
                break;
            }
            used[h] = 1;
            tmp[n++] = c->from[h];
            h = c->next[h];
        } while (h != start);
        if (s != PF_OK)
            break;
        loop *l = &loops[nl];
        l->v = pf_alloc_array((size_t)n, sizeof *l->v);
        if (!l->v) {
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate a cap loop");
            break;
        }
        memcpy(l->v, tmp, (size_t)n * sizeof *tmp);
        l->n = n;
        l->area = loop_area(c, l->v, n);
        l->owner = -1;
        ++nl;
    }
    pf_free(used);
    pf_free(tmp);
    if (s != PF_OK) {
        loops_release(loops, nl);
        return s;
    }
    *out = loops;
    *n_out = nl;
    return PF_OK;
}

/* Crossing-number test of the point p against a loop. */
static int point_in_loop(const cap *c, const loop *l, const double *p)
{
    int inside = 0;
    for (int64_t i = 0; i < l->n; ++i) {
        const double *a = c->uv + 2 * l->v[i], *b = c->uv + 2 * l->v[(i + 1) % l->n];
        if ((a[1] > p[1]) != (b[1] > p[1])) {
            double xc = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if (p[0] < xc)
                inside = !inside;
        }
    }
    return inside;
}

/* Each hole to the smallest outer loop containing the midpoint of its first edge (a point of the
 * hole's boundary that no outer boundary passes through: boundary edges are never shared). */
static pf_status assign_holes(const cap *c, loop *loops, int64_t nl, pf_error *err)
{
    for (int64_t h = 0; h < nl; ++h) {
        if (loops[h].area >= 0)
            continue;
        const double *a = c->uv + 2 * loops[h].v[0], *b = c->uv + 2 * loops[h].v[1 % loops[h].n];
        double mid[2] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
        int32_t best = -1;
        for (int64_t o = 0; o < nl; ++o)
            if (loops[o].area > 0 && point_in_loop(c, &loops[o], mid) &&
                (best < 0 || loops[o].area < loops[best].area))
                best = (int32_t)o;
        PF_CHECK(best >= 0, err, PF_ERR_NUMERIC,
                 "a hole of the cap (at node %u) lies in no outer boundary",
                 c->node[loops[h].v[0]]);
        loops[h].owner = best;
    }
    return PF_OK;
}

static int same_uv(const double *a, const double *b) { return a[0] == b[0] && a[1] == b[1]; }

/* q strictly inside segment ab, given that it is collinear with it. */
static int strictly_between(const double *a, const double *b, const double *q)
{
    double t = (q[0] - a[0]) * (b[0] - a[0]) + (q[1] - a[1]) * (b[1] - a[1]);
    double l2 = (b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]);
    return t > 0 && t < l2;
}

/* The bridge p-m meets segment a-b anywhere except at a shared end point. */
static int bridge_blocked(const double *p, const double *m, const double *a, const double *b)
{
    int ap = same_uv(a, p) || same_uv(a, m), bp = same_uv(b, p) || same_uv(b, m);
    if (ap && bp)
        return 1; /* the bridge would duplicate an edge */
    if (ap || bp) {
        const double *o = ap ? b : a;
        return orient2(p, m, o) == 0 && strictly_between(p, m, o);
    }
    int o1 = sign_of(orient2(p, m, a)), o2 = sign_of(orient2(p, m, b));
    int o3 = sign_of(orient2(a, b, p)), o4 = sign_of(orient2(a, b, m));
    if (o1 * o2 < 0 && o3 * o4 < 0)
        return 1;
    return (o1 == 0 && strictly_between(p, m, a)) || (o2 == 0 && strictly_between(p, m, b)) ||
           (o3 == 0 && strictly_between(a, b, p)) || (o4 == 0 && strictly_between(a, b, m));
}

static int loop_blocks(const cap *c, const int32_t *v, int64_t n, const double *p, const double *m)
{
    for (int64_t i = 0; i < n; ++i)
        if (bridge_blocked(p, m, c->uv + 2 * v[i], c->uv + 2 * v[(i + 1) % n]))
            return 1;
    return 0;
}

/* Direction to q leaves vertex i of the cyclic list v strictly through the region's sector there
 * (counter-clockwise from the outgoing edge to the incoming one). */
static int in_sector(const cap *c, const int32_t *v, int64_t n, int64_t i, const double *q)
{
    int32_t cur = v[i], nx = v[(i + 1) % n], pv = v[(i + n - 1) % n];
    const double *pc = c->uv + 2 * cur;
    double out = direction(c, cur, nx), in = direction(c, cur, pv);
    double d = atan2(q[1] - pc[1], q[0] - pc[0]);
    double wd = ccw_sweep(out, d), wb = ccw_sweep(out, in);
    if (wb == 0)
        wb = TWO_PI;
    return wd > 0 && wd < wb;
}

typedef struct ring {
    int32_t *v;
    int64_t n, cap;
} ring;

/* Joins hole loops[hole] to the ring by the shortest valid bridge from its vertices, tried in
 * order of decreasing u. */
static pf_status bridge_hole(const cap *c, ring *r, const loop *loops, const int64_t *holes,
                             int64_t n_holes, int64_t k, pf_error *err)
{
    const loop *h = &loops[holes[k]];
    int64_t *order = pf_alloc_array((size_t)(h->n + r->n), sizeof *order);
    double *key = pf_alloc_array((size_t)(h->n + r->n), sizeof *key);
    if (!order || !key) {
        pf_free(order), pf_free(key);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate a bridge");
    }
    int64_t bi = -1, bj = -1;
    /* hole vertices by decreasing u (insertion sort: loops are short) */
    for (int64_t j = 0; j < h->n; ++j) {
        int64_t p = j;
        while (p > 0 && c->uv[2 * h->v[order[p - 1]]] < c->uv[2 * h->v[j]]) {
            order[p] = order[p - 1];
            --p;
        }
        order[p] = j;
    }
    int64_t *ring_order = order + h->n;
    double *dist = key + h->n;
    for (int64_t jj = 0; jj < h->n && bi < 0; ++jj) {
        int64_t j = order[jj];
        const double *m = c->uv + 2 * h->v[j];
        for (int64_t i = 0; i < r->n; ++i) {
            const double *p = c->uv + 2 * r->v[i];
            double d = (p[0] - m[0]) * (p[0] - m[0]) + (p[1] - m[1]) * (p[1] - m[1]);
            int64_t q = i;
            while (q > 0 && dist[q - 1] > d) {
                dist[q] = dist[q - 1];
                ring_order[q] = ring_order[q - 1];
                --q;
            }
            dist[q] = d;
            ring_order[q] = i;
        }
        for (int64_t ii = 0; ii < r->n && bi < 0; ++ii) {
            int64_t i = ring_order[ii];
            const double *p = c->uv + 2 * r->v[i];
            if (same_uv(p, m) || !in_sector(c, r->v, r->n, i, m) ||
                !in_sector(c, h->v, h->n, j, p) || loop_blocks(c, r->v, r->n, p, m))
                continue;
            int blocked = 0;
            for (int64_t o = k; o < n_holes && !blocked; ++o)
                blocked = loop_blocks(c, loops[holes[o]].v, loops[holes[o]].n, p, m);
            if (!blocked)
                bi = i, bj = j;
        }
    }
    pf_free(order);
    pf_free(key);
    PF_CHECK(bi >= 0, err, PF_ERR_NUMERIC, "cannot join a hole of the cap (at node %u)",
             c->node[h->v[0]]);
    /* ring[0..bi], hole[bj..], hole[..bj], ring[bi], ring[bi+1..] */
    int64_t n = r->n + h->n + 2;
    if (n > r->cap) {
        int32_t *grown = pf_realloc_array(r->v, (size_t)n, sizeof *grown);
        PF_CHECK(grown, err, PF_ERR_NOMEM, "cannot grow a cap polygon");
        r->v = grown;
        r->cap = n;
    }
    memmove(r->v + bi + 1 + h->n + 2, r->v + bi + 1, (size_t)(r->n - bi - 1) * sizeof *r->v);
    for (int64_t t = 0; t <= h->n; ++t)
        r->v[bi + 1 + t] = h->v[(bj + t) % h->n];
    r->v[bi + 1 + h->n + 1] = r->v[bi];
    r->n = n;
    return PF_OK;
}

static pf_status emit(poly_out *o, const uint32_t *nodes, int64_t n, pf_error *err)
{
    int64_t end = (int64_t)(o->nodes.size / sizeof(uint32_t)) + n;
    PF_TRY(pf_buffer_append(&o->nodes, nodes, (size_t)n * sizeof *nodes, err));
    PF_TRY(pf_buffer_append(&o->off, &end, sizeof end, err));
    o->n++;
    return PF_OK;
}

/* Convex (or straight) corner b of a -> b -> c in the plane. */
static int convex_corner(const double *a, const double *b, const double *c)
{
    double o = orient2(a, b, c);
    if (o != 0)
        return o > 0;
    return (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]) > 0;
}

typedef struct hm_poly {
    int32_t *pos; /* positions in the triangulated polygon */
    int64_t n;
} hm_poly;

static int64_t find_root(int64_t *parent, int64_t t)
{
    while (parent[t] != t)
        t = parent[t] = parent[parent[t]];
    return t;
}

static int compare_diag(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Merges triangles P and Q across their diagonal a-b (positions) when the union is convex. */
static pf_status try_merge(const cap *c, const int32_t *ring_v, hm_poly *pp, hm_poly *pq,
                           int32_t a, int32_t b, int *merged, pf_error *err)
{
    *merged = 0;
    int64_t i = -1, j = -1;
    for (int64_t k = 0; k < pp->n && i < 0; ++k)
        if (pp->pos[k] == a && pp->pos[(k + 1) % pp->n] == b)
            i = k;
    if (i < 0) {
        hm_poly *t = pp;
        pp = pq, pq = t;
        for (int64_t k = 0; k < pp->n && i < 0; ++k)
            if (pp->pos[k] == a && pp->pos[(k + 1) % pp->n] == b)
                i = k;
    }
    for (int64_t k = 0; k < pq->n && j < 0; ++k)
        if (pq->pos[k] == b && pq->pos[(k + 1) % pq->n] == a)
            j = k;
    if (i < 0 || j < 0)
        return PF_OK;
    /* merged: b, P after b .. a, then Q after a .. before b */
    int64_t n = pp->n + pq->n - 2;
    int32_t *m = pf_alloc_array((size_t)n, sizeof *m);
    PF_CHECK(m, err, PF_ERR_NOMEM, "cannot allocate a merged cap polygon");
    int64_t k = 0;
    for (int64_t t = 0; t < pp->n; ++t)
        m[k++] = pp->pos[(i + 1 + t) % pp->n];
    for (int64_t t = 0; t < pq->n - 2; ++t)
        m[k++] = pq->pos[(j + 2 + t) % pq->n];
    int64_t ia = pp->n - 1; /* position of a in m; b is at 0 */
#define UV(idx) (c->uv + 2 * ring_v[m[(idx)]])
    int ok = convex_corner(UV(ia - 1), UV(ia), UV((ia + 1) % n)) &&
             convex_corner(UV(n - 1), UV(0), UV(1));
#undef UV
    if (!ok) {
        pf_free(m);
        return PF_OK;
    }
    pf_free(pp->pos);
    pf_free(pq->pos);
    pp->pos = m;
    pp->n = n;
    pq->pos = NULL;
    pq->n = 0;
    *merged = 1;
    return PF_OK;
}

/* Ear-clips the weakly simple ring and merges the triangles into convex polygons. */
static pf_status decompose_ring(const cap *c, const double *x, const ring *r, poly_out *o,
                                pf_error *err)
{
    int64_t n = r->n, nt = n - 2;
    uint32_t *idx = pf_alloc_array((size_t)n, sizeof *idx);
    uint32_t *tri = pf_alloc_array(3 * (size_t)nt, sizeof *tri);
    uint8_t *bits = pf_alloc_array((size_t)nt, 1);
    uint64_t *diag = pf_alloc_array(3 * (size_t)nt, sizeof *diag);
    hm_poly *polys = pf_calloc((size_t)nt, sizeof *polys);
    int64_t *parent = pf_alloc_array((size_t)nt, sizeof *parent);
    pf_arena arena = {0};
    pf_status s = PF_OK;
    if (!idx || !tri || !bits || !diag || !polys || !parent) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate a cap of %lld "
                         "vertices", (long long)n);
        goto done;
    }
    for (int64_t i = 0; i < n; ++i)
        idx[i] = c->node[r->v[i]];
    s = pf_arena_init(&arena, 24 * (size_t)n + 64, err);
    if (s == PF_OK)
        s = pf_polygon_triangulate(x, idx, (int32_t)n, &arena, tri, bits, err);
    int64_t nd = 0;
    for (int64_t t = 0; t < nt && s == PF_OK; ++t) {
        parent[t] = t;
        polys[t].pos = pf_alloc_array(3, sizeof(int32_t));
        if (!polys[t].pos) {
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate triangles");
            break;
        }
        polys[t].n = 3;
        for (int k = 0; k < 3; ++k) {
            polys[t].pos[k] = (int32_t)tri[3 * t + k];
            if (!(bits[t] & (1u << k))) {
                uint64_t a = tri[3 * t + k], b = tri[3 * t + (k + 1) % 3];
                uint64_t lo = a < b ? a : b, hi = a < b ? b : a;
                diag[nd++] = (lo << 40) | (hi << 20) | (uint64_t)t; /* n < 2^20 checked below */
            }
        }
    }
    if (s == PF_OK && n >= (1 << 20))
        s = pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__, "cap of %lld vertices",
                         (long long)n);
    if (s == PF_OK)
        qsort(diag, (size_t)nd, sizeof *diag, compare_diag);
    for (int64_t d = 0; d + 1 < nd && s == PF_OK; ++d) {
        if ((diag[d] >> 20) != (diag[d + 1] >> 20))
            continue;
        int64_t t1 = find_root(parent, (int64_t)(diag[d] & 0xfffff));
        int64_t t2 = find_root(parent, (int64_t)(diag[d + 1] & 0xfffff));
        if (t1 == t2)
            continue;
        int32_t a = (int32_t)(diag[d] >> 40), b = (int32_t)((diag[d] >> 20) & 0xfffff);
        int merged = 0;
        s = try_merge(c, r->v, &polys[t1], &polys[t2], a, b, &merged, err);
        if (s == PF_OK && merged) {
            if (polys[t1].n == 0) /* try_merge kept the union in whichever held a -> b */
                parent[t1] = t2;
            else
                parent[t2] = t1;
        }
        ++d;
    }
    for (int64_t t = 0; t < nt && s == PF_OK; ++t) {
        if (polys[t].n == 0)
            continue;
        for (int64_t k = 0; k < polys[t].n; ++k)
            idx[k] = c->node[r->v[polys[t].pos[k]]];
        s = emit(o, idx, polys[t].n, err);
    }
done:
    if (polys)
        for (int64_t t = 0; t < nt; ++t)
            pf_free(polys[t].pos);
    pf_free(polys);
    pf_free(parent);
    pf_free(idx);
    pf_free(tri);
    pf_free(bits);
    pf_free(diag);
    pf_arena_release(&arena);
    return s;
}

static int has_repeated_vertex(const loop *l, uint32_t *stamp, uint32_t mark)
{
    int repeated = 0;
    for (int64_t i = 0; i < l->n; ++i) {
        repeated |= stamp[l->v[i]] == mark;
        stamp[l->v[i]] = mark;
    }
    return repeated;
}

static int compare_hole_u(const void *a, const void *b, const cap *c, const loop *loops)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    double ux = -INFINITY, uy = -INFINITY;
    for (int64_t i = 0; i < loops[x].n; ++i)
        ux = fmax(ux, c->uv[2 * loops[x].v[i]]);
    for (int64_t i = 0; i < loops[y].n; ++i)
        uy = fmax(uy, c->uv[2 * loops[y].v[i]]);
    return (ux < uy) - (ux > uy);
}

/* Outer loop o with its holes -> polygons. */
static pf_status region_polygons(const cap *c, const double *x, const loop *loops, int64_t nl,
                                 int64_t o, uint32_t *stamp, poly_out *out, pf_error *err)
{
    int64_t n_holes = 0;
    for (int64_t h = 0; h < nl; ++h)
        n_holes += loops[h].owner == o;
    if (n_holes == 0 && !has_repeated_vertex(&loops[o], stamp, (uint32_t)o + 1)) {
        uint32_t *idx = pf_alloc_array((size_t)loops[o].n, sizeof *idx);
        PF_CHECK(idx, err, PF_ERR_NOMEM, "cannot allocate a cap polygon");
        for (int64_t i = 0; i < loops[o].n; ++i)
            idx[i] = c->node[loops[o].v[i]];
        pf_status s = emit(out, idx, loops[o].n, err);
        pf_free(idx);
        return s;
    }
    int64_t *holes = pf_alloc_array((size_t)n_holes + 1, sizeof *holes);
    ring r = {0};
    int64_t total = loops[o].n;
    for (int64_t h = 0, k = 0; h < nl; ++h)
        if (loops[h].owner == o) {
            if (holes)
                holes[k++] = h;
            total += loops[h].n + 2;
        }
    r.v = pf_alloc_array((size_t)total, sizeof *r.v);
    r.cap = total;
    pf_status s = PF_OK;
    if (!holes || !r.v)
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate a cap region");
    if (s == PF_OK) {
        memcpy(r.v, loops[o].v, (size_t)loops[o].n * sizeof *r.v);
        r.n = loops[o].n;
        /* insertion sort by decreasing largest u */
        for (int64_t k = 1; k < n_holes; ++k)
            for (int64_t q = k; q > 0 && compare_hole_u(&holes[q - 1], &holes[q], c, loops) > 0;
                 --q) {
                int64_t t = holes[q];
                holes[q] = holes[q - 1];
                holes[q - 1] = t;
            }
        for (int64_t k = 0; k < n_holes && s == PF_OK; ++k)
            s = bridge_hole(c, &r, loops, holes, n_holes, k, err);
    }
    if (s == PF_OK)
        s = decompose_ring(c, x, &r, out, err);
    pf_free(holes);
    pf_free(r.v);
    return s;
}

pf_status pf_split_cap_polygons(const double *x, pf_vec3 normal, const uint32_t *edges,
                                int64_t n_edges, int64_t **offsets, uint32_t **nodes,
                                int32_t *n_polys, pf_error *err)
{
    *offsets = NULL;
    *nodes = NULL;
    *n_polys = 0;
    poly_out out = {0};
    int64_t zero = 0;
    PF_TRY(pf_buffer_append(&out.off, &zero, sizeof zero, err));
    cap c = {0};
    loop *loops = NULL;
    int64_t nl = 0;
    uint32_t *stamp = NULL;
    pf_status s = PF_OK;
    if (n_edges > 0) {
        s = cap_build(&c, x, normal, edges, n_edges, err);
        if (s == PF_OK)
            s = cap_link(&c, err);
        if (s == PF_OK)
            s = trace_loops(&c, &loops, &nl, err);
        if (s == PF_OK)
            s = assign_holes(&c, loops, nl, err);
        if (s == PF_OK && !(stamp = pf_calloc((size_t)c.nv, sizeof *stamp)))
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate stamps");
        for (int64_t o = 0; o < nl && s == PF_OK; ++o)
            if (loops[o].area >= 0)
                s = region_polygons(&c, x, loops, nl, o, stamp, &out, err);
    }
    pf_free(stamp);
    loops_release(loops, nl);
    cap_release(&c);
    if (s != PF_OK) {
        pf_buffer_release(&out.off);
        pf_buffer_release(&out.nodes);
        return s;
    }
    if (!out.nodes.data) { /* no polygon: still hand back a (one-entry) node array */
        uint32_t none = 0;
        s = pf_buffer_append(&out.nodes, &none, sizeof none, err);
        if (s != PF_OK) {
            pf_buffer_release(&out.off);
            return s;
        }
    }
    *offsets = (int64_t *)(void *)out.off.data;
    *nodes = (uint32_t *)(void *)out.nodes.data;
    *n_polys = out.n;
    return PF_OK;
}
