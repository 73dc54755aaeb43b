/* Caps of a surface cut (pf_surface_cut): each opened face clipped to the inside of the surface.
 * The clipped region's boundary is made of the section pieces the face holds (directed with the
 * surface's inside on their left about the cap's outward normal) and the pieces of the face's
 * own edges that lie inside the surface (crossing parity of the section in the plane), split
 * where the section meets them; pf_split_cap_polygons turns those edges into polygons. Corners
 * and points on the face's edges are the group's points, so that neighbouring faces' caps, the
 * two sides' caps at the crack front and the slits of the split triangles share vertices. */
#include "surface_cut_internal.h"

#include <pf/split.h>

#include <stdlib.h>
#include <string.h>

typedef struct cap_buf {
    int64_t n, cap;
    uint32_t *e; /* [2 cap] directed edges, surface vertices */
    int32_t n_ends, cap_ends;
    int32_t *ends; /* points ending the face's section pieces */
    int32_t n_chain, cap_chain;
    int32_t *chain;
    double *chain_t;
    pf_vec3 centroid; /* of the face being capped */
    int32_t n_vpt;
    struct vpt_key {
        double x;
        int32_t p;
    } *vpt; /* [n_vpt] the group's points with a surface vertex (the input's, or made where the
               group's split crosses an edge), by first coordinate */
    int64_t n_in_edges;
    uint64_t *in_edges; /* [n_in_edges] edges (lo << 32 | hi) of triangles of the input
                           surface or pieces of them, with an end at an input vertex, sorted */
} cap_buf;

static void cap_buf_release(cap_buf *b)
{
    pf_free(b->e);
    pf_free(b->ends);
    pf_free(b->chain);
    pf_free(b->chain_t);
    pf_free(b->vpt);
    pf_free(b->in_edges);
    memset(b, 0, sizeof *b);
}

static pf_status push_edge(cap_buf *b, int32_t u, int32_t v, pf_error *err)
{
    if (b->n == b->cap) {
        int64_t cap = b->cap ? 2 * b->cap : 64;
        uint32_t *e = pf_realloc_array(b->e, 2 * (size_t)cap, sizeof *e);
        PF_CHECK(e, err, PF_ERR_NOMEM, "out of memory for %lld cap edges", (long long)cap);
        b->e = e;
        b->cap = cap;
    }
    b->e[2 * b->n] = (uint32_t)u;
    b->e[2 * b->n + 1] = (uint32_t)v;
    b->n++;
    return PF_OK;
}

static pf_status push_int(int32_t **a, int32_t *n, int32_t *cap, int32_t v, pf_error *err)
{
    if (*n == *cap) {
        int32_t c = *cap ? 2 * *cap : 32;
        int32_t *p = pf_realloc_array(*a, (size_t)c, sizeof *p);
        PF_CHECK(p, err, PF_ERR_NOMEM, "out of memory for %d cap points", (int)c);
        *a = p;
        *cap = c;
    }
    (*a)[(*n)++] = v;
    return PF_OK;
}

static bool has_edge(const cap_buf *b, int64_t n, uint32_t u, uint32_t v)
{
    for (int64_t i = 0; i < n; ++i)
        if ((b->e[2 * i] == u && b->e[2 * i + 1] == v) ||
            (b->e[2 * i] == v && b->e[2 * i + 1] == u))
            return true;
    return false;
}

static double seg_dist(double u, double v, const double *s)
{
    double ex = s[2] - s[0], ey = s[3] - s[1], wx = u - s[0], wy = v - s[1];
    double ee = ex * ex + ey * ey, t = ee > 0 ? (wx * ex + wy * ey) / ee : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypot(wx - t * ex, wy - t * ey);
}

/* 1 inside the surface, 0 outside, -1 on its section (within tol): on the section of the
 * surface being built (not of the caps earlier groups made: a face's edge along one is a crease
 * of the cut, inside the surface), else the crossing parity of a ray along the first projected axis with
 * the input surface's section (closed curves: the surface being built is open where the caps of
 * the groups still to come are missing). */
