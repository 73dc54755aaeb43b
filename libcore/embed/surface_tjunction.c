/* T-junctions of a surface cut (pf_surface_cut), closed once each side has its vertices.
 *
 * The opened faces are capped group by group (one plane at a time). Where three planes meet at a
 * point no mesh node lies at (a later plane's section crosses the crease where two earlier
 * planes' caps meet), the later group splits the crease there and its own caps have a corner at
 * that point, but the cap an earlier group made along the later plane does not: its edge passes
 * straight through the point. The surface is closed by position (no area is missing) but not by
 * its edges: a border edge u -> v is retraced by a path v -> w ... -> u of border edges whose
 * inner vertices lie on it (within tol). Its triangle is split at those vertices. Only border
 * edges are looked at (after the duplication, each side's own), so a closed part of the surface
 * is never touched, and nothing moves: the vertices are on the edge already. */
#include "surface_cut_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TJ_MAX_INNER 8 /* inner vertices on one edge: more is not a crossing of three planes */

typedef struct tj_edge {
    uint32_t u, v; /* directed as its triangle has it */
    int32_t tri;   /* the triangle, and the corner u is at in it */
    int8_t corner;
} tj_edge;

static int compare_edges(const void *p, const void *q)
{
    const tj_edge *x = p, *y = q;
    if (x->u != y->u)
        return x->u < y->u ? -1 : 1;
    if (x->v != y->v)
        return x->v < y->v ? -1 : 1;
    return (x->tri > y->tri) - (x->tri < y->tri);
}

/* The first edge of e[0 .. n) from u to v or beyond. */
static int64_t first_from(const tj_edge *e, int64_t n, uint32_t u, uint32_t v)
{
    tj_edge key = {u, v, INT32_MIN, 0};
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (compare_edges(&e[mid], &key) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static int64_t count_from(const tj_edge *e, int64_t n, uint32_t u, uint32_t v)
{
    int64_t i = first_from(e, n, u, v), k = 0;
    for (; i + k < n && e[i + k].u == u && e[i + k].v == v; ++k)
        ;
    return k;
}

/* The border edges (used once, never the other way), directed, sorted by start. */
static pf_status border_edges(const sc_surface *s, tj_edge **out, int64_t *n_out, pf_error *err)
{
    int64_t ne = 3 * (int64_t)s->n_tris;
    tj_edge *all = NULL, *b = NULL;
    if (!PF_ALLOC_N(all, (size_t)ne + 1) || !PF_ALLOC_N(b, (size_t)ne + 1)) {
        pf_free(all);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the edges of %d triangles", (int)s->n_tris);
    }
    for (int64_t i = 0; i < ne; ++i)
        all[i] = (tj_edge){s->tri[i], s->tri[i - i % 3 + (i + 1) % 3], (int32_t)(i / 3),
                           (int8_t)(i % 3)};
    qsort(all, (size_t)ne, sizeof *all, compare_edges);
    int64_t n = 0;
    for (int64_t i = 0; i < ne; ++i)
        if (all[i].u != all[i].v && count_from(all, ne, all[i].u, all[i].v) == 1 &&
            count_from(all, ne, all[i].v, all[i].u) == 0)
            b[n++] = all[i];
    pf_free(all);
    *out = b;
    *n_out = n;
    return PF_OK;
}

/* The parameter of vertex w on the segment from x[u] to x[v] when it lies on it within tol,
 * strictly inside; -1 otherwise. */
static double on_segment(const sc_surface *s, uint32_t u, uint32_t v, uint32_t w, double tol)
{
    pf_vec3 a = pf_v3_load(s->x + 3 * (size_t)u), d = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v), a);
    pf_vec3 r = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)w), a);
    double len2 = pf_v3_dot(d, d);
    if (!(len2 > 0))
        return -1;
    double t = pf_v3_dot(r, d) / len2, len = sqrt(len2);
    if (t * len <= tol || (1 - t) * len <= tol || pf_v3_norm(pf_v3_sub(r, pf_v3_scale(d, t))) > tol)
        return -1;
    return t;
}

/* The border path from v back to u through vertices on the segment u-v, each nearer u than the
 * last: its inner vertices in path[] (v's side first) and their count; 0 when there is none. */
static int32_t path_on_edge(const sc_surface *s, const tj_edge *e, int64_t n, uint32_t u,
                            uint32_t v, double tol, uint32_t *path)
{
    int32_t k = 0;
    uint32_t at = v;
    double last = 1;
    for (;;) {
        uint32_t next = UINT32_MAX;
        for (int64_t i = first_from(e, n, at, 0); i < n && e[i].u == at; ++i) {
            if (e[i].v == u && k > 0)
                return k;
            double t = on_segment(s, u, v, e[i].v, tol);
            if (t >= 0 && t < last && next == UINT32_MAX)
                next = e[i].v, last = t;
        }
        if (next == UINT32_MAX || k == TJ_MAX_INNER)
            return 0;
        path[k++] = next;
        at = next;
    }
}

/* Triangle t (u -> v from corner c, then x) as the fan of u, the path from u's side, v about x. */
static pf_status split_along(sc_surface *s, int32_t t, int c, const uint32_t *path, int32_t k,
                             pf_error *err)
{
    uint32_t *tv = s->tri + 3 * (size_t)t;
    uint32_t u = tv[c], v = tv[(c + 1) % 3], x = tv[(c + 2) % 3];
    pf_vec3 normal = pf_v3_load(s->normal + 3 * (size_t)t);
    tv[0] = u, tv[1] = path[k - 1], tv[2] = x;
    for (int32_t i = k - 1; i > 0; --i)
        PF_TRY(pf_sc_add_tri(s, path[i], path[i - 1], x, s->part[t], s->src[t], normal, err));
    return pf_sc_add_tri(s, path[0], v, x, s->part[t], s->src[t], normal, err);
}

pf_status pf_sc_close_t_junctions(sc_state *c, double tol, pf_error *err)
{
    sc_surface *s = c->s;
    tj_edge *e = NULL;
    int64_t n = 0;
    PF_TRY(border_edges(s, &e, &n, err));
    int32_t n_tris = s->n_tris;
    uint8_t *split = pf_calloc((size_t)n_tris + 1, 1);
    pf_status st = split ? PF_OK
                         : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                        "out of memory for %d triangle flags", (int)n_tris);
    uint32_t path[TJ_MAX_INNER];
    for (int64_t i = 0; i < n && st >= 0; ++i) {
        if (split[e[i].tri]) /* its corners moved: the next cut of the surface sees the rest */
            continue;
        int32_t k = path_on_edge(s, e, n, e[i].u, e[i].v, tol, path);
        if (k > 0) {
            st = split_along(s, e[i].tri, e[i].corner, path, k, err);
            split[e[i].tri] = 1;
        }
    }
    pf_free(split);
    pf_free(e);
    return st;
}
