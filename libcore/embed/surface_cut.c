/* Cutting the embedded surface along the faces a mesh cut opened (pf/cut.h): the opened faces
 * are gathered by plane; per plane, every triangle crossing it is split exactly along its
 * section (surface_split.c), the pieces of the section on opened faces being slits, and the faces
 * are capped (surface_cap.c). Then the vertices on the slits are duplicated by the groups of
 * triangles around them (surface_dup.c), which also leaves the crack front shared, and the
 * weights are computed with the visibility rule. */
#include "surface_cut_internal.h"

#include <stdlib.h>
#include <string.h>

#define SC_PLANE_TOL 1e-9 /* on-plane tolerance, fraction of the largest face's diameter */

/* ---- the surface being built ------------------------------------------------------------------
 */

static void sc_surface_release(sc_surface *s)
{
    pf_free(s->x);
    pf_free(s->side);
    pf_free(s->tri);
    pf_free(s->part);
    pf_free(s->src);
    pf_free(s->normal);
    memset(s, 0, sizeof *s);
}

pf_status pf_sc_add_vertex(sc_surface *s, pf_vec3 x, pf_vec3 side, int32_t *id, pf_error *err)
{
    if (s->n_verts == s->cap_verts) {
        PF_CHECK(s->cap_verts < INT32_MAX / 2, err, PF_ERR_TOO_LARGE,
                 "the cut surface would exceed %d vertices", (int)s->cap_verts);
        int32_t cap = s->cap_verts ? 2 * s->cap_verts : 64;
        double *nx = pf_realloc_array(s->x, 3 * (size_t)cap, sizeof *nx);
        if (nx)
            s->x = nx;
        double *ns = nx ? pf_realloc_array(s->side, 3 * (size_t)cap, sizeof *ns) : NULL;
        if (ns)
            s->side = ns;
        PF_CHECK(ns, err, PF_ERR_NOMEM, "out of memory for %d surface vertices", (int)cap);
        s->cap_verts = cap;
    }
    *id = s->n_verts++;
    pf_v3_store(x, s->x + 3 * (size_t)*id);
    pf_v3_store(side, s->side + 3 * (size_t)*id);
    return PF_OK;
}

pf_status pf_sc_add_tri(sc_surface *s, uint32_t a, uint32_t b, uint32_t c, uint8_t part,
                        int32_t src, pf_vec3 normal, pf_error *err)
{
    if (s->n_tris == s->cap_tris) {
        PF_CHECK(s->cap_tris < INT32_MAX / 2, err, PF_ERR_TOO_LARGE,
                 "the cut surface would exceed %d triangles", (int)s->cap_tris);
        int32_t cap = s->cap_tris ? 2 * s->cap_tris : 64;
        uint32_t *nt = pf_realloc_array(s->tri, 3 * (size_t)cap, sizeof *nt);
        if (nt)
            s->tri = nt;
        uint8_t *np = nt ? pf_realloc_array(s->part, (size_t)cap, sizeof *np) : NULL;
        if (np)
            s->part = np;
        int32_t *ns = np ? pf_realloc_array(s->src, (size_t)cap, sizeof *ns) : NULL;
        if (ns)
            s->src = ns;
        double *nn = ns ? pf_realloc_array(s->normal, 3 * (size_t)cap, sizeof *nn) : NULL;
        if (nn)
            s->normal = nn;
        PF_CHECK(nn, err, PF_ERR_NOMEM, "out of memory for %d surface triangles", (int)cap);
        s->cap_tris = cap;
    }
    int32_t t = s->n_tris++;
    s->tri[3 * (size_t)t] = a;
    s->tri[3 * (size_t)t + 1] = b;
    s->tri[3 * (size_t)t + 2] = c;
    s->part[t] = part;
    s->src[t] = src;
    pf_v3_store(normal, s->normal + 3 * (size_t)t);
    return PF_OK;
}

/* ---- planes of the opened faces ----------------------------------------------------------------
 */

static void group_release(sc_group *g)
{
    pf_free(g->face);
    pf_free(g->side);
    pf_free(g->uv_offsets);
    pf_free(g->uv);
    pf_free(g->corner_edge);
    pf_free(g->box);
    pf_free(g->edge_node);
    pf_free(g->canon);
    memset(g, 0, sizeof *g);
}

typedef struct face_info {
    pf_plane plane;
    double diam;
    int8_t outward; /* +1: the stored normal points out of the face's element, -1 reversed */
    int32_t group;
} face_info;

/* Opened faces, each given the plane of the first earlier face it lies in (normals parallel
 * within 1e-9, every corner within the tolerance of that plane), in face order. */
