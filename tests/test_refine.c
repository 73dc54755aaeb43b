/* refine: pf_mesh_refine (octs and halves) on boxes, tets, non-convex and sliced elements.
 *
 * Oracles, independent of the code under test:
 * - volumes: children's volumes sum to their parent's, the mesh's total and its boundary area are
 *   unchanged. Each volume is a sum over fan tetrahedra of O(1) size with relative rounding
 *   ~1e-16 per term; a few hundred terms give ~1e-14, so 1e-12 relative is tight yet safe.
 * - boxes cut at their centres: closed forms (children are cubes of half the side, a shared face
 *   is cut into four quarters, an edge gets its midpoint). Coordinates of a midpoint are exact in
 *   binary, so they are compared with ==.
 * - conformity: pf_mesh_validate and pf_mesh_derive (every face used once or twice, opposite ways
 *   round), no hanging node (no node lies strictly inside a face edge it is not a vertex of,
 *   checked by brute force over the edges of each node), and `changed` against a direct
 *   comparison of each unsplit element's face polygons with its src element's. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_check.h"
#include "test_random.h"
#include <pf/basis.h>
#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/refine.h>

#include "test_prism.h"
#include "test_refine_check.h"

/* ---- helpers -----------------------------------------------------------------------------------
 */

static pf_mesh make_box(int nx, int ny, int nz, double sx, double sy, double sz)
{
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(sx, sy, sz), nx, ny, nz, &err),
                     PF_OK);
    m.id = 7;
    return m;
}

static void elem_bounds(const pf_mesh *m, int32_t e, pf_vec3 *lo, pf_vec3 *hi)
{
    *lo = pf_v3(INFINITY, INFINITY, INFINITY);
    *hi = pf_v3(-INFINITY, -INFINITY, -INFINITY);
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            const double *p = m->x + 3 * (size_t)m->face_nodes[j];
            *lo = pf_v3(fmin(lo->x, p[0]), fmin(lo->y, p[1]), fmin(lo->z, p[2]));
            *hi = pf_v3(fmax(hi->x, p[0]), fmax(hi->y, p[1]), fmax(hi->z, p[2]));
        }
    }
}

/* Whether face f of m has a node at p (exact coordinates). */
static bool face_has_point(const pf_mesh *m, int32_t f, pf_vec3 p)
{
    for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
        const double *q = m->x + 3 * (size_t)m->face_nodes[j];
        if (q[0] == p.x && q[1] == p.y && q[2] == p.z)
            return true;
    }
    return false;
}

/* ---- boxes -------------------------------------------------------------------------------------
 */

/* The corner element of a 2x2x2 box of unit cubes by octs: 8 cubes of side 1/2; the three face
 * neighbours get the shared face as 4 quarters, the three edge neighbours the edge midpoints,
 * the opposite corner nothing. */
