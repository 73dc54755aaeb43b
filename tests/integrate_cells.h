/* The cells and the independent reference moments of the integration tests (test_integrate.c,
 * test_quadrature.c): monomial tables built by plain enumeration, simplex / triangle / square
 * formulas pulled back through affine maps in long double, error measures, and closed
 * polyhedra given by nodes and outward faces. Include after cmocka.h. */
#ifndef PF_TEST_INTEGRATE_CELLS_H
#define PF_TEST_INTEGRATE_CELLS_H

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <pf/integrate.h>

#include "test_random.h"

#define COUNT PF_MOMENT_MAX_COUNT
#define DMAX  PF_MOMENT_MAX_DEGREE

typedef long double real;

/* ---- test-side monomial tables, built by plain enumeration (not by the code under test) ---- */

static int EXPO[COUNT][3];
static int INDEX[DMAX + 1][DMAX + 1][DMAX + 1];

static inline void build_tables(void)
{
    int i = 0;
    for (int d = 0; d <= DMAX; ++d)
        for (int a = d; a >= 0; --a)
            for (int b = d - a; b >= 0; --b, ++i) {
                EXPO[i][0] = a, EXPO[i][1] = b, EXPO[i][2] = d - a - b;
                INDEX[a][b][d - a - b] = i;
            }
}

static inline int degree_of(int i)
{
    return EXPO[i][0] + EXPO[i][1] + EXPO[i][2];
}

static inline int count_of(int degree)
{
    return (degree + 1) * (degree + 2) * (degree + 3) / 6;
}

static inline real factorial(int n)
{
    real f = 1;
    for (int k = 2; k <= n; ++k)
        f *= k;
    return f;
}

/* ---- deterministic random numbers (rotations: test_random.h) ------------------------------- */

