/* coarsen: pf_mesh_coarsen, alone and as the inverse of pf_mesh_refine.
 *
 * Oracles, independent of the code under test:
 * - refine-then-coarsen gives back the refined mesh: the same node count and coordinates (bit for
 *   bit) in the same order, the same elements in the same order, each with the same set of face
 *   polygons seen from outside (each compared as a cyclic node sequence), found by comparing the
 *   two meshes directly.
 * - volumes: each merged element's volume is the sum of its group's, the total unchanged. A
 *   volume is a sum over fan tetrahedra of O(1) size with relative rounding ~1e-16 per term; a
 *   few hundred terms give ~1e-14, so 1e-12 relative is tight yet safe. Removing a node that
 *   lies on a straight edge within PF_COARSEN_TOL = 1e-10 could move a volume by ~1e-10 of it,
 *   but the nodes refinement makes lie on their edges to rounding, so 1e-12 still holds.
 * - boxes merged whole: closed forms (a 2x2x2 box of cubes merges into one hexahedron on its 8
 *   corners).
 * - `changed` against a direct comparison of each dst element's faces with its src element's
 *   through node_map; elements sharing no node with a group must be unchanged. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/refine.h>

#include "test_check.h"
#include "test_prism.h"

/* ---- helpers -----------------------------------------------------------------------------------
 */

/* The outward polygons of element e, each rotated to start at its smallest node, sorted: a
 * canonical form of the element as a set of cyclic node sequences. Row r of the result is
 * (length, nodes..., padding) in a table of width 1 + max_len. */
typedef struct poly_set {
    int32_t n, width;
    uint32_t *rows;
} poly_set;

static int32_t g_width; /* qsort comparator context (tests are single-threaded) */

static int cmp_rows(const void *a, const void *b)
{
    return memcmp(a, b, (size_t)g_width * sizeof(uint32_t));
}

static poly_set element_polys(const pf_mesh *m, int32_t e)
{
    poly_set s = {0};
    s.n = (int32_t)(m->elem_offsets[e + 1] - m->elem_offsets[e]);
    int64_t longest = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        longest = n > longest ? n : longest;
    }
    s.width = (int32_t)longest + 1;
    s.rows = calloc((size_t)s.n * (size_t)s.width, sizeof *s.rows);
    assert_non_null(s.rows);
    for (int32_t i = 0; i < s.n; ++i) {
        uint32_t entry = m->elem_faces[m->elem_offsets[e] + i];
        int32_t f = PF_FACE_INDEX(entry);
        const uint32_t *p = m->face_nodes + m->face_offsets[f];
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        uint32_t *row = s.rows + (size_t)i * (size_t)s.width;
        row[0] = (uint32_t)n;
        int64_t start = 0;
        for (int64_t k = 1; k < n; ++k)
            if (p[k] < p[start])
                start = k;
        for (int64_t k = 0; k < n; ++k) {
            int64_t j = (entry & PF_FACE_REVERSED) ? start - k : start + k;
            row[1 + k] = p[((j % n) + n) % n];
        }
    }
    g_width = s.width;
    qsort(s.rows, (size_t)s.n, (size_t)s.width * sizeof *s.rows, cmp_rows);
    return s;
}

/* b is a (same nodes, same elements in order, same polygon sets, same total volume). */
static void check_same_mesh(const pf_mesh *a, const pf_mesh *b)
{
    assert_int_equal(b->n_nodes, a->n_nodes);
    assert_memory_equal(b->x, a->x, 3 * (size_t)a->n_nodes * sizeof(double));
    assert_int_equal(b->n_elems, a->n_elems);
    assert_int_equal(b->n_faces, a->n_faces);
    for (int32_t e = 0; e < a->n_elems; ++e) {
        poly_set pa = element_polys(a, e), pb = element_polys(b, e);
        CHECKF(pa.n == pb.n && pa.width == pb.width &&
                   memcmp(pa.rows, pb.rows, (size_t)pa.n * (size_t)pa.width * 4) == 0,
               "element %d: faces differ (%d and %d faces)", (int)e, (int)pa.n, (int)pb.n);
        free(pa.rows);
        free(pb.rows);
    }
    double va = pf_mesh_volume(a), vb = pf_mesh_volume(b);
    assert_near(vb, va, 1e-12 * va);
}

