/* Command-line plumbing shared by the pf tools. */
#define _POSIX_C_SOURCE 200809L /* isatty, fileno, mkdir */
#include "cli.h"

#include <pf/io.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h> /* strcasecmp */
#include <sys/stat.h>
#include <unistd.h>

void pf_cli_init(pf_cli *cli, const char *tool, const char *usage, int argc, char **argv)
{
    *cli = (pf_cli){.tool = tool, .usage = usage, .argc = argc, .argv = argv, .next = 1};
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--") == 0)
            break;
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(usage, stdout);
            pf_cli_close_stdout(tool);
            exit(PF_EXIT_OK);
        }
        if (strcmp(argv[i], "--version") == 0) {
            printf("%s (pf) %s\n", tool, PF_VERSION_STRING);
            pf_cli_close_stdout(tool);
            exit(PF_EXIT_OK);
        }
    }
}

void pf_cli_close_stdout(const char *tool)
{
    /* The error flag catches a failed write long ago (its errno is gone: "write error"); fflush
     * and fclose catch what was still buffered, with their errno. */
    errno = 0;
    bool ok = !ferror(stdout);
    int saved = 0;
    if (fflush(stdout) != 0 && ok) {
        ok = false;
        saved = errno;
    }
    errno = 0;
    if (fclose(stdout) != 0 && ok) {
        ok = false;
        saved = errno;
    }
    if (!ok) {
        fprintf(stderr, "%s: stdout: cannot write: %s\n", tool,
                saved ? strerror(saved) : "write error");
        exit(PF_EXIT_INPUT);
    }
}

void pf_cli_usage_error(const pf_cli *cli, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", cli->tool);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\nTry '%s --help'.\n", cli->tool);
    va_end(ap);
    exit(PF_EXIT_USAGE);
}

void pf_cli_fail(const pf_cli *cli, const pf_error *err)
{
    fprintf(stderr, "%s: %s\n", cli->tool, err->msg[0] ? err->msg : pf_status_name(err->status));
    exit(PF_EXIT_INPUT);
}

int pf_cli_next(pf_cli *cli, const pf_cli_option *options, const char **value)
{
    *value = NULL;
    if (cli->next >= cli->argc)
        return PF_CLI_END;
    const char *arg = cli->argv[cli->next++];
    if (!cli->only_positional && strcmp(arg, "--") == 0) {
        cli->only_positional = true;
        return pf_cli_next(cli, options, value);
    }
    if (!cli->only_positional && strcmp(arg, "-q") == 0) /* the one short option: --quiet */
        for (const pf_cli_option *o = options; o && o->name; ++o)
            if (strcmp(o->name, "quiet") == 0)
                return o->id;
    if (cli->only_positional || strncmp(arg, "--", 2) != 0 || strcmp(arg, "-") == 0) {
        if (!cli->only_positional && arg[0] == '-' && arg[1] != '\0')
            pf_cli_usage_error(cli, "unknown option '%s'", arg);
        *value = arg;
        return PF_CLI_POSITIONAL;
    }
    const char *name = arg + 2;
    const char *eq = strchr(name, '=');
    size_t len = eq ? (size_t)(eq - name) : strlen(name);
    for (const pf_cli_option *o = options; o && o->name; ++o) {
        if (strlen(o->name) != len || strncmp(o->name, name, len) != 0)
            continue;
        if (o->has_value != true) {
            if (eq && !o->has_value)
                pf_cli_usage_error(cli, "option '--%s' takes no value", o->name);
            *value = eq ? eq + 1 : NULL;
            return o->id;
        }
        if (eq) {
            *value = eq + 1;
        } else {
            if (cli->next >= cli->argc)
                pf_cli_usage_error(cli, "option '--%s' needs a value", o->name);
            *value = cli->argv[cli->next++];
        }
        return o->id;
    }
    pf_cli_usage_error(cli, "unknown option '%s'", arg);
}

double pf_cli_parse_double(const pf_cli *cli, const char *option, const char *text)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || errno != 0 || !isfinite(v))
        pf_cli_usage_error(cli, "--%s expects a finite number, got '%s'", option, text);
    return v;
}

pf_embed_method pf_cli_parse_embed_method(const pf_cli *cli, const char *option, const char *text)
{
    const pf_embed_method methods[] = {PF_EMBED_MLS, PF_EMBED_BARY, PF_EMBED_HARMONIC};
    for (size_t i = 0; i < sizeof methods / sizeof *methods; ++i)
        if (strcmp(text, pf_embed_method_name(methods[i])) == 0)
            return methods[i];
    pf_cli_usage_error(cli, "--%s is mls, bary or harmonic, not '%s'", option, text);
    return PF_EMBED_MLS;
}

