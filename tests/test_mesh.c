/* mesh: builders, derived adjacency and kinds, validation of every defect, stats, surfaces. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/mesh.h>

/* Two unit cubes side by side along x: [0,2]x[0,1]x[0,1], 12 nodes. */
static const double TWO_CUBES_X[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1,
                                     1, 1, 1, 0, 1, 1, 2, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1};
static const uint32_t TWO_CUBES_HEX[] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 8, 9, 2, 5, 10, 11, 6};

static void two_cubes(pf_mesh *m)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_hexes(m, TWO_CUBES_X, 12, TWO_CUBES_HEX, 2, &err), PF_OK);
}

static void teardown_check(void)
{
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void expect_invalid(const pf_mesh *m, const char *needle)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_ERR_INVALID);
    if (!strstr(err.msg, needle))
        fail_msg("message '%s' lacks '%s'", err.msg, needle);
}

static void test_hexes_share_a_face(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    assert_int_equal(m.n_faces, 11); /* 6 + 6 - 1 shared */
    assert_int_equal(m.n_elems, 2);
    pf_error err = {0};
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    assert_int_equal(m.elem_kind[0], PF_ELEM_HEX);
    assert_int_equal(m.elem_kind[1], PF_ELEM_HEX);
    int interior = 0;
    for (int32_t f = 0; f < m.n_faces; ++f)
        if (m.face_elems[2 * f] >= 0 && m.face_elems[2 * f + 1] >= 0) {
            interior++;
            assert_int_equal(m.face_elems[2 * f], 0);
            assert_int_equal(m.face_elems[2 * f + 1], 1);
        }
    assert_int_equal(interior, 1);
    pf_mesh_stats st;
    assert_int_equal(pf_mesh_compute_stats(&m, &st, &err), PF_OK);
    /* Exact: unit cubes with coordinates that are small integers. */
    assert_true(st.volume == 2.0 && st.min_volume == 1.0 && st.max_volume == 1.0);
    assert_int_equal(st.n_boundary_faces, 10);
    assert_int_equal(st.n_by_kind[PF_ELEM_HEX], 2);
    assert_true(st.hi.x == 2 && st.hi.y == 1 && st.lo.z == 0);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_inside_out_cells_are_reoriented(void **state)
{
    (void)state;
    /* The same tet given with both orientations, and a hex given upside down. */
    const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t tets[] = {0, 1, 2, 3, 0, 2, 1, 3};
    pf_mesh m;
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_tets(&m, x, 4, tets, 1, &err), PF_OK);
    assert_true(fabs(pf_mesh_elem_volume(&m, 0) - 1.0 / 6) < 1e-16);
    assert_int_equal(m.elem_kind[0], PF_ELEM_TET);
    pf_mesh_release(&m);
    assert_int_equal(pf_mesh_from_tets(&m, x, 4, tets + 4, 1, &err), PF_OK);
    assert_true(fabs(pf_mesh_elem_volume(&m, 0) - 1.0 / 6) < 1e-16);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    pf_mesh_release(&m);
    const uint32_t flipped[] = {4, 5, 6, 7, 0, 1, 2, 3};
    assert_int_equal(pf_mesh_from_hexes(&m, TWO_CUBES_X, 12, flipped, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    assert_true(pf_mesh_elem_volume(&m, 0) == 1.0);
    pf_mesh_release(&m);
    teardown_check();
}

/* A sub-mesh of chosen elements keeps the node numbering and shares its shared faces: the
 * checkerboard of a 3 x 3 x 3 box (14 of 27 cubes, touching only along edges) has no shared face;
 * a slab of 9 cubes shares the 12 faces between them. Volumes are those of the chosen cubes
 * (exact: unit cubes at integer coordinates). */
static void test_select_elements(void **state)
{
    (void)state;
    pf_mesh m = {0}, sub = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(3, 3, 3), 3, 3, 3, &err), PF_OK);
    uint8_t keep[27];
    int32_t map[27];
    for (int pass = 0; pass < 2; ++pass) {
        int32_t n_keep = 0;
        for (int32_t e = 0; e < 27; ++e) {
            /* the lowest corner's integer coordinates tell where the cube is */
            pf_vec3 lo = pf_v3(INFINITY, INFINITY, INFINITY);
            for (int64_t k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(m.elem_faces[k]);
                for (int64_t j = m.face_offsets[f]; j < m.face_offsets[f + 1]; ++j) {
                    lo = pf_v3_min(lo, pf_v3_load(m.x + 3 * (size_t)m.face_nodes[j]));
                }
            }
            int ix = (int)lo.x, iy = (int)lo.y, iz = (int)lo.z;
            keep[e] = pass == 0 ? (ix + iy + iz) % 2 == 0 : iz == 1;
            n_keep += keep[e];
        }
        assert_int_equal(n_keep, pass == 0 ? 14 : 9);
        assert_int_equal(pf_mesh_select_elements(&sub, &m, keep, map, &err), PF_OK);
        assert_int_equal(sub.n_nodes, m.n_nodes);
        assert_int_equal(sub.n_elems, n_keep);
        assert_int_equal(sub.n_faces, pass == 0 ? 14 * 6 : 9 * 6 - 12);
        assert_memory_equal(sub.x, m.x, 3 * (size_t)m.n_nodes * sizeof *m.x);
        assert_int_equal(pf_mesh_validate(&sub, NULL, &err), PF_OK);
        for (int32_t d = 0; d < sub.n_elems; ++d) {
            assert_true(keep[map[d]]);
            assert_true(d == 0 || map[d] > map[d - 1]);
            assert_true(pf_mesh_elem_volume(&sub, d) == 1.0);
        }
        pf_mesh_release(&sub);
    }
    pf_mesh_release(&m);
    teardown_check();
}

