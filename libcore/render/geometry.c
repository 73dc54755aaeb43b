/* Triangle lists for drawing: the mesh boundary flat-shaded per face, surfaces smooth-shaded, the
 * embedding mat-vec, and per-node averages of element values. */
#include <pf/render.h>

#include <string.h>

void pf_render_geometry_clear(pf_render_geometry *g)
{
    g->n_verts = 0;
    g->n_tris = 0;
    g->lo = pf_v3(INFINITY, INFINITY, INFINITY);
    g->hi = pf_v3(-INFINITY, -INFINITY, -INFINITY);
}

void pf_render_geometry_release(pf_render_geometry *g)
{
    pf_free(g->verts);
    pf_free(g->tri);
    memset(g, 0, sizeof *g);
}

pf_paint pf_paint_default(void)
{
    pf_paint p = {.kind = PF_PAINT_UNIFORM};
    /* a light clay (sRGB 0.82, 0.74, 0.66) */
    p.rgb[0] = (float)pf_srgb_to_linear(0.82);
    p.rgb[1] = (float)pf_srgb_to_linear(0.74);
    p.rgb[2] = (float)pf_srgb_to_linear(0.66);
    /* caps, the inside of the material a cut shows: a warm flesh red (sRGB #cc6b57) */
    p.cap_rgb[0] = (float)pf_srgb_to_linear(204 / 255.0);
    p.cap_rgb[1] = (float)pf_srgb_to_linear(107 / 255.0);
    p.cap_rgb[2] = (float)pf_srgb_to_linear(87 / 255.0);
    return p;
}

/* Makes room for nv more vertices and nt more triangles, growing by doubling. An empty geometry
 * (never cleared) starts with an empty bounding box. */
static pf_status reserve(pf_render_geometry *g, int64_t nv, int64_t nt, pf_error *err)
{
    if (!g->verts && !g->tri && g->n_verts == 0)
        pf_render_geometry_clear(g);
    PF_CHECK(g->n_verts + nv <= (int64_t)UINT32_MAX, err, PF_ERR_TOO_LARGE,
             "%lld vertices exceed 32-bit indices", (long long)(g->n_verts + nv));
    if (g->n_verts + nv > g->cap_verts) {
        int64_t cap = g->cap_verts ? g->cap_verts : 1024;
        while (cap < g->n_verts + nv)
            cap *= 2;
        pf_render_vertex *v = pf_realloc_array(g->verts, (size_t)cap, sizeof *v);
        PF_CHECK(v, err, PF_ERR_NOMEM, "cannot allocate %lld render vertices", (long long)cap);
        g->verts = v;
        g->cap_verts = cap;
    }
    if (g->n_tris + nt > g->cap_tris) {
        int64_t cap = g->cap_tris ? g->cap_tris : 1024;
        while (cap < g->n_tris + nt)
            cap *= 2;
        uint32_t *t = pf_realloc_array(g->tri, 3 * (size_t)cap, sizeof *t);
        PF_CHECK(t, err, PF_ERR_NOMEM, "cannot allocate %lld render triangles", (long long)cap);
        g->tri = t;
        g->cap_tris = cap;
    }
    return PF_OK;
}

static void put_vertex(pf_render_geometry *g, pf_vec3 p, pf_vec3 n, const float rgb[3],
                       const float edge[3])
{
    pf_render_vertex *v = &g->verts[g->n_verts++];
    v->pos[0] = (float)p.x;
    v->pos[1] = (float)p.y;
    v->pos[2] = (float)p.z;
    v->normal[0] = (float)n.x;
    v->normal[1] = (float)n.y;
    v->normal[2] = (float)n.z;
    memcpy(v->color, rgb, sizeof v->color);
    memcpy(v->edge, edge, sizeof v->edge);
    g->lo = pf_v3_min(g->lo, p);
    g->hi = pf_v3_max(g->hi, p);
}

static void put_triangle(pf_render_geometry *g, int64_t a, int64_t b, int64_t c)
{
    uint32_t *t = g->tri + 3 * g->n_tris++;
    t[0] = (uint32_t)a;
    t[1] = (uint32_t)b;
    t[2] = (uint32_t)c;
}

static double map_value(const pf_paint *p, double v)
{
    return p->hi > p->lo ? (v - p->lo) / (p->hi - p->lo) : 0.5;
}

static pf_vec3 node_position(const pf_mesh *m, const double *u, uint32_t i)
{
    pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)i);
    return u ? pf_v3_add(x, pf_v3_load(u + 3 * (size_t)i)) : x;
}

