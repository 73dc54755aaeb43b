/* import: Gmsh .msh (2.2, 4.1), TetGen .node/.ele and assimp surfaces give the exact unit cube;
 * every malformed file gives its documented status and a message naming file and line; every
 * prefix and a few hundred corruptions of the good files end in PF_OK or a clean error, never a
 * crash or a leak. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp: a private directory for files written by the tests */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <pf/io.h>

/* The cube's volume is 1 and each element's volume is a sum of products of 0s and 1s divided by
 * 6: exact in binary except for the final sums of a few terms, so 1e-15 relative (about 5 ulps)
 * bounds the round-off of any correct import and rejects any wrong element. */
static const double VOLUME_RTOL = 1e-15;

static char data_path[512];

static const char *data(const char *name)
{
    snprintf(data_path, sizeof data_path, "%s/%s", PF_TEST_DATA_DIR, name);
    return data_path;
}

/* |got - want| <= tol, with both numbers printed in full when not. */
static void assert_near(double got, double want, double tol)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%.17g, expected %.17g (tolerance %g)", got, want, tol);
}

static void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

static void read_file(const char *path, pf_buffer *out)
{
    pf_error err = {0};
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    out->size = 0;
    unsigned char piece[4096];
    for (size_t n; (n = fread(piece, 1, sizeof piece, f)) > 0;)
        assert_int_equal(pf_buffer_append(out, piece, n, &err), PF_OK);
    fclose(f);
}