static pf_status assign_groups(const pf_mesh *m, const pf_cut_result *cut, face_info *fi,
                               int32_t *n_groups, int32_t *leader, pf_error *err)
{
    for (int32_t f = 0; f < m->n_faces; ++f)
        fi[f].outward = 0, fi[f].group = -1;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            if (cut->opened[f] && fi[f].outward == 0)
                fi[f].outward = (m->elem_faces[k] & PF_FACE_REVERSED) ? -1 : 1;
        }
    *n_groups = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        if (!cut->opened[f])
            continue;
        int64_t o = m->face_offsets[f], n = m->face_offsets[f + 1] - o;
        const uint32_t *fn = m->face_nodes + o;
        pf_vec3 area = pf_polygon_area_vector(m->x, fn, n);
        PF_CHECK(pf_v3_norm(area) > 0 && fi[f].outward != 0, err, PF_ERR_INVALID,
                 "opened face %d has no area or no element", (int)f);
        fi[f].plane = pf_plane_from_point_normal(pf_polygon_centroid(m->x, fn, n), area);
        fi[f].diam = pf_polygon_diameter(m->x, fn, n);
        for (int32_t g = 0; g < *n_groups && fi[f].group < 0; ++g) {
            const face_info *l = &fi[leader[g]];
            if (fabs(pf_v3_dot(l->plane.n, fi[f].plane.n)) < 1 - 1e-9)
                continue;
            double tol = SC_PLANE_TOL * fmax(l->diam, fi[f].diam);
            int on = 1;
            for (int64_t k = 0; k < n && on; ++k)
                on = fabs(pf_plane_signed_distance(l->plane,
                                                   pf_v3_load(m->x + 3 * (size_t)fn[k]))) <= tol;
            if (on)
                fi[f].group = g;
        }
        if (fi[f].group < 0) {
            leader[*n_groups] = f;
            fi[f].group = (*n_groups)++;
        }
    }
    return PF_OK;
}

static int compare_node_pos(const void *a, const void *b, const double *x)
{
    const double *p = x + 3 * (size_t) * (const int32_t *)a,
                 *q = x + 3 * (size_t) * (const int32_t *)b;
    for (int k = 0; k < 3; ++k)
        if (p[k] != q[k])
            return p[k] < q[k] ? -1 : 1;
    int32_t i = *(const int32_t *)a, j = *(const int32_t *)b;
    return (i > j) - (i < j);
}

/* Insertion-free sort of node indices by position (qsort has no context argument in C11). */
static void sort_nodes(int32_t *v, int32_t n, const double *x, int32_t *tmp)
{
    for (int32_t w = 1; w < n; w *= 2)
        for (int32_t lo = 0; lo < n; lo += 2 * w) {
            int32_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            int32_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi)
                tmp[k++] = compare_node_pos(&v[j], &v[i], x) < 0 ? v[j++] : v[i++];
            while (i < mid)
                tmp[k++] = v[i++];
            while (j < hi)
                tmp[k++] = v[j++];
            memcpy(v + lo, tmp + lo, (size_t)(hi - lo) * sizeof *v);
        }
}

typedef struct edge_key {
    int32_t a, b;   /* canonical nodes, a < b */
    int32_t na, nb; /* the actual nodes, a < b */
    int8_t side;
    int64_t slot; /* corner index of the face */
} edge_key;

static int compare_edge_keys(const void *p, const void *q)
{
    const edge_key *x = p, *y = q;
    if (x->a != y->a)
        return x->a < y->a ? -1 : 1;
    if (x->b != y->b)
        return x->b < y->b ? -1 : 1;
    return (x->slot > y->slot) - (x->slot < y->slot);
}

/* Canonical nodes (bit-identical positions: the copies of a duplicated node) and the distinct
 * edges of the group's faces (the copies of an edge are one edge). */
