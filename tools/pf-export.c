/* pf-export: a pf stream -> ParaView (.vtu series + .pvd) or Blender/Houdini (OBJ/PLY sequences). */
#define _POSIX_C_SOURCE 200809L /* isatty, fileno */
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <unistd.h>

#include <pf/fem.h>
#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-export (--vtu DIR | --obj DIR | --ply DIR | --usd FILE) [--frames A:B] [--quiet]\n"
    "                 [FILE | -]\n"
    "                 [--ascii] [--tets]\n"
    "\n"
    "Exports the frames (FRAM chunks) of a pf stream (default: stdin) as they arrive.\n"
    "  --vtu DIR     DIR/mesh_NNNNN.vtu per frame, NNNNN being the frame's index: the frame's\n"
    "                MESH (a new MESH mid-stream changes the cells from its first frame on) at rest with point data 'displacement' and cell data 'kind' (0 tet, 1 hex,\n"
    "                2 polyhedron), 'volume' and, when a STRS chunk for the frame follows it,\n"
    "                'stress'; and DIR/mesh.pvd listing the files with their times (open it in\n"
    "                ParaView, apply Warp By Vector to see the motion); binary, zlib-compressed\n"
    "  --ascii       with --vtu: ASCII arrays instead (17 digits, 5 to 10 times larger)\n"
    "  --tets        with --vtu: each element as its exact tetrahedral decomposition, so that\n"
    "                ParaView's volumes and integrals are right for non-convex cells\n"
    "  --obj DIR     DIR/frame_NNNNN.obj per frame: the displaced surface (doubles, exact)\n"
    "  --ply DIR     DIR/frame_NNNNN.ply: the same as binary PLY (float32, compact)\n"
    "  --usd FILE    one text USD stage (.usda) of the same surface: points and normals as time\n"
    "                samples (time code = frame index), topology again where it changes, and\n"
    "                on the mesh boundary the von Mises stress per triangle (primvar 'stress')\n"
    "                The surface is the SURF chunk moved by its WGHT embedding when the stream\n"
    "                has both, else the boundary of the MESH (its referenced nodes only) moved by\n"
    "                the frame's displacements. The caps a cut adds to the SURF are OBJ group\n"
    "                and material 'cap', PLY face property 'part' (1), USD GeomSubset 'cap'.\n"
    "  --frames A:B  only frames with index A..B inclusive ('A:' from A on, ':B' up to B, 'A'\n"
    "                just A)\n"
    "  --quiet       no progress and no summary on stderr\n"
    "  --help, --version\n"
    "\n"
    "DIR is created if missing. A stream without frames gives one file of the rest state, index\n"
    "00000. Each file is written to a temporary name and renamed. A damaged or truncated stream:\n"
    "the frames before the damage are written (and listed in mesh.pvd), then the error; exit 1.\n"
    "Exit 2 on bad usage.\n";

enum { OPT_VTU = 1, OPT_OBJ, OPT_PLY, OPT_USD, OPT_FRAMES, OPT_QUIET, OPT_ASCII, OPT_TETS };

typedef enum format { FORMAT_NONE, FORMAT_VTU, FORMAT_OBJ, FORMAT_PLY, FORMAT_USD } format;

typedef struct options {
    format format;
    const char *dir, *input;
    int64_t first, last; /* frame range, inclusive */
    bool quiet;
    pf_vtu_params vtu;
} options;

/* ---- options --------------------------------------------------------------------------------- */

static void set_format(const pf_cli *cli, options *o, format f, const char *dir)
{
    if (o->format != FORMAT_NONE)
        pf_cli_usage_error(cli, "one of --vtu, --obj, --ply and --usd only");
    if (!dir[0])
        pf_cli_usage_error(cli, "the output directory is empty");
    o->format = f;
    o->dir = dir;
}

