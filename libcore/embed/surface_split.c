/* Splitting the triangles of the surface being cut by the plane of a group of opened faces
 * (pf_surface_cut): exact sections, slits on the opened faces, fans on either side. */
#include "surface_cut_internal.h"

#include <stdlib.h>
#include <string.h>

/* ---- splitting the triangles ------------------------------------------------------------------
 */

/* Edge points by the edge's two vertices: open addressing, load at most one half. */
typedef struct edge_map {
    int64_t cap, n;
    uint64_t *key;
    int32_t *val;
} edge_map;

static void edge_map_release(edge_map *h)
{
    pf_free(h->key);
    pf_free(h->val);
    memset(h, 0, sizeof *h);
}

static uint64_t hash64(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    return k;
}

static int32_t *edge_map_slot(edge_map *h, uint64_t key)
{
    for (uint64_t i = hash64(key) & (uint64_t)(h->cap - 1);; i = (i + 1) & (uint64_t)(h->cap - 1))
        if (h->val[i] < 0 || h->key[i] == key) {
            h->key[i] = key;
            return &h->val[i];
        }
}

static pf_status edge_map_grow(edge_map *h, pf_error *err)
{
    if (2 * (h->n + 1) <= h->cap)
        return PF_OK;
    edge_map old = *h;
    h->cap = old.cap ? 2 * old.cap : 1024;
    h->key = NULL;
    h->val = NULL;
    if (!PF_ALLOC_N(h->key, (size_t)h->cap) || !PF_ALLOC_N(h->val, (size_t)h->cap)) {
        edge_map_release(h);
        edge_map_release(&old);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for edge points");
    }
    for (int64_t i = 0; i < h->cap; ++i)
        h->val[i] = -1;
    for (int64_t i = 0; i < old.cap; ++i)
        if (old.val[i] >= 0)
            *edge_map_slot(h, old.key[i]) = old.val[i];
    h->n = old.n;
    edge_map_release(&old);
    return PF_OK;
}

typedef struct split_ctx {
    sc_state *c;
    int32_t nv;      /* vertices at the start of the plane */
    int8_t *cls;     /* [nv] -1, 0, +1 */
    double *dist;    /* [same] signed distances */
    int32_t *vpt;    /* [same] point of an on-plane vertex, -1 */
    edge_map edges;  /* edge points */
    uint32_t *stamp; /* [n_edges of the group] */
    uint32_t now;
    int32_t n_cross, cap_cross;
    double *cross_t;    /* crossings of the current section: parameter */
    int32_t *cross_pt;  /* their points (-1: edge crossing not yet made) */
    int32_t *cross_key; /* corner: -1 - canonical node; edge: edge index */
    uint8_t *split_src; /* [input triangles] split already */
    int32_t *tri_pq;    /* [2 triangles at the start] the plane points of crossing ones, -1 */
    uint8_t *tri_any;   /* [same] the section has a piece on an opened face */
    int64_t n_old_slit; /* c->slit[0 .. n_old_slit) sorted: the slits of earlier planes */
    int32_t n_sub, cap_sub;
    int32_t *sub; /* [3 n_sub] slits of earlier planes split by this one: a, b, the point */
    int32_t n_corners;
    int32_t *corners; /* [n_corners] nodes whose cap corner (earlier groups') is on the plane */
} split_ctx;

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Whether a-b is a slit of an earlier plane. */
static bool old_slit(const split_ctx *k, int32_t a, int32_t b)
{
    uint64_t key = (uint64_t)(a < b ? a : b) << 32 | (uint64_t)(a < b ? b : a);
    return k->n_old_slit > 0 &&
           bsearch(&key, k->c->slit, (size_t)k->n_old_slit, sizeof key, compare_u64) != NULL;
}

/* A slit a-b of an earlier plane is split at point p: a-p and p-b are slits (kept for the end
 * of the plane, when p has its vertex). */
static pf_status push_sub(split_ctx *k, int32_t a, int32_t b, int32_t p, pf_error *err)
{
    if (k->n_sub == k->cap_sub) {
        int32_t cap = k->cap_sub ? 2 * k->cap_sub : 64;
        int32_t *n = pf_realloc_array(k->sub, 3 * (size_t)cap, sizeof *n);
        PF_CHECK(n, err, PF_ERR_NOMEM, "out of memory for %d split slits", (int)cap);
        k->sub = n;
        k->cap_sub = cap;
    }
    int32_t *e = k->sub + 3 * (size_t)k->n_sub++;
    e[0] = a, e[1] = b, e[2] = p;
    return PF_OK;
}

static pf_status push_subs(split_ctx *k, pf_error *err)
{
    for (int32_t i = 0; i < k->n_sub; ++i) {
        const int32_t *e = k->sub + 3 * (size_t)i;
        int32_t id;
        PF_TRY(pf_sc_point_id(k->c, e[2], 1, &id, err));
        PF_TRY(pf_sc_push_slit(k->c, e[0], id, err));
        PF_TRY(pf_sc_push_slit(k->c, id, e[1], err));
    }
    return PF_OK;
}

/* Triangles with a slit mark the ends of their sections; every crossing triangle with a marked
 * end is split too (with a slit or not), and marks its other end: along a section through
 * triangles the marks spread until they reach the plane points no split triangle uses. */