/* The Kuhn tet grid of a box: 6 tets per cell, valid (pf_mesh_validate also checks every face is
 * shared by at most two tets, so neighbouring cells cut their shared faces alike), volumes
 * summing to the box's (a few ulp per tet) and every tet 1/6 of its cell. */
static void test_box_tets(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(&m, pf_v3(-1, 0, 2), pf_v3(2, 1, 2.5), 3, 2, 4, &err),
                     PF_OK);
    assert_int_equal(m.n_elems, 6 * 3 * 2 * 4);
    assert_int_equal(m.n_nodes, 4 * 3 * 5);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    double cell = (3.0 / 3) * (1.0 / 2) * (0.5 / 4), total = 0;
    for (int32_t e = 0; e < m.n_elems; ++e) {
        assert_int_equal(m.elem_kind[e], PF_ELEM_TET);
        double v = pf_mesh_elem_volume(&m, e);
        assert_true(fabs(v - cell / 6) < 1e-14);
        total += v;
    }
    assert_true(fabs(total - 1.5) < 1e-13);
    assert_int_equal(pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 0, 1, 1, &err),
                     PF_ERR_INVALID);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_builder_rejects_bad_cells(void **state)
{
    (void)state;
    const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1};
    const uint32_t out_of_range[] = {0, 1, 2, 9};
    pf_mesh m;
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_tets(&m, x, 4, out_of_range, 1, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "node 9"));
    /* Three tets on one triangle. */
    const uint32_t fan[] = {0, 1, 2, 3, 0, 2, 1, 4, 0, 1, 2, 4};
    assert_int_equal(pf_mesh_from_tets(&m, x, 5, fan, 3, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "three or more"));
    teardown_check();
}