static int inside_section(const sc_state *c, double u, double v)
{
    for (int64_t i = 0; i < c->n_seg; ++i)
        if (seg_dist(u, v, c->seg + 4 * i) <= c->g->tol)
            return -1;
    int inside = 0;
    for (int64_t i = 0; i < c->n_iseg; ++i) {
        const double *s = c->iseg + 4 * i;
        if ((s[1] > v) != (s[3] > v) && u < s[0] + (v - s[1]) * (s[2] - s[0]) / (s[3] - s[1]))
            inside ^= 1;
    }
    return inside;
}

/* ---- the input surface's section ---------------------------------------------------------------
 * Each vertex classified once against the group's plane; the vertices on it counted as above it
 * (the plane lowered by an infinitesimal), so that the section is closed curves whatever lies in
 * the plane (the caps of earlier cuts on it): a triangle with corners below and not below gives
 * the segment between its two edges that cross, at the edge's corner on the plane or its
 * crossing (computed from its lower end in position order, so that both triangles of the edge get
 * the same bits). */

static pf_status push_iseg(sc_state *c, pf_vec3 p, pf_vec3 q, pf_error *err)
{
    if (c->n_iseg == c->cap_iseg) {
        int64_t cap = c->cap_iseg ? 2 * c->cap_iseg : 256;
        double *n = pf_realloc_array(c->iseg, 4 * (size_t)cap, sizeof *n);
        PF_CHECK(n, err, PF_ERR_NOMEM, "out of memory for a section of %lld segments",
                 (long long)cap);
        c->iseg = n;
        c->cap_iseg = cap;
    }
    double *s = c->iseg + 4 * c->n_iseg++;
    s[0] = pf_v3_get(p, c->g->ax[0]), s[1] = pf_v3_get(p, c->g->ax[1]);
    s[2] = pf_v3_get(q, c->g->ax[0]), s[3] = pf_v3_get(q, c->g->ax[1]);
    return PF_OK;
}

static bool below(const double *a, const double *b)
{
    for (int k = 0; k < 3; ++k)
        if (a[k] != b[k])
            return a[k] < b[k];
    return false;
}

/* Where the edge a-b of the input (on opposite sides) meets the plane. */
static pf_vec3 in_edge_point(const sc_state *c, uint32_t a, uint32_t b)
{
    const double *xa = c->in->x + 3 * (size_t)a, *xb = c->in->x + 3 * (size_t)b;
    if (below(xb, xa)) {
        const double *t = xa;
        xa = xb, xb = t;
    }
    pf_vec3 pa = pf_v3_load(xa), pb = pf_v3_load(xb);
    double da = pf_plane_signed_distance(c->g->plane, pa),
           db = pf_plane_signed_distance(c->g->plane, pb);
    return pf_v3_add(pa, pf_v3_scale(pf_v3_sub(pb, pa), da / (da - db)));
}

static pf_status input_section(sc_state *c, pf_error *err)
{
    const pf_surface *in = c->in;
    c->n_iseg = 0;
    for (int32_t i = 0; i < in->n_verts; ++i) {
        double d = pf_plane_signed_distance(c->g->plane, pf_v3_load(in->x + 3 * (size_t)i));
        c->in_cls[i] = (int8_t)(d > c->g->tol ? 1 : d < -c->g->tol ? -1 : 0);
    }
    for (int32_t t = 0; t < in->n_tris; ++t) {
        const uint32_t *v = in->tri + 3 * (size_t)t;
        int below = (c->in_cls[v[0]] < 0) + (c->in_cls[v[1]] < 0) + (c->in_cls[v[2]] < 0);
        if (below == 0 || below == 3)
            continue;
        pf_vec3 p[2];
        int np = 0;
        for (int q = 0; q < 3; ++q) {
            uint32_t a = v[q], b = v[(q + 1) % 3];
            if ((c->in_cls[a] < 0) == (c->in_cls[b] < 0))
                continue;
            uint32_t up = c->in_cls[a] < 0 ? b : a;
            p[np++] = c->in_cls[up] == 0 ? pf_v3_load(in->x + 3 * (size_t)up) : in_edge_point(c, a, b);
        }
        PF_TRY(push_iseg(c, p[0], p[1], err));
    }
    return PF_OK;
}

