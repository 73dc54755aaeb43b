/* The discretisations the simulator drives (private to libcore/sim).
 *
 * The driver (sim.c) owns the state vectors, the system matrix and its factorisation, time
 * stepping, the penalty search, divergence checks and statistics; a method (sim_dg.c, sim_cg.c)
 * owns what depends on the basis: unknowns, matrix pattern, stiffness (warped with its own
 * rotations when corotation is on), mass, constant forces, contact, and the outputs. A method's
 * unknowns are whatever it solves for (DG: polynomial coefficients; CG: free nodal components);
 * the driver never looks inside them. */
#ifndef PF_SIM_METHOD_H
#define PF_SIM_METHOD_H

#include <pf/sim.h>
#include <pf/solve.h>

/* How the elements and nodes of a new mesh relate to the old one's (sim_change.c). */
typedef struct pf_mesh_change {
    const pf_mesh *old_mesh;
    const int32_t *parent;      /* [new elements] the old element each comes from (a merged
                                   element: one of its group) */
    const uint8_t *split;       /* [old elements] 1 for an element split into children */
    const int32_t *merged_into; /* [old elements] the new element an old one was merged into,
                                   -1 for none; NULL when nothing merged */
    const int32_t *node_map;    /* [old nodes] the new index of each old node, -1 when removed;
                                   NULL: every old node keeps its index */
    const int32_t *face_src;    /* [new faces] the old face each new face is, node for node, or
                                   -1 (refinement); NULL: not known */
    const pf_cut_result *cut;   /* a cut (pf_mesh_cut): the embedded surface is cut with the mesh;
                                   NULL for refinement and coarsening */
} pf_mesh_change;

