/* pf-sim: the simulator. A stream with a MESH in, the same stream out with SCEN, one FRAM (and
 * STRS) per frame, flushed as each frame is made. */
#define _POSIX_C_SOURCE 200809L /* fileno */

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <pf/io.h>
#include <pf/sim.h>

#include "cli.h"
#include "scene_files.h"
#include "sim_distrib_out.h"
#include "sim_resume.h"
#include "sim_summary.h"

static const char USAGE[] =
    "Usage: pf-sim [SCENE.json] [options] < mesh.pfs > out.pfs\n"
    "       pf-sim --resume PARTIAL.pfs [--output FILE | > out.pfs]\n"
    "\n"
    "Simulates the stream's MESH as the scene says (docs/scene.md) and writes the stream on:\n"
    "every input chunk except earlier frames, then INFO, SCEN, and one FRAM (stitched nodal\n"
    "displacements) and STRS (von Mises stress per element) per frame, checkpoints (CKPT)\n"
    "and STAT (statistics).\n"
    "Without a scene file, the defaults drop the body under gravity onto a ground plane below\n"
    "it. Contact with the ground and the scene's obstacles acts at the mesh's boundary nodes or,\n"
    "when the stream carries embedding weights (WGHT, from pf-embed) for its SURF, at the\n"
    "surface's vertices.\n"
    "\n"
    "Overrides of scene keys:\n"
    "  --method dg|cg     discretisation (cg: harmonic basis functions, nodal unknowns)\n"
    "  --mass consistent|lumped   CG mass matrix (default consistent)\n"
    "  --edge-samples N   CG MFS kernel samples inside each element edge (1-16, default 2):\n"
    "                     smaller basis errors, slower set-up\n"
    "  --degree 1|2       DG polynomial degree (default 1; 2 for accuracy: docs/guidance.md)\n"
    "  --flux ip|bz       DG flux: interior penalty or Babuska-Zlamal\n"
    "  --penalty ETA      DG penalty factor (default: ip doubled from 1 until K is definite;\n"
    "                     bz 3/16 for degree 1, 1/2 for degree 2, growing under refinement)\n"
    "  --E VALUE --nu VALUE --density VALUE   material\n"
    "  --frames N         frames after the rest frame 0; A:B simulates to B, writes A..B\n"
    "  --dt SECONDS --substeps N   time between frames, time steps per frame\n"
    "  --static[=BOOL]    solve K u = f once and write one frame (true, false; a static scene\n"
    "                     needs a 'fixed' region that holds boundary faces)\n"
    "  --corotation[=BOOL]  stiffness warping, on by default; --corotation=false (or\n"
    "                     --no-corotation) for linear elasticity\n"
    "  --solver auto|direct|pcg|petsc   linear solves: direct refactorises whenever the\n"
    "                     matrix changes; pcg iterates on the last factor and refactorises when\n"
    "                     that pays; auto (default) picks pcg where the matrix changes; petsc:\n"
    "                     PETSc's CG + GAMG over the MPI ranks (builds with -DPF_PETSC=ON)\n"
    "  --tolerance TOL    pcg, petsc: residual relative to the right-hand side (default 1e-10)\n"
    "Checkpoints and resuming (crash-safe long runs):\n"
    "  --checkpoint-every N  a CKPT chunk (the state a run continues from) after frames 0, N,\n"
    "                     2N, ... and the last (default 10; 0: none; none if the scene\n"
    "                     refines); pcg, petsc: later frames' last bits depend on N\n"
    "  --resume PARTIAL   continue the run that wrote PARTIAL (killed, full disk) from its last\n"
    "                     checkpoint, to the bytes of the uninterrupted run (same build and\n"
    "                     threads); reads no input; a scene or overrides must match its own\n"
    "                     (--solver, --tolerance may differ)\n"
    "Other options:\n"
    "  --input FILE       read the stream from FILE instead of stdin\n"
    "  --output FILE      write the stream to FILE instead of stdout, through FILE.part renamed\n"
    "                     when complete (a killed run leaves FILE.part, which --resume\n"
    "                     continues); needed under mpirun\n"
    "  --quiet, -q        no progress or summary on stderr\n"
    "  --progress[=S]     plain lines: set-up phases, frames every S s (default 5); logs: always\n"
    "  --stats FILE       write the run's statistics to FILE as JSON (docs/scene.md, \"Run\n"
    "                     statistics\"), also after a diverged run\n"
    "  --help, --version\n"
    "\n"
    "MPI (builds with -DPF_PETSC=ON): mpirun -n N pf-sim SCENE.json --solver petsc\n"
    "--input in.pfs --output out.pfs (mpirun's forwarding of stdout is not byte-exact);\n"
    "rank 0 reads and writes, all ranks share the solves (docs/petsc.md). Options of one dash\n"
    "(-ksp_monitor, -pc_type lu, each with its value if it takes one) go to PETSc, best last;\n"
    "so does the environment variable PETSC_OPTIONS.\n"
    "\n"
    "Exit 0 ok; 1 bad input or a simulation that diverged (the frames before it are written and\n"
    "the stream is closed properly); 2 bad usage.\n";