static void test_validate_non_finite(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    m.x[3 * 5 + 1] = NAN;
    expect_invalid(&m, "node 5 has a non-finite coordinate");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_degenerate_face(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    /* Collapse face 0 to two distinct nodes by repeating one. */
    const uint32_t *f0 = m.face_nodes;
    uint32_t keep0 = f0[0], keep1 = f0[1];
    m.face_nodes[2] = keep0;
    m.face_nodes[3] = keep1;
    expect_invalid(&m, "face 0 has 2 distinct nodes");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_non_planar(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    m.x[3 * 11 + 0] = 2.1; /* node 11 = (2,1,1) moves out of the x = 2 end face */
    expect_invalid(&m, "is not planar");
    /* A displacement at round-off level is not a bend. */
    m.x[3 * 11 + 0] = 2.0 + 1e-15;
    pf_error err = {0};
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_not_closed(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    /* Drop the face element 1 shares with element 0 (still used by 0, so no orphan face). */
    for (int64_t k = m.elem_offsets[1]; k < m.elem_offsets[2]; ++k)
        if (m.elem_faces[k] & PF_FACE_REVERSED) {
            m.elem_faces[k] = m.elem_faces[m.elem_offsets[2] - 1];
            break;
        }
    m.elem_offsets[2]--;
    expect_invalid(&m, "element 1 is not closed");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_inconsistent_orientation(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    /* Flip a boundary face of element 0 only: its use is no longer outward. */
    for (int64_t k = m.elem_offsets[0]; k < m.elem_offsets[1]; ++k) {
        int32_t f = PF_FACE_INDEX(m.elem_faces[k]);
        if (m.face_elems[2 * f + 1] < 0) {
            m.elem_faces[k] ^= PF_FACE_REVERSED;
            break;
        }
    }
    expect_invalid(&m, "element 0 is not consistently oriented");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_face_used_twice_same_way(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    /* Element 1 uses the shared face the way element 0 does. */
    for (int64_t k = m.elem_offsets[1]; k < m.elem_offsets[2]; ++k)
        if (m.elem_faces[k] & PF_FACE_REVERSED)
            m.elem_faces[k] &= ~PF_FACE_REVERSED;
    expect_invalid(&m, "used twice with the same orientation");
    pf_error err = {0};
    assert_int_equal(pf_mesh_derive(&m, &err), PF_ERR_INVALID);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_negative_volume(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    /* Turn every face of element 1 inside out: closed, consistent, but volume -1. Element 0
     * then shares the face with the same orientation, so validate element 1 alone: a one-cell
     * mesh. */
    pf_mesh_release(&m);
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_hexes(&m, TWO_CUBES_X, 12, TWO_CUBES_HEX, 1, &err), PF_OK);
    for (int64_t k = 0; k < m.elem_offsets[1]; ++k)
        m.elem_faces[k] ^= PF_FACE_REVERSED;
    expect_invalid(&m, "element 0 has non-positive volume -1");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_validate_index_out_of_range(void **state)
{
    (void)state;
    pf_mesh m;
    two_cubes(&m);
    m.face_nodes[5] = 99;
    expect_invalid(&m, "references node 99");
    pf_mesh_release(&m);
    two_cubes(&m);
    m.elem_faces[3] = 77;
    expect_invalid(&m, "references face 77");
    pf_mesh_release(&m);
    teardown_check();
}

static void test_general_polyhedron_kind(void **state)
{
    (void)state;
    /* A triangular prism: 2 triangles + 3 quads is neither tet nor hex. */
    const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1};
    const int64_t fo[] = {0, 3, 6, 10, 14, 18};
    const uint32_t fn[] = {0, 2, 1, 3, 4, 5, 0, 1, 4, 3, 1, 2, 5, 4, 2, 0, 3, 5};
    const int64_t eo[] = {0, 5};
    const uint32_t ef[] = {0, 1, 2, 3, 4};
    pf_mesh m = {.n_nodes = 6, .n_faces = 5, .n_elems = 1, .x = (double *)x,
                 .face_offsets = (int64_t *)fo, .face_nodes = (uint32_t *)fn,
                 .elem_offsets = (int64_t *)eo, .elem_faces = (uint32_t *)ef};
    pf_error err = {0};
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_classify_elem(&m, 0), PF_ELEM_POLY);
    assert_true(fabs(pf_mesh_elem_volume(&m, 0) - 0.5) < 1e-15);
    pf_mesh copy = {0};
    assert_int_equal(pf_mesh_copy(&copy, &m, &err), PF_OK);
    pf_arena arena;
    assert_int_equal(pf_arena_init(&arena, 4096, &err), PF_OK);
    pf_polyhedron p;
    assert_int_equal(pf_mesh_elem_polyhedron(&copy, 0, &arena, &p, &err), PF_OK);
    assert_int_equal(p.n_faces, 5);
    assert_int_equal(p.face_offsets[5], 18);
    pf_arena_release(&arena);
    pf_mesh_release(&copy);
    teardown_check();
}

static void test_print_is_stable(void **state)
{
    (void)state;
    const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t tet[] = {0, 1, 2, 3};
    pf_mesh m;
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_tets(&m, x, 4, tet, 1, &err), PF_OK);
    FILE *f = tmpfile();
    pf_mesh_print(&m, f);
    rewind(f);
    char text[1024] = {0};
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    assert_true(n > 0);
    const char *expected = "mesh 0: 4 nodes, 4 faces, 1 elements\n"
                           "node 0 0 0 0\nnode 1 1 0 0\nnode 2 0 1 0\nnode 3 0 0 1\n"
                           "face 0 0 2 1\nface 1 0 1 3\nface 2 0 3 2\nface 3 1 2 3\n"
                           "elem 0 tet +0 +1 +2 +3\n";
    assert_string_equal(text, expected);
    pf_mesh_release(&m);
    teardown_check();
}

/* The surface of the unit cube: 8 vertices, 12 triangles, outward. */
static const double CUBE_V[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                                0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
static const uint32_t CUBE_T[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                  1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

static void surface_stats(const double *v, int nv, const uint32_t *t, int nt,
                          pf_surface_stats *st)
{
    pf_surface s = {.n_verts = nv, .n_tris = nt, .x = (double *)v, .tri = (uint32_t *)t};
    pf_error err = {0};
    assert_int_equal(pf_surface_compute_stats(&s, st, &err), PF_OK);
}

static void test_surface_closed_cube(void **state)
{
    (void)state;
    pf_surface_stats st;
    surface_stats(CUBE_V, 8, CUBE_T, 12, &st);
    assert_true(st.closed && st.manifold);
    assert_true(fabs(st.volume - 1) < 1e-15 && fabs(st.area - 6) < 1e-14);
    /* Open: drop the last two triangles. */
    surface_stats(CUBE_V, 8, CUBE_T, 10, &st);
    assert_false(st.closed);
    assert_true(st.manifold);
    assert_int_equal(st.n_boundary_edges, 4);
    /* Flip one triangle: closed but inconsistently oriented. */
    uint32_t flipped[36];
    memcpy(flipped, CUBE_T, sizeof flipped);
    flipped[1] = CUBE_T[2];
    flipped[2] = CUBE_T[1];
    surface_stats(CUBE_V, 8, flipped, 12, &st);
    assert_true(st.closed);
    assert_false(st.manifold);
    assert_int_equal(st.n_flipped_edges, 3);
    teardown_check();
}

static void test_surface_two_cubes_touching_at_a_vertex(void **state)
{
    (void)state;
    /* The second cube is the first shifted by (1,1,1) and shares vertex 6 = (1,1,1). */
    double v[3 * 15];
    memcpy(v, CUBE_V, sizeof CUBE_V);
    uint32_t t[72];
    memcpy(t, CUBE_T, sizeof CUBE_T);
    uint32_t map[8];
    for (int i = 0, next = 8; i < 8; ++i) {
        if (i == 0) {
            map[i] = 6;
            continue;
        }
        for (int k = 0; k < 3; ++k)
            v[3 * next + k] = CUBE_V[3 * i + k] + 1;
        map[i] = (uint32_t)next++;
    }
    for (int i = 0; i < 36; ++i)
        t[36 + i] = map[CUBE_T[i]];
    pf_surface_stats st;
    surface_stats(v, 15, t, 24, &st);
    assert_true(st.closed);
    assert_false(st.manifold); /* the shared vertex has two fans */
    assert_true(fabs(st.volume - 2) < 1e-14);
    teardown_check();
}

static void test_surface_rejects_bad_indices(void **state)
{
    (void)state;
    uint32_t t[3] = {0, 1, 8};
    pf_surface s = {.n_verts = 8, .n_tris = 1, .x = (double *)CUBE_V, .tri = t};
    pf_surface_stats st;
    pf_error err = {0};
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "vertex 8"));
    teardown_check();
}

static void test_box_grid(void **state)
{
    (void)state;
    pf_mesh m;
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(-1, 0, 0), pf_v3(3, 1, 0.5), 4, 3, 2, &err), PF_OK);
    assert_int_equal(m.n_elems, 24);
    assert_int_equal(m.n_nodes, 5 * 4 * 3);
    /* Faces: (nx+1) ny nz + nx (ny+1) nz + nx ny (nz+1). */
    assert_int_equal(m.n_faces, 5 * 3 * 2 + 4 * 4 * 2 + 4 * 3 * 3);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    pf_mesh_stats st;
    assert_int_equal(pf_mesh_compute_stats(&m, &st, &err), PF_OK);
    assert_true(fabs(st.volume - 2) < 1e-14); /* 4 x 1 x 0.5, sum of 24 rounded cell volumes */
    assert_int_equal(st.n_by_kind[PF_ELEM_HEX], 24);
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 0, 1, 1, &err),
                     PF_ERR_INVALID);
    pf_mesh_release(&m);
    teardown_check();
}

