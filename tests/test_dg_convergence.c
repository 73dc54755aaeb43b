/* dg_convergence: accuracy of the DG discretisation (DG paper sec. 9.5 and the a-priori rates of
 * interior-penalty DG), and the polynomial-data functions it is measured with.
 *
 * - Polynomial data against independent computations: the weak Dirichlet load of an affine g
 *   equals the one pf_dg_assemble_stiffness builds for it; loads and L2 norms of polynomials on
 *   a box equal closed-form integrals of monomials over the box.
 * - Manufactured solution: u of degree 4 (not in the space), f = -div sigma(u) exactly,
 *   g = u weakly on the whole boundary (IP), on hexes, tets and a sliced sphere (whose domain is
 *   the polyhedral surface itself). The L2 error must fall like h^(p+1).
 * - Locking (K09 fig. 9): a cube of 750 tets clamped at the top sags under its own weight; at
 *   nu = 0.3 and 0.499 DG must stay close to a converged reference, and the sag must be
 *   symmetric, where the conforming-like solution (BZ, huge penalty) locks and is lopsided. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <pf/fem.h>
#include <pf/mesh.h>

/* ---- meshes ------------------------------------------------------------------------------- */

static void make_cube_hexes(pf_mesh *m, int n)
{
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box(m, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, n, n, n, &err), PF_OK);
}

/* The unit cube as n^3 cubes, each split into 6 tetrahedra around its diagonal 0-6 (Kuhn). */
static void make_cube_tets(pf_mesh *m, int n)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), n, n, n, &err), PF_OK);
}

typedef enum family { HEXES, TETS, SPHERE } family;
static const char *const FAMILY_NAMES[] = {"hexes", "tets", "sliced sphere"};

/* The sphere inscribed in the unit cube (centre (0.5, 0.5, 0.5), radius 0.5, where the
 * manufactured field has the scale it has on the cube) as a closed polyhedral surface of 12 bands
 * x 24 segments, sliced by a grid of res cells across (pf_mesh_slice): hexes inside, the exact
 * polyhedra of the solid at the surface. The domain is that polyhedron for every res, so the
 * geometry is exact and only the cells change; h = 1 / res, the grid's cell. */
static void make_sliced_sphere(pf_mesh *m, int res)
{
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 0.5, 12, 24, &err), PF_OK);
    for (int64_t q = 0; q < 3 * (int64_t)s.n_verts; ++q)
        s.x[q] += 0.5;
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    if (pf_mesh_slice(m, &s, &p, NULL, &err) != PF_OK)
        fail_msg("slice res %d: %s", res, err.msg);
    pf_surface_release(&s);
}

/* ---- scalar polynomials of the global position (frame centre 0, scale 1) ------------------ */

typedef struct poly {
    int degree;
    double c[PF_MOMENT_MAX_COUNT];
} poly;

static poly poly_monomial(double coef, int a, int b, int c)
{
    poly p = {a + b + c, {0}};
    p.c[pf_moment_index(a, b, c)] = coef;
    return p;
}

static poly poly_add(poly p, poly q, double beta)
{
    poly r = p;
    if (q.degree > r.degree)
        r.degree = q.degree;
    for (int k = 0; k < PF_MOMENT_MAX_COUNT; ++k)
        r.c[k] += beta * q.c[k];
    return r;
}

static poly poly_mul(poly p, poly q)
{
    poly r = {p.degree + q.degree, {0}};
    assert_true(r.degree <= PF_MOMENT_MAX_DEGREE);
    for (int k = 0; k < pf_moment_count(p.degree); ++k)
        for (int l = 0; l < pf_moment_count(q.degree); ++l) {
            int a, b, c, d, e, f;
            pf_moment_exponents(k, &a, &b, &c);
            pf_moment_exponents(l, &d, &e, &f);
            r.c[pf_moment_index(a + d, b + e, c + f)] += p.c[k] * q.c[l];
        }
    return r;
}