enum {
    OPT_METHOD = 1,
    OPT_MASS,
    OPT_EDGE_SAMPLES,
    OPT_DEGREE,
    OPT_FLUX,
    OPT_PENALTY,
    OPT_E,
    OPT_NU,
    OPT_DENSITY,
    OPT_FRAMES,
    OPT_DT,
    OPT_SUBSTEPS,
    OPT_STATIC,
    OPT_NO_COROTATION,
    OPT_SOLVER,
    OPT_TOLERANCE,
    OPT_COROTATION,
    OPT_INPUT,
    OPT_OUTPUT,
    OPT_QUIET,
    OPT_STATS,
    OPT_CHECKPOINT_EVERY,
    OPT_RESUME,
    OPT_PROGRESS
};

/* Frames between checkpoints by default (docs/stream-format.md, CKPT: what they cost). */
enum { DEFAULT_CHECKPOINT_EVERY = 10 };

typedef struct run {
    pf_cli cli;
    pf_scene scene;
    const char *scene_path;
    const char *input_path;
    const char *output_path;
    bool quiet;
    double progress;        /* --progress=S: S; -1 without (pf_cli_progress_start) */
    pf_cli_progress bar;    /* the set-up's phases, then the frames */
    const char *stats_path; /* --stats FILE, or NULL */
    double wall0, cpu0;     /* the clocks at the start */
    pf_mesh mesh;           /* the input's latest MESH, moved out of input */
    bool have_mesh;
    pf_stream_state input; /* the latest SURF and WGHT, for contact at the embedded surface */
    bool embedded;         /* contact at the surface's vertices */
    pf_stream_writer *out;
    uint64_t written_mesh;    /* the id of the last MESH written: a refined mesh is written anew */
    uint64_t written_surface; /* the id of the embedded surface in the input or last written */
    int32_t checkpoint_every;
    bool checkpoint_given; /* --checkpoint-every was given */
    int32_t checkpoints;   /* CKPT chunks written (or copied, when resuming) */
    pf_buffer checkpoint;  /* scratch for CKPT payloads */
    /* the whole run's counters (STAT, CKPT) are base + the simulator's now - at_restore: a
     * resumed run continues those of the checkpoint it restored */
    pf_run_counts base, at_restore;
    const char *resume_path;
    int64_t first_written; /* --frames A:B: frames before A are simulated, not written */
    char frames_last[24];  /* --frames A:B: B, the frames override */
    /* the scene file's overrides, applied in build_scene */
    int n_overrides;
    int override_ids[64];
    const char *override_values[64];
    pf_error err;
} run;

/* Scene keys by option id, for pf_scene_override. */
static const char *override_key(int id)
{
    switch (id) {
    case OPT_METHOD:
        return "method";
    case OPT_MASS:
        return "mass";
    case OPT_EDGE_SAMPLES:
        return "edge_samples";
    case OPT_DEGREE:
        return "degree";
    case OPT_FLUX:
        return "flux";
    case OPT_PENALTY:
        return "penalty";
    case OPT_E:
        return "E";
    case OPT_NU:
        return "nu";
    case OPT_DENSITY:
        return "density";
    case OPT_FRAMES:
        return "frames";
    case OPT_DT:
        return "dt";
    case OPT_SUBSTEPS:
        return "substeps";
    case OPT_STATIC:
        return "static";
    case OPT_NO_COROTATION:
    case OPT_COROTATION:
        return "corotation";
    case OPT_SOLVER:
        return "solver";
    case OPT_TOLERANCE:
        return "tolerance";
    default:
        return NULL;
    }
}

/* --frames A:B: B (when given) overrides the scene's frames, frames before A are not written. */
static void parse_frame_range(run *r, const char *value)
{
    int64_t first = 0, last = 0;
    pf_cli_parse_frames(&r->cli, value, &first, &last);
    r->first_written = first;
    if (value[strlen(value) - 1] == ':')
        return; /* 'A:': up to the scene's last frame */
    if (r->n_overrides >= 64)
        pf_cli_usage_error(&r->cli, "too many options");
    snprintf(r->frames_last, sizeof r->frames_last, "%lld", (long long)last);
    r->override_ids[r->n_overrides] = OPT_FRAMES;
    r->override_values[r->n_overrides++] = r->frames_last;
}