static const double PI = 3.14159265358979323846;

/* Relative error of a closed generated surface's volume against the smooth solid's. */
static double torus_volume_error(int n)
{
    pf_surface s;
    pf_error err = {0};
    assert_int_equal(pf_surface_make_torus(&s, 2, 0.5, 2 * n, n, &err), PF_OK);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    assert_true(st.closed && st.manifold);
    pf_surface_release(&s);
    const double exact = 2 * PI * PI * 2 * 0.25;
    return fabs(st.volume - exact) / exact;
}

static double sphere_volume_error(int n)
{
    pf_surface s;
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1.5, n, 2 * n, &err), PF_OK);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    assert_true(st.closed && st.manifold);
    assert_true(st.volume > 0);
    pf_surface_release(&s);
    const double exact = 4.0 / 3.0 * PI * 1.5 * 1.5 * 1.5;
    return fabs(st.volume - exact) / exact;
}

static void test_generated_surfaces_converge(void **state)
{
    (void)state;
    /* Inscribed polyhedra lose volume as O(h^2): doubling the resolution divides the error by
     * about 4 (3.5..4.5 leaves room for the higher-order terms at these sizes). */
    double t1 = torus_volume_error(16), t2 = torus_volume_error(32);
    double s1 = sphere_volume_error(16), s2 = sphere_volume_error(32);
    assert_true(t1 < 0.05 && s1 < 0.05);
    assert_true(t1 / t2 > 3.5 && t1 / t2 < 4.5);
    assert_true(s1 / s2 > 3.5 && s1 / s2 < 4.5);
    teardown_check();
}

