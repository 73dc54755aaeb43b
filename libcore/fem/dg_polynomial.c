/* Polynomial data for the DG discretisation: body forces, weak Dirichlet loads and L2 errors of
 * fields that are polynomials of the position (manufactured solutions, DG paper sec. 9 style
 * accuracy studies). The data polynomial is rewritten in the frame of the element it meets
 * (pf_poly_monomial_in_frame), where the basis functions are plain monomials; then every
 * integral is a sum of element or face moments in that frame, exact like the element terms.
 * Degrees: data <= 4, basis <= 2, so products stay within PF_MOMENT_MAX_DEGREE = 8.
 * Also the fields carried from one mesh to the next when the simulation mesh changes: a parent's
 * polynomial re-expanded in a child's frame (refinement), the L2 projection of merged children
 * onto their parent (coarsening), and gradients at any point (the refinement criterion). */
#include <pf/fem.h>

#include <math.h>
#include <string.h>

/* Exponents of the monomials up to PF_MOMENT_MAX_DEGREE, filled once per call (no global). */
typedef struct exponent_table {
    int e[PF_MOMENT_MAX_COUNT][3];
} exponent_table;

static void fill_exponents(exponent_table *t)
{
    for (int k = 0; k < PF_MOMENT_MAX_COUNT; ++k)
        pf_moment_exponents(k, &t->e[k][0], &t->e[k][1], &t->e[k][2]);
}

/* Index of the product of monomials k and l (exponents added). */
static int product_of(const exponent_table *t, int k, int l)
{
    return pf_moment_index(t->e[k][0] + t->e[l][0], t->e[k][1] + t->e[l][1],
                           t->e[k][2] + t->e[l][2]);
}

/* int c(xhat) m_l(xhat) from moments m (degree >= deg c + deg m_l), c of degree `degree`. */
static double integrate_times_monomial(const exponent_table *t, const double *c, int degree, int l,
                                       const double *m)
{
    double s = 0;
    for (int k = 0; k < pf_moment_count(degree); ++k)
        if (c[k] != 0)
            s += c[k] * m[product_of(t, k, l)];
    return s;
}

static pf_status check_poly(const pf_poly3 *p, pf_error *err)
{
    PF_CHECK(p->degree >= 0 && p->degree <= PF_POLY3_MAX_DEGREE, err, PF_ERR_INVALID,
             "polynomial degree %d outside [0, %d]", (int)p->degree, PF_POLY3_MAX_DEGREE);
    PF_CHECK(isfinite(p->frame.scale) && p->frame.scale > 0, err, PF_ERR_INVALID,
             "polynomial frame scale %g is not finite and positive", p->frame.scale);
    return PF_OK;
}

/* The components of p written in frame `to`: out[i] has pf_moment_count(p->degree) entries. */
static void poly3_in_frame(const pf_poly3 *p, const pf_frame *to, double out[3][PF_POLY3_MAX_COUNT])
{
    int n = pf_moment_count(p->degree);
    memset(out, 0, 3 * sizeof out[0]);
    for (int k = 0; k < n; ++k) {
        if (p->c[0][k] == 0 && p->c[1][k] == 0 && p->c[2][k] == 0)
            continue;
        double mono[PF_POLY3_MAX_COUNT]; /* monomial k of p's frame, in frame `to` */
        pf_poly_monomial_in_frame(k, &p->frame, to, mono);
        int a, b, c;
        pf_moment_exponents(k, &a, &b, &c);
        for (int q = 0; q < pf_moment_count(a + b + c); ++q)
            for (int i = 0; i < 3; ++i)
                out[i][q] += p->c[i][k] * mono[q];
    }
}

pf_vec3 pf_poly3_eval(const pf_poly3 *p, pf_vec3 x)
{
    double v[PF_POLY3_MAX_COUNT];
    pf_vec3 local = pf_v3_scale(pf_v3_sub(x, p->frame.center), 1 / p->frame.scale);
    pf_moment_monomials(local, p->degree, v);
    double r[3] = {0, 0, 0};
    for (int k = 0; k < pf_moment_count(p->degree); ++k)
        for (int i = 0; i < 3; ++i)
            r[i] += p->c[i][k] * v[k];
    return (pf_vec3){r[0], r[1], r[2]};
}