static void write_file(const char *path, const void *bytes, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes ? bytes : "", 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

/* A private directory for the test's files, removed with its files at the end. */
typedef struct scratch_dir {
    char dir[64];
    char path[128];
} scratch_dir;

static void scratch_open(scratch_dir *d)
{
    snprintf(d->dir, sizeof d->dir, "/tmp/pf-test-import-XXXXXX");
    assert_non_null(mkdtemp(d->dir));
}

static const char *scratch_file(scratch_dir *d, const char *name)
{
    snprintf(d->path, sizeof d->path, "%s/%s", d->dir, name);
    return d->path;
}

static void scratch_close(scratch_dir *d, const char *const *names)
{
    for (; *names; ++names)
        remove(scratch_file(d, *names));
    rmdir(d->dir);
}

static bool is_zero_mesh(const pf_mesh *m)
{
    static const pf_mesh zero = {0};
    return memcmp(m, &zero, sizeof zero) == 0;
}

/* Counts, kinds, validity and the exact volume of an imported mesh. */
static void check_mesh(const pf_mesh *m, int32_t nodes, int32_t faces, int32_t elems,
                       pf_elem_kind kind, double volume)
{
    pf_error err = {0};
    assert_int_equal(m->n_nodes, nodes);
    assert_int_equal(m->n_faces, faces);
    assert_int_equal(m->n_elems, elems);
    if (pf_mesh_validate(m, NULL, &err) != PF_OK)
        fail_msg("invalid mesh: %s", err.msg);
    pf_mesh_stats st;
    assert_int_equal(pf_mesh_compute_stats(m, &st, &err), PF_OK);
    assert_int_equal(st.n_by_kind[kind], elems);
    if (fabs(st.volume - volume) > VOLUME_RTOL * volume)
        fail_msg("volume %.17g, expected %.17g", st.volume, volume);
    for (int32_t e = 0; e < m->n_elems; ++e)
        assert_true(pf_mesh_elem_volume(m, e) > 0);
    /* Every node lies on the box [0, volume] x [0, 1]^2 that the test files fill. */
    for (int32_t i = 0; i < 3 * m->n_nodes; ++i)
        assert_true(m->x[i] == 0 || m->x[i] == 1 || m->x[i] == 2);
}

/* ---- good files ------------------------------------------------------------------------------ */

static void test_msh_v22_cube(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    if (pf_import_msh(data("cube.msh"), &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    /* 5 tets: 4 corner tets around a central one sharing 4 faces: 20 - 4 faces. The file's 9th
     * node (tag 999) is used by no element and dropped; points, lines and triangles skipped. */
    check_mesh(&m, 8, 16, 5, PF_ELEM_TET, 1.0);
    /* Nodes keep the file's order although their tags (40, 10, 80, ...) do not follow it. */
    assert_true(m.x[0] == 0 && m.x[1] == 1 && m.x[2] == 0);
    assert_true(m.x[3] == 0 && m.x[4] == 0 && m.x[5] == 0);
    assert_true(m.x[21] == 0 && m.x[22] == 0 && m.x[23] == 1);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_msh_v41_cube(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    if (pf_import_msh(data("cube41.msh"), &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    /* 6 tets around the diagonal 0-6, each sharing two faces with its neighbours: 24 - 6. */
    check_mesh(&m, 8, 18, 6, PF_ELEM_TET, 1.0);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_msh_hexes(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    if (pf_import_msh(data("hexes.msh"), &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    /* Two unit hexes sharing one face: 12 - 1 faces, volume 2. Gmsh's hex numbering is the one
     * pf_mesh_from_hexes takes, so a wrong order would show as a non-hex kind or a bad volume. */
    check_mesh(&m, 12, 11, 2, PF_ELEM_HEX, 2.0);
    assert_near(pf_mesh_elem_volume(&m, 0), 1.0, 0.0);
    assert_near(pf_mesh_elem_volume(&m, 1), 1.0, 0.0);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Second-order cells give their corners: a 10-node tet (type 11) and a 20-node hex (type 17),
 * whose mid-edge nodes are then unused and dropped. */
static void test_msh_second_order_cells(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    scratch_dir d;
    scratch_open(&d);
    char text[4096];
    int n = snprintf(text, sizeof text,
                     "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n"
                     "1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0.5 0 0\n6 0.5 0.5 0\n7 0 0.5 0\n"
                     "8 0 0 0.5\n9 0 0.5 0.5\n10 0.5 0 0.5\n$EndNodes\n"
                     "$Elements\n1\n1 11 2 0 1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n");
    write_file(scratch_file(&d, "tet10.msh"), text, (size_t)n);
    pf_error err = {0};
    pf_mesh m = {0};
    if (pf_import_msh(d.path, &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(m.n_nodes, 4);
    assert_int_equal(m.n_elems, 1);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    assert_near(pf_mesh_elem_volume(&m, 0), 1.0 / 6.0, 1e-16);
    pf_mesh_release(&m);

    /* A 20-node hex in 4.1: corners of the unit cube, then 12 mid-edge nodes. */
    static const double CORNER[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                        {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    n = snprintf(text, sizeof text,
                 "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 20 1 20\n"
                 "3 1 0 20\n");
    for (int i = 1; i <= 20; ++i)
        n += snprintf(text + n, sizeof text - (size_t)n, "%d\n", i);
    for (int i = 0; i < 20; ++i)
        n += snprintf(text + n, sizeof text - (size_t)n, "%g %g %g\n", i < 8 ? CORNER[i][0] : 0.5,
                      i < 8 ? CORNER[i][1] : 0.5, i < 8 ? CORNER[i][2] : 0.5 + 0.01 * i);
    n += snprintf(text + n, sizeof text - (size_t)n, "$EndNodes\n$Elements\n1 1 1 1\n3 1 17 1\n1");
    for (int i = 1; i <= 20; ++i)
        n += snprintf(text + n, sizeof text - (size_t)n, " %d", i);
    n += snprintf(text + n, sizeof text - (size_t)n, "\n$EndElements\n");
    write_file(scratch_file(&d, "hex20.msh"), text, (size_t)n);
    if (pf_import_msh(d.path, &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    check_mesh(&m, 8, 6, 1, PF_ELEM_HEX, 1.0);
    pf_mesh_release(&m);
    scratch_close(&d, (const char *const[]){"tet10.msh", "hex20.msh", NULL});
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_tetgen_cube(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    /* The same mesh from the .node file, the .ele file and the stem. */
    const char *names[] = {"cube.node", "cube.ele", "cube"};
    for (int i = 0; i < 3; ++i) {
        if (pf_import_tetgen(data(names[i]), &m, &err) != PF_OK)
            fail_msg("%s: %s", names[i], err.msg);
        check_mesh(&m, 8, 18, 6, PF_ELEM_TET, 1.0);
        pf_mesh_release(&m);
    }
    /* Indices from 0, no attributes or markers, 10-node tets, no trailing newline. */
    scratch_dir d;
    scratch_open(&d);
    static const char NODE[] = "# tet\n4 3\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1 # apex\n";
    static const char ELE[] = "1 10\n0 0 1 2 3 0 1 2 3 0 1";
    write_file(scratch_file(&d, "t.node"), NODE, sizeof NODE - 1);
    write_file(scratch_file(&d, "t.ele"), ELE, sizeof ELE - 1);
    if (pf_import_tetgen(scratch_file(&d, "t"), &m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(m.n_nodes, 4);
    assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
    assert_near(pf_mesh_elem_volume(&m, 0), 1.0 / 6.0, 1e-16);
    pf_mesh_release(&m);
    scratch_close(&d, (const char *const[]){"t.node", "t.ele", NULL});
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_volume_dispatch(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    assert_true(pf_import_is_volume_path("a/b.msh"));
    assert_true(pf_import_is_volume_path("B.MSH"));
    assert_true(pf_import_is_volume_path("x.node"));
    assert_true(pf_import_is_volume_path("x.Ele"));
    assert_false(pf_import_is_volume_path("x.obj"));
    assert_false(pf_import_is_volume_path(".msh.stl"));
    assert_false(pf_import_is_volume_path("msh"));
    pf_error err = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_import_volume(data("cube41.msh"), &m, &err), PF_OK);
    assert_int_equal(m.n_elems, 6);
    pf_mesh_release(&m);
    assert_int_equal(pf_import_volume(data("cube"), &m, &err), PF_OK);
    assert_int_equal(m.n_elems, 6);
    pf_mesh_release(&m);
    assert_int_equal(pf_import_volume(data("cube.obj"), &m, &err), PF_ERR_UNSUPPORTED);
    expect_msg(&err, "cube.obj");
    assert_true(is_zero_mesh(&m));
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_surfaces_are_closed_unit_cubes(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    /* cube_split.obj gives every face its own 4 vertices and normal: only the join by position
     * closes it. */
    const char *names[] = {"cube.obj", "cube_split.obj", "cube.stl"};
    for (int i = 0; i < 3; ++i) {
        pf_error err = {0};
        pf_surface s = {0};
        if (pf_import_surface(data(names[i]), &s, &err) != PF_OK)
            fail_msg("%s: %s", names[i], err.msg);
        assert_int_equal(s.id, 1);
        pf_surface_stats st;
        assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
        assert_int_equal(st.n_verts, 8);
        assert_int_equal(st.n_tris, 12);
        assert_true(st.closed);
        assert_true(st.manifold);
        assert_int_equal(st.n_boundary_edges, 0);
        if (fabs(st.volume - 1.0) > VOLUME_RTOL)
            fail_msg("%s: volume %.17g", names[i], st.volume);
        assert_near(st.area, 6.0, 6.0 * VOLUME_RTOL);
        pf_surface_release(&s);
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- bad files ------------------------------------------------------------------------------- */

typedef struct bad_case {
    const char *file;
    pf_status status;
    const char *where;  /* "file:line:" */
    const char *reason; /* part of the message */
} bad_case;

static void test_bad_files(void **state)
{
    (void)state;
    static const bad_case CASES[] = {
        {"bad_node_range.msh", PF_ERR_FORMAT,
         "bad_node_range.msh:23:", "element 7 refers to node 99, which the file does not define"},
        {"bad_nan.msh", PF_ERR_FORMAT, "bad_nan.msh:9:", "not finite"},
        {"bad_truncated.msh", PF_ERR_FORMAT, "bad_truncated.msh:22:", "file ends inside $Elements"},
        {"bad_count.msh", PF_ERR_FORMAT, "bad_count.msh:5:", "more than the rest of the file"},
        {"bad_no_endnodes.msh", PF_ERR_FORMAT, "bad_no_endnodes.msh:18:", "missing $EndNodes"},
        {"empty.msh", PF_ERR_FORMAT, "empty.msh:1:", "empty file"},
        {"binary.msh", PF_ERR_UNSUPPORTED,
         "binary.msh:2:", "binary .msh is not supported; re-save as ASCII"},
        {"bad_version.msh", PF_ERR_UNSUPPORTED, "bad_version.msh:2:", "version '3.0'"},
        {"bad_range.ele", PF_ERR_FORMAT, "bad_range.ele:4:", "refers to node 9"},
        {"missing.msh", PF_ERR_IO, "missing.msh", "cannot open"},
        {"missing.node", PF_ERR_IO, "missing.node", "cannot open"},
    };
    int64_t live = pf_alloc_live_bytes();
    for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; ++i) {
        const bad_case *c = &CASES[i];
        pf_error err = {0};
        pf_mesh m;
        memset(&m, 0xab, sizeof m); /* the importer zeroes its output whatever it held */
        pf_status s = pf_import_volume(data(c->file), &m, &err);
        if (s != c->status)
            fail_msg("%s: status %d, expected %d (%s)", c->file, s, c->status, err.msg);
        expect_msg(&err, c->where);
        expect_msg(&err, c->reason);
        assert_null(strchr(err.msg, '\n'));
        assert_true(is_zero_mesh(&m));
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_bad_surfaces(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface s;
    memset(&s, 0xab, sizeof s);
    assert_int_equal(pf_import_surface(data("missing.obj"), &s, &err), PF_ERR_IO);
    expect_msg(&err, "missing.obj");
    assert_null(s.x);
    /* Vertices but no face. */
    assert_int_equal(pf_import_surface(data("bad_nofaces.obj"), &s, &err), PF_ERR_FORMAT);
    expect_msg(&err, "bad_nofaces.obj: no triangles");
    assert_null(s.x);
    assert_int_equal(s.n_tris, 0);
    /* A mesh file is no surface assimp reads; its reason is passed on. */
    assert_int_equal(pf_import_surface(data("cube.msh"), &s, &err), PF_ERR_FORMAT);
    expect_msg(&err, "cube.msh");
    expect_msg(&err, "assimp");
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- damaged copies of the good files -------------------------------------------------------- */

/* One import of a damaged file: PF_OK with a valid mesh, or a clean error naming the file. */
static pf_status import_damaged(const char *path, const char *name, bool tetgen)
{
    pf_error err = {0};
    pf_mesh m;
    memset(&m, 0xab, sizeof m);
    pf_status s = tetgen ? pf_import_tetgen(path, &m, &err) : pf_import_msh(path, &m, &err);
    if (s == PF_OK) {
        /* A prefix can still be a whole file (a cut in trailing blanks) or fewer cells. */
        pf_mesh_release(&m);
        return s;
    }
    if (s != PF_ERR_FORMAT && s != PF_ERR_UNSUPPORTED && s != PF_ERR_INVALID)
        fail_msg("status %d: %s", s, err.msg);
    if (getenv("PF_TEST_VERBOSE"))
        print_message("%s\n", err.msg);
    expect_msg(&err, name);
    assert_null(strchr(err.msg, '\n'));
    assert_true(is_zero_mesh(&m));
    return s;
}

static void test_every_prefix_is_ok_or_a_clean_error(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    scratch_dir d;
    scratch_open(&d);
    pf_buffer good = {0};
    const char *files[] = {"cube.msh", "cube41.msh", "hexes.msh"};
    for (int f = 0; f < 3; ++f) {
        read_file(data(files[f]), &good);
        int complete = 0;
        for (size_t n = 0; n < good.size; ++n) {
            write_file(scratch_file(&d, "cut.msh"), good.data, n);
            complete += import_damaged(d.path, "cut.msh", false) == PF_OK;
        }
        /* Only a cut inside the final newline of "$EndElements\n" leaves a whole file. */
        assert_int_equal(complete, 1);
    }
    /* TetGen: every prefix of the .ele file beside the whole .node file, and the reverse. */
    const char *pair[2][2] = {{"cube.node", "cut.node"}, {"cube.ele", "cut.ele"}};
    for (int cut = 0; cut < 2; ++cut) {
        pf_buffer other = {0};
        read_file(data(pair[!cut][0]), &other);
        write_file(scratch_file(&d, pair[!cut][1]), other.data, other.size);
        pf_buffer_release(&other);
        read_file(data(pair[cut][0]), &good);
        for (size_t n = 0; n < good.size; ++n) {
            write_file(scratch_file(&d, pair[cut][1]), good.data, n);
            import_damaged(scratch_file(&d, "cut"), "cut.", true);
        }
        write_file(scratch_file(&d, pair[cut][1]), good.data, good.size);
    }
    pf_buffer_release(&good);
    scratch_close(&d, (const char *const[]){"cut.msh", "cut.node", "cut.ele", NULL});
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Deterministic corruptions: random bytes overwritten with characters that matter to the parser
 * (digits, signs, '$', blanks, newlines, NUL, letters of nan/inf), or lines dropped. */
static void test_corrupted_files_are_ok_or_a_clean_error(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    static const char ALPHABET[] = "0123456789-+.eE $\n\t\rnaifNAIF#x";
    scratch_dir d;
    scratch_open(&d);
    pf_buffer good = {0}, bad = {0};
    pf_error err = {0};
    const char *files[] = {"cube.msh", "cube41.msh", "hexes.msh"};
    uint64_t seed = 0x9e3779b97f4a7c15u;
    int n_ok = 0, n_tried = 0;
    for (int f = 0; f < 3; ++f) {
        read_file(data(files[f]), &good);
        for (int trial = 0; trial < 300; ++trial) {
            bad.size = 0;
            assert_int_equal(pf_buffer_append(&bad, good.data, good.size, &err), PF_OK);
            int edits = 1 + trial % 4;
            for (int e = 0; e < edits; ++e) {
                seed = seed * 6364136223846793005u + 1442695040888963407u;
                size_t at = (size_t)(seed >> 33) % bad.size;
                unsigned pick = (unsigned)(seed >> 17) % (sizeof ALPHABET);
                bad.data[at] = pick == sizeof ALPHABET - 1 ? '\0' : (unsigned char)ALPHABET[pick];
            }
            write_file(scratch_file(&d, "bad.msh"), bad.data, bad.size);
            n_ok += import_damaged(d.path, "bad.msh", false) == PF_OK;
            n_tried++;
        }
    }
    pf_buffer_release(&good);
    pf_buffer_release(&bad);
    scratch_close(&d, (const char *const[]){"bad.msh", NULL});
    /* Most edits break the file; some only touch a value (a coordinate digit) and still import:
     * both outcomes are exercised. */
    print_message("corrupted files: %d of %d imported\n", n_ok, n_tried);
    assert_true(n_ok > 0 && n_ok < n_tried / 2);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_msh_v22_cube),
        cmocka_unit_test(test_msh_v41_cube),
        cmocka_unit_test(test_msh_hexes),
        cmocka_unit_test(test_msh_second_order_cells),
        cmocka_unit_test(test_tetgen_cube),
        cmocka_unit_test(test_volume_dispatch),
        cmocka_unit_test(test_surfaces_are_closed_unit_cubes),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_bad_surfaces),
        cmocka_unit_test(test_every_prefix_is_ok_or_a_clean_error),
        cmocka_unit_test(test_corrupted_files_are_ok_or_a_clean_error),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
