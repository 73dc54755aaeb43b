/* Surface repair before slicing: vertices at one position welded, degenerate and duplicate
 * triangles removed, orientation made consistent and outward, holes up to a size filled.
 *
 * Holes are the loops of edges used by exactly one triangle, traced against the direction of
 * that triangle (so the filling traverses each edge the other way, as a closed surface does);
 * a walk that passes a vertex twice (holes touching at a corner) is split into its simple loops.
 * A loop is filled by its triangulation of least total area (dynamic programming over the
 * polygon's vertex ranges, O(n^3) for n edges; Liepa 2003 without the dihedral term): for a
 * planar simple hole that is a triangulation of the hole itself, since any triangle outside it
 * adds area twice. Diagonals that are edges of the surface already are not used (they would make
 * an edge of three triangles). */
#include <pf/mesh.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

pf_surface_repair_params pf_surface_repair_params_default(void)
{
    return (pf_surface_repair_params){.max_hole = 0.5, .max_hole_edges = 600};
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Vertices with equal coordinates welded onto the first; triangles renumbered. */
static pf_status weld(pf_surface *s, int32_t *welded, pf_error *err)
{
    int32_t *order = pf_alloc_array((size_t)s->n_verts + 1, sizeof *order);
    int32_t *to = pf_alloc_array((size_t)s->n_verts + 1, sizeof *to);
    if (!order || !to) {
        pf_free(order), pf_free(to);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory repairing");
    }
    for (int32_t v = 0; v < s->n_verts; ++v)
        order[v] = v;
    /* the indices sorted by coordinates, then index (qsort has no context for s->x) */
    const double *x = s->x;
    for (int32_t gap = s->n_verts / 2; gap > 0; gap /= 2)
        for (int32_t i = gap; i < s->n_verts; ++i) {
            int32_t t = order[i], j = i;
            while (j >= gap) {
                const double *a = x + 3 * (size_t)order[j - gap], *b = x + 3 * (size_t)t;
                int c = a[0] != b[0]   ? (a[0] > b[0]) - (a[0] < b[0])
                        : a[1] != b[1] ? (a[1] > b[1]) - (a[1] < b[1])
                        : a[2] != b[2] ? (a[2] > b[2]) - (a[2] < b[2])
                                       : (order[j - gap] > t) - (order[j - gap] < t);
                if (c <= 0)
                    break;
                order[j] = order[j - gap];
                j -= gap;
            }
            order[j] = t;
        }
    *welded = 0;
    for (int32_t i = 0; i < s->n_verts; ++i) {
        const double *a = x + 3 * (size_t)order[i];
        const double *b = i > 0 ? x + 3 * (size_t)order[i - 1] : a;
        if (i > 0 && a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) {
            to[order[i]] = to[order[i - 1]];
            ++*welded;
        } else {
            to[order[i]] = order[i];
        }
    }
    for (size_t i = 0; i < 3 * (size_t)s->n_tris; ++i)
        s->tri[i] = (uint32_t)to[s->tri[i]];
    pf_free(order), pf_free(to);
    return PF_OK;
}

/* Triangles with a repeated corner, then repeated triangles: one of several on the same corners
 * facing the same way is kept; a pair facing opposite ways bounds nothing and both go. */
static pf_status remove_bad_triangles(pf_surface *s, pf_surface_repair_report *r, pf_error *err)
{
    int32_t n = 0;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *c = s->tri + 3 * (size_t)t;
        if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0]) {
            r->degenerate++;
            continue;
        }
        memmove(s->tri + 3 * (size_t)n++, c, 3 * sizeof *c);
    }
    s->n_tris = n;
    /* each triangle's corners sorted, with the parity of the permutation that sorts them */
    typedef struct {
        uint32_t a, b, c;
        int32_t t;
        int8_t parity;
    } tri_key;
    tri_key *k = pf_alloc_array((size_t)n + 1, sizeof *k);
    uint8_t *drop = pf_calloc((size_t)n + 1, 1);
    if (!k || !drop) {
        pf_free(k), pf_free(drop);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory repairing");
    }
    for (int32_t t = 0; t < n; ++t) {
        uint32_t v[3];
        memcpy(v, s->tri + 3 * (size_t)t, sizeof v);
        int8_t parity = 0; /* even permutation of the file's order to the sorted one: 0 */
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2 - i; ++j)
                if (v[j] > v[j + 1]) {
                    uint32_t tmp = v[j];
                    v[j] = v[j + 1], v[j + 1] = tmp;
                    parity ^= 1;
                }
        k[t] = (tri_key){v[0], v[1], v[2], t, parity};
    }
    /* sort by corners, then triangle index (shell sort on the small struct) */
    for (int32_t gap = n / 2; gap > 0; gap /= 2)
        for (int32_t i = gap; i < n; ++i) {
            tri_key t = k[i];
            int32_t j = i;
            while (j >= gap) {
                const tri_key *p = &k[j - gap];
                int c = p->a != t.a   ? (p->a > t.a ? 1 : -1)
                        : p->b != t.b ? (p->b > t.b ? 1 : -1)
                        : p->c != t.c ? (p->c > t.c ? 1 : -1)
                                      : (p->t > t.t) - (p->t < t.t);
                if (c <= 0)
                    break;
                k[j] = k[j - gap];
                j -= gap;
            }
            k[j] = t;
        }
    for (int32_t i = 0; i < n;) {
        int32_t j = i, up = 0, down = 0;
        while (j < n && k[j].a == k[i].a && k[j].b == k[i].b && k[j].c == k[i].c)
            ++j;
        /* in each orientation keep the first; then cancel opposite pairs */
        for (int32_t q = i; q < j; ++q) {
            int32_t *count = k[q].parity ? &down : &up;
            if (++*count > 1) {
                drop[k[q].t] = 1;
                r->duplicates++;
            }
        }
        if (up && down) {
            for (int32_t q = i; q < j; ++q)
                drop[k[q].t] = 1;
            r->opposite_pairs++;
        }
        i = j;
    }
    int32_t m = 0;
    for (int32_t t = 0; t < n; ++t)
        if (!drop[t])
            memmove(s->tri + 3 * (size_t)m++, s->tri + 3 * (size_t)t, 3 * sizeof *s->tri);
    s->n_tris = m;
    pf_free(k), pf_free(drop);
    return PF_OK;
}

