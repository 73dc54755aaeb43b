/* The simulator: a scene on a mesh, DG method (Kaufmann et al. 2009).
 *
 * Dynamics: semi-implicit (linearly implicit) Euler on M a + D v + K u = f with Rayleigh damping
 * D = alpha M + beta K. With h = dt / substeps and K, f evaluated at the start of the step
 * (corotation warps K with the current element rotations and moves their constant part into f):
 *     ((1 + h alpha) M + (h beta + h^2) K) v' = M v + h (f - K u),     u' = u + h v'.
 * The matrix changes every step when corotation or contact is on: the pattern is analysed once,
 * the numeric factorisation redone per step; without either it is factored once.
 *
 * Contact with the ground plane n . p = d is a penalty at the mesh nodes, applied per element
 * with each element's own displacement at the node and weight 1 / (elements at the node), so the
 * coupling stays inside elements (the matrix pattern never changes) and a node shared by k
 * elements feels k_c in total. A node is in contact when its position predicted by the current
 * velocity lies below the plane; the force k_c (d - n . p) n is linear in u and treated
 * implicitly (DG paper sec. 8: K += k_c n n^T, f += k_c (d - n . x) n, through the basis). */
#include <pf/sim.h>

#include <math.h>
#include <string.h>

#include <pf/fem.h>

struct pf_sim {
    const pf_scene *scene;
    const pf_mesh *mesh;
    pf_dg dg;
    pf_dg_terms terms;
    int32_t *face_fixed;  /* [n mesh faces] fixed region index or -1 */
    double *fixed_affine; /* [12 n_fixed] */
    double *f_ext;        /* [n_dofs] loads and body forces, constant */
    double *x0;           /* rest coefficients */
    double *u, *v;        /* state */
    double *f, *ku, *rhs;
    double *u_prev, *v_prev; /* the state before the frame, restored on failure */
    double *rot;          /* [9 n_elems] */
    pf_block_matrix k;
    pf_cholesky *chol;
    bool factored_once;   /* linear, contact-free dynamics reuse the first factorisation */
    double ground_stiffness;
    pf_plane ground;
    double time;
    int32_t frame;
    pf_sim_stats stats;
};

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status select_faces(pf_sim *s, pf_error *err)
{
    const pf_scene *sc = s->scene;
    const pf_dg *dg = &s->dg;
    int32_t nf = s->mesh->n_faces;
    s->face_fixed = pf_alloc_array((size_t)nf, sizeof *s->face_fixed);
    s->fixed_affine = pf_calloc(12 * (size_t)(sc->n_fixed > 0 ? sc->n_fixed : 1), sizeof(double));
    PF_CHECK(s->face_fixed && s->fixed_affine, err, PF_ERR_NOMEM, "cannot allocate face flags");
    for (int32_t f = 0; f < nf; ++f)
        s->face_fixed[f] = -1;
    for (int32_t k = 0; k < sc->n_fixed; ++k) {
        s->fixed_affine[12 * k + 9] = sc->fixed[k].displacement.x;
        s->fixed_affine[12 * k + 10] = sc->fixed[k].displacement.y;
        s->fixed_affine[12 * k + 11] = sc->fixed[k].displacement.z;
    }
    for (int32_t q = dg->n_interior; q < dg->n_faces; ++q) {
        const pf_dg_face *face = &dg->faces[q];
        for (int32_t k = 0; k < sc->n_fixed; ++k)
            if (pf_region_contains(&sc->fixed[k].region, face->centroid)) {
                s->face_fixed[face->face] = k;
                s->stats.fixed_faces++;
                break;
            }
        bool loaded = false;
        for (int32_t k = 0; k < sc->n_loads; ++k)
            if (pf_region_contains(&sc->loads[k].region, face->centroid)) {
                pf_dg_add_traction(dg, face->face, sc->loads[k].traction, s->f_ext);
                loaded = true;
            }
        s->stats.loaded_faces += loaded;
    }
    pf_vec3 body = pf_v3_add(pf_v3_scale(sc->gravity, sc->density), sc->body_force);
    if (body.x != 0 || body.y != 0 || body.z != 0)
        pf_dg_add_body_force(dg, body, s->f_ext);
    return PF_OK;
}

