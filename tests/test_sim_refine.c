/* sim_refine: changing the simulation mesh while it runs (pf_sim_split, pf_sim_refine): the state
 * carried over (DG exactly, CG exactly for fields its children reproduce), linear momentum and
 * volume across a change, stress-based refinement where the stress is high and nowhere else,
 * halves against octs, an embedded surface, and bit-for-bit determinism. */
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
#include <pf/embed.h>
#include <pf/fem.h>
#include <pf/sim.h>

#include "test_sim_changes.h"

#include "basis_meshes.h"
#include "sim/sim_internal.h"

/* A free 2 x 1 x 1 box of 4 x 2 x 2 hexes deformed by an affine displacement and moving with an
 * affine velocity (a spin plus a translation). */
static pf_sim *free_affine_body(const char *json, pf_mesh *m, pf_scene *sc)
{
    make_box(m, pf_v3(2, 1, 1), 4, 2, 2);
    parse(sc, json);
    pf_sim *sim = create(sc, m);
    double a[9] = {0.01, 0.02, 0, 0, -0.01, 0.03, 0.02, 0, 0.015}, b[3] = {0.1, -0.2, 0.05};
    pf_sim_set_affine_displacement(sim, a, b);
    pf_sim_set_rigid_velocity(sim, pf_v3(0.3, -0.2, 0.5), pf_v3(1, 0.5, 0.5), pf_v3(1, 2, -3));
    return sim;
}

/* A free body moving with an affine velocity (spin plus translation) and deformed by an affine
 * displacement, split at two elements: both methods represent affine fields exactly on any mesh,
 * so the carried state is the same field; kinetic energy, linear and angular momentum and the
 * deformed volume agree to round-off (1e-12 relative: sums over some hundred elements of products
 * of exact integrals). */
static void affine_state_survives_split(const char *json, pf_split_kind kind)
{
    pf_mesh m = {0};
    pf_scene sc;
    pf_sim *sim = free_affine_body(json, &m, &sc);
    double k0, k1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &k0, &p0, &l0);
    double v0 = pf_sim_deformed_volume(sim);
    pf_refine_request req[2] = {{.elem = 1, .kind = kind, .normal = {1, 1, 0}},
                                {.elem = 6, .kind = kind, .normal = {0, 0, 1}}};
    pf_error err = {0};
    int32_t split = 0;
    if (pf_sim_split(sim, req, 2, &split, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(split, 2);
    const pf_mesh *now = pf_sim_mesh(sim);
    assert_true(now->n_elems == m.n_elems + (kind == PF_SPLIT_OCTS ? 14 : 2));
    assert_true(now->id != m.id);
    assert_true(rel(rest_volume(now), rest_volume(&m)) < 1e-12);
    pf_sim_momentum(sim, &k1, &p1, &l1);
    assert_true(rel(k1, k0) < 1e-12);
    assert_true(vec_rel(p1, p0) < 1e-12);
    assert_true(vec_rel(l1, l0) < 1e-12);
    assert_true(rel(pf_sim_deformed_volume(sim), v0) < 1e-12);
    /* and it runs on */
    if (pf_sim_frame(sim, &err) < 0)
        fail_msg("frame after the split: %s", err.msg);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static const char FREE_BODY[] =
    "{\"gravity\": [0, 0, 0], \"ground\": false, \"time\": {\"dt\": 0.01}";

static void test_dg_affine_octs(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s}", FREE_BODY);
    affine_state_survives_split(json, PF_SPLIT_OCTS);
    snprintf(json, sizeof json, "%s, \"method\": {\"degree\": 2}}", FREE_BODY);
    affine_state_survives_split(json, PF_SPLIT_OCTS);
}

static void test_dg_affine_halves(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s}", FREE_BODY);
    affine_state_survives_split(json, PF_SPLIT_HALVES);
}

static void test_cg_affine(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s, \"method\": \"cg\"}", FREE_BODY);
    affine_state_survives_split(json, PF_SPLIT_OCTS);
    affine_state_survives_split(json, PF_SPLIT_HALVES);
}

/* A bent state (a clamped beam after some frames under gravity: not affine). DG carries the very
 * same polynomial into each child, so momentum and kinetic energy are unchanged to round-off
 * (1e-12). CG's new nodes take the parent's field, exact inside the split hexahedra (their
 * children's trilinear functions reproduce it); the neighbours whose faces gained nodes become
 * harmonic polyhedra whose boundary data still match the old trilinear trace at every node, and
 * whose interior reproduces it to the MFS error only: measured 7e-16 (momentum) and 4e-7
 * (kinetic energy) relative on this beam, bound 1e-5 (25 x the kinetic energy's change). */
