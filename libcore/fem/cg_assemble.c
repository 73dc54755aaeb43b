/* CG assembly over the free nodes: element matrices warped by per-element rotations (harmonic
 * paper sec. 6, stiffness warping after Mueller and Gross 2004) and scattered into 3 x 3 node
 * blocks at slots looked up once (pf_cg_pattern). Each 3 x 3 block is warped and added where it
 * belongs at once, the blocks on and above the diagonal only (K' is symmetric).
 *
 * Corotated element force, for nodal positions x = X + u and the element rotation R:
 *   f_e = -R K_e (R^T x - X) = -(R K_e R^T) u + R K_e (I - R^T) X,
 * which vanishes for every rigid motion x = Q X + t with R = Q (R^T x - X is then the constant
 * R^T t, in the null space of K_e): no ghost forces. Fixed nodes keep x = X + g: with the
 * unknowns split into free (f) and fixed (c) rows, the free rows get -K'_ff u_f - K'_fc g_c. */
#include <pf/fem.h>

#include <string.h>

#include "../base/lanes.h"

void pf_cg_map_release(pf_cg_map *map)
{
    pf_free(map->node_block);
    pf_free(map->block_node);
    pf_free(map->slot);
    pf_free(map->node_elem);
    memset(map, 0, sizeof *map);
}

size_t pf_cg_scratch_size(const pf_cg *cg)
{
    return 6 * (size_t)cg->max_nodes;
}

static pf_status count_pairs(const pf_cg *cg, const pf_cg_map *map, int64_t *pairs)
{
    const pf_basis *b = &cg->basis;
    *pairs = 0;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(b, e, &nodes), free_nodes = 0;
        for (int32_t a = 0; a < k; ++a)
            free_nodes += map->node_block[nodes[a]] >= 0;
        *pairs += (int64_t)free_nodes * (free_nodes - 1) / 2;
    }
    return PF_OK;
}

pf_status pf_cg_pattern(const pf_cg *cg, const uint8_t *fixed, pf_block_matrix *k, pf_cg_map *map,
                        pf_error *err)
{
    memset(map, 0, sizeof *map);
    const pf_basis *b = &cg->basis;
    size_t nn = (size_t)cg->n_nodes;
    map->node_block = pf_alloc_array(nn + 1, sizeof *map->node_block);
    map->block_node = pf_alloc_array(nn + 1, sizeof *map->block_node);
    map->node_elem = pf_alloc_array(nn + 1, sizeof *map->node_elem);
    map->slot = pf_alloc_array((size_t)cg->me_offsets[cg->n_elems] + 1, sizeof *map->slot);
    if (!map->node_block || !map->block_node || !map->node_elem || !map->slot) {
        pf_cg_map_release(map);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the node map of %d nodes", (int)nn);
    }
    /* Nodes no element uses carry no unknowns either. */
    for (size_t i = 0; i < nn; ++i)
        map->node_elem[i] = -1;
    for (int32_t e = cg->n_elems - 1; e >= 0; --e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        for (int32_t a = 0; a < kn; ++a)
            map->node_elem[nodes[a]] = e;
    }
    map->n_free = 0;
    for (size_t i = 0; i < nn; ++i) {
        bool is_free = map->node_elem[i] >= 0 && !(fixed && fixed[i]);
        map->node_block[i] = is_free ? map->n_free : -1;
        if (is_free)
            map->block_node[map->n_free++] = (int32_t)i;
    }
    int64_t n_pairs;
    count_pairs(cg, map, &n_pairs);
    int32_t *size = pf_alloc_array((size_t)map->n_free + 1, sizeof *size);
    int32_t *pairs = pf_alloc_array(2 * (size_t)n_pairs + 1, sizeof *pairs);
    if (!size || !pairs) {
        pf_free(size);
        pf_free(pairs);
        pf_cg_map_release(map);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %lld node pairs", (long long)n_pairs);
    }
    for (int32_t i = 0; i < map->n_free; ++i)
        size[i] = 3;
    int64_t at = 0;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        for (int32_t a = 0; a < kn; ++a)
            for (int32_t c = a + 1; c < kn; ++c) {
                int32_t i = map->node_block[nodes[a]], j = map->node_block[nodes[c]];
                if (i >= 0 && j >= 0) {
                    pairs[at++] = i;
                    pairs[at++] = j;
                }
            }
    }
    pf_status st = pf_block_matrix_create(k, map->n_free, size, n_pairs, pairs, err);
    pf_free(size);
    pf_free(pairs);
    if (st < 0) {
        pf_cg_map_release(map);
        return st;
    }
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        int64_t *slot = map->slot + cg->me_offsets[e];
        for (int32_t a = 0; a < kn; ++a)
            for (int32_t c = 0; c < kn; ++c) {
                int32_t i = map->node_block[nodes[a]], j = map->node_block[nodes[c]];
                slot[a * kn + c] = i >= 0 && j >= 0 ? pf_block_matrix_slot(k, i, j) : -1;
            }
    }
    return PF_OK;
}

