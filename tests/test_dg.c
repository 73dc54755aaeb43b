/* fem: the DG discretisation against exact properties of linear elasticity.
 *
 * - Rigid motions (translations, infinitesimal rotations) are affine, so the DG basis holds them
 *   exactly, they have no strain and no jump: K u = 0. Entries of K are sums of a few hundred
 *   terms of size |K|, so |K u| <= 1e-12 |K| |u| leaves a factor 10-100 over rounding.
 * - Patch test (K09 fig. 1 in 3D): an affine displacement prescribed weakly on the whole
 *   boundary is reproduced inside by IP, whatever the element shapes: the IP form is consistent
 *   and the affine field lies in the space (hex, tet, merged non-convex and sliced-sphere meshes).
 *   The error is the solve's, |du| / |u| below
 *   cond(K) u; the penalty search keeps cond(K) near 1e4-1e6, so 1e-9 is the bound.
 * - Mass: u^T M u for a unit translation is the mass rho V exactly (moments are exact), and
 *   for u = x it is rho int |x|^2, known in closed form for a box. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include <pf/fem.h>

/* ---- meshes ------------------------------------------------------------------------------- */

static void make_hex_box(pf_mesh *m, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, (pf_vec3){0.5, -0.25, 2}, (pf_vec3){2.5, 0.75, 3}, nx,
                                      ny, nz, &err),
                     PF_OK);
}

