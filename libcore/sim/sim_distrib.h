/* A rank's part of the distributed solve (sim_distrib.c, sim_distrib_cg.c, sim_distrib_dyn.c),
 * private to libcore/sim. */
#ifndef PF_SIM_DISTRIB_H
#define PF_SIM_DISTRIB_H

#include <pf/io.h>
#include <pf/sim.h>

#include "contact.h"
#include "method.h"
#include "sim_internal.h"

#ifdef PF_HAVE_PETSC
#include <petscksp.h>

/* What the header of a part's message holds. */
typedef struct part_header {
    int64_t mesh_bytes, groups_bytes;
    int32_t n_elems, n_nodes;     /* the part's */
    int32_t all_elems, all_nodes; /* the whole mesh's */
    int64_t scene_bytes;
    double lo[3], hi[3];      /* the whole mesh's bounds */
    int64_t all_free;         /* CG: the whole mesh's free nodes */
    int32_t fixed_faces;      /* CG: the whole mesh's fixed faces */
    int32_t checkpoint_every; /* frames between checkpoints (0: none) */
    int32_t restoring;        /* 1: the state comes from rank 0's checkpoint */
    int32_t unused;
    int64_t obstacle_bytes; /* the mesh obstacles' surfaces (pf_sim_distrib_obstacles_pack) */
} part_header;

/* One rank's part and what it computes. */
typedef struct part {
    part_header h;
    pf_scene scene;
    pf_mesh mesh;
    int64_t *pelem; /* [n_elems] PETSc number of each element */
    int32_t *gelem; /* [n_elems] its index in the whole mesh */
    int32_t *gnode; /* [n_nodes] each node's index in the whole mesh */
    uint8_t *owned; /* [n_elems] */
    int32_t n_owned;
    const pf_method_ops *ops;
    void *method;
    pf_block_matrix k;
    double *f, *u; /* [n_dofs] */
    int32_t nb3;   /* DG: unknowns per element */
    double penalty;
    int32_t doublings; /* DG: the automatic penalty's, from 1 */
    /* CG only (NULL for DG): per node its PETSc block (-1: fixed), whether this rank owns it (the
     * lowest rank among the parts that hold it) and its prescribed displacement; per face
     * whether it lies between parts */
    int64_t *pnode;      /* [n_nodes] */
    int64_t *wnode;      /* [n_nodes] its block among the whole mesh's free nodes (-1: fixed) */
    uint8_t *node_owned; /* [n_nodes] */
    double *g;           /* [3 n_nodes] */
    uint8_t *cut;        /* [n_faces of the part] */
    /* dynamics with contact (pf_scene_has_contact): per node of the part whether it lies on
     * the whole mesh's boundary and the number of the whole mesh's elements at it */
    uint8_t *boundary;  /* [n_nodes] */
    int32_t *sharers;   /* [n_nodes] */
    /* both: the PETSc row of each of the part's unknowns, and whether this rank owns it */
    int64_t n_dofs;
    PetscInt *row;      /* [n_dofs] */
    uint8_t *row_owned; /* [n_dofs] */
    int64_t *wdof;      /* [n_dofs] its index among the one-process simulator's unknowns */
    PetscInt local_rows, all_rows;
    PetscScalar *coo_v; /* [n_coo] the values this rank sends (pf_sim_distrib_matrix_values) */
    PetscCount n_coo;
} part;

/* Rank 0's view of CG on the whole mesh: each node's fixed flag and displacement (CG's rule on
 * the whole mesh), its owning part and PETSc block (free nodes numbered part by part). */
typedef struct cg_whole {
    uint8_t *fixed;      /* [n_nodes] */
    double *g;           /* [3 n_nodes] */
    int32_t *node_owner; /* [n_nodes] */
    int64_t *pnode;      /* [n_nodes], -1 fixed */
    int64_t *wnode;      /* [n_nodes] free nodes numbered in node order (-1: fixed, unused) */
    int64_t all_free;
    int32_t fixed_faces;
} cg_whole;

/* What a rank reports to rank 0: its owned elements, CPU seconds of its set-up (receiving the
 * part, the method, assembly and matrix), of the steps' assembly (dynamics), of PETSc's solves
 * and of all, peak RSS in MB, and the solves' outcome (dynamics: iterations summed, the largest
 * residual). */
