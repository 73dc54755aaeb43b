/* pf/render.h: off-screen rendering of meshes and surfaces to RGB images.
 *
 * Three layers:
 * - data for drawing, computed on the CPU in double precision and stored as float: the triangulated
 *   boundary of a polyhedral mesh (pf_boundary of pf/mesh.h, once per topology), the embedded
 *   surface moved by its weights (pf_weights_apply), and a triangle list with per-vertex normal, colour and wireframe tags
 *   (pf_render_geometry, once per frame);
 * - a camera (pf_camera): explicit, parsed from JSON, or fitted to a bounding box;
 * - the renderer (pf_renderer, opaque): an OpenGL 3.3 core-profile context on Mesa's OSMesa
 *   (llvmpipe), multisampled, lit in linear light with a shadowed ground plane, read back and
 *   encoded to 8-bit sRGB on the CPU. The same input gives the same bytes at any LP_NUM_THREADS.
 *
 * Colours are linear RGB in [0, 1] unless a name says sRGB. Images are 8-bit RGB, rows top to
 * bottom, 3 * width bytes per row. Lengths are model units; angles degrees where a name says so.
 * The world's up direction (ground normal) is given by the view; the auto camera uses +z.
 */
#ifndef PF_RENDER_H
#define PF_RENDER_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/io.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== colour ================================================================================== */

/* sRGB transfer function (IEC 61966-2-1) and its inverse, for values in [0, 1]. */
double pf_srgb_to_linear(double c);
double pf_linear_to_srgb(double c);
/* The 8-bit sRGB code of linear value c (clamped to [0, 1]): round(255 * pf_linear_to_srgb(c)).
 * The reference for the renderer's encoding (which runs on the GPU side). */
uint8_t pf_linear_to_srgb8(double c);

/* The viridis colour map (perceptually uniform, monotone in lightness) at t in [0, 1] (clamped),
 * as linear RGB in rgb[3]. */
void pf_colormap_viridis(double t, float rgb[3]);

/* Distinct linear colours for the element kinds (tet, hex, general polyhedron) in --mode mesh. */
void pf_render_kind_color(pf_elem_kind kind, float rgb[3]);

/* ==== geometry for drawing ==================================================================== */

/* One vertex as the renderer draws it. */
typedef struct pf_render_vertex {
    float pos[3];    /* model units */
    float normal[3]; /* unit, outward */
    float color[3];  /* linear RGB albedo */
    float edge[3];   /* wireframe tags: corner k of a triangle has edge[k] = 1 and 0 elsewhere;
                        1 at all three corners hides the edge opposite corner k; (1, 1, 1) on
                        every corner draws no wire */
} pf_render_vertex;

/* A growing indexed triangle list. Zero-initialise; pf_render_geometry_clear keeps the memory. */
typedef struct pf_render_geometry {
    int64_t n_verts, cap_verts;
    pf_render_vertex *verts; /* [n_verts] */
    int64_t n_tris, cap_tris;
    uint32_t *tri;  /* [3 n_tris] indices into verts */
    pf_vec3 lo, hi; /* bounding box of the positions (lo > hi when empty) */
    bool closed;    /* set by the caller when the triangles bound solids and face outward
                       (a valid mesh's boundary, a closed manifold surface): back faces
                       are then culled, which halves the work; leave false for open or
                       doubtful surfaces, which are then lit from both sides */
} pf_render_geometry;

/* Empties g (keeping its memory and the closed flag) and resets its bounding box. */
void pf_render_geometry_clear(pf_render_geometry *g);
void pf_render_geometry_release(pf_render_geometry *g);

/* How faces are coloured. */
typedef enum pf_paint_kind {
    PF_PAINT_UNIFORM = 0,    /* rgb */
    PF_PAINT_ELEM_KIND = 1,  /* pf_render_kind_color of the face's element */
    PF_PAINT_ELEM_VALUE = 2, /* viridis((values[elem] - lo) / (hi - lo)) */
    PF_PAINT_VERT_VALUE = 3, /* viridis((values[vertex] - lo) / (hi - lo)), surfaces only */
} pf_paint_kind;

