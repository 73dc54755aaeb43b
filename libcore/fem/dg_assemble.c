/* DG assembly: element and face terms expanded into 3 x 3 blocks, warped with the element
 * rotations (sec. 6), scattered into the block matrix; and the pieces of the right-hand side.
 *
 * Face terms, face f between L (side 0, normal n out of L) and R (side 1), jump sign +1 on L and
 * -1 on R, average weight w = 1/2 (w = 1 on a Dirichlet boundary face, where the outside stress
 * is the inside one, sec. 4.2):
 *   K1[(s a i), (t b k)] = -w sign_s int phi_a^s (sigma(phi_b^t e_k) n)_i
 *                        = -w sign_s (lambda n_i G_k + mu (delta_ik n.G + n_k G_i)),
 *     G = G[s][t][a][b]: the consistency term of eq. 24, its strain taken on side t;
 *   K2 = K1^T (eq. 25);
 *   K3[(s a i), (t b k)] = eta eta_f sign_s sign_t S[s][t][a][b] (2 mu delta_ik + lambda n_i n_k)
 *     (eq. 26, with the Hansbo-Larson weighting of pf/fem.h).
 * With corotation, K1's part with strain on side t is warped with R_t (K_f1^+- of sec. 6.1) and
 * K3 is not warped. Warping a 3 x 3 block of K1 needs no product with R on either side: with
 * n' = R n and G' = R G, R (lambda n G^T + mu ((n.G) I + G n^T)) R^T
 *   = lambda n' G'^T + mu ((n'.G') I + G' n'^T),
 * so a step rotates the face's normal and G vectors (9 flops each) and builds the warped blocks
 * directly, and the warping force R B (I - R^T) x0 is B' (R x0 - x0), B' = R B R^T the block
 * just built. The penalty terms K3 do not rotate: a step copies them (pf_dg_penalty_values). */
#include <pf/fem.h>

#include <math.h>
#include <string.h>

enum { MAX_N = 30 }; /* 3 nb for degree 2 */

