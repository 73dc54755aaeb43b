/* cut: pf_mesh_cut on hex bars and plates (through, partial, along a face, snapped slivers,
 * dropped bodies, blades through nodes, along edges and grazing), on a sliced sphere with random
 * blades, and bad requests.
 *
 * Invariants checked after every cut: the mesh is valid (pf_mesh_validate: closed, conforming,
 * planar faces), the volume is the source's minus what was reported dropped to 1e-12 relative (a
 * cut moves no node; the pieces' volumes are sums of the same fan tetrahedra up to rounding, ~1e-15
 * per element), and no dst node is shared by elements on opposite sides of an opened face. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_bodies.h"
#include "test_check.h"
#include "test_cut_requests.h"
#include "test_random.h"
#include <pf/cut.h>
#include <pf/mesh.h>
#include <pf/refine.h>

/* Each cut face has one user, and no node is shared by two bodies (groups of elements connected
 * through faces): duplication separated every node the cut runs through. */
static void check_separated(const pf_mesh *m, const pf_cut_result *r)
{
    for (int32_t f = 0; f < m->n_faces; ++f)
        CHECKF(!r->cut_face[f] || m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0,
               "cut face %d has two users", (int)f);
    int32_t *body = malloc(((size_t)m->n_elems + 1) * sizeof *body);
    int32_t *owner = malloc(((size_t)m->n_nodes + 1) * sizeof *owner);
    assert_non_null(body);
    assert_non_null(owner);
    element_bodies(m, body);
    int32_t bodies = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        bodies += body[e] == e;
    assert_int_equal(bodies, r->n_bodies);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        owner[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k) {
                uint32_t v = m->face_nodes[k];
                CHECKF(owner[v] < 0 || owner[v] == body[e], "node %u is in bodies %d and %d", v,
                       (int)owner[v], (int)body[e]);
                owner[v] = body[e];
            }
        }
    free(body);
    free(owner);
}

static void cut_ok(const pf_mesh *src, const pf_cut_request *req, int32_t n, const pf_cut_params *p,
                   pf_mesh *dst, pf_cut_result *res)
{
    pf_error err = {0};
    pf_status st = pf_mesh_cut(src, req, n, p, dst, res, &err);
    CHECKF(st == PF_OK, "pf_mesh_cut: %s", err.msg);
    pf_mesh_validate_params vp = pf_mesh_validate_params_default();
    st = pf_mesh_validate(dst, &vp, &err);
    CHECKF(st == PF_OK, "pf_mesh_validate after the cut: %s", err.msg);
    double v0 = pf_mesh_volume(src), v1 = pf_mesh_volume(dst) + res->dropped_volume;
    CHECKF(fabs(v1 - v0) <= 1e-12 * v0, "volume %.17g, expected %.17g", v1, v0);
    assert_int_equal(dst->id, src->id + 1);
    for (int32_t e = 0; e < dst->n_elems; ++e)
        CHECKF(pf_mesh_elem_volume(dst, e) > 0, "element %d has volume %g", (int)e,
               pf_mesh_elem_volume(dst, e));
    check_separated(dst, res);
}

/* The lowest corner of element e's bounding box. */
static pf_vec3 elem_lo(const pf_mesh *m, int32_t e)
{
    pf_vec3 lo = pf_v3(INFINITY, INFINITY, INFINITY);
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k) {
            const double *x = m->x + 3 * (size_t)m->face_nodes[k];
            lo = pf_v3(fmin(lo.x, x[0]), fmin(lo.y, x[1]), fmin(lo.z, x[2]));
        }
    }
    return lo;
}

static pf_cut_request plane_req(int32_t e, pf_vec3 p, pf_vec3 n)
{
    return (pf_cut_request){.elem = e, .plane = pf_plane_from_point_normal(p, n)};
}

static int32_t count(const uint8_t *a, int32_t n)
{
    int32_t k = 0;
    for (int32_t i = 0; i < n; ++i)
        k += a[i] != 0;
    return k;
}

/* A bar of four unit hexes along x cut through the middle of element 1: two bodies, the four cap
 * nodes duplicated, one face opened, and the pieces keep their parents' nodes elsewhere. */