static void parse_arguments(run *r, int argc, char **argv)
{
    static const pf_cli_option options[] = {{"method", true, OPT_METHOD},
                                            {"mass", true, OPT_MASS},
                                            {"degree", true, OPT_DEGREE},
                                            {"edge-samples", true, OPT_EDGE_SAMPLES},
                                            {"flux", true, OPT_FLUX},
                                            {"penalty", true, OPT_PENALTY},
                                            {"E", true, OPT_E},
                                            {"nu", true, OPT_NU},
                                            {"density", true, OPT_DENSITY},
                                            {"frames", true, OPT_FRAMES},
                                            {"dt", true, OPT_DT},
                                            {"substeps", true, OPT_SUBSTEPS},
                                            {"static", PF_CLI_OPTIONAL_VALUE, OPT_STATIC},
                                            {"corotation", PF_CLI_OPTIONAL_VALUE, OPT_COROTATION},
                                            {"no-corotation", false, OPT_NO_COROTATION},
                                            {"solver", true, OPT_SOLVER},
                                            {"tolerance", true, OPT_TOLERANCE},
                                            {"input", true, OPT_INPUT},
                                            {"output", true, OPT_OUTPUT},
                                            {"quiet", false, OPT_QUIET},
                                            {"stats", true, OPT_STATS},
                                            {"checkpoint-every", true, OPT_CHECKPOINT_EVERY},
                                            {"resume", true, OPT_RESUME},
                                            {"progress", PF_CLI_OPTIONAL_VALUE, OPT_PROGRESS},
                                            {NULL, false, 0}};
    pf_cli_init(&r->cli, "pf-sim", USAGE, argc, argv);
    r->checkpoint_every = -1; /* DEFAULT_CHECKPOINT_EVERY, or the resumed run's */
    r->progress = -1;
    /* Overrides apply after the scene file, wherever they stand: collect them first. */
    const char *value;
    for (int id; (id = pf_cli_next(&r->cli, options, &value)) != PF_CLI_END;) {
        if (id == PF_CLI_POSITIONAL) {
            if (r->scene_path)
                pf_cli_usage_error(&r->cli, "one scene file only (got '%s' and '%s')",
                                   r->scene_path, value);
            r->scene_path = value;
        } else if (id == OPT_INPUT) {
            r->input_path = value;
        } else if (id == OPT_OUTPUT) {
            r->output_path = value;
        } else if (id == OPT_QUIET) {
            r->quiet = true;
        } else if (id == OPT_PROGRESS) {
            r->progress = pf_cli_parse_progress(&r->cli, value);
        } else if (id == OPT_STATS) {
            r->stats_path = value;
        } else if (id == OPT_CHECKPOINT_EVERY) {
            r->checkpoint_every =
                (int32_t)pf_cli_parse_long(&r->cli, "--checkpoint-every", value, 0, INT32_MAX);
            r->checkpoint_given = true;
        } else if (id == OPT_RESUME) {
            r->resume_path = value;
        } else if (id == OPT_FRAMES && strchr(value, ':')) {
            parse_frame_range(r, value);
        } else if (r->n_overrides < 64) {
            r->override_ids[r->n_overrides] = id;
            /* --static and --corotation alone mean true (the empty value, docs/scene.md) */
            r->override_values[r->n_overrides++] = id == OPT_NO_COROTATION ? "false"
                                                   : value                 ? value
                                                                           : "";
        } else {
            pf_cli_usage_error(&r->cli, "too many options");
        }
    }
    if (r->checkpoint_every < 0 && !r->resume_path)
        r->checkpoint_every = DEFAULT_CHECKPOINT_EVERY;
    if (r->resume_path && r->input_path)
        pf_cli_usage_error(&r->cli, "--resume reads no input stream: the mesh is in '%s'",
                           r->resume_path);
}

/* The scene: the file (or the defaults) with the overrides applied. Usage errors exit 2, also
 * for a --frames A:B whose A is past the frames the scene makes. */
static void build_scene(run *r, pf_scene *scene)
{
    pf_error err = {0};
    if (r->scene_path) {
        pf_buffer text = {0};
        pf_status st = pf_buffer_read_file(&text, r->scene_path, PF_SCENE_MAX_BYTES, &err);
        if (st == PF_OK)
            st = pf_scene_parse(scene, (const char *)text.data, text.size, r->scene_path, &err);
        pf_buffer_release(&text);
        if (st < 0)
            pf_cli_fail(&r->cli, &err);
    } else {
        pf_scene_default(scene);
    }
    for (int k = 0; k < r->n_overrides; ++k)
        if (pf_scene_override(scene, override_key(r->override_ids[k]), r->override_values[k],
                              &err) < 0)
            pf_cli_usage_error(&r->cli, "%s", err.msg);
    if (r->first_written > (scene->is_static ? 0 : scene->frames))
        pf_cli_usage_error(&r->cli, "--frames %lld: the scene makes frames 0 to %d only",
                           (long long)r->first_written, scene->is_static ? 0 : (int)scene->frames);
}

