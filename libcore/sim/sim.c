/* The simulator: a scene on a mesh, for any method (method.h): DG (sim_dg.c), CG (sim_cg.c).
 *
 * Dynamics: semi-implicit (linearly implicit) Euler on M a + D v + K u = f with Rayleigh damping
 * D = alpha M + beta K. With h = dt / substeps and K, f evaluated at the start of the step
 * (corotation warps K with the current element rotations and moves their constant part into f;
 * contact with the ground and the obstacles adds its linearised penalty, DG paper sec. 8, at the
 * positions predicted by u + h v, against the obstacles where they are at the end of the step;
 * the two sides of a crack, contact_crack.c, likewise against each other):
 *     ((1 + h alpha) M + (h beta + h^2) K) v' = M v + h (f - K u),     u' = u + h v'.
 * Contact's stiffness couples one element's unknowns per contact point (contact.c), so the pattern
 * is the method's, analysed once: embedded contact costs no fill. The solver (pf/solve.h) decides
 * when to factorise: direct whenever the matrix changed (the reference), pcg on the last factor
 * until refactorising pays. */
#include <pf/sim.h>

#include <math.h>
#include <string.h>

#include "sim_change.h"
#include "sim_internal.h"

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status allocate_state(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->n;
    double **vectors[] = {&s->f_ext, &s->u,      &s->v,      &s->f,  &s->ku,
                          &s->rhs,   &s->u_prev, &s->v_prev, &s->dv, &s->dv2};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k) {
        *vectors[k] = pf_calloc(n ? n : 1, sizeof(double));
        PF_CHECK(*vectors[k], err, PF_ERR_NOMEM, "cannot allocate %zu unknowns", n);
    }
    /* the warp preconditioner's rotations: only for a method that gives them, in corotated
     * dynamics */
    if (s->ops->triple_rotations && s->scene->corotation && !s->scene->is_static) {
        s->rot = pf_alloc_array(3 * n + 1, sizeof *s->rot);
        PF_CHECK(s->rot, err, PF_ERR_NOMEM,
                 "cannot allocate the rotations of %zu unknowns", n);
    }
    return PF_OK;
}

void pf_sim_forget_trend(pf_sim *s)
{
    s->trend = 0;
    if (s->method && s->ops->forget_rotations)
        s->ops->forget_rotations(s->method);
}

void pf_sim_sync_solver_stats(pf_sim *s)
{
    pf_solver_stats ss = *pf_solver_get_stats(s->solver);
    const pf_solver_stats *b = &s->solver_before;
    ss.solves += b->solves;
    ss.factorisations += b->factorisations;
    for (int k = 0; k < PF_REFACTOR_REASONS; ++k)
        ss.by_reason[k] += b->by_reason[k];
    ss.pcg_solves += b->pcg_solves;
    ss.iterations += b->iterations;
    ss.max_iterations =
        ss.max_iterations > b->max_iterations ? ss.max_iterations : b->max_iterations;
    ss.factor_seconds += b->factor_seconds;
    ss.solve_seconds += b->solve_seconds;
    ss.factor_cpu_seconds += b->factor_cpu_seconds;
    ss.solve_cpu_seconds += b->solve_cpu_seconds;
    s->stats.solver = ss;
    s->stats.factorisations = ss.factorisations;
    s->stats.factor_seconds = ss.factor_seconds;
    s->stats.solve_seconds = ss.solve_seconds;
    s->stats.matrix_nnz = ss.matrix_nnz;
    s->stats.factor_nnz = ss.factor_nnz;
}

/* The automatic BZ penalty. BZ is positive definite for any eta > 0 (sec. 3.3), so the search
 * below would stop at its first value; BZ's penalty is chosen here instead. BZ's face weight
 * grows like h^-(p+1) under refinement (pf_dg_face_penalty; Babuska and Zlamal 1973), so its
 * error falls with h; eta sets the constant. Its error against the consistent (IP) limit is
 * signed: too soft at a low eta (glue), too stiff at a high one (the continuous fields of the
 * space, fig. 3). The defaults are round values on the soft side of the cantilever
 * of tests/test_sim.c at 8 x 2 x 2, 16 x 4 x 4 and 32 x 8 x 8 hexes (bench_dg bzconverge,
 * docs/scene.md), where the error falls at every refinement: degree 1 +50, +15, +3.8 % at 3/16
 * (+0.7 % at 64 x 16 x 16; at 1/4 it crosses zero between the second and third mesh), degree 2
 * +11, +1.4, -0.1 % at 1/2 (at 1 it crosses between the first and second). */