static void test_bar_through(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(4, 1, 1), 4, 1, 1, &err), PF_OK);
    pf_cut_request req = plane_req(1, pf_v3(1.5, 0, 0), pf_v3(1, 0, 0));
    pf_cut_result r;
    cut_ok(&src, &req, 1, NULL, &dst, &r);
    assert_int_equal(dst.n_elems, 5);
    assert_int_equal(r.n_split, 1);
    assert_int_equal(r.n_opened, 1);
    assert_int_equal(r.n_bodies, 2);
    assert_int_equal(r.n_duplicated, 4);
    assert_int_equal(dst.n_nodes, src.n_nodes + 8);
    assert_int_equal(count(r.cut_face, dst.n_faces), 2);
    assert_int_equal(count(r.opened, dst.n_faces), 2);
    for (int32_t i = 0; i < src.n_nodes; ++i)
        assert_int_equal(r.node_map[i], i);
    for (int32_t i = 0; i < dst.n_nodes; ++i)
        assert_true(i < src.n_nodes ? r.node_src[i] == i : r.node_src[i] == -1);
    assert_int_equal(r.split[1], 1);
    assert_int_equal(r.parent[1], 1);
    assert_int_equal(r.parent[2], 1);
    /* the "cut" face group holds the two opened faces */
    const pf_mesh_group *g = pf_mesh_find_group(&dst, 2, "cut", 0);
    assert_non_null(g);
    for (int32_t f = 0; f < dst.n_faces; ++f)
        assert_int_equal(dst.face_group[f] == g->number, r.cut_face[f]);
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A 3 x 3 plate cut along y = 1.5 in two of the three elements of its middle row: one body, the
 * crack's nodes duplicated except at its front (x = 2), where the uncut element holds them. */
static void test_partial(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(3, 3, 1), 3, 3, 1, &err), PF_OK);
    pf_cut_request req[2];
    int32_t n = 0;
    for (int32_t e = 0; e < src.n_elems; ++e) {
        pf_vec3 lo = elem_lo(&src, e);
        if (lo.y == 1 && lo.x < 2)
            req[n++] = plane_req(e, pf_v3(0, 1.5, 0), pf_v3(0, 1, 0));
    }
    assert_int_equal(n, 2);
    pf_cut_result r;
    cut_ok(&src, req, n, NULL, &dst, &r);
    assert_int_equal(r.n_split, 2);
    assert_int_equal(r.n_bodies, 1);
    assert_int_equal(r.n_opened, 2);
    /* new nodes on y = 1.5: x = 0, 1, 2 (the last inserted into the uncut element's face) times
     * z = 0, 1; copies for x = 0 and 1 only */
    assert_int_equal(r.n_duplicated, 4);
    for (int32_t i = 0; i < dst.n_nodes; ++i) {
        const double *x = dst.x + 3 * (size_t)i;
        if (x[1] == 1.5 && x[0] == 2) {
            int users = 0; /* front nodes are in elements on both sides */
            for (int32_t e = 0; e < dst.n_elems; ++e) {
                bool has = false;
                for (int64_t q = dst.elem_offsets[e]; q < dst.elem_offsets[e + 1]; ++q) {
                    int32_t f = PF_FACE_INDEX(dst.elem_faces[q]);
                    for (int64_t k = dst.face_offsets[f]; k < dst.face_offsets[f + 1]; ++k)
                        has |= dst.face_nodes[k] == (uint32_t)i;
                }
                users += has;
            }
            assert_int_equal(users, 3);
        }
    }
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A blade in the plane of a face splits nothing: both elements lie on their sides and the face
 * between them is opened. */
