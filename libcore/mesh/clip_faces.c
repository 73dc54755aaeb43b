/* The faces of a clipped element's part rebuilt on welded nodes (see clip.c and clip_internal.h).
 *
 * A part comes out of a sequence of plane splits (the kd tree's, then the element's own planes),
 * and two neighbouring elements see different sequences: the region of their shared face may be
 * cut into different polygons, and a node made on one side (where a kd plane crossed the surface,
 * inside a straight edge) has no counterpart on the other. Rebuilding every region as a whole
 * from its boundary, over welded nodes, and dropping the nodes that lie inside a straight edge
 * between exactly two regions makes the faces depend on the geometry alone: the corners of a
 * region (where three regions meet) are the same on both sides. */
#include "clip_internal.h"

#include <pf/split.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- welding ----------------------------------------------------------------------------------
 */

static uint64_t cell_hash(const int64_t *c)
{
    uint64_t h = 0;
    for (int k = 0; k < 3; ++k)
        h = pf_hash_mix(h ^ (uint64_t)c[k]);
    return h;
}

static void cell_of(const pf_weld *w, const double *p, int64_t *c)
{
    double size = 2 * w->tol;
    for (int k = 0; k < 3; ++k)
        c[k] = (int64_t)floor(p[k] / size);
}

int32_t pf_weld_find(const pf_weld *w, const double *p)
{
    if (w->slots == 0)
        return -1;
    int64_t c[3], q[3];
    cell_of(w, p, c);
    int32_t best = -1;
    uint64_t mask = (uint64_t)w->slots - 1;
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                q[0] = c[0] + dx, q[1] = c[1] + dy, q[2] = c[2] + dz;
                for (int32_t i = w->table[cell_hash(q) & mask]; i >= 0; i = w->next[i]) {
                    const int64_t *ci = w->cell + 3 * (size_t)i;
                    if (ci[0] != q[0] || ci[1] != q[1] || ci[2] != q[2])
                        continue;
                    const double *x = w->x + 3 * (size_t)i;
                    if (fabs(x[0] - p[0]) <= w->tol && fabs(x[1] - p[1]) <= w->tol &&
                        fabs(x[2] - p[2]) <= w->tol && (best < 0 || i < best))
                        best = i;
                }
            }
    return best;
}

static void weld_link(pf_weld *w, int32_t i)
{
    uint64_t s = cell_hash(w->cell + 3 * (size_t)i) & ((uint64_t)w->slots - 1);
    w->next[i] = w->table[s];
    w->table[s] = i;
}

pf_status pf_weld_point(pf_weld *w, const double *p, int32_t *id, pf_error *err)
{
    *id = pf_weld_find(w, p);
    if (*id >= 0)
        return PF_OK;
    if (w->n == w->cap) {
        int32_t cap = w->cap ? 2 * w->cap : 1024;
        double *x = pf_realloc_array(w->x, 3 * (size_t)cap, sizeof *x);
        if (x)
            w->x = x;
        int32_t *next = pf_realloc_array(w->next, (size_t)cap, sizeof *next);
        if (next)
            w->next = next;
        int64_t *cell = pf_realloc_array(w->cell, 3 * (size_t)cap, sizeof *cell);
        if (cell)
            w->cell = cell;
        PF_CHECK(x && next && cell, err, PF_ERR_NOMEM, "out of memory clipping");
        w->cap = cap;
    }
    if ((int64_t)(w->n + 1) * 2 > w->slots) {
        int64_t slots = w->slots ? 2 * w->slots : 2048;
        int32_t *table = pf_alloc_array((size_t)slots, sizeof *table);
        PF_CHECK(table, err, PF_ERR_NOMEM, "out of memory clipping");
        for (int64_t s = 0; s < slots; ++s)
            table[s] = -1;
        pf_free(w->table);
        w->table = table;
        w->slots = slots;
        for (int32_t i = 0; i < w->n; ++i)
            weld_link(w, i);
    }
    int32_t i = w->n++;
    memcpy(w->x + 3 * (size_t)i, p, 3 * sizeof *p);
    cell_of(w, p, w->cell + 3 * (size_t)i);
    weld_link(w, i);
    *id = i;
    return PF_OK;
}

