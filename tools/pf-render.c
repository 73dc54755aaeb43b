/* pf-render: frames of a pf stream -> PNG images (and optionally an MP4 through ffmpeg). */
#define _POSIX_C_SOURCE 200809L /* fork, pipe, fdopen, waitpid, mkdir, fstat, signal */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <pf/io.h>
#include <pf/sim.h>
#include <pf/render.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-render [--out DIR] [--size WxH] [--frames A:B] [--camera JSON|auto]\n"
    "                 [--mode surface|mesh|stress] [--mp4 FILE] [--fps N] [--quiet] [FILE | -]\n"
    "\n"
    "Renders every frame (FRAM chunk) of a pf stream (default: stdin) to DIR/frame_NNNNN.png,\n"
    "NNNNN being the frame's index, while the stream arrives: 'pf-sim ... | pf-render' renders\n"
    "as the simulation runs. A stream without frames gives one image, frame_00000.png, of the\n"
    "mesh (or surface) at rest. The same input gives byte-identical images on every run and at\n"
    "any LP_NUM_THREADS.\n"
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
    "  --mp4 FILE       also pipe the frames into ffmpeg (H.264), which must be on PATH\n"
    "  --fps N          frame rate of the MP4 (default 30)\n"
    "  --quiet          no progress on stderr\n"
    "  --help, --version\n"
    "\n"
    "Each image is written to a temporary name and renamed. A damaged or truncated stream: the\n"
    "frames before the damage are written, then the error; exit 1. Exit 2 on bad usage.\n";

enum { OPT_OUT = 1, OPT_SIZE, OPT_FRAMES, OPT_CAMERA, OPT_MODE, OPT_MP4, OPT_FPS, OPT_QUIET };

typedef enum mode { MODE_SURFACE, MODE_MESH, MODE_STRESS } mode;

typedef struct options {
    const char *out_dir, *input, *mp4;
    int32_t width, height;
    int64_t first, last; /* frame range, inclusive */
    bool has_camera;
    pf_camera camera;
    mode mode;
    long fps;
    bool quiet;
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
    o->width = (int32_t)w;
    o->height = (int32_t)h;
}

static bool parse_index(const char *s, const char *stop, int64_t *v)
{
    if (s == stop)
        return false;
    int64_t x = 0;
    for (const char *p = s; p < stop; ++p) {
        if (*p < '0' || *p > '9' || x > (int64_t)UINT32_MAX)
            return false;
        x = 10 * x + (*p - '0');
    }
    *v = x;
    return x <= (int64_t)UINT32_MAX;
}

static void parse_frames(const pf_cli *cli, const char *text, options *o)
{
    const char *colon = strchr(text, ':'), *end = text + strlen(text);
    bool ok;
    if (!colon) {
        ok = parse_index(text, end, &o->first);
        o->last = o->first;
    } else {
        o->first = 0;
        o->last = (int64_t)UINT32_MAX;
        ok = (colon == text || parse_index(text, colon, &o->first)) &&
             (colon + 1 == end || parse_index(colon + 1, end, &o->last)) && end - text > 1;
    }
    if (!ok || o->first > o->last)
        pf_cli_usage_error(cli, "--frames expects A:B, A:, :B or A with 0 <= A <= B, got '%s'",
                           text);
}

/* The camera: inline JSON, or a file holding it. */
static void parse_camera(const pf_cli *cli, const char *text, options *o)
{
    if (strcmp(text, "auto") == 0)
        return;
    char buf[4096];
    const char *json = text;
    if (text[strspn(text, " \t\r\n")] != '{') {
        FILE *f = fopen(text, "rb");
        if (!f)
            pf_cli_usage_error(cli, "--camera: '%s' is neither auto, JSON nor a readable file",
                               text);
        size_t n = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        buf[n] = '\0';
        json = buf;
    }
    pf_error err = {0};
    if (pf_camera_parse_json(json, &o->camera, &err) != PF_OK)
        pf_cli_usage_error(cli, "--camera: %s", err.msg);
    o->has_camera = true;
}