typedef struct pf_paint {
    pf_paint_kind kind;
    float rgb[3];         /* linear RGB for PF_PAINT_UNIFORM */
    const double *values; /* borrowed: [n_elems] or [n_verts] for the value kinds */
    double lo, hi;        /* colour-map range; hi <= lo maps everything to the middle */
    bool wire;            /* tag polygon edges (pf_render_vertex.edge) so that they are drawn */
    float cap_rgb[3];     /* linear RGB of a surface's cap triangles (tri_part PF_SURFACE_CAP)
                             under PF_PAINT_UNIFORM */
} pf_paint;

/* The default: uniform, a light clay colour, no wire; caps a warm flesh red (sRGB #cc6b57). */
pf_paint pf_paint_default(void);

/* Appends the boundary b of mesh m, nodes at m->x + u (u [3 n_nodes] or NULL for the rest
 * shape), flat-shaded per face (Newell normal of the displaced face), painted by p. Each face gets
 * its own vertices. PF_ERR_INVALID when p needs values and has none; PF_ERR_TOO_LARGE beyond
 * 2^32 vertices; PF_ERR_NOMEM. */
pf_status pf_render_add_boundary(pf_render_geometry *g, const pf_mesh *m, const pf_boundary *b,
                                 const double *u, const pf_paint *p, pf_error *err);

/* Appends surface s with vertices at x ([3 s->n_verts], NULL: s->x), smooth-shaded (area-weighted
 * vertex normals), painted by p (PF_PAINT_UNIFORM or PF_PAINT_VERT_VALUE). Cap triangles (tri_part
 * PF_SURFACE_CAP) are flat-shaded on vertices of their own, in p->cap_rgb when uniform, and do
 * not bend the normals of the model's triangles they touch. Same statuses. */
pf_status pf_render_add_surface(pf_render_geometry *g, const pf_surface *s, const double *x,
                                const pf_paint *p, pf_error *err);

/* Per-node values from per-element values: the mean over the elements that use the node (through
 * their faces), 0 for unused nodes. elem_values [m->n_elems], node_values [m->n_nodes].
 * PF_ERR_NOMEM. */
pf_status pf_render_elem_to_node(const pf_mesh *m, const double *elem_values, double *node_values,
                                 pf_error *err);

/* ==== camera ================================================================================== */

typedef struct pf_camera {
    pf_vec3 eye;    /* position, model units */
    pf_vec3 target; /* the point looked at, centre of the image */
    pf_vec3 up;     /* roughly up in the image; need not be orthogonal to the view direction */
    double fov_deg; /* vertical field of view, degrees, in (0, 180) */
} pf_camera;

/* A camera looking at the box [lo, hi] from the front-left and above (azimuth -60 degrees about up
 * from +x, elevation 25 degrees), vertical field of view fov_deg, placed at the smallest distance
 * at which every corner of the box lies within margin (in (0, 1], e.g. 0.9) of the image half-size
 * for an image of the given aspect (width / height). up: the world's up direction. */
pf_camera pf_camera_fit(pf_vec3 lo, pf_vec3 hi, pf_vec3 up, double fov_deg, double aspect,
                        double margin);

/* Parses a JSON object {"eye": [x, y, z], "target": [x, y, z], "up": [x, y, z], "fov": degrees};
 * "up" defaults to [0, 0, 1] and "fov" to 40. Strict: unknown keys, duplicate keys, missing
 * eye/target, non-finite numbers, eye == target, up parallel to the view direction and trailing
 * text are PF_ERR_FORMAT / PF_ERR_INVALID with a message naming the key or character offset. */
pf_status pf_camera_parse_json(const char *text, pf_camera *cam, pf_error *err);

/* PF_ERR_INVALID (naming the problem) unless the camera is usable: finite, eye != target, up not
 * parallel to the view direction, 0 < fov < 180. */
pf_status pf_camera_check(const pf_camera *cam, pf_error *err);

/* Column-major 4x4 view and projection matrices (OpenGL conventions, depth range [-1, 1]) for an
 * image of the given aspect with clip planes near < far > 0. */
void pf_camera_matrices(const pf_camera *cam, double aspect, double near_z, double far_z,
                        double view[16], double proj[16]);

/* ==== renderer ================================================================================ */

