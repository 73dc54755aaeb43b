/* Duplicating the vertices of a surface cut along its slits (pf_surface_cut): around a vertex on
 * a slit, its triangles fall into groups joined by the edges that are not slits; each group gets
 * a vertex of its own. Where a slit ends (the crack front) the triangles stay joined around it
 * and the vertex is shared; where slits of two planes meet (a crack bending from one plane of
 * opened faces to another) the groups follow the material, whatever the planes. Where more than
 * two sheets meet at an edge (cracks of two planes crossing), only sheets next to one another
 * about the edge, with material between them, are joined. */
#include "surface_cut_internal.h"

#include <stdlib.h>
#include <string.h>

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static bool is_slit(const sc_state *c, uint32_t a, uint32_t b)
{
    uint64_t key = (uint64_t)(a < b ? a : b) << 32 | (uint64_t)(a < b ? b : a);
    return bsearch(&key, c->slit, (size_t)c->n_slit, sizeof key, compare_u64) != NULL;
}

static int32_t find_root(int32_t *parent, int32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

static pf_vec3 tri_centroid(const sc_surface *s, int32_t t)
{
    const uint32_t *v = s->tri + 3 * (size_t)t;
    pf_vec3 c = pf_v3(0, 0, 0);
    for (int q = 0; q < 3; ++q)
        c = pf_v3_add(c, pf_v3_load(s->x + 3 * (size_t)v[q]));
    return pf_v3_scale(c, 1.0 / 3);
}

typedef struct dup_work {
    int64_t *off; /* [n_verts + 1] triangles at each vertex on a slit */
    int32_t *tris;
    int32_t *first; /* [n_verts] first copy record of a vertex, -1 */
    int32_t *count; /* [n_verts] its copies */
    int32_t n_rec, cap_rec;
    int32_t *rec_id; /* copies */
    double *rec_dir; /* [3] their directions into their triangles */
    int32_t *parent, *root_comp;
    int32_t cap_local;
} dup_work;

static void dup_work_release(dup_work *d)
{
    pf_free(d->off);
    pf_free(d->tris);
    pf_free(d->first);
    pf_free(d->count);
    pf_free(d->rec_id);
    pf_free(d->rec_dir);
    pf_free(d->parent);
    pf_free(d->root_comp);
    memset(d, 0, sizeof *d);
}

static pf_status push_record(dup_work *d, int32_t id, pf_vec3 dir, pf_error *err)
{
    if (d->n_rec == d->cap_rec) {
        int32_t cap = d->cap_rec ? 2 * d->cap_rec : 256;
        int32_t *ni = pf_realloc_array(d->rec_id, (size_t)cap, sizeof *ni);
        if (ni)
            d->rec_id = ni;
        double *nd = ni ? pf_realloc_array(d->rec_dir, 3 * (size_t)cap, sizeof *nd) : NULL;
        if (nd)
            d->rec_dir = nd;
        PF_CHECK(nd, err, PF_ERR_NOMEM, "out of memory for %d vertex copies", (int)cap);
        d->cap_rec = cap;
    }
    d->rec_id[d->n_rec] = id;
    pf_v3_store(dir, d->rec_dir + 3 * (size_t)d->n_rec);
    d->n_rec++;
    return PF_OK;
}

/* The triangles at every vertex on a slit. */
static pf_status incidence(const sc_state *c, const uint8_t *on_slit, dup_work *d, pf_error *err)
{
    const sc_surface *s = c->s;
    int32_t nv = s->n_verts, nt = s->n_tris;
    PF_CHECK(PF_ALLOC_N(d->off, (size_t)nv + 1), err, PF_ERR_NOMEM, "out of memory for %d vertices",
             (int)nv);
    memset(d->off, 0, ((size_t)nv + 1) * sizeof *d->off);
    for (int32_t t = 0; t < nt; ++t)
        for (int q = 0; q < 3; ++q)
            if (on_slit[s->tri[3 * (size_t)t + q]])
                d->off[s->tri[3 * (size_t)t + q] + 1]++;
    for (int32_t v = 0; v < nv; ++v)
        d->off[v + 1] += d->off[v];
    PF_CHECK(PF_ALLOC_N(d->tris, (size_t)d->off[nv] + 1), err, PF_ERR_NOMEM,
             "out of memory for the triangles at %d vertices", (int)nv);
    for (int32_t t = 0; t < nt; ++t)
        for (int q = 0; q < 3; ++q) {
            uint32_t v = s->tri[3 * (size_t)t + q];
            if (on_slit[v])
                d->tris[d->off[v]++] = t;
        }
    for (int32_t v = nv; v > 0; --v)
        d->off[v] = d->off[v - 1];
    d->off[0] = 0;
    return PF_OK;
}

/* Whether triangle t has the edge v-w, and its direction: +1 v to w, -1 w to v, 0 none. */
static int edge_dir(const sc_surface *s, int32_t t, uint32_t v, uint32_t w)
{
    const uint32_t *c = s->tri + 3 * (size_t)t;
    for (int q = 0; q < 3; ++q) {
        if (c[q] == v && c[(q + 1) % 3] == w)
            return 1;
        if (c[q] == w && c[(q + 1) % 3] == v)
            return -1;
    }
    return 0;
}

/* The triangles among tris[k] (those at v) with the edge v-w. */
static int32_t edge_valence(const sc_surface *s, const int32_t *tris, int32_t k, uint32_t v,
                            uint32_t w)
{
    int32_t n = 0;
    for (int32_t i = 0; i < k; ++i)
        n += edge_dir(s, tris[i], v, w) != 0;
    return n;
}

/* The third corner of triangle t (which has the edge v-w). */
static uint32_t third_corner(const sc_surface *s, int32_t t, uint32_t v, uint32_t w)
{
    const uint32_t *c = s->tri + 3 * (size_t)t;
    return c[0] != v && c[0] != w ? c[0] : c[1] != v && c[1] != w ? c[1] : c[2];
}

static pf_vec3 tri_normal(const sc_surface *s, int32_t t)
{
    const uint32_t *v = s->tri + 3 * (size_t)t;
    pf_vec3 a = pf_v3_load(s->x + 3 * (size_t)v[0]);
    return pf_v3_cross(pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[1]), a),
                       pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[2]), a));
}

