/* render: triangulation, mesh boundary, geometry, colour, camera, PNG, the OSMesa renderer.
 *
 * Also writes the test streams of the renderer's tool tests:
 *   test_render --write-beam FILE    a bent hex beam with an embedded ellipsoid (MESH, SURF, WGHT,
 *                                    two FRAM and two STRS chunks)
 *   test_render --write-mixed FILE   a row of a hex, six tets and a general polyhedron (MESH)
 */
#define _POSIX_C_SOURCE 200809L /* mkstemp, fdopen */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/io.h>
#include <pf/render.h>

static void teardown_check(void)
{
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- test data ------------------------------------------------------------------------------- */

/* Beam [0, 4] x [0, 1] x [0, 1] of 8 x 2 x 2 hexes; node (i, j, k) has index (k 3 + j) 9 + i. */
enum { BEAM_NX = 8, BEAM_NY = 2, BEAM_NZ = 2 };
static const double BEAM_L = 4;

static void make_beam(pf_mesh *m)
{
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(BEAM_L, 1, 1), BEAM_NX, BEAM_NY, BEAM_NZ, &err),
        PF_OK);
}

/* A cantilever clamped at x = 0 bent downwards: deflection w(x) = -d (x / L)^2, cross-sections
 * turned with the slope (u_x = -(z - 1/2) w'(x)), as in Euler-Bernoulli beam theory. */
static void bend(const pf_mesh *m, double d, double *u)
{
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        double x = m->x[3 * i], z = m->x[3 * i + 2];
        double w = -d * (x / BEAM_L) * (x / BEAM_L), slope = -2 * d * x / (BEAM_L * BEAM_L);
        u[3 * i] = -(z - 0.5) * slope;
        u[3 * i + 1] = 0;
        u[3 * i + 2] = w;
    }
}

/* Trilinear interpolation weights of every surface vertex in the beam's grid (exact for a box
 * grid: the hex's trilinear shape functions). */
static void trilinear_weights(const pf_mesh *m, const pf_surface *s, pf_weights *w)
{
    pf_error err = {0};
    assert_int_equal(pf_weights_alloc(w, s->n_verts, m->n_nodes, 8 * (int64_t)s->n_verts, &err),
                     PF_OK);
    w->surface_id = s->id;
    w->mesh_id = m->id;
    double h[3] = {BEAM_L / BEAM_NX, 1.0 / BEAM_NY, 1.0 / BEAM_NZ};
    int n[3] = {BEAM_NX, BEAM_NY, BEAM_NZ};
    for (int32_t v = 0; v < s->n_verts; ++v) {
        int c[3];
        double t[3];
        for (int a = 0; a < 3; ++a) {
            double q = s->x[3 * v + a] / h[a];
            c[a] = (int)floor(q);
            c[a] = c[a] < 0 ? 0 : c[a] >= n[a] ? n[a] - 1 : c[a];
            t[a] = q - c[a];
        }
        int64_t k = 8 * (int64_t)v;
        for (int corner = 0; corner < 8; ++corner, ++k) {
            int di = corner & 1, dj = (corner >> 1) & 1, dk = (corner >> 2) & 1;
            w->col[k] =
                (uint32_t)(((c[2] + dk) * (BEAM_NY + 1) + c[1] + dj) * (BEAM_NX + 1) + c[0] + di);
            w->val[k] = (di ? t[0] : 1 - t[0]) * (dj ? t[1] : 1 - t[1]) * (dk ? t[2] : 1 - t[2]);
        }
        w->row_offsets[v + 1] = k;
    }
}

/* An ellipsoid inside the beam, semi-axes 1.9 x 0.42 x 0.42 around its centre. */
static void make_ellipsoid(pf_surface *s)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(s, 1, 8, 16, &err), PF_OK);
    s->id = 1;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        s->x[3 * v] = 2 + 1.9 * s->x[3 * v];
        s->x[3 * v + 1] = 0.5 + 0.42 * s->x[3 * v + 1];
        s->x[3 * v + 2] = 0.5 + 0.42 * s->x[3 * v + 2];
    }
}

/* Bending stress of the cantilever under a tip load: sigma_xx proportional to the moment (L - x)
 * and to the distance from the neutral axis; the other components zero (von Mises = |sxx|). */