static void bent_state_momentum(const char *json, double bound)
{
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_scene sc;
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    for (int f = 0; f < 3; ++f)
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
    double k0, k1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &k0, &p0, &l0);
    pf_refine_request req[3] = {{.elem = 0, .kind = PF_SPLIT_OCTS},
                                {.elem = 9, .kind = PF_SPLIT_OCTS},
                                {.elem = 31, .kind = PF_SPLIT_OCTS}};
    int32_t split = 0;
    if (pf_sim_split(sim, req, 3, &split, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(split, 3);
    pf_sim_momentum(sim, &k1, &p1, &l1);
    double dp = vec_rel(p1, p0), dk = rel(k1, k0);
    print_message("    %s: momentum %.2e, kinetic energy %.2e relative change\n",
                  sc.method == PF_METHOD_CG ? "cg" : "dg", dp, dk);
    assert_true(dp < bound);
    assert_true(dk < bound);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static const char CLAMPED[] = "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, "
                              "0]}}], \"ground\": false, \"material\": {\"E\": 1e6}";

static void test_bent_momentum(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s}", CLAMPED);
    bent_state_momentum(json, 1e-12);
    snprintf(json, sizeof json, "%s, \"method\": {\"degree\": 2}}", CLAMPED);
    bent_state_momentum(json, 1e-12);
    snprintf(json, sizeof json, "%s, \"method\": \"cg\"}", CLAMPED);
    bent_state_momentum(json, 1e-5);
}

/* The bending bar of the harmonic paper's fig. 8 as a beam clamped at both ends under gravity:
 * the bending moment of a clamped-clamped beam is largest at the clamps, half that at mid-span,
 * and zero near 0.21 L from each end. With the threshold between the mid-span and clamp
 * stresses, refinement happens at the clamps only: every split element had a principal stress
 * above the threshold, and the elements of the middle stay whole. halves makes fewer elements
 * than octs for the same threshold. */
static int32_t bending_bar(pf_split_kind kind, double *max_x_split)
{
    pf_mesh m = {0};
    make_box(&m, pf_v3(9, 1, 1), 18, 2, 2);
    pf_scene sc;
    parse(&sc, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}},"
               " {\"plane\": {\"point\": [9, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"ground\": false, \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.05},"
               " \"time\": {\"frames\": 8}}");
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    for (int f = 0; f < 8; ++f)
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
    /* the threshold: 60 % of the largest stress, above the mid-span's (about half of it) */
    int32_t ne = m.n_elems;
    double *stress = malloc((size_t)ne * sizeof *stress);
    pf_sim_von_mises(sim, stress);
    double largest = 0;
    for (int32_t e = 0; e < ne; ++e)
        largest = fmax(largest, stress[e]);
    free(stress);
    assert_true(refine_once(sim, &sc, 0.6 * largest, kind) > 0);
    const pf_mesh *now = pf_sim_mesh(sim);
    /* every split element is near a clamp: the children are the elements smaller than a cell */
    *max_x_split = 0;
    double cell = 0.5 * 0.5 * 0.5;
    int32_t n = now->n_elems;
    for (int32_t e = 0; e < n; ++e) {
        if (pf_mesh_elem_volume(now, e) > 0.99 * cell)
            continue;
        pf_vec3 lo = {INFINITY, INFINITY, INFINITY};
        for (int64_t q = now->elem_offsets[e]; q < now->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(now->elem_faces[q]);
            for (int64_t k = now->face_offsets[f]; k < now->face_offsets[f + 1]; ++k)
                lo.x = fmin(lo.x, now->x[3 * (size_t)now->face_nodes[k]]);
        }
        double from_end = fmin(lo.x, 9 - lo.x);
        *max_x_split = fmax(*max_x_split, from_end);
    }
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return n;
}

static void test_bending_bar(void **state)
{
    (void)state;
    double octs_reach, halves_reach;
    int32_t octs = bending_bar(PF_SPLIT_OCTS, &octs_reach);
    int32_t halves = bending_bar(PF_SPLIT_HALVES, &halves_reach);
    print_message("    bending bar of 72 hexes: octs %d elements, halves %d; refined within %.2f "
                  "and %.2f of a clamp (span 9)\n",
                  (int)octs, (int)halves, octs_reach, halves_reach);
    assert_true(halves < octs);
    /* the moment's zero is 0.21 x 9 = 1.9 from each end: nothing beyond it is refined */
    assert_true(octs_reach < 1.9);
    assert_true(halves_reach < 1.9);
}

/* A run that refines as it goes, twice: bit-for-bit the same frames, and the scene's limits kept.
 */
