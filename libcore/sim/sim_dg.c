/* The DG method for the simulator (Kaufmann et al. 2009): unknowns are the coefficients of every
 * element's monomials (pf/fem.h). Fixed regions are weak Dirichlet conditions on their faces
 * (sec. 4.2); rotations come from the linear part of each element's displacement (sec. 6.1).
 *
 * Contact is the driver's (contact.c): this method gives it an element's basis at a point. */
#include "method.h"

#include <math.h>
#include <string.h>

#include <pf/fem.h>

typedef struct dg_method {
    const pf_scene *scene;
    const pf_mesh *mesh;
    pf_dg dg;
    pf_dg_terms terms;
    int32_t *face_fixed;  /* [n mesh faces] fixed region index or -1 */
    double *fixed_affine; /* [12 n_fixed] */
    double *x0;           /* rest coefficients */
    double *rot;          /* [9 n_elems] */
    int64_t *face_slot; /* [n_interior] scatter map of the matrix (filled at the first assembly) */
    double *penalty_values; /* [nnz] the penalty terms for terms.eta (pf_dg_penalty_values), made
                               at the first assembly after eta is set; NULL when unaffordable */
    bool penalty_current;
    /* the stitching as a matrix (method.h, nodal_map) */
    int64_t *map_offsets; /* [n_nodes + 1] */
    int64_t *map_triple;  /* [map_offsets[n_nodes]] */
    double *map_w;        /* [map_offsets[n_nodes]] */
} dg_method;

static int64_t n_dofs(const void *m)
{
    return ((const dg_method *)m)->dg.n_dofs;
}

static pf_status pattern(const void *m, pf_block_matrix *k, pf_error *err)
{
    return pf_dg_pattern(&((const dg_method *)m)->dg, k, err);
}

/* Element rotations from the linear part of each element's displacement (sec. 6.1). */
static void update_rotations(dg_method *d, const double *u)
{
    for (int32_t e = 0; e < d->dg.n_elems; ++e) {
        double g[9];
        pf_dg_gradient(&d->dg, u, e, g);
        pf_mat3 f;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                f.m[i][j] = (i == j) + g[3 * i + j];
        pf_mat3 r = pf_mat3_polar_rotation(f);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                d->rot[9 * e + 3 * i + j] = r.m[i][j];
    }
}

static void stiffness(void *m, const double *u, bool corotate, pf_block_matrix *k, double *f)
{
    dg_method *d = m;
    if (!d->terms.face_slot && d->face_slot) { /* the scatter map, once: the pattern is fixed */
        pf_dg_face_slots(&d->dg, k, d->face_slot);
        d->terms.face_slot = d->face_slot;
    }
    if (!d->penalty_current) { /* without the array, every assembly adds the terms itself */
        if (!d->penalty_values)
            d->penalty_values = pf_alloc_array((size_t)k->col_ptr[k->n] + 1, sizeof(double));
        d->terms.penalty_values = NULL;
        if (d->penalty_values) {
            pf_dg_penalty_values(&d->dg, &d->terms, k, d->penalty_values);
            d->terms.penalty_values = d->penalty_values;
        }
        d->penalty_current = true;
    }
    if (corotate)
        update_rotations(d, u);
    pf_dg_assemble_stiffness(&d->dg, &d->terms, corotate ? d->rot : NULL, d->x0, k, f);
}

static void add_mass(const void *m, double alpha, pf_block_matrix *k)
{
    pf_dg_add_mass(&((const dg_method *)m)->dg, alpha, k);
}

static void mass_mul(const void *m, double alpha, const double *x, double *y)
{
    pf_dg_mass_mul(&((const dg_method *)m)->dg, alpha, x, y);
}

