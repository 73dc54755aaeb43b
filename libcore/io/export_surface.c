/* Blender / Houdini output: a triangle surface as Wavefront OBJ (text, exact doubles) or binary
 * little-endian PLY (compact float32), one file per frame of a sequence, with area-weighted vertex
 * normals (pf_surface_part_normals) so that viewers shade it smooth without recomputing them. The
 * caps of a cut (tri_part) are group and material "cap" in OBJ, face property "part" in PLY. */
#include <pf/io.h>

#include <math.h>
#include <string.h>


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

static pf_status vertex_normals(const char *path, const pf_surface *s, const double *x,
                                double **normals, pf_error *err)
{
    *normals = pf_alloc_array(3 * (size_t)s->n_verts + 1, sizeof **normals);
    PF_CHECK(*normals, err, PF_ERR_NOMEM, "%s: out of memory for %d normals", path,
             (int)s->n_verts);
    pf_status st = pf_surface_part_normals(s, x, *normals, err);
    if (st != PF_OK)
        PF_FREE(*normals);
    return st;
}

/* The faces of an OBJ file. With caps, each run of triangles of one part is opened by "g model"
 * / "g cap" with the material of the same name, and a cap triangle takes its own flat normal,
 * vn n_verts + 1 + (its rank among the caps). */
static void write_obj_faces(FILE *f, const pf_surface *s, const double *x)
{
    static const char *const PART[2] = {"model", "cap"};
    bool caps = pf_surface_count_caps(s) > 0;
    if (caps) /* the caps' flat normals after the vertices' */
        for (int64_t t = 0; t < s->n_tris; ++t)
            if (s->tri_part[t] == PF_SURFACE_CAP) {
                const uint32_t *v = s->tri + 3 * t;
                pf_vec3 a = pf_v3_load(x + 3 * (size_t)v[0]);
                pf_vec3 n =
                    pf_v3_normalize(pf_v3_cross(pf_v3_sub(pf_v3_load(x + 3 * (size_t)v[1]), a),
                                                pf_v3_sub(pf_v3_load(x + 3 * (size_t)v[2]), a)));
                fprintf(f, "vn %.9g %.9g %.9g\n", n.x, n.y, n.z);
            }
    int part = -1;
    unsigned long cap_normal = (unsigned long)s->n_verts;
    for (int64_t t = 0; t < s->n_tris; ++t) { /* OBJ counts from 1; normal k is vertex k's */
        unsigned long a = (unsigned long)s->tri[3 * t] + 1,
                      b = (unsigned long)s->tri[3 * t + 1] + 1,
                      c = (unsigned long)s->tri[3 * t + 2] + 1;
        int p = caps && s->tri_part[t] == PF_SURFACE_CAP;
        if (caps && p != part) {
            fprintf(f, "g %s\nusemtl %s\n", PART[p], PART[p]);
            part = p;
        }
        if (p) {
            unsigned long n = ++cap_normal;
            fprintf(f, "f %lu//%lu %lu//%lu %lu//%lu\n", a, n, b, n, c, n);
        } else {
            fprintf(f, "f %lu//%lu %lu//%lu %lu//%lu\n", a, a, b, b, c, c);
        }
    }
}

pf_status pf_export_obj(const char *path, const pf_surface *s, const double *x, pf_error *err)
{
    if (!x)
        x = s->x;
    PF_TRY(check_surface(path, s, x, false, err));
    double *n;
    PF_TRY(vertex_normals(path, s, x, &n, err));
    pf_atomic_file out;
    pf_status st = pf_atomic_file_open(&out, path, err);
    if (st != PF_OK) {
        pf_free(n);
        return st;
    }
    FILE *f = out.f;
    int32_t caps = pf_surface_count_caps(s);
    if (caps)
        fprintf(f, "# pf surface: %d vertices, %d triangles, %d of them caps (g cap)\n",
                (int)s->n_verts, (int)s->n_tris, (int)caps);
    else
        fprintf(f, "# pf surface: %d vertices, %d triangles\n", (int)s->n_verts, (int)s->n_tris);
    for (int64_t i = 0; i < s->n_verts; ++i)
        fprintf(f, "v %.17g %.17g %.17g\n", x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    for (int64_t i = 0; i < s->n_verts; ++i) /* unit vectors: 9 digits are float precision */
        fprintf(f, "vn %.9g %.9g %.9g\n", n[3 * i], n[3 * i + 1], n[3 * i + 2]);
    write_obj_faces(f, s, x);
    pf_free(n);
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
    double *n;
    PF_TRY(vertex_normals(path, s, x, &n, err));
    pf_atomic_file out;
    pf_status st = pf_atomic_file_open(&out, path, err);
    if (st != PF_OK) {
        pf_free(n);
        return st;
    }
    FILE *f = out.f;
    bool caps = pf_surface_count_caps(s) > 0;
    fprintf(f,
            "ply\n"
            "format binary_little_endian 1.0\n"
            "comment pf surface\n"
            "%s"
            "element vertex %d\n"
            "property float x\n"
            "property float y\n"
            "property float z\n"
            "property float nx\n"
            "property float ny\n"
            "property float nz\n"
            "element face %d\n"
            "property list uchar uint vertex_indices\n"
            "%s"
            "end_header\n",
            caps ? "comment part: 0 the model's surface, 1 a cap of a cut\n" : "", (int)s->n_verts,
            (int)s->n_tris, caps ? "property uchar part\n" : "");
    unsigned char rec[24];
    for (int64_t i = 0; i < s->n_verts; ++i) {
        for (int c = 0; c < 3; ++c) {
            put_f32(rec + 4 * c, (float)x[3 * i + c]);
            put_f32(rec + 12 + 4 * c, (float)n[3 * i + c]);
        }
        fwrite(rec, 1, 24, f);
    }
    pf_free(n);
    rec[0] = 3;
    for (int64_t t = 0; t < s->n_tris; ++t) {
        for (int c = 0; c < 3; ++c)
            put_u32(rec + 1 + 4 * c, s->tri[3 * t + c]);
        rec[13] = caps ? s->tri_part[t] : 0;
        fwrite(rec, 1, caps ? 14 : 13, f);
    }
    return pf_atomic_file_commit(&out, "PLY file", err);
}
