/* pf-slice: a closed surface cut into a hex grid: hexes inside, exact polyhedra at the surface. */
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-slice [SURFACE | -] [--res N | --cell H] [--origin X,Y,Z] [--merge F] [--exact]\n"
    "                [--refine N] [--up AXIS] [--scale S] [--keep-orientation] [--quiet]\n"
    "                [--repair[=F]] [--progress[=SECONDS]]\n"
    "\n"
    "Writes a pf stream with the surface (SURF) and a mesh (MESH) of the solid it bounds,\n"
    "intersected with a grid of cubes (DG paper sec. 9.2): cells inside are hexes, every cell the\n"
    "surface crosses becomes the exact polyhedron of the solid inside it (one element per\n"
    "connected piece), so the mesh's boundary is the surface itself. Neighbouring cells share\n"
    "faces. Pieces smaller than a fraction of a cell are merged into the neighbour they share\n"
    "the most face area with; merged elements may be non-convex.\n"
    "\n"
    "Real models are often open, non-manifold, self-intersecting or partly inside out. Such a\n"
    "surface is first oriented consistently and outward; if it is still not closed and manifold,\n"
    "the solid sliced is the one its generalised winding number defines (inside where it is at\n"
    "least 1/2): its boundary is rebuilt on a lattice --refine times finer than the grid, lying\n"
    "on the surface where the surface is a clean boundary and spanning holes smoothly, so the "
    "mesh\n"
    "is watertight and every element valid. Details smaller than the lattice are lost there. A\n"
    "closed, manifold, outward surface is sliced as it is.\n"
    "\n"
    "  SURFACE        a surface in any format assimp reads, or a pf stream with a\n"
    "                 SURF chunk (default: a stream on stdin; its other chunks are passed on)\n"
    "  --res N        cells along the longest side of the bounding box (default 32)\n"
    "  --cell H       cell edge length (overrides --res)\n"
    "  --origin X,Y,Z a grid point (default: the grid is centred on the bounding box)\n"
    "  --merge F      merge pieces below F times a cell's volume (default 0.05; 0: never)\n"
    "  --exact        refuse a surface that is not closed, manifold and outward\n"
    "  --refine N     lattice edges per cell edge for the winding-number boundary, 1..8 (default "
    "2)\n" PF_CLI_REPAIR_USAGE PF_CLI_IMPORT_USAGE
    "  --quiet, -q    no progress and no report on stderr\n"
    "  --progress[=S] a plain progress line every S seconds (default 5); without it, one\n"
    "                 line updated in place with the ETA on a terminal, a line every 5 s\n"
    "                 in a log (stderr not a terminal)\n"
    "\n"
    "Exit 0 ok; 1 bad input (with --exact, an open or non-manifold surface says what is wrong);\n"
    "2 bad usage.\n";

