/* Evaluation of the shape functions of pf/basis.h: closed forms (barycentric, trilinear) and
 * harmonic (kernels 1/r plus a linear polynomial, then the exactness projection of basis.h), at a
 * point or at a block of points (one dgemm). The data layouts are in basis_internal.h. */
#include <math.h>
#include <string.h>

#include <cblas.h>

#include "basis_internal.h"

static void eval_affine(const double *d, pf_basis_kind kind, double *v, double *gv /* [3*8] */,
                        pf_vec3 x)
{
    double r[3] = {x.x - d[0], x.y - d[1], x.z - d[2]};
    const double *mi = d + 3;
    double l[3];
    for (int i = 0; i < 3; ++i)
        l[i] = mi[3 * i] * r[0] + mi[3 * i + 1] * r[1] + mi[3 * i + 2] * r[2];
    if (kind == PF_BASIS_TET) {
        v[0] = 1 - l[0] - l[1] - l[2];
        for (int c = 0; c < 3; ++c) {
            gv[c] = -(mi[c] + mi[3 + c] + mi[6 + c]);
            for (int i = 0; i < 3; ++i)
                gv[3 * (i + 1) + c] = mi[3 * i + c];
        }
        for (int i = 0; i < 3; ++i)
            v[i + 1] = l[i];
        return;
    }
    /* Trilinear: N_bits = prod_d (bit_d ? l_d : 1 - l_d); grad by the chain rule through minv. */
    for (int bits = 0; bits < 8; ++bits) {
        double f[3], df[3];
        for (int i = 0; i < 3; ++i) {
            int on = (bits >> i) & 1;
            f[i] = on ? l[i] : 1 - l[i];
            df[i] = on ? 1 : -1;
        }
        v[bits] = f[0] * f[1] * f[2];
        double dl[3] = {df[0] * f[1] * f[2], f[0] * df[1] * f[2], f[0] * f[1] * df[2]};
        for (int c = 0; c < 3; ++c)
            gv[3 * bits + c] = dl[0] * mi[c] + dl[1] * mi[3 + c] + dl[2] * mi[6 + c];
    }
}

/* Group values G[g] and scaled gradients dG[d ng + g] (d/dy) of a harmonic element, with the
 * exactness projection applied (see pf/basis.h). */
static void eval_harmonic(const double *d, pf_vec3 x, double *G, double *dG, bool want_grad)
{
    pf_vec3 c = pf_v3_load(d);
    double h = d[3];
    int32_t nk = (int32_t)d[4], ng = (int32_t)d[5];
    const double *kern = d + HDR, *coef = kern + 3 * nk;
    const double *gpos = coef + (size_t)(nk + N_POLY) * ng, *q = gpos + 3 * ng;
    double y[3] = {(x.x - c.x) / h, (x.y - c.y) / h, (x.z - c.z) / h};
    for (int32_t g = 0; g < ng; ++g)
        G[g] = 0;
    if (want_grad)
        for (int32_t g = 0; g < 3 * ng; ++g)
            dG[g] = 0;
    for (int32_t j = 0; j < nk; ++j) {
        double r0 = y[0] - kern[3 * j], r1 = y[1] - kern[3 * j + 1], r2 = y[2] - kern[3 * j + 2];
        double ir = 1 / sqrt(r0 * r0 + r1 * r1 + r2 * r2);
        const double *row = coef + (size_t)j * ng;
        for (int32_t g = 0; g < ng; ++g)
            G[g] += ir * row[g];
        if (want_grad) {
            double ir3 = ir * ir * ir;
            for (int32_t g = 0; g < ng; ++g) {
                double w = ir3 * row[g];
                dG[g] -= w * r0;
                dG[ng + g] -= w * r1;
                dG[2 * ng + g] -= w * r2;
            }
        }
    }
    const double *poly = coef + (size_t)nk * ng;
    for (int32_t g = 0; g < ng; ++g)
        G[g] += y[0] * poly[g] + y[1] * poly[ng + g] + y[2] * poly[2 * ng + g] + poly[3 * ng + g];
    double hv[N_HIGH], hd[3 * N_HIGH];
    harmonic_high(y, hv, want_grad ? hd : NULL);
    const double *high = poly + (size_t)N_LINEAR * ng;
    for (int a = 0; a < N_HIGH; ++a)
        for (int32_t g = 0; g < ng; ++g) {
            double cg = high[(size_t)a * ng + g];
            G[g] += hv[a] * cg;
            if (want_grad)
                for (int dd = 0; dd < 3; ++dd)
                    dG[(size_t)dd * ng + g] += hd[3 * a + dd] * cg;
        }
    double t[4] = {1, y[0], y[1], y[2]};
    apply_projection(3, ng, gpos, q, t, G);
    if (!want_grad)
        return;
    for (int dd = 0; dd < 3; ++dd) {
        double *D = dG + (size_t)dd * ng;
        for (int32_t g = 0; g < ng; ++g)
            D[g] += poly[(size_t)dd * ng + g];
        double td[4] = {0, dd == 0, dd == 1, dd == 2};
        apply_projection(3, ng, gpos, q, td, D);
    }
}