/* A 2 x 1 x 1 box of cubes, each split into 6 tetrahedra around its main diagonal. */
static void make_tet_box(pf_mesh *m)
{
    int nx = 2, ny = 1, nz = 1;
    double x[3 * 12];
    int n = 0;
    for (int k = 0; k <= nz; ++k)
        for (int j = 0; j <= ny; ++j)
            for (int i = 0; i <= nx; ++i, ++n) {
                x[3 * n] = 0.3 * i + 0.05 * j;
                x[3 * n + 1] = 0.4 * j;
                x[3 * n + 2] = 0.35 * k + 0.02 * i;
            }
    /* the six tets of the cube (0..7 in hex order) sharing the diagonal 0-6 */
    static const int kuhn[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                   {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    uint32_t tets[4 * 12];
    int t = 0;
    for (int i = 0; i < nx; ++i) {
        uint32_t c[8];
        uint32_t base = (uint32_t)i;
        uint32_t sx = 1, sy = (uint32_t)(nx + 1), sz = (uint32_t)((nx + 1) * (ny + 1));
        c[0] = base, c[1] = base + sx, c[2] = base + sx + sy, c[3] = base + sy;
        for (int q = 0; q < 4; ++q)
            c[4 + q] = c[q] + sz;
        for (int q = 0; q < 6; ++q, ++t)
            for (int v = 0; v < 4; ++v)
                tets[4 * t + v] = c[kuhn[q][v]];
    }
    pf_error err = {0};
    assert_int_equal(pf_mesh_from_tets(m, x, n, tets, t, &err), PF_OK);
}

/* Merges the elements of each group of src into one element (faces shared inside a group are
 * dropped): from a hex grid this makes non-convex polyhedra with coplanar faces. */
static void merge_groups(const pf_mesh *src, const int32_t *group, int32_t n_groups, pf_mesh *m)
{
    pf_error err = {0};
    int32_t *uses = calloc((size_t)src->n_faces, sizeof *uses);
    for (int32_t f = 0; f < src->n_faces; ++f) {
        int32_t a = src->face_elems[2 * f], b = src->face_elems[2 * f + 1];
        uses[f] = !(a >= 0 && b >= 0 && group[a] == group[b]);
    }
    int32_t *new_index = calloc((size_t)src->n_faces, sizeof *new_index);
    int32_t nf = 0;
    int64_t nfn = 0;
    for (int32_t f = 0; f < src->n_faces; ++f)
        if (uses[f]) {
            new_index[f] = nf++;
            nfn += src->face_offsets[f + 1] - src->face_offsets[f];
        }
    int64_t nef = 0;
    for (int32_t e = 0; e < src->n_elems; ++e)
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k)
            nef += uses[PF_FACE_INDEX(src->elem_faces[k])];
    assert_int_equal(pf_mesh_alloc(m, src->n_nodes, nf, nfn, n_groups, nef, &err), PF_OK);
    memcpy(m->x, src->x, 3 * (size_t)src->n_nodes * sizeof *m->x);
    for (int32_t f = 0, q = 0; f < src->n_faces; ++f)
        if (uses[f]) {
            int64_t len = src->face_offsets[f + 1] - src->face_offsets[f];
            memcpy(m->face_nodes + m->face_offsets[q], src->face_nodes + src->face_offsets[f],
                   (size_t)len * sizeof *m->face_nodes);
            m->face_offsets[q + 1] = m->face_offsets[q] + len;
            ++q;
        }
    int64_t at = 0;
    for (int32_t g = 0; g < n_groups; ++g) {
        for (int32_t e = 0; e < src->n_elems; ++e)
            if (group[e] == g)
                for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
                    uint32_t entry = src->elem_faces[k];
                    int32_t f = PF_FACE_INDEX(entry);
                    if (uses[f])
                        m->elem_faces[at++] =
                            (uint32_t)new_index[f] | (entry & PF_FACE_REVERSED);
                }
        m->elem_offsets[g + 1] = at;
    }
    free(uses);
    free(new_index);
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* A 3 x 2 x 2 hex grid merged into 4 elements: two L-shaped (non-convex) blocks of 3 cells, a
 * 2 x 1 x 1 slab and the rest. */
static void make_poly_box(pf_mesh *m)
{
    pf_mesh grid = {0};
    make_hex_box(&grid, 3, 2, 2);
    int32_t group[12];
    for (int32_t e = 0; e < 12; ++e) {
        int i = e % 3, j = (e / 3) % 2, k = e / 6;
        if (k == 0)
            group[e] = (j == 0 || i == 0) ? 0 : 1; /* L of 4 cells, and a 2-cell bar */
        else
            group[e] = (i == 2 || (i == 1 && j == 1)) ? 2 : 3; /* L of 3, and the rest */
    }
    merge_groups(&grid, group, 4, m);
    pf_mesh_release(&grid);
}

/* A sphere sliced at 3 cells across (pf_mesh_slice): hexes inside, exact polyhedra (many-faced,
 * some non-convex after sliver merging) at the surface. */
static void make_sliced_sphere(pf_mesh *m)
{
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 3;
    assert_int_equal(pf_mesh_slice(m, &s, &p, NULL, &err), PF_OK);
    pf_surface_release(&s);
}

typedef void (*mesh_maker)(pf_mesh *);
static void hex_mesh(pf_mesh *m) { make_hex_box(m, 2, 2, 1); }
static const mesh_maker MESHES[] = {hex_mesh, make_tet_box, make_poly_box, make_sliced_sphere};
static const char *const MESH_NAMES[] = {"hex", "tet", "poly", "sliced sphere"};
enum { N_MESHES = 4 };

/* ---- helpers ------------------------------------------------------------------------------ */

static double norm(const double *v, int64_t n)
{
    double s = 0;
    for (int64_t k = 0; k < n; ++k)
        s += v[k] * v[k];
    return sqrt(s);
}

static double matrix_norm(const pf_block_matrix *k)
{
    double s = 0;
    for (int64_t c = 0; c < k->n; ++c)
        for (int64_t p = k->col_ptr[c]; p < k->col_ptr[c + 1]; ++p)
            s += (k->row_idx[p] == c ? 1 : 2) * k->val[p] * k->val[p];
    return sqrt(s);
}

/* Doubles eta from 1 until K (+ a tiny mass shift that lifts the rigid modes of a free body) is
 * positive definite, as sec. 9.1 does. */
static double find_penalty(const pf_dg *dg, pf_dg_terms *terms, pf_block_matrix *k, double *f,
                           double shift)
{
    pf_error err = {0};
    pf_cholesky *c = NULL;
    for (terms->eta = 1; terms->eta < 1e6; terms->eta *= 2) {
        memset(f, 0, (size_t)dg->n_dofs * sizeof *f);
        pf_dg_assemble_stiffness(dg, terms, NULL, NULL, k, f);
        pf_dg_add_mass(dg, shift, k);
        if (!c)
            assert_int_equal(pf_cholesky_create(&c, k, &err), PF_OK);
        if (pf_cholesky_factor(c, k, NULL, &err) == PF_OK)
            break;
    }
    pf_cholesky_destroy(&c);
    assert_true(terms->eta < 1e6);
    return terms->eta;
}

/* ---- tests -------------------------------------------------------------------------------- */

static void rigid_motions_have_no_force(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    for (int mesh_kind = 0; mesh_kind < N_MESHES; ++mesh_kind)
        for (int degree = 1; degree <= 2; ++degree)
            for (int ip = 0; ip <= 1; ++ip) {
                pf_mesh m = {0};
                MESHES[mesh_kind](&m);
                pf_dg dg;
                assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 1000, &err), PF_OK);
                pf_block_matrix k;
                assert_int_equal(pf_dg_pattern(&dg, &k, &err), PF_OK);
                double *f = calloc((size_t)dg.n_dofs, sizeof *f);
                double *u = calloc((size_t)dg.n_dofs, sizeof *u);
                double *ku = calloc((size_t)dg.n_dofs, sizeof *ku);
                pf_dg_terms terms = {.ip = ip, .eta = 20};
                pf_dg_assemble_stiffness(&dg, &terms, NULL, NULL, &k, f);
                double knorm = matrix_norm(&k);
                const double rigid[4][12] = {
                    {0, 0, 0, 0, 0, 0, 0, 0, 0, 1, -2, 0.5},    /* translation */
                    {0, -1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0},      /* rotation about z */
                    {0, 0, 1, 0, 0, 0, -1, 0, 0, 0.3, 0, 0},    /* about y, plus a shift */
                    {0, 0, 0, 0, 0, -0.7, 0, 0.7, 0, 0, 0, 0}}; /* about x */
                for (int r = 0; r < 4; ++r) {
                    pf_dg_affine_coefficients(&dg, rigid[r], rigid[r] + 9, u);
                    pf_block_matrix_mul(&k, 1, u, 0, ku);
                    double rel = norm(ku, dg.n_dofs) / (knorm * norm(u, dg.n_dofs));
                    if (!(rel < 1e-12))
                        fail_msg("%s degree %d %s mode %d: |K u| / |K||u| = %g",
                                 MESH_NAMES[mesh_kind], degree, ip ? "ip" : "bz", r, rel);
                }
                free(f);
                free(u);
                free(ku);
                pf_block_matrix_release(&k);
                pf_dg_release(&dg);
                pf_mesh_release(&m);
            }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void ip_patch_test(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    const double affine[12] = {0.01, 0.002, -0.003, 0.004, -0.02, 0.001,
                               0.0, 0.005, 0.015,   0.1,   -0.05, 0.02};
    for (int mesh_kind = 0; mesh_kind < N_MESHES; ++mesh_kind)
        for (int degree = 1; degree <= 2; ++degree) {
            pf_mesh m = {0};
            MESHES[mesh_kind](&m);
            pf_dg dg;
            assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 1000, &err), PF_OK);
            int32_t *fixed = malloc((size_t)m.n_faces * sizeof *fixed);
            for (int32_t f = 0; f < m.n_faces; ++f)
                fixed[f] = (m.face_elems[2 * f] < 0 || m.face_elems[2 * f + 1] < 0) ? 0 : -1;
            pf_dg_terms terms = {.ip = true, .face_fixed = fixed, .fixed_disp = affine};
            pf_block_matrix k;
            assert_int_equal(pf_dg_pattern(&dg, &k, &err), PF_OK);
            double *f = calloc((size_t)dg.n_dofs, sizeof *f);
            double *u = calloc((size_t)dg.n_dofs, sizeof *u);
            double *exact = calloc((size_t)dg.n_dofs, sizeof *exact);
            find_penalty(&dg, &terms, &k, f, 0);
            pf_cholesky *c = NULL;
            assert_int_equal(pf_cholesky_create(&c, &k, &err), PF_OK);
            assert_int_equal(pf_cholesky_factor(c, &k, NULL, &err), PF_OK);
            assert_int_equal(pf_cholesky_solve(c, f, u, &err), PF_OK);
            pf_dg_affine_coefficients(&dg, affine, affine + 9, exact);
            for (int64_t q = 0; q < dg.n_dofs; ++q)
                u[q] -= exact[q];
            double rel = norm(u, dg.n_dofs) / norm(exact, dg.n_dofs);
            if (!(rel < 1e-9))
                fail_msg("%s degree %d (eta %g): patch test error %g", MESH_NAMES[mesh_kind],
                         degree, terms.eta, rel);
            pf_cholesky_destroy(&c);
            free(f);
            free(u);
            free(exact);
            free(fixed);
            pf_block_matrix_release(&k);
            pf_dg_release(&dg);
            pf_mesh_release(&m);
        }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Box [0.5, 2.5] x [-0.25, 0.75] x [2, 3]: V = 2, int x^2 + y^2 + z^2 = sum over axes of
 * (b^3 - a^3) / 3 times the other two lengths. */
