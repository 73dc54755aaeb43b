/* Penalty contact for the simulator, for every method (private to libcore/sim).
 *
 * Contact points are the mesh's boundary nodes or, when the simulation has embedding weights, the
 * embedded surface's vertices. A point moves by u~ = sum_t beta_t u_t over the method's unknown
 * triples: a node with its element's own field (one point per element at the node for DG, whose
 * fields disagree there, each with its share of the penalty), a surface vertex by its WGHT row
 * through the method's nodal map S (DG paper eq. 32). Obstacles (and the ground plane) are tested
 * against the points' positions predicted for the end of the step; a penetrating point with
 * nearest obstacle surface point c and outward normal n adds the penalty energy
 * 1/2 k (n . (x_c + u~ - c))^2: the force k beta (n . (c - x_c - u~)) n, and the stiffness
 * k (beta beta^T) (x) n n^T (DG paper sec. 8), which enters the step's matrix through the point's
 * compact row b instead of beta (contact.c says why). */
#ifndef PF_SIM_CONTACT_H
#define PF_SIM_CONTACT_H

#include <pf/sim.h>
#include <pf/solve.h>

#include "method.h"

typedef struct pf_contact pf_contact;

/* A rank's part of a distributed mesh (sim_distrib_dyn.c): the points at boundary nodes that this
 * part holds, so that every point of the whole mesh is held by one part. */
typedef struct pf_contact_part {
    const uint8_t *boundary; /* [n_nodes] on the whole mesh's boundary (a part's own boundary
                                includes the faces between parts) */
    const int32_t *sharers;  /* [n_nodes] the elements at the node in the whole mesh whose points
                                split its penalty (DG: all at the node); NULL: node_elements' */
    const uint8_t *element_holds; /* [n_elems] elements whose points the part holds (NULL: all) */
    const uint8_t *node_holds;    /* [n_nodes] nodes whose points the part holds (NULL: all) */
} pf_contact_part;

/* Flags the nodes of m's boundary faces (on [n_nodes], zeroed, may be NULL) and counts them. */
pf_status pf_contact_boundary_nodes(const pf_mesh *m, uint8_t *on, int32_t *count, pf_error *err);

/* What contact needs from the driver; every pointer borrowed for the contact's lifetime. */
typedef struct pf_contact_setup {
    const pf_scene *scene; /* resolved; mesh obstacles' triangles handed over
                              (pf_scene_set_obstacle_surface) */
    const pf_mesh *mesh;
    int64_t n_triples;        /* unknowns / 3 */
    const pf_method_ops *ops; /* the method's nodal map and compact rows (method.h) */
    const void *method;
    const pf_surface *surface; /* embedded surface and its weights, or both NULL: nodes */
    const pf_weights *weights;
    double auto_stiffness; /* the method's automatic stiffness per boundary node */
    double model_size;     /* the mesh's bounding-box diagonal */
    int32_t n_blocks;      /* the system matrix's blocks: block_start [n_blocks + 1] unknowns */
    const int64_t *block_start;
    const pf_contact_part *part; /* NULL on one process; with boundary nodes only (no surface) */
} pf_contact_setup;

/* Time spent, seconds, since creation. */
typedef struct pf_contact_stats {
    int32_t points;        /* contact points: boundary nodes or surface vertices */
    int32_t samples;       /* and samples on surface triangles larger than the elements */
    double embed_seconds;  /* predicted positions of the points (the embedding mat-vec) */
    double search_seconds; /* broad and narrow phase, and assembly of the penalty terms */
} pf_contact_stats;

/* *c = NULL (and PF_OK) when the scene has neither ground nor obstacles: no contact work at all.
 * PF_ERR_INVALID when a mesh obstacle's surface is not loaded or the weights do not match the
 * mesh and surface; PF_ERR_NOMEM. */
pf_status pf_contact_create(pf_contact **c, const pf_contact_setup *setup, pf_error *err);
void pf_contact_destroy(pf_contact **c);

/* Finds the points whose position predicted by u + h v lies inside an obstacle or below the
 * ground at time t (the end of the step), and keeps them for the calls below until the next
 * detection. Returns their number. Allocates nothing. */
int64_t pf_contact_detect(pf_contact *c, double t, const double *u, const double *v, double h);

/* Adds the detected contacts' penalty forces at state u, k beta (g - n . u~) n, to f
 * [3 n_triples] (DG paper sec. 8). Allocates nothing. */
void pf_contact_forces(pf_contact *c, const double *u, double *f);

/* Adds alpha times the contacts' stiffness to k: k (b b^T) (x) n n^T for a point whose row is
 * its compact row b; for a surface vertex (row beta) a matrix at least as stiff, built from b and
 * the diagonal (contact.c): within one element's couplings and the diagonal, which k's pattern
 * has. */
void pf_contact_add_stiffness(pf_contact *c, double alpha, pf_block_matrix *k);

/* k += a (w w^T) (x) n n^T for one point's row: triple [n] ascending, its weights w [n], within
 * one element's couplings (pairs the pattern lacks are skipped); triple_block [n_triples] the
 * matrix block of each triple. Shared with the crack faces' contact (contact_crack.c). */
void pf_contact_add_row(pf_block_matrix *k, const int32_t *triple_block, const int64_t *triple,
                        const double *w, int64_t n, pf_vec3 normal, double a);

/* The power the moving obstacles deliver through the last pf_contact_forces: the sum over the
 * contacts of the penalty force times the obstacle's velocity (0 for fixed obstacles). */
double pf_contact_obstacle_power(const pf_contact *c);

/* Whether the last detection found another set of contacts (points and obstacles) than the one
 * before: the step's matrix then gains or loses terms. */
bool pf_contact_set_changed(const pf_contact *c);

/* The number of contacts found by the last detection. */
int64_t pf_contact_count(const pf_contact *c);

const pf_contact_stats *pf_contact_get_stats(const pf_contact *c);

#endif
