/* export: .vtu / .pvd for ParaView, OBJ / PLY for Blender, written atomically.
 *
 * The files are parsed back here with a reader independent of the writer (strtod on the text,
 * byte decoding of PLY), so every number is compared exactly: %.17g round-trips any double, and
 * PLY stores (float)x, which is what must come back.
 *
 * Also writes the test stream of the tool test:
 *   test_export --write-frames FILE   a 2 x 1 x 1 hex box (MESH), a triangle on three of its
 *                                     corners (SURF + WGHT), frames 0, 1, 2 at times 0, 0.5, 1;
 *                                     STRS (von Mises) after frames 0 and 1 only
 *   test_export --write-bad KIND FILE  a 4 x 4 x 4 hex box (125 nodes) and one frame that every
 *                                     stream reader must refuse or survive; KIND: nodes-124,
 *                                     nodes-130, mesh-id (frame of mesh 7), before-mesh, id-reused
 *                                     (a second MESH with the first's id), huge (u = 1e300, valid)
 *   test_export --drop TAG IN OUT     IN without its TAG chunks (a new END_): the same frames
 *                                     without, say, the SCEN that names the obstacles
 */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, rmdir, geteuid */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <pf/io.h>

#include "export_files.h"

/* ---- VTU ------------------------------------------------------------------------------------- */

static void test_vtu_box(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, 2, 2, 1);
    double *u = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *u);
    displacement(&m, u);
    pf_stress_data st = {0};
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems, 6, &err), PF_OK);
    for (int32_t i = 0; i < 6 * m.n_elems; ++i)
        st.values[i] = 1e6 * cos(0.5 + i) / 7.0;
    tmpdir t;
    tmp_open(&t);
    assert_int_equal(pf_export_vtu(tmp_file(&t, "box.vtu"), &m, u, &st, &err), PF_OK);
    char *xml = slurp(t.path, NULL);
    assert_non_null(strstr(xml, "<VTKFile type=\"UnstructuredGrid\""));
    assert_int_equal(attribute(xml, "NumberOfPoints"), m.n_nodes);
    assert_int_equal(attribute(xml, "NumberOfCells"), m.n_elems);
    size_t n;
    double *pts = data_array(xml, "Points", &n);
    assert_int_equal(n, 3 * (size_t)m.n_nodes);
    for (size_t i = 0; i < n; ++i)
        assert_true(pts[i] == m.x[i]);
    double *du = data_array(xml, "displacement", &n);
    assert_int_equal(n, 3 * (size_t)m.n_nodes);
    for (size_t i = 0; i < n; ++i)
        assert_true(du[i] == u[i]); /* exact: %.17g round-trips */
    double *stress = data_array(xml, "stress", &n);
    assert_int_equal(n, 6 * (size_t)m.n_elems);
    for (size_t i = 0; i < n; ++i)
        assert_true(stress[i] == st.values[i]);
    assert_non_null(strstr(xml, "Name=\"stress\" NumberOfComponents=\"6\""));
    double *vol = data_array(xml, "volume", &n);
    assert_int_equal(n, (size_t)m.n_elems);
    double *kind = data_array(xml, "kind", &n);
    assert_int_equal(n, (size_t)m.n_elems);
    double *types = data_array(xml, "types", &n);
    double *offsets = data_array(xml, "offsets", &n);
    assert_int_equal(n, (size_t)m.n_elems);
    double *conn = data_array(xml, "connectivity", &n);
    assert_int_equal(n, 8 * (size_t)m.n_elems);
    size_t nf;
    assert_null(data_array(xml, "faces", &nf)); /* only hexes: no polyhedron arrays */
    for (int32_t e = 0; e < m.n_elems; ++e) {
        assert_true(vol[e] == pf_mesh_elem_volume(&m, e));
        assert_true(vol[e] == 0.5); /* 1 x 0.5 x 1 cells, exact in binary */
        assert_true(kind[e] == PF_ELEM_HEX);
        assert_true(types[e] == 12);
        assert_true(offsets[e] == 8.0 * (e + 1));
        /* VTK's hexahedron: base 0-1-2-3 counter-clockwise seen from the top, 4..7 above 0..3:
         * in this axis-aligned box every top node sits exactly 1 above its base node, and the
         * base's normal points up */
        const double *c = conn + 8 * e;
        for (int i = 0; i < 4; ++i) {
            pf_vec3 d = pf_v3_sub(node(m.x, c[4 + i]), node(m.x, c[i]));
            assert_true(d.x == 0 && d.y == 0 && d.z == 1);
        }
        assert_true(orient(node(m.x, c[0]), node(m.x, c[1]), node(m.x, c[3]), node(m.x, c[4])) >
                    0);
    }
    assert_null(strstr(xml, "nan"));
    free(xml), free(pts), free(du), free(stress), free(vol), free(kind), free(types);
    free(offsets), free(conn);
    static const char *const names[] = {"box.vtu", NULL};
    tmp_close(&t, names);
    pf_stress_data_release(&st);
    pf_free(u);
    pf_mesh_release(&m);
    teardown_check();
}

