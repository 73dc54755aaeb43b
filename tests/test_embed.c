/* embed: MLS and barycentric embedding weights.
 *
 * Oracles: affine fields (a + G x at the nodes must give a + G x at every vertex: both methods
 * reproduce them exactly, so the tolerance 1e-10 of the model size is round-off with room), the
 * closed form of barycentric coordinates in a tet (mean value coordinates equal them: four nodes
 * and linear precision leave no other choice), symmetry (the centre of a regular octahedron), the
 * closed-form slope of trilinear interpolation of x^2 (2 x_i + h in cell [x_i, x_i + h], so its
 * jump across a face is 2 h), and a brute-force count of vertices outside a voxel mesh. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "test_random.h"
#include <pf/basis.h>
#include <pf/embed.h>
#include <pf/fem.h>
#include <pf/mesh.h>

/* ---- meshes and surfaces -------------------------------------------------------------------- */

static void make_box(pf_mesh *m, int nx, int ny, int nz, double h)
{
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(nx * h, ny * h, nz * h), nx, ny, nz, &err),
        PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* n^3 cubes of edge 1/n, each split into 6 tets around its main diagonal, inner nodes jittered
 * by up to 0.15 of a cell (three draws per node, boundary nodes included, so the jitter is the
 * same whatever the builder's order of cells). */
static void make_tet_box(pf_mesh *m, int n, rng *r)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), n, n, n, &err), PF_OK);
    int nn = n + 1;
    for (int k = 0; k < nn; ++k)
        for (int j = 0; j < nn; ++j)
            for (int i = 0; i < nn; ++i) {
                double *x = m->x + 3 * (size_t)((k * nn + j) * nn + i);
                int inner = i > 0 && i < n && j > 0 && j < n && k > 0 && k < n;
                double jit = inner ? 0.15 / n : 0;
                for (int a = 0; a < 3; ++a)
                    x[a] += jit * uniform(r);
            }
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* A point cloud as a surface without triangles. */
static void make_points(pf_surface *s, int n)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_alloc(s, n, 0, &err), PF_OK);
    s->id = 7;
}

static void random_points(pf_surface *s, int n, pf_vec3 lo, pf_vec3 hi, rng *r)
{
    make_points(s, n);
    for (int i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            double l = pf_v3_get(lo, a), h = pf_v3_get(hi, a);
            s->x[3 * i + a] = l + (h - l) * uniform01(r);
        }
}

/* ---- checks ---------------------------------------------------------------------------------- */

/* Largest |displaced - (x + a + G x)| over the vertices for the nodal field u = a + G x_node,
 * relative to the model size; and the largest |row sum - 1|. */
static double affine_error(const pf_weights *w, const pf_mesh *m, const pf_surface *s, pf_mat3 g,
                           pf_vec3 a, double *unity)
{
    double *u = malloc(sizeof(double) * 3 * (size_t)m->n_nodes);
    double *out = malloc(sizeof(double) * 3 * (size_t)s->n_verts + 1);
    for (int i = 0; i < m->n_nodes; ++i)
        pf_v3_store(pf_v3_add(a, pf_m3_mulv(g, pf_v3_load(m->x + 3 * i))), u + 3 * i);
    pf_weights_apply(w, s->x, u, out);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    double size = pf_v3_dist(lo, hi), worst = 0;
    *unity = 0;
    for (int i = 0; i < s->n_verts; ++i) {
        pf_vec3 x = pf_v3_load(s->x + 3 * i);
        pf_vec3 want = pf_v3_add(x, pf_v3_add(a, pf_m3_mulv(g, x)));
        worst = fmax(worst, pf_v3_dist(want, pf_v3_load(out + 3 * i)) / size);
        double sum = 0;
        for (int64_t k = w->row_offsets[i]; k < w->row_offsets[i + 1]; ++k)
            sum += w->val[k];
        *unity = fmax(*unity, fabs(sum - 1));
    }
    free(u);
    free(out);
    return worst;
}

static pf_mat3 random_matrix(rng *r)
{
    pf_mat3 g;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            g.m[i][j] = uniform(r);
    return g;
}

/* A rotation by angle t about a unit axis, minus the identity: the displacement of a rigid
 * motion is (R - I) x + t. */
static pf_mat3 rotation_minus_identity(pf_vec3 k, double t)
{
    double c = cos(t), s = sin(t), v = 1 - c;
    pf_mat3 r = {{{c + k.x * k.x * v, k.x * k.y * v - k.z * s, k.x * k.z * v + k.y * s},
                  {k.y * k.x * v + k.z * s, c + k.y * k.y * v, k.y * k.z * v - k.x * s},
                  {k.z * k.x * v - k.y * s, k.z * k.y * v + k.x * s, c + k.z * k.z * v}}};
    return pf_m3_add(r, pf_m3_scale(pf_m3_identity(), -1));
}