/* Tractions on the boundary faces the loads select, and gravity and body forces. */
static void external_forces(const void *m, double *f)
{
    const dg_method *d = m;
    const pf_scene *sc = d->scene;
    for (int32_t q = d->dg.n_interior; q < d->dg.n_faces; ++q) {
        const pf_dg_face *face = &d->dg.faces[q];
        for (int32_t k = 0; k < sc->n_loads; ++k)
            if (pf_region_selects_face(&sc->loads[k].region, d->mesh, face->face, face->centroid))
                pf_dg_add_traction(&d->dg, face->face, sc->loads[k].traction, f);
    }
    pf_vec3 g = sc->gravity, b = sc->body_force;
    if (g.x != 0 || g.y != 0 || g.z != 0 || b.x != 0 || b.y != 0 || b.z != 0)
        pf_dg_add_gravity(&d->dg, g, b, f);
}

static double ground_stiffness(const void *m, double h)
{
    const dg_method *d = m;
    return pf_method_ground_stiffness(d->dg.materials, d->dg.n_materials, h);
}

/* The half-diagonal of the element's frame (its nodes' bounding box). */
static double element_size(const void *m, int32_t e)
{
    return ((const dg_method *)m)->dg.frame[e].scale;
}

static void set_penalty(void *m, double eta)
{
    dg_method *d = m;
    d->terms.eta = eta;
    d->terms.penalty_values = NULL;
    d->penalty_current = false;
}

/* 1e-6 of the stiffest element's K/M ratio (lambda + 2 mu) / (rho h^2): lifts the six rigid
 * modes of a free body without hiding a real indefiniteness. */
static double rigid_mode_shift(const void *m)
{
    const dg_method *d = m;
    double h = INFINITY;
    for (int32_t e = 0; e < d->dg.n_elems; ++e)
        h = fmin(h, d->dg.frame[e].scale);
    double modulus, per_density;
    pf_material_stiffest(d->dg.materials, d->dg.n_materials, &modulus, &per_density);
    return 1e-6 * per_density / (h * h);
}

/* Stitching (eq. 30) as a matrix: node i averages u|_K(x_i) = sum_a phi_a(x_i) u_{K,a} over the
 * |N_i| elements K at it, so triple (K, a) gets weight phi_a(x_i) / |N_i|. */
static pf_status build_nodal_map(dg_method *d, pf_error *err)
{
    const pf_dg *dg = &d->dg;
    int nb = dg->nb;
    int64_t nnz = dg->node_offsets[dg->n_nodes] * nb;
    d->map_offsets = pf_alloc_array((size_t)dg->n_nodes + 1, sizeof *d->map_offsets);
    d->map_triple = pf_alloc_array((size_t)nnz + 1, sizeof *d->map_triple);
    d->map_w = pf_alloc_array((size_t)nnz + 1, sizeof *d->map_w);
    PF_CHECK(d->map_offsets && d->map_triple && d->map_w, err, PF_ERR_NOMEM,
             "cannot allocate the nodal map of %d nodes", (int)dg->n_nodes);
    int64_t q = 0;
    d->map_offsets[0] = 0;
    for (int32_t i = 0; i < dg->n_nodes; ++i) {
        int64_t begin = dg->node_offsets[i], end = dg->node_offsets[i + 1];
        double share = end > begin ? 1.0 / (double)(end - begin) : 0;
        int64_t first = q;
        for (int64_t k = begin; k < end; ++k)
            for (int a = 0; a < nb; ++a) {
                d->map_triple[q] = (int64_t)dg->node_elem[k] * nb + a;
                d->map_w[q] = dg->node_phi[(size_t)k * nb + a] * share;
                ++q;
            }
        sort_row(d->map_triple + first, d->map_w + first, q - first);
        d->map_offsets[i + 1] = q;
    }
    return PF_OK;
}

static void nodal_map(const void *m, const int64_t **offsets, const int64_t **triple,
                      const double **w)
{
    const dg_method *d = m;
    *offsets = d->map_offsets;
    *triple = d->map_triple;
    *w = d->map_w;
}

static int32_t point_row(const void *m, int32_t e, pf_vec3 x, int64_t *triple, double *w)
{
    const pf_dg *dg = &((const dg_method *)m)->dg;
    const pf_frame *fr = &dg->frame[e];
    pf_moment_monomials(pf_v3_scale(pf_v3_sub(x, fr->center), 1 / fr->scale), dg->degree, w);
    for (int a = 0; a < dg->nb; ++a)
        triple[a] = (int64_t)e * dg->nb + a;
    return dg->nb;
}

