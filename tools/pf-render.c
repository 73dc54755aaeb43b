/* pf-render: frames of a pf stream -> PNG images (and optionally an MP4 through ffmpeg). The
 * drawing is libcore/render's pf_render_stream; this tool parses options and the simulation's
 * scene (its ground and obstacles), which render does not read. */
#define _POSIX_C_SOURCE 200809L /* fstat, signal */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <pf/io.h>
#include <pf/render.h>
#include <pf/sim.h>

#include "cli.h"
#include "obstacle_shape.h"

static const char USAGE[] =
    "Usage: pf-render [--out DIR] [--size WxH] [--frames A:B] [--camera JSON|auto]\n"
    "                 [--mode surface|mesh|stress] [--cap-color RRGGBB] [--mp4 FILE]\n"
    "                 [--fps N] [--quiet] [--progress[=S]] [FILE | -]\n"
    "\n"
    "Renders every frame (FRAM chunk) of a pf stream (default: stdin) to DIR/frame_NNNNN.png,\n"
    "NNNNN being the frame's index, while the stream arrives: 'pf-sim ... | pf-render' renders\n"
    "as the simulation runs. A stream without frames gives one image, frame_00000.png, of the\n"
    "mesh (or surface) at rest. Each frame is drawn on its own MESH and SURF (refinement and\n"
    "cutting write new ones mid-stream). The same input gives byte-identical images on every run\n"
    "and at any LP_NUM_THREADS.\n"
    "\n"
    "  --out DIR        output directory, created if missing (default: frames)\n"
    "  --size WxH       image size in pixels (default: 1280x720)\n"
    "  --frames A:B     only frames with index A..B inclusive ('A:' from A on, ':B' up to B,\n"
    "                   'A' just A): for splitting a stored stream across machines\n"
    "  --camera auto    (default) frame the whole animation: its bounding box over all frames\n"
    "                   when the input is a file (read twice), the first frame's box with a\n"
    "                   margin on a pipe; +z is up, the ground lies under the lowest point\n"
    "  --camera JSON    {\"eye\": [x,y,z], \"target\": [x,y,z], \"up\": [x,y,z], \"fov\": deg}, "
    "or\n"
    "                   the name of a file holding it; up (default 0,0,1) is also the ground's\n"
    "                   normal; fov is vertical, in degrees (default 40)\n"
    "  --mode surface   (default) the embedded surface moved by its weights (SURF + WGHT), else\n"
    "                   the boundary of the simulation mesh moved by the frame's displacements\n"
    "  --mode mesh      the simulation mesh's boundary with element edges, tets, hexes and\n"
    "                   general polyhedra in different colours\n"
    "  --mode stress    coloured by the frame's STRS chunk (von Mises) with the viridis map and\n"
    "                   a legend; the range is that of all frames for a file, of the frames so\n"
    "                   far on a pipe\n"
    "  --cap-color RRGGBB  the colour (sRGB hex, e.g. cc6b57, the default: a warm flesh red)\n"
    "                   of the caps a cut adds to the embedded surface (its SURF's cap\n"
    "                   triangles); the model's own surface stays clay (--mode stress colours\n"
    "                   caps by the stress too). Without an embedded surface the cut faces are\n"
    "                   part of the mesh boundary, drawn as the rest of it\n"
    "  --mp4 FILE       also pipe the frames into ffmpeg (H.264), which must be on PATH; an odd\n"
    "                   width or height is padded by one black pixel in the MP4 only (H.264's\n"
    "                   yuv420p needs even sizes), with a note on stderr\n"
    "  --fps N          frame rate of the MP4 (default 30)\n"
    "  --quiet, -q      no progress on stderr\n"
    "  --progress[=S]   a plain progress line every S seconds (default 5); without it, one\n"
    "                   line updated in place with the ETA on a terminal, a line every 5 s\n"
    "                   in a log (stderr not a terminal)\n"
    "  --help, --version\n"
    "\n"
    "Each image is written to a temporary name and renamed. A damaged or truncated stream: the\n"
    "frames before the damage are written, then the error; exit 1. Exit 2 on bad usage.\n";

enum { OPT_OUT = 1, OPT_SIZE, OPT_FRAMES, OPT_CAMERA, OPT_MODE, OPT_MP4, OPT_FPS, OPT_QUIET,
       OPT_PROG, OPT_CAP };

typedef struct options {
    pf_render_stream_params p;
    const char *input, *mp4;
    long fps;
    bool quiet;
    double plain_progress; /* --progress[=SECONDS], -1 without */
} options;

/* ---- options --------------------------------------------------------------------------------- */