static pf_status spread_used(split_ctx *k, int32_t nt, pf_error *err)
{
    sc_state *c = k->c;
    int32_t np = c->n_points;
    int64_t *off = NULL;
    int32_t *tris = NULL, *queue = NULL;
    if (!PF_ALLOC_N(off, (size_t)np + 1) || !PF_ALLOC_N(tris, 2 * (size_t)nt + 1) ||
        !PF_ALLOC_N(queue, 2 * (size_t)nt + 1)) {
        pf_free(off);
        pf_free(tris);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the sections of %d triangles", (int)nt);
    }
    memset(off, 0, ((size_t)np + 1) * sizeof *off);
    for (int64_t i = 0; i < 2 * (int64_t)nt; ++i)
        if (k->tri_pq[i] >= 0)
            off[k->tri_pq[i] + 1]++;
    for (int32_t p = 0; p < np; ++p)
        off[p + 1] += off[p];
    for (int64_t i = 0; i < 2 * (int64_t)nt; ++i)
        if (k->tri_pq[i] >= 0)
            tris[off[k->tri_pq[i]]++] = (int32_t)(i / 2);
    for (int32_t p = np; p > 0; --p)
        off[p] = off[p - 1];
    off[0] = 0;
    int64_t head = 0, tail = 0;
    for (int32_t t = 0; t < nt; ++t)
        if (k->tri_pq[2 * (size_t)t] >= 0 && k->tri_any[t])
            queue[tail++] = t;
    for (int64_t i = 0; i < tail; ++i)
        k->tri_any[queue[i]] = 2; /* queued */
    while (head < tail) {
        int32_t t = queue[head++];
        for (int e = 0; e < 2; ++e) {
            int32_t p = k->tri_pq[2 * (size_t)t + e];
            if (c->pt[p].used)
                continue;
            c->pt[p].used = 1;
            for (int64_t j = off[p]; j < off[p + 1]; ++j)
                if (k->tri_any[tris[j]] != 2) {
                    k->tri_any[tris[j]] = 2;
                    queue[tail++] = tris[j];
                }
        }
    }
    pf_free(off);
    pf_free(tris);
    pf_free(queue);
    return PF_OK;
}

static pf_status vertex_point(split_ctx *k, int32_t w, int32_t *out, pf_error *err)
{
    sc_state *c = k->c;
    if (k->vpt[w] < 0) {
        pf_vec3 x = pf_v3_load(c->s->x + 3 * (size_t)w);
        PF_TRY(pf_sc_new_point(c, x, pf_v3_load(c->s->side + 3 * (size_t)w), w, &k->vpt[w], err));
    }
    *out = k->vpt[w];
    return PF_OK;
}

/* Whether some triangle has the edge v-w. */
static bool has_surface_edge(const sc_surface *s, int32_t v, int32_t w)
{
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        if (s->tri[i] == (uint32_t)v && s->tri[i - i % 3 + (i + 1) % 3] == (uint32_t)w)
            return true;
    return false;
}

/* Vertex w replaced by vertex to everywhere: triangles, cap corners, slits (those of earlier
 * planes sorted again) and points. */
static void merge_vertex(split_ctx *k, int32_t w, int32_t to)
{
    sc_state *c = k->c;
    sc_surface *s = c->s;
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        if (s->tri[i] == (uint32_t)w)
            s->tri[i] = (uint32_t)to;
    for (int32_t n = 0; n < c->m->n_nodes; ++n)
        if (c->cap_vert[n] == w)
            c->cap_vert[n] = to;
    for (int64_t i = 0; i < c->n_slit; ++i) {
        uint64_t a = c->slit[i] >> 32, b = c->slit[i] & 0xffffffffu;
        if (a == (uint64_t)w)
            a = (uint64_t)to;
        if (b == (uint64_t)w)
            b = (uint64_t)to;
        c->slit[i] = (a < b ? a : b) << 32 | (a < b ? b : a);
    }
    qsort(c->slit, (size_t)k->n_old_slit, sizeof *c->slit, compare_u64);
    for (int32_t i = 0; i < c->n_points; ++i) {
        for (int q = 0; q < 2; ++q)
            if (c->pt[i].id[q] == w)
                c->pt[i].id[q] = to;
        if (c->pt[i].orig == w)
            c->pt[i].orig = to;
    }
    if (k->vpt[w] >= 0 && k->vpt[to] < 0)
        k->vpt[to] = k->vpt[w];
}

/* The vertex an earlier group of this cut made as a cap corner at a node at x (within tol; of
 * this group's faces, or of the earlier group's only, where its crack bends off this plane) and
 * joined by an edge to a or b, or -1. The caps of both sides of the earlier group may have a
 * corner there (one per copy of the node) with the edge a-b between them, which this plane
 * splits at one point: the corners are made one vertex, which the duplication after the last
 * plane gives one copy per side again, by the slits, together with the edge's pieces (rather
 * than two vertices on the caps that the surface's triangles between them never join). */