/* Sorted undirected edge keys of s, with their use counts (one entry per use). */
static uint64_t edge_key(uint32_t a, uint32_t b)
{
    return a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
}

static bool has_edge(const uint64_t *keys, size_t n, uint32_t a, uint32_t b)
{
    uint64_t key = edge_key(a, b);
    return bsearch(&key, keys, n, sizeof key, compare_u64) != NULL;
}

static double tri_area(const pf_surface *s, uint32_t a, uint32_t b, uint32_t c)
{
    pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)a);
    pf_vec3 e1 = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)b), p);
    pf_vec3 e2 = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)c), p);
    return 0.5 * pf_v3_norm(pf_v3_cross(e1, e2));
}

/* The least-area triangulation of loop[0 .. n) appended to *out (3 (n - 2) corners, in loop
 * order); false when every triangulation needs a diagonal that is an edge already. */
static bool fill_loop(const pf_surface *s, const uint32_t *loop, int32_t n, const uint64_t *keys,
                      size_t n_keys, double *w, int32_t *best, uint32_t *out)
{
    for (int32_t i = 0; i + 1 < n; ++i)
        w[(size_t)i * n + i + 1] = 0;
    for (int32_t len = 2; len < n; ++len)
        for (int32_t i = 0; i + len < n; ++i) {
            int32_t j = i + len;
            double wij = INFINITY;
            int32_t arg = -1;
            /* the diagonal i-j (not the closing edge 0-(n-1)) must be new, and join two
             * vertices (a loop through a vertex twice has no diagonal from it to itself) */
            if (loop[i] == loop[j] ||
                (!(i == 0 && j == n - 1) && has_edge(keys, n_keys, loop[i], loop[j]))) {
                w[(size_t)i * n + j] = INFINITY;
                continue;
            }
            for (int32_t m = i + 1; m < j; ++m) {
                double c = w[(size_t)i * n + m] + w[(size_t)m * n + j];
                if (c < wij) {
                    c += tri_area(s, loop[i], loop[m], loop[j]);
                    if (c < wij)
                        wij = c, arg = m;
                }
            }
            w[(size_t)i * n + j] = wij;
            best[(size_t)i * n + j] = arg;
        }
    if (!isfinite(w[n - 1]))
        return false;
    /* unwind the ranges without recursion: a stack of (i, j) */
    int32_t *stack = best + (size_t)n * n, top = 0, k = 0;
    stack[top++] = 0, stack[top++] = n - 1;
    while (top > 0) {
        int32_t j = stack[--top], i = stack[--top];
        if (j - i < 2)
            continue;
        int32_t m = best[(size_t)i * n + j];
        out[k++] = loop[i], out[k++] = loop[m], out[k++] = loop[j];
        stack[top++] = i, stack[top++] = m;
        stack[top++] = m, stack[top++] = j;
    }
    return true;
}