static void parse_size(const pf_cli *cli, const char *text, options *o)
{
    char *end = NULL;
    long w = strtol(text, &end, 10), h = 0;
    if (end != text && (*end == 'x' || *end == 'X')) {
        const char *hs = end + 1;
        h = strtol(hs, &end, 10);
        if (end == hs)
            h = 0;
    }
    if (*end != '\0' || w < 1 || w > 8192 || h < 1 || h > 8192)
        pf_cli_usage_error(cli, "--size expects WxH with 1 <= W, H <= 8192, got '%s'", text);
    o->p.width = (int32_t)w;
    o->p.height = (int32_t)h;
}

/* --cap-color: 6 hex digits of sRGB (a leading '#' allowed), kept as linear RGB. */
static void parse_cap_color(const pf_cli *cli, const char *text, options *o)
{
    const char *h = text[0] == '#' ? text + 1 : text;
    if (strlen(h) != 6 || strspn(h, "0123456789abcdefABCDEF") != 6)
        pf_cli_usage_error(cli, "--cap-color expects 6 hex digits of sRGB (RRGGBB), got '%s'",
                           text);
    unsigned long v = strtoul(h, NULL, 16);
    for (int c = 0; c < 3; ++c)
        o->p.cap_rgb[c] = (float)pf_srgb_to_linear((double)((v >> (16 - 8 * c)) & 0xff) / 255.0);
}

/* The camera: inline JSON, or a file holding it (a camera is a few hundred bytes; a file of
 * more than 64 KiB is not one). */
static void parse_camera(const pf_cli *cli, const char *text, options *o)
{
    if (strcmp(text, "auto") == 0)
        return;
    pf_error err = {0};
    pf_buffer file = {0};
    const char *json = text;
    if (text[strspn(text, " \t\r\n")] != '{') {
        if (pf_buffer_read_file(&file, text, (size_t)64 << 10, &err) < 0 ||
            pf_buffer_append(&file, "", 1, &err) < 0)
            pf_cli_usage_error(cli, "--camera: '%s' is neither auto, JSON nor a readable camera "
                                    "file (%s)",
                               text, err.msg);
        json = (const char *)file.data;
    }
    pf_status st = pf_camera_parse_json(json, &o->p.camera, &err);
    pf_buffer_release(&file);
    if (st != PF_OK)
        pf_cli_usage_error(cli, "--camera: %s", err.msg);
    o->p.has_camera = true;
}