typedef struct pf_render_params {
    int32_t width, height; /* pixels, 1 .. 8192 (default 1280 x 720) */
    int32_t samples;       /* multisample count: 1, 2 or 4 (default 4) */
    int32_t shadow_size;   /* shadow map texels per side, 0 .. 8192 (default 0: 1024) */
} pf_render_params;

pf_render_params pf_render_params_default(void);

/* What surrounds the geometry of a frame. */
typedef struct pf_render_view {
    pf_camera camera;
    pf_vec3 up;          /* world up: the ground's normal (default +z) */
    pf_vec3 lo, hi;      /* the stage: bounds of everything the animation shows; the ground lies
                            at the lowest point along up, the shadow map covers the box */
    bool ground;         /* draw the ground plane with the shadow (default true) */
    float background[3]; /* linear RGB */
} pf_render_view;

/* Stage [lo, hi], camera fitted to it (fov 35 degrees, margin 0.9), +z up, ground on. */
pf_render_view pf_render_view_default(pf_vec3 lo, pf_vec3 hi, double aspect);

typedef struct pf_renderer pf_renderer;

/* Creates an OSMesa OpenGL 3.3 core-profile context with multisampled framebuffers of the given
 * size. Statuses: PF_ERR_INVALID on bad params; PF_ERR_UNSUPPORTED when the context, the shaders
 * or the framebuffers cannot be made (message says which); PF_ERR_NOMEM. The renderer is bound to
 * no thread but must be used by one thread at a time. */
pf_status pf_renderer_create(pf_renderer **r, const pf_render_params *p, pf_error *err);
void pf_renderer_destroy(pf_renderer **r);

/* Renders g as seen by view into rgb [3 width height] (8-bit sRGB, top row first). g may be empty
 * (ground only). PF_ERR_INVALID on an unusable camera or view, PF_ERR_TOO_LARGE when g has more
 * vertices than 32-bit indices reach, PF_ERR_UNSUPPORTED on a GL error (named). */
pf_status pf_renderer_draw(pf_renderer *r, const pf_render_geometry *g, const pf_render_view *view,
                           uint8_t *rgb, pf_error *err);

/* Draws a colour legend onto rgb (width x height, top row first): a vertical viridis bar near the
 * right edge with the values lo (bottom), (lo + hi) / 2 and hi (top) printed beside it ("%.3g"),
 * sized to the image. Pure CPU, deterministic. */
void pf_render_draw_legend(uint8_t *rgb, int32_t width, int32_t height, double lo, double hi);

/* ==== the frames of a pf stream (pf-render) ===================================================
 * Feeds a stream's chunks through a pf_stream_state and draws each frame (FRAM) in the range on
 * its own mesh to out_dir/frame_NNNNN.png (NNNNN the frame's index): the SURF moved by its WGHT
 * when the stream has weights for the latest mesh, else the mesh's boundary moved by the frame's
 * displacements; in stress mode coloured by the frame's STRS (von Mises; a frame waits for the
 * STRS that follows it). The camera is fixed at the stream's first frame (not the range's): on a
 * stored stream pf_render_stream_survey first reads the whole file for the animation's box and
 * stress range, so that any range of frames gives the whole run's bytes. Deterministic: the same
 * chunks give the same bytes. The simulation's scene is the caller's business (render does not
 * read scenes): hooks give the ground and draw the obstacles. */

typedef enum pf_render_mode {
    PF_RENDER_MODE_SURFACE = 0, /* the embedded surface when it can, else the mesh boundary */
    PF_RENDER_MODE_MESH = 1,    /* the mesh boundary with element edges, coloured by kind */
    PF_RENDER_MODE_STRESS = 2,  /* viridis von Mises colours and a legend */
} pf_render_mode;

