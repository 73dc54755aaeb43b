/* The simulator: a scene on a mesh, for any method (method.h): DG (sim_dg.c), CG (sim_cg.c).
 *
 * Dynamics: semi-implicit (linearly implicit) Euler on M a + D v + K u = f with Rayleigh damping
 * D = alpha M + beta K. With h = dt / substeps and K, f evaluated at the start of the step
 * (corotation warps K with the current element rotations and moves their constant part into f;
 * contact with the ground and the obstacles adds its linearised penalty, DG paper sec. 8, at the
 * positions predicted by u + h v, against the obstacles where they are at the end of the step):
 *     ((1 + h alpha) M + (h beta + h^2) K) v' = M v + h (f - K u),     u' = u + h v'.
 * The matrix changes every step when corotation or contact is on: the pattern is analysed once,
 * the numeric factorisation redone per step; without either it is factored once. */
#include <pf/sim.h>

#include <math.h>
#include <string.h>

#include "contact.h"
#include "method.h"

struct pf_sim {
    const pf_scene *scene;
    const pf_mesh *mesh;
    const pf_method_ops *ops;
    void *method;
    int64_t n;     /* unknowns */
    double *f_ext; /* [n] loads and body forces, constant */
    double *u, *v; /* state */
    double *f, *ku, *rhs;
    double *u_prev, *v_prev; /* the state before the frame, restored on failure */
    pf_block_matrix k;
    pf_cholesky *chol;
    bool factored_once;  /* linear, contact-free dynamics reuse the first factorisation */
    pf_contact *contact; /* NULL without ground and obstacles, and in static scenes */
    double model_size;
    double time;
    int32_t frame;
    pf_sim_stats stats;
};

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status allocate_state(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->n;
    double **vectors[] = {&s->f_ext, &s->u, &s->v, &s->f, &s->ku, &s->rhs, &s->u_prev, &s->v_prev};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k) {
        *vectors[k] = pf_calloc(n ? n : 1, sizeof(double));
        PF_CHECK(*vectors[k], err, PF_ERR_NOMEM, "cannot allocate %zu unknowns", n);
    }
    return PF_OK;
}

static pf_status factor_timed(pf_sim *s, int64_t *failed, pf_error *err)
{
    double t0 = pf_time_seconds();
    pf_status st = pf_cholesky_factor(s->chol, &s->k, failed, err);
    s->stats.factor_seconds += pf_time_seconds() - t0;
    s->stats.factorisations++;
    return st;
}

/* The automatic BZ penalty. BZ is positive definite for any eta > 0 (sec. 3.3), so the search
 * below would stop at its first value, where BZ's glue is weak and the body 44-78 % too soft
 * (degree 2). Its error against the consistent (IP) limit is signed: too soft at a low eta,
 * too stiff at a high one, where it tends to the conforming solution in the continuous fields of
 * its space (fig. 3). The default sits near the crossing, measured by bench_dg bzpenalty and
 * bench_locking bz (docs/scene.md): degree 2 crosses at eta 16-45 on cantilever hexes and
 * 12-110 on the tet cube, so 32, inside sec. 4.1's 10-100; degree 1 crosses at 1-2 on hexes
 * (whose continuous degree-1 fields are nearly affine: eta 8 makes the beam 58-86 % too stiff)
 * and 2-20 on tets, so it keeps the search's 1. */
static double bz_default_penalty(int32_t degree)
{
    return degree >= 2 ? 32 : 1;
}

/* DG paper sec. 9.1: start low and double eta until the stiffness is positive definite (with a
 * tiny mass shift lifting a free body's rigid modes). */
static pf_status choose_penalty(pf_sim *s, pf_error *err)
{
    if (!s->ops->set_penalty)
        return PF_OK;
    double given = s->scene->penalty;
    if (given <= 0 && s->scene->flux == PF_FLUX_BZ)
        given = bz_default_penalty(s->scene->degree);
    if (given > 0) {
        s->ops->set_penalty(s->method, given);
        s->stats.penalty = given;
        return PF_OK;
    }
    double shift = s->ops->rigid_mode_shift(s->method);
    for (double eta = 1; eta <= 1048576; eta *= 2) {
        s->ops->set_penalty(s->method, eta);
        memset(s->f, 0, (size_t)s->n * sizeof *s->f);
        s->ops->stiffness(s->method, s->u, false, &s->k, s->f);
        s->ops->add_mass(s->method, shift, &s->k);
        pf_error ignored = {0};
        if (factor_timed(s, NULL, &ignored) == PF_OK) {
            s->stats.penalty = eta;
            return PF_OK;
        }
        s->stats.penalty_doublings++;
    }
    return pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                        "no penalty up to 2^20 makes the stiffness positive definite: the mesh "
                        "has degenerate elements");
}