static pf_status build_edges(const pf_mesh *m, sc_group *g, pf_error *err)
{
    int64_t nc = g->uv_offsets[g->n_faces];
    int32_t *nodes = NULL, *tmp = NULL;
    edge_key *keys = NULL;
    int ok = PF_ALLOC_N(nodes, (size_t)nc) && PF_ALLOC_N(tmp, (size_t)nc) &&
             PF_ALLOC_N(keys, (size_t)nc) && PF_ALLOC_N(g->corner_edge, (size_t)nc) &&
             PF_ALLOC_N(g->canon, (size_t)m->n_nodes) && PF_ALLOC_N(g->edge_node, 2 * (size_t)nc);
    if (!ok) {
        pf_free(nodes);
        pf_free(tmp);
        pf_free(keys);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the edges of %d opened faces", (int)g->n_faces);
    }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        g->canon[i] = -1;
    int32_t n = 0;
    for (int32_t k = 0; k < g->n_faces; ++k) {
        int32_t f = g->face[k];
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j)
            if (g->canon[m->face_nodes[j]] == -1) {
                g->canon[m->face_nodes[j]] = -2;
                nodes[n++] = (int32_t)m->face_nodes[j];
            }
    }
    sort_nodes(nodes, n, m->x, tmp);
    for (int32_t i = 0; i < n;) {
        int32_t j = i;
        while (j < n && memcmp(m->x + 3 * (size_t)nodes[j], m->x + 3 * (size_t)nodes[i],
                               3 * sizeof(double)) == 0)
            j++;
        for (int32_t q = i; q < j; ++q) /* the first in position order has the lowest index */
            g->canon[nodes[q]] = nodes[i];
        i = j;
    }
    int64_t nk = 0;
    for (int32_t k = 0; k < g->n_faces; ++k) {
        int32_t f = g->face[k];
        int64_t o = m->face_offsets[f], len = m->face_offsets[f + 1] - o;
        for (int64_t j = 0; j < len; ++j) {
            int32_t a = (int32_t)m->face_nodes[o + j],
                    b = (int32_t)m->face_nodes[o + (j + 1) % len];
            int32_t ca = g->canon[a], cb = g->canon[b];
            edge_key e = {ca < cb ? ca : cb, ca < cb ? cb : ca, a < b ? a : b,
                          a < b ? b : a,     g->side[k],        g->uv_offsets[k] + j};
            keys[nk++] = e;
        }
    }
    qsort(keys, (size_t)nk, sizeof *keys, compare_edge_keys);
    g->n_edges = 0;
    for (int64_t i = 0; i < nk;) {
        int64_t j = i;
        while (j < nk && keys[j].a == keys[i].a && keys[j].b == keys[i].b)
            g->corner_edge[keys[j++].slot] = g->n_edges;
        g->edge_node[2 * g->n_edges] = keys[i].a;
        g->edge_node[2 * g->n_edges + 1] = keys[i].b;
        g->n_edges++;
        i = j;
    }
    pf_free(nodes);
    pf_free(tmp);
    pf_free(keys);
    return PF_OK;
}

static pf_status build_group(const pf_mesh *m, const face_info *fi, int32_t gi, int32_t lead,
                             sc_group *g, pf_error *err)
{
    memset(g, 0, sizeof *g);
    g->plane = fi[lead].plane;
    double an[3] = {fabs(g->plane.n.x), fabs(g->plane.n.y), fabs(g->plane.n.z)};
    int k0 = an[0] >= an[1] && an[0] >= an[2] ? 0 : an[1] >= an[2] ? 1 : 2;
    g->ax[0] = (k0 + 1) % 3;
    g->ax[1] = (k0 + 2) % 3;
    int64_t nc = 0;
    double diam = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (fi[f].group == gi) {
            g->n_faces++;
            nc += m->face_offsets[f + 1] - m->face_offsets[f];
            diam = fmax(diam, fi[f].diam);
        }
    g->tol = SC_PLANE_TOL * diam;
    PF_CHECK(PF_ALLOC_N(g->face, (size_t)g->n_faces) && PF_ALLOC_N(g->side, (size_t)g->n_faces) &&
                 PF_ALLOC_N(g->uv_offsets, (size_t)g->n_faces + 1) &&
                 PF_ALLOC_N(g->uv, 2 * (size_t)nc) && PF_ALLOC_N(g->box, 4 * (size_t)g->n_faces),
             err, PF_ERR_NOMEM, "out of memory for %d opened faces", (int)g->n_faces);
    int32_t k = 0;
    g->uv_offsets[0] = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        if (fi[f].group != gi)
            continue;
        g->face[k] = f;
        /* the element lies against its outward normal */
        double along = pf_v3_dot(fi[f].plane.n, g->plane.n) * fi[f].outward;
        g->side[k] = along > 0 ? -1 : 1;
        int64_t o = m->face_offsets[f], n = m->face_offsets[f + 1] - o, u0 = g->uv_offsets[k];
        double *box = g->box + 4 * (size_t)k;
        box[0] = box[1] = INFINITY;
        box[2] = box[3] = -INFINITY;
        for (int64_t j = 0; j < n; ++j) {
            const double *p = m->x + 3 * (size_t)m->face_nodes[o + j];
            double u = p[g->ax[0]], v = p[g->ax[1]];
            g->uv[2 * (u0 + j)] = u;
            g->uv[2 * (u0 + j) + 1] = v;
            box[0] = fmin(box[0], u - g->tol);
            box[1] = fmin(box[1], v - g->tol);
            box[2] = fmax(box[2], u + g->tol);
            box[3] = fmax(box[3], v + g->tol);
        }
        g->uv_offsets[k + 1] = u0 + n;
        k++;
    }
    return build_edges(m, g, err);
}

/* ---- points -------------------------------------------------------------------------------------
 */

int32_t pf_sc_face_at(const sc_group *g, double u, double v, int sigma)
{
    for (int32_t k = 0; k < g->n_faces; ++k) {
        const double *b = g->box + 4 * (size_t)k;
        if (g->side[k] != sigma || u < b[0] || u > b[2] || v < b[1] || v > b[3])
            continue;
        int64_t o = g->uv_offsets[k];
        if (pf_polygon2_contains(g->uv + 2 * o, g->uv_offsets[k + 1] - o, u, v, g->tol))
            return k;
    }
    return -1;
}

