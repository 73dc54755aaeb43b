/* mesh: clipping a mesh by a closed surface (pf_mesh_clip_surface, pf/cut.h; DG paper fig. 10).
 *
 * Oracles. The kept elements partition the solid exactly, so with a polyhedral surface inside
 * the mesh their volumes (exact for planar faces) sum to the surface's enclosed volume (inside),
 * or to the mesh's volume minus it (outside), up to rounding: a few ulp per element times the
 * element count, far below the 1e-12 relative asked (a lost piece is at least the merge threshold,
 * 5 % of an element). Conformity: the boundary faces of the result have exactly the area of the
 * surface (inside) or of the surface plus the box (outside); a crack between two neighbours'
 * parts would add the area of the unmatched faces twice. pf_mesh_validate checks every element
 * closed and positive, and no face used more than twice. */
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

#include <pf/cut.h>
#include <pf/io.h>
#include <pf/mesh.h>

#include "test_surfaces.h"

static double boundary_area(const pf_mesh *m)
{
    double a = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0)
            a += pf_polygon_area(m->x, m->face_nodes + m->face_offsets[f],
                                 m->face_offsets[f + 1] - m->face_offsets[f]);
    return a;
}

/* Clips, checks validity, volume and boundary area against the expected ones (tolerance rel). */
static void clip_and_check(const char *name, const pf_mesh *src, const pf_surface *s,
                           pf_clip_keep keep, double volume, double area, double rel, pf_mesh *out)
{
    pf_error err = {0};
    pf_clip_params p = {.keep = keep};
    pf_clip_stats st;
    if (pf_mesh_clip_surface(src, s, &p, out, &st, &err) != PF_OK)
        fail_msg("%s: %s", name, err.msg);
    if (pf_mesh_validate(out, NULL, &err) != PF_OK)
        fail_msg("%s: invalid: %s", name, err.msg);
    double v = pf_mesh_volume(out), a = boundary_area(out);
    printf("%-22s %5d -> %5d elements (%d kept, %d clipped into %d parts, %d merged, %d "
           "dropped), volume error %.1e, area error %.1e, %lld splits, %.3f s\n",
           name, (int)src->n_elems, (int)out->n_elems, (int)st.n_kept, (int)st.n_clipped,
           (int)st.n_parts, (int)st.n_merged, (int)st.n_dropped, fabs(v / volume - 1),
           fabs(a / area - 1), (long long)st.n_splits, st.seconds);
    if (!(fabs(v / volume - 1) <= rel))
        fail_msg("%s: volume %.17g, expected %.17g", name, v, volume);
    if (!(fabs(st.volume / volume - 1) <= rel))
        fail_msg("%s: reported volume %.17g, expected %.17g", name, st.volume, volume);
    if (!(fabs(a / area - 1) <= rel))
        fail_msg("%s: boundary area %.17g, expected %.17g (a crack between parts?)", name, a, area);
    assert_int_equal(out->id, src->id + 1);
    /* slivers merged: no element below 5 % of the smallest src element unless alone */
    double smallest = INFINITY;
    for (int32_t e = 0; e < src->n_elems; ++e)
        smallest = fmin(smallest, pf_mesh_elem_volume(src, e));
    if (st.n_isolated == 0)
        for (int32_t e = 0; e < out->n_elems; ++e)
            if (!(pf_mesh_elem_volume(out, e) >= 0.05 * smallest * (1 - 1e-12)))
                fail_msg("%s: element %d of volume %g is a sliver", name, (int)e,
                         pf_mesh_elem_volume(out, e));
}