static void test_corner_octs(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 2, 2, 2, 2, 2), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 1);
    assert_int_equal(res.n_skipped, 0);
    assert_int_equal(res.n_planes_skipped, 0);
    assert_int_equal(res.n_children, 8);
    assert_int_equal(dst.n_elems, 15);
    assert_int_equal(dst.n_nodes, 27 + 19); /* a 3x3x3 lattice of nodes in the corner cube */
    for (int32_t c = 0; c < 8; ++c) {
        assert_int_equal(res.parent[c], 0);
        assert_int_equal(dst.elem_kind[c], PF_ELEM_HEX);
        pf_vec3 lo, hi;
        elem_bounds(&dst, c, &lo, &hi);
        assert_true(hi.x - lo.x == 0.5 && hi.y - lo.y == 0.5 && hi.z - lo.z == 0.5);
        assert_true(lo.x == 0 || lo.x == 0.5);
        assert_near(pf_mesh_elem_volume(&dst, c), 0.125, 1e-15);
    }
    /* src element e is dst element e + 7 for e >= 1; box element (i, j, k) = i + 2 j + 4 k */
    for (int32_t e = 1; e < 8; ++e) {
        int32_t d = e + 7;
        assert_int_equal(res.parent[d], e);
        int bits = (e & 1) + ((e >> 1) & 1) + ((e >> 2) & 1);
        assert_int_equal(res.changed[d], bits < 3);
        int32_t quarters = 0, nf = (int32_t)(dst.elem_offsets[d + 1] - dst.elem_offsets[d]);
        for (int64_t k = dst.elem_offsets[d]; k < dst.elem_offsets[d + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(dst.elem_faces[k]);
            int32_t other =
                dst.face_elems[2 * f] == d ? dst.face_elems[2 * f + 1] : dst.face_elems[2 * f];
            if (other >= 0 && other < 8) {
                assert_near(face_area(&dst, f), 0.25, 1e-15);
                quarters++;
            }
        }
        if (bits == 1) { /* face neighbour: 5 faces + 4 quarters */
            assert_int_equal(quarters, 4);
            assert_int_equal(nf, 9);
        } else {
            assert_int_equal(quarters, 0);
            assert_int_equal(nf, 6);
        }
        if (bits == 2) { /* edge neighbour: the shared edge's midpoint is in its two faces on it */
            pf_vec3 mid = pf_v3((e & 1) ? 1 : 0.5, (e & 2) ? 1 : 0.5, (e & 4) ? 1 : 0.5);
            int32_t with_mid = 0;
            for (int64_t k = dst.elem_offsets[d]; k < dst.elem_offsets[d + 1]; ++k)
                with_mid += face_has_point(&dst, PF_FACE_INDEX(dst.elem_faces[k]), mid);
            assert_int_equal(with_mid, 2);
            assert_int_equal(dst.elem_kind[d], PF_ELEM_POLY);
        }
    }
    assert_int_equal(res.n_neighbours_changed, 6);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* Every element of a 2x2x2 box by octs is the 4x4x4 box: 64 hexes of side 1/2 on 125 nodes. The
 * elements split after their neighbours have extra nodes in their faces, which must not tilt
 * their planes: with cells 2 x 1 x 0.5 (distinct moments, no tie) the same. */
static void uniform_octs(double sx, double sy, double sz);

static void test_uniform_octs(void **state)
{
    for (int shape = 0; shape < 2; ++shape)
        uniform_octs(shape ? 4 : 2, shape ? 2 : 2, shape ? 1 : 2);
    (void)state;
}

static void uniform_octs(double sx, double sy, double sz)
{
    pf_mesh src = make_box(2, 2, 2, sx, sy, sz), dst = {0};
    pf_refine_result res;
    pf_refine_request req[8];
    for (int i = 0; i < 8; ++i)
        req[i] = (pf_refine_request){.elem = 7 - i, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, req, 8, &dst, &res);
    assert_int_equal(dst.n_elems, 64);
    assert_int_equal(dst.n_nodes, 125);
    assert_int_equal(dst.n_faces, 3 * 4 * 4 * 5);
    assert_int_equal(res.n_neighbours_changed, 0);
    for (int32_t c = 0; c < 64; ++c) {
        assert_int_equal(dst.elem_kind[c], PF_ELEM_HEX);
        assert_near(pf_mesh_elem_volume(&dst, c), sx * sy * sz / 64, 1e-15);
    }
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A box 2 x 1 x 0.5 by octs: the longest side is cut first, so the children are ordered with
 * x slowest; 8 boxes 1 x 0.5 x 0.25. */
static void test_octs_box_axes(void **state)
{
    (void)state;
    pf_mesh src = make_box(1, 1, 1, 2, 1, 0.5), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(dst.n_elems, 8);
    for (int32_t c = 0; c < 8; ++c) {
        pf_vec3 lo, hi;
        elem_bounds(&dst, c, &lo, &hi);
        assert_true(hi.x - lo.x == 1 && hi.y - lo.y == 0.5 && hi.z - lo.z == 0.25);
        assert_true(lo.x == (c < 4 ? 0 : 1));
    }
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* Two face neighbours split by halves along different planes (z = 1/2 and y = 1/2): the shared
 * face x = 1 becomes four quarters, each used by two children. */
static void test_neighbour_halves(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 1, 1, 2, 1, 1), dst = {0};
    pf_refine_result res;
    pf_refine_request req[2] = {{.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {0, 0, 3}},
                                {.elem = 1, .kind = PF_SPLIT_HALVES, .normal = {0, -1, 0}}};
    refine_ok(&src, req, 2, &dst, &res);
    assert_int_equal(res.n_split, 2);
    assert_int_equal(dst.n_elems, 4);
    int32_t interior = 0;
    for (int32_t f = 0; f < dst.n_faces; ++f)
        interior += dst.face_elems[2 * f] >= 0 && dst.face_elems[2 * f + 1] >= 0;
    /* two caps (z = 1/2 in element 0, y = 1/2 in element 1) and the four quarters of x = 1 */
    assert_int_equal(interior, 6);
    int32_t quarters = 0;
    for (int32_t f = 0; f < dst.n_faces; ++f) {
        bool on_x1 = true;
        for (int64_t j = dst.face_offsets[f]; j < dst.face_offsets[f + 1]; ++j)
            on_x1 &= dst.x[3 * (size_t)dst.face_nodes[j]] == 1;
        if (on_x1) {
            quarters++;
            assert_near(face_area(&dst, f), 0.25, 1e-15);
            assert_true(dst.face_elems[2 * f] >= 0 && dst.face_elems[2 * f + 1] >= 0);
        }
    }
    assert_int_equal(quarters, 4);
    assert_near(boundary_area(&dst), 10, 1e-13);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A plane that contains two edges of a cube up to 5e-14 (within pf_poly_split's tolerance): two
 * prisms on the cube's own nodes, no sliver faces, and the neighbour across x = 1, which the plane
 * only touches along an edge, is left alone. A plane 7e-7 from those edges (within PF_REFINE_SNAP
 * = 1e-6 of the cube's diagonal) is snapped onto them: the same two prisms. A plane 7e-6 from
 * them crosses them and four more edges near their ends (6 new nodes) and cuts a thin triangle
 * off the shared face. */
static void test_plane_near_vertex(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 1, 1, 2, 1, 1), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {1, 1, 1e-13}};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_children, 2);
    assert_int_equal(dst.n_nodes, src.n_nodes);
    for (int c = 0; c < 2; ++c) {
        assert_int_equal(dst.elem_offsets[c + 1] - dst.elem_offsets[c], 5);
        assert_near(pf_mesh_elem_volume(&dst, c), 0.5, 1e-14);
    }
    assert_int_equal(res.changed[2], 0);
    assert_int_equal(res.n_neighbours_changed, 0);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);

    req.normal = pf_v3(1, 1, 2e-6);
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_children, 2);
    assert_int_equal(dst.n_nodes, src.n_nodes);
    for (int c = 0; c < 2; ++c)
        assert_near(pf_mesh_elem_volume(&dst, c), 0.5, 1e-14);
    assert_int_equal(res.n_neighbours_changed, 0);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);

    req.normal = pf_v3(1, 1, 2e-5);
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_children, 2);
    assert_int_equal(dst.n_nodes, src.n_nodes + 6);
    assert_int_equal(res.changed[2], 1);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);

    /* x + 2y - z = 1 contains the opposite corners (1, 0, 0) and (0, 1, 1) of the cube; tilted
     * by 1e-13 it passes them at ~4e-14: they are on it, and only the edges whose ends lie
     * strictly on opposite sides (counted here from the corners' signed distances) get a node. */
    req.normal = pf_v3(1, 2, -1 + 1e-13);
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_children, 2);
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0.5, 0.5, 0.5), req.normal);
    int crossed = 0;
    for (int a = 0; a < 8; ++a)
        for (int bit = 0; bit < 3; ++bit) {
            int b = a | (1 << bit);
            if (b == a)
                continue;
            double da = pf_plane_signed_distance(pl, pf_v3(a & 1, (a >> 1) & 1, a >> 2));
            double db = pf_plane_signed_distance(pl, pf_v3(b & 1, (b >> 1) & 1, b >> 2));
            crossed += (da < -1e-9 && db > 1e-9) || (da > 1e-9 && db < -1e-9);
        }
    assert_int_equal(crossed, 2);
    assert_int_equal(dst.n_nodes, src.n_nodes + crossed);
    for (int c = 0; c < 2; ++c)
        assert_near(pf_mesh_elem_volume(&dst, c), 0.5, 1e-14);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* ---- non-convex elements ----------------------------------------------------------------------
 */