static void parse_options(pf_cli *cli, options *o)
{
    static const pf_cli_option OPTIONS[] = {
        {"out", true, OPT_OUT},       {"size", true, OPT_SIZE},    {"frames", true, OPT_FRAMES},
        {"camera", true, OPT_CAMERA}, {"mode", true, OPT_MODE},    {"mp4", true, OPT_MP4},
        {"fps", true, OPT_FPS},       {"quiet", false, OPT_QUIET}, {NULL, false, 0}};
    *o = (options){.out_dir = "frames",
                   .width = 1280,
                   .height = 720,
                   .first = 0,
                   .last = (int64_t)UINT32_MAX,
                   .mode = MODE_SURFACE,
                   .fps = 30};
    const char *value;
    for (int id; (id = pf_cli_next(cli, OPTIONS, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_OUT:
            o->out_dir = value;
            break;
        case OPT_SIZE:
            parse_size(cli, value, o);
            break;
        case OPT_FRAMES:
            parse_frames(cli, value, o);
            break;
        case OPT_CAMERA:
            parse_camera(cli, value, o);
            break;
        case OPT_MP4:
            o->mp4 = value;
            break;
        case OPT_FPS:
            o->fps = pf_cli_parse_long(cli, "fps", value, 1, 1000);
            break;
        case OPT_QUIET:
            o->quiet = true;
            break;
        case OPT_MODE:
            if (strcmp(value, "surface") == 0)
                o->mode = MODE_SURFACE;
            else if (strcmp(value, "mesh") == 0)
                o->mode = MODE_MESH;
            else if (strcmp(value, "stress") == 0)
                o->mode = MODE_STRESS;
            else
                pf_cli_usage_error(cli, "--mode expects surface, mesh or stress, got '%s'", value);
            break;
        default:
            if (o->input)
                pf_cli_usage_error(cli, "one input only (got '%s' and '%s')", o->input, value);
            o->input = value;
        }
    }
}

/* ---- ffmpeg ---------------------------------------------------------------------------------- */

static bool on_path(const char *program)
{
    const char *path = getenv("PATH");
    if (!path)
        return false;
    char buf[4096];
    for (const char *p = path;;) {
        const char *colon = strchr(p, ':');
        size_t n = colon ? (size_t)(colon - p) : strlen(p);
        if (n == 0 || n + strlen(program) + 2 > sizeof buf) {
            if (!colon)
                return false;
            p = colon + 1;
            continue;
        }
        memcpy(buf, p, n);
        buf[n] = '/';
        strcpy(buf + n + 1, program);
        if (access(buf, X_OK) == 0)
            return true;
        if (!colon)
            return false;
        p = colon + 1;
    }
}

typedef struct encoder {
    FILE *pipe;
    pid_t pid;
} encoder;

static pf_status start_ffmpeg(const options *o, encoder *enc, pf_error *err)
{
    char size[32], fps[16];
    snprintf(size, sizeof size, "%dx%d", (int)o->width, (int)o->height);
    snprintf(fps, sizeof fps, "%ld", o->fps);
    int fd[2];
    PF_CHECK(pipe(fd) == 0, err, PF_ERR_IO, "cannot create a pipe to ffmpeg: %s", strerror(errno));
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]);
        close(fd[1]);
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "cannot start ffmpeg: %s",
                            strerror(errno));
    }
    if (pid == 0) {
        dup2(fd[0], STDIN_FILENO);
        close(fd[0]);
        close(fd[1]);
        /* yuv420p needs even sizes: pad by one pixel where needed */
        char *const argv[] = {
            "ffmpeg",       "-y",       "-loglevel", "error",
            "-f",           "rawvideo", "-pix_fmt",  "rgb24",
            "-s",           size,       "-r",        fps,
            "-i",           "-",        "-vf",       "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-c:v",         "libx264",  "-pix_fmt",  "yuv420p",
            (char *)o->mp4, NULL};
        execvp("ffmpeg", argv);
        _exit(127);
    }
    close(fd[0]);
    enc->pipe = fdopen(fd[1], "wb");
    enc->pid = pid;
    PF_CHECK(enc->pipe, err, PF_ERR_IO, "cannot write to ffmpeg: %s", strerror(errno));
    return PF_OK;
}