/* ---- rotations ---------------------------------------------------------------------------- */

void pf_cg_rotations(const pf_cg *cg, const double *x0, const double *u, bool warm, double *rot)
{
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
        pf_vec3 xc = pf_v3(0, 0, 0), rc = pf_v3(0, 0, 0);
        for (int32_t a = 0; a < k; ++a) {
            pf_vec3 r = pf_v3_load(x0 + 3 * (size_t)nodes[a]);
            rc = pf_v3_add(rc, r);
            xc = pf_v3_add(xc, pf_v3_add(r, pf_v3_load(u + 3 * (size_t)nodes[a])));
        }
        xc = pf_v3_scale(xc, 1.0 / k);
        rc = pf_v3_scale(rc, 1.0 / k);
        /* Shape matching: A = sum (x_a - x_c)(X_a - X_c)^T; R = rotation of A's polar form. */
        pf_mat3 a = {{{0}}};
        for (int32_t p = 0; p < k; ++p) {
            pf_vec3 r = pf_v3_load(x0 + 3 * (size_t)nodes[p]);
            pf_vec3 x = pf_v3_sub(pf_v3_add(r, pf_v3_load(u + 3 * (size_t)nodes[p])), xc);
            r = pf_v3_sub(r, rc);
            const double xv[3] = {x.x, x.y, x.z}, rv[3] = {r.x, r.y, r.z};
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    a.m[i][j] += xv[i] * rv[j];
        }
        double *re = rot + 9 * (size_t)e;
        pf_mat3 r;
        if (warm) {
            pf_mat3 guess;
            memcpy(guess.m, re, sizeof guess.m);
            r = pf_mat3_polar_rotation_near(a, guess, NULL);
        } else {
            r = pf_mat3_polar_rotation(a);
        }
        memcpy(re, r.m, sizeof r.m);
    }
}

/* ---- stiffness ---------------------------------------------------------------------------- */

