/* The reader state of a pf stream: the latest MESH, SURF, WGHT, STRS and SCEN, and the list of
 * meshes with the frames on each. The id checks every frame reader needs are here and nowhere
 * else (docs/stream-format.md, "Mesh changes"). */
#include <pf/io.h>

#include <string.h>

#include "stream_bytes.h"

#define STATE_FAIL(c, err, ...)                                                                    \
    pf_stream_chunk_error((err), PF_ERR_FORMAT, __FILE__, __LINE__, (c), __VA_ARGS__)

void pf_stream_state_release(pf_stream_state *s)
{
    pf_mesh_release(&s->mesh);
    pf_surface_release(&s->surface);
    pf_weights_release(&s->weights);
    pf_stress_data_release(&s->stress);
    pf_free(s->scene_json);
    pf_free(s->meshes);
    pf_free(s->surfaces);
    memset(s, 0, sizeof *s);
}

const pf_stream_mesh_use *pf_stream_state_find_mesh(const pf_stream_state *s, uint64_t id)
{
    for (int32_t k = s->n_meshes - 1; k >= 0; --k)
        if (s->meshes[k].id == id)
            return &s->meshes[k];
    return NULL;
}

/* Room for one more entry in a list of *cap entries of size bytes each. */
static pf_status grow_list(void **list, int32_t n, int32_t *cap, size_t size, const char *what,
                           pf_error *err)
{
    if (n < *cap)
        return PF_OK;
    int32_t more = *cap ? 2 * *cap : 8;
    PF_CHECK(more > *cap, err, PF_ERR_TOO_LARGE, "too many %s chunks", what);
    void *grown = pf_realloc_array(*list, (size_t)more, size);
    PF_CHECK(grown, err, PF_ERR_NOMEM, "out of memory for the list of %s chunks", what);
    *list = grown;
    *cap = more;
    return PF_OK;
}

static pf_status record_mesh(pf_stream_state *s, const pf_chunk *c, const pf_mesh *m,
                             pf_error *err)
{
    void *list = s->meshes;
    pf_status st = grow_list(&list, s->n_meshes, &s->cap_meshes, sizeof *s->meshes, "MESH", err);
    s->meshes = list;
    PF_TRY(st);
    s->meshes[s->n_meshes++] = (pf_stream_mesh_use){.id = m->id,
                                                    .offset = c->offset,
                                                    .n_nodes = m->n_nodes,
                                                    .n_faces = m->n_faces,
                                                    .n_elems = m->n_elems};
    return PF_OK;
}

static pf_status record_surface(pf_stream_state *s, const pf_chunk *c, const pf_surface *sf,
                                pf_error *err)
{
    void *list = s->surfaces;
    pf_status st =
        grow_list(&list, s->n_surfaces, &s->cap_surfaces, sizeof *s->surfaces, "SURF", err);
    s->surfaces = list;
    PF_TRY(st);
    s->surfaces[s->n_surfaces++] = (pf_stream_surface_use){.id = sf->id,
                                                           .offset = c->offset,
                                                           .version = c->version,
                                                           .n_verts = sf->n_verts,
                                                           .n_tris = sf->n_tris,
                                                           .n_caps = pf_surface_count_caps(sf)};
    return PF_OK;
}

static pf_status take_mesh(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    pf_mesh m = {0};
    PF_TRY(pf_stream_decode_mesh(c, &m, err));
    pf_status st = record_mesh(s, c, &m, err);
    if (st < 0) {
        pf_mesh_release(&m);
        return st;
    }
    pf_mesh_release(&s->mesh);
    s->mesh = m;
    s->have_mesh = true;
    ++s->mesh_serial;
    /* weights and stress referred to the mesh this one replaces */
    pf_weights_release(&s->weights);
    pf_stress_data_release(&s->stress);
    s->have_weights = s->have_stress = false;
    return PF_OK;
}