static void parse_options(pf_cli *cli, options *o)
{
    static const pf_cli_option OPTIONS[] = {
        {"out", true, OPT_OUT},       {"size", true, OPT_SIZE},    {"frames", true, OPT_FRAMES},
        {"camera", true, OPT_CAMERA}, {"mode", true, OPT_MODE},    {"mp4", true, OPT_MP4},
        {"fps", true, OPT_FPS},       {"quiet", false, OPT_QUIET}, {"progress", PF_CLI_OPTIONAL_VALUE, OPT_PROG},
        {"cap-color", true, OPT_CAP}, {NULL, false, 0}};
    *o = (options){.p = pf_render_stream_params_default(), .fps = 30, .plain_progress = -1};
    static const char *const MODES[] = {"surface", "mesh", "stress"};
    const char *value;
    for (int id; (id = pf_cli_next(cli, OPTIONS, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_OUT: o->p.out_dir = value; break;
        case OPT_SIZE: parse_size(cli, value, o); break;
        case OPT_FRAMES: pf_cli_parse_frames(cli, value, &o->p.first, &o->p.last); break;
        case OPT_CAMERA: parse_camera(cli, value, o); break;
        case OPT_MP4: o->mp4 = value; break;
        case OPT_FPS: o->fps = pf_cli_parse_long(cli, "fps", value, 1, 1000); break;
        case OPT_QUIET: o->quiet = true; break;
        case OPT_PROG: o->plain_progress = pf_cli_parse_progress(cli, value); break;
        case OPT_CAP: parse_cap_color(cli, value, o); break;
        case OPT_MODE: {
            int m = 0;
            while (m < 3 && strcmp(value, MODES[m]) != 0)
                ++m;
            if (m == 3)
                pf_cli_usage_error(cli, "--mode expects surface, mesh or stress, got '%s'", value);
            o->p.mode = (pf_render_mode)m;
            break;
        }
        default:
            if (o->input)
                pf_cli_usage_error(cli, "one input only (got '%s' and '%s')", o->input, value);
            o->input = value;
        }
    }
}

/* ---- the simulation's scene: ground and obstacles -------------------------------------------- */

typedef struct stage {
    const pf_cli *cli;
    pf_cli_progress progress;
    const pf_render_stream *rs; /* for the progress's total */
    int64_t written;
    pf_video *video;
    /* the scene parsed from a state's SCEN (parsed_for, at its scene_serial) */
    const pf_stream_state *parsed_for;
    uint64_t parsed_serial;
    pf_scene scene;
    bool have_scene;
    /* its obstacles at rest as triangles (shape[k] empty when obstacle k cannot be drawn), built
     * on first use, and scratch for their moved vertices */
    pf_surface *shape;
    bool have_shapes;
    double *moved;
} stage;

static void release_shapes(stage *g)
{
    for (int32_t k = 0; g->shape && k < g->scene.n_obstacles; ++k)
        pf_surface_release(&g->shape[k]);
    PF_FREE(g->shape);
    PF_FREE(g->moved);
    g->have_shapes = false;
}

/* The scene of st, parsed once per SCEN. A scene this pf cannot read is ignored: the picture then
 * keeps its default ground under the lowest point and draws no obstacles. */
static bool ensure_scene(stage *g, const pf_stream_state *st)
{
    if (g->parsed_for == st && g->parsed_serial == st->scene_serial)
        return g->have_scene;
    release_shapes(g);
    pf_scene_release(&g->scene);
    pf_error err = {0};
    g->have_scene = st->have_scene && pf_scene_parse(&g->scene, st->scene_json, st->scene_size,
                                                     "SCEN", &err) == PF_OK;
    g->parsed_for = st;
    g->parsed_serial = st->scene_serial;
    return g->have_scene;
}

/* Height along +z of the simulation's ground plane when it faces +z (the renderer's up): an
 * automatic ground is placed as pf-sim places it, under the rest mesh. */
static bool ground_height(void *ctx, const pf_stream_state *st, double *z)
{
    stage *g = ctx;
    if (!ensure_scene(g, st) || !g->scene.ground)
        return false;
    if (g->scene.ground_auto) {
        if (!st->have_mesh)
            return false;
        pf_vec3 lo, hi;
        pf_mesh_bounds(&st->mesh, &lo, &hi);
        pf_scene_resolve(&g->scene, lo, hi);
    }
    pf_vec3 n = pf_v3_normalize(g->scene.ground_normal);
    if (fabs(n.z - 1) > 1e-9)
        return false;
    *z = g->scene.ground_point.z;
    return true;
}

/* The obstacles' shapes, once per scene; one that cannot be built is skipped with a warning. */
static void build_shapes(stage *g, const pf_stream_state *st)
{
    const pf_scene *sc = &g->scene;
    g->have_shapes = true;
    g->shape = pf_calloc((size_t)sc->n_obstacles + 1, sizeof *g->shape);
    if (!g->shape)
        return;
    pf_vec3 lo = pf_v3(-0.5, -0.5, -0.5), hi = pf_v3(0.5, 0.5, 0.5);
    if (st->have_mesh)
        pf_mesh_bounds(&st->mesh, &lo, &hi);
    pf_vec3 c = pf_v3_scale(pf_v3_add(lo, hi), 0.5);
    double size = fmax(pf_v3_dist(lo, hi), 1e-3);
    int32_t most = 0;
    for (int32_t k = 0; k < sc->n_obstacles; ++k) {
        pf_error err = {0};
        if (pf_obstacle_shape(&sc->obstacles[k], c, size, &g->shape[k], &err) < 0) {
            fprintf(stderr, "%s: warning: obstacles[%d] is not drawn: %s\n", g->cli->tool, (int)k,
                    err.msg);
            pf_surface_release(&g->shape[k]);
        }
        most = g->shape[k].n_verts > most ? g->shape[k].n_verts : most;
    }
    g->moved = pf_alloc_array(3 * (size_t)most + 1, sizeof *g->moved);
}

/* A new scene in the drawing pass: its obstacles' shapes, around the mesh before it. */
static void on_scene(void *ctx, const pf_stream_state *st)
{
    stage *g = ctx;
    if (ensure_scene(g, st))
        build_shapes(g, st);
}

/* The obstacles where their paths put them at time t, painted slate blue. */
static pf_status add_obstacles(void *ctx, const pf_stream_state *st, double t,
                               pf_render_geometry *geom, pf_error *err)
{
    stage *g = ctx;
    if (!ensure_scene(g, st))
        return PF_OK;
    if (!g->have_shapes)
        build_shapes(g, st);
    pf_paint p = pf_paint_default();
    p.rgb[0] = 0.22f, p.rgb[1] = 0.30f, p.rgb[2] = 0.45f;
    for (int32_t k = 0; g->shape && g->moved && k < g->scene.n_obstacles; ++k) {
        const pf_surface *o = &g->shape[k];
        pf_vec3 d = pf_obstacle_translation(&g->scene.obstacles[k], t);
        for (int32_t i = 0; i < o->n_verts; ++i)
            pf_v3_store(pf_v3_add(pf_v3_load(o->x + 3 * i), d), g->moved + 3 * i);
        if (o->n_tris > 0)
            PF_TRY(pf_render_add_surface(geom, o, g->moved, &p, err));
    }
    return PF_OK;
}

static pf_status on_image(void *ctx, uint32_t index, const uint8_t *rgb, pf_error *err)
{
    stage *g = ctx;
    if (g->video)
        PF_TRY(pf_video_write(g->video, rgb, err));
    char what[64];
    snprintf(what, sizeof what, "frame %u, %lld written", (unsigned)index, (long long)++g->written);
    pf_cli_progress_report(&g->progress, what, (double)g->written,
                           (double)pf_render_stream_to_draw(g->rs));
    return PF_OK;
}

static void warn(void *ctx, const char *msg)
{
    const stage *g = ctx;
    fprintf(stderr, "%s: warning: %s\n", g->cli->tool, msg);
}

/* ---- main ------------------------------------------------------------------------------------ */

/* A stored stream is read twice (the survey frames the whole animation), a pipe once. */
static pf_status render_input(pf_render_stream *rs, FILE *in, const char *name, pf_error *err)
{
    struct stat st;
    long start = fstat(fileno(in), &st) == 0 && S_ISREG(st.st_mode) ? ftell(in) : -1;
    if (start >= 0) {
        pf_render_stream_survey(rs, in, name);
        PF_CHECK(fseek(in, start, SEEK_SET) == 0, err, PF_ERR_IO, "%s: cannot rewind: %s", name,
                 strerror(errno));
    }
    pf_stream_reader *r = NULL;
    PF_TRY(pf_stream_reader_create(&r, in, name, err));
    pf_status s = PF_OK;
    for (bool end = false; s == PF_OK && !end;) {
        pf_chunk c;
        s = pf_stream_read_chunk(r, &c, &end, err);
        if (s == PF_OK && !end)
            s = pf_render_stream_take(rs, &c, err);
    }
    pf_stream_reader_destroy(&r);
    pf_status fs = pf_render_stream_finish(rs, s == PF_OK, name, err);
    return s != PF_OK ? s : fs;
}

static pf_status run(options *o, stage *g, FILE *in, const char *name, pf_error *err)
{
    PF_TRY(pf_cli_make_dirs(o->p.out_dir, err));
    o->p.hooks = (pf_render_stream_hooks){
        .ctx = g, .ground_height = ground_height, .on_scene = on_scene,
        .add_obstacles = add_obstacles, .on_image = on_image, .warn = warn};
    pf_render_stream *rs = NULL;
    PF_TRY(pf_render_stream_create(&rs, &o->p, err));
    g->rs = rs;
    pf_status s = o->mp4 ? pf_video_create(&g->video, o->mp4, o->p.width, o->p.height, o->fps, err)
                         : PF_OK;
    if (s == PF_OK && o->mp4 && !o->quiet && (o->p.width % 2 || o->p.height % 2))
        fprintf(stderr, "%s: --mp4: %dx%d frames padded to %dx%d in %s (H.264 yuv420p needs even "
                "sizes); the PNGs keep %dx%d\n", g->cli->tool, (int)o->p.width, (int)o->p.height,
                (int)(o->p.width + o->p.width % 2), (int)(o->p.height + o->p.height % 2), o->mp4,
                (int)o->p.width, (int)o->p.height);
    if (s == PF_OK)
        s = render_input(rs, in, name, err);
    pf_cli_progress_done(&g->progress);
    pf_error video_err = {0};
    pf_status vs = g->video ? pf_video_finish(g->video, s == PF_OK ? err : &video_err) : PF_OK;
    pf_render_stream_destroy(&rs);
    return s != PF_OK ? s : vs;
}

int main(int argc, char **argv)
{
    pf_cli cli;
    pf_cli_init(&cli, "pf-render", USAGE, argc, argv);
    options o;
    parse_options(&cli, &o);
    pf_error err = {0};
    /* check for ffmpeg before rendering anything */
    if (o.mp4 && !pf_video_available()) {
        fprintf(stderr,
                "%s: --mp4 needs ffmpeg, which is not on PATH (install it, e.g. "
                "'apt-get install ffmpeg', or leave out --mp4)\n",
                cli.tool);
        return PF_EXIT_INPUT;
    }
    signal(SIGPIPE, SIG_IGN); /* a dead ffmpeg is a write error, not a silent exit */
    FILE *in = NULL;
    const char *name = NULL;
    if (pf_cli_open_input(o.input, &in, &name, &err) != PF_OK)
        pf_cli_fail(&cli, &err);
    stage g = {.cli = &cli};
    pf_cli_progress_start(&g.progress, cli.tool, o.quiet, o.plain_progress);
    pf_status s = run(&o, &g, in, name, &err);
    pf_video_destroy(&g.video);
    release_shapes(&g);
    pf_scene_release(&g.scene);
    pf_cli_close_input(in);
    if (s != PF_OK)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool); /* nothing written there, but every tool checks it alike */
    return PF_EXIT_OK;
}
