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
#include <pf/fem.h>
#include <pf/geom.h>
#include <pf/io.h>
#include <pf/mesh.h>
#include <pf/cut.h>
#include <pf/refine.h>
#include <pf/solve.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== scene =================================================================================== */

typedef enum pf_method { PF_METHOD_DG = 0, PF_METHOD_CG = 1 } pf_method;
typedef enum pf_flux { PF_FLUX_IP = 0, PF_FLUX_BZ = 1 } pf_flux;
/* CG mass matrix: consistent (int rho N_a N_b, the Galerkin mass) or lumped (row sums). */
typedef enum pf_mass { PF_MASS_CONSISTENT = 0, PF_MASS_LUMPED = 1 } pf_mass;

/* A selection of boundary faces: those whose centroid lies in the box (bounds inclusive), or
 * within tol of the plane, or the faces of a mesh group of dimension 2 (a Gmsh physical surface,
 * pf_mesh.face_group), or all of whose nodes a node list names, or those of the elements an
 * element list names. For materials, a selection of elements: centroid in the box, in a group of
 * dimension 3, all nodes in the node list, or in the element list. */
typedef enum pf_region_kind {
    PF_REGION_BOX = 0,
    PF_REGION_PLANE = 1,
    PF_REGION_GROUP = 2,
    PF_REGION_NODES = 3,   /* "nodes_file" */
    PF_REGION_ELEMENTS = 4 /* "elements_file" */
} pf_region_kind;
enum { PF_GROUP_NAME_MAX = 128 }; /* bytes of a group name, its NUL included */
typedef struct pf_region {
    pf_region_kind kind;
    int32_t group;                      /* group: its number (> 0), or 0 when given by name */
    char group_name[PF_GROUP_NAME_MAX]; /* group: its name ("" when given by number) */
    pf_vec3 lo, hi;                     /* box corners, lo <= hi componentwise */
    pf_plane plane;                     /* unit normal */
    pf_vec3 point; /* plane: the point the scene gave (n . point = d), which pf_scene_to_json
                      writes back so that the plane reads back into the same bits */
    double tol;    /* plane: distance tolerance, model units, >= 0; -1 when the scene did not
                      give one: pf_scene_resolve then sets 1e-6 x the bounding-box diagonal */
    char *file;    /* nodes, elements: the list file, relative to the scene file's directory when
                      the scene names a relative path (pf_alloc; pf_scene_release frees it) */
    uint8_t *listed;    /* nodes, elements: [n_listed] 1 where the list names the node (element),
                           handed over with pf_region_set_list (NULL until then) */
    int32_t n_listed;   /* the nodes (elements) of the mesh the list numbers */
    uint64_t list_mesh; /* that mesh's id */
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

/* A material of the elements a region selects (box: element centroid, the mean of its faces'
 * vertices, inside; group: a mesh group of dimension 3). Values the entry does not give are the
 * scene's material's. */
typedef struct pf_material_region {
    pf_region region;
    double E, nu, density;
} pf_material_region;

/* An obstacle: a rigid solid the body cannot enter, penalty contact (DG paper sec. 8). Plane: the
 * half-space below the plane through point with the unit normal (pointing out of the solid);
 * sphere: the ball; box: the axis-aligned solid box lo..hi; mesh: the solid bounded by a closed
 * triangle surface (or, for an open one, the layer of thickness depth behind it, seen against
 * its triangles' orientation). A path moves it: translation(t) linear between keyframes
 * (key_time strictly increasing), the first and last translation held before and after; without
 * keys it stays put. */
typedef enum pf_obstacle_kind {
    PF_OBSTACLE_PLANE = 0,
    PF_OBSTACLE_SPHERE = 1,
    PF_OBSTACLE_BOX = 2,
    PF_OBSTACLE_MESH = 3,
} pf_obstacle_kind;

typedef struct pf_obstacle {
    pf_obstacle_kind kind;
    pf_vec3 point, normal; /* plane: a point (model units) and the unit normal */
    pf_vec3 centre;        /* sphere: centre (model units) */
    double radius;         /* sphere: radius, > 0 */
    pf_vec3 lo, hi;        /* box: corners, lo < hi componentwise */
    char *file;            /* mesh: the surface file as resolved: relative to the scene file's
                              directory when the file names a relative path (pf_alloc) */
    double depth;          /* mesh: the deepest penetration looked for, model units; 0 =
                              automatic (a tenth of the body's bounding-box diagonal) */
    pf_up_axis up;         /* mesh: the file's up axis, turned onto +z as the tools turn surfaces
                              (PF_UP_AUTO: the axis the file declares; the parser's default) */
    double scale;          /* mesh: factor after the turn, > 0 (the parser's default 1; 0 is
                              taken as 1) */
    double stiffness;      /* penalty, force per unit length per contact point; 0 = automatic
                              (the ground's automatic stiffness) */
    int32_t n_keys;
    double *key_time;         /* [n_keys] time, strictly increasing */
    pf_vec3 *key_translation; /* [n_keys] model units */
    pf_surface surface;       /* mesh: the triangles, handed over by the caller with
                                 pf_scene_set_obstacle_surface (empty until then) */
} pf_obstacle;

/* The obstacle's translation at time t (zero without keys). */
pf_vec3 pf_obstacle_translation(const pf_obstacle *o, double t);

/* A blade of the scene's "cuts" (docs/scene.md): a segment whose end points a, b are moved by a
 * path like an obstacle's, cutting the elements the surface it sweeps between two frames passes
 * through (progressive cutting); or a plane (point, unit normal) cutting every element it crosses
 * at the first frame ending at or after time. */
typedef enum pf_blade_kind { PF_BLADE_SEGMENT = 0, PF_BLADE_PLANE = 1 } pf_blade_kind;

typedef struct pf_blade {
    pf_blade_kind kind;
    pf_vec3 a, b;          /* segment: end points before the path's translation, a != b */
    pf_vec3 point, normal; /* plane */
    double time;           /* plane: when it cuts */
    int32_t n_keys;
    double *key_time;         /* [n_keys] segment: the path, as an obstacle's */
    pf_vec3 *key_translation; /* [n_keys] */
} pf_blade;

/* The segment blade's end points at time t (its path's translation applied). */
void pf_blade_at(const pf_blade *b, double t, pf_vec3 *a, pf_vec3 *bb);

/* Stress-based refinement (docs/scene.md, "refine"; DG paper sec. 9.3, harmonic paper sec. 8):
 * after every frame, an element whose largest absolute principal stress (sampled at its centroid
 * and vertices) exceeds threshold is split, up to max_level splits deep, while the mesh has fewer
 * than max_elements elements and the element is larger than min_size; and the children of a
 * split that have all stayed calm (below coarsen_fraction * threshold) for coarsen_after frames
 * merge back. */
typedef struct pf_refine_params {
    bool enabled;         /* the scene has a "refine" key */
    double threshold;     /* stress units, > 0 */
    pf_split_kind split;  /* octs (default) or halves */
    int32_t max_level;    /* default 2 */
    int32_t max_elements; /* default 100000 */
    double min_size;      /* model units: the cube root of an element's volume; default 0 */
    double coarsen_fraction; /* [0, 1); 0: never (default 0.5) */
    int32_t coarsen_after;   /* frames, >= 1 (default 10) */
    bool rebuild; /* true: the set-up after a change copies nothing from the mesh before (the
                     same results, at the cost of a fresh set-up: for measurements); default
                     false */
} pf_refine_params;

typedef struct pf_scene {
    /* material: isotropic, linear (corotated) */
    double E;       /* Young's modulus, stress units (default 1e5) */
    double nu;      /* Poisson's ratio, in (-1, 0.5) (default 0.3) */
    double density; /* mass per unit volume (default 1000) */
    /* more materials, each for the elements its region selects (the first entry that selects an
     * element wins; the others are of the material above) */
    int32_t n_materials;
    pf_material_region *materials;

    /* method */
    pf_method method;     /* default dg */
    int32_t degree;       /* dg: 1 or 2 (default 1; docs/scene.md says why) */
    pf_flux flux;         /* dg: ip (default) or bz */
    double penalty;       /* dg: eta of eq. 20; 0 = automatic (default): ip, the smallest power of
                             two from 1 for which the stiffness matrix is positive definite; bz
                             (definite for any eta), 3/16 for degree 1 and 1/2 for degree 2,
                             with BZ's growth under refinement (pf_dg_face_penalty) */
    bool corotation;      /* default true */
    pf_mass mass;         /* cg: consistent (default) or lumped */
    int32_t edge_samples; /* cg: MFS kernel samples inside each edge (pf_basis_params; 1-16,
                             default 2): more for smaller boundary errors at a higher set-up */

    /* forces */
    pf_vec3 gravity;    /* acceleration (default 0, 0, -9.81) */
    pf_vec3 body_force; /* force per unit volume, added to gravity's (default 0) */
    int32_t n_fixed;
    pf_fixed *fixed;
    int32_t n_loads;
    pf_load *loads;

    /* damping: D = alpha M + beta K (Rayleigh) */
    double damping_alpha; /* 1/time (default 0) */
    double damping_beta;  /* time (default 0.01) */

    /* ground: the plane through ground_point with normal ground_normal, penalty contact */
    bool ground;             /* default true, except in static scenes */
    bool ground_given;       /* "ground" was in the file: static no longer turns the ground off */
    bool ground_auto;        /* ground_point not given: pf_scene_resolve puts it below the mesh */
    pf_vec3 ground_point;    /* model units */
    pf_vec3 ground_normal;   /* unit (default 0, 0, 1) */
    double ground_stiffness; /* penalty, force per unit length per contact point (a boundary
                                node, or an embedded-surface vertex); 0 = automatic */

    /* obstacles (docs/scene.md, "obstacles") */
    int32_t n_obstacles;
    pf_obstacle *obstacles;

    /* time */
    bool is_static;   /* solve K u = f once, write one frame (default false) */
    double dt;        /* time between frames (default 1/30) */
    int32_t frames;   /* frames to write after the rest frame (default 60) */
    int32_t substeps; /* time steps per frame (default 10) */

    /* linear solves (pf/solve.h): method auto | direct | pcg, the PCG tolerance relative to the
     * right-hand side (default 1e-10) and its iteration limit per factor (default 200) */
    pf_solver_params solver;

    /* stress-based refinement and coarsening (off unless the scene has a "refine" key) */
    pf_refine_params refine;

    /* cutting (the "cuts" key): blades, applied between frames in order */
    int32_t n_cuts;
    pf_blade *cuts;

    char *json; /* the scene text as read (NUL-terminated), for the SCEN chunk; NULL without file */
} pf_scene;

/* The defaults above (no file). */
void pf_scene_default(pf_scene *s);

/* Whether a simulation of the scene changes its mesh between frames (refinement or cuts). */
bool pf_scene_changes_mesh(const pf_scene *s);
/* Whether its dynamics test contact with a ground or obstacles (static scenes have none). */
bool pf_scene_has_contact(const pf_scene *s);

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

/* The largest scene text a tool reads (pf_buffer_read_file, then pf_scene_parse with the file's
 * path as the name): a scene of 64 MiB is not a scene. The simulator reads no file: a tool reads
 * the scene and the obstacles' meshes and hands them over. */
#define PF_SCENE_MAX_BYTES ((size_t)64 << 20)

/* A command-line override of one common key: key is one of method (dg|cg), degree, flux (ip|bz),
 * mass (consistent|lumped), edge_samples, frames, dt, static, E, nu, density, penalty, substeps,
 * corotation, solver (auto|direct|pcg), tolerance (the solver's). Booleans (static, corotation)
 * take true or false, NULL or empty meaning true. Numbers must be the whole of value (strtod /
 * base-10 strtol) and obey the same ranges as the file. static re-applies the rule "no ground in a
 * static scene unless the file gave one". PF_ERR_INVALID "key: reason, got 'value'" for an unknown
 * key or a bad value (s then unchanged). */
pf_status pf_scene_override(pf_scene *s, const char *key, const char *value, pf_error *err);

/* Completes the scene for a mesh with bounding box lo..hi (model units, lo <= hi). When
 * ground_auto: with n = ground_normal, s = the smallest and ext = the spread (max - min) of
 * dot(n, corner) over the 8 box corners, ground_point = (s - 0.05 ext) n (the ground is 5 % of the
 * body's extent along n below its lowest point). Every plane region with tol < 0 (not given) gets
 * tol = 1e-6 x |hi - lo|. Call after parsing and overrides, before simulating; calling it again
 * (a new mesh) moves an automatic ground, not tolerances already set. */
void pf_scene_resolve(pf_scene *s, pf_vec3 lo, pf_vec3 hi);

/* Hands the triangles of mesh obstacle i over to the scene: s->obstacles[i].surface takes the
 * arrays of *surface, which is left zeroed (an earlier surface of the obstacle is released).
 * libcore/sim reads no files: the caller reads obstacles[i].file (pf_import_surface) and hands
 * its triangles over before pf_sim_create. PF_ERR_INVALID "obstacles[i].mesh: FILE: no
 * triangles" for an empty surface, and when i is out of range or not a mesh obstacle (*surface
 * is then left as it was). */
pf_status pf_scene_set_obstacle_surface(pf_scene *s, int32_t i, pf_surface *surface,
                                        pf_error *err);

/* The scene as a scene file (every key explicit, overrides included; an automatic ground stays
 * automatic), NUL-terminated, freed with pf_free. Parsing it gives the same scene. */
pf_status pf_scene_to_json(const pf_scene *s, char **json, pf_error *err);

/* Frees fixed, loads, materials (their regions' list files and lists), obstacles (their keys,
 * files and surfaces), cuts and json and zeroes s (NULL allowed). */
void pf_scene_release(pf_scene *s);

/* True when point p (a face centroid) is selected by region r: a box with inclusive bounds, a
 * plane when |signed distance| <= tol (never, while tol is still -1: resolve first); never for a
 * group or a list (pf_region_selects_face). */
bool pf_region_contains(const pf_region *r, pf_vec3 p);

/* True when region r selects face f of mesh m, whose centroid is c: a group when m lists it with
 * dimension 2 and f is in it; a node list when it names every node of f; an element list when it
 * names an element of f; pf_region_contains(r, c) otherwise. */
bool pf_region_selects_face(const pf_region *r, const pf_mesh *m, int32_t f, pf_vec3 c);

/* Hands over the indices the list file of region r (kind nodes or elements) names, which the
 * caller read from r->file (pf_import_index_list: libcore/sim reads no files), for mesh m: r
 * then selects by them on m only (an earlier list of r is released). PF_ERR_INVALID for another
 * kind of region or an index outside m's nodes (elements); PF_ERR_NOMEM. */
pf_status pf_region_set_list(pf_region *r, const pf_mesh *m, const int32_t *indices, int32_t n,
                             pf_error *err);

/* The per-element materials of the scene on mesh m: *table [*n] (entry 0 the scene's material,
 * k + 1 materials[k]) and *elem [m->n_elems] (pf_alloc'd, pf_free them), the first materials
 * entry that selects an element, else 0. Also checks that every group the scene names (fixed,
 * loads: dimension 2; materials: dimension 3) is one of the mesh's: PF_ERR_INVALID "fixed[1].group:
 * the mesh has no group 'name' of faces (its groups: ...)"; and that every list region was handed
 * over for m (PF_ERR_INVALID otherwise; a simulator whose mesh changes carries its own copy of
 * the lists to each new mesh). PF_ERR_NOMEM. */
pf_status pf_scene_materials(const pf_scene *s, const pf_mesh *m, pf_material **table, int32_t *n,
                             int32_t **elem, pf_error *err);

/* ==== simulator ===============================================================================
 * One scene on one mesh. Dynamic scenes advance frame by frame (pf_sim_frame); static scenes solve
 * K u = f once (pf_sim_solve_static). Methods: DG (scene->method = dg, unknowns the elements'
 * polynomial coefficients) and CG (cg: harmonic shape functions, 3 unknowns per free node, the
 * nodes of fixed faces removed). */

typedef struct pf_sim pf_sim;

/* Time spent, seconds, and what was done, since creation. */
typedef struct pf_sim_stats {
    int64_t dofs;
    int64_t matrix_nnz; /* stored (upper) entries of the system matrix */
    int64_t factor_nnz;
    double penalty; /* the eta in use */
    int32_t penalty_doublings;
    double setup_seconds;    /* basis, integrals, pattern, analysis, penalty search */
    double assemble_seconds; /* stiffness assembly, rotations */
    double setup_cpu_seconds, assemble_cpu_seconds; /* the same in CPU seconds of the process
                                                       (all threads): on a loaded machine the
                                                       ones to compare */
    double contact_seconds;  /* contact search (broad and narrow phase) and penalty assembly */
    double embed_seconds;    /* predicted positions of the contact points (embedding mat-vec) */
    int32_t contact_points;  /* boundary nodes or embedded-surface vertices (0: no contact) */
    int32_t contact_samples; /* points on embedded-surface triangles larger than the elements */
    double factor_seconds;
    double solve_seconds;
    int64_t steps, factorisations;
    int32_t fixed_faces, loaded_faces;
    int64_t contacts; /* active contact points summed over steps */
    /* cg only (0 for dg) */
    int32_t closed_form_elems; /* tets and parallelepiped hexes: closed forms, MFS skipped */
    int32_t harmonic_elems;    /* elements with MFS harmonic functions */
    int64_t kernels;           /* MFS kernels of all harmonic elements (edge_samples sets them) */
    double basis_seconds;      /* shape-function set-up (part of setup_seconds) */
    double basis_error;        /* largest boundary error of the current elements' shape
                                  functions (pf_sim_error_indicator) */
    /* the linear solves: method, factorisations and why, PCG iterations (factorisations,
     * factor_seconds, solve_seconds, matrix_nnz and factor_nnz above repeat its counts) */
    pf_solver_stats solver;
    /* mesh changes (refinement and coarsening) */
    int32_t elements;        /* of the current mesh */
    int32_t refinements;     /* mesh changes */
    int64_t elements_split;  /* over all changes */
    int64_t elements_merged; /* groups of children merged back into their parent */
    double refine_seconds;   /* criterion, new mesh, set-up on it and state transfer (CPU
                                seconds of the process: a busy machine biases them little) */
    /* its parts (CPU seconds): the new mesh (pf_mesh_refine, pf_mesh_coarsen), the method on it
     * (integrals, basis functions), the rest of the set-up (an embedded surface's weights,
     * pattern, contact, the solver's analysis), the state carried over; the first factorisation
     * on a new mesh is the solver's (reason "first") */
    double refine_mesh_seconds, refine_method_seconds, refine_setup_seconds,
        refine_transfer_seconds;
    /* Element and face integrals (DG), element matrices (CG: K_e, M_e, int N_a, centroid
     * gradients) copied from the set-up of the mesh before a change, and computed (by every
     * set-up, the first included) */
    int64_t integrals_reused, integrals_computed;
    /* CG: elements whose shape functions were copied from the mesh before a change (the same
     * element node for node), and built (by every set-up, the first included) */
    int64_t basis_reused, basis_computed;
    /* The embedded surface's weights on each new mesh (pf_embed_update): rows over all changes,
     * rows recomputed (the others copied, their nodes renumbered: the first change after the
     * caller's or a cut's weights recomputes all), and the CPU seconds (part of
     * refine_setup_seconds) */
    int64_t embed_rows, embed_rows_computed;
    double refine_embed_seconds;
    /* cutting (the scene's "cuts"; each cut is also a mesh change above) */
    int32_t cuts;            /* cuts applied (a blade's sweep over one frame, or a plane) */
    int64_t elements_cut;    /* elements split by them */
    int32_t bodies;          /* connected pieces after the latest cut (0 before any) */
    double dropped_volume;   /* pieces too small to keep alone (pf/cut.h), model units */
    double dropped_mass;     /* their mass (their elements' densities) */
    int32_t uncapped_faces;  /* opened faces the latest cut embedded surface left without a cap
                                (pf_surface_cut_stats.n_uncapped; 0: it is closed where cut) */
    double cut_seconds;      /* finding the elements, the cut, the new set-up, CPU seconds */
} pf_sim_stats;

/* Sets everything up for the scene (resolved with pf_scene_resolve; mesh obstacles' triangles handed
 * over with pf_scene_set_obstacle_surface) on the mesh (valid, derived). Contact with the ground and the
 * obstacles acts at the mesh's boundary nodes. The mesh and scene are borrowed and must outlive
 * the simulator. PF_ERR_INVALID also for a mesh obstacle whose surface is not loaded.
 * PF_ERR_INVALID for a static scene without fixed faces (rigid motions make it singular),
 * PF_ERR_NUMERIC when no penalty up to 2^20 makes the stiffness positive definite. */
pf_status pf_sim_create(pf_sim **sim, const pf_scene *scene, const pf_mesh *mesh, pf_error *err);
/* The same with contact at the vertices of an embedded surface instead of the mesh's boundary
 * nodes (DG paper sec. 8, fig. 6): a vertex's displacement is its weights' row (pf_weights:
 * surface x mesh nodes, weights->rows = surface->n_verts, weights->cols = mesh->n_nodes) applied
 * to the method's nodal displacements, and its penalty forces and stiffness reach the unknowns
 * through the same weights (W^T A W). surface and weights are borrowed (both NULL: nodes, as
 * pf_sim_create). The automatic contact stiffness is then divided by the number of vertices per
 * boundary node, so the body's total contact stiffness does not depend on the surface's
 * resolution. PF_ERR_INVALID when only one is given or their sizes do not match. */
pf_status pf_sim_create_embedded(pf_sim **sim, const pf_scene *scene, const pf_mesh *mesh,
                                 const pf_surface *surface, const pf_weights *weights,
                                 pf_error *err);

/* What pf_sim_create_with takes besides the scene and mesh; the zero value (or NULL) is
 * pf_sim_create's. */
typedef struct pf_sim_options {
    /* an embedded surface for contact and its weights, both or neither (pf_sim_create_embedded) */
    const pf_surface *surface;
    const pf_weights *weights;
    /* Hears the set-up's phases: DG "element integrals" and "face integrals", CG "basis
     * functions" and "element matrices" (pf/base.h: counted in elements or faces), then the
     * solver's "symbolic analysis" and "numeric factorisation" (start and end only, total 1;
     * the DG penalty search factorises once per penalty tried). The same phases are heard
     * again at every later factorisation (pf_sim_frame, pf_sim_solve_static) and at every mesh
     * change's new set-up. Borrowed: user must outlive the simulator. Zero: none, at no cost. */
    pf_progress_hook progress;
} pf_sim_options;

/* pf_sim_create_embedded with options (NULL: none). */
pf_status pf_sim_create_with(pf_sim **sim, const pf_scene *scene, const pf_mesh *mesh,
                             const pf_sim_options *options, pf_error *err);
void pf_sim_destroy(pf_sim **sim);

/* ---- every MPI rank assembling its own elements (sim_distrib.c, sim_distrib_dyn.c) ----------
 * Rank 0 partitions the elements and sends each rank its own (DG: with their face neighbours);
 * each rank sets up the method on them, assembles its rows into PETSc's distributed matrix and
 * evaluates its elements' outputs, which rank 0 receives. Static scenes with the petsc solver, CG
 * or DG, without node or element list files (their indices are the whole mesh's), and dynamic
 * ones without cuts or refinement, each time step's corotated stiffness assembled by each rank on
 * its elements, the state kept distributed; contact with the ground and obstacles (not meshes) at
 * the boundary nodes, each rank testing the points of its own elements. Other scenes keep
 * rank 0 assembling everything (pf_sim_create). Built with PETSc only. */
typedef struct pf_sim_distrib_rank {
    int32_t elements;         /* the elements it owned and assembled */
    double setup_cpu_seconds; /* its part's arrival, set-up, assembly and PETSc's matrix */
    double assembly_cpu_seconds; /* dynamics: each step's system and its values sent to PETSc */
    double solve_cpu_seconds;    /* PETSc's solves, the preconditioner's set-up included */
    double cpu_seconds;          /* all of its share */
    double peak_rss_mb;       /* its process's peak resident memory */
} pf_sim_distrib_rank;

typedef struct pf_sim_distrib_result {
    double *u;         /* [3 n_nodes] nodal displacements (DG: the stitched field, eq. 30) */
    double *von_mises; /* [n_elems] at each element's centre */
    int32_t frame;     /* the frame u and von_mises are of (0: the start, or the static solution) */
    double time;       /* its time (dynamics) */
    int64_t dofs;
    double penalty;             /* DG's; 0 for CG */
    int32_t penalty_doublings; /* IP's automatic penalty: its doublings from 1; 0 otherwise */
    int32_t iterations;        /* the solve's; dynamics: of all steps */
    double residual;           /* relative to the right-hand side; dynamics: the largest */
    int64_t steps;             /* dynamics: the time steps taken */
    double kinetic;            /* dynamics: the kinetic energy of the last frame */
    int64_t contacts;          /* dynamics: contacts found, summed over steps and ranks (as
                                  pf_sim_stats.contacts) */
    int32_t factorisations;    /* MUMPS's, the definiteness tests of IP's automatic penalty */
    double error_indicator;    /* of the last frame, as pf_sim_error_indicator (NAN: none) */
    int32_t ranks;
    pf_sim_distrib_rank *rank; /* [ranks] */
} pf_sim_distrib_result;

/* Rank 0, after each frame (pf_sim_distrib_run): res holds the frame's outputs (u, von_mises,
 * frame, time). Its failure ends the run on every rank with its error. */
typedef pf_status (*pf_sim_distrib_frame_fn)(void *ctx, const pf_sim_distrib_result *res,
                                             pf_error *err);

/* Rank 0, after the frames 0, N, 2N, ... and the last (pf_sim_distrib_options): state [size]
 * holds the state the next frames depend on in the layout pf_sim_checkpoint writes for the same
 * scene and mesh (the whole mesh's unknowns in a one-process simulator's order), and res the
 * run's outputs and counts so far (frame, time, steps, iterations, factorisations). A checkpoint
 * is a restart point: the velocity trend the solver's first guess extrapolates is forgotten
 * after it, as on one process. Its failure ends the run on every rank with its error. */
typedef pf_status (*pf_sim_distrib_checkpoint_fn)(void *ctx, const pf_sim_distrib_result *res,
                                                  const void *state, size_t size, pf_error *err);

/* What pf_sim_distrib_run_with takes besides the scene and mesh (rank 0's). */
typedef struct pf_sim_distrib_options {
    pf_sim_distrib_frame_fn frame;           /* NULL: none */
    pf_sim_distrib_checkpoint_fn checkpoint; /* NULL: none */
    void *ctx;                               /* both functions' */
    int32_t checkpoint_every;                /* frames between checkpoints; 0: none */
    /* a state as pf_sim_checkpoint writes (pf_sim_restore's checks; that of a one-process run
     * too) to continue from: frames after its frame; a static scene solves nothing. NULL: the
     * start. */
    const void *restore;
    size_t restore_size;
} pf_sim_distrib_options;

/* Whether pf_sim_distrib_run takes the scene, for a mesh with an embedded surface and its weights
 * or without (embedded): contact there is at the surface's vertices, whose rows reach across
 * parts; that path has contact at the mesh's boundary nodes only. */
bool pf_sim_distrib_applies(const pf_scene *scene, bool embedded);
/* Rank 0, collective: the scene (resolved for mesh, which must be derived) on all ranks: the
 * static solve, or frame 0 and the scene's frames; frame (NULL: none) hears every frame, and out
 * holds the last. Every rank fails alike (no fixed face in a static scene, a diverging step, a
 * PETSc failure). */
pf_status pf_sim_distrib_run(const pf_scene *scene, const pf_mesh *mesh,
                             pf_sim_distrib_frame_fn frame, void *ctx, pf_sim_distrib_result *out,
                             pf_error *err);
/* pf_sim_distrib_run with checkpoints and a state to continue from (opt NULL: none). */
pf_status pf_sim_distrib_run_with(const pf_scene *scene, const pf_mesh *mesh,
                                  const pf_sim_distrib_options *opt, pf_sim_distrib_result *out,
                                  pf_error *err);
/* pf_sim_distrib_run of a static scene without a frame function. */
pf_status pf_sim_distrib_static(const pf_scene *scene, const pf_mesh *mesh,
                                pf_sim_distrib_result *out, pf_error *err);
/* Ranks > 0: their half, the task of pf_petsc_serve. */
pf_status pf_sim_distrib_serve(pf_error *err);
void pf_sim_distrib_result_release(pf_sim_distrib_result *r);

/* Static solve: the displacement under the scene's loads, gravity and fixed regions (linear
 * elasticity: no corotation, no contact). */
pf_status pf_sim_solve_static(pf_sim *sim, pf_error *err);

/* Advances one frame (scene->substeps semi-implicit Euler steps of dt / substeps). On a
 * non-finite or exploding state: PF_ERR_NUMERIC naming the frame and the element where it
 * started; the state before the frame is kept. */
pf_status pf_sim_frame(pf_sim *sim, pf_error *err);

/* Checkpoints (pf-sim --resume; the payload of the stream's CKPT chunk, docs/stream-format.md).
 * pf_sim_checkpoint appends to out the state the next frames depend on (unknowns, velocities,
 * time, frame, the energy check's sums, a fingerprint of scene, mesh and obstacle surfaces), and
 * makes the current state a restart point: the solver drops its factor so that the next step
 * factorises afresh, as a restored simulator's does (which changes the last bits of later frames
 * under pcg, never their accuracy). pf_sim_restore sets a simulator made for the same scene, mesh
 * and surface from such bytes; it then makes the same frames, bit for bit, as the run that wrote
 * them (same pf build and thread counts). PF_ERR_FORMAT for bytes that are not such a state
 * (sizes, counts, non-finite numbers, another mesh id or number of unknowns), PF_ERR_INVALID
 * when the fingerprint differs (another scene, mesh or obstacle file); s is unchanged then.
 * pf_sim_checkpoint refuses (PF_ERR_UNSUPPORTED) a simulator whose scene refines or whose mesh
 * changed (pf_sim_split, pf_sim_merge): the refinement's state is not stored. */
pf_status pf_sim_checkpoint(pf_sim *sim, pf_buffer *out, pf_error *err);
pf_status pf_sim_restore(pf_sim *sim, const void *bytes, size_t size, pf_error *err);

/* Simulated time and the number of frames advanced. */
double pf_sim_time(const pf_sim *sim);
int32_t pf_sim_frame_index(const pf_sim *sim);

/* Nodal displacements, out [3 n_nodes]: stitched (DG eq. 30), or the nodal unknowns (CG; fixed
 * nodes at their prescribed displacement). */
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
 * model units. It shrinks as the penalty grows (DG paper, fig. 1). 0 for cg (conforming). */
double pf_sim_max_node_jump(const pf_sim *sim);

/* An a-posteriori error indicator of the current state, a fraction (0.01: 1 %), for a user
 * asking how accurate a run is. dg: the largest jump between elements at a node
 * (pf_sim_max_node_jump) relative to the largest stitched nodal displacement (0 when nothing
 * moves): round-off (~1e-12) where the discrete solution is exact (affine fields), larger as the
 * mesh under-resolves the field. cg: the largest relative L2 boundary error of the shape
 * functions of the current elements (pf/basis.h; 0 when every element has closed forms): how
 * far the method is from conforming; it does not depend on the state. */
double pf_sim_error_indicator(const pf_sim *sim);
/* The name of the indicator's measure ("node_jump_over_displacement" for dg,
 * "basis_boundary_error" for cg), as statistics name it; *meaning (when not NULL) says what it
 * measures in words. Both are static strings. */
const char *pf_sim_error_measure(const pf_sim *sim, const char **meaning);

/* Volume of the deformed body: the mesh's elements with the stitched displacement applied to
 * their nodes, model units cubed. */
double pf_sim_deformed_volume(const pf_sim *sim);

const pf_sim_stats *pf_sim_get_stats(const pf_sim *sim);

/* The mesh the simulator runs on now: the one it was created with, or its latest change (owned
 * by the simulator, valid until the next frame or change; a new mesh has a new id). The embedded
 * surface's weights on it (NULL without an embedded surface). */
const pf_mesh *pf_sim_mesh(const pf_sim *sim);
const pf_weights *pf_sim_weights(const pf_sim *sim);
/* The embedded surface in force: the caller's, or the cut one after a cut (NULL without). */
const pf_surface *pf_sim_surface(const pf_sim *sim);

/* Splits the requested elements of the current mesh (pf_mesh_refine) and carries the state over
 * (DG: each child the parent's polynomial, exact; CG: new nodes take the parent's field at their
 * position), between steps: a new discretisation on the new mesh (DG integrals of untouched
 * elements and faces copied, the rest computed; pattern, factorisation), the same penalty, the
 * same time and energy bookkeeping. The embedded surface's weights are recomputed (MLS,
 * pf_embed_compute's defaults; after the first change only the rows the change reaches,
 * pf_embed_update). *n_split (may be NULL) receives the elements split (0: nothing
 * changed). On failure the simulator is unchanged. */
pf_status pf_sim_split(pf_sim *sim, const pf_refine_request *req, int32_t n_req, int32_t *n_split,
                       pf_error *err);

/* Merges groups of elements back into one element each (pf_mesh_coarsen: group[e] >= 0 the
 * group of element e of the current mesh, -1 kept) and carries the state over (DG: the L2
 * projection of the group's fields onto the merged element's polynomials, which keeps mass and
 * linear momentum exactly; CG: the nodes the merged mesh keeps keep their values). *n_merged
 * (may be NULL) receives the groups merged. On failure the simulator is unchanged. */
pf_status pf_sim_merge(pf_sim *sim, const int32_t *group, int32_t *n_merged, pf_error *err);

/* Cuts the current mesh by the requests (pf_mesh_cut on the rest shape; requests name elements
 * of pf_sim_mesh) and carries the state over in one transaction, as pf_sim_split: DG copies each
 * piece its parent's polynomial (exact), CG gives each node the field at its position (a copy of
 * a node its value). The embedded surface is cut with the mesh (pf_surface_cut) and re-weighted.
 * res (may be NULL) receives the cut's description (release it with pf_cut_result_release). On
 * failure the simulator is unchanged. */
pf_status pf_sim_cut(pf_sim *sim, const pf_cut_request *req, int32_t n_req, pf_cut_result *res,
                     pf_error *err);

/* The scene's cuts (docs/scene.md, "cuts") over the time from t0 to t1: each segment blade cuts
 * the elements, as they are deformed now, that the surface it swept from t0 to t1 passes
 * through; each plane whose time lies in (t0, t1] (or at or before t1 when t0 is 0) cuts every
 * element it crosses. A blade's plane reaches the rest shape through the affine map that best
 * fits the deformation of the elements it crosses at its first cut (exact when they move rigidly
 * or deform affinely), and stays there while the blade sweeps the same world plane. pf_sim_frame calls it after each frame; *n_cut (may be NULL) receives the
 * elements split. */
pf_status pf_sim_apply_cuts(pf_sim *sim, double t0, double t1, int32_t *n_cut, pf_error *err);

/* Stress-based refinement by the scene's "refine" parameters: every element whose largest absolute
 * corotated principal stress (at its centroid and vertices) exceeds the threshold, below
 * max_level and larger than min_size, is split (octs, or halves across the direction of that
 * stress), the most stressed first while the mesh stays within max_elements; but first, when the
 * children of some split have all stayed calm for coarsen_after calls, those merge back instead
 * (and splits wait for the next call). pf_sim_frame calls it after every frame when the scene
 * refines. *n_changed (may be NULL): the elements split or groups merged. */
pf_status pf_sim_refine(pf_sim *sim, int32_t *n_changed, pf_error *err);

/* The refinement criterion's stress of every element (pf_sim_refine compares it with the
 * threshold): value [n_elems] the corotated principal stress of largest magnitude at the
 * element's centroid and vertices (signed, stress units), direction [n_elems] its direction in
 * the rest frame (unit). For a threshold relative to the largest value now (bench/bench_adapt.c,
 * tests/test_sim_refine_accuracy.c). */
void pf_sim_principal_stresses(const pf_sim *sim, double *value, pf_vec3 *direction);

/* The work of the scene's constant loads and body forces (tractions, gravity) on the current
 * displacement, f . u, force times length. After pf_sim_solve_static it is the compliance, twice
 * the elastic energy: for a conforming method (CG) it approaches the exact value from below under
 * refinement, the gap being the squared energy norm of the error. */
double pf_sim_load_work(const pf_sim *sim);

/* The run's statistics as a JSON object (docs/scene.md, "Run statistics"): pf_sim_get_stats with
 * the solver's factorisations by reason, PCG iterations (mean and largest), seconds per phase
 * (wall, and CPU where measured), frames and simulated time, and the whole run's wall_seconds and
 * cpu_seconds as the caller measured them. *json is NUL-terminated, freed with pf_free.
 * PF_ERR_NOMEM. */
pf_status pf_sim_stats_json(const pf_sim *sim, double wall_seconds, double cpu_seconds,
                            char **json, pf_error *err);

/* The counters a resumed run carries over (a CKPT's header): time steps, factorisations, linear
 * solves and PCG iterations of this simulator so far, its set-up included. */
void pf_sim_run_counts(const pf_sim *sim, pf_run_counts *c);

/* The run's statistics as the entries of a STAT chunk (docs/stream-format.md), for pf-info:
 * method, degree and flux (dg), the error indicator and its measure (pf_sim_error_indicator),
 * elements and unknowns of the current mesh, frames, simulated time, the counters of counts
 * (NULL: pf_sim_run_counts; a resumed run passes the whole run's), solver, mesh changes and cuts.
 * Only numbers that the same run reproduces bit for bit: no timings. Appended to d (keys already
 * there are replaced). A non-finite indicator (a diverged state) is left out. PF_ERR_NOMEM. */
pf_status pf_sim_stats_entries(const pf_sim *sim, const pf_run_counts *counts, pf_stats_data *d,
                               pf_error *err);
/* The same entries for a run of pf_sim_distrib_run on a mesh of elements (res: its result, the
 * last frame's): steps, solves (static: 1), PETSc's iterations as pcg_iterations, MUMPS's
 * definiteness tests as factorisations. */
pf_status pf_sim_distrib_stats_entries(const pf_scene *scene, int32_t elements,
                                       const pf_sim_distrib_result *res, pf_stats_data *d,
                                       pf_error *err);
/* pf-sim --stats of a run of pf_sim_distrib_run (res its result) as JSON (*json: pf_free):
 * frames, steps, unknowns, penalty, the indicator, rank 0's CPU seconds by phase (set-up,
 * assembly, PETSc's solves) beside the run's wall and CPU (wall_seconds, cpu_seconds), the solves
 * and iterations, and per rank its elements, CPU by phase and peak RSS. PF_ERR_NOMEM. */
pf_status pf_sim_distrib_stats_json(const pf_scene *scene, const pf_sim_distrib_result *res,
                                    double wall_seconds, double cpu_seconds, char **json,
                                    pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