/* Of the triangles at edge v-w, the first that triangle a meets turning about the edge from its
 * own half-plane towards its inside (against its normal): the one bounding the same wedge of
 * material. Of two met at one angle (both sides' caps of a plane), the one facing away from a;
 * a triangle in a's own half-plane is met last (its inside lies the other way). Angles within
 * 1e-9 radians are one. */
static int32_t first_around(const sc_surface *s, int32_t a, uint32_t v, uint32_t w,
                            const int32_t *tris, int32_t k)
{
    pf_vec3 xv = pf_v3_load(s->x + 3 * (size_t)v);
    pf_vec3 e = pf_v3_normalize(pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)w), xv));
    pf_vec3 p = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)third_corner(s, a, v, w)), xv);
    pf_vec3 u = pf_v3_normalize(pf_v3_sub(p, pf_v3_scale(e, pf_v3_dot(p, e))));
    pf_vec3 na = tri_normal(s, a);
    pf_vec3 in = pf_v3_normalize(pf_v3_scale(pf_v3_sub(na, pf_v3_scale(e, pf_v3_dot(na, e))), -1));
    pf_vec3 axis = pf_v3_cross(u, in);
    int32_t best = -1;
    double best_angle = INFINITY;
    bool best_away = false;
    const double eps = 1e-9, turn = 2 * acos(-1.0);
    for (int32_t i = 0; i < k; ++i) {
        int32_t t = tris[i];
        if (t == a || edge_dir(s, t, v, w) == 0)
            continue;
        pf_vec3 q = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)third_corner(s, t, v, w)), xv);
        q = pf_v3_normalize(pf_v3_sub(q, pf_v3_scale(e, pf_v3_dot(q, e))));
        double angle = atan2(pf_v3_dot(q, in), pf_v3_dot(q, u));
        if (angle <= eps)
            angle += turn;
        bool away = pf_v3_dot(tri_normal(s, t), pf_v3_cross(axis, q)) > 0;
        if (angle < best_angle - eps || (angle <= best_angle + eps && away && !best_away))
            best = t, best_angle = angle, best_away = away;
    }
    return best;
}