void pf_basis_eval(const pf_basis *b, int32_t e, pf_vec3 x, double *n, double *grad)
{
    const double *d = b->data + b->data_offsets[e];
    int64_t o = b->node_offsets[e];
    int32_t k = (int32_t)(b->node_offsets[e + 1] - o);
    const int32_t *slot = b->node_slot + o;
    pf_basis_kind kind = (pf_basis_kind)b->kind[e];
    if (kind != PF_BASIS_HARMONIC) {
        double v[8], gv[24];
        eval_affine(d, kind, v, gv, x);
        for (int32_t i = 0; i < k; ++i) {
            if (n)
                n[i] = v[slot[i]];
            if (grad)
                for (int c = 0; c < 3; ++c)
                    grad[3 * i + c] = gv[3 * slot[i] + c];
        }
        return;
    }
    double G[PF_BASIS_MAX_NODES], dG[3 * PF_BASIS_MAX_NODES];
    eval_harmonic(d, x, G, dG, grad != NULL);
    int32_t nk = (int32_t)d[4], ng = (int32_t)d[5];
    const double *gcount = d + HDR + 3 * nk + (size_t)(nk + N_POLY) * ng + 7 * (size_t)ng;
    double ih = 1 / d[3];
    for (int32_t i = 0; i < k; ++i) {
        int32_t g = slot[i];
        double share = 1 / gcount[g];
        if (n)
            n[i] = G[g] * share;
        if (grad)
            for (int c = 0; c < 3; ++c)
                grad[3 * i + c] = dG[(size_t)c * ng + g] * share * ih;
    }
}

size_t pf_basis_eval_block_scratch(const pf_basis *b, int32_t e)
{
    if (b->kind[e] != PF_BASIS_HARMONIC)
        return 0;
    const double *d = b->data + b->data_offsets[e];
    size_t nk = (size_t)d[4], ng = (size_t)d[5];
    return 4 * (size_t)PF_BASIS_EVAL_BLOCK * (nk + N_POLY + ng);
}

/* The harmonic case of pf_basis_eval for a block of points as one product: the rows of
 * phi [r n x (nk + 4)] are, per point, the kernels 1/r and the polynomial (y, 1) (value row),
 * then (with gradients, r = 4) their derivatives by y_x, y_y, y_z; phi coef = the unprojected
 * group functions and their gradients, projected row by row as in eval_harmonic (eq. 14's
 * constraints). */