long pf_cli_parse_long(const pf_cli *cli, const char *option, const char *text, long lo, long hi)
{
    char *end = NULL;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno != 0 || v < lo || v > hi)
        pf_cli_usage_error(cli, "--%s expects an integer in [%ld, %ld], got '%s'", option, lo, hi,
                           text);
    return v;
}

void pf_cli_parse_vec3(const pf_cli *cli, const char *option, const char *text, double out[3])
{
    const char *p = text;
    for (int i = 0; i < 3; ++i) {
        char *end = NULL;
        errno = 0;
        out[i] = strtod(p, &end);
        if (end == p || errno != 0 || !isfinite(out[i]) || *end != (i < 2 ? ',' : '\0'))
            pf_cli_usage_error(cli, "--%s expects x,y,z, got '%s'", option, text);
        p = end + 1;
    }
}

/* A frame index: decimal digits, at most UINT32_MAX. */
static bool parse_index(const char *s, size_t n, int64_t *v)
{
    if (n == 0 || n > 10)
        return false;
    int64_t x = 0;
    for (size_t i = 0; i < n; ++i) {
        if (s[i] < '0' || s[i] > '9')
            return false;
        x = 10 * x + (s[i] - '0');
    }
    *v = x;
    return x <= (int64_t)UINT32_MAX;
}

void pf_cli_parse_frames(const pf_cli *cli, const char *text, int64_t *first, int64_t *last)
{
    const char *colon = strchr(text, ':');
    size_t len = strlen(text);
    bool ok;
    *first = 0;
    *last = (int64_t)UINT32_MAX;
    if (!colon) {
        ok = parse_index(text, len, first);
        *last = *first;
    } else {
        size_t a = (size_t)(colon - text), b = len - a - 1;
        ok = len > 1 && (a == 0 || parse_index(text, a, first)) &&
             (b == 0 || parse_index(colon + 1, b, last));
    }
    if (!ok || *first > *last)
        pf_cli_usage_error(cli, "--frames expects A:B, A:, :B or A with 0 <= A <= B, got '%s'",
                           text);
}

pf_status pf_cli_open_input(const char *path, FILE **f, const char **name, pf_error *err)
{
    if (!path || strcmp(path, "-") == 0) {
        *f = stdin;
        *name = "stdin";
        return PF_OK;
    }
    *name = path;
    *f = fopen(path, "rb");
    PF_CHECK(*f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    return PF_OK;
}

void pf_cli_close_input(FILE *f)
{
    if (f && f != stdin)
        fclose(f);
}

pf_status pf_cli_make_dirs(const char *dir, pf_error *err)
{
    size_t n = strlen(dir);
    char *p = pf_alloc(n + 1);
    PF_CHECK(p, err, PF_ERR_NOMEM, "out of memory");
    memcpy(p, dir, n + 1);
    pf_status s = PF_OK;
    for (size_t i = 1; i <= n && s == PF_OK; ++i) {
        if (p[i] != '/' && p[i] != '\0')
            continue;
        char saved = p[i];
        p[i] = '\0';
        if (mkdir(p, 0777) != 0 && errno != EEXIST)
            s = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot create directory: %s",
                             p, strerror(errno));
        p[i] = saved;
    }
    pf_free(p);
    PF_TRY(s);
    struct stat st;
    PF_CHECK(stat(dir, &st) == 0 && S_ISDIR(st.st_mode), err, PF_ERR_IO, "%s: not a directory",
             dir);
    return PF_OK;
}

bool pf_cli_file_is_stream(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return false;
    pf_stream_reader *r = NULL;
    bool is_stream = pf_stream_reader_create(&r, f, path, NULL) == PF_OK;
    pf_stream_reader_destroy(&r);
    fclose(f);
    return is_stream;
}

void pf_cli_prefix_surface_error(const char *path, pf_error *err)
{
    bool from_stdin = !path || strcmp(path, "-") == 0;
    pf_error_prefix(err, "%s%s", from_stdin ? "stdin" : path,
                    from_stdin || pf_cli_file_is_stream(path) ? ": chunk SURF" : "");
}

FILE *pf_cli_binary_stdout(const pf_cli *cli)
{
    if (isatty(fileno(stdout)))
        pf_cli_usage_error(cli, "refusing to write a binary pf stream to a terminal; redirect "
                                "stdout to a file or a pipe");
    return stdout;
}

