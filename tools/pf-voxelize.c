/* pf-voxelize: the grid cells inside a surface as a hex mesh. */
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-voxelize [SURFACE | -] [--res N | --cell H] [--origin X,Y,Z]\n"
    "                   [--mode inside|overlap] [--inside auto|rays|winding] [--up AXIS]\n"
    "                   [--scale S] [--keep-orientation] [--keep-islands] [--quiet]\n"
    "\n"
    "Writes a pf stream with the surface (SURF, for embedding and rendering later) and a hex mesh\n"
    "(MESH) of the grid cells of the solid, to stdout.\n"
    "\n"
    "  SURFACE        a surface file in any format assimp reads, or a pf stream with a SURF chunk\n"
    "                 (default: a stream on stdin; its other chunks are passed on)\n"
    "  --res N        cells along the longest side of the bounding box (default 32)\n"
    "  --cell H       cell edge length (overrides --res)\n"
    "  --origin X,Y,Z a grid point (default: the grid is centred on the bounding box)\n"
    "  --mode inside  cells whose centre is inside the surface (default)\n"
    "  --mode overlap those and every cell a triangle passes through\n"
    "  --inside T     the inside test: auto (default: rays for a closed surface, else winding),\n"
    "                 rays or winding\n"
    PF_CLI_IMPORT_USAGE
    "  --keep-islands keep every part; by default only the largest set of cells connected through\n"
    "                 faces is kept (the report says how many cells were dropped)\n"
    "  --quiet        no report on stderr\n"
    "\n"
    "Inside tests: rays counts signed ray crossings (Embree) along grid rows in x, y and z, a cell\n"
    "being inside where at least two of the three directions say so, so that a small defect (a\n"
    "hole smaller than a cell, a few rows through it) does not leak along a row; winding is the\n"
    "generalised winding number (inside where it is >= 1/2), robust to holes of any size but\n"
    "O(triangles) per cell. The report says which was used.\n";

enum { OPT_RES = 1, OPT_CELL, OPT_ORIGIN, OPT_MODE, OPT_INSIDE, OPT_QUIET, OPT_ISLANDS, OPT_IMPORT };

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {{"res", true, OPT_RES},       {"cell", true, OPT_CELL},
                                            {"origin", true, OPT_ORIGIN}, {"mode", true, OPT_MODE},
                                            {"inside", true, OPT_INSIDE}, {"quiet", false, OPT_QUIET},
                                            {"keep-islands", false, OPT_ISLANDS},
                                            PF_CLI_IMPORT_OPTIONS(OPT_IMPORT),
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-voxelize", USAGE, argc, argv);
    pf_voxelize_params p = pf_voxelize_params_default();
    pf_cli_import imp = pf_cli_import_default();
    const char *path = NULL, *value;
    bool quiet = false, islands = false;
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_RES: pf_cli_grid_option(&cli, 'r', value, &p); break;
        case OPT_CELL: pf_cli_grid_option(&cli, 'c', value, &p); break;
        case OPT_ORIGIN: pf_cli_grid_option(&cli, 'o', value, &p); break;
        case OPT_MODE:
            if (strcmp(value, "inside") == 0)
                p.mode = PF_VOXEL_INSIDE;
            else if (strcmp(value, "overlap") == 0)
                p.mode = PF_VOXEL_OVERLAP;
            else
                pf_cli_usage_error(&cli, "--mode is inside or overlap, not '%s'", value);
            break;
        case OPT_INSIDE:
            if (strcmp(value, "auto") == 0)
                p.inside = PF_INSIDE_AUTO;
            else if (strcmp(value, "rays") == 0)
                p.inside = PF_INSIDE_RAYS;
            else if (strcmp(value, "winding") == 0)
                p.inside = PF_INSIDE_WINDING;
            else
                pf_cli_usage_error(&cli, "--inside is auto, rays or winding, not '%s'", value);
            break;
        case OPT_QUIET: quiet = true; break;
        case OPT_ISLANDS: islands = true; break;
        case OPT_IMPORT:
        case OPT_IMPORT + 1:
        case OPT_IMPORT + 2: pf_cli_import_apply(&cli, id - OPT_IMPORT, value, &imp); break;
        default:
            if (path)
                pf_cli_usage_error(&cli, "one input only (got '%s' and '%s')", path, value);
            path = value;
        }
    }
    FILE *out = pf_cli_binary_stdout(&cli);
    pf_error err = {0};
    pf_surface surface = {0};
    pf_mesh mesh = {0};
    pf_stream_writer *w = NULL;
    pf_status st = pf_stream_writer_create(&w, out, "stdout", &err);
    if (st >= 0)
        st = pf_cli_write_info(&cli, w, &err);
    if (st >= 0)
        st = pf_cli_read_surface(path, &surface, w, &imp, &err);
    pf_grid grid = {0};
    pf_inside_method method = PF_INSIDE_RAYS;
    double t0 = pf_time_seconds();
    if (st >= 0) {
        st = pf_mesh_voxelize(&mesh, &surface, &p, &grid, &method, &err);
        if (st < 0)
            pf_cli_prefix_surface_error(path, &err);
    }
    int32_t parts = 1, dropped = 0;
    if (st >= 0 && !islands)
        st = pf_mesh_keep_largest_part(&mesh, &parts, &dropped, &err);
    double seconds = pf_time_seconds() - t0;
    if (st >= 0)
        st = pf_stream_write_surface(w, &surface, &err);
    if (st >= 0)
        st = pf_stream_write_mesh(w, &mesh, &err);
    if (st >= 0)
        st = pf_stream_writer_finish(w, &err);
    if (st >= 0 && !quiet)
        fprintf(stderr,
                "pf-voxelize: %d x %d x %d grid of cell %.6g, %d hexes (%s test), %.3f s\n",
                (int)grid.n[0], (int)grid.n[1], (int)grid.n[2], grid.h, (int)mesh.n_elems,
                method == PF_INSIDE_RAYS ? "ray-crossing" : "winding-number", seconds);
    if (st >= 0 && !quiet && dropped > 0)
        fprintf(stderr,
                "pf-voxelize: kept the largest of %d parts, dropped %d cells in the others "
                "(--keep-islands keeps them)\n",
                (int)parts, (int)dropped);
    if (st >= 0 && !quiet)
        pf_cli_report_import(&cli, &imp);
    pf_stream_writer_destroy(&w);
    pf_mesh_release(&mesh);
    pf_surface_release(&surface);
    if (st < 0)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