static const double IDENTITY[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

double pf_dg_face_penalty(const pf_dg_terms *terms, const pf_dg_face *f)
{
    return terms->eta * f->eta_geometry * (terms->ip ? 1 : f->bz_growth);
}

/* ---- pattern ------------------------------------------------------------------------------ */

pf_status pf_dg_pattern(const pf_dg *dg, pf_block_matrix *k, pf_error *err)
{
    int32_t *size = pf_alloc_array((size_t)dg->n_elems, sizeof *size);
    int32_t *pairs = pf_alloc_array(2 * (size_t)dg->n_interior, sizeof *pairs);
    if ((!size && dg->n_elems) || (!pairs && dg->n_interior)) {
        pf_free(size);
        pf_free(pairs);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the pattern of %d elements", (int)dg->n_elems);
    }
    for (int32_t e = 0; e < dg->n_elems; ++e)
        size[e] = 3 * dg->nb;
    for (int32_t f = 0; f < dg->n_interior; ++f) {
        pairs[2 * f] = dg->faces[f].elem[0];
        pairs[2 * f + 1] = dg->faces[f].elem[1];
    }
    pf_status s = pf_block_matrix_create(k, dg->n_elems, size, dg->n_interior, pairs, err);
    pf_free(size);
    pf_free(pairs);
    return s;
}

/* ---- 3 x 3 block helpers ----------------------------------------------------------------- */

/* out = R b R^T for every 3 x 3 block of the n x n matrix b (R row-major). */
static void warp_block(const double *r, const double *b, int n, double *out)
{
    for (int a = 0; a < n; a += 3)
        for (int c = 0; c < n; c += 3) {
            double t[3][3]; /* R b_ac */
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    t[i][j] = r[3 * i] * b[(a + 0) * n + c + j] +
                              r[3 * i + 1] * b[(a + 1) * n + c + j] +
                              r[3 * i + 2] * b[(a + 2) * n + c + j];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    out[(a + i) * n + c + j] =
                        t[i][0] * r[3 * j] + t[i][1] * r[3 * j + 1] + t[i][2] * r[3 * j + 2];
        }
}

/* z = R x0 - x0 per 3-vector of an element's coefficients (n of them). */
static void rotation_offset(const double *r, const double *x0, int n, double *z)
{
    for (int a = 0; a < n; a += 3)
        for (int i = 0; i < 3; ++i)
            z[a + i] =
                r[3 * i] * x0[a] + r[3 * i + 1] * x0[a + 1] + r[3 * i + 2] * x0[a + 2] - x0[a + i];
}

/* f_rows += B' z (transpose: B'^T z), B' = R b R^T a warped block and z = R x0 - x0 of the
 * columns' element: R b (I - R^T) x0 = B' (R - I) x0, the constant part of a warped term
 * (sec. 6.3). */
static void add_warp_force(const double *warped, int n, bool transpose, const double *z,
                           double *f_rows)
{
    if (transpose) {
        for (int q = 0; q < n; ++q) {
            double zq = z[q];
            const double *row = warped + q * n;
            for (int p = 0; p < n; ++p)
                f_rows[p] += row[p] * zq;
        }
        return;
    }
    for (int p = 0; p < n; ++p) {
        const double *row = warped + p * n;
        double sum = 0;
        for (int q = 0; q < n; ++q)
            sum += row[q] * z[q];
        f_rows[p] += sum;
    }
}

/* The slot of the diagonal block (e, e): it closes its block column. */
static int64_t diagonal_slot(const pf_block_matrix *k, int32_t e)
{
    return k->adj_offsets[e + 1] - 1;
}

void pf_dg_face_slots(const pf_dg *dg, const pf_block_matrix *k, int64_t *slot)
{
    for (int32_t q = 0; q < dg->n_interior; ++q)
        slot[q] = pf_block_matrix_slot(k, dg->faces[q].elem[0], dg->faces[q].elem[1]);
}

/* Adds the symmetric n x n block b to element e's diagonal block: its upper triangle, read as
 * the lower one (b's rows are the stored columns: contiguous reads). */
static void add_diagonal(pf_block_matrix *k, int32_t e, const double *b, int n)
{
    int64_t first = k->block_start[e], row0 = k->adj_row[diagonal_slot(k, e)];
    for (int c = 0; c < n; ++c) {
        double *v = k->val + k->col_ptr[first + c] + row0;
        const double *bc = b + c * n;
        for (int r = 0; r <= c; ++r)
            v[r] += bc[r];
    }
}

/* Adds b + b^T to element e's diagonal block. */
static void add_symmetric_part(pf_block_matrix *k, int32_t e, const double *b, int n)
{
    double sym[MAX_N * MAX_N];
    for (int p = 0; p < n; ++p)
        for (int q = 0; q < n; ++q)
            sym[p * n + q] = b[p * n + q] + b[q * n + p];
    add_diagonal(k, e, sym, n);
}

/* ---- face blocks ------------------------------------------------------------------------- */

static const double *g_entry(const pf_dg *dg, const pf_dg_face *f, int s, int t, int a, int b)
{
    int nb = dg->nb;
    return f->G + 3 * ((size_t)((s * 2 + t) * nb + a) * nb + b);
}

static double s_entry(const pf_dg *dg, const pf_dg_face *f, int s, int t, int a, int b)
{
    int nb = dg->nb;
    return f->S[(size_t)((s * 2 + t) * nb + a) * nb + b];
}

/* K1's block (s, t) of face f warped with the rotation r (row-major; NULL: none), as above. */
static void consistency_block(const pf_dg *dg, const pf_dg_face *f, int s, int t, double w,
                              const double *r, double *out)
{
    int nb = dg->nb, n = 3 * nb;
    double sign = s == 0 ? 1 : -1;
    double nv[3] = {f->normal.x, f->normal.y, f->normal.z};
    if (r) {
        const double n0[3] = {nv[0], nv[1], nv[2]};
        for (int i = 0; i < 3; ++i)
            nv[i] = r[3 * i] * n0[0] + r[3 * i + 1] * n0[1] + r[3 * i + 2] * n0[2];
    }
    const pf_material *mat = pf_dg_material(dg, f->elem[t]); /* the stress of side t */
    double lam = -w * sign * mat->lambda, mu = -w * sign * mat->mu;
    for (int a = 0; a < nb; ++a)
        for (int b = 0; b < nb; ++b) {
            const double *g0 = g_entry(dg, f, s, t, a, b);
            double g[3] = {g0[0], g0[1], g0[2]};
            if (r)
                for (int i = 0; i < 3; ++i)
                    g[i] = r[3 * i] * g0[0] + r[3 * i + 1] * g0[1] + r[3 * i + 2] * g0[2];
            double ng = mu * (nv[0] * g[0] + nv[1] * g[1] + nv[2] * g[2]);
            double *row = out + (3 * a) * n + 3 * b;
            for (int i = 0; i < 3; ++i, row += n) {
                double li = lam * nv[i], mi = mu * g[i];
                for (int k = 0; k < 3; ++k)
                    row[k] = li * g[k] + mi * nv[k];
                row[i] += ng;
            }
        }
}

static void penalty_block(const pf_dg *dg, const pf_dg_face *f, int s, int t, double weight,
                          double *out)
{
    int nb = dg->nb, n = 3 * nb;
    double sign = (s == t) ? 1 : -1;
    double scale = weight * sign;
    const double nv[3] = {f->normal.x, f->normal.y, f->normal.z};
    /* the stiffer side's moduli across an interface between two materials */
    double lambda = pf_dg_material(dg, f->elem[0])->lambda, mu = pf_dg_material(dg, f->elem[0])->mu;
    if (f->elem[1] >= 0) {
        lambda = fmax(lambda, pf_dg_material(dg, f->elem[1])->lambda);
        mu = fmax(mu, pf_dg_material(dg, f->elem[1])->mu);
    }
    for (int a = 0; a < nb; ++a)
        for (int b = 0; b < nb; ++b) {
            double sab = scale * s_entry(dg, f, s, t, a, b);
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k)
                    out[(3 * a + i) * n + 3 * b + k] =
                        sab * ((i == k ? 2 * mu : 0) + lambda * nv[i] * nv[k]);
        }
}

