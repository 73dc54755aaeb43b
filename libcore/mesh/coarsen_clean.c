/* pf_mesh_coarsen's cleaning (coarsen.c does the rest): the pieces of a polygon a refinement cut
 * apart, now faces of one merged element toward one neighbour, become that polygon again; then
 * the nodes of removed and united faces that no face needs are dropped from every face. */
#include "coarsen_internal.h"

#include <math.h>
#include <stdlib.h>

#define NOMEM(err) pf_error_set((err), PF_ERR_NOMEM, __FILE__, __LINE__, "coarsen: out of memory")

/* ---- cut edges ------------------------------------------------------------------------------ */

static uint64_t edge_key(uint32_t a, uint32_t b)
{
    return a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
}

static bool is_cut_edge(const coarsen *c, uint32_t a, uint32_t b)
{
    uint64_t k = edge_key(a, b), mask = (uint64_t)c->edge_slots - 1;
    for (uint64_t s = mix(k) & mask; c->edge_table[s] != UINT64_MAX; s = (s + 1) & mask)
        if (c->edge_table[s] == k)
            return true;
    return false;
}

pf_status pf_coarsen_cut_edges(coarsen *c, pf_error *err)
{
    int64_t n = 0;
    for (int64_t i = 0; i < c->n_dead; ++i) {
        int32_t len;
        poly(c, c->dead[i], &len);
        n += len;
    }
    c->edge_slots = pow2_at_least(2 * n);
    PF_CHECK(PF_ALLOC_N(c->edge_table, c->edge_slots), err, PF_ERR_NOMEM, "coarsen: out of memory");
    memset(c->edge_table, 0xff, (size_t)c->edge_slots * sizeof *c->edge_table);
    uint64_t mask = (uint64_t)c->edge_slots - 1;
    for (int64_t i = 0; i < c->n_dead; ++i) {
        int32_t len;
        const uint32_t *p = poly(c, c->dead[i], &len);
        for (int32_t k = 0; k < len; ++k) {
            uint64_t key = edge_key(p[k], p[(k + 1) % len]);
            uint64_t s = mix(key) & mask;
            while (c->edge_table[s] != UINT64_MAX && c->edge_table[s] != key)
                s = (s + 1) & mask;
            c->edge_table[s] = key;
        }
    }
    return PF_OK;
}

/* ---- uniting the pieces of a polygon -------------------------------------------------------- */

/* A face of a merged element: the class is the element on its other side (its group's first
 * element for a merged one; -1 on the boundary); rev: the merged element uses it reversed. */
typedef struct item {
    int32_t cls, face, rev, pad;
} item;

typedef struct dir_edge {
    uint64_t key; /* tail << 32 | head */
    int32_t item;
    int32_t pad;
} dir_edge;

