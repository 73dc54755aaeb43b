/* The simulator's state, shared by the driver (sim.c) and the mesh changes (sim_refine.c).
 * Private to libcore/sim. */
#ifndef PF_SIM_INTERNAL_H
#define PF_SIM_INTERNAL_H

#include <pf/sim.h>

#include "contact.h"
#include "contact_crack.h"
#include "method.h"

struct pf_sim {
    const pf_scene *scene;     /* the caller's, or owned_scene after a mesh change */
    pf_scene *owned_scene;     /* the caller's with its node and element lists carried to the
                                  current mesh (sim_change.h); NULL without lists */
    const pf_mesh *mesh;       /* the caller's, or owned_mesh after a refinement */
    pf_mesh *owned_mesh;       /* NULL until a refinement (on the heap: the method and contact
                                  keep pointers to it) */
    const pf_surface *surface; /* the embedded surface (the caller's), NULL without */
    const pf_weights *weights; /* its weights on mesh: the caller's, or owned_weights */
    pf_weights *owned_weights;
    int32_t *embed_steps;      /* [surface vertices] the growth steps of owned_weights
                                  (pf_embed_compute_steps), NULL while the weights are the
                                  caller's or a cut's: the next change then computes all rows */
    pf_surface *owned_surface; /* the surface after a cut (surface then points to it) */
    const pf_surface *uncut_surface; /* the caller's surface, from which every cut surface is
                                        made with all the faces opened so far */
    /* the scene's blades (sim_cut.c): the rest-shape plane each cuts along, fixed at its first
     * cut for as long as it moves in the same world plane; NULL before any cut */
    struct blade_lock *blade_locks;
    /* refinement bookkeeping (sim_refine.c), NULL until the first refinement or criterion:
     * per element its depth, its family (the split that made it, an index into families, -1
     * for the first mesh's elements) and the frames in a row it has been calm */
    int32_t *level, *family, *calm;
    pf_buffer families;
    const pf_method_ops *ops;
    void *method;
    int64_t n;     /* unknowns */
    double *f_ext; /* [n] loads and body forces, constant */
    double *u, *v; /* state */
    double *f, *ku, *rhs;
    double *u_prev, *v_prev; /* the state before the frame, restored on failure */
    /* The warm start's trend: the last two steps' velocity changes, valid for the last trend
     * steps (0, 1 or 2; pf_sim_forget_trend) */
    double *dv, *dv2;
    int32_t trend;
    /* [3 n] the rotation of every unknown triple (pcg's warp) */
    double *rot;
    pf_block_matrix k;
    pf_solver *solver;
    bool assembled;      /* the system matrix has been assembled once (it changes afterwards only
                            with corotation) */
    pf_contact *contact; /* NULL without ground and obstacles, and in static scenes */
    pf_crack *crack;     /* the crack faces' contact: NULL until a cut opened faces */
    double model_size;
    /* the energy check (energy_is_bounded): the kinetic energy when the first frame began, the
     * work of the loads, body forces and moving obstacles since, the elastic energy the start
     * can release, and a floor below which kinetic energy is noise */
    bool energy_started;
    double kinetic0, work, fixed_energy, energy_floor;
    double time;
    int32_t frame;
    pf_sim_stats stats;
    pf_solver_stats solver_before; /* the solves of the solvers of meshes before a change */
    double method_seconds;         /* creating the method (pf_sim_build), CPU seconds */
    pf_progress_hook progress;     /* the caller's (pf_sim_options), zero: none */
};

/* Creates the discretisation of s->scene on mesh: the method (taking over what reuse allows; NULL:
 * nothing), state vectors, pattern, contact, solver and constant forces, with the penalty given
 * (> 0, DG) or searched (0). s->scene, s->surface, s->weights and s->progress must be set. */
pf_status pf_sim_build(pf_sim *s, const pf_mesh *mesh, const pf_method_reuse *reuse, double penalty,
                       pf_error *err);

/* The BZ flux's penalty when the scene gives none (sim.c). */
double pf_sim_bz_default_penalty(int32_t degree);
/* Corotated dynamics take this multiple of the smallest IP penalty definite at rest (sim.c,
 * choose_penalty, says why). */
enum { PF_SIM_COROTATED_PENALTY_MARGIN = 8 };

/* Frees what pf_sim_build made and the owned mesh and weights, but not s. */
void pf_sim_release(pf_sim *s);

/* The solver's statistics, with those of earlier meshes' solvers, into the simulator's. */
void pf_sim_sync_solver_stats(pf_sim *s);

/* Drops the history the next step starts from (the velocity trend, the warp's last rotations,
 * the method's element rotations): after a failed step, a restored state or a restart point, so
 * that what follows depends on the state alone. */
void pf_sim_forget_trend(pf_sim *s);

/* A checkpoint's state (sim_state.c, the CKPT payload of docs/stream-format.md) apart from the
 * unknowns and velocities [n] that follow it: what pf_sim_checkpoint stores, shared with the runs
 * where every rank assembles its own elements (sim_distrib_ckpt.c). */
typedef struct pf_sim_saved {
    uint64_t mesh_id;
    int32_t frame;
    uint32_t print; /* pf_sim_state_fingerprint */
    double time;
    int64_t n;
    bool energy_started;
    double kinetic0, work, fixed_energy, energy_floor;
} pf_sim_saved;

/* CRC-32 of the scene as resolved (its JSON), the mesh's nodes and the obstacles' triangles. */
pf_status pf_sim_state_fingerprint(const pf_scene *scene, const pf_mesh *mesh, uint32_t *out,
                                   pf_error *err);
/* Appends st, then u [st->n] and v [st->n], to out. */
pf_status pf_sim_state_encode(const pf_sim_saved *st, const double *u, const double *v,
                              pf_buffer *out, pf_error *err);
/* Reads and checks bytes as the state of n unknowns of scene on mesh (pf_sim_restore's errors);
 * *values: the 2 n numbers, read with pf_sim_state_value (u's, then v's). */
pf_status pf_sim_state_decode(const void *bytes, size_t size, const pf_scene *scene,
                              const pf_mesh *mesh, int64_t n, pf_sim_saved *st,
                              const unsigned char **values, pf_error *err);
double pf_sim_state_value(const unsigned char *values, int64_t q);

#endif
