/* pf-cut: offline cuts of a stream's mesh: through planes (pf_mesh_cut), or by a closed surface
 * (pf_mesh_clip_surface: keep its inside or its outside). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <pf/cut.h>
#include <pf/embed.h>
#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-cut [FILE | -] [--plane PX,PY,PZ,NX,NY,NZ ...]\n"
    "              [--surface KNIFE [--keep inside|outside]] [--merge F]\n"
    "              [--embed mls|bary|harmonic] [--output FILE] [--stats FILE] [--quiet]\n"
    "              [--up AXIS] [--scale S] [--keep-orientation]\n"
    "\n"
    "Cuts the mesh (the latest MESH) of a pf stream before a simulation and writes the\n"
    "stream on with the cut mesh:\n"
    "  pf-slice bunny.obj | pf-cut --plane 0,0,0.1,0,0,1 | pf-sim scene.json\n"
    "  pf-shape box --extent 1,1,1 --cells 12,12,12 | pf-cut --surface knife.obj > out.pfs\n"
    "\n"
    "  FILE           the input stream (default: stdin)\n"
    "  --plane P,N    cut through the plane of point P and normal N (six numbers): every\n"
    "                 element the plane crosses or touches is split by it, and the material\n"
    "                 is separated across it (the faces on the plane become boundary faces\n"
    "                 of both sides, their nodes duplicated), so the mesh may fall into\n"
    "                 several bodies. Repeatable; the planes are applied in order. Pieces\n"
    "                 below the sliver fraction are not made (the element stays whole on\n"
    "                 one side) and a body below it is dropped, its volume reported. The\n"
    "                 faces the cuts opened form the mesh's face group \"cut\" (GRPS chunk),\n"
    "                 which pf-sim and pf-render read\n"
    "  --surface KNIFE  keep every element's intersection with the inside of the closed\n"
    "                 surface KNIFE (any format pf-import reads, or a stream's first SURF):\n"
    "                 elements wholly inside stay as they are, elements outside are dropped,\n"
    "                 crossed ones become their exact parts (they must be convex: tets,\n"
    "                 hexes), slivers merged into a neighbour; the DG paper's bunny cut out\n"
    "                 of a cube. Applied before the planes\n"
    "  --keep inside|outside  which side of KNIFE to keep (default inside)\n"
    "  --merge F      the sliver fraction of an element's volume, in (0, 1) (default 0.05)\n"
    "  --embed M      how the cut embedded surface's new weights are computed: mls\n"
    "                 (default), bary or harmonic, as pf-embed's --method\n"
    "  --drop-surface do not cut the embedded surface: drop SURF and WGHT\n" PF_CLI_IMPORT_USAGE
    "                 (these three apply to KNIFE)\n"
    "  --output FILE  write the stream to FILE (through FILE.part, renamed when complete)\n"
    "                 instead of stdout\n"
    "  --stats FILE   write what was done as JSON to FILE (docs/cut.md)\n"
    "  --quiet        no summary on stderr\n"
    "\n"
    "The stream's embedded surface (SURF) is cut by the planes too: its triangles are split\n"
    "on the opened faces, its vertices there duplicated per side, the cut capped, and its\n"
    "weights (WGHT) recomputed so that no vertex moves with material across the cut. After\n"
    "--surface (or with --drop-surface) the old SURF and WGHT are dropped (pf-render then\n"
    "draws the mesh's boundary). The stream's other chunks are passed on; frames, stress\n"
    "and checkpoints of the old mesh are dropped.\n"
    "\n"
    "Exit 0 ok; 1 bad input (the message names the file, chunk or element); 2 bad usage.\n";

enum {
    OPT_PLANE = 1,
    OPT_SURFACE,
    OPT_KEEP,
    OPT_MERGE,
    OPT_EMBED,
    OPT_DROP_SURFACE,
    OPT_OUTPUT,
    OPT_STATS,
    OPT_QUIET,
    OPT_IMPORT /* and the next two: PF_CLI_IMPORT_OPTIONS */
};

