/* pf/fem.h: finite element discretisations of linear elasticity on polyhedral meshes.
 *
 * DG (Kaufmann et al. 2009, sec. 4-6): per element the monomials of degree <= p (p = 1: 4,
 * p = 2: 10 functions) of the element's local coordinates xhat = (x - c_K) / h_K (pf_frame of
 * pf/integrate.h), each with a 3-vector coefficient. Unknowns are ordered element by element,
 * then basis function, then component: unknown 3 (nb e + a) + i is component i of the
 * coefficient of basis function a of element e. Every integral is exact (moments by the
 * divergence theorem); element and face terms are computed once per topology and stored as
 * scalar integrals, expanded into 3 x 3 blocks (and rotated, for corotation) when assembled.
 *
 * Material: isotropic, sigma = lambda tr(eps) I + 2 mu eps. The interior-penalty term follows
 * Hansbo and Larson (2002): eta_f (2 mu [u].[v] + lambda ([u].n)([v].n)), with eta_f of eq. 20,
 * so that the penalty scales like the consistency terms it must dominate, and eta stays
 * dimensionless (order 1-100) for any material, also as nu -> 1/2. */
#ifndef PF_FEM_H
#define PF_FEM_H

#include <stdbool.h>
#include <stdint.h>

#include <pf/base.h>
#include <pf/basis.h>
#include <pf/geom.h>
#include <pf/integrate.h>
#include <pf/mesh.h>
#include <pf/solve.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Lame parameters from Young's modulus and Poisson's ratio (nu in (-1, 1/2)). */
void pf_lame(double E, double nu, double *lambda, double *mu);

/* An isotropic material: Young's modulus (stress units), Poisson's ratio, density (mass per unit
 * volume) and its Lame parameters. */
typedef struct pf_material {
    double E, nu, density;
    double lambda, mu; /* pf_lame(E, nu) */
} pf_material;

/* The material with its Lame parameters. */
pf_material pf_material_make(double E, double nu, double density);
/* The largest p-wave modulus lambda + 2 mu, and the largest (lambda + 2 mu) / density, of the n
 * materials of table. */
void pf_material_stiffest(const pf_material *table, int32_t n, double *modulus,
                          double *modulus_per_density);

/* Materials over a mesh's elements (borrowed by the create functions, which copy them): element e
 * is made of table[elem[e]]; elem NULL: every element of table[0]. n >= 1, every material with
 * E > 0, nu in (-1, 1/2), density > 0, every elem[e] in [0, n). */
typedef struct pf_materials {
    int32_t n;
    const pf_material *table; /* [n] */
    const int32_t *elem;      /* [n_elems] or NULL */
} pf_materials;

/* ==== polynomials in local frames =============================================================
 * A polynomial of degree <= d is its coefficients in the graded monomial order of pf/integrate.h
 * (pf_moment_count(d) of them). */

/* Coefficients (in frame `to`) of the monomial `index` of frame `from`:
 * m((x - c_from) / h_from) written as a polynomial of (x - c_to) / h_to. Writes the first
 * pf_moment_count(degree of the monomial) entries of out, and no others. */
void pf_poly_monomial_in_frame(int index, const pf_frame *from, const pf_frame *to, double *out);

/* int P Q over a domain, from the domain's moments m (degree >= deg P + deg Q) in the frame both
 * polynomials are written in; deg P, deg Q <= PF_MOMENT_MAX_DEGREE / 2. */
double pf_poly_integrate_product(const double *p, int deg_p, const double *q, int deg_q,
                                 const double *m);

/* ==== DG discretisation ======================================================================= */

/* Per face f with elements (L, R) and the unit normal n pointing out of L: the scalar integrals
 * the face terms are made of, for sides s, t in {0 = L, 1 = R}:
 *   S[s][t][a][b]    = int_f phi_a^s phi_b^t
 *   G[s][t][a][b][j] = int_f phi_a^s d_j phi_b^t
 * Boundary faces have R = -1 and only the (0, 0) entries. */