static int32_t max_point_row(const void *m)
{
    return ((const dg_method *)m)->dg.nb;
}

static int32_t node_elements(const void *m, int32_t i, const int32_t **elems)
{
    const pf_dg *dg = &((const dg_method *)m)->dg;
    *elems = dg->node_elem + dg->node_offsets[i];
    return (int32_t)(dg->node_offsets[i + 1] - dg->node_offsets[i]);
}

static int32_t element_of_dof(const void *m, int64_t k)
{
    return (int32_t)(k / (3 * ((const dg_method *)m)->dg.nb));
}

static void nodal_displacements(const void *m, const double *u, double *out)
{
    pf_dg_stitch(&((const dg_method *)m)->dg, u, out);
}

/* Von Mises stress of the corotated linear strain (sym(R^T F) - I) at each element's centre. */
static void von_mises(const void *m, const double *u, double *out)
{
    const pf_dg *dg = &((const dg_method *)m)->dg;
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        double lambda = pf_dg_material(dg, e)->lambda, mu = pf_dg_material(dg, e)->mu;
        double g[9];
        pf_dg_gradient(dg, u, e, g);
        pf_mat3 f;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                f.m[i][j] = (i == j) + g[3 * i + j];
        double sigma[6];
        pf_corotated_stress(f, lambda, mu, sigma);
        out[e] = pf_von_mises(sigma);
    }
}

/* Kinetic energy 1/2 v^T M v; momentum int rho v = sum_b v_b int rho phi_b (phi_0 = 1); angular
 * momentum int rho (x + u) x v with x + u = sum_a (x0_a + u_a) phi_a. */
static void momentum(const void *m, const double *u, const double *v, double *kinetic,
                     pf_vec3 *linear, pf_vec3 *angular)
{
    const dg_method *d = m;
    const pf_dg *dg = &d->dg;
    int nb = dg->nb, n = 3 * nb;
    double ke = 0;
    pf_vec3 p = {0, 0, 0}, l = {0, 0, 0};
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const double *me = dg->me + (size_t)e * nb * nb;
        const double *ve = v + (size_t)e * n, *ue = u + (size_t)e * n;
        const double *xe = d->x0 + (size_t)e * n;
        for (int a = 0; a < nb; ++a)
            for (int b = 0; b < nb; ++b) {
                double mab = me[a * nb + b];
                pf_vec3 va = {ve[3 * a], ve[3 * a + 1], ve[3 * a + 2]};
                pf_vec3 vb = {ve[3 * b], ve[3 * b + 1], ve[3 * b + 2]};
                pf_vec3 xa = {xe[3 * a] + ue[3 * a], xe[3 * a + 1] + ue[3 * a + 1],
                              xe[3 * a + 2] + ue[3 * a + 2]};
                pf_method_momentum_pair(mab, xa, va, vb, a == 0, &ke, &p, &l);
            }
    }
    *kinetic = ke;
    *linear = p;
    *angular = l;
}

static void affine(const void *m, const double a[9], const double b[3], double *u)
{
    pf_dg_affine_coefficients(&((const dg_method *)m)->dg, a, b, u);
}

/* The largest disagreement between elements at a node, and in *umax (when not NULL) the largest
 * stitched nodal displacement; NAN when the stitched field cannot be allocated. */
static double node_jump(const pf_dg *dg, const double *u, double *umax)
{
    int nb = dg->nb, n = 3 * nb;
    double *stitched = pf_alloc_array(3 * (size_t)dg->n_nodes, sizeof *stitched);
    if (!stitched)
        return NAN;
    pf_dg_stitch(dg, u, stitched);
    double largest = 0, size = 0;
    for (int32_t i = 0; i < dg->n_nodes; ++i) {
        const double *si = stitched + 3 * (size_t)i;
        size = fmax(size, pf_v3_norm(pf_v3(si[0], si[1], si[2])));
        for (int64_t q = dg->node_offsets[i]; q < dg->node_offsets[i + 1]; ++q) {
            const double *ue = u + (size_t)dg->node_elem[q] * n;
            const double *phi = dg->node_phi + (size_t)q * nb;
            double d2 = 0;
            for (int c = 0; c < 3; ++c) {
                double value = 0;
                for (int a = 0; a < nb; ++a)
                    value += phi[a] * ue[3 * a + c];
                double diff = value - si[c];
                d2 += diff * diff;
            }
            largest = fmax(largest, sqrt(d2));
        }
    }
    pf_free(stitched);
    if (umax)
        *umax = size;
    return largest;
}