static int32_t node_vertex_at(split_ctx *k, pf_vec3 x, int32_t a, int32_t b)
{
    const sc_state *c = k->c;
    const pf_mesh *m = c->m;
    int32_t found = -1;
    for (int32_t i = 0; i < k->n_corners; ++i) {
        int32_t n = k->corners[i], w = c->cap_vert[n];
        if (pf_v3_dist(pf_v3_load(m->x + 3 * (size_t)n), x) > c->g->tol)
            continue;
        if (has_surface_edge(c->s, w, a) || has_surface_edge(c->s, a, w) ||
            has_surface_edge(c->s, w, b) || has_surface_edge(c->s, b, w)) {
            if (found < 0)
                found = w;
            else if (w != found)
                merge_vertex(k, w, found);
        }
    }
    return found;
}

/* The point where the surface edge a-b (on opposite sides) meets the plane, placed from the
 * lower vertex index so that both triangles of the edge get the same point. Where an earlier
 * group of this cut put a cap corner there (the edge runs along its caps' border: a later plane
 * crosses an earlier one's crack), the point is that corner's vertex, not a second vertex a few
 * ulps away. */
static pf_status edge_point(split_ctx *k, int32_t a, int32_t b, int32_t *out, pf_error *err)
{
    if (a > b) {
        int32_t t = a;
        a = b;
        b = t;
    }
    PF_TRY(edge_map_grow(&k->edges, err));
    int32_t *slot = edge_map_slot(&k->edges, (uint64_t)a << 32 | (uint64_t)b);
    if (*slot >= 0) {
        *out = *slot;
        return PF_OK;
    }
    sc_state *c = k->c;
    double t = k->dist[a] / (k->dist[a] - k->dist[b]);
    pf_vec3 xa = pf_v3_load(c->s->x + 3 * (size_t)a), xb = pf_v3_load(c->s->x + 3 * (size_t)b);
    pf_vec3 x = pf_v3_add(xa, pf_v3_scale(pf_v3_sub(xb, xa), t));
    int32_t p, w = node_vertex_at(k, x, a, b);
    if (w >= 0) {
        PF_TRY(vertex_point(k, w, &p, err));
    } else {
        pf_vec3 sa = pf_v3_load(c->s->side + 3 * (size_t)a),
                sb = pf_v3_load(c->s->side + 3 * (size_t)b);
        pf_vec3 side = pf_v3_add(pf_v3_scale(sa, 1 - t), pf_v3_scale(sb, t));
        PF_TRY(pf_sc_new_point(c, x, side, -1, &p, err));
    }
    if (old_slit(k, a, b))
        PF_TRY(push_sub(k, a, b, p, err));
    k->edges.n++;
    *edge_map_slot(&k->edges, (uint64_t)a << 32 | (uint64_t)b) = p;
    *out = p;
    return PF_OK;
}

static pf_status push_crossing(split_ctx *k, double t, int32_t key, pf_error *err)
{
    if (k->n_cross == k->cap_cross) {
        int32_t cap = k->cap_cross ? 2 * k->cap_cross : 32;
        double *nt = pf_realloc_array(k->cross_t, (size_t)cap, sizeof *nt);
        if (nt)
            k->cross_t = nt;
        int32_t *np = nt ? pf_realloc_array(k->cross_pt, (size_t)cap, sizeof *np) : NULL;
        if (np)
            k->cross_pt = np;
        int32_t *nk = np ? pf_realloc_array(k->cross_key, (size_t)cap, sizeof *nk) : NULL;
        if (nk)
            k->cross_key = nk;
        PF_CHECK(nk, err, PF_ERR_NOMEM, "out of memory for %d crossings", (int)cap);
        k->cap_cross = cap;
    }
    k->cross_t[k->n_cross] = t;
    k->cross_key[k->n_cross] = key;
    k->cross_pt[k->n_cross++] = -1;
    return PF_OK;
}

static double orient2(const double *a, const double *b, const double *p)
{
    return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
}

/* Where the section P-Q (projected pp, pq, length len) meets the corners and edges of the
 * group's faces strictly inside it: corners within tol of it, proper crossings of edges away
 * from their corners. Sorted by parameter, corners first at equal parameters, and merged within
 * tol (the first kept). */
