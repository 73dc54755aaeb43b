/* The boundary of the solid a surface's winding number defines, as a closed manifold surface.
 *
 * The winding number w is sampled at the nodes of a lattice; a node is inside where w >= 1/2.
 * Every lattice cube is split into the six tetrahedra around its diagonal from the lowest to the
 * highest corner (Kuhn), which tile space conformingly, and each tetrahedron whose corners are not
 * all on one side contributes the triangle or quadrilateral separating them (marching
 * tetrahedra). The result is the zero set of a piecewise-linear function with no zero at a node,
 * hence closed, edge- and vertex-manifold and free of self-intersections whatever the input was.
 *
 * Where the input is a clean boundary, w jumps across it and the contour vertex of a lattice edge
 * is placed where the edge crosses the input (the crossing that leaves the solid, nearest to the
 * linear estimate), so the contour lies on the input surface there; across a hole w is smooth and
 * the vertex is its linear interpolation at 1/2. Vertices are kept within [0.05, 0.95] of their
 * edge: triangles then have no zero angle (the slicer's tolerance is 1e-10 of the model), at the
 * price of moving a vertex by up to 5% of a lattice edge. */
#include <pf/mesh.h>

#include <math.h>
#include <string.h>

static const double T_MIN = 0.05;

/* The 7 lattice edges leaving a node upwards, by the bit pattern dx | dy << 1 | dz << 2. */
static const int8_t EDGE_OF_PATTERN[8] = {-1, 0, 1, 3, 2, 4, 5, 6};

typedef struct contour {
    const pf_surface *s;
    const pf_rayscene *rs;
    pf_vec3 origin;
    double h;
    int32_t n[3];
    const double *w;   /* [nodes] winding numbers */
    const uint8_t *in; /* [nodes] inside flags */
    int32_t *vert;     /* [7 nodes] contour vertex of each edge, -1 none yet */
    pf_buffer x;       /* double[3 nv] */
    pf_buffer tri;     /* uint32[3 nt] */
    int32_t nv;
    pf_crossing hits[64];
    pf_winding_contour_stats *stats;
} contour;

static size_t node_index(const contour *c, const int32_t p[3])
{
    return ((size_t)p[2] * c->n[1] + p[1]) * c->n[0] + p[0];
}

static pf_vec3 node_position(const contour *c, const int32_t p[3])
{
    return pf_v3(c->origin.x + p[0] * c->h, c->origin.y + p[1] * c->h, c->origin.z + p[2] * c->h);
}

/* Parameter along the edge from the inside node a to the outside node b where the contour
 * crosses it (see the header comment). */
static pf_status crossing_parameter(contour *c, pf_vec3 a, pf_vec3 b, double wa, double wb,
                                    double *t, pf_error *err)
{
    double linear = (wa - 0.5) / (wa - wb);
    int64_t n = 0;
    PF_TRY(pf_rayscene_crossings(c->rs, a, pf_v3_sub(b, a), 1.0, 1e-9, c->hits, 64, &n, err));
    int best = -1;
    for (int pass = 0; pass < 2 && best < 0; ++pass)
        for (int64_t k = 0; k < n && k < 64; ++k) {
            if (pass == 0 && c->hits[k].sign <= 0)
                continue;
            if (best < 0 || fabs(c->hits[k].t - linear) < fabs(c->hits[best].t - linear))
                best = (int)k;
        }
    *t = best >= 0 ? c->hits[best].t : linear;
    if (best >= 0)
        c->stats->on_surface++;
    else
        c->stats->interpolated++;
    *t = fmin(fmax(*t, T_MIN), 1 - T_MIN);
    return PF_OK;
}

/* The contour vertex on the lattice edge between nodes p and q (adjacent in the Kuhn tiling). */
static pf_status edge_vertex(contour *c, const int32_t p[3], const int32_t q[3], uint32_t *out,
                             pf_error *err)
{
    const int32_t *lo = p, *hi = q;
    if (q[0] < p[0] || q[1] < p[1] || q[2] < p[2])
        lo = q, hi = p;
    int pattern = (hi[0] - lo[0]) | (hi[1] - lo[1]) << 1 | (hi[2] - lo[2]) << 2;
    size_t key = 7 * node_index(c, lo) + (size_t)EDGE_OF_PATTERN[pattern];
    if (c->vert[key] < 0) {
        const int32_t *a = c->in[node_index(c, p)] ? p : q, *b = a == p ? q : p;
        pf_vec3 pa = node_position(c, a), pb = node_position(c, b);
        double t;
        PF_TRY(
            crossing_parameter(c, pa, pb, c->w[node_index(c, a)], c->w[node_index(c, b)], &t, err));
        double x[3];
        pf_v3_store(pf_v3_add(pa, pf_v3_scale(pf_v3_sub(pb, pa), t)), x);
        PF_TRY(pf_buffer_append(&c->x, x, sizeof x, err));
        PF_CHECK(c->nv < INT32_MAX, err, PF_ERR_TOO_LARGE, "contour of too many vertices");
        c->vert[key] = c->nv++;
    }
    *out = (uint32_t)c->vert[key];
    return PF_OK;
}