/* Twice the area of (a, b, d) about normal (positive counter-clockwise). */
static double turn(const double *x, uint32_t a, uint32_t b, uint32_t d, pf_vec3 normal)
{
    pf_vec3 xa = pf_v3_load(x + 3 * (size_t)a);
    return pf_v3_dot(pf_v3_cross(pf_v3_sub(pf_v3_load(x + 3 * (size_t)b), xa),
                                 pf_v3_sub(pf_v3_load(x + 3 * (size_t)d), xa)),
                     normal);
}

/* Ear clipping that takes only ears of positive area holding no other corner (on their edges
 * included): a cap polygon has runs of collinear corners (the points where the section meets
 * the face's edges), which a fan would join into triangles without area. tri[3 (n - 2)] gets
 * positions in poly; false when no such ear is left (then the caller falls back). */
static bool ear_clip(const double *x, const uint32_t *poly, int32_t n, pf_vec3 normal, double eps,
                     int32_t *left, uint32_t *tri)
{
    for (int32_t i = 0; i < n; ++i)
        left[i] = i;
    int32_t m = n, nt = 0;
    while (m > 3) {
        bool found = false;
        for (int32_t i = 0; i < m && !found; ++i) {
            int32_t ia = left[(i + m - 1) % m], ib = left[i], ic = left[(i + 1) % m];
            uint32_t a = poly[ia], b = poly[ib], d = poly[ic];
            if (turn(x, a, b, d, normal) <= eps)
                continue;
            bool empty = true;
            for (int32_t j = 0; j < m && empty; ++j) {
                uint32_t p = poly[left[j]];
                if (left[j] == ia || left[j] == ib || left[j] == ic || p == a || p == b || p == d)
                    continue;
                empty = !(turn(x, a, b, p, normal) >= -eps && turn(x, b, d, p, normal) >= -eps &&
                          turn(x, d, a, p, normal) >= -eps);
            }
            if (!empty)
                continue;
            tri[3 * nt] = (uint32_t)ia, tri[3 * nt + 1] = (uint32_t)ib,
                    tri[3 * nt + 2] = (uint32_t)ic;
            nt++;
            for (int32_t j = i; j + 1 < m; ++j)
                left[j] = left[j + 1];
            m--;
            found = true;
        }
        if (!found)
            return false;
    }
    tri[3 * nt] = (uint32_t)left[0], tri[3 * nt + 1] = (uint32_t)left[1];
    tri[3 * nt + 2] = (uint32_t)left[2];
    return true;
}

static pf_status triangulate_cap(sc_state *c, const uint32_t *poly, int32_t n, pf_arena *arena,
                                 int32_t face, pf_vec3 normal, pf_error *err)
{
    uint32_t *tri = pf_alloc_array(3 * (size_t)n, sizeof *tri);
    int32_t *left = pf_alloc_array((size_t)n, sizeof *left);
    if (!tri || !left) {
        pf_free(tri);
        pf_free(left);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for a cap of %d corners", (int)n);
    }
    double size = 0;
    for (int32_t k = 1; k < n; ++k)
        size = fmax(size, pf_v3_dist(pf_v3_load(c->s->x + 3 * (size_t)poly[0]),
                                     pf_v3_load(c->s->x + 3 * (size_t)poly[k])));
    pf_status st = PF_OK;
    if (!ear_clip(c->s->x, poly, n, normal, 1e-12 * size * size, left, tri))
        st = pf_polygon_triangulate(c->s->x, poly, n, arena, tri, NULL, err);
    pf_free(left);
    for (int32_t t = 0; t < n - 2 && st >= 0; ++t) {
        uint32_t a = poly[tri[3 * t]], b = poly[tri[3 * t + 1]], d = poly[tri[3 * t + 2]];
        st = pf_sc_add_tri(c->s, a, b, d, PF_SURFACE_CAP, -1, normal, err);
        if (st >= 0) {
            pf_vec3 xa = pf_v3_load(c->s->x + 3 * (size_t)a);
            pf_vec3 ab = pf_v3_sub(pf_v3_load(c->s->x + 3 * (size_t)b), xa);
            pf_vec3 ad = pf_v3_sub(pf_v3_load(c->s->x + 3 * (size_t)d), xa);
            c->stats->cap_area += 0.5 * pf_v3_norm(pf_v3_cross(ab, ad));
            c->stats->n_cap_tris++;
        }
    }
    pf_free(tri);
    if (st < 0)
        pf_error_prefix(err, "cap of opened face %d", (int)face);
    return st;
}