static poly poly_deriv(poly p, int j)
{
    poly r = {p.degree > 0 ? p.degree - 1 : 0, {0}};
    for (int k = 0; k < pf_moment_count(p.degree); ++k) {
        int e[3];
        pf_moment_exponents(k, &e[0], &e[1], &e[2]);
        if (e[j] == 0)
            continue;
        double f = e[j] * p.c[k];
        e[j]--;
        r.c[pf_moment_index(e[0], e[1], e[2])] += f;
    }
    return r;
}

/* int over the box [lo, hi] of p: a product of 1D integrals per monomial. */
static double poly_box_integral(poly p, const double lo[3], const double hi[3])
{
    double s = 0;
    for (int k = 0; k < pf_moment_count(p.degree); ++k) {
        int e[3];
        pf_moment_exponents(k, &e[0], &e[1], &e[2]);
        double v = p.c[k];
        for (int i = 0; i < 3; ++i)
            v *= (pow(hi[i], e[i] + 1) - pow(lo[i], e[i] + 1)) / (e[i] + 1);
        s += v;
    }
    return s;
}

static pf_poly3 poly3_of(const poly p[3])
{
    pf_poly3 r = {.frame = {{0, 0, 0}, 1}, .degree = 0};
    for (int i = 0; i < 3; ++i) {
        assert_true(p[i].degree <= PF_POLY3_MAX_DEGREE);
        if (p[i].degree > r.degree)
            r.degree = p[i].degree;
        memcpy(r.c[i], p[i].c, PF_POLY3_MAX_COUNT * sizeof(double));
    }
    return r;
}

/* The affine field A x + b written in the frame fr: value A c + b at the centre, slope s A. */
static pf_poly3 affine_in_frame(const double a[12], pf_frame fr, int declared_degree)
{
    pf_poly3 r = {.frame = fr, .degree = declared_degree};
    const double c[3] = {fr.center.x, fr.center.y, fr.center.z};
    for (int i = 0; i < 3; ++i) {
        r.c[i][0] = a[3 * i] * c[0] + a[3 * i + 1] * c[1] + a[3 * i + 2] * c[2] + a[9 + i];
        for (int j = 0; j < 3; ++j)
            r.c[i][1 + j] = fr.scale * a[3 * i + j];
    }
    return r;
}

/* ---- helpers ------------------------------------------------------------------------------ */

static double norm(const double *v, int64_t n)
{
    double s = 0;
    for (int64_t k = 0; k < n; ++k)
        s += v[k] * v[k];
    return sqrt(s);
}

static bool is_boundary(const pf_mesh *m, int32_t f)
{
    return m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0;
}

/* Assembles K with eta doubled from eta_start until the Cholesky factorisation succeeds (the
 * search of sec. 9.1, also used by test_dg.c); c is left factored. The right-hand side of the
 * assembly is discarded: the callers add their own loads. */
static void assemble_definite(const pf_dg *dg, pf_dg_terms *terms, double eta_start,
                              pf_block_matrix *k, pf_cholesky **c)
{
    pf_error err = {0};
    double *scratch = calloc((size_t)dg->n_dofs, sizeof *scratch);
    for (terms->eta = eta_start; terms->eta < 1e6; terms->eta *= 2) {
        pf_dg_assemble_stiffness(dg, terms, NULL, NULL, k, scratch);
        if (!*c)
            assert_int_equal(pf_cholesky_create(c, k, &err), PF_OK);
        if (pf_cholesky_factor(*c, k, NULL, &err) == PF_OK)
            break;
    }
    free(scratch);
    assert_true(terms->eta < 1e6);
}

/* ---- polynomial data ---------------------------------------------------------------------- */

/* For an affine g the polynomial load must be the assembly's own (same terms, both exact): the
 * two differ by the order of a few hundred roundings of terms of size |f|, so 1e-12 |f|. */