static int cmp_item(const void *pa, const void *pb)
{
    const item *a = pa, *b = pb;
    if (a->cls != b->cls)
        return a->cls < b->cls ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

static int cmp_edge(const void *pa, const void *pb)
{
    const dir_edge *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return (a->item > b->item) - (a->item < b->item);
}

static int cmp_i32(const void *pa, const void *pb)
{
    int32_t a = *(const int32_t *)pa, b = *(const int32_t *)pb;
    return (a > b) - (a < b);
}

/* The first directed edge with this key in e[n] (sorted), or -1. */
static int64_t find_edge(const dir_edge *e, int64_t n, uint64_t key)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = (lo + hi) / 2;
        if (e[mid].key < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && e[lo].key == key ? lo : -1;
}

/* Node k of face f's polygon seen from the merged element (reversed when it uses f reversed). */
static uint32_t item_node(const coarsen *c, const item *it, int32_t k)
{
    int32_t n;
    const uint32_t *p = poly(c, it->face, &n);
    return it->rev ? p[n - 1 - k] : p[k];
}

static int32_t item_len(const coarsen *c, const item *it)
{
    int32_t n;
    poly(c, it->face, &n);
    return n;
}

/* Plane of an item's polygon: unit normal (outward from the merged element), a point on it, and
 * its bounding box. */
typedef struct plane_box {
    pf_vec3 n, p, lo, hi;
} plane_box;

static plane_box item_plane(const coarsen *c, const item *it)
{
    int32_t n;
    const uint32_t *p = poly(c, it->face, &n);
    plane_box pb;
    pb.n = pf_v3_normalize(pf_polygon_area_vector(c->src->x, p, n));
    if (it->rev)
        pb.n = pf_v3_scale(pb.n, -1);
    pb.p = pf_polygon_centroid(c->src->x, p, n);
    pb.lo = pb.hi = node_at(c, p[0]);
    for (int32_t k = 1; k < n; ++k) {
        pb.lo = pf_v3_min(pb.lo, node_at(c, p[k]));
        pb.hi = pf_v3_max(pb.hi, node_at(c, p[k]));
    }
    return pb;
}

/* Every node of b within PF_COARSEN_TOL * (diameter of the two) of a's plane and the reverse,
 * normals the same way. */
static bool coplanar(const coarsen *c, const item *ia, const plane_box *a, const item *ib,
                     const plane_box *b)
{
    if (pf_v3_dot(a->n, b->n) <= 0)
        return false;
    double tol =
        PF_COARSEN_TOL * pf_v3_norm(pf_v3_sub(pf_v3_max(a->hi, b->hi), pf_v3_min(a->lo, b->lo)));
    for (int s = 0; s < 2; ++s) {
        const plane_box *pl = s ? b : a;
        const item *other = s ? ia : ib;
        for (int32_t k = 0, n = item_len(c, other); k < n; ++k) {
            pf_vec3 q = node_at(c, item_node(c, other, k));
            if (fabs(pf_v3_dot(pf_v3_sub(q, pl->p), pl->n)) > tol)
                return false;
        }
    }
    return true;
}

typedef struct unite_scratch {
    pf_buffer items, edges, parent, planes, cycle, members;
} unite_scratch;

static void unite_scratch_release(unite_scratch *s)
{
    pf_buffer_release(&s->items);
    pf_buffer_release(&s->edges);
    pf_buffer_release(&s->parent);
    pf_buffer_release(&s->planes);
    pf_buffer_release(&s->cycle);
    pf_buffer_release(&s->members);
}

/* The union of the cluster's polygons its[member[0..n)] as one simple cycle (seen from the
 * merged element) in s->cycle, or *ok false: directed edges of the members whose reverse is in
 * the cluster too are inside; the rest must chain into one cycle through distinct nodes. */
static pf_status union_cycle(const coarsen *c, const item *its, const int32_t *member, int32_t n,
                             unite_scratch *s, int32_t *out_len, bool *ok, pf_error *err)
{
    int64_t ne = 0;
    for (int32_t i = 0; i < n; ++i)
        ne += item_len(c, &its[member[i]]);
    s->edges.size = 0;
    PF_TRY(pf_buffer_reserve(&s->edges, (size_t)(2 * ne) * sizeof(dir_edge), err));
    dir_edge *e = (dir_edge *)s->edges.data, *bnd = e + ne;
    int64_t k = 0;
    for (int32_t i = 0; i < n; ++i) {
        const item *it = &its[member[i]];
        int32_t len = item_len(c, it);
        for (int32_t j = 0; j < len; ++j) {
            uint32_t a = item_node(c, it, j), b = item_node(c, it, (j + 1) % len);
            e[k++] = (dir_edge){.key = (uint64_t)a << 32 | b, .item = member[i]};
        }
    }
    qsort(e, (size_t)ne, sizeof *e, cmp_edge);
    *ok = false;
    int64_t nb = 0;
    for (int64_t i = 0; i < ne; ++i) {
        if (i > 0 && e[i].key == e[i - 1].key)
            return PF_OK; /* the same directed edge twice: overlapping pieces */
        uint64_t rev = e[i].key << 32 | e[i].key >> 32;
        if (find_edge(e, ne, rev) < 0)
            bnd[nb++] = e[i];
    }
    /* bnd is sorted by tail; one cycle needs distinct tails and a walk through all of them */
    for (int64_t i = 1; i < nb; ++i)
        if (bnd[i].key >> 32 == bnd[i - 1].key >> 32)
            return PF_OK;
    if (nb < 3)
        return PF_OK;
    PF_TRY(pf_buffer_reserve(&s->cycle, (size_t)nb * sizeof(uint32_t), err));
    uint32_t *cyc = (uint32_t *)s->cycle.data;
    int64_t at = 0, steps = 0;
    do {
        cyc[steps++] = (uint32_t)(bnd[at].key >> 32);
        uint64_t head = bnd[at].key & 0xffffffffu;
        int64_t lo = 0, hi = nb;
        while (lo < hi) {
            int64_t mid = (lo + hi) / 2;
            if ((bnd[mid].key >> 32) < head)
                lo = mid + 1;
            else
                hi = mid;
        }
        if (lo == nb || (bnd[lo].key >> 32) != head)
            return PF_OK;
        at = lo;
    } while (at != 0 && steps < nb);
    if (at != 0 || steps != nb)
        return PF_OK;
    /* the union must be as planar as a face must be */
    double lo3[3] = {INFINITY, INFINITY, INFINITY}, hi3[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t i = 0; i < nb; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = c->src->x[3 * (size_t)cyc[i] + d];
            lo3[d] = fmin(lo3[d], v), hi3[d] = fmax(hi3[d], v);
        }
    double diam = pf_v3_norm(pf_v3(hi3[0] - lo3[0], hi3[1] - lo3[1], hi3[2] - lo3[2]));
    if (pf_polygon_planarity_error(c->src->x, cyc, nb) > PF_COARSEN_TOL * diam)
        return PF_OK;
    *out_len = (int32_t)nb;
    *ok = true;
    return PF_OK;
}

/* Clusters of one class its[0..n): faces meeting along a cut edge and coplanar; each cluster of
 * two or more whose union is one simple polygon becomes that polygon, in its lowest face. */
static pf_status unite_class(coarsen *c, item *its, int32_t n, unite_scratch *s, pf_error *err)
{
    s->parent.size = s->planes.size = s->members.size = 0;
    PF_TRY(pf_buffer_reserve(&s->parent, (size_t)n * sizeof(int32_t), err));
    PF_TRY(pf_buffer_reserve(&s->planes, (size_t)n * sizeof(plane_box), err));
    PF_TRY(pf_buffer_reserve(&s->members, (size_t)n * sizeof(int32_t), err));
    int32_t *parent = (int32_t *)s->parent.data, *member = (int32_t *)s->members.data;
    plane_box *pl = (plane_box *)s->planes.data;
    int64_t ne = 0;
    for (int32_t i = 0; i < n; ++i) {
        parent[i] = i;
        pl[i] = item_plane(c, &its[i]);
        ne += item_len(c, &its[i]);
    }
    /* cut edges of the class, directed as the merged element sees them */
    s->edges.size = 0;
    PF_TRY(pf_buffer_reserve(&s->edges, (size_t)ne * sizeof(dir_edge), err));
    dir_edge *e = (dir_edge *)s->edges.data;
    int64_t k = 0;
    for (int32_t i = 0; i < n; ++i) {
        int32_t len = item_len(c, &its[i]);
        for (int32_t j = 0; j < len; ++j) {
            uint32_t a = item_node(c, &its[i], j), b = item_node(c, &its[i], (j + 1) % len);
            if (is_cut_edge(c, a, b))
                e[k++] = (dir_edge){.key = (uint64_t)a << 32 | b, .item = i};
        }
    }
    qsort(e, (size_t)k, sizeof *e, cmp_edge);
    bool any = false;
    for (int64_t i = 0; i < k; ++i) {
        uint64_t rev = e[i].key << 32 | e[i].key >> 32;
        int64_t j = find_edge(e, k, rev);
        if (j < 0 || e[j].item == e[i].item)
            continue;
        int32_t a = e[i].item, b = e[j].item;
        if (pf_uf_find(parent, a) != pf_uf_find(parent, b) &&
            coplanar(c, &its[a], &pl[a], &its[b], &pl[b])) {
            pf_uf_union(parent, a, b);
            any = true;
        }
    }
    if (!any)
        return PF_OK;
    for (int32_t r = 0; r < n; ++r) {
        if (pf_uf_find(parent, r) != r)
            continue;
        int32_t m = 0;
        for (int32_t i = r; i < n; ++i)
            if (pf_uf_find(parent, i) == r)
                member[m++] = i;
        if (m < 2)
            continue;
        int32_t len = 0;
        bool ok = false;
        PF_TRY(union_cycle(c, its, member, m, s, &len, &ok, err));
        if (!ok)
            continue;
        /* its are sorted by face: member[0] is the lowest face, which keeps the union */
        const item *rep = &its[member[0]];
        for (int32_t i = 0; i < m; ++i) {
            const item *it = &its[member[i]];
            for (int32_t j = 0, l = item_len(c, it); j < l; ++j)
                PF_TRY(pf_coarsen_add_candidate(c, item_node(c, it, j), err));
            for (int side = 0; side < 2; ++side)
                if (c->face_user[2 * it->face + side] >= 0)
                    c->touched[c->face_user[2 * it->face + side]] = 1;
            if (i > 0)
                c->face_state[it->face] = FACE_DEAD;
        }
        uint32_t *cyc = (uint32_t *)s->cycle.data;
        if (rep->rev)
            for (int32_t i = 0; i < len / 2; ++i) {
                uint32_t t = cyc[i];
                cyc[i] = cyc[len - 1 - i];
                cyc[len - 1 - i] = t;
            }
        PF_TRY(pf_coarsen_set_poly(c, rep->face, cyc, len, err));
    }
    return PF_OK;
}

/* Every merged element's faces by class; a class between two merged elements is done from the
 * one whose group comes first. */
pf_status pf_coarsen_unite(coarsen *c, pf_error *err)
{
    const pf_mesh *m = c->src;
    unite_scratch s = {0};
    pf_status st = PF_OK;
    for (int32_t g = 0; g < c->n_groups && st >= 0; ++g) {
        int32_t g0 = c->group_off[g], g1 = c->group_off[g + 1];
        if (g1 - g0 < 2)
            continue;
        int32_t owner = c->group_elem[g0];
        int64_t n = 0;
        for (int32_t i = g0; i < g1; ++i)
            n += m->elem_offsets[c->group_elem[i] + 1] - m->elem_offsets[c->group_elem[i]];
        s.items.size = 0;
        st = pf_buffer_reserve(&s.items, (size_t)n * sizeof(item), err);
        if (st < 0)
            break;
        item *its = (item *)s.items.data;
        int32_t ni = 0;
        for (int32_t i = g0; i < g1; ++i) {
            int32_t e = c->group_elem[i];
            for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
                int side = (m->elem_faces[k] & PF_FACE_REVERSED) ? 1 : 0;
                if (c->face_state[f] == FACE_DEAD)
                    continue;
                int32_t other = c->face_user[2 * f + 1 - side], cls = other;
                if (other >= 0 && c->elem_group[other] >= 0) {
                    int32_t og = c->elem_group[other];
                    if (c->group_off[og + 1] - c->group_off[og] >= 2) {
                        cls = c->group_elem[c->group_off[og]];
                        if (cls < owner)
                            continue;
                    }
                }
                its[ni++] = (item){.cls = cls, .face = f, .rev = side};
            }
        }
        qsort(its, (size_t)ni, sizeof *its, cmp_item);
        for (int32_t a = 0; a < ni && st >= 0;) {
            int32_t b = a + 1;
            while (b < ni && its[b].cls == its[a].cls)
                ++b;
            if (b - a >= 2) {
                /* unite_class may grow the scratch buffers, not items */
                st = unite_class(c, its + a, b - a, &s, err);
            }
            a = b;
        }
    }
    unite_scratch_release(&s);
    return st;
}

