/* pf-octree: an adaptive octree mesh of a surface, refined toward it, without hanging nodes. */
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-octree [SURFACE | -] [--depth D] [--min-depth d] [--slice] [--merge F] [--exact]\n"
    "                 [--refine N] [--up AXIS] [--scale S] [--keep-orientation] [--quiet]\n"
    "                 [--repair[=F]] [--progress[=SECONDS]]\n"
    "\n"
    "Writes a pf stream with the surface (SURF, for embedding and rendering later) and a mesh\n"
    "(MESH) of an adaptive octree over the surface's bounding cube (harmonic paper sec. 7): every\n"
    "cell is refined to depth d, and the cells the surface comes near down to depth D, so cells\n"
    "inside stay coarse and the element count grows with the surface's area, not its volume. No\n"
    "2:1 balance: where a cell meets smaller ones, its face is split into their faces and it\n"
    "becomes a polyhedron with extra nodes (coplanar faces, no hanging nodes), as the harmonic\n"
    "basis (pf-sim --method cg) needs.\n"
    "\n"
    "  SURFACE         a surface in any format assimp reads, or a pf stream with a SURF chunk\n"
    "                  (default: a stream on stdin; its other chunks are passed on)\n"
    "  --depth D       depth of the cells at the surface, 1..12 (default 5: 32 cells along the\n"
    "                  bounding cube's side, pf-slice's default grid)\n"
    "  --min-depth d   depth of the coarsest cells, 0..D (default 2)\n"
    "  --slice         cut the cells at the surface exactly, as pf-slice does (one element per\n"
    "                  connected piece of the solid in a cell): the mesh's boundary is the "
    "surface.\n"
    "                  A surface that is not closed, manifold and outward is replaced first by\n"
    "                  the boundary of its winding-number solid, as in pf-slice (see its --help)\n"
    "  --merge F       with --slice: merge pieces below F times a finest cell's volume into the\n"
    "                  neighbour they share the most face area with (default 0.05; 0: never)\n"
    "  --exact         with --slice: refuse a surface that is not closed, manifold and outward\n"
    "  --refine N      lattice edges per finest cell edge for that boundary, 1..8 (default "
    "2)\n" PF_CLI_REPAIR_USAGE PF_CLI_IMPORT_USAGE
    "  --quiet, -q     no progress and no report on stderr\n"
    "  --progress[=S]  a plain progress line every S seconds (default 5); without it, one\n"
    "                  line updated in place with the ETA on a terminal, a line every 5 s\n"
    "                  in a log (stderr not a terminal)\n"
    "\n"
    "Inside test: without --slice the elements are the cells whose centre is inside: for a closed\n"
    "surface by signed ray crossings (Embree) along rows of cell centres in x, y and z, inside\n"
    "where at least two of the three directions say so; for an open surface (holes) by the\n"
    "generalised winding number (>= 1/2), slower but robust to holes. With --slice the cut itself\n"
    "decides: a cell the surface stays away from is inside when the cut solid fills it. The "
    "report\n"
    "says which was used.\n"
    "\n"
    "Exit 0 ok; 1 bad input (an open surface with --slice --exact says what is wrong); 2 bad\n"
    "usage.\n";

