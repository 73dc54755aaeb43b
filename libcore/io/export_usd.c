/* A triangle surface animated over frames as one text USD stage (.usda) for Blender, Houdini and
 * other USD readers: a Mesh prim whose points and normals are time samples (one per frame, time
 * code = frame index), whose topology is sampled again only when it changes, and an optional
 * per-triangle primvar "stress". Frames arrive one at a time while a simulation streams, but a
 * USD attribute's samples sit together in the file, so each attribute's samples are kept as text
 * in memory and the file is written whole (temp file + rename) by pf_usd_writer_finish. */
#include <pf/io.h>

#include <math.h>
#include <stdarg.h>
#include <string.h>


struct pf_usd_writer {
    char *path;
    pf_buffer points, normals, counts, indices, stress; /* "time: [...],\n" samples as text */
    pf_buffer caps; /* the cap triangles' indices, sampled with the topology */
    bool any_caps;  /* some sample has caps: the GeomSubset "cap" is written */
    uint32_t *tri;  /* [3 n_tris] the last sampled topology */
    uint8_t *part;  /* [n_tris] its parts (PF_SURFACE_MODEL / PF_SURFACE_CAP) */
    int32_t n_tris;
    int64_t samples;
    double first_code, last_code, first_time, last_time;
    double *scratch; /* [3 n_verts] normals of one frame */
    size_t scratch_size;
};