/* Passes every input chunk on except the ones this run replaces (scene, frames, stress,
 * checkpoints, statistics of an earlier run, END_), keeping the last MESH. */
static pf_status copy_input(run *r, pf_stream_reader *in, pf_error *err)
{
    for (;;) {
        pf_chunk c;
        bool end = false;
        PF_TRY(pf_stream_read_chunk(in, &c, &end, err));
        if (end)
            return PF_OK;
        if (!strcmp(c.tag, "END_"))
            continue;
        if (!strcmp(c.tag, "FRAM") || !strcmp(c.tag, "STRS") || !strcmp(c.tag, "SCEN") ||
            !strcmp(c.tag, "CKPT") || !strcmp(c.tag, "STAT"))
            continue;
        PF_TRY(pf_stream_state_take(&r->input, &c, err)); /* MESH, SURF, WGHT and their ids */
        PF_TRY(pf_stream_write_raw(r->out, &c, err));
    }
}

/* The simulator owns the mesh it runs on: the input's latest MESH moves out of the state. */
static void take_input_mesh(run *r)
{
    r->have_mesh = r->input.have_mesh;
    if (!r->have_mesh)
        return;
    r->mesh = r->input.mesh;
    memset(&r->input.mesh, 0, sizeof r->input.mesh);
    r->input.have_mesh = false;
}

/* SCEN: the scene as simulated (file, defaults and overrides), so the stream says how it was
 * made and pf-render finds the ground. */
static pf_status write_scene(run *r, pf_error *err)
{
    char *json = NULL;
    PF_TRY(pf_scene_to_json(&r->scene, &json, err));
    pf_status st = pf_stream_write_scene(r->out, json, strlen(json), err);
    pf_free(json);
    return st;
}

/* A mesh the simulator changed (refinement, cuts) goes out before the first frame on it, with
 * the embedded surface (when a cut changed it) and its weights on it. */
static pf_status write_changed_mesh(run *r, const pf_sim *sim, pf_error *err)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    if (m->id == r->written_mesh)
        return PF_OK;
    PF_TRY(pf_stream_write_mesh(r->out, m, err));
    const pf_surface *s = pf_sim_surface(sim);
    if (s && s->id != r->written_surface) {
        PF_TRY(pf_stream_write_surface(r->out, s, err));
        r->written_surface = s->id;
    }
    if (pf_sim_weights(sim))
        PF_TRY(pf_stream_write_weights(r->out, pf_sim_weights(sim), err));
    r->written_mesh = m->id;
    return PF_OK;
}

static pf_status write_frame(run *r, const pf_sim *sim, int32_t index, pf_error *err)
{
    const pf_mesh *m = pf_sim_mesh(sim);
    PF_TRY(write_changed_mesh(r, sim, err));
    double *u = pf_alloc_array(3 * (size_t)m->n_nodes + 1, sizeof *u);
    double *von_mises = pf_alloc_array((size_t)m->n_elems + 1, sizeof *von_mises);
    pf_status st = u && von_mises ? PF_OK
                                  : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                 "frame %d: out of memory", (int)index);
    if (st >= 0) {
        pf_sim_nodal_displacements(sim, u);
        pf_sim_von_mises(sim, von_mises);
        st = pf_cli_write_frame(r->out, m, (uint32_t)index, pf_sim_time(sim), u, von_mises,
                                err);
    }
    pf_free(u);
    pf_free(von_mises);
    return st;
}

/* --stats FILE: the statistics as JSON, written atomically. */
static pf_status write_stats(const run *r, const pf_sim *sim, pf_error *err)
{
    char *json = NULL;
    PF_TRY(pf_sim_stats_json(sim, pf_time_seconds() - r->wall0, pf_cpu_seconds() - r->cpu0, &json,
                             err));
    pf_status st = pf_write_file_atomic(r->stats_path, json, strlen(json), "statistics", err);
    pf_free(json);
    return st;
}

/* The whole run's counters so far (a resumed run's include those before its checkpoint). */
static pf_run_counts run_counts(const run *r, const pf_sim *sim)
{
    pf_run_counts c;
    pf_sim_run_counts(sim, &c);
    c.steps = r->base.steps + (c.steps - r->at_restore.steps);
    c.factorisations = r->base.factorisations + (c.factorisations - r->at_restore.factorisations);
    c.solves = r->base.solves + (c.solves - r->at_restore.solves);
    c.pcg_iterations = r->base.pcg_iterations + (c.pcg_iterations - r->at_restore.pcg_iterations);
    return c;
}

