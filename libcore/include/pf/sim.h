/* pf/sim.h: scenes (what to simulate: material, method, loads, time) and the simulator.
 *
 * A scene is read from JSON (docs/scene.md lists every key, its unit and default); every field
 * has a default, so an empty object, or no file at all, is a valid scene: a body dropped under
 * gravity onto a ground plane below it. Units are any consistent set; the defaults are SI (metres,
 * kilograms, seconds, pascals). */
#ifndef PF_SIM_H
#define PF_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== scene =================================================================================== */

typedef enum pf_method { PF_METHOD_DG = 0, PF_METHOD_CG = 1 } pf_method;
typedef enum pf_flux { PF_FLUX_IP = 0, PF_FLUX_BZ = 1 } pf_flux;

/* A selection of boundary faces: those whose centroid lies in the box (bounds inclusive), or
 * within tol of the plane. */
typedef enum pf_region_kind { PF_REGION_BOX = 0, PF_REGION_PLANE = 1 } pf_region_kind;
typedef struct pf_region {
    pf_region_kind kind;
    pf_vec3 lo, hi;  /* box corners, lo <= hi componentwise */
    pf_plane plane;  /* unit normal */
    double tol;      /* plane: distance tolerance, model units, >= 0; -1 when the scene did not
                        give one: pf_scene_resolve then sets 1e-6 x the bounding-box diagonal */
} pf_region;

/* A fixed region: weak Dirichlet on its faces (DG) or every node of its faces fixed (CG), to
 * the given displacement (zero by default). */
typedef struct pf_fixed {
    pf_region region;
    pf_vec3 displacement; /* model units */
} pf_fixed;

/* A traction on the boundary faces of a region, force per unit area. */
typedef struct pf_load {
    pf_region region;
    pf_vec3 traction;
} pf_load;

typedef struct pf_scene {
    /* material: isotropic, linear (corotated) */
    double E;       /* Young's modulus, stress units (default 1e5) */
    double nu;      /* Poisson's ratio, in (-1, 0.5) (default 0.3) */
    double density; /* mass per unit volume (default 1000) */

    /* method */
    pf_method method; /* default dg */
    int32_t degree;   /* dg: 1 or 2 (default 1) */
    pf_flux flux;     /* dg: ip (default) or bz */
    double penalty;   /* dg: eta of eq. 20; 0 = automatic (default): ip, the smallest power of
                         two from 1 for which the stiffness matrix is positive definite; bz
                         (definite for any eta), 1 for degree 1 and 32 for degree 2 */
    bool corotation;  /* default true */

    /* forces */
    pf_vec3 gravity;     /* acceleration (default 0, 0, -9.81) */
    pf_vec3 body_force;  /* force per unit volume, added to gravity's (default 0) */
    int32_t n_fixed;
    pf_fixed *fixed;
    int32_t n_loads;
    pf_load *loads;

    /* damping: D = alpha M + beta K (Rayleigh) */
    double damping_alpha; /* 1/time (default 0) */
    double damping_beta;  /* time (default 0.01) */

    /* ground: the plane through ground_point with normal ground_normal, penalty contact */
    bool ground;            /* default true, except in static scenes */
    bool ground_given;      /* "ground" was in the file: static no longer turns the ground off */
    bool ground_auto;       /* ground_point not given: pf_scene_resolve puts it below the mesh */
    pf_vec3 ground_point;   /* model units */
    pf_vec3 ground_normal;  /* unit (default 0, 0, 1) */
    double ground_stiffness; /* penalty, force per unit length per node; 0 = automatic */

    /* time */
    bool is_static;   /* solve K u = f once, write one frame (default false) */
    double dt;        /* time between frames (default 1/30) */
    int32_t frames;   /* frames to write after the rest frame (default 60) */
    int32_t substeps; /* time steps per frame (default 10) */

    char *json; /* the scene text as read (NUL-terminated), for the SCEN chunk; NULL without file */
} pf_scene;

/* The defaults above (no file). */
void pf_scene_default(pf_scene *s);

/* Parses JSON text (len bytes, need not be NUL-terminated) into s (defaults first, then every key
 * given). name (the file name; "scene" when NULL) prefixes every message. Errors: PF_ERR_FORMAT
 * "name:LINE:COL: JSON syntax error near '...'" for text that is not strict JSON (RFC 8259; LINE
 * and COL 1-based, COL counting UTF-8 characters, at the first character that cannot continue a
 * valid document, or the start of a bad token), an empty text, or a NUL byte;
 * PF_ERR_INVALID "name: key.path: reason" (e.g. "scene.json: fixed[1].plane.normal: must be a
 * non-zero vector") for an unknown or duplicate key, a wrong type, a non-finite number, or a value
 * out of range (E <= 0, nu outside (-1, 0.5), degree not 1 or 2, dt <= 0, frames < 0,
 * substeps < 1, a box with lo > hi, a zero normal, ...); PF_ERR_NOMEM. s->json keeps a copy of
 * the text (pf_alloc). s is overwritten without being released first (release it with
 * pf_scene_release either way, also after an error). Not to be called from two threads at once:
 * cJSON, which builds the tree, keeps its last error in a process-wide variable. */
pf_status pf_scene_parse(pf_scene *s, const char *text, size_t len, const char *name,
                         pf_error *err);

/* Reads and parses a file; its path is the name in messages. PF_ERR_IO naming it when it cannot
 * be read, PF_ERR_TOO_LARGE beyond 64 MiB. Reads to end of file, so pipes work. */
pf_status pf_scene_load(pf_scene *s, const char *path, pf_error *err);