static const double *rotation_of(const double *rot, int32_t e)
{
    return rot ? rot + 9 * (size_t)e : IDENTITY;
}

/* The consistency terms of a face (IP): for each strain side t and row side s, K1 warped with
 * R_t at (s, t) and its transpose at (t, s). The off-diagonal pair's two terms go in as one
 * block. */
static void assemble_consistency(const pf_dg *dg, const pf_dg_face *f, int sides, double w,
                                 const double *rot, const double *x0, int64_t slot,
                                 pf_block_matrix *k, double *rhs)
{
    int n = 3 * dg->nb;
    double b[MAX_N * MAX_N], pair[MAX_N * MAX_N], z[2][2][MAX_N];
    if (sides == 2)
        memset(pair, 0, (size_t)n * n * sizeof *pair);
    for (int t = 0; t < sides && rot; ++t) /* z[t][s] = R_t x0_s - x0_s */
        for (int s = 0; s < sides; ++s)
            rotation_offset(rotation_of(rot, f->elem[t]), x0 + (size_t)f->elem[s] * n, n, z[t][s]);
    for (int t = 0; t < sides; ++t) {
        int32_t et = f->elem[t];
        const double *r = rot ? rotation_of(rot, et) : NULL;
        for (int s = 0; s < sides; ++s) {
            int32_t es = f->elem[s];
            consistency_block(dg, f, s, t, w, r, b);
            if (rot) {
                add_warp_force(b, n, false, z[t][t], rhs + (size_t)es * n);
                add_warp_force(b, n, true, z[t][s], rhs + (size_t)et * n);
            }
            if (s == t) {
                add_symmetric_part(k, es, b, n);
            } else if (es > et) { /* b is (es, et): as pair is built */
                for (int p = 0; p < n * n; ++p)
                    pair[p] += b[p];
            } else { /* pair takes its transpose */
                for (int p = 0; p < n; ++p)
                    for (int q = 0; q < n; ++q)
                        pair[p * n + q] += b[q * n + p];
            }
        }
    }
    if (sides == 2) { /* pair is the block (hi, lo) of the two elements: its rows are stored
                         contiguously */
        int32_t hi = f->elem[0] > f->elem[1] ? f->elem[0] : f->elem[1];
        int32_t lo = f->elem[0] + f->elem[1] - hi;
        pf_block_matrix_add(k, slot, hi, lo, pair, n);
    }
}