static void test_along_face(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    pf_cut_request req[2] = {plane_req(0, pf_v3(1, 0, 0), pf_v3(1, 0, 0)),
                             plane_req(1, pf_v3(1, 0, 0), pf_v3(1, 0, 0))};
    pf_cut_result r;
    cut_ok(&src, req, 2, NULL, &dst, &r);
    assert_int_equal(dst.n_elems, 2);
    assert_int_equal(r.n_split, 0);
    assert_int_equal(r.n_snapped, 2);
    assert_int_equal(r.n_opened, 1);
    assert_int_equal(r.n_bodies, 2);
    assert_int_equal(r.n_duplicated, 4);
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A plane 2 % into element 1 would make a sliver: the element stays whole on its centroid's side
 * and the crack follows its face with element 0. */
static void test_snapped_sliver(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    pf_cut_request req[2] = {plane_req(0, pf_v3(1.02, 0, 0), pf_v3(1, 0, 0)),
                             plane_req(1, pf_v3(1.02, 0, 0), pf_v3(1, 0, 0))};
    pf_cut_result r;
    cut_ok(&src, req, 2, NULL, &dst, &r);
    assert_int_equal(dst.n_elems, 2);
    assert_int_equal(r.n_split, 0);
    assert_int_equal(r.n_bodies, 2);
    for (int32_t e = 0; e < dst.n_elems; ++e)
        assert_true(fabs(pf_mesh_elem_volume(&dst, e) - 1) < 1e-14);
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* The same plane requested on element 1 only (element 0 lies wholly on its other side, so a
 * blade finding the elements it crosses would not name it): the snapped element must still open
 * its face with element 0, or it would bridge the crack. */
static void test_snapped_next_to_untouched(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(3, 1, 1), 3, 1, 1, &err), PF_OK);
    int32_t e1 = -1;
    for (int32_t e = 0; e < src.n_elems; ++e)
        e1 = elem_lo(&src, e).x == 1 ? e : e1;
    pf_cut_request req = plane_req(e1, pf_v3(1.02, 0, 0), pf_v3(1, 0, 0));
    pf_cut_result r;
    cut_ok(&src, &req, 1, NULL, &dst, &r);
    assert_int_equal(r.n_split, 0);
    assert_int_equal(r.n_opened, 1);
    assert_int_equal(r.n_bodies, 2);
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A thin slab cut off a bar (10 %), then cut across with the sliver fraction at 20 %: the plane
 * would make two pieces of 0.05, below 20 % of the median element (0.9), so the slab stays whole;
 * alone in its body and below that floor, it is dropped, its volume reported. The earlier cut's
 * faces on the kept side stay cut faces. */
static void test_dropped_body(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, mid = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    pf_cut_request req =
        plane_req(elem_lo(&src, 0).x == 0 ? 0 : 1, pf_v3(0.1, 0, 0), pf_v3(1, 0, 0));
    pf_cut_result r;
    cut_ok(&src, &req, 1, NULL, &mid, &r);
    assert_int_equal(r.n_bodies, 2);
    pf_cut_result_release(&r);
    int32_t slab = -1;
    for (int32_t e = 0; e < mid.n_elems; ++e)
        if (fabs(pf_mesh_elem_volume(&mid, e) - 0.1) < 1e-12)
            slab = e;
    assert_true(slab >= 0);
    req = plane_req(slab, pf_v3(0, 0.5, 0), pf_v3(0, 1, 0));
    pf_cut_params p = {.min_fraction = 0.2};
    cut_ok(&mid, &req, 1, &p, &dst, &r);
    assert_int_equal(r.n_split, 0);
    assert_int_equal(r.n_dropped, 1);
    assert_near(r.dropped_volume, 0.1, 1e-14);
    assert_int_equal(r.n_bodies, 1);
    /* the first cut's face pieces on the kept side are still cut faces (from mid's "cut" group) */
    assert_true(count(r.cut_face, dst.n_faces) > count(r.opened, dst.n_faces));
    pf_cut_result_release(&r);
    pf_mesh_release(&dst);
    pf_mesh_release(&mid);
    pf_mesh_release(&src);
}

/* The sliver rule after a cut of src into dst: every piece of a split element has at least
 * PF_REFINE_MIN_FRACTION of its element's volume and of src's median element volume. */
static void check_no_sliver(const pf_mesh *src, const pf_mesh *dst, const pf_cut_result *r)
{
    double *vol = calloc((size_t)src->n_elems + 1, sizeof *vol);
    for (int32_t e = 0; e < src->n_elems; ++e)
        vol[e] = pf_mesh_elem_volume(src, e);
    double floor = PF_REFINE_MIN_FRACTION * pf_median(vol, src->n_elems);
    for (int32_t e = 0; e < dst->n_elems; ++e) {
        int32_t p = r->parent[e];
        if (!r->split[p])
            continue;
        double v = pf_mesh_elem_volume(dst, e);
        CHECKF(v >= floor && v >= PF_REFINE_MIN_FRACTION * pf_mesh_elem_volume(src, p),
               "piece %d of element %d: volume %g, floor %g, parent %g", (int)e, (int)p, v, floor,
               pf_mesh_elem_volume(src, p));
    }
    free(vol);
}

/* Degenerate blades through a 2 x 2 x 2 box of unit hexes, each requested on every element it
 * crosses or touches: through nodes (x + y + z = 3 meets the centre node and cuts corner tets off
 * some hexes, touching others at one node), along edges (x = y holds three lines of edges and
 * halves the diagonal hexes into prisms), grazing a corner or an edge of the box (nothing to
 * split). Each leaves a valid mesh of the box's volume in which every element lies on one side of
 * the plane, with the expected bodies. */
static void test_degenerate_blades(void **state)
{
    (void)state;
    struct {
        pf_vec3 point, normal;
        int32_t bodies, split;
    } blades[] = {
        {{1, 1, 1}, {1, 1, 1}, 2, 6},  /* through nodes: 6 hexes have 3 corners on the plane */
        {{0, 0, 0}, {1, -1, 0}, 2, 4}, /* along edges: the 4 hexes of the diagonal columns */
        {{0, 0, 0}, {1, 1, 1}, 1, 0},  /* grazing the corner node at the origin */
        {{0, 0, 0}, {1, 1, 0}, 1, 0},  /* grazing the edge along z at the origin */
    };
    for (size_t b = 0; b < sizeof blades / sizeof *blades; ++b) {
        pf_error err = {0};
        pf_mesh src = {0}, dst = {0};
        assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(2, 2, 2), 2, 2, 2, &err),
                         PF_OK);
        pf_plane pl = pf_plane_from_point_normal(blades[b].point, blades[b].normal);
        pf_cut_request req[8];
        /* 1e-12: the box's coordinates are exact in binary; the plane's offset rounds */
        int32_t k = requests_meeting(&src, pl, 1e-12, req);
        pf_cut_result r;
        cut_ok(&src, req, k, NULL, &dst, &r);
        CHECKF(r.n_bodies == blades[b].bodies && r.n_split == blades[b].split,
               "blade %d: %d bodies, %d split; expected %d, %d", (int)b, (int)r.n_bodies,
               (int)r.n_split, (int)blades[b].bodies, (int)blades[b].split);
        check_no_sliver(&src, &dst, &r);
        for (int32_t e = 0; e < dst.n_elems; ++e) {
            double lo, hi;
            plane_range(&dst, e, pl, &lo, &hi);
            CHECKF(lo > -1e-12 || hi < 1e-12, "blade %d: element %d spans [%g, %g]", (int)b, (int)e,
                   lo, hi);
        }
        pf_cut_result_release(&r);
        pf_mesh_release(&dst);
        pf_mesh_release(&src);
    }
}