/* Each hook may be NULL; ctx is passed to every call. */
typedef struct pf_render_stream_hooks {
    void *ctx;
    /* Height along +z of the simulated ground seen from the state (its SCEN and latest MESH),
     * false when there is none facing +z: the automatic camera's stage reaches down to it. */
    bool (*ground_height)(void *ctx, const pf_stream_state *st, double *z);
    /* Called after each SCEN chunk of the drawing pass (pf_render_stream_take) with the state
     * holding it and the MESH before it: the moment to build what the scene draws. */
    void (*on_scene)(void *ctx, const pf_stream_state *st);
    /* Adds the scene's obstacles at time t (seconds) to g, after the body. */
    pf_status (*add_obstacles)(void *ctx, const pf_stream_state *st, double t,
                               pf_render_geometry *g, pf_error *err);
    /* Called with each image (rgb [3 width height]) after its PNG is written. */
    pf_status (*on_image)(void *ctx, uint32_t index, const uint8_t *rgb, pf_error *err);
    /* A warning for the user (one line, no newline). */
    void (*warn)(void *ctx, const char *msg);
} pf_render_stream_hooks;

typedef struct pf_render_stream_params {
    int32_t width, height;  /* pixels (default 1280 x 720) */
    pf_render_mode mode;    /* default surface */
    bool has_camera;        /* false (default): the automatic camera */
    pf_camera camera;       /* when has_camera; its up is also the ground's normal */
    int64_t first, last;    /* frames drawn: index first..last inclusive (default all) */
    float cap_rgb[3];       /* linear RGB of the surface's cap triangles (default
                               pf_paint_default's) */
    const char *out_dir;    /* borrowed, must exist (default "frames") */
    pf_render_stream_hooks hooks;
} pf_render_stream_params;

pf_render_stream_params pf_render_stream_params_default(void);

typedef struct pf_render_stream pf_render_stream;

/* Creates the off-screen renderer and the image buffers. PF_ERR_INVALID on bad params, the
 * statuses of pf_renderer_create, PF_ERR_NOMEM. On failure *rs is NULL. */
pf_status pf_render_stream_create(pf_render_stream **rs, const pf_render_stream_params *p,
                                  pf_error *err);
/* Pass 1 on a stored stream (f borrowed, read to its end or its first error, which the drawing
 * pass reports): the bounding box of every frame and the stress range of every STRS. The caller
 * rewinds f before pass 2. */
void pf_render_stream_survey(pf_render_stream *rs, FILE *f, const char *name);
/* Pass 2, one chunk at a time as the reader returns them: draws the frames in range. Errors: the
 * reader state's (naming chunk and byte offset), pf_png_write's, the hooks'. */
pf_status pf_render_stream_take(pf_render_stream *rs, const pf_chunk *c, pf_error *err);
/* After the last chunk (stream_ok false: the reading stopped at an error already in the caller's
 * hands): draws a frame still waiting for its STRS, and, for a stream without frames, one image
 * (index 0) of the rest shape; PF_ERR_FORMAT "NAME: nothing to draw" when there is neither a MESH
 * nor a SURF. After a read error the first error stays the caller's and this one is dropped. */
pf_status pf_render_stream_finish(pf_render_stream *rs, bool stream_ok, const char *name,
                                  pf_error *err);
/* Images written so far. */
int64_t pf_render_stream_written(const pf_render_stream *rs);
/* The images the survey counted (the frames in range of the file, or the rest shape), for a
 * progress's total; -1 without a survey (a pipe: unknown). */
int64_t pf_render_stream_to_draw(const pf_render_stream *rs);
void pf_render_stream_destroy(pf_render_stream **rs);

/* ==== MP4 through ffmpeg ======================================================================= */

typedef struct pf_video pf_video;

/* True when an executable ffmpeg is on PATH. */
bool pf_video_available(void);
/* Starts ffmpeg writing path (H.264, yuv420p, sizes padded to even) from raw RGB frames of
 * width x height at fps frames per second. PF_ERR_IO when it cannot be started. */
pf_status pf_video_create(pf_video **v, const char *path, int32_t width, int32_t height, long fps,
                          pf_error *err);
/* One frame, rgb [3 width height], top row first. PF_ERR_IO naming the file when ffmpeg is gone. */
pf_status pf_video_write(pf_video *v, const uint8_t *rgb, pf_error *err);
/* Closes the pipe and waits for ffmpeg; PF_ERR_IO "path: ffmpeg failed (exit status N)". */
pf_status pf_video_finish(pf_video *v, pf_error *err);
/* Finishes (ignoring the status) and frees; sets *v to NULL; safe on NULL. */
void pf_video_destroy(pf_video **v);

#ifdef __cplusplus
}
#endif
#endif
