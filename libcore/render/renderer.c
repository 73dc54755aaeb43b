/* The renderer: an OSMesa OpenGL 3.3 core context, a shadow pass, a multisampled scene pass and a
 * resolve pass that writes 8-bit sRGB, read back into the caller's image.
 *
 * Determinism: llvmpipe rasterises in tiles, each tile by one thread in primitive order, with the
 * standard fixed sample positions; every shader input here is computed in a fixed order on the CPU
 * and the shaders use no random or time-dependent state, so the bytes do not depend on the number
 * of rasteriser threads.
 */
#include <pf/render.h>

#include <string.h>

#include "gl.h"

struct pf_renderer {
    pf_render_params p;
    OSMesaContext ctx;
    unsigned char window[4 * 4 * 4]; /* the context's own (unused) 4 x 4 RGBA framebuffer */
    pf_gl gl;
    GLuint scene_prog[2], depth_prog, ground_prog[2], resolve_prog; /* [wire], [shadowed] */
    GLuint vao, vbo, ebo, ground_vao, ground_vbo, empty_vao;
    GLuint ms_fbo, ms_color, ms_depth; /* multisampled linear colour and depth */
    GLuint out_fbo, out_color;         /* resolved sRGB, 8 bits per channel */
    GLuint shadow_fbo, shadow_tex;     /* shadow map (depth) */
    uint8_t *readback;                 /* [4 width height] */
};

pf_render_params pf_render_params_default(void)
{
    return (pf_render_params){.width = 1280, .height = 720, .samples = 4, .shadow_size = 0};
}

pf_render_view pf_render_view_default(pf_vec3 lo, pf_vec3 hi, double aspect)
{
    pf_render_view v = {.up = pf_v3(0, 0, 1), .lo = lo, .hi = hi, .ground = true};
    v.camera = pf_camera_fit(lo, hi, v.up, 35, aspect, 0.9);
    /* a pale blue-grey, sRGB (0.86, 0.88, 0.91) */
    v.background[0] = (float)pf_srgb_to_linear(0.86);
    v.background[1] = (float)pf_srgb_to_linear(0.88);
    v.background[2] = (float)pf_srgb_to_linear(0.91);
    return v;
}

static pf_status check_params(const pf_render_params *p, pf_error *err)
{
    PF_CHECK(p->width >= 1 && p->width <= 8192 && p->height >= 1 && p->height <= 8192, err,
             PF_ERR_INVALID, "image size %dx%d outside 1x1 .. 8192x8192", (int)p->width,
             (int)p->height);
    PF_CHECK(p->samples == 1 || p->samples == 2 || p->samples == 4, err, PF_ERR_INVALID,
             "multisample count %d is not 1, 2 or 4", (int)p->samples);
    PF_CHECK(p->shadow_size >= 0 && p->shadow_size <= 8192, err, PF_ERR_INVALID,
             "shadow map size %d outside 0 .. 8192", (int)p->shadow_size);
    return PF_OK;
}

static pf_status make_context(pf_renderer *r, pf_error *err)
{
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           0,
                           OSMESA_PROFILE,
                           OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           3,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           3,
                           0};
    r->ctx = OSMesaCreateContextAttribs(attribs, NULL);
    PF_CHECK(r->ctx, err, PF_ERR_UNSUPPORTED,
             "OSMesa cannot create an OpenGL 3.3 core-profile context");
    PF_CHECK(OSMesaMakeCurrent(r->ctx, r->window, GL_UNSIGNED_BYTE, 4, 4), err, PF_ERR_UNSUPPORTED,
             "OSMesa cannot make its context current");
    return pf_gl_load(&r->gl, err);
}

#define OBJECT_TAPS_N 1
#define GROUND_TAPS_N 8
/* Shadow taps: on objects one bilinear comparison (their self-shadows are seen at the scale of a
 * shadow-map texel, and every tap is a texture fetch per fragment, the renderer's largest cost);
 * on the ground, where the soft shadow is the depth cue, a filtered penumbra. */
#define PF_STR_(x) #x
#define PF_STR(x)  PF_STR_(x)

