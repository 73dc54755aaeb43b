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
} pf_paint;

/* The default: uniform, a light clay colour, no wire. */
pf_paint pf_paint_default(void);

/* Appends the boundary b of mesh m, nodes at m->x + u (u [3 n_nodes] or NULL for the rest
 * shape), flat-shaded per face (Newell normal of the displaced face), painted by p. Each face gets
 * its own vertices. PF_ERR_INVALID when p needs values and has none; PF_ERR_TOO_LARGE beyond
 * 2^32 vertices; PF_ERR_NOMEM. */
pf_status pf_render_add_boundary(pf_render_geometry *g, const pf_mesh *m, const pf_boundary *b,
                                 const double *u, const pf_paint *p, pf_error *err);

/* Appends surface s with vertices at x ([3 s->n_verts], NULL: s->x), smooth-shaded (area-weighted
 * vertex normals), painted by p (PF_PAINT_UNIFORM or PF_PAINT_VERT_VALUE). Same statuses. */
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

#ifdef __cplusplus
}
#endif
#endif
