/* The frames of a pf stream as PNG images (pf-render): the reader state of the stream
 * (pf_stream_state), each frame drawn on its own mesh, the surface moved by its weights or the
 * mesh boundary, stress colours, one camera for the whole shot, and the survey pass that gives a
 * stored stream's camera and stress range before anything is drawn, so that any --frames range
 * reproduces the whole run's bytes. The simulation's scene (ground, obstacles) comes through the
 * caller's hooks: render does not read scenes. */
#include <pf/render.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The stream as the picture needs it: the reader state, the displaced surface's scratch and
 * whether the surface is closed (for back-face culling), per-element stress as von Mises. */
typedef struct picture {
    pf_stream_state st;
    bool surface_closed;
    double *x; /* [3 st.surface.n_verts] */
} picture;

/* The animation's bounding box and stress range: the survey of a file, or grown frame by frame on
 * a pipe. */
typedef struct survey {
    bool have_box;
    pf_vec3 lo, hi;
    bool have_stress;
    double stress_lo, stress_hi;
    int64_t to_draw; /* the images the file gives in the frames range (progress's total) */
} survey;

struct pf_render_stream {
    pf_render_stream_params p;
    picture pic;
    survey sv;
    bool from_file; /* sv covers the whole animation */
    pf_boundary boundary;
    uint64_t boundary_serial; /* the state's mesh_serial the boundary is of (0: none) */
    pf_render_geometry geom;
    pf_renderer *renderer;
    pf_render_view view;
    bool view_ready;
    uint8_t *rgb;
    double *node_values, *vert_values;
    bool warned_no_stress;
    int64_t written;
    char *path;
    pf_frame_data pending; /* stress mode: a frame waiting for its STRS chunk */
    bool have_pending;
};

pf_render_stream_params pf_render_stream_params_default(void)
{
    pf_render_stream_params p = {.width = 1280,
                                 .height = 720,
                                 .mode = PF_RENDER_MODE_SURFACE,
                                 .first = 0,
                                 .last = (int64_t)UINT32_MAX,
                                 .out_dir = "frames"};
    pf_paint d = pf_paint_default();
    memcpy(p.cap_rgb, d.cap_rgb, sizeof p.cap_rgb);
    return p;
}

static bool in_range(const pf_render_stream *rs, uint32_t index)
{
    return (int64_t)index >= rs->p.first && (int64_t)index <= rs->p.last;
}

/* ---- the picture of the stream --------------------------------------------------------------- */

static void picture_release(picture *pic)
{
    pf_stream_state_release(&pic->st);
    pf_free(pic->x);
    memset(pic, 0, sizeof *pic);
}

/* A chunk other than FRAM into the state, and what the picture derives from it. */
static pf_status picture_take(picture *pic, const pf_chunk *c, pf_error *err)
{
    PF_TRY(pf_stream_state_take(&pic->st, c, err));
    if (strcmp(c->tag, "SURF") == 0) {
        pf_surface_stats st;
        PF_TRY(pf_surface_compute_stats(&pic->st.surface, &st, err));
        pic->surface_closed = st.closed && st.manifold;
        pf_free(pic->x);
        pic->x = pf_alloc_array(3 * (size_t)pic->st.surface.n_verts + 1, sizeof *pic->x);
        PF_CHECK(pic->x, err, PF_ERR_NOMEM, "out of memory for a surface of %d vertices",
                 (int)pic->st.surface.n_verts);
    } else if (strcmp(c->tag, "STRS") == 0) {
        pf_stress_data *s = &pic->st.stress; /* von Mises in place from 6 components */
        if (s->components == 6)
            for (int32_t e = 0; e < s->n_elems; ++e)
                s->values[e] = pf_von_mises(s->values + 6 * (size_t)e);
        s->components = 1;
    }
    return PF_OK;
}

/* Draws the surface (moved by the weights) when it can, else the mesh boundary; mesh mode draws
 * the mesh whenever there is one. */
static bool draws_surface(const picture *pic, pf_render_mode m)
{
    if (m == PF_RENDER_MODE_MESH)
        return !pic->st.have_mesh;
    return pic->st.have_weights || !pic->st.have_mesh;
}

