/* pf-info: every chunk of a pf stream, as text or as JSON lines. */
#include <math.h>
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-info [--json] [--probe X,Y,Z] [--print-mesh] [--scene] [FILE | -]\n"
    "\n"
    "Prints every chunk of a pf stream (default: stdin).\n"
    "  MESH  counts of nodes, faces, elements by kind, exact total volume, smallest and largest\n"
    "        element volume, bounding box, and the validation result (first offending entity)\n"
    "  SURF  vertices, triangles (and how many are caps of a cut), enclosed volume, closed /\n"
    "        manifold, and whether every coordinate is a float32 value (the surface came\n"
    "        through single precision)\n"
    "  FRAM  consecutive frames as one entry: frame count, time range, largest displacement\n"
    "  STRS  consecutive stress chunks as one entry: count, largest value\n"
    "  CKPT  pf-sim's checkpoints among those frames: count, the last one's frame\n"
    "  STAT  pf-sim's run statistics: method, the error indicator and what it measures,\n"
    "        unknowns, frames, steps, factorisations, solves (docs/scene.md)\n"
    "  SCEN  the scene as simulated (JSON, every key, overrides applied)\n"
    "  others: tag, version, size; unknown chunks are listed, not interpreted\n"
    "and at the end every mesh of the stream (a refining or cutting run has several) with the\n"
    "frames on it, and every surface (a cut writes a new one, with caps) with the frames drawn\n"
    "on it (those after its WGHT). WGHT, STRS and FRAM chunks must refer to the latest MESH (and\n"
    "SURF).\n"
    "\n"
    "  --json          one JSON object per line and entry, for scripts\n"
    "  --probe X,Y,Z   for every frame, the displacement of the mesh node nearest to the point,\n"
    "                  with that node's position and its distance to the point\n"
    "  --print-mesh    also print every node, face and element of each MESH (text mode)\n"
    "  --scene         print only the scene (the last SCEN chunk), verbatim: a scene file that\n"
    "                  pf-sim reads back (exit 1 when the stream has none)\n"
    "  --help, --version\n"
    "\n"
    "A damaged or truncated stream: everything before the damage is printed, then the error;\n"
    "exit 1. Exit 2 on bad usage.\n";

enum { OPT_JSON = 1, OPT_PROBE, OPT_PRINT_MESH, OPT_SCENE };

typedef struct probe_sample {
    uint32_t frame;
    double time;
    double u[3];
} probe_sample;

typedef struct info {
    bool json, print_mesh, has_probe;
    bool scene_only; /* --scene */
    char *scene;     /* with scene_only: the last SCEN's JSON, NUL-terminated */
    size_t scene_size;
    double probe[3];
    pf_stream_state st;    /* the latest MESH (for probes), SURF, ...; the meshes and frames */
    int32_t probe_node;    /* nearest node of mesh to the probe point, -1 before a mesh */
    /* The current run of FRAM / STRS chunks. */
    int64_t frames, stresses, checkpoints;
    uint32_t checkpoint_frame; /* the frame the latest CKPT follows */
    uint64_t frame_mesh_id;
    uint64_t first_offset;
    double t0, t1, max_u, max_stress;
    probe_sample *samples;
    int64_t n_samples, cap_samples;
} info;

/* |v| without overflow for any finite v: 1e300 in each component is a finite 1.7e300, not inf. */
static double norm3(const double *v)
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    if (m == 0 || !isfinite(m))
        return m;
    double a = v[0] / m, b = v[1] / m, c = v[2] / m;
    return m * sqrt(a * a + b * b + c * c);
}

static void json_vec(const double *v)
{
    printf("[");
    for (int i = 0; i < 3; ++i)
        printf(isfinite(v[i]) ? "%s%.17g" : "%snull", i ? "," : "", v[i]);
    printf("]");
}