static pf_status take_surface(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    pf_surface sf = {0};
    PF_TRY(pf_stream_decode_surface(c, &sf, err));
    pf_status st = record_surface(s, c, &sf, err);
    if (st < 0) {
        pf_surface_release(&sf);
        return st;
    }
    pf_surface_release(&s->surface);
    s->surface = sf;
    s->have_surface = true;
    ++s->surface_serial;
    pf_weights_release(&s->weights);
    s->have_weights = false;
    return PF_OK;
}

/* "mesh 3 (12 nodes, 2 elements)" or "missing", for messages about the latest MESH. */
static const char *latest_mesh(const pf_stream_state *s, char *buf, size_t n)
{
    if (!s->have_mesh)
        return "missing";
    snprintf(buf, n, "mesh %llu with %d nodes and %d elements", (unsigned long long)s->mesh.id,
             (int)s->mesh.n_nodes, (int)s->mesh.n_elems);
    return buf;
}

static pf_status take_weights(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    pf_weights w = {0};
    PF_TRY(pf_stream_decode_weights(c, &w, err));
    char buf[96];
    pf_status st = PF_OK;
    if (!s->have_surface || w.surface_id != s->surface.id || w.rows != s->surface.n_verts)
        st = STATE_FAIL(c, err,
                        "weights for surface %llu with %d vertices, but the latest SURF is %s",
                        (unsigned long long)w.surface_id, (int)w.rows,
                        s->have_surface ? "another" : "missing");
    else if (!s->have_mesh || w.mesh_id != s->mesh.id || w.cols != s->mesh.n_nodes)
        st = STATE_FAIL(c, err, "weights for mesh %llu with %d nodes, but the latest MESH is %s",
                        (unsigned long long)w.mesh_id, (int)w.cols,
                        latest_mesh(s, buf, sizeof buf));
    if (st < 0) {
        pf_weights_release(&w);
        return st;
    }
    pf_weights_release(&s->weights);
    s->weights = w;
    s->have_weights = true;
    return PF_OK;
}

static pf_status take_stress(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    pf_stress_data st = {0};
    PF_TRY(pf_stream_decode_stress(c, &st, err));
    if (!s->have_mesh || st.mesh_id != s->mesh.id || st.n_elems != s->mesh.n_elems) {
        char buf[96];
        pf_status r = STATE_FAIL(c, err,
                                 "stress of frame %u for mesh %llu with %d elements, but the "
                                 "latest MESH is %s",
                                 (unsigned)st.frame, (unsigned long long)st.mesh_id,
                                 (int)st.n_elems, latest_mesh(s, buf, sizeof buf));
        pf_stress_data_release(&st);
        return r;
    }
    pf_stress_data_release(&s->stress);
    s->stress = st;
    s->have_stress = true;
    return PF_OK;
}

static pf_status take_scene(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    char *json = NULL;
    size_t size = 0;
    PF_TRY(pf_stream_decode_scene(c, &json, &size, err));
    pf_free(s->scene_json);
    s->scene_json = json;
    s->scene_size = size;
    s->have_scene = true;
    ++s->scene_serial;
    return PF_OK;
}

static void count_frame(int64_t *n, uint32_t *first, uint32_t *last, uint32_t index)
{
    if (*n == 0 || index < *first)
        *first = index;
    if (*n == 0 || index > *last)
        *last = index;
    ++*n;
}

/* A frame must be on the latest MESH: mesh-dependent chunks refer to it (a tool that emits a new
 * MESH emits it before the first FRAM on it). */