/* 100 random blades through a sliced sphere, one after the other on the previous cut's mesh:
 * each a random plane through a random point, requested on every element it crosses. */
static void test_random_blades(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 3;
    assert_int_equal(pf_mesh_slice(&m, &s, &sp, NULL, &err), PF_OK);
    double v0 = pf_mesh_volume(&m), dropped = 0;
    rng g = {0x9e3779b97f4a7c15ull};
    for (int blade = 0; blade < 100; ++blade) {
        pf_vec3 p = pf_v3(0.6 * uniform(&g), 0.6 * uniform(&g), 0.6 * uniform(&g));
        pf_vec3 n = pf_v3(uniform(&g), uniform(&g), uniform(&g));
        if (pf_v3_norm(n) < 1e-3)
            continue;
        pf_plane pl = pf_plane_from_point_normal(p, n);
        pf_cut_request *req = calloc((size_t)m.n_elems + 1, sizeof *req);
        int32_t k = requests_meeting(&m, pl, 0, req);
        pf_mesh next = {0};
        pf_cut_result r;
        cut_ok(&m, req, k, NULL, &next, &r);
        check_no_sliver(&m, &next, &r);
        dropped += r.dropped_volume;
        for (int32_t i = 0; i < 3 * next.n_nodes; ++i)
            assert_true(isfinite(next.x[i]));
        pf_cut_result_release(&r);
        pf_mesh_release(&m);
        m = next;
        free(req);
    }
    double v1 = pf_mesh_volume(&m) + dropped;
    CHECKF(fabs(v1 - v0) <= 1e-11 * v0, "after 100 blades: %.17g + dropped vs %.17g", v1, v0);
    pf_mesh_release(&m);
    pf_surface_release(&s);
}

static void test_bad_requests(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0}, dst = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    pf_cut_result r;
    pf_cut_request req[2] = {plane_req(0, pf_v3(0.5, 0, 0), pf_v3(1, 0, 0)),
                             plane_req(0, pf_v3(0.5, 0, 0), pf_v3(1, 0, 0))};
    assert_int_equal(pf_mesh_cut(&src, req, 2, NULL, &dst, &r, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "second time"));
    req[0].elem = 7;
    assert_int_equal(pf_mesh_cut(&src, req, 1, NULL, &dst, &r, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "out of range"));
    req[0] = (pf_cut_request){.elem = 0, .plane = {.n = pf_v3(NAN, 0, 0), .d = 0}};
    assert_int_equal(pf_mesh_cut(&src, req, 1, NULL, &dst, &r, &err), PF_ERR_INVALID);
    assert_null(dst.x);
    assert_null(r.parent);
    pf_mesh_release(&src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bar_through),
        cmocka_unit_test(test_partial),
        cmocka_unit_test(test_along_face),
        cmocka_unit_test(test_snapped_sliver),
        cmocka_unit_test(test_snapped_next_to_untouched),
        cmocka_unit_test(test_dropped_body),
        cmocka_unit_test(test_degenerate_blades),
        cmocka_unit_test(test_random_blades),
        cmocka_unit_test(test_bad_requests),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