/* The flat-shaded box: each face's own four vertices, so the surface is open by its indices but
 * closed in space: volume (divergence theorem) and area are the box's to rounding, every triangle
 * faces out (positive volume), and a box with lo >= hi on an axis is refused. */
static void test_surface_box(void **state)
{
    (void)state;
    pf_surface s = {0};
    pf_error err = {0};
    assert_int_equal(pf_surface_make_box(&s, pf_v3(-1, 0, 2), pf_v3(2, 0.5, 4), &err), PF_OK);
    assert_int_equal(s.n_verts, 24);
    assert_int_equal(s.n_tris, 12);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    assert_true(fabs(st.volume - 3.0) < 1e-14);
    assert_true(fabs(st.area - 2 * (1.5 + 6 + 1)) < 1e-14);
    assert_true(st.lo.x == -1 && st.lo.y == 0 && st.lo.z == 2);
    assert_true(st.hi.x == 2 && st.hi.y == 0.5 && st.hi.z == 4);
    pf_surface_release(&s);
    assert_int_equal(pf_surface_make_box(&s, pf_v3(0, 0, 0), pf_v3(1, 0, 1), &err),
                     PF_ERR_INVALID);
    teardown_check();
}

static void test_rayscene_crossings(void **state)
{
    (void)state;
    pf_rayscene *rs = NULL;
    pf_error err = {0};
    assert_int_equal(pf_rayscene_create(&rs, CUBE_V, 8, CUBE_T, 12, &err), PF_OK);
    pf_crossing hits[8];
    int64_t n = 0;
    /* Through the open faces: enter at t = 1, leave at t = 2 (float precision inside Embree). */
    assert_int_equal(pf_rayscene_crossings(rs, pf_v3(-1, 0.3, 0.4), pf_v3(1, 0, 0), 10, 1e-6, hits,
                                           8, &n, &err),
                     PF_OK);
    assert_int_equal(n, 2);
    assert_true(fabs(hits[0].t - 1) < 1e-6 && fabs(hits[1].t - 2) < 1e-6);
    assert_int_equal(hits[0].sign, -1);
    assert_int_equal(hits[1].sign, 1);
    /* Exactly through the diagonal edges of the x = 0 and x = 1 faces: still one crossing each. */
    assert_int_equal(pf_rayscene_crossings(rs, pf_v3(-1, 0.5, 0.5), pf_v3(1, 0, 0), 10, 1e-6, hits,
                                           8, &n, &err),
                     PF_OK);
    assert_int_equal(n, 2);
    assert_true(hits[0].sign == -1 && hits[1].sign == 1);
    /* A ray that misses, and one too short to arrive. */
    assert_int_equal(pf_rayscene_crossings(rs, pf_v3(-1, 3, 0.5), pf_v3(1, 0, 0), 10, 1e-6, hits,
                                           8, &n, &err),
                     PF_OK);
    assert_int_equal(n, 0);
    assert_int_equal(pf_rayscene_crossings(rs, pf_v3(-1, 0.3, 0.4), pf_v3(1, 0, 0), 0.5, 1e-6,
                                           hits, 8, &n, &err),
                     PF_OK);
    assert_int_equal(n, 0);
    pf_rayscene_destroy(&rs);
    assert_null(rs);
    double bad[24];
    memcpy(bad, CUBE_V, sizeof bad);
    bad[4] = NAN;
    assert_int_equal(pf_rayscene_create(&rs, bad, 8, CUBE_T, 12, &err), PF_ERR_INVALID);
    teardown_check();
}

