/* Command-line plumbing shared by the pf tools: options, --help/--version, exit codes, files.
 *
 * Exit codes: 0 success, 1 bad input (message names file, chunk, byte offset or line), 2 bad usage.
 */
#ifndef PF_TOOLS_CLI_H
#define PF_TOOLS_CLI_H

#include <stdbool.h>
#include <stdio.h>

#include <pf/base.h>
#include <pf/embed.h>
#include <pf/io.h>

enum { PF_EXIT_OK = 0, PF_EXIT_INPUT = 1, PF_EXIT_USAGE = 2 };

typedef struct pf_cli_option {
    const char *name;  /* long name without "--" */
    int has_value;     /* true: takes a value, "--name VALUE" or "--name=VALUE"; false: none;
                          PF_CLI_OPTIONAL_VALUE: "--name" (value NULL) or "--name=VALUE" */
    int id;            /* returned by pf_cli_next */
} pf_cli_option;

enum { PF_CLI_OPTIONAL_VALUE = 2 };

typedef struct pf_cli {
    const char *tool;   /* "pf-info" */
    const char *usage;  /* full --help text */
    int argc;
    char **argv;
    int next;           /* index of the next argument to parse */
    bool only_positional; /* after "--" */
} pf_cli;

enum { PF_CLI_END = -1, PF_CLI_POSITIONAL = -2 };

/* Starts parsing; handles --help and --version (prints and exits 0) wherever they appear. */
void pf_cli_init(pf_cli *cli, const char *tool, const char *usage, int argc, char **argv);

/* Next option: its id (value in *value when it has one), PF_CLI_POSITIONAL with the argument in
 * *value, or PF_CLI_END. An unknown option or a missing value prints a usage error and exits 2. */
int pf_cli_next(pf_cli *cli, const pf_cli_option *options, const char **value);

/* Prints "tool: message" and a hint to --help, exits 2. */
void pf_cli_usage_error(const pf_cli *cli, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3), noreturn))
#endif
    ;

/* Prints "tool: message" from err and exits 1 (2 for PF_ERR_INVALID raised by option parsing is
 * the caller's business). */
void pf_cli_fail(const pf_cli *cli, const pf_error *err)
#if defined(__GNUC__)
    __attribute__((noreturn))
#endif
    ;

/* Parsers for option values; on failure they call pf_cli_usage_error. */
double pf_cli_parse_double(const pf_cli *cli, const char *option, const char *text);
long pf_cli_parse_long(const pf_cli *cli, const char *option, const char *text, long lo, long hi);
/* An embedding method by its name (pf_embed_method_name: mls, bary, harmonic). */
pf_embed_method pf_cli_parse_embed_method(const pf_cli *cli, const char *option,
                                          const char *text);
/* "x,y,z" */
void pf_cli_parse_vec3(const pf_cli *cli, const char *option, const char *text, double out[3]);
/* --frames A:B (inclusive), 'A:' from A on, ':B' up to B, 'A' just A; indices 0 .. 2^32 - 1 and
 * A <= B. *first and *last default to 0 and 2^32 - 1. */
void pf_cli_parse_frames(const pf_cli *cli, const char *text, int64_t *first, int64_t *last);

/* Opens a stream input: path "-" or NULL is stdin. *name is the path or "stdin" for messages. */
pf_status pf_cli_open_input(const char *path, FILE **f, const char **name, pf_error *err);
void pf_cli_close_input(FILE *f);

/* mkdir -p: creates every missing directory along dir; PF_ERR_IO naming the directory that
 * cannot be made, or dir when it is not a directory. */
pf_status pf_cli_make_dirs(const char *dir, pf_error *err);

/* True when the file at path opens and starts with the pf stream signature. */
bool pf_cli_file_is_stream(const char *path);

/* Prepends the input a surface read by pf_cli_read_surface came from to err's message ("bunny.obj",
 * "stdin: chunk SURF", "in.pfs: chunk SURF"), for errors found in the surface after reading it. */