/* Element e of src and element d of dst have the same faces node for node through map. */
static bool same_faces(const pf_mesh *src, int32_t e, const pf_mesh *dst, int32_t d,
                       const int32_t *map)
{
    int64_t n = src->elem_offsets[e + 1] - src->elem_offsets[e];
    if (dst->elem_offsets[d + 1] - dst->elem_offsets[d] != n)
        return false;
    for (int64_t k = 0; k < n; ++k) {
        uint32_t es = src->elem_faces[src->elem_offsets[e] + k];
        uint32_t ed = dst->elem_faces[dst->elem_offsets[d] + k];
        int32_t fs = PF_FACE_INDEX(es), fd = PF_FACE_INDEX(ed);
        int64_t len = src->face_offsets[fs + 1] - src->face_offsets[fs];
        if ((es ^ ed) & PF_FACE_REVERSED ||
            dst->face_offsets[fd + 1] - dst->face_offsets[fd] != len)
            return false;
        for (int64_t j = 0; j < len; ++j)
            if (map[src->face_nodes[src->face_offsets[fs] + j]] !=
                (int32_t)dst->face_nodes[dst->face_offsets[fd] + j])
                return false;
    }
    return true;
}

/* Everything pf_mesh_coarsen promises for any input. */
static void check_coarsened(const pf_mesh *src, const int32_t *group, const pf_mesh *dst,
                            const pf_coarsen_result *res)
{
    pf_error err = {0};
    CHECKF(pf_mesh_validate(dst, NULL, &err) == PF_OK, "validate: %s", err.msg);
    assert_non_null(dst->face_elems);
    assert_true(dst->id == src->id + 1);
    /* kept nodes compact in src order, coordinates bit for bit */
    int32_t next = 0, removed = 0;
    for (int32_t v = 0; v < src->n_nodes; ++v) {
        if (res->node_map[v] < 0) {
            removed++;
            continue;
        }
        assert_int_equal(res->node_map[v], next++);
        assert_memory_equal(dst->x + 3 * (size_t)res->node_map[v], src->x + 3 * (size_t)v,
                            3 * sizeof(double));
    }
    assert_int_equal(next, dst->n_nodes);
    assert_int_equal(removed, res->n_removed_nodes);
    /* elements in src order, a group at its first element with its volume */
    int32_t d = 0, merged = 0;
    uint8_t *near_group = calloc((size_t)src->n_nodes + 1, 1);
    assert_non_null(near_group);
    for (int32_t e = 0; e < src->n_elems; ++e)
        if (group[e] >= 0) {
            int32_t count = 0;
            for (int32_t o = 0; o < src->n_elems; ++o)
                count += group[o] == group[e];
            if (count < 2)
                continue;
            for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(src->elem_faces[k]);
                for (int64_t j = src->face_offsets[f]; j < src->face_offsets[f + 1]; ++j)
                    near_group[src->face_nodes[j]] = 1;
            }
        }
    for (int32_t e = 0; e < src->n_elems; ++e) {
        int32_t first = e;
        if (group[e] >= 0)
            for (int32_t o = 0; o < e && first == e; ++o)
                if (group[o] == group[e])
                    first = o;
        if (first != e)
            continue;
        CHECKF(d < dst->n_elems && res->parent[d] == e, "element %d is not in place", (int)e);
        double want = 0;
        int32_t count = 0;
        for (int32_t o = e; o < src->n_elems; ++o)
            if (o == e || (group[e] >= 0 && group[o] == group[e])) {
                want += pf_mesh_elem_volume(src, o);
                count++;
            }
        assert_near(pf_mesh_elem_volume(dst, d), want, 1e-12 * want);
        merged += count >= 2;
        bool same = count < 2 && same_faces(src, e, dst, d, res->node_map);
        CHECKF(res->changed[d] == !same, "element %d: changed %d", (int)e, res->changed[d]);
        bool untouched = count < 2;
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1] && untouched; ++k) {
            int32_t f = PF_FACE_INDEX(src->elem_faces[k]);
            for (int64_t j = src->face_offsets[f]; j < src->face_offsets[f + 1]; ++j)
                untouched &= !near_group[src->face_nodes[j]];
        }
        if (untouched)
            CHECKF(res->changed[d] == 0, "untouched element %d changed", (int)e);
        d++;
    }
    free(near_group);
    assert_int_equal(d, dst->n_elems);
    /* face_src: the src face with the same mapped node sequence, else -1 (by brute force) */
    for (int32_t f = 0; f < dst->n_faces; ++f) {
        int64_t n = dst->face_offsets[f + 1] - dst->face_offsets[f];
        const uint32_t *q = dst->face_nodes + dst->face_offsets[f];
        int32_t found = -1;
        for (int32_t g = 0; g < src->n_faces && found < 0; ++g) {
            const uint32_t *p = src->face_nodes + src->face_offsets[g];
            if (src->face_offsets[g + 1] - src->face_offsets[g] != n ||
                res->node_map[p[0]] != (int32_t)q[0])
                continue;
            bool same = true;
            for (int64_t k = 1; k < n && same; ++k)
                same = res->node_map[p[k]] == (int32_t)q[k];
            if (same)
                found = g;
        }
        CHECKF(res->face_src[f] == found, "face %d: face_src %d, expected %d", (int)f,
               (int)res->face_src[f], (int)found);
    }
    assert_int_equal(merged, res->n_merged);
    double vs = pf_mesh_volume(src), vd = pf_mesh_volume(dst);
    assert_near(vd, vs, 1e-12 * vs);
}