/* Contact (contact.c) through the method's nodal map, and the pattern it needs. */
static pf_status setup_contact(pf_sim *s, const pf_surface *surface, const pf_weights *weights,
                               pf_error *err)
{
    if (s->scene->is_static)
        return PF_OK;
    pf_contact_setup cs = {.scene = s->scene,
                           .mesh = s->mesh,
                           .n_triples = s->n / 3,
                           .surface = surface,
                           .weights = weights,
                           .auto_stiffness = s->ops->ground_stiffness(s->method),
                           .model_size = s->model_size,
                           .n_blocks = s->k.n_blocks,
                           .block_start = s->k.block_start};
    s->ops->nodal_map(s->method, &cs.map_offsets, &cs.map_triple, &cs.map_w);
    PF_TRY(pf_contact_create(&s->contact, &cs, err));
    if (!s->contact)
        return PF_OK;
    s->stats.contact_points = pf_contact_get_stats(s->contact)->points;
    return PF_OK;
}

pf_status pf_sim_create(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh, pf_error *err)
{
    return pf_sim_create_embedded(out, scene, mesh, NULL, NULL, err);
}

pf_status pf_sim_create_embedded(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh,
                                 const pf_surface *surface, const pf_weights *weights,
                                 pf_error *err)
{
    *out = NULL;
    PF_CHECK(!surface == !weights, err, PF_ERR_INVALID,
             "an embedded surface needs both the surface and its weights");
    double t0 = pf_time_seconds();
    pf_sim *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate the simulator");
    s->scene = scene;
    s->mesh = mesh;
    pf_method_create_fn create =
        scene->method == PF_METHOD_CG ? pf_sim_cg_create : pf_sim_dg_create;
    pf_status st = create(scene, mesh, &s->ops, &s->method, &s->stats.fixed_faces,
                          &s->stats.loaded_faces, err);
    if (st >= 0 && scene->method == PF_METHOD_CG)
        pf_sim_cg_stats(s->method, &s->stats.closed_form_elems, &s->stats.harmonic_elems,
                        &s->stats.kernels, &s->stats.basis_seconds);
    if (st >= 0) {
        s->n = s->ops->n_dofs(s->method);
        st = allocate_state(s, err);
    }
    if (st >= 0 && scene->is_static && s->stats.fixed_faces == 0)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "a static scene needs fixed faces: no boundary face centroid lies in "
                          "any 'fixed' region");
    pf_vec3 lo, hi;
    pf_mesh_bounds(mesh, &lo, &hi);
    s->model_size = pf_v3_norm(pf_v3_sub(hi, lo));
    if (st >= 0)
        st = s->ops->pattern(s->method, &s->k, err);
    if (st >= 0)
        st = setup_contact(s, surface, weights, err);
    if (st >= 0)
        st = pf_cholesky_create(&s->chol, &s->k, err);
    if (st >= 0)
        st = choose_penalty(s, err);
    if (st < 0) {
        pf_sim_destroy(&s);
        return st;
    }
    s->ops->external_forces(s->method, s->f_ext);
    s->stats.dofs = s->n;
    s->stats.matrix_nnz = s->k.col_ptr[s->k.n];
    s->stats.factor_nnz = pf_cholesky_factor_nnz(s->chol);
    s->stats.setup_seconds = pf_time_seconds() - t0;
    *out = s;
    return PF_OK;
}

void pf_sim_destroy(pf_sim **sim)
{
    pf_sim *s = *sim;
    if (!s)
        return;
    if (s->ops)
        s->ops->destroy(s->method);
    double *vectors[] = {s->f_ext, s->u, s->v, s->f, s->ku, s->rhs, s->u_prev, s->v_prev};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k)
        pf_free(vectors[k]);
    pf_block_matrix_release(&s->k);
    pf_cholesky_destroy(&s->chol);
    pf_contact_destroy(&s->contact);
    pf_free(s);
    *sim = NULL;
}