typedef struct pf_dg_face {
    int32_t face;    /* mesh face index */
    int32_t elem[2]; /* L, R (-1 on the boundary) */
    pf_vec3 normal;  /* unit, out of L */
    double area;
    pf_vec3 centroid;
    double eta_geometry; /* area(f) (1 / vol(L) + 1 / vol(R)) of eq. 20 (R omitted on the
                            boundary), 1 / length */
    double bz_growth;    /* (L / h_f)^p: BZ's penalty growth under refinement (pf_dg_face_penalty),
                            h_f = sides / eta_geometry, L = pf_dg.body_length */
    double *S;           /* [4 nb nb] (s, t, a, b) row-major */
    double *G;           /* [4 nb nb 3] */
} pf_dg_face;

typedef struct pf_dg {
    int32_t degree; /* 1 or 2 */
    int32_t nb;     /* basis functions per element: 4 or 10 */
    int32_t n_elems;
    int64_t n_dofs;             /* 3 nb n_elems */
    double lambda, mu, density; /* materials[0]'s (the whole body's when there is one material) */
    int32_t n_materials;
    pf_material *materials; /* [n_materials] */
    int32_t *elem_material; /* [n_elems] index into materials: one array, so that children of a
                               refined element take their parent's entry */
    double body_length; /* (total volume)^(1/3): the fixed length BZ's penalty growth is measured
                           against (pf_dg_face_penalty) */
    pf_frame *frame;  /* [n_elems] */
    double *volume;   /* [n_elems] */
    double *centroid; /* [3 n_elems] */
    double *ke;       /* [n_elems (3 nb)^2] element stiffness, row-major, unwarped */
    double *me;       /* [n_elems nb^2] int_K rho phi_a phi_b (the mass is me (x) I3) */
    double *phi_int;  /* [n_elems nb] int_K phi_a (body forces) */
    int32_t n_faces;  /* every mesh face, interior first, then boundary */
    int32_t n_interior;
    pf_dg_face *faces;
    int32_t *face_slot; /* [mesh faces] index into faces */
    double *face_storage;
    /* stitching to nodes (eq. 30): for node i the pairs (element, basis values at x_i),
     * averaged over the elements using the node */
    int32_t n_nodes;
    int64_t *node_offsets; /* [n_nodes + 1] into node_elem */
    int32_t *node_elem;    /* element of each incidence */
    double *node_phi;      /* [nb per incidence] phi_a^elem(x_node) */
    /* pf_dg_create_reusing: element and face terms copied instead of integrated */
    int32_t reused_elems, reused_faces;
} pf_dg;

/* Sets up everything that depends on the mesh and material only: frames, moments, element
 * stiffness and mass, face integrals, stitching. The mesh must be valid and derived
 * (pf_mesh_derive). PF_ERR_INVALID for a degree other than 1 or 2 or a bad material. */
pf_status pf_dg_create(pf_dg *dg, const pf_mesh *m, int32_t degree, double E, double nu,
                       double density, pf_error *err);
/* The same with several materials (one per element); face terms between elements of different
 * materials take each side's stress for the consistency terms and the stiffer side's moduli
 * (the larger lambda and mu) for the penalty. */
pf_status pf_dg_create_materials(pf_dg *dg, const pf_mesh *m, int32_t degree,
                                 const pf_materials *materials, pf_error *err);
/* Element e's material. */
static inline const pf_material *pf_dg_material(const pf_dg *dg, int32_t e)
{
    return &dg->materials[dg->elem_material[e]];
}

void pf_dg_release(pf_dg *dg);

/* What a refined mesh (pf/refine.h) takes over from the set-up of the mesh it came from: element
 * e of the new mesh comes from element parent[e] of old_mesh (set up as old, same degree and
 * material); same_solid[e] non-zero when e is its parent's polyhedron (not a child: a neighbour
 * whose faces were only subdivided is still the same solid), so its element integrals are the
 * parent's; same_faces[e] non-zero when e's faces are its parent's node for node
 * (pf_refine_result.changed == 0), so every face between two such elements has the old face's
 * integrals. The DG paper sec. 9.4: after a split only the integrals over what the split
 * touched are computed again. */