static void coarsen_ok(const pf_mesh *src, const int32_t *group, pf_mesh *dst,
                       pf_coarsen_result *res)
{
    pf_error err = {0};
    pf_status st = pf_mesh_coarsen(src, group, dst, res, &err);
    CHECKF(st == PF_OK, "coarsen: %s", err.msg);
    check_coarsened(src, group, dst, res);
}

static void refine_ok(const pf_mesh *src, const pf_refine_request *req, int32_t n, pf_mesh *dst,
                      pf_refine_result *res)
{
    pf_error err = {0};
    pf_status st = pf_mesh_refine(src, req, n, dst, res, &err);
    CHECKF(st == PF_OK, "refine: %s", err.msg);
}

/* Refines src by req, coarsens every split element's children again (group = the refine
 * result's parent) and checks that src comes back. Returns the number of children. */
static int32_t cycle(const pf_mesh *src, const pf_refine_request *req, int32_t n)
{
    pf_mesh mid = {0}, back = {0};
    pf_refine_result rr;
    pf_coarsen_result cr;
    refine_ok(src, req, n, &mid, &rr);
    int32_t children = rr.n_children;
    coarsen_ok(&mid, rr.parent, &back, &cr);
    assert_int_equal(cr.n_merged, rr.n_split);
    check_same_mesh(src, &back);
    /* elements the refinement left alone are unchanged by the coarsening too */
    for (int32_t d = 0, e = 0; d < mid.n_elems; ++d) {
        if (d > 0 && rr.parent[d] == rr.parent[d - 1])
            continue;
        if (!rr.changed[d])
            CHECKF(!cr.changed[e], "element %d: changed after the cycle", (int)e);
        e++;
    }
    pf_refine_result_release(&rr);
    pf_coarsen_result_release(&cr);
    pf_mesh_release(&mid);
    pf_mesh_release(&back);
    return children;
}

static pf_mesh make_box(int nx, int ny, int nz, double sx, double sy, double sz)
{
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(sx, sy, sz), nx, ny, nz, &err),
                     PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    m.id = 7;
    return m;
}

/* ---- merging whole boxes ------------------------------------------------------------------------
 */

/* The 8 cubes of a 2x2x2 box as one group: one hexahedron on the 8 corners (the 19 other nodes
 * are inside, in the middle of a face or of an edge), its faces the box's sides. */
static void test_merge_box(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 2, 2, 2, 2, 2), dst = {0}, one = make_box(1, 1, 1, 2, 2, 2);
    int32_t group[8] = {5, 5, 5, 5, 5, 5, 5, 5};
    pf_coarsen_result res;
    coarsen_ok(&src, group, &dst, &res);
    assert_int_equal(dst.n_elems, 1);
    assert_int_equal(dst.n_nodes, 8);
    assert_int_equal(dst.n_faces, 6);
    assert_int_equal(dst.elem_kind[0], PF_ELEM_HEX);
    assert_int_equal(res.n_merged, 1);
    assert_int_equal(res.n_removed_nodes, 19);
    /* the corners are nodes 0, 2, 6, 8, 18, 20, 24, 26 of the 3x3x3 lattice, in that order */
    const int corners[8] = {0, 2, 6, 8, 18, 20, 24, 26};
    for (int i = 0; i < 8; ++i)
        assert_int_equal(res.node_map[corners[i]], i);
    check_same_mesh(&one, &dst);
    pf_coarsen_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
    pf_mesh_release(&one);
}