/* ---- one step ---------------------------------------------------------------------------- */

/* The element whose unknowns first went non-finite, or the one that moved most. */
static int32_t worst_element(const pf_sim *s)
{
    int64_t worst = 0;
    double largest = -1;
    for (int64_t q = 0; q < s->n; ++q) {
        if (!isfinite(s->u[q]))
            return s->ops->element_of_dof(s->method, q);
        if (fabs(s->u[q]) > largest)
            largest = fabs(s->u[q]), worst = q;
    }
    return s->ops->element_of_dof(s->method, worst);
}

/* A state is broken when it holds a non-finite number, or a displacement above 1e3 model sizes
 * (nothing physical moves a body a thousand times its size within one frame of a drop). */
static bool state_is_sane(const pf_sim *s)
{
    for (int64_t q = 0; q < s->n; ++q)
        if (!isfinite(s->u[q]) || !isfinite(s->v[q]) || fabs(s->u[q]) > 1e3 * s->model_size)
            return false;
    return true;
}

/* New contact points whose couplings the pattern lacks: the pattern grows and is analysed again
 * (a growth event; the steady state allocates nothing). */
static pf_status grow_pattern(pf_sim *s, pf_error *err)
{
    double t0 = pf_time_seconds();
    PF_TRY(pf_contact_grow_pattern(s->contact, &s->k, err));
    pf_cholesky_destroy(&s->chol);
    PF_TRY(pf_cholesky_create(&s->chol, &s->k, err));
    s->factored_once = false;
    s->stats.matrix_nnz = s->k.col_ptr[s->k.n];
    s->stats.factor_nnz = pf_cholesky_factor_nnz(s->chol);
    s->stats.pattern_growths++;
    s->stats.setup_seconds += pf_time_seconds() - t0;
    return PF_OK;
}

static pf_status step(pf_sim *s, double h, pf_error *err)
{
    const pf_scene *sc = s->scene;
    size_t n = (size_t)s->n;
    int64_t contacts = 0;
    const pf_contact_stats *cs = s->contact ? pf_contact_get_stats(s->contact) : NULL;
    double embed0 = cs ? cs->embed_seconds : 0, search0 = cs ? cs->search_seconds : 0;
    if (s->contact) {
        contacts = pf_contact_detect(s->contact, s->time + h, s->u, s->v, h);
        if (pf_contact_needs_pattern(s->contact))
            PF_TRY(grow_pattern(s, err));
    }
    double t0 = pf_time_seconds();
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    s->ops->stiffness(s->method, s->u, sc->corotation, &s->k, s->f);
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    if (s->contact) {
        pf_contact_assemble(s->contact, &s->k, s->f);
        s->stats.embed_seconds += cs->embed_seconds - embed0;
        s->stats.contact_seconds += cs->search_seconds - search0;
    }
    s->stats.contacts += contacts;
    t0 = pf_time_seconds();
    /* rhs = M v + h (f - K u); then k := (h beta + h^2) K + (1 + h alpha) M */
    pf_block_matrix_mul(&s->k, 1, s->u, 0, s->ku);
    for (size_t q = 0; q < n; ++q)
        s->rhs[q] = h * (s->f[q] - s->ku[q]);
    s->ops->mass_mul(s->method, 1, s->v, s->rhs);
    bool refactor = sc->corotation || contacts > 0 || !s->factored_once;
    if (refactor) {
        double kscale = h * sc->damping_beta + h * h;
        for (int64_t q = 0; q < s->k.col_ptr[s->k.n]; ++q)
            s->k.val[q] *= kscale;
        s->ops->add_mass(s->method, 1 + h * sc->damping_alpha, &s->k);
    }
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    if (refactor) {
        int64_t failed = -1;
        pf_status st = factor_timed(s, &failed, err);
        if (st < 0) {
            s->factored_once = false;
            pf_error_prefix(err, "element %d", (int)s->ops->element_of_dof(s->method, failed));
            return st;
        }
        /* Linear dynamics without contact keep this factorisation; with contact it changes. */
        s->factored_once = !sc->corotation && contacts == 0;
    }
    double t1 = pf_time_seconds();
    PF_TRY(pf_cholesky_solve(s->chol, s->rhs, s->v, err));
    for (size_t q = 0; q < n; ++q)
        s->u[q] += h * s->v[q];
    s->stats.solve_seconds += pf_time_seconds() - t1;
    s->stats.steps++;
    return PF_OK;
}