static void bending_stress(const pf_mesh *m, double scale, pf_stress_data *st, uint32_t frame)
{
    pf_error err = {0};
    assert_int_equal(pf_stress_data_alloc(st, m->n_elems, 6, &err), PF_OK);
    st->mesh_id = m->id;
    st->frame = frame;
    pf_arena arena = {0};
    assert_int_equal(pf_arena_init(&arena, 1 << 16, &err), PF_OK);
    for (int32_t e = 0; e < m->n_elems; ++e) {
        pf_polyhedron p;
        size_t mark = pf_arena_mark(&arena);
        assert_int_equal(pf_mesh_elem_polyhedron(m, e, &arena, &p, &err), PF_OK);
        pf_vec3 lo, hi;
        pf_polyhedron_bounds(&p, &lo, &hi);
        pf_arena_reset(&arena, mark);
        double xc = 0.5 * (lo.x + hi.x), zc = 0.5 * (lo.z + hi.z);
        double *v = st->values + 6 * (size_t)e;
        memset(v, 0, 6 * sizeof *v);
        v[0] = scale * (BEAM_L - xc) * (0.5 - zc);
    }
    pf_arena_release(&arena);
}

static void write_beam(FILE *f)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_surface s = {0};
    pf_weights w = {0};
    pf_frame_data fr = {0};
    pf_stress_data st = {0};
    make_beam(&m);
    m.id = 1;
    make_ellipsoid(&s);
    trilinear_weights(&m, &s, &w);
    assert_int_equal(pf_frame_data_alloc(&fr, m.n_nodes, &err), PF_OK);
    fr.mesh_id = m.id;
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "beam", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    assert_int_equal(pf_stream_write_surface(wr, &s, &err), PF_OK);
    assert_int_equal(pf_stream_write_weights(wr, &w, &err), PF_OK);
    for (uint32_t k = 0; k < 2; ++k) {
        fr.index = k;
        fr.time = 0.1 * k;
        bend(&m, 0.6 * k, fr.u);
        assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
        bending_stress(&m, 1e6 * k, &st, k);
        assert_int_equal(pf_stream_write_stress(wr, &st, &err), PF_OK);
        pf_stress_data_release(&st);
    }
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_frame_data_release(&fr);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_mesh_release(&m);
}

/* Merges elements a < b that share face f into one polyhedron (f dropped, left unused). */
static void merge_elements(pf_mesh *m, int32_t a, int32_t b)
{
    int64_t n = m->elem_offsets[m->n_elems];
    uint32_t *faces = pf_alloc_array((size_t)n, sizeof *faces);
    int64_t *offsets = pf_alloc_array((size_t)m->n_elems, sizeof *offsets);
    assert_non_null(faces);
    assert_non_null(offsets);
    int64_t k = 0;
    int32_t ne = 0;
    offsets[0] = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        if (e == b)
            continue;
        int32_t parts[2] = {e, b};
        for (int q = 0; q < (e == a ? 2 : 1); ++q)
            for (int64_t j = m->elem_offsets[parts[q]]; j < m->elem_offsets[parts[q] + 1]; ++j) {
                uint32_t face = (uint32_t)PF_FACE_INDEX(m->elem_faces[j]);
                bool shared = false;
                int32_t other = parts[q] == a ? b : a;
                for (int64_t i = m->elem_offsets[other]; i < m->elem_offsets[other + 1]; ++i)
                    shared |= e == a && (uint32_t)PF_FACE_INDEX(m->elem_faces[i]) == face;
                if (!shared)
                    faces[k++] = m->elem_faces[j];
            }
        offsets[++ne] = k;
    }
    pf_free(m->elem_faces);
    pf_free(m->elem_offsets);
    m->elem_faces = faces;
    m->elem_offsets = offsets;
    m->n_elems = ne;
}

/* Four unit cubes along x: a hex, the Kuhn split of a cube into six tets around its diagonal
 * 0-6, and two hexes merged into one 2 x 1 x 1 polyhedron (10 faces, 12 nodes). */