static pf_status finish_ffmpeg(encoder *enc, const char *file, pf_error *err)
{
    if (!enc->pipe)
        return PF_OK;
    bool write_ok = fclose(enc->pipe) == 0;
    enc->pipe = NULL;
    int status = 0;
    waitpid(enc->pid, &status, 0);
    PF_CHECK(write_ok && WIFEXITED(status) && WEXITSTATUS(status) == 0, err, PF_ERR_IO,
             "%s: ffmpeg failed (exit status %d)", file,
             WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return PF_OK;
}

/* ---- the stream's state ---------------------------------------------------------------------- */

typedef struct scene {
    pf_stream_state st; /* the latest MESH, SURF, WGHT, STRS (von Mises) and SCEN */
    bool surface_closed;
    double *x;          /* [3 st.surface.n_verts] displaced surface */
    pf_scene sim_scene; /* the simulation's scene (SCEN), for its ground plane */
    bool have_sim_scene;
    /* its obstacles at rest, as triangles (obstacle[k] of the scene is shape[k], empty when it
     * cannot be drawn), and scratch for their moved vertices */
    pf_surface *obstacle_shape;
    int32_t n_obstacle_shapes;
    double *obstacle_x;
} scene;

static void scene_release(scene *s)
{
    pf_stream_state_release(&s->st);
    pf_scene_release(&s->sim_scene);
    for (int32_t k = 0; k < s->n_obstacle_shapes; ++k)
        pf_surface_release(&s->obstacle_shape[k]);
    pf_free(s->obstacle_shape);
    pf_free(s->obstacle_x);
    pf_free(s->x);
    memset(s, 0, sizeof *s);
}

/* A box lo..hi as 24 vertices (four per face, so each face is shaded flat) and 12 triangles,
 * counter-clockwise seen from outside. */
static pf_status box_shape(pf_surface *b, pf_vec3 lo, pf_vec3 hi, pf_error *err)
{
    PF_TRY(pf_surface_alloc(b, 24, 12, err));
    for (int f = 0; f < 6; ++f) {
        int axis = f / 2, side = f % 2, a = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int q = 0; q < 4; ++q) {
            double p[3];
            p[axis] = side ? pf_v3_get(hi, axis) : pf_v3_get(lo, axis);
            p[a] = (q == 1 || q == 2) ? pf_v3_get(hi, a) : pf_v3_get(lo, a);
            p[c] = q >= 2 ? pf_v3_get(hi, c) : pf_v3_get(lo, c);
            memcpy(b->x + 3 * (4 * f + q), p, sizeof p);
        }
        /* corners 0 1 2 3 run counter-clockwise in (a, c), which faces +axis */
        uint32_t v = (uint32_t)(4 * f), t[6] = {v, v + 1, v + 2, v, v + 2, v + 3};
        for (int k = 0; k < 6; ++k)
            b->tri[6 * f + k] = side ? t[k] : t[5 - k];
    }
    return PF_OK;
}

/* The triangles of obstacle o at rest: a sphere of 16 x 32 bands, a box, the mesh's file (read
 * here; a file that cannot be read is skipped with a warning), a plane as a square of side
 * 4 size centred under the mesh's centre c. */
static pf_status obstacle_shape(const pf_obstacle *o, pf_vec3 c, double size, pf_surface *out,
                                pf_error *err)
{
    switch (o->kind) {
    case PF_OBSTACLE_SPHERE:
        PF_TRY(pf_surface_make_sphere(out, o->radius, 16, 32, err));
        for (int32_t i = 0; i < out->n_verts; ++i) {
            out->x[3 * i] += o->centre.x;
            out->x[3 * i + 1] += o->centre.y;
            out->x[3 * i + 2] += o->centre.z;
        }
        return PF_OK;
    case PF_OBSTACLE_BOX: return box_shape(out, o->lo, o->hi, err);
    case PF_OBSTACLE_MESH: return pf_import_surface(o->file, out, err);
    case PF_OBSTACLE_PLANE: {
        /* two unit vectors across the normal, the square's centre on the plane below c */
        pf_vec3 n = o->normal;
        pf_vec3 t = fabs(n.x) < 0.9 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0);
        pf_vec3 e1 = pf_v3_normalize(pf_v3_cross(n, t)), e2 = pf_v3_cross(n, e1);
        pf_vec3 m = pf_v3_sub(c, pf_v3_scale(n, pf_v3_dot(n, pf_v3_sub(c, o->point))));
        PF_TRY(pf_surface_alloc(out, 4, 2, err));
        for (int q = 0; q < 4; ++q) {
            double s1 = (q == 1 || q == 2) ? 2 * size : -2 * size, s2 = q >= 2 ? 2 * size : -2 * size;
            pf_vec3 p = pf_v3_add(m, pf_v3_add(pf_v3_scale(e1, s1), pf_v3_scale(e2, s2)));
            pf_v3_store(p, out->x + 3 * q);
        }
        const uint32_t tri[6] = {0, 1, 2, 0, 2, 3}; /* e1 x e2 = n: counter-clockwise seen from n */
        memcpy(out->tri, tri, sizeof tri);
        return PF_OK;
    }
    }
    return PF_OK;
}

/* The scene's obstacles as triangles, once per SCEN; tool NULL: no warnings. */
static void take_obstacles(scene *s, const char *tool)
{
    const pf_scene *sc = &s->sim_scene;
    if (sc->n_obstacles == 0)
        return;
    s->obstacle_shape = pf_calloc((size_t)sc->n_obstacles, sizeof *s->obstacle_shape);
    if (!s->obstacle_shape)
        return;
    s->n_obstacle_shapes = sc->n_obstacles;
    pf_vec3 lo = pf_v3(-0.5, -0.5, -0.5), hi = pf_v3(0.5, 0.5, 0.5);
    if (s->st.have_mesh)
        pf_mesh_bounds(&s->st.mesh, &lo, &hi);
    pf_vec3 c = pf_v3_scale(pf_v3_add(lo, hi), 0.5);
    double size = fmax(pf_v3_dist(lo, hi), 1e-3);
    int32_t most = 0;
    for (int32_t k = 0; k < sc->n_obstacles; ++k) {
        pf_error err = {0};
        if (obstacle_shape(&sc->obstacles[k], c, size, &s->obstacle_shape[k], &err) < 0) {
            if (tool) /* the rendering pass warns; the survey pass is quiet */
                fprintf(stderr, "%s: warning: obstacles[%d] is not drawn: %s\n", tool, (int)k,
                    err.msg);
            pf_surface_release(&s->obstacle_shape[k]);
        }
        most = s->obstacle_shape[k].n_verts > most ? s->obstacle_shape[k].n_verts : most;
    }
    s->obstacle_x = pf_alloc_array(3 * (size_t)most + 1, sizeof *s->obstacle_x);
}

