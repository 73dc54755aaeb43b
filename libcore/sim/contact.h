/* Penalty contact for the simulator, for every method (private to libcore/sim).
 *
 * Contact points are the mesh's boundary nodes or, when the simulation has embedding weights, the
 * embedded surface's vertices. A point's displacement is a linear combination of the method's
 * unknown triples: the method's nodal map S (method.h) composed with the point's row of nodes
 * (identity for a node, the WGHT row for a surface vertex), u~(x_c) = sum_t beta_t u_t (DG paper
 * eq. 32). Obstacles (and the ground plane) are tested against the points' positions predicted
 * for the end of the step; a penetrating point with nearest obstacle surface point c and outward
 * normal n adds the penalty energy 1/2 k (n . (x_c + u~ - c))^2, linear in the unknowns: the
 * paper's sec. 8 terms K_ab += k beta_a beta_b n n^T and F_a += k beta_a (n . (c - x_c)) n. */
#ifndef PF_SIM_CONTACT_H
#define PF_SIM_CONTACT_H

#include <pf/sim.h>
#include <pf/solve.h>

typedef struct pf_contact pf_contact;

/* What contact needs from the driver; every pointer borrowed for the contact's lifetime. */
typedef struct pf_contact_setup {
    const pf_scene *scene; /* resolved; mesh obstacles loaded (pf_scene_load_obstacles) */
    const pf_mesh *mesh;
    int64_t n_triples;     /* unknowns / 3 */
    const int64_t *map_offsets, *map_triple; /* the method's nodal map (method.h) */
    const double *map_w;
    const pf_surface *surface; /* embedded surface and its weights, or both NULL: nodes */
    const pf_weights *weights;
    double auto_stiffness; /* the method's automatic stiffness per boundary node */
    double model_size;     /* the mesh's bounding-box diagonal */
    int32_t n_blocks;      /* the matrix's blocks: block_start [n_blocks + 1] unknowns */
    const int64_t *block_start;
} pf_contact_setup;

/* Time spent, seconds, since creation. */
typedef struct pf_contact_stats {
    int32_t points;        /* contact points */
    double embed_seconds;  /* predicted positions of the points (the embedding mat-vec) */
    double search_seconds; /* broad and narrow phase, and assembly of the penalty terms */
} pf_contact_stats;

/* *c = NULL (and PF_OK) when the scene has neither ground nor obstacles: no contact work at all.
 * PF_ERR_INVALID when a mesh obstacle's surface is not loaded or the weights do not match the
 * mesh and surface; PF_ERR_NOMEM. */
pf_status pf_contact_create(pf_contact **c, const pf_contact_setup *setup, pf_error *err);
void pf_contact_destroy(pf_contact **c);

/* Finds the points whose position predicted by u + h v lies inside an obstacle or below the
 * ground at time t (the end of the step), and keeps them for pf_contact_assemble. Returns their
 * number. A contact whose couplings are not in the matrix pattern yet asks for growth
 * (pf_contact_needs_pattern): contact only costs pattern and fill where it happens. Allocates
 * nothing. */
int64_t pf_contact_detect(pf_contact *c, double t, const double *u, const double *v, double h);

/* True after a detection found points outside the pattern. */
bool pf_contact_needs_pattern(const pf_contact *c);

/* Rebuilds k's pattern (values zero) from its current pairs plus every pair of blocks a point in
 * the pattern set may couple: the blocks of the triples in one point's combination. The caller
 * analyses the new pattern again (a growth event, not a steady-state step). PF_ERR_NOMEM. */
pf_status pf_contact_grow_pattern(pf_contact *c, pf_block_matrix *k, pf_error *err);

/* Adds the linearised penalty of the detected contacts to k (pattern grown) and f, DG paper
 * sec. 8. Allocates nothing. */
void pf_contact_assemble(pf_contact *c, pf_block_matrix *k, double *f);

const pf_contact_stats *pf_contact_get_stats(const pf_contact *c);

#endif