/* A CKPT after frames 0, N, 2N, ... and the last one (the stream format's CKPT); none in a
 * scene that refines or cuts: its mesh changes between frames, which a checkpoint does not
 * hold. */
static pf_status write_checkpoint(run *r, pf_sim *sim, int32_t index, bool last, pf_error *err)
{
    if (r->checkpoint_every <= 0 || pf_scene_changes_mesh(&r->scene) ||
        (index % r->checkpoint_every != 0 && !last))
        return PF_OK;
    r->checkpoint.size = 0;
    pf_checkpoint_header h = {.mesh_id = pf_sim_mesh(sim)->id,
                              .frame = (uint32_t)index,
                              .every = (uint32_t)r->checkpoint_every,
                              .counts = run_counts(r, sim)};
    PF_TRY(pf_stream_encode_checkpoint_header(&h, &r->checkpoint, err));
    PF_TRY(pf_sim_checkpoint(sim, &r->checkpoint, err));
    PF_TRY(pf_stream_write_chunk(r->out, "CKPT", pf_stream_tag_version("CKPT"), r->checkpoint.data,
                                 r->checkpoint.size, err));
    r->checkpoints++;
    return PF_OK;
}

/* A frame made and written (unless --frames A:B leaves it out), with its checkpoint. */
static pf_status emit_frame(run *r, pf_sim *sim, int32_t index, pf_error *err)
{
    if (index >= r->first_written)
        PF_TRY(write_frame(r, sim, index, err));
    bool last = r->scene.is_static || index == r->scene.frames;
    return write_checkpoint(r, sim, index, last, err);
}

/* The simulator in the state of the checkpoint restore (a CKPT chunk of r->resume_path). */
static pf_status restore_checkpoint(run *r, pf_sim *sim, const pf_chunk *restore, int32_t *frame,
                                    pf_error *err)
{
    pf_checkpoint_header h = {0};
    pf_status st = pf_stream_checkpoint_header(restore, &h, err);
    if (st >= 0 && !h.have_counts)
        st = pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                          "a version 1 checkpoint, without the run's counters for its STAT "
                          "chunk (an older pf-sim wrote it): rerun");
    if (st >= 0)
        st = pf_sim_restore(sim, h.state, h.state_size, err);
    r->base = h.counts;
    pf_sim_run_counts(sim, &r->at_restore); /* the set-up of this process is not the run's */
    if (st < 0)
        pf_error_prefix(err, "%s: chunk CKPT at byte %llu", r->resume_path,
                        (unsigned long long)restore->offset);
    *frame = (int32_t)h.frame;
    return st;
}

/* The dynamic frames after first, and whether the body came to rest: the last frame's kinetic
 * energy against the largest (of the frames this run made). */
static pf_status advance(run *r, pf_sim *sim, int32_t first, pf_error *err)
{
    pf_cli_progress *progress = &r->bar; /* the simulator's phases go on reaching it */
    pf_cli_progress_done(progress);
    pf_cli_progress_start(progress, "pf-sim", r->quiet, r->progress);
    pf_status st = PF_OK;
    double kinetic = 0, peak = 0;
    int32_t peak_frame = 0;
    for (int32_t k = first + 1; st >= 0 && k <= r->scene.frames; ++k) {
        st = pf_sim_frame(sim, err);
        if (st >= 0)
            st = emit_frame(r, sim, k, err);
        char what[48];
        snprintf(what, sizeof what, "frame %d of %d", (int)k, (int)r->scene.frames);
        pf_cli_progress_report(progress, what, k - first, r->scene.frames - first);
        pf_vec3 linear, angular;
        pf_sim_momentum(sim, &kinetic, &linear, &angular);
        if (kinetic > peak)
            peak = kinetic, peak_frame = k;
    }
    pf_cli_progress_done(progress);
    if (st >= 0 && !r->quiet && first < r->scene.frames)
        fprintf(
            stderr,
            "pf-sim: kinetic energy %.6g at the last frame, %.3g of its peak %.6g (frame %d%s)\n",
            kinetic, peak > 0 ? kinetic / peak : 0.0, peak, (int)peak_frame,
            first > 0 ? ", among the frames resumed" : "");
    return st;
}