/* The simulation's scene, for the ground it simulated against. A scene this pf cannot read is
 * ignored: the picture then keeps its default ground under the lowest point. */
static void take_scene(scene *s, const char *tool)
{
    pf_error err = {0};
    pf_scene_release(&s->sim_scene);
    s->have_sim_scene = pf_scene_parse(&s->sim_scene, s->st.scene_json, s->st.scene_size, "SCEN",
                                       &err) == PF_OK;
    for (int32_t k = 0; k < s->n_obstacle_shapes; ++k)
        pf_surface_release(&s->obstacle_shape[k]);
    PF_FREE(s->obstacle_shape);
    PF_FREE(s->obstacle_x);
    s->n_obstacle_shapes = 0;
    if (s->have_sim_scene)
        take_obstacles(s, tool);
}

/* Height along +z of the simulation's ground plane, when the scene has one facing +z (the
 * renderer's up): the automatic ground is placed as pf-sim places it, under the rest mesh. */
static bool sim_ground_height(scene *s, double *height)
{
    pf_scene *sc = &s->sim_scene;
    if (!s->have_sim_scene || !sc->ground)
        return false;
    if (sc->ground_auto) {
        if (!s->st.have_mesh)
            return false;
        pf_vec3 lo, hi;
        pf_mesh_bounds(&s->st.mesh, &lo, &hi);
        pf_scene_resolve(sc, lo, hi);
    }
    pf_vec3 n = pf_v3_normalize(sc->ground_normal);
    if (fabs(n.z - 1) > 1e-9)
        return false;
    *height = sc->ground_point.z;
    return true;
}

/* A chunk other than FRAM into the reader state, and what the picture derives from it: the
 * surface's scratch and closedness, one von Mises value per element, the parsed scene. */
static pf_status take_chunk(scene *s, const pf_chunk *c, const char *tool, pf_error *err)
{
    PF_TRY(pf_stream_state_take(&s->st, c, err));
    if (strcmp(c->tag, "SURF") == 0) {
        pf_surface_stats st;
        PF_TRY(pf_surface_compute_stats(&s->st.surface, &st, err));
        s->surface_closed = st.closed && st.manifold;
        pf_free(s->x);
        s->x = pf_alloc_array(3 * (size_t)s->st.surface.n_verts + 1, sizeof *s->x);
        PF_CHECK(s->x, err, PF_ERR_NOMEM, "out of memory for a surface of %d vertices",
                 (int)s->st.surface.n_verts);
    } else if (strcmp(c->tag, "STRS") == 0) {
        pf_stress_data *st = &s->st.stress; /* von Mises in place from 6 components */
        if (st->components == 6)
            for (int32_t e = 0; e < st->n_elems; ++e)
                st->values[e] = pf_von_mises(st->values + 6 * (size_t)e);
        st->components = 1;
    } else if (strcmp(c->tag, "SCEN") == 0) {
        take_scene(s, tool);
    }
    return PF_OK;
}

/* Draws the surface (moved by the weights) when it can, else the mesh boundary; --mode mesh
 * draws the mesh whenever there is one. */
static bool draws_surface(const scene *s, mode m)
{
    if (m == MODE_MESH)
        return !s->st.have_mesh;
    return s->st.have_weights || !s->st.have_mesh;
}

/* The positions of the drawn geometry of a frame (u NULL: at rest), as their bounding box. */
static void frame_bounds(scene *s, mode m, const double *u, pf_vec3 *lo, pf_vec3 *hi)
{
    *lo = pf_v3(INFINITY, INFINITY, INFINITY);
    *hi = pf_v3(-INFINITY, -INFINITY, -INFINITY);
    const double *x;
    int32_t n;
    if (draws_surface(s, m)) {
        x = s->st.surface.x;
        if (u && s->st.have_weights) {
            pf_weights_apply(&s->st.weights, s->st.surface.x, u, s->x);
            x = s->x;
        }
        n = s->st.surface.n_verts;
        u = NULL;
    } else {
        x = s->st.mesh.x;
        n = s->st.mesh.n_nodes;
    }
    for (int32_t i = 0; i < n; ++i) {
        pf_vec3 p = pf_v3_load(x + 3 * (size_t)i);
        if (u)
            p = pf_v3_add(p, pf_v3_load(u + 3 * (size_t)i));
        *lo = pf_v3_min(*lo, p);
        *hi = pf_v3_max(*hi, p);
    }
}