static pf_status append_text(pf_buffer *b, pf_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static pf_status append_text(pf_buffer *b, pf_error *err, const char *fmt, ...)
{
    char line[128];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    PF_CHECK(n >= 0 && (size_t)n < sizeof line, err, PF_ERR_INVALID, "USD text line too long");
    return pf_buffer_append(b, line, (size_t)n, err);
}

/* "  CODE: [(x, y, z), ...],\n" with float precision (USD's point3f / normal3f). */
static pf_status append_vec3s(pf_buffer *b, double code, const double *v, int32_t n,
                              pf_error *err)
{
    PF_TRY(append_text(b, err, "            %.17g: [", code));
    for (int32_t i = 0; i < n; ++i)
        PF_TRY(append_text(b, err, "%s(%.9g, %.9g, %.9g)", i ? ", " : "", (double)(float)v[3 * i],
                           (double)(float)v[3 * i + 1], (double)(float)v[3 * i + 2]));
    return append_text(b, err, "],\n");
}

pf_status pf_usd_writer_create(pf_usd_writer **w, const char *path, pf_error *err)
{
    *w = pf_calloc(1, sizeof **w);
    PF_CHECK(*w, err, PF_ERR_NOMEM, "%s: out of memory", path);
    size_t n = strlen(path) + 1;
    (*w)->path = pf_alloc(n);
    if (!(*w)->path) {
        pf_usd_writer_destroy(w);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    }
    memcpy((*w)->path, path, n);
    return PF_OK;
}

static uint8_t part_of(const pf_surface *s, int32_t t)
{
    return s->tri_part ? s->tri_part[t] : PF_SURFACE_MODEL;
}

static bool same_topology(const pf_usd_writer *w, const pf_surface *s)
{
    if (!w->tri || w->n_tris != s->n_tris ||
        memcmp(w->tri, s->tri, 3 * (size_t)s->n_tris * sizeof *s->tri) != 0)
        return false;
    for (int32_t t = 0; t < s->n_tris; ++t)
        if (w->part[t] != part_of(s, t))
            return false;
    return true;
}

/* "CODE: [i, j, ...],\n": the cap triangles of s. */
static pf_status sample_caps(pf_usd_writer *w, double code, const pf_surface *s, pf_error *err)
{
    PF_TRY(append_text(&w->caps, err, "                %.17g: [", code));
    int32_t k = 0;
    for (int32_t t = 0; t < s->n_tris; ++t)
        if (part_of(s, t) == PF_SURFACE_CAP)
            PF_TRY(append_text(&w->caps, err, "%s%d", k++ ? ", " : "", (int)t));
    w->any_caps |= k > 0;
    return append_text(&w->caps, err, "],\n");
}

static pf_status sample_topology(pf_usd_writer *w, double code, const pf_surface *s, pf_error *err)
{
    if (same_topology(w, s))
        return PF_OK;
    uint32_t *tri = pf_realloc_array(w->tri, 3 * (size_t)s->n_tris + 1, sizeof *tri);
    if (tri)
        w->tri = tri;
    uint8_t *part = pf_realloc_array(w->part, (size_t)s->n_tris + 1, 1);
    if (part)
        w->part = part;
    PF_CHECK(tri && part, err, PF_ERR_NOMEM, "%s: out of memory", w->path);
    memcpy(w->tri, s->tri, 3 * (size_t)s->n_tris * sizeof *tri);
    for (int32_t t = 0; t < s->n_tris; ++t)
        w->part[t] = part_of(s, t);
    w->n_tris = s->n_tris;
    PF_TRY(sample_caps(w, code, s, err));
    PF_TRY(append_text(&w->counts, err, "            %.17g: [", code));
    PF_TRY(append_text(&w->indices, err, "            %.17g: [", code));
    for (int32_t t = 0; t < s->n_tris; ++t) {
        PF_TRY(append_text(&w->counts, err, t ? ", 3" : "3"));
        PF_TRY(append_text(&w->indices, err, "%s%u, %u, %u", t ? ", " : "",
                           (unsigned)s->tri[3 * t], (unsigned)s->tri[3 * t + 1],
                           (unsigned)s->tri[3 * t + 2]));
    }
    PF_TRY(append_text(&w->counts, err, "],\n"));
    return append_text(&w->indices, err, "],\n");
}

pf_status pf_usd_writer_add(pf_usd_writer *w, double code, double time, const pf_surface *s,
                            const double *x, const double *stress, pf_error *err)
{
    if (!x)
        x = s->x;
    PF_CHECK(isfinite(code) && isfinite(time) && (w->samples == 0 || code > w->last_code), err,
             PF_ERR_INVALID, "%s: time code %g after %g (samples must increase)", w->path, code,
             w->last_code);
    for (int64_t i = 0; i < 3 * (int64_t)s->n_tris; ++i)
        PF_CHECK(s->tri[i] < (uint32_t)s->n_verts, err, PF_ERR_INVALID,
                 "%s: triangle %lld has vertex %u of %d", w->path, (long long)(i / 3),
                 (unsigned)s->tri[i], (int)s->n_verts);
    for (int64_t i = 0; i < 3 * (int64_t)s->n_verts; ++i)
        PF_CHECK(isfinite(x[i]) && fabs(x[i]) <= 3.4e38, err, PF_ERR_INVALID,
                 "%s: vertex %lld is not a finite float", w->path, (long long)(i / 3));
    for (int64_t t = 0; stress && t < s->n_tris; ++t)
        PF_CHECK(isfinite(stress[t]), err, PF_ERR_INVALID, "%s: triangle %lld's stress is not "
                 "finite", w->path, (long long)t);
    size_t need = 3 * (size_t)s->n_verts + 1;
    if (need > w->scratch_size) {
        double *n = pf_realloc_array(w->scratch, need, sizeof *n);
        PF_CHECK(n, err, PF_ERR_NOMEM, "%s: out of memory", w->path);
        w->scratch = n;
        w->scratch_size = need;
    }
    PF_TRY(pf_surface_part_normals(s, x, w->scratch, err));
    PF_TRY(sample_topology(w, code, s, err));
    PF_TRY(append_vec3s(&w->points, code, x, s->n_verts, err));
    PF_TRY(append_vec3s(&w->normals, code, w->scratch, s->n_verts, err));
    if (stress) {
        PF_TRY(append_text(&w->stress, err, "            %.17g: [", code));
        for (int32_t t = 0; t < s->n_tris; ++t)
            PF_TRY(append_text(&w->stress, err, "%s%.9g", t ? ", " : "", (double)(float)stress[t]));
        PF_TRY(append_text(&w->stress, err, "],\n"));
    }
    if (w->samples == 0) {
        w->first_code = code;
        w->first_time = time;
    }
    w->last_code = code;
    w->last_time = time;
    w->samples++;
    return PF_OK;
}

static void write_samples(FILE *f, const char *decl, const char *meta, const pf_buffer *b)
{
    if (meta)
        fprintf(f, "        %s (\n            %s\n        )\n", decl, meta);
    fprintf(f, "        %s.timeSamples = {\n", decl);
    fwrite(b->data, 1, b->size, f);
    fputs("        }\n", f);
}

pf_status pf_usd_writer_finish(pf_usd_writer *w, pf_error *err)
{
    PF_CHECK(w->samples > 0, err, PF_ERR_INVALID, "%s: no frame to write", w->path);
    /* time codes are frame indices; their rate from the first and last frame's times */
    double per_second = 24;
    if (w->samples > 1 && w->last_time > w->first_time)
        per_second = (w->last_code - w->first_code) / (w->last_time - w->first_time);
    pf_atomic_file out;
    PF_TRY(pf_atomic_file_open(&out, w->path, err));
    FILE *f = out.f;
    fprintf(f,
            "#usda 1.0\n"
            "(\n"
            "    defaultPrim = \"pf\"\n"
            "    doc = \"pf-export: the simulated surface, one time sample per frame\"\n"
            "    startTimeCode = %.17g\n"
            "    endTimeCode = %.17g\n"
            "    timeCodesPerSecond = %.17g\n"
            "    framesPerSecond = %.17g\n"
            "    upAxis = \"Z\"\n"
            ")\n\n"
            "def Xform \"pf\" (\n"
            "    kind = \"component\"\n"
            ")\n"
            "{\n"
            "    def Mesh \"surface\"\n"
            "    {\n"
            "        uniform token orientation = \"rightHanded\"\n"
            "        uniform token subdivisionScheme = \"none\"\n",
            w->first_code, w->last_code, per_second, per_second);
    write_samples(f, "int[] faceVertexCounts", NULL, &w->counts);
    write_samples(f, "int[] faceVertexIndices", NULL, &w->indices);
    write_samples(f, "point3f[] points", NULL, &w->points);
    write_samples(f, "normal3f[] normals", "interpolation = \"vertex\"", &w->normals);
    if (w->stress.size)
        write_samples(f, "float[] primvars:stress", "interpolation = \"uniform\"", &w->stress);
    if (w->any_caps) { /* the caps of cuts: a subset a material can be bound to */
        fputs("\n        def GeomSubset \"cap\"\n"
              "        {\n"
              "            uniform token elementType = \"face\"\n"
              "            uniform token familyName = \"materialBind\"\n"
              "            int[] indices.timeSamples = {\n",
              f);
        fwrite(w->caps.data, 1, w->caps.size, f);
        fputs("            }\n        }\n", f);
    }
    fputs("    }\n}\n", f);
    return pf_atomic_file_commit(&out, "USD file", err);
}

void pf_usd_writer_destroy(pf_usd_writer **w)
{
    if (!*w)
        return;
    pf_free((*w)->path);
    pf_buffer_release(&(*w)->points);
    pf_buffer_release(&(*w)->normals);
    pf_buffer_release(&(*w)->counts);
    pf_buffer_release(&(*w)->indices);
    pf_buffer_release(&(*w)->stress);
    pf_buffer_release(&(*w)->caps);
    pf_free((*w)->tri);
    pf_free((*w)->part);
    pf_free((*w)->scratch);
    pf_free(*w);
    *w = NULL;
}
