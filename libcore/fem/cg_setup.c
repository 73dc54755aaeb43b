/* CG set-up: shape functions (pf/basis.h) and the element matrices of the harmonic paper, sec. 6,
 * computed once from the rest state.
 *
 * For every rule point (x, w) with values N_a and gradients g_a = grad N_a:
 *   D_ab[i][j] += w g_a,i g_b,j,   M_ab += w rho N_a N_b,   int N_a += w N_a,
 * and K_e[(a i), (b j)] = lambda D_ab[i][j] + mu (delta_ij tr D_ab + D_ab[j][i]), the isotropic
 * form of int B^T C B (eq. 15). Rules: tets in closed form, parallelepiped hexes the 2 x 2 x 2
 * Gauss product in reference coordinates (N_a trilinear: every product of two values or two
 * gradient components has degree <= 2 per reference coordinate, which 2 points integrate
 * exactly), harmonic elements pf_polyhedron_quadrature. */
#include <pf/fem.h>

#include "fem_internal.h"

#include <math.h>
#include <string.h>

#include <cblas.h>

pf_cg_params pf_cg_params_default(void)
{
    pf_cg_params p = {0};
    /* Uniform samples: the degree-2 rule's error on graded kernels (8-12 % of K_e on sliced
     * cells) would exceed what the sliced-cell settings gain (docs/basis.md). */
    p.basis = pf_basis_params_uniform();
    p.quadrature_degree = PF_CG_DEFAULT_QUADRATURE;
    return p;
}

void pf_cg_release(pf_cg *cg)
{
    pf_basis_release(&cg->basis);
    double *arrays[] = {cg->ke,          cg->me,     cg->n_int, cg->lumped,
                        cg->grad_center, cg->volume, cg->size,  cg->elem_ms};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; ++k)
        pf_free(arrays[k]);
    pf_free(cg->ke_offsets);
    pf_free(cg->me_offsets);
    pf_free(cg->centroid);
    pf_free(cg->materials);
    pf_free(cg->elem_material);
    memset(cg, 0, sizeof *cg);
}

/* Integrals of one element, accumulated over rule points. */
typedef struct accum {
    int32_t k;
    double *d;     /* [k k 9] D_ab[i][j] */
    double *me;    /* [k k] */
    double *n_int; /* [k] */
    double *val;   /* [k] */
    double *grad;  /* [3 k] */
    double *gint;  /* [3 k] int grad N_a */
    double *flux;  /* [3 k] sum over faces of int t_a n (the consistency correction) */
    double volume;
    pf_vec3 moment; /* int x */
} accum;

static void accum_start(accum *a, int32_t k)
{
    a->k = k;
    memset(a->d, 0, (size_t)k * k * 9 * sizeof *a->d);
    memset(a->me, 0, (size_t)k * k * sizeof *a->me);
    memset(a->n_int, 0, (size_t)k * sizeof *a->n_int);
    memset(a->gint, 0, 3 * (size_t)k * sizeof *a->gint);
    a->volume = 0;
    a->moment = pf_v3(0, 0, 0);
}

/* Adds the point x of weight w with values val [k] and gradients grad [3 k]. Upper triangle
 * (q >= p) only: accum_symmetrize mirrors it. */
static void accum_values(accum *a, pf_vec3 x, double w, double rho, const double *val,
                         const double *grad)
{
    int32_t k = a->k;
    for (int32_t p = 0; p < k; ++p) {
        double wp = w * val[p];
        a->n_int[p] += wp;
        const double *gp = grad + 3 * p;
        double wg[3] = {w * gp[0], w * gp[1], w * gp[2]};
        for (int i = 0; i < 3; ++i)
            a->gint[3 * p + i] += wg[i];
        for (int32_t q = p; q < k; ++q) {
            a->me[p * k + q] += rho * wp * val[q];
            const double *gq = grad + 3 * q;
            double *d = a->d + 9 * ((size_t)p * k + q);
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    d[3 * i + j] += wg[i] * gq[j];
        }
    }
    a->volume += w;
    a->moment = pf_v3_add(a->moment, pf_v3_scale(x, w));
}

static void accum_point(accum *a, const pf_basis *b, int32_t e, pf_vec3 x, double w, double rho)
{
    pf_basis_eval(b, e, x, a->val, a->grad);
    accum_values(a, x, w, rho, a->val, a->grad);
}

/* D_qp = D_pq^T and M_qp = M_pq for q < p. */
static void accum_symmetrize(accum *a)
{
    int32_t k = a->k;
    for (int32_t p = 0; p < k; ++p)
        for (int32_t q = 0; q < p; ++q) {
            a->me[p * k + q] = a->me[q * k + p];
            const double *src = a->d + 9 * ((size_t)q * k + p);
            double *dst = a->d + 9 * ((size_t)p * k + q);
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    dst[3 * i + j] = src[3 * j + i];
        }
}