static void make_mixed(pf_mesh *m)
{
    double x[3 * 20];
    for (int i = 0; i < 20; ++i) {
        x[3 * i] = i % 5;
        x[3 * i + 1] = (i / 5) % 2;
        x[3 * i + 2] = i / 10;
    }
#define N(i, j, k) ((uint32_t)((k)*10 + (j)*5 + (i)))
#define HEX(i)                                                                                     \
    N(i, 0, 0), N(i + 1, 0, 0), N(i + 1, 1, 0), N(i, 1, 0), N(i, 0, 1), N(i + 1, 0, 1),            \
        N(i + 1, 1, 1), N(i, 1, 1)
    uint32_t c1[8] = {HEX(1)};
    static const int KUHN[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                   {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    uint32_t cells[8 + 24 + 16] = {HEX(0)};
    for (int t = 0; t < 6; ++t)
        for (int q = 0; q < 4; ++q)
            cells[8 + 4 * t + q] = c1[KUHN[t][q]];
    uint32_t tail[16] = {HEX(2), HEX(3)};
    memcpy(cells + 32, tail, sizeof tail);
#undef HEX
#undef N
    int64_t offsets[10] = {0, 8, 12, 16, 20, 24, 28, 32, 40, 48};
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_cells(m, x, 20, offsets, cells, 9, &err), PF_OK);
    merge_elements(m, 7, 8);
    m->id = 1;
}

static void write_mixed(FILE *f)
{
    pf_error err = {0};
    pf_mesh m = {0};
    make_mixed(&m);
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "mixed", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_mesh_release(&m);
}

/* ---- triangulation and boundary ------------------------------------------------------------- */

static double tri_area_normal(const double *x, const uint32_t *idx, const uint32_t *t, pf_vec3 n)
{
    pf_vec3 a = pf_v3_load(x + 3 * idx[t[0]]), b = pf_v3_load(x + 3 * idx[t[1]]);
    pf_vec3 c = pf_v3_load(x + 3 * idx[t[2]]);
    return 0.5 * pf_v3_dot(pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a)), n);
}

/* Every triangle counter-clockwise about the polygon's normal (area >= 0) and the areas adding up
 * to the polygon's: together they mean the triangles tile the polygon without overlap. */
static void check_triangulation(const double *x, const uint32_t *idx, int32_t n)
{
    pf_error err = {0};
    pf_arena arena = {0};
    assert_int_equal(pf_arena_init(&arena, 4096, &err), PF_OK);
    uint32_t tri[3 * 16];
    uint8_t edges[16];
    assert_int_equal(pf_polygon_triangulate(x, idx, n, &arena, tri, edges, &err), PF_OK);
    assert_int_equal(arena.top, 0);
    pf_vec3 an = pf_polygon_area_vector(x, idx, n);
    double area = pf_v3_norm(an), sum = 0;
    pf_vec3 unit = pf_v3_normalize(an);
    int polygon_edges = 0;
    for (int t = 0; t < n - 2; ++t) {
        double a = tri_area_normal(x, idx, tri + 3 * t, unit);
        /* round-off of a cross product of O(1) coordinates: 1e-15 */
        assert_true(a > -1e-15);
        sum += a;
        for (int b = 0; b < 3; ++b)
            polygon_edges += (edges[t] >> b) & 1;
    }
    /* sums of O(n) products of O(1) numbers */
    assert_true(fabs(sum - area) < 1e-13);
    assert_int_equal(polygon_edges, n); /* every polygon edge in exactly one triangle */
    pf_arena_release(&arena);
}

static void test_triangulate_convex(void **state)
{
    (void)state;
    static const double X[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 1.5, 0};
    static const uint32_t QUAD[] = {0, 1, 2, 3}, PENT[] = {0, 1, 2, 4, 3};
    check_triangulation(X, QUAD, 4);
    check_triangulation(X, PENT, 5);
    teardown_check();
}

/* A comb (non-convex, 10 vertices) in a tilted plane, both orientations: a fan from vertex 0
 * would cover area outside it, so the area check fails for anything but a correct tiling. */
static void test_triangulate_nonconvex(void **state)
{
    (void)state;
    static const double UV[10][2] = {{0, 0}, {5, 0}, {5, 3}, {4, 3}, {4, 1},
                                     {3, 1}, {3, 3}, {2, 3}, {2, 1}, {0, 1}};
    double x[30];
    /* the plane spanned by (1, 0, 1) / sqrt 2 and (0, 1, 0), offset */
    for (int i = 0; i < 10; ++i) {
        x[3 * i] = 0.5 + UV[i][0] / sqrt(2.0);
        x[3 * i + 1] = -1 + UV[i][1];
        x[3 * i + 2] = 2 + UV[i][0] / sqrt(2.0);
    }
    uint32_t idx[10], rev[10];
    for (uint32_t i = 0; i < 10; ++i) {
        idx[i] = i;
        rev[i] = 9 - i;
    }
    check_triangulation(x, idx, 10);
    check_triangulation(x, rev, 10);
    /* starting the polygon at a reflex vertex */
    uint32_t rot[10];
    for (uint32_t i = 0; i < 10; ++i)
        rot[i] = (i + 4) % 10;
    check_triangulation(x, rot, 10);
    teardown_check();
}

/* Boundary of a 3 x 2 x 2 box grid: 2 (3*2 + 2*2 + 3*2) = 32 quads, 64 triangles, enclosing the
 * box's volume (divergence theorem: V = sum over triangles of a . (b x c) / 6, outward). */