static pf_status allocate_state(pf_sim *s, pf_error *err)
{
    size_t n = (size_t)s->dg.n_dofs;
    double **vectors[] = {&s->f_ext, &s->x0, &s->u, &s->v, &s->f, &s->ku, &s->rhs, &s->u_prev, &s->v_prev};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k) {
        *vectors[k] = pf_calloc(n ? n : 1, sizeof(double));
        PF_CHECK(*vectors[k], err, PF_ERR_NOMEM, "cannot allocate %zu unknowns", n);
    }
    s->rot = pf_alloc_array(9 * (size_t)(s->dg.n_elems ? s->dg.n_elems : 1), sizeof *s->rot);
    PF_CHECK(s->rot, err, PF_ERR_NOMEM, "cannot allocate rotations");
    pf_dg_rest_coefficients(&s->dg, s->x0);
    return PF_OK;
}

/* A shift that lifts the six rigid modes of a free body without hiding a real indefiniteness:
 * 1e-6 of the stiffest element's K/M ratio (lambda + 2 mu) / (rho h^2). */
static double rigid_mode_shift(const pf_sim *s)
{
    double h = INFINITY;
    for (int32_t e = 0; e < s->dg.n_elems; ++e)
        h = fmin(h, s->dg.frame[e].scale);
    return 1e-6 * (s->dg.lambda + 2 * s->dg.mu) / (s->dg.density * h * h);
}

static pf_status factor_timed(pf_sim *s, int64_t *failed, pf_error *err)
{
    double t0 = pf_time_seconds();
    pf_status st = pf_cholesky_factor(s->chol, &s->k, failed, err);
    s->stats.factor_seconds += pf_time_seconds() - t0;
    s->stats.factorisations++;
    return st;
}

/* Sec. 9.1: start low and double eta until the stiffness is positive definite. */
static pf_status choose_penalty(pf_sim *s, pf_error *err)
{
    if (s->scene->penalty > 0) {
        s->terms.eta = s->scene->penalty;
        return PF_OK;
    }
    double shift = rigid_mode_shift(s);
    for (s->terms.eta = 1; s->terms.eta <= 1048576; s->terms.eta *= 2) {
        memset(s->f, 0, (size_t)s->dg.n_dofs * sizeof *s->f);
        pf_dg_assemble_stiffness(&s->dg, &s->terms, NULL, NULL, &s->k, s->f);
        pf_dg_add_mass(&s->dg, shift, &s->k);
        pf_error ignored = {0};
        if (factor_timed(s, NULL, &ignored) == PF_OK)
            return PF_OK;
        s->stats.penalty_doublings++;
    }
    return pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                        "no penalty up to 2^20 makes the stiffness positive definite: the mesh "
                        "has degenerate elements");
}

/* The automatic ground stiffness: ten times an element's stiffness (lambda + 2 mu) h. */
static double ground_stiffness(const pf_sim *s)
{
    if (s->scene->ground_stiffness > 0)
        return s->scene->ground_stiffness;
    double h = 0;
    for (int32_t e = 0; e < s->dg.n_elems; ++e)
        h += s->dg.frame[e].scale;
    h /= s->dg.n_elems > 0 ? s->dg.n_elems : 1;
    return 10 * (s->dg.lambda + 2 * s->dg.mu) * h;
}

pf_status pf_sim_create(pf_sim **out, const pf_scene *scene, const pf_mesh *mesh, pf_error *err)
{
    *out = NULL;
    PF_CHECK(scene->method == PF_METHOD_DG, err, PF_ERR_UNSUPPORTED,
             "method cg (harmonic basis) is not available yet; use method dg");
    double t0 = pf_time_seconds();
    pf_sim *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate the simulator");
    s->scene = scene;
    s->mesh = mesh;
    pf_status st = pf_dg_create(&s->dg, mesh, scene->degree, scene->E, scene->nu, scene->density,
                                err);
    if (st >= 0)
        st = allocate_state(s, err);
    if (st >= 0)
        st = select_faces(s, err);
    if (st >= 0 && scene->is_static && s->stats.fixed_faces == 0)
        st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                          "a static scene needs fixed faces: no boundary face centroid lies in "
                          "any 'fixed' region");
    if (st >= 0) {
        s->terms.ip = scene->flux == PF_FLUX_IP;
        s->terms.face_fixed = s->face_fixed;
        s->terms.fixed_disp = s->fixed_affine;
        st = pf_dg_pattern(&s->dg, &s->k, err);
    }
    if (st >= 0)
        st = pf_cholesky_create(&s->chol, &s->k, err);
    if (st >= 0)
        st = choose_penalty(s, err);
    if (st < 0) {
        pf_sim_destroy(&s);
        return st;
    }
    s->ground_stiffness = ground_stiffness(s);
    s->ground = pf_plane_from_point_normal(scene->ground_point, scene->ground_normal);
    s->stats.dofs = s->dg.n_dofs;
    s->stats.matrix_nnz = s->k.col_ptr[s->k.n];
    s->stats.factor_nnz = pf_cholesky_factor_nnz(s->chol);
    s->stats.penalty = s->terms.eta;
    s->stats.setup_seconds = pf_time_seconds() - t0;
    *out = s;
    return PF_OK;
}

