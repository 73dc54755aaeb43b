/* basis_face: the face functions of harmonic cells (2D MFS on a face, harmonic paper sec. 4),
 * whose edge traces two faces meeting at an edge must agree on. Oracle: the linear data along
 * each edge that they are fitted to. */
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

#include <pf/basis.h>

#include "basis/basis_internal.h"
#include "basis_meshes.h"

static const double FACE_TRACE_MEDIAN = 7e-3, FACE_TRACE_MAX = 0.063, FACE_TRACE_L2 = 6e-3,
                    FACE_TRACE_TRAPEZOID = 5.3e-4;

/* Face functions (2D MFS) along their own edges against the data they were fitted to, linear
 * between the edge's two nodes and 0 for the others, at 21 points per edge between the
 * collocation points: on every MFS face of the sliced sphere and of a trapezoid. These traces
 * are what two faces meeting at an edge (so cells sharing only an edge) must agree on.
 * Measured: largest error on a face, median over the faces 4.7e-3 and largest 4.2e-2 (a face
 * with a very short edge next to a long one); relative L2 over all faces 4.1e-3. Without the 2D
 * harmonic polynomials (Re, Im (u + iv)^2, (u + iv)^3) these were 1.7e-2, 7.8e-2 and 1.2e-2.
 * The frustum's two trapezoids: 3.5e-4. Bounds: 1.5x. */
static int cmp_double_asc(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double face_trace_error(const pf_mesh *m, int32_t f, basis_ws *w, double *num, double *den)
{
    pf_error err = {0};
    pf_basis_params p = pf_basis_params_default();
    face_fn fn;
    memset(&fn, 0, sizeof fn);
    assert_int_equal(pf_face_init(&fn, m, f, &err), PF_OK);
    assert_int_equal(pf_face_solve(&fn, m, f, &p, w, &err), PF_OK);
    double worst = -1; /* -1: a closed form, not counted */
    if (fn.kind == FACE_MFS) {
        worst = 0;
        for (int32_t a = 0; a < fn.n; ++a) {
            int32_t b = (a + 1) % fn.n;
            pf_vec3 xa = pf_v3_load(m->x + 3 * (size_t)fn.nodes[a]);
            pf_vec3 xb = pf_v3_load(m->x + 3 * (size_t)fn.nodes[b]);
            for (int j = 0; j < 21; ++j) {
                double t = (j + 0.5) / 21, v[PF_BASIS_MAX_NODES];
                pf_face_eval(&fn, pf_v3_add(xa, pf_v3_scale(pf_v3_sub(xb, xa), t)), v);
                for (int32_t c = 0; c < fn.n; ++c) {
                    double want = (c == a ? 1 - t : 0) + (c == b ? t : 0);
                    worst = fmax(worst, fabs(v[c] - want));
                    *num += (v[c] - want) * (v[c] - want);
                    *den += want * want;
                }
            }
        }
    }
    pf_face_release(&fn);
    return worst;
}

static void test_face_traces_match_edge_data(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_sphere_mesh(&m);
    basis_ws w;
    memset(&w, 0, sizeof w);
    double *worst = calloc((size_t)m.n_faces, sizeof *worst), num = 0, den = 0;
    assert_non_null(worst);
    int32_t n = 0;
    for (int32_t f = 0; f < m.n_faces; ++f) {
        double e = face_trace_error(&m, f, &w, &num, &den);
        if (e >= 0)
            worst[n++] = e;
    }
    pf_mesh_release(&m);
    qsort(worst, (size_t)n, sizeof *worst, cmp_double_asc);
    double l2 = sqrt(num / den);
    printf("  face traces, %d MFS faces of the sliced sphere: median %.2e, largest %.2e, L2 %.2e\n",
           (int)n, worst[n / 2], worst[n - 1], l2);
    assert_true(n > 50);
    assert_true(worst[n / 2] < FACE_TRACE_MEDIAN && worst[n - 1] < FACE_TRACE_MAX &&
                l2 < FACE_TRACE_L2);
    free(worst);
    /* A trapezoid (no closed form): one face, the bottom of a frustum-like hexahedron. */
    const double x[24] = {0, 0, 0, 2, 0, 0, 1.5, 1, 0, 0.5, 1, 0,
                          0, 0, 1, 2, 0, 1, 1.5, 1, 1, 0.5, 1, 1};
    mesh_from_poly(&m, x, 8, CUBE_OFF, CUBE_FACES, 6);
    num = den = 0;
    double tw = 0;
    for (int32_t f = 0; f < m.n_faces; ++f)
        tw = fmax(tw, face_trace_error(&m, f, &w, &num, &den));
    printf("  face traces, trapezoids: largest %.2e\n", tw);
    assert_true(tw > 0 && tw < FACE_TRACE_TRAPEZOID);
    pf_mesh_release(&m);
    pf_ws_release(&w);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(int argc, char **argv)
{
    if (argc > 1)
        cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_face_traces_match_edge_data),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
