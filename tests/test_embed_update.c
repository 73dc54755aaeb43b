/* embed_update: MLS weights updated after a refinement and a coarsening are bit for bit the
 * weights computed afresh on the new mesh, and only the rows the change reaches are recomputed.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "test_check.h"
#include <pf/embed.h>
#include <pf/io.h>
#include <pf/mesh.h>
#include <pf/refine.h>

typedef struct embedded {
    pf_weights w;
    int32_t *steps;
} embedded;

static void embedded_release(embedded *e)
{
    pf_weights_release(&e->w);
    free(e->steps);
    memset(e, 0, sizeof *e);
}

static embedded compute(const pf_mesh *m, const pf_surface *s)
{
    pf_error err = {0};
    embedded e = {0};
    e.steps = calloc((size_t)s->n_verts, sizeof *e.steps);
    assert_non_null(e.steps);
    pf_status st = pf_embed_compute_steps(m, s, NULL, &e.w, e.steps, NULL, &err);
    CHECKF(st == PF_OK, "embed: %s", err.msg);
    return e;
}

static void assert_same_bits(const embedded *a, const embedded *b)
{
    assert_int_equal(a->w.rows, b->w.rows);
    assert_int_equal(a->w.cols, b->w.cols);
    assert_true(a->w.mesh_id == b->w.mesh_id && a->w.surface_id == b->w.surface_id);
    int32_t rows = a->w.rows;
    assert_memory_equal(a->w.row_offsets, b->w.row_offsets, ((size_t)rows + 1) * sizeof(int64_t));
    size_t nnz = (size_t)a->w.row_offsets[rows];
    assert_memory_equal(a->w.col, b->w.col, nnz * sizeof *a->w.col);
    assert_memory_equal(a->w.val, b->w.val, nnz * sizeof *a->w.val);
    assert_memory_equal(a->steps, b->steps, (size_t)rows * sizeof *a->steps);
}

/* Rows of a and b that differ (a's nodes renumbered by node_map, NULL: the identity). */
static int32_t rows_differing(const embedded *a, const embedded *b, const int32_t *node_map)
{
    int32_t n = 0;
    for (int32_t v = 0; v < a->w.rows; ++v) {
        int64_t qa = a->w.row_offsets[v], qb = b->w.row_offsets[v];
        int64_t len = a->w.row_offsets[v + 1] - qa;
        bool differ = len != b->w.row_offsets[v + 1] - qb || a->steps[v] != b->steps[v];
        for (int64_t k = 0; k < len && !differ; ++k) {
            uint32_t c = a->w.col[qa + k];
            differ = (node_map ? (uint32_t)node_map[c] : c) != b->w.col[qb + k] ||
                     memcmp(a->w.val + qa + k, b->w.val + qb + k, sizeof(double));
        }
        n += differ;
    }
    return n;
}

/* The update from (m0, e0) to m1 checked against a full computation on m1; returns the full one
 * and the update's statistics. */
static embedded update_and_check(const pf_mesh *m0, const embedded *e0, const pf_mesh *m1,
                                 const int32_t *node_map, const pf_surface *s,
                                 pf_embed_update_stats *st)
{
    pf_error err = {0};
    embedded up = {0};
    up.steps = calloc((size_t)s->n_verts, sizeof *up.steps);
    assert_non_null(up.steps);
    pf_status status =
        pf_embed_update(m0, &e0->w, e0->steps, m1, node_map, s, NULL, &up.w, up.steps, st, &err);
    CHECKF(status == PF_OK, "update: %s", err.msg);
    embedded full = compute(m1, s);
    assert_same_bits(&up, &full);
    embedded_release(&up);
    assert_int_equal(st->rows, s->n_verts);
    int32_t differ = rows_differing(e0, &full, node_map);
    print_message("%d of %d rows recomputed, %d of them changed, %d nodes changed\n",
                  (int)st->rows_computed, (int)st->rows, (int)differ, (int)st->nodes_changed);
    /* a row that changed was recomputed; and on these meshes every recomputed row changed (a
     * node entering or leaving a support, or a radius changing in it, moves the weights): no row
     * is recomputed for nothing */
    assert_int_equal(st->rows_computed, differ);
    return full;
}

/* The mean x of element e's face corners (each face's own). */
static double mean_x(const pf_mesh *m, int32_t e)
{
    double sum = 0;
    int64_t n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q, ++n)
            sum += m->x[3 * (size_t)m->face_nodes[q]];
    }
    return sum / (double)n;
}

/* Refines the elements whose mean corner lies beyond the plane x = cut (octs), updates, coarsens
 * them back, updates again: each update matches a full computation; a local change recomputes
 * the rows it changes and no other (at most max_fraction of them), the unchanged mesh none. */