/* ---- nodes no face needs -------------------------------------------------------------------- */

/* Whether v, at position at of the polygon p[n], lies strictly between its two neighbours on
 * the line through them, within PF_COARSEN_TOL of their distance. */
static bool on_straight_part(const coarsen *c, const uint32_t *p, int32_t n, int32_t at)
{
    pf_vec3 u = node_at(c, p[(at + n - 1) % n]), v = node_at(c, p[at]),
            w = node_at(c, p[(at + 1) % n]);
    pf_vec3 d = pf_v3_sub(w, u), q = pf_v3_sub(v, u);
    double len2 = pf_v3_dot(d, d);
    if (!(len2 > 0))
        return false;
    double t = pf_v3_dot(q, d) / len2;
    double off = pf_v3_norm(pf_v3_sub(q, pf_v3_scale(d, t)));
    return t > 0 && t < 1 && off <= PF_COARSEN_TOL * sqrt(len2);
}

static int32_t position(const uint32_t *p, int32_t n, uint32_t v)
{
    for (int32_t k = 0; k < n; ++k)
        if (p[k] == v)
            return k;
    return -1;
}

/* Records the faces around the candidates: count (inc NULL) or fill inc at fill[]. */
static void scan_faces(const coarsen *c, const int32_t *id, int64_t *fill, int32_t *inc)
{
    for (int32_t f = 0; f < c->src->n_faces; ++f) {
        if (c->face_state[f] == FACE_DEAD)
            continue;
        int32_t n;
        const uint32_t *p = poly(c, f, &n);
        for (int32_t k = 0; k < n; ++k)
            if (c->candidate[p[k]]) {
                if (inc)
                    inc[fill[id[p[k]]]] = f;
                fill[id[p[k]]]++;
            }
    }
}

