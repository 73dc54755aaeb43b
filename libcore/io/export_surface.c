/* Blender / Houdini output: a triangle surface as Wavefront OBJ (text, exact doubles) or binary
 * little-endian PLY (compact float32), one file per frame of a sequence. */
#include <pf/io.h>

#include <math.h>
#include <string.h>

#include "atomic_file.h"

/* Indices in range and finite positions; for PLY also representable as float32 (a double beyond
 * FLT_MAX would turn into an infinity that no viewer can place). */
static pf_status check_surface(const char *path, const pf_surface *s, const double *x,
                               bool float32, pf_error *err)
{
    PF_CHECK(s->n_verts >= 0 && s->n_tris >= 0 && (x || s->n_verts == 0) &&
                 (s->tri || s->n_tris == 0),
             err, PF_ERR_INVALID, "%s: a surface of %d vertices and %d triangles without arrays",
             path, (int)s->n_verts, (int)s->n_tris);
    for (int64_t i = 0; i < 3 * (int64_t)s->n_verts; ++i)
        PF_CHECK(isfinite(x[i]) && (!float32 || isfinite((float)x[i])), err, PF_ERR_INVALID,
                 "%s: vertex %lld has a position that is not finite%s", path, (long long)(i / 3),
                 float32 ? " in float32" : "");
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        PF_CHECK(s->tri[i] < (uint32_t)s->n_verts, err, PF_ERR_INVALID,
                 "%s: triangle %lld uses vertex %u of %d", path, (long long)(i / 3),
                 (unsigned)s->tri[i], (int)s->n_verts);
    return PF_OK;
}

pf_status pf_export_obj(const char *path, const pf_surface *s, const double *x, pf_error *err)
{
    if (!x)
        x = s->x;
    PF_TRY(check_surface(path, s, x, false, err));
    pf_atomic_file out;
    PF_TRY(pf_atomic_file_open(&out, path, err));
    FILE *f = out.f;
    fprintf(f, "# pf surface: %d vertices, %d triangles\n", (int)s->n_verts, (int)s->n_tris);
    for (int64_t i = 0; i < s->n_verts; ++i)
        fprintf(f, "v %.17g %.17g %.17g\n", x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    for (int64_t t = 0; t < s->n_tris; ++t) /* OBJ counts vertices from 1 */
        fprintf(f, "f %lu %lu %lu\n", (unsigned long)s->tri[3 * t] + 1,
                (unsigned long)s->tri[3 * t + 1] + 1, (unsigned long)s->tri[3 * t + 2] + 1);
    return pf_atomic_file_commit(&out, "OBJ file", err);
}

/* Little-endian bytes whatever the host's order. */
static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static void put_f32(unsigned char *p, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u32(p, bits);
}

pf_status pf_export_ply(const char *path, const pf_surface *s, const double *x, pf_error *err)
{
    if (!x)
        x = s->x;
    PF_TRY(check_surface(path, s, x, true, err));
    pf_atomic_file out;
    PF_TRY(pf_atomic_file_open(&out, path, err));
    FILE *f = out.f;
    fprintf(f,
            "ply\n"
            "format binary_little_endian 1.0\n"
            "comment pf surface\n"
            "element vertex %d\n"
            "property float x\n"
            "property float y\n"
            "property float z\n"
            "element face %d\n"
            "property list uchar uint vertex_indices\n"
            "end_header\n",
            (int)s->n_verts, (int)s->n_tris);
    unsigned char rec[13];
    for (int64_t i = 0; i < s->n_verts; ++i) {
        for (int c = 0; c < 3; ++c)
            put_f32(rec + 4 * c, (float)x[3 * i + c]);
        fwrite(rec, 1, 12, f);
    }
    rec[0] = 3;
    for (int64_t t = 0; t < s->n_tris; ++t) {
        for (int c = 0; c < 3; ++c)
            put_u32(rec + 1 + 4 * c, s->tri[3 * t + c]);
        fwrite(rec, 1, 13, f);
    }
    return pf_atomic_file_commit(&out, "PLY file", err);
}
