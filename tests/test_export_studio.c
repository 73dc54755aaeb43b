/* export, for studios and ParaView: binary VTU read back equal to the ASCII export, the exact
 * tetrahedral decomposition (--tets) against the elements' volumes, and the USD stage's structure
 * (time samples and their sizes). Files are read back by the independent reader of
 * export_files.h. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, rmdir */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <pf/integrate.h>
#include <pf/io.h>

#include "export_files.h"

/* Every array of the binary file equals the ASCII file's, value for value (%.17g round-trips,
 * and the binary copy is exact), on a mixed mesh and on a box big enough for several 32 KiB
 * compression blocks per array. */
static void compare_binary_ascii(const pf_mesh *m, const double *u, const pf_stress_data *st)
{
    static const char *const arrays[] = {"Points", "displacement", "kind", "volume", "stress",
                                         "connectivity", "offsets", "types", "faces",
                                         "faceoffsets"};
    pf_error err = {0};
    tmpdir t;
    tmp_open(&t);
    pf_vtu_params ascii = pf_vtu_params_default();
    ascii.ascii = true;
    assert_int_equal(pf_export_vtu_with(tmp_file(&t, "a.vtu"), m, u, st, &ascii, &err), PF_OK);
    char *xa = slurp(t.path, NULL);
    assert_int_equal(pf_export_vtu(tmp_file(&t, "b.vtu"), m, u, st, &err), PF_OK);
    size_t size_b;
    char *xb = slurp(t.path, &size_b);
    assert_non_null(strstr(xb, "compressor=\"vtkZLibDataCompressor\""));
    assert_null(strstr(xb, "format=\"ascii\""));
    assert_null(strstr(xa, "AppendedData"));
    int compared = 0;
    for (size_t i = 0; i < sizeof arrays / sizeof *arrays; ++i) {
        size_t na, nb;
        double *va = data_array(xa, arrays[i], &na), *vb = data_array(xb, arrays[i], &nb);
        assert_true((va == NULL) == (vb == NULL));
        assert_int_equal(na, nb);
        for (size_t k = 0; k < na; ++k)
            assert_true(va[k] == vb[k]);
        compared += va != NULL;
        free(va), free(vb);
    }
    assert_true(compared >= 7);
    free(xa), free(xb);
    static const char *const names[] = {"a.vtu", "b.vtu", NULL};
    tmp_close(&t, names);
}

static void test_vtu_binary_equals_ascii(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_prism_tet(&m);
    double u[21];
    displacement(&m, u);
    pf_stress_data st = {0};
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems, 6, &err), PF_OK);
    for (int32_t i = 0; i < 6 * m.n_elems; ++i)
        st.values[i] = 1e6 * cos(0.5 + i) / 7.0;
    compare_binary_ascii(&m, u, &st);
    compare_binary_ascii(&m, NULL, NULL);
    pf_stress_data_release(&st);
    pf_mesh_release(&m);
    make_box(&m, 20, 20, 20); /* 9261 points: 217 KiB of Points, 7 blocks */
    double *ub = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *ub);
    displacement(&m, ub);
    compare_binary_ascii(&m, ub, NULL);
    pf_free(ub);
    pf_mesh_release(&m);
    teardown_check();
}

/* --tets on a sliced torus (non-convex cells): every tet positive, each element's tets sum to
 * its volume to 1e-12 relative (two exact decompositions of the same solid differing only in
 * rounding: ~50 terms of 1e-16 each), mesh points unchanged, and an affine displacement field
 * reproduced at the new points to 1e-12 (the least-squares fit is exact for it). */
