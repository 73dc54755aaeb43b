/* Face functions (harmonic paper sec. 4: the boundary data of a 3D cell are the 2D harmonic
 * coordinates of its faces), least squares by LAPACK, and the exactness projection. */
#include <float.h>
#include <math.h>
#include <string.h>

#include <lapacke.h>

#include "basis_internal.h"

/* ---- scratch ------------------------------------------------------------------------------ */

void *pf_ws_get(basis_ws *w, int which, size_t count, size_t size)
{
    size_t bytes;
    if (pf_mul_overflows(count, size, &bytes))
        return NULL;
    if (bytes == 0)
        bytes = 16;
    if (bytes > w->cap[which]) {
        pf_free(w->buf[which]);
        size_t cap = bytes + bytes / 2;
        w->buf[which] = pf_alloc(cap);
        w->cap[which] = w->buf[which] ? cap : 0;
    }
    return w->buf[which];
}

void pf_ws_release(basis_ws *w)
{
    for (int k = 0; k < WS_COUNT; ++k)
        pf_free(w->buf[k]);
    memset(w, 0, sizeof *w);
}

/* ---- least squares (paper eq. 14) --------------------------------------------------------- */

pf_status pf_lsq_solve(basis_ws *w, int32_t m, int32_t cols, int32_t g, double rcond, bool *used_svd,
                    pf_error *err)
{
    double *a = w->buf[WS_A], *b = w->buf[WS_B];
    lapack_int ldb = m > cols ? m : cols, info = -1;
    double rc = 0;
    if (m >= cols) {
        /* Householder QR. Below QR_BLOCKED_MIN columns (the face systems) the plain LAPACK
         * factorisation is fastest; above (the element systems, 100-250 columns) the compact WY
         * form blocked by QR_BLOCK columns is 1.3-1.5x faster (LAPACK's dgeqrf blocks only beyond
         * 128 columns, and dgels also scans A and B for their norms first). */
        bool blocked = cols >= QR_BLOCKED_MIN;
        lapack_int nb = blocked ? QR_BLOCK : 1;
        size_t lwork = (size_t)QR_BLOCK * (size_t)(cols > g ? cols : g) + 3 * (size_t)cols;
        double *t = pf_ws_get(w, WS_TFACTOR, (size_t)nb * (size_t)cols, sizeof *t);
        double *work = pf_ws_get(w, WS_WORK, lwork, sizeof *work);
        lapack_int *iwork = pf_ws_get(w, WS_IWORK, (size_t)cols + 1, sizeof *iwork);
        PF_CHECK(t && work && iwork, err, PF_ERR_NOMEM, "least squares: no memory for %zu doubles",
                 lwork);
        info = blocked ? LAPACKE_dgeqrt_work(LAPACK_COL_MAJOR, m, cols, nb, a, m, t, nb, work)
                       : LAPACKE_dgeqrf_work(LAPACK_COL_MAJOR, m, cols, a, m, t, work,
                                             (lapack_int)lwork);
        if (info == 0)
            info =
                LAPACKE_dtrcon_work(LAPACK_COL_MAJOR, '1', 'U', 'N', cols, a, m, &rc, work, iwork);
        if (info == 0 && rc >= rcond) {
            info = blocked ? LAPACKE_dgemqrt_work(LAPACK_COL_MAJOR, 'L', 'T', m, g, cols, nb, a, m,
                                                  t, nb, b, ldb, work)
                           : LAPACKE_dormqr_work(LAPACK_COL_MAJOR, 'L', 'T', m, g, cols, a, m, t, b,
                                                 ldb, work, (lapack_int)lwork);
            if (info == 0)
                info = LAPACKE_dtrtrs_work(LAPACK_COL_MAJOR, 'U', 'N', 'N', cols, g, a, m, b, ldb);
        }
    }
    *used_svd = info != 0 || !(rc >= rcond);
    if (!*used_svd)
        return PF_OK;

    /* Rank-deficient (paper sec. 5, "Degenerate elements"): the SVD pseudo-inverse. */
    memcpy(a, w->buf[WS_A0], (size_t)m * (size_t)cols * sizeof *a);
    memcpy(b, w->buf[WS_B0], (size_t)ldb * (size_t)g * sizeof *b);
    int32_t mn = m < cols ? m : cols;
    double *sing = pf_ws_get(w, WS_SING, (size_t)mn, sizeof *sing);
    PF_CHECK(sing, err, PF_ERR_NOMEM, "least squares: no memory");
    lapack_int rank, iq = 0;
    double q;
    info = LAPACKE_dgelsd_work(LAPACK_COL_MAJOR, m, cols, g, a, m, b, ldb, sing, rcond, &rank, &q,
                               -1, &iq);
    PF_CHECK(info == 0, err, PF_ERR_NUMERIC, "least squares: dgelsd workspace query failed");
    size_t lwork = (size_t)q;
    double *work = pf_ws_get(w, WS_WORK, lwork, sizeof *work);
    lapack_int *iwork = pf_ws_get(w, WS_IWORK, (size_t)(iq > 1 ? iq : 1), sizeof *iwork);
    PF_CHECK(work && iwork, err, PF_ERR_NOMEM, "least squares: no memory for %zu doubles", lwork);
    info = LAPACKE_dgelsd_work(LAPACK_COL_MAJOR, m, cols, g, a, m, b, ldb, sing, rcond, &rank, work,
                               (lapack_int)lwork, iwork);
    PF_CHECK(info == 0, err, PF_ERR_NUMERIC, "least squares: the SVD did not converge (%d)",
             (int)info);
    return PF_OK;
}