static void test_winding_number(void **state)
{
    (void)state;
    /* Closed outward surface: exactly 1 inside, 0 outside (up to round-off of atan2 sums). */
    assert_true(fabs(pf_winding_number(CUBE_V, CUBE_T, 12, pf_v3(0.3, 0.6, 0.2)) - 1) < 1e-14);
    assert_true(fabs(pf_winding_number(CUBE_V, CUBE_T, 12, pf_v3(1.3, 0.6, 0.2))) < 1e-14);
    /* The open box (no top): at the centre of the missing face's mirror, w = 1 - 1/6 by symmetry
     * (the top subtends a sixth of the sphere from the cube centre). */
    assert_true(fabs(pf_winding_number(CUBE_V, CUBE_T, 10, pf_v3(0.5, 0.5, 0.5)) - 5.0 / 6) <
                1e-14);
    teardown_check();
}

static pf_surface cube_surface(void)
{
    return (pf_surface){.n_verts = 8, .n_tris = 12, .x = (double *)CUBE_V, .tri = (uint32_t *)CUBE_T};
}

static void test_voxelize_grid_aligned_cube(void **state)
{
    (void)state;
    pf_surface s = cube_surface();
    pf_voxelize_params p = pf_voxelize_params_default();
    p.res = 4;
    for (int mode = 0; mode < 2; ++mode) {
        p.mode = (pf_voxel_mode)mode;
        pf_mesh m;
        pf_grid g;
        pf_inside_method method;
        pf_error err = {0};
        assert_int_equal(pf_mesh_voxelize(&m, &s, &p, &g, &method, &err), PF_OK);
        assert_int_equal(method, PF_INSIDE_RAYS);
        assert_true(g.h == 0.25 && g.n[0] == 4 && g.origin.x == 0);
        /* The surface lies on grid planes: exactly the 64 cells inside, in both modes (touching
         * a cell's face is not overlapping it). */
        assert_int_equal(m.n_elems, 64);
        pf_mesh_stats st;
        assert_int_equal(pf_mesh_compute_stats(&m, &st, &err), PF_OK);
        assert_true(st.volume == 1.0);
        assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
        pf_mesh_release(&m);
    }
    /* Open box: the winding number decides, with the same result. */
    s.n_tris = 10;
    p.mode = PF_VOXEL_INSIDE;
    pf_mesh m;
    pf_inside_method method;
    pf_error err = {0};
    assert_int_equal(pf_mesh_voxelize(&m, &s, &p, NULL, &method, &err), PF_OK);
    assert_int_equal(method, PF_INSIDE_WINDING);
    assert_int_equal(m.n_elems, 64);
    pf_mesh_release(&m);
    teardown_check();
}

/* Rays and the winding number are independent computations: on a closed surface they must give
 * the same cells, except centres within float precision of the surface, which none of these
 * grids has (the cell centres are at least 1e-3 h away from the surface for these parameters;
 * a disagreement would show as a count difference). */
static void check_rays_match_winding(const pf_surface *s, int32_t res)
{
    pf_surface_stats st;
    pf_error err = {0};
    assert_int_equal(pf_surface_compute_stats(s, &st, &err), PF_OK);
    pf_voxelize_params p = pf_voxelize_params_default();
    p.res = res;
    pf_grid g;
    assert_int_equal(pf_grid_fit(st.lo, st.hi, &p, &g, &err), PF_OK);
    size_t cells = (size_t)g.n[0] * g.n[1] * g.n[2];
    uint8_t *inside = pf_alloc(cells);
    pf_inside_method method;
    assert_int_equal(pf_surface_classify_cells(s, &g, inside, &method, &err), PF_OK);
    assert_int_equal(method, PF_INSIDE_RAYS);
    int64_t mismatches = 0, n_inside = 0;
    for (int32_t k = 0; k < g.n[2]; ++k)
        for (int32_t j = 0; j < g.n[1]; ++j)
            for (int32_t i = 0; i < g.n[0]; ++i) {
                pf_vec3 c = pf_v3(g.origin.x + (i + 0.5) * g.h, g.origin.y + (j + 0.5) * g.h,
                                  g.origin.z + (k + 0.5) * g.h);
                int w = pf_winding_number(s->x, s->tri, s->n_tris, c) >= 0.5;
                int r = inside[((size_t)k * g.n[1] + j) * g.n[0] + i];
                mismatches += w != r;
                n_inside += r;
            }
    assert_int_equal(mismatches, 0);
    assert_true(n_inside > 0);
    pf_free(inside);
}