/* Volume of a polyhedron from VTK's face stream (nfaces, then npts ids... per face) by the
 * divergence theorem over fan triangles: independent of the mesh's own volume code. */
static double stream_volume(const double *x, const double *stream, size_t *used)
{
    size_t k = 0;
    int nfaces = (int)stream[k++];
    double six_v = 0;
    pf_vec3 o = pf_v3(0, 0, 0);
    for (int f = 0; f < nfaces; ++f) {
        int n = (int)stream[k++];
        for (int j = 1; j + 1 < n; ++j)
            six_v += orient(o, node(x, stream[k]), node(x, stream[k + j]),
                            node(x, stream[k + j + 1]));
        k += (size_t)n;
    }
    *used = k;
    return six_v / 6;
}

static void test_vtu_polyhedron_and_tet(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_prism_tet(&m);
    pf_stress_data st = {0};
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems, 1, &err), PF_OK);
    st.values[0] = 1.5;
    st.values[1] = 0.1;
    tmpdir t;
    tmp_open(&t);
    assert_int_equal(pf_export_vtu(tmp_file(&t, "mixed.vtu"), &m, NULL, &st, &err), PF_OK);
    char *xml = slurp(t.path, NULL);
    size_t n, n_conn, n_faces;
    assert_null(data_array(xml, "displacement", &n));
    assert_null(strstr(xml, "<PointData"));
    double *types = data_array(xml, "types", &n);
    assert_int_equal(n, 2);
    assert_true(types[0] == 42 && types[1] == 10);
    double *kind = data_array(xml, "kind", &n);
    assert_true(kind[0] == PF_ELEM_POLY && kind[1] == PF_ELEM_TET);
    double *offsets = data_array(xml, "offsets", &n);
    assert_true(offsets[0] == 6 && offsets[1] == 10);
    double *conn = data_array(xml, "connectivity", &n_conn);
    assert_int_equal(n_conn, 10);
    /* the prism lists each of its 6 nodes once */
    for (uint32_t v = 0; v < 6; ++v) {
        int count = 0;
        for (int i = 0; i < 6; ++i)
            count += conn[i] == v;
        assert_int_equal(count, 1);
    }
    /* the tet: 0, 1, 2 counter-clockwise seen from 3, i.e. positive orientation */
    assert_true(conn[9] == 6);
    assert_true(orient(node(m.x, conn[6]), node(m.x, conn[7]), node(m.x, conn[8]),
                       node(m.x, conn[9])) > 0);
    double *faces = data_array(xml, "faces", &n_faces);
    double *faceoffsets = data_array(xml, "faceoffsets", &n);
    assert_int_equal(n, 2);
    /* 5 faces: 1 + (1 + 3) * 2 + (1 + 4) * 3 = 24 numbers */
    assert_int_equal(n_faces, 24);
    assert_true(faceoffsets[0] == 24 && faceoffsets[1] == -1);
    assert_true(faces[0] == 5);
    /* faces walked outward: the stream's volume is the element's, positive. Both sum 14
     * products of small exact numbers; 1e-15 relative covers their round-off. */
    size_t used;
    double v = stream_volume(m.x, faces, &used);
    assert_int_equal(used, 24);
    assert_true(v > 0);
    assert_true(fabs(v - pf_mesh_elem_volume(&m, 0)) <= 1e-15 * v);
    double *vol = data_array(xml, "volume", &n);
    assert_true(vol[0] == pf_mesh_elem_volume(&m, 0) && vol[1] == pf_mesh_elem_volume(&m, 1));
    double *stress = data_array(xml, "stress", &n);
    assert_int_equal(n, 2);
    assert_true(stress[0] == 1.5 && stress[1] == 0.1);
    free(xml), free(types), free(kind), free(offsets), free(conn), free(faces);
    free(faceoffsets), free(vol), free(stress);
    static const char *const names[] = {"mixed.vtu", NULL};
    tmp_close(&t, names);
    pf_stress_data_release(&st);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_vtu_invalid(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, 2, 1, 1);
    tmpdir t;
    tmp_open(&t);
    const char *path = tmp_file(&t, "bad.vtu");
    pf_stress_data st = {0};
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems + 1, 1, &err), PF_OK);
    for (int32_t e = 0; e <= m.n_elems; ++e)
        st.values[e] = 1;
    assert_int_equal(pf_export_vtu(path, &m, NULL, &st, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "stress of 3 elements"));
    double *u = pf_calloc(3 * (size_t)m.n_nodes, sizeof *u);
    u[7] = NAN;
    assert_int_equal(pf_export_vtu(path, &m, u, NULL, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "node 2 has a non-finite displacement"));
    m.face_nodes[5] = (uint32_t)m.n_nodes;
    assert_int_equal(pf_export_vtu(path, &m, NULL, NULL, &err), PF_ERR_INVALID);
    assert_false(exists(path));
    static const char *const names[] = {NULL};
    tmp_close(&t, names);
    pf_free(u);
    pf_stress_data_release(&st);
    pf_mesh_release(&m);
    teardown_check();
}