pf_status pf_sc_new_point(sc_state *c, pf_vec3 x, pf_vec3 side, int32_t orig, int32_t *out,
                          pf_error *err)
{
    if (c->n_points == c->cap_points) {
        int32_t cap = c->cap_points ? 2 * c->cap_points : 256;
        sc_point *p = pf_realloc_array(c->pt, (size_t)cap, sizeof *p);
        PF_CHECK(p, err, PF_ERR_NOMEM, "out of memory for %d points on a cut", (int)cap);
        c->pt = p;
        c->cap_points = cap;
    }
    sc_point *p = &c->pt[c->n_points];
    p->x = x;
    p->side = side;
    p->orig = orig;
    p->id[0] = p->id[1] = -1;
    p->node[0] = p->node[1] = -1;
    p->used = 0;
    *out = c->n_points++;
    return PF_OK;
}

pf_status pf_sc_point_id(sc_state *c, int32_t i, int sigma, int32_t *id, pf_error *err)
{
    (void)sigma; /* one vertex for both sides until surface_dup.c splits it */
    sc_point *p = &c->pt[i];
    if (p->id[0] < 0) {
        if (p->orig >= 0)
            p->id[0] = p->orig;
        else
            PF_TRY(pf_sc_add_vertex(c->s, p->x, p->side, &p->id[0], err));
        p->id[1] = p->id[0];
    }
    *id = p->id[0];
    return PF_OK;
}

pf_status pf_sc_node_point(sc_state *c, int32_t n, int32_t *out, pf_error *err)
{
    if (c->node_pt[n] >= 0) {
        *out = c->node_pt[n];
        return PF_OK;
    }
    /* the node's copies on each side, from the faces using them */
    const sc_group *g = c->g;
    int32_t node[2] = {-1, -1};
    for (int32_t k = 0; k < g->n_faces; ++k) {
        int32_t f = g->face[k];
        for (int64_t j = c->m->face_offsets[f]; j < c->m->face_offsets[f + 1]; ++j) {
            int32_t a = (int32_t)c->m->face_nodes[j];
            if (g->canon[a] == n && node[g->side[k] > 0] < 0)
                node[g->side[k] > 0] = a;
        }
    }
    PF_TRY(pf_sc_new_point(c, pf_v3_load(c->m->x + 3 * (size_t)n), pf_v3(0, 0, 0), -1, out, err));
    c->pt[*out].node[0] = node[0];
    c->pt[*out].node[1] = node[1];
    c->node_pt[n] = *out;
    return PF_OK;
}

pf_status pf_sc_cap_point(sc_state *c, int32_t n, int32_t *out, pf_error *err)
{
    if (c->cap_pt[n] < 0) {
        PF_TRY(pf_sc_new_point(c, pf_v3_load(c->m->x + 3 * (size_t)n), pf_v3(0, 0, 0), -1,
                               &c->cap_pt[n], err));
        sc_point *p = &c->pt[c->cap_pt[n]];
        p->node[0] = n;
        p->id[0] = p->id[1] = c->cap_vert[n]; /* a corner of faces of an earlier plane */
    }
    *out = c->cap_pt[n];
    return PF_OK;
}

pf_status pf_sc_push_slit(sc_state *c, int32_t u, int32_t v, pf_error *err)
{
    if (c->n_slit == c->cap_slit) {
        int64_t cap = c->cap_slit ? 2 * c->cap_slit : 256;
        uint64_t *n = pf_realloc_array(c->slit, (size_t)cap, sizeof *n);
        PF_CHECK(n, err, PF_ERR_NOMEM, "out of memory for %lld slits", (long long)cap);
        c->slit = n;
        c->cap_slit = cap;
    }
    uint64_t a = (uint64_t)(u < v ? u : v), b = (uint64_t)(u < v ? v : u);
    c->slit[c->n_slit++] = a << 32 | b;
    return PF_OK;
}

/* ---- vertices at one point --------------------------------------------------------------------
 */

typedef struct x_key {
    double x;
    int32_t v;
} x_key;

static int compare_x_keys(const void *a, const void *b)
{
    const x_key *p = a, *q = b;
    if (p->x != q->x)
        return p->x < q->x ? -1 : 1;
    return (p->v > q->v) - (p->v < q->v);
}

/* to[v] for the vertices v of [n0, n): the lowest of [n0, n) within tol of it (through chains
 * of such), v itself for the others. */