/* The vertex of point p in a cap on side sigma; a face corner's vertex collects the inward
 * normals of the faces using it as its side (they cancel at the crack front, where both sides'
 * faces share it). */
static pf_status cap_id(sc_state *c, int32_t p, int sigma, int32_t *id, pf_error *err)
{
    PF_TRY(pf_sc_point_id(c, p, sigma, id, err));
    int32_t n = c->pt[p].node[0];
    if (n >= 0 && c->cap_pt[n] == p) {
        c->cap_vert[n] = *id;
        double *side = c->s->side + 3 * (size_t)*id;
        pf_v3_store(pf_v3_add(pf_v3_load(side), pf_v3_scale(c->g->plane.n, sigma)), side);
    }
    return PF_OK;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static int compare_vpt(const void *a, const void *b)
{
    const struct vpt_key *x = a, *y = b;
    if (x->x != y->x)
        return x->x < y->x ? -1 : 1;
    return (x->p > y->p) - (x->p < y->p);
}

/* The lookups of the group's caps: its points with a surface vertex by position, and the edges
 * of the input's triangles (and their pieces) with an end at an input vertex. */
static pf_status cap_lookups(const sc_state *c, cap_buf *b, pf_error *err)
{
    const sc_surface *s = c->s;
    int32_t n_in = c->in->n_verts;
    b->n_vpt = 0;
    b->n_in_edges = 0;
    pf_free(b->vpt);
    pf_free(b->in_edges);
    b->vpt = NULL;
    b->in_edges = NULL;
    PF_CHECK(PF_ALLOC_N(b->vpt, (size_t)c->n_points) &&
                 PF_ALLOC_N(b->in_edges, 3 * (size_t)s->n_tris),
             err, PF_ERR_NOMEM, "out of memory for the lookups of %d points", (int)c->n_points);
    for (int32_t i = 0; i < c->n_points; ++i)
        if (c->pt[i].orig >= 0 || c->pt[i].id[0] >= 0)
            b->vpt[b->n_vpt++] = (struct vpt_key){c->pt[i].x.x, i};
    if (b->n_vpt > 1)
        qsort(b->vpt, (size_t)b->n_vpt, sizeof *b->vpt, compare_vpt);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *tv = s->tri + 3 * (size_t)t;
        for (int q = 0; q < 3 && s->src[t] >= 0; ++q) {
            uint32_t u = tv[q], v = tv[(q + 1) % 3];
            if ((int32_t)u < n_in || (int32_t)v < n_in)
                b->in_edges[b->n_in_edges++] = (uint64_t)(u < v ? u : v) << 32 | (u < v ? v : u);
        }
    }
    if (b->n_in_edges > 1)
        qsort(b->in_edges, (size_t)b->n_in_edges, sizeof *b->in_edges, compare_u64);
    return PF_OK;
}

/* Whether the edge u-v (one end at an input vertex) is one of a triangle of the input surface
 * or of a piece of one. */
static bool surface_edge(const cap_buf *b, int32_t u, int32_t v)
{
    uint64_t key = (uint64_t)(u < v ? u : v) << 32 | (uint64_t)(u < v ? v : u);
    return b->n_in_edges > 0 &&
           bsearch(&key, b->in_edges, (size_t)b->n_in_edges, sizeof key, compare_u64) != NULL;
}

/* The corner of triangle tv that is vertex v (0, 1, 2), or -1. */
static int corner_of(const uint32_t *tv, int32_t v)
{
    return tv[0] == (uint32_t)v ? 0 : tv[1] == (uint32_t)v ? 1 : tv[2] == (uint32_t)v ? 2 : -1;
}