char *pf_cli_command_line(const pf_cli *cli)
{
    size_t len = 1;
    for (int i = 0; i < cli->argc; ++i)
        len += strlen(cli->argv[i]) + 1;
    char *line = pf_alloc(len);
    if (!line)
        return NULL;
    line[0] = '\0';
    for (int i = 0; i < cli->argc; ++i) {
        if (i)
            strcat(line, " ");
        strcat(line, cli->argv[i]);
    }
    return line;
}

pf_status pf_cli_write_info(const pf_cli *cli, pf_stream_writer *w, pf_error *err)
{
    char *command = pf_cli_command_line(cli);
    pf_status st =
        pf_stream_write_info(w, cli->tool, PF_VERSION_STRING, command ? command : "", err);
    pf_free(command);
    return st;
}

pf_status pf_cli_write_frame(pf_stream_writer *w, const pf_mesh *m, uint32_t index, double time,
                             const double *u, const double *von_mises, pf_error *err)
{
    /* The chunks borrow the arrays: the writer only reads them. */
    pf_frame_data f = {.mesh_id = m->id, .index = index, .time = time, .n_nodes = m->n_nodes,
                       .u = (double *)u};
    pf_stress_data s = {.mesh_id = m->id, .frame = index, .n_elems = m->n_elems,
                        .components = 1, .values = (double *)von_mises};
    PF_TRY(pf_stream_write_frame(w, &f, err));
    return pf_stream_write_stress(w, &s, err);
}

void pf_cli_report_import(const pf_cli *cli, const pf_cli_import *imp)
{
    char line[512];
    if (pf_cli_import_summary(imp, line, sizeof line))
        fprintf(stderr, "%s: import: %s\n", cli->tool, line);
    if (pf_cli_repair_summary(imp, line, sizeof line))
        fprintf(stderr, "%s: repair: %s\n", cli->tool, line);
}

bool pf_cli_show_progress(bool quiet)
{
    return !quiet && isatty(fileno(stderr));
}

void pf_cli_progress_start(pf_cli_progress *p, const char *tool, bool quiet, double plain)
{
    bool tty = isatty(fileno(stderr)) != 0;
    *p = (pf_cli_progress){.tool = tool,
                           .on = !quiet,
                           .tty = tty && plain < 0,
                           .interval = plain < 0 ? 5 : plain,
                           .wall0 = pf_time_seconds(),
                           .cpu0 = pf_cpu_seconds()};
    p->last = p->wall0;
}

double pf_cli_parse_progress(const pf_cli *cli, const char *value)
{
    if (!value)
        return 5;
    double s = pf_cli_parse_double(cli, "progress", value);
    if (s < 0)
        pf_cli_usage_error(cli, "--progress expects seconds >= 0, got '%s'", value);
    return s;
}

/* "12 s", "4 min 10 s", "2 h 5 min": an ETA needs no more. */
static void format_duration(double s, char *buf, size_t size)
{
    if (s < 60)
        snprintf(buf, size, "%.0f s", s);
    else if (s < 3600)
        snprintf(buf, size, "%d min %d s", (int)(s / 60), (int)fmod(s, 60));
    else
        snprintf(buf, size, "%d h %d min", (int)(s / 3600), (int)fmod(s / 60, 60));
}

const char *pf_cli_progress_times(const pf_cli_progress *p, char *buf, size_t size)
{
    snprintf(buf, size, "%.3g s (CPU %.3g s)", pf_time_seconds() - p->wall0,
             pf_cpu_seconds() - p->cpu0);
    return buf;
}

/* One progress line now: what, the percentage of done in total (total <= 0: none), the seconds
 * since wall0 and cpu0, and the ETA at the rate since wall0. */
static void print_line(pf_cli_progress *p, const char *what, double done, double total,
                       double wall0, double cpu0)
{
    double now = pf_time_seconds();
    p->last = now;
    char times[64], eta[64] = "";
    snprintf(times, sizeof times, "%.3g s (CPU %.3g s)", now - wall0, pf_cpu_seconds() - cpu0);
    double elapsed = now - wall0;
    if (total > 0 && done > 0 && done < total) {
        char d[32];
        format_duration(elapsed * (total - done) / done, d, sizeof d);
        snprintf(eta, sizeof eta, ", ETA %s", d);
    }
    if (total > 0)
        fprintf(stderr, "%s%s: %s%s%.0f%%, %s%s%s", p->tty ? "\r" : "", p->tool, what,
                what[0] ? ", " : "", 100 * done / total, times, eta, p->tty ? "\033[K" : "\n");
    else
        fprintf(stderr, "%s%s:%s%s, %s%s", p->tty ? "\r" : "", p->tool, what[0] ? " " : "", what,
                times, p->tty ? "\033[K" : "\n");
    p->printed = p->tty;
    fflush(stderr);
}