static pf_status make_programs(pf_renderer *r, pf_error *err)
{
    static const char *const SCENE_ATTRIBS[] = {"a_pos", "a_normal", "a_color", "a_edge"};
    const pf_gl *gl = &r->gl;
    PF_TRY(pf_gl_program(gl, "scene", "#define WIRE 0\n#define TAPS " PF_STR(OBJECT_TAPS_N) "\n",
                         PF_GLSL_SCENE_VS, PF_GLSL_SCENE_FS, SCENE_ATTRIBS, 4, &r->scene_prog[0],
                         err));
    PF_TRY(pf_gl_program(
        gl, "wireframe", "#define WIRE 1\n#define TAPS " PF_STR(OBJECT_TAPS_N) "\n",
        PF_GLSL_SCENE_VS, PF_GLSL_SCENE_FS, SCENE_ATTRIBS, 4, &r->scene_prog[1], err));
    PF_TRY(pf_gl_program(gl, "shadow", NULL, PF_GLSL_DEPTH_VS, PF_GLSL_DEPTH_FS, SCENE_ATTRIBS, 1,
                         &r->depth_prog, err));
    PF_TRY(pf_gl_program(gl, "ground", "#define TAPS 0\n", PF_GLSL_GROUND_VS, PF_GLSL_GROUND_FS,
                         SCENE_ATTRIBS, 1, &r->ground_prog[0], err));
    PF_TRY(pf_gl_program(gl, "shadowed ground", "#define TAPS " PF_STR(GROUND_TAPS_N) "\n",
                         PF_GLSL_GROUND_VS, PF_GLSL_GROUND_FS, SCENE_ATTRIBS, 1, &r->ground_prog[1],
                         err));
    return pf_gl_program(gl, "resolve", NULL, PF_GLSL_RESOLVE_VS, PF_GLSL_RESOLVE_FS, NULL, 0,
                         &r->resolve_prog, err);
}

static pf_status check_framebuffer(const pf_gl *gl, const char *name, pf_error *err)
{
    GLenum s = gl->CheckFramebufferStatus(GL_FRAMEBUFFER);
    PF_CHECK(s == GL_FRAMEBUFFER_COMPLETE, err, PF_ERR_UNSUPPORTED,
             "OpenGL: the %s framebuffer is incomplete (status 0x%04x)", name, (unsigned)s);
    return PF_OK;
}

static int32_t shadow_size(const pf_render_params *p)
{
    return p->shadow_size ? p->shadow_size : 1024;
}

static pf_status make_framebuffers(pf_renderer *r, pf_error *err)
{
    const pf_gl *gl = &r->gl;
    GLsizei w = r->p.width, h = r->p.height, n = r->p.samples;
    gl->GenTextures(1, &r->ms_color);
    gl->BindTexture(GL_TEXTURE_2D_MULTISAMPLE, r->ms_color);
    gl->TexImage2DMultisample(GL_TEXTURE_2D_MULTISAMPLE, n, GL_RGBA16F, w, h, GL_TRUE);
    gl->GenRenderbuffers(1, &r->ms_depth);
    gl->BindRenderbuffer(GL_RENDERBUFFER, r->ms_depth);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, n, GL_DEPTH_COMPONENT24, w, h);
    gl->GenFramebuffers(1, &r->ms_fbo);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->ms_fbo);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D_MULTISAMPLE,
                             r->ms_color, 0);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->ms_depth);
    PF_TRY(check_framebuffer(gl, "multisampled scene", err));

    gl->GenTextures(1, &r->out_color);
    gl->BindTexture(GL_TEXTURE_2D, r->out_color);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
    gl->GenFramebuffers(1, &r->out_fbo);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->out_fbo);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r->out_color, 0);
    PF_TRY(check_framebuffer(gl, "output", err));

    GLsizei s = shadow_size(&r->p);
    static const GLfloat BORDER[4] = {1, 1, 1, 1}; /* depth 1 outside the map: lit */
    gl->GenTextures(1, &r->shadow_tex);
    gl->BindTexture(GL_TEXTURE_2D, r->shadow_tex);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, s, s, 0, GL_DEPTH_COMPONENT,
                   GL_UNSIGNED_INT, NULL);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
    gl->TexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_BORDER_COLOR, BORDER);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    gl->GenFramebuffers(1, &r->shadow_fbo);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->shadow_fbo);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, r->shadow_tex, 0);
    gl->DrawBuffer(GL_NONE);
    gl->ReadBuffer(GL_NONE);
    PF_TRY(check_framebuffer(gl, "shadow", err));
    return pf_gl_check(gl, "creating the framebuffers", err);
}

