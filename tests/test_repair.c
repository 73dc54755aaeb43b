/* pf_surface_repair on surfaces with known answers: a sphere missing one face gets that face
 * back (its volume to the bit of the closed sphere's, up to summation order), a sphere missing a
 * polar cap gets the flat polygon (volume: the sphere's minus the cap's, both by the divergence
 * theorem; area: the polygon's), a cube with a duplicated face or a face doubled the other way
 * round is the cube again, two cubes sharing a face become their union, and a hole over the size
 * limit is left open and reported. Each repaired surface is closed and manifold and slices
 * exactly (the exact mode, which refuses open surfaces) to its own volume. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/mesh.h>

#include "test_surfaces.h"

static double volume_of(const pf_surface *s, double *area)
{
    pf_error err = {0};
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(s, &st, &err), PF_OK);
    if (area)
        *area = st.area;
    return st.volume;
}

/* Repairs s with the default parameters (or max_hole >= 0), checks it closed and manifold. */
static pf_surface_repair_report repair(pf_surface *s, double max_hole)
{
    pf_error err = {0};
    pf_surface_repair_params p = pf_surface_repair_params_default();
    if (max_hole >= 0)
        p.max_hole = max_hole;
    pf_surface_repair_report r;
    if (pf_surface_repair(s, &p, &r, &err) != PF_OK)
        fail_msg("%s", err.msg);
    return r;
}

/* The exact slice (robust mode off) of a repaired surface: valid, with the surface's volume. */
static void slices_exactly(const pf_surface *s, double volume)
{
    pf_error err = {0};
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 8;
    p.robust = false;
    pf_mesh m = {0};
    if (pf_mesh_slice(&m, s, &p, NULL, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    double v = pf_mesh_volume(&m);
    assert_true(fabs(v / volume - 1) < 1e-9);
    pf_mesh_release(&m);
}

static void remove_triangle(pf_surface *s, int32_t t)
{
    memmove(s->tri + 3 * (size_t)t, s->tri + 3 * (size_t)(t + 1),
            3 * (size_t)(s->n_tris - t - 1) * sizeof *s->tri);
    s->n_tris--;
}

static void sphere_missing_a_face(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 12, 24, &err), PF_OK);
    double full = volume_of(&s, NULL);
    remove_triangle(&s, 100);
    pf_surface_repair_report r = repair(&s, -1);
    assert_int_equal(r.holes, 1);
    assert_int_equal(r.holes_filled, 1);
    assert_int_equal(r.fill_triangles, 1);
    assert_true(r.closed);
    assert_int_equal(r.orient.flipped_faces, 0);
    double v = volume_of(&s, NULL);
    printf("sphere missing a face: volume %.17g, closed sphere %.17g\n", v, full);
    assert_true(fabs(v / full - 1) < 1e-14);
    slices_exactly(&s, v);
    pf_surface_release(&s);
}

/* Two faces sharing one corner removed: two holes touching at a vertex, whose boundary walk may
 * pass that vertex twice; each is filled by its face again. */
static void holes_touching_at_a_vertex(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 12, 24, &err), PF_OK);
    double full = volume_of(&s, NULL);
    const uint32_t *a = s.tri + 3 * 100;
    int32_t other = -1;
    for (int32_t t = 101; t < s.n_tris && other < 0; ++t) {
        int shared = 0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                shared += a[i] == s.tri[3 * (size_t)t + j];
        if (shared == 1)
            other = t;
    }
    assert_true(other > 100);
    remove_triangle(&s, other);
    remove_triangle(&s, 100);
    pf_surface_repair_report r = repair(&s, -1);
    assert_int_equal(r.holes, 2);
    assert_int_equal(r.holes_filled, 2);
    assert_int_equal(r.fill_triangles, 2);
    assert_true(r.closed);
    assert_true(fabs(volume_of(&s, NULL) / full - 1) < 1e-14);
    pf_surface_release(&s);
}

