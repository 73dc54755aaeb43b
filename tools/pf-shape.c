/* pf-shape: generated models (a torus, a sphere, a hex box) as a pf stream, for tests and demos. */
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-shape torus [--R R] [--r r] [--segments N]\n"
    "       pf-shape sphere [--radius R] [--segments N]\n"
    "       pf-shape box [--extent X,Y,Z] [--origin X,Y,Z] [--cells NX,NY,NZ]\n"
    "\n"
    "Writes a pf stream (INFO + SURF for torus and sphere, INFO + MESH for box) to stdout.\n"
    "  torus   around the z axis, tube centre radius --R (default 1), tube radius --r (0.35),\n"
    "          2N x N segments (--segments N, default 32)\n"
    "  sphere  radius --radius (default 1), N bands x 2N segments (--segments N, default 32)\n"
    "  box     a hex grid filling [origin, origin + extent] (defaults: origin 0,0,0, extent\n"
    "          4,1,1, cells 8,2,2)\n"
    "  --help, --version\n"
    "The former spellings --res N (a grid's cell count in pf-slice and pf-voxelize) and --size\n"
    "X,Y,Z (the image size WxH in pf-render) still work, with a deprecation note on stderr.\n";

enum {
    OPT_R = 1,
    OPT_SMALL_R,
    OPT_SEGMENTS,
    OPT_RES, /* deprecated: --segments */
    OPT_RADIUS,
    OPT_EXTENT,
    OPT_SIZE, /* deprecated: --extent */
    OPT_ORIGIN,
    OPT_CELLS
};

/* One meaning per flag name across the tools: the old spelling keeps working, with a note. */
static void deprecated(const char *old, const char *now, const char *why)
{
    fprintf(stderr, "pf-shape: --%s is deprecated, use --%s (%s)\n", old, now, why);
}

static void parse_cells(const pf_cli *cli, const char *text, int32_t cells[3])
{
    double v[3];
    pf_cli_parse_vec3(cli, "cells", text, v);
    for (int i = 0; i < 3; ++i) {
        if (v[i] < 1 || v[i] > 4096 || v[i] != (double)(int32_t)v[i])
            pf_cli_usage_error(cli, "--cells expects three integers in [1, 4096], got '%s'", text);
        cells[i] = (int32_t)v[i];
    }
}

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {
        {"R", true, OPT_R},           {"r", true, OPT_SMALL_R},       {"segments", true, OPT_SEGMENTS},
        {"res", true, OPT_RES},       {"radius", true, OPT_RADIUS},   {"extent", true, OPT_EXTENT},
        {"size", true, OPT_SIZE},     {"origin", true, OPT_ORIGIN},   {"cells", true, OPT_CELLS},
        {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-shape", USAGE, argc, argv);
    const char *shape = NULL, *value;
    double R = 1, r = 0.35, radius = 1, size[3] = {4, 1, 1}, origin[3] = {0, 0, 0};
    long res = 32;
    int32_t cells[3] = {8, 2, 2};
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_R: R = pf_cli_parse_double(&cli, "R", value); break;
        case OPT_SMALL_R: r = pf_cli_parse_double(&cli, "r", value); break;
        case OPT_RADIUS: radius = pf_cli_parse_double(&cli, "radius", value); break;
        case OPT_RES:
            deprecated("res", "segments", "--res counts grid cells in pf-slice and pf-voxelize");
            /* fall through */
        case OPT_SEGMENTS: res = pf_cli_parse_long(&cli, "segments", value, 3, 4096); break;
        case OPT_SIZE:
            deprecated("size", "extent", "--size is the image size WxH in pf-render");
            /* fall through */
        case OPT_EXTENT: pf_cli_parse_vec3(&cli, "extent", value, size); break;
        case OPT_ORIGIN: pf_cli_parse_vec3(&cli, "origin", value, origin); break;
        case OPT_CELLS: parse_cells(&cli, value, cells); break;
        default:
            if (shape)
                pf_cli_usage_error(&cli, "one shape only (got '%s' and '%s')", shape, value);
            shape = value;
        }
    }
    if (!shape)
        pf_cli_usage_error(&cli, "which shape? torus, sphere or box");
    pf_error err = {0};
    pf_surface surface = {0};
    pf_mesh mesh = {0};
    pf_status s;
    bool is_mesh = false;
    if (strcmp(shape, "torus") == 0) {
        s = pf_surface_make_torus(&surface, R, r, (int32_t)(2 * res), (int32_t)res, &err);
    } else if (strcmp(shape, "sphere") == 0) {
        s = pf_surface_make_sphere(&surface, radius, (int32_t)res, (int32_t)(2 * res), &err);
    } else if (strcmp(shape, "box") == 0) {
        pf_vec3 lo = pf_v3_load(origin);
        s = pf_mesh_make_box(&mesh, lo, pf_v3_add(lo, pf_v3_load(size)), cells[0], cells[1],
                             cells[2], &err);
        is_mesh = true;
    } else {
        pf_cli_usage_error(&cli, "unknown shape '%s' (torus, sphere or box)", shape);
    }
    if (s < 0) /* the parameters were the user's: a usage error */
        pf_cli_usage_error(&cli, "%s", err.msg);

    FILE *out = pf_cli_binary_stdout(&cli);
    pf_stream_writer *w = NULL;
    s = pf_stream_writer_create(&w, out, "stdout", &err);
    if (s >= 0)
        s = pf_cli_write_info(&cli, w, &err);
    if (s >= 0)
        s = is_mesh ? pf_stream_write_mesh(w, &mesh, &err)
                    : pf_stream_write_surface(w, &surface, &err);
    if (s >= 0)
        s = pf_stream_writer_finish(w, &err);
    pf_stream_writer_destroy(&w);
    pf_mesh_release(&mesh);
    pf_surface_release(&surface);
    if (s < 0)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