typedef struct run {
    pf_cli cli;
    const char *input, *output, *stats_path, *knife_path;
    pf_plane *planes;
    int32_t n_planes;
    pf_clip_params clip;
    double min_fraction;
    bool quiet;
    pf_cli_import imp;
    const char *in_name;
    pf_stream_state state;  /* the input's latest MESH (with its groups), SURF and WGHT */
    int64_t dropped_chunks; /* FRAM, STRS, CKPT of the old mesh */
    pf_mesh mesh;           /* the mesh being cut */
    pf_surface surf;        /* the embedded surface being cut, and its weights */
    pf_weights weights;
    bool have_surf, surf_dropped, drop_surface;
    pf_embed_params embed;
    pf_surface_cut_stats surf_stats; /* of the embedded surface's cut */
    /* what was done */
    int32_t in_elems, in_nodes;
    double in_volume;
    bool clipped;
    pf_clip_stats clip_stats;
    int32_t split, snapped, opened, duplicated, bodies, dropped_bodies;
    double dropped_volume;
    double wall0, cpu0;
} run;

/* "px,py,pz,nx,ny,nz": six finite numbers, a normal that is not zero. */
static pf_plane parse_plane(const pf_cli *cli, const char *text)
{
    double v[6];
    const char *p = text;
    for (int i = 0; i < 6; ++i) {
        char *end = NULL;
        v[i] = strtod(p, &end);
        if (end == p || !isfinite(v[i]) || *end != (i < 5 ? ',' : '\0'))
            pf_cli_usage_error(cli,
                               "--plane expects six numbers PX,PY,PZ,NX,NY,NZ (a point and a "
                               "normal), got '%s'",
                               text);
        p = end + 1;
    }
    pf_vec3 n = pf_v3(v[3], v[4], v[5]);
    if (!(pf_v3_norm(n) > 0) || !isfinite(pf_v3_norm(n)))
        pf_cli_usage_error(cli, "--plane '%s': the normal is zero", text);
    return pf_plane_from_point_normal(pf_v3(v[0], v[1], v[2]), n);
}