/* A scene on PETSc where every rank assembles its own elements (sim_distrib_out.c). */
static pf_status simulate_distributed(run *r, const pf_chunk *restore, pf_error *err)
{
    pf_cli_distrib_run d = {.out = r->out,
                            .scene = &r->scene,
                            .mesh = &r->mesh,
                            .first_written = r->first_written,
                            .checkpoint_every = r->checkpoint_every,
                            .restore = restore,
                            .resume_path = r->resume_path,
                            .quiet = r->quiet,
                            .stats_path = r->stats_path,
                            .wall0 = r->wall0,
                            .cpu0 = r->cpu0};
    pf_status st = pf_cli_distrib_simulate(&d, err);
    r->checkpoints += d.checkpoints;
    return st;
}

/* The frames: one for a static scene, the rest state and scene->frames more otherwise; when
 * resuming, those after the checkpoint's frame (restore: the CKPT payload). */
static pf_status simulate(run *r, const pf_chunk *restore, pf_error *err)
{
    pf_vec3 lo, hi;
    pf_mesh_bounds(&r->mesh, &lo, &hi);
    pf_scene_resolve(&r->scene, lo, hi);
    /* contact at the embedded surface when the stream has weights (the reader state checked
     * that they belong to its latest SURF and MESH) */
    const pf_weights *w = &r->input.weights;
    bool embedded = r->embedded = r->input.have_weights;
    r->written_mesh = r->mesh.id;
    r->written_surface = embedded ? r->input.surface.id : 0;
    PF_TRY(pf_scene_read_files(&r->scene, &r->mesh, err));
    /* PF_SIM_RANK0_ASSEMBLY=1: rank 0 assembles all, as for other scenes (to compare) */
    if (pf_sim_distrib_applies(&r->scene, embedded) && !getenv("PF_SIM_RANK0_ASSEMBLY"))
        return simulate_distributed(r, restore, err);
    pf_cli_progress_start(&r->bar, "pf-sim", r->quiet, r->progress);
    r->bar.phase_lines = true;
    pf_sim_options opt = {.surface = embedded ? &r->input.surface : NULL,
                          .weights = embedded ? w : NULL,
                          .progress = {pf_cli_progress_event, &r->bar}};
    pf_sim *sim = NULL;
    pf_status created = pf_sim_create_with(&sim, &r->scene, &r->mesh, &opt, err);
    pf_cli_progress_done(&r->bar);
    PF_TRY(created);
    if (pf_scene_changes_mesh(&r->scene) && r->checkpoint_given && r->checkpoint_every > 0 &&
        !r->quiet)
        fprintf(stderr, "pf-sim: the scene refines or cuts (its mesh changes between frames): "
                        "no checkpoints, whatever --checkpoint-every says\n");
    pf_status st = PF_OK;
    int32_t first = 0;
    if (restore)
        st = restore_checkpoint(r, sim, restore, &first, err);
    else if (r->scene.is_static)
        st = pf_sim_solve_static(sim, err);
    if (st >= 0 && !restore)
        st = emit_frame(r, sim, 0, err);
    if (st >= 0 && !r->scene.is_static)
        st = advance(r, sim, first, err);
    pf_cli_progress_done(&r->bar);
    if (st >= 0 || err->status == PF_ERR_NUMERIC) { /* also after a diverged frame */
        pf_error stat_err = {0};
        pf_run_counts counts = run_counts(r, sim);
        pf_status ss = pf_cli_write_stat(r->out, sim, &counts, &stat_err);
        if (ss < 0 && st >= 0) {
            *err = stat_err;
            st = ss;
        }
    }
    if (!r->quiet)
        pf_cli_sim_summary(sim, r->embedded, r->mesh.n_elems);
    if (r->stats_path) { /* also after a failed frame: the statistics of what was done */
        pf_error stats_err = {0};
        pf_status ss = write_stats(r, sim, &stats_err);
        if (ss < 0 && st >= 0) {
            *err = stats_err;
            st = ss;
        }
    }
    pf_sim_destroy(&sim);
    return st;
}

static pf_status prepare_mesh(run *r, const char *input_name, pf_error *err)
{
    PF_CHECK(r->have_mesh, err, PF_ERR_FORMAT, "%s: no MESH chunk to simulate", input_name);
    pf_status st = pf_mesh_validate(&r->mesh, NULL, err);
    if (st >= 0)
        st = pf_mesh_derive(&r->mesh, err);
    if (st < 0)
        pf_error_prefix(err, "%s: MESH", input_name);
    return st;
}

/* The stream's own SCEN as the scene, which must read back into the same JSON (so the resumed
 * scene is bit for bit the one simulated), and equal the scene given, if any. */