static pf_status find_crossings(split_ctx *k, const double *pp, const double *pq, double len,
                                pf_error *err)
{
    const sc_group *g = k->c->g;
    const pf_mesh *m = k->c->m;
    double tol = g->tol, lo[2], hi[2];
    for (int a = 0; a < 2; ++a) {
        lo[a] = fmin(pp[a], pq[a]) - tol;
        hi[a] = fmax(pp[a], pq[a]) + tol;
    }
    k->n_cross = 0;
    if (++k->now == 0) {
        memset(k->stamp, 0, (size_t)g->n_edges * sizeof *k->stamp);
        k->now = 1;
    }
    double d[2] = {pq[0] - pp[0], pq[1] - pp[1]};
    for (int32_t f = 0; f < g->n_faces; ++f) {
        const double *b = g->box + 4 * (size_t)f;
        if (b[0] > hi[0] || b[2] < lo[0] || b[1] > hi[1] || b[3] < lo[1])
            continue;
        int64_t o = g->uv_offsets[f], n = g->uv_offsets[f + 1] - o;
        for (int64_t j = 0; j < n; ++j) {
            const double *a = g->uv + 2 * (o + j), *c = g->uv + 2 * (o + (j + 1) % n);
            int32_t e = g->corner_edge[o + j];
            /* corner a */
            double t = ((a[0] - pp[0]) * d[0] + (a[1] - pp[1]) * d[1]) / (len * len);
            if (t * len > tol && (1 - t) * len > tol && fabs(orient2(pp, pq, a)) / len <= tol) {
                int32_t node = g->canon[m->face_nodes[m->face_offsets[g->face[f]] + j]];
                PF_TRY(push_crossing(k, t, -1 - node, err));
            }
            if (k->stamp[e] == k->now)
                continue;
            k->stamp[e] = k->now;
            double da = orient2(pp, pq, a) / len, dc = orient2(pp, pq, c) / len;
            if (!((da > tol && dc < -tol) || (da < -tol && dc > tol)))
                continue;
            double lam = da / (da - dc), el = hypot(c[0] - a[0], c[1] - a[1]);
            if (lam * el <= tol || (1 - lam) * el <= tol)
                continue;
            double x[2] = {a[0] + lam * (c[0] - a[0]), a[1] + lam * (c[1] - a[1])};
            t = ((x[0] - pp[0]) * d[0] + (x[1] - pp[1]) * d[1]) / (len * len);
            if (t * len > tol && (1 - t) * len > tol)
                PF_TRY(push_crossing(k, t, e, err));
        }
    }
    /* insertion sort: by parameter, corners (negative keys) before edges, then by key */
    for (int32_t i = 1; i < k->n_cross; ++i)
        for (int32_t j = i; j > 0; --j) {
            double t0 = k->cross_t[j - 1], t1 = k->cross_t[j];
            int32_t k0 = k->cross_key[j - 1], k1 = k->cross_key[j];
            bool swap = t1 < t0 - tol / len ||
                        (fabs(t1 - t0) * len <= tol && (k1 < 0) > (k0 < 0)) ||
                        (fabs(t1 - t0) * len <= tol && (k1 < 0) == (k0 < 0) && k1 < k0);
            if (!swap)
                break;
            k->cross_t[j - 1] = t1, k->cross_t[j] = t0;
            k->cross_key[j - 1] = k1, k->cross_key[j] = k0;
        }
    int32_t n = 0;
    for (int32_t i = 0; i < k->n_cross; ++i)
        if (n == 0 || (k->cross_t[i] - k->cross_t[n - 1]) * len > tol) {
            k->cross_t[n] = k->cross_t[i];
            k->cross_key[n++] = k->cross_key[i];
        }
    k->n_cross = n;
    return PF_OK;
}

static pf_status push_segment(sc_state *c, const double *pp, const double *pq, pf_error *err)
{
    if (c->n_seg == c->cap_seg) {
        int64_t cap = c->cap_seg ? 2 * c->cap_seg : 256;
        double *s = pf_realloc_array(c->seg, 4 * (size_t)cap, sizeof *s);
        PF_CHECK(s, err, PF_ERR_NOMEM, "out of memory for a section of %lld segments",
                 (long long)cap);
        c->seg = s;
        c->cap_seg = cap;
    }
    memcpy(c->seg + 4 * c->n_seg, pp, 2 * sizeof *pp);
    memcpy(c->seg + 4 * c->n_seg + 2, pq, 2 * sizeof *pq);
    c->n_seg++;
    return PF_OK;
}

static pf_status push_section(sc_state *c, sc_section s, pf_error *err)
{
    if (c->n_sec == c->cap_sec) {
        int32_t cap = c->cap_sec ? 2 * c->cap_sec : 256;
        sc_section *n = pf_realloc_array(c->sec, (size_t)cap, sizeof *n);
        PF_CHECK(n, err, PF_ERR_NOMEM, "out of memory for %d section pieces", (int)cap);
        c->sec = n;
        c->cap_sec = cap;
    }
    c->sec[c->n_sec++] = s;
    return PF_OK;
}

/* The section from point P to point Q projected (pp, pq) and its crossings (k->cross_*). */
static pf_status section_of(split_ctx *k, int32_t P, int32_t Q, double pp[2], double pq[2],
                            pf_error *err)
{
    const sc_group *g = k->c->g;
    pf_vec3 xp = k->c->pt[P].x, xq = k->c->pt[Q].x;
    pp[0] = pf_v3_get(xp, g->ax[0]), pp[1] = pf_v3_get(xp, g->ax[1]);
    pq[0] = pf_v3_get(xq, g->ax[0]), pq[1] = pf_v3_get(xq, g->ax[1]);
    double len = hypot(pq[0] - pp[0], pq[1] - pp[1]);
    k->n_cross = 0;
    if (len > g->tol)
        PF_TRY(find_crossings(k, pp, pq, len, err));
    return PF_OK;
}

/* line[0] = P, line[n_cross + 1] = Q and the points of the crossings between. */
static pf_status make_line(split_ctx *k, int32_t P, int32_t Q, int32_t *line, pf_error *err)
{
    sc_state *c = k->c;
    int32_t nl = k->n_cross + 2;
    line[0] = P;
    line[nl - 1] = Q;
    pf_vec3 xp = c->pt[P].x, xq = c->pt[Q].x;
    for (int32_t i = 0; i < k->n_cross; ++i) {
        int32_t key = k->cross_key[i];
        if (key < 0) {
            PF_TRY(pf_sc_node_point(c, -1 - key, &line[i + 1], err));
        } else {
            double tt = k->cross_t[i];
            pf_vec3 x = pf_v3_add(xp, pf_v3_scale(pf_v3_sub(xq, xp), tt));
            pf_vec3 side =
                pf_v3_add(pf_v3_scale(c->pt[P].side, 1 - tt), pf_v3_scale(c->pt[Q].side, tt));
            PF_TRY(pf_sc_new_point(c, x, side, -1, &line[i + 1], err));
        }
    }
    return PF_OK;
}

