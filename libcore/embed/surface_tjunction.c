/* T-junctions of a surface cut (pf_surface_cut), closed before its vertices are duplicated.
 *
 * The opened faces are capped group by group (one plane at a time). Where three planes meet at a
 * point no mesh node lies at (a later plane's section crosses the crease where two earlier
 * planes' caps meet), the later group splits the crease there and its own caps have a corner at
 * that point, but the cap an earlier group made along the later plane does not: its edge passes
 * straight through the point. The surface is closed by position (no area is missing) but not by
 * its edges: an edge u-v has a vertex w on it (within tol) that edges u-w and w-v join, and no
 * triangle has all three. Every triangle on u-v is split at w (a path through several such
 * vertices is taken one vertex per pass). Nothing of the surface moves and no two places are
 * joined that were not: w already joins u and v along the edge. */
#include "surface_cut_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TJ_MAX_PASSES 4 /* vertices on one edge: more is not a crossing of three planes */

typedef struct tj_half {
    uint32_t a, b; /* the edge a-b seen from a */
    int32_t tri;   /* a triangle using it, and the corner of the edge's first vertex in it */
    int8_t corner;
} tj_half;

static int compare_half(const void *p, const void *q)
{
    const tj_half *x = p, *y = q;
    if (x->a != y->a)
        return x->a < y->a ? -1 : 1;
    if (x->b != y->b)
        return x->b < y->b ? -1 : 1;
    return (x->tri > y->tri) - (x->tri < y->tri);
}

/* Both directions of every triangle edge, sorted by first vertex, second, triangle. */
static pf_status half_edges(const sc_surface *s, tj_half **out, int64_t *n_out, pf_error *err)
{
    int64_t ne = 3 * (int64_t)s->n_tris;
    tj_half *h = NULL;
    PF_CHECK(PF_ALLOC_N(h, 2 * (size_t)ne + 1), err, PF_ERR_NOMEM,
             "out of memory for the edges of %d triangles", (int)s->n_tris);
    for (int64_t i = 0; i < ne; ++i) {
        uint32_t u = s->tri[i], v = s->tri[i - i % 3 + (i + 1) % 3];
        h[2 * i] = (tj_half){u, v, (int32_t)(i / 3), (int8_t)(i % 3)};
        h[2 * i + 1] = (tj_half){v, u, (int32_t)(i / 3), (int8_t)(i % 3)};
    }
    qsort(h, 2 * (size_t)ne, sizeof *h, compare_half);
    *out = h;
    *n_out = 2 * ne;
    return PF_OK;
}

/* The first half-edge from a to b or beyond. */
static int64_t first_from(const tj_half *h, int64_t n, uint32_t a, uint32_t b)
{
    tj_half key = {a, b, INT32_MIN, 0};
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (compare_half(&h[mid], &key) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static bool joined(const tj_half *h, int64_t n, uint32_t a, uint32_t b)
{
    int64_t i = first_from(h, n, a, b);
    return i < n && h[i].a == a && h[i].b == b;
}

/* Whether vertex w lies on the segment from x[u] to x[v] within tol, strictly inside. */
static bool on_segment(const sc_surface *s, uint32_t u, uint32_t v, uint32_t w, double tol)
{
    pf_vec3 a = pf_v3_load(s->x + 3 * (size_t)u), d = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v), a);
    pf_vec3 r = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)w), a);
    double len2 = pf_v3_dot(d, d);
    if (!(len2 > 0))
        return false;
    double t = pf_v3_dot(r, d) / len2, len = sqrt(len2);
    return t * len > tol && (1 - t) * len > tol &&
           pf_v3_norm(pf_v3_sub(r, pf_v3_scale(d, t))) <= tol;
}

static bool tri_has(const sc_surface *s, int32_t t, uint32_t w)
{
    const uint32_t *v = s->tri + 3 * (size_t)t;
    return v[0] == w || v[1] == w || v[2] == w;
}

/* A vertex on the edge u-v (its triangles h[i0 .. i1), seen from u) joined by edges to both ends
 * and in none of those triangles; UINT32_MAX when there is none. */