/* Drops candidate v from its faces inc[k0..k1) when no face uses it or every face using it has
 * it on a straight part of its boundary (and keeps three nodes without it). */
static pf_status try_remove(coarsen *c, uint32_t v, const int32_t *inc, int64_t k0, int64_t k1,
                            int32_t *n_removed, pf_error *err)
{
    for (int64_t k = k0; k < k1; ++k) {
        int32_t n;
        const uint32_t *p = poly(c, inc[k], &n);
        int32_t at = position(p, n, v);
        if (at < 0 || n <= 3 || !on_straight_part(c, p, n, at))
            return PF_OK;
    }
    c->candidate[v] = 2;
    ++*n_removed;
    for (int64_t k = k0; k < k1; ++k) {
        int32_t f = inc[k], n;
        const uint32_t *p = poly(c, f, &n);
        if (c->face_state[f] != FACE_OWN)
            PF_TRY(pf_coarsen_set_poly(c, f, p, n, err));
        uint32_t *q = c->pool + c->own_start[f];
        int32_t at = position(q, n, v);
        memmove(q + at, q + at + 1, (size_t)(n - at - 1) * sizeof *q);
        c->own_len[f] = n - 1;
        for (int side = 0; side < 2; ++side)
            if (c->face_user[2 * f + side] >= 0)
                c->touched[c->face_user[2 * f + side]] = 1;
    }
    return PF_OK;
}

