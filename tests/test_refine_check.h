/* Shared by the refinement tests (test_refine.c, test_refine_sliced.c): a refined mesh checked
 * against its source (valid, conforming without hanging nodes, volume and boundary area kept,
 * children in their parents, unchanged elements marked so) and pf_mesh_refine with that check.
 * Include after <cmocka.h>, <math.h>, "test_check.h" and <pf/refine.h>. */
#ifndef PF_TEST_REFINE_CHECK_H
#define PF_TEST_REFINE_CHECK_H

#include <stdbool.h>

#include <pf/mesh.h>
#include <pf/refine.h>

static inline double face_area(const pf_mesh *m, int32_t f)
{
    return pf_polygon_area(m->x, m->face_nodes + m->face_offsets[f],
                           m->face_offsets[f + 1] - m->face_offsets[f]);
}

static inline double boundary_area(const pf_mesh *m)
{
    double a = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0)
            a += face_area(m, f);
    return a;
}

static inline double total_volume(const pf_mesh *m)
{
    double v = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        v += pf_mesh_elem_volume(m, e);
    return v;
}

/* The narrowest face of m: over the faces, the largest distance of a face's node from the line
 * through its two farthest nodes, over their distance (0 for a face with collinear nodes). */
static inline double narrowest_face(const pf_mesh *m)
{
    double worst = INFINITY;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t k0 = m->face_offsets[f], n = m->face_offsets[f + 1] - k0;
        const uint32_t *fn = m->face_nodes + k0;
        pf_vec3 a = pf_v3_load(m->x + 3 * (size_t)fn[0]), b = a;
        double diam = 0;
        for (int64_t i = 0; i < n; ++i)
            for (int64_t j = i + 1; j < n; ++j) {
                pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)fn[i]);
                pf_vec3 q = pf_v3_load(m->x + 3 * (size_t)fn[j]);
                if (pf_v3_dist(p, q) > diam)
                    diam = pf_v3_dist(p, q), a = p, b = q;
            }
        pf_vec3 u = pf_v3_normalize(pf_v3_sub(b, a));
        double width = 0;
        for (int64_t i = 0; i < n; ++i) {
            pf_vec3 d = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)fn[i]), a);
            width = fmax(width, pf_v3_norm(pf_v3_sub(d, pf_v3_scale(u, pf_v3_dot(d, u)))));
        }
        worst = fmin(worst, width / diam);
    }
    return worst;
}

/* Element e of a and element d of b have the same face polygons, node for node, in order. */
static inline bool same_polygons(const pf_mesh *a, int32_t e, const pf_mesh *b, int32_t d)
{
    int64_t n = a->elem_offsets[e + 1] - a->elem_offsets[e];
    if (b->elem_offsets[d + 1] - b->elem_offsets[d] != n)
        return false;
    for (int64_t k = 0; k < n; ++k) {
        uint32_t ea = a->elem_faces[a->elem_offsets[e] + k];
        uint32_t eb = b->elem_faces[b->elem_offsets[d] + k];
        if ((ea & PF_FACE_REVERSED) != (eb & PF_FACE_REVERSED))
            return false;
        int32_t fa = PF_FACE_INDEX(ea), fb = PF_FACE_INDEX(eb);
        int64_t len = a->face_offsets[fa + 1] - a->face_offsets[fa];
        if (b->face_offsets[fb + 1] - b->face_offsets[fb] != len ||
            memcmp(a->face_nodes + a->face_offsets[fa], b->face_nodes + b->face_offsets[fb],
                   (size_t)len * sizeof(uint32_t)) != 0)
            return false;
    }
    return true;
}

/* No node lies strictly inside a face edge (u, v): for each edge, the other edges at u are
 * checked for one that runs along (u, v) and ends before v. */