/* Three unit cubes along x; the outer two cut first by planes near z = 1/2 (1e-7 above it, tilted
 * by 1e-7 about x, on the left; 1e-7 below on the right), which put on the middle cube's faces
 * x = 1 and x = 2 four nodes 0.5e-7 to 1.5e-7 off z = 1/2 that no plane passes through (coplanar
 * to 2.5e-8 only, far above the snap's 1e-10). Then the middle cube split in halves across z:
 * its plane z = 1/2 would leave faces 1e-7 wide (of 1, which the harmonic basis refuses as
 * collinear), and no fit puts the four nodes on it; it is moved up by one step of
 * PF_REFINE_SHIFT of the diagonal (1.73e-5) instead, which leaves every node at least 1.7e-5
 * off it: no face narrower than 1e-5 of its size, and the lower half is 1/2 + 1.73e-5. (Before
 * the move, the plane stayed where it was: faces 1e-7 wide.) */
static void test_plane_between_neighbour_cuts(void **state)
{
    (void)state;
    pf_mesh src = make_box(3, 1, 1, 3, 1, 1), mid = {0}, dst = {0};
    pf_refine_result res;
    const pf_refine_request cuts[2] = {
        {.elem = 0, .kind = PF_SPLIT_PLANE, .normal = {0, -1e-7, 1}, .point = {0.5, 0.5, 0.5 + 1e-7}},
        {.elem = 2, .kind = PF_SPLIT_PLANE, .normal = {0, 0, 1}, .point = {2.5, 0.5, 0.5 - 1e-7}}};
    refine_ok(&src, cuts, 2, &mid, &res);
    assert_int_equal(res.n_split, 2);
    pf_refine_result_release(&res);
    /* elements: 0, 1 (left), 2 (middle), 3, 4 (right) */
    pf_refine_request req = {.elem = 2, .kind = PF_SPLIT_HALVES, .normal = {0, 0, 1}};
    refine_ok(&mid, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 1);
    double narrow = narrowest_face(&dst);
    printf("plane between neighbour cuts: narrowest face %.3g of its size\n", narrow);
    assert_true(narrow > 1e-5);
    double v0 = pf_mesh_elem_volume(&dst, 2), v1 = pf_mesh_elem_volume(&dst, 3);
    assert_near(v0 + v1, 1, 1e-14);
    assert_near(fabs(v0 - 0.5), PF_REFINE_SHIFT * sqrt(3), 1e-12);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&mid);
    pf_mesh_release(&src);
}

