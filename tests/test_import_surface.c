/* import_surface: pf's own OBJ, OFF, PLY (ASCII, binary little- and big-endian) and STL (ASCII,
 * binary) readers give back exactly the doubles written (bit for bit: no float on the way), keep
 * valid surfaces at any scale (1e-12 .. 1e12, through assimp too), refuse size bombs before
 * allocating, and name file and line (text) or byte (binary) in every error. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
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
#include <pf/mesh.h>

typedef struct scratch_dir {
    char dir[64];
    char path[160];
} scratch_dir;

static void scratch_open(scratch_dir *d)
{
    snprintf(d->dir, sizeof d->dir, "/tmp/pf-test-surface-XXXXXX");
    assert_non_null(mkdtemp(d->dir));
}

static const char *scratch_file(scratch_dir *d, const char *name)
{
    snprintf(d->path, sizeof d->path, "%s/%s", d->dir, name);
    return d->path;
}

static void scratch_close(scratch_dir *d, const char *const *names, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        unlink(scratch_file(d, names[i]));
    rmdir(d->dir);
}

static void write_bytes(const char *path, const void *bytes, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

/* ---- writers of the reference surface in every format ---------------------------------------- */

static void put_le(FILE *f, const void *v, size_t n, bool big_endian)
{
    const unsigned char *b = v;
    for (size_t i = 0; i < n; ++i)
        fputc(b[big_endian ? n - 1 - i : i], f);
}

static void write_obj(const char *path, const pf_surface *s)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "# reference sphere\nmtllib none.mtl\no sphere\n");
    for (int32_t v = 0; v < s->n_verts; ++v)
        fprintf(f, "v %.17g %.17g %.17g\nvn 0 0 1\n", s->x[3 * v], s->x[3 * v + 1],
                s->x[3 * v + 2]);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *c = s->tri + 3 * t;
        if (t % 3 == 0) /* relative references, counted back from the last vertex */
            fprintf(f, "f %d %d %d\n", (int)c[0] - s->n_verts, (int)c[1] - s->n_verts,
                    (int)c[2] - s->n_verts);
        else if (t % 3 == 1)
            fprintf(f, "f %u//1 %u//1 %u//1\n", c[0] + 1, c[1] + 1, c[2] + 1);
        else
            fprintf(f, "f %u/1/1 %u/1/1 %u/1/1\n", c[0] + 1, c[1] + 1, c[2] + 1);
    }
    assert_int_equal(fclose(f), 0);
}

static void write_off(const char *path, const pf_surface *s)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "OFF\n# counts\n%d %d 0\n", (int)s->n_verts, (int)s->n_tris);
    for (int32_t v = 0; v < s->n_verts; ++v)
        fprintf(f, "%.17g %.17g %.17g\n", s->x[3 * v], s->x[3 * v + 1], s->x[3 * v + 2]);
    for (int32_t t = 0; t < s->n_tris; ++t)
        fprintf(f, "3 %u %u %u\n", s->tri[3 * t], s->tri[3 * t + 1], s->tri[3 * t + 2]);
    assert_int_equal(fclose(f), 0);
}

typedef enum { PLY_ASCII, PLY_LE, PLY_BE } ply_kind;

/* A PLY with an extra vertex property and an extra element, which the reader reads past, and a
 * free-text header line as old Blender exporters wrote ("Created by Blender3D 247 ..."), which it
 * skips as a comment. */