/* The piece a-b of a section: recorded when it lies on an opened face (*any set). */
static pf_status push_piece(sc_state *c, int32_t a, int32_t b, pf_vec3 normal, bool *any,
                            pf_error *err)
{
    const sc_group *g = c->g;
    pf_vec3 mid = pf_v3_scale(pf_v3_add(c->pt[a].x, c->pt[b].x), 0.5);
    /* the face on the surface's inside of the piece: a piece along the edge of a face (the
     * outer edge of the cut, an edge between two faces, an earlier cut) belongs to the face
     * its surface's inside lies on, not to the one behind it */
    pf_vec3 in = pf_v3_scale(normal, -1);
    in = pf_v3_sub(in, pf_v3_scale(g->plane.n, pf_v3_dot(in, g->plane.n)));
    double len = pf_v3_norm(in);
    if (len > 0)
        mid = pf_v3_add(mid, pf_v3_scale(in, 1e3 * g->tol / len));
    double u = pf_v3_get(mid, g->ax[0]), w = pf_v3_get(mid, g->ax[1]);
    sc_section sec = {a, b, {pf_sc_face_at(g, u, w, -1), pf_sc_face_at(g, u, w, 1)}, normal};
    if (sec.face[0] < 0 && sec.face[1] < 0)
        return PF_OK;
    *any = true;
    int32_t ia, ib;
    PF_TRY(pf_sc_point_id(c, a, -1, &ia, err));
    PF_TRY(pf_sc_point_id(c, b, -1, &ib, err));
    PF_TRY(pf_sc_push_slit(c, ia, ib, err));
    return push_section(c, sec, err);
}

/* Triangle t crosses the plane: its boundary as corners and the two plane points; the section
 * between them split at the crossings; the pieces on opened faces become slits; each side's
 * polygon fanned from its first corner (off the plane, so no fan triangle is flat). */
static pf_status split_triangle(split_ctx *k, int32_t t, bool decide, pf_error *err)
{
    sc_state *c = k->c;
    sc_surface *s = c->s;
    const sc_group *g = c->g;
    uint32_t v[3];
    memcpy(v, s->tri + 3 * (size_t)t, sizeof v);
    int32_t item[6], is_plane[6], n_item = 0, plane_at[2], n_plane = 0;
    for (int q = 0; q < 3; ++q) {
        int32_t a = (int32_t)v[q], b = (int32_t)v[(q + 1) % 3];
        if (k->cls[a] == 0) {
            PF_TRY(vertex_point(k, a, &item[n_item], err));
            is_plane[n_item] = 1;
            plane_at[n_plane++] = n_item++;
        } else {
            item[n_item] = a;
            is_plane[n_item++] = 0;
        }
        if (k->cls[a] * k->cls[b] < 0) {
            PF_TRY(edge_point(k, a, b, &item[n_item], err));
            is_plane[n_item] = 1;
            plane_at[n_plane++] = n_item++;
        }
    }
    PF_CHECK(n_plane == 2, err, PF_ERR_NUMERIC,
             "surface triangle %d meets the plane of opened face %d at %d points", (int)s->src[t],
             (int)g->face[0], (int)n_plane);
    int32_t P = item[plane_at[0]], Q = item[plane_at[1]];
    double pp[2], pq[2];
    PF_TRY(section_of(k, P, Q, pp, pq, err));
    if (decide) {
        /* a slit: some piece of the section (between crossings) on an opened face */
        bool any = false;
        for (int32_t i = 0; i <= k->n_cross && !any; ++i) {
            double t0 = i ? k->cross_t[i - 1] : 0, t1 = i < k->n_cross ? k->cross_t[i] : 1;
            double tm = 0.5 * (t0 + t1);
            double u = pp[0] + tm * (pq[0] - pp[0]), w = pp[1] + tm * (pq[1] - pp[1]);
            any = pf_sc_face_at(g, u, w, -1) >= 0 || pf_sc_face_at(g, u, w, 1) >= 0;
        }
        k->tri_pq[2 * (size_t)t] = P;
        k->tri_pq[2 * (size_t)t + 1] = Q;
        k->tri_any[t] = any;
        return PF_OK;
    }
    /* the surface's own section: not that of a cap an earlier group of this cut made, whose
     * edge on this plane is the crease where this group's cap joins it (taken for the surface's
     * section, that crease was left out of this group's caps: a hole along every bend of a
     * crack from one plane to another) */
    if (s->src[t] >= 0)
        PF_TRY(push_segment(c, pp, pq, err));
    /* the points along the section: P, crossings, Q */
    int32_t nl = k->n_cross + 2;
    int32_t local[128],
        *line = 2 * nl + 8 <= 128 ? local : pf_alloc_array(2 * (size_t)nl + 8, sizeof *line);
    PF_CHECK(line, err, PF_ERR_NOMEM, "out of memory for %d section points", (int)nl);
    int32_t *poly = line + nl;
    pf_status st = make_line(k, P, Q, line, err);
    pf_vec3 normal = pf_v3_cross(
        pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[1]), pf_v3_load(s->x + 3 * (size_t)v[0])),
        pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[2]), pf_v3_load(s->x + 3 * (size_t)v[0])));
    bool any = false;
    for (int32_t i = 0; i + 1 < nl && st >= 0; ++i)
        st = push_piece(c, line[i], line[i + 1], normal, &any, err);
    if (st >= 0 && (any || c->pt[P].used || c->pt[Q].used)) {
        int32_t src = s->src[t];
        if (src >= 0 && !k->split_src[src]) {
            k->split_src[src] = 1;
            c->stats->n_split_tris++;
        }
        uint8_t part = s->part[t];
        bool first = true;
        for (int sigma = -1; sigma <= 1 && st >= 0; sigma += 2) {
            /* start at the plane item followed by a corner on this side */
            int32_t start = -1;
            for (int32_t i = 0; i < n_item && start < 0; ++i)
                if (is_plane[i] && !is_plane[(i + 1) % n_item] &&
                    k->cls[item[(i + 1) % n_item]] == sigma)
                    start = i;
            int32_t np = 0, end_item = -1;
            st = pf_sc_point_id(c, item[start], sigma, &poly[np++], err);
            for (int32_t i = (start + 1) % n_item; st >= 0; i = (i + 1) % n_item) {
                if (is_plane[i]) {
                    st = pf_sc_point_id(c, item[i], sigma, &poly[np++], err);
                    end_item = item[i];
                    break;
                }
                poly[np++] = item[i];
            }
            /* back along the section from the end point to the start point */
            bool from_q = end_item == Q;
            for (int32_t j = 1; j + 1 < nl && st >= 0; ++j)
                st = pf_sc_point_id(c, line[from_q ? nl - 1 - j : j], sigma, &poly[np++], err);
            for (int32_t j = 2; j < np && st >= 0; ++j) {
                uint32_t a = (uint32_t)poly[1], b = (uint32_t)poly[j],
                         d = (uint32_t)poly[(j + 1) % np];
                if (first) {
                    s->tri[3 * (size_t)t] = a, s->tri[3 * (size_t)t + 1] = b,
                               s->tri[3 * (size_t)t + 2] = d;
                    first = false;
                } else {
                    st = pf_sc_add_tri(s, a, b, d, part, src, pf_v3_load(s->normal + 3 * (size_t)t),
                                       err);
                }
            }
        }
    }
    if (line != local)
        pf_free(line);
    return st;
}