void pf_weld_release(pf_weld *w)
{
    pf_free(w->x);
    pf_free(w->table);
    pf_free(w->next);
    pf_free(w->cell);
    memset(w, 0, sizeof *w);
}

/* ---- regions ----------------------------------------------------------------------------------
 */

typedef struct bedge {
    int32_t group;
    uint32_t a, b;
    bool alive;
} bedge;

typedef struct sorted_edge {
    uint32_t lo, hi;
    int dir; /* +1: lo -> hi */
} sorted_edge;

static int compare_sorted_edge(const void *pa, const void *pb)
{
    const sorted_edge *a = pa, *b = pb;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    return (a->hi > b->hi) - (a->hi < b->hi);
}

static int compare_pair(const void *pa, const void *pb)
{
    const uint32_t *a = pa, *b = pb;
    if (a[0] != b[0])
        return a[0] < b[0] ? -1 : 1;
    return (a[1] > b[1]) - (a[1] < b[1]);
}

typedef struct face_order {
    int32_t key, face;
} face_order;

static int compare_face_order(const void *pa, const void *pb)
{
    const face_order *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

/* True when v lies inside the segment u-w, within tol of it. */
static bool inside_segment(const double *x, uint32_t u, uint32_t v, uint32_t w, double tol)
{
    pf_vec3 pu = pf_v3(x[3 * (size_t)u], x[3 * (size_t)u + 1], x[3 * (size_t)u + 2]);
    pf_vec3 pv = pf_v3(x[3 * (size_t)v], x[3 * (size_t)v + 1], x[3 * (size_t)v + 2]);
    pf_vec3 pw = pf_v3(x[3 * (size_t)w], x[3 * (size_t)w + 1], x[3 * (size_t)w + 2]);
    pf_vec3 d = pf_v3_sub(pw, pu), r = pf_v3_sub(pv, pu);
    double len2 = pf_v3_dot(d, d), t = pf_v3_dot(r, d);
    if (!(len2 > 0) || t <= 0 || t >= len2)
        return false;
    return pf_v3_norm(pf_v3_cross(r, d)) <= tol * sqrt(len2);
}

/* Drops the node v of edges u -> v -> w in one group and w -> v -> u in another when v is no
 * node of the mesh and lies inside the straight segment u-w: a node only a plane split made. */
static bool drop_straight_nodes(bedge *e, int64_t n, const double *x, int32_t n_fixed, double tol)
{
    bool changed = false;
    for (int64_t i = 0; i < n; ++i) {
        if (!e[i].alive || (int32_t)e[i].b < n_fixed)
            continue;
        uint32_t v = e[i].b;
        int64_t inc[4];
        int32_t k = 0;
        for (int64_t j = 0; j < n && k <= 4; ++j)
            if (e[j].alive && (e[j].a == v || e[j].b == v)) {
                if (k < 4)
                    inc[k] = j;
                ++k;
            }
        if (k != 4)
            continue;
        /* i: u -> v in group g1; find v -> w in g1, w -> v and v -> u in the other group */
        int64_t out1 = -1, in2 = -1, out2 = -1;
        for (int q = 0; q < 4; ++q) {
            const bedge *f = &e[inc[q]];
            if (inc[q] == i)
                continue;
            if (f->group == e[i].group && f->a == v)
                out1 = inc[q];
            else if (f->group != e[i].group && f->b == v)
                in2 = inc[q];
            else if (f->group != e[i].group && f->a == v)
                out2 = inc[q];
        }
        if (out1 < 0 || in2 < 0 || out2 < 0 || e[in2].group != e[out2].group)
            continue;
        uint32_t u = e[i].a, w = e[out1].b;
        if (u == w || e[in2].a != w || e[out2].b != u || !inside_segment(x, u, v, w, tol))
            continue;
        e[i].b = w;
        e[out1].alive = false;
        e[in2].b = u;
        e[out2].alive = false;
        changed = true;
    }
    return changed;
}

void pf_part_faces_release(pf_part_faces *f)
{
    pf_free(f->offsets);
    pf_free(f->nodes);
    pf_free(f->key);
    memset(f, 0, sizeof *f);
}

/* The welded faces of p, consecutive repeats dropped, faces left with under 3 nodes dropped. */
static pf_status weld_faces(pf_weld *w, const piece *p, const int32_t *face_key, int64_t *off,
                            uint32_t *nodes, int32_t *key, int32_t *n_faces, pf_error *err)
{
    int32_t *wid = pf_alloc_array((size_t)p->n_nodes + 1, sizeof *wid);
    PF_CHECK(wid, err, PF_ERR_NOMEM, "out of memory clipping");
    pf_status st = PF_OK;
    for (int32_t i = 0; st >= 0 && i < p->n_nodes; ++i)
        st = pf_weld_point(w, p->x + 3 * (size_t)i, &wid[i], err);
    int32_t nf = 0;
    off[0] = 0;
    for (int32_t f = 0; st >= 0 && f < p->n_faces; ++f) {
        int64_t at = off[nf];
        for (int64_t q = p->face_offsets[f]; q < p->face_offsets[f + 1]; ++q) {
            uint32_t id = (uint32_t)wid[p->face_nodes[q]];
            if (at > off[nf] && nodes[at - 1] == id)
                continue;
            nodes[at++] = id;
        }
        while (at - off[nf] > 1 && nodes[at - 1] == nodes[off[nf]])
            --at;
        if (at - off[nf] < 3)
            continue;
        key[nf] = face_key[f];
        off[++nf] = at;
    }
    pf_free(wid);
    *n_faces = nf;
    return st;
}

/* The boundary of each group of faces (directed edges not cancelled by their reverse). */
static pf_status group_boundaries(const int64_t *off, const uint32_t *nodes, const int32_t *key,
                                  int32_t nf, face_order *order, pf_buffer *edges,
                                  pf_buffer *group_key, pf_error *err)
{
    for (int32_t f = 0; f < nf; ++f)
        order[f] = (face_order){key[f], f};
    qsort(order, (size_t)nf, sizeof *order, compare_face_order);
    sorted_edge *se = pf_alloc_array((size_t)off[nf] + 1, sizeof *se);
    PF_CHECK(se, err, PF_ERR_NOMEM, "out of memory clipping");
    pf_status st = PF_OK;
    int32_t g = 0;
    for (int32_t i = 0; st >= 0 && i < nf; ++g) {
        int32_t j = i;
        int64_t n = 0;
        for (; j < nf && order[j].key == order[i].key; ++j) {
            int32_t f = order[j].face;
            int64_t len = off[f + 1] - off[f];
            for (int64_t q = 0; q < len; ++q) {
                uint32_t a = nodes[off[f] + q], b = nodes[off[f] + (q + 1) % len];
                se[n++] = a < b ? (sorted_edge){a, b, 1} : (sorted_edge){b, a, -1};
            }
        }
        qsort(se, (size_t)n, sizeof *se, compare_sorted_edge);
        for (int64_t s = 0; st >= 0 && s < n;) {
            int64_t t = s;
            int net = 0;
            for (; t < n && se[t].lo == se[s].lo && se[t].hi == se[s].hi; ++t)
                net += se[t].dir;
            for (int c = 0; st >= 0 && c < abs(net); ++c) {
                bedge b = {g, net > 0 ? se[s].lo : se[s].hi, net > 0 ? se[s].hi : se[s].lo, true};
                st = pf_buffer_append(edges, &b, sizeof b, err);
            }
            s = t;
        }
        if (st >= 0)
            st = pf_buffer_append(group_key, &order[i].key, sizeof(int32_t), err);
        i = j;
    }
    pf_free(se);
    return st;
}

/* The polygons of group g, appended to out. */
static pf_status group_polygons(const pf_weld *w, const bedge *e, int64_t ne, int32_t g,
                                int32_t key, const pf_mesh *m, const int32_t *face_ref,
                                const uint8_t *face_rev, const double *tri_normal, pf_buffer *off,
                                pf_buffer *nodes, pf_buffer *keys, pf_error *err)
{
    bool rev = key < 0 && face_rev[-key - 1];
    pf_vec3 normal;
    if (key < 0) {
        int32_t f = face_ref[-key - 1];
        normal = pf_polygon_area_vector(m->x, m->face_nodes + m->face_offsets[f],
                                        m->face_offsets[f + 1] - m->face_offsets[f]);
    } else {
        normal = pf_v3(tri_normal[3 * (size_t)key], tri_normal[3 * (size_t)key + 1],
                       tri_normal[3 * (size_t)key + 2]);
    }
    int64_t n = 0;
    for (int64_t i = 0; i < ne; ++i)
        n += e[i].alive && e[i].group == g;
    if (n == 0)
        return PF_OK;
    uint32_t *pairs = pf_alloc_array(2 * (size_t)n, sizeof *pairs);
    PF_CHECK(pairs, err, PF_ERR_NOMEM, "out of memory clipping");
    int64_t k = 0;
    for (int64_t i = 0; i < ne; ++i)
        if (e[i].alive && e[i].group == g) {
            pairs[2 * k] = rev ? e[i].b : e[i].a;
            pairs[2 * k + 1] = rev ? e[i].a : e[i].b;
            ++k;
        }
    qsort(pairs, (size_t)n, 2 * sizeof *pairs, compare_pair);
    int64_t *po = NULL;
    uint32_t *pn = NULL;
    int32_t np = 0;
    pf_status st = pf_split_cap_polygons(w->x, normal, pairs, n, &po, &pn, &np, err);
    pf_free(pairs);
    int64_t base = off->size ? ((const int64_t *)off->data)[off->size / sizeof(int64_t) - 1] : 0;
    for (int32_t p = 0; st >= 0 && p < np; ++p) {
        int64_t len = po[p + 1] - po[p];
        for (int64_t q = 0; st >= 0 && q < len; ++q) {
            uint32_t id = pn[po[p] + (rev ? (len - q) % len : q)];
            st = pf_buffer_append(nodes, &id, sizeof id, err);
        }
        base += len;
        if (st >= 0)
            st = pf_buffer_append(off, &base, sizeof base, err);
        if (st >= 0)
            st = pf_buffer_append(keys, &key, sizeof key, err);
    }
    pf_free(po);
    pf_free(pn);
    return st;
}

pf_status pf_clip_rebuild_part(pf_weld *w, const piece *p, const int32_t *face_key,
                               const pf_mesh *m, const int32_t *face_ref, const uint8_t *face_rev,
                               const double *tri_normal, pf_part_faces *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    int64_t n_idx = p->face_offsets[p->n_faces];
    int64_t *off = pf_alloc_array((size_t)p->n_faces + 1, sizeof *off);
    uint32_t *nodes = pf_alloc_array((size_t)n_idx + 1, sizeof *nodes);
    int32_t *key = pf_alloc_array((size_t)p->n_faces + 1, sizeof *key);
    face_order *order = pf_alloc_array((size_t)p->n_faces + 1, sizeof *order);
    pf_buffer edges = {0}, group_key = {0}, o_off = {0}, o_nodes = {0}, o_keys = {0};
    pf_status st = PF_OK;
    if (!off || !nodes || !key || !order)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    int32_t nf = 0;
    if (st >= 0)
        st = weld_faces(w, p, face_key, off, nodes, key, &nf, err);
    if (st >= 0)
        st = group_boundaries(off, nodes, key, nf, order, &edges, &group_key, err);
    bedge *e = (bedge *)edges.data;
    int64_t ne = (int64_t)(edges.size / sizeof(bedge));
    while (st >= 0 && drop_straight_nodes(e, ne, w->x, w->n_fixed, w->tol)) {
    }
    int64_t zero = 0;
    if (st >= 0)
        st = pf_buffer_append(&o_off, &zero, sizeof zero, err);
    int32_t ng = (int32_t)(group_key.size / sizeof(int32_t));
    for (int32_t g = 0; st >= 0 && g < ng; ++g)
        st = group_polygons(w, e, ne, g, ((const int32_t *)group_key.data)[g], m, face_ref,
                            face_rev, tri_normal, &o_off, &o_nodes, &o_keys, err);
    if (st >= 0) {
        out->n_faces = (int32_t)(o_keys.size / sizeof(int32_t));
        out->offsets = (int64_t *)o_off.data;
        out->nodes = (uint32_t *)o_nodes.data;
        out->key = (int32_t *)o_keys.data;
        o_off = o_nodes = o_keys = (pf_buffer){0};
    }
    pf_free(off), pf_free(nodes), pf_free(key), pf_free(order);
    pf_buffer_release(&edges), pf_buffer_release(&group_key);
    pf_buffer_release(&o_off), pf_buffer_release(&o_nodes), pf_buffer_release(&o_keys);
    return st;
}