/* Two groups side by side in a 4x1x1 row and an element that stays: {0, 1} and {2, 3} become two
 * 2x1x1 boxes sharing the face x = 2; the face x = 1 and x = 3 nodes go. */
static void test_two_groups(void **state)
{
    (void)state;
    pf_mesh src = make_box(4, 1, 1, 4, 1, 1), dst = {0};
    int32_t group[4] = {9, 9, 3, 3};
    pf_coarsen_result res;
    coarsen_ok(&src, group, &dst, &res);
    assert_int_equal(dst.n_elems, 2);
    assert_int_equal(dst.n_nodes, 12);
    assert_int_equal(dst.n_faces, 11);
    assert_int_equal(res.n_merged, 2);
    assert_int_equal(res.parent[0], 0);
    assert_int_equal(res.parent[1], 2);
    for (int d = 0; d < 2; ++d) {
        assert_int_equal(dst.elem_kind[d], PF_ELEM_HEX);
        assert_near(pf_mesh_elem_volume(&dst, d), 2, 1e-14);
    }
    pf_coarsen_result_release(&res);
    pf_mesh_release(&dst);
    /* a group of one element and elements without a group stay as they are */
    int32_t alone[4] = {-1, 4, -1, 0};
    coarsen_ok(&src, alone, &dst, &res);
    assert_int_equal(res.n_merged, 0);
    assert_int_equal(res.n_removed_nodes, 0);
    check_same_mesh(&src, &dst);
    for (int d = 0; d < 4; ++d)
        assert_int_equal(res.changed[d], 0);
    pf_coarsen_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
}

/* A ring: the 8 cubes of a 3x3x1 box around its centre as one group (an element with a hole).
 * The tops (and bottoms) are coplanar and meet along removed faces' edges, but their union is an
 * annulus, not one simple polygon: they stay 8 faces each. Each outer side's 3 squares become one
 * 3x1 rectangle (its inner nodes are corners of the tops and bottoms, so they stay); the hole's
 * sides are single squares already. Nothing is removed: 32 nodes, 8 + 8 + 4 + 4 faces. */
static void test_ring_not_simple(void **state)
{
    (void)state;
    pf_mesh sq = make_box(3, 3, 1, 3, 3, 1), ring = {0}, dst = {0};
    pf_error err = {0};
    uint8_t keep[9] = {1, 1, 1, 1, 0, 1, 1, 1, 1};
    assert_int_equal(pf_mesh_select_elements(&ring, &sq, keep, NULL, &err), PF_OK);
    int32_t group[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    pf_coarsen_result res;
    coarsen_ok(&ring, group, &dst, &res);
    assert_int_equal(dst.n_elems, 1);
    assert_int_equal(dst.n_nodes, 32);
    assert_int_equal(res.n_removed_nodes, 0);
    assert_int_equal(dst.n_faces, 24);
    assert_near(pf_mesh_elem_volume(&dst, 0), 8, 1e-14);
    int32_t rect = 0;
    for (int32_t f = 0; f < dst.n_faces; ++f)
        rect += fabs(pf_polygon_area(dst.x, dst.face_nodes + dst.face_offsets[f],
                                     dst.face_offsets[f + 1] - dst.face_offsets[f]) -
                     3) < 1e-14;
    assert_int_equal(rect, 4);
    pf_coarsen_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&ring);
    pf_mesh_release(&sq);
}

/* A group must be face-connected: elements 0 and 2 of a row of 3 (or 0 and 3 of a 2x2x1 box,
 * which share only an edge) are refused, naming the group; nothing is output. */
static void test_not_connected(void **state)
{
    (void)state;
    pf_mesh row = make_box(3, 1, 1, 3, 1, 1), sq = make_box(2, 2, 1, 2, 2, 1), dst = {0};
    pf_coarsen_result res;
    pf_error err = {0};
    int32_t g1[3] = {4, -1, 4}, g2[4] = {6, 1, 2, 6}, g3[3] = {-1, -2, -1};
    assert_int_equal(pf_mesh_coarsen(&row, g1, &dst, &res, &err), PF_ERR_INVALID);
    CHECKF(strstr(err.msg, "group 4 is not face-connected"), "%s", err.msg);
    assert_null(dst.x);
    assert_null(res.parent);
    assert_int_equal(pf_mesh_coarsen(&sq, g2, &dst, &res, &err), PF_ERR_INVALID);
    CHECKF(strstr(err.msg, "group 6"), "%s", err.msg);
    assert_null(dst.x);
    assert_int_equal(pf_mesh_coarsen(&row, g3, &dst, &res, &err), PF_ERR_INVALID);
    CHECKF(strstr(err.msg, "element 1"), "%s", err.msg);
    assert_null(res.node_map);
    pf_mesh_release(&row);
    pf_mesh_release(&sq);
}