/* ---- pass 1 (files): the animation's bounding box and stress range --------------------------- */

typedef struct survey {
    bool have_box;
    pf_vec3 lo, hi;
    bool have_stress;
    double stress_lo, stress_hi;
} survey;

static void grow_box(survey *sv, pf_vec3 lo, pf_vec3 hi)
{
    if (!(lo.x <= hi.x))
        return;
    sv->lo = sv->have_box ? pf_v3_min(sv->lo, lo) : lo;
    sv->hi = sv->have_box ? pf_v3_max(sv->hi, hi) : hi;
    sv->have_box = true;
}

static void grow_stress(survey *sv, const pf_stress_data *st)
{
    for (int32_t e = 0; e < st->n_elems; ++e) {
        double v = st->values[e];
        sv->stress_lo = sv->have_stress ? fmin(sv->stress_lo, v) : fmin(0, v);
        sv->stress_hi = sv->have_stress ? fmax(sv->stress_hi, v) : v;
        sv->have_stress = true;
    }
}

static pf_status survey_chunk(scene *s, survey *sv, mode m, const pf_chunk *c, int64_t *frames,
                              pf_error *err)
{
    if (strcmp(c->tag, "FRAM") != 0) {
        PF_TRY(take_chunk(s, c, NULL, err));
        if (strcmp(c->tag, "STRS") == 0)
            grow_stress(sv, &s->st.stress);
        return PF_OK;
    }
    pf_frame_data f = {0};
    PF_TRY(pf_stream_state_frame(&s->st, c, &f, err));
    pf_vec3 lo, hi;
    frame_bounds(s, m, f.u, &lo, &hi);
    grow_box(sv, lo, hi);
    ++*frames;
    pf_frame_data_release(&f);
    return PF_OK;
}

/* Reads the whole file once; errors end the survey quietly (the rendering pass reports them). */
static void survey_file(FILE *f, const char *name, mode m, survey *sv)
{
    scene s = {0};
    pf_stream_reader *r = NULL;
    pf_error err = {0};
    int64_t frames = 0;
    if (pf_stream_reader_create(&r, f, name, &err) == PF_OK) {
        for (;;) {
            pf_chunk c;
            bool end = false;
            if (pf_stream_read_chunk(r, &c, &end, &err) != PF_OK || end)
                break;
            if (survey_chunk(&s, sv, m, &c, &frames, &err) != PF_OK)
                break;
        }
    }
    /* no frames: the rest shape is what is drawn */
    if (frames == 0 && (s.st.have_mesh || s.st.have_surface)) {
        pf_vec3 lo, hi;
        frame_bounds(&s, m, NULL, &lo, &hi);
        grow_box(sv, lo, hi);
    }
    double ground;
    if (sv->have_box && sim_ground_height(&s, &ground))
        sv->lo.z = fmin(sv->lo.z, ground); /* the stage reaches down to the simulated ground */
    pf_stream_reader_destroy(&r);
    scene_release(&s);
}

/* ---- pass 2: rendering ----------------------------------------------------------------------- */

typedef struct render {
    const options *o;
    const pf_cli *cli;
    scene s;
    survey sv;      /* from pass 1, or grown frame by frame on a pipe */
    bool from_file; /* sv covers the whole animation */
    pf_boundary boundary;
    uint64_t boundary_mesh; /* the MESH (state's mesh_serial) the boundary was extracted from */
    bool have_boundary;
    pf_render_geometry geom;
    pf_renderer *renderer;
    pf_render_view view;
    bool view_ready;
    uint8_t *rgb;
    double *node_values, *vert_values;
    encoder enc;
    bool progress, warned_no_stress;
    int64_t written;
    char *path; /* scratch for file names */
    /* a frame waiting for its STRS chunk (stress mode) */
    pf_frame_data pending;
    bool have_pending;
} render;

static pf_status ensure_boundary(render *rd, pf_error *err)
{
    if (rd->have_boundary && rd->boundary_mesh == rd->s.st.mesh_serial)
        return PF_OK;
    pf_boundary_release(&rd->boundary);
    rd->have_boundary = false;
    PF_TRY(pf_boundary_extract(&rd->s.st.mesh, &rd->boundary, err));
    rd->boundary_mesh = rd->s.st.mesh_serial;
    rd->have_boundary = true;
    return PF_OK;
}