/* Of the triangles of the input surface (pieces included) at vertex v, the corner opening widest
 * (largest sine): its bisector nudged 1e-3 radians inward, a direction into the material (*dir),
 * and the shortest edge at v (*h); false when v has none. */
static bool widest_corner(const sc_surface *s, int32_t v, pf_vec3 *dir, double *h)
{
    pf_vec3 x = pf_v3_load(s->x + 3 * (size_t)v);
    double widest = 0;
    *h = INFINITY;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *tv = s->tri + 3 * (size_t)t;
        int q = corner_of(tv, v);
        if (s->src[t] < 0 || q < 0)
            continue;
        pf_vec3 a = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)tv[(q + 1) % 3]), x);
        pf_vec3 b = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)tv[(q + 2) % 3]), x);
        pf_vec3 n = pf_v3_cross(a, b);
        double la = pf_v3_norm(a), lb = pf_v3_norm(b), ln = pf_v3_norm(n);
        if (!(la > 0 && lb > 0 && ln > 0))
            continue;
        *h = fmin(*h, fmin(la, lb));
        if (ln / (la * lb) > widest) {
            widest = ln / (la * lb);
            pf_vec3 mid = pf_v3_add(pf_v3_scale(a, 1 / la), pf_v3_scale(b, 1 / lb));
            *dir = pf_v3_sub(pf_v3_normalize(mid), pf_v3_scale(n, 1e-3 / ln));
        }
    }
    return widest > 0;
}

/* Whether the material at vertex v lies towards the unit direction d: about 1 if so, 0 if not.
 * Its triangles of the input surface are a disk about v (the caps this cut made so far face both
 * of its sides, and are left out). Close to v the disk's winding number is the indicator of the
 * material less the solid angle of its rim seen from v over 4 pi, the same wherever taken: its
 * difference between x + h d and a point known inside (widest_corner), both at 1e-4 of v's
 * shortest edge from v, is the indicator less one. */
static double material_towards(const sc_surface *s, int32_t v, pf_vec3 d)
{
    pf_vec3 in = pf_v3(0, 0, 0), x = pf_v3_load(s->x + 3 * (size_t)v);
    double h;
    if (!widest_corner(s, v, &in, &h))
        return 0;
    pf_vec3 p = pf_v3_add(x, pf_v3_scale(d, 1e-4 * h)), r = pf_v3_add(x, pf_v3_scale(in, 1e-4 * h));
    double w = 1;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *tv = s->tri + 3 * (size_t)t;
        if (s->src[t] >= 0 && corner_of(tv, v) >= 0)
            w += pf_winding_number(s->x, tv, 1, p) - pf_winding_number(s->x, tv, 1, r);
    }
    return w;
}

/* A vertex of the surface at a face's corner x (on the plane: a corner of an earlier cut's
 * caps, or the point where this plane crosses an edge of them, the crack meeting an earlier one
 * at a corner of the face only) that the face's cap joins: of the copies there (one per side of
 * the earlier cut), the one whose material lies towards the face (the face lies on one side of
 * the earlier cut); -1 when there is none. */
static int32_t corner_vertex(const sc_state *c, const cap_buf *b, pf_vec3 x, pf_vec3 into)
{
    int32_t best = -1, lo = 0, hi = b->n_vpt;
    double best_score = 0.5;
    pf_vec3 d = pf_v3_normalize(into);
    while (lo < hi) { /* the first point at x.x - tol or beyond */
        int32_t mid = lo + (hi - lo) / 2;
        if (b->vpt[mid].x < x.x - c->g->tol)
            lo = mid + 1;
        else
            hi = mid;
    }
    for (int32_t i = lo; i < b->n_vpt && b->vpt[i].x <= x.x + c->g->tol; ++i) {
        const sc_point *p = &c->pt[b->vpt[i].p];
        if (pf_v3_dist(p->x, x) > c->g->tol)
            continue;
        int32_t v = p->orig >= 0 ? p->orig : p->id[0];
        double score = material_towards(c->s, v, d);
        if (score > best_score)
            best = v, best_score = score;
    }
    return best;
}

