/* Shared by the export tests (test_export.c, test_export_studio.c): temporary directories, files
 * read back whole, a reader of VTU data arrays independent of the writer (ASCII by strtod, binary
 * appended arrays decompressed with zlib), and small test meshes. Include after cmocka.h. */
#ifndef PF_TESTS_EXPORT_FILES_H
#define PF_TESTS_EXPORT_FILES_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <pf/io.h>
#include <zlib.h>

static inline void teardown_check(void)
{
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- helpers --------------------------------------------------------------------------------- */

typedef struct tmpdir {
    char dir[64];
    char path[160];
} tmpdir;

static inline void tmp_open(tmpdir *t)
{
    strcpy(t->dir, "/tmp/pf_test_export_XXXXXX");
    assert_non_null(mkdtemp(t->dir));
}

static inline const char *tmp_file(tmpdir *t, const char *name)
{
    snprintf(t->path, sizeof t->path, "%s/%s", t->dir, name);
    return t->path;
}

static inline void tmp_close(tmpdir *t, const char *const *names)
{
    for (; *names; ++names)
        remove(tmp_file(t, *names));
    assert_int_equal(rmdir(t->dir), 0); /* fails if anything else (a .part) was left */
}

static inline bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* The whole file, NUL-terminated; *size its length. Plain malloc: not pf memory. */
static inline char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = malloc((size_t)n + 1);
    assert_non_null(text);
    assert_int_equal(fread(text, 1, (size_t)n, f), (size_t)n);
    text[n] = '\0';
    fclose(f);
    if (size)
        *size = (size_t)n;
    return text;
}

/* An appended array's values as doubles: at offset bytes into <AppendedData> (after its '_'), the
 * UInt64 header [blocks, block size, last block size or 0, compressed sizes] and the zlib blocks
 * (VTK's vtkZLibDataCompressor layout), decoded here with zlib's uncompress. */
static inline double *appended_array(const char *xml, const char *tag, size_t *n)
{
    const char *type = strstr(tag, "type=\"") + 6;
    size_t width = strncmp(type, "UInt8", 5) == 0 ? 1 : strncmp(type, "Int32", 5) == 0 ? 4 : 8;
    const char *off = strstr(tag, "offset=\"");
    assert_non_null(off);
    const char *data = strstr(xml, "<AppendedData encoding=\"raw\">");
    assert_non_null(data);
    data = strchr(data, '_') + 1 + strtoull(off + 8, NULL, 10);
    uint64_t head[3];
    memcpy(head, data, sizeof head);
    uint64_t total = head[0] == 0 ? 0 : (head[0] - 1) * head[1] + (head[2] ? head[2] : head[1]);
    unsigned char *raw = malloc(total + 1);
    const unsigned char *block = (const unsigned char *)data + (3 + head[0]) * 8;
    for (uint64_t b = 0; b < head[0]; ++b) {
        uint64_t size;
        memcpy(&size, data + (3 + b) * 8, 8);
        uLongf len = (uLongf)(total - b * head[1] < head[1] ? total - b * head[1] : head[1]);
        assert_int_equal(uncompress(raw + b * head[1], &len, block, (uLong)size), Z_OK);
        block += size;
    }
    assert_int_equal(total % width, 0);
    *n = total / width;
    double *v = malloc(sizeof *v * (*n + 1));
    for (size_t i = 0; i < *n; ++i) {
        if (width == 1) {
            v[i] = raw[i];
        } else if (width == 4) {
            int32_t x;
            memcpy(&x, raw + 4 * i, 4);
            v[i] = x;
        } else if (strncmp(type, "Float64", 7) == 0) {
            memcpy(&v[i], raw + 8 * i, 8);
        } else {
            int64_t x;
            memcpy(&x, raw + 8 * i, 8);
            v[i] = (double)x;
        }
    }
    free(raw);
    return v;
}

/* The numbers of the DataArray named name, or NULL when there is none; *n their count. ASCII
 * arrays are parsed with strtod, appended ones decompressed (appended_array). */
static inline double *data_array(const char *xml, const char *name, size_t *n)
{
    char key[64];
    snprintf(key, sizeof key, "Name=\"%s\"", name);
    const char *p = strstr(xml, key);
    *n = 0;
    if (!p)
        return NULL;
    const char *tag = p;
    while (tag > xml && *tag != '<')
        --tag;
    p = strchr(p, '>') + 1;
    if (strstr(tag, "format=\"appended\"") && strstr(tag, "format=\"appended\"") < p)
        return appended_array(xml, tag, n);
    const char *end = strstr(p, "</DataArray>");
    assert_non_null(end);
    double *v = malloc(sizeof *v * ((size_t)(end - p) / 2 + 1));
    for (;;) {
        char *next;
        double x = strtod(p, &next);
        if (next == p || next > end)
            break;
        v[(*n)++] = x;
        p = next;
    }
    return v;
}

static inline long attribute(const char *xml, const char *name)
{
    char key[64];
    snprintf(key, sizeof key, "%s=\"", name);
    const char *p = strstr(xml, key);
    assert_non_null(p);
    return strtol(p + strlen(key), NULL, 10);
}

static inline pf_vec3 node(const double *x, double id) { return pf_v3_load(x + 3 * (size_t)id); }

/* det[b - a, c - a, d - a]: six times the signed volume of tet (a, b, c, d). */
static inline double orient(pf_vec3 a, pf_vec3 b, pf_vec3 c, pf_vec3 d)
{
    return pf_v3_dot(pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a)), pf_v3_sub(d, a));
}

/* ---- test meshes ----------------------------------------------------------------------------- */

static inline void make_box(pf_mesh *m, int32_t nx, int32_t ny, int32_t nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), nx, ny, nz, &err), PF_OK);
    m->id = 1;
}

/* A triangular prism (a general polyhedron: 2 triangles, 3 quads) with a tet on its top face,
 * which the tet uses reversed. Faces counter-clockwise seen from outside the prism / the tet. */
static inline void make_prism_tet(pf_mesh *m)
{
    static const double x[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 0.2, 0.2, 2};
    static const uint32_t faces[][4] = {{0, 2, 1}, {3, 4, 5},    {0, 1, 4, 3}, {0, 3, 5, 2},
                                        {1, 2, 5, 4}, {3, 4, 6}, {4, 5, 6},    {5, 3, 6}};
    static const int sizes[] = {3, 3, 4, 4, 4, 3, 3, 3};
    static const uint32_t elem_faces[] = {0, 1, 2, 3, 4, 1 | PF_FACE_REVERSED, 5, 6, 7};
    pf_error err = {0};
    assert_int_equal(pf_mesh_alloc(m, 7, 8, 27, 2, 9, &err), PF_OK);
    memcpy(m->x, x, sizeof x);
    int64_t k = 0;
    for (int f = 0; f < 8; ++f) {
        for (int j = 0; j < sizes[f]; ++j)
            m->face_nodes[k++] = faces[f][j];
        m->face_offsets[f + 1] = k;
    }
    memcpy(m->elem_faces, elem_faces, sizeof elem_faces);
    m->elem_offsets[1] = 5;
    m->elem_offsets[2] = 9;
    m->id = 7;
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_OK);
}

/* A displacement whose decimal expansions are long: round-trips only with 17 digits. */
static inline void displacement(const pf_mesh *m, double *u)
{
    for (int32_t i = 0; i < 3 * m->n_nodes; ++i)
        u[i] = sin(1.0 + i) / 3.0;
}

#endif