/* An L (areas 2 + 1, centroid x = y = 5/6) by halves along x: a rectangle 5/6 x 2 and an L. */
static void test_l_shape(void **state)
{
    (void)state;
    const double xy[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    pf_mesh src = make_prism(xy, 6), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {1, 0, 0}};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(dst.n_elems, 2);
    assert_near(pf_mesh_elem_volume(&dst, 0), 5.0 / 3, 1e-14);
    assert_near(pf_mesh_elem_volume(&dst, 1), 4.0 / 3, 1e-14);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    /* an L whose centroid lies on the plane of its inner face x = 1 (base 3 x 1 and arm 1 x 3,
     * centroid x = (3 * 1.5 + 3 * 0.5) / 6 = 1): that face lies in the plane and stays a face of
     * the left child, a rectangle 1 x 4; the right one is 2 x 1 */
    const double xy2[] = {0, 0, 3, 0, 3, 1, 1, 1, 1, 4, 0, 4};
    pf_mesh src2 = make_prism(xy2, 6);
    refine_ok(&src2, &req, 1, &dst, &res);
    assert_int_equal(dst.n_elems, 2);
    assert_near(pf_mesh_elem_volume(&dst, 0), 4, 1e-14);
    assert_near(pf_mesh_elem_volume(&dst, 1), 2, 1e-14);
    assert_int_equal(dst.n_nodes, src2.n_nodes + 2); /* (1, 0, 0) and (1, 0, 1) */
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src2);
    /* octs: the L's principal axes are the diagonals; every piece's volume sums to 3 */
    req.kind = PF_SPLIT_OCTS;
    refine_ok(&src, &req, 1, &dst, &res);
    assert_true(dst.n_elems >= 4);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A U (base 3 x 1, arms 1 x 2; area 7, centroid y = 9.5 / 7) cut along y through its centroid:
 * the plane cuts both arms, so three children: the base with stubs and the two arm tips (each
 * 1 x (3 - 9.5/7)). A plane request makes them; halves, which make at most two children, skip
 * that plane and leave the U whole. */