/* Weights for every method (mls, bary, harmonic); rigid and random affine fields reproduced to
 * 1e-10, rows sum to 1, rows sorted and in range. */
static void check_affine(const pf_mesh *m, const pf_surface *s, pf_embed_stats *out_stats)
{
    rng r = {0x9e3779b97f4a7c15ull};
    for (int method = 0; method < 3; ++method) {
        pf_embed_params p = pf_embed_params_default();
        p.method = (pf_embed_method)method;
        pf_weights w = {0};
        pf_embed_stats st;
        pf_error err = {0};
        assert_int_equal(pf_embed_compute(m, s, &p, &w, &st, &err), PF_OK);
        assert_int_equal(w.rows, s->n_verts);
        assert_int_equal(w.cols, m->n_nodes);
        assert_true(w.surface_id == s->id && w.mesh_id == m->id);
        for (int i = 0; i < w.rows; ++i)
            for (int64_t k = w.row_offsets[i]; k < w.row_offsets[i + 1]; ++k) {
                assert_true(w.col[k] < (uint32_t)m->n_nodes);
                if (k > w.row_offsets[i])
                    assert_true(w.col[k - 1] < w.col[k]);
            }
        double unity;
        pf_mat3 rigid = rotation_minus_identity(pf_v3_normalize(pf_v3(1, 2, -0.5)), 0.7);
        double e_rigid = affine_error(&w, m, s, rigid, pf_v3(0.3, -1, 2), &unity);
        assert_true(e_rigid < 1e-10);
        assert_true(unity < 1e-12);
        for (int trial = 0; trial < 3; ++trial) {
            double e = affine_error(&w, m, s, random_matrix(&r),
                                    pf_v3(uniform(&r), uniform(&r), uniform(&r)), &unity);
            assert_true(e < 1e-10);
        }
        if (out_stats)
            out_stats[method] = st;
        pf_weights_release(&w);
    }
}

/* ---- tests ------------------------------------------------------------------------------------
 */

static void mean_value_coordinates_match_closed_forms(void **state)
{
    (void)state;
    pf_error err = {0};
    /* In a tet they are the barycentric coordinates, also close to a face and outside. */
    double x[12] = {0.1, 0, 0, 1.2, 0.1, 0, 0.2, 0.9, 0.1, 0.3, 0.2, 1.1};
    uint32_t nodes[4] = {0, 1, 2, 3};
    uint32_t tri[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2}; /* outward */
    pf_mat3 t;
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a)
            t.m[a][c] = x[3 * (c + 1) + a] - x[a];
    pf_mat3 inv = pf_m3_inverse(t, NULL);
    rng r = {12345};
    double worst = 0;
    for (int trial = 0; trial < 200; ++trial) {
        /* barycentric coordinates chosen: inside, then near face 0-1-2 (l3 -> 0), then outside */
        double l[4];
        double sum = 0;
        for (int k = 0; k < 4; ++k)
            sum += l[k] = 0.05 + uniform01(&r);
        for (int k = 0; k < 4; ++k)
            l[k] /= sum;
        if (trial >= 100 && trial < 150) {
            double d = pow(10.0, -2 - (trial % 12)); /* 1e-2 .. 1e-13 off the face */
            l[0] += l[3] - d, l[3] = d;
        } else if (trial >= 150) {
            l[0] += l[3] + 0.3, l[3] = -0.3;
        }
        pf_vec3 p = pf_v3(0, 0, 0);
        for (int k = 0; k < 4; ++k)
            p = pf_v3_add(p, pf_v3_scale(pf_v3_load(x + 3 * k), l[k]));
        double w[4];
        assert_int_equal(pf_embed_mean_value(x, tri, 4, nodes, 4, p, w, &err), PF_OK);
        pf_vec3 b = pf_m3_mulv(inv, pf_v3_sub(p, pf_v3_load(x)));
        double want[4] = {1 - b.x - b.y - b.z, b.x, b.y, b.z};
        double e = 0;
        for (int k = 0; k < 4; ++k)
            e = fmax(e, fabs(w[k] - want[k]));
        worst = fmax(worst, e);
    }
    /* round-off: the weights are corrected to reproduce affine functions exactly */
    assert_true(worst < 1e-12);

    /* The centre of a regular octahedron: 1/6 each, by symmetry. */
    double o[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    uint32_t on[6] = {0, 1, 2, 3, 4, 5};
    uint32_t ot[24] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    double w[6];
    assert_int_equal(pf_embed_mean_value(o, ot, 8, on, 6, pf_v3(0, 0, 0), w, &err), PF_OK);
    for (int k = 0; k < 6; ++k)
        assert_true(fabs(w[k] - 1.0 / 6) < 1e-15);
    /* on a face: the face's linear interpolation */
    pf_vec3 p = pf_v3(0.5, 0.3, 0.2); /* on face 0-2-4: x + y + z = 1 */
    assert_int_equal(pf_embed_mean_value(o, ot, 8, on, 6, p, w, &err), PF_OK);
    assert_true(fabs(w[0] - 0.5) < 1e-12 && fabs(w[2] - 0.3) < 1e-12 && fabs(w[4] - 0.2) < 1e-12);
}