/* Vertex layout of pf_render_vertex: four float triples. */
static void make_buffers(pf_renderer *r)
{
    const pf_gl *gl = &r->gl;
    gl->GenVertexArrays(1, &r->vao);
    gl->BindVertexArray(r->vao);
    gl->GenBuffers(1, &r->vbo);
    gl->GenBuffers(1, &r->ebo);
    gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo);
    gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ebo);
    for (GLuint a = 0; a < 4; ++a) {
        gl->VertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, (GLsizei)sizeof(pf_render_vertex),
                                (const void *)(a * 3 * sizeof(float)));
        gl->EnableVertexAttribArray(a);
    }
    gl->GenVertexArrays(1, &r->ground_vao);
    gl->BindVertexArray(r->ground_vao);
    gl->GenBuffers(1, &r->ground_vbo);
    gl->BindBuffer(GL_ARRAY_BUFFER, r->ground_vbo);
    gl->VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), NULL);
    gl->EnableVertexAttribArray(0);
    gl->GenVertexArrays(1, &r->empty_vao);
    gl->BindVertexArray(0);
}

pf_status pf_renderer_create(pf_renderer **out, const pf_render_params *p, pf_error *err)
{
    *out = NULL;
    PF_TRY(check_params(p, err));
    pf_renderer *r = pf_calloc(1, sizeof *r);
    PF_CHECK(r, err, PF_ERR_NOMEM, "cannot allocate a renderer");
    r->p = *p;
    r->readback = pf_alloc_array(4 * (size_t)p->width, (size_t)p->height);
    pf_status s =
        r->readback ? PF_OK
                    : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                   "cannot allocate a %dx%d image", (int)p->width, (int)p->height);
    if (s == PF_OK)
        s = make_context(r, err);
    if (s == PF_OK)
        s = make_programs(r, err);
    if (s == PF_OK)
        s = make_framebuffers(r, err);
    if (s == PF_OK) {
        make_buffers(r);
        s = pf_gl_check(&r->gl, "creating the vertex buffers", err);
    }
    if (s != PF_OK) {
        pf_renderer_destroy(&r);
        return s;
    }
    *out = r;
    return PF_OK;
}

void pf_renderer_destroy(pf_renderer **rp)
{
    pf_renderer *r = *rp;
    if (!r)
        return;
    if (r->ctx) {
        /* Destroying the context frees every GL object it owns. */
        OSMesaMakeCurrent(r->ctx, r->window, GL_UNSIGNED_BYTE, 4, 4);
        OSMesaDestroyContext(r->ctx);
    }
    pf_free(r->readback);
    pf_free(r);
    *rp = NULL;
}

/* ---- drawing --------------------------------------------------------------------------------- */

static void to_float16(const double m[16], GLfloat f[16])
{
    for (int i = 0; i < 16; ++i)
        f[i] = (GLfloat)m[i];
}

/* c = a b for column-major 4x4 matrices. */
static void mat4_mul(const double a[16], const double b[16], double c[16])
{
    for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) {
            double s = 0;
            for (int k = 0; k < 4; ++k)
                s += a[4 * k + row] * b[4 * col + k];
            c[4 * col + row] = s;
        }
}

/* What every draw of a frame shares, computed once on the CPU in double precision. */
typedef struct frame_setup {
    pf_vec3 up, e1, e2; /* world up and two horizontal unit axes */
    pf_vec3 center;     /* centre of the stage */
    double radius;      /* radius of the stage's bounding sphere (> 0) */
    double ground;      /* height of the ground along up */
    pf_vec3 light;      /* unit vector towards the key light */
    GLfloat view_proj[16], light_view_proj[16];
    double shadow_radius; /* PCF radius in shadow-map uv units */
} frame_setup;

static pf_vec3 perpendicular_unit(pf_vec3 up)
{
    pf_vec3 a = fabs(up.x) < 0.9 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0);
    return pf_v3_normalize(pf_v3_sub(a, pf_v3_scale(up, pf_v3_dot(a, up))));
}