/* K_e from the gradient products D (eq. 15 with isotropic C). */
static void stiffness_from_d(const double *d, int32_t k, double lambda, double mu, double *ke)
{
    int32_t n = 3 * k;
    for (int32_t p = 0; p < k; ++p)
        for (int32_t q = 0; q < k; ++q) {
            const double *dd = d + 9 * ((size_t)p * k + q);
            double trace = dd[0] + dd[4] + dd[8];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    ke[(size_t)(3 * p + i) * n + 3 * q + j] =
                        lambda * dd[3 * i + j] + mu * ((i == j ? trace : 0) + dd[3 * j + i]);
        }
}

static pf_vec3 node_average(const pf_mesh *m, const int32_t *nodes, int32_t k)
{
    pf_vec3 c = pf_v3(0, 0, 0);
    for (int32_t a = 0; a < k; ++a)
        c = pf_v3_add(c, pf_v3_load(m->x + 3 * (size_t)nodes[a]));
    return pf_v3_scale(c, 1.0 / k);
}

/* Tet: constant gradients, D = V g g^T; M_ab = rho V (1 + delta_ab) / 20, int N_a = V / 4. */
static void integrate_tet(accum *a, const pf_basis *b, const pf_mesh *m, int32_t e,
                          const int32_t *nodes, double rho)
{
    pf_vec3 c = node_average(m, nodes, 4);
    double v = fabs(pf_mesh_elem_volume(m, e));
    pf_basis_eval(b, e, c, a->val, a->grad);
    for (int p = 0; p < 4; ++p) {
        a->n_int[p] = v / 4;
        for (int q = 0; q < 4; ++q) {
            a->me[p * 4 + q] = rho * v * (p == q ? 2 : 1) / 20;
            double *d = a->d + 9 * (p * 4 + q);
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    d[3 * i + j] = v * a->grad[3 * p + i] * a->grad[3 * q + j];
        }
        for (int i = 0; i < 3; ++i)
            a->gint[3 * p + i] = v * a->grad[3 * p + i];
    }
    a->volume = v;
    a->moment = pf_v3_scale(c, v);
}

/* Parallelepiped: x = x0 + [e1 e2 e3] l, l in [0, 1]^3, corners by the slot bits. */
static void integrate_hex(accum *a, const pf_basis *b, const pf_mesh *m, int32_t e,
                          const int32_t *nodes, double rho)
{
    const int32_t *slot = b->node_slot + b->node_offsets[e];
    pf_vec3 corner[8];
    for (int p = 0; p < 8; ++p)
        corner[slot[p]] = pf_v3_load(m->x + 3 * (size_t)nodes[p]);
    pf_vec3 x0 = corner[0], e1 = pf_v3_sub(corner[1], x0), e2 = pf_v3_sub(corner[2], x0),
            e3 = pf_v3_sub(corner[4], x0);
    double det = fabs(pf_v3_dot(e1, pf_v3_cross(e2, e3)));
    const double g[2] = {0.5 - 0.5 / sqrt(3.0), 0.5 + 0.5 / sqrt(3.0)};
    for (int q = 0; q < 8; ++q) {
        double l0 = g[q & 1], l1 = g[(q >> 1) & 1], l2 = g[(q >> 2) & 1];
        pf_vec3 x = pf_v3_add(x0, pf_v3_add(pf_v3_scale(e1, l0),
                                            pf_v3_add(pf_v3_scale(e2, l1), pf_v3_scale(e3, l2))));
        accum_point(a, b, e, x, det / 8, rho);
    }
    accum_symmetrize(a);
}

static pf_status integrate_harmonic(accum *a, const pf_basis *b, const pf_mesh *m, int32_t e,
                                    int degree, double rho, pf_arena *arena, int64_t *points,
                                    pf_error *err)
{
    size_t mark = pf_arena_mark(arena);
    pf_polyhedron poly;
    PF_TRY(pf_mesh_elem_polyhedron(m, e, arena, &poly, err));
    pf_quadrature rule;
    pf_status st = pf_polyhedron_quadrature(&poly, m->n_nodes, degree, &rule, err);
    pf_arena_reset(arena, mark);
    PF_TRY(st);
    /* By blocks of points: values V [n k] and gradients G [n 3k] at once, then the sums of
     * accum_values as products, D += G^T diag(w) G and M += rho V^T diag(w) V. */
    int32_t k = a->k;
    size_t nb = PF_BASIS_EVAL_BLOCK, k3 = 3 * (size_t)k;
    double *val = pf_arena_push(arena, 8 * (size_t)k * nb, sizeof *val);
    double *dfull = pf_arena_push(arena, k3 * k3, sizeof *dfull);
    double *scratch = pf_arena_push(arena, pf_basis_eval_block_scratch(b, e) + 1, sizeof *scratch);
    if (!val || !dfull || !scratch) {
        pf_arena_reset(arena, mark);
        pf_quadrature_release(&rule);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "element %d: no scratch for the basis at the rule points", (int)e);
    }
    double *grad = val + (size_t)k * nb, *wval = grad + k3 * nb, *wgrad = wval + (size_t)k * nb;
    memset(dfull, 0, k3 * k3 * sizeof *dfull);
    for (int64_t q0 = 0; q0 < rule.n; q0 += PF_BASIS_EVAL_BLOCK) {
        int32_t n =
            (int32_t)(rule.n - q0 < PF_BASIS_EVAL_BLOCK ? rule.n - q0 : PF_BASIS_EVAL_BLOCK);
        pf_basis_eval_block(b, e, n, rule.x + 3 * q0, val, grad, scratch);
        for (int32_t q = 0; q < n; ++q) {
            double w = rule.w[q0 + q];
            const double *v = val + (size_t)q * k, *g = grad + k3 * q;
            double *wv = wval + (size_t)q * k, *wg = wgrad + k3 * q;
            for (int32_t p = 0; p < k; ++p) {
                wv[p] = w * v[p];
                a->n_int[p] += wv[p];
                wv[p] *= rho;
            }
            for (size_t c = 0; c < k3; ++c) {
                wg[c] = w * g[c];
                a->gint[c] += wg[c];
            }
            a->volume += w;
            a->moment = pf_v3_add(a->moment, pf_v3_scale(pf_v3_load(rule.x + 3 * (q0 + q)), w));
        }
        cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, (int)k3, (int)k3, n, 1, wgrad, (int)k3,
                    grad, (int)k3, 1, dfull, (int)k3);
        cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, k, k, n, 1, wval, k, val, k, 1, a->me,
                    k);
    }
    for (int32_t p = 0; p < k; ++p)
        for (int32_t q = p; q < k; ++q)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    a->d[9 * ((size_t)p * k + q) + 3 * i + j] =
                        dfull[(3 * (size_t)p + i) * k3 + 3 * (size_t)q + j];
    pf_arena_reset(arena, mark);
    *points += rule.n;
    pf_quadrature_release(&rule);
    accum_symmetrize(a);
    return PF_OK;
}