/* Triangles a and b sharing the edge v-w lie on the same side of the cut around v: across a
 * slit, a cap and a triangle of the surface traversing it the opposite ways (the cap closes that
 * triangle's side); across another edge, two triangles of the surface, or a cap and a surface
 * triangle traversing it the opposite ways. Two caps: of one plane, facing the same way and not
 * across a slit, or facing the opposite ways across an edge that only they have when v is on no
 * slit (inside: the crack front inside the material, where both sides' caps meet); of two
 * planes, traversing it the opposite ways. tris[k]: the triangles at v. */
static bool joined(const sc_state *c, int32_t a, int32_t b, uint32_t v, uint32_t w, bool slit,
                   bool inside, const int32_t *tris, int32_t k)
{
    const sc_surface *s = c->s;
    int da = edge_dir(s, a, v, w), db = edge_dir(s, b, v, w);
    if (da == 0 || db == 0)
        return false;
    /* more than two sheets at the edge: only neighbours about it bound one wedge */
    if (edge_valence(s, tris, k, v, w) > 2 &&
        (first_around(s, a, v, w, tris, k) != b || first_around(s, b, v, w, tris, k) != a))
        return false;
    bool cap_a = s->src[a] < 0, cap_b = s->src[b] < 0;
    if (cap_a && cap_b) {
        /* caps of two planes (a crack bending at the edge): the material's two caps traverse
         * it the opposite ways; caps of one plane: those facing the same way, never across a
         * slit */
        pf_vec3 na = pf_v3_load(s->normal + 3 * (size_t)a),
                nb = pf_v3_load(s->normal + 3 * (size_t)b);
        double d = pf_v3_dot(na, nb);
        if (fabs(d) < (1 - 1e-9) * pf_v3_norm(na) * pf_v3_norm(nb))
            return da == -db;
        if (slit)
            return false;
        return d > 0 || (inside && da == -db && edge_valence(s, tris, k, v, w) == 2);
    }
    if (slit)
        return cap_a != cap_b && da == -db;
    if (!cap_a && !cap_b)
        return true;
    return da == -db;
}

/* Whether tris[k] are all caps facing one way: a vertex inside the caps of one side (a point
 * where a later plane split them), whose side is the caps' inward normal. */
static bool one_facing_caps(const sc_surface *s, const int32_t *tris, int32_t k)
{
    for (int32_t i = 0; i < k; ++i)
        if (s->src[tris[i]] >= 0 || pf_v3_dot(pf_v3_load(s->normal + 3 * (size_t)tris[i]),
                                              pf_v3_load(s->normal + 3 * (size_t)tris[0])) <= 0)
            return false;
    return k > 0;
}

/* The groups of triangles around vertex v and a vertex for each (inside: v is on no slit, a
 * corner of caps only). */