/* What filling needs across holes: the surface's edges, the scratch of the triangulation, the
 * triangles added so far and the limits. */
typedef struct filler {
    const pf_surface *s;
    const uint64_t *keys; /* sorted edge keys of s, one per use */
    size_t n_keys;
    double *w;
    int32_t *best;
    uint32_t *added;
    size_t n_added, cap_added;
    double limit; /* largest perimeter filled */
    int32_t cap;  /* largest edge count filled */
    pf_surface_repair_report *r;
} filler;

/* One hole, the simple loop loop[0 .. n) (closed false: a chain that did not close): filled
 * when within the limits and a triangulation exists, else reported as left open. */
static pf_status fill_simple(filler *f, const uint32_t *loop, int32_t n, bool closed, pf_error *err)
{
    double perimeter = 0;
    for (int32_t q = 0; q < n; ++q)
        if (closed || q + 1 < n)
            perimeter += pf_v3_dist(pf_v3_load(f->s->x + 3 * (size_t)loop[q]),
                                    pf_v3_load(f->s->x + 3 * (size_t)loop[(q + 1) % n]));
    f->r->holes++;
    bool fits = closed && n >= 3 && perimeter <= f->limit && n <= f->cap;
    if (fits && f->cap_added < f->n_added + 3 * (size_t)n) {
        size_t cap = 2 * (f->n_added + 3 * (size_t)n);
        uint32_t *grown = pf_realloc_array(f->added, cap, sizeof *grown);
        PF_CHECK(grown, err, PF_ERR_NOMEM, "out of memory repairing");
        f->added = grown, f->cap_added = cap;
    }
    if (fits &&
        fill_loop(f->s, loop, n, f->keys, f->n_keys, f->w, f->best, f->added + f->n_added)) {
        f->n_added += 3 * (size_t)(n - 2);
        f->r->holes_filled++;
        f->r->fill_triangles += n - 2;
    } else if (perimeter > f->r->largest_left) {
        f->r->largest_left = perimeter;
    }
    return PF_OK;
}

/* A closed loop through some vertex more than once (holes touching at a vertex) as its simple
 * loops: each return to a vertex on the stack closes the loop since that vertex. pos[v] is the
 * stack position of v, -1 when absent (left so). */
static pf_status fill_split(filler *f, uint32_t *loop, int32_t n, int32_t *pos, pf_error *err)
{
    int32_t k = 0; /* loop[0 .. k) is the stack, reused in place */
    pf_status st = PF_OK;
    for (int32_t q = 0; q < n && st >= 0; ++q) {
        uint32_t v = loop[q];
        if (pos[v] >= 0) {
            int32_t p = pos[v];
            st = fill_simple(f, loop + p, k - p, true, err);
            for (int32_t i = p + 1; i < k; ++i)
                pos[loop[i]] = -1;
            k = p + 1;
            continue;
        }
        pos[v] = k;
        loop[k++] = v;
    }
    if (st >= 0 && k > 1)
        st = fill_simple(f, loop, k, true, err);
    for (int32_t i = 0; i < k; ++i)
        pos[loop[i]] = -1;
    return st;
}