static void test_voxelize_matches_winding_number(void **state)
{
    (void)state;
    pf_surface s;
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 12, 24, &err), PF_OK);
    check_rays_match_winding(&s, 16);
    pf_surface_release(&s);
    assert_int_equal(pf_surface_make_torus(&s, 1, 0.35, 24, 12, &err), PF_OK);
    check_rays_match_winding(&s, 20);
    pf_surface_release(&s);
    teardown_check();
}

static void test_voxelize_overlap_covers_surface(void **state)
{
    (void)state;
    pf_surface s;
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 16, 32, &err), PF_OK);
    pf_voxelize_params p = pf_voxelize_params_default();
    p.res = 10;
    pf_mesh inside, overlap;
    assert_int_equal(pf_mesh_voxelize(&inside, &s, &p, NULL, NULL, &err), PF_OK);
    p.mode = PF_VOXEL_OVERLAP;
    assert_int_equal(pf_mesh_voxelize(&overlap, &s, &p, NULL, NULL, &err), PF_OK);
    pf_mesh_stats a, b;
    assert_int_equal(pf_mesh_compute_stats(&inside, &a, &err), PF_OK);
    assert_int_equal(pf_mesh_compute_stats(&overlap, &b, &err), PF_OK);
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(&s, &ss, &err), PF_OK);
    /* The overlap mesh contains the solid; the inside mesh is within one cell of it. */
    assert_true(b.volume > ss.volume);
    assert_true(a.volume < b.volume);
    assert_true(b.lo.x <= ss.lo.x && b.hi.z >= ss.hi.z);
    assert_int_equal(pf_mesh_validate(&overlap, NULL, &err), PF_OK);
    pf_mesh_release(&inside);
    pf_mesh_release(&overlap);
    pf_surface_release(&s);
    teardown_check();
}

/* Strictly inside the triangle (a, b, c) of the plane, either orientation. */
static bool inside_triangle_2d(const double *a, const double *b, const double *c, double u,
                               double v)
{
    double d0 = (b[0] - a[0]) * (v - a[1]) - (b[1] - a[1]) * (u - a[0]);
    double d1 = (c[0] - b[0]) * (v - b[1]) - (c[1] - b[1]) * (u - b[0]);
    double d2 = (a[0] - c[0]) * (v - c[1]) - (a[1] - c[1]) * (u - c[0]);
    return (d0 > 0 && d1 > 0 && d2 > 0) || (d0 < 0 && d1 < 0 && d2 < 0);
}

/* Rows of cells along axis a whose centre line passes through triangle t (its shadow on the
 * plane of the other two axes). */
static int rows_through(const pf_surface *s, const uint32_t *t, const pf_grid *g, int a)
{
    int b = (a + 1) % 3, c = (a + 2) % 3;
    double p[3][2];
    for (int q = 0; q < 3; ++q)
        p[q][0] = s->x[3 * (size_t)t[q] + b], p[q][1] = s->x[3 * (size_t)t[q] + c];
    double ob = pf_v3_get(g->origin, b), oc = pf_v3_get(g->origin, c);
    int rows = 0;
    for (int32_t v = 0; v < g->n[c]; ++v)
        for (int32_t u = 0; u < g->n[b]; ++u)
            rows += inside_triangle_2d(p[0], p[1], p[2], ob + (u + 0.5) * g->h,
                                       oc + (v + 0.5) * g->h);
    return rows;
}

/* A closed sphere with one triangle taken out, the one facing -x, on the side the x rows enter
 * through: a hole about three cells across in y and z but thinner along x than the spacing of the
 * cell centres. Along every x row through it the entering crossing is missing, so that row's count
 * is wrong in every cell behind the hole (inside cells say outside, the outside beyond the far
 * side says inside); no y or z row passes through it, so the two-of-three vote of the ray test
 * still gives exactly the cells of the closed sphere. */