/* ---- exactness projection ------------------------------------------------------------------ */

/* Inverse of the small symmetric positive matrix s (n x n, n <= 4) by Gauss-Jordan with partial
 * pivoting; false when singular relative to its largest entry. */
static bool invert_small(int n, const double *s, double *inv)
{
    double a[4][8];
    double big = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            a[i][j] = s[i * n + j];
            a[i][n + j] = i == j;
            big = fmax(big, fabs(s[i * n + j]));
        }
    for (int c = 0; c < n; ++c) {
        int piv = c;
        for (int r = c + 1; r < n; ++r)
            if (fabs(a[r][c]) > fabs(a[piv][c]))
                piv = r;
        if (!(fabs(a[piv][c]) > 1e-13 * big))
            return false;
        for (int j = 0; j < 2 * n; ++j) {
            double t = a[c][j];
            a[c][j] = a[piv][j];
            a[piv][j] = t;
        }
        double d = 1 / a[c][c];
        for (int j = 0; j < 2 * n; ++j)
            a[c][j] *= d;
        for (int r = 0; r < n; ++r)
            if (r != c) {
                double f = a[r][c];
                for (int j = 0; j < 2 * n; ++j)
                    a[r][j] -= f * a[c][j];
            }
    }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            inv[i * n + j] = a[i][n + j];
    return true;
}

pf_status pf_exactness_projection(int dim, int32_t ng, const double *pos, double *q)
{
    int c = dim + 1;
    double ptp[16] = {0}, inv[16];
    for (int32_t g = 0; g < ng; ++g) {
        double row[4] = {1, pos[dim * g], pos[dim * g + 1], dim == 3 ? pos[dim * g + 2] : 0};
        for (int i = 0; i < c; ++i)
            for (int j = 0; j < c; ++j)
                ptp[i * c + j] += row[i] * row[j];
    }
    if (!invert_small(c, ptp, inv))
        return PF_ERR_NUMERIC;
    for (int32_t g = 0; g < ng; ++g) {
        double row[4] = {1, pos[dim * g], pos[dim * g + 1], dim == 3 ? pos[dim * g + 2] : 0};
        for (int i = 0; i < c; ++i) {
            double s = 0;
            for (int j = 0; j < c; ++j)
                s += inv[i * c + j] * row[j];
            q[c * g + i] = s;
        }
    }
    return PF_OK;
}