/* Moments of element e of m up to `degree`, in dg's frame of e. */
static pf_status element_moments(const pf_dg *dg, const pf_mesh *m, int32_t e, int degree,
                                 pf_arena *arena, double *mom, pf_error *err)
{
    size_t mark = pf_arena_mark(arena);
    pf_polyhedron p;
    pf_status s = pf_mesh_elem_polyhedron(m, e, arena, &p, err);
    if (s >= 0)
        s = pf_polyhedron_moments(&p, &dg->frame[e], degree, mom, err);
    pf_arena_reset(arena, mark);
    if (s < 0)
        pf_error_prefix(err, "element %d", (int)e);
    return s;
}

static pf_status check_mesh(const pf_dg *dg, const pf_mesh *m, pf_error *err)
{
    PF_CHECK(m->n_elems == dg->n_elems && m->n_faces == dg->n_faces, err, PF_ERR_INVALID,
             "mesh of %d elements and %d faces is not the DG's (%d, %d)", (int)m->n_elems,
             (int)m->n_faces, (int)dg->n_elems, (int)dg->n_faces);
    return PF_OK;
}

pf_status pf_dg_add_polynomial_body_force(const pf_dg *dg, const pf_mesh *m, const pf_poly3 *f,
                                          double *rhs, pf_error *err)
{
    PF_TRY(check_poly(f, err));
    PF_TRY(check_mesh(dg, m, err));
    exponent_table t;
    fill_exponents(&t);
    pf_arena arena;
    PF_TRY(pf_arena_init(&arena, (size_t)1 << 20, err));
    int nb = dg->nb;
    pf_status s = PF_OK;
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        double mom[PF_MOMENT_MAX_COUNT];
        s = element_moments(dg, m, e, f->degree + dg->degree, &arena, mom, err);
        if (s < 0)
            break;
        double local[3][PF_POLY3_MAX_COUNT];
        poly3_in_frame(f, &dg->frame[e], local);
        /* int_K f_i phi_a: phi_a is monomial a of the element frame */
        for (int a = 0; a < nb; ++a)
            for (int i = 0; i < 3; ++i)
                rhs[3 * ((size_t)e * nb + a) + i] +=
                    integrate_times_monomial(&t, local[i], f->degree, a, mom);
    }
    pf_arena_release(&arena);
    return s;
}

/* Weak Dirichlet load (pf/fem.h), with v = phi_b e_k and sigma(v) n =
 * lambda d_k phi_b n + mu (e_k (grad phi_b . n) + grad phi_b n_k):
 *   -int g . sigma(v) n = -(lambda sum_i n_i D_ik + mu (sum_j n_j D_kj + n_k sum_j D_jj)),
 *     D_ij = int g_i d_j phi_b                     (the consistency term of eq. 24, u = g outside)
 *   eta eta_f (2 mu P_k + lambda n_k (n . P)),   P_i = int g_i phi_b   (eq. 26). */
pf_status pf_dg_add_polynomial_dirichlet(const pf_dg *dg, const pf_mesh *m,
                                         const pf_dg_terms *terms, int32_t mesh_face,
                                         const pf_poly3 *g, double *rhs, pf_error *err)
{
    PF_TRY(check_poly(g, err));
    PF_TRY(check_mesh(dg, m, err));
    PF_CHECK(mesh_face >= 0 && mesh_face < dg->n_faces, err, PF_ERR_INVALID,
             "face %d out of range [0, %d)", (int)mesh_face, (int)dg->n_faces);
    const pf_dg_face *fc = &dg->faces[dg->face_slot[mesh_face]];
    PF_CHECK(fc->elem[1] < 0, err, PF_ERR_INVALID, "face %d is not on the boundary",
             (int)mesh_face);
    int32_t e = fc->elem[0];
    const pf_frame *fr = &dg->frame[e];
    int nb = dg->nb;
    const uint32_t *idx = m->face_nodes + m->face_offsets[mesh_face];
    int64_t count = m->face_offsets[mesh_face + 1] - m->face_offsets[mesh_face];
    double mom[PF_MOMENT_MAX_COUNT];
    pf_status s = pf_polygon_moments(m->x, idx, count, fr, g->degree + dg->degree, mom, err);
    if (s < 0) {
        pf_error_prefix(err, "face %d", (int)mesh_face);
        return s;
    }
    exponent_table t;
    fill_exponents(&t);
    double local[3][PF_POLY3_MAX_COUNT];
    poly3_in_frame(g, fr, local);
    const double n[3] = {fc->normal.x, fc->normal.y, fc->normal.z};
    double penalty = pf_dg_face_penalty(terms, fc);
    double *fe = rhs + 3 * (size_t)e * nb;
    for (int b = 0; b < nb; ++b) {
        double p[3];
        for (int i = 0; i < 3; ++i)
            p[i] = integrate_times_monomial(&t, local[i], g->degree, b, mom);
        double np = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
        double d[3][3] = {{0}}; /* d_j phi_b = e_b[j] / h m_(b lowered in j) */
        for (int j = 0; j < 3; ++j) {
            if (t.e[b][j] == 0)
                continue;
            int low[3] = {t.e[b][0], t.e[b][1], t.e[b][2]};
            low[j]--;
            int l = pf_moment_index(low[0], low[1], low[2]);
            for (int i = 0; i < 3; ++i)
                d[i][j] = t.e[b][j] / fr->scale *
                          integrate_times_monomial(&t, local[i], g->degree, l, mom);
        }
        double trace = d[0][0] + d[1][1] + d[2][2];
        double lambda = pf_dg_material(dg, e)->lambda, mu = pf_dg_material(dg, e)->mu;
        for (int k = 0; k < 3; ++k) {
            double load = penalty * (2 * mu * p[k] + lambda * n[k] * np);
            if (terms->ip)
                load -= lambda * (n[0] * d[0][k] + n[1] * d[1][k] + n[2] * d[2][k]) +
                        mu * (n[0] * d[k][0] + n[1] * d[k][1] + n[2] * d[k][2] + n[k] * trace);
            fe[3 * b + k] += load;
        }
    }
    return PF_OK;
}