static void sphere_in_box(pf_mesh *box, int tets)
{
    pf_error err = {0};
    pf_vec3 lo = pf_v3(-1, -1.1, -1.2), hi = pf_v3(1.05, 1, 1.1);
    if (tets)
        assert_int_equal(pf_mesh_make_box_tets(box, lo, hi, 4, 4, 5, &err), PF_OK);
    else
        assert_int_equal(pf_mesh_make_box(box, lo, hi, 5, 4, 6, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(box, &err), PF_OK);
}

static void test_sphere(void **state, int tets)
{
    (void)state;
    pf_error err = {0};
    pf_mesh box = {0}, in = {0}, out = {0};
    sphere_in_box(&box, tets);
    pf_surface sphere = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 0.83, 14, 22, &err), PF_OK);
    for (int32_t v = 0; v < sphere.n_verts; ++v) /* off the grid's planes and its centre */
        sphere.x[3 * v] += 0.0123, sphere.x[3 * v + 1] -= 0.0371, sphere.x[3 * v + 2] += 0.011;
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(&sphere, &ss, &err), PF_OK);
    pf_mesh_stats ms;
    assert_int_equal(pf_mesh_compute_stats(&box, &ms, &err), PF_OK);
    double box_area = boundary_area(&box);
    clip_and_check(tets ? "tets inside sphere" : "hexes inside sphere", &box, &sphere,
                   PF_CLIP_INSIDE, ss.volume, ss.area, 1e-12, &in);
    clip_and_check(tets ? "tets outside sphere" : "hexes outside sphere", &box, &sphere,
                   PF_CLIP_OUTSIDE, ms.volume - ss.volume, box_area + ss.area, 1e-12, &out);
    /* deterministic: the same mesh twice */
    pf_mesh again = {0};
    pf_clip_params p = {.keep = PF_CLIP_INSIDE};
    assert_int_equal(pf_mesh_clip_surface(&box, &sphere, &p, &again, NULL, &err), PF_OK);
    assert_int_equal(again.n_nodes, in.n_nodes);
    assert_int_equal(again.n_faces, in.n_faces);
    assert_int_equal(again.n_elems, in.n_elems);
    assert_memory_equal(again.x, in.x, 3 * (size_t)in.n_nodes * sizeof *in.x);
    assert_memory_equal(again.face_nodes, in.face_nodes,
                        (size_t)in.face_offsets[in.n_faces] * sizeof *in.face_nodes);
    assert_memory_equal(again.elem_faces, in.elem_faces,
                        (size_t)in.elem_offsets[in.n_elems] * sizeof *in.elem_faces);
    pf_mesh_release(&again);
    pf_mesh_release(&in);
    pf_mesh_release(&out);
    pf_mesh_release(&box);
    pf_surface_release(&sphere);
}

static void test_sphere_hexes(void **state)
{
    test_sphere(state, 0);
}

static void test_sphere_tets(void **state)
{
    test_sphere(state, 1);
}

/* A surface that runs along grid planes: a box knife whose faces lie on the mesh's faces. Every
 * element is kept whole or dropped; nothing is split. */
static void test_knife_on_faces(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh box = {0}, in = {0};
    assert_int_equal(pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(4, 4, 4), 4, 4, 4, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&box, &err), PF_OK);
    pf_surface knife = {0};
    add_box(&knife, pf_v3(1, 1, 1), pf_v3(3, 3, 5));
    clip_and_check("box knife on faces", &box, &knife, PF_CLIP_INSIDE, 2 * 2 * 3,
                   2 * (2 * 2 + 2 * 3 + 2 * 3), 1e-14, &in);
    assert_int_equal(in.n_elems, 12);
    for (int32_t e = 0; e < in.n_elems; ++e)
        assert_int_equal(in.elem_kind[e], PF_ELEM_HEX);
    pf_mesh_release(&in);
    pf_mesh_release(&box);
    pf_surface_release(&knife);
}