static void assemble_penalty(const pf_dg *dg, const pf_dg_face *f, int sides, double weight,
                             int64_t slot, pf_block_matrix *k)
{
    int n = 3 * dg->nb;
    double b[MAX_N * MAX_N];
    for (int s = 0; s < sides; ++s)
        for (int t = s; t < sides; ++t) {
            int32_t es = f->elem[s], et = f->elem[t];
            penalty_block(dg, f, s, t, weight, b);
            pf_block_matrix_add(k, es == et ? diagonal_slot(k, es) : slot, es, et, b, n);
        }
}

/* Prescribed displacement g(x) = A x + b on a Dirichlet face, written exactly in the element's
 * basis (coefficients gc): f_(b k) += sum_(a i) gc_(a i) (K1 + K3)[(a i), (b k)], the terms of
 * -[u] : {sigma(v)} and eta [u] : [v] with u = g outside. */
static void add_dirichlet_force(const pf_dg *dg, const pf_dg_face *f, bool ip, double weight,
                                const double *affine, double *rhs)
{
    int nb = dg->nb, n = 3 * nb;
    int32_t e = f->elem[0];
    const pf_frame *fr = &dg->frame[e];
    double gc[MAX_N] = {0};
    const double *a = affine, *b = affine + 9;
    const double c[3] = {fr->center.x, fr->center.y, fr->center.z};
    for (int i = 0; i < 3; ++i) { /* as pf_dg_affine_coefficients, for one element */
        gc[i] = a[3 * i] * c[0] + a[3 * i + 1] * c[1] + a[3 * i + 2] * c[2] + b[i];
        for (int j = 0; j < 3; ++j)
            gc[3 * (1 + j) + i] = fr->scale * a[3 * i + j];
    }
    double blk[MAX_N * MAX_N];
    double *fe = rhs + (size_t)e * n;
    for (int term = ip ? 0 : 1; term < 2; ++term) {
        if (term == 0)
            consistency_block(dg, f, 0, 0, 1, NULL, blk);
        else
            penalty_block(dg, f, 0, 0, weight, blk);
        for (int row = 0; row < 12; ++row) /* only the affine coefficients are non-zero */
            if (gc[row] != 0)
                for (int col = 0; col < n; ++col)
                    fe[col] += gc[row] * blk[row * n + col];
    }
}

/* The slot of an interior face's element pair, -1 for a boundary face. */
static int64_t face_pair_slot(const pf_dg *dg, const pf_dg_terms *terms, const pf_block_matrix *k,
                              int32_t q)
{
    if (q >= dg->n_interior)
        return -1;
    return terms->face_slot ? terms->face_slot[q]
                            : pf_block_matrix_slot(k, dg->faces[q].elem[0], dg->faces[q].elem[1]);
}