void pf_cli_progress_report(pf_cli_progress *p, const char *what, double done, double total)
{
    if (!p->on || pf_time_seconds() - p->last < (p->tty ? 0.1 : p->interval))
        return;
    print_line(p, what, done, total, p->wall0, p->cpu0);
}

void pf_cli_progress_event(void *user, const pf_progress_event *ev)
{
    pf_cli_progress *p = user;
    if (!p->on)
        return;
    bool start = ev->done == 0 || ev->phase != p->phase, end = ev->done >= ev->total;
    if (start) {
        p->phase = ev->phase;
        p->phase_wall0 = pf_time_seconds();
        p->phase_cpu0 = pf_cpu_seconds();
    }
    /* phases of one step (analysis, factorisation) have no share to show */
    double total = ev->total > 1 ? (double)ev->total : 0;
    /* in a log, a phase reported element by element gets a line a second at most, whatever
     * --progress=S says */
    double gap = p->tty ? 0.1 : fmax(p->interval, 1);
    if (!(p->phase_lines && (start || end)) && pf_time_seconds() - p->last < gap)
        return;
    if (start && !p->tty) { /* no times yet: the count to do */
        fprintf(stderr, "%s: %s started", p->tool, ev->phase);
        if (total > 0)
            fprintf(stderr, " (%lld)", (long long)ev->total);
        fputc('\n', stderr);
        fflush(stderr);
        p->last = pf_time_seconds();
        return;
    }
    char what[96];
    snprintf(what, sizeof what, end ? "%s done" : "%s", ev->phase);
    print_line(p, what, end ? 0 : (double)ev->done, end ? 0 : total, p->phase_wall0, p->phase_cpu0);
}

void pf_cli_progress_done(pf_cli_progress *p)
{
    if (p->printed)
        fputc('\n', stderr);
    p->printed = false;
}

void pf_cli_progress_fn(void *ctx, double done, double total)
{
    pf_cli_progress_report(ctx, "", done, total);
}

/* The SURF of a stream on f, keeping its other chunks to pass on. */
static pf_status read_stream_surface(FILE *f, const char *name, pf_surface *s, pf_stream_writer *w,
                                     pf_error *err)
{
    pf_stream_reader *r = NULL;
    PF_TRY(pf_stream_reader_create(&r, f, name, err));
    pf_status st = PF_OK;
    bool have = false;
    for (;;) {
        pf_chunk c;
        bool end = false;
        st = pf_stream_read_chunk(r, &c, &end, err);
        if (st < 0 || end)
            break;
        if (strcmp(c.tag, "SURF") == 0 && !have) {
            st = pf_stream_decode_surface(&c, s, err);
            have = st >= 0;
        } else if (w && strcmp(c.tag, "END_") != 0 && !pf_stream_tag_is_mesh_dependent(c.tag) &&
                   strcmp(c.tag, "MESH") != 0) {
            st = pf_stream_write_raw(w, &c, err);
        }
        if (st < 0)
            break;
    }
    pf_stream_reader_destroy(&r);
    if (st >= 0 && !have)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "%s: the stream has no SURF chunk to mesh", name);
    return st;
}

pf_cli_import pf_cli_import_default(void)
{
    pf_cli_import imp = {.fix = pf_surface_fix_params_default()};
    imp.fix.up = PF_UP_AUTO;
    imp.repair_params = pf_surface_repair_params_default();
    return imp;
}

void pf_cli_repair_option(const pf_cli *cli, const char *value, pf_cli_import *imp)
{
    imp->repair = true;
    if (!value)
        return;
    imp->repair_params.max_hole = pf_cli_parse_double(cli, "repair", value);
    if (!(imp->repair_params.max_hole >= 0) || !isfinite(imp->repair_params.max_hole))
        pf_cli_usage_error(cli, "--repair takes a hole size >= 0 (a fraction of the diagonal)");
}