static pf_status integrate(const pf_cg *cg, const pf_mesh *m, int32_t e, int degree, accum *a,
                           pf_arena *arena, int64_t *points, pf_error *err)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
    accum_start(a, k);
    switch (pf_basis_elem_kind(&cg->basis, e)) {
    case PF_BASIS_TET:
        integrate_tet(a, &cg->basis, m, e, nodes, pf_cg_material(cg, e)->density);
        break;
    case PF_BASIS_HEX:
        integrate_hex(a, &cg->basis, m, e, nodes, pf_cg_material(cg, e)->density);
        break;
    default:
        PF_TRY(integrate_harmonic(a, &cg->basis, m, e, degree, pf_cg_material(cg, e)->density,
                                  arena, points, err));
    }
    PF_CHECK(a->volume > 0 && isfinite(a->volume), err, PF_ERR_INVALID,
             "element %d: quadrature volume %g", (int)e, a->volume);
    return PF_OK;
}

/* ---- consistency correction -------------------------------------------------------------
 * Not in the paper. MFS functions are C0 across faces only to the boundary error, so the
 * element integrals of grad N_a around an interior node do not cancel, and a linear field
 * prescribed on the boundary is reproduced inside only to about that error (the patch test
 * misses by 1e-3). Each element's gradients are therefore shifted by a constant per node,
 *   grad N_a + c_a,   c_a = (int_de t_a n dA - int_e grad N_a) / V_e,
 * where t_a are traces shared by both elements of a face: the functions of the face's closed-form
 * element if it has one, else of the lower-numbered element, restricted to the face's nodes and
 * projected (as in pf/basis.h) so that sum_a t_a = 1 and sum_a x_a t_a = x on the face. Then the
 * corrected gradients integrate to int t_a n, whose sum over the elements around an interior node
 * cancels face by face (the same points, opposite normals): the patch test holds to round-off.
 * sum_a c_a = 0 and sum_a x_a c_a^T = 0 (the face rule integrates n and x n^T exactly), so the
 * corrected gradients still reproduce constant and linear fields exactly, and for closed-form
 * neighbours (traces exact) the correction is round-off. K_e = int (g + c)^T C (g + c) needs
 * only the integrals already accumulated:
 *   D_ab += c_a (int g_b)^T + (int g_a) c_b^T + V c_a c_b^T. */

static int32_t trace_source(const pf_cg *cg, const pf_mesh *m, int32_t f, int32_t e)
{
    int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
    if (a < 0 || b < 0)
        return e;
    bool ca = pf_basis_elem_kind(&cg->basis, a) != PF_BASIS_HARMONIC;
    bool cb = pf_basis_elem_kind(&cg->basis, b) != PF_BASIS_HARMONIC;
    if (ca != cb)
        return ca ? a : b;
    return a < b ? a : b;
}

static int32_t find_node(const int32_t *nodes, int32_t k, uint32_t node)
{
    for (int32_t a = 0; a < k; ++a)
        if (nodes[a] == (int32_t)node)
            return a;
    return -1;
}