/* The candidates (nodes of the faces removed or united) in ascending order, each on the faces
 * as the earlier removals left them. The faces around them come from one pass over the faces. */
pf_status pf_coarsen_remove_nodes(coarsen *c, int32_t *n_removed, pf_error *err)
{
    int32_t nc = (int32_t)(c->cands.size / sizeof(int32_t));
    int32_t *cand = (int32_t *)c->cands.data;
    if (nc <= 0)
        return PF_OK;
    qsort(cand, (size_t)nc, sizeof *cand, cmp_i32);
    int32_t *id = c->node_map; /* the candidate index of a candidate node, for now */
    for (int32_t i = 0; i < nc; ++i)
        id[cand[i]] = i;
    int64_t *off = pf_calloc((size_t)nc + 1, sizeof *off);
    int64_t *fill = pf_alloc_array((size_t)nc + 1, sizeof *fill);
    int32_t *inc = NULL;
    pf_status st = PF_OK;
    if (!off || !fill) {
        st = NOMEM(err);
        goto done;
    }
    scan_faces(c, id, off + 1, NULL);
    for (int32_t i = 0; i < nc; ++i)
        off[i + 1] += off[i];
    inc = pf_alloc_array((size_t)off[nc] + 1, sizeof *inc);
    if (!inc) {
        st = NOMEM(err);
        goto done;
    }
    memcpy(fill, off, (size_t)nc * sizeof *fill);
    scan_faces(c, id, fill, inc);
    for (int32_t i = 0; i < nc && st >= 0; ++i)
        st = try_remove(c, (uint32_t)cand[i], inc, off[i], off[i + 1], n_removed, err);
done:
    pf_free(off);
    pf_free(fill);
    pf_free(inc);
    return st;
}