pf_status pf_dg_l2_error(const pf_dg *dg, const pf_mesh *m, const double *u, const pf_poly3 *exact,
                         double *error, double *norm, pf_error *err)
{
    PF_TRY(check_poly(exact, err));
    PF_TRY(check_mesh(dg, m, err));
    pf_arena arena;
    PF_TRY(pf_arena_init(&arena, (size_t)1 << 20, err));
    int nb = dg->nb;
    int degree = exact->degree > dg->degree ? exact->degree : dg->degree;
    double sum_error = 0, sum_norm = 0;
    pf_status s = PF_OK;
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        double mom[PF_MOMENT_MAX_COUNT];
        s = element_moments(dg, m, e, 2 * degree, &arena, mom, err);
        if (s < 0)
            break;
        double local[3][PF_POLY3_MAX_COUNT], diff[PF_POLY3_MAX_COUNT];
        poly3_in_frame(exact, &dg->frame[e], local);
        const double *ue = u + 3 * (size_t)e * nb;
        for (int i = 0; i < 3; ++i) {
            /* u_h - u in the element frame, then int (u_h - u)^2 from the moments of degree 2d */
            for (int k = 0; k < pf_moment_count(degree); ++k)
                diff[k] = (k < nb ? ue[3 * k + i] : 0) -
                          (k < pf_moment_count(exact->degree) ? local[i][k] : 0);
            sum_error += fmax(0, pf_poly_integrate_product(diff, degree, diff, degree, mom));
            sum_norm += fmax(0, pf_poly_integrate_product(local[i], exact->degree, local[i],
                                                          exact->degree, mom));
        }
    }
    pf_arena_release(&arena);
    if (s < 0)
        return s;
    *error = sqrt(sum_error);
    if (norm)
        *norm = sqrt(sum_norm);
    return PF_OK;
}

void pf_dg_gradient_at(const pf_dg *dg, const double *u, int32_t e, pf_vec3 x, double g[9])
{
    const pf_frame *fr = &dg->frame[e];
    pf_vec3 p = pf_v3_scale(pf_v3_sub(x, fr->center), 1 / fr->scale);
    double m[10]; /* the monomials of degree <= 1 at p: d/dx_j of x^a y^b z^c needs them */
    pf_moment_monomials(p, 1, m);
    const double *ue = u + 3 * (size_t)e * dg->nb;
    memset(g, 0, 9 * sizeof *g);
    for (int k = 1; k < dg->nb; ++k) {
        int ex[3];
        pf_moment_exponents(k, &ex[0], &ex[1], &ex[2]);
        for (int j = 0; j < 3; ++j) {
            if (ex[j] == 0)
                continue;
            int lower[3] = {ex[0], ex[1], ex[2]};
            lower[j]--;
            double d = ex[j] * m[pf_moment_index(lower[0], lower[1], lower[2])] / fr->scale;
            for (int i = 0; i < 3; ++i)
                g[3 * i + j] += ue[3 * k + i] * d;
        }
    }
}