/* ---- surface edges in the plane ---------------------------------------------------------------
 * An edge of the surface lying in the plane between a triangle on each side is a piece of the
 * section that no triangle crosses: its pieces on opened faces are recorded as the section, and
 * both triangles are fanned from their third corner through the points where it meets the
 * faces' edges. An edge between two triangles on one side only touches the plane. */

typedef struct plane_edge {
    uint32_t lo, hi; /* vertices, lo < hi */
    int32_t t;
    int8_t side, dir; /* the side of its third corner; +1: t has the edge from lo to hi */
} plane_edge;

static int compare_plane_edges(const void *p, const void *q)
{
    const plane_edge *a = p, *b = q;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    if (a->side != b->side)
        return a->side < b->side ? -1 : 1;
    return (a->t > b->t) - (a->t < b->t);
}

/* Triangles touching the plane along an edge (the edge and the side of the third corner). */
static pf_status collect_plane_edges(split_ctx *k, int32_t nt, plane_edge **out, int32_t *n_out,
                                     pf_error *err)
{
    const sc_surface *s = k->c->s;
    int32_t n = 0, cap = 0;
    plane_edge *e = NULL;
    for (int32_t t = 0; t < nt; ++t) {
        const uint32_t *v = s->tri + 3 * (size_t)t;
        for (int q = 0; q < 3; ++q) {
            uint32_t a = v[q], b = v[(q + 1) % 3], c = v[(q + 2) % 3];
            if (k->cls[a] != 0 || k->cls[b] != 0 || k->cls[c] == 0)
                continue;
            if (n == cap) {
                cap = cap ? 2 * cap : 64;
                plane_edge *ne = pf_realloc_array(e, (size_t)cap, sizeof *ne);
                if (!ne) {
                    pf_free(e);
                    return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                        "out of memory for %d surface edges in a plane", (int)cap);
                }
                e = ne;
            }
            e[n++] = (plane_edge){a < b ? a : b, a < b ? b : a, t, k->cls[c], a < b ? 1 : -1};
        }
    }
    if (n > 1)
        qsort(e, (size_t)n, sizeof *e, compare_plane_edges);
    *out = e;
    *n_out = n;
    return PF_OK;
}

static pf_vec3 tri_normal(const sc_surface *s, int32_t t)
{
    const uint32_t *v = s->tri + 3 * (size_t)t;
    pf_vec3 a = pf_v3_load(s->x + 3 * (size_t)v[0]);
    return pf_v3_cross(pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[1]), a),
                       pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[2]), a));
}