/* ---- polygons in the plane ---------------------------------------------------------------- */

bool pf_polygon_contains(const double *p, int32_t n, double x, double y)
{
    bool in = false;
    for (int32_t i = 0, j = n - 1; i < n; j = i++) {
        double yi = p[2 * i + 1], yj = p[2 * j + 1];
        if ((yi > y) != (yj > y)) {
            double xc = p[2 * j] + (y - yj) / (yi - yj) * (p[2 * i] - p[2 * j]);
            if (x < xc)
                in = !in;
        }
    }
    return in;
}

double pf_polygon_boundary_distance(const double *p, int32_t n, double x, double y)
{
    double best2 = INFINITY; /* squared: one square root at the end (scaled, O(1) coordinates) */
    for (int32_t i = 0; i < n; ++i) {
        int32_t j = (i + 1) % n;
        double ex = p[2 * j] - p[2 * i], ey = p[2 * j + 1] - p[2 * i + 1];
        double dx = x - p[2 * i], dy = y - p[2 * i + 1];
        double l2 = ex * ex + ey * ey;
        double t = l2 > 0 ? (dx * ex + dy * ey) / l2 : 0;
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        double rx = dx - t * ex, ry = dy - t * ey;
        best2 = fmin(best2, rx * rx + ry * ry);
    }
    return sqrt(best2);
}

/* ---- face frame ------------------------------------------------------------------------------ */

pf_status pf_face_init(face_fn *f, const pf_mesh *m, int32_t face, pf_error *err)
{
    memset(f, 0, sizeof *f);
    int64_t a = m->face_offsets[face], b = m->face_offsets[face + 1];
    PF_CHECK(b - a >= 3, err, PF_ERR_INVALID, "face %d has %lld nodes", (int)face,
             (long long)(b - a));
    f->n = (int32_t)(b - a);
    f->nodes = m->face_nodes + a;
    for (int32_t i = 0; i < f->n; ++i)
        PF_CHECK(f->nodes[i] < (uint32_t)m->n_nodes, err, PF_ERR_INVALID,
                 "face %d: node %u out of range", (int)face, f->nodes[i]);
    pf_vec3 area = pf_polygon_area_vector(m->x, f->nodes, f->n);
    pf_vec3 o = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < f->n; ++i)
        o = pf_v3_add(o, pf_v3_load(m->x + 3 * f->nodes[i]));
    o = pf_v3_scale(o, 1.0 / f->n);
    double s = 0, diam = 0;
    int32_t far = 0;
    for (int32_t i = 0; i < f->n; ++i) {
        pf_vec3 xi = pf_v3_load(m->x + 3 * f->nodes[i]);
        double d = pf_v3_dist(xi, o);
        if (d > s)
            s = d, far = i;
        for (int32_t j = 0; j < i; ++j)
            diam = fmax(diam, pf_v3_dist(xi, pf_v3_load(m->x + 3 * f->nodes[j])));
    }
    double an = pf_v3_norm(area);
    PF_CHECK(an > 1e-14 * diam * diam && s > 0, err, PF_ERR_INVALID, "face %d has zero area",
             (int)face);
    f->o = o;
    f->s = s;
    f->diam = diam;
    f->nrm = pf_v3_scale(area, 1 / an);
    pf_vec3 r = pf_v3_sub(pf_v3_load(m->x + 3 * f->nodes[far]), o);
    f->u = pf_v3_normalize(pf_v3_sub(r, pf_v3_scale(f->nrm, pf_v3_dot(r, f->nrm))));
    f->v = pf_v3_cross(f->nrm, f->u);
    PF_CHECK(PF_ALLOC_N(f->p2, 2 * f->n), err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    for (int32_t i = 0; i < f->n; ++i)
        face_coords(f, pf_v3_load(m->x + 3 * f->nodes[i]), &f->p2[2 * i], &f->p2[2 * i + 1]);
    return PF_OK;
}