void pf_basis_eval_block(const pf_basis *b, int32_t e, int32_t n, const double *x, double *vals,
                         double *grads, double *scratch)
{
    const double *d = b->data + b->data_offsets[e];
    int64_t o = b->node_offsets[e];
    int32_t k = (int32_t)(b->node_offsets[e + 1] - o);
    if (b->kind[e] != PF_BASIS_HARMONIC) {
        for (int32_t p = 0; p < n; ++p)
            pf_basis_eval(b, e, pf_v3_load(x + 3 * (size_t)p), vals + (size_t)p * k,
                          grads ? grads + 3 * (size_t)p * k : NULL);
        return;
    }
    const int32_t *slot = b->node_slot + o;
    pf_vec3 c = pf_v3_load(d);
    double h = d[3], ih = 1 / h;
    int32_t nk = (int32_t)d[4], ng = (int32_t)d[5];
    const double *kern = d + HDR, *coef = kern + 3 * nk;
    const double *gpos = coef + (size_t)(nk + N_POLY) * ng, *q = gpos + 3 * ng,
                 *gcount = q + 4 * ng;
    size_t cols = (size_t)nk + N_POLY;
    int nr = grads ? 4 : 1; /* rows per point */
    double *phi = scratch, *out = scratch + 4 * (size_t)PF_BASIS_EVAL_BLOCK * cols;
    static const double dpoly[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
    for (int32_t p = 0; p < n; ++p) {
        double y[3] = {(x[3 * p] - c.x) / h, (x[3 * p + 1] - c.y) / h, (x[3 * p + 2] - c.z) / h};
        double *r0 = phi + (size_t)nr * p * cols;
        if (grads) {
            double *r1 = r0 + cols, *r2 = r1 + cols, *r3 = r2 + cols;
#pragma omp simd
            for (int32_t j = 0; j < nk; ++j) {
                double a0 = y[0] - kern[3 * j], a1 = y[1] - kern[3 * j + 1],
                       a2 = y[2] - kern[3 * j + 2];
                double ir = 1 / sqrt(a0 * a0 + a1 * a1 + a2 * a2), ir3 = ir * ir * ir;
                r0[j] = ir;
                r1[j] = -ir3 * a0;
                r2[j] = -ir3 * a1;
                r3[j] = -ir3 * a2;
            }
            memcpy(r1 + nk, dpoly[0], sizeof dpoly[0]);
            memcpy(r2 + nk, dpoly[1], sizeof dpoly[1]);
            memcpy(r3 + nk, dpoly[2], sizeof dpoly[2]);
        } else {
#pragma omp simd
            for (int32_t j = 0; j < nk; ++j) {
                double a0 = y[0] - kern[3 * j], a1 = y[1] - kern[3 * j + 1],
                       a2 = y[2] - kern[3 * j + 2];
                r0[j] = 1 / sqrt(a0 * a0 + a1 * a1 + a2 * a2);
            }
        }
        double poly[4] = {y[0], y[1], y[2], 1};
        memcpy(r0 + nk, poly, sizeof poly);
        double hd[3 * N_HIGH];
        harmonic_high(y, r0 + nk + N_LINEAR, grads ? hd : NULL);
        if (grads)
            for (int a = 0; a < N_HIGH; ++a)
                for (int dd = 0; dd < 3; ++dd)
                    r0[(size_t)(dd + 1) * cols + nk + N_LINEAR + a] = hd[3 * a + dd];
    }
    cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, nr * n, ng, (int)cols, 1, phi, (int)cols,
                coef, ng, 0, out, ng);
    for (int32_t p = 0; p < n; ++p) {
        const double *y = phi + (size_t)nr * p * cols + nk; /* y_x, y_y, y_z, 1 */
        double t[4][4] = {{1, y[0], y[1], y[2]}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
        double *G = out + (size_t)nr * p * ng;
        for (int r = 0; r < nr; ++r)
            apply_projection(3, ng, gpos, q, t[r], G + (size_t)r * ng);
        double *nv = vals + (size_t)p * k, *gv = grads ? grads + 3 * (size_t)p * k : NULL;
        for (int32_t i = 0; i < k; ++i) {
            int32_t g = slot[i];
            double share = 1 / gcount[g];
            nv[i] = G[g] * share;
            if (gv)
                for (int dd = 0; dd < 3; ++dd)
                    gv[3 * i + dd] = G[(size_t)(dd + 1) * ng + g] * share * ih;
        }
    }
}