/* The DG paper's fig. 10: a bunny cut out of a cube of hexes. */
static void test_bunny(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface bunny = {0};
    if (pf_import_surface(PF_TEST_DATA_DIR "/../../data/models/bunny.obj", &bunny, &err) != PF_OK)
        fail_msg("%s", err.msg);
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(&bunny, &ss, &err), PF_OK);
    if (!ss.closed || !ss.manifold || !(ss.volume > 0))
        fail_msg("bunny.obj is not a closed outward surface (%lld open edges)",
                 (long long)ss.n_boundary_edges);
    pf_vec3 d = pf_v3_sub(ss.hi, ss.lo);
    pf_vec3 lo = pf_v3_sub(ss.lo, pf_v3_scale(d, 0.05)),
            hi = pf_v3_add(ss.hi, pf_v3_scale(d, 0.05));
    pf_mesh cube = {0}, in = {0};
    assert_int_equal(pf_mesh_make_box(&cube, lo, hi, 9, 9, 9, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&cube, &err), PF_OK);
    clip_and_check("bunny out of a cube", &cube, &bunny, PF_CLIP_INSIDE, ss.volume, ss.area, 1e-10,
                   &in);
    pf_mesh_release(&in);
    pf_mesh_release(&cube);
    /* and out of a block of tets, whose planes are not the kd tree's */
    assert_int_equal(pf_mesh_make_box_tets(&cube, lo, hi, 7, 6, 7, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&cube, &err), PF_OK);
    clip_and_check("bunny out of tets", &cube, &bunny, PF_CLIP_INSIDE, ss.volume, ss.area, 1e-10,
                   &in);
    pf_mesh_release(&in);
    pf_mesh_release(&cube);
    pf_surface_release(&bunny);
}

/* Spheres at random places and sizes (a fixed seed) in hex and tet grids: surfaces crossing
 * elements in every way, grazing faces and edges within the tolerance included. */
static void test_random_spheres(void **state)
{
    (void)state;
    pf_error err = {0};
    uint64_t seed = 0x9e3779b97f4a7c15ull;
    for (int trial = 0; trial < 16; ++trial) {
        double r[5];
        for (int k = 0; k < 5; ++k) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            r[k] = (double)(seed >> 11) / 9007199254740992.0;
        }
        pf_mesh box = {0}, in = {0}, out = {0};
        int32_t n = 3 + trial % 4;
        pf_vec3 lo = pf_v3(-1, -1, -1), hi = pf_v3(1, 1, 1);
        if (trial % 2)
            assert_int_equal(pf_mesh_make_box_tets(&box, lo, hi, n, n, n, &err), PF_OK);
        else
            assert_int_equal(pf_mesh_make_box(&box, lo, hi, n, n + 1, n, &err), PF_OK);
        assert_int_equal(pf_mesh_derive(&box, &err), PF_OK);
        pf_surface sphere = {0};
        double radius = 0.3 + 0.4 * r[0];
        assert_int_equal(pf_surface_make_sphere(&sphere, radius, 6 + trial, 8 + trial, &err),
                         PF_OK);
        /* trials 0 and 1 centred on a grid node, the others anywhere inside */
        for (int32_t v = 0; v < sphere.n_verts; ++v)
            for (int c = 0; c < 3; ++c)
                sphere.x[3 * v + c] += trial < 2 ? 0 : (1 - radius - 0.05) * (2 * r[1 + c] - 1);
        pf_surface_stats ss;
        assert_int_equal(pf_surface_compute_stats(&sphere, &ss, &err), PF_OK);
        char name[64];
        snprintf(name, sizeof name, "random %d in", trial);
        clip_and_check(name, &box, &sphere, PF_CLIP_INSIDE, ss.volume, ss.area, 1e-12, &in);
        snprintf(name, sizeof name, "random %d out", trial);
        clip_and_check(name, &box, &sphere, PF_CLIP_OUTSIDE, 8 - ss.volume, 24 + ss.area, 1e-12,
                       &out);
        pf_mesh_release(&in);
        pf_mesh_release(&out);
        pf_mesh_release(&box);
        pf_surface_release(&sphere);
    }
}

static char *dup_name(const char *n)
{
    char *s = pf_alloc(strlen(n) + 1);
    assert_non_null(s);
    memcpy(s, n, strlen(n) + 1);
    return s;
}

/* Groups are carried: elements keep their element's group, the boundary faces lying in a
 * grouped face of the box keep its group, and no other face gets one. */