typedef struct pf_method_ops {
    /* Unknowns and the pattern of the system matrix. */
    int64_t (*n_dofs)(const void *m);
    pf_status (*pattern)(const void *m, pf_block_matrix *k, pf_error *err);
    /* Stiffness at state u into k (zeroed first); its constant terms (prescribed displacements,
     * the warping terms R K (I - R^T) X0) added to f. corotate: rotations from u. */
    void (*stiffness)(void *m, const double *u, bool corotate, pf_block_matrix *k, double *f);
    void (*add_mass)(const void *m, double alpha, pf_block_matrix *k);
    /* The implicit step's system at state u in one pass: k := kscale K + mscale M (K as stiffness
     * gives it at u), f += stiffness's constant terms - K u (the elastic force at u), mv += M v.
     * NULL: the driver composes it from stiffness, add_mass and mass_mul. */
    void (*step_system)(void *m, const double *u, const double *v, bool corotate, double kscale,
                        double mscale, pf_block_matrix *k, double *f, double *mv);
    /* y += alpha M x */
    void (*mass_mul)(const void *m, double alpha, const double *x, double *y);
    /* The rotation of every unknown triple [n / 3][9] (row-major) of the last corotated
     * stiffness: the solver's warp (pf_solver_set_rotations). NULL: none. DG has none: its
     * penalty terms are not warped, and with each element's rotation PCG needed more iterations
     * on the clamped beam of bench_solver (4.53 per solve against 4.09); with the body's mean
     * rotation fewer there (3.81) and on a box spinning at 20 rad/s (7.03 against 9.79), but
     * more on small spinning boxes (4 x 2 x 2 hexes: 98 factorisations in 100 steps against
     * 58), for no CPU time gained on the beam. */
    void (*triple_rotations)(const void *m, double *rot);
    /* Drops what the corotated stiffness keeps from the last step as the next one's starting
     * guess (CG: the element rotations), so that the next stiffness depends on u alone: at a
     * checkpoint's restart point and after a failed step (pf_sim_forget_trend). NULL: none. */
    void (*forget_rotations)(void *m);
    /* Loads and body forces, constant in time, added to f. */
    void (*external_forces)(const void *m, double *f);
    /* The linear map S from the unknowns to the nodal displacements, with which the driver moves
     * embedded-surface vertices in contact (through WGHT, DG paper sec. 8, eq. 32). The unknowns
     * are read as consecutive (x, y, z) triples, u_t = (u[3 t], u[3 t + 1], u[3 t + 2]), each
     * weighted alike in the three components; node i moves by sum_{q in [offsets[i], offsets[i +
     * 1])}  w[q] u_{triple[q]}. DG: the stitching of eq. 30 (triples are an element's monomial
     * coefficients); a conforming method: weight 1 on the node's own free triple, no entry for a
     * fixed node. Triples are sorted ascending within each node. The arrays (offsets [n_nodes + 1],
     * triple and w [offsets[n_nodes]]) are the method's, valid until destroy. */
    void (*nodal_map)(const void *m, const int64_t **offsets, const int64_t **triple,
                      const double **w);
    /* Contact's compact rows (contact.c): a point x in element e moves by sum w u_t over up to
     * max_point_row triples that point_row returns, exact for every affine field and within one
     * element's couplings of the pattern: a contact node's motion, and an embedded vertex's in
     * the step's matrix. DG: e's basis at
     * x; CG: the point's node when x is one of e's free nodes, else the least-norm affine
     * weights over e's free nodes. node_elements: the elements whose own fields move a contact
     * at node i (*elems, the count returned; each takes an equal share of the penalty): DG every
     * element at the node (its fields disagree there), CG one (they agree). */
    int32_t (*point_row)(const void *m, int32_t e, pf_vec3 x, int64_t *triple, double *w);
    int32_t (*max_point_row)(const void *m);
    int32_t (*node_elements)(const void *m, int32_t i, const int32_t **elems);
    /* The automatic contact stiffness per point for elements of mean size h: ten times an
     * element's stiffness (pf_method_ground_stiffness with the method's materials); an element's
     * size, half the diagonal of its nodes' bounding box (the mean over the whole mesh is h: on
     * one process pf_method_mean_element_size, on ranks a sum over the parts). */
    double (*ground_stiffness)(const void *m, double h);
    double (*element_size)(const void *m, int32_t e);
    /* DG only (NULL otherwise): the penalty factor, and the mass shift that lifts the rigid modes
     * of a free body in the definiteness test of the penalty search. */
    void (*set_penalty)(void *m, double eta);
    double (*rigid_mode_shift)(const void *m);
    /* The element unknown k belongs to, for messages. */
    int32_t (*element_of_dof)(const void *m, int64_t k);
    /* Outputs. */
    void (*nodal_displacements)(const void *m, const double *u, double *out);
    void (*von_mises)(const void *m, const double *u, double *out);
    void (*momentum)(const void *m, const double *u, const double *v, double *kinetic,
                     pf_vec3 *linear, pf_vec3 *angular);
    /* u = A x + b exactly (tests); the same for a velocity. */
    void (*affine)(const void *m, const double a[9], const double b[3], double *u);
    /* Largest disagreement between elements at a node (0 for a conforming method). */
    double (*max_node_jump)(const void *m, const double *u);
    /* The method's a-posteriori error indicator for the field u (pf_sim_error_indicator; NAN when
     * it cannot be computed), the name of its measure in statistics and what it measures, in
     * words for a summary line. */
    double (*error_indicator)(const void *m, const double *u);
    const char *error_measure;
    const char *error_meaning;
    /* Refinement (sim_refine.c). For every element e, the principal stress of largest magnitude
     * (corotated, sampled at its centroid and vertices) in value[e] and its direction in the rest
     * frame in direction[e]. */
    void (*principal_stresses)(const void *m, const double *u, double *value,
                               pf_vec3 *direction);
    /* The field u_old of old (this method on the mesh before a change, pf_mesh_change) carried
     * over to this method's unknowns u_new. DG: each child its parent's polynomial (exact), each
     * merged element the L2 projection of its children (momentum exact); CG: old nodes keep
     * their values (through node_map), new ones take the parent's field at their position. */
    pf_status (*transfer)(const void *m, const void *old, const pf_mesh_change *change,
                          const double *u_old, double *u_new, pf_error *err);
    /* The set-up's statistics into st (the fields the method knows: CG its closed-form and
     * harmonic elements, MFS kernels and basis seconds; DG the integrals it copied from an old
     * mesh's set-up and computed, added to the totals). */
    void (*setup_stats)(const void *m, pf_sim_stats *st);
    void (*destroy)(void *m);
} pf_method_ops;