/* Orthographic light camera along -light, covering the stage's bounding sphere sideways and three
 * radii deep on either side, so that the ground under the stage is inside the depth range. */
static void light_matrix(const frame_setup *f, double out[16])
{
    pf_camera lc = {.eye = pf_v3_add(f->center, pf_v3_scale(f->light, 4 * f->radius)),
                    .target = f->center,
                    .up = perpendicular_unit(f->light),
                    .fov_deg = 1};
    double view[16], proj[16] = {0};
    pf_camera_matrices(&lc, 1, 1, 2, view, proj); /* only the view is used */
    double r = f->radius, n = f->radius, fa = 8 * f->radius;
    memset(proj, 0, sizeof proj);
    proj[0] = 1 / r;
    proj[5] = 1 / r;
    proj[10] = -2 / (fa - n);
    proj[14] = -(fa + n) / (fa - n);
    proj[15] = 1;
    mat4_mul(proj, view, out);
}

static void setup_frame(const pf_renderer *r, const pf_render_view *v, frame_setup *f)
{
    f->up = pf_v3_normalize(v->up);
    f->e1 = perpendicular_unit(f->up);
    f->e2 = pf_v3_cross(f->up, f->e1);
    f->center = pf_v3_scale(pf_v3_add(v->lo, v->hi), 0.5);
    f->radius = 0.5 * pf_v3_dist(v->lo, v->hi);
    if (!(f->radius > 0))
        f->radius = 1;
    f->ground = INFINITY;
    for (int k = 0; k < 8; ++k) {
        pf_vec3 p =
            pf_v3(k & 1 ? v->hi.x : v->lo.x, k & 2 ? v->hi.y : v->lo.y, k & 4 ? v->hi.z : v->lo.z);
        f->ground = fmin(f->ground, pf_v3_dot(p, f->up));
    }
    /* a hair below the lowest point, so that a face resting on the ground does not z-fight */
    f->ground -= 1e-3 * f->radius;
    /* the key light: 55 degrees above the horizon, from the camera's left-front quarter */
    pf_vec3 h = pf_v3_normalize(pf_v3_add(pf_v3_scale(f->e1, -0.45), pf_v3_scale(f->e2, -0.9)));
    f->light = pf_v3_normalize(pf_v3_add(pf_v3_scale(h, cos(55 * 3.14159265358979 / 180)),
                                         pf_v3_scale(f->up, sin(55 * 3.14159265358979 / 180))));

    double aspect = (double)r->p.width / r->p.height;
    double dist = pf_v3_dist(v->camera.eye, f->center);
    double near_z = fmax(0.01 * f->radius, dist - 2 * f->radius);
    double far_z = dist + 10 * f->radius;
    double view[16], proj[16], vp[16], lvp[16];
    pf_camera_matrices(&v->camera, aspect, near_z, far_z, view, proj);
    mat4_mul(proj, view, vp);
    to_float16(vp, f->view_proj);
    light_matrix(f, lvp);
    to_float16(lvp, f->light_view_proj);
    f->shadow_radius = 0.008; /* of the map's width: 1.6% of the stage diameter, 8 texels */
}

/* The PCF tap offsets (shadow-map uv units): a Vogel spiral, radius sqrt((i + 1/2) / n) times the
 * filter radius and the golden angle between taps, which covers the disc evenly for any n. One tap
 * sits at the centre. */
static void set_taps(const pf_renderer *r, GLuint prog, int n, double radius)
{
    GLfloat taps[2 * 16];
    for (int i = 0; i < n && i < 16; ++i) {
        double rho = n == 1 ? 0 : radius * sqrt((i + 0.5) / n), a = 2.39996322972865332 * i;
        taps[2 * i] = (GLfloat)(rho * cos(a));
        taps[2 * i + 1] = (GLfloat)(rho * sin(a));
    }
    r->gl.Uniform2fv(r->gl.GetUniformLocation(prog, "u_taps"), n, taps);
}

