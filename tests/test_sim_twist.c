/* sim_twist: stress-based refinement of a twisted bar, the harmonic paper's "Twisting" row of
 * table 1 (a bar of 40 hexes, 10 x 2 x 2 cells), as a static Saint-Venant torsion: a 5 x 1 x 1
 * bar clamped at x = 0 and twisted by a couple of tractions on its sides over x in [4, 5].
 * Torsion's shear stress is the same along the whole twisted length, where bending's (the
 * bending bar of test_sim_refine.c) is largest at the clamps: with the threshold at half the
 * analytic largest shear stress, every element of the twisted length splits, and the elements at
 * the free end, which carry only part of the couple, stay whole. The refined mesh twists closer to
 * Saint-Venant's rate than the coarse one. DG (degree 1) and CG, octs and halves. */
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

#include "test_check.h"
#include "test_sim_changes.h"

/* The couple: traction 100 on each side over x in [4, 5] (area 1 each, arm 0.5): T = 200 about
 * the bar's axis. */
static const char TWIST[] =
    "{\"static\": true, \"ground\": false, \"gravity\": [0, 0, 0], \"material\": {\"E\": 1e6},"
    " \"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
    " \"loads\": [{\"box\": [[3.99, 0.99, -1], [5.01, 1.01, 2]], \"traction\": [0, 0, 100]},"
    "  {\"box\": [[3.99, -0.01, -1], [5.01, 0.01, 2]], \"traction\": [0, 0, -100]},"
    "  {\"box\": [[3.99, -1, 0.99], [5.01, 2, 1.01]], \"traction\": [0, -100, 0]},"
    "  {\"box\": [[3.99, -1, -0.01], [5.01, 2, 0.01]], \"traction\": [0, 100, 0]}]}";
static const double TORQUE = 200, E = 1e6, NU = 0.3;

/* Saint-Venant's torsion of a unit square section (Timoshenko and Goodier, sec. 109): rate
 * T / (G k1), largest shear stress T / k2 at the middle of each side. */
static const double K1 = 0.1406, K2 = 0.208;

/* The twist at x: the rotation about the axis from the z displacements of the nodes at the
 * middle of the sides y = 1 and y = 0 (bending moves both alike). */
static double twist_at(const pf_sim *sim, double x)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    double *u = malloc(3 * (size_t)m->n_nodes * sizeof *u), top = NAN, bottom = NAN;
    assert_non_null(u);
    pf_sim_nodal_displacements(sim, u);
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        const double *p = m->x + 3 * (size_t)i;
        if (p[0] == x && p[2] == 0.5 && (p[1] == 0 || p[1] == 1))
            *(p[1] == 1 ? &top : &bottom) = u[3 * (size_t)i + 2];
    }
    free(u);
    assert_false(isnan(top) || isnan(bottom));
    return top - bottom;
}

static double twist_rate(const pf_sim *sim)
{
    return (twist_at(sim, 3) - twist_at(sim, 1)) / 2;
}

static double centroid_x(const pf_mesh *m, int32_t e)
{
    double lo = INFINITY, hi = -INFINITY;
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k)
            lo = fmin(lo, m->x[3 * (size_t)m->face_nodes[k]]),
            hi = fmax(hi, m->x[3 * (size_t)m->face_nodes[k]]);
    }
    return 0.5 * (lo + hi);
}

static void twisted_bar(pf_method method, pf_split_kind kind, const char *name)
{
    pf_mesh m = {0};
    make_box(&m, pf_v3(5, 1, 1), 10, 2, 2);
    pf_scene sc;
    parse(&sc, TWIST);
    sc.method = method;
    sc.degree = 2; /* DG degree 1 cannot twist inside an element (u_y = -theta' x z is bilinear):
                      it locks in torsion as in bending (docs/scene.md) */
    pf_sim *sim = create(&sc, &m);
    pf_error err = {0};
    if (pf_sim_solve_static(sim, &err) < 0)
        fail_msg("solve: %s", err.msg);
    double exact = TORQUE / (E / (2 * (1 + NU)) * K1), coarse = twist_rate(sim);
    int32_t split = refine_once(sim, &sc, 0.5 * TORQUE / K2, kind);
    const pf_mesh *now = pf_sim_mesh(sim);
    /* every element of [0, 4] split (32 of them), none of [4.5, 5] */
    int32_t children = kind == PF_SPLIT_OCTS ? 8 : 2, whole_end = 0, small_twisted = 0;
    for (int32_t e = 0; e < now->n_elems; ++e) {
        bool whole = pf_mesh_elem_volume(now, e) > 0.99 * 0.125;
        double x = centroid_x(now, e);
        whole_end += whole && x > 4.5;
        small_twisted += !whole && x < 4;
        CHECKF(!(whole && x < 4), "%s: element %d at x = %.2f is whole", name, (int)e, x);
    }
    assert_int_equal(small_twisted, 32 * children);
    assert_int_equal(whole_end, 4);
    if (pf_sim_solve_static(sim, &err) < 0)
        fail_msg("solve: %s", err.msg);
    double fine = twist_rate(sim);
    print_message("    %s: %d split, %d elements; twist rate %.4e coarse, %.4e refined, "
                  "Saint-Venant %.4e\n",
                  name, (int)split, (int)now->n_elems, coarse, fine, exact);
    /* Both meshes are stiffer than the solid. Octs make box hexes whose fields contain their
     * parent's (trilinear for CG, quadratic for DG), so the refined mesh is looser, toward the
     * exact rate (measured: CG 15.6 % -> 4.9 % below it, DG 11.9 % -> 1.8 %). Halves split along
     * the shear's principal directions, at 45 degrees to the axis: oblique pieces whose fields do
     * not contain the parent's (CG's neighbours become harmonic polyhedra), and the rate does not
     * improve (CG 15.6 % -> 17.1 %, DG 11.9 % -> 10.9 %): only their pattern is checked. */
    assert_true(coarse < exact && fine < exact);
    if (kind == PF_SPLIT_OCTS)
        assert_true(exact - fine < 0.35 * (exact - coarse));
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void test_dg_octs(void **state)
{
    (void)state;
    twisted_bar(PF_METHOD_DG, PF_SPLIT_OCTS, "dg octs");
}

static void test_dg_halves(void **state)
{
    (void)state;
    twisted_bar(PF_METHOD_DG, PF_SPLIT_HALVES, "dg halves");
}

static void test_cg_octs(void **state)
{
    (void)state;
    twisted_bar(PF_METHOD_CG, PF_SPLIT_OCTS, "cg octs");
}

static void test_cg_halves(void **state)
{
    (void)state;
    twisted_bar(PF_METHOD_CG, PF_SPLIT_HALVES, "cg halves");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dg_octs),
        cmocka_unit_test(test_dg_halves),
        cmocka_unit_test(test_cg_octs),
        cmocka_unit_test(test_cg_halves),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