/* Traces the hole loops and fills those within the limits; the new triangles are appended. */
static pf_status fill_holes(pf_surface *s, const pf_surface_repair_params *p,
                            pf_surface_repair_report *r, pf_error *err)
{
    size_t n3 = 3 * (size_t)s->n_tris;
    uint64_t *keys = pf_alloc_array(n3 + 1, sizeof *keys);
    PF_CHECK(keys, err, PF_ERR_NOMEM, "out of memory repairing");
    for (size_t i = 0; i < n3; ++i)
        keys[i] = edge_key(s->tri[i], s->tri[i - i % 3 + (i % 3 + 1) % 3]);
    qsort(keys, n3, sizeof *keys, compare_u64);
    /* the open edges, each as the directed edge b -> a of the hole (a -> b in its triangle),
     * sorted by their start b */
    uint64_t *open = pf_alloc_array(n3 + 1, sizeof *open);
    int32_t n_open = 0;
    if (!open) {
        pf_free(keys);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory repairing");
    }
    for (size_t i = 0; i < n3; ++i) {
        uint32_t a = s->tri[i], b = s->tri[i - i % 3 + (i % 3 + 1) % 3];
        uint64_t key = edge_key(a, b);
        uint64_t *hit = bsearch(&key, keys, n3, sizeof key, compare_u64);
        /* the first and last entries of equal keys around hit: one use only */
        bool once = !((hit > keys && hit[-1] == key) || (hit + 1 < keys + n3 && hit[1] == key));
        if (once)
            open[n_open++] = ((uint64_t)b << 32) | a;
    }
    qsort(open, (size_t)n_open, sizeof *open, compare_u64);
    pf_surface_stats st;
    pf_status status = pf_surface_compute_stats(s, &st, err);
    double diag = pf_v3_dist(st.lo, st.hi), limit = p->max_hole * diag;
    int32_t cap = p->max_hole_edges, max_n = n_open < cap ? n_open : cap;
    uint8_t *used = pf_calloc((size_t)n_open + 1, 1);
    uint32_t *loop = pf_alloc_array((size_t)n_open + 1, sizeof *loop);
    double *w = pf_alloc_array((size_t)max_n * max_n + 1, sizeof *w);
    int32_t *best = pf_alloc_array((size_t)max_n * max_n + 4 * (size_t)max_n + 4, sizeof *best);
    int32_t *pos = pf_alloc_array((size_t)s->n_verts + 1, sizeof *pos);
    uint32_t *added = NULL;
    size_t n_added = 0;
    if (status >= 0 && (!used || !loop || !w || !best || !pos))
        status = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory repairing");
    for (int32_t v = 0; pos && v < s->n_verts; ++v)
        pos[v] = -1;
    filler f = {.s = s,
                .keys = keys,
                .n_keys = n3,
                .w = w,
                .best = best,
                .limit = limit,
                .cap = cap,
                .r = r};
    for (int32_t e0 = 0; status >= 0 && e0 < n_open; ++e0) {
        if (used[e0])
            continue;
        /* follow b -> a, then the first unused open edge starting at a, back to the start */
        int32_t n = 0, e = e0;
        uint32_t start = (uint32_t)(open[e0] >> 32);
        bool closed = false;
        while (e >= 0) {
            used[e] = 1;
            uint32_t from = (uint32_t)(open[e] >> 32), to = (uint32_t)open[e];
            loop[n++] = from;
            if (to == start) {
                closed = true;
                break;
            }
            uint64_t lo = (uint64_t)to << 32;
            int32_t a = 0, b = n_open; /* first open edge starting at `to` */
            while (a < b) {
                int32_t mid = (a + b) / 2;
                if (open[mid] < lo)
                    a = mid + 1;
                else
                    b = mid;
            }
            e = -1;
            for (int32_t q = a; q < n_open && (open[q] >> 32) == to; ++q)
                if (!used[q]) {
                    e = q;
                    break;
                }
            if (e < 0)
                loop[n++] = to; /* a chain that does not close: its last vertex */
        }
        status = closed ? fill_split(&f, loop, n, pos, err) : fill_simple(&f, loop, n, false, err);
    }
    n_added = f.n_added, added = f.added;
    if (status >= 0 && n_added > 0) {
        uint32_t *tri = pf_realloc_array(s->tri, n3 + n_added, sizeof *tri);
        if (!tri) {
            status = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        } else {
            memcpy(tri + n3, added, n_added * sizeof *tri);
            s->tri = tri;
            s->n_tris += (int32_t)(n_added / 3);
        }
    }
    r->largest_left = diag > 0 ? r->largest_left / diag : 0;
    pf_free(keys), pf_free(open), pf_free(used), pf_free(loop), pf_free(w), pf_free(best);
    pf_free(pos);
    pf_free(added);
    return status;
}