/* Triangle t (corners already its side's vertices) fanned from its corner off the plane through
 * the points line[1 .. nl - 2] between its corners on the plane (line[0] at vertex lo). */
static pf_status fan_triangle(split_ctx *k, int32_t t, const int32_t *line, int32_t nl, int sigma,
                              pf_error *err)
{
    sc_state *c = k->c;
    sc_surface *s = c->s;
    uint32_t v[3];
    memcpy(v, s->tri + 3 * (size_t)t, sizeof v);
    /* the corner off the plane is the one whose point is not on the plane: the vertices of the
     * two on the plane were replaced, so find it as the corner not at either end's position */
    int q = 0;
    pf_vec3 xlo = c->pt[line[0]].x, xhi = c->pt[line[nl - 1]].x;
    for (; q < 3; ++q) {
        pf_vec3 x = pf_v3_load(s->x + 3 * (size_t)v[q]);
        if (pf_v3_dist(x, xlo) > 0 && pf_v3_dist(x, xhi) > 0)
            break;
    }
    uint32_t apex = v[q], first = v[(q + 1) % 3];
    bool from_lo = pf_v3_dist(pf_v3_load(s->x + 3 * (size_t)first), xlo) == 0;
    uint32_t prev = first;
    int32_t src = s->src[t];
    uint8_t part = s->part[t];
    for (int32_t j = 1; j < nl; ++j) {
        int32_t id;
        if (j == nl - 1)
            id = (int32_t)v[(q + 2) % 3];
        else
            PF_TRY(pf_sc_point_id(c, line[from_lo ? j : nl - 1 - j], sigma, &id, err));
        if (j == 1) {
            s->tri[3 * (size_t)t] = apex;
            s->tri[3 * (size_t)t + 1] = prev;
            s->tri[3 * (size_t)t + 2] = (uint32_t)id;
        } else {
            PF_TRY(pf_sc_add_tri(s, apex, prev, (uint32_t)id, part, src,
                                 pf_v3_load(s->normal + 3 * (size_t)t), err));
        }
        prev = (uint32_t)id;
    }
    if (src >= 0 && !k->split_src[src]) {
        k->split_src[src] = 1;
        c->stats->n_split_tris++;
    }
    return PF_OK;
}

/* The edge lo-hi between triangle tm (side -1) and tp (side +1). */
static pf_status plane_edge_section(split_ctx *k, uint32_t lo, uint32_t hi, int32_t tm, int32_t tp,
                                    pf_error *err)
{
    sc_state *c = k->c;
    int32_t P, Q;
    PF_TRY(vertex_point(k, (int32_t)lo, &P, err));
    PF_TRY(vertex_point(k, (int32_t)hi, &Q, err));
    double pp[2], pq[2];
    PF_TRY(section_of(k, P, Q, pp, pq, err));
    if (c->s->src[tm] >= 0 || c->s->src[tp] >= 0) /* not between caps: as in split_triangle */
        PF_TRY(push_segment(c, pp, pq, err));
    int32_t nl = k->n_cross + 2;
    int32_t *line = pf_alloc_array((size_t)nl, sizeof *line);
    PF_CHECK(line, err, PF_ERR_NOMEM, "out of memory for %d section points", (int)nl);
    pf_status st = make_line(k, P, Q, line, err);
    pf_vec3 normal = pf_v3_add(tri_normal(c->s, tm), tri_normal(c->s, tp));
    bool any = false;
    for (int32_t i = 0; i + 1 < nl && st >= 0; ++i)
        st = push_piece(c, line[i], line[i + 1], normal, &any, err);
    for (int32_t i = 0; i + 1 < nl && st >= 0 && nl > 2 && old_slit(k, (int32_t)lo, (int32_t)hi);
         ++i) {
        int32_t a, b;
        st = pf_sc_point_id(c, line[i], 1, &a, err);
        if (st >= 0)
            st = pf_sc_point_id(c, line[i + 1], 1, &b, err);
        if (st >= 0)
            st = pf_sc_push_slit(c, a, b, err);
    }
    if (st >= 0 && nl > 2) {
        st = fan_triangle(k, tm, line, nl, -1, err);
        if (st >= 0)
            st = fan_triangle(k, tp, line, nl, 1, err);
    }
    pf_free(line);
    return st;
}

static pf_status plane_edges(split_ctx *k, const plane_edge *e, int32_t n, pf_error *err)
{
    for (int32_t i = 0; i < n;) {
        int32_t j = i;
        int32_t t[2][2] = {{-1, -1}, {-1, -1}}; /* [side > 0][dir > 0]: the first */
        for (; j < n && e[j].lo == e[i].lo && e[j].hi == e[i].hi; ++j)
            if (t[e[j].side > 0][e[j].dir > 0] < 0)
                t[e[j].side > 0][e[j].dir > 0] = e[j].t;
        /* of several on a side (caps of an earlier group), two traversing it the opposite ways */
        int d = t[0][1] >= 0 && t[1][0] >= 0 ? 1 : 0;
        int32_t tm = t[0][d] >= 0 ? t[0][d] : t[0][!d], tp = t[1][!d] >= 0 ? t[1][!d] : t[1][d];
        if (tm >= 0 && tp >= 0)
            PF_TRY(plane_edge_section(k, e[i].lo, e[i].hi, tm, tp, err));
        i = j;
    }
    return PF_OK;
}