static void refining_run(int32_t *elements, double **frames, size_t *n_values)
{
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_scene sc;
    parse(&sc, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"ground\": false, \"material\": {\"E\": 1e6},"
               " \"refine\": {\"threshold\": 2000, \"max_level\": 1, \"max_elements\": 60}}");
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    size_t cap = 0;
    *frames = NULL;
    *n_values = 0;
    for (int f = 0; f < 6; ++f) {
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
        size_t nn = 3 * (size_t)pf_sim_mesh(sim)->n_nodes;
        if (*n_values + nn > cap) {
            cap = 2 * (*n_values + nn);
            *frames = realloc(*frames, cap * sizeof **frames);
        }
        pf_sim_nodal_displacements(sim, *frames + *n_values);
        *n_values += nn;
    }
    *elements = pf_sim_mesh(sim)->n_elems;
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    assert_true(st->refinements > 0);
    assert_true(*elements <= 60);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_deterministic(void **state)
{
    (void)state;
    int32_t e1, e2;
    double *f1, *f2;
    size_t n1, n2;
    refining_run(&e1, &f1, &n1);
    refining_run(&e2, &f2, &n2);
    assert_int_equal(e1, e2);
    assert_true(n1 == n2);
    assert_memory_equal(f1, f2, n1 * sizeof *f1);
    free(f1);
    free(f2);
}

/* An embedded surface (a box inside the mesh) dropped on the ground while the mesh refines: the
 * weights follow every new mesh (rows = surface vertices, columns = the new nodes). */
static void test_embedded(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, pf_v3(1, 1, 1), 3, 3, 3);
    pf_surface surf = {0};
    assert_int_equal(pf_surface_make_box(&surf, pf_v3(0.1, 0.1, 0.1), pf_v3(0.9, 0.9, 0.9), &err),
                     PF_OK);
    pf_weights w = {0};
    assert_int_equal(pf_embed_compute(&m, &surf, NULL, &w, NULL, &err), PF_OK);
    pf_scene sc;
    parse(&sc, "{\"ground\": {\"point\": [0, 0, 0.05]}, \"time\": {\"dt\": 0.02},"
               " \"refine\": {\"threshold\": 10, \"max_level\": 1, \"max_elements\": 60}}");
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create_embedded(&sim, &sc, &m, &surf, &w, &err), PF_OK);
    for (int f = 0; f < 10; ++f)
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame %d: %s", f, err.msg);
    const pf_mesh *now = pf_sim_mesh(sim);
    const pf_weights *nw = pf_sim_weights(sim);
    assert_true(pf_sim_get_stats(sim)->refinements > 0);
    assert_int_equal(nw->rows, surf.n_verts);
    assert_int_equal(nw->cols, now->n_nodes);
    assert_true(nw->mesh_id == now->id);
    /* the rows updated change after change are those computed afresh, bit for bit; the first
     * change computes every row (the caller's weights carry no growth steps) */
    pf_weights fresh = {0};
    assert_int_equal(pf_embed_compute(now, &surf, NULL, &fresh, NULL, &err), PF_OK);
    size_t nnz = (size_t)fresh.row_offsets[fresh.rows];
    assert_int_equal(nw->row_offsets[nw->rows], (int64_t)nnz);
    assert_memory_equal(nw->col, fresh.col, nnz * sizeof *fresh.col);
    assert_memory_equal(nw->val, fresh.val, nnz * sizeof *fresh.val);
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    assert_int_equal(st->embed_rows, (int64_t)st->refinements * surf.n_verts);
    assert_true(st->embed_rows_computed >= surf.n_verts &&
                st->embed_rows_computed <= st->embed_rows);
    pf_weights_release(&fresh);
    pf_sim_destroy(&sim);
    pf_weights_release(&w);
    pf_surface_release(&surf);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* Refine, then merge each split's children back: the mesh is the original again (nodes, element
 * volumes), and the DG field is the L2 projection of the children's: a field that was one
 * polynomial of the parent's degree on all children (here: carried from the parent, then merged
 * before any step) comes back with the same coefficients, to round-off; momentum and kinetic
 * energy unchanged to 1e-12. CG: the nodes kept keep their values, so an affine field survives. */