static pf_status check_frame(pf_stream_state *s, const pf_chunk *c, uint64_t mesh_id,
                             uint32_t index, int32_t n_nodes, pf_error *err)
{
    char buf[96];
    if (!s->have_mesh || mesh_id != s->mesh.id) {
        const pf_stream_mesh_use *u = pf_stream_state_find_mesh(s, mesh_id);
        if (!u)
            return STATE_FAIL(c, err,
                              "frame %u refers to mesh %llu, which no MESH chunk before it "
                              "declares (the latest MESH is %s)",
                              (unsigned)index, (unsigned long long)mesh_id,
                              latest_mesh(s, buf, sizeof buf));
        return STATE_FAIL(c, err,
                          "frame %u refers to mesh %llu (MESH at byte %llu), which a later MESH "
                          "replaced: the latest MESH is %s",
                          (unsigned)index, (unsigned long long)mesh_id,
                          (unsigned long long)u->offset, latest_mesh(s, buf, sizeof buf));
    }
    if (n_nodes != s->mesh.n_nodes)
        return STATE_FAIL(c, err, "frame %u has %d nodes, but its MESH (%s) has %d",
                          (unsigned)index, (int)n_nodes, latest_mesh(s, buf, sizeof buf),
                          (int)s->mesh.n_nodes);
    pf_stream_mesh_use *u = &s->meshes[s->n_meshes - 1];
    count_frame(&u->n_frames, &u->first_frame, &u->last_frame, index);
    if (s->have_weights) { /* drawn on the latest surface */
        pf_stream_surface_use *v = &s->surfaces[s->n_surfaces - 1];
        count_frame(&v->n_frames, &v->first_frame, &v->last_frame, index);
    }
    ++s->n_frames;
    return PF_OK;
}

pf_status pf_stream_state_frame(pf_stream_state *s, const pf_chunk *c, pf_frame_data *f,
                                pf_error *err)
{
    PF_TRY(pf_stream_decode_frame(c, f, err));
    pf_status st = check_frame(s, c, f->mesh_id, f->index, f->n_nodes, err);
    if (st < 0)
        pf_frame_data_release(f);
    return st;
}

pf_status pf_stream_state_skip_frame(pf_stream_state *s, const pf_chunk *c, uint32_t *index,
                                     pf_error *err)
{
    /* checks tag, version and that the 24-byte header is there (docs/stream-format.md, FRAM) */
    PF_TRY(pf_stream_frame_index(c, index, err));
    uint64_t mesh_id = le_get_u64(c->payload);
    uint32_t n_nodes = le_get_u32(c->payload + 20);
    if (n_nodes > (uint32_t)INT32_MAX)
        return pf_stream_chunk_error(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__, c,
                                     "frame %u has %lu nodes", (unsigned)*index,
                                     (unsigned long)n_nodes);
    return check_frame(s, c, mesh_id, *index, (int32_t)n_nodes, err);
}

/* The groups of the latest MESH. GRPS is not critical: groups of another mesh (a tool that does
 * not know GRPS passed them on after making a new MESH) are ignored, not an error. */
static pf_status take_groups(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    if (!s->have_mesh || c->size < 20 || c->version != pf_stream_tag_version("GRPS") ||
        le_get_u64(c->payload) != s->mesh.id ||
        le_get_u32(c->payload + 8) != (uint32_t)s->mesh.n_elems ||
        le_get_u32(c->payload + 12) != (uint32_t)s->mesh.n_faces)
        return PF_OK;
    return pf_stream_decode_groups(c, &s->mesh, err);
}

pf_status pf_stream_state_take(pf_stream_state *s, const pf_chunk *c, pf_error *err)
{
    if (strcmp(c->tag, "MESH") == 0)
        return take_mesh(s, c, err);
    if (strcmp(c->tag, "SURF") == 0)
        return take_surface(s, c, err);
    if (strcmp(c->tag, "GRPS") == 0)
        return take_groups(s, c, err);
    if (strcmp(c->tag, "WGHT") == 0)
        return take_weights(s, c, err);
    if (strcmp(c->tag, "STRS") == 0)
        return take_stress(s, c, err);
    if (strcmp(c->tag, "SCEN") == 0)
        return take_scene(s, c, err);
    if (strcmp(c->tag, "FRAM") == 0) {
        pf_frame_data f = {0};
        PF_TRY(pf_stream_state_frame(s, c, &f, err));
        pf_frame_data_release(&f);
    }
    return PF_OK; /* INFO, END_ and unknown chunks */
}