/* acc->flux[3 a + i] = sum over e's faces of int_f t_a n_i dA (n outward from e). */
static pf_status face_flux(const pf_cg *cg, const pf_mesh *m, int32_t e, accum *acc,
                           pf_arena *arena, pf_error *err)
{
    enum { NG = 3 }; /* collapsed Gauss product per triangle, exact for degree 4 */
    double gx[NG], gw[NG];
    pf_gauss_legendre(NG, gx, gw);
    const pf_basis *b = &cg->basis;
    const int32_t *enodes;
    int32_t k = pf_basis_elem_nodes(b, e, &enodes);
    memset(acc->flux, 0, 3 * (size_t)k * sizeof *acc->flux);
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        const uint32_t *idx = m->face_nodes + m->face_offsets[f];
        int32_t n = (int32_t)(m->face_offsets[f + 1] - m->face_offsets[f]);
        int32_t src = trace_source(cg, m, f, e);
        const int32_t *snodes;
        int32_t ks = pf_basis_elem_nodes(b, src, &snodes);
        size_t mark = pf_arena_mark(arena);
        int32_t *sloc = pf_arena_push(arena, (size_t)n, sizeof *sloc);
        int32_t *eloc = pf_arena_push(arena, (size_t)n, sizeof *eloc);
        uint32_t *tri = pf_arena_push(arena, 3 * (size_t)(n - 2), sizeof *tri);
        double *val = pf_arena_push(arena, NG * NG * (size_t)ks, sizeof *val);
        double *xs = pf_arena_push(arena, 3 * NG * NG, sizeof *xs);
        double *scratch =
            pf_arena_push(arena, pf_basis_eval_block_scratch(b, src) + 1, sizeof *scratch);
        double *t = pf_arena_push(arena, (size_t)n, sizeof *t);
        double *py = pf_arena_push(arena, 2 * (size_t)n, sizeof *py);
        PF_CHECK(sloc && eloc && tri && val && xs && scratch && t && py, err, PF_ERR_NOMEM,
                 "element %d: scratch too small for face %d", (int)e, (int)f);
        for (int32_t j = 0; j < n; ++j) {
            sloc[j] = find_node(snodes, ks, idx[j]);
            eloc[j] = find_node(enodes, k, idx[j]);
            PF_CHECK(sloc[j] >= 0 && eloc[j] >= 0, err, PF_ERR_INVALID,
                     "element %d: face %d node %u is not an element node", (int)e, (int)f, idx[j]);
        }
        pf_vec3 area = pf_polygon_area_vector(m->x, idx, n);
        pf_vec3 nrm = pf_v3_normalize(area);
        if (m->elem_faces[q] & PF_FACE_REVERSED)
            nrm = pf_v3_scale(nrm, -1);
        /* Face-plane coordinates y = ((x - o).u, (x - o).v) / s, and (P^T P)^-1 for the rows
         * P_j = (1, y_j) of the exactness projection. */
        pf_vec3 o = pf_v3_load(m->x + 3 * (size_t)idx[0]);
        pf_vec3 u = pf_v3_normalize(pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)idx[1]), o));
        pf_vec3 v = pf_v3_cross(pf_v3_normalize(area), u);
        double sc = pf_polygon_diameter(m->x, idx, n);
        pf_mat3 ptp = {{{0}}};
        for (int32_t j = 0; j < n; ++j) {
            pf_vec3 d = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)idx[j]), o);
            double row[3] = {1, pf_v3_dot(d, u) / sc, pf_v3_dot(d, v) / sc};
            py[2 * j] = row[1];
            py[2 * j + 1] = row[2];
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    ptp.m[r][c] += row[r] * row[c];
        }
        double det;
        pf_mat3 qinv = pf_m3_inverse(ptp, &det);
        PF_CHECK(det > 0, err, PF_ERR_INVALID, "element %d: face %d is degenerate", (int)e, (int)f);
        pf_status st = pf_polygon_triangulate(m->x, idx, n, arena, tri, NULL, err);
        if (st < 0) {
            pf_error_prefix(err, "element %d, face %d", (int)e, (int)f);
            return st;
        }
        for (int32_t tr = 0; tr < n - 2; ++tr) {
            pf_vec3 v0 = pf_v3_load(m->x + 3 * (size_t)idx[tri[3 * tr]]);
            pf_vec3 e1 = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)idx[tri[3 * tr + 1]]), v0);
            pf_vec3 e2 = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)idx[tri[3 * tr + 2]]), v0);
            double jac = pf_v3_norm(pf_v3_cross(e1, e2));
            for (int i = 0; i < NG; ++i)
                for (int j = 0; j < NG; ++j) {
                    double a = gx[i], bb = gx[j];
                    pf_v3_store(
                        pf_v3_add(v0, pf_v3_add(pf_v3_scale(e1, a), pf_v3_scale(e2, bb * (1 - a)))),
                        xs + 3 * (NG * i + j));
                }
            pf_basis_eval_block(b, src, NG * NG, xs, val, NULL, scratch);
            for (int i = 0; i < NG; ++i)
                for (int j = 0; j < NG; ++j) {
                    double a = gx[i];
                    pf_vec3 x = pf_v3_load(xs + 3 * (NG * i + j));
                    double w = gw[i] * gw[j] * jac * (1 - a);
                    const double *vq = val + (size_t)ks * (NG * i + j);
                    pf_vec3 d = pf_v3_sub(x, o);
                    double r[3] = {1, pf_v3_dot(d, u) / sc, pf_v3_dot(d, v) / sc};
                    for (int32_t p = 0; p < n; ++p) {
                        t[p] = vq[sloc[p]];
                        r[0] -= t[p];
                        r[1] -= t[p] * py[2 * p];
                        r[2] -= t[p] * py[2 * p + 1];
                    }
                    pf_vec3 lam = pf_m3_mulv(qinv, pf_v3(r[0], r[1], r[2]));
                    for (int32_t p = 0; p < n; ++p) {
                        double tp = t[p] + lam.x + lam.y * py[2 * p] + lam.z * py[2 * p + 1];
                        double *fl = acc->flux + 3 * eloc[p];
                        fl[0] += w * tp * nrm.x;
                        fl[1] += w * tp * nrm.y;
                        fl[2] += w * tp * nrm.z;
                    }
                }
        }
        pf_arena_reset(arena, mark);
    }
    return PF_OK;
}