static void refine_then_merge(const char *json, pf_split_kind kind)
{
    pf_mesh m = {0};
    pf_scene sc;
    pf_sim *sim = free_affine_body(json, &m, &sc);
    size_t nn = 3 * (size_t)m.n_nodes;
    double *u0 = malloc(nn * sizeof *u0), *u1 = malloc(nn * sizeof *u1);
    pf_sim_nodal_displacements(sim, u0);
    double k0, k1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &k0, &p0, &l0);
    pf_refine_request req[2] = {{.elem = 1, .kind = kind, .normal = {1, 1, 0}},
                                {.elem = 2, .kind = kind, .normal = {0, 0, 1}}};
    pf_error err = {0};
    int32_t changed = 0;
    if (pf_sim_split(sim, req, 2, &changed, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(changed, 2);
    /* the groups: the children of element 1 and of element 2 */
    const pf_mesh *fine = pf_sim_mesh(sim);
    int32_t *group = malloc((size_t)fine->n_elems * sizeof *group);
    int32_t children = kind == PF_SPLIT_OCTS ? 8 : 2;
    for (int32_t e = 0; e < fine->n_elems; ++e)
        group[e] = e >= 1 && e < 1 + 2 * children ? (e - 1) / children : -1;
    if (pf_sim_merge(sim, group, &changed, &err) < 0)
        fail_msg("merge: %s", err.msg);
    free(group);
    assert_int_equal(changed, 2);
    const pf_mesh *back = pf_sim_mesh(sim);
    assert_int_equal(back->n_elems, m.n_elems);
    assert_int_equal(back->n_nodes, m.n_nodes);
    assert_memory_equal(back->x, m.x, nn * sizeof *m.x);
    for (int32_t e = 0; e < m.n_elems; ++e)
        assert_true(rel(pf_mesh_elem_volume(back, e), pf_mesh_elem_volume(&m, e)) < 1e-12);
    pf_sim_nodal_displacements(sim, u1);
    for (size_t q = 0; q < nn; ++q)
        assert_true(fabs(u1[q] - u0[q]) < 1e-12);
    pf_sim_momentum(sim, &k1, &p1, &l1);
    assert_true(rel(k1, k0) < 1e-12);
    assert_true(vec_rel(p1, p0) < 1e-12);
    assert_true(vec_rel(l1, l0) < 1e-12);
    free(u0);
    free(u1);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_refine_then_merge(void **state)
{
    (void)state;
    char json[256];
    snprintf(json, sizeof json, "%s}", FREE_BODY);
    refine_then_merge(json, PF_SPLIT_OCTS);
    refine_then_merge(json, PF_SPLIT_HALVES);
    snprintf(json, sizeof json, "%s, \"method\": {\"degree\": 2}}", FREE_BODY);
    refine_then_merge(json, PF_SPLIT_OCTS);
    snprintf(json, sizeof json, "%s, \"method\": \"cg\"}", FREE_BODY);
    refine_then_merge(json, PF_SPLIT_OCTS);
}

/* A bent DG state (not one polynomial across the children): merging keeps the momentum exactly
 * (the projection keeps the integral of the field against constants) and does not add kinetic
 * energy (an L2 projection does not increase the mass-weighted norm). */
static void test_merge_bent(void **state)
{
    (void)state;
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_scene sc;
    char json[256];
    snprintf(json, sizeof json, "%s, \"method\": {\"degree\": 2}}", CLAMPED);
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    int32_t changed = 0;
    if (pf_sim_split(sim, &req, 1, &changed, &err) < 0)
        fail_msg("split: %s", err.msg);
    for (int f = 0; f < 3; ++f)
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
    double k0, k1;
    pf_vec3 p0, l0, p1, l1;
    pf_sim_momentum(sim, &k0, &p0, &l0);
    const pf_mesh *fine = pf_sim_mesh(sim);
    int32_t *group = malloc((size_t)fine->n_elems * sizeof *group);
    for (int32_t e = 0; e < fine->n_elems; ++e)
        group[e] = e < 8 ? 0 : -1;
    if (pf_sim_merge(sim, group, &changed, &err) < 0)
        fail_msg("merge: %s", err.msg);
    free(group);
    pf_sim_momentum(sim, &k1, &p1, &l1);
    print_message(
        "    merged bent dg: momentum %.2e relative change, kinetic energy %.6f of before\n",
        vec_rel(p1, p0), k1 / k0);
    assert_true(vec_rel(p1, p0) < 1e-12);
    assert_true(k1 <= k0 * (1 + 1e-12));
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* The scene's criterion over a run: a clamped bar set swinging (an initial rotation about the
 * clamp, no gravity) bends hardest near the clamp and refines there; damping brings it to rest,
 * its stress falls below the coarsening stress and the splits merge back: the run ends on the
 * original mesh. */
static void test_bend_and_release(void **state)
{
    (void)state;
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_scene sc;
    parse(&sc, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"ground\": false, \"gravity\": [0, 0, 0], \"material\": {\"E\": 1e6},"
               " \"damping\": {\"alpha\": 3, \"beta\": 0.02},"
               " \"refine\": {\"threshold\": 2000, \"max_level\": 1, \"coarsen_after\": 3}}");
    pf_sim *sim = create(&sc, &m);
    pf_sim_set_rigid_velocity(sim, pf_v3(0, 0.5, 0), pf_v3(0, 0.5, 0.5), pf_v3(0, 0, 0));
    pf_error err = {0};
    int32_t most = m.n_elems;
    for (int f = 0; f < 90; ++f) { /* it swings twice; at rest by frame 85 */
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
        most = pf_sim_mesh(sim)->n_elems > most ? pf_sim_mesh(sim)->n_elems : most;
    }
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    print_message("    swing and rest: %d -> %d -> %d elements, %lld splits, %lld merges\n",
                  (int)m.n_elems, (int)most, (int)pf_sim_mesh(sim)->n_elems,
                  (long long)st->elements_split, (long long)st->elements_merged);
    assert_true(most > m.n_elems);
    assert_true(st->elements_merged > 0);
    assert_int_equal(pf_sim_mesh(sim)->n_elems, m.n_elems);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* A split of a split on a bar at rest (no stress): with coarsen_after 3 the deeper family merges
 * at the third frame and the one above it at the fourth, since the element merged back has been
 * calm as long as its children; it does not wait coarsen_after frames more per level. */
static void test_merge_levels_in_a_row(void **state)
{
    (void)state;
    pf_mesh m = {0};
    make_box(&m, pf_v3(4, 1, 1), 8, 2, 2);
    pf_scene sc;
    parse(&sc, "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
               " \"ground\": false, \"gravity\": [0, 0, 0],"
               " \"refine\": {\"threshold\": 1e9, \"coarsen_after\": 3}}");
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    pf_refine_request req = {.elem = 0, .kind = PF_SPLIT_OCTS};
    if (pf_sim_split(sim, &req, 1, NULL, &err) < 0 || pf_sim_split(sim, &req, 1, NULL, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(pf_sim_mesh(sim)->n_elems, 32 + 7 + 7);
    int32_t after[4];
    for (int f = 0; f < 4; ++f) {
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame: %s", err.msg);
        after[f] = pf_sim_mesh(sim)->n_elems;
    }
    print_message("    elements after frames 1-4: %d %d %d %d\n", (int)after[0], (int)after[1],
                  (int)after[2], (int)after[3]);
    assert_int_equal(after[1], 46);
    assert_int_equal(after[2], 39);
    assert_int_equal(after[3], 32);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* The DG integrals a refined mesh copies from the old set-up (pf_dg_create_reusing, with the
 * refinement's face map) equal those a fresh set-up computes, to round-off (1e-12 of each
 * array's largest entry: the same integrals summed in another order over subdivided faces), and
 * on a mesh of 128 elements most of them are copied: all but the split elements and the faces
 * they touch (more than 80 %). */
static void test_dg_reuse_matches_fresh(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0}, fine = {0};
    make_box(&m, pf_v3(4, 2, 2), 8, 4, 4);
    pf_refine_request req[2] = {{.elem = 1, .kind = PF_SPLIT_OCTS},
                                {.elem = 6, .kind = PF_SPLIT_HALVES, .normal = {1, 0, 1}}};
    pf_refine_result res = {0};
    assert_int_equal(pf_mesh_refine(&m, req, 2, &fine, &res, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&fine, &err), PF_OK);
    int32_t ne = fine.n_elems;
    uint8_t *same = calloc(2 * (size_t)ne, 1);
    for (int32_t e = 0; e < ne; ++e) {
        int32_t p = res.parent[e];
        same[e] = p != 1 && p != 6;
        same[ne + e] = same[e] && !res.changed[e];
    }
    pf_dg old, fresh, reused;
    pf_material steel = pf_material_make(1e5, 0.3, 1000);
    pf_materials one = {.n = 1, .table = &steel, .elem = NULL};
    assert_int_equal(pf_dg_create(&old, &m, 2, 1e5, 0.3, 1000, &err), PF_OK);
    assert_int_equal(pf_dg_create(&fresh, &fine, 2, 1e5, 0.3, 1000, &err), PF_OK);
    pf_dg_reuse reuse = {.old = &old,
                         .old_mesh = &m,
                         .parent = res.parent,
                         .same_solid = same,
                         .same_faces = same + ne,
                         .face_src = res.face_src};
    assert_int_equal(pf_dg_create_reusing(&reused, &fine, 2, &one, &reuse, NULL, &err), PF_OK);
    int nb = fresh.nb;
    size_t nk = (size_t)ne * 9 * nb * nb, nm = (size_t)ne * nb * nb;
    double scale = 0, worst = 0;
    for (size_t q = 0; q < nk; ++q)
        scale = fmax(scale, fabs(fresh.ke[q]));
    for (size_t q = 0; q < nk; ++q)
        worst = fmax(worst, fabs(fresh.ke[q] - reused.ke[q]) / scale);
    for (size_t q = 0; q < nm; ++q)
        worst = fmax(worst, fabs(fresh.me[q] - reused.me[q]) / fabs(fresh.me[0]));
    size_t block = (size_t)nb * nb;
    for (int32_t f = 0; f < fine.n_faces; ++f) {
        const pf_dg_face *a = &fresh.faces[fresh.face_slot[f]],
                         *b = &reused.faces[reused.face_slot[f]];
        assert_int_equal(a->elem[0], b->elem[0]);
        assert_int_equal(a->elem[1], b->elem[1]);
        /* the (s, t) blocks of the sides the face has (a boundary face: (0, 0) only; the
         * others are not written) */
        int sides = a->elem[1] >= 0 ? 2 : 1;
        for (int st = 0; st < 4; ++st)
            for (size_t q = 0; st / 2 < sides && st % 2 < sides && q < block; ++q)
                worst = fmax(worst, fabs(a->S[st * block + q] - b->S[st * block + q]) / a->area);
        worst = fmax(worst, vec_rel(b->normal, a->normal));
    }
    int64_t total = (int64_t)ne + fine.n_faces, copied = reused.reused_elems + reused.reused_faces;
    print_message("    dg reuse: %lld of %lld integrals copied, largest difference %.1e\n",
                  (long long)copied, (long long)total, worst);
    assert_true(worst < 1e-12);
    assert_true(copied > 0.8 * (double)total);
    pf_dg_release(&old);
    pf_dg_release(&fresh);
    pf_dg_release(&reused);
    free(same);
    pf_refine_result_release(&res);
    pf_mesh_release(&fine);
    pf_mesh_release(&m);
}

/* The method's arrays of s at rest, bit for bit comparable: the unrotated stiffness (values of
 * the upper triangle) and its constant terms, the product of the mass with a fixed vector, and
 * the constant forces. */
typedef struct method_arrays {
    pf_block_matrix k;
    double *f, *mx, *ext;
} method_arrays;

static void get_arrays(pf_sim *s, method_arrays *a)
{
    pf_error err = {0};
    int64_t n = s->ops->n_dofs(s->method);
    memset(a, 0, sizeof *a);
    assert_int_equal(s->ops->pattern(s->method, &a->k, &err), PF_OK);
    a->f = calloc((size_t)n, sizeof *a->f);
    a->mx = calloc((size_t)n, sizeof *a->mx);
    a->ext = calloc((size_t)n, sizeof *a->ext);
    double *zero = calloc((size_t)n, sizeof *zero), *x = malloc((size_t)n * sizeof *x);
    for (int64_t i = 0; i < n; ++i)
        x[i] = sin(0.37 * (double)i + 0.1);
    s->ops->stiffness(s->method, zero, false, &a->k, a->f);
    s->ops->mass_mul(s->method, 1, x, a->mx);
    s->ops->external_forces(s->method, a->ext);
    free(zero);
    free(x);
}

static void release_arrays(method_arrays *a)
{
    pf_block_matrix_release(&a->k);
    free(a->f);
    free(a->mx);
    free(a->ext);
}

static bool same_bits(const double *a, const double *b, int64_t n)
{
    return memcmp(a, b, (size_t)n * sizeof *a) == 0;
}

/* sim (CG, at rest, after changes) against a simulator built from scratch on a copy of its mesh:
 * the stiffness, mass, forces and three frames of stepping agree bit for bit. before: sim's
 * statistics before the last change (they add up over changes). */
static void matches_fresh(pf_sim *sim, const pf_scene *sc, pf_sim_stats before)
{
    pf_error err = {0};
    pf_mesh copy = {0};
    const pf_mesh *now = pf_sim_mesh(sim);
    assert_int_equal(pf_mesh_copy(&copy, now, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&copy, &err), PF_OK);
    pf_sim *fresh = NULL;
    if (pf_sim_create(&fresh, sc, &copy, &err) < 0)
        fail_msg("fresh: %s", err.msg);
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    int64_t taken = st->basis_reused - before.basis_reused;
    int64_t built = st->basis_computed - before.basis_computed;
    int64_t copied = st->integrals_reused - before.integrals_reused;
    print_message("    cg reuse: %d elements, functions %lld copied %lld built, matrices %lld "
                  "copied\n",
                  (int)now->n_elems, (long long)taken, (long long)built, (long long)copied);
    assert_int_equal(taken + built, now->n_elems);
    assert_true(3 * taken >= now->n_elems);
    assert_true(copied > 0 && copied <= taken);
    int64_t n = sim->ops->n_dofs(sim->method);
    assert_int_equal(n, fresh->ops->n_dofs(fresh->method));
    method_arrays a, b;
    get_arrays(sim, &a);
    get_arrays(fresh, &b);
    assert_int_equal(a.k.col_ptr[n], b.k.col_ptr[n]);
    assert_memory_equal(a.k.row_idx, b.k.row_idx, (size_t)a.k.col_ptr[n] * sizeof *a.k.row_idx);
    assert_true(same_bits(a.k.val, b.k.val, a.k.col_ptr[n]));
    assert_true(same_bits(a.f, b.f, n));
    assert_true(same_bits(a.mx, b.mx, n));
    assert_true(same_bits(a.ext, b.ext, n));
    release_arrays(&a);
    release_arrays(&b);
    for (int frame = 0; frame < 3; ++frame) {
        if (pf_sim_frame(sim, &err) < 0 || pf_sim_frame(fresh, &err) < 0)
            fail_msg("frame: %s", err.msg);
        assert_true(same_bits(sim->u, fresh->u, n));
        assert_true(same_bits(sim->v, fresh->v, n));
    }
    pf_sim_destroy(&fresh);
    pf_mesh_release(&copy);
}

static bool on_boundary(const pf_mesh *m, int32_t e)
{
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        if (m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0)
            return true;
    }
    return false;
}

static bool share_a_node(const pf_mesh *m, int32_t a, int32_t b)
{
    for (int64_t p = m->elem_offsets[a]; p < m->elem_offsets[a + 1]; ++p)
        for (int64_t q = m->elem_offsets[b]; q < m->elem_offsets[b + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[p]), g = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t i = m->face_offsets[f]; i < m->face_offsets[f + 1]; ++i)
                for (int64_t j = m->face_offsets[g]; j < m->face_offsets[g + 1]; ++j)
                    if (m->face_nodes[i] == m->face_nodes[j])
                        return true;
        }
    return false;
}

/* The sphere sliced 4 across (its boundary cells harmonic polyhedra) under CG, fixed at the
 * bottom: an interior hexahedron and a harmonic boundary cell apart from it. */
static pf_sim *sliced_sphere(pf_mesh *m, pf_scene *sc, int32_t *hex, int32_t *cell)
{
    make_sphere_mesh_res(m, 4);
    parse(sc, "{\"method\": \"cg\", \"ground\": false, \"time\": {\"dt\": 0.01},"
              " \"fixed\": [{\"box\": [[-2, -2, -2], [2, 2, -0.7]]}]}");
    pf_sim *sim = create(sc, m);
    assert_int_equal(pf_sim_get_stats(sim)->basis_computed, m->n_elems);
    assert_int_equal(pf_sim_get_stats(sim)->basis_reused, 0);
    *hex = *cell = -1;
    for (int32_t e = 0; e < m->n_elems && *hex < 0; ++e)
        if (!on_boundary(m, e))
            *hex = e;
    for (int32_t e = 0; e < m->n_elems && *cell < 0; ++e)
        if (on_boundary(m, e) && pf_mesh_classify_elem(m, e) != PF_ELEM_HEX &&
            !share_a_node(m, e, *hex))
            *cell = e;
    assert_true(*hex >= 0 && *cell >= 0);
    return sim;
}

static void split_one(pf_sim *sim, pf_refine_request req)
{
    pf_error err = {0};
    int32_t split = 0;
    if (pf_sim_split(sim, &req, 1, &split, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(split, 1);
}

/* CG on a changed mesh takes over the functions and matrices of every element that is its old
 * element node for node (pf_cg_create_reusing) and computes only the split elements, the
 * neighbours whose faces gained nodes, and (matrices only) the elements with a face whose
 * traces come from a recomputed neighbour. Split by halves at a boundary cell and by octs at an
 * interior hexahedron in one change, the sliced sphere's new simulator is the fresh one bit for
 * bit. The sphere is small (56 elements), so the two splits touch much of it: at least a third
 * of the elements' functions are copied (measured: half), and some matrices. */
static void test_cg_reuse_matches_fresh(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_scene sc;
    int32_t hex, cell;
    pf_sim *sim = sliced_sphere(&m, &sc, &hex, &cell);
    pf_sim_stats before = *pf_sim_get_stats(sim);
    pf_refine_request req[2] = {{.elem = cell, .kind = PF_SPLIT_HALVES, .normal = {1, 0.3, 0}},
                                {.elem = hex, .kind = PF_SPLIT_OCTS}};
    pf_error err = {0};
    int32_t split = 0;
    if (pf_sim_split(sim, req, 2, &split, &err) < 0)
        fail_msg("split: %s", err.msg);
    assert_int_equal(split, 2);
    matches_fresh(sim, &sc, before);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* The same across a merge whose node map moves indices: the hexahedron split first (its nodes
 * numbered first), the cell then, and the hexahedron's children merged back, which drops its
 * nodes and renumbers the cell's children's nodes: those children are copied through the node
 * map, and the simulator is the fresh one bit for bit. */
static void test_cg_reuse_after_merge(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_scene sc;
    int32_t hex, cell;
    pf_sim *sim = sliced_sphere(&m, &sc, &hex, &cell);
    pf_vec3 lo = pf_v3(INFINITY, INFINITY, INFINITY), hi = pf_v3(-INFINITY, -INFINITY, -INFINITY);
    for (int64_t q = m.elem_offsets[hex]; q < m.elem_offsets[hex + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m.elem_faces[q]);
        for (int64_t i = m.face_offsets[f]; i < m.face_offsets[f + 1]; ++i) {
            lo = pf_v3_min(lo, pf_v3_load(m.x + 3 * (size_t)m.face_nodes[i]));
            hi = pf_v3_max(hi, pf_v3_load(m.x + 3 * (size_t)m.face_nodes[i]));
        }
    }
    split_one(sim, (pf_refine_request){.elem = hex, .kind = PF_SPLIT_OCTS});
    int32_t shifted = cell > hex ? cell + 7 : cell;
    split_one(sim,
              (pf_refine_request){.elem = shifted, .kind = PF_SPLIT_HALVES, .normal = {1, 0.3, 0}});
    const pf_mesh *fine = pf_sim_mesh(sim);
    int32_t *group = malloc((size_t)fine->n_elems * sizeof *group), merged = 0;
    for (int32_t e = 0; e < fine->n_elems; ++e) {
        pf_vec3 c = pf_v3(0, 0, 0);
        int32_t count = 0;
        for (int64_t q = fine->elem_offsets[e]; q < fine->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(fine->elem_faces[q]);
            for (int64_t i = fine->face_offsets[f]; i < fine->face_offsets[f + 1]; ++i, ++count)
                c = pf_v3_add(c, pf_v3_load(fine->x + 3 * (size_t)fine->face_nodes[i]));
        }
        c = pf_v3_scale(c, 1.0 / count);
        bool inside =
            c.x > lo.x && c.y > lo.y && c.z > lo.z && c.x < hi.x && c.y < hi.y && c.z < hi.z;
        group[e] = inside ? 0 : -1;
    }
    pf_sim_stats before = *pf_sim_get_stats(sim);
    pf_error err = {0};
    if (pf_sim_merge(sim, group, &merged, &err) < 0)
        fail_msg("merge: %s", err.msg);
    free(group);
    assert_int_equal(merged, 1);
    assert_int_equal(pf_sim_mesh(sim)->n_elems, m.n_elems + 1);
    matches_fresh(sim, &sc, before);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* The same across a cut, which duplicates the nodes on the crack: a plane z = 0.05 through the
 * elements it crosses on the side x < 0 (the crack stops half way). The uncut elements whose
 * nodes kept their indices are copied, and the simulator is the fresh one bit for bit. */
static void test_cg_reuse_after_cut(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_scene sc;
    int32_t hex, cell;
    pf_sim *sim = sliced_sphere(&m, &sc, &hex, &cell);
    pf_cut_request *req = calloc((size_t)m.n_elems, sizeof *req);
    int32_t n = 0;
    for (int32_t e = 0; e < m.n_elems; ++e) {
        double zlo = INFINITY, zhi = -INFINITY, xhi = -INFINITY;
        for (int64_t q = m.elem_offsets[e]; q < m.elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m.elem_faces[q]);
            for (int64_t i = m.face_offsets[f]; i < m.face_offsets[f + 1]; ++i) {
                const double *x = m.x + 3 * (size_t)m.face_nodes[i];
                zlo = fmin(zlo, x[2]), zhi = fmax(zhi, x[2]), xhi = fmax(xhi, x[0]);
            }
        }
        if (zlo < 0.05 && zhi > 0.05 && xhi <= 0)
            req[n++] = (pf_cut_request){.elem = e, .plane = {.n = {0, 0, 1}, .d = 0.05}};
    }
    assert_true(n > 0);
    pf_sim_stats before = *pf_sim_get_stats(sim);
    pf_error err = {0};
    pf_cut_result res = {0};
    if (pf_sim_cut(sim, req, n, &res, &err) < 0)
        fail_msg("cut: %s", err.msg);
    assert_true(res.n_split > 0);
    assert_true(pf_sim_mesh(sim)->n_nodes > m.n_nodes + res.n_split);
    pf_cut_result_release(&res);
    free(req);
    matches_fresh(sim, &sc, before);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dg_affine_octs),
        cmocka_unit_test(test_dg_affine_halves),
        cmocka_unit_test(test_cg_affine),
        cmocka_unit_test(test_bent_momentum),
        cmocka_unit_test(test_bending_bar),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_embedded),
        cmocka_unit_test(test_refine_then_merge),
        cmocka_unit_test(test_merge_bent),
        cmocka_unit_test(test_bend_and_release),
        cmocka_unit_test(test_merge_levels_in_a_row),
        cmocka_unit_test(test_dg_reuse_matches_fresh),
        cmocka_unit_test(test_cg_reuse_matches_fresh),
        cmocka_unit_test(test_cg_reuse_after_merge),
        cmocka_unit_test(test_cg_reuse_after_cut),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