static void json_string(const char *s, size_t n)
{
    putchar('"');
    for (size_t i = 0; i < n; ++i) {
        unsigned char c = (unsigned char)s[i];
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

static void print_mesh_chunk(info *in, const pf_chunk *c, pf_mesh *m)
{
    pf_error err = {0};
    pf_mesh_stats st;
    pf_status valid = pf_mesh_validate(m, NULL, &err);
    const char *verdict = valid == PF_OK ? "ok" : err.msg;
    if (pf_mesh_compute_stats(m, &st, &err) < 0) {
        memset(&st, 0, sizeof st);
    }
    double lo[3] = {st.lo.x, st.lo.y, st.lo.z}, hi[3] = {st.hi.x, st.hi.y, st.hi.z};
    if (in->json) {
        printf("{\"chunk\":\"MESH\",\"offset\":%llu,\"version\":%u,\"id\":%llu,\"nodes\":%d,"
               "\"faces\":%d,\"boundary_faces\":%d,\"elements\":%d,\"tets\":%d,\"hexes\":%d,"
               "\"polyhedra\":%d,\"volume\":%.17g,\"min_element_volume\":%.17g,"
               "\"max_element_volume\":%.17g,\"bbox\":[",
               (unsigned long long)c->offset, c->version, (unsigned long long)m->id,
               (int)st.n_nodes, (int)st.n_faces, (int)st.n_boundary_faces, (int)st.n_elems,
               (int)st.n_by_kind[PF_ELEM_TET], (int)st.n_by_kind[PF_ELEM_HEX],
               (int)st.n_by_kind[PF_ELEM_POLY], st.volume, st.min_volume, st.max_volume);
        json_vec(lo);
        printf(",");
        json_vec(hi);
        printf("],\"valid\":%s,\"validation\":", valid == PF_OK ? "true" : "false");
        json_string(verdict, strlen(verdict));
        printf("}\n");
    } else {
        printf("MESH  at byte %llu, id %llu: %d nodes, %d faces (%d on the boundary), %d elements "
               "(%d tets, %d hexes, %d polyhedra)\n",
               (unsigned long long)c->offset, (unsigned long long)m->id, (int)st.n_nodes,
               (int)st.n_faces, (int)st.n_boundary_faces, (int)st.n_elems,
               (int)st.n_by_kind[PF_ELEM_TET], (int)st.n_by_kind[PF_ELEM_HEX],
               (int)st.n_by_kind[PF_ELEM_POLY]);
        printf("      volume %.17g (elements %.6g .. %.6g)\n", st.volume, st.min_volume,
               st.max_volume);
        printf("      bounds (%.6g, %.6g, %.6g) .. (%.6g, %.6g, %.6g)\n", lo[0], lo[1], lo[2], hi[0],
               hi[1], hi[2]);
        printf("      validation: %s\n", verdict);
        if (in->print_mesh)
            pf_mesh_print(m, stdout);
    }
}

/* True when every coordinate is a float32 value: the surface came through single precision (an
 * assimp import, a float STL or PLY) or is that coarse by nature, as a unit cube is. */
static bool fits_float32(const pf_surface *s)
{
    for (size_t i = 0; i < 3 * (size_t)s->n_verts; ++i)
        if ((double)(float)s->x[i] != s->x[i])
            return false;
    return true;
}

static void print_surface_chunk(const info *in, const pf_chunk *c, const pf_surface *s)
{
    const bool single = fits_float32(s);
    pf_error err = {0};
    pf_surface_stats st;
    if (pf_surface_compute_stats(s, &st, &err) < 0) {
        memset(&st, 0, sizeof st);
    }
    double lo[3] = {st.lo.x, st.lo.y, st.lo.z}, hi[3] = {st.hi.x, st.hi.y, st.hi.z};
    if (in->json) {
        printf("{\"chunk\":\"SURF\",\"offset\":%llu,\"version\":%u,\"id\":%llu,\"vertices\":%d,"
               "\"triangles\":%d,\"volume\":%.17g,\"area\":%.17g,\"closed\":%s,\"manifold\":%s,"
               "\"boundary_edges\":%lld,\"nonmanifold_edges\":%lld,\"flipped_edges\":%lld,"
               "\"single_precision\":%s,\"caps\":%d,\"bbox\":[",
               (unsigned long long)c->offset, c->version, (unsigned long long)s->id,
               (int)st.n_verts, (int)st.n_tris, st.volume, st.area, st.closed ? "true" : "false",
               st.manifold ? "true" : "false", (long long)st.n_boundary_edges,
               (long long)st.n_nonmanifold_edges, (long long)st.n_flipped_edges,
               single ? "true" : "false", (int)pf_surface_count_caps(s));
        json_vec(lo);
        printf(",");
        json_vec(hi);
        printf("]}\n");
    } else {
        printf("SURF  at byte %llu, id %llu: %d vertices, %d triangles, %s, %s\n",
               (unsigned long long)c->offset, (unsigned long long)s->id, (int)st.n_verts,
               (int)st.n_tris, st.closed ? "closed" : "open (not watertight)",
               st.manifold ? "manifold" : "not manifold");
        printf("      enclosed volume %.17g, area %.17g\n", st.volume, st.area);
        if (pf_surface_count_caps(s))
            printf("      %d cap triangles (closing cuts), %d of the model's surface\n",
                   (int)pf_surface_count_caps(s), (int)(st.n_tris - pf_surface_count_caps(s)));
        if (single)
            printf("      every coordinate is a float32 value: single precision (as from assimp, "
                   "a float STL or PLY)\n");
        if (st.n_boundary_edges || st.n_nonmanifold_edges || st.n_flipped_edges)
            printf("      %lld boundary edges, %lld non-manifold edges, %lld inconsistently "
                   "oriented edges\n",
                   (long long)st.n_boundary_edges, (long long)st.n_nonmanifold_edges,
                   (long long)st.n_flipped_edges);
        printf("      bounds (%.6g, %.6g, %.6g) .. (%.6g, %.6g, %.6g)\n", lo[0], lo[1], lo[2], hi[0],
               hi[1], hi[2]);
    }
}

static void print_frames(info *in)
{
    if (in->frames == 0 && in->stresses == 0)
        return;
    const double *pos = in->probe_node >= 0 ? in->st.mesh.x + 3 * (size_t)in->probe_node : NULL;
    if (in->frames && in->json) {
        printf("{\"chunk\":\"FRAM\",\"offset\":%llu,\"frames\":%lld,\"mesh_id\":%llu,"
               "\"time\":[%.17g,%.17g],\"max_displacement\":%.17g",
               (unsigned long long)in->first_offset, (long long)in->frames,
               (unsigned long long)in->frame_mesh_id, in->t0, in->t1, in->max_u);
        if (in->has_probe && pos) {
            double d = pf_v3_dist(pf_v3_load(pos), pf_v3_load(in->probe));
            printf(",\"probe\":{\"point\":");
            json_vec(in->probe);
            printf(",\"node\":%d,\"position\":", (int)in->probe_node);
            json_vec(pos);
            printf(",\"distance\":%.17g,\"frames\":[", d);
            for (int64_t i = 0; i < in->n_samples; ++i) {
                printf("%s{\"frame\":%u,\"time\":%.17g,\"u\":", i ? "," : "",
                       in->samples[i].frame, in->samples[i].time);
                json_vec(in->samples[i].u);
                printf("}");
            }
            printf("]}");
        }
        printf("}\n");
    } else if (in->frames) {
        printf("FRAM  at byte %llu: %lld frames of mesh %llu, time %.6g .. %.6g, largest "
               "displacement %.6g\n",
               (unsigned long long)in->first_offset, (long long)in->frames,
               (unsigned long long)in->frame_mesh_id, in->t0, in->t1, in->max_u);
        if (in->has_probe && pos) {
            printf("      probe (%.6g, %.6g, %.6g): node %d at (%.17g, %.17g, %.17g), distance %.6g\n",
                   in->probe[0], in->probe[1], in->probe[2], (int)in->probe_node, pos[0], pos[1],
                   pos[2], pf_v3_dist(pf_v3_load(pos), pf_v3_load(in->probe)));
            for (int64_t i = 0; i < in->n_samples; ++i)
                printf("      frame %u t %.17g u %.17g %.17g %.17g\n", in->samples[i].frame,
                       in->samples[i].time, in->samples[i].u[0], in->samples[i].u[1],
                       in->samples[i].u[2]);
        }
    }
    if (in->stresses) {
        if (in->json)
            printf("{\"chunk\":\"STRS\",\"count\":%lld,\"max\":%.17g}\n", (long long)in->stresses,
                   in->max_stress);
        else
            printf("STRS  %lld stress chunks, largest value %.6g\n", (long long)in->stresses,
                   in->max_stress);
    }
    if (in->checkpoints) {
        if (in->json)
            printf("{\"chunk\":\"CKPT\",\"count\":%lld,\"last_frame\":%u}\n",
                   (long long)in->checkpoints, (unsigned)in->checkpoint_frame);
        else
            printf("CKPT  %lld checkpoints (pf-sim --resume), the last after frame %u\n",
                   (long long)in->checkpoints, (unsigned)in->checkpoint_frame);
    }
    in->frames = in->stresses = in->checkpoints = in->n_samples = 0;
}

static int32_t nearest_node(const pf_mesh *m, const double *p)
{
    int32_t best = -1;
    double best_d = INFINITY;
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        double d = pf_v3_dist(pf_v3_load(m->x + 3 * (size_t)i), pf_v3_load(p));
        if (d < best_d) {
            best_d = d;
            best = i;
        }
    }
    return best;
}

static pf_status add_frame(info *in, const pf_chunk *c, pf_error *err)
{
    pf_frame_data fr = {0};
    PF_TRY(pf_stream_state_frame(&in->st, c, &fr, err));
    if (in->frames == 0 || fr.mesh_id != in->frame_mesh_id) {
        print_frames(in);
        in->frame_mesh_id = fr.mesh_id;
        in->first_offset = c->offset;
        in->t0 = fr.time;
        in->max_u = 0;
    }
    in->frames++;
    in->t1 = fr.time;
    for (int32_t i = 0; i < fr.n_nodes; ++i)
        in->max_u = fmax(in->max_u, norm3(fr.u + 3 * (size_t)i));
    pf_status s = PF_OK;
    if (in->has_probe && in->probe_node >= 0 && in->probe_node < fr.n_nodes &&
        fr.mesh_id == in->st.mesh.id) {
        if (in->n_samples == in->cap_samples) {
            int64_t cap = in->cap_samples ? 2 * in->cap_samples : 64;
            probe_sample *grown = pf_realloc_array(in->samples, (size_t)cap, sizeof *grown);
            if (!grown)
                s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
            else
                in->samples = grown, in->cap_samples = cap;
        }
        if (s == PF_OK) {
            probe_sample *p = &in->samples[in->n_samples++];
            p->frame = fr.index;
            p->time = fr.time;
            memcpy(p->u, fr.u + 3 * (size_t)in->probe_node, sizeof p->u);
        }
    }
    pf_frame_data_release(&fr);
    return s;
}

static pf_status add_stress(info *in, const pf_chunk *c, pf_error *err)
{
    PF_TRY(pf_stream_state_take(&in->st, c, err));
    const pf_stress_data *st = &in->st.stress;
    if (in->stresses == 0)
        in->max_stress = 0;
    in->stresses++;
    for (int64_t i = 0; i < (int64_t)st->n_elems * st->components; ++i)
        in->max_stress = fmax(in->max_stress, fabs(st->values[i]));
    return PF_OK;
}

/* CKPT: pf-sim's checkpoint of the latest MESH, counted with the frames around it. */
static pf_status add_checkpoint(info *in, const pf_chunk *c, pf_error *err)
{
    pf_checkpoint_header h;
    PF_TRY(pf_stream_checkpoint_header(c, &h, err));
    PF_CHECK(in->st.have_mesh && h.mesh_id == in->st.mesh.id, err, PF_ERR_FORMAT,
             "chunk CKPT at byte %llu: checkpoint of mesh %llu, which is not the latest MESH",
             (unsigned long long)c->offset, (unsigned long long)h.mesh_id);
    in->checkpoints++;
    in->checkpoint_frame = h.frame;
    return PF_OK;
}

/* An id names one mesh in a stream: the MESH just taken (the latest in st's list of meshes) must
 * not reuse the id of an earlier one, which frames and stress of that mesh would then name too. */
static pf_status check_mesh_id(const info *in, const pf_chunk *c, pf_error *err)
{
    const pf_stream_state *st = &in->st;
    for (int32_t k = 0; k + 1 < st->n_meshes; ++k)
        PF_CHECK(st->meshes[k].id != st->mesh.id, err, PF_ERR_FORMAT,
                 "chunk MESH at byte %llu: mesh id %llu is already that of the MESH at byte %llu",
                 (unsigned long long)c->offset, (unsigned long long)st->mesh.id,
                 (unsigned long long)st->meshes[k].offset);
    return PF_OK;
}

/* A chunk listed, not interpreted: unknown to this pf, or of a version it does not read. */
static void print_other(const info *in, const pf_chunk *c, const char *note)
{
    if (in->json) {
        printf("{\"chunk\":");
        json_string(c->tag, 4);
        printf(",\"offset\":%llu,\"version\":%u,\"bytes\":%llu,\"known\":%s}\n",
               (unsigned long long)c->offset, c->version, (unsigned long long)c->size,
               pf_stream_tag_is_known(c->tag) ? "true" : "false");
    } else {
        printf("%s  at byte %llu: version %u, %llu bytes%s\n", c->tag,
               (unsigned long long)c->offset, c->version, (unsigned long long)c->size, note);
    }
}

/* GRPS: every group of the latest mesh with its number, dimension, name and size. */
static void print_groups(const info *in, const pf_chunk *c, const pf_mesh *m)
{
    if (!m->elem_group) { /* the reader state ignored groups of another mesh */
        print_other(in, c, " (groups of another mesh than the latest: ignored)");
        return;
    }
    if (in->json)
        printf("{\"chunk\":\"GRPS\",\"offset\":%llu,\"version\":%u,\"groups\":[",
               (unsigned long long)c->offset, c->version);
    else
        printf("GRPS  at byte %llu: %d groups of mesh %llu\n", (unsigned long long)c->offset,
               (int)m->n_groups, (unsigned long long)m->id);
    for (int32_t g = 0; g < m->n_groups; ++g) {
        const pf_mesh_group *p = &m->groups[g];
        const int32_t *tags = p->dim == 3 ? m->elem_group : m->face_group;
        int32_t n = p->dim == 3 ? m->n_elems : m->n_faces, count = 0;
        for (int32_t i = 0; i < n; ++i)
            count += tags[i] == p->number;
        if (in->json) {
            printf("%s{\"number\":%d,\"dim\":%d,\"name\":", g ? "," : "", (int)p->number,
                   (int)p->dim);
            json_string(p->name, strlen(p->name));
            printf(",\"%s\":%d}", p->dim == 3 ? "elements" : "faces", (int)count);
        } else {
            printf("      %d '%s': %d %s\n", (int)p->number, p->name, (int)count,
                   p->dim == 3 ? "elements" : "faces");
        }
    }
    if (in->json)
        printf("]}\n");
}

/* STAT: a run's statistics, every entry in stream order (those this pf does not know too). */
static pf_status print_stats(const info *in, const pf_chunk *c, pf_error *err)
{
    pf_stats_data d = {0};
    PF_TRY(pf_stream_decode_stats(c, &d, err));
    if (in->json)
        printf("{\"chunk\":\"STAT\",\"offset\":%llu,\"version\":%u,\"stats\":{",
               (unsigned long long)c->offset, c->version);
    else
        printf("STAT  at byte %llu: run statistics, %d entries\n", (unsigned long long)c->offset,
               (int)d.n);
    for (int32_t i = 0; i < d.n; ++i) {
        const pf_stat_entry *e = &d.entries[i];
        if (in->json) {
            printf("%s\"%s\":", i ? "," : "", e->key); /* keys need no escapes */
            if (e->text)
                json_string(e->text, strlen(e->text));
            else
                printf("%.17g", e->value);
        } else if (e->text) {
            printf("      %s %s\n", e->key, e->text);
        } else {
            printf("      %s %.6g\n", e->key, e->value);
        }
    }
    if (in->json)
        printf("}}\n");
    pf_stats_data_release(&d);
    return PF_OK;
}

/* SCEN: the JSON as stored (docs/scene.md: every key, the overrides applied). */
static pf_status print_scene(info *in, const pf_chunk *c, pf_error *err)
{
    char *json = NULL;
    size_t size = 0;
    PF_TRY(pf_stream_decode_scene(c, &json, &size, err));
    if (in->scene_only) {
        pf_free(in->scene);
        in->scene = json;
        in->scene_size = size;
        return PF_OK;
    }
    if (in->json) {
        printf("{\"chunk\":\"SCEN\",\"offset\":%llu,\"version\":%u,\"scene\":",
               (unsigned long long)c->offset, c->version);
        json_string(json, size);
        printf("}\n");
    } else {
        printf("SCEN  at byte %llu: scene, %zu bytes:\n", (unsigned long long)c->offset, size);
        fwrite(json, 1, size, stdout);
        if (size && json[size - 1] != '\n')
            putchar('\n');
    }
    pf_free(json);
    return PF_OK;
}

static pf_status print_chunk(info *in, const pf_chunk *c, pf_error *err)
{
    if (in->scene_only)
        return strcmp(c->tag, "SCEN") == 0 ? print_scene(in, c, err) : PF_OK;
    /* A non-critical chunk of a version this pf does not read is skipped (the stream spec);
     * critical ones reach their decoder, which refuses them. */
    if (pf_stream_tag_is_known(c->tag) && !pf_stream_tag_is_critical(c->tag) &&
        !pf_stream_version_is_read(c->tag, c->version)) {
        print_frames(in);
        print_other(in, c, " (a version this pf does not read: skipped)");
        return PF_OK;
    }
    if (strcmp(c->tag, "SCEN") == 0) {
        print_frames(in);
        return print_scene(in, c, err);
    }
    if (strcmp(c->tag, "FRAM") == 0)
        return add_frame(in, c, err);
    if (strcmp(c->tag, "STRS") == 0)
        return add_stress(in, c, err);
    if (strcmp(c->tag, "CKPT") == 0)
        return add_checkpoint(in, c, err);
    print_frames(in);
    if (strcmp(c->tag, "STAT") == 0)
        return print_stats(in, c, err);
    PF_TRY(pf_stream_state_take(&in->st, c, err)); /* the id checks of WGHT and the others */
    if (strcmp(c->tag, "MESH") == 0) {
        PF_TRY(check_mesh_id(in, c, err));
        print_mesh_chunk(in, c, &in->st.mesh);
        in->probe_node = in->has_probe ? nearest_node(&in->st.mesh, in->probe) : -1;
    } else if (strcmp(c->tag, "SURF") == 0) {
        print_surface_chunk(in, c, &in->st.surface);
    } else if (strcmp(c->tag, "INFO") == 0) {
        pf_info_data d = {0};
        PF_TRY(pf_stream_decode_info(c, &d, err));
        if (in->json) {
            printf("{\"chunk\":\"INFO\",\"offset\":%llu,\"version\":%u,\"producer\":",
                   (unsigned long long)c->offset, c->version);
            json_string(d.producer, strlen(d.producer));
            printf(",\"producer_version\":");
            json_string(d.version, strlen(d.version));
            printf(",\"command\":");
            json_string(d.command, strlen(d.command));
            printf("}\n");
        } else {
            printf("INFO  at byte %llu: %s %s: %s\n", (unsigned long long)c->offset, d.producer,
                   d.version, d.command);
        }
        pf_info_data_release(&d);
    } else if (strcmp(c->tag, "GRPS") == 0) {
        print_groups(in, c, &in->st.mesh);
    } else if (strcmp(c->tag, "END_") == 0) {
        pf_end_data d = {0};
        PF_TRY(pf_stream_decode_end(c, &d, err));
        if (in->json)
            printf("{\"chunk\":\"END_\",\"offset\":%llu,\"chunks\":%llu,\"frames\":%llu}\n",
                   (unsigned long long)c->offset, (unsigned long long)d.chunk_count,
                   (unsigned long long)d.frame_count);
        else
            printf("END_  at byte %llu: %llu chunks, %llu frames\n", (unsigned long long)c->offset,
                   (unsigned long long)d.chunk_count, (unsigned long long)d.frame_count);
    } else {
        print_other(in, c,
                    pf_stream_tag_is_known(c->tag) ? "" : " (unknown to this pf, passed through)");
    }
    return PF_OK;
}

/* The frames drawn on a mesh or surface: the end of its JSON object, or the end of its line. */
static void print_frame_range(bool json, int64_t n, uint32_t first, uint32_t last)
{
    if (json && n)
        printf(",\"first_frame\":%u,\"last_frame\":%u}", (unsigned)first, (unsigned)last);
    else if (json)
        printf("}");
    else if (n)
        printf("frames %u .. %u (%lld)\n", (unsigned)first, (unsigned)last, (long long)n);
    else
        printf("no frames\n");
}

/* Every mesh and the frames on it (what a refining or cutting run's stream holds). */
static void print_meshes(const info *in)
{
    const pf_stream_state *st = &in->st;
    if (st->n_meshes == 0)
        return;
    if (in->json)
        printf("{\"meshes\":[");
    else
        printf("meshes: %d\n", (int)st->n_meshes);
    for (int32_t k = 0; k < st->n_meshes; ++k) {
        const pf_stream_mesh_use *u = &st->meshes[k];
        if (in->json) {
            printf("%s{\"id\":%llu,\"offset\":%llu,\"nodes\":%d,\"faces\":%d,\"elements\":%d,"
                   "\"frames\":%lld",
                   k ? "," : "", (unsigned long long)u->id, (unsigned long long)u->offset,
                   (int)u->n_nodes, (int)u->n_faces, (int)u->n_elems, (long long)u->n_frames);
            print_frame_range(true, u->n_frames, u->first_frame, u->last_frame);
        } else {
            printf("      mesh %llu (MESH at byte %llu): %d nodes, %d elements; ",
                   (unsigned long long)u->id, (unsigned long long)u->offset, (int)u->n_nodes,
                   (int)u->n_elems);
            print_frame_range(false, u->n_frames, u->first_frame, u->last_frame);
        }
    }
    if (in->json)
        printf("]}\n");
}

/* Every surface, its caps and the frames drawn on it. */
static void print_surfaces(const info *in)
{
    const pf_stream_state *st = &in->st;
    if (st->n_surfaces == 0)
        return;
    if (in->json)
        printf("{\"surfaces\":[");
    else
        printf("surfaces: %d\n", (int)st->n_surfaces);
    for (int32_t k = 0; k < st->n_surfaces; ++k) {
        const pf_stream_surface_use *u = &st->surfaces[k];
        if (in->json) {
            printf("%s{\"id\":%llu,\"offset\":%llu,\"vertices\":%d,\"triangles\":%d,"
                   "\"caps\":%d,\"frames\":%lld",
                   k ? "," : "", (unsigned long long)u->id, (unsigned long long)u->offset,
                   (int)u->n_verts, (int)u->n_tris, (int)u->n_caps, (long long)u->n_frames);
            print_frame_range(true, u->n_frames, u->first_frame, u->last_frame);
        } else {
            printf("      surface %llu (SURF at byte %llu): %d vertices, %d triangles, %d caps; ",
                   (unsigned long long)u->id, (unsigned long long)u->offset, (int)u->n_verts,
                   (int)u->n_tris, (int)u->n_caps);
            print_frame_range(false, u->n_frames, u->first_frame, u->last_frame);
        }
    }
    if (in->json)
        printf("]}\n");
}

static pf_status run(info *in, FILE *f, const char *name, pf_error *err)
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
        s = print_chunk(in, &c, err);
        if (s < 0)
            break;
    }
    if (!in->scene_only) {
        print_frames(in);
        print_meshes(in);
        print_surfaces(in);
    }
    pf_stream_reader_destroy(&r);
    if (s >= 0 && in->scene_only) {
        PF_CHECK(in->scene, err, PF_ERR_FORMAT, "%s: no SCEN chunk (the stream did not go "
                 "through pf-sim)", name);
        fwrite(in->scene, 1, in->scene_size, stdout);
    }
    return s;
}