void pf_cli_prefix_surface_error(const char *path, pf_error *err);

/* Flushes and closes stdout, and exits 1 with "tool: stdout: cannot write: reason" when any
 * write to it failed (a full disk, an I/O error): output that was lost is never reported as a
 * success. Every tool calls it on its way out after writing to stdout (text or stream). */
void pf_cli_close_stdout(const char *tool);

/* Binary output to stdout: refuses (exit 2) when stdout is a terminal. */
FILE *pf_cli_binary_stdout(const pf_cli *cli);

/* The command line joined with spaces, for INFO chunks; caller frees with pf_free. */
char *pf_cli_command_line(const pf_cli *cli);

/* True when progress should be printed: stderr is a terminal and --quiet was not given. */
bool pf_cli_show_progress(bool quiet);

/* Progress on stderr for long-running tools. On a terminal one line rewritten in place at most
 * 10 times a second; in a log (stderr not a terminal) or with plain, one line every `interval`
 * seconds (default 5) so that farm logs show the run is alive; nothing when quiet. Each report
 * gives the percentage (when the total is known), wall and CPU seconds so far, and the ETA
 * (remaining wall time at the rate so far). */
typedef struct pf_cli_progress {
    const char *tool;
    bool on, tty;
    double interval;
    double wall0, cpu0, last; /* wall and CPU seconds at the start, wall at the last report */
    bool printed;             /* a line is pending on a terminal */
    /* phases (pf_cli_progress_event) */
    bool phase_lines;          /* in a log, a line at each phase's start and end (a set-up);
                                  false: phases only feed the lines every interval */
    const char *phase;         /* the phase under way, NULL before the first */
    double phase_wall0, phase_cpu0; /* the clocks at its start */
} pf_cli_progress;

/* plain: the seconds between plain lines given by --progress[=SECONDS], or < 0 when --progress
 * was not given (then a terminal gets the line in place, a log a line every 5 s). */
void pf_cli_progress_start(pf_cli_progress *p, const char *tool, bool quiet, double plain);
/* The value of --progress[=SECONDS]: 5 when value is NULL; usage error unless a number >= 0. */
double pf_cli_parse_progress(const pf_cli *cli, const char *value);
/* what: a short label ("frame 12", "slabs"); total <= 0 when unknown (no percentage, no ETA). */
void pf_cli_progress_report(pf_cli_progress *p, const char *what, double done, double total);
/* Ends a terminal line; the next report starts a new one. */
void pf_cli_progress_done(pf_cli_progress *p);
/* A pf_progress_fn for library calls: ctx is a pf_cli_progress, labelled "done". */
void pf_cli_progress_fn(void *ctx, double done, double total);
/* A pf_progress_event_fn (pf/base.h) for library calls made of phases: user is a
 * pf_cli_progress. On a terminal the line in place names the phase, its percentage and ETA
 * (from the phase's own rate); in a log, with phase_lines, one line when a phase starts and one
 * when it ends (its wall and CPU seconds), and the phase's line every interval (at least a
 * second) in between; nothing when quiet. */
void pf_cli_progress_event(void *user, const pf_progress_event *ev);
/* Wall and CPU seconds since start, "1.23 s (CPU 0.98 s)", into buf. */
const char *pf_cli_progress_times(const pf_cli_progress *p, char *buf, size_t size);

/* ---- surface input and grid options, shared by the meshers ------------------------------------ */

/* The post-import options every tool reading a surface takes: --up AXIS, --scale S, --keep-orientation. */
typedef struct pf_cli_import {
    pf_surface_fix_params fix;
    bool up_given;    /* --up given (not auto): else the axis the file declares */
    bool scale_given;
    bool applied;     /* set by pf_cli_read_surface: the fix ran, report valid */
    pf_surface_import_info how; /* set by pf_cli_read_surface for a file: the reader it used */
    pf_surface_fix_report report;
    bool repair; /* --repair[=F] (pf-slice, pf-octree): pf_surface_repair after the fix */
    pf_surface_repair_params repair_params;
    pf_surface_repair_report repair_report; /* set when repair ran */
} pf_cli_import;