/* ---- refine, then coarsen
 * ------------------------------------------------------------------------
 */

static void test_cycle_boxes(void **state)
{
    (void)state;
    pf_mesh src = make_box(3, 3, 3, 3, 3, 3);
    /* the centre, a corner, an edge element; one by halves along a slanted plane */
    pf_refine_request one = {.elem = 13, .kind = PF_SPLIT_OCTS};
    assert_int_equal(cycle(&src, &one, 1), 8);
    pf_refine_request req[4] = {{.elem = 0, .kind = PF_SPLIT_OCTS},
                                {.elem = 1, .kind = PF_SPLIT_OCTS}, /* adjacent to 0 */
                                {.elem = 4, .kind = PF_SPLIT_HALVES, .normal = {0, 0, 1}},
                                {.elem = 5, .kind = PF_SPLIT_HALVES, .normal = {1, 0.3, 0.2}}};
    assert_true(cycle(&src, req, 4) >= 8 + 8 + 2 + 2);
    /* halves of two adjacent elements along different planes (their shared face in quarters) */
    pf_refine_request hv[2] = {{.elem = 13, .kind = PF_SPLIT_HALVES, .normal = {0, 0, 1}},
                               {.elem = 14, .kind = PF_SPLIT_HALVES, .normal = {0, 1, 0}}};
    assert_int_equal(cycle(&src, hv, 2), 4);
    /* a plane through two edges of a cube: its faces are cut along diagonals */
    pf_refine_request diag = {.elem = 13, .kind = PF_SPLIT_HALVES, .normal = {1, 1, 0}};
    assert_int_equal(cycle(&src, &diag, 1), 2);
    /* every element */
    pf_refine_request all[27];
    for (int i = 0; i < 27; ++i)
        all[i] = (pf_refine_request){.elem = (i * 5) % 27,
                                     .kind = i % 3 ? PF_SPLIT_OCTS : PF_SPLIT_HALVES,
                                     .normal = {1, 0.5 * i, 0.25}};
    assert_true(cycle(&src, all, 27) > 27);
    pf_mesh_release(&src);
}

static void test_cycle_tets(void **state)
{
    (void)state;
    pf_mesh src = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(&src, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err),
                     PF_OK);
    pf_refine_request req[12] = {{.elem = 0, .kind = PF_SPLIT_OCTS},
                                 {.elem = 1, .kind = PF_SPLIT_HALVES, .normal = {1, 2, 3}}};
    assert_true(cycle(&src, req, 2) >= 4);
    for (int i = 0; i < 12; ++i)
        req[i] = (pf_refine_request){.elem = (i * 5) % 12, .kind = PF_SPLIT_OCTS};
    assert_true(cycle(&src, req, 12) > 12);
    for (int i = 0; i < 12; ++i)
        req[i] = (pf_refine_request){.elem = i, .kind = PF_SPLIT_HALVES, .normal = {1, 0.5, 0.25}};
    assert_true(cycle(&src, req, 12) > 12);
    pf_mesh_release(&src);
}


/* Non-convex: an L-shaped mesh (a 2x2x1 box without one cube) and a single L-prism element,
 * whose halves and octs make non-convex children (the U's plane through its centroid makes
 * three: a plane request, since halves make at most two and skip it). */