static double max_node_jump(const void *m, const double *u)
{
    return node_jump(&((const dg_method *)m)->dg, u, NULL);
}

/* The largest jump between elements at a node relative to the largest stitched nodal
 * displacement (0 when nothing moves). */
static double error_indicator(const void *m, const double *u)
{
    double umax = 0;
    double jump = node_jump(&((const dg_method *)m)->dg, u, &umax);
    if (isnan(jump))
        return NAN;
    return umax > 0 ? jump / umax : 0;
}

/* The corotated principal stress of element e at x, kept in *best (and its direction) when it
 * is larger in magnitude. */
static void stress_sample(const pf_dg *dg, const double *u, int32_t e, pf_vec3 x, double *best,
                          pf_vec3 *direction)
{
    double g[9], sigma[6];
    pf_dg_gradient_at(dg, u, e, x, g);
    pf_mat3 f;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            f.m[i][j] = (i == j) + g[3 * i + j];
    pf_corotated_stress(f, pf_dg_material(dg, e)->lambda, pf_dg_material(dg, e)->mu, sigma);
    pf_vec3 dir;
    double value = pf_principal_stress(sigma, &dir);
    if (fabs(value) > fabs(*best))
        *best = value, *direction = dir;
}

/* At each element's centroid and, for degree 2 (degree 1 has a constant gradient), every
 * vertex. */
static void principal_stresses(const void *m, const double *u, double *value, pf_vec3 *direction)
{
    const dg_method *d = m;
    const pf_mesh *mesh = d->mesh;
    for (int32_t e = 0; e < d->dg.n_elems; ++e) {
        value[e] = 0;
        direction[e] = pf_v3(1, 0, 0);
        pf_vec3 centroid = pf_v3_load(d->dg.centroid + 3 * (size_t)e);
        stress_sample(&d->dg, u, e, centroid, &value[e], &direction[e]);
        for (int64_t q = mesh->elem_offsets[e]; d->dg.degree >= 2 && q < mesh->elem_offsets[e + 1];
             ++q) {
            int32_t f = PF_FACE_INDEX(mesh->elem_faces[q]);
            for (int64_t k = mesh->face_offsets[f]; k < mesh->face_offsets[f + 1]; ++k)
                stress_sample(&d->dg, u, e, pf_v3_load(mesh->x + 3 * (size_t)mesh->face_nodes[k]),
                              &value[e], &direction[e]);
        }
    }
}

/* Every child takes its parent's polynomial and unchanged elements their own (exact); a merged
 * element the L2 projection of the elements merged into it. */
static pf_status transfer(const void *m, const void *old, const pf_mesh_change *change,
                          const double *u_old, double *u_new, pf_error *err)
{
    const dg_method *d = m, *o = old;
    int32_t n_old = o->dg.n_elems;
    int32_t *group = NULL, *first = NULL; /* old elements by the new element they merged into */
    if (change->merged_into) {
        group = pf_alloc_array((size_t)n_old + 1, sizeof *group);
        first = pf_calloc((size_t)d->dg.n_elems + 2, sizeof *first);
        PF_CHECK(group && first, err, PF_ERR_NOMEM, "cannot allocate %d merge slots", (int)n_old);
        for (int32_t q = 0; q < n_old; ++q)
            if (change->merged_into[q] >= 0)
                first[change->merged_into[q] + 2]++;
        for (int32_t e = 0; e < d->dg.n_elems; ++e)
            first[e + 2] += first[e + 1];
        for (int32_t q = 0; q < n_old; ++q)
            if (change->merged_into[q] >= 0)
                group[first[change->merged_into[q] + 1]++] = q;
    }
    pf_status st = PF_OK;
    for (int32_t e = 0; e < d->dg.n_elems && st >= 0; ++e) {
        int32_t begin = group ? first[e] : 0, end = group ? first[e + 1] : 0;
        if (end > begin)
            st = pf_dg_project_field(&o->dg, change->old_mesh, u_old, group + begin, end - begin,
                                     &d->dg, e, u_new, err);
        else
            pf_dg_copy_field(&o->dg, u_old, change->parent[e], &d->dg, e, u_new);
    }
    pf_free(group);
    pf_free(first);
    return st;
}