static void parse_arguments(run *r, int argc, char **argv)
{
    static const pf_cli_option options[] = {{"plane", true, OPT_PLANE},
                                            {"surface", true, OPT_SURFACE},
                                            {"keep", true, OPT_KEEP},
                                            {"merge", true, OPT_MERGE},
                                            {"embed", true, OPT_EMBED},
                                            {"drop-surface", false, OPT_DROP_SURFACE},
                                            {"output", true, OPT_OUTPUT},
                                            {"stats", true, OPT_STATS},
                                            {"quiet", false, OPT_QUIET},
                                            PF_CLI_IMPORT_OPTIONS(OPT_IMPORT),
                                            {NULL, false, 0}};
    pf_cli_init(&r->cli, "pf-cut", USAGE, argc, argv);
    r->imp = pf_cli_import_default();
    r->embed = pf_embed_params_default();
    bool keep_given = false;
    const char *value;
    for (int id; (id = pf_cli_next(&r->cli, options, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_PLANE: {
            pf_plane *p = pf_realloc_array(r->planes, (size_t)r->n_planes + 1, sizeof *p);
            if (!p)
                pf_cli_usage_error(&r->cli, "out of memory");
            r->planes = p;
            r->planes[r->n_planes++] = parse_plane(&r->cli, value);
            break;
        }
        case OPT_SURFACE:
            r->knife_path = value;
            break;
        case OPT_KEEP:
            if (strcmp(value, "inside") == 0)
                r->clip.keep = PF_CLIP_INSIDE;
            else if (strcmp(value, "outside") == 0)
                r->clip.keep = PF_CLIP_OUTSIDE;
            else
                pf_cli_usage_error(&r->cli, "--keep is inside or outside, not '%s'", value);
            keep_given = true;
            break;
        case OPT_MERGE:
            r->min_fraction = pf_cli_parse_double(&r->cli, "merge", value);
            if (!(r->min_fraction > 0 && r->min_fraction < 1))
                pf_cli_usage_error(&r->cli, "--merge must be in (0, 1)");
            break;
        case OPT_EMBED:
            r->embed.method = pf_cli_parse_embed_method(&r->cli, "embed", value);
            break;
        case OPT_DROP_SURFACE:
            r->drop_surface = true;
            break;
        case OPT_OUTPUT:
            r->output = value;
            break;
        case OPT_STATS:
            r->stats_path = value;
            break;
        case OPT_QUIET:
            r->quiet = true;
            break;
        case OPT_IMPORT:
        case OPT_IMPORT + 1:
        case OPT_IMPORT + 2:
            pf_cli_import_apply(&r->cli, id - OPT_IMPORT, value, &r->imp);
            break;
        default:
            if (r->input)
                pf_cli_usage_error(&r->cli, "one input only (got '%s' and '%s')", r->input, value);
            r->input = value;
        }
    }
    if (!r->knife_path && r->n_planes == 0)
        pf_cli_usage_error(&r->cli, "nothing to cut with: give --plane or --surface");
    if (keep_given && !r->knife_path)
        pf_cli_usage_error(&r->cli, "--keep needs --surface");
    r->clip.min_fraction = r->min_fraction;
}

/* Passes the input on to out, except what the new mesh replaces; keeps MESH, GRPS, SURF, WGHT. */
static pf_status read_input(run *r, pf_stream_reader *in, pf_stream_writer *out, pf_error *err)
{
    for (;;) {
        pf_chunk c;
        bool end = false;
        PF_TRY(pf_stream_read_chunk(in, &c, &end, err));
        if (end)
            return PF_OK;
        if (!strcmp(c.tag, "MESH") || !strcmp(c.tag, "GRPS") || !strcmp(c.tag, "SURF") ||
            !strcmp(c.tag, "WGHT")) {
            PF_TRY(pf_stream_state_take(&r->state, &c, err));
            continue;
        }
        if (!strcmp(c.tag, "END_"))
            continue;
        if (pf_stream_tag_is_mesh_dependent(c.tag)) {
            r->dropped_chunks++;
            continue;
        }
        PF_TRY(pf_stream_write_raw(out, &c, err));
    }
}

/* The mesh by the knife's inside or outside. */
static pf_status clip(run *r, pf_error *err)
{
    pf_surface knife = {0};
    pf_status st = pf_cli_read_surface(r->knife_path, &knife, NULL, &r->imp, err);
    pf_mesh out = {0};
    if (st >= 0) {
        st = pf_mesh_clip_surface(&r->mesh, &knife, &r->clip, &out, &r->clip_stats, err);
        if (st < 0)
            pf_error_prefix(err, "--surface %s", r->knife_path);
    }
    pf_surface_release(&knife);
    if (st < 0)
        return st;
    pf_mesh_release(&r->mesh);
    r->mesh = out;
    r->clipped = true;
    return PF_OK;
}

/* *opened (faces of the mesh before the cut, 1: opened by an earlier plane of this run) carried
 * to the mesh after it, with the faces this cut opened. */
static pf_status carry_opened(const pf_mesh *before, const pf_mesh *after, const pf_cut_result *res,
                              int32_t **opened, pf_error *err)
{
    int32_t *now = pf_calloc((size_t)after->n_faces + 1, sizeof *now);
    PF_CHECK(now, err, PF_ERR_NOMEM, "out of memory for %d face labels", (int)after->n_faces);
    pf_status st = *opened ? pf_mesh_carry_face_label(after, before, res->parent, NULL,
                                                      res->face_src, *opened, now, err)
                           : PF_OK;
    for (int32_t f = 0; f < after->n_faces; ++f)
        now[f] = now[f] || res->opened[f];
    pf_free(*opened);
    *opened = now;
    return st;
}

/* One plane through the whole mesh: every element it crosses or touches and their neighbours
 * are requested, so that where the sliver rule leaves an element whole on one side, the crack
 * follows its face to the neighbour on the other side. *cut_face carried from cut to cut (with
 * the mesh's earlier "cut" group), and, when there is an embedded surface to cut, *opened: the
 * faces the planes of this run opened so far. */
static pf_status cut_plane(run *r, int32_t k, uint8_t **cut_face, int32_t **opened, pf_error *err)
{
    pf_mesh *m = &r->mesh;
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    double tol = 1e-9 * pf_v3_norm(pf_v3_sub(hi, lo));
    pf_cut_request *req = pf_alloc_array((size_t)m->n_elems + 1, sizeof *req);
    uint8_t *touch = pf_calloc((size_t)m->n_elems + 1, 1);
    if (!req || !touch) {
        pf_free(req), pf_free(touch);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    for (int32_t e = 0; e < m->n_elems; ++e) {
        double dlo = INFINITY, dhi = -INFINITY;
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t i = m->face_offsets[f]; i < m->face_offsets[f + 1]; ++i) {
                const double *x = m->x + 3 * (size_t)m->face_nodes[i];
                double d = pf_plane_signed_distance(r->planes[k], pf_v3(x[0], x[1], x[2]));
                dlo = fmin(dlo, d), dhi = fmax(dhi, d);
            }
        }
        touch[e] = dlo <= tol && dhi >= -tol;
    }
    int32_t n = 0, missed = 0; /* neighbours the plane misses: pf_mesh_cut counts them snapped */
    for (int32_t e = 0; e < m->n_elems; ++e) {
        bool near = touch[e];
        for (int64_t q = m->elem_offsets[e]; !near && q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
            near = (a >= 0 && touch[a]) || (b >= 0 && touch[b]);
        }
        if (near)
            req[n++] = (pf_cut_request){e, r->planes[k]};
        missed += near && !touch[e];
    }
    pf_free(touch);
    pf_cut_params p = {.min_fraction = r->min_fraction, .src_cut_face = *cut_face};
    pf_mesh out = {0};
    pf_cut_result res = {0};
    pf_status st = pf_mesh_cut(m, req, n, &p, &out, &res, err);
    pf_free(req);
    if (st >= 0 && r->have_surf)
        st = carry_opened(m, &out, &res, opened, err);
    if (st < 0) {
        pf_error_prefix(err, "--plane %d", (int)k + 1);
        pf_cut_result_release(&res);
        pf_mesh_release(&out);
        return st;
    }
    r->split += res.n_split;
    r->snapped += res.n_snapped - missed;
    r->opened += res.n_opened;
    r->duplicated += res.n_duplicated;
    r->bodies = res.n_bodies;
    r->dropped_bodies += res.n_dropped;
    r->dropped_volume += res.dropped_volume;
    pf_free(*cut_face);
    *cut_face = res.cut_face;
    res.cut_face = NULL;
    pf_cut_result_release(&res);
    pf_mesh_release(m);
    *m = out;
    return PF_OK;
}