/* Shifts D by the correction; leaves c_a in acc->flux. */
static void apply_correction(accum *a)
{
    int32_t k = a->k;
    for (int32_t p = 0; p < 3 * k; ++p)
        a->flux[p] = (a->flux[p] - a->gint[p]) / a->volume;
    for (int32_t p = 0; p < k; ++p)
        for (int32_t q = 0; q < k; ++q) {
            double *d = a->d + 9 * ((size_t)p * k + q);
            const double *cp = a->flux + 3 * p, *cq = a->flux + 3 * q;
            const double *gp = a->gint + 3 * p, *gq = a->gint + 3 * q;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    d[3 * i + j] += cp[i] * gq[j] + gp[i] * cq[j] + a->volume * cp[i] * cq[j];
        }
}

/* Integrals, correction and K_e of element e into a and ke. */
static pf_status elem_matrices(const pf_cg *cg, const pf_mesh *m, int32_t e, int degree, accum *a,
                               pf_arena *arena, int64_t *points, double *ke, pf_error *err)
{
    PF_TRY(integrate(cg, m, e, degree, a, arena, points, err));
    if (cg->consistency) {
        PF_TRY(face_flux(cg, m, e, a, arena, err));
        apply_correction(a);
    } else {
        memset(a->flux, 0, 3 * (size_t)a->k * sizeof *a->flux);
    }
    stiffness_from_d(a->d, a->k, pf_cg_material(cg, e)->lambda, pf_cg_material(cg, e)->mu, ke);
    return PF_OK;
}

/* Scratch of an accumulator for k nodes, from the arena. */
static bool accum_init(accum *a, pf_arena *arena, int32_t k)
{
    a->d = pf_arena_push(arena, (size_t)k * k * 9, sizeof(double));
    a->me = pf_arena_push(arena, (size_t)k * k, sizeof(double));
    a->n_int = pf_arena_push(arena, (size_t)k, sizeof(double));
    a->val = pf_arena_push(arena, (size_t)k, sizeof(double));
    a->grad = pf_arena_push(arena, 3 * (size_t)k, sizeof(double));
    a->gint = pf_arena_push(arena, 3 * (size_t)k, sizeof(double));
    a->flux = pf_arena_push(arena, 3 * (size_t)k, sizeof(double));
    return a->d && a->me && a->n_int && a->val && a->grad && a->gint && a->flux;
}

/* Face-node and face counts of element e (the size of its polyhedron view). */
static size_t elem_view_entries(const pf_mesh *m, int32_t e)
{
    size_t n = 0;
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        n += (size_t)(m->face_offsets[f + 1] - m->face_offsets[f]) + 1;
    }
    return n + 1;
}

/* Bytes an accumulator for k nodes, a polyhedron view of `entries` and block evaluation with
 * `eval` doubles of basis scratch (rule points, then face points of a trace source) need. */
static size_t arena_bytes(int32_t k, size_t entries, size_t eval)
{
    return ((size_t)k * k * 10 + 11 * (size_t)k + PF_BASIS_MAX_NODES) * sizeof(double) + 16 * 16 +
           16 * entries + 64 * entries + 1024 +
           (8 * (size_t)k * PF_BASIS_EVAL_BLOCK + 9 * (size_t)k * k + eval + 1) * sizeof(double) +
           (9 * (size_t)PF_BASIS_MAX_NODES + 27 + eval + 1) * sizeof(double) + 96;
}

pf_status pf_cg_integrate_elem(const pf_cg *cg, const pf_mesh *m, int32_t e, int degree, double *ke,
                               double *me, pf_error *err)
{
    PF_CHECK(e >= 0 && e < cg->n_elems, err, PF_ERR_INVALID, "element %d of %d", (int)e,
             (int)cg->n_elems);
    int32_t k = pf_basis_elem_nodes(&cg->basis, e, NULL);
    pf_arena arena;
    size_t eval = 0; /* e's and the trace sources' (face_flux) */
    for (int32_t f = 0; f < cg->n_elems; ++f) {
        size_t s = pf_basis_eval_block_scratch(&cg->basis, f);
        eval = s > eval ? s : eval;
    }
    PF_TRY(pf_arena_init(&arena, arena_bytes(k, elem_view_entries(m, e), eval), err));
    accum a;
    int64_t points = 0;
    pf_status st = accum_init(&a, &arena, k)
                       ? elem_matrices(cg, m, e, degree, &a, &arena, &points, ke, err)
                       : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "no scratch");
    if (st >= 0) {
        if (me)
            memcpy(me, a.me, (size_t)k * k * sizeof *me);
    }
    pf_arena_release(&arena);
    return st;
}