/* The bounding box of the drawn geometry of a frame (u NULL: at rest). */
static void frame_bounds(picture *pic, pf_render_mode m, const double *u, pf_vec3 *lo,
                         pf_vec3 *hi)
{
    const pf_stream_state *st = &pic->st;
    *lo = pf_v3(INFINITY, INFINITY, INFINITY);
    *hi = pf_v3(-INFINITY, -INFINITY, -INFINITY);
    const double *x;
    int32_t n;
    if (draws_surface(pic, m)) {
        x = st->surface.x;
        if (u && st->have_weights) {
            pf_weights_apply(&st->weights, st->surface.x, u, pic->x);
            x = pic->x;
        }
        n = st->surface.n_verts;
        u = NULL;
    } else {
        x = st->mesh.x;
        n = st->mesh.n_nodes;
    }
    for (int32_t i = 0; i < n; ++i) {
        pf_vec3 p = pf_v3_load(x + 3 * (size_t)i);
        if (u)
            p = pf_v3_add(p, pf_v3_load(u + 3 * (size_t)i));
        *lo = pf_v3_min(*lo, p);
        *hi = pf_v3_max(*hi, p);
    }
}

/* The renderer works in float, and its view transform multiplies positions by distances:
 * positions beyond 1e30 (float's range ends at 3.4e38) cannot be drawn. Refused naming the frame,
 * rather than failing later on a camera built from an overflowing box. */
static pf_status check_drawable(pf_vec3 lo, pf_vec3 hi, uint32_t index, pf_error *err)
{
    if (!(lo.x <= hi.x))
        return PF_OK; /* nothing drawn */
    double m = fmax(fmax(fmax(fabs(lo.x), fabs(lo.y)), fmax(fabs(lo.z), fabs(hi.x))),
                    fmax(fabs(hi.y), fabs(hi.z)));
    PF_CHECK(m <= 1e30, err, PF_ERR_FORMAT,
             "frame %u: displaced positions reach %.3g, beyond the 1e30 the renderer's single "
             "precision can draw (a diverged simulation?)",
             (unsigned)index, m);
    return PF_OK;
}

static bool ground_height(const pf_render_stream *rs, const picture *pic, double *z)
{
    const pf_render_stream_hooks *h = &rs->p.hooks;
    return h->ground_height && h->ground_height(h->ctx, &pic->st, z);
}

/* ---- pass 1 (files): the animation's bounding box and stress range --------------------------- */

static void grow_box(survey *sv, pf_vec3 lo, pf_vec3 hi)
{
    if (!(lo.x <= hi.x))
        return;
    sv->lo = sv->have_box ? pf_v3_min(sv->lo, lo) : lo;
    sv->hi = sv->have_box ? pf_v3_max(sv->hi, hi) : hi;
    sv->have_box = true;
}

static void grow_stress(survey *sv, const pf_stress_data *st)
{
    for (int32_t e = 0; e < st->n_elems; ++e) {
        double v = st->values[e];
        sv->stress_lo = sv->have_stress ? fmin(sv->stress_lo, v) : fmin(0, v);
        sv->stress_hi = sv->have_stress ? fmax(sv->stress_hi, v) : v;
        sv->have_stress = true;
    }
}

static pf_status survey_chunk(picture *pic, survey *sv, pf_render_mode m, const pf_chunk *c,
                              pf_error *err)
{
    if (strcmp(c->tag, "FRAM") != 0) {
        PF_TRY(picture_take(pic, c, err));
        if (strcmp(c->tag, "STRS") == 0)
            grow_stress(sv, &pic->st.stress);
        return PF_OK;
    }
    pf_frame_data f = {0};
    PF_TRY(pf_stream_state_frame(&pic->st, c, &f, err));
    pf_vec3 lo, hi;
    frame_bounds(pic, m, f.u, &lo, &hi);
    pf_status st = check_drawable(lo, hi, f.index, err); /* ends the survey before the box */
    if (st == PF_OK)
        grow_box(sv, lo, hi);
    pf_frame_data_release(&f);
    return st;
}

void pf_render_stream_survey(pf_render_stream *rs, FILE *f, const char *name)
{
    picture pic = {0};
    survey *sv = &rs->sv;
    pf_stream_reader *r = NULL;
    pf_error err = {0};
    if (pf_stream_reader_create(&r, f, name, &err) == PF_OK) {
        for (;;) {
            pf_chunk c;
            bool end = false;
            if (pf_stream_read_chunk(r, &c, &end, &err) != PF_OK || end)
                break;
            if (survey_chunk(&pic, sv, rs->p.mode, &c, &err) != PF_OK)
                break; /* the rendering pass reports it */
            uint32_t index;
            if (strcmp(c.tag, "FRAM") == 0 && pf_stream_frame_index(&c, &index, &err) == PF_OK &&
                in_range(rs, index))
                ++sv->to_draw;
        }
    }
    /* no frames: the rest shape is what is drawn */
    if (pic.st.n_frames == 0 && (pic.st.have_mesh || pic.st.have_surface)) {
        pf_vec3 lo, hi;
        frame_bounds(&pic, rs->p.mode, NULL, &lo, &hi);
        grow_box(sv, lo, hi);
        sv->to_draw = in_range(rs, 0) ? 1 : 0;
    }
    double ground;
    if (sv->have_box && ground_height(rs, &pic, &ground))
        sv->lo.z = fmin(sv->lo.z, ground); /* the stage reaches down to the simulated ground */
    pf_stream_reader_destroy(&r);
    picture_release(&pic);
    rs->from_file = true;
}