static pf_status resume_scene(run *r, pf_error *err)
{
    const pf_stream_state *in = &r->input;
    PF_CHECK(in->have_scene, err, PF_ERR_FORMAT, "%s: no SCEN chunk", r->resume_path);
    pf_status st = pf_scene_parse(&r->scene, in->scene_json, in->scene_size, "SCEN", err);
    char *json = NULL;
    if (st >= 0)
        st = pf_scene_to_json(&r->scene, &json, err);
    if (st >= 0 && strcmp(json, in->scene_json) != 0)
        st = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                          "the stored scene does not read back into the same numbers, so the run "
                          "cannot continue exactly");
    if (st < 0)
        pf_error_prefix(err, "%s", r->resume_path);
    pf_free(json);
    PF_TRY(st);
    /* --solver and --tolerance choose how the frames after the checkpoint are solved (on one
     * process or on many), which changes their last bits only */
    int others = 0;
    for (int k = 0; k < r->n_overrides; ++k) {
        int id = r->override_ids[k];
        if (id != OPT_SOLVER && id != OPT_TOLERANCE)
            others++;
        else if (pf_scene_override(&r->scene, override_key(id), r->override_values[k], err) < 0)
            pf_cli_usage_error(&r->cli, "%s", err->msg);
    }
    if (!r->scene_path && others == 0)
        return PF_OK;
    pf_scene given = {0};
    build_scene(r, &given);
    json = NULL;
    st = pf_scene_to_json(&given, &json, err);
    pf_scene_release(&given);
    PF_TRY(st);
    char *stored = NULL;
    if (pf_scene_to_json(&r->scene, &stored, err) < 0) {
        pf_free(json);
        return err->status;
    }
    size_t at = 0;
    while (json[at] && json[at] == stored[at])
        ++at;
    bool same = json[at] == stored[at];
    pf_free(json), pf_free(stored);
    PF_CHECK(same, err, PF_ERR_INVALID,
             "%s: the scene given (%s%s) differs from the one stored in its SCEN chunk (from "
             "byte %zu of the JSON; pf-info --scene prints it): resume without a scene file and "
             "overrides, or with the ones of the run",
             r->resume_path, r->scene_path ? r->scene_path : "defaults",
             r->n_overrides ? " and overrides" : "", at);
    return PF_OK;
}

/* The same file (device and inode) as the stream resumed. */
static bool same_file(FILE *f, const char *path)
{
    struct stat a, b;
    if (fstat(fileno(f), &a) != 0 || stat(path, &b) != 0)
        return false;
    return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

/* The output: stdout, or FILE through FILE.part. */
static pf_status open_output(run *r, pf_atomic_file *file, FILE *resumed, pf_error *err)
{
    FILE *out = NULL;
    const char *name = "stdout";
    if (r->output_path) {
        char part[4096];
        snprintf(part, sizeof part, "%s.part", r->output_path);
        PF_CHECK(!resumed || !same_file(resumed, part), err, PF_ERR_INVALID,
                 "--output %s would overwrite %s, the stream being resumed: move it first",
                 r->output_path, part);
        PF_TRY(pf_atomic_file_open(file, r->output_path, err));
        out = file->f;
        name = r->output_path;
    } else {
        if (pf_cli_launcher_rank() >= 0)
            pf_cli_usage_error(&r->cli, "under mpirun, write the stream with --output FILE "
                                        "(mpirun's forwarding of stdout is not byte-exact)");
        out = pf_cli_binary_stdout(&r->cli);
        PF_CHECK(!resumed || !same_file(stdout, r->resume_path), err, PF_ERR_INVALID,
                 "stdout is %s, the stream being resumed: write to another file", r->resume_path);
    }
    return pf_stream_writer_create(&r->out, out, name, err);
}

/* A new run: the input stream's chunks, INFO, SCEN, the frames. */
static pf_status run_new(run *r, pf_atomic_file *file, pf_error *err)
{
    build_scene(r, &r->scene);
    FILE *in_file = NULL;
    const char *in_name = NULL;
    PF_TRY(pf_cli_open_input(r->input_path, &in_file, &in_name, err));
    pf_stream_reader *in = NULL;
    pf_status st = pf_stream_reader_create(&in, in_file, in_name, err);
    if (st >= 0)
        st = open_output(r, file, NULL, err);
    if (st >= 0)
        st = copy_input(r, in, err);
    take_input_mesh(r);
    if (st >= 0)
        st = prepare_mesh(r, in_name, err);
    if (st >= 0)
        st = pf_cli_write_info(&r->cli, r->out, err);
    if (st >= 0)
        st = write_scene(r, err);
    if (st >= 0)
        st = simulate(r, NULL, err);
    pf_stream_reader_destroy(&in);
    pf_cli_close_input(in_file);
    return st;
}

/* --resume: the partial stream up to its last checkpoint, then the frames after it. */
static pf_status run_resumed(run *r, pf_atomic_file *file, pf_error *err)
{
    FILE *f = fopen(r->resume_path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", r->resume_path, strerror(errno));
    pf_resume_point p;
    pf_stream_reader *in = NULL;
    pf_chunk ckpt;
    pf_status st = pf_resume_find(f, r->resume_path, &p, err);
    if (st >= 0 && fseek(f, 0, SEEK_SET) != 0)
        st = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot seek: %s", r->resume_path,
                          strerror(errno));
    if (st >= 0)
        st = pf_stream_reader_create(&in, f, r->resume_path, err);
    if (st >= 0)
        st = open_output(r, file, f, err);
    if (st >= 0)
        st = pf_resume_copy(in, &p, r->out, &r->input, &ckpt, err);
    take_input_mesh(r);
    pf_checkpoint_header h = {0};
    if (st >= 0)
        st = pf_stream_checkpoint_header(&ckpt, &h, err);
    if (st >= 0 && h.mesh_id != r->mesh.id)
        st = pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                          "%s: chunk CKPT at byte %llu is of mesh %llu, not the input's MESH %llu: "
                          "resuming a run whose mesh changed (refinement) is not supported yet",
                          r->resume_path, (unsigned long long)p.offset,
                          (unsigned long long)h.mesh_id, (unsigned long long)r->mesh.id);
    if (st >= 0)
        r->checkpoints = 1; /* copied: the output can be resumed again */
    if (st >= 0 && r->checkpoint_every >= 0 && (uint32_t)r->checkpoint_every != p.every)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "--checkpoint-every %d: %s was written with %u; resume without it",
                          (int)r->checkpoint_every, r->resume_path, (unsigned)p.every);
    r->checkpoint_every = (int32_t)p.every;
    if (st >= 0)
        st = prepare_mesh(r, r->resume_path, err);
    if (st >= 0)
        st = resume_scene(r, err);
    if (st >= 0 && !r->quiet)
        fprintf(stderr,
                "pf-sim: resuming %s after frame %u (chunk CKPT at byte %llu) of %lld; %s\n",
                r->resume_path, (unsigned)p.frame, (unsigned long long)p.offset,
                (long long)p.frames, p.complete ? "the stream was complete" : p.cut);
    if (st >= 0)
        st = simulate(r, &ckpt, err);
    pf_stream_reader_destroy(&in);
    fclose(f);
    return st;
}