static pf_status allocate(pf_cg *cg, pf_error *err)
{
    size_t ne = (size_t)cg->n_elems, nn = (size_t)cg->n_nodes;
    const pf_basis *b = &cg->basis;
    cg->ke_offsets = pf_alloc_array(ne + 1, sizeof *cg->ke_offsets);
    cg->me_offsets = pf_alloc_array(ne + 1, sizeof *cg->me_offsets);
    PF_CHECK(cg->ke_offsets && cg->me_offsets, err, PF_ERR_NOMEM,
             "cannot allocate the offsets of %d elements", (int)ne);
    cg->ke_offsets[0] = cg->me_offsets[0] = 0;
    cg->max_nodes = 0;
    for (size_t e = 0; e < ne; ++e) {
        int64_t k = b->node_offsets[e + 1] - b->node_offsets[e];
        cg->ke_offsets[e + 1] = cg->ke_offsets[e] + 9 * k * k;
        cg->me_offsets[e + 1] = cg->me_offsets[e] + k * k;
        if (k > cg->max_nodes)
            cg->max_nodes = (int32_t)k;
    }
    size_t incid = (size_t)b->node_offsets[ne];
    cg->ke = pf_alloc_array((size_t)cg->ke_offsets[ne] + 1, sizeof *cg->ke);
    cg->me = pf_alloc_array((size_t)cg->me_offsets[ne] + 1, sizeof *cg->me);
    cg->n_int = pf_alloc_array(incid + 1, sizeof *cg->n_int);
    cg->lumped = pf_calloc(nn + 1, sizeof *cg->lumped);
    cg->grad_center = pf_alloc_array(3 * incid + 1, sizeof *cg->grad_center);
    cg->volume = pf_alloc_array(ne + 1, sizeof *cg->volume);
    cg->size = pf_alloc_array(ne + 1, sizeof *cg->size);
    cg->elem_ms = pf_alloc_array(ne + 1, sizeof *cg->elem_ms);
    cg->centroid = pf_alloc_array(ne + 1, sizeof *cg->centroid);
    PF_CHECK(cg->ke && cg->me && cg->n_int && cg->lumped && cg->grad_center && cg->volume &&
                 cg->size && cg->elem_ms && cg->centroid,
             err, PF_ERR_NOMEM, "cannot allocate the matrices of %d elements", (int)ne);
    return PF_OK;
}

static double half_diagonal(const pf_mesh *m, const int32_t *nodes, int32_t k)
{
    pf_vec3 lo = pf_v3_load(m->x + 3 * (size_t)nodes[0]), hi = lo;
    for (int32_t a = 1; a < k; ++a) {
        pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)nodes[a]);
        lo = pf_v3_min(lo, x);
        hi = pf_v3_max(hi, x);
    }
    return 0.5 * pf_v3_dist(lo, hi);
}

/* The old element whose matrices element e can copy (pf_cg_reuse), or -1: its functions were
 * taken, its material and the rules are the same, and each face's traces come from the same
 * functions (trace_source: e itself as o itself, or a neighbour whose functions were taken from
 * the old source). */
static int32_t copy_source(const pf_cg *cg, const pf_mesh *m, int32_t e, const pf_cg_reuse *r)
{
    int32_t o = r && cg->basis.taken ? cg->basis.taken[e] : -1;
    if (o < 0)
        return -1;
    const pf_cg *old = r->old;
    const pf_material *a = pf_cg_material(cg, e), *b = pf_cg_material(old, o);
    if (a->lambda != b->lambda || a->mu != b->mu || a->density != b->density ||
        old->quadrature_degree != cg->quadrature_degree || old->consistency != cg->consistency)
        return -1;
    int64_t q0 = m->elem_offsets[e], p0 = r->old_mesh->elem_offsets[o];
    for (int64_t k = 0; cg->consistency && k < m->elem_offsets[e + 1] - q0; ++k) {
        int32_t src = trace_source(cg, m, PF_FACE_INDEX(m->elem_faces[q0 + k]), e);
        int32_t old_src =
            trace_source(old, r->old_mesh, PF_FACE_INDEX(r->old_mesh->elem_faces[p0 + k]), o);
        if (src == e ? old_src != o : old_src == o || cg->basis.taken[src] != old_src)
            return -1;
    }
    return o;
}