static void test_u_shape_three_children(void **state)
{
    (void)state;
    const double xy[] = {0, 0, 3, 0, 3, 3, 2, 3, 2, 1, 1, 1, 1, 3, 0, 3};
    pf_mesh src = make_prism(xy, 8), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {0, 1, 0}};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 0);
    assert_int_equal(res.n_skipped, 1);
    assert_int_equal(res.n_planes_skipped, 1);
    assert_true(same_polygons(&src, 0, &dst, 0));
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    req = (pf_refine_request){
        .elem = 0, .kind = PF_SPLIT_PLANE, .normal = {0, 1, 0}, .point = {1.5, 9.5 / 7, 0.5}};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_children, 3);
    double tip = 3 - 9.5 / 7;
    assert_near(pf_mesh_elem_volume(&dst, 0), 7 - 2 * tip, 1e-13);
    assert_near(pf_mesh_elem_volume(&dst, 1), tip, 1e-13);
    assert_near(pf_mesh_elem_volume(&dst, 2), tip, 1e-13);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* The bound on children: a comb (base 7 x 1, four teeth 1 x 3 at x = 0, 2, 4, 6; area 19, mirror-
 * symmetric about x = 3.5, centroid y = 33.5 / 19) by octs. Its principal axes are x, y, z; the
 * plane x = 3.5 passes between the teeth (two pieces), the plane y = 1.763 would cut all four
 * teeth (six pieces of two, then twelve children with z = 1/2; the tips are 5.9 % of the element,
 * above the sliver rule's 5 %), so it is skipped: four children of 19 / 4. */
static void test_octs_comb_bounded(void **state)
{
    (void)state;
    const double xy[] = {0, 0, 7, 0, 7, 4, 6, 4, 6, 1, 5, 1, 5, 4, 4, 4,
                         4, 1, 3, 1, 3, 4, 2, 4, 2, 1, 1, 1, 1, 4, 0, 4};
    pf_mesh src = make_prism(xy, 16), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 1);
    assert_int_equal(res.n_planes_skipped, 1);
    assert_int_equal(res.n_children, 4);
    for (int c = 0; c < 4; ++c)
        assert_near(pf_mesh_elem_volume(&dst, c), 19.0 / 4, 1e-12 * 19);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* The sliver rule: a U whose right arm is a stub 0.1 x 0.3 (area 10 + 4 + 0.03, centroid
 * y = 17.0345 / 14.03 = 1.214): the plane y = 1.214 cuts 0.1 x 0.086 off the stub, 0.06 % of the
 * element, so the request is skipped and the mesh unchanged. Octs skip only such a plane. */
static void test_sliver_skipped(void **state)
{
    (void)state;
    const double xy[] = {0, 0, 10, 0, 10, 1.3, 9.9, 1.3, 9.9, 1, 1, 1, 1, 5, 0, 5};
    pf_mesh src = make_prism(xy, 8), dst = {0};
    pf_refine_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {0, 1, 0}};
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 0);
    assert_int_equal(res.n_skipped, 1);
    assert_int_equal(res.n_planes_skipped, 1);
    assert_int_equal(dst.n_elems, 1);
    assert_int_equal(res.changed[0], 0);
    assert_true(same_polygons(&src, 0, &dst, 0));
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    /* octs skip only the plane that makes slivers: a base 10 x 1 with a middle arm 2 x 4 and end
     * stubs 0.1 x 0.8 (area 18.16, mirror-symmetric about x = 5, centroid y = 29.224 / 18.16 =
     * 1.609): the principal axes are x, y and z; the plane y = 1.609 would cut 0.1 x 0.19 tips off
     * the stubs (0.1 % each), so only x = 5 and z = 1/2 apply: four mirror-image children */
    const double comb[] = {0, 0, 10, 0, 10, 1.8, 9.9, 1.8, 9.9, 1,   6, 1,
                           6, 5, 4,  5, 4,  1,   0.1, 1,   0.1, 1.8, 0, 1.8};
    pf_mesh src2 = make_prism(comb, 12);
    pf_refine_request octs = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src2, &octs, 1, &dst, &res);
    assert_int_equal(res.n_split, 1);
    assert_int_equal(res.n_planes_skipped, 1);
    assert_int_equal(res.n_children, 4);
    for (int c = 0; c < 4; ++c)
        assert_near(pf_mesh_elem_volume(&dst, c), 18.16 / 4, 1e-12 * 18.16);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src2);
    /* the other direction makes no sliver */
    req.normal = pf_v3(1, 0, 0);
    refine_ok(&src, &req, 1, &dst, &res);
    assert_int_equal(res.n_split, 1);
    assert_int_equal(res.n_planes_skipped, 0);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* ---- tetrahedra and sliced meshes -------------------------------------------------------------
 */

/* Kuhn tets of a 2x1x1 box: one by octs, one (a face neighbour) by halves, then every tet by
 * octs. A tet's children by octs are whatever the planes make; with the sliver rule some planes
 * may be skipped, never all three (the first plane through a convex element's centroid leaves at
 * least (3/4)^3 of it on each side, Gruenbaum's bound). */