static void parse_options(pf_cli *cli, options *o)
{
    static const pf_cli_option OPTIONS[] = {
        {"vtu", true, OPT_VTU},       {"obj", true, OPT_OBJ},      {"ply", true, OPT_PLY},
        {"frames", true, OPT_FRAMES}, {"quiet", false, OPT_QUIET}, {"ascii", false, OPT_ASCII},
        {"tets", false, OPT_TETS},    {"usd", true, OPT_USD},      {NULL, false, 0}};
    *o = (options){.first = 0, .last = (int64_t)UINT32_MAX};
    const char *value;
    for (int id; (id = pf_cli_next(cli, OPTIONS, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_VTU: set_format(cli, o, FORMAT_VTU, value); break;
        case OPT_OBJ: set_format(cli, o, FORMAT_OBJ, value); break;
        case OPT_PLY: set_format(cli, o, FORMAT_PLY, value); break;
        case OPT_USD: set_format(cli, o, FORMAT_USD, value); break;
        case OPT_FRAMES: pf_cli_parse_frames(cli, value, &o->first, &o->last); break;
        case OPT_QUIET: o->quiet = true; break;
        case OPT_ASCII: o->vtu.ascii = true; break;
        case OPT_TETS: o->vtu.tets = true; break;
        default:
            if (o->input)
                pf_cli_usage_error(cli, "one input only (got '%s' and '%s')", o->input, value);
            o->input = value;
        }
    }
    if (o->format == FORMAT_NONE)
        pf_cli_usage_error(cli, "say what to write: --vtu DIR, --obj DIR, --ply DIR or --usd FILE");
    if ((o->vtu.ascii || o->vtu.tets) && o->format != FORMAT_VTU)
        pf_cli_usage_error(cli, "--ascii and --tets go with --vtu");
    if ((!o->input || strcmp(o->input, "-") == 0) && isatty(STDIN_FILENO))
        pf_cli_usage_error(cli, "refusing to read a binary pf stream from a terminal; give a FILE "
                                "or pipe a stream in");
}

/* ---- the exporter's state -------------------------------------------------------------------- */

typedef struct exporter {
    const options *o;
    const pf_cli *cli;
    const char *name;     /* the input, for messages */
    pf_stream_state st;   /* the latest MESH, SURF, WGHT and STRS */
    /* OBJ/PLY: the embedded surface moved by its weights, or the mesh boundary as a surface */
    double *surface_x;    /* [3 st.surface.n_verts] displaced */
    uint64_t surface_serial; /* the SURF surface_x was sized for */
    pf_surface boundary;
    int32_t *boundary_node;  /* [boundary.n_verts] the mesh node of each boundary vertex */
    double *boundary_x;      /* [3 boundary.n_verts] displaced */
    int32_t *boundary_elem;  /* [boundary.n_tris] the element each boundary triangle bounds */
    double *tri_stress;      /* --usd: [boundary.n_tris] the frame's (von Mises) stress */
    uint64_t boundary_serial; /* the MESH the boundary is of (0: none) */
    /* VTU: a frame waiting for the STRS chunk that may follow it */
    pf_frame_data pending;
    bool have_pending;
    /* VTU: the series so far, for mesh.pvd */
    uint32_t *series_index;
    double *series_time;
    int64_t n_series, cap_series;
    char *path; /* scratch for file names */
    pf_usd_writer *usd; /* --usd: the stage, written at the end */
    double time;        /* the time of the frame being written */
    int64_t written;
    bool progress;
} exporter;

static void exporter_release(exporter *x)
{
    pf_stream_state_release(&x->st);
    pf_usd_writer_destroy(&x->usd);
    pf_surface_release(&x->boundary);
    pf_free(x->surface_x);
    pf_free(x->boundary_node);
    pf_free(x->boundary_x);
    pf_free(x->boundary_elem);
    pf_free(x->tri_stress);
    pf_frame_data_release(&x->pending);
    pf_free(x->series_index);
    pf_free(x->series_time);
    pf_free(x->path);
}

/* Errors of work on a decoded chunk (not the decoders, whose messages name the input already)
 * get the input's name in front. */
static pf_status named(const exporter *x, pf_status s, pf_error *err)
{
    if (s < 0)
        pf_error_prefix(err, "%s", x->name);
    return s;
}

static bool in_range(const options *o, uint32_t index)
{
    return (int64_t)index >= o->first && (int64_t)index <= o->last;
}

static void report(exporter *x, uint32_t index)
{
    ++x->written;
    if (x->progress)
        fprintf(stderr, "\r%s: frame %u, %lld files written", x->cli->tool, (unsigned)index,
                (long long)x->written);
}

/* ---- VTU ------------------------------------------------------------------------------------- */

static pf_status add_to_series(exporter *x, uint32_t index, double time, pf_error *err)
{
    /* a repeated index rewrote its file: one entry, the latest time */
    for (int64_t i = x->n_series - 1; i >= 0; --i)
        if (x->series_index[i] == index) {
            x->series_time[i] = time;
            return PF_OK;
        }
    if (x->n_series == x->cap_series) {
        int64_t cap = x->cap_series ? 2 * x->cap_series : 64;
        uint32_t *idx = pf_realloc_array(x->series_index, (size_t)cap, sizeof *idx);
        if (idx)
            x->series_index = idx;
        double *t = pf_realloc_array(x->series_time, (size_t)cap, sizeof *t);
        if (t)
            x->series_time = t;
        PF_CHECK(idx && t, err, PF_ERR_NOMEM, "out of memory for the list of frames");
        x->cap_series = cap;
    }
    x->series_index[x->n_series] = index;
    x->series_time[x->n_series++] = time;
    return PF_OK;
}

static pf_status write_vtu(exporter *x, uint32_t index, double time, const double *u,
                           const pf_stress_data *stress, pf_error *err)
{
    sprintf(x->path, "%s/mesh_%05u.vtu", x->o->dir, (unsigned)index);
    PF_TRY(pf_export_vtu_with(x->path, &x->st.mesh, u, stress, &x->o->vtu, err));
    PF_TRY(add_to_series(x, index, time, err));
    report(x, index);
    return PF_OK;
}

static pf_status write_surface(exporter *x, uint32_t index, const double *u,
                               const pf_stress_data *stress, pf_error *err);

static pf_status flush_pending(exporter *x, pf_error *err)
{
    if (!x->have_pending)
        return PF_OK;
    x->have_pending = false;
    x->time = x->pending.time;
    bool has_stress = x->st.have_stress && x->st.stress.frame == x->pending.index;
    const pf_stress_data *stress = has_stress ? &x->st.stress : NULL;
    pf_status s = x->usd ? write_surface(x, x->pending.index, x->pending.u, stress, err)
                         : write_vtu(x, x->pending.index, x->pending.time, x->pending.u, stress,
                                     err);
    pf_frame_data_release(&x->pending);
    return s;
}

static pf_status write_pvd(exporter *x, pf_error *err)
{
    if (x->n_series == 0)
        return PF_OK;
    char **files = pf_alloc_array((size_t)x->n_series, sizeof *files);
    char *names = pf_alloc_array((size_t)x->n_series, 32);
    pf_status s = PF_OK;
    if (!files || !names) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for mesh.pvd");
    } else {
        for (int64_t i = 0; i < x->n_series; ++i) {
            files[i] = names + 32 * i;
            sprintf(files[i], "mesh_%05u.vtu", (unsigned)x->series_index[i]);
        }
        sprintf(x->path, "%s/mesh.pvd", x->o->dir);
        s = pf_export_pvd(x->path, (const char *const *)files, x->series_time,
                          (int32_t)x->n_series, err);
    }
    pf_free(files);
    pf_free(names);
    return s;
}