/* ---- pass 2: drawing ------------------------------------------------------------------------- */

static pf_status ensure_boundary(pf_render_stream *rs, pf_error *err)
{
    if (rs->boundary_serial == rs->pic.st.mesh_serial)
        return PF_OK;
    pf_boundary_release(&rs->boundary);
    rs->boundary_serial = 0;
    PF_TRY(pf_boundary_extract(&rs->pic.st.mesh, &rs->boundary, err));
    rs->boundary_serial = rs->pic.st.mesh_serial;
    return PF_OK;
}

static pf_status stress_paint(pf_render_stream *rs, pf_paint *p, bool on_surface, pf_error *err)
{
    const pf_stream_state *st = &rs->pic.st;
    p->kind = PF_PAINT_ELEM_VALUE;
    p->values = st->stress.values;
    p->lo = rs->sv.stress_lo;
    p->hi = rs->sv.stress_hi > rs->sv.stress_lo ? rs->sv.stress_hi : rs->sv.stress_lo + 1;
    if (!on_surface)
        return PF_OK;
    pf_free(rs->node_values);
    pf_free(rs->vert_values);
    rs->node_values = pf_alloc_array((size_t)st->mesh.n_nodes + 1, sizeof *rs->node_values);
    rs->vert_values = pf_alloc_array((size_t)st->surface.n_verts + 1, sizeof *rs->vert_values);
    PF_CHECK(rs->node_values && rs->vert_values, err, PF_ERR_NOMEM, "out of memory");
    PF_TRY(pf_render_elem_to_node(&st->mesh, st->stress.values, rs->node_values, err));
    pf_weights_apply_scalar(&st->weights, rs->node_values, rs->vert_values);
    p->kind = PF_PAINT_VERT_VALUE;
    p->values = rs->vert_values;
    return PF_OK;
}

/* The frame's geometry: surface or mesh boundary, painted by the mode. *legend: a stress legend
 * belongs in the image. */
static pf_status build_geometry(pf_render_stream *rs, const pf_frame_data *f, bool *legend,
                                pf_error *err)
{
    picture *pic = &rs->pic;
    const pf_stream_state *st = &pic->st;
    const double *u = f ? f->u : NULL;
    pf_render_mode mode = rs->p.mode;
    bool surface = draws_surface(pic, mode);
    bool stress = mode == PF_RENDER_MODE_STRESS && f && st->have_stress &&
                  st->stress.frame == f->index && st->stress.mesh_id == st->mesh.id;
    if (mode == PF_RENDER_MODE_STRESS && !stress && !rs->warned_no_stress) {
        if (rs->p.hooks.warn) {
            char msg[96];
            snprintf(msg, sizeof msg, "no STRS chunk for frame %u: drawn without colours",
                     f ? (unsigned)f->index : 0u);
            rs->p.hooks.warn(rs->p.hooks.ctx, msg);
        }
        rs->warned_no_stress = true;
    }
    pf_paint p = pf_paint_default();
    *legend = false;
    if (stress) {
        if (!rs->from_file)
            grow_stress(&rs->sv, &st->stress);
        PF_TRY(stress_paint(rs, &p, surface && st->have_weights, err));
        *legend = true;
    }
    pf_render_geometry_clear(&rs->geom);
    if (surface) {
        const double *x = st->surface.x;
        if (u && st->have_weights) {
            pf_weights_apply(&st->weights, st->surface.x, u, pic->x);
            x = pic->x;
        }
        p.wire = mode == PF_RENDER_MODE_MESH;
        if (p.kind == PF_PAINT_ELEM_VALUE) /* stress without weights cannot reach the surface */
            p = pf_paint_default(), *legend = false;
        memcpy(p.cap_rgb, rs->p.cap_rgb, sizeof p.cap_rgb);
        rs->geom.closed = pic->surface_closed;
        return pf_render_add_surface(&rs->geom, &st->surface, x, &p, err);
    }
    PF_TRY(ensure_boundary(rs, err));
    if (mode == PF_RENDER_MODE_MESH) {
        p.kind = PF_PAINT_ELEM_KIND;
        p.wire = true;
    }
    rs->geom.closed = true;
    return pf_render_add_boundary(&rs->geom, &st->mesh, &rs->boundary, u, &p, err);
}

