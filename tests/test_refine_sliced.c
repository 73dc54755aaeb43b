/* refine_sliced: pf_mesh_refine on sliced spheres (hexes inside, non-convex-faced polyhedra at
 * the surface): every cell split by octs or halves stays valid and volume-exact, and octs of every
 * cell of a finer sphere leave no degenerate edge.
 */
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
#include <pf/basis.h>
#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/refine.h>

#include "test_refine_check.h"

/* The unit sphere of bands x 2 bands facets sliced res across (pf_mesh_slice's defaults). */
static pf_mesh sliced_sphere(int32_t bands, int32_t res)
{
    pf_error err = {0};
    pf_surface s = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, bands, 2 * bands, &err), PF_OK);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    assert_int_equal(pf_mesh_slice(&m, &s, &p, NULL, &err), PF_OK);
    pf_surface_release(&s);
    return m;
}

/* A sphere sliced on a 4^3 grid (hexes inside, exact non-convex-faced polyhedra at the surface):
 * every other element by octs, the others by halves along varied normals, in a scrambled order. */
static void test_sliced_sphere(void **state)
{
    (void)state;
    pf_mesh src = sliced_sphere(8, 4), dst = {0};
    int32_t n = src.n_elems;
    pf_refine_request *req = calloc((size_t)n, sizeof *req);
    assert_non_null(req);
    /* a scrambled order: i -> i * step mod n, step a prime not dividing n */
    const int64_t primes[] = {7, 11, 13, 17};
    int64_t step = 0;
    for (int i = 3; i >= 0; --i)
        if (n % primes[i] != 0)
            step = primes[i];
    assert_true(step > 0);
    for (int32_t i = 0; i < n; ++i) {
        int32_t e = (int32_t)(((int64_t)i * step) % n);
        req[i].elem = e;
        req[i].kind = (e % 2) ? PF_SPLIT_HALVES : PF_SPLIT_OCTS;
        req[i].normal = pf_v3(cos(e), sin(2.0 * e), 0.3 + cos(3.0 * e));
    }
    pf_refine_result res;
    refine_ok(&src, req, n, &dst, &res);
    assert_true(res.n_split > n / 2);
    assert_int_equal(res.n_split + res.n_skipped, n);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    /* a third of them: unsplit neighbours get subdivided faces */
    refine_ok(&src, req, n / 3, &dst, &res);
    assert_true(res.n_neighbours_changed > 0);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    free(req);
    pf_mesh_release(&src);
}

/* Shortest edge of any face of m over that face's diameter. */
static double shortest_relative_edge(const pf_mesh *m)
{
    double worst = INFINITY;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t k0 = m->face_offsets[f], n = m->face_offsets[f + 1] - k0;
        double diam = 0, edge = INFINITY;
        const uint32_t *fn = m->face_nodes + k0;
        for (int64_t a = 0; a < n; ++a) {
            pf_vec3 pa = pf_v3_load(m->x + 3 * (size_t)fn[a]);
            for (int64_t b = a + 1; b < n; ++b)
                diam = fmax(diam, pf_v3_dist(pa, pf_v3_load(m->x + 3 * (size_t)fn[b])));
            edge = fmin(edge, pf_v3_dist(pa, pf_v3_load(m->x + 3 * (size_t)fn[(a + 1) % n])));
        }
        worst = fmin(worst, edge / diam);
    }
    return worst;
}

/* The sphere of pf-shape (radius 1, 32 x 64 facets) sliced 6 across, every element by octs: the
 * octs planes of its nearly symmetric cells pass within ~1e-9 of their corners and those of
 * mirror-symmetric neighbours differ by rounding, which made edges of ~1e-11 of their face (the
 * harmonic basis merged their nodes, 1e-9 of the face, and refused the face as collinear) and
 * made a split inconsistent. Snapped (PF_REFINE_SNAP), the mesh is valid with volumes exact
 * (check_refined, 1e-12), no split adds an edge below 1e-9 of its face (the source's shortest
 * is 1.1e-5, the refined mesh's 1.2e-7; before the snap 7e-12) and the harmonic basis builds on
 * every element. */
static void test_sliced_sphere_all_octs(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh src = sliced_sphere(32, 6), dst = {0};
    pf_refine_request *req = calloc((size_t)src.n_elems, sizeof *req);
    assert_non_null(req);
    for (int32_t e = 0; e < src.n_elems; ++e)
        req[e] = (pf_refine_request){.elem = e, .kind = PF_SPLIT_OCTS};
    pf_refine_result res;
    refine_ok(&src, req, src.n_elems, &dst, &res);
    assert_int_equal(res.n_split, src.n_elems);
    double shortest = shortest_relative_edge(&dst);
    printf("sliced sphere 6 across, all octs: %d -> %d elements, shortest edge %.3g of its face\n",
           (int)src.n_elems, (int)dst.n_elems, shortest);
    assert_true(shortest > 1e-9);
    pf_basis b = {0};
    pf_status st = pf_basis_create(&b, &dst, NULL, &err);
    CHECKF(st == PF_OK, "basis on the refined sphere: %s", err.msg);
    pf_basis_release(&b);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    free(req);
    pf_mesh_release(&src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sliced_sphere),
        cmocka_unit_test(test_sliced_sphere_all_octs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