/* ---- OBJ / PLY ------------------------------------------------------------------------------- */

/* The mesh boundary as a triangle surface over the nodes it references (no loose vertices in
 * Blender), computed once per MESH. */
static pf_status ensure_boundary(exporter *x, pf_error *err)
{
    const pf_mesh *m = &x->st.mesh;
    if (x->boundary_serial == x->st.mesh_serial)
        return PF_OK;
    pf_surface_release(&x->boundary);
    PF_FREE(x->boundary_node);
    PF_FREE(x->boundary_x);
    PF_FREE(x->boundary_elem);
    PF_FREE(x->tri_stress);
    pf_boundary b = {0};
    PF_TRY(named(x, pf_boundary_extract(m, &b, err), err));
    int32_t n_tris = (int32_t)b.tri_offsets[b.n_faces];
    int32_t *vert = pf_alloc_array((size_t)m->n_nodes + 1, sizeof *vert);
    pf_status s = PF_OK;
    if (!vert) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        goto done;
    }
    int32_t n_verts = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        vert[i] = -1;
    for (int64_t k = 0; k < 3 * (int64_t)n_tris; ++k)
        if (vert[b.tri[k]] < 0)
            vert[b.tri[k]] = n_verts++;
    s = pf_surface_alloc(&x->boundary, n_verts, n_tris, err);
    if (s != PF_OK)
        goto done;
    x->boundary.id = m->id;
    x->boundary_node = pf_alloc_array((size_t)n_verts + 1, sizeof *x->boundary_node);
    x->boundary_x = pf_alloc_array(3 * (size_t)n_verts + 1, sizeof *x->boundary_x);
    x->boundary_elem = pf_alloc_array((size_t)n_tris + 1, sizeof *x->boundary_elem);
    x->tri_stress = pf_alloc_array((size_t)n_tris + 1, sizeof *x->tri_stress);
    if (!x->boundary_node || !x->boundary_x || !x->boundary_elem || !x->tri_stress) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        goto done;
    }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (vert[i] >= 0) {
            x->boundary_node[vert[i]] = i;
            memcpy(x->boundary.x + 3 * (size_t)vert[i], m->x + 3 * (size_t)i,
                   3 * sizeof(double));
        }
    for (int64_t k = 0; k < 3 * (int64_t)n_tris; ++k)
        x->boundary.tri[k] = (uint32_t)vert[b.tri[k]];
    for (int32_t f = 0; f < b.n_faces; ++f)
        for (int64_t t = b.tri_offsets[f]; t < b.tri_offsets[f + 1]; ++t)
            x->boundary_elem[t] = b.elem[f];
    x->boundary_serial = x->st.mesh_serial;