/* Element e's matrices and per-node data are old element o's (copy_source). */
static void copy_elem(pf_cg *cg, int32_t e, const pf_cg *old, int32_t o)
{
    int32_t k = pf_basis_elem_nodes(&cg->basis, e, NULL);
    int64_t to = cg->basis.node_offsets[e], from = old->basis.node_offsets[o];
    memcpy(cg->ke + cg->ke_offsets[e], old->ke + old->ke_offsets[o],
           9 * (size_t)k * k * sizeof *cg->ke);
    memcpy(cg->me + cg->me_offsets[e], old->me + old->me_offsets[o],
           (size_t)k * k * sizeof *cg->me);
    memcpy(cg->n_int + to, old->n_int + from, (size_t)k * sizeof *cg->n_int);
    memcpy(cg->grad_center + 3 * to, old->grad_center + 3 * from,
           3 * (size_t)k * sizeof *cg->grad_center);
    cg->volume[e] = old->volume[o];
    cg->centroid[e] = old->centroid[o];
    cg->elem_ms[e] = 0;
    cg->n_reused++;
}

static pf_status setup_elements(pf_cg *cg, const pf_mesh *m, const pf_cg_reuse *reuse,
                                const pf_progress_hook *progress, pf_error *err)
{
    size_t entries = 0, eval = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        size_t n = elem_view_entries(m, e), s = pf_basis_eval_block_scratch(&cg->basis, e);
        entries = n > entries ? n : entries;
        eval = s > eval ? s : eval;
    }
    pf_arena arena;
    PF_TRY(pf_arena_init(&arena, arena_bytes(cg->max_nodes, entries, eval), err));
    accum a;
    pf_status st = accum_init(&a, &arena, cg->max_nodes)
                       ? PF_OK
                       : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "no scratch");
    double t0 = pf_time_seconds();
    pf_progress_post(progress, "element matrices", 0, cg->n_elems);
    for (int32_t e = 0; st >= 0 && e < cg->n_elems; ++e) {
        if (e > 0)
            pf_progress_post(progress, "element matrices", e, cg->n_elems);
        double te = pf_time_seconds();
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
        int64_t o = cg->basis.node_offsets[e];
        cg->size[e] = half_diagonal(m, nodes, k);
        cg->n_closed_form += pf_basis_elem_kind(&cg->basis, e) != PF_BASIS_HARMONIC;
        int32_t from = copy_source(cg, m, e, reuse);
        if (from >= 0) {
            copy_elem(cg, e, reuse->old, from);
        } else {
            st = elem_matrices(cg, m, e, cg->quadrature_degree, &a, &arena,
                               &cg->n_quadrature_points, cg->ke + cg->ke_offsets[e], err);
            if (st < 0)
                break;
            memcpy(cg->me + cg->me_offsets[e], a.me, (size_t)k * k * sizeof *a.me);
            memcpy(cg->n_int + o, a.n_int, (size_t)k * sizeof *a.n_int);
            cg->volume[e] = a.volume;
            cg->centroid[e] = pf_v3_scale(a.moment, 1 / a.volume);
            double *gc = cg->grad_center + 3 * o;
            pf_basis_eval(&cg->basis, e, cg->centroid[e], NULL, gc);
            for (int32_t p = 0; p < 3 * k; ++p)
                gc[p] += a.flux[p];
            cg->elem_ms[e] = 1e3 * (pf_time_seconds() - te);
        }
        for (int32_t p = 0; p < k; ++p)
            cg->lumped[nodes[p]] += pf_cg_material(cg, e)->density * cg->n_int[o + p];
    }
    cg->integrate_seconds = pf_time_seconds() - t0;
    if (st >= 0 && cg->n_elems > 0)
        pf_progress_post(progress, "element matrices", cg->n_elems, cg->n_elems);
    pf_arena_release(&arena);
    return st;
}

pf_status pf_cg_create(pf_cg *cg, const pf_mesh *m, double E, double nu, double density,
                       const pf_cg_params *params, pf_error *err)
{
    pf_material one = {.E = E, .nu = nu, .density = density};
    pf_materials mat = {.n = 1, .table = &one, .elem = NULL};
    return pf_cg_create_materials(cg, m, &mat, params, err);
}

pf_status pf_cg_create_materials(pf_cg *cg, const pf_mesh *m, const pf_materials *materials,
                                 const pf_cg_params *params, pf_error *err)
{
    return pf_cg_create_reusing(cg, m, materials, params, NULL, err);
}