/* Newell's normal of the displaced boundary face i, in its outward orientation. */
static pf_vec3 face_normal(const pf_mesh *m, const pf_boundary *b, const double *u, int32_t i)
{
    int32_t f = b->face[i];
    int64_t off = m->face_offsets[f];
    int64_t d = m->face_offsets[f + 1] - off;
    pf_vec3 n = pf_v3(0, 0, 0);
    for (int64_t k = 0; k < d; ++k) {
        pf_vec3 p = node_position(m, u, m->face_nodes[off + k]);
        pf_vec3 q = node_position(m, u, m->face_nodes[off + (k + 1) % d]);
        n = pf_v3_add(n,
                      pf_v3(p.y * q.z - p.z * q.y, p.z * q.x - p.x * q.z, p.x * q.y - p.y * q.x));
    }
    n = pf_v3_normalize(n);
    return b->reversed[i] ? pf_v3_scale(n, -1) : n;
}

static void face_color(const pf_mesh *m, const pf_boundary *b, const pf_paint *p, int32_t i,
                       float rgb[3])
{
    switch (p->kind) {
    case PF_PAINT_ELEM_KIND:
        pf_render_kind_color(pf_mesh_classify_elem(m, b->elem[i]), rgb);
        break;
    case PF_PAINT_ELEM_VALUE:
        pf_colormap_viridis(map_value(p, p->values[b->elem[i]]), rgb);
        break;
    default:
        memcpy(rgb, p->rgb, 3 * sizeof *rgb);
    }
}

static const float NO_WIRE[3] = {1, 1, 1};

/* One boundary face: its distinct nodes once (no wire), or three vertices per triangle carrying the
 * polygon-edge tags. */
static void add_face(pf_render_geometry *g, const pf_mesh *m, const pf_boundary *b, const double *u,
                     const pf_paint *p, int32_t i)
{
    pf_vec3 n = face_normal(m, b, u, i);
    float rgb[3];
    face_color(m, b, p, i, rgb);
    const uint32_t *t = b->tri + 3 * b->tri_offsets[i];
    int64_t nt = b->tri_offsets[i + 1] - b->tri_offsets[i];
    if (p->wire) {
        for (int64_t k = 0; k < nt; ++k) {
            uint8_t bits = b->tri_edges[b->tri_offsets[i] + k];
            int64_t v0 = g->n_verts;
            for (int c = 0; c < 3; ++c) {
                /* corner c's tag is 0 on the edge opposite it: that edge is (c+1 -> c+2), bit c+1
                 */
                float e[3] = {1, 1, 1};
                for (int j = 0; j < 3; ++j)
                    if (bits & (1u << ((j + 1) % 3)))
                        e[j] = j == c ? 1.0f : 0.0f;
                put_vertex(g, node_position(m, u, t[3 * k + c]), n, rgb, e);
            }
            put_triangle(g, v0, v0 + 1, v0 + 2);
        }
        return;
    }
    int32_t f = b->face[i];
    int64_t off = m->face_offsets[f], d = m->face_offsets[f + 1] - off;
    int64_t v0 = g->n_verts;
    for (int64_t k = 0; k < d; ++k)
        put_vertex(g, node_position(m, u, m->face_nodes[off + k]), n, rgb, NO_WIRE);
    for (int64_t k = 0; k < nt; ++k) {
        int64_t corner[3];
        for (int c = 0; c < 3; ++c) {
            int64_t j = 0;
            while (m->face_nodes[off + j] != t[3 * k + c])
                ++j;
            corner[c] = v0 + j;
        }
        put_triangle(g, corner[0], corner[1], corner[2]);
    }
}

pf_status pf_render_add_boundary(pf_render_geometry *g, const pf_mesh *m, const pf_boundary *b,
                                 const double *u, const pf_paint *p, pf_error *err)
{
    PF_CHECK(p->kind != PF_PAINT_ELEM_VALUE || p->values, err, PF_ERR_INVALID,
             "element colours need element values");
    PF_CHECK(p->kind != PF_PAINT_VERT_VALUE, err, PF_ERR_INVALID,
             "vertex values colour surfaces, not the mesh boundary");
    int64_t nt = b->tri_offsets ? b->tri_offsets[b->n_faces] : 0;
    int64_t nv = 3 * nt; /* wire: 3 per triangle; else d = nt_face + 2 <= 3 nt_face per face */
    PF_TRY(reserve(g, nv, nt, err));
    for (int32_t i = 0; i < b->n_faces; ++i)
        add_face(g, m, b, u, p, i);
    return PF_OK;
}

static bool is_cap(const pf_surface *s, int32_t t)
{
    return s->tri_part && s->tri_part[t] == PF_SURFACE_CAP;
}

static pf_vec3 triangle_normal(const pf_surface *s, const double *x, int32_t t)
{
    const uint32_t *c = s->tri + 3 * (size_t)t;
    pf_vec3 a = pf_v3_load(x + 3 * (size_t)c[0]), b = pf_v3_load(x + 3 * (size_t)c[1]);
    pf_vec3 d = pf_v3_load(x + 3 * (size_t)c[2]);
    return pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(d, a));
}