typedef struct pf_dg_reuse {
    const pf_dg *old;
    const pf_mesh *old_mesh;
    const int32_t *parent;
    const uint8_t *same_solid;
    const uint8_t *same_faces;
    const int32_t *face_src; /* [faces of m] the old face each face is, node for node, or -1
                                (pf_refine_result.face_src); NULL: faces are matched by their
                                position in same_faces elements */
} pf_dg_reuse;

/* pf_dg_create_materials, copying what reuse allows (NULL: nothing: an element copied keeps
 * its parent's material, as every element that is its parent's solid does); dg->reused_elems and
 * dg->reused_faces count what was copied. progress (NULL or zero: none) hears the phases
 * "element integrals" (elements) and "face integrals" (faces), copies counted as done. */
pf_status pf_dg_create_reusing(pf_dg *dg, const pf_mesh *m, int32_t degree,
                               const pf_materials *materials, const pf_dg_reuse *reuse,
                               const pf_progress_hook *progress, pf_error *err);

/* The coefficient vector of the rest positions, X0 of sec. 6.2 (x = sum_a x0_a phi_a), [n_dofs]. */
void pf_dg_rest_coefficients(const pf_dg *dg, double *x0);

/* Coefficients of the displacement u(x) = A x + b (A row-major 3 x 3), exact in the basis. */
void pf_dg_affine_coefficients(const pf_dg *dg, const double a[9], const double b[3], double *u);

/* The displacement of element e at point x. */
pf_vec3 pf_dg_eval(const pf_dg *dg, const double *u, int32_t e, pf_vec3 x);

/* Displacement gradient of element e at its frame centre (the linear part), row-major 3 x 3:
 * g[3 i + j] = d u_i / d x_j. */
void pf_dg_gradient(const pf_dg *dg, const double *u, int32_t e, double g[9]);

/* The same at the point x (degree 2: the gradient varies linearly). */
void pf_dg_gradient_at(const pf_dg *dg, const double *u, int32_t e, pf_vec3 x, double g[9]);

/* Coefficients of element e of dst (u_dst, in dst's layout) equal to the field of element p of src
 * (u_src): the same polynomial re-expanded in e's frame, exact up to rounding (a copy when the
 * frames are equal). Both of the same degree. */
void pf_dg_copy_field(const pf_dg *src, const double *u_src, int32_t p, const pf_dg *dst,
                      int32_t e, double *u_dst);

/* Coefficients of element e of dst: the L2 projection (weighted by the density) onto e's
 * polynomials of the field of the src elements q[0 .. n) (src_mesh's elements, which together
 * fill e: merged children), exact integrals from their moments in e's frame. Keeps the field's
 * integral against every polynomial of e's degree: the mass and linear momentum of a velocity
 * field exactly, and a field that is one polynomial of that degree on all of them exactly.
 * PF_ERR_INVALID when an element's moments fail; PF_ERR_NUMERIC for a singular mass. */
pf_status pf_dg_project_field(const pf_dg *src, const pf_mesh *src_mesh, const double *u_src,
                              const int32_t *q, int32_t n, const pf_dg *dst, int32_t e,
                              double *u_dst, pf_error *err);

/* Stitched nodal displacements (eq. 30), out [3 n_nodes]. */
void pf_dg_stitch(const pf_dg *dg, const double *u, double *out);

/* Which faces carry which terms. face_fixed[f] (mesh face index; NULL: none) >= 0 marks a
 * boundary face with weak Dirichlet to the affine displacement g(x) = A x + b given by
 * fixed_disp[12 face_fixed[f] ..]: A row-major (9), then b (3). */
typedef struct pf_dg_terms {
    bool ip;             /* interior penalty (consistency + symmetry + penalty) or BZ (penalty) */
    double eta;          /* global penalty factor, > 0 */
    const int32_t *face_fixed;  /* [n mesh faces] index into fixed_disp, or -1 */
    const double *fixed_disp;   /* [12 k] prescribed affine displacements */
    const int64_t *face_slot;   /* [n_interior] the block slot of each interior face's element
                                   pair in the matrix assembled into (pf_dg_face_slots), or NULL:
                                   looked up each time */
    const double *penalty_values; /* the penalty terms as the matrix's values
                                     (pf_dg_penalty_values, for this ip and eta), or NULL:
                                     assembled each time */
} pf_dg_terms;