static void test_vtu_tets(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_torus(&s, 1, 0.4, 24, 12, &err), PF_OK);
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 6;
    assert_int_equal(pf_mesh_slice(&m, &s, &sp, NULL, &err), PF_OK);
    pf_surface_release(&s);
    /* u(x) = a + B x */
    const double a[3] = {0.1, -0.2, 0.3};
    const double b[3][3] = {{0.01, 0.02, -0.03}, {0.005, -0.01, 0.02}, {0.03, 0.0, 0.015}};
    double *u = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *u);
    for (int32_t i = 0; i < m.n_nodes; ++i)
        for (int r = 0; r < 3; ++r)
            u[3 * i + r] = a[r] + b[r][0] * m.x[3 * i] + b[r][1] * m.x[3 * i + 1] +
                           b[r][2] * m.x[3 * i + 2];
    pf_stress_data st = {0};
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems, 1, &err), PF_OK);
    for (int32_t e = 0; e < m.n_elems; ++e)
        st.values[e] = e;
    tmpdir t;
    tmp_open(&t);
    pf_vtu_params p = pf_vtu_params_default();
    p.tets = true;
    assert_int_equal(pf_export_vtu_with(tmp_file(&t, "tets.vtu"), &m, u, &st, &p, &err), PF_OK);
    char *xml = slurp(t.path, NULL);
    size_t n_pts, n_cells, n, n_conn;
    double *pts = data_array(xml, "Points", &n_pts);
    double *du = data_array(xml, "displacement", &n);
    assert_int_equal(n, n_pts);
    double *types = data_array(xml, "types", &n_cells);
    double *elem = data_array(xml, "element", &n);
    assert_int_equal(n, n_cells);
    double *vol = data_array(xml, "volume", &n);
    double *stress = data_array(xml, "stress", &n);
    double *conn = data_array(xml, "connectivity", &n_conn);
    assert_int_equal(n_conn, 4 * n_cells);
    for (size_t i = 0; i < 3 * (size_t)m.n_nodes; ++i)
        assert_true(pts[i] == m.x[i] && du[i] == u[i]);
    for (size_t i = 3 * (size_t)m.n_nodes; i < n_pts; i += 3)
        for (int r = 0; r < 3; ++r) {
            double exact = a[r] + b[r][0] * pts[i] + b[r][1] * pts[i + 1] + b[r][2] * pts[i + 2];
            assert_true(fabs(du[i + r] - exact) <= 1e-12);
        }
    double *sum = calloc((size_t)m.n_elems, sizeof *sum);
    for (size_t c = 0; c < n_cells; ++c) {
        assert_true(types[c] == 10);
        double v = orient(node(pts, conn[4 * c]), node(pts, conn[4 * c + 1]),
                          node(pts, conn[4 * c + 2]), node(pts, conn[4 * c + 3])) / 6;
        assert_true(v > 0);
        /* the same triple product in another order: rounding of ~eps * edge^3, edges < 1 */
        assert_true(fabs(v - vol[c]) <= 1e-15);
        sum[(size_t)elem[c]] += vol[c];
        assert_true(stress[c] == elem[c]);
    }
    int nonconvex_cells = 0;
    double total = 0, total_tets = 0;
    for (int32_t e = 0; e < m.n_elems; ++e) {
        double v = pf_mesh_elem_volume(&m, e);
        assert_true(fabs(sum[e] - v) <= 1e-12 * v);
        total += v;
        total_tets += sum[e];
        nonconvex_cells += m.elem_kind[e] == PF_ELEM_POLY;
    }
    assert_true(nonconvex_cells > 0);
    assert_true(fabs(total - total_tets) <= 1e-12 * total);
    assert_true(n_pts > 3 * (size_t)m.n_nodes); /* cone apexes were added */
    free(sum), free(xml), free(pts), free(du), free(types), free(elem), free(vol), free(stress);
    free(conn);
    static const char *const names[] = {"tets.vtu", NULL};
    tmp_close(&t, names);
    pf_stress_data_release(&st);
    pf_free(u);
    pf_mesh_release(&m);
    teardown_check();
}

/* The samples of attribute decl in a .usda text: count, and the tuple or value count of each. */
static int usd_samples(const char *text, const char *decl, int counts[8], double codes[8])
{
    char key[96];
    snprintf(key, sizeof key, "%s.timeSamples = {\n", decl);
    const char *p = strstr(text, key);
    if (!p)
        return 0;
    p += strlen(key);
    const char *end = strstr(p, "        }\n");
    int n = 0;
    while (p < end && n < 8) {
        char *colon;
        codes[n] = strtod(p, &colon);
        const char *open = strchr(colon, '['), *close = strchr(open, ']');
        int items = 0;
        bool tuples = open[1] == '(';
        for (const char *q = open + 1; q < close; ++q)
            items += tuples ? *q == '(' : *q == ',';
        counts[n++] = tuples ? items : (close > open + 1 ? items + 1 : 0);
        p = close + 3; /* "],\n" */
    }
    return n;
}