static inline lanes_d load_lanes(const double *p)
{
    lanes_d v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* z = K y for a symmetric n x n K, by K's rows: z_p = sum_q K_qp y_q added in the order of q
 * (as a scalar loop does), eight and then four entries of z at a time. */
PF_KERNEL_CLONES
static void symmetric_mul(const double *ke, int32_t n, const double *y, double *z)
{
    int32_t p = 0;
    for (; p + 8 <= n; p += 8) {
        lanes_d z0 = {0, 0, 0, 0}, z1 = z0;
        for (int32_t q = 0; q < n; ++q) {
            const double *kq = ke + (size_t)q * n + p;
            z0 += load_lanes(kq) * y[q];
            z1 += load_lanes(kq + 4) * y[q];
        }
        memcpy(z + p, &z0, sizeof z0);
        memcpy(z + p + 4, &z1, sizeof z1);
    }
    for (; p + 4 <= n; p += 4) {
        lanes_d z0 = {0, 0, 0, 0};
        for (int32_t q = 0; q < n; ++q)
            z0 += load_lanes(ke + (size_t)q * n + p) * y[q];
        memcpy(z + p, &z0, sizeof z0);
    }
    for (; p < n; ++p) {
        double zp = 0;
        for (int32_t q = 0; q < n; ++q)
            zp += ke[(size_t)q * n + p] * y[q];
        z[p] = zp;
    }
}

/* out = R K_ac R^T for the 3 x 3 block at (a, c) of K (row stride n; R row-major). */
static void warp_block(const double *r, const double *kk, int32_t n, double out[9])
{
    double t[3][3]; /* R K_ac */
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            t[i][j] = r[3 * i] * kk[j] + r[3 * i + 1] * kk[n + j] + r[3 * i + 2] * kk[2 * n + j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            out[3 * i + j] = t[i][0] * r[3 * j] + t[i][1] * r[3 * j + 1] + t[i][2] * r[3 * j + 2];
}

/* Adds the 3 x 3 block m at node blocks (i, j), i <= j (only the upper triangle of the matrix is
 * stored: the block's three columns are contiguous rows of m^T). For i = j, m's upper triangle. */
static void add_node_block(pf_block_matrix *k, int64_t slot, int32_t i, int32_t j,
                           const double m[9])
{
    int64_t row0 = k->adj_row[slot];
    for (int c = 0; c < 3; ++c) {
        double *v = k->val + k->col_ptr[3 * (int64_t)j + c] + row0;
        for (int r = 0; r < 3; ++r)
            if (i != j || r <= c)
                v[r] += m[3 * r + c];
    }
}

/* The rows of W = R B R^T for the 3 x 3 block B at b (row stride n), lane j of row i holding
 * W_ij (lane 3 zero): with the columns c_q of R, (B R^T)_p = sum_q B_pq c_q, then
 * W_i = sum_p R_ip (B R^T)_p. */
static inline void warp_rows(const double *r, const lanes_d col[3], const double *b, int32_t n,
                             lanes_d w[3])
{
    lanes_d t[3];
    for (int p = 0; p < 3; ++p) {
        const double *bp = b + (size_t)p * n;
        t[p] = (bp[0] * col[0] + bp[1] * col[1]) + bp[2] * col[2];
    }
    for (int i = 0; i < 3; ++i)
        w[i] = (r[3 * i] * t[0] + r[3 * i + 1] * t[1]) + r[3 * i + 2] * t[2];
}

/* Adds the block M of node blocks (i, j), i <= j, given the rows of M^T (its columns): column c of
 * the stored block is contiguous. For i = j, M's upper triangle. */
static inline void add_block_columns(pf_block_matrix *k, int64_t slot, int32_t i, int32_t j,
                                     const lanes_d mt[3])
{
    int64_t row0 = k->adj_row[slot];
    for (int c = 0; c < 3; ++c) {
        double *v = k->val + k->col_ptr[3 * (int64_t)j + c] + row0;
        for (int r = 0; r < 3; ++r)
            if (i != j || r <= c)
                v[r] += mt[c][r];
    }
}

/* The warped blocks (a, c), c >= a, of element e's free node pairs added to k: the stored block
 * (i, j), i <= j, is K'_ac when i = block(a) <= j = block(c) (its columns: the rows of
 * K'_ac^T = R K_ca R^T), else K'_ca (the rows of K'_ac = R K_ac R^T); each scaled by s (folded
 * into R's columns: exact for s = 1), plus, with the element's mass me (k x k, NULL: none),
 * mscale me_ac I (rotation invariant: R (m I) R^T = m I). */
PF_KERNEL_CLONES
static void scatter_free_pairs(const int32_t *block, const int32_t *nodes, int32_t kn,
                               const double *ke, const double *r, double s, const double *me,
                               double mscale, const int64_t *slot, pf_block_matrix *k)
{
    int32_t n = 3 * kn;
    lanes_d col[3];
    for (int q = 0; q < 3; ++q)
        col[q] = (lanes_d){s * r[q], s * r[3 + q], s * r[6 + q], 0};
    for (int32_t a = 0; a < kn; ++a) {
        int32_t i = block[nodes[a]];
        if (i < 0)
            continue;
        for (int32_t c = a; c < kn; ++c) {
            int32_t j = block[nodes[c]];
            if (j < 0)
                continue;
            lanes_d w[3];
            if (i <= j)
                warp_rows(r, col, ke + (size_t)3 * c * n + 3 * a, n, w);
            else
                warp_rows(r, col, ke + (size_t)3 * a * n + 3 * c, n, w);
            if (me) {
                double m = mscale * me[a * kn + c];
                for (int d = 0; d < 3; ++d)
                    w[d][d] += m;
            }
            add_block_columns(k, slot[a * kn + c], i <= j ? i : j, i <= j ? j : i, w);
        }
    }
}

/* y_rows -= m g (transpose: m^T g). */
static void subtract_times(const double m[9], bool transpose, const double *g, double *y)
{
    for (int p = 0; p < 3; ++p)
        for (int q = 0; q < 3; ++q)
            y[p] -= (transpose ? m[3 * q + p] : m[3 * p + q]) * g[q];
}

void pf_cg_assemble_stiffness(const pf_cg *cg, const pf_cg_map *map, const double *rot,
                              const double *x0, const double *g, double *scratch,
                              pf_block_matrix *k, double *f)
{
    pf_block_matrix_zero(k);
    const pf_basis *b = &cg->basis;
    size_t nmax = 3 * (size_t)cg->max_nodes;
    double *y = scratch, *z = y + nmax;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes), n = 3 * kn;
        const double *ke = pf_cg_elem_stiffness(cg, e);
        const double *r = rot ? rot + 9 * (size_t)e : NULL;
        /* Constant force of the free rows: R K (I - R^T) X - K' g_c (K' = R K R^T). */
        bool any = r != NULL;
        if (r) {
            for (int32_t a = 0; a < kn; ++a) {
                const double *xa = x0 + 3 * (size_t)nodes[a];
                for (int i = 0; i < 3; ++i)
                    y[3 * a + i] = xa[i] - (r[i] * xa[0] + r[3 + i] * xa[1] + r[6 + i] * xa[2]);
            }
            symmetric_mul(ke, n, y, z);
            for (int32_t a = 0; a < kn; ++a)
                for (int i = 0; i < 3; ++i)
                    y[3 * a + i] = r[3 * i] * z[3 * a] + r[3 * i + 1] * z[3 * a + 1] +
                                   r[3 * i + 2] * z[3 * a + 2];
        } else {
            memset(y, 0, (size_t)n * sizeof *y);
        }
        /* the blocks (a, c), c >= a, warped and scattered at once; a pair of a free and a fixed
         * node adds its term of -K'_fc g_c instead */
        const int64_t *slot = map->slot + cg->me_offsets[e];
        if (r)
            scatter_free_pairs(map->node_block, nodes, kn, ke, r, 1, NULL, 0, slot, k);
        for (int32_t a = 0; a < kn; ++a) {
            int32_t i = map->node_block[nodes[a]];
            for (int32_t c = a; c < kn; ++c) {
                int32_t j = map->node_block[nodes[c]];
                if ((i < 0 && j < 0) || (i < 0 && !g) || (j < 0 && !g) || (r && i >= 0 && j >= 0))
                    continue;
                const double *kac = ke + (size_t)3 * a * n + 3 * c;
                double m[9];
                if (r) {
                    warp_block(r, kac, n, m);
                } else {
                    for (int p = 0; p < 3; ++p)
                        for (int q = 0; q < 3; ++q)
                            m[3 * p + q] = kac[(size_t)p * n + q];
                }
                if (i >= 0 && j >= 0) {
                    if (i <= j) {
                        add_node_block(k, slot[a * kn + c], i, j, m);
                    } else {
                        const double mt[9] = {m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]};
                        add_node_block(k, slot[a * kn + c], j, i, mt);
                    }
                } else if (i >= 0) {
                    subtract_times(m, false, g + 3 * (size_t)nodes[c], y + 3 * a);
                    any = true;
                } else {
                    subtract_times(m, true, g + 3 * (size_t)nodes[a], y + 3 * c);
                    any = true;
                }
            }
        }
        if (any)
            for (int32_t a = 0; a < kn; ++a) {
                int32_t i = map->node_block[nodes[a]];
                if (i >= 0)
                    for (int c = 0; c < 3; ++c)
                        f[3 * (size_t)i + c] += y[3 * a + c];
            }
    }
}