static uint32_t vertex_on_edge(const sc_surface *s, const tj_half *h, int64_t n, int64_t i0,
                               int64_t i1, double tol)
{
    uint32_t u = h[i0].a, v = h[i0].b;
    for (int64_t j = first_from(h, n, u, 0); j < n && h[j].a == u; ++j) {
        uint32_t w = h[j].b;
        if (w == v || (j > 0 && h[j - 1].a == u && h[j - 1].b == w))
            continue; /* the edge itself, or w seen already */
        bool in_tri = false;
        for (int64_t i = i0; i < i1 && !in_tri; ++i)
            in_tri = tri_has(s, h[i].tri, w);
        if (!in_tri && joined(h, n, w, v) && on_segment(s, u, v, w, tol))
            return w;
    }
    return UINT32_MAX;
}

/* Triangle t, whose edge from corner c is u-v (either way), as the two triangles through w. */
static pf_status split_at(sc_surface *s, int32_t t, int c, uint32_t w, pf_error *err)
{
    uint32_t *v = s->tri + 3 * (size_t)t;
    uint32_t a = v[c], b = v[(c + 1) % 3], x = v[(c + 2) % 3];
    v[0] = a, v[1] = w, v[2] = x;
    return pf_sc_add_tri(s, w, b, x, s->part[t], s->src[t], pf_v3_load(s->normal + 3 * (size_t)t),
                         err);
}

/* The slit u-v, if it is one, replaced by u-w and w-v. */
static pf_status split_slit(sc_state *c, uint32_t u, uint32_t v, uint32_t w, pf_error *err)
{
    uint64_t key = (uint64_t)(u < v ? u : v) << 32 | (u < v ? v : u);
    for (int64_t i = 0; i < c->n_slit; ++i)
        if (c->slit[i] == key) {
            c->slit[i] = (uint64_t)(u < w ? u : w) << 32 | (u < w ? w : u);
            return pf_sc_push_slit(c, (int32_t)w, (int32_t)v, err);
        }
    return PF_OK;
}

/* One pass: every edge with a vertex on it split there, unless one of its triangles was split
 * already in this pass (the next pass takes it); *n_left the edges split or left. */
static pf_status split_pass(sc_state *c, double tol, int32_t *n_left, pf_error *err)
{
    sc_surface *s = c->s;
    tj_half *h = NULL;
    uint8_t *split = NULL;
    int64_t n = 0;
    *n_left = 0;
    PF_TRY(half_edges(s, &h, &n, err));
    if (!(split = pf_calloc((size_t)s->n_tris + 1, 1))) {
        pf_free(h);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for %d triangle flags", (int)s->n_tris);
    }
    pf_status st = PF_OK;
    for (int64_t i0 = 0; i0 < n && st >= 0;) {
        int64_t i1 = i0;
        bool fresh = true;
        for (; i1 < n && h[i1].a == h[i0].a && h[i1].b == h[i0].b; ++i1)
            fresh = fresh && !split[h[i1].tri];
        uint32_t u = h[i0].a, v = h[i0].b;
        uint32_t w = u < v ? vertex_on_edge(s, h, n, i0, i1, tol) : UINT32_MAX;
        for (int64_t i = i0; i < i1 && w != UINT32_MAX && fresh && st >= 0; ++i) {
            st = split_at(s, h[i].tri, h[i].corner, w, err);
            split[h[i].tri] = 1;
        }
        if (w != UINT32_MAX && fresh && st >= 0)
            st = split_slit(c, u, v, w, err);
        *n_left += w != UINT32_MAX;
        i0 = i1;
    }
    pf_free(split);
    pf_free(h);
    return st;
}

pf_status pf_sc_close_t_junctions(sc_state *c, double tol, pf_error *err)
{
    int32_t n_left = 1;
    for (int pass = 0; pass < TJ_MAX_PASSES && n_left > 0; ++pass)
        PF_TRY(split_pass(c, tol, &n_left, err));
    return PF_OK;
}