double pf_sim_bz_default_penalty(int32_t degree)
{
    return degree >= 2 ? 0.5 : 0.1875;
}

/* Whether K at rest, plus the rigid-mode shift, is positive definite. */
static bool definite_at(pf_sim *s, const double *u, double shift)
{
    memset(s->f, 0, (size_t)s->n * sizeof *s->f);
    s->ops->stiffness(s->method, u, false, &s->k, s->f);
    s->ops->add_mass(s->method, shift, &s->k);
    pf_error ignored = {0};
    return pf_solver_factor(s->solver, &s->k, NULL, &ignored) == PF_OK;
}

/* DG paper sec. 9.1: start low and double eta until the stiffness is positive definite (with a
 * tiny mass shift lifting a free body's rigid modes). Definiteness at rest is not enough once
 * corotation turns the elements: an element's rotation relative to its neighbours is resisted by
 * the penalty alone, and the lagged rotations of the semi-implicit step feed it back. Measured
 * with IP degree 1 and that smallest eta (2 on both), a clamped 8 x 2 x 2 box of 32 hexes and a
 * 4 x 1 x 1 box of 256 hexes under gravity explode (tip at 20 and 2660 model units after 30 and
 * 40 frames), while 2 x and 4 x that eta settle at the CG answer (5.2-5.5 and 7.2-7.5; CG 5.2
 * and 7.6). Corotated dynamics therefore take 8 x the smallest definite eta, one doubling of
 * margin beyond the largest failure seen (PF_SIM_COROTATED_PENALTY_MARGIN); the DG paper reports
 * 10-100 in practice. */