/* Area-weighted vertex normals: the sum of the (unnormalised) normals of the adjacent triangles,
 * the model's only (caps are drawn on vertices of their own). */
static void vertex_normals(const pf_surface *s, const double *x, pf_vec3 *n)
{
    for (int32_t i = 0; i < s->n_verts; ++i)
        n[i] = pf_v3(0, 0, 0);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        if (is_cap(s, t))
            continue;
        const uint32_t *c = s->tri + 3 * (size_t)t;
        pf_vec3 fn = triangle_normal(s, x, t);
        for (int k = 0; k < 3; ++k)
            n[c[k]] = pf_v3_add(n[c[k]], fn);
    }
    for (int32_t i = 0; i < s->n_verts; ++i)
        n[i] = pf_v3_normalize(n[i]);
}

static void vertex_color(const pf_paint *p, int32_t i, bool cap, float rgb[3])
{
    if (p->kind == PF_PAINT_VERT_VALUE)
        pf_colormap_viridis(map_value(p, p->values[i]), rgb);
    else
        memcpy(rgb, cap ? p->cap_rgb : p->rgb, 3 * sizeof *rgb);
}

/* Triangle t on three vertices of its own (wire tags, or a cap's flat normal and colour). */
static void put_own_triangle(pf_render_geometry *g, const pf_surface *s, const double *x,
                             const pf_vec3 *n, const pf_paint *p, int32_t t)
{
    static const float E[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    bool cap = is_cap(s, t);
    pf_vec3 flat = cap ? pf_v3_normalize(triangle_normal(s, x, t)) : pf_v3(0, 0, 0);
    int64_t v0 = g->n_verts;
    float rgb[3];
    for (int c = 0; c < 3; ++c) {
        uint32_t i = s->tri[3 * (size_t)t + (size_t)c];
        vertex_color(p, (int32_t)i, cap, rgb);
        put_vertex(g, pf_v3_load(x + 3 * (size_t)i), cap ? flat : n[i], rgb,
                   p->wire ? E[c] : NO_WIRE);
    }
    put_triangle(g, v0, v0 + 1, v0 + 2);
}

pf_status pf_render_add_surface(pf_render_geometry *g, const pf_surface *s, const double *x,
                                const pf_paint *p, pf_error *err)
{
    PF_CHECK(p->kind == PF_PAINT_UNIFORM || (p->kind == PF_PAINT_VERT_VALUE && p->values), err,
             PF_ERR_INVALID, "a surface is painted uniformly or by vertex values");
    if (!x)
        x = s->x;
    int32_t caps = pf_surface_count_caps(s);
    pf_vec3 *n = pf_alloc_array((size_t)s->n_verts + 1, sizeof *n);
    PF_CHECK(n, err, PF_ERR_NOMEM, "cannot allocate %d vertex normals", (int)s->n_verts);
    int64_t nv = p->wire ? 3 * (int64_t)s->n_tris : s->n_verts + 3 * (int64_t)caps;
    pf_status st = reserve(g, nv, s->n_tris, err);
    if (st != PF_OK) {
        pf_free(n);
        return st;
    }
    vertex_normals(s, x, n);
    if (p->wire) {
        for (int32_t t = 0; t < s->n_tris; ++t)
            put_own_triangle(g, s, x, n, p, t);
    } else {
        int64_t v0 = g->n_verts;
        float rgb[3];
        for (int32_t i = 0; i < s->n_verts; ++i) {
            vertex_color(p, i, false, rgb);
            put_vertex(g, pf_v3_load(x + 3 * (size_t)i), n[i], rgb, NO_WIRE);
        }
        for (int32_t t = 0; t < s->n_tris; ++t) {
            const uint32_t *c = s->tri + 3 * (size_t)t;
            if (is_cap(s, t))
                put_own_triangle(g, s, x, n, p, t);
            else
                put_triangle(g, v0 + c[0], v0 + c[1], v0 + c[2]);
        }
    }
    pf_free(n);
    return PF_OK;
}

pf_status pf_render_elem_to_node(const pf_mesh *m, const double *elem_values, double *node_values,
                                 pf_error *err)
{
    int32_t *stamp = pf_alloc_array((size_t)m->n_nodes + 1, sizeof *stamp);
    int32_t *count = pf_calloc((size_t)m->n_nodes + 1, sizeof *count);
    if (!stamp || !count) {
        pf_free(stamp);
        pf_free(count);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate node averages for %d nodes", (int)m->n_nodes);
    }
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        stamp[i] = -1;
        node_values[i] = 0;
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
                uint32_t i = m->face_nodes[j];
                if (stamp[i] == e)
                    continue;
                stamp[i] = e;
                node_values[i] += elem_values[e];
                count[i]++;
            }
        }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (count[i])
            node_values[i] /= count[i];
    pf_free(stamp);
    pf_free(count);
    return PF_OK;
}