static void test_usd(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 4, 8, &err), PF_OK);
    tmpdir t;
    tmp_open(&t);
    pf_usd_writer *w = NULL;
    assert_int_equal(pf_usd_writer_create(&w, tmp_file(&t, "a.usda"), &err), PF_OK);
    assert_int_equal(pf_usd_writer_finish(w, &err), PF_ERR_INVALID); /* nothing to write */
    double *x = pf_alloc_array(3 * (size_t)s.n_verts, sizeof *x);
    double *stress = pf_alloc_array((size_t)s.n_tris, sizeof *stress);
    for (int32_t i = 0; i < s.n_tris; ++i)
        stress[i] = i;
    for (int k = 0; k < 3; ++k) { /* frames 10, 11, 12 at 0.5 s apart: 2 time codes a second */
        for (int32_t i = 0; i < 3 * s.n_verts; ++i)
            x[i] = s.x[i] * (1 + 0.1 * k);
        if (k == 2)
            s.n_tris -= 2; /* the topology changes at the last frame */
        assert_int_equal(pf_usd_writer_add(w, 10 + k, 0.5 * k, &s, x, stress, &err), PF_OK);
    }
    assert_int_equal(pf_usd_writer_add(w, 12, 2, &s, x, NULL, &err), PF_ERR_INVALID);
    assert_int_equal(pf_usd_writer_finish(w, &err), PF_OK);
    pf_usd_writer_destroy(&w);
    assert_null(w);
    char *text = slurp(t.path, NULL);
    assert_true(strncmp(text, "#usda 1.0\n", 10) == 0);
    assert_non_null(strstr(text, "timeCodesPerSecond = 2\n"));
    assert_non_null(strstr(text, "startTimeCode = 10\n"));
    assert_non_null(strstr(text, "endTimeCode = 12\n"));
    int counts[8];
    double codes[8];
    assert_int_equal(usd_samples(text, "point3f[] points", counts, codes), 3);
    for (int k = 0; k < 3; ++k)
        assert_true(counts[k] == s.n_verts && codes[k] == 10 + k);
    assert_int_equal(usd_samples(text, "normal3f[] normals", counts, codes), 3);
    assert_true(counts[2] == s.n_verts);
    assert_int_equal(usd_samples(text, "int[] faceVertexCounts", counts, codes), 2);
    assert_true(counts[0] == s.n_tris + 2 && counts[1] == s.n_tris && codes[1] == 12);
    assert_int_equal(usd_samples(text, "int[] faceVertexIndices", counts, codes), 2);
    assert_true(counts[0] == 3 * (s.n_tris + 2) && counts[1] == 3 * s.n_tris);
    assert_int_equal(usd_samples(text, "float[] primvars:stress", counts, codes), 3);
    assert_true(counts[0] == s.n_tris + 2 && counts[2] == s.n_tris);
    assert_non_null(strstr(text, "normal3f[] normals (\n            interpolation = \"vertex\""));
    /* on a sphere, vertex 0's normal is close to its direction from the centre (outward) */
    const char *n0 = strstr(strstr(text, "normals.timeSamples"), "10: [(") + 6;
    double nx = strtod(n0, (char **)&n0), ny = strtod(n0 + 1, (char **)&n0);
    double nz = strtod(n0 + 1, NULL);
    pf_vec3 radial = pf_v3_normalize(pf_v3_load(s.x));
    assert_true(fabs(nx * nx + ny * ny + nz * nz - 1) < 1e-6);
    assert_true(pf_v3_dot(pf_v3(nx, ny, nz), radial) > 0.9);
    free(text);
    static const char *const names[] = {"a.usda", NULL};
    tmp_close(&t, names);
    pf_free(x);
    pf_free(stress);
    pf_surface_release(&s);
    teardown_check();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vtu_binary_equals_ascii),
        cmocka_unit_test(test_vtu_tets),
        cmocka_unit_test(test_usd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