static pf_status weld_map(const double *x, int32_t n0, int32_t n, double tol, int32_t *to,
                          pf_error *err)
{
    for (int32_t i = 0; i < n; ++i)
        to[i] = i;
    if (n - n0 < 2)
        return PF_OK;
    x_key *keys = NULL;
    PF_CHECK(PF_ALLOC_N(keys, (size_t)(n - n0)), err, PF_ERR_NOMEM,
             "out of memory welding %d vertices", (int)(n - n0));
    int32_t nk = n - n0;
    for (int32_t i = 0; i < nk; ++i)
        keys[i] = (x_key){x[3 * (size_t)(n0 + i)], n0 + i};
    qsort(keys, (size_t)nk, sizeof *keys, compare_x_keys);
    for (int32_t i = 0; i < nk; ++i) {
        int32_t v = keys[i].v;
        pf_vec3 xv = pf_v3_load(x + 3 * (size_t)v);
        for (int32_t j = i - 1; j >= 0 && keys[i].x - keys[j].x <= tol; --j) {
            int32_t w = keys[j].v;
            if (to[w] == w && pf_v3_dist(xv, pf_v3_load(x + 3 * (size_t)w)) <= tol &&
                (to[v] == v || w < to[v]))
                to[v] = w;
        }
    }
    for (int32_t i = 0; i < nk; ++i) { /* the lowest of a chain */
        int32_t v = keys[i].v;
        while (to[to[v]] != to[v])
            to[v] = to[to[v]];
    }
    pf_free(keys);
    return PF_OK;
}

/* ---- closedness -------------------------------------------------------------------------------
 */

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Whether the surface is closed once its vertices within tol of one another are taken as one:
 * every edge traversed as often one way as the other. An earlier cut leaves a surface closed in
 * this sense where its vertex copies do not join up exactly; its caps still bound the solid, so
 * the inside of the caps to come is decided by the section's parity as for a closed surface. */
static pf_status closed_by_position(const pf_surface *s, double tol, bool *closed, pf_error *err)
{
    int64_t ne = 3 * (int64_t)s->n_tris;
    int32_t *to = NULL;
    uint64_t *keys = NULL;
    *closed = false;
    if (!PF_ALLOC_N(to, (size_t)s->n_verts + 1) || !PF_ALLOC_N(keys, (size_t)ne + 1)) {
        pf_free(to);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory welding %d surface vertices", (int)s->n_verts);
    }
    pf_status st = weld_map(s->x, 0, s->n_verts, tol, to, err);
    int64_t n = 0;
    for (int64_t i = 0; i < ne && st >= 0; ++i) {
        uint64_t p = (uint64_t)to[s->tri[i]], q = (uint64_t)to[s->tri[i - i % 3 + (i + 1) % 3]];
        if (p != q)
            keys[n++] = ((p < q ? p << 32 | q : q << 32 | p) << 1) | (p > q);
    }
    qsort(keys, (size_t)n, sizeof *keys, compare_u64);
    bool ok = st >= 0 && n > 0;
    for (int64_t i = 0; i < n && ok;) {
        int64_t j = i, fwd = 0;
        while (j < n && keys[j] >> 1 == keys[i] >> 1)
            fwd += (keys[j++] & 1) == 0;
        ok = 2 * fwd == j - i;
        i = j;
    }
    *closed = ok;
    pf_free(to);
    pf_free(keys);
    return st;
}

/* ---- one vertex where two were made -----------------------------------------------------------
 * Before the duplication, a cut of a closed surface has no border: its slits still join both
 * sides. A border edge u-v that some other border edge v'-u' retraces the other way, between
 * vertices at the same places (within tol), is a point made twice (a corner of a cap made once
 * per copy of its node, where one vertex was needed): u' is made u and v' is made v, and the
 * duplication then gives each side its copy by the slits. Never two cap corners of nodes of two
 * bodies: both bodies have a hole there (a cap missing on each side), which joining them would
 * hide while tying one body's surface to the other's. */

typedef struct border_edge {
    uint64_t key; /* lo << 32 | hi */
    uint32_t u, v; /* directed as its triangle has it */
} border_edge;

static int compare_border(const void *a, const void *b)
{
    uint64_t x = ((const border_edge *)a)->key, y = ((const border_edge *)b)->key;
    return (x > y) - (x < y);
}

static int32_t weld_root(int32_t *to, int32_t i)
{
    while (to[i] != i)
        i = to[i] = to[to[i]];
    return i;
}

/* The vertices welded into others (to: their union-find parents, roots the lowest) dropped and
 * the others renumbered in order, in the triangles and the slits. */
static pf_status renumber_welded(sc_state *c, int32_t *to, pf_error *err)
{
    sc_surface *s = c->s;
    int32_t *num = NULL;
    PF_CHECK(PF_ALLOC_N(num, (size_t)s->n_verts + 1), err, PF_ERR_NOMEM,
             "out of memory renumbering %d vertices", (int)s->n_verts);
    int32_t n = 0;
    for (int32_t i = 0; i < s->n_verts; ++i) {
        int32_t r = weld_root(to, i); /* the lowest of its set: numbered already */
        if (r == i) {
            memmove(s->x + 3 * (size_t)n, s->x + 3 * (size_t)i, 3 * sizeof *s->x);
            memmove(s->side + 3 * (size_t)n, s->side + 3 * (size_t)i, 3 * sizeof *s->side);
            num[i] = n++;
        } else {
            num[i] = num[r];
        }
    }
    s->n_verts = n;
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        s->tri[i] = (uint32_t)num[s->tri[i]];
    for (int64_t i = 0; i < c->n_slit; ++i) {
        uint64_t a = (uint64_t)num[c->slit[i] >> 32], b = (uint64_t)num[c->slit[i] & 0xffffffffu];
        c->slit[i] = (a < b ? a : b) << 32 | (a < b ? b : a);
    }
    pf_free(num);
    return PF_OK;
}