/* The faces with terms: the interior ones and the fixed boundary ones. */
static bool face_has_terms(const pf_dg *dg, const pf_dg_terms *terms, int32_t q)
{
    return q < dg->n_interior || (terms->face_fixed && terms->face_fixed[dg->faces[q].face] >= 0);
}

static void add_penalties(const pf_dg *dg, const pf_dg_terms *terms, pf_block_matrix *k)
{
    for (int32_t q = 0; q < dg->n_faces; ++q)
        if (face_has_terms(dg, terms, q))
            assemble_penalty(dg, &dg->faces[q], q < dg->n_interior ? 2 : 1,
                             pf_dg_face_penalty(terms, &dg->faces[q]),
                             face_pair_slot(dg, terms, k, q), k);
}

void pf_dg_penalty_values(const pf_dg *dg, const pf_dg_terms *terms, pf_block_matrix *k,
                          double *values)
{
    pf_block_matrix_zero(k);
    add_penalties(dg, terms, k);
    memcpy(values, k->val, (size_t)k->col_ptr[k->n] * sizeof *values);
}

void pf_dg_assemble_stiffness(const pf_dg *dg, const pf_dg_terms *terms, const double *rot,
                              const double *x0, pf_block_matrix *k, double *f)
{
    int n = 3 * dg->nb;
    double warped[MAX_N * MAX_N], z[MAX_N];
    if (terms->penalty_values) {
        memcpy(k->val, terms->penalty_values, (size_t)k->col_ptr[k->n] * sizeof *k->val);
    } else {
        pf_block_matrix_zero(k);
        add_penalties(dg, terms, k);
    }
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const double *ke = dg->ke + (size_t)e * n * n;
        const double *use = ke;
        if (rot) {
            warp_block(rot + 9 * (size_t)e, ke, n, warped);
            rotation_offset(rot + 9 * (size_t)e, x0 + (size_t)e * n, n, z);
            add_warp_force(warped, n, false, z, f + (size_t)e * n);
            use = warped;
        }
        add_diagonal(k, e, use, n);
    }
    for (int32_t q = 0; q < dg->n_faces; ++q) {
        if (!face_has_terms(dg, terms, q))
            continue; /* a free boundary: natural condition, no term */
        const pf_dg_face *face = &dg->faces[q];
        bool interior = q < dg->n_interior;
        if (terms->ip)
            assemble_consistency(dg, face, interior ? 2 : 1, interior ? 0.5 : 1, rot, x0,
                                 face_pair_slot(dg, terms, k, q), k, f);
        if (!interior)
            add_dirichlet_force(dg, face, terms->ip, pf_dg_face_penalty(terms, face),
                                terms->fixed_disp + 12 * terms->face_fixed[face->face], f);
    }
}

/* ---- mass and forces --------------------------------------------------------------------- */

void pf_dg_add_mass(const pf_dg *dg, double alpha, pf_block_matrix *k)
{
    int nb = dg->nb, n = 3 * nb;
    double b[MAX_N * MAX_N];
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const double *me = dg->me + (size_t)e * nb * nb;
        memset(b, 0, sizeof b);
        for (int a = 0; a < nb; ++a)
            for (int c = 0; c < nb; ++c)
                for (int i = 0; i < 3; ++i)
                    b[(3 * a + i) * n + 3 * c + i] = alpha * me[a * nb + c];
        pf_block_matrix_add(k, diagonal_slot(k, e), e, e, b, n);
    }
}

void pf_dg_mass_mul(const pf_dg *dg, double alpha, const double *x, double *y)
{
    int nb = dg->nb, n = 3 * nb;
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const double *me = dg->me + (size_t)e * nb * nb;
        const double *xe = x + (size_t)e * n;
        double *ye = y + (size_t)e * n;
        for (int a = 0; a < nb; ++a)
            for (int c = 0; c < nb; ++c) {
                double m = alpha * me[a * nb + c];
                for (int i = 0; i < 3; ++i)
                    ye[3 * a + i] += m * xe[3 * c + i];
            }
    }
}