static void test_tets(void **state)
{
    (void)state;
    pf_mesh src = {0}, dst = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err),
                     PF_OK);
    pf_refine_result res;
    pf_refine_request req[12] = {{.elem = 0, .kind = PF_SPLIT_OCTS},
                                 {.elem = 1, .kind = PF_SPLIT_HALVES, .normal = {1, 2, 3}}};
    refine_ok(&src, req, 2, &dst, &res);
    assert_int_equal(res.n_split, 2);
    assert_true(res.n_children >= 2 + 2);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    for (int32_t e = 0; e < 12; ++e) { /* each alone */
        req[0] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_OCTS};
        refine_ok(&src, req, 1, &dst, &res);
        assert_int_equal(res.n_split, 1);
        pf_refine_result_release(&res);
        pf_mesh_release(&dst);
        req[0] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_HALVES, .normal = {-1, 0.5, 2}};
        refine_ok(&src, req, 1, &dst, &res);
        assert_int_equal(res.n_split, 1);
        pf_refine_result_release(&res);
        pf_mesh_release(&dst);
    }
    for (int i = 0; i < 12; ++i)
        req[i] = (pf_refine_request){.elem = (i * 5) % 12, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, req, 12, &dst, &res);
    assert_int_equal(res.n_split, 12);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* Random requests (about a third of the elements, either kind, random normals, random order),
 * twice in a row (the second round splits elements whose faces the first subdivided), on a hex
 * box, Kuhn tets, a sliced sphere and an octree of a sphere (cells of three depths: faces split
 * into the neighbours' faces, collinear face vertices). */
static void refine_randomly(pf_mesh *m, rng *r, const char *name)
{
    for (int round = 0; round < 2; ++round) {
        int32_t n = 0;
        pf_refine_request *req = calloc((size_t)m->n_elems, sizeof *req);
        uint8_t *used = calloc((size_t)m->n_elems, 1);
        assert_non_null(req), assert_non_null(used);
        for (int32_t i = 0; i < m->n_elems / 3; ++i) {
            int32_t e = (int32_t)(uniform01(r) * m->n_elems);
            if (used[e])
                continue;
            used[e] = 1;
            req[n++] =
                (pf_refine_request){.elem = e,
                                    .kind = uniform01(r) < 0.5 ? PF_SPLIT_OCTS : PF_SPLIT_HALVES,
                                    .normal = pf_v3(uniform(r), uniform(r), uniform(r))};
        }
        pf_mesh dst = {0};
        pf_refine_result res;
        pf_error err = {0};
        pf_status st = pf_mesh_refine(m, req, n, &dst, &res, &err);
        CHECKF(st == PF_OK, "%s round %d: %s", name, round, err.msg);
        check_refined(m, &dst, &res);
        assert_int_equal(res.n_split + res.n_skipped, n);
        printf(
            "%s round %d: %d elements, %d split, %d skipped, %d children, %d neighbours changed\n",
            name, round, (int)m->n_elems, (int)res.n_split, (int)res.n_skipped, (int)res.n_children,
            (int)res.n_neighbours_changed);
        pf_refine_result_release(&res);
        pf_mesh_release(m);
        *m = dst;
        free(req);
        free(used);
    }
}

static void test_random_requests(void **state)
{
    (void)state;
    rng r = {0x9e3779b97f4a7c15ull};
    pf_error err = {0};
    pf_mesh m = make_box(4, 3, 3, 4, 3, 3);
    refine_randomly(&m, &r, "box");
    pf_mesh_release(&m);
    assert_int_equal(pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(2, 2, 1), 2, 2, 1, &err),
                     PF_OK);
    refine_randomly(&m, &r, "tets");
    pf_mesh_release(&m);

    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 4;
    assert_int_equal(pf_mesh_slice(&m, &s, &sp, NULL, &err), PF_OK);
    refine_randomly(&m, &r, "sliced sphere");
    pf_mesh_release(&m);
    pf_octree_params op = pf_octree_params_default();
    op.depth = 3;
    op.min_depth = 1;
    assert_int_equal(pf_mesh_octree(&m, &s, &op, NULL, &err), PF_OK);
    refine_randomly(&m, &r, "octree");
    pf_mesh_release(&m);
    pf_surface_release(&s);
}