static void test_boundary_box(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_boundary b = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(-1, 0, 2), pf_v3(2, 2, 4), 3, 2, 2, &err), PF_OK);
    assert_int_equal(pf_boundary_extract(&m, &b, &err), PF_OK);
    assert_int_equal(b.n_faces, 32);
    assert_int_equal(b.tri_offsets[b.n_faces], 64);
    double volume = 0;
    for (int64_t t = 0; t < 64; ++t) {
        pf_vec3 p[3];
        for (int c = 0; c < 3; ++c)
            p[c] = pf_v3_load(m.x + 3 * b.tri[3 * t + c]);
        volume += pf_v3_dot(p[0], pf_v3_cross(p[1], p[2])) / 6;
    }
    /* 3 x 2 x 2 = 12, to round-off of O(1) sums */
    assert_true(fabs(volume - 12) < 1e-12);
    pf_boundary_release(&b);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_boundary_mixed(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_boundary b = {0};
    pf_error err = {0};
    make_mixed(&m);
    assert_int_equal(m.n_elems, 8);
    assert_int_equal(pf_mesh_classify_elem(&m, 0), PF_ELEM_HEX);
    assert_int_equal(pf_mesh_classify_elem(&m, 3), PF_ELEM_TET);
    assert_int_equal(pf_mesh_classify_elem(&m, 7), PF_ELEM_POLY);
    assert_int_equal(pf_boundary_extract(&m, &b, &err), PF_OK);
    /* the outer surface of [0,4]x[0,1]x[0,1] plus the quad and the two triangles at x = 1 and
     * x = 2 where the tets meet the hexes non-conformingly (hidden inside) */
    double outward = 0;
    for (int64_t t = 0; t < b.tri_offsets[b.n_faces]; ++t) {
        pf_vec3 p[3];
        for (int c = 0; c < 3; ++c)
            p[c] = pf_v3_load(m.x + 3 * b.tri[3 * t + c]);
        outward += pf_v3_dot(p[0], pf_v3_cross(p[1], p[2])) / 6;
    }
    /* The hidden pairs at x = 1 and x = 2 each enclose zero volume (the same square both ways),
     * so the total is the solid's volume 4; small integer coordinates: exact. */
    assert_true(fabs(outward - 4) < 1e-13);
    pf_boundary_release(&b);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_boundary_bad_face(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_boundary b = {0};
    pf_error err = {0};
    make_beam(&m);
    m.elem_faces[3] = (uint32_t)m.n_faces + 5;
    assert_int_equal(pf_boundary_extract(&m, &b, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "element 0 refers to face"));
    assert_null(b.face);
    pf_mesh_release(&m);
    teardown_check();
}

/* ---- geometry -------------------------------------------------------------------------------- */

static void test_geometry_wire_tags(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_boundary b = {0};
    pf_render_geometry g = {0};
    pf_error err = {0};
    make_beam(&m);
    assert_int_equal(pf_boundary_extract(&m, &b, &err), PF_OK);
    pf_paint p = pf_paint_default();
    p.kind = PF_PAINT_ELEM_KIND;
    p.wire = true;
    assert_int_equal(pf_render_add_boundary(&g, &m, &b, NULL, &p, &err), PF_OK);
    int64_t nt = b.tri_offsets[b.n_faces];
    assert_int_equal(g.n_tris, nt);
    assert_int_equal(g.n_verts, 3 * nt);
    /* each triangle of a quad has two polygon edges (tag 0 at the opposite corner) and hides the
     * diagonal (tag 1 at all three corners) */
    for (int64_t t = 0; t < nt; ++t) {
        int hidden = 0;
        for (int k = 0; k < 3; ++k) {
            const pf_render_vertex *v = &g.verts[g.tri[3 * t]];
            const pf_render_vertex *w = &g.verts[g.tri[3 * t + 1]];
            const pf_render_vertex *z = &g.verts[g.tri[3 * t + 2]];
            hidden += v->edge[k] == 1 && w->edge[k] == 1 && z->edge[k] == 1;
        }
        assert_int_equal(hidden, 1);
    }
    float hex[3];
    pf_render_kind_color(PF_ELEM_HEX, hex);
    assert_memory_equal(g.verts[0].color, hex, sizeof hex);
    /* the box's bounding box */
    assert_true(g.lo.x == 0 && g.lo.y == 0 && g.lo.z == 0 && g.hi.x == 4 && g.hi.z == 1);
    pf_render_geometry_release(&g);
    pf_boundary_release(&b);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_weights_apply(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_surface s = {0};
    pf_weights w = {0};
    make_beam(&m);
    make_ellipsoid(&s);
    trilinear_weights(&m, &s, &w);
    double *u = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *u);
    double *out = pf_alloc_array(3 * (size_t)s.n_verts, sizeof *out);
    /* trilinear interpolation reproduces affine fields: u(x) = A x + c */
    for (int32_t i = 0; i < m.n_nodes; ++i) {
        const double *x = m.x + 3 * i;
        u[3 * i] = 0.1 * x[0] - 0.2 * x[2] + 0.3;
        u[3 * i + 1] = 0.05 * x[1];
        u[3 * i + 2] = -0.4 * x[0] + 0.01;
    }
    pf_weights_apply(&w, s.x, u, out);
    for (int32_t v = 0; v < s.n_verts; ++v) {
        const double *x = s.x + 3 * v;
        /* sums of 8 products of O(1) numbers: 1e-14 */
        assert_true(fabs(out[3 * v] - (x[0] + 0.1 * x[0] - 0.2 * x[2] + 0.3)) < 1e-14);
        assert_true(fabs(out[3 * v + 1] - (x[1] + 0.05 * x[1])) < 1e-14);
        assert_true(fabs(out[3 * v + 2] - (x[2] - 0.4 * x[0] + 0.01)) < 1e-14);
    }
    /* and constants through the scalar form */
    double *nv = pf_alloc_array((size_t)m.n_nodes, sizeof *nv), *sv = out;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        nv[i] = 2.5;
    pf_weights_apply_scalar(&w, nv, sv);
    for (int32_t v = 0; v < s.n_verts; ++v)
        assert_true(fabs(sv[v] - 2.5) < 1e-14);
    pf_free(nv);
    pf_free(u);
    pf_free(out);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_elem_to_node(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    double ev[2] = {1, 3}, nv[12];
    assert_int_equal(pf_render_elem_to_node(&m, ev, nv, &err), PF_OK);
    for (int32_t i = 0; i < 12; ++i) {
        double x = m.x[3 * i];
        double want = x == 0 ? 1 : x == 1 ? 2 : 3;
        assert_true(nv[i] == want);
    }
    pf_mesh_release(&m);
    teardown_check();
}

/* ---- colour ---------------------------------------------------------------------------------- */

static void test_srgb(void **state)
{
    (void)state;
    assert_int_equal(pf_linear_to_srgb8(0), 0);
    assert_int_equal(pf_linear_to_srgb8(1), 255);
    assert_int_equal(pf_linear_to_srgb8(-3), 0);
    /* linear 0.5 is sRGB 0.7354 (IEC 61966-2-1): code 188 */
    assert_int_equal(pf_linear_to_srgb8(0.5), 188);
    /* every 8-bit code survives decode + encode */
    for (int k = 0; k < 256; ++k)
        assert_int_equal(pf_linear_to_srgb8(pf_srgb_to_linear(k / 255.0)), k);
    /* the two branches meet continuously at the break point */
    assert_true(fabs(pf_linear_to_srgb(0.0031308) - 0.0404500) < 1e-6);
    teardown_check();
}

static double luminance(const float c[3])
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static void test_viridis(void **state)
{
    (void)state;
    float a[3], b[3];
    pf_colormap_viridis(0, a);
    /* viridis(0) = sRGB (0.267004, 0.004874, 0.329415); float storage: 1e-6 */
    assert_true(fabs(a[0] - pf_srgb_to_linear(0.267004)) < 1e-6);
    assert_true(fabs(a[2] - pf_srgb_to_linear(0.329415)) < 1e-6);
    pf_colormap_viridis(1, b);
    assert_true(fabs(b[1] - pf_srgb_to_linear(0.906157)) < 1e-6);
    pf_colormap_viridis(NAN, b);
    assert_memory_equal(a, b, sizeof a);
    /* lightness increases monotonically: the property that makes the map readable */
    double prev = -1;
    for (int i = 0; i <= 200; ++i) {
        pf_colormap_viridis(i / 200.0, a);
        assert_true(luminance(a) > prev);
        prev = luminance(a);
    }
    teardown_check();
}

/* ---- camera ---------------------------------------------------------------------------------- */

static void project(const double vp[16], pf_vec3 p, double *x, double *y, double *w)
{
    double q[4];
    for (int r = 0; r < 4; ++r)
        q[r] = vp[r] * p.x + vp[4 + r] * p.y + vp[8 + r] * p.z + vp[12 + r];
    *x = q[0] / q[3];
    *y = q[1] / q[3];
    *w = q[3];
}

/* The fitted camera keeps every corner of the box within margin of the image half-size and
 * touches that bound with at least one corner (the smallest such distance). */
static void test_camera_fit(void **state)
{
    (void)state;
    pf_vec3 lo = pf_v3(-1, 2, 0.5), hi = pf_v3(3, 2.5, 1.5);
    double aspect = 16.0 / 9.0, margin = 0.9;
    pf_camera c = pf_camera_fit(lo, hi, pf_v3(0, 0, 1), 35, aspect, margin);
    pf_error err = {0};
    assert_int_equal(pf_camera_check(&c, &err), PF_OK);
    double view[16], proj[16], vp[16];
    pf_camera_matrices(&c, aspect, 0.1, 100, view, proj);
    for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) {
            vp[4 * col + row] = 0;
            for (int k = 0; k < 4; ++k)
                vp[4 * col + row] += proj[4 * k + row] * view[4 * col + k];
        }
    double widest = 0;
    for (int k = 0; k < 8; ++k) {
        pf_vec3 p = pf_v3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        double x, y, w;
        project(vp, p, &x, &y, &w);
        assert_true(w > 0);
        widest = fmax(widest, fmax(fabs(x), fabs(y)));
    }
    /* a few ulps of the trigonometry and the 4x4 products */
    assert_true(widest <= margin + 1e-12);
    assert_true(widest >= margin - 1e-12);
    /* the target is the box centre, projected to the image centre */
    double x, y, w;
    project(vp, pf_v3(1, 2.25, 1), &x, &y, &w);
    assert_true(fabs(x) < 1e-12 && fabs(y) < 1e-12);
    teardown_check();
}

static void expect_camera_error(const char *json, pf_status code, const char *needle)
{
    pf_camera c;
    pf_error err = {0};
    assert_int_equal(pf_camera_parse_json(json, &c, &err), code);
    if (!strstr(err.msg, needle))
        fail_msg("message '%s' lacks '%s'", err.msg, needle);
}

static void test_camera_json(void **state)
{
    (void)state;
    pf_camera c;
    pf_error err = {0};
    assert_int_equal(pf_camera_parse_json(" { \"eye\": [1, 2.5, -3e0], \"target\":[0,0,0],"
                                          "\"fov\": 50 }\n",
                                          &c, &err),
                     PF_OK);
    assert_true(c.eye.x == 1 && c.eye.y == 2.5 && c.eye.z == -3 && c.fov_deg == 50);
    assert_true(c.up.z == 1 && c.up.x == 0);
    expect_camera_error("{\"eye\": [1,2,3]}", PF_ERR_FORMAT, "\"eye\" and \"target\" are required");
    expect_camera_error("{\"eye\": [1,2,3], \"target\": [0,0,0], \"zoom\": 2}", PF_ERR_FORMAT,
                        "unknown key \"zoom\"");
    expect_camera_error("{\"eye\": [1,2,3], \"eye\": [1,2,3]}", PF_ERR_FORMAT, "given twice");
    expect_camera_error("{\"eye\": [1,2], \"target\": [0,0,0]}", PF_ERR_FORMAT,
                        "expected ',' at offset 12");
    expect_camera_error("{\"eye\": [1,2,nan], \"target\": [0,0,0]}", PF_ERR_FORMAT,
                        "expected a number");
    expect_camera_error("{\"eye\": [1,2,3], \"target\": [0,0,0]} x", PF_ERR_FORMAT,
                        "unexpected text at offset 36");
    expect_camera_error("{\"eye\": [0,0,3], \"target\": [0,0,0]}", PF_ERR_INVALID,
                        "parallel to the view direction");
    expect_camera_error("{\"eye\": [1,0,3], \"target\": [1,0,3]}", PF_ERR_INVALID, "coincide");
    expect_camera_error("{\"eye\": [1,0,3], \"target\": [0,0,0], \"fov\": 180}", PF_ERR_INVALID,
                        "fov must lie in (0, 180)");
    teardown_check();
}

/* ---- PNG ------------------------------------------------------------------------------------- */

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char *buf = pf_alloc(1 << 20);
    assert_non_null(buf);
    *n = fread(buf, 1, 1 << 20, f);
    fclose(f);
    return buf;
}

