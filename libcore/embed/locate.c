/* Point location for embedding: element boundaries as triangles, a uniform bucket grid over
 * element boxes, inside tests by the winding number and the nearest element for points outside. */
#include "embed_internal.h"

#include <string.h>

/* ---- element boundaries -------------------------------------------------------------------- */

void pf_elem_geometry_release(elem_geometry *g)
{
    pf_free(g->tri_offsets);
    pf_free(g->tri);
    pf_free(g->node_offsets);
    pf_free(g->nodes);
    pf_free(g->box);
    pf_free(g->kind);
    memset(g, 0, sizeof *g);
}

/* Triangles of every face in its stored orientation: face f has face_tri[3 (face_nodes offset
 * minus 2 f) ..], n_f - 2 of them, as positions within the face. */
static pf_status triangulate_faces(const pf_mesh *m, uint32_t **face_tri, pf_error *err)
{
    int64_t total = m->face_offsets[m->n_faces] - 2 * (int64_t)m->n_faces;
    int64_t longest = 3;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        PF_CHECK(n >= 3, err, PF_ERR_INVALID, "face %d has %lld nodes", (int)f, (long long)n);
        longest = n > longest ? n : longest;
    }
    PF_CHECK(PF_ALLOC_N(*face_tri, 3 * total), err, PF_ERR_NOMEM,
             "out of memory for %lld face triangles", (long long)total);
    pf_arena arena = {0};
    /* 2 n doubles and 2 n int32 plus alignment, as pf_polygon_triangulate asks */
    PF_TRY(pf_arena_init(&arena, (size_t)longest * 32 + 256, err));
    pf_status st = PF_OK;
    for (int32_t f = 0; f < m->n_faces && st >= 0; ++f) {
        int64_t o = m->face_offsets[f];
        int32_t n = (int32_t)(m->face_offsets[f + 1] - o);
        st = pf_polygon_triangulate(m->x, m->face_nodes + o, n, &arena,
                                    *face_tri + 3 * (o - 2 * (int64_t)f), NULL, err);
    }
    pf_arena_release(&arena);
    if (st < 0)
        PF_FREE(*face_tri);
    return st;
}

static int32_t add_distinct(uint32_t *nodes, int32_t n, uint32_t v)
{
    for (int32_t k = 0; k < n; ++k)
        if (nodes[k] == v)
            return n;
    nodes[n] = v;
    return n + 1;
}

static void fill_elem(const pf_mesh *m, const uint32_t *face_tri, int32_t e, elem_geometry *g)
{
    uint32_t *tri = g->tri + 3 * g->tri_offsets[e];
    uint32_t *nodes = g->nodes + g->node_offsets[e];
    int32_t n_nodes = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int reversed = (m->elem_faces[k] & PF_FACE_REVERSED) != 0;
        int64_t o = m->face_offsets[f];
        int64_t nt = m->face_offsets[f + 1] - o - 2;
        const uint32_t *ft = face_tri + 3 * (o - 2 * (int64_t)f);
        for (int64_t t = 0; t < nt; ++t, tri += 3) {
            tri[0] = m->face_nodes[o + ft[3 * t]];
            tri[1] = m->face_nodes[o + ft[3 * t + (reversed ? 2 : 1)]];
            tri[2] = m->face_nodes[o + ft[3 * t + (reversed ? 1 : 2)]];
        }
        for (int64_t j = o; j < m->face_offsets[f + 1]; ++j)
            n_nodes = add_distinct(nodes, n_nodes, m->face_nodes[j]);
    }
    pf_vec3 lo = pf_v3_load(m->x + 3 * (size_t)nodes[0]), hi = lo;
    for (int32_t k = 1; k < n_nodes; ++k) {
        pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)nodes[k]);
        lo = pf_v3_min(lo, p);
        hi = pf_v3_max(hi, p);
    }
    pf_v3_store(lo, g->box + 6 * (size_t)e);
    pf_v3_store(hi, g->box + 6 * (size_t)e + 3);
    g->node_offsets[e + 1] = g->node_offsets[e] + n_nodes;
    g->kind[e] = (uint8_t)(m->elem_kind ? (pf_elem_kind)m->elem_kind[e] : pf_mesh_classify_elem(m, e));
    g->max_nodes = n_nodes > g->max_nodes ? n_nodes : g->max_nodes;
}