done:
    pf_free(vert);
    pf_boundary_release(&b);
    return s;
}

/* The surface of a frame (u NULL: at rest) and its positions. */
static pf_status frame_surface(exporter *x, const double *u, const pf_surface **s,
                               const double **pos, pf_error *err)
{
    const pf_stream_state *st = &x->st;
    if (st->have_surface && (st->have_weights || !u || !st->have_mesh)) {
        *s = &st->surface;
        *pos = st->surface.x;
        if (u && st->have_weights) {
            if (x->surface_serial != st->surface_serial) {
                pf_free(x->surface_x);
                x->surface_x = pf_alloc_array(3 * (size_t)st->surface.n_verts + 1,
                                              sizeof *x->surface_x);
                PF_CHECK(x->surface_x, err, PF_ERR_NOMEM,
                         "out of memory for a surface of %d vertices", (int)st->surface.n_verts);
                x->surface_serial = st->surface_serial;
            }
            pf_weights_apply(&st->weights, st->surface.x, u, x->surface_x);
            *pos = x->surface_x;
        }
        return PF_OK;
    }
    PF_TRY(ensure_boundary(x, err));
    *s = &x->boundary;
    *pos = x->boundary.x;
    if (u) {
        for (int32_t v = 0; v < x->boundary.n_verts; ++v)
            for (int c = 0; c < 3; ++c)
                x->boundary_x[3 * v + c] =
                    x->boundary.x[3 * v + c] + u[3 * (size_t)x->boundary_node[v] + c];
        *pos = x->boundary_x;
    }
    return PF_OK;
}

/* --usd: the frame's stress on the triangles of the mesh boundary (von Mises of the element each
 * bounds), or NULL: no STRS, or the surface is the embedded one (no triangle -> element map). */
static const double *triangle_stress(exporter *x, const pf_surface *s,
                                     const pf_stress_data *stress)
{
    if (!stress || s != &x->boundary)
        return NULL;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const double *v = stress->values + (size_t)x->boundary_elem[t] * stress->components;
        x->tri_stress[t] = stress->components == 6 ? pf_von_mises(v) : v[0];
    }
    return x->tri_stress;
}

static pf_status write_surface(exporter *x, uint32_t index, const double *u,
                               const pf_stress_data *stress, pf_error *err)
{
    const pf_surface *s;
    const double *pos;
    PF_TRY(frame_surface(x, u, &s, &pos, err));
    if (x->usd) {
        PF_TRY(pf_usd_writer_add(x->usd, index, x->time, s, pos, triangle_stress(x, s, stress),
                                 err));
        report(x, index);
        return PF_OK;
    }
    bool obj = x->o->format == FORMAT_OBJ;
    sprintf(x->path, "%s/frame_%05u.%s", x->o->dir, (unsigned)index, obj ? "obj" : "ply");
    PF_TRY(obj ? pf_export_obj(x->path, s, pos, err) : pf_export_ply(x->path, s, pos, err));
    report(x, index);
    return PF_OK;
}

/* ---- chunks ---------------------------------------------------------------------------------- */

static pf_status take_frame(exporter *x, const pf_chunk *c, pf_error *err)
{
    PF_TRY(flush_pending(x, err));
    uint32_t index;
    PF_TRY(pf_stream_frame_index(c, &index, err));
    if (!in_range(x->o, index))
        return pf_stream_state_skip_frame(&x->st, c, &index, err);
    pf_frame_data f = {0};
    PF_TRY(pf_stream_state_frame(&x->st, c, &f, err));
    if (x->o->format == FORMAT_VTU || x->usd) {
        x->pending = f; /* its STRS may follow */
        x->have_pending = true;
        return PF_OK;
    }
    x->time = f.time;
    pf_status s = write_surface(x, f.index, f.u, NULL, err);
    pf_frame_data_release(&f);
    return s;
}

/* A pending frame is written on the mesh and surface it came with, before a new MESH, SURF or
 * WGHT replaces them, or when the STRS chunk of its index arrives. */