static void set_common_uniforms(const pf_renderer *r, GLuint prog, const frame_setup *f,
                                const pf_render_view *v)
{
    const pf_gl *gl = &r->gl;
    GLfloat up[3] = {(GLfloat)f->up.x, (GLfloat)f->up.y, (GLfloat)f->up.z};
    GLfloat light[3] = {(GLfloat)f->light.x, (GLfloat)f->light.y, (GLfloat)f->light.z};
    GLfloat eye[3] = {(GLfloat)v->camera.eye.x, (GLfloat)v->camera.eye.y, (GLfloat)v->camera.eye.z};
    gl->UseProgram(prog);
    gl->UniformMatrix4fv(gl->GetUniformLocation(prog, "u_view_proj"), 1, GL_FALSE, f->view_proj);
    gl->UniformMatrix4fv(gl->GetUniformLocation(prog, "u_light_view_proj"), 1, GL_FALSE,
                         f->light_view_proj);
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_shadow"), 0);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_up"), 1, up);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_light_dir"), 1, light);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_eye"), 1, eye);
}

static void upload(const pf_renderer *r, const pf_render_geometry *g)
{
    const pf_gl *gl = &r->gl;
    gl->BindVertexArray(r->vao);
    gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(g->n_verts * (int64_t)sizeof *g->verts), g->verts,
                   GL_STREAM_DRAW);
    gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(3 * g->n_tris * (int64_t)sizeof *g->tri),
                   g->tri, GL_STREAM_DRAW);
}

/* Without a ground there is no shadow: the map stays cleared (depth 1, everything lit). */
static void shadow_pass(const pf_renderer *r, const pf_render_geometry *g, const frame_setup *f,
                        bool casters)
{
    const pf_gl *gl = &r->gl;
    GLsizei s = shadow_size(&r->p);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->shadow_fbo);
    gl->Viewport(0, 0, s, s);
    gl->ClearDepth(1);
    gl->Clear(GL_DEPTH_BUFFER_BIT);
    if (g->n_tris == 0 || !casters)
        return;
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->UseProgram(r->depth_prog);
    gl->UniformMatrix4fv(gl->GetUniformLocation(r->depth_prog, "u_view_proj"), 1, GL_FALSE,
                         f->light_view_proj);
    /* slope-scaled bias against self-shadowing acne */
    gl->Enable(GL_POLYGON_OFFSET_FILL);
    gl->PolygonOffset(2.0f, 4.0f);
    gl->BindVertexArray(r->vao);
    if (g->closed)
        gl->Enable(GL_CULL_FACE);
    gl->DrawElements(GL_TRIANGLES, (GLsizei)(3 * g->n_tris), GL_UNSIGNED_INT, NULL);
    gl->Disable(GL_CULL_FACE);
    gl->Disable(GL_POLYGON_OFFSET_FILL);
    gl->Disable(GL_DEPTH_TEST);
}

/* A nice grid spacing: 1, 2 or 5 times a power of ten, near a fifth of the stage radius. */
static double grid_spacing(double radius)
{
    double target = radius / 5, p = pow(10, floor(log10(target)));
    double m = target / p;
    return p * (m < 1.5 ? 1 : m < 3.5 ? 2 : 5);
}

static void ground_uniforms(const pf_renderer *r, GLuint prog, const frame_setup *f,
                            const pf_render_view *v, pf_vec3 c)
{
    const pf_gl *gl = &r->gl;
    set_common_uniforms(r, prog, f, v);
    GLfloat center[3] = {(GLfloat)c.x, (GLfloat)c.y, (GLfloat)c.z};
    GLfloat a1[3] = {(GLfloat)f->e1.x, (GLfloat)f->e1.y, (GLfloat)f->e1.z};
    GLfloat a2[3] = {(GLfloat)f->e2.x, (GLfloat)f->e2.y, (GLfloat)f->e2.z};
    GLfloat ground[3] = {(GLfloat)pf_srgb_to_linear(0.74), (GLfloat)pf_srgb_to_linear(0.74),
                         (GLfloat)pf_srgb_to_linear(0.72)};
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_center"), 1, center);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_axis1"), 1, a1);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_axis2"), 1, a2);
    gl->Uniform1f(gl->GetUniformLocation(prog, "u_grid"), (GLfloat)grid_spacing(f->radius));
    gl->Uniform1f(gl->GetUniformLocation(prog, "u_fade0"), (GLfloat)(1.2 * f->radius));
    /* faded out by the edge of the ground square: it meets the background seamlessly */
    gl->Uniform1f(gl->GetUniformLocation(prog, "u_fade1"), (GLfloat)(3.5 * f->radius));
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_ground_color"), 1, ground);
    gl->Uniform3fv(gl->GetUniformLocation(prog, "u_background"), 1, v->background);
}