/* The point at a corner of the face: a section end within tol of it, else the node's point
 * (the surface's vertex there, if any, the first time). */
static pf_status corner_point(sc_state *c, const cap_buf *b, uint32_t node, int32_t *out,
                              pf_error *err)
{
    pf_vec3 x = pf_v3_load(c->m->x + 3 * (size_t)node);
    for (int32_t i = 0; i < b->n_ends; ++i)
        if (pf_v3_dist(c->pt[b->ends[i]].x, x) <= c->g->tol) {
            *out = b->ends[i];
            return PF_OK;
        }
    if (c->cap_pt[node] < 0 && c->cap_vert[node] < 0)
        c->cap_vert[node] = corner_vertex(c, b, x, pf_v3_sub(b->centroid, x));
    return pf_sc_cap_point(c, (int32_t)node, out, err);
}

/* Whether the piece a-b of an edge of a face on side sigma (its cap's boundary, counter-clockwise
 * about the outward normal) bounds the cap: not where its middle lies on the section of the
 * surface being built (the section pieces bound the cap there); else where the face beside it is
 * inside the surface, by the parity 1e3 tol off its middle into the face (the middle itself may
 * lie on the input's section, an earlier crack bending along the edge, undecided). */
static bool piece_inside(const sc_state *c, pf_vec3 a, pf_vec3 b, int sigma)
{
    const sc_group *g = c->g;
    pf_vec3 mid = pf_v3_scale(pf_v3_add(a, b), 0.5);
    if (inside_section(c, pf_v3_get(mid, g->ax[0]), pf_v3_get(mid, g->ax[1])) < 0)
        return false;
    pf_vec3 left = pf_v3_cross(pf_v3_scale(g->plane.n, -sigma), pf_v3_sub(b, a));
    double len = pf_v3_norm(left);
    if (len > 0)
        mid = pf_v3_add(mid, pf_v3_scale(left, 1e3 * g->tol / len));
    return inside_section(c, pf_v3_get(mid, g->ax[0]), pf_v3_get(mid, g->ax[1])) == 1;
}

/* The boundary pieces of face k on the edge from corner node a to node b, inside the surface
 * (whole > 0: all of them, the face lying wholly inside; whole < 0: each piece tested). */