static bool contains(const unsigned char *buf, size_t n, const char *tag)
{
    for (size_t i = 0; i + 4 <= n; ++i)
        if (memcmp(buf + i, tag, 4) == 0)
            return true;
    return false;
}

static void test_png_round_trip(void **state)
{
    (void)state;
    char path[] = "/tmp/pf_test_render_png_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    fclose(fdopen(fd, "w"));
    enum { W = 37, H = 23 };
    uint8_t rgb[3 * W * H], rgba[4 * W * H];
    uint32_t state32 = 12345;
    for (size_t i = 0; i < sizeof rgba; ++i) {
        state32 = state32 * 1664525u + 1013904223u; /* LCG: reproducible noise */
        rgba[i] = (uint8_t)(state32 >> 24);
        if (i < sizeof rgb)
            rgb[i] = rgba[i];
    }
    pf_error err = {0};
    pf_image img = {0};
    assert_int_equal(pf_png_write(path, rgb, W, H, 3, &err), PF_OK);
    size_t n1, n2;
    unsigned char *a = slurp(path, &n1);
    assert_int_equal(pf_png_read(path, &img, &err), PF_OK);
    assert_true(img.width == W && img.height == H && img.channels == 4);
    for (size_t i = 0; i < (size_t)W * H; ++i) {
        assert_memory_equal(img.pixels + 4 * i, rgb + 3 * i, 3);
        assert_int_equal(img.pixels[4 * i + 3], 255);
    }
    pf_image_release(&img);
    /* determinism: the same pixels give the same bytes; no time stamp, the sRGB chunk */
    assert_int_equal(pf_png_write(path, rgb, W, H, 3, &err), PF_OK);
    unsigned char *b = slurp(path, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    assert_false(contains(a, n1, "tIME"));
    assert_true(contains(a, n1, "sRGB"));
    pf_free(a);
    pf_free(b);
    assert_int_equal(pf_png_write(path, rgba, W, H, 4, &err), PF_OK);
    assert_int_equal(pf_png_read(path, &img, &err), PF_OK);
    assert_memory_equal(img.pixels, rgba, sizeof rgba);
    pf_image_release(&img);
    /* not a PNG, missing, bad sizes */
    FILE *f = fopen(path, "wb");
    fputs("not a png", f);
    fclose(f);
    assert_int_equal(pf_png_read(path, &img, &err), PF_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "not a readable PNG"));
    assert_null(img.pixels);
    remove(path);
    assert_int_equal(pf_png_read(path, &img, &err), PF_ERR_IO);
    assert_int_equal(pf_png_write(path, rgb, 0, H, 3, &err), PF_ERR_INVALID);
    assert_int_equal(pf_png_write("/nonexistent-dir/x.png", rgb, W, H, 3, &err), PF_ERR_IO);
    assert_non_null(strstr(err.msg, "cannot create"));
    teardown_check();
}