/* The view, fixed at the first frame of the stream (u: its displacements; NULL: the rest shape).
 * The automatic camera frames the survey's box when there is one (a file: the whole animation);
 * on a pipe, the first frame's box grown by a quarter of its size on every side but the bottom
 * (room for the motion to come), down to the simulated ground when the hooks give one. The first
 * frame of the stream, not of the range, so that every range of a shot has the same camera. */
static void ensure_view(pf_render_stream *rs, const double *u)
{
    if (rs->view_ready)
        return;
    double aspect = (double)rs->p.width / rs->p.height;
    pf_vec3 lo, hi;
    frame_bounds(&rs->pic, rs->p.mode, u, &lo, &hi);
    if (rs->sv.have_box) {
        lo = rs->sv.lo;
        hi = rs->sv.hi;
    } else if (lo.x <= hi.x) {
        pf_vec3 m = pf_v3_scale(pf_v3_sub(hi, lo), 0.25);
        lo = pf_v3(lo.x - m.x, lo.y - m.y, lo.z);
        hi = pf_v3_add(hi, m);
        double ground;
        if (ground_height(rs, &rs->pic, &ground))
            lo.z = fmin(lo.z, ground);
    } else {
        lo = pf_v3(-1, -1, -1);
        hi = pf_v3(1, 1, 1);
    }
    rs->view = pf_render_view_default(lo, hi, aspect);
    if (rs->p.has_camera) {
        rs->view.camera = rs->p.camera;
        rs->view.up = pf_v3_normalize(rs->p.camera.up);
    }
    rs->view_ready = true;
}

static pf_status render_frame(pf_render_stream *rs, const pf_frame_data *f, pf_error *err)
{
    const pf_render_stream_hooks *h = &rs->p.hooks;
    pf_vec3 lo, hi;
    frame_bounds(&rs->pic, rs->p.mode, f ? f->u : NULL, &lo, &hi);
    PF_TRY(check_drawable(lo, hi, f ? f->index : 0u, err));
    bool legend;
    PF_TRY(build_geometry(rs, f, &legend, err));
    ensure_view(rs, f ? f->u : NULL); /* framed on the body, not the obstacles */
    if (h->add_obstacles)
        PF_TRY(h->add_obstacles(h->ctx, &rs->pic.st, f ? f->time : 0, &rs->geom, err));
    PF_TRY(pf_renderer_draw(rs->renderer, &rs->geom, &rs->view, rs->rgb, err));
    if (legend)
        pf_render_draw_legend(rs->rgb, rs->p.width, rs->p.height, rs->sv.stress_lo,
                              rs->sv.stress_hi > rs->sv.stress_lo ? rs->sv.stress_hi
                                                                  : rs->sv.stress_lo + 1);
    uint32_t index = f ? f->index : 0u;
    sprintf(rs->path, "%s/frame_%05u.png", rs->p.out_dir, (unsigned)index);
    PF_TRY(pf_png_write(rs->path, rs->rgb, rs->p.width, rs->p.height, 3, err));
    ++rs->written;
    if (h->on_image)
        PF_TRY(h->on_image(h->ctx, index, rs->rgb, err));
    return PF_OK;
}

static pf_status flush_pending(pf_render_stream *rs, pf_error *err)
{
    if (!rs->have_pending)
        return PF_OK;
    rs->have_pending = false;
    pf_status s = render_frame(rs, &rs->pending, err);
    pf_frame_data_release(&rs->pending);
    return s;
}

static pf_status take_frame(pf_render_stream *rs, const pf_chunk *c, pf_error *err)
{
    PF_TRY(flush_pending(rs, err));
    uint32_t index;
    PF_TRY(pf_stream_frame_index(c, &index, err));
    /* frames out of range are checked by their header, not decoded, but for the first one,
     * which fixes the camera */
    if (!in_range(rs, index) && rs->view_ready)
        return pf_stream_state_skip_frame(&rs->pic.st, c, &index, err);
    pf_frame_data f = {0};
    PF_TRY(pf_stream_state_frame(&rs->pic.st, c, &f, err));
    ensure_view(rs, f.u);
    pf_status s = PF_OK;
    if (in_range(rs, f.index)) {
        /* in stress mode a frame waits for its STRS, which may follow it */
        const pf_stream_state *st = &rs->pic.st;
        if (rs->p.mode == PF_RENDER_MODE_STRESS &&
            !(st->have_stress && st->stress.frame == f.index)) {
            rs->pending = f;
            rs->have_pending = true;
            return PF_OK;
        }
        s = render_frame(rs, &f, err);
    }
    pf_frame_data_release(&f);
    return s;
}

