/* A polygon soup into a pf_surface: triangulation, join of identical positions, clean-up.
 *
 * Positions are joined by exact equality of the coordinates read (no tolerance: distinct but close
 * vertices are the file's business, and a tolerance would merge the vertices of a valid surface
 * scaled small enough). A file that splits a vertex by normal or texture coordinate (assimp's
 * output for a cube with per-face normals, STL's triangle-by-triangle layout) is closed by it. */
#include "surface_soup.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include <pf/geom.h>

void pf_surface_soup_release(surface_soup *s)
{
    pf_buffer_release(&s->x);
    pf_buffer_release(&s->offsets);
    pf_buffer_release(&s->nodes);
    memset(s, 0, sizeof *s);
}

pf_status pf_surface_soup_vertex(surface_soup *s, const double p[3], pf_error *err)
{
    PF_TRY(pf_buffer_append(&s->x, p, 3 * sizeof *p, err));
    s->n_verts++;
    return PF_OK;
}

pf_status pf_surface_soup_polygon(surface_soup *s, const uint32_t *idx, int64_t n, pf_error *err)
{
    if (n < 3)
        return PF_OK;
    if (s->offsets.size == 0) {
        const int64_t zero = 0;
        PF_TRY(pf_buffer_append(&s->offsets, &zero, sizeof zero, err));
    }
    PF_TRY(pf_buffer_append(&s->nodes, idx, (size_t)n * sizeof *idx, err));
    const int64_t end = (int64_t)(s->nodes.size / sizeof *idx);
    PF_TRY(pf_buffer_append(&s->offsets, &end, sizeof end, err));
    s->n_polys++;
    return PF_OK;
}

/* One vertex with its position, for sorting by position. */
typedef struct vertex_key {
    double p[3];
    int64_t index;
} vertex_key;

static int compare_vertex_key(const void *pa, const void *pb)
{
    const vertex_key *a = pa, *b = pb;
    for (int c = 0; c < 3; ++c)
        if (a->p[c] != b->p[c])
            return a->p[c] < b->p[c] ? -1 : 1;
    return (a->index > b->index) - (a->index < b->index);
}

/* Equal coordinates (so -0 and +0 are one position; readers refuse NaN). */
static bool same_position(const vertex_key *a, const vertex_key *b)
{
    return a->p[0] == b->p[0] && a->p[1] == b->p[1] && a->p[2] == b->p[2];
}

/* group[i]: the joined vertex of soup vertex i, numbered in the order of first occurrence. */
static int32_t join_positions(const double *x, int64_t n, vertex_key *keys, int32_t *group)
{
    for (int64_t i = 0; i < n; ++i)
        keys[i] = (vertex_key){{x[3 * i], x[3 * i + 1], x[3 * i + 2]}, i};
    qsort(keys, (size_t)n, sizeof *keys, compare_vertex_key);
    /* Sorted by position, then index: each run of equal positions starts with its smallest
     * index, which every vertex of the run points at. */
    for (int64_t i = 0, run = 0; i < n; ++i) {
        if (!same_position(&keys[i], &keys[run]))
            run = i;
        group[keys[i].index] = (int32_t)keys[run].index;
    }
    int32_t count = 0;
    for (int64_t i = 0; i < n; ++i)
        group[i] = group[i] == (int32_t)i ? count++ : group[group[i]];
    return count;
}

/* Triangles of the soup's polygons on joined vertices, those that lost a corner to the join left
 * out; *n_tris set. tri has room for every polygon's n - 2 triangles. */