/* The automatic contact stiffness per point for a method whose elements have the mean size h
 * (model units): ten times (lambda + 2 mu) h of the stiffest material of table[n], an element's
 * stiffness against a push of its own size. One rule for every method. */
static inline double pf_method_ground_stiffness(const pf_material *table, int32_t n, double h)
{
    double modulus, per_density;
    pf_material_stiffest(table, n, &modulus, &per_density);
    return 10 * modulus * h;
}

/* The mean of ops->element_size over the method's n_elems elements (0 for none). */
static inline double pf_method_mean_element_size(const pf_method_ops *ops, const void *m,
                                                 int32_t n_elems)
{
    double h = 0;
    for (int32_t e = 0; e < n_elems; ++e)
        h += ops->element_size(m, e);
    return n_elems > 0 ? h / n_elems : 0;
}

/* The scene's fixed region that holds boundary face f of m (centroid c): the first that selects
 * it (pf_region_selects_face), or -1. Both methods fix a face by this rule (DG weakly on the face,
 * CG strongly at its nodes). */
static inline int32_t pf_method_fixed_region(const pf_scene *sc, const pf_mesh *m, int32_t f,
                                             pf_vec3 c)
{
    for (int32_t k = 0; k < sc->n_fixed; ++k)
        if (pf_region_selects_face(&sc->fixed[k].region, m, f, c))
            return k;
    return -1;
}

/* Whether some load region of the scene selects boundary face f of m (centroid c). */
static inline bool pf_method_face_loaded(const pf_scene *sc, const pf_mesh *m, int32_t f,
                                         pf_vec3 c)
{
    for (int32_t k = 0; k < sc->n_loads; ++k)
        if (pf_region_selects_face(&sc->loads[k].region, m, f, c))
            return true;
    return false;
}

/* One mass-matrix pair's share of the kinetic energy 1/2 v^T M v, the linear momentum and the
 * angular momentum int rho (x + u) x v, both methods writing the velocity and the deformed
 * position through their functions (M_ab = int rho phi_a phi_b, x + u = sum_a x_a phi_a): with
 * the pair's mass m_ab, position x_a and velocities v_a, v_b, adds 1/2 m_ab v_a . v_b to *ke,
 * m_ab x_a x v_b to *angular and, when linear, m_ab v_b to *p (CG: every pair, as the functions
 * sum to 1; DG: the pairs of its constant function phi_0 = 1 only). */
static inline void pf_method_momentum_pair(double mab, pf_vec3 xa, pf_vec3 va, pf_vec3 vb,
                                           bool linear, double *ke, pf_vec3 *p, pf_vec3 *angular)
{
    *ke += 0.5 * mab * pf_v3_dot(va, vb);
    if (linear)
        *p = pf_v3_add(*p, pf_v3_scale(vb, mab));
    *angular = pf_v3_add(*angular, pf_v3_scale(pf_v3_cross(xa, vb), mab));
}

/* Sorts a row of n triples ascending, their weights alongside (insertion sort: rows hold a few
 * dozen entries). */
static inline void sort_row(int64_t *triple, double *w, int64_t n)
{
    for (int64_t x = 1; x < n; ++x)
        for (int64_t y = x; y > 0 && triple[y - 1] > triple[y]; --y) {
            int64_t t = triple[y];
            triple[y] = triple[y - 1];
            triple[y - 1] = t;
            double v = w[y];
            w[y] = w[y - 1];
            w[y - 1] = v;
        }
}

/* What a method on a changed mesh may take over from the same method on the mesh before
 * (pf_sim_split, pf_sim_merge): the old method's context and mesh, each new element's parent, and
 * per new element whether it is its parent's solid (not a child) and whether its faces are the
 * parent's node for node (pf_refine_result.changed == 0), and the old nodes' new indices. */
typedef struct pf_method_reuse {
    const void *old;
    const pf_mesh *old_mesh;
    const int32_t *parent;
    const uint8_t *same_solid;
    const uint8_t *same_faces;
    const int32_t *face_src; /* [new faces] the old face each is, node for node, or -1; NULL */
    const int32_t *node_map; /* [old nodes] the new index of each, -1 removed; NULL: the same */
} pf_method_reuse;