static pf_status edge_pieces(sc_state *c, cap_buf *b, int64_t n_sec_edges, uint32_t na, uint32_t nb,
                             int sigma, int whole, pf_error *err)
{
    const sc_group *g = c->g;
    int32_t pa, pb;
    PF_TRY(corner_point(c, b, na, &pa, err));
    PF_TRY(corner_point(c, b, nb, &pb, err));
    pf_vec3 xa = c->pt[pa].x, xb = c->pt[pb].x, d = pf_v3_sub(xb, xa);
    double len = pf_v3_norm(d);
    b->n_chain = 0;
    int32_t cap_t = b->cap_chain;
    PF_TRY(push_int(&b->chain, &b->n_chain, &b->cap_chain, pa, err));
    if (b->cap_chain != cap_t) {
        double *t = pf_realloc_array(b->chain_t, (size_t)b->cap_chain, sizeof *t);
        PF_CHECK(t, err, PF_ERR_NOMEM, "out of memory for a cap chain");
        b->chain_t = t;
    }
    b->chain_t[0] = 0;
    for (int32_t i = 0; i < b->n_ends && len > g->tol; ++i) {
        int32_t p = b->ends[i];
        if (p == pa || p == pb)
            continue;
        pf_vec3 w = pf_v3_sub(c->pt[p].x, xa);
        double t = pf_v3_dot(w, d) / (len * len);
        if (t * len <= g->tol || (1 - t) * len <= g->tol ||
            pf_v3_norm(pf_v3_sub(w, pf_v3_scale(d, t))) > g->tol)
            continue;
        cap_t = b->cap_chain;
        PF_TRY(push_int(&b->chain, &b->n_chain, &b->cap_chain, p, err));
        if (b->cap_chain != cap_t) {
            double *nt = pf_realloc_array(b->chain_t, (size_t)b->cap_chain, sizeof *nt);
            PF_CHECK(nt, err, PF_ERR_NOMEM, "out of memory for a cap chain");
            b->chain_t = nt;
        }
        int32_t j = b->n_chain - 1;
        for (; j > 1 && b->chain_t[j - 1] > t; --j) {
            b->chain[j] = b->chain[j - 1];
            b->chain_t[j] = b->chain_t[j - 1];
        }
        b->chain[j] = p;
        b->chain_t[j] = t;
    }
    cap_t = b->cap_chain;
    PF_TRY(push_int(&b->chain, &b->n_chain, &b->cap_chain, pb, err));
    if (b->cap_chain != cap_t) {
        double *nt = pf_realloc_array(b->chain_t, (size_t)b->cap_chain, sizeof *nt);
        PF_CHECK(nt, err, PF_ERR_NOMEM, "out of memory for a cap chain");
        b->chain_t = nt;
    }
    b->chain_t[b->n_chain - 1] = 1;
    for (int32_t i = 0; i + 1 < b->n_chain; ++i) {
        int32_t p = b->chain[i], q = b->chain[i + 1], u, v;
        if (p == q || (whole < 0 && !piece_inside(c, c->pt[p].x, c->pt[q].x, sigma)))
            continue;
        PF_TRY(cap_id(c, p, sigma, &u, err));
        PF_TRY(cap_id(c, q, sigma, &v, err));
        if (u != v && !has_edge(b, n_sec_edges, (uint32_t)u, (uint32_t)v))
            PF_TRY(push_edge(b, u, v, err));
        if (u != v && (u < c->in->n_verts || v < c->in->n_verts) && surface_edge(b, u, v))
            PF_TRY(pf_sc_push_slit(c, u, v, err)); /* an earlier cut's edge the crack goes on from */
    }
    return PF_OK;
}

/* A face no section piece lies on is wholly inside the surface or wholly outside: 1 or 0 by the
 * first centroid of a fan triangle of its corners that lies in the face and off the section (its
 * edges may run along the section, where the test at their midpoints is undecided); -1 when
 * none is found (then each edge is tested). */
static int face_inside(const sc_state *c, int32_t k)
{
    const sc_group *g = c->g;
    int64_t o = g->uv_offsets[k], n = g->uv_offsets[k + 1] - o;
    const double *uv = g->uv + 2 * o;
    for (int64_t j = 1; j + 1 < n; ++j) {
        double u = (uv[0] + uv[2 * j] + uv[2 * j + 2]) / 3,
               v = (uv[1] + uv[2 * j + 1] + uv[2 * j + 3]) / 3;
        if (!pf_polygon2_contains(uv, n, u, v, 0))
            continue;
        int in = inside_section(c, u, v);
        if (in >= 0)
            return in;
    }
    return -1;
}