static void write_ply(const char *path, const pf_surface *s, ply_kind kind)
{
    static const char *FORMAT[] = {"ascii", "binary_little_endian", "binary_big_endian"};
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fprintf(f,
            "ply\nformat %s 1.0\ncomment reference sphere\nCreated by hand, source file: \n"
            "element vertex %d\nproperty double x\n"
            "property double y\nproperty uchar red\nproperty double z\nelement face %d\n"
            "property list uchar int vertex_indices\nelement note 2\nproperty list int short k\n"
            "property float w\nend_header\n",
            FORMAT[kind], (int)s->n_verts, (int)s->n_tris);
    const bool be = kind == PLY_BE;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        const double *p = s->x + 3 * v;
        const unsigned char red = 200;
        if (kind == PLY_ASCII) {
            fprintf(f, "%.17g %.17g %d %.17g\n", p[0], p[1], red, p[2]);
            continue;
        }
        put_le(f, &p[0], 8, be);
        put_le(f, &p[1], 8, be);
        put_le(f, &red, 1, be);
        put_le(f, &p[2], 8, be);
    }
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const int32_t c[3] = {(int32_t)s->tri[3 * t], (int32_t)s->tri[3 * t + 1],
                              (int32_t)s->tri[3 * t + 2]};
        if (kind == PLY_ASCII) {
            fprintf(f, "3 %d %d %d\n", c[0], c[1], c[2]);
            continue;
        }
        const unsigned char three = 3;
        put_le(f, &three, 1, be);
        for (int i = 0; i < 3; ++i)
            put_le(f, &c[i], 4, be);
    }
    for (int k = 0; k < 2; ++k) {
        const int32_t n = 2;
        const int16_t items[2] = {7, -7};
        const float w = 0.5f;
        if (kind == PLY_ASCII) {
            fprintf(f, "2 7 -7 0.5\n");
            continue;
        }
        put_le(f, &n, 4, be);
        put_le(f, &items[0], 2, be);
        put_le(f, &items[1], 2, be);
        put_le(f, &w, 4, be);
    }
    assert_int_equal(fclose(f), 0);
}

static void write_stl_ascii(const char *path, const pf_surface *s)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "solid sphere\n");
    for (int32_t t = 0; t < s->n_tris; ++t) {
        fprintf(f, "  facet normal 0 0 0\n    outer loop\n");
        for (int i = 0; i < 3; ++i) {
            const double *p = s->x + 3 * s->tri[3 * t + i];
            fprintf(f, "      vertex %.17g %.17g %.17g\n", p[0], p[1], p[2]);
        }
        fprintf(f, "    endloop\n  endfacet\n");
    }
    fprintf(f, "endsolid sphere\n");
    assert_int_equal(fclose(f), 0);
}

/* Binary STL whose 80-byte header starts with "solid", as many exporters write it. */
static void write_stl_binary(const char *path, const pf_surface *s)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    char header[80] = "solid but binary";
    fwrite(header, 1, sizeof header, f);
    const uint32_t n = (uint32_t)s->n_tris;
    put_le(f, &n, 4, false);
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const float normal[3] = {0, 0, 0};
        for (int k = 0; k < 3; ++k)
            put_le(f, &normal[k], 4, false);
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) {
                const float c = (float)s->x[3 * s->tri[3 * t + i] + k];
                put_le(f, &c, 4, false);
            }
        const uint16_t attr = 0;
        put_le(f, &attr, 2, false);
    }
    assert_int_equal(fclose(f), 0);
}

/* ---- comparison ------------------------------------------------------------------------------- */