/* The weight of the penalty term on face f, the factor of int_f (2 mu [u].[v] + lambda
 * ([u].n)([v].n)) (1 / length):
 *   IP: eta eta_f, eta_f of eq. 20 (Hansbo and Larson 2002), which scales like 1 / h;
 *   BZ: eta eta_f (L / h_f)^p, p the degree: a penalty that grows like h^-(p+1) under refinement.
 * BZ is not consistent (sec. 3.3): with the 1 / h weight of a consistent method it converges to
 * a body whose faces are glued by a finite spring, and its error tends to a constant of order
 * 1 / eta. Babuska and Zlamal (1973) let the penalty grow faster than 1 / h, so that the
 * inconsistency vanishes under refinement; see libcore/fem/dg_setup.c for the exponent. */
double pf_dg_face_penalty(const pf_dg_terms *terms, const pf_dg_face *f);

/* The block pattern: one block per element, coupled across interior faces. */
pf_status pf_dg_pattern(const pf_dg *dg, pf_block_matrix *k, pf_error *err);

/* The scatter map of k (from pf_dg_pattern): the slot of each interior face's element pair,
 * slot [n_interior], so that a step's assembly looks nothing up. */
void pf_dg_face_slots(const pf_dg *dg, const pf_block_matrix *k, int64_t *slot);

/* The penalty terms of every interior and fixed face (those that corotation does not warp) as
 * the values of k, which they overwrite: values [nnz of k] = k's values afterwards. A corotated
 * step then starts from a copy of them (pf_dg_terms.penalty_values): the array costs as much as
 * the matrix (7 MB on the 1,911-hex beam at degree 1, 44 MB at degree 2), a few percent of the
 * factor's memory. terms->penalty_values is not read. */
void pf_dg_penalty_values(const pf_dg *dg, const pf_dg_terms *terms, pf_block_matrix *k,
                          double *values);

/* Assembles the stiffness into k (zeroed first; k from pf_dg_pattern) and adds its constant
 * right-hand side terms to f [n_dofs] (prescribed displacements; with rotations, the warping
 * terms R K (I - R^T) X0 of sec. 6.3). rot [9 n_elems] row-major element rotations, or NULL for
 * linear elasticity. x0 = pf_dg_rest_coefficients (needed with rotations only). */
void pf_dg_assemble_stiffness(const pf_dg *dg, const pf_dg_terms *terms, const double *rot,
                              const double *x0, pf_block_matrix *k, double *f);

/* Adds alpha times the mass matrix to k. */
void pf_dg_add_mass(const pf_dg *dg, double alpha, pf_block_matrix *k);

/* y += alpha M x. */
void pf_dg_mass_mul(const pf_dg *dg, double alpha, const double *x, double *y);

/* Adds the body force (force per unit volume b, constant) and the traction t on mesh face
 * `face` (force per area) to f. */
void pf_dg_add_body_force(const pf_dg *dg, pf_vec3 b, double *f);
/* f += int_K phi (rho_K g + b) over every element K: gravity g (acceleration) on each element's
 * own density, plus the force per unit volume b. */
void pf_dg_add_gravity(const pf_dg *dg, pf_vec3 g, pf_vec3 b, double *f);
void pf_dg_add_traction(const pf_dg *dg, int32_t face, pf_vec3 t, double *f);

/* ==== polynomial data (manufactured solutions) ================================================
 * Exact right-hand sides and errors for data that are polynomials of the global position (body
 * forces, prescribed displacements, exact solutions of manufactured problems): every integral is
 * a combination of element or face moments, so the results are exact up to rounding, like the
 * element terms themselves. */

/* Highest degree per component, and the coefficients that degree takes: products with a degree-2
 * basis function (6) and squares of the error against a degree <= 2 field (8) stay within
 * PF_MOMENT_MAX_DEGREE. */
#define PF_POLY3_MAX_DEGREE 4
#define PF_POLY3_MAX_COUNT 35