typedef struct rank_stats {
    double owned, setup_cpu, assembly_cpu, solve_cpu, cpu, rss_mb, iterations, residual, reason;
} rank_stats;

/* Rank 0's outputs: the result, the sums [4 all_nodes] its nodal displacements are made of, the
 * function that hears each frame (NULL: none), the run's options (checkpoints, the state to
 * restore) and its scene and whole mesh (the checkpoints' fingerprint). NULL on the other
 * ranks. */
typedef struct distrib_out {
    pf_sim_distrib_result *res;
    double *nodes;
    pf_sim_distrib_frame_fn frame;
    void *ctx;
    const pf_sim_distrib_options *opt;
    const pf_scene *scene;
    const pf_mesh *mesh;
} distrib_out;

/* What contact on a part needs of the whole mesh (sim_distrib_contact.c): per node whether it
 * lies on a boundary face and the number of elements using it (DG's node_elements: every element
 * with a face at the node). */
typedef struct contact_whole {
    uint8_t *boundary; /* [n_nodes] */
    int32_t *sharers;  /* [n_nodes] */
} contact_whole;

/* Rank 0: w for the derived mesh m. */
pf_status pf_sim_distrib_contact_whole(const pf_mesh *m, contact_whole *w, pf_error *err);
void pf_sim_distrib_contact_whole_release(contact_whole *w);
/* Rank 0: the part's nodes' (node_id >= 0, in order) entries of w appended to out. */
pf_status pf_sim_distrib_contact_pack(const pf_mesh *m, const contact_whole *w,
                                      const int32_t *node_id, pf_buffer *out, pf_error *err);
/* Each rank: p->boundary and p->sharers from what pf_sim_distrib_contact_pack wrote at *at,
 * which moves past it. */
pf_status pf_sim_distrib_contact_unpack(part *p, unsigned char **at, pf_error *err);
/* Rank 0: the scene's mesh obstacles' triangles (SURF payloads, each after its size) into out;
 * each rank: them handed to its scene (pf_scene_set_obstacle_surface) from bytes [size]. */
pf_status pf_sim_distrib_obstacles_pack(const pf_scene *scene, pf_buffer *out, pf_error *err);
pf_status pf_sim_distrib_obstacles_unpack(pf_scene *scene, const unsigned char *bytes,
                                          int64_t size, pf_error *err);
/* Each rank, collective: contact at the part's boundary nodes (sim_distrib_contact.c) into *c
 * (NULL without ground and obstacles, or on a rank without elements), cp its part's filter
 * (borrowed by *c); model_size the whole mesh's bounding-box diagonal. */
pf_status pf_sim_distrib_contact_create(part *p, double model_size, pf_contact_part *cp,
                                        pf_contact **c, pf_error *err);

/* Collective: every rank learns whether any failed (st < 0 on some rank); its own error stays, the
 * others get one saying another rank failed (rank 0 reports its own error when it has one). Before
 * collective calls that a rank failing alone would leave the others waiting in. */
pf_status pf_sim_distrib_agree(pf_status st, pf_error *err);

/* Rank 0: w for the mesh m (derived) whose elements are in parts owner [n_elems]. */
pf_status pf_sim_distrib_cg_whole(const pf_scene *scene, const pf_mesh *m, const int64_t *owner,
                                  int32_t parts, cg_whole *w, pf_error *err);
void pf_sim_distrib_cg_whole_release(cg_whole *w);
/* Rank 0: part r's CG data appended to out: per kept node (node_id >= 0, in order) its PETSc
 * block, ownership and displacement; per face of the part (m's faces a kept element uses, in m's
 * order) whether it lies between parts. */
pf_status pf_sim_distrib_cg_pack(const pf_mesh *m, const cg_whole *w, const uint8_t *keep,
                                 const int32_t *node_id, int32_t r, pf_buffer *out, pf_error *err);
/* Each rank: reads what pf_sim_distrib_cg_pack wrote (at: after the node ids; p->mesh decoded,
 * not yet derived). */