static void polynomial_dirichlet_matches_affine_path(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double affine[12] = {0.01, 0.002, -0.003, 0.004, -0.02, 0.001,
                               0.0,  0.005, 0.015,  0.1,   -0.05, 0.02};
    const double zero[12] = {0};
    for (int kind = 0; kind < 3; ++kind)
        for (int degree = 1; degree <= 2; ++degree)
            for (int ip = 0; ip <= 1; ++ip) {
                pf_mesh m = {0};
                if (kind == 0)
                    make_cube_hexes(&m, 2);
                else if (kind == 1)
                    make_cube_tets(&m, 1);
                else
                    make_sliced_sphere(&m, 3); /* tilted, many-sided boundary polygons */
                pf_dg dg;
                assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 1000, &err), PF_OK);
                int32_t *fixed = malloc((size_t)m.n_faces * sizeof *fixed);
                for (int32_t f = 0; f < m.n_faces; ++f)
                    fixed[f] = is_boundary(&m, f) ? 0 : -1;
                pf_block_matrix k;
                assert_int_equal(pf_dg_pattern(&dg, &k, &err), PF_OK);
                double *want = calloc((size_t)dg.n_dofs, sizeof *want);
                double *got = calloc((size_t)dg.n_dofs, sizeof *got);
                pf_dg_terms terms = {.ip = ip, .eta = 7, .face_fixed = fixed,
                                     .fixed_disp = affine};
                pf_dg_assemble_stiffness(&dg, &terms, NULL, NULL, &k, want);
                terms.fixed_disp = zero;
                pf_dg_assemble_stiffness(&dg, &terms, NULL, NULL, &k, got);
                assert_true(norm(got, dg.n_dofs) == 0);
                /* g in a frame away from the cube, declared of degree 4 (zero high terms) */
                pf_poly3 g = affine_in_frame(affine, (pf_frame){{0.3, -0.2, 1.1}, 0.7}, 4);
                for (int32_t f = 0; f < m.n_faces; ++f)
                    if (is_boundary(&m, f))
                        assert_int_equal(
                            pf_dg_add_polynomial_dirichlet(&dg, &m, &terms, f, &g, got, &err),
                            PF_OK);
                for (int64_t q = 0; q < dg.n_dofs; ++q)
                    got[q] -= want[q];
                double rel = norm(got, dg.n_dofs) / norm(want, dg.n_dofs);
                if (!(rel < 1e-12))
                    fail_msg("mesh %d degree %d ip %d: |f - f_affine| / |f_affine| = %g", kind,
                             degree, ip, rel);
                free(want);
                free(got);
                free(fixed);
                pf_block_matrix_release(&k);
                pf_dg_release(&dg);
                pf_mesh_release(&m);
            }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A degree-4 test field used by the data tests. */
static void test_field(poly p[3])
{
    p[0] = poly_add(poly_monomial(1, 2, 1, 1), poly_monomial(-0.5, 0, 0, 4), 1);
    p[1] = poly_add(poly_monomial(0.3, 0, 0, 0), poly_monomial(2, 1, 3, 0), 1);
    p[2] = poly_add(poly_monomial(-1, 1, 0, 2), poly_monomial(0.7, 0, 2, 0), 1);
}

/* rhs . (coefficients of A x + b) = int f . (A x + b) over the box, closed form; the constant
 * force equals pf_dg_add_body_force. Relative 1e-13: sums of ~1e3 exact terms. */