void pf_dg_add_body_force(const pf_dg *dg, pf_vec3 b, double *f)
{
    pf_dg_add_gravity(dg, (pf_vec3){0, 0, 0}, b, f);
}

void pf_dg_add_traction(const pf_dg *dg, int32_t face, pf_vec3 t, double *f)
{
    const pf_dg_face *fc = &dg->faces[dg->face_slot[face]];
    int nb = dg->nb;
    for (int a = 0; a < nb; ++a) {
        double w = s_entry(dg, fc, 0, 0, a, 0); /* int_f phi_a phi_0, phi_0 = 1 */
        double *fa = f + 3 * ((size_t)fc->elem[0] * nb + a);
        fa[0] += w * t.x;
        fa[1] += w * t.y;
        fa[2] += w * t.z;
    }
}

/* ---- coefficients and evaluation --------------------------------------------------------- */

void pf_dg_affine_coefficients(const pf_dg *dg, const double a[9], const double b[3], double *u)
{
    int nb = dg->nb;
    memset(u, 0, (size_t)dg->n_dofs * sizeof *u);
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        const pf_frame *fr = &dg->frame[e];
        const double c[3] = {fr->center.x, fr->center.y, fr->center.z};
        double *ue = u + 3 * (size_t)e * nb;
        for (int i = 0; i < 3; ++i) {
            /* u = (A c + b) + h A xhat: basis 0 is 1, bases 1..3 are xhat, yhat, zhat */
            ue[i] = a[3 * i] * c[0] + a[3 * i + 1] * c[1] + a[3 * i + 2] * c[2] + b[i];
            for (int j = 0; j < 3; ++j)
                ue[3 * (1 + j) + i] = fr->scale * a[3 * i + j];
        }
    }
}

void pf_dg_rest_coefficients(const pf_dg *dg, double *x0)
{
    const double zero[3] = {0, 0, 0};
    pf_dg_affine_coefficients(dg, IDENTITY, zero, x0);
}

pf_vec3 pf_dg_eval(const pf_dg *dg, const double *u, int32_t e, pf_vec3 x)
{
    const pf_frame *fr = &dg->frame[e];
    double phi[10];
    pf_moment_monomials(pf_v3_scale(pf_v3_sub(x, fr->center), 1 / fr->scale), dg->degree, phi);
    const double *ue = u + 3 * (size_t)e * dg->nb;
    pf_vec3 r = {0, 0, 0};
    for (int a = 0; a < dg->nb; ++a)
        r = pf_v3_add(r, pf_v3_scale((pf_vec3){ue[3 * a], ue[3 * a + 1], ue[3 * a + 2]}, phi[a]));
    return r;
}

void pf_dg_gradient(const pf_dg *dg, const double *u, int32_t e, double g[9])
{
    const double *ue = u + 3 * (size_t)e * dg->nb;
    double h = dg->frame[e].scale;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            g[3 * i + j] = ue[3 * (1 + j) + i] / h;
}

void pf_dg_stitch(const pf_dg *dg, const double *u, double *out)
{
    int nb = dg->nb;
    for (int32_t i = 0; i < dg->n_nodes; ++i) {
        double s[3] = {0, 0, 0};
        int64_t begin = dg->node_offsets[i], end = dg->node_offsets[i + 1];
        for (int64_t k = begin; k < end; ++k) {
            const double *ue = u + 3 * (size_t)dg->node_elem[k] * nb;
            const double *phi = dg->node_phi + (size_t)k * nb;
            for (int a = 0; a < nb; ++a)
                for (int c = 0; c < 3; ++c)
                    s[c] += phi[a] * ue[3 * a + c];
        }
        double w = end > begin ? 1.0 / (double)(end - begin) : 0;
        for (int c = 0; c < 3; ++c)
            out[3 * (size_t)i + c] = s[c] * w;
    }
}