static void test_cycle_non_convex(void **state)
{
    (void)state;
    pf_mesh sq = make_box(2, 2, 2, 2, 2, 2), l = {0};
    pf_error err = {0};
    uint8_t keep[8] = {1, 1, 1, 0, 1, 1, 1, 0};
    assert_int_equal(pf_mesh_select_elements(&l, &sq, keep, NULL, &err), PF_OK);
    pf_refine_request req[3] = {{.elem = 0, .kind = PF_SPLIT_OCTS},
                                {.elem = 2, .kind = PF_SPLIT_HALVES, .normal = {1, 1, 0}},
                                {.elem = 4, .kind = PF_SPLIT_OCTS}};
    assert_true(cycle(&l, req, 3) >= 18);
    pf_mesh_release(&l);
    pf_mesh_release(&sq);

    const double lxy[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    pf_mesh lp = make_prism(lxy, 6);
    pf_refine_request r = {.elem = 0, .kind = PF_SPLIT_HALVES, .normal = {1, 0, 0}};
    assert_int_equal(cycle(&lp, &r, 1), 2);
    r.kind = PF_SPLIT_OCTS;
    assert_true(cycle(&lp, &r, 1) >= 4);
    pf_mesh_release(&lp);
    const double uxy[] = {0, 0, 3, 0, 3, 3, 2, 3, 2, 1, 1, 1, 1, 3, 0, 3};
    pf_mesh up = make_prism(uxy, 8);
    r = (pf_refine_request){
        .elem = 0, .kind = PF_SPLIT_PLANE, .normal = {0, 1, 0}, .point = {1.5, 9.5 / 7, 0.5}};
    assert_int_equal(cycle(&up, &r, 1), 3);
    pf_mesh_release(&up);
}

/* A sphere sliced on a 4^3 grid: exact polyhedra with non-convex faces at the surface. Every
 * third element by octs or halves, then every element. */
static void test_cycle_sliced_sphere(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh src = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 4;
    assert_int_equal(pf_mesh_slice(&src, &s, &p, NULL, &err), PF_OK);
    int32_t n = src.n_elems;
    pf_refine_request *req = calloc((size_t)n, sizeof *req);
    assert_non_null(req);
    int32_t nr = 0;
    for (int32_t e = 0; e < n; e += 3)
        req[nr++] = (pf_refine_request){.elem = e,
                                        .kind = (e % 2) ? PF_SPLIT_HALVES : PF_SPLIT_OCTS,
                                        .normal = {cos(e), sin(2.0 * e), 0.3 + cos(3.0 * e)}};
    cycle(&src, req, nr);
    for (int32_t e = 0; e < n; ++e)
        req[e] = (pf_refine_request){.elem = e,
                                     .kind = (e % 2) ? PF_SPLIT_HALVES : PF_SPLIT_OCTS,
                                     .normal = {cos(e), sin(2.0 * e), 0.3 + cos(3.0 * e)}};
    cycle(&src, req, n);
    free(req);
    pf_mesh_release(&src);
    pf_surface_release(&s);
}

/* Refined twice nested: a child of a refined cube refined again. Coarsening the grandchildren
 * gives back the once-refined mesh, coarsening that the original; both levels in one call too. */
static void test_cycle_nested(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 2, 2, 2, 2, 2), m1 = {0}, m2 = {0}, b1 = {0}, b0 = {0};
    pf_refine_result r1, r2;
    pf_coarsen_result c1, c0;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, &req, 1, &m1, &r1);
    pf_refine_request req2[2] = {{.elem = 7, .kind = PF_SPLIT_OCTS}, /* the inner child */
                                 {.elem = 2, .kind = PF_SPLIT_HALVES, .normal = {1, 0, 1}}};
    refine_ok(&m1, req2, 2, &m2, &r2);
    coarsen_ok(&m2, r2.parent, &b1, &c1);
    assert_int_equal(c1.n_merged, 2);
    check_same_mesh(&m1, &b1);
    coarsen_ok(&b1, r1.parent, &b0, &c0);
    assert_int_equal(c0.n_merged, 1);
    check_same_mesh(&src, &b0);
    pf_coarsen_result_release(&c1);
    pf_coarsen_result_release(&c0);
    pf_mesh_release(&b1);
    pf_mesh_release(&b0);
    /* both levels at once */
    int32_t *group = malloc((size_t)m2.n_elems * sizeof *group);
    assert_non_null(group);
    for (int32_t d = 0; d < m2.n_elems; ++d)
        group[d] = r1.parent[r2.parent[d]];
    coarsen_ok(&m2, group, &b0, &c0);
    check_same_mesh(&src, &b0);
    free(group);
    pf_coarsen_result_release(&c0);
    pf_mesh_release(&b0);
    pf_refine_result_release(&r1);
    pf_refine_result_release(&r2);
    pf_mesh_release(&m1);
    pf_mesh_release(&m2);
    pf_mesh_release(&src);
}

/* Three rounds of refinement of pseudo-random elements (a fixed linear congruential sequence:
 * every third element, octs or halves along varied normals), undone in reverse order: each
 * coarsening gives back the mesh before the matching refinement. */