static void test_pvd(void **state)
{
    (void)state;
    pf_error err = {0};
    tmpdir t;
    tmp_open(&t);
    const char *files[] = {"mesh_00000.vtu", "a&b <\"c\">.vtu"};
    const double times[] = {0, 0.1};
    assert_int_equal(pf_export_pvd(tmp_file(&t, "mesh.pvd"), files, times, 2, &err), PF_OK);
    char *xml = slurp(t.path, NULL);
    assert_non_null(strstr(xml, "<VTKFile type=\"Collection\""));
    const char *a = strstr(xml, "file=\"mesh_00000.vtu\"");
    const char *b = strstr(xml, "file=\"a&amp;b &lt;&quot;c&quot;&gt;.vtu\"");
    assert_true(a && b && a < b);
    const char *ts = strstr(a, "timestep=\"");
    assert_non_null(ts);
    assert_true(strtod(ts + strlen("timestep=\""), NULL) == 0.1);
    free(xml);
    const double bad[] = {0, INFINITY};
    assert_int_equal(pf_export_pvd(tmp_file(&t, "bad.pvd"), files, bad, 2, &err), PF_ERR_INVALID);
    assert_false(exists(t.path));
    static const char *const names[] = {"mesh.pvd", NULL};
    tmp_close(&t, names);
    teardown_check();
}

/* ---- OBJ / PLY ------------------------------------------------------------------------------- */

static void make_moved_torus(pf_surface *s, double **x)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_make_torus(s, 1, 0.35, 12, 6, &err), PF_OK);
    *x = pf_alloc_array(3 * (size_t)s->n_verts, sizeof **x);
    for (int32_t i = 0; i < 3 * s->n_verts; ++i)
        (*x)[i] = s->x[i] + sin(2.0 + i) / 9.0;
}