/* ---- renderer -------------------------------------------------------------------------------- */

static const uint8_t *pixel(const uint8_t *rgb, int w, int x, int y)
{
    return rgb + 3 * ((size_t)y * (size_t)w + (size_t)x);
}

/* A unit cube seen straight from above at distance 4.5 from its top face: the top face spans
 * 0.5 / 4.5 / tan(20 deg) = 0.305 of the image half-width around the centre, +-9.8 of the 32
 * pixels (the side faces turn away from the eye). Pixels well inside are the cube, pixels well
 * outside the background. */
static void test_renderer_silhouette(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_boundary b = {0};
    pf_render_geometry g = {0};
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box(&m, pf_v3(-0.5, -0.5, -0.5), pf_v3(0.5, 0.5, 0.5), 1, 1, 1, &err), PF_OK);
    assert_int_equal(pf_boundary_extract(&m, &b, &err), PF_OK);
    pf_paint p = pf_paint_default();
    assert_int_equal(pf_render_add_boundary(&g, &m, &b, NULL, &p, &err), PF_OK);
    g.closed = true;
    pf_render_params rp = pf_render_params_default();
    rp.width = rp.height = 64;
    pf_renderer *r = NULL;
    assert_int_equal(pf_renderer_create(&r, &rp, &err), PF_OK);
    pf_render_view v = pf_render_view_default(g.lo, g.hi, 1);
    v.ground = false;
    v.camera = (pf_camera){
        .eye = pf_v3(0, 0, 5), .target = pf_v3(0, 0, 0), .up = pf_v3(0, 1, 0), .fov_deg = 40};
    uint8_t rgb[3 * 64 * 64], again[3 * 64 * 64];
    assert_int_equal(pf_renderer_draw(r, &g, &v, rgb, &err), PF_OK);
    const uint8_t *corner = pixel(rgb, 64, 0, 0), *center = pixel(rgb, 64, 32, 32);
    /* background: sRGB (0.86, 0.88, 0.91) -> codes 219, 224, 232, within one level of the GPU's
     * approximate power function */
    assert_true(abs(corner[0] - 219) <= 1 && abs(corner[1] - 224) <= 1 &&
                abs(corner[2] - 232) <= 1);
    for (int k = 0; k < 64; ++k) { /* an inner and an outer ring of pixels */
        int in = 25 + (k % 15);
        assert_memory_not_equal(pixel(rgb, 64, in, 25), corner, 3);
        assert_memory_not_equal(pixel(rgb, 64, 39, in), corner, 3);
        assert_memory_equal(pixel(rgb, 64, 18, k), corner, 3);
        assert_memory_equal(pixel(rgb, 64, 46, k), corner, 3);
        assert_memory_equal(pixel(rgb, 64, k, 18), corner, 3);
        assert_memory_equal(pixel(rgb, 64, k, 46), corner, 3);
    }
    /* the top face is lit: brighter than black, and uniform (flat shading, no shadow) */
    assert_true(center[0] > 60);
    assert_memory_equal(pixel(rgb, 64, 30, 30), pixel(rgb, 64, 34, 34), 3);
    /* the same scene again gives the same bytes */
    assert_int_equal(pf_renderer_draw(r, &g, &v, again, &err), PF_OK);
    assert_memory_equal(rgb, again, sizeof rgb);
    pf_renderer_destroy(&r);
    assert_null(r);
    pf_render_geometry_release(&g);
    pf_boundary_release(&b);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_renderer_checks(void **state)
{
    (void)state;
    pf_render_params rp = pf_render_params_default();
    pf_renderer *r = NULL;
    pf_error err = {0};
    rp.width = 0;
    assert_int_equal(pf_renderer_create(&r, &rp, &err), PF_ERR_INVALID);
    rp = pf_render_params_default();
    rp.samples = 3;
    assert_int_equal(pf_renderer_create(&r, &rp, &err), PF_ERR_INVALID);
    assert_null(r);
    rp = pf_render_params_default();
    rp.width = 16;
    rp.height = 8;
    assert_int_equal(pf_renderer_create(&r, &rp, &err), PF_OK);
    pf_render_geometry g = {0};
    pf_render_view v = pf_render_view_default(pf_v3(0, 0, 0), pf_v3(1, 1, 1), 2);
    v.camera.eye = v.camera.target;
    uint8_t rgb[3 * 16 * 8];
    assert_int_equal(pf_renderer_draw(r, &g, &v, rgb, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "coincide"));
    /* an empty scene draws the ground alone */
    v = pf_render_view_default(pf_v3(0, 0, 0), pf_v3(1, 1, 1), 2);
    assert_int_equal(pf_renderer_draw(r, &g, &v, rgb, &err), PF_OK);
    pf_renderer_destroy(&r);
    teardown_check();
}