/* Creates a method for the scene on the mesh: *ops and *ctx; fixed_faces and loaded_faces count
 * the boundary faces the scene's regions selected. reuse: NULL, or what a refined mesh takes
 * over. progress hears the set-up's phases (zero hook: none). */
typedef pf_status (*pf_method_create_fn)(const pf_scene *scene, const pf_mesh *mesh,
                                         const pf_method_reuse *reuse,
                                         const pf_progress_hook *progress,
                                         const pf_method_ops **ops, void **ctx,
                                         int32_t *fixed_faces, int32_t *loaded_faces,
                                         pf_error *err);

/* The implicit step's system (sim.c's step; the per-rank dynamics of sim_distrib_dyn.c), in two
 * halves around the forces a step adds to f (contact): begin at state (u, v) with f holding the
 * external forces: k := K and f += the stiffness's constant terms, or through the method's
 * step_system in one pass k := kscale K + mscale M, f -= K u, ku := M v; finish: rhs =
 * M v + h (f - K u) and k := kscale K + mscale M (ku is scratch [n]). */
void pf_method_step_begin(const pf_method_ops *ops, void *m, const double *u, const double *v,
                          bool corotate, double kscale, double mscale, pf_block_matrix *k,
                          double *f, double *ku, size_t n);
void pf_method_step_finish(const pf_method_ops *ops, const void *m, const double *u,
                           const double *v, double h, double kscale, double mscale,
                           pf_block_matrix *k, const double *f, double *ku, double *rhs, size_t n);

/* The operations of a method (the registry of sim.c: NULL for a method pf does not have), and
 * each method's own, for what needs them without a method context (statistics of a run on
 * several ranks: the name of the error measure). */
const pf_method_ops *pf_method_ops_of(pf_method method);
const pf_method_ops *pf_sim_dg_ops(void);
const pf_method_ops *pf_sim_cg_ops(void);

pf_status pf_sim_dg_create(const pf_scene *scene, const pf_mesh *mesh, const pf_method_reuse *reuse,
                           const pf_progress_hook *progress, const pf_method_ops **ops, void **ctx,
                           int32_t *fixed_faces, int32_t *loaded_faces, pf_error *err);

/* DG on one rank's part of a mesh (sim_distrib.c): the mesh's elements with owned[e] != 0 and
 * their face neighbours. The volume of the owned elements; the boundary faces of owned elements
 * the scene fixes; and the body length that BZ's penalty growth is measured with set to the
 * whole mesh's (the faces' growth rescaled). */
double pf_sim_dg_owned_volume(const void *m, const uint8_t *owned);
int32_t pf_sim_dg_owned_fixed_faces(const void *m, const uint8_t *owned);
void pf_sim_dg_set_body_length(void *m, double length);

pf_status pf_sim_cg_create(const pf_scene *scene, const pf_mesh *mesh, const pf_method_reuse *reuse,
                           const pf_progress_hook *progress, const pf_method_ops **ops, void **ctx,
                           int32_t *fixed_faces, int32_t *loaded_faces, pf_error *err);

/* CG's fixed nodes (sim_cg.c): every node of a boundary face whose centroid lies in a fixed
 * region is fixed (fixed[i] = 1, of n_nodes zeroed) to that region's displacement (g [3 n_nodes],
 * the first region that selects the face). Returns the count of fixed faces; *loaded_faces (or
 * NULL) receives that of loaded faces. mesh derived. */
int32_t pf_sim_cg_fixed_nodes(const pf_scene *scene, const pf_mesh *mesh, uint8_t *fixed, double *g,
                              int32_t *loaded_faces);
/* CG on one rank's part of a mesh (sim_distrib_cg.c): the fixed nodes and their displacements as
 * the whole mesh has them (fixed [n_nodes], g [3 n_nodes]: a node of a face fixed in another part
 * is fixed here too), and the faces between parts (cut [n_faces], 1: the part's boundary there is
 * not the body's, loads skip it). Renumbers the unknowns. PF_ERR_NOMEM. */
pf_status pf_sim_cg_set_part(void *m, const uint8_t *fixed, const double *g, const uint8_t *cut,
                             pf_error *err);

#endif