static void test_obj_round_trip(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    double *x;
    make_moved_torus(&s, &x);
    tmpdir t;
    tmp_open(&t);
    assert_int_equal(pf_export_obj(tmp_file(&t, "t.obj"), &s, x, &err), PF_OK);
    char *text = slurp(t.path, NULL);
    int32_t nv = 0, nt = 0, nn = 0;
    double *normals = pf_alloc_array(3 * (size_t)s.n_verts, sizeof *normals);
    pf_surface_vertex_normals(&s, x, normals);
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        if (line[0] == 'v' && line[1] == 'n') {
            double n[3];
            assert_int_equal(sscanf(line, "vn %lf %lf %lf", &n[0], &n[1], &n[2]), 3);
            assert_true(nn < s.n_verts);
            /* 9 significant digits of a unit vector: within 5e-9 */
            for (int c = 0; c < 3; ++c)
                assert_true(fabs(n[c] - normals[3 * nn + c]) <= 5e-9);
            assert_true(fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1) <= 2e-8);
            ++nn;
        } else if (line[0] == 'v') {
            double p[3];
            assert_int_equal(sscanf(line, "v %lf %lf %lf", &p[0], &p[1], &p[2]), 3);
            assert_true(nv < s.n_verts);
            for (int c = 0; c < 3; ++c)
                assert_true(p[c] == x[3 * nv + c]);
            ++nv;
        } else if (line[0] == 'f') {
            unsigned long a, b, c, na, nb, nc;
            assert_int_equal(sscanf(line, "f %lu//%lu %lu//%lu %lu//%lu", &a, &na, &b, &nb, &c,
                                    &nc), 6);
            assert_true(a == na && b == nb && c == nc);
            assert_true(nt < s.n_tris);
            assert_true(a == s.tri[3 * nt] + 1ul && b == s.tri[3 * nt + 1] + 1ul &&
                        c == s.tri[3 * nt + 2] + 1ul);
            ++nt;
        } else {
            assert_int_equal(line[0], '#');
        }
    }
    assert_int_equal(nv, s.n_verts);
    assert_int_equal(nn, s.n_verts);
    assert_int_equal(nt, s.n_tris);
    pf_free(normals);
    free(text);
    /* NULL positions: the surface's own */
    assert_int_equal(pf_export_obj(tmp_file(&t, "rest.obj"), &s, NULL, &err), PF_OK);
    text = slurp(t.path, NULL);
    double p[3];
    assert_int_equal(sscanf(strstr(text, "\nv ") + 1, "v %lf %lf %lf", &p[0], &p[1], &p[2]), 3);
    assert_true(p[0] == s.x[0] && p[1] == s.x[1] && p[2] == s.x[2]);
    free(text);
    s.tri[4] = (uint32_t)s.n_verts;
    assert_int_equal(pf_export_obj(tmp_file(&t, "bad.obj"), &s, x, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "triangle 1 uses vertex"));
    static const char *const names[] = {"t.obj", "rest.obj", NULL};
    tmp_close(&t, names);
    pf_free(x);
    pf_surface_release(&s);
    teardown_check();
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void test_ply_round_trip(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    double *x;
    make_moved_torus(&s, &x);
    tmpdir t;
    tmp_open(&t);
    assert_int_equal(pf_export_ply(tmp_file(&t, "t.ply"), &s, x, &err), PF_OK);
    size_t size;
    char *bytes = slurp(t.path, &size);
    char header[512];
    snprintf(header, sizeof header,
             "ply\nformat binary_little_endian 1.0\ncomment pf surface\nelement vertex %d\n"
             "property float x\nproperty float y\nproperty float z\nproperty float nx\n"
             "property float ny\nproperty float nz\nelement face %d\n"
             "property list uchar uint vertex_indices\nend_header\n",
             (int)s.n_verts, (int)s.n_tris);
    size_t h = strlen(header);
    assert_int_equal(size, h + 24 * (size_t)s.n_verts + 13 * (size_t)s.n_tris);
    assert_memory_equal(bytes, header, h);
    const unsigned char *p = (const unsigned char *)bytes + h;
    double *normals = pf_alloc_array(3 * (size_t)s.n_verts, sizeof *normals);
    pf_surface_vertex_normals(&s, x, normals);
    for (int32_t i = 0; i < 6 * s.n_verts; ++i, p += 4) {
        uint32_t bits = get_u32(p);
        float v;
        memcpy(&v, &bits, sizeof v);
        int32_t vert = i / 6, c = i % 6;
        /* float-exact: the nearest float32 of the position, then of the normal */
        assert_true(v == (float)(c < 3 ? x[3 * vert + c] : normals[3 * vert + c - 3]));
    }
    pf_free(normals);
    for (int32_t k = 0; k < s.n_tris; ++k, p += 13) {
        assert_int_equal(p[0], 3);
        for (int c = 0; c < 3; ++c)
            assert_int_equal(get_u32(p + 1 + 4 * c), s.tri[3 * k + c]);
    }
    free(bytes);
    x[5] = 1e39; /* finite as a double, infinite as a float */
    assert_int_equal(pf_export_ply(tmp_file(&t, "bad.ply"), &s, x, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "vertex 1"));
    assert_false(exists(t.path));
    static const char *const names[] = {"t.ply", NULL};
    tmp_close(&t, names);
    pf_free(x);
    pf_surface_release(&s);
    teardown_check();
}

/* ---- atomic writes --------------------------------------------------------------------------- */