static pf_status triangulate(const surface_soup *s, const int32_t *group, uint32_t *tri,
                             int64_t *n_tris, pf_error *err)
{
    const int64_t *off = (const int64_t *)s->offsets.data;
    const uint32_t *nodes = (const uint32_t *)s->nodes.data;
    const double *x = (const double *)s->x.data;
    pf_arena scratch = {0};
    PF_TRY(pf_arena_init(&scratch, 64 * (size_t)SURFACE_POLYGON_MAX, err));
    uint32_t *local = pf_alloc_array(3 * (size_t)SURFACE_POLYGON_MAX, sizeof *local);
    pf_status st = local ? PF_OK
                         : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    int64_t count = 0;
    for (int64_t p = 0; st == PF_OK && p < s->n_polys; ++p) {
        const uint32_t *poly = nodes + off[p];
        const int32_t n = (int32_t)(off[p + 1] - off[p]);
        st = pf_polygon_triangulate(x, poly, n, &scratch, local, NULL, err);
        for (int32_t t = 0; st == PF_OK && t < n - 2; ++t) {
            uint32_t c[3];
            for (int i = 0; i < 3; ++i)
                c[i] = (uint32_t)group[poly[local[3 * t + i]]];
            if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0])
                continue;
            memcpy(tri + 3 * count++, c, sizeof c);
        }
    }
    pf_free(local);
    pf_arena_release(&scratch);
    *n_tris = count;
    return st;
}

pf_status pf_surface_soup_finish(const surface_soup *s, const char *path, pf_surface *out,
                              pf_error *err)
{
    memset(out, 0, sizeof *out);
    const int64_t *off = (const int64_t *)s->offsets.data;
    const int64_t max_tris = s->n_polys ? off[s->n_polys] - 2 * s->n_polys : 0;
    PF_CHECK(s->n_verts <= INT32_MAX && max_tris <= INT32_MAX, err, PF_ERR_TOO_LARGE,
             "%s: %lld vertices and %lld triangles: more than pf handles", path,
             (long long)s->n_verts, (long long)max_tris);
    PF_CHECK(max_tris > 0, err, PF_ERR_FORMAT, "%s: no triangles (%lld vertices, no face)", path,
             (long long)s->n_verts);
    vertex_key *keys = pf_alloc_array((size_t)s->n_verts, sizeof *keys);
    int32_t *group = pf_alloc_array((size_t)s->n_verts, sizeof *group);
    uint32_t *tri = pf_alloc_array(3 * (size_t)max_tris, sizeof *tri);
    int32_t *used = NULL;
    pf_status st = PF_OK;
    if (!keys || !group || !tri)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    int64_t n_tris = 0;
    int32_t n_groups = 0, n_used = 0;
    if (st == PF_OK) {
        n_groups = join_positions((const double *)s->x.data, s->n_verts, keys, group);
        st = triangulate(s, group, tri, &n_tris, err);
    }
    if (st == PF_OK && n_tris == 0)
        st = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                          "%s: no triangles (all %lld are degenerate: corners at one position)",
                          path, (long long)max_tris);
    if (st == PF_OK && !(used = pf_alloc_array((size_t)n_groups, sizeof *used)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    if (st == PF_OK) {
        /* Vertices no triangle uses (points, dropped degenerates) are left out. */
        for (int32_t g = 0; g < n_groups; ++g)
            used[g] = -1;
        for (int64_t i = 0; i < 3 * n_tris; ++i)
            used[tri[i]] = 0;
        for (int32_t g = 0; g < n_groups; ++g)
            if (used[g] == 0)
                used[g] = n_used++;
        st = pf_surface_alloc(out, n_used, (int32_t)n_tris, err);
    }
    if (st == PF_OK) {
        out->id = 1;
        for (int64_t i = 0; i < s->n_verts; ++i) {
            int32_t v = used[group[keys[i].index]];
            if (v >= 0)
                memcpy(out->x + 3 * (size_t)v, keys[i].p, sizeof keys[i].p);
        }
        for (int64_t i = 0; i < 3 * n_tris; ++i)
            out->tri[i] = (uint32_t)used[tri[i]];
    }
    pf_free(keys);
    pf_free(group);
    pf_free(tri);
    pf_free(used);
    return st;
}