/* A vector polynomial p(x) = sum_k c[i][k] m_k((x - frame.center) / frame.scale) per component i,
 * m_k the monomials of pf/integrate.h in graded order; entries k >= pf_moment_count(degree) are
 * ignored. degree in [0, PF_POLY3_MAX_DEGREE]. */
typedef struct pf_poly3 {
    pf_frame frame;
    int32_t degree;
    double c[3][PF_POLY3_MAX_COUNT];
} pf_poly3;

/* Value of p at the point x (model units). */
pf_vec3 pf_poly3_eval(const pf_poly3 *p, pf_vec3 x);

/* rhs [n_dofs] += int_K f . phi_a e_i for every element K, basis function a and component i:
 * the load of the body force f (force per unit volume). m is the mesh dg was created from.
 * PF_ERR_INVALID for a bad degree or frame (rhs untouched), or when an element's moments fail. */
pf_status pf_dg_add_polynomial_body_force(const pf_dg *dg, const pf_mesh *m, const pf_poly3 *f,
                                          double *rhs, pf_error *err);

/* rhs [n_dofs] += the weak Dirichlet load of the prescribed displacement g on the boundary face
 * mesh_face of m, the same terms pf_dg_assemble_stiffness adds for an affine g on a face marked
 * in face_fixed: with n the outward normal and v = phi_a e_i of the face's element,
 *   - int_f g . sigma(v) n                                   (terms->ip only)
 *   + eta eta_f int_f (2 mu g . v + lambda (g . n)(v . n))    (eta = terms->eta, eta_f of eq. 20).
 * The stiffness must carry the face's matrix terms: mark the face in face_fixed (with a zero
 * displacement there, this adds the whole load). PF_ERR_INVALID for an interior or out-of-range
 * face, a bad degree or frame. */
pf_status pf_dg_add_polynomial_dirichlet(const pf_dg *dg, const pf_mesh *m,
                                         const pf_dg_terms *terms, int32_t mesh_face,
                                         const pf_poly3 *g, double *rhs, pf_error *err);

/* *error = sqrt(sum_K int_K |u_h - u|^2), the L2 norm of the difference between the DG field of
 * the coefficients u [n_dofs] and the exact field `exact` (model units of displacement times
 * length^(3/2)). *norm (may be NULL) gets the L2 norm of exact alone, for relative errors.
 * Errors as pf_dg_add_polynomial_body_force. */
pf_status pf_dg_l2_error(const pf_dg *dg, const pf_mesh *m, const double *u,
                         const pf_poly3 *exact, double *error, double *norm, pf_error *err);

/* ==== CG discretisation (harmonic paper sec. 6) ===============================================
 * Conforming nodal FEM on the shape functions of pf/basis.h: the displacement inside element e
 * is u(x) = sum_a N_a(x) u_a over the element's nodes a (eq. 5), 3 unknowns per mesh node. Every
 * element matrix is computed once from the rest state and stored in the element's node order
 * (pf_basis_elem_nodes), rows and columns 3 a + i (node a, component i):
 *   K_e = int_e B^T C B (eq. 15), M_e = int_e rho N_a N_b (times I3).
 * Integration: tets in closed form (constant gradients; M_ab = rho V (1 + delta_ab) / 20);
 * parallelepiped hexes by the 2 x 2 x 2 Gauss product in their reference coordinates, exact for
 * both matrices (every integrand has degree <= 2 in each reference coordinate); harmonic elements
 * by pf_polyhedron_quadrature of degree quadrature_degree (Gauss rules on the cones of the
 * element's convex pieces).
 *
 * Consistency correction (not in the paper): MFS functions are C0 across faces only to their
 * boundary error, which makes the paper's K_e fail the patch test by about that error (1.4e-3
 * on the mixed block of tests/test_cg.c). By
 * default each element's gradients are shifted by a constant per node so that they integrate to
 * int_de t_a n dA, with traces t_a shared exactly by the two elements of each face (the
 * closed-form side's functions, else the lower-numbered element's, projected onto exact
 * partition of unity and linear reproduction); the patch test then holds to round-off, linear
 * reproduction and rigid modes are kept, and closed-form meshes are unchanged (cg_setup.c has
 * the derivation). Fixed nodes are removed from the unknowns (strong Dirichlet); the
 * unknowns are ordered free node by free node, component innermost. */