int main(int argc, char **argv)
{
    static const pf_cli_option options[] = {{"json", false, OPT_JSON},
                                            {"probe", true, OPT_PROBE},
                                            {"print-mesh", false, OPT_PRINT_MESH},
                                            {"scene", false, OPT_SCENE},
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-info", USAGE, argc, argv);
    info in = {.probe_node = -1};
    const char *path = NULL, *value;
    for (int id; (id = pf_cli_next(&cli, options, &value)) != PF_CLI_END;) {
        if (id == OPT_JSON)
            in.json = true;
        else if (id == OPT_PRINT_MESH)
            in.print_mesh = true;
        else if (id == OPT_SCENE)
            in.scene_only = true;
        else if (id == OPT_PROBE) {
            pf_cli_parse_vec3(&cli, "probe", value, in.probe);
            in.has_probe = true;
        } else if (path)
            pf_cli_usage_error(&cli, "one input only (got '%s' and '%s')", path, value);
        else
            path = value;
    }
    pf_error err = {0};
    FILE *f;
    const char *name;
    if (pf_cli_open_input(path, &f, &name, &err) < 0)
        pf_cli_fail(&cli, &err);
    pf_status s = run(&in, f, name, &err);
    pf_cli_close_input(f);
    pf_stream_state_release(&in.st);
    pf_free(in.samples);
    pf_free(in.scene);
    if (s < 0) {
        fflush(stdout); /* what was read before the damage, then the error */
        pf_cli_fail(&cli, &err);
    }
    pf_cli_close_stdout(cli.tool);
    return PF_EXIT_OK;
}