static void affine_fields_move_embedded_points_exactly(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    rng r = {77};
    pf_mesh m = {0};
    pf_surface s = {0};
    pf_embed_stats st[3];

    make_box(&m, 4, 3, 2, 0.5); /* hexes */
    random_points(&s, 500, pf_v3(0, 0, 0), pf_v3(2, 1.5, 1), &r);
    check_affine(&m, &s, st);
    assert_int_equal(st[1].n_by_kind[PF_ELEM_HEX], 500);
    assert_int_equal(st[0].n_outside + st[1].n_outside, 0);
    /* distorted hexes: Newton's inverse of the trilinear map */
    for (int i = 0; i < m.n_nodes; ++i)
        for (int a = 0; a < 3; ++a)
            m.x[3 * i + a] += 0.06 * uniform(&r);
    check_affine(&m, &s, NULL);
    pf_surface_release(&s);
    pf_mesh_release(&m);

    make_tet_box(&m, 4, &r); /* jittered tets */
    random_points(&s, 500, pf_v3(0, 0, 0), pf_v3(1, 1, 1), &r);
    check_affine(&m, &s, st);
    assert_int_equal(st[1].n_by_kind[PF_ELEM_TET], 500);
    pf_surface_release(&s);
    pf_mesh_release(&m);

    /* A sliced sphere: hexes inside, polyhedra at the surface; the sphere itself embedded (its
     * vertices lie on the mesh boundary) and a finer one just inside. */
    pf_error err = {0};
    pf_surface sphere = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 1, 10, 20, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 5;
    assert_int_equal(pf_mesh_slice(&m, &sphere, &sp, NULL, &err), PF_OK);
    check_affine(&m, &sphere, st);
    assert_true(st[1].n_by_kind[PF_ELEM_POLY] > sphere.n_verts / 2);
    assert_int_equal(st[0].n_outside + st[1].n_outside, 0);
    assert_int_equal(st[1].n_fallback + st[2].n_fallback, 0);
    assert_true(st[2].n_harmonic > 0 && st[2].n_harmonic < m.n_elems);
    pf_surface_release(&s);
    assert_int_equal(pf_surface_make_sphere(&s, 0.97, 30, 60, &err), PF_OK);
    check_affine(&m, &s, st);
    assert_int_equal(st[1].n_fallback + st[2].n_fallback, 0);
    pf_surface_release(&s);
    pf_surface_release(&sphere);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Harmonic weights are the CG method's shape functions: those of a basis built on the whole mesh
 * at the same point. The sub-mesh of the elements holding vertices shares their faces, and face
 * and element functions depend only on their own geometry, so the two agree to round-off (1e-12
 * of the weights, which are O(1)). */
static void harmonic_weights_are_the_cg_shape_functions(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface sphere = {0}, s = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 1, 10, 20, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 4;
    assert_int_equal(pf_mesh_slice(&m, &sphere, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    assert_int_equal(pf_surface_make_sphere(&s, 0.9, 8, 16, &err), PF_OK);
    pf_embed_params p = pf_embed_params_default();
    p.method = PF_EMBED_HARMONIC;
    pf_weights w = {0};
    pf_embed_stats st;
    assert_int_equal(pf_embed_compute(&m, &s, &p, &w, &st, &err), PF_OK);
    assert_true(st.n_harmonic > 0);
    pf_basis b;
    pf_basis_params bp = pf_cg_params_default().basis; /* the uniform functions of both */
    assert_int_equal(pf_basis_create(&b, &m, &bp, &err), PF_OK);
    double *n = malloc(sizeof(double) * PF_BASIS_MAX_NODES);
    int32_t checked = 0;
    for (int32_t v = 0; v < s.n_verts; ++v) {
        pf_vec3 x = pf_v3_load(s.x + 3 * (size_t)v);
        /* the element whose functions the row holds: the one whose node set is the row's */
        int64_t a = w.row_offsets[v], len = w.row_offsets[v + 1] - a;
        for (int32_t e = 0; e < m.n_elems; ++e) {
            const int32_t *nodes;
            int32_t k = pf_basis_elem_nodes(&b, e, &nodes);
            if (pf_basis_elem_kind(&b, e) != PF_BASIS_HARMONIC || k != len)
                continue;
            bool same = true;
            for (int32_t i = 0; i < k && same; ++i) {
                bool found = false;
                for (int64_t j = a; j < a + len; ++j)
                    found = found || w.col[j] == (uint32_t)nodes[i];
                same = found;
            }
            if (!same)
                continue;
            pf_basis_eval(&b, e, x, n, NULL);
            for (int32_t i = 0; i < k; ++i)
                for (int64_t j = a; j < a + len; ++j)
                    if (w.col[j] == (uint32_t)nodes[i])
                        assert_true(fabs(w.val[j] - n[i]) < 1e-12);
            ++checked;
            break;
        }
    }
    /* most vertices of the inner sphere lie in the polyhedra of the sliced layer */
    assert_true(checked > s.n_verts / 2);
    free(n);
    pf_basis_release(&b);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_surface_release(&sphere);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* u = (x^2, 0, 0) at the nodes of a grid of cells h = 0.5; the slope d u_x / dx just left and
 * right of the interior face x = 1 at (y, z) = (0.3, 0.6). Trilinear interpolation has slopes
 * 1.5 and 2.5 (a jump of 2 h); MLS is C1, so its one-sided difference quotients differ only by
 * the curvature times the step. */
static double slope_jump(pf_embed_method method, double *left, double *right)
{
    pf_mesh m = {0};
    make_box(&m, 4, 2, 2, 0.5);
    pf_surface s = {0};
    make_points(&s, 3);
    double delta = 1e-4;
    for (int i = 0; i < 3; ++i) {
        s.x[3 * i] = 1.0 + (i - 1) * delta;
        s.x[3 * i + 1] = 0.3;
        s.x[3 * i + 2] = 0.6;
    }
    double *u = calloc(3 * (size_t)m.n_nodes, sizeof *u);
    for (int i = 0; i < m.n_nodes; ++i)
        u[3 * i] = m.x[3 * i] * m.x[3 * i];
    pf_embed_params p = pf_embed_params_default();
    p.method = method;
    pf_weights w = {0};
    pf_error err = {0};
    assert_int_equal(pf_embed_compute(&m, &s, &p, &w, NULL, &err), PF_OK);
    double out[9];
    pf_weights_apply(&w, s.x, u, out);
    double ux[3];
    for (int i = 0; i < 3; ++i)
        ux[i] = out[3 * i] - s.x[3 * i];
    *left = (ux[1] - ux[0]) / delta;
    *right = (ux[2] - ux[1]) / delta;
    free(u);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    return fabs(*right - *left);
}

static void mls_is_smooth_where_barycentric_is_not(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    double l, r;
    double bary = slope_jump(PF_EMBED_BARY, &l, &r);
    /* closed form, up to the difference quotient's round-off (1e-16 / 1e-4 ~ 1e-12) */
    assert_true(fabs(l - 1.5) < 1e-9 && fabs(r - 2.5) < 1e-9);
    assert_true(fabs(bary - 1.0) < 1e-9);
    double mls = slope_jump(PF_EMBED_MLS, &l, &r);
    /* C1: the jump of one-sided quotients is O(delta) = 1e-4 times the second derivative */
    assert_true(mls < 1e-2 * bary);
    assert_true(fabs(l - 2.0) < 0.2); /* the slope of x^2 at 1, to the fit's accuracy */
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void mls_uses_nodes_within_their_support_only(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    rng r = {4242};
    pf_mesh m = {0};
    make_tet_box(&m, 5, &r);
    pf_surface s = {0};
    random_points(&s, 400, pf_v3(0, 0, 0), pf_v3(1, 1, 1), &r);
    pf_embed_params p = pf_embed_params_default();
    double *radius = malloc(sizeof(double) * (size_t)m.n_nodes);
    pf_error err = {0};
    assert_int_equal(pf_embed_mls_radii(&m, &p, radius, &err), PF_OK);
    /* the radius is twice the longest edge at the node: at least 2 / 5 on this grid */
    for (int i = 0; i < m.n_nodes; ++i)
        assert_true(radius[i] >= 2 * 0.7 / 5 && radius[i] <= 2 * 2.0 / 5);
    pf_weights w = {0};
    pf_embed_stats st;
    assert_int_equal(pf_embed_compute(&m, &s, &p, &w, &st, &err), PF_OK);
    assert_int_equal(st.n_grown, 0);
    int64_t beyond = 0;
    for (int i = 0; i < w.rows; ++i) {
        pf_vec3 x = pf_v3_load(s.x + 3 * i);
        for (int64_t k = w.row_offsets[i]; k < w.row_offsets[i + 1]; ++k)
            beyond += pf_v3_dist(x, pf_v3_load(m.x + 3 * (size_t)w.col[k])) >= radius[w.col[k]];
        assert_true(w.row_offsets[i + 1] - w.row_offsets[i] >= 4);
    }
    assert_int_equal(beyond, 0);
    pf_weights_release(&w);

    /* A support too small for an affine fit (0.6 of the spacing misses most cube corners) grows
     * until it is well conditioned, still exact for affine fields. */
    pf_mesh_release(&m);
    make_box(&m, 3, 3, 3, 1.0 / 3);
    p.support = 0.6;
    assert_int_equal(pf_embed_compute(&m, &s, &p, &w, &st, &err), PF_OK);
    assert_true(st.n_grown > 0);
    double unity;
    double e = affine_error(&w, &m, &s, random_matrix(&r), pf_v3(1, 2, 3), &unity);
    assert_true(e < 1e-10 && unity < 1e-12);
    pf_weights_release(&w);
    free(radius);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A sphere voxelized at 6 cells: the surface pokes out of the cubes. A vertex is outside when no
 * cube (axis-aligned, so its box is the cube) holds it: brute force over all cubes. */
static void counts_vertices_outside_a_voxel_mesh(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 16, 32, &err), PF_OK);
    pf_voxelize_params vp = pf_voxelize_params_default();
    vp.res = 6;
    pf_mesh m = {0};
    pf_grid grid;
    assert_int_equal(pf_mesh_voxelize(&m, &s, &vp, &grid, NULL, &err), PF_OK);
    int32_t outside = 0;
    double tol = 1e-9 * 2 * sqrt(3.0);
    for (int i = 0; i < s.n_verts; ++i) {
        pf_vec3 x = pf_v3_load(s.x + 3 * i);
        int in = 0;
        for (int e = 0; e < m.n_elems && !in; ++e) {
            pf_polyhedron ph;
            pf_vec3 lo, hi;
            pf_arena a;
            assert_int_equal(pf_arena_init(&a, 4096, &err), PF_OK);
            assert_int_equal(pf_mesh_elem_polyhedron(&m, e, &a, &ph, &err), PF_OK);
            pf_polyhedron_bounds(&ph, &lo, &hi);
            pf_arena_release(&a);
            in = x.x >= lo.x - tol && x.x <= hi.x + tol && x.y >= lo.y - tol && x.y <= hi.y + tol &&
                 x.z >= lo.z - tol && x.z <= hi.z + tol;
        }
        outside += !in;
    }
    assert_true(outside > 0);
    pf_embed_stats st[3];
    check_affine(&m, &s, st);
    assert_int_equal(st[0].n_outside, outside);
    assert_int_equal(st[1].n_outside, outside);
    assert_true(st[1].max_outside > 0 && st[1].max_outside < grid.h * sqrt(3.0));
    pf_surface_release(&s);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void refuses_bad_input(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0}, empty = {0};
    make_box(&m, 1, 1, 1, 1);
    pf_surface s = {0};
    make_points(&s, 1);
    s.x[0] = s.x[1] = s.x[2] = 0.5;
    pf_weights w = {0};
    assert_int_equal(pf_embed_compute(&empty, &s, NULL, &w, NULL, &err), PF_ERR_INVALID);
    pf_embed_params p = pf_embed_params_default();
    p.growth = 0.5;
    assert_int_equal(pf_embed_compute(&m, &s, &p, &w, NULL, &err), PF_ERR_INVALID);
    s.x[1] = NAN;
    assert_int_equal(pf_embed_compute(&m, &s, NULL, &w, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "vertex 0"));
    assert_null(w.row_offsets);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(mean_value_coordinates_match_closed_forms),
        cmocka_unit_test(affine_fields_move_embedded_points_exactly),
        cmocka_unit_test(harmonic_weights_are_the_cg_shape_functions),
        cmocka_unit_test(mls_is_smooth_where_barycentric_is_not),
        cmocka_unit_test(mls_uses_nodes_within_their_support_only),
        cmocka_unit_test(counts_vertices_outside_a_voxel_mesh),
        cmocka_unit_test(refuses_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