static void test_cycle_three_rounds(void **state)
{
    (void)state;
    pf_mesh m[4] = {make_box(3, 2, 2, 3, 2, 2)};
    pf_refine_result r[3];
    uint32_t seed = 12345;
    for (int round = 0; round < 3; ++round) {
        int32_t n = m[round].n_elems, nr = 0;
        pf_refine_request *req = calloc((size_t)n, sizeof *req);
        assert_non_null(req);
        for (int32_t e = 0; e < n; ++e) {
            seed = seed * 1664525u + 1013904223u;
            if ((seed >> 16) % 3 != 0)
                continue;
            double a = (double)(seed >> 8 & 0xff) / 40.0;
            req[nr++] =
                (pf_refine_request){.elem = e,
                                    .kind = (seed >> 24) & 1 ? PF_SPLIT_HALVES : PF_SPLIT_OCTS,
                                    .normal = {cos(a), sin(a), 0.5 * cos(3 * a)}};
        }
        m[round + 1] = (pf_mesh){0};
        refine_ok(&m[round], req, nr, &m[round + 1], &r[round]);
        assert_true(r[round].n_split > 0);
        free(req);
    }
    pf_mesh cur = m[3];
    for (int round = 2; round >= 0; --round) {
        pf_mesh back = {0};
        pf_coarsen_result cr;
        coarsen_ok(&cur, r[round].parent, &back, &cr);
        assert_int_equal(cr.n_merged, r[round].n_split);
        check_same_mesh(&m[round], &back);
        pf_coarsen_result_release(&cr);
        if (round < 2)
            pf_mesh_release(&cur);
        cur = back;
    }
    pf_mesh_release(&cur);
    for (int i = 0; i < 4; ++i)
        pf_mesh_release(&m[i]);
    for (int i = 0; i < 3; ++i)
        pf_refine_result_release(&r[i]);
}

/* Whether element e of m has a node at p (exact coordinates) in n faces. */
static int32_t faces_with_point(const pf_mesh *m, int32_t e, pf_vec3 p)
{
    int32_t n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            const double *q = m->x + 3 * (size_t)m->face_nodes[j];
            n += q[0] == p.x && q[1] == p.y && q[2] == p.z;
        }
    }
    return n;
}

/* Conformity wins: cube A of a 2x1x1 row refined by octs, then its neighbour N by octs; merging
 * A's children keeps N's nodes on the shared face x = 1: that face stays 4 quarters, each shared
 * with one child of N, and the edge midpoints of x = 1 stay (corners of the quarters); A's other
 * 14 nodes go. Nodes: 12 + 19 of N's refinement. Merging N's children then gives the row back. */
static void test_neighbour_refined_later(void **state)
{
    (void)state;
    pf_mesh src = make_box(2, 1, 1, 2, 1, 1), m1 = {0}, m2 = {0}, dst = {0};
    pf_refine_result r1, r2;
    pf_coarsen_result res;
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    refine_ok(&src, &req, 1, &m1, &r1);
    req.elem = 8;
    refine_ok(&m1, &req, 1, &m2, &r2);
    assert_int_equal(m2.n_elems, 16);
    int32_t group[16];
    for (int32_t d = 0; d < 16; ++d)
        group[d] = r1.parent[r2.parent[d]] == 0 ? 0 : -1;
    coarsen_ok(&m2, group, &dst, &res);
    assert_int_equal(dst.n_elems, 9);
    assert_int_equal(dst.n_nodes, 12 + 19);
    assert_int_equal(res.n_removed_nodes, 14);
    assert_near(pf_mesh_elem_volume(&dst, 0), 1, 1e-14);
    int32_t quarters = 0;
    for (int64_t k = dst.elem_offsets[0]; k < dst.elem_offsets[1]; ++k) {
        int32_t f = PF_FACE_INDEX(dst.elem_faces[k]);
        int32_t other =
            dst.face_elems[2 * f] == 0 ? dst.face_elems[2 * f + 1] : dst.face_elems[2 * f];
        if (other >= 1) {
            quarters++;
            assert_near(pf_polygon_area(dst.x, dst.face_nodes + dst.face_offsets[f],
                                        dst.face_offsets[f + 1] - dst.face_offsets[f]),
                        0.25, 1e-15);
        }
    }
    assert_int_equal(quarters, 4);
    assert_int_equal(dst.elem_offsets[1] - dst.elem_offsets[0], 5 + 4);
    /* the centre of x = 1 in the 4 quarters; an edge midpoint of x = 1 in 2 quarters and in the
     * side face it lies on; the midpoint of an edge away from x = 1 nowhere */
    assert_int_equal(faces_with_point(&dst, 0, pf_v3(1, 0.5, 0.5)), 4);
    assert_int_equal(faces_with_point(&dst, 0, pf_v3(1, 0, 0.5)), 3);
    assert_int_equal(faces_with_point(&dst, 0, pf_v3(0.5, 0, 0)), 0);
    for (int32_t d = 1; d < 9; ++d)
        assert_int_equal(res.changed[d], 0);
    /* then N's children: the row of two cubes again */
    int32_t g2[9] = {-1, 1, 1, 1, 1, 1, 1, 1, 1};
    pf_mesh back = {0};
    pf_coarsen_result r3;
    coarsen_ok(&dst, g2, &back, &r3);
    check_same_mesh(&src, &back);
    pf_coarsen_result_release(&r3);
    pf_mesh_release(&back);
    pf_coarsen_result_release(&res);
    pf_mesh_release(&dst);
    pf_refine_result_release(&r1);
    pf_refine_result_release(&r2);
    pf_mesh_release(&m1);
    pf_mesh_release(&m2);
    pf_mesh_release(&src);
}