static int compare_point(const void *pa, const void *pb)
{
    const double *a = pa, *b = pb;
    for (int k = 0; k < 3; ++k)
        if (a[k] != b[k])
            return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* got has want's triangles on want's positions (rounded to float when single), exactly: the same
 * counts, the same set of positions bit for bit, and (positions joined in order of first use) the
 * same enclosed volume to the last bit, since it sums the same triangles in the same order. */
static void expect_same_surface(const char *what, const pf_surface *got, const pf_surface *want,
                                bool single)
{
    if (got->n_verts != want->n_verts || got->n_tris != want->n_tris)
        fail_msg("%s: %d vertices, %d triangles; expected %d, %d", what, (int)got->n_verts,
                 (int)got->n_tris, (int)want->n_verts, (int)want->n_tris);
    const size_t n = 3 * (size_t)want->n_verts;
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    assert_non_null(a);
    assert_non_null(b);
    for (size_t i = 0; i < n; ++i) {
        a[i] = got->x[i];
        b[i] = single ? (double)(float)want->x[i] : want->x[i];
    }
    qsort(a, (size_t)want->n_verts, 3 * sizeof *a, compare_point);
    qsort(b, (size_t)want->n_verts, 3 * sizeof *b, compare_point);
    for (size_t i = 0; i < n; ++i)
        if (a[i] != b[i])
            fail_msg("%s: coordinate %zu is %.17g, expected %.17g", what, i, a[i], b[i]);
    free(a);
    free(b);
    pf_error err = {0};
    pf_surface_stats sg, sw;
    assert_int_equal(pf_surface_compute_stats(got, &sg, &err), PF_OK);
    assert_int_equal(pf_surface_compute_stats(want, &sw, &err), PF_OK);
    if (!sg.closed || !sg.manifold)
        fail_msg("%s: not closed and manifold", what);
    if (!single && sg.volume != sw.volume)
        fail_msg("%s: volume %.17g, expected %.17g", what, sg.volume, sw.volume);
}

static void test_formats_read_exact_doubles(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_surface ref = {0};
    /* Coordinates from sin and cos: almost none is a float, so any float on the way shows. */
    assert_int_equal(pf_surface_make_sphere(&ref, 1.0, 9, 14, &err), PF_OK);
    scratch_dir d;
    scratch_open(&d);
    static const char *NAMES[] = {"s.obj", "s.off", "s.ply", "le.PLY", "be.ply", "a.stl", "b.stl"};
    write_obj(scratch_file(&d, NAMES[0]), &ref);
    write_off(scratch_file(&d, NAMES[1]), &ref);
    write_ply(scratch_file(&d, NAMES[2]), &ref, PLY_ASCII);
    write_ply(scratch_file(&d, NAMES[3]), &ref, PLY_LE);
    write_ply(scratch_file(&d, NAMES[4]), &ref, PLY_BE);
    write_stl_ascii(scratch_file(&d, NAMES[5]), &ref);
    write_stl_binary(scratch_file(&d, NAMES[6]), &ref);
    for (size_t i = 0; i < 7; ++i) {
        pf_surface s = {0};
        pf_surface_import_info how;
        if (pf_import_surface_ex(scratch_file(&d, NAMES[i]), &s, &how, &err) != PF_OK)
            fail_msg("%s: %s", NAMES[i], err.msg);
        assert_false(how.single_precision);
        assert_int_equal(s.id, 1);
        expect_same_surface(NAMES[i], &s, &ref, i == 6);
        pf_surface_release(&s);
    }
    scratch_close(&d, NAMES, 7);
    pf_surface_release(&ref);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* An L-shaped prism: its two end faces are non-convex hexagons, given whole. A fan from a corner
 * of an L would flip a triangle; ear clipping keeps every triangle's normal along its face's. */
static void test_obj_polygons(void **state)
{
    (void)state;
    static const char OBJ[] = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n"
                              "v 0 0 1\nv 2 0 1\nv 2 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\n"
                              "f 4 3 2 1 6 5\nf 7 8 9 10 11 12\n"
                              "f 1 2 8 7\nf 2 3 9 8\nf 3 4 10 9\nf 4 5 11 10\nf 5 6 12 11\n"
                              "f 6 1 7 12\n";
    scratch_dir d;
    scratch_open(&d);
    const char *names[] = {"l.obj"};
    write_bytes(scratch_file(&d, names[0]), OBJ, sizeof OBJ - 1);
    pf_error err = {0};
    pf_surface s = {0};
    if (pf_import_surface(scratch_file(&d, names[0]), &s, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(s.n_verts, 12);
    assert_int_equal(s.n_tris, 2 * 4 + 6 * 2);
    pf_surface_stats st;
    assert_int_equal(pf_surface_compute_stats(&s, &st, &err), PF_OK);
    assert_true(st.closed && st.manifold);
    assert_true(st.volume == 3.0); /* exact: small integers */
    for (int32_t t = 0; t < s.n_tris; ++t) {
        const double *a = s.x + 3 * s.tri[3 * t], *b = s.x + 3 * s.tri[3 * t + 1],
                     *c = s.x + 3 * s.tri[3 * t + 2];
        double nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if (a[2] == b[2] && b[2] == c[2]) /* an end face: outward is -z at 0, +z at 1 */
            assert_true(a[2] == 0 ? nz < 0 : nz > 0);
    }
    pf_surface_release(&s);
    scratch_close(&d, names, 1);
}

/* A closed sphere at 1e-12 and 1e12 keeps all its triangles (no absolute area or distance test),
 * through pf's reader and through assimp (a DirectX .x tetrahedron, told single precision). */
static void test_any_scale(void **state)
{
    (void)state;
    pf_error err = {0};
    scratch_dir d;
    scratch_open(&d);
    const char *names[] = {"tiny.obj", "tet.x"};
    static const double SCALES[] = {1e-12, 1e12, 1e-30};
    for (int k = 0; k < 3; ++k) {
        pf_surface ref = {0}, s = {0};
        assert_int_equal(pf_surface_make_sphere(&ref, SCALES[k], 8, 16, &err), PF_OK);
        write_obj(scratch_file(&d, names[0]), &ref);
        if (pf_import_surface(scratch_file(&d, names[0]), &s, &err) != PF_OK)
            fail_msg("scale %g: %s", SCALES[k], err.msg);
        expect_same_surface("scaled sphere", &s, &ref, false);
        pf_surface_release(&s);
        pf_surface_release(&ref);
    }
    static const char X[] = "xof 0303txt 0032\nMesh {\n 4;\n 0;0;0;,\n 1e-12;0;0;,\n 0;1e-12;0;,\n"
                            " 0;0;1e-12;;\n 4;\n 3;0,2,1;,\n 3;0,1,3;,\n 3;0,3,2;,\n 3;1,2,3;;\n}\n";
    write_bytes(scratch_file(&d, names[1]), X, sizeof X - 1);
    pf_surface s = {0};
    pf_surface_import_info how;
    if (pf_import_surface_ex(scratch_file(&d, names[1]), &s, &how, &err) != PF_OK)
        fail_msg("tet.x: %s", err.msg);
    assert_string_equal(how.reader, "assimp");
    assert_true(how.single_precision);
    assert_int_equal(s.n_verts, 4);
    assert_int_equal(s.n_tris, 4);
    pf_surface_release(&s);
    scratch_close(&d, names, 2);
}

/* ---- hostile files ---------------------------------------------------------------------------- */

typedef struct bad_surface {
    const char *name;
    const char *bytes; /* NULL: the binary STL bomb */
    pf_status status;
    const char *needle;
} bad_surface;

static void test_bad_surfaces(void **state)
{
    (void)state;
    static const bad_surface CASES[] = {
        /* Counts far beyond what the bytes can hold: refused before any allocation. */
        {"bomb.ply",
         "ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n",
         PF_ERR_FORMAT, "bomb.ply:3: 2000000000 'vertex' announced, more than the rest"},
        {"bomb_bin.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty double x\n"
         "property double y\nproperty double z\nend_header\n0123456789abcdef",
         PF_ERR_FORMAT, "bomb_bin.ply:3: 2000000000 'vertex' announced"},
        {"bomb_faces.ply",
         "ply\nformat binary_big_endian 1.0\nelement vertex 0\nproperty double x\n"
         "property double y\nproperty double z\nelement face 1999999999\n"
         "property list uint int vertex_indices\nend_header\n",
         PF_ERR_FORMAT, "1999999999 'face' announced"},
        {"bomb.off", "OFF\n2000000000 1 0\n0 0 0\n", PF_ERR_FORMAT,
         "bomb.off:2: 2000000000 vertices announced, more than the rest of the file can hold"},
        {"bomb.stl", NULL, PF_ERR_FORMAT,
         "bomb.stl: byte 80: 2000000000 triangles announced, more than the file's 184 bytes"},
        /* Malformed files: file and line (text) or byte (binary). */
        {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", PF_ERR_FORMAT,
         "range.obj:4: face refers to vertex 4, but 3 vertices are defined so far"},
        {"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", PF_ERR_FORMAT,
         "zero.obj:4: face refers to vertex 0"},
        {"nan.obj", "v 0 0 0\nv nan 0 0\n", PF_ERR_FORMAT, "nan.obj:2: a vertex coordinate is not finite"},
        {"junk.obj", "v 0 0 0\nf 1 x 1\n", PF_ERR_FORMAT, "junk.obj:2: expected a vertex reference"},
        {"nofaces.obj", "v 0 0 0\nv 1 0 0\n", PF_ERR_FORMAT, "nofaces.obj: no triangles"},
        {"flat.obj", "v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n", PF_ERR_FORMAT,
         "flat.obj: no triangles (all 1 are degenerate"},
        {"cut.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n", PF_ERR_FORMAT,
         "cut.off:5: file ends after 0 of 1 faces"},
        {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", PF_ERR_FORMAT,
         "range.off:6: face refers to vertex 3, but the file defines 3"},
        {"notoff.off", "4OFF\n1 1 0\n", PF_ERR_FORMAT, "notoff.off:1: not an OFF file"},
        {"format.ply", "ply\nformat utf8 1.0\nend_header\n", PF_ERR_FORMAT,
         "format.ply:2: unknown format"},
        {"noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
         PF_ERR_FORMAT, "no 'vertex' element with properties x, y and z"},
        {"range.ply",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
         PF_ERR_FORMAT, "range.ply:13: face refers to vertex 5, but the file has 3"},
        {"cut.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
         "property double y\nproperty double z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n0123456789abcdef01234567\x03" "abcd",
         PF_ERR_FORMAT, "cut.ply: byte 197: list of 3 items in record 0 runs past the end"},
        {"short.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
         "property double y\nproperty double z\nend_header\n0123456789abcdef",
         PF_ERR_FORMAT, "short.ply:3: 1 'vertex' announced"},
        {"header.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", PF_ERR_FORMAT,
         "header.ply:3: file ends inside the header"},
        {"loose.stl", "solid x\nvertex 0 0 0\nendsolid x\n", PF_ERR_FORMAT,
         "loose.stl:2: 'vertex' outside a facet"},
        {"open.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", PF_ERR_FORMAT,
         "open.stl:4: file ends inside a facet"},
        {"short.stl", "not an stl", PF_ERR_FORMAT, "short.stl: 10 bytes: neither ASCII STL"},
    };
    enum { N = sizeof CASES / sizeof CASES[0] };
    const char *names[N];
    for (size_t i = 0; i < N; ++i)
        names[i] = CASES[i].name;
    int64_t live = pf_alloc_live_bytes();
    scratch_dir d;
    scratch_open(&d);
    for (size_t i = 0; i < N; ++i) {
        const bad_surface *c = &CASES[i];
        if (c->bytes) {
            write_bytes(scratch_file(&d, c->name), c->bytes, strlen(c->bytes));
        } else { /* binary STL: 80-byte header, count 2e9, two triangles' worth of bytes */
            unsigned char b[184] = {0};
            const uint32_t n = 2000000000u;
            memcpy(b + 80, &n, 4);
            write_bytes(scratch_file(&d, c->name), b, sizeof b);
        }
        pf_error err = {0};
        pf_surface s;
        memset(&s, 0xab, sizeof s);
        pf_status st = pf_import_surface(scratch_file(&d, c->name), &s, &err);
        if (st != c->status)
            fail_msg("%s: status %d, expected %d (%s)", c->name, st, c->status, err.msg);
        expect_msg(&err, c->needle);
        assert_null(strchr(err.msg, '\n'));
        assert_null(s.x);
        assert_null(s.tri);
        assert_int_equal(s.n_verts, 0);
    }
    scratch_close(&d, names, N);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_formats_read_exact_doubles),
        cmocka_unit_test(test_obj_polygons),
        cmocka_unit_test(test_any_scale),
        cmocka_unit_test(test_bad_surfaces),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