/* Orientation of the tetrahedron (a, b, c, d) of lattice points: the sign of its volume, exact
 * in integers. */
static int orientation(const int32_t *a, const int32_t *b, const int32_t *c, const int32_t *d)
{
    int64_t u[3], v[3], w[3];
    for (int i = 0; i < 3; ++i)
        u[i] = b[i] - a[i], v[i] = c[i] - a[i], w[i] = d[i] - a[i];
    int64_t det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                  u[2] * (v[0] * w[1] - v[1] * w[0]);
    return (det > 0) - (det < 0);
}

static pf_status emit(contour *c, uint32_t a, uint32_t b, uint32_t d, bool swap, pf_error *err)
{
    uint32_t t[3] = {a, swap ? d : b, swap ? b : d};
    return pf_buffer_append(&c->tri, t, sizeof t, err);
}

/* Marching tetrahedra on one tetrahedron v[4] of lattice points. For a positive tetrahedron
 * (v0, v1, v2, v3), the triangle on the edges from v0 in the order v1, v2, v3 faces away from v0,
 * and with v0, v1 inside and v2, v3 outside the quadrilateral on edges 02, 03, 13, 12 faces
 * outward; other cases are permutations of these, their parity read from the orientation. */
static pf_status march_tet(contour *c, const int32_t v[4][3], pf_error *err)
{
    int in[4], n_in = 0;
    for (int k = 0; k < 4; ++k)
        n_in += in[k] = c->in[node_index(c, v[k])];
    if (n_in == 0 || n_in == 4)
        return PF_OK;
    if (n_in == 1 || n_in == 3) {
        int lone = 0;
        while (in[lone] == (n_in == 3))
            ++lone;
        int o[3], m = 0;
        for (int k = 0; k < 4; ++k)
            if (k != lone)
                o[m++] = k;
        uint32_t e[3];
        for (int k = 0; k < 3; ++k)
            PF_TRY(edge_vertex(c, v[lone], v[o[k]], &e[k], err));
        bool away = orientation(v[lone], v[o[0]], v[o[1]], v[o[2]]) > 0;
        /* outward: away from a lone inside corner, towards a lone outside one */
        return emit(c, e[0], e[1], e[2], away != (n_in == 1), err);
    }
    int ins[2], outs[2], ni = 0, no = 0;
    for (int k = 0; k < 4; ++k) {
        if (in[k])
            ins[ni++] = k;
        else
            outs[no++] = k;
    }
    uint32_t ac, ad, bd, bc;
    PF_TRY(edge_vertex(c, v[ins[0]], v[outs[0]], &ac, err));
    PF_TRY(edge_vertex(c, v[ins[0]], v[outs[1]], &ad, err));
    PF_TRY(edge_vertex(c, v[ins[1]], v[outs[1]], &bd, err));
    PF_TRY(edge_vertex(c, v[ins[1]], v[outs[0]], &bc, err));
    bool swap = orientation(v[ins[0]], v[ins[1]], v[outs[0]], v[outs[1]]) < 0;
    PF_TRY(emit(c, ac, ad, bd, swap, err));
    return emit(c, ac, bd, bc, swap, err);
}