static pf_status choose_penalty(pf_sim *s, double given, pf_error *err)
{
    if (!s->ops->set_penalty)
        return PF_OK;
    if (given <= 0)
        given = s->scene->penalty;
    if (given <= 0 && s->scene->flux == PF_FLUX_BZ)
        given = pf_sim_bz_default_penalty(s->scene->degree);
    if (given > 0) {
        s->ops->set_penalty(s->method, given);
        s->stats.penalty = given;
        return PF_OK;
    }
    double shift = s->ops->rigid_mode_shift(s->method);
    for (double eta = 1; eta <= 1048576; eta *= 2) {
        s->ops->set_penalty(s->method, eta);
        if (definite_at(s, s->u, shift)) {
            /* corotated dynamics need a margin over definiteness at rest (see above) */
            if (s->scene->corotation && !s->scene->is_static)
                eta *= PF_SIM_COROTATED_PENALTY_MARGIN;
            s->ops->set_penalty(s->method, eta);
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
static pf_status setup_contact(pf_sim *s, pf_error *err)
{
    if (s->scene->is_static)
        return PF_OK;
    pf_contact_setup cs = {.scene = s->scene,
                           .mesh = s->mesh,
                           .n_triples = s->n / 3,
                           .surface = s->surface,
                           .weights = s->weights,
                           .auto_stiffness = s->ops->ground_stiffness(
                               s->method, pf_method_mean_element_size(s->ops, s->method,
                                                                      s->mesh->n_elems)),
                           .model_size = s->model_size,
                           .ops = s->ops,
                           .method = s->method,
                           .n_blocks = s->k.n_blocks,
                           .block_start = s->k.block_start};
    PF_TRY(pf_contact_create(&s->contact, &cs, err));
    PF_TRY(pf_crack_create(&s->crack, &cs, err));
    if (!s->contact)
        return PF_OK;
    s->stats.contact_points = pf_contact_get_stats(s->contact)->points;
    s->stats.contact_samples = pf_contact_get_stats(s->contact)->samples;
    return PF_OK;
}

/* The petsc solver's multigrid wants the rigid modes in the method's unknowns: the three
 * translations and the three rotations about the mesh's centre, each an affine field the method
 * represents exactly (DG: an element's constant and linear monomial coefficients; CG: the free
 * nodes' displacements). */
static pf_status set_rigid_modes(pf_sim *s, pf_error *err)
{
    if (pf_solver_get_stats(s->solver)->method != PF_SOLVER_PETSC)
        return PF_OK;
    double *modes = pf_alloc_array(6 * (size_t)s->n + 1, sizeof *modes);
    PF_CHECK(modes, err, PF_ERR_NOMEM, "cannot allocate the rigid modes of %lld unknowns",
             (long long)s->n);
    pf_vec3 lo, hi;
    pf_mesh_bounds(s->mesh, &lo, &hi);
    double c[3] = {0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y), 0.5 * (lo.z + hi.z)};
    for (int k = 0; k < 3; ++k) {
        double zero[9] = {0}, t[3] = {0};
        t[k] = 1;
        s->ops->affine(s->method, zero, t, modes + (size_t)k * (size_t)s->n);
        /* u = e_k x (x - c): A = [e_k]_x, b = -A c */
        double a[9] = {0}, b[3];
        int i = (k + 1) % 3, j = (k + 2) % 3;
        a[3 * j + i] = 1;
        a[3 * i + j] = -1;
        for (int r = 0; r < 3; ++r)
            b[r] = -(a[3 * r] * c[0] + a[3 * r + 1] * c[1] + a[3 * r + 2] * c[2]);
        s->ops->affine(s->method, a, b, modes + (size_t)(3 + k) * (size_t)s->n);
    }
    pf_status st = pf_solver_set_near_null_space(s->solver, 6, modes, err);
    pf_free(modes);
    return st;
}

pf_status pf_sim_create(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh, pf_error *err)
{
    return pf_sim_create_with(out, scene, mesh, NULL, err);
}

pf_status pf_sim_create_embedded(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh,
                                 const pf_surface *surface, const pf_weights *weights,
                                 pf_error *err)
{
    pf_sim_options opt = {.surface = surface, .weights = weights};
    return pf_sim_create_with(out, scene, mesh, &opt, err);
}

/* The methods, by the scene's method (method.h). */
static const struct {
    pf_method method;
    pf_method_create_fn create;
    const pf_method_ops *(*ops)(void);
} METHODS[] = {{PF_METHOD_DG, pf_sim_dg_create, pf_sim_dg_ops},
               {PF_METHOD_CG, pf_sim_cg_create, pf_sim_cg_ops}};

void pf_method_step_begin(const pf_method_ops *ops, void *m, const double *u, const double *v,
                          bool corotate, double kscale, double mscale, pf_block_matrix *k,
                          double *f, double *ku, size_t n)
{
    if (ops->step_system) {
        memset(ku, 0, n * sizeof *ku);
        ops->step_system(m, u, v, corotate, kscale, mscale, k, f, ku);
    } else {
        ops->stiffness(m, u, corotate, k, f);
    }
}

void pf_method_step_finish(const pf_method_ops *ops, const void *m, const double *u,
                           const double *v, double h, double kscale, double mscale,
                           pf_block_matrix *k, const double *f, double *ku, double *rhs, size_t n)
{
    if (ops->step_system) {
        for (size_t q = 0; q < n; ++q)
            rhs[q] = h * f[q] + ku[q];
        return;
    }
    pf_block_matrix_mul(k, 1, u, 0, ku);
    for (size_t q = 0; q < n; ++q)
        rhs[q] = h * (f[q] - ku[q]);
    ops->mass_mul(m, 1, v, rhs);
    for (int64_t q = 0; q < k->col_ptr[k->n]; ++q)
        k->val[q] *= kscale;
    ops->add_mass(m, mscale, k);
}

const pf_method_ops *pf_method_ops_of(pf_method method)
{
    for (size_t k = 0; k < sizeof METHODS / sizeof *METHODS; ++k)
        if (METHODS[k].method == method)
            return METHODS[k].ops();
    return NULL;
}

/* The scene's solver, except that auto keeps pcg once it chose it on the mesh before a change
 * (solver_before.method, set by pf_sim_change_mesh): auto weighs a factorisation against PCG
 * iterations by flops, and a cut that leaves separate pieces lowers the factorisation's flops
 * far more than its time (its supernodes shrink, and CHOLMOD's rate per flop with them). On the
 * 1,200 Kuhn tets of bench_cut steps, DG degree 1, three cuts took a factorisation from 26 to 8
 * modelled iterations, below auto's 10, while it still cost about 19 measured ones: every step
 * after the cuts refactorised (73 ms per step against 32 before; with pcg kept, 30 against 42,
 * bench/results/cut_steps.csv). Direct is re-judged on the new mesh: a refinement can make a
 * cheap factorisation costly. */
static pf_solver_params solver_params(const pf_sim *s)
{
    pf_solver_params params = s->scene->solver;
    params.progress = s->progress;
    if (params.method == PF_SOLVER_AUTO && s->solver_before.method == PF_SOLVER_PCG)
        params.method = PF_SOLVER_PCG;
    return params;
}

pf_status pf_sim_build(pf_sim *s, const pf_mesh *mesh, const pf_method_reuse *reuse, double penalty,
                       pf_error *err)
{
    const pf_scene *scene = s->scene;
    s->mesh = mesh;
    pf_method_create_fn create = NULL;
    for (size_t k = 0; k < sizeof METHODS / sizeof *METHODS; ++k)
        if (METHODS[k].method == scene->method)
            create = METHODS[k].create;
    PF_CHECK(create, err, PF_ERR_INVALID, "unknown method %d", (int)scene->method);
    double t0 = pf_cpu_seconds();
    pf_status st = create(scene, mesh, reuse, &s->progress, &s->ops, &s->method,
                          &s->stats.fixed_faces, &s->stats.loaded_faces, err);
    s->method_seconds = pf_cpu_seconds() - t0;
    if (st >= 0)
        s->ops->setup_stats(s->method, &s->stats);
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
        st = setup_contact(s, err);
    if (st >= 0) {
        bool changes = !scene->is_static && (scene->corotation || s->contact || s->crack);
        pf_solver_params params = solver_params(s);
        st = pf_solver_create(&s->solver, &s->k, &params, changes, err);
    }
    if (st >= 0)
        st = set_rigid_modes(s, err);
    if (st >= 0)
        st = choose_penalty(s, penalty, err);
    if (st < 0)
        return st;
    s->ops->external_forces(s->method, s->f_ext);
    s->stats.dofs = s->n;
    s->stats.elements = mesh->n_elems;
    pf_sim_sync_solver_stats(s);
    return PF_OK;
}

pf_status pf_sim_create_with(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh,
                             const pf_sim_options *options, pf_error *err)
{
    *out = NULL;
    pf_sim_options opt = options ? *options : (pf_sim_options){0};
    const pf_surface *surface = opt.surface;
    const pf_weights *weights = opt.weights;
    PF_CHECK(!surface == !weights, err, PF_ERR_INVALID,
             "an embedded surface needs both the surface and its weights");
    double t0 = pf_time_seconds(), cpu0 = pf_cpu_seconds();
    pf_sim *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate the simulator");
    s->scene = scene;
    s->surface = s->uncut_surface = surface;
    s->weights = weights;
    s->progress = opt.progress;
    pf_status st = pf_sim_build(s, mesh, NULL, 0, err);
    if (st < 0) {
        pf_sim_destroy(&s);
        return st;
    }
    s->stats.setup_seconds = pf_time_seconds() - t0;
    s->stats.setup_cpu_seconds = pf_cpu_seconds() - cpu0;
    *out = s;
    return PF_OK;
}

void pf_sim_release(pf_sim *s)
{
    if (s->ops)
        s->ops->destroy(s->method);
    s->ops = NULL;
    s->method = NULL;
    double **vectors[] = {&s->f_ext, &s->u,      &s->v,      &s->f,  &s->ku,
                          &s->rhs,   &s->u_prev, &s->v_prev, &s->dv, &s->dv2};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k) {
        pf_free(*vectors[k]);
        *vectors[k] = NULL;
    }
    pf_free(s->rot);
    s->rot = NULL;
    s->trend = 0;
    pf_block_matrix_release(&s->k);
    pf_solver_destroy(&s->solver);
    pf_contact_destroy(&s->contact);
    pf_crack_destroy(&s->crack);
    pf_free(s->level);
    pf_free(s->family);
    pf_free(s->calm);
    s->level = s->family = s->calm = NULL;
    pf_buffer_release(&s->families);
    if (s->owned_weights)
        pf_weights_release(s->owned_weights);
    pf_free(s->owned_weights);
    s->owned_weights = NULL;
    pf_free(s->embed_steps);
    s->embed_steps = NULL;
    pf_free(s->blade_locks);
    s->blade_locks = NULL;
    pf_scene_free_lists(&s->owned_scene);
    if (s->owned_surface)
        pf_surface_release(s->owned_surface);
    pf_free(s->owned_surface);
    s->owned_surface = NULL;
    if (s->owned_mesh)
        pf_mesh_release(s->owned_mesh);
    pf_free(s->owned_mesh);
    s->owned_mesh = NULL;
}

void pf_sim_destroy(pf_sim **sim)
{
    pf_sim *s = *sim;
    if (!s)
        return;
    pf_sim_release(s);
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

static pf_status step(pf_sim *s, double h, pf_error *err)
{
    const pf_scene *sc = s->scene;
    size_t n = (size_t)s->n;
    int64_t contacts = 0;
    const pf_contact_stats *cs = s->contact ? pf_contact_get_stats(s->contact) : NULL;
    double embed0 = cs ? cs->embed_seconds : 0, search0 = cs ? cs->search_seconds : 0;
    if (s->contact)
        contacts = pf_contact_detect(s->contact, s->time + h, s->u, s->v, h);
    int64_t cracks = s->crack ? pf_crack_detect(s->crack, s->u, s->v, h) : 0;
    double t0 = pf_time_seconds(), cpu0 = pf_cpu_seconds();
    /* k := (h beta + h^2) K + (1 + h alpha) M; ku: M v where the method builds it in the same
     * pass (step_system), f then with the elastic force -K u */
    double kscale = h * sc->damping_beta + h * h, mscale = 1 + h * sc->damping_alpha;
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    pf_method_step_begin(s->ops, s->method, s->u, s->v, sc->corotation, kscale, mscale, &s->k,
                         s->f, s->ku, n);
    if (s->rot && pf_solver_get_stats(s->solver)->method == PF_SOLVER_PCG) {
        /* the warp only without contact: contact's stiff terms stay in the world frame, and
         * the warp turned the old factor's with the body (on the embedded CG bunny of
         * scripts/demo's pipeline, PCG on a one-step-old factor took 7-16 iterations without
         * it where it failed after 300 with it) */
        bool warp = contacts == 0 && cracks == 0;
        if (warp)
            s->ops->triple_rotations(s->method, s->rot);
        PF_TRY(pf_solver_set_rotations(s->solver, warp ? s->rot : NULL, err));
    }
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    s->stats.assemble_cpu_seconds += pf_cpu_seconds() - cpu0;
    if (contacts > 0) {
        pf_contact_forces(s->contact, s->u, s->f);
        s->stats.contacts += contacts;
    }
    if (cracks > 0) {
        pf_crack_forces(s->crack, s->u, s->f);
        s->stats.contacts += cracks;
    }
    if (cs) {
        s->stats.embed_seconds += cs->embed_seconds - embed0;
        s->stats.contact_seconds += cs->search_seconds - search0;
    }
    t0 = pf_time_seconds();
    cpu0 = pf_cpu_seconds();
    /* rhs = M v + h (f - K u), f with the contact forces at u; then
     * k := (h beta + h^2) (K + C) + (1 + h alpha) M, C the contact stiffness */
    pf_method_step_finish(s->ops, s->method, s->u, s->v, h, kscale, mscale, &s->k, s->f, s->ku,
                          s->rhs, n);
    if (contacts > 0)
        pf_contact_add_stiffness(s->contact, kscale, &s->k);
    if (cracks > 0)
        pf_crack_add_stiffness(s->crack, kscale, &s->k);
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    s->stats.assemble_cpu_seconds += pf_cpu_seconds() - cpu0;
    /* the matrix changed: new terms when contacts came or went, a drift of its values with
     * corotation or contacts that stay (their normals may turn) */
    pf_matrix_change change = PF_MATRIX_SAME;
    if (!s->assembled || (s->contact && pf_contact_set_changed(s->contact)) ||
        (s->crack && pf_crack_set_changed(s->crack))) {
        change = s->assembled ? PF_MATRIX_TERMS : PF_MATRIX_NEW;
        s->trend = 0; /* an impact or a release: the velocity's trend breaks (on the torus
                         dropped by scripts/demo, 1,188 PCG iterations in 600 steps against
                         1,190 with the trend kept) */
    } else if (sc->corotation || contacts > 0 || cracks > 0)
        change = PF_MATRIX_DRIFTED;
    s->assembled = true;
    int64_t failed = -1;
    /* v' started from the velocity extrapolated through the last three steps' (a quadratic in
     * time: v + 2 dv - dv2, the trend of a smooth motion; linear or none when fewer are
     * known), the velocity before kept in ku to update the trend */
    for (size_t q = 0; q < n; ++q)
        s->ku[q] = s->v[q];
    if (s->trend == 1)
        for (size_t q = 0; q < n; ++q)
            s->v[q] += s->dv[q];
    else if (s->trend == 2)
        for (size_t q = 0; q < n; ++q)
            s->v[q] += 2 * s->dv[q] - s->dv2[q];
    pf_status st = pf_solver_solve(s->solver, &s->k, change, s->rhs, s->v, &failed, err);
    pf_sim_sync_solver_stats(s);
    if (st < 0) {
        if (failed >= 0)
            pf_error_prefix(err, "element %d", (int)s->ops->element_of_dof(s->method, failed));
        return st;
    }
    double *older = s->dv2; /* the trend moves on a step */
    s->dv2 = s->dv;
    s->dv = older;
    for (size_t q = 0; q < n; ++q) {
        s->u[q] += h * s->v[q];
        s->dv[q] = s->v[q] - s->ku[q];
    }
    s->trend = s->trend < 2 ? s->trend + 1 : 2;
    /* the work of the constant forces and of moving obstacles over the step */
    double power = 0;
    for (size_t q = 0; q < n; ++q)
        power += s->f_ext[q] * s->v[q];
    if (contacts > 0)
        power += pf_contact_obstacle_power(s->contact);
    s->work += h * power;
    s->stats.steps++;
    return PF_OK;
}

/* A dissipative step (semi-implicit Euler with damping) keeps the kinetic energy below what the
 * body had plus what was done on it: T(t) <= T(0) + W(t) + E_0, W the work of the loads, body
 * forces and moving obstacles, E_0 the elastic energy the start can release (initial_energy),
 * elastic and penalty energy being >= 0. Corotation's lagged rotations
 * add a little; a growth beyond four times the bound is an instability feeding itself (an
 * exploding clamped beam: the bound is exceeded within a few frames of the start of growth,
 * long before the displacement looks absurd). */
static bool energy_is_bounded(const pf_sim *s, double *kinetic, double *bound)
{
    pf_vec3 p, l;
    s->ops->momentum(s->method, s->u, s->v, kinetic, &p, &l);
    *bound = s->kinetic0 + fmax(s->work, 0) + s->fixed_energy;
    return *kinetic <= 4 * *bound + s->energy_floor;
}

/* The elastic energy the start can release: 1/2 u^T K u of a deformed initial state (an upper
 * bound of its corotated energy), and 1/2 f^T K^-1 f, what the constant loads with prescribed
 * displacements release in the linear regime, in scenes that prescribe one (one factorisation;
 * the loads' own work is counted as it happens). */
static pf_status initial_energy(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->n;
    bool moves = false, deformed = false;
    for (int32_t k = 0; k < s->scene->n_fixed; ++k)
        moves |= pf_v3_max_abs(s->scene->fixed[k].displacement) > 0;
    for (size_t q = 0; q < n; ++q)
        deformed |= s->u[q] != 0;
    if (!moves && !deformed)
        return PF_OK;
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    memset(s->ku, 0, n * sizeof *s->ku);
    s->ops->stiffness(s->method, s->ku, false, &s->k, s->f);
    s->assembled = false;
    if (deformed) {
        pf_block_matrix_mul(&s->k, 1, s->u, 0, s->rhs);
        for (size_t q = 0; q < n; ++q)
            s->fixed_energy += 0.5 * s->u[q] * s->rhs[q];
    }
    if (!moves)
        return PF_OK;
    memset(s->ku, 0, n * sizeof *s->ku);
    PF_TRY(pf_solver_solve(s->solver, &s->k, PF_MATRIX_NEW, s->f, s->ku, NULL, err));
    pf_solver_reset(s->solver);
    double e = 0;
    for (size_t q = 0; q < n; ++q)
        e += 0.5 * s->f[q] * s->ku[q];
    s->fixed_energy += fabs(e);
    return PF_OK;
}

/* The energy check's starting values: the kinetic energy now, and the floor: 1e-12 of the body
 * moving its own size in a time step (kinetic energy below that is round-off). */
static void start_energy(pf_sim *s)
{
    pf_vec3 p, l;
    double a[9] = {0}, b[3] = {s->model_size / s->scene->dt, 0, 0}, t;
    s->ops->momentum(s->method, s->u, s->v, &s->kinetic0, &p, &l);
    s->ops->affine(s->method, a, b, s->rhs); /* a uniform velocity, for the body's mass */
    s->ops->momentum(s->method, s->u, s->rhs, &t, &p, &l);
    s->energy_floor = 1e-12 * t;
    s->work = 0;
    s->energy_started = true;
}

pf_status pf_sim_frame(pf_sim *s, pf_error *err)
{
    const pf_scene *sc = s->scene;
    size_t n = (size_t)s->n;
    if (!s->energy_started) {
        start_energy(s);
        pf_status st = initial_energy(s, err);
        if (st < 0) {
            pf_error_prefix(err, "energy of the initial state");
            return st;
        }
    }
    memcpy(s->u_prev, s->u, n * sizeof *s->u);
    memcpy(s->v_prev, s->v, n * sizeof *s->v);
    double h = sc->dt / sc->substeps, t_start = s->time;
    for (int32_t k = 0; k < sc->substeps; ++k) {
        pf_status st = step(s, h, err);
        double kinetic = 0, bound = 0;
        if (st >= 0 && !state_is_sane(s))
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the simulation diverged (element %d first)", (int)worst_element(s));
        else if (st >= 0 && k + 1 == sc->substeps && !energy_is_bounded(s, &kinetic, &bound))
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the simulation diverged: kinetic energy %.3g exceeds four times "
                              "what the body had and was given (%.3g), element %d moved most; "
                              "a larger penalty (DG), a smaller time step or more damping may "
                              "help",
                              kinetic, bound, (int)worst_element(s));
        if (st < 0) {
            memcpy(s->u, s->u_prev, n * sizeof *s->u);
            memcpy(s->v, s->v_prev, n * sizeof *s->v);
            pf_sim_forget_trend(s);
            pf_solver_reset(s->solver);
            s->assembled = false;
            pf_error_prefix(err, "frame %d, step %d", (int)s->frame + 1, (int)k + 1);
            return st;
        }
        s->time += h;
    }
    s->frame++;
    if (sc->n_cuts > 0) {
        pf_status st = pf_sim_apply_cuts(s, t_start, s->time, NULL, err);
        if (st < 0) {
            pf_error_prefix(err, "frame %d", (int)s->frame);
            return st;
        }
    }
    if (sc->refine.enabled) {
        pf_status st = pf_sim_refine(s, NULL, err);
        if (st < 0) {
            pf_error_prefix(err, "frame %d", (int)s->frame);
            return st;
        }
    }
    return PF_OK;
}

pf_status pf_sim_solve_static(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->n;
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    double t0 = pf_time_seconds(), cpu0 = pf_cpu_seconds();
    s->ops->stiffness(s->method, s->u, false, &s->k, s->f);
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    s->stats.assemble_cpu_seconds += pf_cpu_seconds() - cpu0;
    int64_t failed = -1;
    pf_status st = pf_solver_solve(s->solver, &s->k, PF_MATRIX_NEW, s->f, s->u, &failed, err);
    pf_sim_sync_solver_stats(s);
    if (st < 0) {
        if (failed >= 0)
            pf_error_prefix(err, "static solve, element %d",
                            (int)s->ops->element_of_dof(s->method, failed));
        else
            pf_error_prefix(err, "static solve");
        return st;
    }
    memset(s->v, 0, n * sizeof *s->v);
    s->assembled = false;
    pf_solver_reset(s->solver); /* its factor is K's, not the dynamic system's */
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

void pf_sim_principal_stresses(const pf_sim *s, double *value, pf_vec3 *direction)
{
    s->ops->principal_stresses(s->method, s->u, value, direction);
}

double pf_sim_load_work(const pf_sim *s)
{
    double w = 0;
    for (int64_t i = 0; i < s->n; ++i)
        w += s->f_ext[i] * s->u[i];
    return w;
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
    double volume = pf_mesh_volume(&moved);
    pf_free(x);
    return volume;
}

double pf_sim_max_node_jump(const pf_sim *s)
{
    return s->ops->max_node_jump(s->method, s->u);
}

double pf_sim_error_indicator(const pf_sim *s)
{
    return s->ops->error_indicator(s->method, s->u);
}

const char *pf_sim_error_measure(const pf_sim *s, const char **meaning)
{
    if (meaning)
        *meaning = s->ops->error_meaning;
    return s->ops->error_measure;
}