/* The embedded surface along every face the planes of this run opened (opened), in one cut after
 * the last plane, as pf-sim cuts it: where a crack bends from one plane onto another, the caps
 * of both meet at the crease as one surface (cut plane by plane, the later plane has to split
 * the earlier caps). Faces of earlier runs (cut_face also holds them) were cut then. */
static pf_status cut_surface(run *r, uint8_t *cut_face, const int32_t *opened, pf_error *err)
{
    uint8_t *here = pf_calloc((size_t)r->mesh.n_faces + 1, 1);
    PF_CHECK(here, err, PF_ERR_NOMEM, "out of memory for %d face flags", (int)r->mesh.n_faces);
    for (int32_t f = 0; f < r->mesh.n_faces; ++f)
        here[f] = opened[f] != 0;
    pf_cut_result all = {.opened = here, .cut_face = cut_face};
    pf_surface cut_surf = {0};
    pf_weights cut_w = {0};
    pf_status st =
        pf_surface_cut(&r->surf, &r->mesh, &all, &r->embed, &cut_surf, &cut_w, &r->surf_stats, err);
    pf_free(here);
    if (st < 0) {
        pf_error_prefix(err, "the embedded surface (--drop-surface cuts the mesh alone)");
        return st;
    }
    pf_surface_release(&r->surf);
    pf_weights_release(&r->weights);
    r->surf = cut_surf;
    r->weights = cut_w;
    return PF_OK;
}

static pf_status cut(run *r, pf_error *err)
{
    PF_CHECK(r->state.have_mesh, err, PF_ERR_INVALID, "%s: no MESH chunk to cut", r->in_name);
    pf_status st = pf_mesh_copy(&r->mesh, &r->state.mesh, err);
    if (st >= 0)
        st = pf_mesh_validate(&r->mesh, NULL, err);
    if (st >= 0)
        st = pf_mesh_derive(&r->mesh, err);
    if (st < 0) {
        pf_error_prefix(err, "%s: chunk MESH", r->in_name);
        return st;
    }
    r->in_elems = r->mesh.n_elems;
    r->in_nodes = r->mesh.n_nodes;
    r->in_volume = pf_mesh_volume(&r->mesh);
    if (r->knife_path)
        PF_TRY(clip(r, err));
    if (r->knife_path || r->drop_surface) {
        r->surf_dropped = r->state.have_surface;
    } else if (r->state.have_surface) {
        const pf_surface *in = &r->state.surface;
        PF_TRY(pf_surface_alloc(&r->surf, in->n_verts, in->n_tris, err));
        r->surf.id = in->id;
        memcpy(r->surf.x, in->x, 3 * (size_t)in->n_verts * sizeof *in->x);
        memcpy(r->surf.tri, in->tri, 3 * (size_t)in->n_tris * sizeof *in->tri);
        if (in->tri_part) {
            PF_CHECK(PF_ALLOC_N(r->surf.tri_part, in->n_tris), err, PF_ERR_NOMEM, "out of memory");
            memcpy(r->surf.tri_part, in->tri_part, (size_t)in->n_tris);
        }
        r->have_surf = true;
    }
    uint8_t *cut_face = NULL;
    int32_t *opened = NULL;
    for (int32_t k = 0; st >= 0 && k < r->n_planes; ++k)
        st = cut_plane(r, k, &cut_face, &opened, err);
    if (st >= 0 && r->have_surf && opened)
        st = cut_surface(r, cut_face, opened, err);
    pf_free(cut_face);
    pf_free(opened);
    return st;
}

