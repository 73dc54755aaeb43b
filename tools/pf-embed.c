/* pf-embed: embedding weights (WGHT) of the stream's surface in its simulation mesh. */
#include <string.h>

#include <pf/embed.h>
#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-embed [--method mls|bary|harmonic] [--surface FILE] [--quiet] [FILE | -]\n"
    "\n"
    "Reads a pf stream with a MESH and the SURF the mesher passed on, and writes the stream on "
    "with\n"
    "a WGHT chunk (the sparse map from the mesh's nodal displacements to the surface's vertices)\n"
    "right after the MESH / SURF it belongs to. Every other chunk is passed on; earlier WGHT "
    "chunks\n"
    "are replaced.\n"
    "\n"
    "  FILE            the input stream (default: stdin)\n"
    "  --method mls    (default) moving least squares, linear basis, C1-truncated Gaussian "
    "weights\n"
    "                  whose radius is twice the longest mesh edge at each node (grown where the\n"
    "                  support is too small or flat for an affine fit): smooth across elements\n"
    "  --method bary   the element's shape functions: linear on tets, trilinear on hexes, mean\n"
    "                  value coordinates on other polyhedra: continuous, not smooth\n"
    "  --method harmonic  as bary, but other polyhedra use the CG method's harmonic shape\n"
    "                  functions (MFS, as pf-basis reports them), so the surface moves exactly\n"
    "                  with a CG simulation; continuous to their boundary error only\n"
    "  --surface FILE  embed this surface (any format assimp reads, or a stream's first SURF)\n"
    "                  instead of the stream's; it is written to the stream as its SURF\n"
    "  --quiet         no summary on stderr\n"
    "\n"
    "Every method reproduces affine displacements exactly. Surface vertices outside every element\n"
    "are attached to the nearest one and counted in a warning.\n";

enum { OPT_METHOD = 1, OPT_SURFACE, OPT_QUIET };

typedef struct run {
    pf_cli cli;
    pf_embed_params params;
    const char *input;
    const char *surface_path;
    bool quiet;
    pf_mesh mesh;
    pf_surface surface;
    bool have_mesh, have_surface;
    pf_stream_writer *out;
    const char *in_name;
} run;

static void parse_arguments(run *r, int argc, char **argv)
{
    static const pf_cli_option options[] = {{"method", true, OPT_METHOD},
                                            {"surface", true, OPT_SURFACE},
                                            {"quiet", false, OPT_QUIET},
                                            {NULL, false, 0}};
    pf_cli_init(&r->cli, "pf-embed", USAGE, argc, argv);
    r->params = pf_embed_params_default();
    const char *value;
    for (int id; (id = pf_cli_next(&r->cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_METHOD:
            r->params.method = pf_cli_parse_embed_method(&r->cli, "method", value);
            break;
        case OPT_SURFACE:
            r->surface_path = value;
            break;
        case OPT_QUIET:
            r->quiet = true;
            break;
        default:
            if (r->input)
                pf_cli_usage_error(&r->cli, "one input only (got '%s' and '%s')", r->input, value);
            r->input = value;
        }
    }
}

/* The first SURF of a stream file. */
static pf_status read_stream_surface(const char *path, pf_surface *s, pf_error *err)
{
    FILE *f;
    const char *name;
    PF_TRY(pf_cli_open_input(path, &f, &name, err));
    pf_stream_reader *rd = NULL;
    pf_status st = pf_stream_reader_create(&rd, f, name, err);
    bool have = false;
    while (st >= 0 && !have) {
        pf_chunk c;
        bool end = false;
        st = pf_stream_read_chunk(rd, &c, &end, err);
        if (st < 0 || end)
            break;
        if (strcmp(c.tag, "SURF") == 0) {
            st = pf_stream_decode_surface(&c, s, err);
            have = st >= 0;
        }
    }
    pf_stream_reader_destroy(&rd);
    pf_cli_close_input(f);
    if (st >= 0 && !have)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__, "%s: no SURF chunk", path);
    return st;
}

static pf_status load_surface_option(run *r, pf_error *err)
{
    pf_status st = pf_cli_file_is_stream(r->surface_path)
                       ? read_stream_surface(r->surface_path, &r->surface, err)
                       : pf_import_surface(r->surface_path, &r->surface, err);
    if (st < 0)
        return st;
    r->have_surface = true;
    return pf_stream_write_surface(r->out, &r->surface, err);
}