/* Gauss rule degree for harmonic elements, chosen by the convergence check in tests/test_cg.c:
 * the smallest degree at which K_e of every harmonic cell tested lies within that cell's own
 * boundary error (pf/basis.h) of a degree-12 rule. MFS integrands vary steeply near the
 * boundary (kernels 0.1 sizes outside it), so rules converge slowly: degree 2 differs from
 * degree 12 by <= 1.5e-2 on block-like cells and <= 0.11 on sliced-sphere cells (their boundary
 * errors: 1-3 % and 7-18 %), degree 4 by 1e-2 and 3.3e-2 at 2.4 times the points, degree 1 misses
 * on every cell. 27 points per tetrahedron of the cone decomposition. */
#define PF_CG_DEFAULT_QUADRATURE 2

typedef struct pf_cg_params {
    pf_basis_params basis;     /* pf_cg_params_default: pf_basis_params_uniform (this
                                  quadrature is too coarse for the graded kernels of sliced
                                  cells, docs/basis.md); zero fields: basis defaults */
    int32_t quadrature_degree; /* harmonic elements, 1..29; 0 = PF_CG_DEFAULT_QUADRATURE */
    bool no_consistency_correction; /* true: the paper's K_e as is (above; studies) */
    pf_progress_hook progress; /* the phases "basis functions" (unless basis.progress is set)
                                  and "element matrices" (elements, copied ones counted);
                                  borrowed during the set-up only; zero: none */
} pf_cg_params;

pf_cg_params pf_cg_params_default(void);

typedef struct pf_cg {
    int32_t n_nodes, n_elems;
    double lambda, mu, density; /* materials[0]'s (the whole body's when there is one material) */
    int32_t n_materials;
    pf_material *materials; /* [n_materials] */
    int32_t *elem_material; /* [n_elems] index into materials (children of a refined element take
                               their parent's entry) */
    pf_basis basis;         /* shape functions; element e's nodes: pf_basis_elem_nodes(&basis, e) */
    int32_t max_nodes;      /* largest node count of an element */
    double *ke;             /* element stiffness matrices, unwarped: see pf_cg_elem_stiffness */
    int64_t *ke_offsets; /* [n_elems + 1]: element e's K_e is (3k)^2 doubles from ke_offsets[e] */
    int64_t *me_offsets; /* [n_elems + 1]: element e's M_e is k^2 doubles from me_offsets[e] */
    double *me;          /* int_e rho N_a N_b, row-major k x k */
    double *n_int;       /* [basis.node_offsets[n_elems]] int_e N_a (volume units) */
    double *lumped;      /* [n_nodes] lumped (row-sum) nodal mass sum_e rho int_e N_a */
    double *grad_center; /* [3 basis.node_offsets[n_elems]] grad N_a at the element's centroid */
    double *volume;      /* [n_elems] sum of the rule's weights (exact volume for closed forms) */
    pf_vec3 *centroid;   /* [n_elems] */
    double *size;        /* [n_elems] half the diagonal of the element nodes' bounding box */
    double *elem_ms;     /* [n_elems] wall-clock integration time of K_e and M_e, milliseconds */
    int32_t quadrature_degree;
    bool consistency;            /* the consistency correction is applied */
    int64_t n_quadrature_points; /* over all harmonic elements */
    int32_t n_closed_form;       /* elements with closed-form functions (MFS skipped) */
    int32_t n_reused;            /* elements whose matrices were copied (pf_cg_create_reusing) */
    double basis_seconds;        /* pf_basis_create */
    double integrate_seconds;    /* element matrices */
} pf_cg;

/* Shape functions and element matrices of every element of the valid, derived mesh m for the
 * material (E > 0, nu in (-1, 1/2), density > 0); params may be NULL. cg is overwritten (release
 * with pf_cg_release; also released on failure). Statuses: PF_ERR_INVALID for a bad material or
 * quadrature degree, an underived mesh, and what pf_basis_create and pf_polyhedron_quadrature
 * report (the message names the element); PF_ERR_NOMEM. */