pf_status pf_sim_distrib_cg_unpack(part *p, const unsigned char *at, pf_error *err);
/* Each rank: the CG method on its part with the whole mesh's fixed nodes, and the rows. */
pf_status pf_sim_distrib_cg_create(part *p, pf_error *err);
/* Each rank: per node of the whole mesh [4 all_nodes] the displacement of the nodes it owns with
 * a count of 1 (p->u solved). */
void pf_sim_distrib_cg_nodal(const part *p, double *sum, double *scratch);
void pf_sim_distrib_cg_release(part *p);

/* Each rank, collective: the part's outputs at p->u (its elements' fields at their nodes, von
 * Mises) into rank 0's o->res (frame and time set by the caller), then o->frame hears them. */
pf_status pf_sim_distrib_outputs(part *p, const distrib_out *o, pf_error *err);
/* Each rank, collective: the six rigid modes (about the whole mesh's centre) as a's near-null
 * space; p->u is the scratch and is left zero. */
pf_status pf_sim_distrib_rigid_modes(part *p, Mat a, pf_error *err);
/* Each rank, collective (sim_distrib_dyn.c): the dynamic frames of a part (set up; DG: penalty
 * chosen), each frame's outputs to o; rs gets the solves' counts and the set-up's CPU seconds
 * (from cpu0). */
pf_status pf_sim_distrib_dynamics(part *p, const distrib_out *o, rank_stats *rs, double cpu0,
                                  pf_error *err);

/* Rank 0's result's counts from its part and statistics: iterations, residual, penalty, MUMPS's
 * definiteness tests, unknowns (res NULL: nothing). */
void pf_sim_distrib_result_counts(const part *p, const rank_stats *rs, pf_sim_distrib_result *res);

/* ---- checkpoints (sim_distrib_ckpt.c): the one-process simulator's CKPT state ------------------
 * Each rank: p->wdof, the whole mesh's index of each unknown of the part (after its rows). */
pf_status pf_sim_distrib_whole_dofs(part *p, pf_error *err);
/* Whether frame index gets a checkpoint (after frames 0, N, 2N, ... and the last). */
bool pf_sim_distrib_checkpoint_due(const part *p, int32_t index);
/* Each rank, collective: the owned unknowns' p->u and v [n_dofs] (NULL: at rest) gathered on rank
 * 0 in the whole mesh's order, with st (its work this rank's share, summed here; mesh, print and n
 * filled in), as the CKPT state o->opt->checkpoint hears (o->res's counts from rs). */
pf_status pf_sim_distrib_checkpoint(part *p, const double *v, const pf_sim_saved *st,
                                    const rank_stats *rs, const distrib_out *o, pf_error *err);
/* Each rank, collective: rank 0 reads and checks o->opt->restore, every rank receives its part's
 * p->u and v [n_dofs] (NULL: dropped) and st (its work rank 0's alone, 0 elsewhere). */
pf_status pf_sim_distrib_restore(part *p, double *v, pf_sim_saved *st, const distrib_out *o,
                                 pf_error *err);

/* Each rank, collective: pf_sim_distrib_restore, then the restored state's outputs into o->res
 * (its frame and time; no frame function: the stream resumed has that frame). */
pf_status pf_sim_distrib_resume(part *p, double *v, pf_sim_saved *st, const distrib_out *o,
                                pf_error *err);

/* Each rank, collective (sim_distrib_mat.c): PETSc's matrix *a of all ranks' parts, from the
 * entries of p->k this rank is the one to send (DG: see sim_distrib.c; CG: all), at the rows
 * p->row; duplicates summed. */
pf_status pf_sim_distrib_matrix(part *p, Mat *a, pf_error *err);
/* Each rank, collective: a's values again from p->k (a made by pf_sim_distrib_matrix from the same
 * pattern), through the part's COO value buffer (made once). */
pf_status pf_sim_distrib_matrix_values(part *p, Mat a, pf_error *err);
/* Each rank, collective: DG's automatic interior penalty on the whole mesh into p->penalty (p->k's
 * pattern made, p->u zero; p->f left zero). PF_ERR_NUMERIC when none up to 2^20 is definite. */
pf_status pf_sim_distrib_search_penalty(part *p, pf_error *err);

#endif
#endif