pf_status pf_elem_geometry_build(const pf_mesh *m, elem_geometry *g, pf_error *err)
{
    memset(g, 0, sizeof *g);
    uint32_t *face_tri = NULL;
    PF_TRY(triangulate_faces(m, &face_tri, err));
    int32_t ne = m->n_elems;
    g->n_elems = ne;
    int ok = PF_ALLOC_N(g->tri_offsets, (size_t)ne + 1) &&
             PF_ALLOC_N(g->node_offsets, (size_t)ne + 1) && PF_ALLOC_N(g->box, 6 * (size_t)ne) &&
             PF_ALLOC_N(g->kind, (size_t)ne);
    int64_t n_tri = 0, n_node_slots = 0;
    for (int32_t e = 0; ok && e < ne; ++e) {
        g->tri_offsets[e] = n_tri;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            n_tri += m->face_offsets[f + 1] - m->face_offsets[f] - 2;
            n_node_slots += m->face_offsets[f + 1] - m->face_offsets[f];
        }
    }
    if (ok) {
        g->tri_offsets[ne] = n_tri;
        g->node_offsets[0] = 0;
        ok = PF_ALLOC_N(g->tri, 3 * (size_t)n_tri) && PF_ALLOC_N(g->nodes, (size_t)n_node_slots);
    }
    if (!ok) {
        pf_free(face_tri);
        pf_elem_geometry_release(g);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the boundaries of %d elements", (int)ne);
    }
    for (int32_t e = 0; e < ne; ++e)
        fill_elem(m, face_tri, e, g);
    pf_free(face_tri);
    return PF_OK;
}

/* ---- bucket grid ----------------------------------------------------------------------------- */

void pf_bucket_grid_release(bucket_grid *g)
{
    pf_free(g->offsets);
    pf_free(g->items);
    memset(g, 0, sizeof *g);
}

void pf_bucket_grid_cell(const bucket_grid *g, pf_vec3 p, int32_t c[3])
{
    for (int a = 0; a < 3; ++a) {
        double t = floor((pf_v3_get(p, a) - pf_v3_get(g->origin, a)) / g->h);
        c[a] = t < 0 ? 0 : t >= g->n[a] ? g->n[a] - 1 : (int32_t)t;
    }
}

/* Cell range [c0, c1] of a box, clamped. */
static void box_cells(const bucket_grid *g, const double *box, int32_t c0[3], int32_t c1[3])
{
    pf_bucket_grid_cell(g, pf_v3_load(box), c0);
    pf_bucket_grid_cell(g, pf_v3_load(box + 3), c1);
}

pf_status pf_bucket_grid_build(bucket_grid *g, const double *box, int32_t n_items, double h,
                            pf_error *err)
{
    memset(g, 0, sizeof *g);
    PF_CHECK(n_items > 0, err, PF_ERR_INVALID, "nothing to put in a grid");
    pf_vec3 lo = pf_v3_load(box), hi = pf_v3_load(box + 3);
    for (int32_t i = 1; i < n_items; ++i) {
        lo = pf_v3_min(lo, pf_v3_load(box + 6 * (size_t)i));
        hi = pf_v3_max(hi, pf_v3_load(box + 6 * (size_t)i + 3));
    }
    pf_vec3 ext = pf_v3_sub(hi, lo);
    double size = fmax(pf_v3_max_abs(ext), 1e-300);
    if (!(h > 0) || !isfinite(h))
        h = size;
    h = fmax(h, size * 1e-6);
    /* at most about 8 cells per item (and a few thousand for tiny inputs) */
    double limit = 8.0 * n_items + 4096;
    for (;;) {
        double cells = (floor(ext.x / h) + 1) * (floor(ext.y / h) + 1) * (floor(ext.z / h) + 1);
        if (cells <= limit)
            break;
        h *= 1.25;
    }
    g->origin = lo;
    g->h = h;
    for (int a = 0; a < 3; ++a)
        g->n[a] = (int32_t)floor(pf_v3_get(ext, a) / h) + 1;
    int64_t n_cells = (int64_t)g->n[0] * g->n[1] * g->n[2];
    PF_CHECK(PF_ALLOC_N(g->offsets, (size_t)n_cells + 1), err, PF_ERR_NOMEM,
             "out of memory for a grid of %lld cells", (long long)n_cells);
    memset(g->offsets, 0, ((size_t)n_cells + 1) * sizeof *g->offsets);
    int32_t c0[3], c1[3];
    for (int32_t i = 0; i < n_items; ++i) { /* count, shifted by one */
        box_cells(g, box + 6 * (size_t)i, c0, c1);
        for (int32_t k = c0[2]; k <= c1[2]; ++k)
            for (int32_t j = c0[1]; j <= c1[1]; ++j)
                for (int32_t c = c0[0]; c <= c1[0]; ++c)
                    g->offsets[bucket_grid_index(g, c, j, k) + 1]++;
    }
    for (int64_t c = 0; c < n_cells; ++c)
        g->offsets[c + 1] += g->offsets[c];
    if (!PF_ALLOC_N(g->items, (size_t)g->offsets[n_cells])) {
        pf_bucket_grid_release(g);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for a grid");
    }
    for (int32_t i = 0; i < n_items; ++i) { /* fill, using offsets[c] as the cursor */
        box_cells(g, box + 6 * (size_t)i, c0, c1);
        for (int32_t k = c0[2]; k <= c1[2]; ++k)
            for (int32_t j = c0[1]; j <= c1[1]; ++j)
                for (int32_t c = c0[0]; c <= c1[0]; ++c)
                    g->items[g->offsets[bucket_grid_index(g, c, j, k)]++] = i;
    }
    for (int64_t c = n_cells; c > 0; --c)
        g->offsets[c] = g->offsets[c - 1];
    g->offsets[0] = 0;
    return PF_OK;
}