pf_status pf_cg_create(pf_cg *cg, const pf_mesh *m, double E, double nu, double density,
                       const pf_cg_params *params, pf_error *err);
/* The same with several materials (pf_materials: one per element). */
pf_status pf_cg_create_materials(pf_cg *cg, const pf_mesh *m, const pf_materials *materials,
                                 const pf_cg_params *params, pf_error *err);
/* What a changed mesh takes over from the set-up of the mesh before (the harmonic paper: only
 * the cut elements are computed again). Element e may take old element source[e]'s functions
 * (pf_basis_reuse: the same element node for node) and then its K_e, M_e, int N_a, volume,
 * centroid and centroid gradients, when its material is the same and, with the consistency
 * correction, every face's traces come from the same functions as before (the face's trace
 * source, cg_setup.c, is the element itself or a neighbour whose functions were taken from the
 * old source). What is copied is bit for bit what pf_cg_create_materials computes. */
typedef struct pf_cg_reuse {
    const pf_cg *old;
    const pf_mesh *old_mesh; /* the mesh old was set up on */
    const int32_t *source;   /* [m->n_elems] candidate old element of each element, or -1 */
    const int32_t *node_map; /* [old_mesh->n_nodes] new index of each old node, -1 for one
                                removed; NULL: the same indices */
} pf_cg_reuse;

/* pf_cg_create_materials taking over what reuse allows (NULL: nothing); cg->basis.n_taken
 * counts the elements whose functions were copied, cg->n_reused those whose matrices were. */
pf_status pf_cg_create_reusing(pf_cg *cg, const pf_mesh *m, const pf_materials *materials,
                               const pf_cg_params *params, const pf_cg_reuse *reuse,
                               pf_error *err);
/* Element e's material. */
static inline const pf_material *pf_cg_material(const pf_cg *cg, int32_t e)
{
    return &cg->materials[cg->elem_material[e]];
}
void pf_cg_release(pf_cg *cg);

/* Element e's stored (unwarped) stiffness, (3k)^2 row-major, and mass, k^2 row-major. */
static inline const double *pf_cg_elem_stiffness(const pf_cg *cg, int32_t e)
{
    return cg->ke + cg->ke_offsets[e];
}
static inline const double *pf_cg_elem_mass(const pf_cg *cg, int32_t e)
{
    return cg->me + cg->me_offsets[e];
}

/* Computes K_e and M_e of one element with an explicit rule degree for harmonic elements (the
 * convergence study; pf_cg_create stores the default's): ke [(3k)^2], me [k^2] (may be NULL).
 * m is the mesh cg was created from. Statuses of pf_polyhedron_quadrature. */
pf_status pf_cg_integrate_elem(const pf_cg *cg, const pf_mesh *m, int32_t e, int degree,
                               double *ke, double *me, pf_error *err);

/* Free nodes and where their blocks go. */
typedef struct pf_cg_map {
    int32_t n_free;      /* free nodes: the blocks of the matrix (3 unknowns each) */
    int32_t *node_block; /* [n_nodes] block of each node, -1 when fixed */
    int32_t *block_node; /* [n_free] */
    int64_t *slot;       /* [me_offsets[n_elems]] block slot of element node pair (a, b) (row-major
                            k x k per element), -1 when either node is fixed */
    int32_t *node_elem;  /* [n_nodes] one element using the node (-1 when none), for messages */
} pf_cg_map;

/* The block pattern over the free nodes (fixed[i] != 0: node i fixed; NULL: none) coupling every
 * two free nodes of an element, and the scatter slots. k and map zeroed or released first.
 * PF_ERR_NOMEM, and what pf_block_matrix_create reports. */
pf_status pf_cg_pattern(const pf_cg *cg, const uint8_t *fixed, pf_block_matrix *k, pf_cg_map *map,
                        pf_error *err);
void pf_cg_map_release(pf_cg_map *map);

/* Doubles of scratch the assembly needs: 6 max_nodes. */
size_t pf_cg_scratch_size(const pf_cg *cg);