static void report(const run *r)
{
    if (r->quiet)
        return;
    char times[64];
    pf_cli_progress p = {.wall0 = r->wall0, .cpu0 = r->cpu0};
    pf_cli_progress_times(&p, times, sizeof times);
    if (r->clipped) {
        const pf_clip_stats *c = &r->clip_stats;
        fprintf(stderr,
                "pf-cut: --surface %s (keep %s): %d elements kept whole, %d clipped into %d "
                "parts (%d slivers merged), %d dropped; volume %.9g of %.9g\n",
                r->knife_path, r->clip.keep == PF_CLIP_OUTSIDE ? "outside" : "inside",
                (int)c->n_kept, (int)c->n_clipped, (int)c->n_parts, (int)c->n_merged,
                (int)c->n_dropped, c->volume, r->in_volume);
    }
    if (r->n_planes > 0)
        fprintf(stderr,
                "pf-cut: %d plane%s: %d elements split (%d left whole by the sliver rule), "
                "%d faces opened, %d nodes duplicated; %d bodies, %d dropped (volume "
                "%.6g)\n",
                (int)r->n_planes, r->n_planes == 1 ? "" : "s", (int)r->split, (int)r->snapped,
                (int)r->opened, (int)r->duplicated, (int)r->bodies, (int)r->dropped_bodies,
                r->dropped_volume);
    fprintf(stderr, "pf-cut: %d -> %d elements, %d -> %d nodes; %s\n", (int)r->in_elems,
            (int)r->mesh.n_elems, (int)r->in_nodes, (int)r->mesh.n_nodes, times);
    if (r->have_surf)
        fprintf(stderr,
                "pf-cut: embedded surface: %d triangles split, %d vertices duplicated, %d cap "
                "triangles (area %.6g), %d triangles; %s weights recomputed\n",
                (int)r->surf_stats.n_split_tris, (int)r->surf_stats.n_duplicated,
                (int)r->surf_stats.n_cap_tris, r->surf_stats.cap_area, (int)r->surf.n_tris,
                pf_embed_method_name(r->embed.method));
    if (r->have_surf && r->surf_stats.n_uncapped > 0)
        fprintf(stderr,
                "pf-cut: warning: %d opened faces left without a cap (their boundary inside the "
                "surface did not close): the embedded surface has holes there\n",
                (int)r->surf_stats.n_uncapped);
    if (r->surf_dropped || r->dropped_chunks > 0)
        fprintf(stderr,
                "pf-cut: dropped from the stream:%s%s%s (they belong to the mesh before the "
                "cut)\n",
                r->surf_dropped ? " the embedded surface (SURF)" : "",
                r->surf_dropped && r->state.have_weights ? " and its weights (WGHT)" : "",
                r->dropped_chunks > 0 ? " frames, stress and checkpoints" : "");
}