void pf_sim_destroy(pf_sim **sim)
{
    pf_sim *s = *sim;
    if (!s)
        return;
    pf_dg_release(&s->dg);
    pf_free(s->face_fixed);
    pf_free(s->fixed_affine);
    double *vectors[] = {s->f_ext, s->x0, s->u, s->v, s->f, s->ku, s->rhs, s->u_prev, s->v_prev, s->rot};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k)
        pf_free(vectors[k]);
    pf_block_matrix_release(&s->k);
    pf_cholesky_destroy(&s->chol);
    pf_free(s);
    *sim = NULL;
}

/* ---- one step ---------------------------------------------------------------------------- */

/* Element rotations from the linear part of each element's displacement (sec. 6.1). */
static void update_rotations(pf_sim *s)
{
    for (int32_t e = 0; e < s->dg.n_elems; ++e) {
        double g[9];
        pf_dg_gradient(&s->dg, s->u, e, g);
        pf_mat3 f;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                f.m[i][j] = (i == j) + g[3 * i + j];
        pf_mat3 r = pf_mat3_polar_rotation(f);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                s->rot[9 * e + 3 * i + j] = r.m[i][j];
    }
}

/* Ground contact at the nodes, per element (see the file comment); adds to k and f. */
static void add_ground_contact(pf_sim *s, double h)
{
    const pf_dg *dg = &s->dg;
    int nb = dg->nb, n = 3 * nb;
    pf_vec3 nrm = s->ground.n;
    double nn[3] = {nrm.x, nrm.y, nrm.z};
    double block[30 * 30];
    for (int32_t i = 0; i < dg->n_nodes; ++i) {
        int64_t begin = dg->node_offsets[i], end = dg->node_offsets[i + 1];
        if (end == begin)
            continue;
        const double *xi = s->mesh->x + 3 * (size_t)i;
        double w = s->ground_stiffness / (double)(end - begin);
        for (int64_t q = begin; q < end; ++q) {
            int32_t e = dg->node_elem[q];
            const double *phi = dg->node_phi + (size_t)q * nb;
            const double *ue = s->u + (size_t)e * n, *ve = s->v + (size_t)e * n;
            double pred = 0, rest = 0; /* n . (x + u + h v) and n . x */
            for (int c = 0; c < 3; ++c) {
                double uc = 0, vc = 0;
                for (int a = 0; a < nb; ++a) {
                    uc += phi[a] * ue[3 * a + c];
                    vc += phi[a] * ve[3 * a + c];
                }
                pred += nn[c] * (xi[c] + uc + h * vc);
                rest += nn[c] * xi[c];
            }
            if (pred >= s->ground.d)
                continue;
            s->stats.contacts++;
            for (int a = 0; a < nb; ++a) {
                for (int b = 0; b < nb; ++b)
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c)
                            block[(3 * a + r) * n + 3 * b + c] = w * phi[a] * phi[b] * nn[r] * nn[c];
                for (int r = 0; r < 3; ++r)
                    s->f[(size_t)e * n + 3 * a + r] += w * (s->ground.d - rest) * nn[r] * phi[a];
            }
            pf_block_matrix_add(&s->k, pf_block_matrix_slot(&s->k, e, e), e, e, block, n);
        }
    }
}

/* The element whose coefficients first went non-finite, or the one that moved most. */
static int32_t worst_element(const pf_sim *s, const double *u)
{
    int n = 3 * s->dg.nb;
    int32_t worst = 0;
    double largest = -1;
    for (int32_t e = 0; e < s->dg.n_elems; ++e)
        for (int q = 0; q < n; ++q) {
            double x = u[(size_t)e * n + q];
            if (!isfinite(x))
                return e;
            if (fabs(x) > largest)
                largest = fabs(x), worst = e;
        }
    return worst;
}

/* A state is broken when it holds a non-finite number, or a displacement above 1e3 model sizes
 * (nothing physical moves a body a thousand times its size within one frame of a drop). */
static bool state_is_sane(const pf_sim *s, double model_size)
{
    for (int64_t q = 0; q < s->dg.n_dofs; ++q)
        if (!isfinite(s->u[q]) || !isfinite(s->v[q]) || fabs(s->u[q]) > 1e3 * model_size)
            return false;
    return true;
}