static void test_atomic(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, 1, 1, 1);
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 3, 4, &err), PF_OK);
    tmpdir t;
    tmp_open(&t);
    /* a directory that does not exist: PF_ERR_IO naming the file and the reason */
    const char *missing = tmp_file(&t, "no/such/dir/mesh.vtu");
    assert_int_equal(pf_export_vtu(missing, &m, NULL, NULL, &err), PF_ERR_IO);
    assert_non_null(strstr(err.msg, "no/such/dir/mesh.vtu.part"));
    assert_non_null(strstr(err.msg, "No such file or directory"));
    assert_int_equal(pf_export_obj(missing, &s, NULL, &err), PF_ERR_IO);
    assert_int_equal(pf_export_ply(missing, &s, NULL, &err), PF_ERR_IO);
    /* the file cannot be renamed into place (a directory is in the way): the .part goes */
    assert_int_equal(mkdir(tmp_file(&t, "in_the_way.obj"), 0777), 0);
    assert_int_equal(pf_export_obj(t.path, &s, NULL, &err), PF_ERR_IO);
    assert_non_null(strstr(err.msg, "in_the_way.obj: cannot write OBJ file: cannot rename"));
    assert_false(exists(tmp_file(&t, "in_the_way.obj.part")));
    assert_int_equal(rmdir(tmp_file(&t, "in_the_way.obj")), 0);
    /* an unwritable directory (permissions do not stop root, so only checked for others) */
    if (geteuid() != 0) {
        assert_int_equal(mkdir(tmp_file(&t, "ro"), 0555), 0);
        assert_int_equal(pf_export_ply(tmp_file(&t, "ro/s.ply"), &s, NULL, &err), PF_ERR_IO);
        assert_false(exists(t.path));
        assert_int_equal(rmdir(tmp_file(&t, "ro")), 0);
    }
    /* a second export replaces the first whole */
    const char *path = tmp_file(&t, "twice.vtu");
    assert_int_equal(pf_export_vtu(path, &m, NULL, NULL, &err), PF_OK);
    size_t first;
    free(slurp(path, &first));
    double *u = pf_calloc(3 * (size_t)m.n_nodes, sizeof *u);
    assert_int_equal(pf_export_vtu(path, &m, u, NULL, &err), PF_OK);
    size_t size;
    char *xml = slurp(path, &size);
    assert_non_null(strstr(xml, "Name=\"displacement\""));
    assert_true(size > 11 && memcmp(xml + size - 11, "</VTKFile>\n", 11) == 0);
    free(xml);
    static const char *const names[] = {"twice.vtu", NULL};
    tmp_close(&t, names);
    pf_free(u);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    teardown_check();
}

/* ---- the tool test's stream ------------------------------------------------------------------ */