/* vnode[v]: the mesh node whose cap corner vertex v is (-1: none); body[n]: a node of the body
 * of node n (nodes joined through the faces of the cut mesh). */
static void node_bodies(const sc_state *c, int32_t *vnode, int32_t *body)
{
    const pf_mesh *m = c->m;
    for (int32_t v = 0; v < c->s->n_verts; ++v)
        vnode[v] = -1;
    for (int32_t n = 0; n < m->n_nodes; ++n) {
        body[n] = n;
        if (c->cap_vert[n] >= 0)
            vnode[c->cap_vert[n]] = n;
    }
    for (int32_t f = 0; f < m->n_faces; ++f)
        for (int64_t k = m->face_offsets[f] + 1; k < m->face_offsets[f + 1]; ++k) {
            int32_t a = weld_root(body, (int32_t)m->face_nodes[k - 1]),
                    b = weld_root(body, (int32_t)m->face_nodes[k]);
            body[a > b ? a : b] = a < b ? a : b;
        }
    for (int32_t n = 0; n < m->n_nodes; ++n)
        body[n] = weld_root(body, n);
}

static pf_status weld_borders(sc_state *c, double tol, pf_error *err)
{
    sc_surface *s = c->s;
    int64_t ne = 3 * (int64_t)s->n_tris;
    border_edge *e = NULL;
    int32_t *to = NULL;
    if (!PF_ALLOC_N(e, (size_t)ne + 1) || !PF_ALLOC_N(to, (size_t)s->n_verts + 1)) {
        pf_free(e);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the edges of %d triangles", (int)s->n_tris);
    }
    for (int64_t i = 0; i < ne; ++i) {
        uint32_t u = s->tri[i], v = s->tri[i - i % 3 + (i + 1) % 3];
        e[i] = (border_edge){(uint64_t)(u < v ? u : v) << 32 | (u < v ? v : u), u, v};
    }
    qsort(e, (size_t)ne, sizeof *e, compare_border);
    int64_t nb = 0;
    for (int64_t i = 0; i < ne;) {
        int64_t j = i;
        while (j < ne && e[j].key == e[i].key)
            j++;
        if (j - i == 1)
            e[nb++] = e[i];
        i = j;
    }
    for (int32_t i = 0; i < s->n_verts; ++i)
        to[i] = i;
    int32_t *vnode = NULL, *body = NULL;
    if (nb > 1 && (!PF_ALLOC_N(vnode, (size_t)s->n_verts) ||
                   !PF_ALLOC_N(body, (size_t)c->m->n_nodes + 1))) {
        pf_free(e), pf_free(to), pf_free(vnode);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the bodies of %d nodes", (int)c->m->n_nodes);
    }
    if (nb > 1)
        node_bodies(c, vnode, body);
    bool any = false;
    for (int64_t i = 0; i < nb; ++i)
        for (int64_t j = i + 1; j < nb; ++j) {
            pf_vec3 ui = pf_v3_load(s->x + 3 * (size_t)e[i].u),
                    vi = pf_v3_load(s->x + 3 * (size_t)e[i].v);
            if (pf_v3_dist(ui, pf_v3_load(s->x + 3 * (size_t)e[j].v)) > tol ||
                pf_v3_dist(vi, pf_v3_load(s->x + 3 * (size_t)e[j].u)) > tol)
                continue;
            int32_t pairs[2][2] = {{(int32_t)e[i].u, (int32_t)e[j].v},
                                   {(int32_t)e[i].v, (int32_t)e[j].u}};
            bool one_body = true; /* corners of caps of two bodies: a hole on both sides */
            for (int q = 0; q < 2; ++q) {
                int32_t na = vnode[pairs[q][0]], nb_ = vnode[pairs[q][1]];
                one_body = one_body && (na < 0 || nb_ < 0 || body[na] == body[nb_]);
            }
            for (int q = 0; q < 2 && one_body; ++q) {
                int32_t a = weld_root(to, pairs[q][0]), b = weld_root(to, pairs[q][1]);
                if (a != b)
                    to[a > b ? a : b] = a < b ? a : b, any = true;
            }
        }
    pf_status st = any ? renumber_welded(c, to, err) : PF_OK;
    pf_free(e);
    pf_free(to);
    pf_free(vnode);
    pf_free(body);
    return st;
}

/* ---- entry point --------------------------------------------------------------------------------
 */