static void mass_is_exact(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_hex_box(&m, 2, 2, 1);
    for (int degree = 1; degree <= 2; ++degree) {
        pf_dg dg;
        assert_int_equal(pf_dg_create(&dg, &m, degree, 1e5, 0.3, 7, &err), PF_OK);
        double *u = calloc((size_t)dg.n_dofs, sizeof *u);
        double *mu = calloc((size_t)dg.n_dofs, sizeof *mu);
        const double shift[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0};
        const double ident[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
        pf_dg_affine_coefficients(&dg, shift, shift + 9, u);
        pf_dg_mass_mul(&dg, 1, u, mu);
        double umu = 0;
        for (int64_t q = 0; q < dg.n_dofs; ++q)
            umu += u[q] * mu[q];
        assert_true(fabs(umu - 7 * 2) <= 1e-13 * 14);
        pf_dg_affine_coefficients(&dg, ident, ident + 9, u);
        memset(mu, 0, (size_t)dg.n_dofs * sizeof *mu);
        pf_dg_mass_mul(&dg, 1, u, mu);
        umu = 0;
        for (int64_t q = 0; q < dg.n_dofs; ++q)
            umu += u[q] * mu[q];
        double ix = (2.5 * 2.5 * 2.5 - 0.125) / 3 * 1 * 1;
        double iy = (0.75 * 0.75 * 0.75 + 0.25 * 0.25 * 0.25) / 3 * 2 * 1;
        double iz = (27.0 - 8.0) / 3 * 2 * 1;
        double exact = 7 * (ix + iy + iz);
        assert_true(fabs(umu - exact) <= 1e-13 * exact);
        free(u);
        free(mu);
        pf_dg_release(&dg);
    }
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Stitching averages each element's own value at the node: for an affine field all elements
 * agree, so the nodal values are the field at the nodes. */
static void stitching_reproduces_affine_fields(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_poly_box(&m);
    pf_dg dg;
    assert_int_equal(pf_dg_create(&dg, &m, 2, 1e5, 0.3, 1, &err), PF_OK);
    const double a[12] = {0.1, 0.2, 0.3, -0.1, 0.05, 0, 0.2, 0, -0.3, 1, 2, 3};
    double *u = calloc((size_t)dg.n_dofs, sizeof *u);
    double *nodal = calloc(3 * (size_t)m.n_nodes, sizeof *nodal);
    pf_dg_affine_coefficients(&dg, a, a + 9, u);
    pf_dg_stitch(&dg, u, nodal);
    for (int32_t i = 0; i < m.n_nodes; ++i)
        for (int c = 0; c < 3; ++c) {
            const double *x = m.x + 3 * (size_t)i;
            double want = a[3 * c] * x[0] + a[3 * c + 1] * x[1] + a[3 * c + 2] * x[2] + a[9 + c];
            assert_true(fabs(nodal[3 * i + c] - want) <= 1e-14 * 8);
        }
    free(u);
    free(nodal);
    pf_dg_release(&dg);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void bad_arguments_are_refused(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_mesh m = {0};
    make_hex_box(&m, 1, 1, 1);
    pf_dg dg;
    assert_int_equal(pf_dg_create(&dg, &m, 3, 1e5, 0.3, 1, &err), PF_ERR_INVALID);
    assert_int_equal(pf_dg_create(&dg, &m, 1, 1e5, 0.5, 1, &err), PF_ERR_INVALID);
    assert_int_equal(pf_dg_create(&dg, &m, 1, -1, 0.3, 1, &err), PF_ERR_INVALID);
    assert_int_equal(pf_dg_create(&dg, &m, 1, 1e5, 0.3, NAN, &err), PF_ERR_INVALID);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(rigid_motions_have_no_force),
        cmocka_unit_test(ip_patch_test),
        cmocka_unit_test(mass_is_exact),
        cmocka_unit_test(stitching_reproduces_affine_fields),
        cmocka_unit_test(bad_arguments_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
