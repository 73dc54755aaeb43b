/* pf-import: a surface or a volume mesh file into a pf stream. */
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-import [--surface | --volume] [--up AXIS] [--scale S] [--keep-orientation]\n"
    "                 [--quiet] FILE\n"
    "\n"
    "Writes a pf stream with INFO and MESH (volume meshes) or SURF (surfaces) to stdout.\n"
    "\n"
    "  FILE        Gmsh .msh (v2.2 or v4.1 ASCII; tets and hexes), TetGen .node/.ele (give either\n"
    "              file or the common stem), or a surface: OBJ, PLY, STL, OFF (read by pf in\n"
    "              double precision) or any other format assimp reads (glTF, DAE, FBX, ...;\n"
    "              assimp keeps coordinates in single precision, which the report says).\n"
    "  --surface   read FILE as a surface whatever its extension\n"
    "  --volume    read FILE as a volume mesh whatever its extension\n"
    "Surfaces are turned so that their up axis is pf's +z, scaled, and oriented consistently\n"
    "outward (triangles disagreeing with their neighbours and inside-out parts flipped):\n"
    PF_CLI_IMPORT_USAGE
    "  --quiet     no report on stderr\n"
    "  --help, --version\n"
    "\n"
    "Prints a one-line report on stderr: counts, volume, and for surfaces whether they are closed\n"
    "and manifold (only closed surfaces bound a solid). Exit 0 ok, 1 bad input, 2 bad usage.\n";

enum { OPT_SURFACE = 1, OPT_VOLUME, OPT_QUIET, OPT_IMPORT };

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {{"surface", false, OPT_SURFACE},
                                            {"volume", false, OPT_VOLUME},
                                            {"quiet", false, OPT_QUIET},
                                            PF_CLI_IMPORT_OPTIONS(OPT_IMPORT),
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-import", USAGE, argc, argv);
    const char *path = NULL, *value;
    int kind = 0; /* 0 by extension, 1 surface, 2 volume */
    bool quiet = false;
    pf_cli_import imp = pf_cli_import_default();
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        if (id == OPT_SURFACE || id == OPT_VOLUME)
            kind = id == OPT_SURFACE ? 1 : 2;
        else if (id == OPT_QUIET)
            quiet = true;
        else if (id >= OPT_IMPORT && id <= OPT_IMPORT + 2)
            pf_cli_import_apply(&cli, id - OPT_IMPORT, value, &imp);
        else if (path)
            pf_cli_usage_error(&cli, "one input file only (got '%s' and '%s')", path, value);
        else
            path = value;
    }
    if (!path)
        pf_cli_usage_error(&cli, "no input file");
    if (kind == 0)
        kind = pf_import_is_volume_path(path) ? 2 : 1;

    pf_error err = {0};
    pf_mesh mesh = {0};
    pf_surface surface = {0};
    if (kind == 2) {
        if (pf_import_volume(path, &mesh, &err) < 0)
            pf_cli_fail(&cli, &err);
        /* Refuse what the simulator could not use, naming the entity, before writing anything. */
        if (pf_mesh_validate(&mesh, NULL, &err) < 0) {
            pf_error_prefix(&err, "%s: invalid mesh", path);
            pf_mesh_release(&mesh);
            pf_cli_fail(&cli, &err);
        }
    } else if (pf_cli_read_surface(path, &surface, NULL, &imp, &err) < 0) {
        pf_cli_fail(&cli, &err);
    }

    FILE *out = pf_cli_binary_stdout(&cli);
    pf_stream_writer *w = NULL;
    pf_status s = pf_stream_writer_create(&w, out, "stdout", &err);
    if (s >= 0)
        s = pf_cli_write_info(&cli, w, &err);
    if (s >= 0)
        s = kind == 2 ? pf_stream_write_mesh(w, &mesh, &err)
                      : pf_stream_write_surface(w, &surface, &err);
    if (s >= 0)
        s = pf_stream_writer_finish(w, &err);
    pf_stream_writer_destroy(&w);
    if (s >= 0 && !quiet) {
        if (kind == 2) {
            pf_mesh_stats st;
            if (pf_mesh_compute_stats(&mesh, &st, &err) >= 0)
                fprintf(stderr, "pf-import: %s: %d nodes, %d faces, %d elements (%d tets, %d hexes), "
                                "volume %.17g\n",
                        path, (int)st.n_nodes, (int)st.n_faces, (int)st.n_elems,
                        (int)st.n_by_kind[PF_ELEM_TET], (int)st.n_by_kind[PF_ELEM_HEX], st.volume);
        } else {
            pf_surface_stats st;
            if (pf_surface_compute_stats(&surface, &st, &err) >= 0)
                fprintf(stderr, "pf-import: %s: %d vertices, %d triangles, %s, %s, volume %.17g%s\n",
                        path, (int)st.n_verts, (int)st.n_tris, st.closed ? "closed" : "open",
                        st.manifold ? "manifold" : "not manifold", st.volume,
                        imp.how.single_precision ? " (read by assimp: coordinates rounded to "
                                                   "single precision; OBJ, PLY, STL and OFF are "
                                                   "read in double)"
                                                 : "");
            char line[320];
            if (pf_cli_import_summary(&imp, line, sizeof line))
                fprintf(stderr, "pf-import: %s\n", line);
        }
    }
    pf_mesh_release(&mesh);
    pf_surface_release(&surface);
    if (s < 0)
        pf_cli_fail(&cli, &err);
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