static pf_status check_inputs(const pf_surface *s, const pf_mesh *m, const pf_cut_result *cut,
                              pf_error *err)
{
    PF_CHECK(s && m && cut, err, PF_ERR_INVALID,
             "pf_surface_cut needs a surface, a mesh and a cut");
    PF_CHECK(cut->opened && cut->cut_face, err, PF_ERR_INVALID,
             "the cut result has no opened or cut faces (was pf_mesh_cut's result released?)");
    PF_CHECK(m->n_nodes > 0 && m->n_elems > 0, err, PF_ERR_INVALID,
             "the cut mesh has no elements (%d nodes, %d elements)", (int)m->n_nodes,
             (int)m->n_elems);
    for (int64_t k = 0; k < 3 * (int64_t)s->n_verts; ++k)
        PF_CHECK(isfinite(s->x[k]), err, PF_ERR_INVALID, "surface vertex %lld is not finite",
                 (long long)(k / 3));
    for (int64_t k = 0; k < 3 * (int64_t)s->n_tris; ++k)
        PF_CHECK(s->tri[k] < (uint32_t)s->n_verts, err, PF_ERR_INVALID,
                 "surface triangle %lld has vertex %u, past the %d vertices", (long long)(k / 3),
                 (unsigned)s->tri[k], (int)s->n_verts);
    for (int32_t t = 0; s->tri_part && t < s->n_tris; ++t)
        PF_CHECK(s->tri_part[t] == PF_SURFACE_MODEL || s->tri_part[t] == PF_SURFACE_CAP, err,
                 PF_ERR_INVALID, "surface triangle %d has part %d", (int)t, (int)s->tri_part[t]);
    return PF_OK;
}

static pf_status copy_input(const pf_surface *s, sc_surface *w, pf_error *err)
{
    memset(w, 0, sizeof *w);
    for (int32_t v = 0; v < s->n_verts; ++v) {
        int32_t id;
        PF_TRY(pf_sc_add_vertex(w, pf_v3_load(s->x + 3 * (size_t)v), pf_v3(0, 0, 0), &id, err));
    }
    for (int32_t t = 0; t < s->n_tris; ++t)
        PF_TRY(pf_sc_add_tri(
            w, s->tri[3 * (size_t)t], s->tri[3 * (size_t)t + 1], s->tri[3 * (size_t)t + 2],
            s->tri_part ? s->tri_part[t] : (uint8_t)PF_SURFACE_MODEL, t, pf_v3(0, 0, 0), err));
    return PF_OK;
}

static pf_status cut_by_groups(sc_state *c, const face_info *fi, const int32_t *leader,
                               int32_t n_groups, uint8_t *split_src, pf_error *err)
{
    pf_status st = PF_OK;
    for (int32_t gi = 0; gi < n_groups && st >= 0; ++gi) {
        sc_group g;
        st = build_group(c->m, fi, gi, leader[gi], &g, err);
        c->g = &g;
        c->n_points = c->n_sec = 0;
        c->n_seg = 0;
        for (int32_t i = 0; i < c->m->n_nodes && st >= 0; ++i)
            c->node_pt[i] = c->cap_pt[i] = -1;
        if (st >= 0)
            st = pf_sc_split(c, split_src, err);
        if (st >= 0)
            st = pf_sc_caps(c, err);
        group_release(&g);
        c->g = NULL;
    }
    return st;
}

/* Vertices on the caps of earlier cuts (input triangles marked PF_SURFACE_CAP) have no side
 * of their own: each takes the inward normal of the caps it is a corner of, unless caps facing
 * both ways use it (an earlier crack front, shared by both sides). */
static pf_status sides_of_earlier_caps(const pf_surface *in, sc_surface *w, pf_error *err)
{
    if (!in->tri_part)
        return PF_OK;
    uint8_t *mixed = NULL;
    double *sum = NULL;
    if (!PF_ALLOC_N(mixed, (size_t)w->n_verts) || !PF_ALLOC_N(sum, 3 * (size_t)w->n_verts)) {
        pf_free(mixed);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the sides of %d vertices", (int)w->n_verts);
    }
    memset(mixed, 0, (size_t)w->n_verts);
    memset(sum, 0, 3 * (size_t)w->n_verts * sizeof *sum);
    for (int32_t t = 0; t < w->n_tris; ++t) {
        if (w->src[t] < 0 || in->tri_part[w->src[t]] != PF_SURFACE_CAP)
            continue;
        const uint32_t *v = w->tri + 3 * (size_t)t;
        pf_vec3 a = pf_v3_load(w->x + 3 * (size_t)v[0]);
        pf_vec3 n = pf_v3_cross(pf_v3_sub(pf_v3_load(w->x + 3 * (size_t)v[1]), a),
                                pf_v3_sub(pf_v3_load(w->x + 3 * (size_t)v[2]), a));
        double len = pf_v3_norm(n);
        if (!(len > 0))
            continue;
        pf_vec3 inward = pf_v3_scale(n, -1.0 / len);
        for (int q = 0; q < 3; ++q) {
            double *sv = sum + 3 * (size_t)v[q];
            if (pf_v3_dot(pf_v3_load(sv), inward) < 0)
                mixed[v[q]] = 1;
            pf_v3_store(pf_v3_add(pf_v3_load(sv), inward), sv);
        }
    }
    for (int32_t i = 0; i < w->n_verts; ++i) {
        double *side = w->side + 3 * (size_t)i;
        if (!mixed[i] && side[0] == 0 && side[1] == 0 && side[2] == 0)
            memcpy(side, sum + 3 * (size_t)i, 3 * sizeof *side);
    }
    pf_free(mixed);
    pf_free(sum);
    return PF_OK;
}