pf_status pf_cg_create_reusing(pf_cg *cg, const pf_mesh *m, const pf_materials *materials,
                               const pf_cg_params *params, const pf_cg_reuse *reuse, pf_error *err)
{
    memset(cg, 0, sizeof *cg);
    pf_cg_params p = params ? *params : pf_cg_params_default();
    if (p.quadrature_degree == 0)
        p.quadrature_degree = PF_CG_DEFAULT_QUADRATURE;
    if (!p.basis.progress.fn)
        p.basis.progress = p.progress;
    PF_CHECK(p.quadrature_degree >= 1 && p.quadrature_degree <= 29, err, PF_ERR_INVALID,
             "CG quadrature degree must be in [1, 29], got %d", (int)p.quadrature_degree);
    PF_CHECK(m->face_elems, err, PF_ERR_INVALID, "mesh not derived (pf_mesh_derive)");
    pf_status st =
        pf_fem_copy_materials(materials, m->n_elems, &cg->materials, &cg->elem_material, err);
    if (st < 0) {
        pf_cg_release(cg);
        return st;
    }
    cg->n_materials = materials->n;
    cg->n_nodes = m->n_nodes;
    cg->n_elems = m->n_elems;
    cg->density = cg->materials[0].density;
    cg->lambda = cg->materials[0].lambda;
    cg->mu = cg->materials[0].mu;
    cg->quadrature_degree = p.quadrature_degree;
    cg->consistency = !p.no_consistency_correction;
    /* One BLAS thread: small products, and bits independent of the core count (pf/base.h). */
    pf_blas_threads blas = pf_blas_threads_set(1, false);
    double t0 = pf_time_seconds();
    pf_basis_reuse basis_reuse = {0};
    if (reuse)
        basis_reuse = (pf_basis_reuse){.old = &reuse->old->basis,
                                       .old_mesh = reuse->old_mesh,
                                       .source = reuse->source,
                                       .node_map = reuse->node_map};
    st = pf_basis_create_reusing(&cg->basis, m, &p.basis, reuse ? &basis_reuse : NULL, err);
    cg->basis_seconds = pf_time_seconds() - t0;
    if (st >= 0)
        st = allocate(cg, err);
    if (st >= 0)
        st = setup_elements(cg, m, reuse, &p.progress, err);
    pf_blas_threads_restore(blas);
    if (st < 0)
        pf_cg_release(cg);
    return st;
}

/* f += int N_a (rho_e g + b) over every element e: gravity on each element's own density. */
void pf_cg_add_gravity(const pf_cg *cg, pf_vec3 g, pf_vec3 b, double *f)
{
    const pf_basis *bs = &cg->basis;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        pf_vec3 load = pf_v3_add(pf_v3_scale(g, pf_cg_material(cg, e)->density), b);
        for (int64_t q = bs->node_offsets[e]; q < bs->node_offsets[e + 1]; ++q) {
            double *fi = f + 3 * (size_t)bs->nodes[q];
            fi[0] += load.x * cg->n_int[q];
            fi[1] += load.y * cg->n_int[q];
            fi[2] += load.z * cg->n_int[q];
        }
    }
}

/* ---- loads and stress ------------------------------------------------------------------- */

void pf_cg_add_body_force(const pf_cg *cg, pf_vec3 b, double *f)
{
    pf_cg_add_gravity(cg, (pf_vec3){0, 0, 0}, b, f);
}

void pf_cg_add_traction(const pf_cg *cg, const pf_mesh *m, const pf_boundary *bd, int32_t index,
                        pf_vec3 t, double *f)
{
    /* Collapsed Gauss product on each triangle: x = v0 + a e1 + b (1 - a) e2,
     * dA = |e1 x e2| (1 - a) da db; 3 points per direction are exact for degree 4 in x. */
    enum { NG = 3 };
    double gx[NG], gw[NG];
    pf_gauss_legendre(NG, gx, gw);
    int32_t e = bd->elem[index];
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
    double val[PF_BASIS_MAX_NODES], acc[PF_BASIS_MAX_NODES];
    for (int32_t p = 0; p < k; ++p)
        acc[p] = 0;
    for (int64_t tr = bd->tri_offsets[index]; tr < bd->tri_offsets[index + 1]; ++tr) {
        const uint32_t *v = bd->tri + 3 * tr;
        pf_vec3 v0 = pf_v3_load(m->x + 3 * (size_t)v[0]);
        pf_vec3 e1 = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)v[1]), v0);
        pf_vec3 e2 = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)v[2]), v0);
        double jac = pf_v3_norm(pf_v3_cross(e1, e2));
        for (int i = 0; i < NG; ++i)
            for (int j = 0; j < NG; ++j) {
                double a = gx[i], bb = gx[j];
                pf_vec3 x =
                    pf_v3_add(v0, pf_v3_add(pf_v3_scale(e1, a), pf_v3_scale(e2, bb * (1 - a))));
                double w = gw[i] * gw[j] * jac * (1 - a);
                pf_basis_eval(&cg->basis, e, x, val, NULL);
                for (int32_t p = 0; p < k; ++p)
                    acc[p] += w * val[p];
            }
    }
    for (int32_t p = 0; p < k; ++p) {
        double *fi = f + 3 * (size_t)nodes[p];
        fi[0] += t.x * acc[p];
        fi[1] += t.y * acc[p];
        fi[2] += t.z * acc[p];
    }
}

void pf_cg_von_mises(const pf_cg *cg, const double *u, double *out)
{
    const pf_basis *b = &cg->basis;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(b, e, &nodes);
        const double *g = cg->grad_center + 3 * b->node_offsets[e];
        pf_mat3 f = pf_m3_identity();
        for (int32_t p = 0; p < k; ++p)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    f.m[i][j] += u[3 * (size_t)nodes[p] + i] * g[3 * p + j];
        double sigma[6];
        const pf_material *mat = pf_cg_material(cg, e);
        pf_corotated_stress(f, mat->lambda, mat->mu, sigma);
        out[e] = pf_von_mises(sigma);
    }
}