/* ---- the step's system in one pass -------------------------------------------------------- */

static const double IDENTITY[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

/* f_a -= R_e K_e (R_e^T x - X) over e's free nodes a (x = X + u, u [3 n_nodes] with the fixed
 * nodes at their prescribed displacements; R_e = I: f -= K_e u exactly). y, z [3 k] scratch. */
static void subtract_elastic_force(const int32_t *block, const int32_t *nodes, int32_t kn,
                                   const double *ke, const double *r, const double *x0,
                                   const double *u, double *y, double *z, double *f)
{
    int32_t n = 3 * kn;
    for (int32_t a = 0; a < kn; ++a) {
        const double *ua = u + 3 * (size_t)nodes[a];
        if (!r) {
            memcpy(y + 3 * a, ua, 3 * sizeof *y);
            continue;
        }
        const double *xa = x0 + 3 * (size_t)nodes[a];
        double x[3] = {xa[0] + ua[0], xa[1] + ua[1], xa[2] + ua[2]};
        for (int i = 0; i < 3; ++i)
            y[3 * a + i] = (r[i] * x[0] + r[3 + i] * x[1] + r[6 + i] * x[2]) - xa[i];
    }
    symmetric_mul(ke, n, y, z);
    for (int32_t a = 0; a < kn; ++a) {
        int32_t i = block[nodes[a]];
        if (i < 0)
            continue;
        const double *za = z + 3 * a;
        for (int d = 0; d < 3; ++d)
            f[3 * (size_t)i + d] -=
                r ? r[3 * d] * za[0] + r[3 * d + 1] * za[1] + r[3 * d + 2] * za[2] : za[d];
    }
}

/* mv_a += sum_c me_ac v_c over e's free nodes a, c. */
static void add_mass_times(const int32_t *block, const int32_t *nodes, int32_t kn,
                           const double *me, const double *v, double *mv)
{
    for (int32_t a = 0; a < kn; ++a) {
        int32_t i = block[nodes[a]];
        if (i < 0)
            continue;
        double s0 = 0, s1 = 0, s2 = 0;
        for (int32_t c = 0; c < kn; ++c) {
            int32_t j = block[nodes[c]];
            if (j < 0)
                continue;
            double m = me[a * kn + c];
            const double *vj = v + 3 * (size_t)j;
            s0 += m * vj[0];
            s1 += m * vj[1];
            s2 += m * vj[2];
        }
        mv[3 * (size_t)i] += s0;
        mv[3 * (size_t)i + 1] += s1;
        mv[3 * (size_t)i + 2] += s2;
    }
}

void pf_cg_assemble_step(const pf_cg *cg, const pf_cg_map *map, const pf_cg_step *in,
                         double *scratch, pf_block_matrix *k, double *f, double *mv)
{
    pf_block_matrix_zero(k);
    const pf_basis *b = &cg->basis;
    const int32_t *block = map->node_block;
    double *y = scratch, *z = y + 3 * (size_t)cg->max_nodes;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        const double *ke = pf_cg_elem_stiffness(cg, e);
        const double *r = in->rot ? in->rot + 9 * (size_t)e : NULL;
        const double *me = in->lumped ? NULL : pf_cg_elem_mass(cg, e);
        subtract_elastic_force(block, nodes, kn, ke, r, in->x0, in->u, y, z, f);
        scatter_free_pairs(block, nodes, kn, ke, r ? r : IDENTITY, in->kscale, me, in->mscale,
                           map->slot + cg->me_offsets[e], k);
        if (me)
            add_mass_times(block, nodes, kn, me, in->v, mv);
    }
    if (in->lumped) {
        pf_cg_add_mass(cg, map, true, in->mscale, k);
        pf_cg_mass_mul(cg, map, true, 1, in->v, mv);
    }
}

