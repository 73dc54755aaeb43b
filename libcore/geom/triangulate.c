/* Triangulation of planar polygons in their own plane. Convex polygons get a fan; non-convex ones
 * are ear-clipped (Meisters' two-ears theorem:
 * every simple polygon with n > 3 vertices has an ear, a vertex whose triangle with its two
 * neighbours lies inside the polygon; cutting it off leaves a simple polygon with n - 1 vertices).
 */
#include <pf/geom.h>

#include <stdbool.h>
#include <string.h>

/* Polygon edge bits of triangle (a, b, c), positions within an n-gon: an edge of the triangle is a
 * polygon edge when its end follows its start in the polygon's order. */
static uint8_t edge_bits(int32_t a, int32_t b, int32_t c, int32_t n)
{
    uint8_t bits = 0;
    if ((a + 1) % n == b)
        bits |= 1;
    if ((b + 1) % n == c)
        bits |= 2;
    if ((c + 1) % n == a)
        bits |= 4;
    return bits;
}

/* Twice the signed area of the 2D triangle (a, b, c): positive when counter-clockwise. */
static double orient2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* Projects the polygon onto the coordinate plane most nearly parallel to it, with the two axes in
 * the order that keeps it counter-clockwise (the projection along axis k scales areas by |N_k| /
 * |N| and keeps the orientation when N_k > 0). */
static void project_polygon(const double *x, const uint32_t *idx, int32_t n, pf_vec3 normal,
                            double *uv)
{
    double an[3] = {fabs(normal.x), fabs(normal.y), fabs(normal.z)};
    int k = an[0] >= an[1] && an[0] >= an[2] ? 0 : an[1] >= an[2] ? 1 : 2;
    int u = (k + 1) % 3, v = (k + 2) % 3;
    if (pf_v3_get(normal, k) < 0) {
        int t = u;
        u = v;
        v = t;
    }
    for (int32_t i = 0; i < n; ++i) {
        uv[2 * i] = x[3 * (size_t)idx[i] + (size_t)u];
        uv[2 * i + 1] = x[3 * (size_t)idx[i] + (size_t)v];
    }
}

static bool is_convex(const double *uv, int32_t n)
{
    for (int32_t i = 0; i < n; ++i) {
        const double *a = uv + 2 * ((i + n - 1) % n), *b = uv + 2 * i, *c = uv + 2 * ((i + 1) % n);
        if (orient2(a, b, c) < 0)
            return false;
    }
    return true;
}

static void fan(int32_t n, uint32_t *tri, uint8_t *edges)
{
    for (int32_t k = 1; k + 1 < n; ++k) {
        uint32_t *t = tri + 3 * (k - 1);
        t[0] = 0;
        t[1] = (uint32_t)k;
        t[2] = (uint32_t)(k + 1);
        if (edges)
            edges[k - 1] = edge_bits(0, k, k + 1, n);
    }
}

/* True when p lies inside or on the counter-clockwise triangle (a, b, c). */
static bool in_triangle(const double *p, const double *a, const double *b, const double *c)
{
    return orient2(a, b, p) >= 0 && orient2(b, c, p) >= 0 && orient2(c, a, p) >= 0;
}

static bool same_point(const double *p, const double *q)
{
    return p[0] == q[0] && p[1] == q[1];
}

/* Vertex i of the remaining polygon (linked through prev/next) is an ear: convex, and no other
 * remaining reflex or flat vertex inside its triangle (only those can poke into it). */
static bool is_ear(const double *uv, const int32_t *prev, const int32_t *next, int32_t i)
{
    int32_t a = prev[i], c = next[i];
    const double *pa = uv + 2 * a, *pb = uv + 2 * i, *pc = uv + 2 * c;
    if (orient2(pa, pb, pc) <= 0)
        return false;
    for (int32_t j = next[c]; j != a; j = next[j]) {
        const double *pj = uv + 2 * j;
        if (orient2(uv + 2 * prev[j], pj, uv + 2 * next[j]) > 0)
            continue;
        if (same_point(pj, pa) || same_point(pj, pb) || same_point(pj, pc))
            continue;
        if (in_triangle(pj, pa, pb, pc))
            return false;
    }
    return true;
}

/* Ear clipping. When rounding leaves no ear (a nearly degenerate polygon), the vertex with the
 * largest turn is cut anyway, so the result always has n - 2 triangles. */
static void ear_clip(const double *uv, int32_t n, int32_t *prev, int32_t *next, uint32_t *tri,
                     uint8_t *edges)
{
    for (int32_t i = 0; i < n; ++i) {
        prev[i] = (i + n - 1) % n;
        next[i] = (i + 1) % n;
    }
    int32_t cur = 0;
    for (int32_t left = n, t = 0; left > 3; --left, ++t) {
        int32_t ear = -1, best = cur;
        double best_turn = -INFINITY;
        int32_t i = cur;
        for (int32_t k = 0; k < left; ++k, i = next[i]) {
            if (is_ear(uv, prev, next, i)) {
                ear = i;
                break;
            }
            double turn = orient2(uv + 2 * prev[i], uv + 2 * i, uv + 2 * next[i]);
            if (turn > best_turn) {
                best_turn = turn;
                best = i;
            }
        }
        if (ear < 0)
            ear = best;
        int32_t a = prev[ear], c = next[ear];
        tri[3 * t] = (uint32_t)a;
        tri[3 * t + 1] = (uint32_t)ear;
        tri[3 * t + 2] = (uint32_t)c;
        if (edges)
            edges[t] = edge_bits(a, ear, c, n);
        next[a] = c;
        prev[c] = a;
        cur = c;
    }
    int32_t a = prev[cur], c = next[cur];
    uint32_t *last = tri + 3 * (n - 3);
    last[0] = (uint32_t)a;
    last[1] = (uint32_t)cur;
    last[2] = (uint32_t)c;
    if (edges)
        edges[n - 3] = edge_bits(a, cur, c, n);
}

pf_status pf_polygon_triangulate(const double *x, const uint32_t *idx, int32_t n, pf_arena *scratch,
                                uint32_t *tri, uint8_t *edges, pf_error *err)
{
    PF_CHECK(n >= 3, err, PF_ERR_INVALID, "polygon with %d vertices cannot be triangulated",
             (int)n);
    if (n == 3) {
        fan(n, tri, edges);
        return PF_OK;
    }
    size_t mark = pf_arena_mark(scratch);
    double *uv = pf_arena_push(scratch, 2 * (size_t)n, sizeof *uv);
    int32_t *links = pf_arena_push(scratch, 2 * (size_t)n, sizeof *links);
    if (!uv || !links) {
        pf_arena_reset(scratch, mark);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "scratch too small to triangulate a polygon of %d vertices", (int)n);
    }
    pf_vec3 normal = pf_polygon_area_vector(x, idx, n);
    project_polygon(x, idx, n, normal, uv);
    if (pf_v3_norm(normal) == 0 || is_convex(uv, n))
        fan(n, tri, edges);
    else
        ear_clip(uv, n, links, links + n, tri, edges);
    pf_arena_reset(scratch, mark);
    return PF_OK;
}