static void test_legend(void **state)
{
    (void)state;
    enum { W = 160, H = 120 };
    uint8_t rgb[3 * W * H];
    memset(rgb, 255, sizeof rgb);
    pf_render_draw_legend(rgb, W, H, 0, 2.5e6);
    /* the bar: x in [W - 10, W - 4), y in [30, 90); bottom row viridis(0), top row viridis(1) */
    float lin[3];
    pf_colormap_viridis(0, lin);
    const uint8_t *bottom = pixel(rgb, W, W - 7, 89), *top = pixel(rgb, W, W - 7, 30);
    for (int c = 0; c < 3; ++c)
        assert_int_equal(bottom[c], pf_linear_to_srgb8(lin[c]));
    pf_colormap_viridis(1, lin);
    for (int c = 0; c < 3; ++c)
        assert_int_equal(top[c], pf_linear_to_srgb8(lin[c]));
    /* some dark text pixels left of the bar */
    int dark = 0;
    for (int y = 20; y < 100; ++y)
        for (int x = W - 70; x < W - 12; ++x)
            dark += pixel(rgb, W, x, y)[0] < 100;
    assert_true(dark > 30);
    teardown_check();
}

static int write_stream(const char *what, const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f) {
        perror(path);
        return 1;
    }
    if (strcmp(what, "--write-beam") == 0)
        write_beam(f);
    else
        write_mixed(f);
    return fclose(f) == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 3 &&
        (strcmp(argv[1], "--write-beam") == 0 || strcmp(argv[1], "--write-mixed") == 0))
        return write_stream(argv[1], argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_triangulate_convex),
        cmocka_unit_test(test_triangulate_nonconvex),
        cmocka_unit_test(test_boundary_box),
        cmocka_unit_test(test_boundary_mixed),
        cmocka_unit_test(test_boundary_bad_face),
        cmocka_unit_test(test_geometry_wire_tags),
        cmocka_unit_test(test_weights_apply),
        cmocka_unit_test(test_elem_to_node),
        cmocka_unit_test(test_srgb),
        cmocka_unit_test(test_viridis),
        cmocka_unit_test(test_camera_fit),
        cmocka_unit_test(test_camera_json),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_renderer_silhouette),
        cmocka_unit_test(test_renderer_checks),
        cmocka_unit_test(test_legend),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