static pf_status face_cap(sc_state *c, int32_t k, cap_buf *b, pf_arena *arena, pf_error *err)
{
    const sc_group *g = c->g;
    const pf_mesh *m = c->m;
    int sigma = g->side[k];
    int32_t f = g->face[k];
    pf_vec3 normal = pf_v3_scale(g->plane.n, -sigma); /* outward from the face's element */
    int64_t o = m->face_offsets[f], n = m->face_offsets[f + 1] - o;
    bool reversed = pf_v3_dot(pf_polygon_area_vector(m->x, m->face_nodes + o, n), normal) < 0;
    b->n = 0;
    b->n_ends = 0;
    for (int32_t i = 0; i < c->n_sec; ++i) {
        const sc_section *s = &c->sec[i];
        if (s->face[sigma > 0] != k)
            continue;
        int32_t u, v;
        PF_TRY(pf_sc_point_id(c, s->p, sigma, &u, err));
        PF_TRY(pf_sc_point_id(c, s->q, sigma, &v, err));
        pf_vec3 d = pf_v3_sub(c->pt[s->q].x, c->pt[s->p].x);
        bool flip = pf_v3_dot(pf_v3_cross(normal, d), s->normal) > 0;
        PF_TRY(push_edge(b, flip ? v : u, flip ? u : v, err));
        for (int e = 0; e < 2; ++e) {
            int32_t p = e ? s->q : s->p, seen = 0;
            for (int32_t j = 0; j < b->n_ends && !seen; ++j)
                seen = b->ends[j] == p;
            if (!seen)
                PF_TRY(push_int(&b->ends, &b->n_ends, &b->cap_ends, p, err));
        }
    }
    int64_t n_sec_edges = b->n;
    if (!c->closed) {
        /* an open surface: the whole face, where the surface crosses it */
        if (n_sec_edges == 0)
            return PF_OK;
        b->n = 0;
        for (int64_t j = 0; j < n; ++j) {
            uint32_t na = m->face_nodes[o + (reversed ? n - 1 - j : j)];
            int32_t p, id;
            PF_TRY(pf_sc_cap_point(c, (int32_t)na, &p, err));
            PF_TRY(cap_id(c, p, sigma, &id, err));
            PF_TRY(push_edge(b, id, id, err));
        }
        uint32_t *poly = NULL;
        PF_CHECK(PF_ALLOC_N(poly, (size_t)n), err, PF_ERR_NOMEM, "out of memory for a cap");
        for (int64_t j = 0; j < n; ++j)
            poly[j] = b->e[2 * j];
        pf_status st = triangulate_cap(c, poly, (int32_t)n, arena, f, normal, err);
        pf_free(poly);
        return st;
    }
    b->centroid = pf_polygon_centroid(m->x, m->face_nodes + o, n);
    int whole = n_sec_edges == 0 ? face_inside(c, k) : -1;
    if (whole == 0)
        return PF_OK;
    for (int64_t j = 0; j < n; ++j) {
        int64_t a = reversed ? n - 1 - j : j, bb = reversed ? (2 * n - 2 - j) % n : (j + 1) % n;
        PF_TRY(edge_pieces(c, b, n_sec_edges, m->face_nodes[o + a], m->face_nodes[o + bb], sigma,
                           whole, err));
    }
    if (b->n == 0)
        return PF_OK;
    int64_t *offsets = NULL;
    uint32_t *nodes = NULL;
    int32_t n_polys = 0;
    pf_status st =
        pf_split_cap_polygons(c->s->x, normal, b->e, b->n, &offsets, &nodes, &n_polys, err);
    if (st == PF_ERR_NUMERIC) { /* a hole in the surface rather than no cut surface at all */
        c->stats->n_uncapped++;
        return PF_OK;
    }
    if (st < 0)
        pf_error_prefix(err, "cap of opened face %d", (int)f);
    for (int32_t q = 0; q < n_polys && st >= 0; ++q)
        st = triangulate_cap(c, nodes + offsets[q], (int32_t)(offsets[q + 1] - offsets[q]), arena,
                             f, normal, err);
    pf_free(offsets);
    pf_free(nodes);
    return st;
}

pf_status pf_sc_caps(sc_state *c, pf_error *err)
{
    cap_buf b;
    memset(&b, 0, sizeof b);
    pf_arena arena = {0};
    int64_t longest = 0;
    for (int32_t k = 0; k < c->g->n_faces; ++k)
        if (c->g->uv_offsets[k + 1] - c->g->uv_offsets[k] > longest)
            longest = c->g->uv_offsets[k + 1] - c->g->uv_offsets[k];
    /* a cap polygon has at most the face's corners and the section's points */
    int64_t room = 32 * (longest + 2 * (int64_t)c->n_points + 8) + 256;
    pf_status st = pf_arena_init(&arena, (size_t)room, err);
    if (st >= 0 && c->closed)
        st = input_section(c, err);
    if (st >= 0)
        st = cap_lookups(c, &b, err);
    for (int32_t k = 0; k < c->g->n_faces && st >= 0; ++k)
        st = face_cap(c, k, &b, &arena, err);
    pf_arena_release(&arena);
    cap_buf_release(&b);
    return st;
}