static pf_status take_chunk(exporter *x, const pf_chunk *c, pf_error *err)
{
    if (strcmp(c->tag, "FRAM") == 0)
        return take_frame(x, c, err);
    if (strcmp(c->tag, "MESH") == 0 || strcmp(c->tag, "SURF") == 0 || strcmp(c->tag, "WGHT") == 0 ||
        strcmp(c->tag, "END_") == 0)
        PF_TRY(flush_pending(x, err));
    PF_TRY(pf_stream_state_take(&x->st, c, err));
    if (strcmp(c->tag, "STRS") == 0 && x->have_pending && x->st.stress.frame == x->pending.index)
        return flush_pending(x, err);
    return PF_OK;
}

/* A stream without frames: the rest state as index 0. */
static pf_status write_rest(exporter *x, pf_error *err)
{
    if (x->o->format == FORMAT_VTU) {
        PF_CHECK(x->st.have_mesh, err, PF_ERR_FORMAT, "%s: nothing to export: no MESH chunk",
                 x->name);
        return write_vtu(x, 0, 0.0, NULL, NULL, err);
    }
    PF_CHECK(x->st.have_mesh || x->st.have_surface, err, PF_ERR_FORMAT,
             "%s: nothing to export: no MESH and no SURF chunk", x->name);
    return write_surface(x, 0, NULL, NULL, err);
}

static pf_status export_stream(exporter *x, FILE *f, pf_error *err)
{
    pf_stream_reader *r = NULL;
    PF_TRY(pf_stream_reader_create(&r, f, x->name, err));
    pf_status s;
    for (;;) {
        pf_chunk c;
        bool end = false;
        s = pf_stream_read_chunk(r, &c, &end, err);
        if (s != PF_OK || end)
            break;
        s = take_chunk(x, &c, err);
        if (s != PF_OK)
            break;
    }
    uint64_t chunks = 0, frames = 0;
    pf_stream_reader_counts(r, &chunks, &frames);
    pf_stream_reader_destroy(&r);
    /* the frames read before an error are written all the same, and listed */
    pf_error later = {0};
    pf_status fs = flush_pending(x, s == PF_OK ? err : &later);
    if (s == PF_OK)
        s = fs;
    if (s == PF_OK && frames == 0 && in_range(x->o, 0))
        s = write_rest(x, err);
    if (x->usd && x->written) {
        pf_status us = pf_usd_writer_finish(x->usd, s == PF_OK ? err : &later);
        if (s == PF_OK)
            s = us;
    }
    if (x->o->format == FORMAT_VTU) {
        pf_status ps = write_pvd(x, s == PF_OK ? err : &later);
        if (s == PF_OK)
            s = ps;
    }
    return s;
}

/* ---- main ------------------------------------------------------------------------------------ */

static void summary(const exporter *x)
{
    static const char *const WHAT[] = {"", "VTU", "OBJ", "PLY", "USD"};
    if (x->usd) {
        fprintf(stderr, "%s: %lld frame%s written to %s\n", x->cli->tool, (long long)x->written,
                x->written == 1 ? "" : "s", x->o->dir);
        return;
    }
    fprintf(stderr, "%s: %lld %s file%s written to %s%s\n", x->cli->tool, (long long)x->written,
            WHAT[x->o->format], x->written == 1 ? "" : "s", x->o->dir,
            x->o->format == FORMAT_VTU && x->n_series ? ", listed in mesh.pvd" : "");
}

int main(int argc, char **argv)
{
    pf_cli cli;
    pf_cli_init(&cli, "pf-export", USAGE, argc, argv);
    options o;
    parse_options(&cli, &o);
    pf_error err = {0};
    FILE *in = NULL;
    const char *name = NULL;
    if (pf_cli_open_input(o.input, &in, &name, &err) != PF_OK)
        pf_cli_fail(&cli, &err);
    exporter x = {.o = &o, .cli = &cli, .name = name, .progress = pf_cli_show_progress(o.quiet)};
    pf_status s = o.format == FORMAT_USD ? pf_usd_writer_create(&x.usd, o.dir, &err)
                                         : pf_cli_make_dirs(o.dir, &err);
    if (s == PF_OK) {
        x.path = pf_alloc(strlen(o.dir) + 32);
        s = x.path ? export_stream(&x, in, &err)
                   : pf_error_set(&err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    if (x.progress && x.written)
        fputc('\n', stderr);
    if (!o.quiet && x.path)
        summary(&x);
    exporter_release(&x);
    pf_cli_close_input(in);
    if (s != PF_OK)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool); /* nothing written there, but every tool checks it alike */
    return PF_EXIT_OK;
}