/* Element rotations by shape matching (sec. 6, stiffness warping): R_e the rotation of the polar
 * decomposition of A = sum_a (x_a - x_c)(X_a - X_c)^T over the element's nodes, X the rest
 * positions x0 [3 n_nodes], x = X + u (u [3 n_nodes] nodal displacements), c the node averages.
 * rot [9 n_elems] row-major. warm: rot holds rotations near the new ones (the last time step's),
 * the starting guesses of pf_mat3_polar_rotation_near; else the SVD's polar. Both agree to a few
 * ulps. */
void pf_cg_rotations(const pf_cg *cg, const double *x0, const double *u, bool warm, double *rot);

/* Assembles the stiffness over the free nodes into k (zeroed first; from pf_cg_pattern) and adds
 * its constant terms to f [3 n_free]: with rotations (rot [9 n_elems], NULL for linear
 * elasticity) each element's force is -R K_e (R^T x - X) (no ghost forces: zero for any rigid
 * motion), i.e. stiffness R K_e R^T and constant force R K_e (I - R^T) X, X = x0 [3 n_nodes]
 * (needed with rotations only); the prescribed displacements g [3 n_nodes] of fixed nodes (read
 * at fixed nodes only; NULL: zero) add -K_fc g. scratch [pf_cg_scratch_size]. */
void pf_cg_assemble_stiffness(const pf_cg *cg, const pf_cg_map *map, const double *rot,
                              const double *x0, const double *g, double *scratch,
                              pf_block_matrix *k, double *f);

/* The implicit step's system in one element pass: k := kscale K + mscale M (zeroed first; K the
 * stiffness of pf_cg_assemble_stiffness, M as pf_cg_add_mass), f [3 n_free] += the elastic force
 * at u, -R K_e (R^T x - X) per element (R = I without rotations: -K u), and mv [3 n_free] += M v.
 * scratch [pf_cg_scratch_size]. */
typedef struct pf_cg_step {
    const double *rot; /* [9 n_elems] element rotations, row-major; NULL: linear elasticity */
    const double *x0;  /* [3 n_nodes] rest positions X */
    const double *u;   /* [3 n_nodes] nodal displacements, the fixed nodes' prescribed ones */
    const double *v;   /* [3 n_free] velocities of the free unknowns */
    bool lumped;       /* lumped mass (the diagonal of row sums), else consistent */
    double kscale, mscale;
} pf_cg_step;
void pf_cg_assemble_step(const pf_cg *cg, const pf_cg_map *map, const pf_cg_step *in,
                         double *scratch, pf_block_matrix *k, double *f, double *mv);

/* Adds alpha M to k (consistent, or lumped: the diagonal of row sums); y += alpha M x for free
 * unknowns x, y [3 n_free]. */
void pf_cg_add_mass(const pf_cg *cg, const pf_cg_map *map, bool lumped, double alpha,
                    pf_block_matrix *k);
void pf_cg_mass_mul(const pf_cg *cg, const pf_cg_map *map, bool lumped, double alpha,
                    const double *x, double *y);

/* Nodal loads, f [3 n_nodes] (every node; the caller keeps the free rows): body force b (force
 * per volume) f_a += b int N_a; traction t (force per area) on the boundary face
 * bd->face[index] of m: f_a += t int_face N_a dA over the face's triangles (bd from
 * pf_boundary_extract of m) with a degree-4 Gauss rule per triangle (exact for closed forms). */
void pf_cg_add_body_force(const pf_cg *cg, pf_vec3 b, double *f);
/* f += int N_a (rho_e g + b) over every element e: gravity g (acceleration) on each element's own
 * density, plus the force per unit volume b. */
void pf_cg_add_gravity(const pf_cg *cg, pf_vec3 g, pf_vec3 b, double *f);
void pf_cg_add_traction(const pf_cg *cg, const pf_mesh *m, const pf_boundary *bd, int32_t index,
                        pf_vec3 t, double *f);

/* Von Mises stress of the corotated linear strain sym(R^T F) - I, F = I + grad u at each
 * element's centroid (corrected gradients; R the polar rotation of F), u [3 n_nodes];
 * out [n_elems]. */
void pf_cg_von_mises(const pf_cg *cg, const double *u, double *out);

#ifdef __cplusplus
}
#endif
#endif