/* ---- mass --------------------------------------------------------------------------------- */

/* Adds m I to a 3 x 3 node block of the stored (upper) triangle: slot in block column j. */
static void add_scaled_identity(pf_block_matrix *k, int64_t slot, int32_t j, double m)
{
    int64_t row0 = k->adj_row[slot];
    for (int c = 0; c < 3; ++c)
        k->val[k->col_ptr[3 * (int64_t)j + c] + row0 + c] += m;
}

void pf_cg_add_mass(const pf_cg *cg, const pf_cg_map *map, bool lumped, double alpha,
                    pf_block_matrix *k)
{
    if (lumped) {
        for (int32_t i = 0; i < map->n_free; ++i)
            add_scaled_identity(k, k->adj_offsets[i + 1] - 1, i,
                                alpha * cg->lumped[map->block_node[i]]);
        return;
    }
    const pf_basis *b = &cg->basis;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        const double *me = pf_cg_elem_mass(cg, e);
        const int64_t *slot = map->slot + cg->me_offsets[e];
        for (int32_t a = 0; a < kn; ++a) {
            int32_t i = map->node_block[nodes[a]];
            if (i < 0)
                continue;
            for (int32_t c = a; c < kn; ++c) {
                int32_t j = map->node_block[nodes[c]];
                if (j < 0)
                    continue;
                add_scaled_identity(k, slot[a * kn + c], i > j ? i : j, alpha * me[a * kn + c]);
            }
        }
    }
}

void pf_cg_mass_mul(const pf_cg *cg, const pf_cg_map *map, bool lumped, double alpha,
                    const double *x, double *y)
{
    if (lumped) {
        for (int32_t i = 0; i < map->n_free; ++i) {
            double m = alpha * cg->lumped[map->block_node[i]];
            for (int c = 0; c < 3; ++c)
                y[3 * (size_t)i + c] += m * x[3 * (size_t)i + c];
        }
        return;
    }
    const pf_basis *b = &cg->basis;
    for (int32_t e = 0; e < cg->n_elems; ++e) {
        const int32_t *nodes;
        int32_t kn = pf_basis_elem_nodes(b, e, &nodes);
        const double *me = pf_cg_elem_mass(cg, e);
        for (int32_t a = 0; a < kn; ++a) {
            int32_t i = map->node_block[nodes[a]];
            if (i < 0)
                continue;
            for (int32_t c = 0; c < kn; ++c) {
                int32_t j = map->node_block[nodes[c]];
                if (j < 0)
                    continue;
                double m = alpha * me[a * kn + c];
                for (int d = 0; d < 3; ++d)
                    y[3 * (size_t)i + d] += m * x[3 * (size_t)j + d];
            }
        }
    }
}
