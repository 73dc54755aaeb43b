/* Triangle surfaces: storage and the closed / manifold / volume report. */
#include <pf/mesh.h>

#include <stdlib.h>
#include <string.h>

pf_status pf_surface_alloc(pf_surface *s, int32_t n_verts, int32_t n_tris, pf_error *err)
{
    memset(s, 0, sizeof *s);
    PF_CHECK(n_verts >= 0 && n_tris >= 0, err, PF_ERR_INVALID, "surface counts must be >= 0");
    s->x = pf_alloc_array(3 * (size_t)n_verts, sizeof *s->x);
    s->tri = pf_alloc_array(3 * (size_t)n_tris, sizeof *s->tri);
    if ((!s->x && n_verts) || (!s->tri && n_tris)) {
        pf_surface_release(s);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate a surface of %d vertices, %d triangles",
                            (int)n_verts, (int)n_tris);
    }
    s->n_verts = n_verts;
    s->n_tris = n_tris;
    return PF_OK;
}

void pf_surface_release(pf_surface *s)
{
    pf_free(s->x);
    pf_free(s->tri);
    pf_free(s->tri_part);
    memset(s, 0, sizeof *s);
}

int32_t pf_surface_count_caps(const pf_surface *s)
{
    int32_t n = 0;
    for (int32_t t = 0; s->tri_part && t < s->n_tris; ++t)
        n += s->tri_part[t] == PF_SURFACE_CAP;
    return n;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Directed edges a->b as keys (min << 32 | max) << 1 | (a > b): sorting groups the uses of each
 * undirected edge and keeps their directions. */
static void classify_edges(uint64_t *keys, int64_t n, pf_surface_stats *out)
{
    qsort(keys, (size_t)n, sizeof *keys, compare_u64);
    for (int64_t i = 0; i < n;) {
        int64_t j = i;
        int64_t dirs[2] = {0, 0};
        while (j < n && keys[j] >> 1 == keys[i] >> 1)
            dirs[keys[j++] & 1]++;
        int64_t uses = j - i;
        if (uses == 1)
            out->n_boundary_edges++;
        else if (uses > 2)
            out->n_nonmanifold_edges++;
        else if (dirs[0] != 1)
            out->n_flipped_edges++;
        i = j;
    }
}

/* A vertex is manifold when its triangles form one fan: connected through edges at the vertex. */
static int64_t count_nonmanifold_vertices(const pf_surface *s, const int64_t *vt_off,
                                          const int32_t *vt, int32_t *parent)
{
    int64_t bad = 0;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        int64_t a = vt_off[v], n = vt_off[v + 1] - a;
        for (int64_t i = 0; i < n; ++i)
            parent[i] = (int32_t)i;
        for (int64_t i = 0; i < n; ++i)
            for (int64_t j = i + 1; j < n; ++j) {
                const uint32_t *ti = s->tri + 3 * (size_t)vt[a + i];
                const uint32_t *tj = s->tri + 3 * (size_t)vt[a + j];
                int shared = 0;
                for (int p = 0; p < 3; ++p)
                    for (int q = 0; q < 3; ++q)
                        shared += ti[p] == tj[q] && ti[p] != (uint32_t)v;
                if (!shared)
                    continue;
                int32_t ri = (int32_t)i, rj = (int32_t)j;
                while (parent[ri] != ri)
                    ri = parent[ri];
                while (parent[rj] != rj)
                    rj = parent[rj];
                parent[ri] = rj;
            }
        int64_t roots = 0;
        for (int64_t i = 0; i < n; ++i)
            roots += parent[i] == i;
        bad += roots > 1;
    }
    return bad;
}

static pf_status vertex_fans(const pf_surface *s, int64_t *n_bad, pf_error *err)
{
    int64_t *off = pf_calloc((size_t)s->n_verts + 1, sizeof *off);
    int32_t *vt = pf_alloc_array(3 * (size_t)s->n_tris, sizeof *vt);
    int64_t max_valence = 0;
    pf_status st = PF_OK;
    if (!off || (!vt && s->n_tris)) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate vertex fans");
        goto done;
    }
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        off[s->tri[i] + 1]++;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        max_valence = off[v + 1] > max_valence ? off[v + 1] : max_valence;
        off[v + 1] += off[v];
    }
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i) {
        uint32_t v = s->tri[i];
        vt[off[v]++] = (int32_t)(i / 3);
    }
    for (int32_t v = s->n_verts; v > 0; --v)
        off[v] = off[v - 1];
    off[0] = 0;
    int32_t *parent = pf_alloc_array((size_t)max_valence, sizeof *parent);
    if (!parent && max_valence) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate vertex fans");
        goto done;
    }
    *n_bad = count_nonmanifold_vertices(s, off, vt, parent);
    pf_free(parent);
done:
    pf_free(off);
    pf_free(vt);
    return st;
}