static void polynomial_body_force_is_exact(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    const double affine[12] = {0.2, -0.1, 0.3, 0.05, 0.4, -0.2, 0.1, 0.0, -0.3, 1, -0.5, 0.25};
    for (int kind = 0; kind < 2; ++kind)
        for (int degree = 1; degree <= 2; ++degree) {
            pf_mesh m = {0};
            if (kind == 0)
                make_cube_hexes(&m, 2);
            else
                make_cube_tets(&m, 2);
            pf_dg dg;
            assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 1000, &err), PF_OK);
            double *rhs = calloc((size_t)dg.n_dofs, sizeof *rhs);
            double *v = calloc((size_t)dg.n_dofs, sizeof *v);
            poly f[3];
            test_field(f);
            pf_poly3 fp = poly3_of(f);
            assert_int_equal(pf_dg_add_polynomial_body_force(&dg, &m, &fp, rhs, &err), PF_OK);
            pf_dg_affine_coefficients(&dg, affine, affine + 9, v);
            double got = 0;
            for (int64_t q = 0; q < dg.n_dofs; ++q)
                got += rhs[q] * v[q];
            double want = 0;
            for (int i = 0; i < 3; ++i) {
                poly vi = poly_add(poly_add(poly_add(poly_monomial(affine[9 + i], 0, 0, 0),
                                                     poly_monomial(affine[3 * i], 1, 0, 0), 1),
                                            poly_monomial(affine[3 * i + 1], 0, 1, 0), 1),
                                   poly_monomial(affine[3 * i + 2], 0, 0, 1), 1);
                want += poly_box_integral(poly_mul(f[i], vi), lo, hi);
            }
            assert_true(fabs(got - want) <= 1e-13 * fabs(want));
            /* constant force */
            pf_poly3 b = {.frame = {{5, 5, 5}, 3}, .degree = 0, .c = {{1.5}, {-2}, {0.25}}};
            memset(rhs, 0, (size_t)dg.n_dofs * sizeof *rhs);
            memset(v, 0, (size_t)dg.n_dofs * sizeof *v);
            assert_int_equal(pf_dg_add_polynomial_body_force(&dg, &m, &b, rhs, &err), PF_OK);
            pf_dg_add_body_force(&dg, (pf_vec3){1.5, -2, 0.25}, v);
            for (int64_t q = 0; q < dg.n_dofs; ++q)
                assert_true(fabs(rhs[q] - v[q]) <= 1e-14 * 2);
            free(rhs);
            free(v);
            pf_dg_release(&dg);
            pf_mesh_release(&m);
        }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The L2 norm of a degree-4 field (u_h = 0) is the closed-form int |p|^2 over the box, and an
 * affine field, which the basis holds, has error 0 (rounding: 1e-13 of its norm). */