/* The triangles with every corner above z0 removed from a 16 x 32 sphere: a hole of 32 edges on
 * the latitude circle, planar and convex. */
static void sphere_missing_a_cap(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 16, 32, &err), PF_OK);
    double full = volume_of(&s, NULL);
    const double z0 = 0.9; /* between the latitudes of the first two bands' lower circles */
    double cap = 0;        /* the removed triangles' signed volume about the origin */
    int32_t n = 0;
    double ring_z = 1;
    for (int32_t t = 0; t < s.n_tris; ++t) {
        const uint32_t *c = s.tri + 3 * (size_t)t;
        bool above = true;
        for (int k = 0; k < 3; ++k) {
            above &= s.x[3 * (size_t)c[k] + 2] > z0;
            if (s.x[3 * (size_t)c[k] + 2] > z0 && s.x[3 * (size_t)c[k] + 2] < ring_z &&
                s.x[3 * (size_t)c[k] + 2] < 0.99999)
                ring_z = s.x[3 * (size_t)c[k] + 2];
        }
        if (above) {
            pf_vec3 p[3];
            for (int k = 0; k < 3; ++k)
                p[k] = pf_v3_load(s.x + 3 * (size_t)c[k]);
            cap += pf_v3_dot(p[0], pf_v3_cross(p[1], p[2])) / 6;
            continue;
        }
        memmove(s.tri + 3 * (size_t)n++, c, 3 * sizeof *c);
    }
    s.n_tris = n;
    /* the flat 32-gon closing the cap, on the circle of radius rho at height ring_z: the cone
     * from the origin over it has volume area * ring_z / 3 */
    const double PI = 3.14159265358979323846;
    double rho = sqrt(1 - ring_z * ring_z), polygon = 0.5 * 32 * rho * rho * sin(2 * PI / 32);
    double expected = full - (cap - polygon * ring_z / 3);
    double area_before;
    volume_of(&s, &area_before);
    /* its perimeter, 2.4, is 0.69 of the diagonal: above the default limit of 0.5 */
    pf_surface_repair_report r = repair(&s, 1);
    assert_int_equal(r.holes, 1);
    assert_int_equal(r.holes_filled, 1);
    assert_int_equal(r.fill_triangles, 30);
    assert_true(r.closed);
    double area, v = volume_of(&s, &area);
    printf("sphere missing a cap at z %.6f: volume %.15g, expected %.15g; fill area %.15g, "
           "polygon %.15g\n",
           ring_z, v, expected, area - area_before, polygon);
    assert_true(fabs(v / expected - 1) < 1e-12);
    assert_true(fabs((area - area_before) / polygon - 1) < 1e-12);
    slices_exactly(&s, v);
    /* the same hole over a limit of 0.1 */
    pf_surface t = {0};
    assert_int_equal(pf_surface_make_sphere(&t, 1, 16, 32, &err), PF_OK);
    n = 0;
    for (int32_t k = 0; k < t.n_tris; ++k) {
        const uint32_t *c = t.tri + 3 * (size_t)k;
        if (!(t.x[3 * (size_t)c[0] + 2] > z0 && t.x[3 * (size_t)c[1] + 2] > z0 &&
              t.x[3 * (size_t)c[2] + 2] > z0))
            memmove(t.tri + 3 * (size_t)n++, c, 3 * sizeof *c);
    }
    t.n_tris = n;
    r = repair(&t, 0.1);
    assert_int_equal(r.holes, 1);
    assert_int_equal(r.holes_filled, 0);
    assert_false(r.closed);
    double diag = sqrt(4.0 + 4.0 + (1 + ring_z) * (1 + ring_z));
    double perimeter = 32 * 2 * rho * sin(PI / 32);
    printf("left open: perimeter %.6f of the diagonal, expected %.6f\n", r.largest_left,
           perimeter / diag);
    assert_true(fabs(r.largest_left / (perimeter / diag) - 1) < 1e-6);
    pf_surface_release(&t);
    pf_surface_release(&s);
}

