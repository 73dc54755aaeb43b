/* Penalty contact between the two sides of a crack (private to libcore/sim).
 *
 * The faces a cut opened (the mesh's face group "cut", pf/cut.h) come in twins: both sides of an
 * opened face start coincident, one boundary face of each side. A crack point is a node on an
 * opened face, moved by its element's own field (a DG node once per element at it, each with its
 * share of the penalty, as contact.h does); its twin faces are the opened faces of the other side
 * whose rest polygon holds the node's rest position. The point's partner is the material point of
 * the twin face's element at that same rest position, so with a the point's compact row and b the
 * partner's (method.h, point_row), the gap along the twin face's deformed outward normal n is
 * g = n . (a - b)^T u, and a penetrating point (g < 0, projecting inside the twin polygon) adds the
 * energy 1/2 k g^2: the force -k g n through a and its opposite through b (momentum exact), and
 * the stiffness k (a - b)(a - b)^T (x) n n^T, which enters the step's matrix as its majorant
 * 2 k (a a^T + b b^T) (x) n n^T: within each side's own element, which the pattern has. */
#ifndef PF_SIM_CONTACT_CRACK_H
#define PF_SIM_CONTACT_CRACK_H

#include "contact.h"

typedef struct pf_crack pf_crack;

typedef struct pf_crack_stats {
    int32_t faces;    /* opened faces (both sides) */
    int32_t points;   /* crack points: nodes on them with a twin face, a DG node once per
                         element at it */
    int32_t unpaired; /* nodes on them without one: the crack front, where both sides meet */
    double nodes;     /* the points' shares summed: the nodes on opened faces */
    double stiffness; /* the penalty per node (a point's is its share of it) */
    double max_depth; /* the deepest penetration of the last detection (predicted), model units */
} pf_crack_stats;

/* *c = NULL (and PF_OK) when the mesh has no opened face with a twin, or the scene is static:
 * no work at all.
 * The penalty per point is the scene's ground stiffness when given, else setup->auto_stiffness,
 * times the point's share. Borrows what setup borrows. PF_ERR_NOMEM. */
pf_status pf_crack_create(pf_crack **c, const pf_contact_setup *setup, pf_error *err);
void pf_crack_destroy(pf_crack **c);

/* Finds the points whose position predicted by u + h v lies behind a twin face (projecting
 * inside its polygon, within a twentieth of its diameter) and keeps them, with the twin's
 * outward normal there, for the calls below. Returns their number. Allocates nothing. */
int64_t pf_crack_detect(pf_crack *c, const double *u, const double *v, double h);

/* Adds the detected contacts' penalty forces at state u to f [3 n_triples]: -k g n through the
 * point's row, k g n through its partner's. Allocates nothing. */
void pf_crack_forces(const pf_crack *c, const double *u, double *f);

/* Adds alpha times the majorant 2 k (a a^T + b b^T) (x) n n^T of every detected contact to k. */
void pf_crack_add_stiffness(const pf_crack *c, double alpha, pf_block_matrix *k);

/* Whether the last detection found another set of contacts than the one before. */
bool pf_crack_set_changed(const pf_crack *c);

/* The number of contacts found by the last detection. */
int64_t pf_crack_count(const pf_crack *c);

const pf_crack_stats *pf_crack_get_stats(const pf_crack *c);

#endif