const char *pf_cli_repair_summary(const pf_cli_import *imp, char *buf, size_t size)
{
    if (!imp || !imp->repair || !imp->applied)
        return NULL;
    const pf_surface_repair_report *r = &imp->repair_report;
    char left[96] = "";
    if (r->holes > r->holes_filled)
        snprintf(left, sizeof left, " (the largest left open: perimeter %.3g of the diagonal)",
                 r->largest_left);
    snprintf(buf, size,
             "%d vertices welded, %d degenerate and %d duplicate triangles removed, %d opposite "
             "pairs removed, %d triangles flipped and %d parts turned outward, %d of %d holes "
             "filled with %d triangles%s: %s",
             (int)r->welded, (int)r->degenerate, (int)r->duplicates, (int)r->opposite_pairs,
             (int)r->orient.flipped_faces, (int)r->orient.flipped_components, (int)r->holes_filled,
             (int)r->holes, (int)r->fill_triangles, left,
             r->closed ? "closed and manifold" : "still open or not manifold");
    return buf;
}

void pf_cli_import_apply(const pf_cli *cli, int offset, const char *value, pf_cli_import *imp)
{
    if (offset == 0) {
        if (!pf_up_axis_parse(value, &imp->fix.up))
            pf_cli_usage_error(cli, "--up is x, y, z, -x, -y, -z or auto, not '%s'", value);
        imp->up_given = imp->fix.up != PF_UP_AUTO;
    } else if (offset == 1) {
        imp->fix.scale = pf_cli_parse_double(cli, "scale", value);
        if (!(imp->fix.scale > 0) || !isfinite(imp->fix.scale))
            pf_cli_usage_error(cli, "--scale must be finite and > 0");
        imp->scale_given = true;
    } else {
        imp->fix.orient = false;
    }
}

const char *pf_cli_import_summary(const pf_cli_import *imp, char *buf, size_t size)
{
    if (!imp || !imp->applied)
        return NULL;
    const pf_surface_fix_report *r = &imp->report;
    pf_up_axis up = imp->fix.up == PF_UP_AUTO ? imp->how.up : imp->fix.up;
    const char *source = imp->up_given ? "as given" : imp->how.up_source;
    int n = snprintf(buf, size, "up %s (%s), scale %g", pf_up_axis_name(up),
                     source ? source : "the format says nothing: pf's +z", imp->fix.scale);
    if (imp->fix.orient && n >= 0 && (size_t)n < size)
        snprintf(buf + n, size - (size_t)n,
                 "; oriented: %d triangles flipped to agree with their neighbours, %d of %d parts "
                 "turned outward (volume %.6g -> %.6g)",
                 (int)r->flipped_faces, (int)r->flipped_components, (int)r->components,
                 r->volume_before, r->volume_after);
    return buf;
}

static pf_status repair(const char *path, pf_surface *s, pf_cli_import *imp, pf_error *err)
{
    if (!imp->repair)
        return PF_OK;
    pf_status st = pf_surface_repair(s, &imp->repair_params, &imp->repair_report, err);
    if (st < 0)
        pf_cli_prefix_surface_error(path, err);
    return st;
}

pf_status pf_cli_read_surface(const char *path, pf_surface *s, pf_stream_writer *w,
                              pf_cli_import *imp, pf_error *err)
{
    bool from_stream = !path || strcmp(path, "-") == 0 || pf_cli_file_is_stream(path);
    if (!from_stream) {
        if (!imp)
            return pf_import_surface(path, s, err);
        PF_TRY(pf_import_surface_fixed(path, &imp->fix, s, &imp->how, &imp->report, err));
        imp->applied = true;
        return repair(path, s, imp, err);
    }
    FILE *f;
    const char *name;
    PF_TRY(pf_cli_open_input(path, &f, &name, err));
    pf_status st = read_stream_surface(f, name, s, w, err);
    pf_cli_close_input(f);
    PF_TRY(st);
    if (!imp || (!imp->up_given && !imp->scale_given && !imp->repair))
        return PF_OK;
    imp->fix.orient = false; /* oriented when it was imported */
    imp->how = (pf_surface_import_info){"stream", false, PF_UP_Z, "a stream is pf's +z"};
    st = pf_surface_fix(s, &imp->fix, &imp->report, err);
    if (st < 0) {
        pf_cli_prefix_surface_error(path, err);
        return st;
    }
    imp->applied = true;
    return repair(path, s, imp, err);
}

void pf_cli_grid_option(const pf_cli *cli, char which, const char *value, pf_voxelize_params *p)
{
    if (which == 'r') {
        p->res = (int32_t)pf_cli_parse_long(cli, "res", value, 1, 4096);
    } else if (which == 'c') {
        p->cell = pf_cli_parse_double(cli, "cell", value);
        if (!(p->cell > 0))
            pf_cli_usage_error(cli, "--cell must be > 0");
    } else {
        double o[3];
        pf_cli_parse_vec3(cli, "origin", value, o);
        p->origin = pf_v3_load(o);
        p->has_origin = true;
    }
}