enum {
    OPT_RES = 1,
    OPT_CELL,
    OPT_ORIGIN,
    OPT_MERGE,
    OPT_QUIET,
    OPT_EXACT,
    OPT_REFINE,
    OPT_PROGRESS,
    OPT_REPAIR,
    OPT_IMPORT /* and the next two: PF_CLI_IMPORT_OPTIONS */
};

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {{"res", true, OPT_RES},
                                            {"cell", true, OPT_CELL},
                                            {"origin", true, OPT_ORIGIN},
                                            {"merge", true, OPT_MERGE},
                                            {"quiet", false, OPT_QUIET},
                                            {"exact", false, OPT_EXACT},
                                            {"refine", true, OPT_REFINE},
                                            {"progress", PF_CLI_OPTIONAL_VALUE, OPT_PROGRESS},
                                            {"repair", PF_CLI_OPTIONAL_VALUE, OPT_REPAIR},
                                            PF_CLI_IMPORT_OPTIONS(OPT_IMPORT),
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-slice", USAGE, argc, argv);
    pf_slice_params p = pf_slice_params_default();
    pf_cli_import imp = pf_cli_import_default();
    const char *path = NULL, *value;
    double plain = -1;
    bool quiet = false;
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_RES:
            pf_cli_grid_option(&cli, 'r', value, &p.grid);
            break;
        case OPT_CELL:
            pf_cli_grid_option(&cli, 'c', value, &p.grid);
            break;
        case OPT_ORIGIN:
            pf_cli_grid_option(&cli, 'o', value, &p.grid);
            break;
        case OPT_MERGE:
            p.merge = pf_cli_parse_double(&cli, "merge", value);
            if (!(p.merge >= 0 && p.merge < 1))
                pf_cli_usage_error(&cli, "--merge must be in [0, 1)");
            break;
        case OPT_QUIET:
            quiet = true;
            break;
        case OPT_EXACT:
            p.robust = false;
            break;
        case OPT_REFINE:
            p.contour_refine = (int32_t)pf_cli_parse_long(&cli, "refine", value, 1, 8);
            break;
        case OPT_PROGRESS:
            plain = pf_cli_parse_progress(&cli, value);
            break;
        case OPT_REPAIR:
            pf_cli_repair_option(&cli, value, &imp);
            break;
        case OPT_IMPORT:
        case OPT_IMPORT + 1:
        case OPT_IMPORT + 2:
            pf_cli_import_apply(&cli, id - OPT_IMPORT, value, &imp);
            break;
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
    pf_slice_stats stats;
    pf_cli_progress prog;
    double slice_cpu = 0;
    pf_cli_progress_start(&prog, "pf-slice", quiet, plain);
    p.progress = pf_cli_progress_fn;
    p.progress_ctx = &prog;
    if (st >= 0) {
        st = pf_mesh_slice(&mesh, &surface, &p, &stats, &err);
        pf_cli_progress_done(&prog);
        slice_cpu = pf_cpu_seconds() - prog.cpu0;
        if (st < 0)
            pf_cli_prefix_surface_error(path, &err);
    }
    if (st >= 0)
        st = pf_mesh_validate(&mesh, NULL, &err);
    if (st >= 0)
        st = pf_stream_write_surface(w, &surface, &err);
    if (st >= 0)
        st = pf_stream_write_mesh(w, &mesh, &err);
    if (st >= 0)
        st = pf_stream_writer_finish(w, &err);
    if (st >= 0 && !quiet)
        fprintf(stderr,
                "pf-slice: %d x %d x %d grid of cell %.6g: %d elements (%d hexes, %d tets, %d "
                "polyhedra), %d slivers merged, %d isolated, %lld splits, %.3f s (CPU %.3f s)\n",
                (int)stats.grid.n[0], (int)stats.grid.n[1], (int)stats.grid.n[2], stats.grid.h,
                (int)mesh.n_elems, (int)stats.kinds[PF_ELEM_HEX], (int)stats.kinds[PF_ELEM_TET],
                (int)stats.kinds[PF_ELEM_POLY], (int)stats.merged, (int)stats.isolated_slivers,
                (long long)stats.splits, stats.seconds, slice_cpu);
    if (st >= 0 && !quiet)
        pf_cli_report_import(&cli, &imp);
    if (st >= 0 && !quiet && stats.robust_used)
        fprintf(stderr,
                "pf-slice: robust: the surface was not closed, manifold and outward; oriented "
                "(%d triangles flipped, %d parts turned outward)%s",
                (int)stats.orient.flipped_faces, (int)stats.orient.flipped_components,
                stats.contoured ? "" : ", then sliced as it is\n");
    if (st >= 0 && !quiet && stats.contoured)
        fprintf(stderr,
                ", then its winding-number solid was sliced: boundary of %d triangles, %lld "
                "vertices on the surface, %lld across holes, %.3f s\n",
                (int)stats.contour.n_tris, (long long)stats.contour.on_surface,
                (long long)stats.contour.interpolated, stats.contour.seconds);
    pf_stream_writer_destroy(&w);
    pf_mesh_release(&mesh);
    pf_surface_release(&surface);
    if (st < 0)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
