/* pf-basis: the numerical health of every element's shape functions (harmonic paper sec. 5). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/basis.h>
#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-basis [--json] [--sliced auto|all|off] [--accurate] [--xi X] [--edge-samples N]\n"
    "                [--grading G] [--patch-angle DEG] [--max-kernels N] [--force-mfs]\n"
    "                [FILE | -]\n"
    "\n"
    "Builds the CG shape functions of every MESH in a pf stream (default: stdin) and reports per\n"
    "element: kind (tet / hex closed forms, harmonic by the method of fundamental solutions),\n"
    "nodes, faces, kernels, collocation points, boundary L2 error (relative, a fraction: 0.01 =\n"
    "1 %), linear-reproduction error, partition-of-unity error, smallest value (undershoot when\n"
    "negative) and setup time; then a summary per mesh.\n"
    "\n"
    "  --json             one JSON object per line and element, the summary last\n"
    "  --xi X             kernel offset as a fraction of the element size (default 0.1)\n"
    "  --edge-samples N   kernel samples inside each edge (default 2)\n"
    "  --sliced WHERE     which cells get the sliced-cell settings (graded samples, smooth\n"
    "                     data on the surface patch, kernel offset 0.2): auto (default) the\n"
    "                     cells whose mesh-boundary faces form a patch, all, or off (uniform\n"
    "                     samples and per-facet data everywhere, what pf-sim uses)\n"
    "  --accurate         sliced-cell settings on every harmonic cell, xi 0.2, no kernel\n"
    "                     budget (pf_basis_params_accurate); the flags below override them\n"
    "  --grading G        growth rate of the graded spacing away from small features\n"
    "                     (default 0.2)\n"
    "  --patch-angle DEG  mesh-boundary faces of an element whose normals lie within DEG\n"
    "                     degrees of their mean form its patch (default 60)\n"
    "  --max-kernels N    kernel budget of a graded cell; 0: none (default 400)\n"
    "  --force-mfs        harmonic functions also for tets and parallelepipeds\n"
    "  --quiet            no progress on stderr\n"
    "  --help, --version\n"
    "\n"
    "Exit 1 on a damaged stream, a stream without MESH or an element the basis cannot handle\n"
    "(the message names it); 2 on bad usage.\n";

enum {
    OPT_JSON = 1,
    OPT_SLICED,
    OPT_MAXK,
    OPT_XI,
    OPT_EDGES,
    OPT_FORCE,
    OPT_QUIET,
    OPT_ACCURATE,
    OPT_GRADING,
    OPT_PATCH
};

typedef struct tool {
    bool json, quiet;
    pf_basis_params params;
    int32_t meshes;
} tool;

static void print_element(const tool *t, uint64_t mesh_id, const pf_basis *b, int32_t e)
{
    const pf_basis_elem_stats *s = &b->stats[e];
    const char *kind = pf_basis_kind_name((pf_basis_kind)b->kind[e]);
    if (t->json) {
        printf("{\"mesh\":%llu,\"element\":%d,\"kind\":\"%s\",\"nodes\":%d,\"faces\":%d,"
               "\"merged_nodes\":%d,\"kernels\":%d,\"collocation_points\":%d,"
               "\"kernels_moved\":%d,\"kernels_dropped\":%d,\"svd\":%s,"
               "\"boundary_error\":%.6g,\"linear_reproduction_error\":%.6g,"
               "\"partition_of_unity_error\":%.6g,\"min_value\":%.6g,\"setup_ms\":%.6g}\n",
               (unsigned long long)mesh_id, (int)e, kind, (int)s->n_nodes, (int)s->n_faces,
               (int)s->n_merged, (int)s->n_kernels, (int)s->n_collocation, (int)s->n_kernels_moved,
               (int)s->n_kernels_dropped, s->used_svd ? "true" : "false", s->boundary_error,
               s->linear_error, s->unity_error, s->min_value, s->setup_ms);
    } else {
        printf("%8d  %-8s %5d %5d %7d %7d  %9.3g %9.2e %9.2e %8.4f %9.3f%s\n", (int)e, kind,
               (int)s->n_nodes, (int)s->n_faces, (int)s->n_kernels, (int)s->n_collocation,
               s->boundary_error, s->linear_error, s->unity_error, s->min_value, s->setup_ms,
               b->kind[e] == PF_BASIS_HARMONIC ? "" : "  (closed form, no MFS)");
    }
}

static pf_status report_mesh(tool *t, const pf_chunk *c, pf_error *err)
{
    pf_mesh m = {0};
    PF_TRY(pf_stream_decode_mesh(c, &m, err));
    pf_basis b;
    pf_status s = pf_basis_create(&b, &m, &t->params, err);
    if (s < 0) {
        pf_error_prefix(err, "%s%schunk MESH at byte %llu", c->source ? c->source : "",
                        c->source ? ": " : "", (unsigned long long)c->offset);
        pf_mesh_release(&m);
        return s;
    }
    if (!t->json) {
        printf("MESH  at byte %llu, id %llu: %d elements\n", (unsigned long long)c->offset,
               (unsigned long long)m.id, (int)b.n_elems);
        printf("%8s  %-8s %5s %5s %7s %7s  %9s %9s %9s %8s %9s\n", "element", "kind", "nodes",
               "faces", "kernels", "colloc", "boundary", "linear", "unity", "min", "setup_ms");
    }
    for (int32_t e = 0; e < b.n_elems; ++e)
        print_element(t, m.id, &b, e);
    pf_basis_summary sum;
    s = pf_basis_summarize(&b, &sum, err);
    if (s == PF_OK) {
        if (t->json)
            printf("{\"summary\":true,\"mesh\":%llu,\"elements\":%d,\"tets\":%d,\"hexes\":%d,"
                   "\"harmonic\":%d,\"faces_mfs\":%d,\"faces_closed_form\":%d,\"kernels\":%lld,"
                   "\"collocation_points\":%lld,\"max_linear_reproduction_error\":%.6g,"
                   "\"max_partition_of_unity_error\":%.6g,\"median_boundary_error\":%.6g,"
                   "\"max_boundary_error\":%.6g,\"min_value\":%.6g,\"median_setup_ms\":%.6g,"
                   "\"max_setup_ms\":%.6g,\"total_setup_ms\":%.6g}\n",
                   (unsigned long long)m.id, (int)sum.n_elems, (int)sum.n_by_kind[PF_BASIS_TET],
                   (int)sum.n_by_kind[PF_BASIS_HEX], (int)sum.n_by_kind[PF_BASIS_HARMONIC],
                   (int)b.n_face_mfs, (int)b.n_face_closed, (long long)sum.n_kernels,
                   (long long)sum.n_collocation, sum.max_linear_error, sum.max_unity_error,
                   sum.median_boundary_error, sum.max_boundary_error, sum.min_value,
                   sum.median_setup_ms, sum.max_setup_ms, 1e3 * b.setup_seconds);
        else
            printf("summary: %d elements: %d tets and %d hexes in closed form (no MFS), %d "
                   "harmonic; faces: %d by 2D MFS, %d closed form\n"
                   "  boundary error median %.3g max %.3g; linear reproduction max %.2e; "
                   "partition of unity max %.2e; smallest value %.4f\n"
                   "  setup per harmonic element median %.3f ms, max %.3f ms; total %.1f ms\n",
                   (int)sum.n_elems, (int)sum.n_by_kind[PF_BASIS_TET],
                   (int)sum.n_by_kind[PF_BASIS_HEX], (int)sum.n_by_kind[PF_BASIS_HARMONIC],
                   (int)b.n_face_mfs, (int)b.n_face_closed, sum.median_boundary_error,
                   sum.max_boundary_error, sum.max_linear_error, sum.max_unity_error, sum.min_value,
                   sum.median_setup_ms, sum.max_setup_ms, 1e3 * b.setup_seconds);
    }
    t->meshes++;
    pf_basis_release(&b);
    pf_mesh_release(&m);
    return s;
}

static pf_status run(tool *t, FILE *f, const char *name, pf_error *err)
{
    pf_stream_reader *r = NULL;
    PF_TRY(pf_stream_reader_create(&r, f, name, err));
    pf_status s = PF_OK;
    for (;;) {
        pf_chunk c;
        bool end = false;
        s = pf_stream_read_chunk(r, &c, &end, err);
        if (s < 0 || end)
            break;
        if (strcmp(c.tag, "MESH") == 0) {
            if (pf_cli_show_progress(t->quiet))
                fprintf(stderr, "pf-basis: MESH at byte %llu...\n", (unsigned long long)c.offset);
            s = report_mesh(t, &c, err);
            if (s < 0)
                break;
        }
    }
    pf_stream_reader_destroy(&r);
    if (s >= 0 && t->meshes == 0)
        s = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__, "%s: no MESH chunk", name);
    return s;
}

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {{"json", false, OPT_JSON},
                                            {"xi", true, OPT_XI},
                                            {"edge-samples", true, OPT_EDGES},
                                            {"force-mfs", false, OPT_FORCE},
                                            {"quiet", false, OPT_QUIET},
                                            {"accurate", false, OPT_ACCURATE},
                                            {"grading", true, OPT_GRADING},
                                            {"patch-angle", true, OPT_PATCH},
                                            {"sliced", true, OPT_SLICED},
                                            {"max-kernels", true, OPT_MAXK},
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-basis", USAGE, argc, argv);
    tool t = {.params = pf_basis_params_default()};
    const char *path = NULL, *value;
    bool accurate = false;
    double xi = 0, grading = -1, patch = -1;
    int32_t edges = 0, sliced = -1;
    long maxk = -1;
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        if (id == OPT_ACCURATE)
            accurate = true;
        else if (id == OPT_GRADING) {
            grading = pf_cli_parse_double(&cli, "grading", value);
            if (!(grading > 0 && grading <= 10))
                pf_cli_usage_error(&cli, "--grading must be in (0, 10]");
        } else if (id == OPT_PATCH) {
            patch = pf_cli_parse_double(&cli, "patch-angle", value);
            if (!(patch > 0 && patch < 90))
                pf_cli_usage_error(&cli, "--patch-angle must be in (0, 90)");
        } else if (id == OPT_SLICED) {
            sliced = strcmp(value, "auto") == 0  ? PF_BASIS_SLICED_AUTO
                     : strcmp(value, "all") == 0 ? PF_BASIS_SLICED_ALL
                     : strcmp(value, "off") == 0 ? PF_BASIS_SLICED_OFF
                                                 : -1;
            if (sliced < 0)
                pf_cli_usage_error(&cli, "--sliced must be auto, all or off (got '%s')", value);
        } else if (id == OPT_MAXK)
            maxk = pf_cli_parse_long(&cli, "max-kernels", value, 0, 1000000);
        else if (id == OPT_JSON)
            t.json = true;
        else if (id == OPT_QUIET)
            t.quiet = true;
        else if (id == OPT_FORCE)
            t.params.force_mfs = true;
        else if (id == OPT_XI) {
            xi = pf_cli_parse_double(&cli, "xi", value);
            if (!(xi > 0 && xi <= 1))
                pf_cli_usage_error(&cli, "--xi must be in (0, 1]");
        } else if (id == OPT_EDGES)
            edges = (int32_t)pf_cli_parse_long(&cli, "edge-samples", value, 1, 64);
        else if (path)
            pf_cli_usage_error(&cli, "one input only (got '%s' and '%s')", path, value);
        else
            path = value;
    }
    bool force = t.params.force_mfs;
    if (accurate)
        t.params = pf_basis_params_accurate();
    t.params.force_mfs = force;
    if (xi > 0)
        t.params.xi = xi;
    if (edges > 0)
        t.params.edge_samples = edges;
    if (grading > 0)
        t.params.grading = grading;
    if (patch > 0)
        t.params.patch_angle = patch;
    if (sliced >= 0)
        t.params.sliced = (pf_basis_sliced)sliced;
    if (maxk >= 0)
        t.params.max_kernels = maxk > 0 ? (int32_t)maxk : -1;
    pf_error err = {0};
    FILE *f;
    const char *name;
    if (pf_cli_open_input(path, &f, &name, &err) < 0)
        pf_cli_fail(&cli, &err);
    pf_status s = run(&t, f, name, &err);
    pf_cli_close_input(f);
    if (s < 0) {
        fflush(stdout);
        pf_cli_fail(&cli, &err);
    }
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