/* The ground is a square of half-size 3.5 R around the stage (R: the stage's radius), cut into a
 * 3 x 3 grid of rectangles whose middle cell holds every shadow: the stage's bounding sphere
 * projected along the light onto the ground is an ellipse with semi-axes R and R / sin(elevation)
 * around the projection of the centre. Only that cell runs the filtered shadow lookups. The cells
 * share their corners exactly, so the plane is watertight. */
static void ground_pass(const pf_renderer *r, const frame_setup *f, const pf_render_view *v)
{
    const pf_gl *gl = &r->gl;
    pf_vec3 c = pf_v3_add(f->center, pf_v3_scale(f->up, f->ground - pf_v3_dot(f->center, f->up)));
    double size = 3.5 * f->radius, sin_el = pf_v3_dot(f->light, f->up);
    pf_vec3 foot =
        pf_v3_sub(c, pf_v3_scale(f->light, pf_v3_dot(pf_v3_sub(f->center, c), f->up) / sin_el));
    double half = 1.05 * f->radius / sin_el + 0.02 * f->radius;
    double fx = pf_v3_dot(pf_v3_sub(foot, c), f->e1), fy = pf_v3_dot(pf_v3_sub(foot, c), f->e2);
    double xs[4] = {-size, fmax(-size, fx - half), fmin(size, fx + half), size};
    double ys[4] = {-size, fmax(-size, fy - half), fmin(size, fy + half), size};
    GLfloat quad[9][6][3];
    static const int CORNER[6][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}};
    for (int cell = 0; cell < 9; ++cell) {
        int i = cell % 3, j = cell / 3;
        for (int k = 0; k < 6; ++k) {
            pf_vec3 p = pf_v3_add(c, pf_v3_add(pf_v3_scale(f->e1, xs[i + CORNER[k][0]]),
                                               pf_v3_scale(f->e2, ys[j + CORNER[k][1]])));
            int slot = cell == 4 ? 8 : cell > 4 ? cell - 1 : cell; /* the middle cell last */
            quad[slot][k][0] = (GLfloat)p.x;
            quad[slot][k][1] = (GLfloat)p.y;
            quad[slot][k][2] = (GLfloat)p.z;
        }
    }
    gl->BindVertexArray(r->ground_vao);
    gl->BindBuffer(GL_ARRAY_BUFFER, r->ground_vbo);
    gl->BufferData(GL_ARRAY_BUFFER, sizeof quad, quad, GL_STREAM_DRAW);
    ground_uniforms(r, r->ground_prog[0], f, v, c);
    gl->DrawArrays(GL_TRIANGLES, 0, 8 * 6);
    ground_uniforms(r, r->ground_prog[1], f, v, c);
    set_taps(r, r->ground_prog[1], GROUND_TAPS_N, f->shadow_radius);
    gl->DrawArrays(GL_TRIANGLES, 8 * 6, 6);
}

/* True when some vertex carries a wire tag (an edge component below 1). */
static int has_wire(const pf_render_geometry *g)
{
    for (int64_t i = 0; i < g->n_verts; ++i) {
        const float *e = g->verts[i].edge;
        if (e[0] < 1 || e[1] < 1 || e[2] < 1)
            return 1;
    }
    return 0;
}