static pf_status stress_paint(render *rd, pf_paint *p, bool on_surface, pf_error *err)
{
    scene *s = &rd->s;
    p->kind = PF_PAINT_ELEM_VALUE;
    p->values = s->st.stress.values;
    p->lo = rd->sv.stress_lo;
    p->hi = rd->sv.stress_hi > rd->sv.stress_lo ? rd->sv.stress_hi : rd->sv.stress_lo + 1;
    if (!on_surface)
        return PF_OK;
    pf_free(rd->node_values);
    pf_free(rd->vert_values);
    rd->node_values = pf_alloc_array((size_t)s->st.mesh.n_nodes + 1, sizeof *rd->node_values);
    rd->vert_values = pf_alloc_array((size_t)s->st.surface.n_verts + 1, sizeof *rd->vert_values);
    PF_CHECK(rd->node_values && rd->vert_values, err, PF_ERR_NOMEM, "out of memory");
    PF_TRY(pf_render_elem_to_node(&s->st.mesh, s->st.stress.values, rd->node_values, err));
    pf_weights_apply_scalar(&s->st.weights, rd->node_values, rd->vert_values);
    p->kind = PF_PAINT_VERT_VALUE;
    p->values = rd->vert_values;
    return PF_OK;
}

/* The frame's geometry: surface or mesh boundary, painted by the mode. *legend: a stress legend
 * belongs in the image. */
static pf_status build_geometry(render *rd, const pf_frame_data *f, bool *legend, pf_error *err)
{
    scene *s = &rd->s;
    const double *u = f ? f->u : NULL;
    bool surface = draws_surface(s, rd->o->mode);
    bool stress = rd->o->mode == MODE_STRESS && f && s->st.have_stress &&
                  s->st.stress.frame == f->index && s->st.stress.mesh_id == s->st.mesh.id;
    if (rd->o->mode == MODE_STRESS && !stress && !rd->warned_no_stress) {
        fprintf(stderr, "%s: warning: no STRS chunk for frame %u: drawn without colours\n",
                rd->cli->tool, f ? (unsigned)f->index : 0u);
        rd->warned_no_stress = true;
    }
    pf_paint p = pf_paint_default();
    *legend = false;
    if (stress) {
        if (!rd->from_file)
            grow_stress(&rd->sv, &s->st.stress);
        PF_TRY(stress_paint(rd, &p, surface && s->st.have_weights, err));
        *legend = true;
    }
    pf_render_geometry_clear(&rd->geom);
    if (surface) {
        const double *x = s->st.surface.x;
        if (u && s->st.have_weights) {
            pf_weights_apply(&s->st.weights, s->st.surface.x, u, s->x);
            x = s->x;
        }
        p.wire = rd->o->mode == MODE_MESH;
        if (p.kind == PF_PAINT_ELEM_VALUE) /* stress without weights cannot reach the surface */
            p = pf_paint_default(), *legend = false;
        rd->geom.closed = s->surface_closed;
        return pf_render_add_surface(&rd->geom, &s->st.surface, x, &p, err);
    }
    PF_TRY(ensure_boundary(rd, err));
    if (rd->o->mode == MODE_MESH) {
        p.kind = PF_PAINT_ELEM_KIND;
        p.wire = true;
    }
    rd->geom.closed = true;
    return pf_render_add_boundary(&rd->geom, &s->st.mesh, &rd->boundary, u, &p, err);
}

/* The view, fixed at the first frame of the stream (u: its displacements; NULL: the rest shape).
 * The auto camera frames the survey's box when the input is a file (the whole animation); on a
 * pipe, the first frame's box grown by a quarter of its size on every side but the bottom (room
 * for the motion to come), down to the simulated ground when the stream's scene has one (else the
 * ground stays under the first frame). The first frame of the stream, not of --frames, so that
 * every range of a shot is seen through the same camera. */
static void ensure_view(render *rd, const double *u)
{
    if (rd->view_ready)
        return;
    double aspect = (double)rd->o->width / rd->o->height;
    pf_vec3 lo, hi;
    frame_bounds(&rd->s, rd->o->mode, u, &lo, &hi);
    if (rd->sv.have_box) {
        lo = rd->sv.lo;
        hi = rd->sv.hi;
    } else if (lo.x <= hi.x) {
        pf_vec3 m = pf_v3_scale(pf_v3_sub(hi, lo), 0.25);
        lo = pf_v3(lo.x - m.x, lo.y - m.y, lo.z);
        hi = pf_v3_add(hi, m);
        double ground;
        if (sim_ground_height(&rd->s, &ground))
            lo.z = fmin(lo.z, ground);
    } else {
        lo = pf_v3(-1, -1, -1);
        hi = pf_v3(1, 1, 1);
    }
    rd->view = pf_render_view_default(lo, hi, aspect);
    if (rd->o->has_camera) {
        rd->view.camera = rd->o->camera;
        rd->view.up = pf_v3_normalize(rd->o->camera.up);
    }
    rd->view_ready = true;
}

