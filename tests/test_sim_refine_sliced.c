/* sim_refine_sliced: stress-driven refinement of a sliced body (hexes inside, exact polyhedra at
 * the surface) while the simulation runs: the bunny sliced 8 across, as pf-slice makes it, under
 * DG (octs and halves) and CG (halves, and octs within max_elements: the harmonic basis of its
 * split surface cells is the cost), refined by stress over a few events with frames between
 * them; and a CG sphere sliced 6 across whose third stress-driven change once made faces too thin
 * for the harmonic basis. */
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
#include <pf/io.h>
#include <pf/mesh.h>
#include <pf/refine.h>
#include <pf/sim.h>

#include "test_refine_check.h"
#include "test_sim_changes.h"

/* data/models/bunny.obj sliced res across (pf-slice's defaults otherwise), derived. */
static pf_mesh sliced_bunny(int32_t res)
{
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    if (pf_import_surface(PF_TEST_DATA_DIR "/../../data/models/bunny.obj", &s, &err) != PF_OK)
        fail_msg("bunny.obj: %s", err.msg);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    assert_int_equal(pf_mesh_slice(&m, &s, &p, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    pf_surface_release(&s);
    return m;
}

/* The largest von Mises stress of the simulator's elements. */
static double largest_stress(const pf_sim *sim)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    double *vm = malloc(((size_t)m->n_elems + 1) * sizeof *vm), largest = 0;
    assert_non_null(vm);
    pf_sim_von_mises(sim, vm);
    for (int32_t e = 0; e < m->n_elems; ++e)
        largest = fmax(largest, vm[e]);
    free(vm);
    return largest;
}

/* The bunny sagging under gravity with its lowest tenth fixed, refined by stress: events of
 * pf_sim_refine (threshold a fraction of the largest stress after three frames, max_level 2),
 * each followed by a frame on the new mesh (which refines again: the scene refines). Every change
 * keeps the mesh valid and its volume (1e-12 relative: the children of a split are exact
 * polyhedra; the sum over some thousand elements rounds at ~1e-15), a split makes at most 8
 * children (octs) or 2 (halves), the mesh stays within max_elements, and the run goes on. */
static void bunny_refines(const char *method, pf_split_kind kind, int events, double fraction,
                          int32_t max_elements)
{
    pf_error err = {0};
    pf_mesh m = sliced_bunny(8);
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    char json[512];
    snprintf(json, sizeof json,
             "{\"method\": %s, \"material\": {\"E\": 1e6}, \"ground\": false,"
             " \"fixed\": [{\"box\": [[-1e9, -1e9, -1e9], [1e9, 1e9, %.17g]]}]}",
             method, lo.z + 0.1 * (hi.z - lo.z));
    pf_scene sc;
    parse(&sc, json);
    pf_sim *sim = create(&sc, &m);
    double v0 = rest_volume(&m);
    run_frames(sim, 3);
    sc.refine = (pf_refine_params){.enabled = true,
                                   .threshold = fraction * largest_stress(sim),
                                   .split = kind,
                                   .max_level = 2,
                                   .max_elements = max_elements};
    int32_t n0 = m.n_elems, changed = 0, total = 0, most_added = kind == PF_SPLIT_OCTS ? 7 : 1;
    for (int ev = 0; ev < events; ++ev) {
        int32_t before = pf_sim_mesh(sim)->n_elems;
        if (pf_sim_refine(sim, &changed, &err) < 0)
            fail_msg("event %d: %s", ev, err.msg);
        total += changed;
        const pf_mesh *now = pf_sim_mesh(sim);
        CHECKF(now->n_elems - before <= most_added * changed,
               "event %d: %d -> %d elements, %d split", ev, (int)before, (int)now->n_elems,
               (int)changed);
        CHECKF(now->n_elems <= max_elements, "event %d: %d elements", ev, (int)now->n_elems);
        CHECKF(pf_mesh_validate(now, NULL, &err) == PF_OK, "event %d: %s", ev, err.msg);
        double v = rest_volume(now);
        CHECKF(fabs(v - v0) <= 1e-12 * v0, "event %d: volume %.17g, was %.17g", ev, v, v0);
        run_frames(sim, 1);
        CHECKF(pf_sim_mesh(sim)->n_elems <= max_elements, "frame after event %d: %d elements", ev,
               (int)pf_sim_mesh(sim)->n_elems);
    }
    /* the frames' refinement splits too: the run's count holds every split */
    int64_t all = pf_sim_get_stats(sim)->elements_split;
    printf("bunny %s %s: %d -> %d elements, %d splits in %d events (%lld with the frames'),"
           " narrowest face %.3g\n",
           method, kind == PF_SPLIT_OCTS ? "octs" : "halves", (int)n0,
           (int)pf_sim_mesh(sim)->n_elems, (int)total, events, (long long)all,
           narrowest_face(pf_sim_mesh(sim)));
    CHECKF(pf_sim_mesh(sim)->n_elems - n0 <= most_added * all, "%d -> %d elements in %lld splits",
           (int)n0, (int)pf_sim_mesh(sim)->n_elems, (long long)all);
    assert_true(total > 0);
    assert_true(pf_sim_mesh(sim)->n_elems > n0);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static const char BUNNY_DG[] = "{\"name\": \"dg\", \"degree\": 1}";
static const char BUNNY_CG[] = "{\"name\": \"cg\"}";

/* The case of bench_adapt reuse slice 6: a sphere (8 x 16 facets) sliced 6 across under CG, its
 * lowest eighth fixed, refined by octs where the stress exceeds 0.8 of its largest after five
 * frames. Its third change once failed ("face ...: nodes are collinear"): an element's plane
 * passed 1e-8 to 5e-8 of its diagonal from nodes the planes of several neighbours (split in the
 * change before) had put on its faces, leaving faces 1e-9 wide of 0.05. Now the three changes
 * go through, the harmonic basis builds on every element, and no face is narrower than
 * PF_REFINE_SNAP of its size (measured: 8.4e-6 after the third change). */
static void test_sphere_cg_three_changes(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 6;
    assert_int_equal(pf_mesh_slice(&m, &s, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    pf_surface_release(&s);
    pf_scene sc;
    parse(&sc, "{\"method\": {\"name\": \"cg\"}, \"material\": {\"E\": 1e6},"
               " \"damping\": {\"beta\": 0.02}, \"ground\": false,"
               " \"fixed\": [{\"box\": [[-9, -9, -9], [9, 9, -0.75]]}]}");
    pf_sim *sim = create(&sc, &m);
    run_frames(sim, 5);
    sc.refine = (pf_refine_params){.enabled = true,
                                   .threshold = 0.8 * largest_stress(sim),
                                   .split = PF_SPLIT_OCTS,
                                   .max_level = 2,
                                   .max_elements = 100000};
    int32_t counts[3];
    for (int c = 0; c < 3; ++c) {
        int32_t split = 0;
        if (pf_sim_refine(sim, &split, &err) < 0)
            fail_msg("change %d: %s", c, err.msg);
        counts[c] = split;
    }
    double narrow = narrowest_face(pf_sim_mesh(sim));
    printf("sphere sliced 6 across, CG: %d -> %d elements (%d, %d, %d split), narrowest face %.3g\n",
           (int)m.n_elems, (int)pf_sim_mesh(sim)->n_elems, (int)counts[0], (int)counts[1],
           (int)counts[2], narrow);
    assert_true(counts[2] > 0);
    assert_true(narrow > PF_REFINE_SNAP);
    run_frames(sim, 1);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_bunny_dg(void **state)
{
    (void)state;
    bunny_refines(BUNNY_DG, PF_SPLIT_OCTS, 3, 0.5, 100000);
    bunny_refines(BUNNY_DG, PF_SPLIT_HALVES, 3, 0.5, 100000);
}

static void test_bunny_cg(void **state)
{
    (void)state;
    bunny_refines(BUNNY_CG, PF_SPLIT_HALVES, 2, 0.8, 100000);
}

/* CG with octs: every split made 8 children (measured), but without a useful max_elements the events and
 * the frames' own refinement reach max_level almost everywhere (five changes: 173 -> 8,960
 * elements, 4.4 GB resident; at 6,944 elements the factor alone holds 150 million entries);
 * max_elements 1,200 stops it at 1,195 elements, 0.7 GB and about 18 s of CPU. */
static void test_bunny_cg_octs(void **state)
{
    (void)state;
    bunny_refines(BUNNY_CG, PF_SPLIT_OCTS, 2, 0.8, 1200);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_cg_three_changes),
        cmocka_unit_test(test_bunny_dg),
        cmocka_unit_test(test_bunny_cg),
        cmocka_unit_test(test_bunny_cg_octs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