static void test_voxelize_rays_tolerate_a_small_hole(void **state)
{
    (void)state;
    pf_surface s;
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 16, 32, &err), PF_OK);
    pf_voxelize_params p = pf_voxelize_params_default();
    p.res = 32;
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    pf_grid g;
    assert_int_equal(pf_grid_fit(st.lo, st.hi, &p, &g, &err), PF_OK);
    size_t cells = (size_t)g.n[0] * g.n[1] * g.n[2];
    uint8_t *closed = pf_alloc(cells), *holed = pf_alloc(cells);
    assert_non_null(closed);
    assert_non_null(holed);
    pf_inside_method method;
    assert_int_equal(pf_surface_classify_cells(&s, &g, closed, &method, &err), PF_OK);
    assert_int_equal(method, PF_INSIDE_RAYS);

    /* the hole: the triangle farthest towards -x, moved to the end and dropped */
    int32_t hole = 0;
    double best = INFINITY;
    for (int32_t t = 0; t < s.n_tris; ++t) {
        double cx = 0;
        for (int q = 0; q < 3; ++q)
            cx += s.x[3 * (size_t)s.tri[3 * t + q]];
        if (cx < best)
            best = cx, hole = t;
    }
    uint32_t tri[3];
    memcpy(tri, s.tri + 3 * (size_t)hole, sizeof tri);
    memmove(s.tri + 3 * (size_t)hole, s.tri + 3 * (size_t)(hole + 1),
            3 * (size_t)(s.n_tris - hole - 1) * sizeof *s.tri);
    memcpy(s.tri + 3 * (size_t)(s.n_tris - 1), tri, sizeof tri);
    s.n_tris--;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    assert_false(st.closed);
    int rows = rows_through(&s, tri, &g, 0);
    assert_true(rows >= 2);
    assert_int_equal(rows_through(&s, tri, &g, 1), 0);
    assert_int_equal(rows_through(&s, tri, &g, 2), 0);

    assert_int_equal(pf_surface_classify_cells_by(&s, &g, PF_INSIDE_RAYS, holed, &method, &err),
                     PF_OK);
    assert_int_equal(method, PF_INSIDE_RAYS);
    int64_t differ = 0, n_inside = 0;
    for (size_t i = 0; i < cells; ++i) {
        differ += closed[i] != holed[i];
        n_inside += closed[i];
    }
    printf("sphere with a hole: %d x rows through it, %lld of %lld inside cells differ\n", rows,
           (long long)differ, (long long)n_inside);
    assert_int_equal(differ, 0);

    /* through pf_mesh_voxelize: the same count with rays chosen; auto picks the winding number */
    pf_mesh m;
    p.inside = PF_INSIDE_RAYS;
    assert_int_equal(pf_mesh_voxelize(&m, &s, &p, NULL, &method, &err), PF_OK);
    assert_int_equal(method, PF_INSIDE_RAYS);
    assert_int_equal(m.n_elems, n_inside);
    pf_mesh_release(&m);
    p.inside = PF_INSIDE_AUTO;
    assert_int_equal(pf_mesh_voxelize(&m, &s, &p, NULL, &method, &err), PF_OK);
    assert_int_equal(method, PF_INSIDE_WINDING);
    pf_mesh_release(&m);
    p.inside = (pf_inside_method)7;
    assert_int_equal(pf_mesh_voxelize(&m, &s, &p, NULL, &method, &err), PF_ERR_INVALID);

    s.n_tris++;
    pf_free(closed);
    pf_free(holed);
    pf_surface_release(&s);
    teardown_check();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hexes_share_a_face),
        cmocka_unit_test(test_inside_out_cells_are_reoriented),
        cmocka_unit_test(test_builder_rejects_bad_cells),
        cmocka_unit_test(test_validate_non_finite),
        cmocka_unit_test(test_validate_degenerate_face),
        cmocka_unit_test(test_validate_non_planar),
        cmocka_unit_test(test_validate_not_closed),
        cmocka_unit_test(test_validate_inconsistent_orientation),
        cmocka_unit_test(test_validate_face_used_twice_same_way),
        cmocka_unit_test(test_validate_negative_volume),
        cmocka_unit_test(test_validate_index_out_of_range),
        cmocka_unit_test(test_general_polyhedron_kind),
        cmocka_unit_test(test_print_is_stable),
        cmocka_unit_test(test_surface_closed_cube),
        cmocka_unit_test(test_surface_two_cubes_touching_at_a_vertex),
        cmocka_unit_test(test_surface_rejects_bad_indices),
        cmocka_unit_test(test_box_grid),
        cmocka_unit_test(test_generated_surfaces_converge),
        cmocka_unit_test(test_surface_box),
        cmocka_unit_test(test_rayscene_crossings),
        cmocka_unit_test(test_winding_number),
        cmocka_unit_test(test_voxelize_grid_aligned_cube),
        cmocka_unit_test(test_voxelize_matches_winding_number),
        cmocka_unit_test(test_voxelize_overlap_covers_surface),
        cmocka_unit_test(test_voxelize_rays_tolerate_a_small_hole),
        cmocka_unit_test(test_select_elements),
        cmocka_unit_test(test_box_tets),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