static void l2_error_is_exact(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    const double affine[12] = {0.2, -0.1, 0.3, 0.05, 0.4, -0.2, 0.1, 0.0, -0.3, 1, -0.5, 0.25};
    for (int kind = 0; kind < 2; ++kind)
        for (int degree = 1; degree <= 2; ++degree) {
            pf_mesh m = {0};
            if (kind == 0)
                make_cube_hexes(&m, 2);
            else
                make_cube_tets(&m, 2);
            pf_dg dg;
            assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 1000, &err), PF_OK);
            double *u = calloc((size_t)dg.n_dofs, sizeof *u);
            poly f[3];
            test_field(f);
            pf_poly3 fp = poly3_of(f);
            double e, n;
            assert_int_equal(pf_dg_l2_error(&dg, &m, u, &fp, &e, &n, &err), PF_OK);
            double want = 0;
            for (int i = 0; i < 3; ++i)
                want += poly_box_integral(poly_mul(f[i], f[i]), lo, hi);
            assert_true(fabs(e - sqrt(want)) <= 1e-13 * sqrt(want));
            assert_true(fabs(n - sqrt(want)) <= 1e-13 * sqrt(want));
            pf_dg_affine_coefficients(&dg, affine, affine + 9, u);
            pf_poly3 a = affine_in_frame(affine, (pf_frame){{-1, 2, 0.5}, 2.5}, 4);
            assert_int_equal(pf_dg_l2_error(&dg, &m, u, &a, &e, &n, &err), PF_OK);
            assert_true(e <= 1e-13 * n);
            free(u);
            pf_dg_release(&dg);
            pf_mesh_release(&m);
        }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void bad_polynomial_arguments_are_refused(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_cube_hexes(&m, 2);
    pf_dg dg;
    assert_int_equal(pf_dg_create(&dg, &m, 1, 1e5, 0.3, 1000, &err), PF_OK);
    double *rhs = calloc((size_t)dg.n_dofs, sizeof *rhs);
    pf_poly3 p = {.frame = {{0, 0, 0}, 1}, .degree = 5};
    pf_dg_terms terms = {.ip = true, .eta = 1};
    assert_int_equal(pf_dg_add_polynomial_body_force(&dg, &m, &p, rhs, &err), PF_ERR_INVALID);
    p.degree = 1;
    p.frame.scale = 0;
    assert_int_equal(pf_dg_add_polynomial_body_force(&dg, &m, &p, rhs, &err), PF_ERR_INVALID);
    p.frame.scale = 1;
    int32_t interior = 0;
    while (is_boundary(&m, interior))
        ++interior;
    assert_int_equal(pf_dg_add_polynomial_dirichlet(&dg, &m, &terms, interior, &p, rhs, &err),
                     PF_ERR_INVALID);
    assert_int_equal(pf_dg_add_polynomial_dirichlet(&dg, &m, &terms, m.n_faces, &p, rhs, &err),
                     PF_ERR_INVALID);
    assert_true(norm(rhs, dg.n_dofs) == 0);
    free(rhs);
    pf_dg_release(&dg);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- manufactured solution ---------------------------------------------------------------- */

static const double E_MOD = 1e5, NU = 0.3;

/* u_x = x y (1-x)(1-y) + x z^3, u_y = y z (1-y)(1-z) + x^2 y, u_z = z x (1-z)(1-x) + y^3:
 * degree 4, not in the space of degree <= 2. */
static void manufactured(poly u[3])
{
    for (int i = 0; i < 3; ++i) {
        int a = i, b = (i + 1) % 3; /* the bubble in axes a, b */
        int ea[3] = {0, 0, 0}, eb[3] = {0, 0, 0};
        ea[a] = 1;
        eb[b] = 1;
        poly xa = poly_monomial(1, ea[0], ea[1], ea[2]), xb = poly_monomial(1, eb[0], eb[1], eb[2]);
        poly one = poly_monomial(1, 0, 0, 0);
        u[i] = poly_mul(poly_mul(xa, poly_add(one, xa, -1)), poly_mul(xb, poly_add(one, xb, -1)));
    }
    u[0] = poly_add(u[0], poly_monomial(1, 1, 0, 3), 1);
    u[1] = poly_add(u[1], poly_monomial(1, 2, 1, 0), 1);
    u[2] = poly_add(u[2], poly_monomial(1, 0, 3, 0), 1);
}

/* f = -div sigma(u) = -((lambda + mu) grad div u + mu lap u), exact on the coefficients. */
static void body_force_of(const poly u[3], double lambda, double mu, poly f[3])
{
    poly div = poly_add(poly_add(poly_deriv(u[0], 0), poly_deriv(u[1], 1), 1),
                        poly_deriv(u[2], 2), 1);
    for (int i = 0; i < 3; ++i) {
        poly lap = {0, {0}};
        for (int j = 0; j < 3; ++j)
            lap = poly_add(lap, poly_deriv(poly_deriv(u[i], j), j), 1);
        f[i] = poly_add(poly_monomial(0, 0, 0, 0), poly_deriv(div, i), -(lambda + mu));
        f[i] = poly_add(f[i], lap, -mu);
    }
}

/* L2 error of IP with g = u on every boundary face; *eta is where the penalty search starts and
 * gets the penalty it found (sec. 9.1). The search depends on the element shapes only: a hex or
 * tet family (every mesh the same shapes) carries it from one mesh to the next. */
static double solve_manufactured(const pf_mesh *m, int degree, double *eta, double *rel)
{
    pf_error err = {0};
    pf_dg dg;
    assert_int_equal(pf_dg_create(&dg, m, degree, E_MOD, NU, 1, &err), PF_OK);
    poly u[3], f[3];
    manufactured(u);
    body_force_of(u, dg.lambda, dg.mu, f);
    pf_poly3 up = poly3_of(u), fp = poly3_of(f);
    int32_t *fixed = malloc((size_t)m->n_faces * sizeof *fixed);
    for (int32_t q = 0; q < m->n_faces; ++q)
        fixed[q] = is_boundary(m, q) ? 0 : -1;
    const double zero[12] = {0};
    pf_dg_terms terms = {.ip = true, .face_fixed = fixed, .fixed_disp = zero};
    pf_block_matrix k;
    assert_int_equal(pf_dg_pattern(&dg, &k, &err), PF_OK);
    pf_cholesky *c = NULL;
    assemble_definite(&dg, &terms, *eta, &k, &c);
    *eta = terms.eta;
    double *rhs = calloc((size_t)dg.n_dofs, sizeof *rhs);
    double *x = calloc((size_t)dg.n_dofs, sizeof *x);
    assert_int_equal(pf_dg_add_polynomial_body_force(&dg, m, &fp, rhs, &err), PF_OK);
    for (int32_t q = 0; q < m->n_faces; ++q)
        if (fixed[q] >= 0)
            assert_int_equal(pf_dg_add_polynomial_dirichlet(&dg, m, &terms, q, &up, rhs, &err),
                             PF_OK);
    assert_int_equal(pf_cholesky_solve(c, rhs, x, &err), PF_OK);
    double e, n;
    assert_int_equal(pf_dg_l2_error(&dg, m, x, &up, &e, &n, &err), PF_OK);
    *rel = e / n;
    pf_cholesky_destroy(&c);
    free(rhs);
    free(x);
    free(fixed);
    pf_block_matrix_release(&k);
    pf_dg_release(&dg);
    return e;
}

/* Runs a mesh family (sizes: cells across) and checks the rate between every pair of successive
 * meshes, so that a family whose error stalls anywhere fails, not only one whose finest pair does. */
static void convergence_family(family fam, int degree, const int *sizes, int count, double rate)
{
    size_t live = pf_alloc_live_bytes();
    double eta = 1, prev = 0, slowest = INFINITY;
    clock_t t0 = clock();
    printf("%s degree %d (IP)\n   n  elems    L2 error   relative    rate   eta\n",
           FAMILY_NAMES[fam], degree);
    for (int s = 0; s < count; ++s) {
        pf_mesh m = {0};
        if (fam == TETS)
            make_cube_tets(&m, sizes[s]);
        else if (fam == HEXES)
            make_cube_hexes(&m, sizes[s]);
        else
            make_sliced_sphere(&m, sizes[s]);
        double rel;
        if (fam == SPHERE)
            eta = 1; /* cut cells differ from mesh to mesh: search afresh */
        double e = solve_manufactured(&m, degree, &eta, &rel);
        double pair_rate = s > 0 ? log(prev / e) / log((double)sizes[s] / sizes[s - 1]) : 0.0;
        if (s > 0 && pair_rate < slowest)
            slowest = pair_rate;
        printf("%4d %6d  %10.3e  %9.3e  %6.3f  %4g\n", sizes[s], (int)m.n_elems, e, rel,
               pair_rate, eta);
        prev = e;
        pf_mesh_release(&m);
    }
    printf("   (%.2f s of CPU)\n", (double)(clock() - t0) / CLOCKS_PER_SEC);
    if (!(slowest >= rate))
        fail_msg("%s degree %d: L2 rate %.3f below %.2f", FAMILY_NAMES[fam], degree, slowest,
                 rate);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Rates >= 1.8 (p = 1) and >= 2.7 (p = 2), the a-priori h^(p+1) less a margin for the
 * pre-asymptotic coarse meshes, between every pair of successive meshes. Measured: 2.75, 2.27,
 * 2.23 (p = 1) and 2.82, 3.01, 3.09 (p = 2). */
static void l2_convergence_hexes(void **state)
{
    (void)state;
    const int p1[] = {2, 4, 8, 16}, p2[] = {2, 4, 6, 8};
    convergence_family(HEXES, 1, p1, 4, 1.8);
    convergence_family(HEXES, 2, p2, 4, 2.7);
}

/* Measured: 1.85, 1.90 (p = 1) and 2.78, 2.84 (p = 2). Degree 2 starts at 2 cells: from 1 cell
 * (6 tets) the first rate is 2.60, pre-asymptotic. */
static void l2_convergence_tets(void **state)
{
    (void)state;
    const int p1[] = {2, 4, 8}, p2[] = {2, 3, 4};
    convergence_family(TETS, 1, p1, 3, 1.8);
    convergence_family(TETS, 2, p2, 3, 2.7);
}

/* The cut cells at the surface are not nested from one res to the next, so the error does not
 * fall as regularly as on hexes. From res 2 the first rates are pre-asymptotic (1.45 for p = 1;
 * 1.43 and 1.66 from res 2 and 3 for p = 2: two cells across a sphere are mostly surface), so
 * the families start at res 4, where every pair passes: measured 2.29, 2.15 (p = 1) and 2.99,
 * 3.43 (p = 2). The penalty is searched per mesh: a penalty carried over from a coarser mesh (64 for
 * p = 1 against the 8 the finest needs) over-stiffens the jumps and stalls the p = 1 error near
 * 30 % (sec. 9.1: eta must not be too high). About 1.2 s of CPU at -O2. */
static void l2_convergence_sliced_sphere(void **state)
{
    (void)state;
    const int p1[] = {4, 6, 8}, p2[] = {4, 6, 8};
    convergence_family(SPHERE, 1, p1, 3, 1.8);
    convergence_family(SPHERE, 2, p2, 3, 2.7);
}

/* ---- locking ------------------------------------------------------------------------------ */

/* Sags of the reference at nu = 0.3 and 0.499: IP degree 2 on the cube of 15^3 x 6 = 20,250
 * tets (607,500 unknowns), far too costly for ctest (230 s of CPU and 12 GB each), so computed
 * by
 *   bench_locking reference 15   (bench/results/locking.csv, rows "ip,2,0.3,20250" and
 *                                 "ip,2,0.499,20250").
 * The issue asks for the mesh refined twice, 20^3 x 6 = 48,000 tets and 1.44 million unknowns:
 * its Cholesky factor, growing like unknowns^1.29 as measured from 6000 tets (2.5 GB) to 20,250
 * (12 GB), would need about 37 GB, more than the machine's 23. How converged this one is: it
 * differs from the 6000-tet sag by 0.03 % (nu = 0.3) and 0.21 % (nu = 0.499), and that one from
 * the 750-tet sag by 0.10 % and 0.78 %: the differences shrink about 3.5 times per step, so the
 * reference lies within a few tenths of a percent of the limit, far inside the bounds below. */
static const double REFERENCE_SAG[2] = {-4.639558e-02, -4.043720e-02};

typedef struct sag_result {
    double mean;         /* mean u_z over the bottom face (negative: down) */
    double cell[5][5];   /* mean u_z over each bottom cell (i, j) */
} sag_result;

/* The cube of 5^3 x 6 tets, clamped (weak u = 0) on the top face, under gravity; the penalty
 * search starts at eta. */
static void hanging_cube(int degree, bool ip, double nu, double eta, sag_result *r)
{
    pf_error err = {0};
    pf_mesh m = {0};
    make_cube_tets(&m, 5);
    assert_int_equal(m.n_elems, 750);
    pf_dg dg;
    const double rho = 1000, gravity = 9.81;
    assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, nu, rho, &err), PF_OK);
    int32_t *fixed = malloc((size_t)m.n_faces * sizeof *fixed);
    for (int32_t q = 0; q < dg.n_faces; ++q) {
        const pf_dg_face *fc = &dg.faces[q];
        fixed[fc->face] = (fc->elem[1] < 0 && fabs(fc->centroid.z - 1) < 1e-12) ? 0 : -1;
    }
    const double zero[12] = {0};
    pf_dg_terms terms = {.ip = ip, .face_fixed = fixed, .fixed_disp = zero};
    pf_block_matrix k;
    assert_int_equal(pf_dg_pattern(&dg, &k, &err), PF_OK);
    pf_cholesky *c = NULL;
    assemble_definite(&dg, &terms, eta, &k, &c);
    double *rhs = calloc((size_t)dg.n_dofs, sizeof *rhs);
    double *x = calloc((size_t)dg.n_dofs, sizeof *x);
    pf_dg_add_body_force(&dg, (pf_vec3){0, 0, -rho * gravity}, rhs);
    assert_int_equal(pf_cholesky_solve(c, rhs, x, &err), PF_OK);
    /* int_f u_z = sum_a S[0][0][a][0] u_z,a (phi_0 = 1) over the bottom faces */
    double total = 0, area = 0;
    double cell_int[5][5] = {{0}}, cell_area[5][5] = {{0}};
    int nb = dg.nb;
    for (int32_t q = dg.n_interior; q < dg.n_faces; ++q) {
        const pf_dg_face *fc = &dg.faces[q];
        if (fabs(fc->centroid.z) > 1e-12)
            continue;
        const double *ue = x + 3 * (size_t)fc->elem[0] * nb;
        double s = 0;
        for (int a = 0; a < nb; ++a)
            s += fc->S[(size_t)a * nb] * ue[3 * a + 2];
        int i = (int)(fc->centroid.x * 5), j = (int)(fc->centroid.y * 5);
        cell_int[i][j] += s;
        cell_area[i][j] += fc->area;
        total += s;
        area += fc->area;
    }
    r->mean = total / area;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j)
            r->cell[i][j] = cell_int[i][j] / cell_area[i][j];
    pf_cholesky_destroy(&c);
    free(rhs);
    free(x);
    free(fixed);
    pf_block_matrix_release(&k);
    pf_dg_release(&dg);
    pf_mesh_release(&m);
}