static pf_status write_out(const pf_surface *s, const sc_surface *w, pf_surface *out, pf_error *err)
{
    PF_TRY(pf_surface_alloc(out, w->n_verts, w->n_tris, err));
    out->id = s->id + 1;
    memcpy(out->x, w->x, 3 * (size_t)w->n_verts * sizeof *out->x);
    memcpy(out->tri, w->tri, 3 * (size_t)w->n_tris * sizeof *out->tri);
    if (!PF_ALLOC_N(out->tri_part, (size_t)w->n_tris)) {
        pf_surface_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for %d triangle parts", (int)w->n_tris);
    }
    if (w->n_tris)
        memcpy(out->tri_part, w->part, (size_t)w->n_tris);
    return PF_OK;
}

pf_status pf_surface_cut(const pf_surface *s, const pf_mesh *m, const pf_cut_result *cut,
                         const pf_embed_params *embed, pf_surface *out, pf_weights *w,
                         pf_surface_cut_stats *stats, pf_error *err)
{
    memset(out, 0, sizeof *out);
    memset(w, 0, sizeof *w);
    pf_surface_cut_stats local;
    pf_surface_cut_stats *so = stats ? stats : &local;
    memset(so, 0, sizeof *so);
    PF_TRY(check_inputs(s, m, cut, err));
    pf_surface_stats ss;
    PF_TRY(pf_surface_compute_stats(s, &ss, err));
    face_info *fi = NULL;
    int32_t *leader = NULL, n_groups = 0;
    uint8_t *split_src = NULL;
    sc_surface work;
    memset(&work, 0, sizeof work);
    sc_state c;
    memset(&c, 0, sizeof c);
    c.m = m;
    c.s = &work;
    c.closed = ss.closed;
    if (!c.closed)
        PF_TRY(closed_by_position(s, SC_PLANE_TOL * pf_v3_dist(ss.lo, ss.hi), &c.closed, err));
    c.in = s;
    c.stats = so;
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(fi, (size_t)m->n_faces) || !PF_ALLOC_N(leader, (size_t)m->n_faces) ||
        !PF_ALLOC_N(split_src, (size_t)s->n_tris) || !PF_ALLOC_N(c.node_pt, (size_t)m->n_nodes) ||
        !PF_ALLOC_N(c.cap_pt, (size_t)m->n_nodes) || !PF_ALLOC_N(c.cap_vert, (size_t)m->n_nodes) ||
        !PF_ALLOC_N(c.in_cls, (size_t)s->n_verts))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "out of memory for a surface cut (%d faces, %d triangles)",
                          (int)m->n_faces, (int)s->n_tris);
    if (st >= 0) {
        for (int32_t i = 0; i < m->n_nodes; ++i)
            c.cap_vert[i] = -1;
        if (s->n_tris)
            memset(split_src, 0, (size_t)s->n_tris);
        st = assign_groups(m, cut, fi, &n_groups, leader, err);
    }
    if (st >= 0)
        st = copy_input(s, &work, err);
    if (st >= 0)
        st = cut_by_groups(&c, fi, leader, n_groups, split_src, err);
    if (st >= 0 && c.closed)
        st = weld_borders(&c, SC_PLANE_TOL * pf_v3_dist(ss.lo, ss.hi), err);
    if (st >= 0)
        st = pf_sc_duplicate(&c, err);
    if (st >= 0 && c.closed)
        st = pf_sc_close_t_junctions(&c, SC_PLANE_TOL * pf_v3_dist(ss.lo, ss.hi), err);
    if (st >= 0)
        st = sides_of_earlier_caps(s, &work, err);
    if (st >= 0)
        st = write_out(s, &work, out, err);
    if (st >= 0) {
        pf_embed_params p = embed ? *embed : pf_embed_params_default();
        p.blocking_faces = cut->cut_face;
        p.vertex_side = work.side;
        st = pf_embed_compute(m, out, &p, w, NULL, err);
        if (st < 0)
            pf_surface_release(out);
    }
    pf_free(fi);
    pf_free(leader);
    pf_free(split_src);
    pf_free(c.node_pt);
    pf_free(c.cap_pt);
    pf_free(c.cap_vert);
    pf_free(c.in_cls);
    pf_free(c.iseg);
    pf_free(c.slit);
    pf_free(c.pt);
    pf_free(c.sec);
    pf_free(c.seg);
    sc_surface_release(&work);
    return st;
}