#define PF_CLI_REPAIR_USAGE                                                                       \
    "  --repair[=F]   first weld coincident vertices, remove degenerate and duplicate triangles,\n" \
    "                 orient, and fill holes whose perimeter is at most F times the bounding\n"    \
    "                 box's diagonal (default 0.5) by their least-area triangulation\n"

/* --repair[=F]: sets imp->repair and the largest hole (usage error unless F is a number >= 0). */
void pf_cli_repair_option(const pf_cli *cli, const char *value, pf_cli_import *imp);
/* What --repair did, one line into buf (NULL when it did not run). */
const char *pf_cli_repair_summary(const pf_cli_import *imp, char *buf, size_t size);

#define PF_CLI_IMPORT_USAGE                                                                     \
    "  --up AXIS      the file's up axis, turned onto pf's +z: x, y, z, -x, -y, -z or auto\n"  \
    "                 (default auto: the axis the file declares, FBX's UpAxis, +y for glTF and\n" \
    "                 Collada; z for formats that declare none, such as OBJ, PLY, STL, OFF)\n"  \
    "  --scale S      multiply coordinates by S > 0 after the turn (units; default 1)\n"          \
    "  --keep-orientation  do not make triangle orientation consistent and outward\n"

pf_cli_import pf_cli_import_default(void);
/* The option table entries for those three, ids id, id + 1, id + 2. */
#define PF_CLI_IMPORT_OPTIONS(id) {"up", true, (id)}, {"scale", true, (id) + 1}, \
                                  {"keep-orientation", false, (id) + 2}
/* Applies an import option by its table id offset (0 up, 1 scale, 2 keep-orientation). */
void pf_cli_import_apply(const pf_cli *cli, int offset, const char *value, pf_cli_import *imp);
/* "oriented: 10 triangles flipped, 1 part turned outward; up y" or NULL when nothing happened,
 * for the tools' reports, written into buf. */
const char *pf_cli_import_summary(const pf_cli_import *imp, char *buf, size_t size);

/* The surface to mesh: a file in any format assimp reads, or a pf stream (path "-", NULL or a
 * file starting with the stream signature) whose first SURF is taken and whose other chunks,
 * except meshes and what depends on them, are passed on to w. With imp (may be NULL): a file is
 * turned, scaled and oriented (pf_surface_fix); a stream's surface, already imported, only when
 * --up or --scale was given. */
pf_status pf_cli_read_surface(const char *path, pf_surface *s, pf_stream_writer *w,
                              pf_cli_import *imp, pf_error *err);

/* Writes the INFO chunk that opens every stream a tool writes: the tool's name, pf's version and
 * the command line it ran with, so that a stream says how it was made. */
pf_status pf_cli_write_info(const pf_cli *cli, pf_stream_writer *w, pf_error *err);

/* One frame of mesh m as pf-sim writes it: a FRAM of the nodal displacements u [3 n_nodes] and a
 * STRS of the elements' von Mises stress [n_elems], frame index at the simulated time. */
pf_status pf_cli_write_frame(pf_stream_writer *w, const pf_mesh *m, uint32_t index, double time,
                             const double *u, const double *von_mises, pf_error *err);

/* The "import:" and "repair:" lines of a mesher's report on stderr, for what happened only. */
void pf_cli_report_import(const pf_cli *cli, const pf_cli_import *imp);

/* The grid options --res N, --cell H, --origin X,Y,Z: which is 'r', 'c' or 'o'. */
void pf_cli_grid_option(const pf_cli *cli, char which, const char *value, pf_voxelize_params *p);

#endif