/* Largest |sag(i, j) - sag(mirror)| / |mean sag| over the mirror images x <-> 1 - x,
 * y <-> 1 - y and both. */
static double asymmetry(const sag_result *r)
{
    double worst = 0;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) {
            double v = r->cell[i][j];
            worst = fmax(worst, fabs(v - r->cell[4 - i][j]));
            worst = fmax(worst, fabs(v - r->cell[i][4 - j]));
            worst = fmax(worst, fabs(v - r->cell[4 - i][4 - j]));
        }
    return worst / fabs(r->mean);
}

static void no_locking(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    const double nus[2] = {0.3, 0.499};
    for (int v = 0; v < 2; ++v) {
        sag_result r1, r2, cg;
        hanging_cube(1, true, nus[v], 1, &r1);
        hanging_cube(2, true, nus[v], 1, &r2);
        hanging_cube(1, false, nus[v], 4096, &cg);
        double ref = REFERENCE_SAG[v];
        printf("hanging cube, 750 tets, nu = %g: IP p=1 sag %.6e (%+.2f %%, asym %.3g), IP p=2 "
               "sag %.6e (%+.2f %%, asym %.3g); BZ p=1 eta 4096 (~CG) %.6e (%+.2f %%, asym "
               "%.3g); reference %.6e\n",
               nus[v], r1.mean, 100 * (r1.mean / ref - 1), asymmetry(&r1), r2.mean,
               100 * (r2.mean / ref - 1), asymmetry(&r2), cg.mean, 100 * (cg.mean / ref - 1),
               asymmetry(&cg), ref);
        if (v == 0) {
            /* nu = 0.3 locks nothing: measured -0.1 % for both degrees, asymmetry 2.8 % (p = 1)
             * and 0.2 % (p = 2); the bounds leave a factor of about 2 over those and over the
             * reference's own uncertainty (see REFERENCE_SAG) */
            assert_true(fabs(r2.mean - ref) <= 0.01 * fabs(ref));
            assert_true(fabs(r1.mean - ref) <= 0.01 * fabs(ref));
            assert_true(asymmetry(&r2) <= 0.005);
            assert_true(asymmetry(&r1) <= 0.06);
        } else {
            /* the bounds at nu = 0.499 (measured -1.0 % and -6.8 %); the asymmetry is
             * the discretisation error of the Kuhn split, which is not mirror-symmetric:
             * measured 1.1 % (p = 2) and 6.3 % (p = 1), bounds a factor of about 2 above */
            assert_true(fabs(r2.mean - ref) <= 0.05 * fabs(ref));
            assert_true(fabs(r1.mean - ref) <= 0.15 * fabs(ref));
            assert_true(asymmetry(&r2) <= 0.02);
            assert_true(asymmetry(&r1) <= 0.12);
            /* Both checks can fail: BZ of degree 1 with a huge penalty is nearly the conforming
             * linear-tet solution, which locks (fig. 9): measured -44 % and asymmetry 66 %. */
            assert_true(fabs(cg.mean - ref) > 0.3 * fabs(ref));
            assert_true(asymmetry(&cg) > 0.3);
        }
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(polynomial_dirichlet_matches_affine_path),
        cmocka_unit_test(polynomial_body_force_is_exact),
        cmocka_unit_test(l2_error_is_exact),
        cmocka_unit_test(bad_polynomial_arguments_are_refused),
        cmocka_unit_test(l2_convergence_hexes),
        cmocka_unit_test(l2_convergence_tets),
        cmocka_unit_test(l2_convergence_sliced_sphere),
        cmocka_unit_test(no_locking),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