/* The simulation's obstacles where their paths put them at time t, painted slate blue. */
static pf_status add_obstacles(render *rd, double t, pf_error *err)
{
    scene *s = &rd->s;
    pf_paint p = pf_paint_default();
    p.rgb[0] = 0.22f, p.rgb[1] = 0.30f, p.rgb[2] = 0.45f;
    for (int32_t k = 0; k < s->n_obstacle_shapes && s->obstacle_x; ++k) {
        const pf_surface *o = &s->obstacle_shape[k];
        if (o->n_tris == 0)
            continue;
        pf_vec3 d = pf_obstacle_translation(&s->sim_scene.obstacles[k], t);
        for (int32_t i = 0; i < o->n_verts; ++i) {
            s->obstacle_x[3 * i] = o->x[3 * i] + d.x;
            s->obstacle_x[3 * i + 1] = o->x[3 * i + 1] + d.y;
            s->obstacle_x[3 * i + 2] = o->x[3 * i + 2] + d.z;
        }
        PF_TRY(pf_render_add_surface(&rd->geom, o, s->obstacle_x, &p, err));
    }
    return PF_OK;
}

static pf_status render_frame(render *rd, const pf_frame_data *f, pf_error *err)
{
    bool legend;
    PF_TRY(build_geometry(rd, f, &legend, err));
    ensure_view(rd, f ? f->u : NULL); /* framed on the body, not the obstacles */
    PF_TRY(add_obstacles(rd, f ? f->time : 0, err));
    PF_TRY(pf_renderer_draw(rd->renderer, &rd->geom, &rd->view, rd->rgb, err));
    if (legend)
        pf_render_draw_legend(rd->rgb, rd->o->width, rd->o->height, rd->sv.stress_lo,
                              rd->sv.stress_hi > rd->sv.stress_lo ? rd->sv.stress_hi
                                                                  : rd->sv.stress_lo + 1);
    unsigned index = f ? (unsigned)f->index : 0u;
    sprintf(rd->path, "%s/frame_%05u.png", rd->o->out_dir, index);
    PF_TRY(pf_png_write(rd->path, rd->rgb, rd->o->width, rd->o->height, 3, err));
    if (rd->enc.pipe) {
        size_t n = 3 * (size_t)rd->o->width * (size_t)rd->o->height;
        PF_CHECK(fwrite(rd->rgb, 1, n, rd->enc.pipe) == n, err, PF_ERR_IO,
                 "%s: cannot write to ffmpeg: %s", rd->o->mp4, strerror(errno));
    }
    ++rd->written;
    if (rd->progress)
        fprintf(stderr, "\r%s: frame %u, %lld written", rd->cli->tool, index,
                (long long)rd->written);
    return PF_OK;
}

static bool in_range(const options *o, uint32_t index)
{
    return (int64_t)index >= o->first && (int64_t)index <= o->last;
}

static pf_status flush_pending(render *rd, pf_error *err)
{
    if (!rd->have_pending)
        return PF_OK;
    rd->have_pending = false;
    pf_status s = render_frame(rd, &rd->pending, err);
    pf_frame_data_release(&rd->pending);
    return s;
}

static pf_status on_frame(render *rd, const pf_chunk *c, pf_error *err)
{
    PF_TRY(flush_pending(rd, err));
    uint32_t index;
    PF_TRY(pf_stream_frame_index(c, &index, err));
    /* frames out of range are checked by their header, not decoded, but for the first one,
     * which fixes the camera */
    if (!in_range(rd->o, index) && rd->view_ready)
        return pf_stream_state_skip_frame(&rd->s.st, c, &index, err);
    pf_frame_data f = {0};
    PF_TRY(pf_stream_state_frame(&rd->s.st, c, &f, err));
    ensure_view(rd, f.u);
    pf_status s = PF_OK;
    if (in_range(rd->o, f.index)) {
        /* in stress mode a frame waits for its STRS, which may follow it */
        const pf_stream_state *st = &rd->s.st;
        if (rd->o->mode == MODE_STRESS && !(st->have_stress && st->stress.frame == f.index)) {
            rd->pending = f;
            rd->have_pending = true;
            return PF_OK;
        }
        s = render_frame(rd, &f, err);
    }
    pf_frame_data_release(&f);
    return s;
}