/* k->corners: the nodes whose cap corner vertex (made by an earlier group) lies on the plane,
 * in node order; the only ones an edge point may meet (node_vertex_at). */
static pf_status plane_corners(split_ctx *k, pf_error *err)
{
    const sc_state *c = k->c;
    int32_t n = 0;
    for (int32_t i = 0; i < c->m->n_nodes; ++i) {
        int32_t w = c->cap_vert[i];
        n += w >= 0 && w < k->nv && k->cls[w] == 0;
    }
    PF_CHECK(PF_ALLOC_N(k->corners, (size_t)n + 1), err, PF_ERR_NOMEM,
             "out of memory for %d cap corners", (int)n);
    for (int32_t i = 0; i < c->m->n_nodes; ++i) {
        int32_t w = c->cap_vert[i];
        if (w >= 0 && w < k->nv && k->cls[w] == 0)
            k->corners[k->n_corners++] = i;
    }
    return PF_OK;
}

pf_status pf_sc_split(sc_state *c, uint8_t *split_src, pf_error *err)
{
    split_ctx k;
    memset(&k, 0, sizeof k);
    k.c = c;
    k.split_src = split_src;
    sc_surface *s = c->s;
    const sc_group *g = c->g;
    int32_t nv = s->n_verts, nt = s->n_tris;
    k.nv = nv;
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(k.cls, (size_t)nv) || !PF_ALLOC_N(k.dist, (size_t)nv) ||
        !PF_ALLOC_N(k.vpt, (size_t)nv) || !PF_ALLOC_N(k.stamp, (size_t)g->n_edges) ||
        !PF_ALLOC_N(k.tri_pq, 2 * (size_t)nt) || !PF_ALLOC_N(k.tri_any, (size_t)nt))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "out of memory classifying %d surface vertices", (int)nv);
    if (st >= 0 && c->n_slit > 1) {
        qsort(c->slit, (size_t)c->n_slit, sizeof *c->slit, compare_u64);
        int64_t n = 1;
        for (int64_t i = 1; i < c->n_slit; ++i)
            if (c->slit[i] != c->slit[n - 1])
                c->slit[n++] = c->slit[i];
        c->n_slit = n;
    }
    k.n_old_slit = c->n_slit;
    if (st >= 0) {
        memset(k.stamp, 0, (size_t)g->n_edges * sizeof *k.stamp);
        for (int64_t i = 0; i < 2 * (int64_t)nt; ++i)
            k.tri_pq[i] = -1;
        for (int32_t i = 0; i < nv; ++i) {
            double d = pf_plane_signed_distance(g->plane, pf_v3_load(s->x + 3 * (size_t)i));
            k.dist[i] = d;
            k.cls[i] = (int8_t)(d > g->tol ? 1 : d < -g->tol ? -1 : 0);
            k.vpt[i] = -1;
        }
    }
    if (st >= 0)
        st = plane_corners(&k, err);
    /* first which triangles get a slit, so that their neighbours on the same edge points are
     * split there too (a section leaving the opened faces ends on a shared point) */
    for (int32_t t = 0; t < nt && st >= 0; ++t) {
        const uint32_t *v = s->tri + 3 * (size_t)t;
        int has[3] = {0, 0, 0};
        for (int q = 0; q < 3; ++q)
            has[k.cls[v[q]] + 1] = 1;
        if (has[0] && has[2])
            st = split_triangle(&k, t, true, err);
    }
    if (st >= 0)
        st = spread_used(&k, nt, err);
    plane_edge *pe = NULL;
    int32_t n_pe = 0;
    if (st >= 0)
        st = collect_plane_edges(&k, nt, &pe, &n_pe, err);
    for (int32_t t = 0; t < nt && st >= 0; ++t) {
        uint32_t *v = s->tri + 3 * (size_t)t;
        int has[3] = {0, 0, 0}; /* -1, 0, +1 */
        for (int q = 0; q < 3; ++q)
            has[k.cls[v[q]] + 1] = 1;
        if (has[0] && has[2]) {
            st = split_triangle(&k, t, false, err);
        } else if (has[1] && (has[0] || has[2])) {
            /* touching the plane: its corners there take the vertex of its side */
            int sigma = has[2] ? 1 : -1;
            for (int q = 0; q < 3 && st >= 0; ++q)
                if (k.cls[v[q]] == 0) {
                    int32_t p, id;
                    st = vertex_point(&k, (int32_t)v[q], &p, err);
                    if (st >= 0)
                        st = pf_sc_point_id(c, p, sigma, &id, err);
                    if (st >= 0)
                        v[q] = (uint32_t)id;
                }
        }
    }
    if (st >= 0)
        st = plane_edges(&k, pe, n_pe, err);
    if (st >= 0)
        st = push_subs(&k, err);
    pf_free(pe);
    pf_free(k.sub);
    pf_free(k.corners);
    pf_free(k.cls);
    pf_free(k.dist);
    pf_free(k.vpt);
    pf_free(k.stamp);
    pf_free(k.tri_pq);
    pf_free(k.tri_any);
    pf_free(k.cross_t);
    pf_free(k.cross_pt);
    pf_free(k.cross_key);
    edge_map_release(&k.edges);
    return st;
}