static pf_status march(contour *c, pf_error *err)
{
    static const int PERM[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                   {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int32_t k = 0; k + 1 < c->n[2]; ++k)
        for (int32_t j = 0; j + 1 < c->n[1]; ++j)
            for (int32_t i = 0; i + 1 < c->n[0]; ++i) {
                int32_t base[3] = {i, j, k}, hi[3] = {i + 1, j + 1, k + 1};
                int mixed = 0;
                for (int q = 0; q < 8; ++q) {
                    int32_t p[3] = {i + (q & 1), j + (q >> 1 & 1), k + (q >> 2)};
                    mixed += c->in[node_index(c, p)];
                }
                if (mixed == 0 || mixed == 8)
                    continue;
                for (int t = 0; t < 6; ++t) {
                    int32_t v[4][3];
                    memcpy(v[0], base, sizeof base);
                    memcpy(v[1], base, sizeof base);
                    v[1][PERM[t][0]]++;
                    memcpy(v[2], v[1], sizeof base);
                    v[2][PERM[t][1]]++;
                    memcpy(v[3], hi, sizeof hi);
                    PF_TRY(march_tet(c, (const int32_t(*)[3])v, err));
                }
            }
    return PF_OK;
}

/* Winding numbers at every node; the outer layer of the lattice counts as outside so that the
 * contour closes inside it. */
static pf_status sample(contour *c, double *w, uint8_t *in, pf_error *err)
{
    pf_winding_tree *wt = NULL;
    PF_TRY(pf_winding_tree_create(&wt, c->s->x, c->s->n_verts, c->s->tri, c->s->n_tris, err));
    for (int32_t k = 0; k < c->n[2]; ++k)
        for (int32_t j = 0; j < c->n[1]; ++j)
            for (int32_t i = 0; i < c->n[0]; ++i) {
                int32_t p[3] = {i, j, k};
                size_t id = node_index(c, p);
                bool border = i == 0 || j == 0 || k == 0 || i == c->n[0] - 1 || j == c->n[1] - 1 ||
                              k == c->n[2] - 1;
                w[id] = border ? 0 : pf_winding_tree_eval(wt, node_position(c, p));
                in[id] = w[id] >= 0.5;
                c->stats->inside_nodes += in[id];
            }
    pf_winding_tree_destroy(&wt);
    return PF_OK;
}

pf_status pf_surface_winding_contour(const pf_surface *s, pf_vec3 origin, double h,
                                     const int32_t n[3], pf_surface *out,
                                     pf_winding_contour_stats *stats, pf_error *err)
{
    memset(out, 0, sizeof *out);
    pf_winding_contour_stats local;
    contour c = {
        .s = s, .origin = origin, .h = h, .n = {n[0], n[1], n[2]}, .stats = stats ? stats : &local};
    memset(c.stats, 0, sizeof *c.stats);
    double t0 = pf_time_seconds();
    PF_CHECK(h > 0 && isfinite(h) && pf_v3_isfinite(origin), err, PF_ERR_INVALID,
             "contour lattice needs a finite origin and spacing > 0");
    PF_CHECK(n[0] >= 2 && n[1] >= 2 && n[2] >= 2, err, PF_ERR_INVALID,
             "contour lattice needs at least 2 nodes along each axis");
    double total = (double)n[0] * n[1] * n[2];
    PF_CHECK(total <= (double)(1 << 27), err, PF_ERR_TOO_LARGE,
             "contour lattice of %d x %d x %d nodes (at most 2^27): use a larger cell", (int)n[0],
             (int)n[1], (int)n[2]);
    size_t nodes = (size_t)total;
    double *w = pf_alloc_array(nodes, sizeof *w);
    uint8_t *in = pf_alloc(nodes);
    c.vert = pf_alloc_array(7 * nodes, sizeof *c.vert);
    pf_rayscene *rs = NULL;
    pf_status st = PF_OK;
    if (!w || !in || !c.vert)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "out of memory for a contour lattice of %zu nodes", nodes);
    if (st >= 0)
        st = pf_rayscene_create(&rs, s->x, s->n_verts, s->tri, s->n_tris, err);
    c.rs = rs, c.w = w, c.in = in;
    if (st >= 0)
        st = sample(&c, w, in, err);
    if (st >= 0) {
        for (size_t i = 0; i < 7 * nodes; ++i)
            c.vert[i] = -1;
        st = march(&c, err);
    }
    int64_t nt = (int64_t)(c.tri.size / (3 * sizeof(uint32_t)));
    if (st >= 0 && nt == 0)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "no lattice node is inside the surface (winding number >= 1/2 nowhere "
                          "at spacing %g): use a smaller cell",
                          h);
    if (st >= 0 && nt > INT32_MAX)
        st = pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__,
                          "contour of too many triangles");
    if (st >= 0)
        st = pf_surface_alloc(out, c.nv, (int32_t)nt, err);
    if (st >= 0) {
        memcpy(out->x, c.x.data, 3 * (size_t)c.nv * sizeof(double));
        memcpy(out->tri, c.tri.data, 3 * (size_t)nt * sizeof(uint32_t));
        out->id = s->id;
        c.stats->n_tris = (int32_t)nt;
    }
    pf_rayscene_destroy(&rs);
    pf_buffer_release(&c.x);
    pf_buffer_release(&c.tri);
    pf_free(w), pf_free(in), pf_free(c.vert);
    c.stats->seconds = pf_time_seconds() - t0;
    return st;
}