static pf_status split_vertex(sc_state *c, dup_work *d, uint32_t v, bool inside, pf_error *err)
{
    sc_surface *s = c->s;
    const int32_t *tris = d->tris + d->off[v];
    int32_t k = (int32_t)(d->off[v + 1] - d->off[v]);
    if (k > d->cap_local) {
        int32_t cap = 2 * k;
        int32_t *p = pf_realloc_array(d->parent, (size_t)cap, sizeof *p);
        if (p)
            d->parent = p;
        int32_t *r = p ? pf_realloc_array(d->root_comp, (size_t)cap, sizeof *r) : NULL;
        if (r)
            d->root_comp = r;
        PF_CHECK(r, err, PF_ERR_NOMEM, "out of memory around vertex %u", (unsigned)v);
        d->cap_local = cap;
    }
    for (int32_t i = 0; i < k; ++i)
        d->parent[i] = i;
    for (int32_t i = 0; i < k; ++i)
        for (int q = 0; q < 3; ++q) {
            uint32_t w = s->tri[3 * (size_t)tris[i] + q];
            if (w == v)
                continue;
            bool slit = is_slit(c, v, w);
            for (int32_t j = 0; j < i; ++j)
                if (joined(c, tris[i], tris[j], v, w, slit, inside, tris, k)) {
                    int32_t a = find_root(d->parent, i), b = find_root(d->parent, j);
                    d->parent[a > b ? a : b] = a < b ? a : b;
                }
        }
    int32_t n_comp = 0;
    for (int32_t i = 0; i < k; ++i)
        d->root_comp[i] = -1;
    for (int32_t i = 0; i < k; ++i) {
        int32_t r = find_root(d->parent, i);
        if (d->root_comp[r] < 0)
            d->root_comp[r] = n_comp++;
    }
    d->first[v] = d->n_rec;
    d->count[v] = n_comp;
    pf_vec3 x = pf_v3_load(s->x + 3 * (size_t)v), base = pf_v3_load(s->side + 3 * (size_t)v);
    for (int32_t ci = 0; ci < n_comp; ++ci) {
        pf_vec3 dir = pf_v3(0, 0, 0);
        for (int32_t i = 0; i < k; ++i)
            if (d->root_comp[find_root(d->parent, i)] == ci) {
                pf_vec3 e = s->src[tris[i]] >= 0
                                ? pf_v3_sub(tri_centroid(s, tris[i]), x)
                                : pf_v3_scale(pf_v3_load(s->normal + 3 * (size_t)tris[i]), -1);
                double len = pf_v3_norm(e);
                if (len > 0)
                    dir = pf_v3_add(dir, pf_v3_scale(e, 1.0 / len));
            }
        double len = pf_v3_norm(dir);
        dir = len > 0 ? pf_v3_scale(dir, 1.0 / len) : dir;
        int32_t id = (int32_t)v;
        if (ci > 0) {
            PF_TRY(pf_sc_add_vertex(s, x, pf_v3(0, 0, 0), &id, err));
            c->stats->n_duplicated++;
        }
        if (n_comp > 1)
            pf_v3_store(pf_v3_add(base, dir), s->side + 3 * (size_t)id);
        else if (pf_v3_norm(base) == 0 && one_facing_caps(s, tris, k))
            pf_v3_store(dir, s->side + 3 * (size_t)id);
        PF_TRY(push_record(d, id, dir, err));
        for (int32_t i = 0; i < k && ci > 0; ++i)
            if (d->root_comp[find_root(d->parent, i)] == ci) {
                uint32_t *tv = s->tri + 3 * (size_t)tris[i];
                for (int q = 0; q < 3; ++q)
                    if (tv[q] == v)
                        tv[q] = (uint32_t)id;
            }
    }
    return PF_OK;
}

pf_status pf_sc_duplicate(sc_state *c, pf_error *err)
{
    if (c->n_slit == 0)
        return PF_OK;
    qsort(c->slit, (size_t)c->n_slit, sizeof *c->slit, compare_u64);
    int64_t n = 0;
    for (int64_t i = 0; i < c->n_slit; ++i)
        if (n == 0 || c->slit[i] != c->slit[n - 1])
            c->slit[n++] = c->slit[i];
    c->n_slit = n;
    sc_surface *s = c->s;
    int32_t nv = s->n_verts;
    uint8_t *on_slit = NULL;
    dup_work d;
    memset(&d, 0, sizeof d);
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(on_slit, (size_t)nv) || !PF_ALLOC_N(d.first, (size_t)nv) ||
        !PF_ALLOC_N(d.count, (size_t)nv))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for %d vertices",
                          (int)nv);
    if (st >= 0) {
        memset(on_slit, 0, (size_t)nv);
        for (int32_t v = 0; v < nv; ++v)
            d.first[v] = -1, d.count[v] = 0;
        for (int64_t i = 0; i < c->n_slit; ++i)
            on_slit[c->slit[i] >> 32] = on_slit[c->slit[i] & 0xffffffffu] = 1;
        /* and the corners of caps: a later plane splitting an edge both sides' caps had (they
         * share the points of the section until here) makes a point of both, on no slit */
        for (int32_t t = 0; t < s->n_tris; ++t)
            for (int q = 0; q < 3 && s->src[t] < 0; ++q)
                if (!on_slit[s->tri[3 * (size_t)t + q]])
                    on_slit[s->tri[3 * (size_t)t + q]] = 2;
        st = incidence(c, on_slit, &d, err);
    }
    for (int32_t v = 0; v < nv && st >= 0; ++v)
        if (on_slit[v])
            st = split_vertex(c, &d, (uint32_t)v, on_slit[v] == 2, err);
    pf_free(on_slit);
    dup_work_release(&d);
    return st;
}