pf_status pf_render_stream_take(pf_render_stream *rs, const pf_chunk *c, pf_error *err)
{
    if (strcmp(c->tag, "FRAM") == 0)
        return take_frame(rs, c, err);
    /* a pending frame is drawn on its own mesh, surface and weights */
    if (strcmp(c->tag, "MESH") == 0 || strcmp(c->tag, "SURF") == 0 || strcmp(c->tag, "WGHT") == 0)
        PF_TRY(flush_pending(rs, err));
    PF_TRY(picture_take(&rs->pic, c, err));
    if (strcmp(c->tag, "SCEN") == 0 && rs->p.hooks.on_scene)
        rs->p.hooks.on_scene(rs->p.hooks.ctx, &rs->pic.st);
    if (strcmp(c->tag, "STRS") == 0 && rs->have_pending &&
        rs->pic.st.stress.frame == rs->pending.index)
        return flush_pending(rs, err);
    return PF_OK; /* INFO, END_ and unknown chunks do not change the picture */
}

pf_status pf_render_stream_finish(pf_render_stream *rs, bool stream_ok, const char *name,
                                  pf_error *err)
{
    /* the frames read before an error are drawn all the same; the first error is reported */
    pf_error later = {0};
    pf_status s = flush_pending(rs, stream_ok ? err : &later);
    if (!stream_ok || s != PF_OK)
        return s;
    if (rs->pic.st.n_frames == 0 && rs->written == 0 && in_range(rs, 0)) {
        PF_CHECK(rs->pic.st.have_mesh || rs->pic.st.have_surface, err, PF_ERR_FORMAT,
                 "%s: nothing to draw: no MESH and no SURF chunk", name);
        return render_frame(rs, NULL, err);
    }
    return PF_OK;
}

int64_t pf_render_stream_written(const pf_render_stream *rs)
{
    return rs->written;
}

int64_t pf_render_stream_to_draw(const pf_render_stream *rs)
{
    return rs->from_file ? rs->sv.to_draw : -1;
}

/* ---- life cycle ------------------------------------------------------------------------------ */

pf_status pf_render_stream_create(pf_render_stream **out, const pf_render_stream_params *p,
                                  pf_error *err)
{
    *out = NULL;
    PF_CHECK(p->width > 0 && p->height > 0 && p->out_dir && p->first <= p->last, err,
             PF_ERR_INVALID, "bad render stream parameters (size %dx%d, frames %lld..%lld)",
             (int)p->width, (int)p->height, (long long)p->first, (long long)p->last);
    pf_render_stream *rs = pf_calloc(1, sizeof *rs);
    PF_CHECK(rs, err, PF_ERR_NOMEM, "out of memory");
    rs->p = *p;
    rs->path = pf_alloc(strlen(p->out_dir) + 32);
    rs->rgb = pf_alloc_array(3 * (size_t)p->width, (size_t)p->height);
    pf_status s = PF_OK;
    if (!rs->path || !rs->rgb)
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                         "out of memory for a %dx%d image", (int)p->width, (int)p->height);
    if (s == PF_OK) {
        pf_render_params rp = pf_render_params_default();
        rp.width = p->width;
        rp.height = p->height;
        s = pf_renderer_create(&rs->renderer, &rp, err);
    }
    if (s != PF_OK) {
        pf_render_stream_destroy(&rs);
        return s;
    }
    *out = rs;
    return PF_OK;
}

void pf_render_stream_destroy(pf_render_stream **rs)
{
    pf_render_stream *r = *rs;
    if (!r)
        return;
    pf_renderer_destroy(&r->renderer);
    pf_render_geometry_release(&r->geom);
    pf_boundary_release(&r->boundary);
    pf_frame_data_release(&r->pending);
    picture_release(&r->pic);
    pf_free(r->rgb);
    pf_free(r->path);
    pf_free(r->node_values);
    pf_free(r->vert_values);
    pf_free(r);
    *rs = NULL;
}