static pf_status step(pf_sim *s, double h, pf_error *err)
{
    const pf_scene *sc = s->scene;
    size_t n = (size_t)s->dg.n_dofs;
    double t0 = pf_time_seconds();
    const double *rot = NULL;
    if (sc->corotation) {
        update_rotations(s);
        rot = s->rot;
    }
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    pf_dg_assemble_stiffness(&s->dg, &s->terms, rot, s->x0, &s->k, s->f);
    int64_t contacts_before = s->stats.contacts;
    if (sc->ground)
        add_ground_contact(s, h);
    bool contact = s->stats.contacts != contacts_before;
    /* rhs = M v + h (f - K u); then k := (h beta + h^2) K + (1 + h alpha) M */
    pf_block_matrix_mul(&s->k, 1, s->u, 0, s->ku);
    for (size_t q = 0; q < n; ++q)
        s->rhs[q] = h * (s->f[q] - s->ku[q]);
    pf_dg_mass_mul(&s->dg, 1, s->v, s->rhs);
    bool refactor = sc->corotation || contact || !s->factored_once;
    if (refactor) {
        double kscale = h * sc->damping_beta + h * h;
        for (int64_t q = 0; q < s->k.col_ptr[s->k.n]; ++q)
            s->k.val[q] *= kscale;
        pf_dg_add_mass(&s->dg, 1 + h * sc->damping_alpha, &s->k);
    }
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    if (refactor) {
        int64_t failed = -1;
        pf_status st = factor_timed(s, &failed, err);
        if (st < 0) {
            s->factored_once = false;
            pf_error_prefix(err, "element %d", (int)(failed / (3 * s->dg.nb)));
            return st;
        }
        /* Linear dynamics without contact keep this factorisation; with contact it changes. */
        s->factored_once = !sc->corotation && !contact;
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
    size_t n = (size_t)s->dg.n_dofs;
    memcpy(s->u_prev, s->u, n * sizeof *s->u);
    memcpy(s->v_prev, s->v, n * sizeof *s->v);
    pf_vec3 lo, hi;
    pf_mesh_bounds(s->mesh, &lo, &hi);
    double size = pf_v3_norm(pf_v3_sub(hi, lo));
    double h = sc->dt / sc->substeps;
    for (int32_t k = 0; k < sc->substeps; ++k) {
        pf_status st = step(s, h, err);
        if (st >= 0 && !state_is_sane(s, size))
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "the simulation diverged (element %d first)",
                              (int)worst_element(s, s->u));
        if (st < 0) {
            memcpy(s->u, s->u_prev, n * sizeof *s->u);
            memcpy(s->v, s->v_prev, n * sizeof *s->v);
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
    size_t n = (size_t)s->dg.n_dofs;
    memcpy(s->f, s->f_ext, n * sizeof *s->f);
    double t0 = pf_time_seconds();
    pf_dg_assemble_stiffness(&s->dg, &s->terms, NULL, NULL, &s->k, s->f);
    s->stats.assemble_seconds += pf_time_seconds() - t0;
    int64_t failed = -1;
    pf_status st = factor_timed(s, &failed, err);
    if (st < 0) {
        pf_error_prefix(err, "static solve, element %d", (int)(failed / (3 * s->dg.nb)));
        return st;
    }
    double t1 = pf_time_seconds();
    PF_TRY(pf_cholesky_solve(s->chol, s->f, s->u, err));
    s->stats.solve_seconds += pf_time_seconds() - t1;
    memset(s->v, 0, n * sizeof *s->v);
    for (size_t q = 0; q < n; ++q)
        PF_CHECK(isfinite(s->u[q]), err, PF_ERR_NUMERIC,
                 "static solve gave a non-finite displacement in element %d",
                 (int)(q / (size_t)(3 * s->dg.nb)));
    s->frame++;
    return PF_OK;
}

/* ---- output and diagnostics -------------------------------------------------------------- */

double pf_sim_time(const pf_sim *s) { return s->time; }
int32_t pf_sim_frame_index(const pf_sim *s) { return s->frame; }
const pf_sim_stats *pf_sim_get_stats(const pf_sim *s) { return &s->stats; }

void pf_sim_nodal_displacements(const pf_sim *s, double *out)
{
    pf_dg_stitch(&s->dg, s->u, out);
}

void pf_sim_von_mises(const pf_sim *s, double *out)
{
    double lambda = s->dg.lambda, mu = s->dg.mu;
    for (int32_t e = 0; e < s->dg.n_elems; ++e) {
        double g[9];
        pf_dg_gradient(&s->dg, s->u, e, g);
        pf_mat3 f;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                f.m[i][j] = (i == j) + g[3 * i + j];
        /* corotated strain: the symmetric part of R^T F - I */
        pf_mat3 rf = pf_m3_mul(pf_m3_transpose(pf_mat3_polar_rotation(f)), f);
        double eps[3][3];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                eps[i][j] = 0.5 * (rf.m[i][j] + rf.m[j][i]) - (i == j);
        double tr = eps[0][0] + eps[1][1] + eps[2][2];
        double sigma[6] = {lambda * tr + 2 * mu * eps[0][0], lambda * tr + 2 * mu * eps[1][1],
                           lambda * tr + 2 * mu * eps[2][2], 2 * mu * eps[0][1],
                           2 * mu * eps[1][2],              2 * mu * eps[2][0]};
        out[e] = pf_von_mises(sigma);
    }
}

void pf_sim_momentum(const pf_sim *s, double *kinetic, pf_vec3 *linear, pf_vec3 *angular)
{
    const pf_dg *dg = &s->dg;
    int nb = dg->nb, n = 3 * nb;
    double ke = 0;
    pf_vec3 p = {0, 0, 0}, l = {0, 0, 0};
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const double *me = dg->me + (size_t)e * nb * nb;
        const double *ve = s->v + (size_t)e * n, *ue = s->u + (size_t)e * n;
        const double *xe = s->x0 + (size_t)e * n;
        for (int a = 0; a < nb; ++a)
            for (int b = 0; b < nb; ++b) {
                double m = me[a * nb + b];
                pf_vec3 va = {ve[3 * a], ve[3 * a + 1], ve[3 * a + 2]};
                pf_vec3 vb = {ve[3 * b], ve[3 * b + 1], ve[3 * b + 2]};
                pf_vec3 xa = {xe[3 * a] + ue[3 * a], xe[3 * a + 1] + ue[3 * a + 1],
                              xe[3 * a + 2] + ue[3 * a + 2]};
                ke += 0.5 * m * pf_v3_dot(va, vb);
                if (a == 0) /* phi_0 = 1: int rho v = sum_b v_b int rho phi_b */
                    p = pf_v3_add(p, pf_v3_scale(vb, m));
                l = pf_v3_add(l, pf_v3_scale(pf_v3_cross(xa, vb), m));
            }
    }
    *kinetic = ke;
    *linear = p;
    *angular = l;
}

void pf_sim_set_rigid_velocity(pf_sim *s, pf_vec3 w, pf_vec3 c, pf_vec3 v0)
{
    /* v(x) = w x (x - c) + v0 = W x + (v0 - W c), W the cross-product matrix of w */
    double a[9] = {0, -w.z, w.y, w.z, 0, -w.x, -w.y, w.x, 0};
    pf_vec3 wc = pf_v3_cross(w, c);
    double b[3] = {v0.x - wc.x, v0.y - wc.y, v0.z - wc.z};
    pf_dg_affine_coefficients(&s->dg, a, b, s->v);
}

void pf_sim_set_affine_displacement(pf_sim *s, const double a[9], const double b[3])
{
    pf_dg_affine_coefficients(&s->dg, a, b, s->u);
}

double pf_sim_deformed_volume(const pf_sim *s)
{
    const pf_mesh *m = s->mesh;
    double *x = pf_alloc_array(3 * (size_t)m->n_nodes, sizeof *x);
    if (!x)
        return NAN;
    pf_dg_stitch(&s->dg, s->u, x);
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
    const pf_dg *dg = &s->dg;
    int nb = dg->nb, n = 3 * nb;
    double *stitched = pf_alloc_array(3 * (size_t)dg->n_nodes, sizeof *stitched);
    if (!stitched)
        return NAN;
    pf_dg_stitch(dg, s->u, stitched);
    double largest = 0;
    for (int32_t i = 0; i < dg->n_nodes; ++i)
        for (int64_t q = dg->node_offsets[i]; q < dg->node_offsets[i + 1]; ++q) {
            const double *ue = s->u + (size_t)dg->node_elem[q] * n;
            const double *phi = dg->node_phi + (size_t)q * nb;
            double d2 = 0;
            for (int c = 0; c < 3; ++c) {
                double value = 0;
                for (int a = 0; a < nb; ++a)
                    value += phi[a] * ue[3 * a + c];
                double d = value - stitched[3 * (size_t)i + c];
                d2 += d * d;
            }
            largest = fmax(largest, sqrt(d2));
        }
    pf_free(stitched);
    return largest;
}