/* A Kuhn cube (6 tets around its diagonal): one tet split by halves, then a neighbour by octs, in
 * two calls (the neighbour's faces carry the first split's nodes, on the diagonal too): every
 * ordered pair, with halves planes along an axis, a face diagonal, through a tet edge, through a
 * vertex and generic. */
static void test_kuhn_halves_then_octs(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = {0};
    assert_int_equal(pf_mesh_make_box_tets(&src, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 1, 1, 1, &err),
                     PF_OK);
    assert_int_equal(src.n_elems, 6);
    assert_int_equal(pf_mesh_derive(&src, &err), PF_OK);
    const pf_vec3 normals[] = {{0, 1, 0}, {1, -1, 0}, {1, 1, -2}, {1, -2, 1}, {0.3, -0.8, 0.5}};
    for (int32_t a = 0; a < 6; ++a)
        for (int32_t b = 0; b < 6; ++b)
            for (size_t k = 0; k < sizeof normals / sizeof *normals && a != b; ++k) {
                pf_mesh mid = {0}, dst = {0};
                pf_refine_result r1, r2;
                pf_refine_request req = {.elem = a, .kind = PF_SPLIT_HALVES, .normal = normals[k]};
                refine_ok(&src, &req, 1, &mid, &r1);
                req = (pf_refine_request){.elem = -1, .kind = PF_SPLIT_OCTS};
                for (int32_t e = 0; e < mid.n_elems && req.elem < 0; ++e)
                    req.elem = r1.parent[e] == b ? e : -1;
                refine_ok(&mid, &req, 1, &dst, &r2);
                assert_int_equal(r2.n_split, 1);
                pf_refine_result_release(&r1), pf_refine_result_release(&r2);
                pf_mesh_release(&mid), pf_mesh_release(&dst);
            }
    pf_mesh_release(&src);
}

/* 200 random sequences of 4 calls, each of 1 to 3 requests (either kind, halves normals random
 * or along an axis), on a Kuhn cube and on the sphere sliced 3 across: every result is valid
 * and keeps the volume (check_refined). */
static void test_random_sequences(void **state)
{
    (void)state;
    rng r = {0x2545f4914f6cdd1dull};
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    for (int seq = 0; seq < 200; ++seq) {
        pf_mesh m = {0};
        if (seq % 2 == 0) {
            assert_int_equal(
                pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 1, 1, 1, &err), PF_OK);
        } else {
            pf_slice_params sp = pf_slice_params_default();
            sp.grid.res = 3;
            assert_int_equal(pf_mesh_slice(&m, &s, &sp, NULL, &err), PF_OK);
        }
        for (int call = 0; call < 4; ++call) {
            pf_refine_request req[3];
            int32_t n = 0, want = 1 + (int32_t)(3 * uniform01(&r));
            for (int32_t k = 0; k < want; ++k) {
                int32_t e = (int32_t)(uniform01(&r) * m.n_elems),
                        axis = (int32_t)(4 * uniform01(&r));
                bool seen = false;
                for (int32_t j = 0; j < n; ++j)
                    seen |= req[j].elem == e;
                pf_vec3 normal = axis < 3 ? pf_v3(axis == 0, axis == 1, axis == 2)
                                          : pf_v3(uniform(&r), uniform(&r), uniform(&r));
                if (!seen)
                    req[n++] = (pf_refine_request){.elem = e,
                                                   .kind = uniform01(&r) < 0.5 ? PF_SPLIT_OCTS
                                                                               : PF_SPLIT_HALVES,
                                                   .normal = normal};
            }
            pf_mesh dst = {0};
            pf_refine_result res;
            pf_status st = pf_mesh_refine(&m, req, n, &dst, &res, &err);
            CHECKF(st == PF_OK, "sequence %d call %d: %s", seq, call, err.msg);
            check_refined(&m, &dst, &res);
            pf_refine_result_release(&res);
            pf_mesh_release(&m);
            m = dst;
        }
        pf_mesh_release(&m);
    }
    pf_surface_release(&s);
}

