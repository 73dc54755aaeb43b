/* T-junctions of a surface cut (pf_surface_cut), closed before its vertices are duplicated.
 *
 * The opened faces are capped group by group (one plane at a time). Where three planes meet at a
 * point no mesh node lies at (a later plane's section crosses the crease where two earlier
 * planes' caps meet), the later group splits the crease there and its own caps have a corner at
 * that point, but the cap an earlier group made along the later plane does not: its edge passes
 * straight through the point. The surface is closed by position (no area is missing) but not by
 * its edges: the long edge u -> v of the earlier cap is retraced by a path v -> w ... -> u of
 * border edges whose inner vertices lie on it. Splitting the long edge's triangle at those
 * vertices closes it. A triangle is split only when the whole path lies on its edge within tol,
 * so nothing of the surface moves and no two places are joined. */
#include "surface_cut_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TJ_MAX_INNER 8 /* inner vertices on one edge: more is not a T-junction of three planes */

typedef struct tj_edge {
    uint32_t u, v; /* directed as its triangle has it */
    int32_t tri;   /* the triangle, and the corner u is in it */
    int8_t corner;
} tj_edge;

static int compare_from(const void *a, const void *b)
{
    const tj_edge *x = a, *y = b;
    if (x->u != y->u)
        return x->u < y->u ? -1 : 1;
    return (x->v > y->v) - (x->v < y->v);
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static uint64_t edge_key(uint32_t a, uint32_t b)
{
    return (uint64_t)(a < b ? a : b) << 32 | (a < b ? b : a);
}

/* The edges used by one triangle only and not retraced (lo << 32 | hi keys sorted in keys[]),
 * directed, sorted by their start. */
static pf_status border_edges(const sc_surface *s, tj_edge **out, int64_t *n_out, pf_error *err)
{
    int64_t ne = 3 * (int64_t)s->n_tris;
    uint64_t *keys = NULL;
    tj_edge *e = NULL;
    if (!PF_ALLOC_N(keys, (size_t)ne + 1) || !PF_ALLOC_N(e, (size_t)ne + 1)) {
        pf_free(keys);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the edges of %d triangles", (int)s->n_tris);
    }
    for (int64_t i = 0; i < ne; ++i)
        keys[i] = edge_key(s->tri[i], s->tri[i - i % 3 + (i + 1) % 3]);
    qsort(keys, (size_t)ne, sizeof *keys, compare_u64);
    int64_t n = 0;
    for (int64_t i = 0; i < ne; ++i) {
        uint32_t u = s->tri[i], v = s->tri[i - i % 3 + (i + 1) % 3];
        uint64_t k = edge_key(u, v);
        uint64_t *lo = bsearch(&k, keys, (size_t)ne, sizeof k, compare_u64);
        int64_t a = lo - keys, b = a;
        while (a > 0 && keys[a - 1] == k)
            a--;
        while (b + 1 < ne && keys[b + 1] == k)
            b++;
        if (a == b && u != v)
            e[n++] = (tj_edge){u, v, (int32_t)(i / 3), (int8_t)(i % 3)};
    }
    pf_free(keys);
    qsort(e, (size_t)n, sizeof *e, compare_from);
    *out = e;
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
 * last: its inner vertices in path[] (from v's side), their count, or 0 when there is none. */
static int32_t path_on_edge(const sc_surface *s, const tj_edge *e, int64_t n, uint32_t u,
                            uint32_t v, double tol, uint32_t *path)
{
    int32_t k = 0;
    uint32_t at = v;
    double last = 1;
    while (k <= TJ_MAX_INNER) {
        tj_edge key = {.u = at, .v = 0};
        int64_t lo = 0, hi = n;
        while (lo < hi) { /* the first border edge from at */
            int64_t mid = lo + (hi - lo) / 2;
            if (compare_from(&e[mid], &key) < 0)
                lo = mid + 1;
            else
                hi = mid;
        }
        uint32_t next = UINT32_MAX;
        for (int64_t i = lo; i < n && e[i].u == at && next == UINT32_MAX; ++i) {
            if (e[i].v == u && k > 0)
                return k;
            double t = on_segment(s, u, v, e[i].v, tol);
            if (t >= 0 && t < last)
                next = e[i].v, last = t;
        }
        if (next == UINT32_MAX || k == TJ_MAX_INNER)
            return 0;
        path[k++] = next;
        at = next;
    }
    return 0;
}

/* Triangle t (u -> v at corner c, then x) as the fan u, path reversed, v about x. */
static pf_status split_triangle_at(sc_surface *s, int32_t t, int corner, const uint32_t *path,
                                   int32_t k, pf_error *err)
{
    uint32_t u = s->tri[3 * (size_t)t + corner], v = s->tri[3 * (size_t)t + (corner + 1) % 3],
             x = s->tri[3 * (size_t)t + (corner + 2) % 3];
    pf_vec3 normal = pf_v3_load(s->normal + 3 * (size_t)t);
    uint32_t prev = u;
    for (int32_t i = k - 1; i >= 0; --i) { /* path[k - 1] is nearest u */
        if (prev == u) {
            s->tri[3 * (size_t)t] = u, s->tri[3 * (size_t)t + 1] = path[i];
            s->tri[3 * (size_t)t + 2] = x;
        } else {
            PF_TRY(pf_sc_add_tri(s, prev, path[i], x, s->part[t], s->src[t], normal, err));
        }
        prev = path[i];
    }
    return pf_sc_add_tri(s, prev, v, x, s->part[t], s->src[t], normal, err);
}

/* The slit u-v, if it is one, replaced by its pieces along the path. */
static pf_status split_slit(sc_state *c, uint32_t u, uint32_t v, const uint32_t *path, int32_t k,
                            pf_error *err)
{
    uint64_t key = edge_key(u, v);
    for (int64_t i = 0; i < c->n_slit; ++i) {
        if (c->slit[i] != key)
            continue;
        c->slit[i] = edge_key(u, path[k - 1]);
        for (int32_t j = k - 1; j > 0; --j)
            PF_TRY(pf_sc_push_slit(c, (int32_t)path[j], (int32_t)path[j - 1], err));
        return pf_sc_push_slit(c, (int32_t)path[0], (int32_t)v, err);
    }
    return PF_OK;
}

pf_status pf_sc_close_t_junctions(sc_state *c, double tol, pf_error *err)
{
    sc_surface *s = c->s;
    tj_edge *e = NULL;
    int64_t n = 0;
    PF_TRY(border_edges(s, &e, &n, err));
    pf_status st = PF_OK;
    uint32_t path[TJ_MAX_INNER + 1];
    for (int64_t i = 0; i < n && st >= 0; ++i) {
        int32_t t = e[i].tri;
        int corner = e[i].corner;
        uint32_t u = e[i].u, v = e[i].v;
        if (s->tri[3 * (size_t)t + corner] != u || s->tri[3 * (size_t)t + (corner + 1) % 3] != v)
            continue; /* this triangle was split already */
        int32_t k = path_on_edge(s, e, n, u, v, tol, path);
        if (k == 0)
            continue;
        st = split_triangle_at(s, t, corner, path, k, err);
        if (st >= 0)
            st = split_slit(c, u, v, path, k, err);
    }
    pf_free(e);
    return st;
}