static void scene_pass(const pf_renderer *r, const pf_render_geometry *g, const frame_setup *f,
                       const pf_render_view *v)
{
    int wire = has_wire(g);
    const pf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->ms_fbo);
    gl->Viewport(0, 0, r->p.width, r->p.height);
    gl->ClearColor(v->background[0], v->background[1], v->background[2], 1);
    gl->ClearDepth(1);
    gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_2D, r->shadow_tex);
    if (g->n_tris > 0) {
        GLuint prog = r->scene_prog[wire];
        set_common_uniforms(r, prog, f, v);
        set_taps(r, prog, OBJECT_TAPS_N, 0);
        /* offset shadow lookups along the normal by about two shadow-map texels */
        double texel = 2 * f->radius / shadow_size(&r->p);
        gl->Uniform1f(gl->GetUniformLocation(prog, "u_normal_offset"), (GLfloat)(2 * texel));
        /* wire lines about 1 pixel wide at 720 lines, thicker on larger images */
        double half = 0.5 * fmax(1.0, r->p.height / 720.0);
        gl->Uniform1f(gl->GetUniformLocation(prog, "u_wire_half_width"), (GLfloat)half);
        GLfloat wire_rgb[3] = {0.02f, 0.02f, 0.025f};
        gl->Uniform3fv(gl->GetUniformLocation(prog, "u_wire_color"), 1, wire_rgb);
        gl->BindVertexArray(r->vao);
        if (g->closed)
            gl->Enable(GL_CULL_FACE);
        gl->DrawElements(GL_TRIANGLES, (GLsizei)(3 * g->n_tris), GL_UNSIGNED_INT, NULL);
        gl->Disable(GL_CULL_FACE);
    }
    /* the ground last: the depth test rejects what the objects hide before it is shaded */
    if (v->ground)
        ground_pass(r, f, v);
    gl->Disable(GL_DEPTH_TEST);
}

static void resolve_pass(const pf_renderer *r)
{
    const pf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->out_fbo);
    gl->Viewport(0, 0, r->p.width, r->p.height);
    gl->UseProgram(r->resolve_prog);
    gl->ActiveTexture(GL_TEXTURE1);
    gl->BindTexture(GL_TEXTURE_2D_MULTISAMPLE, r->ms_color);
    gl->Uniform1i(gl->GetUniformLocation(r->resolve_prog, "u_color"), 1);
    gl->Uniform1i(gl->GetUniformLocation(r->resolve_prog, "u_samples"), r->p.samples);
    gl->BindVertexArray(r->empty_vao);
    gl->DrawArrays(GL_TRIANGLES, 0, 3);
    gl->ActiveTexture(GL_TEXTURE0);
}

/* GL rows run bottom to top; images top to bottom. */
static void read_image(pf_renderer *r, uint8_t *rgb)
{
    const pf_gl *gl = &r->gl;
    gl->PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl->ReadBuffer(GL_COLOR_ATTACHMENT0);
    gl->ReadPixels(0, 0, r->p.width, r->p.height, GL_RGBA, GL_UNSIGNED_BYTE, r->readback);
    size_t w = (size_t)r->p.width, h = (size_t)r->p.height;
    for (size_t y = 0; y < h; ++y) {
        const uint8_t *src = r->readback + 4 * w * (h - 1 - y);
        uint8_t *dst = rgb + 3 * w * y;
        for (size_t x = 0; x < w; ++x) {
            dst[3 * x] = src[4 * x];
            dst[3 * x + 1] = src[4 * x + 1];
            dst[3 * x + 2] = src[4 * x + 2];
        }
    }
}

static pf_status check_view(const pf_render_view *v, pf_error *err)
{
    PF_TRY(pf_camera_check(&v->camera, err));
    PF_CHECK(pf_v3_isfinite(v->lo) && pf_v3_isfinite(v->hi) && pf_v3_norm(v->up) > 0 &&
                 pf_v3_isfinite(v->up),
             err, PF_ERR_INVALID, "render view: the stage and up must be finite, up non-zero");
    return PF_OK;
}

pf_status pf_renderer_draw(pf_renderer *r, const pf_render_geometry *g, const pf_render_view *v,
                           uint8_t *rgb, pf_error *err)
{
    PF_TRY(check_view(v, err));
    PF_CHECK(g->n_verts <= (int64_t)UINT32_MAX && 3 * g->n_tris <= (int64_t)INT32_MAX, err,
             PF_ERR_TOO_LARGE, "%lld triangles are more than one draw call takes",
             (long long)g->n_tris);
    PF_CHECK(OSMesaMakeCurrent(r->ctx, r->window, GL_UNSIGNED_BYTE, 4, 4), err, PF_ERR_UNSUPPORTED,
             "OSMesa cannot make its context current");
    frame_setup f;
    setup_frame(r, v, &f);
    upload(r, g);
    shadow_pass(r, g, &f, v->ground);
    scene_pass(r, g, &f, v);
    resolve_pass(r);
    read_image(r, rgb);
    return pf_gl_check(&r->gl, "drawing a frame", err);
}