/* A pending frame is drawn on its own mesh: before a new MESH replaces it. */
static pf_status render_chunk(render *rd, const pf_chunk *c, pf_error *err)
{
    if (strcmp(c->tag, "FRAM") == 0)
        return on_frame(rd, c, err);
    if (strcmp(c->tag, "MESH") == 0)
        PF_TRY(flush_pending(rd, err));
    PF_TRY(take_chunk(&rd->s, c, rd->cli->tool, err));
    if (strcmp(c->tag, "STRS") == 0 && rd->have_pending &&
        rd->s.st.stress.frame == rd->pending.index)
        return flush_pending(rd, err);
    return PF_OK; /* INFO, END_ and unknown chunks do not change the picture */
}

static pf_status render_stream(render *rd, FILE *f, const char *name, pf_error *err)
{
    pf_stream_reader *r = NULL;
    PF_TRY(pf_stream_reader_create(&r, f, name, err));
    pf_status s = PF_OK;
    for (;;) {
        pf_chunk c;
        bool end = false;
        s = pf_stream_read_chunk(r, &c, &end, err);
        if (s != PF_OK || end)
            break;
        s = render_chunk(rd, &c, err);
        if (s != PF_OK)
            break;
    }
    uint64_t chunks = 0, frames = 0;
    pf_stream_reader_counts(r, &chunks, &frames);
    pf_stream_reader_destroy(&r);
    /* the frames read before an error are rendered all the same */
    pf_error later = {0};
    pf_status fs = flush_pending(rd, s == PF_OK ? err : &later);
    if (s == PF_OK)
        s = fs;
    if (s == PF_OK && frames == 0 && rd->written == 0 && in_range(rd->o, 0)) {
        PF_CHECK(rd->s.st.have_mesh || rd->s.st.have_surface, err, PF_ERR_FORMAT,
                 "%s: nothing to draw: no MESH and no SURF chunk", name);
        s = render_frame(rd, NULL, err);
    }
    return s;
}

/* ---- main ------------------------------------------------------------------------------------ */

static bool is_regular_file(FILE *f)
{
    struct stat st;
    return fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode);
}

static pf_status make_out_dir(const char *dir, pf_error *err)
{
    if (mkdir(dir, 0777) == 0 || errno == EEXIST) {
        struct stat st;
        PF_CHECK(stat(dir, &st) == 0 && S_ISDIR(st.st_mode), err, PF_ERR_IO, "%s: not a directory",
                 dir);
        return PF_OK;
    }
    return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot create directory: %s", dir,
                        strerror(errno));
}

static pf_status run(render *rd, FILE *in, const char *name, pf_error *err)
{
    const options *o = rd->o;
    PF_TRY(make_out_dir(o->out_dir, err));
    rd->path = pf_alloc(strlen(o->out_dir) + 32);
    rd->rgb = pf_alloc_array(3 * (size_t)o->width, (size_t)o->height);
    PF_CHECK(rd->path && rd->rgb, err, PF_ERR_NOMEM, "out of memory for a %dx%d image",
             (int)o->width, (int)o->height);
    pf_render_params p = pf_render_params_default();
    p.width = o->width;
    p.height = o->height;
    PF_TRY(pf_renderer_create(&rd->renderer, &p, err));
    if (is_regular_file(in)) {
        long start = ftell(in);
        if (start >= 0) {
            survey_file(in, name, o->mode, &rd->sv);
            rd->from_file = true;
            PF_CHECK(fseek(in, start, SEEK_SET) == 0, err, PF_ERR_IO, "%s: cannot rewind: %s", name,
                     strerror(errno));
        }
    }
    if (o->mp4)
        PF_TRY(start_ffmpeg(o, &rd->enc, err));
    pf_status s = render_stream(rd, in, name, err);
    if (rd->progress && rd->written)
        fputc('\n', stderr);
    pf_error enc_err = {0};
    pf_status es = finish_ffmpeg(&rd->enc, o->mp4, s == PF_OK ? err : &enc_err);
    return s != PF_OK ? s : es;
}

static void render_release(render *rd)
{
    pf_renderer_destroy(&rd->renderer);
    pf_render_geometry_release(&rd->geom);
    pf_boundary_release(&rd->boundary);
    pf_frame_data_release(&rd->pending);
    scene_release(&rd->s);
    pf_free(rd->rgb);
    pf_free(rd->path);
    pf_free(rd->node_values);
    pf_free(rd->vert_values);
}

int main(int argc, char **argv)
{
    pf_cli cli;
    pf_cli_init(&cli, "pf-render", USAGE, argc, argv);
    options o;
    parse_options(&cli, &o);
    pf_error err = {0};
    /* check for ffmpeg before rendering anything */
    if (o.mp4 && !on_path("ffmpeg")) {
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
    render rd = {.o = &o, .cli = &cli, .progress = pf_cli_show_progress(o.quiet)};
    pf_status s = run(&rd, in, name, &err);
    render_release(&rd);
    pf_cli_close_input(in);
    if (s != PF_OK)
        pf_cli_fail(&cli, &err);
    return PF_EXIT_OK;
}