/* --stats FILE: what was done, as JSON. */
static pf_status write_stats(const run *r, pf_error *err)
{
    const pf_clip_stats *c = &r->clip_stats;
    char json[2048];
    int n = snprintf(
        json, sizeof json,
        "{\n  \"elements_in\": %d,\n  \"elements_out\": %d,\n  \"nodes_in\": %d,\n  "
        "\"nodes_out\": %d,\n  \"volume_in\": %.17g,\n  \"volume_out\": %.17g,\n  \"planes\": "
        "%d,\n  \"elements_split\": %d,\n  \"requests_snapped\": %d,\n  \"faces_opened\": %d,\n  "
        "\"nodes_duplicated\": %d,\n  \"bodies\": %d,\n  \"bodies_dropped\": %d,\n  "
        "\"dropped_volume\": %.17g,\n  \"surface\": %s,\n  \"keep\": \"%s\",\n  "
        "\"elements_kept\": %d,\n  \"elements_clipped\": %d,\n  \"parts\": %d,\n  "
        "\"slivers_merged\": %d,\n  \"elements_dropped\": %d,\n  \"embedded_surface\": %s,\n  "
        "\"surface_triangles_split\": %d,\n  \"surface_vertices_duplicated\": %d,\n  "
        "\"cap_triangles\": %d,\n  \"cap_area\": %.17g,\n  \"uncapped_faces\": %d,\n  "
        "\"wall_seconds\": %.6f,\n  "
        "\"cpu_seconds\": %.6f\n}\n",
        (int)r->in_elems, (int)r->mesh.n_elems, (int)r->in_nodes, (int)r->mesh.n_nodes,
        r->in_volume, pf_mesh_volume(&r->mesh), (int)r->n_planes, (int)r->split, (int)r->snapped,
        (int)r->opened, (int)r->duplicated, (int)r->bodies, (int)r->dropped_bodies,
        r->dropped_volume, r->clipped ? "true" : "false",
        r->clip.keep == PF_CLIP_OUTSIDE ? "outside" : "inside", (int)c->n_kept, (int)c->n_clipped,
        (int)c->n_parts, (int)c->n_merged, (int)c->n_dropped, r->have_surf ? "true" : "false",
        (int)r->surf_stats.n_split_tris, (int)r->surf_stats.n_duplicated,
        (int)r->surf_stats.n_cap_tris, r->surf_stats.cap_area, (int)r->surf_stats.n_uncapped,
        pf_time_seconds() - r->wall0, pf_cpu_seconds() - r->cpu0);
    PF_CHECK(n > 0 && (size_t)n < sizeof json, err, PF_ERR_INVALID, "statistics too long");
    return pf_write_file_atomic(r->stats_path, json, (size_t)n, "statistics", err);
}

static pf_status run_cut(run *r, pf_atomic_file *file, pf_error *err)
{
    FILE *in_file = NULL;
    PF_TRY(pf_cli_open_input(r->input, &in_file, &r->in_name, err));
    pf_stream_reader *in = NULL;
    pf_stream_writer *out = NULL;
    pf_status st = pf_stream_reader_create(&in, in_file, r->in_name, err);
    FILE *f = NULL;
    const char *out_name = "stdout";
    if (st >= 0 && r->output) {
        st = pf_atomic_file_open(file, r->output, err);
        f = file->f;
        out_name = r->output;
    } else if (st >= 0) {
        f = pf_cli_binary_stdout(&r->cli);
    }
    if (st >= 0)
        st = pf_stream_writer_create(&out, f, out_name, err);
    if (st >= 0)
        st = pf_cli_write_info(&r->cli, out, err);
    if (st >= 0)
        st = read_input(r, in, out, err);
    if (st >= 0)
        st = cut(r, err);
    if (st >= 0 && r->have_surf)
        st = pf_stream_write_surface(out, &r->surf, err);
    if (st >= 0)
        st = pf_stream_write_mesh(out, &r->mesh, err);
    if (st >= 0 && r->have_surf)
        st = pf_stream_write_weights(out, &r->weights, err);
    if (st >= 0)
        st = pf_stream_writer_finish(out, err);
    pf_stream_writer_destroy(&out);
    pf_stream_reader_destroy(&in);
    pf_cli_close_input(in_file);
    return st;
}

int main(int argc, char **argv)
{
    run r;
    memset(&r, 0, sizeof r);
    r.wall0 = pf_time_seconds();
    r.cpu0 = pf_cpu_seconds();
    parse_arguments(&r, argc, argv);
    pf_error err = {0};
    pf_atomic_file file = {0};
    pf_status st = run_cut(&r, &file, &err);
    if (file.f) {
        if (st >= 0)
            st = pf_atomic_file_commit(&file, "stream", &err);
        else
            pf_atomic_file_abort(&file);
    }
    if (st >= 0 && r.stats_path)
        st = write_stats(&r, &err);
    if (st >= 0)
        report(&r);
    pf_mesh_release(&r.mesh);
    pf_surface_release(&r.surf);
    pf_weights_release(&r.weights);
    pf_stream_state_release(&r.state);
    pf_free(r.planes);
    if (st < 0)
        pf_cli_fail(&r.cli, &err);
    pf_cli_close_stdout(r.cli.tool);
    return PF_EXIT_OK;
}