/* The integrals copied from an old mesh's set-up (pf_dg_create_reusing) and computed. */
static void setup_stats(const void *m, pf_sim_stats *st)
{
    const pf_dg *dg = &((const dg_method *)m)->dg;
    int64_t reused = (int64_t)dg->reused_elems + dg->reused_faces;
    st->integrals_reused += reused;
    st->integrals_computed += (int64_t)dg->n_elems + dg->n_faces - reused;
}

static void destroy(void *m)
{
    dg_method *d = m;
    if (!d)
        return;
    pf_dg_release(&d->dg);
    pf_free(d->face_fixed);
    pf_free(d->fixed_affine);
    pf_free(d->x0);
    pf_free(d->rot);
    pf_free(d->map_offsets);
    pf_free(d->map_triple);
    pf_free(d->map_w);
    pf_free(d->face_slot);
    pf_free(d->penalty_values);
    pf_free(d);
}

static const pf_method_ops DG_OPS = {
    .n_dofs = n_dofs,
    .pattern = pattern,
    .stiffness = stiffness,
    .add_mass = add_mass,
    .mass_mul = mass_mul,
    .external_forces = external_forces,
    .ground_stiffness = ground_stiffness,
    .element_size = element_size,
    .set_penalty = set_penalty,
    .rigid_mode_shift = rigid_mode_shift,
    .element_of_dof = element_of_dof,
    .nodal_map = nodal_map,
    .point_row = point_row,
    .max_point_row = max_point_row,
    .node_elements = node_elements,
    .nodal_displacements = nodal_displacements,
    .von_mises = von_mises,
    .momentum = momentum,
    .affine = affine,
    .max_node_jump = max_node_jump,
    .error_indicator = error_indicator,
    .error_measure = "node_jump_over_displacement",
    .error_meaning = "largest jump between elements at a node over the largest displacement",
    .principal_stresses = principal_stresses,
    .transfer = transfer,
    .setup_stats = setup_stats,
    .destroy = destroy,
};

const pf_method_ops *pf_sim_dg_ops(void)
{
    return &DG_OPS;
}

/* Boundary faces in a fixed region get weak Dirichlet to that region's displacement; counts the
 * faces fixed and loaded. */
static pf_status select_faces(dg_method *d, int32_t *fixed_faces, int32_t *loaded_faces,
                              pf_error *err)
{
    const pf_scene *sc = d->scene;
    int32_t nf = d->mesh->n_faces;
    d->face_fixed = pf_alloc_array((size_t)nf, sizeof *d->face_fixed);
    d->fixed_affine = pf_calloc(12 * (size_t)(sc->n_fixed > 0 ? sc->n_fixed : 1), sizeof(double));
    PF_CHECK(d->face_fixed && d->fixed_affine, err, PF_ERR_NOMEM, "cannot allocate face flags");
    for (int32_t f = 0; f < nf; ++f)
        d->face_fixed[f] = -1;
    for (int32_t k = 0; k < sc->n_fixed; ++k) {
        d->fixed_affine[12 * k + 9] = sc->fixed[k].displacement.x;
        d->fixed_affine[12 * k + 10] = sc->fixed[k].displacement.y;
        d->fixed_affine[12 * k + 11] = sc->fixed[k].displacement.z;
    }
    *fixed_faces = *loaded_faces = 0;
    for (int32_t q = d->dg.n_interior; q < d->dg.n_faces; ++q) {
        const pf_dg_face *face = &d->dg.faces[q];
        int32_t k = pf_method_fixed_region(sc, d->mesh, face->face, face->centroid);
        d->face_fixed[face->face] = k;
        *fixed_faces += k >= 0;
        *loaded_faces += pf_method_face_loaded(sc, d->mesh, face->face, face->centroid);
    }
    d->terms.ip = sc->flux == PF_FLUX_IP;
    d->terms.eta = sc->penalty > 0 ? sc->penalty : 1;
    d->terms.face_fixed = d->face_fixed;
    d->terms.fixed_disp = d->fixed_affine;
    return PF_OK;
}

