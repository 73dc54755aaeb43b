/* mesh: hexahedral slicing against the acceptance of the meshing issue.
 *
 * The elements partition the solid exactly: their volumes (exact for planar faces) sum to the
 * surface's enclosed volume up to rounding, a few ulp per element times the element count, so
 * 1e-9 relative is a loose bound that only a lost or doubled piece can break (the smallest
 * piece kept is 5 % of a cell, far above 1e-9 of the solid). Every element is valid, the mesh is
 * conforming at face level (pf_mesh_derive accepts it: no face used by more than two elements),
 * its boundary faces are exactly the surface's area, and no element is below the merge
 * threshold unless it touches no other element. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/mesh.h>

#include "test_surfaces.h"

/* Slices and checks every acceptance property; returns the element count. */
static int32_t slice_and_check(const char *name, const pf_surface *s, pf_slice_params p)
{
    pf_error err = {0};
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(s, &ss, &err), PF_OK);
    pf_mesh m = {0};
    pf_slice_stats st;
    if (pf_mesh_slice(&m, s, &p, &st, &err) != PF_OK)
        fail_msg("%s: %s", name, err.msg);
    if (pf_mesh_validate(&m, NULL, &err) != PF_OK)
        fail_msg("%s: invalid mesh: %s", name, err.msg);
    double volume = 0, smallest = INFINITY, boundary_area = 0;
    for (int32_t e = 0; e < m.n_elems; ++e) {
        double v = pf_mesh_elem_volume(&m, e);
        volume += v;
        smallest = fmin(smallest, v);
    }
    for (int32_t f = 0; f < m.n_faces; ++f)
        if (m.face_elems[2 * f] < 0 || m.face_elems[2 * f + 1] < 0)
            boundary_area += pf_polygon_area(m.x, m.face_nodes + m.face_offsets[f],
                                             m.face_offsets[f + 1] - m.face_offsets[f]);
    double cell = st.grid.h * st.grid.h * st.grid.h;
    printf("%-12s %5d elements (%d hexes, %d polyhedra), volume error %.1e, area error %.1e, "
           "smallest %.3f cells, %d merged, %.3f s\n",
           name, (int)m.n_elems, (int)st.kinds[PF_ELEM_HEX], (int)st.kinds[PF_ELEM_POLY],
           fabs(volume / ss.volume - 1), fabs(boundary_area / ss.area - 1), smallest / cell,
           (int)st.merged, st.seconds);
    if (!(fabs(volume / ss.volume - 1) < 1e-9))
        fail_msg("%s: element volumes %.17g, surface %.17g", name, volume, ss.volume);
    if (!(fabs(boundary_area / ss.area - 1) < 1e-9))
        fail_msg("%s: boundary area %.17g, surface %.17g", name, boundary_area, ss.area);
    if (st.isolated_slivers == 0 && !(smallest >= p.merge * cell))
        fail_msg("%s: an element of %.3g cells remains below the merge threshold", name,
                 smallest / cell);
    int32_t n = m.n_elems;
    pf_mesh_release(&m);
    return n;
}

static void slices_spheres_and_tori(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface s = {0};
    pf_slice_params p = pf_slice_params_default();
    assert_int_equal(pf_surface_make_sphere(&s, 1, 24, 48, &err), PF_OK);
    for (int res = 2; res <= 16; res *= 2) {
        p.grid.res = res;
        slice_and_check("sphere", &s, p);
    }
    pf_surface_release(&s);
    /* a torus: cutting planes through its hole give caps with holes */
    assert_int_equal(pf_surface_make_torus(&s, 1, 0.35, 48, 24, &err), PF_OK);
    for (int res = 3; res <= 12; res *= 2) {
        p.grid.res = res;
        slice_and_check("torus", &s, p);
    }
    p.grid.res = 8;
    p.merge = 0; /* no merging: every piece is kept, down to the thinnest sliver */
    slice_and_check("torus,merge0", &s, p);
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A cube whose faces lie exactly on grid planes: surface faces on cutting planes, and every cell
 * a hex-shaped piece (its boundary faces are the surface's triangles). */
static void slices_a_grid_aligned_cube(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_surface s = {0};
    add_box(&s, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1});
    pf_slice_params p = pf_slice_params_default();
    p.grid.cell = 0.25;
    p.grid.has_origin = true;
    p.grid.origin = (pf_vec3){0, 0, 0};
    assert_int_equal(slice_and_check("cube", &s, p), 64);
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A plate thinner than a cell, and two separate bodies in one surface. */
static void slices_thin_and_separate_bodies(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface s = {0};
    add_box(&s, (pf_vec3){-1, -1, -0.02}, (pf_vec3){1.3, 1.1, 0.03});
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 7;
    slice_and_check("thin plate", &s, p);
    pf_surface_release(&s);

    pf_surface sphere = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 0.5, 12, 24, &err), PF_OK);
    add_box(&s, (pf_vec3){0, 0, 0}, (pf_vec3){1, 0.7, 0.4});
    translate(&sphere, (pf_vec3){2.1, 0.3, 0.2});
    append(&s, &sphere);
    p.grid.res = 10;
    slice_and_check("two bodies", &s, p);
    pf_surface_release(&sphere);
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void refuses_open_surfaces(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_surface s = {0};
    add_box(&s, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1});
    s.n_tris -= 2; /* a missing face */
    pf_mesh m = {0};
    pf_error err = {0};
    pf_slice_params p = pf_slice_params_default();
    p.robust = false; /* the robust mode slices it (test_robust.c) */
    assert_int_equal(pf_mesh_slice(&m, &s, &p, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "closed"));
    s.n_tris += 2;
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* FNV-1a over bytes, chained. */
static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *c = data;
    for (size_t i = 0; i < n; ++i) {
        h ^= c[i];
        h *= 1099511628211ull;
    }
    return h;
}