/* Vertices no triangle uses are dropped (welding and removals leave some). */
static pf_status compact(pf_surface *s, pf_error *err)
{
    int32_t *to = pf_alloc_array((size_t)s->n_verts + 1, sizeof *to);
    PF_CHECK(to, err, PF_ERR_NOMEM, "out of memory repairing");
    for (int32_t v = 0; v < s->n_verts; ++v)
        to[v] = -1;
    for (size_t i = 0; i < 3 * (size_t)s->n_tris; ++i)
        to[s->tri[i]] = 0;
    int32_t n = 0;
    for (int32_t v = 0; v < s->n_verts; ++v)
        if (to[v] == 0) {
            memmove(s->x + 3 * (size_t)n, s->x + 3 * (size_t)v, 3 * sizeof *s->x);
            to[v] = n++;
        }
    for (size_t i = 0; i < 3 * (size_t)s->n_tris; ++i)
        s->tri[i] = (uint32_t)to[s->tri[i]];
    s->n_verts = n;
    pf_free(to);
    return PF_OK;
}

pf_status pf_surface_repair(pf_surface *s, const pf_surface_repair_params *params,
                            pf_surface_repair_report *report, pf_error *err)
{
    pf_surface_repair_params p = params ? *params : pf_surface_repair_params_default();
    pf_surface_repair_report local;
    pf_surface_repair_report *r = report ? report : &local;
    memset(r, 0, sizeof *r);
    PF_CHECK(p.max_hole >= 0 && isfinite(p.max_hole), err, PF_ERR_INVALID,
             "repair: the largest hole must be finite and >= 0, got %g", p.max_hole);
    PF_CHECK(p.max_hole_edges >= 3 && p.max_hole_edges <= 4096, err, PF_ERR_INVALID,
             "repair: the largest hole's edge count must be in 3 .. 4096, got %d",
             (int)p.max_hole_edges);
    pf_surface_stats st;
    PF_TRY(pf_surface_compute_stats(s, &st, err));
    r->tris_before = s->n_tris;
    PF_TRY(weld(s, &r->welded, err));
    PF_TRY(remove_bad_triangles(s, r, err));
    PF_CHECK(s->n_tris > 0, err, PF_ERR_INVALID, "repair: no triangle is left");
    PF_TRY(compact(s, err)); /* the diagonal of what is left bounds the holes filled */
    PF_TRY(pf_surface_orient(s, &r->orient, err));
    PF_TRY(fill_holes(s, &p, r, err));
    if (r->fill_triangles > 0) {
        pf_surface_fix_report again;
        PF_TRY(pf_surface_orient(s, &again, err));
        r->orient.flipped_faces += again.flipped_faces;
        r->orient.flipped_components += again.flipped_components;
        r->orient.components = again.components;
    }
    PF_TRY(pf_surface_compute_stats(s, &st, err));
    r->closed = st.closed && st.manifold;
    return PF_OK;
}