pf_status pf_sim_dg_create(const pf_scene *scene, const pf_mesh *mesh, const pf_method_reuse *reuse,
                           const pf_progress_hook *progress, const pf_method_ops **ops, void **ctx,
                           int32_t *fixed_faces, int32_t *loaded_faces, pf_error *err)
{
    *ops = &DG_OPS;
    *ctx = NULL;
    dg_method *d = pf_calloc(1, sizeof *d);
    PF_CHECK(d, err, PF_ERR_NOMEM, "cannot allocate the DG method");
    d->scene = scene;
    d->mesh = mesh;
    pf_material *table = NULL;
    int32_t *elem = NULL, n_materials = 0;
    pf_status st = pf_scene_materials(scene, mesh, &table, &n_materials, &elem, err);
    if (st >= 0) {
        pf_materials mat = {.n = n_materials, .table = table, .elem = elem};
        pf_dg_reuse dg_reuse = {0};
        if (reuse)
            dg_reuse = (pf_dg_reuse){.old = &((const dg_method *)reuse->old)->dg,
                                     .old_mesh = reuse->old_mesh,
                                     .parent = reuse->parent,
                                     .same_solid = reuse->same_solid,
                                     .same_faces = reuse->same_faces,
                                     .face_src = reuse->face_src};
        st = pf_dg_create_reusing(&d->dg, mesh, scene->degree, &mat, reuse ? &dg_reuse : NULL,
                                  progress, err);
    }
    pf_free(table);
    pf_free(elem);
    if (st >= 0) {
        d->x0 = pf_alloc_array((size_t)(d->dg.n_dofs ? d->dg.n_dofs : 1), sizeof *d->x0);
        d->rot = pf_alloc_array(9 * (size_t)(d->dg.n_elems ? d->dg.n_elems : 1), sizeof *d->rot);
        d->face_slot = pf_alloc_array((size_t)d->dg.n_interior + 1, sizeof *d->face_slot);
        st = d->x0 && d->rot && d->face_slot ? PF_OK
                                             : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                            "cannot allocate the DG state");
    }
    if (st >= 0) {
        pf_dg_rest_coefficients(&d->dg, d->x0);
        st = select_faces(d, fixed_faces, loaded_faces, err);
    }
    if (st >= 0)
        st = build_nodal_map(d, err);
    if (st < 0) {
        destroy(d);
        return st;
    }
    *ctx = d;
    return PF_OK;
}

double pf_sim_dg_owned_volume(const void *m, const uint8_t *owned)
{
    const pf_dg *dg = &((const dg_method *)m)->dg;
    double v = 0;
    for (int32_t e = 0; e < dg->n_elems; ++e)
        v += owned[e] ? dg->volume[e] : 0;
    return v;
}

int32_t pf_sim_dg_owned_fixed_faces(const void *m, const uint8_t *owned)
{
    const dg_method *d = m;
    int32_t n = 0;
    for (int32_t q = d->dg.n_interior; q < d->dg.n_faces; ++q)
        n += owned[d->dg.faces[q].elem[0]] && d->face_fixed[d->dg.faces[q].face] >= 0;
    return n;
}

void pf_sim_dg_set_body_length(void *m, double length)
{
    dg_method *d = m;
    double scale = pow(length / d->dg.body_length, d->dg.degree);
    for (int32_t q = 0; q < d->dg.n_faces; ++q)
        d->dg.faces[q].bz_growth *= scale;
    d->dg.body_length = length;
    d->penalty_current = false;
}