void pf_dg_copy_field(const pf_dg *src, const double *u_src, int32_t p, const pf_dg *dst, int32_t e,
                      double *u_dst)
{
    int nb = dst->nb;
    const double *up = u_src + 3 * (size_t)p * nb;
    double *ue = u_dst + 3 * (size_t)e * nb;
    const pf_frame *from = &src->frame[p], *to = &dst->frame[e];
    if (from->scale == to->scale && pf_v3_max_abs(pf_v3_sub(from->center, to->center)) == 0) {
        memcpy(ue, up, 3 * (size_t)nb * sizeof *ue);
        return;
    }
    memset(ue, 0, 3 * (size_t)nb * sizeof *ue);
    for (int a = 0; a < nb; ++a) {
        double c[10] = {0};
        pf_poly_monomial_in_frame(a, from, to, c);
        for (int b = 0; b < nb; ++b)
            for (int i = 0; i < 3; ++i)
                ue[3 * b + i] += c[b] * up[3 * a + i];
    }
}

/* Solves a x = b (a symmetric positive definite, n x n row-major, overwritten by its Cholesky
 * factor; b by x). false when a pivot is not positive. */
static bool solve_spd(double *a, int n, double *b, int nrhs)
{
    for (int j = 0; j < n; ++j) {
        double d = a[j * n + j];
        for (int k = 0; k < j; ++k)
            d -= a[j * n + k] * a[j * n + k];
        if (!(d > 0))
            return false;
        a[j * n + j] = sqrt(d);
        for (int i = j + 1; i < n; ++i) {
            double v = a[i * n + j];
            for (int k = 0; k < j; ++k)
                v -= a[i * n + k] * a[j * n + k];
            a[i * n + j] = v / a[j * n + j];
        }
    }
    for (int r = 0; r < nrhs; ++r) {
        for (int i = 0; i < n; ++i) { /* L y = b */
            double v = b[i * nrhs + r];
            for (int k = 0; k < i; ++k)
                v -= a[i * n + k] * b[k * nrhs + r];
            b[i * nrhs + r] = v / a[i * n + i];
        }
        for (int i = n - 1; i >= 0; --i) { /* L^T x = y */
            double v = b[i * nrhs + r];
            for (int k = i + 1; k < n; ++k)
                v -= a[k * n + i] * b[k * nrhs + r];
            b[i * nrhs + r] = v / a[i * n + i];
        }
    }
    return true;
}

pf_status pf_dg_project_field(const pf_dg *src, const pf_mesh *src_mesh, const double *u_src,
                              const int32_t *q, int32_t n, const pf_dg *dst, int32_t e,
                              double *u_dst, pf_error *err)
{
    int nb = dst->nb, p = dst->degree;
    const pf_frame *to = &dst->frame[e];
    double rhs[10 * 3] = {0}, mass[10 * 10];
    memcpy(mass, dst->me + (size_t)e * nb * nb, (size_t)nb * nb * sizeof *mass);
    pf_arena arena;
    PF_TRY(pf_arena_init(&arena, (size_t)1 << 16, err));
    pf_status st = PF_OK;
    for (int32_t k = 0; k < n && st >= 0; ++k) {
        /* int_q rho phi^e_a u_q = rho sum_b u_{q,b} int_q phi^e_a phi^q_b, phi^q_b re-expanded
         * in e's frame, over q's moments in e's frame */
        pf_polyhedron poly;
        double m[PF_MOMENT_MAX_COUNT];
        size_t mark = pf_arena_mark(&arena);
        st = pf_mesh_elem_polyhedron(src_mesh, q[k], &arena, &poly, err);
        if (st >= 0)
            st = pf_polyhedron_moments(&poly, to, 2 * p, m, err);
        pf_arena_reset(&arena, mark);
        if (st < 0) {
            pf_error_prefix(err, "element %d", (int)q[k]);
            break;
        }
        const double *uq = u_src + 3 * (size_t)q[k] * nb;
        for (int b = 0; b < nb; ++b) {
            double cb[10] = {0};
            pf_poly_monomial_in_frame(b, &src->frame[q[k]], to, cb);
            for (int a = 0; a < nb; ++a) {
                double ea[10] = {0};
                ea[a] = 1;
                double w = pf_dg_material(src, q[k])->density *
                           pf_poly_integrate_product(ea, p, cb, p, m);
                for (int i = 0; i < 3; ++i)
                    rhs[3 * a + i] += w * uq[3 * b + i];
            }
        }
    }
    pf_arena_release(&arena);
    PF_TRY(st);
    PF_CHECK(solve_spd(mass, nb, rhs, 3), err, PF_ERR_NUMERIC,
             "element %d: the mass matrix is not positive definite", (int)e);
    memcpy(u_dst + 3 * (size_t)e * nb, rhs, 3 * (size_t)nb * sizeof *u_dst);
    return PF_OK;
}