/* The same call twice gives byte-identical meshes and results. */
static void test_deterministic(void **state)
{
    (void)state;
    pf_mesh src = make_box(3, 2, 2, 3, 2, 2), mid = {0}, a = {0}, b = {0};
    pf_refine_request req[4] = {{.elem = 4, .kind = PF_SPLIT_OCTS},
                                {.elem = 5, .kind = PF_SPLIT_HALVES, .normal = {0.3, 1, 0.2}},
                                {.elem = 1, .kind = PF_SPLIT_HALVES, .normal = {1, 0.1, 0.7}},
                                {.elem = 10, .kind = PF_SPLIT_OCTS}};
    pf_refine_result rr;
    pf_coarsen_result ra, rb;
    refine_ok(&src, req, 4, &mid, &rr);
    coarsen_ok(&mid, rr.parent, &a, &ra);
    coarsen_ok(&mid, rr.parent, &b, &rb);
    assert_int_equal(a.n_nodes, b.n_nodes);
    assert_int_equal(a.n_faces, b.n_faces);
    assert_int_equal(a.n_elems, b.n_elems);
    assert_true(a.id == b.id);
    assert_memory_equal(a.x, b.x, 3 * (size_t)a.n_nodes * sizeof(double));
    assert_memory_equal(a.face_offsets, b.face_offsets, ((size_t)a.n_faces + 1) * sizeof(int64_t));
    assert_memory_equal(a.face_nodes, b.face_nodes,
                        (size_t)a.face_offsets[a.n_faces] * sizeof(uint32_t));
    assert_memory_equal(a.elem_offsets, b.elem_offsets, ((size_t)a.n_elems + 1) * sizeof(int64_t));
    assert_memory_equal(a.elem_faces, b.elem_faces,
                        (size_t)a.elem_offsets[a.n_elems] * sizeof(uint32_t));
    assert_memory_equal(ra.parent, rb.parent, (size_t)a.n_elems * sizeof(int32_t));
    assert_memory_equal(ra.changed, rb.changed, (size_t)a.n_elems);
    assert_memory_equal(ra.node_map, rb.node_map, (size_t)mid.n_nodes * sizeof(int32_t));
    assert_int_equal(ra.n_removed_nodes, rb.n_removed_nodes);
    pf_coarsen_result_release(&ra);
    pf_coarsen_result_release(&rb);
    pf_refine_result_release(&rr);
    pf_mesh_release(&a);
    pf_mesh_release(&b);
    pf_mesh_release(&mid);
    pf_mesh_release(&src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_merge_box),
        cmocka_unit_test(test_two_groups),
        cmocka_unit_test(test_ring_not_simple),
        cmocka_unit_test(test_not_connected),
        cmocka_unit_test(test_cycle_boxes),
        cmocka_unit_test(test_cycle_tets),
        cmocka_unit_test(test_cycle_non_convex),
        cmocka_unit_test(test_cycle_sliced_sphere),
        cmocka_unit_test(test_cycle_nested),
        cmocka_unit_test(test_cycle_three_rounds),
        cmocka_unit_test(test_neighbour_refined_later),
        cmocka_unit_test(test_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