/* A unit cube with one face's triangle repeated, then with a face's two triangles repeated the
 * other way round (a doubled wall: both copies go, the hole is refilled), then a triangle with a
 * repeated corner: the unit cube each time. */
static void cube_with_duplicates(void **state)
{
    (void)state;
    pf_error err = {0};
    for (int variant = 0; variant < 3; ++variant) {
        pf_surface s = {0};
        add_box(&s, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
        pf_surface g = {0};
        int extra = variant == 1 ? 2 : 1;
        assert_int_equal(pf_surface_alloc(&g, s.n_verts, s.n_tris + extra, &err), PF_OK);
        memcpy(g.x, s.x, 3 * (size_t)s.n_verts * sizeof *g.x);
        memcpy(g.tri, s.tri, 3 * (size_t)s.n_tris * sizeof *g.tri);
        uint32_t *t = g.tri + 3 * (size_t)s.n_tris;
        if (variant == 0) {
            memcpy(t, s.tri + 6, 3 * sizeof *t);
        } else if (variant == 1) {
            for (int q = 0; q < 2; ++q)
                t[3 * q] = s.tri[3 * q], t[3 * q + 1] = s.tri[3 * q + 2],
                      t[3 * q + 2] = s.tri[3 * q + 1];
        } else {
            t[0] = 0, t[1] = 1, t[2] = 1;
        }
        pf_surface_release(&s);
        /* the doubled face's hole: perimeter 4, 2.3 diagonals */
        pf_surface_repair_report r = repair(&g, 3);
        assert_int_equal(r.duplicates, variant == 0);
        assert_int_equal(r.opposite_pairs, variant == 1 ? 2 : 0);
        assert_int_equal(r.degenerate, variant == 2);
        assert_int_equal(r.holes_filled, variant == 1);
        assert_int_equal(r.fill_triangles, variant == 1 ? 2 : 0);
        assert_true(r.closed);
        assert_int_equal(g.n_tris, 12);
        assert_true(fabs(volume_of(&g, NULL) - 1) < 1e-15);
        slices_exactly(&g, 1);
        pf_surface_release(&g);
    }
}

/* Two unit cubes side by side, each closed with its own vertices: the shared face's vertices are
 * welded, its two pairs of opposite triangles removed, and the union is closed, volume 2. */
static void cubes_sharing_a_face(void **state)
{
    (void)state;
    pf_surface s = {0};
    add_box(&s, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
    add_box(&s, pf_v3(1, 0, 0), pf_v3(2, 1, 1));
    pf_surface_repair_report r = repair(&s, -1);
    assert_int_equal(r.welded, 4);
    assert_int_equal(r.opposite_pairs, 2);
    assert_int_equal(r.holes, 0);
    assert_true(r.closed);
    assert_int_equal(s.n_verts, 12);
    assert_int_equal(s.n_tris, 20);
    assert_true(fabs(volume_of(&s, NULL) - 2) < 1e-15);
    slices_exactly(&s, 2);
    pf_surface_release(&s);
}

static void rejects_bad_parameters(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    add_box(&s, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
    pf_surface_repair_params p = pf_surface_repair_params_default();
    p.max_hole = -1;
    assert_int_equal(pf_surface_repair(&s, &p, NULL, &err), PF_ERR_INVALID);
    p = pf_surface_repair_params_default();
    p.max_hole_edges = 2;
    assert_int_equal(pf_surface_repair(&s, &p, NULL, &err), PF_ERR_INVALID);
    assert_int_equal(pf_surface_repair(&s, NULL, NULL, &err), PF_OK);
    assert_int_equal(s.n_tris, 12);
    pf_surface_release(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sphere_missing_a_face), cmocka_unit_test(holes_touching_at_a_vertex),
        cmocka_unit_test(sphere_missing_a_cap),  cmocka_unit_test(cube_with_duplicates),
        cmocka_unit_test(cubes_sharing_a_face),  cmocka_unit_test(rejects_bad_parameters),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