static void test_groups(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh box = {0}, in = {0};
    assert_int_equal(pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(4, 4, 4), 4, 4, 4, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&box, &err), PF_OK);
    assert_int_equal(pf_mesh_groups_alloc(&box, 2, &err), PF_OK);
    box.groups[0] = (pf_mesh_group){1, 3, dup_name("body")};
    box.groups[1] = (pf_mesh_group){2, 2, dup_name("fixed")};
    for (int32_t e = 0; e < box.n_elems; ++e)
        box.elem_group[e] = 1;
    for (int32_t f = 0; f < box.n_faces; ++f) {
        bool at_zero = true;
        for (int64_t q = box.face_offsets[f]; q < box.face_offsets[f + 1]; ++q)
            at_zero &= box.x[3 * (size_t)box.face_nodes[q]] == 0;
        box.face_group[f] = at_zero ? 2 : 0;
    }
    pf_surface ball = {0};
    assert_int_equal(pf_surface_make_sphere(&ball, 1.5, 10, 16, &err), PF_OK);
    for (int32_t v = 0; v < ball.n_verts; ++v)
        ball.x[3 * v] += 0.31, ball.x[3 * v + 1] += 2.03, ball.x[3 * v + 2] += 1.97;
    assert_int_equal(pf_mesh_clip_surface(&box, &ball, NULL, &in, NULL, &err), PF_OK);
    assert_non_null(in.elem_group);
    assert_non_null(in.face_group);
    assert_non_null(pf_mesh_find_group(&in, 2, "fixed", 0));
    for (int32_t e = 0; e < in.n_elems; ++e)
        assert_int_equal(in.elem_group[e], 1);
    int32_t fixed = 0;
    for (int32_t f = 0; f < in.n_faces; ++f) {
        bool at_zero = true;
        for (int64_t q = in.face_offsets[f]; q < in.face_offsets[f + 1]; ++q)
            at_zero &= fabs(in.x[3 * (size_t)in.face_nodes[q]]) <= 1e-12;
        bool boundary = in.face_elems[2 * f] < 0 || in.face_elems[2 * f + 1] < 0;
        assert_int_equal(in.face_group[f], at_zero && boundary ? 2 : 0);
        fixed += in.face_group[f] == 2;
    }
    assert_true(fixed > 0);
    pf_mesh_release(&in);
    pf_mesh_release(&box);
    pf_surface_release(&ball);
}

static void test_errors(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh box = {0}, out = {0};
    assert_int_equal(pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 2, 2, 2, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&box, &err), PF_OK);
    pf_surface sphere = {0};
    assert_int_equal(pf_surface_make_sphere(&sphere, 0.3, 8, 12, &err), PF_OK);
    /* an open surface: one triangle fewer */
    sphere.n_tris--;
    assert_int_equal(pf_mesh_clip_surface(&box, &sphere, NULL, &out, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "closed"));
    sphere.n_tris++;
    /* nothing inside: a sphere away from the mesh */
    for (int32_t v = 0; v < sphere.n_verts; ++v)
        sphere.x[3 * v] += 5;
    assert_int_equal(pf_mesh_clip_surface(&box, &sphere, NULL, &out, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "nothing"));
    /* a crossed element that is not convex: the sliced torus's */
    pf_surface torus = {0};
    assert_int_equal(pf_surface_make_torus(&torus, 1, 0.45, 24, 12, &err), PF_OK);
    pf_mesh ring = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 3;
    assert_int_equal(pf_mesh_slice(&ring, &torus, &sp, NULL, &err), PF_OK);
    for (int32_t v = 0; v < sphere.n_verts; ++v) { /* through the hole: saddle-shaped parts */
        sphere.x[3 * v] -= 5;
        for (int c = 0; c < 3; ++c)
            sphere.x[3 * v + c] *= 0.7 / 0.3;
    }
    pf_status st = pf_mesh_clip_surface(&ring, &sphere, NULL, &out, NULL, &err);
    printf("non-convex: %s\n", err.msg);
    assert_int_equal(st, PF_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.msg, "element "));
    assert_null(out.x);
    pf_mesh_release(&ring);
    pf_mesh_release(&box);
    pf_surface_release(&sphere);
    pf_surface_release(&torus);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_hexes),   cmocka_unit_test(test_sphere_tets),
        cmocka_unit_test(test_knife_on_faces), cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_random_spheres), cmocka_unit_test(test_groups),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