pf_status pf_surface_compute_stats(const pf_surface *s, pf_surface_stats *out, pf_error *err)
{
    *out = (pf_surface_stats){.n_verts = s->n_verts, .n_tris = s->n_tris};
    for (int32_t i = 0; i < s->n_verts; ++i) {
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)i);
        PF_CHECK(pf_v3_isfinite(p), err, PF_ERR_INVALID,
                 "surface vertex %d has a non-finite coordinate", (int)i);
        out->lo = i ? pf_v3_min(out->lo, p) : p;
        out->hi = i ? pf_v3_max(out->hi, p) : p;
    }
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        PF_CHECK(s->tri[i] < (uint32_t)s->n_verts, err, PF_ERR_INVALID,
                 "surface triangle %lld references vertex %u of %d", (long long)(i / 3),
                 s->tri[i], (int)s->n_verts);
    uint64_t *keys = pf_alloc_array(3 * (size_t)s->n_tris, sizeof *keys);
    PF_CHECK(keys || s->n_tris == 0, err, PF_ERR_NOMEM, "cannot allocate surface edges");
    /* Enclosed volume by the divergence theorem, relative to the box centre for accuracy. */
    pf_vec3 c = pf_v3_scale(pf_v3_add(out->lo, out->hi), 0.5);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *v = s->tri + 3 * (size_t)t;
        pf_vec3 a = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[0]), c);
        pf_vec3 b = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[1]), c);
        pf_vec3 d = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[2]), c);
        out->volume += pf_v3_dot(a, pf_v3_cross(b, d)) / 6.0;
        out->area += 0.5 * pf_v3_norm(pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(d, a)));
        for (int k = 0; k < 3; ++k) {
            uint64_t p = v[k], q = v[(k + 1) % 3];
            keys[3 * (size_t)t + k] = ((p < q ? p << 32 | q : q << 32 | p) << 1) | (p > q);
        }
    }
    classify_edges(keys, 3 * (int64_t)s->n_tris, out);
    pf_free(keys);
    int64_t bad_vertices = 0;
    PF_TRY(vertex_fans(s, &bad_vertices, err));
    out->closed = out->n_boundary_edges == 0 && out->n_nonmanifold_edges == 0 && s->n_tris > 0;
    out->manifold = out->n_nonmanifold_edges == 0 && out->n_flipped_edges == 0 && bad_vertices == 0;
    return PF_OK;
}

void pf_surface_vertex_normals(const pf_surface *s, const double *x, double *normals)
{
    /* Each triangle adds its area vector (a - c) x (b - c) / 2 to its three vertices: the
     * area-weighted average normal, the usual choice for smooth shading of a triangle mesh. */
    if (!x)
        x = s->x;
    memset(normals, 0, 3 * (size_t)s->n_verts * sizeof *normals);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *v = s->tri + 3 * (size_t)t;
        pf_vec3 a = pf_v3_load(x + 3 * (size_t)v[0]), b = pf_v3_load(x + 3 * (size_t)v[1]);
        pf_vec3 c = pf_v3_load(x + 3 * (size_t)v[2]);
        pf_vec3 n = pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a));
        for (int k = 0; k < 3; ++k) {
            double *o = normals + 3 * (size_t)v[k];
            o[0] += n.x, o[1] += n.y, o[2] += n.z;
        }
    }
    for (int32_t i = 0; i < s->n_verts; ++i) {
        pf_vec3 n = pf_v3_normalize(pf_v3_load(normals + 3 * (size_t)i));
        normals[3 * i] = n.x, normals[3 * i + 1] = n.y, normals[3 * i + 2] = n.z;
    }
}

/* The area vectors of the triangles of one part (cap or not) added to the vertices not in skip. */
static void add_part_normals(const pf_surface *s, const double *x, bool cap, const uint8_t *skip,
                             double *normals)
{
    for (int32_t t = 0; t < s->n_tris; ++t) {
        if ((s->tri_part[t] == PF_SURFACE_CAP) != cap)
            continue;
        const uint32_t *v = s->tri + 3 * (size_t)t;
        pf_vec3 a = pf_v3_load(x + 3 * (size_t)v[0]), b = pf_v3_load(x + 3 * (size_t)v[1]);
        pf_vec3 c = pf_v3_load(x + 3 * (size_t)v[2]);
        pf_vec3 n = pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a));
        for (int k = 0; k < 3; ++k) {
            if (skip && skip[v[k]])
                continue;
            double *o = normals + 3 * (size_t)v[k];
            o[0] += n.x, o[1] += n.y, o[2] += n.z;
        }
    }
}

pf_status pf_surface_part_normals(const pf_surface *s, const double *x, double *normals,
                                  pf_error *err)
{
    if (pf_surface_count_caps(s) == 0) {
        pf_surface_vertex_normals(s, x, normals);
        return PF_OK;
    }
    if (!x)
        x = s->x;
    uint8_t *model = pf_calloc((size_t)s->n_verts + 1, 1);
    PF_CHECK(model, err, PF_ERR_NOMEM, "cannot allocate the parts of %d vertices", (int)s->n_verts);
    for (int32_t t = 0; t < s->n_tris; ++t)
        if (s->tri_part[t] != PF_SURFACE_CAP)
            for (int k = 0; k < 3; ++k)
                model[s->tri[3 * (size_t)t + (size_t)k]] = 1;
    memset(normals, 0, 3 * (size_t)s->n_verts * sizeof *normals);
    add_part_normals(s, x, false, NULL, normals);
    add_part_normals(s, x, true, model, normals);
    for (int32_t i = 0; i < s->n_verts; ++i) {
        pf_vec3 n = pf_v3_normalize(pf_v3_load(normals + 3 * (size_t)i));
        normals[3 * i] = n.x, normals[3 * i + 1] = n.y, normals[3 * i + 2] = n.z;
    }
    pf_free(model);
    return PF_OK;
}