/* ---- distances --------------------------------------------------------------------------------- */

/* Closest point on a triangle by its Voronoi regions (vertex, edge, face). */
double pf_point_triangle_distance(pf_vec3 p, pf_vec3 a, pf_vec3 b, pf_vec3 c)
{
    pf_vec3 ab = pf_v3_sub(b, a), ac = pf_v3_sub(c, a), ap = pf_v3_sub(p, a);
    double d1 = pf_v3_dot(ab, ap), d2 = pf_v3_dot(ac, ap);
    if (d1 <= 0 && d2 <= 0)
        return pf_v3_norm(ap);
    pf_vec3 bp = pf_v3_sub(p, b);
    double d3 = pf_v3_dot(ab, bp), d4 = pf_v3_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3)
        return pf_v3_norm(bp);
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0)
        return pf_v3_dist(p, pf_v3_add(a, pf_v3_scale(ab, d1 / (d1 - d3))));
    pf_vec3 cp = pf_v3_sub(p, c);
    double d5 = pf_v3_dot(ab, cp), d6 = pf_v3_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6)
        return pf_v3_norm(cp);
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0)
        return pf_v3_dist(p, pf_v3_add(a, pf_v3_scale(ac, d2 / (d2 - d6))));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return pf_v3_dist(p, pf_v3_add(b, pf_v3_scale(pf_v3_sub(c, b), t)));
    }
    double den = 1.0 / (va + vb + vc);
    pf_vec3 q = pf_v3_add(a, pf_v3_add(pf_v3_scale(ab, vb * den), pf_v3_scale(ac, vc * den)));
    return pf_v3_dist(p, q);
}

static double box_distance(const double *box, pf_vec3 p)
{
    double s = 0;
    for (int a = 0; a < 3; ++a) {
        double v = pf_v3_get(p, a), d = fmax(box[a] - v, v - box[3 + a]);
        if (d > 0)
            s += d * d;
    }
    return sqrt(s);
}

static double elem_distance(const locator *L, int32_t e, pf_vec3 p)
{
    const double *x = L->mesh->x;
    double best = INFINITY;
    for (int64_t t = L->geo.tri_offsets[e]; t < L->geo.tri_offsets[e + 1]; ++t) {
        const uint32_t *v = L->geo.tri + 3 * t;
        best = fmin(best, pf_point_triangle_distance(p, pf_v3_load(x + 3 * (size_t)v[0]),
                                                  pf_v3_load(x + 3 * (size_t)v[1]),
                                                  pf_v3_load(x + 3 * (size_t)v[2])));
    }
    return best;
}