static inline void check_no_hanging_nodes(const pf_mesh *m)
{
    int64_t nfn = m->face_offsets[m->n_faces];
    /* all undirected edges as (u, v) pairs, both ways round */
    uint32_t *ed = malloc(4 * (size_t)nfn * sizeof *ed);
    int64_t *first = calloc((size_t)m->n_nodes + 1, sizeof *first);
    uint32_t *nbr = malloc(2 * (size_t)nfn * sizeof *nbr);
    assert_non_null(ed), assert_non_null(first), assert_non_null(nbr);
    int64_t ne = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t k0 = m->face_offsets[f], n = m->face_offsets[f + 1] - k0;
        for (int64_t k = 0; k < n; ++k) {
            uint32_t u = m->face_nodes[k0 + k], v = m->face_nodes[k0 + (k + 1) % n];
            ed[2 * ne] = u, ed[2 * ne + 1] = v, ne++;
            ed[2 * ne] = v, ed[2 * ne + 1] = u, ne++;
        }
    }
    for (int64_t i = 0; i < ne; ++i)
        first[ed[2 * i] + 1]++;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        first[i + 1] += first[i];
    int64_t *fill = malloc(((size_t)m->n_nodes + 1) * sizeof *fill);
    memcpy(fill, first, ((size_t)m->n_nodes + 1) * sizeof *fill);
    for (int64_t i = 0; i < ne; ++i)
        nbr[fill[ed[2 * i]]++] = ed[2 * i + 1];
    for (int64_t i = 0; i < ne; ++i) {
        uint32_t u = ed[2 * i], v = ed[2 * i + 1];
        pf_vec3 pu = pf_v3(m->x[3 * u], m->x[3 * u + 1], m->x[3 * u + 2]);
        pf_vec3 d = pf_v3_sub(pf_v3(m->x[3 * v], m->x[3 * v + 1], m->x[3 * v + 2]), pu);
        double len2 = pf_v3_dot(d, d);
        for (int64_t k = first[u]; k < first[u + 1]; ++k) {
            uint32_t w = nbr[k];
            if (w == v)
                continue;
            pf_vec3 q = pf_v3_sub(pf_v3(m->x[3 * w], m->x[3 * w + 1], m->x[3 * w + 2]), pu);
            double t = pf_v3_dot(q, d) / len2;
            double off = pf_v3_norm(pf_v3_sub(q, pf_v3_scale(d, t)));
            CHECKF(!(t > 1e-9 && t < 1 - 1e-9 && off <= 1e-9 * sqrt(len2)),
                   "node %u hangs inside edge %u-%u", w, u, v);
        }
    }
    free(ed), free(first), free(nbr), free(fill);
}

/* Everything pf_mesh_refine promises for any input: a valid derived conforming mesh without
 * hanging nodes, src nodes kept bit for bit, children in place of their parent with the parent's
 * volume, total volume and boundary area unchanged, `changed` and `face_src` exact. */
static inline void check_refined(const pf_mesh *src, const pf_mesh *dst,
                                 const pf_refine_result *res)
{
    pf_error err = {0};
    CHECKF(pf_mesh_validate(dst, NULL, &err) == PF_OK, "validate: %s", err.msg);
    assert_non_null(dst->face_elems);
    assert_true(dst->id == src->id + 1);
    assert_true(dst->n_nodes >= src->n_nodes);
    assert_memory_equal(dst->x, src->x, 3 * (size_t)src->n_nodes * sizeof(double));
    check_no_hanging_nodes(dst);

    pf_mesh s = {0};
    assert_int_equal(pf_mesh_copy(&s, src, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&s, &err), PF_OK);
    double vs = total_volume(&s), vd = total_volume(dst);
    assert_near(vd, vs, 1e-12 * vs);
    double as = boundary_area(&s), ad = boundary_area(dst);
    assert_near(ad, as, 1e-12 * as);

    int32_t d = 0, children = 0, neighbours = 0;
    for (int32_t e = 0; e < src->n_elems; ++e) {
        CHECKF(d < dst->n_elems && res->parent[d] == e, "element %d is not in place", (int)e);
        int32_t d0 = d;
        double sum = 0;
        while (d < dst->n_elems && res->parent[d] == e)
            sum += pf_mesh_elem_volume(dst, d++);
        double ve = pf_mesh_elem_volume(src, e);
        assert_near(sum, ve, 1e-12 * ve);
        if (d - d0 > 1) {
            children += d - d0;
            for (int32_t c = d0; c < d; ++c)
                assert_int_equal(res->changed[c], 1);
        } else {
            bool same = same_polygons(src, e, dst, d0);
            CHECKF(res->changed[d0] == !same, "element %d: changed %d, polygons %s", (int)e,
                   res->changed[d0], same ? "same" : "different");
            neighbours += res->changed[d0];
        }
    }
    assert_int_equal(d, dst->n_elems);
    assert_int_equal(res->n_children, children);
    assert_int_equal(res->n_neighbours_changed, neighbours);
    for (int32_t f = 0; f < dst->n_faces; ++f) {
        int32_t g = res->face_src[f];
        if (g < 0)
            continue;
        int64_t n = dst->face_offsets[f + 1] - dst->face_offsets[f];
        assert_true(g < src->n_faces);
        assert_int_equal(src->face_offsets[g + 1] - src->face_offsets[g], n);
        assert_memory_equal(dst->face_nodes + dst->face_offsets[f],
                            src->face_nodes + src->face_offsets[g], (size_t)n * sizeof(uint32_t));
    }
    pf_mesh_release(&s);
}

static inline void refine_ok(const pf_mesh *src, const pf_refine_request *req, int32_t n,
                             pf_mesh *dst, pf_refine_result *res)
{
    pf_error err = {0};
    pf_status st = pf_mesh_refine(src, req, n, dst, res, &err);
    CHECKF(st == PF_OK, "refine: %s", err.msg);
    check_refined(src, dst, res);
}

#endif