void pf_face_release(face_fn *f)
{
    pf_free(f->p2);
    pf_free(f->slot);
    pf_free(f->gcount);
    pf_free(f->gpos);
    pf_free(f->q);
    pf_free(f->kern);
    pf_free(f->coef);
    memset(f, 0, sizeof *f);
}

/* ---- closed forms on faces --------------------------------------------------------------------
 * A triangle's harmonic coordinates are its barycentric coordinates. On a parallelogram the
 * bilinear functions are the restriction of the trilinear functions of a parallelepiped hex that
 * may share the face (and harmonic when the parallelogram is a rectangle), so a harmonic cell
 * next to a closed-form hex matches it on their common face. */

static bool invert2(const double *e1, const double *e2, double *minv)
{
    double det = e1[0] * e2[1] - e1[1] * e2[0];
    double scale = fabs(e1[0]) + fabs(e1[1]) + fabs(e2[0]) + fabs(e2[1]);
    if (!(fabs(det) > 1e-12 * scale * scale))
        return false;
    minv[0] = e2[1] / det, minv[1] = -e2[0] / det;
    minv[2] = -e1[1] / det, minv[3] = e1[0] / det;
    return true;
}

static bool face_closed_form(face_fn *f, double tol)
{
    const double *p = f->p2;
    if (f->n == 3) {
        double e1[2] = {p[2] - p[0], p[3] - p[1]}, e2[2] = {p[4] - p[0], p[5] - p[1]};
        if (!invert2(e1, e2, f->minv))
            return false;
        f->a0[0] = p[0], f->a0[1] = p[1];
        f->kind = FACE_LINEAR;
        return true;
    }
    if (f->n != 4)
        return false;
    /* Parallelogram: a0 + a2 = a1 + a3 (relative to the face's scale, 2D coordinates are / s). */
    double dx = p[0] + p[4] - p[2] - p[6], dy = p[1] + p[5] - p[3] - p[7];
    if (hypot(dx, dy) > tol * f->diam / f->s)
        return false;
    double e1[2] = {p[2] - p[0], p[3] - p[1]}, e2[2] = {p[6] - p[0], p[7] - p[1]};
    if (!invert2(e1, e2, f->minv))
        return false;
    f->a0[0] = p[0], f->a0[1] = p[1];
    f->bits[0] = 0, f->bits[1] = 1, f->bits[2] = 3, f->bits[3] = 2;
    f->kind = FACE_BILINEAR;
    return true;
}

/* ---- 2D MFS on a face (paper eq. 11-14 with psi = log r) ------------------------------------- */

typedef struct pt2 {
    double x, y;
    int32_t a, b; /* value: linear between nodes a and b (a == b: node a) */
    double t;
} pt2;

/* Samples of the face boundary: the nodes, then on each edge of length L the points
 * t = j / (n + 1), j = 1..n, with n = max(at_least, ceil(L / spacing) - 1) (scaled units): at
 * least the paper's 3-5 per edge, more on long edges. 2D systems are small, so the face data
 * (the 3D boundary condition) is made accurate rather than cheap. */
static int32_t edge_count(double len, double spacing, int32_t at_least)
{
    double n = ceil(len / spacing - 1e-9) - 1;
    return n > at_least ? (int32_t)n : at_least;
}

static int32_t face_samples(const face_fn *f, double spacing, int32_t at_least, pt2 *out)
{
    int32_t c = 0;
    for (int32_t a = 0; a < f->n; ++a)
        out[c++] = (pt2){f->p2[2 * a], f->p2[2 * a + 1], a, a, 0};
    for (int32_t a = 0; a < f->n; ++a) {
        int32_t b = (a + 1) % f->n;
        double ex = f->p2[2 * b] - f->p2[2 * a], ey = f->p2[2 * b + 1] - f->p2[2 * a + 1];
        int32_t ne = hypot(ex, ey) > 0 ? edge_count(hypot(ex, ey), spacing, at_least) : 0;
        for (int32_t j = 1; j <= ne; ++j) {
            double t = (double)j / (ne + 1);
            out[c++] = (pt2){f->p2[2 * a] + t * ex, f->p2[2 * a + 1] + t * ey, a, b, t};
        }
    }
    return c;
}