static void report(const run *r, const pf_embed_stats *st)
{
    if (st->n_outside > 0)
        fprintf(stderr,
                "pf-embed: warning: %d of %d surface vertices lie outside every element (up to "
                "%.3g away); attached to the nearest element\n",
                (int)st->n_outside, (int)st->n_verts, st->max_outside);
    if (r->quiet)
        return;
    fprintf(stderr,
            "pf-embed: %s weights of %d vertices in mesh %llu (%d nodes, %d elements): %lld "
            "entries (%.1f per vertex)",
            pf_embed_method_name(r->params.method), (int)st->n_verts,
            (unsigned long long)r->mesh.id, (int)r->mesh.n_nodes, (int)r->mesh.n_elems,
            (long long)st->nnz, st->mean_row);
    if (r->params.method == PF_EMBED_MLS)
        fprintf(stderr, ", %d supports grown", (int)st->n_grown);
    else
        fprintf(stderr, "; in tets %d, hexes %d, polyhedra %d", (int)st->n_by_kind[PF_ELEM_TET],
                (int)st->n_by_kind[PF_ELEM_HEX], (int)st->n_by_kind[PF_ELEM_POLY]);
    if (r->params.method == PF_EMBED_HARMONIC)
        fprintf(stderr, "; harmonic functions of %d polyhedra in %.3f s", (int)st->n_harmonic,
                st->basis_seconds);
    fprintf(stderr, "; %.3f s\n", st->seconds);
}

static pf_status emit_weights(run *r, pf_error *err)
{
    pf_weights w = {0};
    pf_embed_stats st;
    PF_TRY(pf_embed_compute(&r->mesh, &r->surface, &r->params, &w, &st, err));
    pf_status s = pf_stream_write_weights(r->out, &w, err);
    pf_weights_release(&w);
    if (s >= 0)
        report(r, &st);
    return s;
}

static pf_status take_mesh(run *r, const pf_chunk *c, pf_error *err)
{
    pf_mesh_release(&r->mesh);
    r->have_mesh = false;
    PF_TRY(pf_stream_decode_mesh(c, &r->mesh, err));
    pf_status st = pf_mesh_validate(&r->mesh, NULL, err);
    if (st >= 0)
        st = pf_mesh_derive(&r->mesh, err);
    if (st < 0) {
        pf_error_prefix(err, "%s: chunk MESH at byte %llu", r->in_name,
                        (unsigned long long)c->offset);
        return st;
    }
    r->have_mesh = true;
    return PF_OK;
}

/* Passes the input on, the WGHT of the latest MESH and SURF after whichever of them came last. */
static pf_status copy_and_embed(run *r, pf_stream_reader *in, pf_error *err)
{
    for (;;) {
        pf_chunk c;
        bool end = false;
        PF_TRY(pf_stream_read_chunk(in, &c, &end, err));
        if (end)
            return PF_OK;
        if (!strcmp(c.tag, "END_") || !strcmp(c.tag, "WGHT"))
            continue;
        bool is_mesh = !strcmp(c.tag, "MESH"), is_surface = !strcmp(c.tag, "SURF");
        if (is_surface && r->surface_path)
            continue; /* replaced by --surface */
        if (is_mesh)
            PF_TRY(take_mesh(r, &c, err));
        if (is_surface) {
            pf_surface_release(&r->surface);
            r->have_surface = false;
            PF_TRY(pf_stream_decode_surface(&c, &r->surface, err));
            r->have_surface = true;
        }
        PF_TRY(pf_stream_write_raw(r->out, &c, err));
        if ((is_mesh || is_surface) && r->have_mesh && r->have_surface)
            PF_TRY(emit_weights(r, err));
    }
}

int main(int argc, char **argv)
{
    run r;
    memset(&r, 0, sizeof r);
    parse_arguments(&r, argc, argv);
    pf_error err = {0};
    FILE *in_file = NULL;
    if (pf_cli_open_input(r.input, &in_file, &r.in_name, &err) < 0)
        pf_cli_fail(&r.cli, &err);
    FILE *out = pf_cli_binary_stdout(&r.cli);
    pf_stream_reader *in = NULL;
    pf_status st = pf_stream_reader_create(&in, in_file, r.in_name, &err);
    if (st >= 0)
        st = pf_stream_writer_create(&r.out, out, "stdout", &err);
    if (st >= 0)
        st = pf_cli_write_info(&r.cli, r.out, &err);
    if (st >= 0 && r.surface_path)
        st = load_surface_option(&r, &err);
    if (st >= 0)
        st = copy_and_embed(&r, in, &err);
    if (st >= 0 && !r.have_mesh)
        st = pf_error_set(&err, PF_ERR_INVALID, __FILE__, __LINE__, "%s: no MESH chunk to embed in",
                          r.in_name);
    if (st >= 0 && !r.have_surface)
        st = pf_error_set(&err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "%s: no SURF chunk to embed (give one with --surface)", r.in_name);
    if (st >= 0)
        st = pf_stream_writer_finish(r.out, &err);
    pf_stream_writer_destroy(&r.out);
    pf_stream_reader_destroy(&in);
    pf_cli_close_input(in_file);
    pf_mesh_release(&r.mesh);
    pf_surface_release(&r.surface);
    if (st < 0)
        pf_cli_fail(&r.cli, &err);
    pf_cli_close_stdout(r.cli.tool);
    return PF_EXIT_OK;
}