static void refine_and_coarsen(pf_mesh *m0, const pf_surface *s, double cut, double max_fraction)
{
    pf_error err = {0};
    m0->id = 1;
    embedded e0 = compute(m0, s);
    pf_refine_request *req = calloc((size_t)m0->n_elems, sizeof *req);
    assert_non_null(req);
    int32_t n_req = 0;
    for (int32_t e = 0; e < m0->n_elems; ++e) {
        if (mean_x(m0, e) > cut)
            req[n_req++] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_OCTS};
    }
    assert_true(n_req > 0 && n_req < m0->n_elems);
    pf_mesh m1 = {0};
    pf_refine_result res;
    CHECKF(pf_mesh_refine(m0, req, n_req, &m1, &res, &err) == PF_OK, "refine: %s", err.msg);
    m1.id = 2;
    pf_embed_update_stats st;
    embedded e1 = update_and_check(m0, &e0, &m1, NULL, s, &st);
    assert_true(st.rows_computed > 0);
    assert_true(st.rows_computed <= max_fraction * st.rows);
    assert_true(st.nodes_changed > 0);

    pf_mesh m2 = {0};
    pf_coarsen_result cres;
    CHECKF(pf_mesh_coarsen(&m1, res.parent, &m2, &cres, &err) == PF_OK, "coarsen: %s", err.msg);
    m2.id = 3;
    assert_true(cres.n_removed_nodes > 0);
    embedded e2 = update_and_check(&m1, &e1, &m2, cres.node_map, s, &st);
    assert_true(st.rows_computed > 0 && st.rows_computed <= max_fraction * st.rows);
    /* the cycle gives back the first mesh, and with it the first weights' bits */
    assert_int_equal(m2.n_nodes, m0->n_nodes);
    assert_memory_equal(e2.w.val, e0.w.val, (size_t)e0.w.row_offsets[s->n_verts] * sizeof(double));

    /* nothing changed: nothing recomputed */
    embedded e3 = update_and_check(&m2, &e2, &m2, NULL, s, &st);
    assert_int_equal(st.rows_computed, 0);
    assert_int_equal(st.nodes_changed, 0);

    embedded_release(&e0);
    embedded_release(&e1);
    embedded_release(&e2);
    embedded_release(&e3);
    pf_coarsen_result_release(&cres);
    pf_refine_result_release(&res);
    pf_mesh_release(&m1);
    pf_mesh_release(&m2);
    free(req);
}

/* A fine sphere inside a sliced coarser one (hexes inside, polyhedra at the surface). */
static void sphere_in_sliced_sphere(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface outer = {0}, inner = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_surface_make_sphere(&outer, 1, 8, 16, &err), PF_OK);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 8;
    assert_int_equal(pf_mesh_slice(&m, &outer, &p, NULL, &err), PF_OK);
    assert_int_equal(pf_surface_make_sphere(&inner, 0.9, 24, 48, &err), PF_OK);
    refine_and_coarsen(&m, &inner, 0.5, 0.5);
    pf_mesh_release(&m);
    pf_surface_release(&outer);
    pf_surface_release(&inner);
}

/* A sphere inside a box of hexes (the voxel case: its surface inside the mesh). */
static void sphere_in_hex_box(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(-1, -1, -1), pf_v3(1, 1, 1), 6, 6, 6, &err), PF_OK);
    assert_int_equal(pf_surface_make_sphere(&s, 0.8, 20, 40, &err), PF_OK);
    refine_and_coarsen(&m, &s, 0.5, 0.5);
    pf_mesh_release(&m);
    pf_surface_release(&s);
}

/* The bunny in its own sliced mesh at a small resolution. */
static void bunny_in_sliced_bunny(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    if (pf_import_surface(PF_TEST_DATA_DIR "/../../data/models/bunny.obj", &s, &err) != PF_OK)
        fail_msg("bunny: %s", err.msg);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 4;
    CHECKF(pf_mesh_slice(&m, &s, &p, NULL, &err) == PF_OK, "slice: %s", err.msg);
    double lo = INFINITY, hi = -INFINITY;
    for (int32_t i = 0; i < m.n_nodes; ++i) {
        lo = fmin(lo, m.x[3 * (size_t)i]);
        hi = fmax(hi, m.x[3 * (size_t)i]);
    }
    refine_and_coarsen(&m, &s, lo + 0.7 * (hi - lo), 0.6);
    pf_mesh_release(&m);
    pf_surface_release(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sphere_in_sliced_sphere),
        cmocka_unit_test(sphere_in_hex_box),
        cmocka_unit_test(bunny_in_sliced_bunny),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