/* The same call twice gives byte-identical meshes and results. */
static void test_deterministic(void **state)
{
    (void)state;
    pf_mesh src = make_box(3, 2, 2, 3, 2, 2), a = {0}, b = {0};
    pf_refine_request req[4] = {{.elem = 4, .kind = PF_SPLIT_OCTS},
                                {.elem = 5, .kind = PF_SPLIT_HALVES, .normal = {0.3, 1, 0.2}},
                                {.elem = 1, .kind = PF_SPLIT_HALVES, .normal = {1, 0.1, 0.7}},
                                {.elem = 10, .kind = PF_SPLIT_OCTS}};
    pf_refine_result ra, rb;
    refine_ok(&src, req, 4, &a, &ra);
    refine_ok(&src, req, 4, &b, &rb);
    assert_int_equal(a.n_nodes, b.n_nodes);
    assert_int_equal(a.n_faces, b.n_faces);
    assert_int_equal(a.n_elems, b.n_elems);
    assert_memory_equal(a.x, b.x, 3 * (size_t)a.n_nodes * sizeof(double));
    assert_memory_equal(a.face_offsets, b.face_offsets, ((size_t)a.n_faces + 1) * sizeof(int64_t));
    assert_memory_equal(a.face_nodes, b.face_nodes,
                        (size_t)a.face_offsets[a.n_faces] * sizeof(uint32_t));
    assert_memory_equal(a.elem_offsets, b.elem_offsets, ((size_t)a.n_elems + 1) * sizeof(int64_t));
    assert_memory_equal(a.elem_faces, b.elem_faces,
                        (size_t)a.elem_offsets[a.n_elems] * sizeof(uint32_t));
    assert_memory_equal(ra.parent, rb.parent, (size_t)a.n_elems * sizeof(int32_t));
    assert_memory_equal(ra.changed, rb.changed, (size_t)a.n_elems);
    assert_memory_equal(ra.face_src, rb.face_src, (size_t)a.n_faces * sizeof(int32_t));
    pf_refine_result_release(&ra);
    pf_refine_result_release(&rb);
    pf_mesh_release(&a);
    pf_mesh_release(&b);
    pf_mesh_release(&src);
}

/* Bad requests: nothing is output, and the message names the request and element. */
static void test_bad_requests(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 1, 1, 2, 1, 1), dst = {0};
    pf_refine_result res;
    pf_error err = {0};
    struct {
        pf_refine_request req[2];
        const char *says;
    } cases[] = {
        {{{.elem = 2, .kind = PF_SPLIT_OCTS}, {.elem = 0}}, "element 2"},
        {{{.elem = 1, .kind = PF_SPLIT_OCTS}, {.elem = 1}}, "element 1 a second time"},
        {{{.elem = 0, .kind = PF_SPLIT_OCTS}, {.elem = 1, .kind = 7}}, "unknown split kind"},
        {{{.elem = 0, .kind = PF_SPLIT_OCTS}, {.elem = 1, .kind = PF_SPLIT_HALVES}}, "element 1"},
        {{{.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {NAN, 0, 1}}, {.elem = 1}}, "element 0"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; ++i) {
        pf_status st = pf_mesh_refine(&src, cases[i].req, 2, &dst, &res, &err);
        assert_int_equal(st, PF_ERR_INVALID);
        CHECKF(strstr(err.msg, cases[i].says), "case %zu: %s", i, err.msg);
        assert_null(dst.x);
        assert_null(res.parent);
        assert_int_equal(dst.n_elems, 0);
    }
    /* an inside-out element */
    pf_mesh_release(&src);
    src = make_box(1, 1, 1, 1, 1, 1);
    for (int64_t k = 0; k < src.elem_offsets[1]; ++k)
        src.elem_faces[k] ^= PF_FACE_REVERSED;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    pf_status st = pf_mesh_refine(&src, &req, 1, &dst, &res, &err);
    assert_true(st < 0);
    CHECKF(strstr(err.msg, "element 0"), "%s", err.msg);
    assert_null(dst.x);
    pf_mesh_release(&src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_corner_octs),
        cmocka_unit_test(test_uniform_octs),
        cmocka_unit_test(test_octs_box_axes),
        cmocka_unit_test(test_neighbour_halves),
        cmocka_unit_test(test_plane_near_vertex),
        cmocka_unit_test(test_plane_between_neighbour_cuts),
        cmocka_unit_test(test_l_shape),
        cmocka_unit_test(test_u_shape_three_children),
        cmocka_unit_test(test_octs_comb_bounded),
        cmocka_unit_test(test_sliver_skipped),
        cmocka_unit_test(test_tets),
        cmocka_unit_test(test_random_requests),
        cmocka_unit_test(test_kuhn_halves_then_octs),
        cmocka_unit_test(test_random_sequences),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_bad_requests),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