enum {
    OPT_DEPTH = 1,
    OPT_MIN_DEPTH,
    OPT_SLICE,
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
    static const pf_cli_option options[] = {{"depth", true, OPT_DEPTH},
                                            {"min-depth", true, OPT_MIN_DEPTH},
                                            {"slice", false, OPT_SLICE},
                                            {"merge", true, OPT_MERGE},
                                            {"quiet", false, OPT_QUIET},
                                            {"exact", false, OPT_EXACT},
                                            {"refine", true, OPT_REFINE},
                                            {"progress", PF_CLI_OPTIONAL_VALUE, OPT_PROGRESS},
                                            {"repair", PF_CLI_OPTIONAL_VALUE, OPT_REPAIR},
                                            PF_CLI_IMPORT_OPTIONS(OPT_IMPORT),
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-octree", USAGE, argc, argv);
    pf_octree_params p = pf_octree_params_default();
    pf_cli_import imp = pf_cli_import_default();
    const char *path = NULL, *value;
    double plain = -1;
    bool quiet = false, min_given = false, merge_given = false;
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_DEPTH:
            p.depth = (int32_t)pf_cli_parse_long(&cli, "depth", value, 1, PF_OCTREE_MAX_DEPTH);
            break;
        case OPT_MIN_DEPTH:
            p.min_depth =
                (int32_t)pf_cli_parse_long(&cli, "min-depth", value, 0, PF_OCTREE_MAX_DEPTH);
            min_given = true;
            break;
        case OPT_SLICE:
            p.slice = true;
            break;
        case OPT_MERGE:
            p.merge = pf_cli_parse_double(&cli, "merge", value);
            if (!(p.merge >= 0 && p.merge < 1))
                pf_cli_usage_error(&cli, "--merge must be in [0, 1)");
            merge_given = true;
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
        case OPT_REPAIR:
            pf_cli_repair_option(&cli, value, &imp);
            break;
        case OPT_IMPORT:
        case OPT_IMPORT + 1:
        case OPT_IMPORT + 2:
            pf_cli_import_apply(&cli, id - OPT_IMPORT, value, &imp);
            break;
        case OPT_PROGRESS:
            plain = pf_cli_parse_progress(&cli, value);
            break;
        default:
            if (path)
                pf_cli_usage_error(&cli, "one input only (got '%s' and '%s')", path, value);
            path = value;
        }
    }
    if (min_given && p.min_depth > p.depth)
        pf_cli_usage_error(&cli, "--min-depth %d exceeds --depth %d", (int)p.min_depth,
                           (int)p.depth);
    if (!min_given && p.min_depth > p.depth)
        p.min_depth = p.depth; /* the default min depth for a shallow tree */
    if (merge_given && !p.slice)
        pf_cli_usage_error(&cli, "--merge applies to --slice only");
    FILE *out = pf_cli_binary_stdout(&cli);
    bool progress = pf_cli_show_progress(quiet);
    pf_error err = {0};
    pf_surface surface = {0};
    pf_mesh mesh = {0};
    pf_stream_writer *w = NULL;
    pf_status st = pf_stream_writer_create(&w, out, "stdout", &err);
    if (st >= 0)
        st = pf_cli_write_info(&cli, w, &err);
    if (st >= 0)
        st = pf_cli_read_surface(path, &surface, w, &imp, &err);
    if (st >= 0 && progress)
        fprintf(stderr, "pf-octree: %d triangles, depth %d..%d%s ...\n", (int)surface.n_tris,
                (int)p.min_depth, (int)p.depth, p.slice ? ", slicing" : "");
    pf_octree_stats stats;
    pf_cli_progress prog;
    pf_cli_progress_start(&prog, "pf-octree", quiet, plain);
    p.progress = pf_cli_progress_fn;
    p.progress_ctx = &prog;
    double octree_cpu = 0;
    if (st >= 0) {
        st = pf_mesh_octree(&mesh, &surface, &p, &stats, &err);
        pf_cli_progress_done(&prog);
        octree_cpu = pf_cpu_seconds() - prog.cpu0;
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
    if (st >= 0 && !quiet) {
        fprintf(stderr,
                "pf-octree: cube of side %.6g at (%.6g, %.6g, %.6g), finest cell %.6g: %d leaves "
                "(%d at the surface), %d elements (%d hexes, %d tets, %d polyhedra), %d cell "
                "faces split, ",
                stats.size, stats.origin.x, stats.origin.y, stats.origin.z, stats.h,
                (int)stats.leaves, (int)stats.surface_leaves, (int)mesh.n_elems,
                (int)stats.kinds[PF_ELEM_HEX], (int)stats.kinds[PF_ELEM_TET],
                (int)stats.kinds[PF_ELEM_POLY], (int)stats.split_faces);
        if (p.slice)
            fprintf(stderr, "exact cut (%d slivers merged, %d isolated, %lld splits)",
                    (int)stats.merged, (int)stats.isolated_slivers, (long long)stats.splits);
        else
            fprintf(stderr, "%s test",
                    stats.method == PF_INSIDE_RAYS ? "ray-crossing" : "winding-number");
        fprintf(stderr, ", %.3f s (CPU %.3f s)\n", stats.seconds, octree_cpu);
        fprintf(stderr, "pf-octree: whole cells by depth:");
        for (int k = 0; k <= p.depth; ++k)
            if (stats.cells_by_depth[k])
                fprintf(stderr, " %d: %d", k, (int)stats.cells_by_depth[k]);
        fprintf(stderr, "\n");
        pf_cli_report_import(&cli, &imp);
        if (stats.robust_used)
            fprintf(stderr,
                    "pf-octree: robust: the surface was not closed, manifold and outward; %s "
                    "(boundary of %d triangles, %lld vertices on the surface, %lld across "
                    "holes)\n",
                    stats.contoured ? "its winding-number solid was sliced"
                                    : "oriented, it was sliced as it is",
                    (int)stats.contour.n_tris, (long long)stats.contour.on_surface,
                    (long long)stats.contour.interpolated);
    }
    pf_stream_writer_destroy(&w);
    pf_mesh_release(&mesh);
    pf_surface_release(&surface);
    if (st < 0)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