static inline void no_leaks(void)
{
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- reference moments -------------------------------------------------------------------- */

/* Moments of xi^beta over the reference cells, in local units. */
static inline real ref_simplex(const int *e) /* unit tetrahedron */
{
    return factorial(e[0]) * factorial(e[1]) * factorial(e[2]) / factorial(e[0] + e[1] + e[2] + 3);
}
static inline real ref_triangle(const int *e) /* unit triangle in the (xi, eta) plane */
{
    return e[2] ? 0 : factorial(e[0]) * factorial(e[1]) / factorial(e[0] + e[1] + 2);
}
static inline real ref_square(const int *e) /* unit square in the (xi, eta) plane */
{
    return e[2] ? 0 : 1.0L / ((e[0] + 1) * (e[1] + 1));
}

/* Adds sign * int over the image of a reference cell under x = v0 + J xi of every monomial of
 * xhat = (x - c) / s to out: the affine map in local coordinates, xhat = o + A xi, is expanded
 * monomial by monomial (x^a y^b z^c = one more linear factor times a monomial of degree - 1),
 * then each xi^beta integrated over the reference cell. measure = det J (3D, signed) or
 * |J e1 x J e2| (2D) in physical units. */
static inline void add_affine_moments(const pf_frame *fr, const double v0[3], double jac[3][3],
                                      real measure, real (*ref)(const int *), int degree, real sign,
                                      real *out)
{
    int n = count_of(degree);
    real(*coef)[COUNT] = calloc((size_t)n, sizeof *coef);
    assert_non_null(coef);
    real o[3], a[3][3];
    const double c[3] = {fr->center.x, fr->center.y, fr->center.z};
    for (int i = 0; i < 3; ++i) {
        o[i] = ((real)v0[i] - c[i]) / fr->scale;
        for (int j = 0; j < 3; ++j)
            a[i][j] = (real)jac[i][j] / fr->scale;
    }
    coef[0][0] = 1;
    for (int i = 1; i < n; ++i) {
        int e[3] = {EXPO[i][0], EXPO[i][1], EXPO[i][2]};
        int v = e[0] > 0 ? 0 : e[1] > 0 ? 1 : 2;
        e[v] -= 1;
        int parent = INDEX[e[0]][e[1]][e[2]];
        for (int k = 0; k < count_of(degree_of(i) - 1); ++k) {
            real p = coef[parent][k];
            if (p == 0)
                continue;
            coef[i][k] += o[v] * p;
            for (int j = 0; j < 3; ++j) {
                int f[3] = {EXPO[k][0], EXPO[k][1], EXPO[k][2]};
                f[j] += 1;
                coef[i][INDEX[f[0]][f[1]][f[2]]] += a[v][j] * p;
            }
        }
    }
    for (int i = 0; i < n; ++i) {
        real s = 0;
        for (int k = 0; k < n; ++k)
            if (coef[i][k] != 0)
                s += coef[i][k] * ref(EXPO[k]);
        out[i] += sign * measure * s;
    }
    free(coef);
}

/* Tetrahedron (p0, p1, p2, p3), signed by det(p1 - p0, p2 - p0, p3 - p0). */
static inline void add_tet_moments(const pf_frame *fr, const double *p0, const double *p1,
                                   const double *p2, const double *p3, int degree, real sign,
                                   real *out)
{
    double jac[3][3];
    const double *p[3] = {p1, p2, p3};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            jac[i][j] = p[j][i] - p0[i];
    real det = (real)jac[0][0] * ((real)jac[1][1] * jac[2][2] - (real)jac[1][2] * jac[2][1]) -
               (real)jac[0][1] * ((real)jac[1][0] * jac[2][2] - (real)jac[1][2] * jac[2][0]) +
               (real)jac[0][2] * ((real)jac[1][0] * jac[2][1] - (real)jac[1][1] * jac[2][0]);
    add_affine_moments(fr, p0, jac, det, ref_simplex, degree, sign, out);
}

/* Triangle (p0, p0 + e1, p0 + e2) or parallelogram (p0, p0 + e1, p0 + e1 + e2, p0 + e2). */
static inline void add_planar_moments(const pf_frame *fr, const double *p0, const double *e1,
                                      const double *e2, real (*ref)(const int *), int degree,
                                      real *out)
{
    double jac[3][3];
    for (int i = 0; i < 3; ++i)
        jac[i][0] = e1[i], jac[i][1] = e2[i], jac[i][2] = 0;
    real cx = (real)e1[1] * e2[2] - (real)e1[2] * e2[1];
    real cy = (real)e1[2] * e2[0] - (real)e1[0] * e2[2];
    real cz = (real)e1[0] * e2[1] - (real)e1[1] * e2[0];
    add_affine_moments(fr, p0, jac, sqrtl(cx * cx + cy * cy + cz * cz), ref, degree, 1, out);
}

/* int over the box [lo, hi] (physical) of xhat^a yhat^b zhat^c: products of 1D integrals
 * (B^(a+1) - A^(a+1)) / (a+1) in local coordinates, times scale^3. */
static inline void add_box_moments(const pf_frame *fr, const double lo[3], const double hi[3],
                                   int degree, real sign, real *out)
{
    const double c[3] = {fr->center.x, fr->center.y, fr->center.z};
    real s = fr->scale;
    for (int i = 0; i < count_of(degree); ++i) {
        real v = s * s * s;
        for (int k = 0; k < 3; ++k) {
            real a = ((real)lo[k] - c[k]) / s, b = ((real)hi[k] - c[k]) / s;
            int e = EXPO[i][k];
            v *= (powl(b, e + 1) - powl(a, e + 1)) / (e + 1);
        }
        out[i] += sign * v;
    }
}

/* ---- checking ----------------------------------------------------------------------------- */

/* Largest |xhat|, |yhat|, |zhat| over the nodes x[3 n]. */
static inline double local_radius(const double *x, int n, const pf_frame *fr)
{
    double r = 0;
    for (int i = 0; i < n; ++i) {
        pf_vec3 q = pf_v3_sub(pf_v3_load(x + 3 * i), fr->center);
        r = fmax(r, pf_v3_max_abs(q) / fr->scale);
    }
    return r;
}

/* Tolerance for degree d, relative to S_d (see the header comment). */
static inline double tolerance(int d)
{
    return d <= 4 ? 1e-13 : 1e-11;
}

/* Asserts |m_i - want_i| <= tol(d) * |measure| * rho^d for every moment and returns the largest
 * ratio err / (|measure| rho^d) seen. */
static inline double check_moments(const char *what, const double *m, const real *want, int degree,
                                   double measure, double rho)
{
    double worst = 0;
    for (int i = 0; i < count_of(degree); ++i) {
        int d = degree_of(i);
        double scale = fabs(measure) * pow(rho, d);
        double err = (double)fabsl((real)m[i] - want[i]) / scale;
        worst = fmax(worst, err);
        if (!(err <= tolerance(d)))
            fail_msg("%s: moment x^%d y^%d z^%d = %.17g, want %.17Lg (error %.3g S_%d)", what,
                     EXPO[i][0], EXPO[i][1], EXPO[i][2], m[i], want[i], err, d);
    }
    return worst;
}

/* ---- cells: nodes and outward faces ------------------------------------------------------- */

enum { CELL_NODES = 64, CELL_FACE_NODES = 256, CELL_FACES = 40 };

typedef struct cell {
    double x[3 * CELL_NODES];
    int n_nodes;
    uint32_t face_nodes[CELL_FACE_NODES];
    int64_t offsets[CELL_FACES + 1];
    int32_t n_faces;
} cell;

static inline void cell_init(cell *c)
{
    memset(c, 0, sizeof *c);
}

static inline uint32_t cell_node(cell *c, pf_vec3 p)
{
    assert_true(c->n_nodes < CELL_NODES);
    pf_v3_store(p, c->x + 3 * c->n_nodes);
    return (uint32_t)c->n_nodes++;
}

static inline void cell_face(cell *c, int n, const uint32_t *ids)
{
    int64_t k = c->offsets[c->n_faces];
    assert_true(c->n_faces < CELL_FACES && k + n <= CELL_FACE_NODES);
    for (int i = 0; i < n; ++i)
        c->face_nodes[k + i] = ids[i];
    c->offsets[++c->n_faces] = k + n;
}

static inline pf_polyhedron cell_view(const cell *c)
{
    return (pf_polyhedron){c->x, c->n_faces, c->offsets, c->face_nodes};
}

/* Box [lo, hi]: nodes i = bit0 x, bit1 y, bit2 z; six outward quads. */
static inline void cell_box(cell *c, pf_vec3 lo, pf_vec3 hi)
{
    static const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                         {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    cell_init(c);
    for (int i = 0; i < 8; ++i)
        cell_node(c, pf_v3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
    for (int f = 0; f < 6; ++f)
        cell_face(c, 4, faces[f]);
}

/* Tetrahedron with positive det(p1 - p0, p2 - p0, p3 - p0). */
static inline void cell_tet(cell *c, const pf_vec3 p[4])
{
    static const uint32_t faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    cell_init(c);
    for (int i = 0; i < 4; ++i)
        cell_node(c, p[i]);
    for (int f = 0; f < 4; ++f)
        cell_face(c, 3, faces[f]);
}

/* The prism over the counter-clockwise polygon l[2 n] in z = 0 up to z = 2, moved by t. */
static inline void cell_polygon_prism(cell *c, const double *l, int n, pf_vec3 t)
{
    cell_init(c);
    for (int k = 0; k < 2; ++k)
        for (int i = 0; i < n; ++i)
            cell_node(c, pf_v3_add(t, pf_v3(l[2 * i], l[2 * i + 1], 2.0 * k)));
    uint32_t bottom[16], top[16];
    for (int i = 0; i < n; ++i) {
        bottom[i] = (uint32_t)(n - 1 - i);
        top[i] = (uint32_t)(n + i);
    }
    cell_face(c, n, bottom);
    cell_face(c, n, top);
    for (uint32_t i = 0; i < (uint32_t)n; ++i) {
        uint32_t b = (i + 1) % (uint32_t)n, side[4] = {i, b, b + (uint32_t)n, i + (uint32_t)n};
        cell_face(c, 4, side);
    }
}

/* The prism over the L = [0,2]x[0,1] u [0,1]x[1,2] (non-convex hexagons top and bottom),
 * z in [0, 2], moved by t. Star-shaped: every face is seen from inside from near (0.5, 0.5). */
static inline void cell_L_prism(cell *c, pf_vec3 t)
{
    static const double l[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    cell_polygon_prism(c, l, 6, t);
}

/* The prism over the U = [0,3]x[0,3] minus the slot [1,2]x[1,3], moved by t: not star-shaped
 * (the slot's walls x = 1 and x = 2 face each other), so it must be cut. */
static inline void cell_U_prism(cell *c, pf_vec3 t)
{
    static const double u[] = {0, 0, 3, 0, 3, 3, 2, 3, 2, 1, 1, 1, 1, 3, 0, 3};
    cell_polygon_prism(c, u, 8, t);
}

/* Pyramid over the dart (0,0) (2,1) (0,2) (0.7,1) (reflex at (0.7,1)) in z = 0 with the apex
 * (1, 1, 1.5) above its kernel, moved by t: non-convex, with a non-convex face. */
static inline void cell_dart_pyramid(cell *c, pf_vec3 t)
{
    static const double dart[] = {0, 0, 2, 1, 0, 2, 0.7, 1};
    cell_init(c);
    for (int i = 0; i < 4; ++i)
        cell_node(c, pf_v3_add(t, pf_v3(dart[2 * i], dart[2 * i + 1], 0)));
    cell_node(c, pf_v3_add(t, pf_v3(1, 1, 1.5)));
    const uint32_t base[4] = {3, 2, 1, 0};
    cell_face(c, 4, base);
    for (uint32_t i = 0; i < 4; ++i) {
        uint32_t side[3] = {i, (i + 1) % 4, 4};
        cell_face(c, 3, side);
    }
}

static inline const double *node_of(const cell *c, int i)
{
    return c->x + 3 * i;
}

static inline double moments_of(const cell *c, const pf_frame *fr, int degree, double *m)
{
    pf_polyhedron p = cell_view(c);
    pf_error err = {0};
    assert_int_equal(pf_polyhedron_moments(&p, fr, degree, m, &err), PF_OK);
    return local_radius(c->x, c->n_nodes, fr);
}

static const pf_vec3 OFFSET = {1e4, 1e4, 1e4};

#endif