int main(int argc, char **argv)
{
    pf_cli_start_mpi(&argc, &argv);
    char **args = pf_calloc((size_t)argc + 1, sizeof *args);
    if (!args) {
        fprintf(stderr, "pf-sim: out of memory\n");
        return PF_EXIT_INPUT;
    }
    int n_args = pf_cli_without_petsc_options(argc, argv, args);
    run r;
    memset(&r, 0, sizeof r);
    r.wall0 = pf_time_seconds();
    r.cpu0 = pf_cpu_seconds();
    parse_arguments(&r, n_args, args);
    pf_error *err = &r.err;
    pf_atomic_file file = {0};
    pf_status st = r.resume_path ? run_resumed(&r, &file, err) : run_new(&r, &file, err);
    /* Close the stream even after a failed frame: the frames written stay readable. */
    pf_error finish_err = {0};
    if (r.out && pf_stream_writer_finish(r.out, &finish_err) < 0 && st >= 0) {
        *err = finish_err;
        st = finish_err.status;
    }
    bool closed = r.out && finish_err.status == PF_OK;
    pf_stream_writer_destroy(&r.out);
    if (file.f && closed && (st >= 0 || err->status == PF_ERR_NUMERIC)) {
        /* complete, or closed after a diverged frame (its frames kept, as on stdout) */
        pf_error commit_err = {0};
        if (pf_atomic_file_commit(&file, "stream", &commit_err) < 0 && st >= 0) {
            *err = commit_err;
            st = commit_err.status;
        }
    } else if (file.f && r.checkpoints > 0) {
        /* FILE.part keeps what was written (a full disk): the frames up to its last checkpoint
         * can be resumed */
        fclose(file.f);
        fprintf(stderr,
                "pf-sim: %s keeps the stream written so far; to continue it: mv %s partial.pfs; "
                "pf-sim --resume partial.pfs --output %s\n",
                file.part, file.part, r.output_path);
        pf_free(file.part);
    } else {
        pf_atomic_file_abort(&file); /* nothing to resume from: no file */
    }
    pf_mesh_release(&r.mesh);
    pf_stream_state_release(&r.input);
    pf_scene_release(&r.scene);
    pf_buffer_release(&r.checkpoint);
    if (st < 0)
        pf_cli_fail(&r.cli, err);
    pf_cli_close_stdout(r.cli.tool);
    pf_free(args);
    pf_petsc_finalize(PF_EXIT_OK);
    return PF_EXIT_OK;
}