static int write_frames(const char *path)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 1;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, 2, 1, 1);
    /* a triangle on corners 0, 2 and 11, each vertex following its node (weight 1) */
    static const uint32_t corner[3] = {0, 2, 11};
    pf_surface s = {0};
    pf_weights w = {0};
    assert_int_equal(pf_surface_alloc(&s, 3, 1, &err), PF_OK);
    assert_int_equal(pf_weights_alloc(&w, 3, m.n_nodes, 3, &err), PF_OK);
    s.id = 5;
    w.surface_id = s.id;
    w.mesh_id = m.id;
    for (int v = 0; v < 3; ++v) {
        memcpy(s.x + 3 * v, m.x + 3 * corner[v], 3 * sizeof(double));
        s.tri[v] = (uint32_t)v;
        w.col[v] = corner[v];
        w.val[v] = 1;
        w.row_offsets[v + 1] = v + 1;
    }
    pf_frame_data fr = {0};
    pf_stress_data st = {0};
    assert_int_equal(pf_frame_data_alloc(&fr, m.n_nodes, &err), PF_OK);
    assert_int_equal(pf_stress_data_alloc(&st, m.n_elems, 1, &err), PF_OK);
    fr.mesh_id = st.mesh_id = m.id;
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, path, &err), PF_OK);
    assert_int_equal(pf_stream_write_info(wr, "test_export", "0", "test_export", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    assert_int_equal(pf_stream_write_surface(wr, &s, &err), PF_OK);
    assert_int_equal(pf_stream_write_weights(wr, &w, &err), PF_OK);
    for (uint32_t k = 0; k < 3; ++k) {
        fr.index = st.frame = k;
        fr.time = 0.5 * k;
        for (int32_t i = 0; i < 3 * m.n_nodes; ++i)
            fr.u[i] = 0.01 * k * (i % 3 == 2 ? -m.x[i - 2] : 0); /* sagging along x */
        assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
        for (int32_t e = 0; e < m.n_elems; ++e)
            st.values[e] = 100.0 * k + e;
        if (k < 2)
            assert_int_equal(pf_stream_write_stress(wr, &st, &err), PF_OK);
    }
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_stress_data_release(&st);
    pf_frame_data_release(&fr);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_mesh_release(&m);
    return fclose(f) == 0 ? 0 : 1;
}

/* The streams of --write-bad: each breaks one rule of docs/stream-format.md (or, for huge, none:
 * a finite frame no renderer can draw). */
static int write_bad(const char *kind, const char *path)
{
    const bool nodes_124 = strcmp(kind, "nodes-124") == 0, nodes_130 = strcmp(kind, "nodes-130") == 0,
               other_id = strcmp(kind, "mesh-id") == 0, before = strcmp(kind, "before-mesh") == 0,
               reused = strcmp(kind, "id-reused") == 0, huge = strcmp(kind, "huge") == 0;
    if (!nodes_124 && !nodes_130 && !other_id && !before && !reused && !huge)
        return 2;
    FILE *f = fopen(path, "wb");
    if (!f)
        return 1;
    pf_error err = {0};
    pf_mesh m = {0};
    make_box(&m, 4, 4, 4);
    pf_frame_data fr = {0};
    const int32_t n = nodes_124 ? 124 : nodes_130 ? 130 : m.n_nodes;
    assert_int_equal(pf_frame_data_alloc(&fr, n, &err), PF_OK);
    fr.mesh_id = other_id ? 7 : m.id;
    fr.index = 1;
    fr.time = 0.25;
    for (int32_t i = 0; i < 3 * n; ++i)
        fr.u[i] = huge ? 1e300 : 0.001 * (i % 3);
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, path, &err), PF_OK);
    assert_int_equal(pf_stream_write_info(wr, "test_export", "0", kind, &err), PF_OK);
    if (before)
        assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    if (reused)
        assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    fr.index = 0;
    if (huge) { /* frame 0 at rest, frame 1 far away */
        pf_frame_data rest = {0};
        assert_int_equal(pf_frame_data_alloc(&rest, n, &err), PF_OK);
        rest.mesh_id = m.id;
        assert_int_equal(pf_stream_write_frame(wr, &rest, &err), PF_OK);
        pf_frame_data_release(&rest);
        fr.index = 1;
    }
    if (!before)
        assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_frame_data_release(&fr);
    pf_mesh_release(&m);
    return fclose(f) == 0 ? 0 : 1;
}

static int drop_chunks(const char *tag, const char *in_path, const char *out_path)
{
    FILE *in = fopen(in_path, "rb"), *out = fopen(out_path, "wb");
    if (!in || !out)
        return 1;
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    pf_stream_writer *w = NULL;
    pf_status st = pf_stream_reader_create(&r, in, in_path, &err);
    if (st == PF_OK)
        st = pf_stream_writer_create(&w, out, out_path, &err);
    for (bool end = false; st == PF_OK;) {
        pf_chunk c;
        st = pf_stream_read_chunk(r, &c, &end, &err);
        if (st != PF_OK || end)
            break;
        if (strcmp(c.tag, tag) != 0 && strcmp(c.tag, "END_") != 0)
            st = pf_stream_write_raw(w, &c, &err);
    }
    if (st == PF_OK)
        st = pf_stream_writer_finish(w, &err);
    if (st != PF_OK)
        fprintf(stderr, "test_export --drop: %s\n", err.msg);
    pf_stream_writer_destroy(&w);
    pf_stream_reader_destroy(&r);
    fclose(in);
    return fclose(out) == 0 && st == PF_OK ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-frames") == 0)
        return write_frames(argv[2]);
    if (argc == 4 && strcmp(argv[1], "--write-bad") == 0)
        return write_bad(argv[2], argv[3]);
    if (argc == 5 && strcmp(argv[1], "--drop") == 0)
        return drop_chunks(argv[2], argv[3], argv[4]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vtu_box),
        cmocka_unit_test(test_vtu_polyhedron_and_tet),
        cmocka_unit_test(test_vtu_invalid),
        cmocka_unit_test(test_pvd),
        cmocka_unit_test(test_obj_round_trip),
        cmocka_unit_test(test_ply_round_trip),
        cmocka_unit_test(test_atomic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