pf_status pf_sim_frame(pf_sim *s, pf_error *err)
{
    const pf_scene *sc = s->scene;
    size_t n = (size_t)s->n;
    memcpy(s->u_prev, s->u, n * sizeof *s->u);
    memcpy(s->v_prev, s->v, n * sizeof *s->v);
    double h = sc->dt / sc->substeps;
    for (int32_t k = 0; k < sc->substeps; ++k) {
        pf_status st = step(s, h, err);
        if (st >= 0 && !state_is_sane(s))
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the simulation diverged (element %d first)", (int)worst_element(s));
        if (st < 0) {
            memcpy(s->u, s->u_prev, n * sizeof *s->u);
            memcpy(s->v, s->v_prev, n * sizeof *s->v);
            s->factored_once = false;
            pf_error_prefix(err, "frame %d, step %d", (int)s->frame + 1, (int)k + 1);
            return st;
        }
        s->time += h;
    }
    s->frame++;
    return PF_OK;
}

pf_status pf_sim_solve_static(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->n;
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    double t0 = pf_time_seconds();
    s->ops->stiffness(s->method, s->u, false, &s->k, s->f);
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    int64_t failed = -1;
    pf_status st = factor_timed(s, &failed, err);
    if (st < 0) {
        pf_error_prefix(err, "static solve, element %d",
                        (int)s->ops->element_of_dof(s->method, failed));
        return st;
    }
    double t1 = pf_time_seconds();
    PF_TRY(pf_cholesky_solve(s->chol, s->f, s->u, err));
    s->stats.solve_seconds += pf_time_seconds() - t1;
    memset(s->v, 0, n * sizeof *s->v);
    s->factored_once = false; /* the factorisation is K's, not the dynamic system's */
    if (!state_is_sane(s))
        return pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                            "static solve gave a non-finite displacement (element %d first)",
                            (int)worst_element(s));
    s->frame++;
    return PF_OK;
}

/* ---- output and diagnostics -------------------------------------------------------------- */

double pf_sim_time(const pf_sim *s)
{
    return s->time;
}
int32_t pf_sim_frame_index(const pf_sim *s)
{
    return s->frame;
}
const pf_sim_stats *pf_sim_get_stats(const pf_sim *s)
{
    return &s->stats;
}

void pf_sim_nodal_displacements(const pf_sim *s, double *out)
{
    s->ops->nodal_displacements(s->method, s->u, out);
}

void pf_sim_von_mises(const pf_sim *s, double *out)
{
    s->ops->von_mises(s->method, s->u, out);
}

void pf_sim_momentum(const pf_sim *s, double *kinetic, pf_vec3 *linear, pf_vec3 *angular)
{
    s->ops->momentum(s->method, s->u, s->v, kinetic, linear, angular);
}

void pf_sim_set_rigid_velocity(pf_sim *s, pf_vec3 w, pf_vec3 c, pf_vec3 v0)
{
    /* v(x) = w x (x - c) + v0 = W x + (v0 - W c), W the cross-product matrix of w */
    double a[9] = {0, -w.z, w.y, w.z, 0, -w.x, -w.y, w.x, 0};
    pf_vec3 wc = pf_v3_cross(w, c);
    double b[3] = {v0.x - wc.x, v0.y - wc.y, v0.z - wc.z};
    s->ops->affine(s->method, a, b, s->v);
}

void pf_sim_set_affine_displacement(pf_sim *s, const double a[9], const double b[3])
{
    s->ops->affine(s->method, a, b, s->u);
}

double pf_sim_deformed_volume(const pf_sim *s)
{
    const pf_mesh *m = s->mesh;
    double *x = pf_alloc_array(3 * (size_t)m->n_nodes, sizeof *x);
    if (!x)
        return NAN;
    s->ops->nodal_displacements(s->method, s->u, x);
    for (size_t q = 0; q < 3 * (size_t)m->n_nodes; ++q)
        x[q] += m->x[q];
    pf_mesh moved = *m; /* borrowed arrays, only the positions differ */
    moved.x = x;
    double volume = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        volume += pf_mesh_elem_volume(&moved, e);
    pf_free(x);
    return volume;
}

double pf_sim_max_node_jump(const pf_sim *s)
{
    return s->ops->max_node_jump(s->method, s->u);
}