/* Longest edge (scaled units). */
static double longest_edge(const face_fn *f)
{
    double l = 0;
    for (int32_t a = 0; a < f->n; ++a) {
        int32_t b = (a + 1) % f->n;
        l = fmax(l, hypot(f->p2[2 * b] - f->p2[2 * a], f->p2[2 * b + 1] - f->p2[2 * a + 1]));
    }
    return l;
}

/* Outward unit normal (2D, counter-clockwise polygon) of edge a -> a+1. */
static void edge_normal(const face_fn *f, int32_t a, double *nx, double *ny)
{
    int32_t b = (a + 1) % f->n;
    double ex = f->p2[2 * b] - f->p2[2 * a], ey = f->p2[2 * b + 1] - f->p2[2 * a + 1];
    double l = hypot(ex, ey);
    *nx = l > 0 ? ey / l : 0;
    *ny = l > 0 ? -ex / l : 0;
}

static pf_status face_mfs(face_fn *f, int32_t face, const pf_basis_params *p, basis_ws *w,
                          pf_error *err)
{
    int32_t n = f->n;
    /* Coincident nodes: groups (paper sec. 5). */
    PF_CHECK(PF_ALLOC_N(f->slot, n) && PF_ALLOC_N(f->gcount, n) && PF_ALLOC_N(f->gpos, 2 * n) &&
                 PF_ALLOC_N(f->q, 3 * n),
             err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    double merge = p->merge_tol * f->diam / f->s;
    f->n_groups = 0;
    for (int32_t a = 0; a < n; ++a) {
        int32_t g = -1;
        for (int32_t c = 0; c < a && g < 0; ++c)
            if (hypot(f->p2[2 * a] - f->p2[2 * c], f->p2[2 * a + 1] - f->p2[2 * c + 1]) <= merge)
                g = f->slot[c];
        if (g < 0) {
            g = f->n_groups++;
            f->gcount[g] = 0;
            f->gpos[2 * g] = f->p2[2 * a], f->gpos[2 * g + 1] = f->p2[2 * a + 1];
        }
        f->slot[a] = g;
        f->gcount[g] += 1;
    }
    int32_t ng = f->n_groups;
    PF_CHECK(pf_exactness_projection(2, ng, f->gpos, f->q) == PF_OK, err, PF_ERR_INVALID,
             "face %d: nodes are collinear", (int)face);

    /* Kernels: samples moved outward by xi * diameter (eq. 12); at a node along the mean of its
     * two edge normals. Back toward the boundary, then dropped, when that lands inside. */
    /* Kernel samples every lmax / (2 edge_samples + 4) along the edges, at least 2 edge_samples
     * + 3 inside each (7 at the default), collocation points collocation_density times denser. */
    double lmax = longest_edge(f);
    int32_t per_edge = 2 * p->edge_samples + 3,
            per_edge_c = (int32_t)lround(p->collocation_density * (per_edge + 1)) - 1;
    double sp = lmax / (per_edge + 1), spc = sp / p->collocation_density;
    int32_t ncol = f->n;
    for (int32_t a = 0; a < f->n; ++a) {
        int32_t b = (a + 1) % f->n;
        ncol += edge_count(hypot(f->p2[2 * b] - f->p2[2 * a], f->p2[2 * b + 1] - f->p2[2 * a + 1]),
                           spc, per_edge_c);
    }
    pt2 *pts = pf_ws_get(w, WS_KERN, (size_t)ncol, sizeof *pts);
    PF_CHECK(pts, err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    int32_t ns = face_samples(f, sp, per_edge, pts);
    PF_CHECK(PF_ALLOC_N(f->kern, 2 * ns), err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    /* Offsets scaled down near short edges: a kernel resolves data on the scale of its
     * distance from the boundary. */
    double *nlen = pf_ws_get(w, WS_SING, (size_t)n, sizeof *nlen);
    PF_CHECK(nlen, err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    for (int32_t a = 0; a < n; ++a) {
        int32_t b = (a + 1) % n, z = (a + n - 1) % n;
        double l1 = hypot(f->p2[2 * b] - f->p2[2 * a], f->p2[2 * b + 1] - f->p2[2 * a + 1]);
        double l0 = hypot(f->p2[2 * z] - f->p2[2 * a], f->p2[2 * z + 1] - f->p2[2 * a + 1]);
        nlen[a] = fmin(l0 > 0 ? l0 : l1, l1 > 0 ? l1 : l0);
    }
    int32_t nk = 0;
    for (int32_t k = 0; k < ns; ++k) {
        double nx, ny, len;
        if (pts[k].a == pts[k].b)
            len = nlen[pts[k].a];
        else
            len = hypot(f->p2[2 * pts[k].b] - f->p2[2 * pts[k].a],
                        f->p2[2 * pts[k].b + 1] - f->p2[2 * pts[k].a + 1]);
        double off = p->xi * f->diam / f->s * fmin(1, len / lmax);
        if (pts[k].a == pts[k].b) {
            double n1x, n1y, n2x, n2y;
            edge_normal(f, pts[k].a, &n1x, &n1y);
            edge_normal(f, (pts[k].a + n - 1) % n, &n2x, &n2y);
            nx = n1x + n2x, ny = n1y + n2y;
            double l = hypot(nx, ny);
            if (l < 1e-6)
                continue;
            nx /= l, ny /= l;
        } else {
            edge_normal(f, pts[k].a, &nx, &ny);
        }
        for (double shrink = 1; shrink > 0.2; shrink *= 0.5) {
            double kx = pts[k].x + shrink * off * nx, ky = pts[k].y + shrink * off * ny;
            if (!pf_polygon_contains(f->p2, n, kx, ky) &&
                pf_polygon_boundary_distance(f->p2, n, kx, ky) > 0.2 * shrink * off) {
                f->kern[2 * nk] = kx, f->kern[2 * nk + 1] = ky;
                ++nk;
                break;
            }
        }
    }
    f->nk = nk;

    /* Collocation points (m ~ density * n) and the system of eq. 14. */
    int32_t m = face_samples(f, spc, per_edge_c, pts);
    int32_t cols = nk + N_POLY2, ldb = m > cols ? m : cols;
    double *A = pf_ws_get(w, WS_A, (size_t)m * cols, sizeof *A);
    double *A0 = pf_ws_get(w, WS_A0, (size_t)m * cols, sizeof *A0);
    double *B = pf_ws_get(w, WS_B, (size_t)ldb * ng, sizeof *B);
    double *B0 = pf_ws_get(w, WS_B0, (size_t)ldb * ng, sizeof *B0);
    PF_CHECK(A && A0 && B && B0, err, PF_ERR_NOMEM, "face %d: no memory", (int)face);
    for (int32_t r = 0; r < m; ++r) {
        for (int32_t j = 0; j < nk; ++j)
            A[r + (size_t)j * m] =
                0.5 * log((pts[r].x - f->kern[2 * j]) * (pts[r].x - f->kern[2 * j]) +
                          (pts[r].y - f->kern[2 * j + 1]) * (pts[r].y - f->kern[2 * j + 1]));
        A[r + (size_t)nk * m] = pts[r].x;
        A[r + (size_t)(nk + 1) * m] = pts[r].y;
        A[r + (size_t)(nk + 2) * m] = 1;
        double h[N_HIGH2];
        face_high(pts[r].x, pts[r].y, h);
        for (int a = 0; a < N_HIGH2; ++a)
            A[r + (size_t)(nk + N_LINEAR2 + a) * m] = h[a];
    }
    memset(B, 0, (size_t)ldb * ng * sizeof *B);
    for (int32_t r = 0; r < m; ++r) {
        B[r + (size_t)f->slot[pts[r].a] * ldb] += 1 - pts[r].t;
        if (pts[r].b != pts[r].a)
            B[r + (size_t)f->slot[pts[r].b] * ldb] += pts[r].t;
    }
    memcpy(A0, A, (size_t)m * cols * sizeof *A);
    memcpy(B0, B, (size_t)ldb * ng * sizeof *B);
    bool svd;
    PF_TRY(pf_lsq_solve(w, m, cols, ng, p->rank_rcond, &svd, err));
    PF_CHECK(PF_ALLOC_N(f->coef, (size_t)cols * ng), err, PF_ERR_NOMEM, "face %d: no memory",
             (int)face);
    for (int32_t j = 0; j < cols; ++j)
        for (int32_t g = 0; g < ng; ++g) {
            double c = B[j + (size_t)g * ldb];
            PF_CHECK(isfinite(c), err, PF_ERR_NUMERIC, "face %d: non-finite MFS coefficient",
                     (int)face);
            f->coef[(size_t)j * ng + g] = c;
        }
    f->kind = FACE_MFS;
    return PF_OK;
}

pf_status pf_face_solve(face_fn *f, const pf_mesh *m, int32_t face, const pf_basis_params *p,
                     basis_ws *w, pf_error *err)
{
    (void)m;
    double t0 = pf_time_seconds();
    if (!face_closed_form(f, p->parallel_tol))
        PF_TRY(face_mfs(f, face, p, w, err));
    f->setup_ms = 1e3 * (pf_time_seconds() - t0);
    return PF_OK;
}

void pf_face_eval(const face_fn *f, pf_vec3 x, double *vals)
{
    double pu, pv;
    face_coords(f, x, &pu, &pv);
    if (f->kind == FACE_LINEAR || f->kind == FACE_BILINEAR) {
        double du = pu - f->a0[0], dv = pv - f->a0[1];
        double s = f->minv[0] * du + f->minv[1] * dv, t = f->minv[2] * du + f->minv[3] * dv;
        if (f->kind == FACE_LINEAR) {
            vals[0] = 1 - s - t, vals[1] = s, vals[2] = t;
        } else {
            for (int a = 0; a < 4; ++a)
                vals[a] = ((f->bits[a] & 1) ? s : 1 - s) * ((f->bits[a] & 2) ? t : 1 - t);
        }
        return;
    }
    double G[PF_BASIS_MAX_NODES];
    int32_t ng = f->n_groups;
    for (int32_t g = 0; g < ng; ++g)
        G[g] = 0;
    for (int32_t j = 0; j < f->nk; ++j) {
        double dx = pu - f->kern[2 * j], dy = pv - f->kern[2 * j + 1];
        double psi = 0.5 * log(dx * dx + dy * dy);
        const double *row = f->coef + (size_t)j * ng;
        for (int32_t g = 0; g < ng; ++g)
            G[g] += psi * row[g];
    }
    const double *cu = f->coef + (size_t)f->nk * ng, *cv = cu + ng, *c1 = cv + ng;
    for (int32_t g = 0; g < ng; ++g)
        G[g] += pu * cu[g] + pv * cv[g] + c1[g];
    double h[N_HIGH2];
    face_high(pu, pv, h);
    for (int a = 0; a < N_HIGH2; ++a) {
        const double *row = c1 + (size_t)(1 + a) * ng;
        for (int32_t g = 0; g < ng; ++g)
            G[g] += h[a] * row[g];
    }
    double t[3] = {1, pu, pv};
    apply_projection(2, ng, f->gpos, f->q, t, G);
    for (int32_t a = 0; a < f->n; ++a)
        vals[a] = G[f->slot[a]] / f->gcount[f->slot[a]];
}