/* Hash of every array of a mesh: node coordinates bit for bit, faces and elements in order. */
static uint64_t mesh_hash(const pf_mesh *m)
{
    uint64_t h = 1469598103934665603ull;
    h = fnv1a(h, m->x, 3 * (size_t)m->n_nodes * sizeof *m->x);
    h = fnv1a(h, m->face_offsets, ((size_t)m->n_faces + 1) * sizeof *m->face_offsets);
    h = fnv1a(h, m->face_nodes, (size_t)m->face_offsets[m->n_faces] * sizeof *m->face_nodes);
    h = fnv1a(h, m->elem_offsets, ((size_t)m->n_elems + 1) * sizeof *m->elem_offsets);
    h = fnv1a(h, m->elem_faces, (size_t)m->elem_offsets[m->n_elems] * sizeof *m->elem_faces);
    return h;
}

/* The mesh of two fixed cases, pinned bit for bit (counts, then a hash of every array): a change
 * that only makes slicing faster must leave them as they are. The slicer is deterministic (one
 * global plane order, -ffp-contract=off, no threads), so the hash is exact, not approximate. A
 * deliberate change of the output (another merge rule, node order) updates these numbers. */
static void pins_the_output_of_fixed_cases(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    static const struct {
        const char *name;
        int32_t res, nodes, faces, elems, merged;
        int64_t splits;
        uint64_t hash;
    } cases[] = {
        {"sphere", 8, 2917, 4868, 360, 48, 407, 0x23db1d8b9e17a5e8ull},
        {"torus", 6, 1984, 3248, 56, 8, 61, 0x3a7ec00019c04a73ull},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        pf_error err = {0};
        pf_surface s = {0};
        if (c == 0)
            assert_int_equal(pf_surface_make_sphere(&s, 1, 24, 48, &err), PF_OK);
        else
            assert_int_equal(pf_surface_make_torus(&s, 1, 0.35, 48, 24, &err), PF_OK);
        pf_slice_params p = pf_slice_params_default();
        p.grid.res = cases[c].res;
        pf_mesh m = {0};
        pf_slice_stats st;
        if (pf_mesh_slice(&m, &s, &p, &st, &err) != PF_OK)
            fail_msg("%s: %s", cases[c].name, err.msg);
        uint64_t h = mesh_hash(&m);
        printf("%-8s res %d: %d nodes, %d faces, %d elements, %d merged, %lld splits, hash "
               "%016llx\n",
               cases[c].name, (int)cases[c].res, (int)m.n_nodes, (int)m.n_faces, (int)m.n_elems,
               (int)st.merged, (long long)st.splits, (unsigned long long)h);
        assert_int_equal(m.n_nodes, cases[c].nodes);
        assert_int_equal(m.n_faces, cases[c].faces);
        assert_int_equal(m.n_elems, cases[c].elems);
        assert_int_equal(st.merged, cases[c].merged);
        assert_int_equal(st.splits, cases[c].splits);
        assert_true(h == cases[c].hash);
        pf_mesh_release(&m);
        pf_surface_release(&s);
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(slices_spheres_and_tori),
        cmocka_unit_test(slices_a_grid_aligned_cube),
        cmocka_unit_test(slices_thin_and_separate_bodies),
        cmocka_unit_test(refuses_open_surfaces),
        cmocka_unit_test(pins_the_output_of_fixed_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