/* A command-line override of one common key: key is one of method (dg|cg), degree, flux (ip|bz),
 * frames, dt, static, E, nu, density, penalty, substeps, corotation. Booleans (static,
 * corotation) take true or false, NULL or empty meaning true. Numbers must be the whole of value
 * (strtod / base-10 strtol) and obey the same ranges as the file. static re-applies the rule "no
 * ground in a static scene unless the file gave one". PF_ERR_INVALID "key: reason, got 'value'"
 * for an unknown key or a bad value (s then unchanged). */
pf_status pf_scene_override(pf_scene *s, const char *key, const char *value, pf_error *err);

/* Completes the scene for a mesh with bounding box lo..hi (model units, lo <= hi). When
 * ground_auto: with n = ground_normal, s = the smallest and ext = the spread (max - min) of
 * dot(n, corner) over the 8 box corners, ground_point = (s - 0.05 ext) n (the ground is 5 % of the
 * body's extent along n below its lowest point). Every plane region with tol < 0 (not given) gets
 * tol = 1e-6 x |hi - lo|. Call after parsing and overrides, before simulating; calling it again
 * (a new mesh) moves an automatic ground, not tolerances already set. */
void pf_scene_resolve(pf_scene *s, pf_vec3 lo, pf_vec3 hi);

/* Frees fixed, loads and json and zeroes s (NULL allowed). */
/* The scene as a scene file (every key explicit, overrides included; an automatic ground stays
 * automatic), NUL-terminated, freed with pf_free. Parsing it gives the same scene. */
pf_status pf_scene_to_json(const pf_scene *s, char **json, pf_error *err);

void pf_scene_release(pf_scene *s);

/* True when point p (a face centroid) is selected by region r: a box with inclusive bounds, a
 * plane when |signed distance| <= tol (never, while tol is still -1: resolve first). */
bool pf_region_contains(const pf_region *r, pf_vec3 p);

/* ==== simulator ===============================================================================
 * One scene on one mesh. Dynamic scenes advance frame by frame (pf_sim_frame); static scenes solve
 * K u = f once (pf_sim_solve_static). The DG method (scene->method = dg) is implemented;
 * method cg gives PF_ERR_UNSUPPORTED until the harmonic basis lands. */

typedef struct pf_sim pf_sim;

/* Time spent, seconds, and what was done, since creation. */
typedef struct pf_sim_stats {
    int64_t dofs;
    int64_t matrix_nnz;      /* stored (upper) entries of the system matrix */
    int64_t factor_nnz;
    double penalty;          /* the eta in use */
    int32_t penalty_doublings;
    double setup_seconds;    /* basis, integrals, pattern, analysis, penalty search */
    double assemble_seconds; /* stiffness assembly, rotations, contact */
    double factor_seconds;
    double solve_seconds;
    int64_t steps, factorisations;
    int32_t fixed_faces, loaded_faces;
    int64_t contacts;        /* active contact points summed over steps */
} pf_sim_stats;

/* Sets everything up for the scene (resolved with pf_scene_resolve) on the mesh (valid, derived).
 * The mesh and scene are borrowed and must outlive the simulator. PF_ERR_INVALID for a static
 * scene without fixed faces (rigid motions make it singular), PF_ERR_NUMERIC when no penalty up
 * to 2^20 makes the stiffness positive definite. */
pf_status pf_sim_create(pf_sim **sim, const pf_scene *scene, const pf_mesh *mesh, pf_error *err);
void pf_sim_destroy(pf_sim **sim);

/* Static solve: the displacement under the scene's loads, gravity and fixed regions (linear
 * elasticity: no corotation, no contact). */
pf_status pf_sim_solve_static(pf_sim *sim, pf_error *err);

/* Advances one frame (scene->substeps semi-implicit Euler steps of dt / substeps). On a
 * non-finite or exploding state: PF_ERR_NUMERIC naming the frame and the element where it
 * started; the state before the frame is kept. */
pf_status pf_sim_frame(pf_sim *sim, pf_error *err);

/* Simulated time and the number of frames advanced. */
double pf_sim_time(const pf_sim *sim);
int32_t pf_sim_frame_index(const pf_sim *sim);

/* Stitched nodal displacements (DG eq. 30), out [3 n_nodes]. */
void pf_sim_nodal_displacements(const pf_sim *sim, double *out);
/* Per-element von Mises stress of the corotated linear strain at the element's centre. */
void pf_sim_von_mises(const pf_sim *sim, double *out);

/* Kinetic energy, linear and angular momentum (about the origin) of the current state. */
void pf_sim_momentum(const pf_sim *sim, double *kinetic, pf_vec3 *linear, pf_vec3 *angular);

/* Sets the velocity to the rigid motion v(x) = w x (x - c) + v0 (tests, spinning bodies). */
void pf_sim_set_rigid_velocity(pf_sim *sim, pf_vec3 w, pf_vec3 c, pf_vec3 v0);

/* Sets the displacement to u(x) = A x + b (A row-major), exactly in the basis (tests: rigidly
 * rotated rest shapes). */
void pf_sim_set_affine_displacement(pf_sim *sim, const double a[9], const double b[3]);

/* The largest discontinuity of the DG displacement at a mesh node: the largest distance between
 * an element's own displacement at one of its nodes and the stitched (averaged) value there,
 * model units. It shrinks as the penalty grows (DG paper, fig. 1). */
double pf_sim_max_node_jump(const pf_sim *sim);

/* Volume of the deformed body: the mesh's elements with the stitched displacement applied to
 * their nodes, model units cubed. */
double pf_sim_deformed_volume(const pf_sim *sim);

const pf_sim_stats *pf_sim_get_stats(const pf_sim *sim);

#ifdef __cplusplus
}
#endif
#endif