static int elem_contains(const locator *L, int32_t e, pf_vec3 p)
{
    if (box_distance(L->geo.box + 6 * (size_t)e, p) > L->tol)
        return 0;
    int64_t t0 = L->geo.tri_offsets[e];
    return pf_winding_number(L->mesh->x, L->geo.tri + 3 * t0,
                             (int32_t)(L->geo.tri_offsets[e + 1] - t0), p) >= 0.5;
}

/* ---- locator --------------------------------------------------------------------------------- */

void pf_locator_release(locator *L)
{
    pf_elem_geometry_release(&L->geo);
    pf_bucket_grid_release(&L->grid);
    pf_free(L->stamp);
    memset(L, 0, sizeof *L);
}

pf_status pf_locator_build(locator *L, const pf_mesh *m, pf_error *err)
{
    memset(L, 0, sizeof *L);
    L->mesh = m;
    PF_TRY(pf_elem_geometry_build(m, &L->geo, err));
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    L->tol = 1e-9 * pf_v3_dist(lo, hi);
    /* Cells about the mean element box: a few elements per cell. */
    double mean = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        const double *b = L->geo.box + 6 * (size_t)e;
        mean += fmax(b[3] - b[0], fmax(b[4] - b[1], b[5] - b[2]));
    }
    mean /= m->n_elems;
    pf_status st = pf_bucket_grid_build(&L->grid, L->geo.box, m->n_elems, mean, err);
    if (st >= 0 && !PF_ALLOC_N(L->stamp, (size_t)m->n_elems))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for a locator");
    if (st < 0) {
        pf_locator_release(L);
        return st;
    }
    memset(L->stamp, 0, (size_t)m->n_elems * sizeof *L->stamp);
    return PF_OK;
}

/* Nearest element by rings of cells around p's (clamped) cell. After ring r, every element not
 * yet seen lies wholly outside the cells within r of that cell, so at least r h from p's
 * projection onto the grid box, and (the projection onto a convex set never increases
 * distances to its points) at least r h from p. */
static int32_t nearest_elem(locator *L, pf_vec3 p, double *dist)
{
    const bucket_grid *g = &L->grid;
    if (++L->now == 0) {
        memset(L->stamp, 0, (size_t)L->geo.n_elems * sizeof *L->stamp);
        L->now = 1;
    }
    int32_t c[3];
    pf_bucket_grid_cell(g, p, c);
    int32_t best_e = -1;
    double best = INFINITY;
    int32_t max_ring = g->n[0] > g->n[1] ? g->n[0] : g->n[1];
    max_ring = max_ring > g->n[2] ? max_ring : g->n[2];
    for (int32_t r = 0; r <= max_ring; ++r) {
        for (int32_t k = c[2] - r; k <= c[2] + r; ++k) {
            if (k < 0 || k >= g->n[2])
                continue;
            for (int32_t j = c[1] - r; j <= c[1] + r; ++j) {
                if (j < 0 || j >= g->n[1])
                    continue;
                int on_shell = k == c[2] - r || k == c[2] + r || j == c[1] - r || j == c[1] + r;
                for (int32_t i = c[0] - r; i <= c[0] + r; i += on_shell ? 1 : 2 * r) {
                    if (i >= 0 && i < g->n[0]) {
                        int64_t cell = bucket_grid_index(g, i, j, k);
                        for (int64_t q = g->offsets[cell]; q < g->offsets[cell + 1]; ++q) {
                            int32_t e = g->items[q];
                            if (L->stamp[e] == L->now)
                                continue;
                            L->stamp[e] = L->now;
                            if (box_distance(L->geo.box + 6 * (size_t)e, p) >= best)
                                continue;
                            double d = elem_distance(L, e, p);
                            if (d < best)
                                best = d, best_e = e;
                        }
                    }
                    if (r == 0)
                        break;
                }
            }
        }
        if (best <= r * g->h)
            break;
    }
    *dist = best;
    return best_e;
}

int32_t pf_locator_find(locator *L, pf_vec3 p, double *dist)
{
    const bucket_grid *g = &L->grid;
    int32_t c[3];
    pf_bucket_grid_cell(g, p, c);
    int64_t cell = bucket_grid_index(g, c[0], c[1], c[2]);
    for (int64_t q = g->offsets[cell]; q < g->offsets[cell + 1]; ++q)
        if (elem_contains(L, g->items[q], p)) {
            *dist = 0;
            return g->items[q];
        }
    return nearest_elem(L, p, dist);
}
