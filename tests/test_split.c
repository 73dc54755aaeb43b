/* split: pf_poly_split on convex and non-convex cells, against closed forms.
 *
 * Oracles, independent of the code under test:
 * - volumes: a split conserves volume; the parts' volumes sum to the input's. pf_polyhedron_volume
 *   sums 6 V over fan tetrahedra of O(1) size with relative rounding ~1e-16 each; a few hundred
 *   terms give ~1e-14, so 1e-12 relative is tight yet safe.
 * - voxel-built cells (box, L, U, frame, corner-cut cube) cut by axis-aligned planes: the volume
 *   below is the sum over unit voxels of their clamped extent, the cap area the number of unit
 *   squares with solid on both sides: exact small integers or halves (1e-12).
 * - prisms cut by a plane crossing all lateral edges: cap area = base area / |n_z|, volume below
 *   = (d A - n_x S_x - n_y S_y) / n_z with the base polygon's first moments (1e-12 relative).
 * - convex cells: the cross-section is the convex hull of the edge-plane crossings (1e-12).
 * - anything else: the cap area is the derivative of the volume below with respect to the plane
 *   offset; a central difference with step h = 1e-6 L has truncation error ~h L (A is piecewise
 *   quadratic in the offset) and rounding ~1e-16 L^3 / h, so 1e-5 relative.
 * Every piece is checked with pf_mesh_validate as a one-element mesh, and nodes of pieces below
 * (above) lie at signed distance <= tol (>= -tol). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "test_check.h"
#include "test_random.h"
#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/split.h>

/* ---- random numbers -------------------------------------------------------------------------- */

static double uniform_in(rng *r, double lo, double hi) { return lo + (hi - lo) * uniform01(r); }

static int32_t rand_int(rng *r, int32_t n) { return (int32_t)(uniform01(r) * n); }

static pf_vec3 random_unit(rng *r)
{
    pf_vec3 v;
    do
        v = pf_v3(uniform_in(r, -1, 1), uniform_in(r, -1, 1), uniform_in(r, -1, 1));
    while (pf_v3_norm(v) < 0.1 || pf_v3_norm(v) > 1);
    return pf_v3_normalize(v);
}

/* ---- cells ----------------------------------------------------------------------------------- */

enum { MAXN = 512, MAXF = 256, MAXFN = 4096 };

typedef struct shape {
    int32_t nn, nf;
    double x[3 * MAXN];
    int64_t off[MAXF + 1];
    uint32_t fn[MAXFN];
} shape;

static void shape_init(shape *s)
{
    s->nn = 0;
    s->nf = 0;
    s->off[0] = 0;
}

static uint32_t add_node(shape *s, double x, double y, double z)
{
    assert_true(s->nn < MAXN);
    s->x[3 * s->nn] = x;
    s->x[3 * s->nn + 1] = y;
    s->x[3 * s->nn + 2] = z;
    return (uint32_t)s->nn++;
}

/* Adds a face, reversed when its Newell normal points against `outward` (unless zero). */
static void add_face(shape *s, const uint32_t *v, int n, pf_vec3 outward)
{
    assert_true(s->nf < MAXF && s->off[s->nf] + n <= MAXFN);
    uint32_t *dst = s->fn + s->off[s->nf];
    memcpy(dst, v, (size_t)n * sizeof *v);
    if (pf_v3_dot(pf_polygon_area_vector(s->x, dst, n), outward) < 0)
        for (int i = 0; i < n; ++i)
            dst[i] = v[n - 1 - i];
    s->off[s->nf + 1] = s->off[s->nf] + n;
    s->nf++;
}

static pf_polyhedron view(const shape *s)
{
    return (pf_polyhedron){.x = s->x, .n_faces = s->nf, .face_offsets = s->off,
                           .face_nodes = s->fn};
}

/* Prism z in [0, h] over polygons (CCW in xy) sharing edges: bottom and top copies of each, and
 * a side quad on every edge not shared by two polygons. */
static void make_prism(shape *s, const double *xy, int nv, const int *poff, const int *pv,
                       int np, double h)
{
    shape_init(s);
    for (int i = 0; i < nv; ++i)
        add_node(s, xy[2 * i], xy[2 * i + 1], 0);
    for (int i = 0; i < nv; ++i)
        add_node(s, xy[2 * i], xy[2 * i + 1], h);
    for (int p = 0; p < np; ++p) {
        uint32_t v[64];
        int n = poff[p + 1] - poff[p];
        for (int i = 0; i < n; ++i)
            v[i] = (uint32_t)pv[poff[p] + i];
        add_face(s, v, n, pf_v3(0, 0, -1));
        for (int i = 0; i < n; ++i)
            v[i] = (uint32_t)(pv[poff[p] + i] + nv);
        add_face(s, v, n, pf_v3(0, 0, 1));
    }
    for (int p = 0; p < np; ++p) {
        int n = poff[p + 1] - poff[p];
        for (int i = 0; i < n; ++i) {
            int a = pv[poff[p] + i], b = pv[poff[p] + (i + 1) % n], shared = 0;
            for (int q = 0; q < np && !shared; ++q) {
                int m = poff[q + 1] - poff[q];
                for (int j = 0; j < m; ++j)
                    shared |= pv[poff[q] + j] == b && pv[poff[q] + (j + 1) % m] == a;
            }
            if (shared)
                continue;
            uint32_t quad[4] = {(uint32_t)a, (uint32_t)b, (uint32_t)(b + nv), (uint32_t)(a + nv)};
            double dx = xy[2 * b] - xy[2 * a], dy = xy[2 * b + 1] - xy[2 * a + 1];
            add_face(s, quad, 4, pf_v3(dy, -dx, 0));
        }
    }
}

/* Voxel descriptions of the grid-aligned cells: unit cells in [0, 4)^3. */
typedef struct voxels {
    uint8_t on[4][4][4]; /* [i][j][k] for x, y, z */
} voxels;

typedef struct named_cell {
    const char *name;
    shape s;
    voxels vox;  /* filled for grid-aligned cells */
    int has_vox;
    int prism;   /* extruded along z over base polygons */
    double base_area, base_sx, base_sy, height;
} named_cell;

static void fill_prism_voxels(named_cell *c, const int (*cells)[2], int n, int layers)
{
    memset(&c->vox, 0, sizeof c->vox);
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < layers; ++k)
            c->vox.on[cells[i][0]][cells[i][1]][k] = 1;
    c->has_vox = 1;
}

/* Area and first moments of a simple polygon (shoelace). */
static void polygon_moments(const double *xy, int n, double *a, double *sx, double *sy)
{
    *a = *sx = *sy = 0;
    for (int i = 0; i < n; ++i) {
        const double *p = xy + 2 * i, *q = xy + 2 * ((i + 1) % n);
        double cr = p[0] * q[1] - q[0] * p[1];
        *a += cr / 2;
        *sx += (p[0] + q[0]) * cr / 6;
        *sy += (p[1] + q[1]) * cr / 6;
    }
}

static void cell_single_prism(named_cell *c, const char *name, const double *xy, int nv, double h)
{
    int off[2] = {0, nv}, v[64];
    for (int i = 0; i < nv; ++i)
        v[i] = i;
    c->name = name;
    make_prism(&c->s, xy, nv, off, v, 1, h);
    c->prism = 1;
    c->height = h;
    polygon_moments(xy, nv, &c->base_area, &c->base_sx, &c->base_sy);
    c->has_vox = 0;
}

static void cell_box(named_cell *c)
{
    static const double xy[] = {0, 0, 3, 0, 3, 2, 0, 2};
    static const int cells[][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {1, 1}, {2, 1}};
    cell_single_prism(c, "box", xy, 4, 2);
    fill_prism_voxels(c, cells, 6, 2);
}

static void cell_l(named_cell *c)
{
    static const double xy[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    static const int cells[][2] = {{0, 0}, {1, 0}, {0, 1}};
    cell_single_prism(c, "L-prism", xy, 6, 2);
    fill_prism_voxels(c, cells, 3, 2);
}

static void cell_u(named_cell *c)
{
    static const double xy[] = {0, 0, 3, 0, 3, 3, 2, 3, 2, 1, 1, 1, 1, 3, 0, 3};
    static const int cells[][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {0, 2}, {2, 1}, {2, 2}};
    cell_single_prism(c, "U-prism", xy, 8, 2);
    fill_prism_voxels(c, cells, 7, 2);
}

/* Square frame: 3x3 minus the centre, a box with a square through-hole along z. */
static void cell_frame(named_cell *c)
{
    static const double xy[] = {0, 0, 3, 0, 3, 3, 0, 3, 1, 1, 2, 1, 2, 2, 1, 2};
    static const int off[] = {0, 4, 8, 12, 16};
    static const int v[] = {0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};
    static const int cells[][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {2, 1}, {0, 2}, {1, 2}, {2, 2}};
    c->name = "frame";
    make_prism(&c->s, xy, 8, off, v, 4, 2);
    c->prism = 1;
    c->height = 2;
    double a1, x1, y1, a2, x2, y2;
    polygon_moments(xy, 4, &a1, &x1, &y1);
    polygon_moments(xy + 8, 4, &a2, &x2, &y2);
    c->base_area = a1 - a2, c->base_sx = x1 - x2, c->base_sy = y1 - y2;
    fill_prism_voxels(c, cells, 8, 2);
}

static void cell_star(named_cell *c)
{
    double xy[20];
    for (int i = 0; i < 10; ++i) {
        double r = i % 2 ? 0.45 : 1.0, a = 2 * 3.14159265358979323846 * i / 10;
        xy[2 * i] = r * cos(a);
        xy[2 * i + 1] = r * sin(a);
    }
    cell_single_prism(c, "star-prism", xy, 10, 0.7);
}

/* Cube [0,2]^3 minus the corner cube [1,2]^3: three L-shaped faces. */
static void cell_corner_cut(named_cell *c)
{
    shape *s = &c->s;
    shape_init(s);
    for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i)
                add_node(s, i, j, k);
#define G(i, j, k) ((uint32_t)((i) + 3 * (j) + 9 * (k)))
    uint32_t f[][6] = {
        {G(0, 0, 0), G(0, 2, 0), G(0, 2, 2), G(0, 0, 2)},
        {G(0, 0, 0), G(2, 0, 0), G(2, 0, 2), G(0, 0, 2)},
        {G(0, 0, 0), G(2, 0, 0), G(2, 2, 0), G(0, 2, 0)},
        {G(2, 0, 0), G(2, 2, 0), G(2, 2, 1), G(2, 1, 1), G(2, 1, 2), G(2, 0, 2)},
        {G(0, 2, 0), G(2, 2, 0), G(2, 2, 1), G(1, 2, 1), G(1, 2, 2), G(0, 2, 2)},
        {G(0, 0, 2), G(2, 0, 2), G(2, 1, 2), G(1, 1, 2), G(1, 2, 2), G(0, 2, 2)},
        {G(1, 1, 1), G(1, 2, 1), G(1, 2, 2), G(1, 1, 2)},
        {G(1, 1, 1), G(2, 1, 1), G(2, 1, 2), G(1, 1, 2)},
        {G(1, 1, 1), G(2, 1, 1), G(2, 2, 1), G(1, 2, 1)},
    };
#undef G
    int n[] = {4, 4, 4, 6, 6, 6, 4, 4, 4};
    pf_vec3 out[] = {pf_v3(-1, 0, 0), pf_v3(0, -1, 0), pf_v3(0, 0, -1), pf_v3(1, 0, 0), pf_v3(0, 1, 0),
                     pf_v3(0, 0, 1),  pf_v3(1, 0, 0),  pf_v3(0, 1, 0),  pf_v3(0, 0, 1)};
    for (int i = 0; i < 9; ++i)
        add_face(s, f[i], n[i], out[i]);
    c->name = "corner-cut cube";
    c->prism = 0;
    memset(&c->vox, 0, sizeof c->vox);
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            for (int k = 0; k < 2; ++k)
                c->vox.on[i][j][k] = !(i && j && k);
    c->has_vox = 1;
}

static void make_tet(shape *s, const pf_vec3 *p)
{
    shape_init(s);
    for (int i = 0; i < 4; ++i)
        add_node(s, p[i].x, p[i].y, p[i].z);
    pf_vec3 c = pf_v3_scale(pf_v3_add(pf_v3_add(p[0], p[1]), pf_v3_add(p[2], p[3])), 0.25);
    static const uint32_t f[4][3] = {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
    for (int i = 0; i < 4; ++i) {
        pf_vec3 fc = pf_v3_scale(pf_v3_add(pf_v3_add(p[f[i][0]], p[f[i][1]]), p[f[i][2]]), 1.0 / 3);
        add_face(s, f[i], 3, pf_v3_sub(fc, c));
    }
}

static void transform(shape *s, pf_mat3 r, pf_vec3 t)
{
    for (int i = 0; i < s->nn; ++i)
        pf_v3_store(pf_v3_add(pf_m3_mulv(r, pf_v3_load(s->x + 3 * i)), t), s->x + 3 * i);
}

/* ---- checking a split ------------------------------------------------------------------------ */

typedef struct outcome {
    int32_t pieces[2]; /* below, above */
    double volume[2];
    double cap[2];     /* total cap area on each side */
    int32_t cap_faces[2];
} outcome;

static pf_polyhedron pf_piece_view(const pf_split *s, int32_t k)
{
    return (pf_polyhedron){.x = s->x,
                           .n_faces = (int32_t)(s->piece_faces[k + 1] - s->piece_faces[k]),
                           .face_offsets = s->face_offsets + s->piece_faces[k],
                           .face_nodes = s->face_nodes};
}

/* One-element mesh of piece k, validated. */
static void validate_piece(const pf_split *s, int32_t k, const char *what)
{
    pf_error err = {0};
    int64_t f0 = s->piece_faces[k], f1 = s->piece_faces[k + 1];
    int32_t nf = (int32_t)(f1 - f0);
    int64_t nfn = s->face_offsets[f1] - s->face_offsets[f0];
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_alloc(&m, s->n_nodes, nf, nfn, 1, nf, &err), PF_OK);
    memcpy(m.x, s->x, 3 * (size_t)s->n_nodes * sizeof *m.x);
    for (int32_t f = 0; f < nf; ++f)
        m.face_offsets[f + 1] = s->face_offsets[f0 + f + 1] - s->face_offsets[f0];
    memcpy(m.face_nodes, s->face_nodes + s->face_offsets[f0], (size_t)nfn * sizeof(uint32_t));
    m.elem_offsets[1] = nf;
    for (int32_t f = 0; f < nf; ++f)
        m.elem_faces[f] = (uint32_t)f;
    pf_status st = pf_mesh_validate(&m, NULL, &err);
    pf_mesh_release(&m);
    CHECKF(st == PF_OK, "%s: piece %d invalid: %s", what, (int)k, err.msg);
}

static outcome check_split(const shape *c, pf_plane pl, const pf_split_params *prm,
                           const char *what)
{
    pf_polyhedron p = view(c);
    pf_split s;
    pf_error err = {0};
    pf_status st = pf_poly_split(&p, c->nn, &pl, prm, &s, &err);
    CHECKF(st == PF_OK, "%s: split failed: %s", what, err.msg);
    outcome o = {{0, 0}, {0, 0}, {0, 0}, {0, 0}};
    double v0 = pf_polyhedron_volume(&p);
    assert_int_equal(s.n_input_nodes, c->nn);
    assert_memory_equal(s.x, c->x, 3 * (size_t)c->nn * sizeof(double));
    for (int32_t i = 0; i < s.n_nodes - s.n_input_nodes; ++i) {
        /* new nodes lie on their edge, strictly inside it */
        double t = s.new_t[i];
        assert_true(t > 0 && t < 1);
        const double *a = s.x + 3 * s.new_edge[2 * i], *b = s.x + 3 * s.new_edge[2 * i + 1];
        const double *q = s.x + 3 * (s.n_input_nodes + i);
        for (int d = 0; d < 3; ++d)
            assert_true(q[d] >= fmin(a[d], b[d]) && q[d] <= fmax(a[d], b[d]));
        assert_true(fabs(pf_plane_signed_distance(pl, pf_v3_load(q))) <= s.tol);
    }
    for (int32_t k = 0; k < s.n_pieces; ++k) {
        int side = s.piece_side[k];
        assert_true(side == -1 || side == 1);
        int si = side > 0;
        pf_polyhedron pv = pf_piece_view(&s, k);
        double v = pf_polyhedron_volume(&pv);
        CHECKF(v > 0, "%s: piece %d has volume %g", what, (int)k, v);
        o.pieces[si]++;
        o.volume[si] += v;
        for (int64_t f = s.piece_faces[k]; f < s.piece_faces[k + 1]; ++f) {
            for (int64_t j = s.face_offsets[f]; j < s.face_offsets[f + 1]; ++j) {
                double d = pf_plane_signed_distance(pl, pf_v3_load(s.x + 3 * s.face_nodes[j]));
                CHECKF(side * d >= -s.tol, "%s: node %u of piece %d (side %d) at distance %g",
                       what, s.face_nodes[j], (int)k, side, d);
            }
            if (s.face_source[f] < 0) {
                o.cap[si] += pf_polygon_area(s.x, s.face_nodes + s.face_offsets[f],
                                             s.face_offsets[f + 1] - s.face_offsets[f]);
                o.cap_faces[si]++;
                /* caps lie on the plane with the outward normal pointing across it */
                pf_vec3 a = pf_polygon_area_vector(s.x, s.face_nodes + s.face_offsets[f],
                                                   s.face_offsets[f + 1] - s.face_offsets[f]);
                assert_true(-side * pf_v3_dot(a, pl.n) > 0);
            } else {
                assert_true(s.face_source[f] < c->nf);
            }
        }
        validate_piece(&s, k, what);
    }
    CHECKF(fabs(o.volume[0] + o.volume[1] - v0) <= 1e-12 * v0, "%s: volumes %.17g + %.17g != %.17g",
           what, o.volume[0], o.volume[1], v0);
    /* both sides see the same cap region */
    CHECKF(fabs(o.cap[0] - o.cap[1]) <= 1e-12 * (1 + o.cap[0]), "%s: caps %.17g / %.17g", what,
           o.cap[0], o.cap[1]);
    pf_split_release(&s);
    return o;
}

/* Exact volume below x_axis = c (normal +axis) and cap area for voxel cells. */
static void voxel_oracle(const voxels *v, int axis, double c, double *below, double *cap)
{
    *below = 0;
    *cap = 0;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k) {
                if (!v->on[i][j][k])
                    continue;
                int lo = axis == 0 ? i : axis == 1 ? j : k;
                *below += fmin(fmax(c - lo, 0), 1);
                if (c > lo && c < lo + 1)
                    *cap += 1;
                if (c == lo && lo > 0) { /* solid on both sides of the unit square */
                    int ii = i - (axis == 0), jj = j - (axis == 1), kk = k - (axis == 2);
                    *cap += v->on[ii][jj][kk];
                }
            }
}

/* ---- tests ----------------------------------------------------------------------------------- */

static int64_t live0;

static int setup(void **state)
{
    (void)state;
    live0 = pf_alloc_live_bytes();
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    assert_int_equal(pf_alloc_live_bytes(), live0);
    return 0;
}

static void all_cells(named_cell *cells)
{
    cell_box(&cells[0]);
    cell_l(&cells[1]);
    cell_u(&cells[2]);
    cell_frame(&cells[3]);
    cell_corner_cut(&cells[4]);
    cell_star(&cells[5]);
}
enum { N_CELLS = 6 };

static void test_inputs_are_valid(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    double expect[N_CELLS] = {12, 6, 14, 16, 7, 0};
    for (int i = 0; i < N_CELLS; ++i) {
        pf_polyhedron p = view(&cells[i].s);
        if (expect[i] > 0)
            assert_near(pf_polyhedron_volume(&p), expect[i], 1e-13);
        else
            assert_near(pf_polyhedron_volume(&p), cells[i].base_area * cells[i].height,
                                1e-13);
    }
}

/* Plane missing the cell or touching it along a face: one piece, the input itself. */
static void test_miss_and_touch(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    for (int i = 0; i < N_CELLS; ++i) {
        const shape *c = &cells[i].s;
        pf_polyhedron p = view(c);
        pf_plane planes[4] = {pf_plane_from_point_normal(pf_v3(0, 0, 10), pf_v3(0.1, 0.2, 1)),
                              pf_plane_from_point_normal(pf_v3(0, 0, -10), pf_v3(0.1, 0.2, 1)),
                              pf_plane_from_point_normal(pf_v3(0, 0, 0), pf_v3(0, 0, 1)),
                              pf_plane_from_point_normal(pf_v3(0, 0, 0), pf_v3(0, 0, -1))};
        int sides[4] = {-1, 1, 1, -1};
        for (int k = 0; k < 4; ++k) {
            pf_split s;
            pf_error err = {0};
            assert_int_equal(pf_poly_split(&p, c->nn, &planes[k], NULL, &s, &err), PF_OK);
            assert_int_equal(s.n_pieces, 1);
            assert_int_equal(s.piece_side[0], sides[k]);
            assert_int_equal(s.n_nodes, c->nn);
            assert_int_equal(s.n_faces, c->nf);
            assert_memory_equal(s.face_offsets, c->off, ((size_t)c->nf + 1) * sizeof(int64_t));
            assert_memory_equal(s.face_nodes, c->fn, (size_t)c->off[c->nf] * sizeof(uint32_t));
            for (int32_t f = 0; f < c->nf; ++f)
                assert_int_equal(s.face_source[f], f);
            pf_split_release(&s);
        }
    }
}

/* Grid-aligned cells, every axis-aligned plane at quarter steps (through vertices, edges and
 * faces at the integers), both orientations: exact volumes and cap areas. */
static void test_axis_planes_exact(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    char what[128];
    int n = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        if (!cells[i].has_vox)
            continue;
        for (int axis = 0; axis < 3; ++axis)
            for (int q = 1; q < 12; ++q) {
                double c = q * 0.25;
                pf_vec3 lo, hi;
                pf_polyhedron p = view(&cells[i].s);
                pf_polyhedron_bounds(&p, &lo, &hi);
                if (c >= pf_v3_get(hi, axis))
                    continue;
                double below, cap;
                voxel_oracle(&cells[i].vox, axis, c, &below, &cap);
                double total = pf_polyhedron_volume(&p);
                for (int sgn = -1; sgn <= 1; sgn += 2) {
                    pf_vec3 nrm = pf_v3(axis == 0 ? sgn : 0, axis == 1 ? sgn : 0,
                                        axis == 2 ? sgn : 0);
                    pf_vec3 at = pf_v3(c, c, c);
                    snprintf(what, sizeof what, "%s axis %d at %g sign %d", cells[i].name, axis,
                             c, sgn);
                    outcome o = check_split(&cells[i].s, pf_plane_from_point_normal(at, nrm),
                                            NULL, what);
                    double vb = sgn > 0 ? below : total - below;
                    CHECKF(fabs(o.volume[0] - vb) <= 1e-12 * total, "%s: below %.17g, expected %g",
                           what, o.volume[0], vb);
                    CHECKF(fabs(o.cap[0] - cap) <= 1e-12 * total, "%s: cap %.17g, expected %g",
                           what, o.cap[0], cap);
                    ++n;
                }
            }
    }
    assert_true(n > 150);
}

static int32_t count_side(const pf_split *s, int side)
{
    int32_t n = 0;
    for (int32_t k = 0; k < s->n_pieces; ++k)
        n += s->piece_side[k] == side;
    return n;
}

/* The shapes the issue names: U cut across both arms (two pieces on one side), the frame cut
 * through its hole (an annulus cap), the L cut through its reflex edge (two pieces touching along
 * it), the corner-cut cube cut through its inner corner. */
static void test_named_topologies(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    pf_error err = {0};
    pf_split s;
    pf_polyhedron p;
    pf_plane pl;

    /* U across both arms at y = 2: below the base, above the two arms */
    p = view(&cells[2].s);
    pl = pf_plane_from_point_normal(pf_v3(0, 2, 0), pf_v3(0, 1, 0));
    assert_int_equal(pf_poly_split(&p, cells[2].s.nn, &pl, NULL, &s, &err), PF_OK);
    assert_int_equal(count_side(&s, -1), 1);
    assert_int_equal(count_side(&s, 1), 2);
    pf_split_release(&s);
    outcome o = check_split(&cells[2].s, pl, NULL, "U across arms");
    assert_near(o.volume[1], 2 * 1 * 2, 1e-12);
    assert_near(o.cap[0], 2 * 2, 1e-12);

    /* frame, tilted plane through the hole: the cap is an annulus of area 8 / n_z */
    pf_vec3 nrm = pf_v3_normalize(pf_v3(0.1, -0.05, 1));
    pl = pf_plane_from_point_normal(pf_v3(1.5, 1.5, 1), nrm);
    o = check_split(&cells[3].s, pl, NULL, "frame annulus");
    assert_int_equal(o.pieces[0], 1);
    assert_int_equal(o.pieces[1], 1);
    assert_true(o.cap_faces[0] >= 2); /* an annulus is not one simple polygon */
    assert_near(o.cap[0], 8 / nrm.z, 1e-12);
    /* axis-aligned through the hole: the cap's holes share no vertex with the outer loop */
    pl = pf_plane_from_point_normal(pf_v3(0, 0, 1), pf_v3(0, 0, 1));
    o = check_split(&cells[3].s, pl, NULL, "frame annulus, flat");
    assert_near(o.cap[0], 8, 1e-12);
    /* along the hole: two U-shaped halves */
    pl = pf_plane_from_point_normal(pf_v3(1.5, 0, 0), pf_v3(1, 0, 0));
    o = check_split(&cells[3].s, pl, NULL, "frame halves");
    assert_int_equal(o.pieces[0], 1);
    assert_int_equal(o.pieces[1], 1);
    assert_near(o.cap[0], 2 * 2, 1e-12);

    /* L through its reflex edge at 45 degrees: above, two triangular prisms touching along it */
    pl = pf_plane_from_point_normal(pf_v3(1, 1, 0), pf_v3(1, 1, 0));
    o = check_split(&cells[1].s, pl, NULL, "L reflex edge");
    assert_int_equal(o.pieces[0], 1);
    assert_int_equal(o.pieces[1], 2);
    assert_near(o.volume[1], 2 * 0.5 * 2, 1e-12);
    assert_near(o.cap[0], 2 * sqrt(2.0) * 2, 1e-12);
    /* the same, reversed normal: the two touching prisms are below */
    pl = pf_plane_from_point_normal(pf_v3(1, 1, 0), pf_v3(-1, -1, 0));
    o = check_split(&cells[1].s, pl, NULL, "L reflex edge, reversed");
    assert_int_equal(o.pieces[0], 2);
    assert_int_equal(o.pieces[1], 1);

    /* corner-cut cube through the inner corner (1,1,1) with normal (1,1,1): the cap is the
     * hexagon of the cube's cross-section minus the triangle the missing corner would add */
    pl = pf_plane_from_point_normal(pf_v3(1, 1, 1), pf_v3(1, 1, 1));
    o = check_split(&cells[4].s, pl, NULL, "corner-cut through corner");
    /* cube [0,2]^3 cut by x+y+z=3: regular hexagon of side sqrt(2), area 3 sqrt(3); the missing
     * corner [1,2]^3 meets the plane only at (1,1,1) */
    assert_near(o.cap[0], 3 * sqrt(3.0), 1e-12);
    assert_near(o.volume[0], 4, 1e-12);
}

/* Prisms cut by tilted planes crossing every lateral edge: closed-form cap and volume. */
static void test_prisms_tilted(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    rng r = {0x9e3779b97f4a7c15ull};
    char what[128];
    int n = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        if (!cells[i].prism)
            continue;
        named_cell *c = &cells[i];
        pf_polyhedron p = view(&c->s);
        for (int trial = 0; trial < 300; ++trial) {
            pf_vec3 nrm = pf_v3_normalize(pf_v3(uniform_in(&r, -0.3, 0.3), uniform_in(&r, -0.3, 0.3),
                                                uniform01(&r) < 0.5 ? -1 : 1));
            pf_vec3 at = pf_v3(0, 0, uniform_in(&r, 0.3, 0.7) * c->height);
            pf_plane pl = pf_plane_from_point_normal(at, nrm);
            int crosses = 1;
            for (int32_t k = 0; k < c->s.nn; ++k) {
                double d = pf_plane_signed_distance(pl, pf_v3_load(c->s.x + 3 * k));
                int top = c->s.x[3 * k + 2] > 0;
                crosses &= (top ? d : -d) * (nrm.z > 0 ? 1 : -1) > 0;
            }
            if (!crosses)
                continue;
            snprintf(what, sizeof what, "%s tilted %d", c->name, trial);
            outcome o = check_split(&c->s, pl, NULL, what);
            double v0 = pf_polyhedron_volume(&p);
            double below_z = (pl.d * c->base_area - nrm.x * c->base_sx - nrm.y * c->base_sy) / nrm.z;
            double below = nrm.z > 0 ? below_z : v0 - below_z;
            double cap = c->base_area / fabs(nrm.z);
            CHECKF(fabs(o.cap[0] - cap) <= 1e-12 * cap, "%s: cap %.17g expected %.17g", what,
                   o.cap[0], cap);
            CHECKF(fabs(o.volume[0] - below) <= 1e-12 * v0, "%s: below %.17g expected %.17g",
                   what, o.volume[0], below);
            assert_int_equal(o.pieces[0], 1);
            assert_int_equal(o.pieces[1], 1);
            ++n;
        }
    }
    assert_true(n > 500);
}

/* ---- convex cells ---------------------------------------------------------------------------- */

static double hull_area(double (*pt)[2], int n)
{
    /* Andrew's monotone chain */
    for (int i = 1; i < n; ++i)
        for (int j = i; j > 0 && (pt[j][0] < pt[j - 1][0] ||
                                  (pt[j][0] == pt[j - 1][0] && pt[j][1] < pt[j - 1][1]));
             --j) {
            double t0 = pt[j][0], t1 = pt[j][1];
            pt[j][0] = pt[j - 1][0], pt[j][1] = pt[j - 1][1];
            pt[j - 1][0] = t0, pt[j - 1][1] = t1;
        }
    double h[2 * 512][2];
    int k = 0;
    for (int pass = 0; pass < 2; ++pass) {
        int base = k;
        for (int ii = 0; ii < n; ++ii) {
            int i = pass ? n - 1 - ii : ii;
            while (k >= base + 2 &&
                   (h[k - 1][0] - h[k - 2][0]) * (pt[i][1] - h[k - 2][1]) -
                           (h[k - 1][1] - h[k - 2][1]) * (pt[i][0] - h[k - 2][0]) <= 0)
                --k;
            h[k][0] = pt[i][0], h[k][1] = pt[i][1];
            ++k;
        }
        --k;
    }
    double a = 0;
    for (int i = 0; i < k; ++i)
        a += h[i][0] * h[(i + 1) % k][1] - h[(i + 1) % k][0] * h[i][1];
    return fabs(a) / 2;
}

/* Cross-section area of a convex cell: hull of the on-plane nodes and edge crossings. */
static double convex_section(const shape *c, pf_plane pl, double tol)
{
    static double pt[4 * MAXFN][2];
    pf_vec3 e1 = pf_v3_normalize(pf_v3_cross(fabs(pl.n.x) < 0.6 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0),
                                             pl.n));
    pf_vec3 e2 = pf_v3_cross(pl.n, e1);
    int n = 0, below = 0, above = 0;
    for (int32_t f = 0; f < c->nf; ++f)
        for (int64_t k = c->off[f]; k < c->off[f + 1]; ++k) {
            uint32_t a = c->fn[k], b = c->fn[k + 1 < c->off[f + 1] ? k + 1 : c->off[f]];
            pf_vec3 xa = pf_v3_load(c->x + 3 * a), xb = pf_v3_load(c->x + 3 * b);
            double da = pf_plane_signed_distance(pl, xa), db = pf_plane_signed_distance(pl, xb);
            below |= da < -tol;
            above |= da > tol;
            pf_vec3 q;
            if (fabs(da) <= tol)
                q = xa;
            else if ((da < -tol && db > tol) || (da > tol && db < -tol))
                q = pf_v3_add(xa, pf_v3_scale(pf_v3_sub(xb, xa), da / (da - db)));
            else
                continue;
            pt[n][0] = pf_v3_dot(q, e1);
            pt[n][1] = pf_v3_dot(q, e2);
            ++n;
        }
    if (!below || !above || n < 3)
        return 0;
    return hull_area(pt, n);
}

/* A convex cell: the piece below after cutting a cube by a few random planes through points near
 * its centre (with this kernel), nodes compacted. */
static void random_cut_cube(shape *out, rng *r)
{
    static named_cell box;
    shape *cur = out;
    static const double xy[] = {-1, -1, 1, -1, 1, 1, -1, 1};
    cell_single_prism(&box, "cube", xy, 4, 2);
    *cur = box.s;
    int cuts = 2 + rand_int(r, 4);
    for (int i = 0; i < cuts; ++i) {
        pf_vec3 mean = pf_v3(0, 0, 0); /* the vertex average lies inside a convex cell */
        for (int32_t v = 0; v < cur->nn; ++v)
            mean = pf_v3_add(mean, pf_v3_load(cur->x + 3 * v));
        pf_plane pl = pf_plane_from_point_normal(pf_v3_scale(mean, 1.0 / cur->nn), random_unit(r));
        pf_polyhedron p = view(cur);
        pf_split s;
        pf_error err = {0};
        assert_int_equal(pf_poly_split(&p, cur->nn, &pl, NULL, &s, &err), PF_OK);
        int32_t k = 0;
        while (s.piece_side[k] != -1)
            ++k;
        static int32_t map[MAXN + 64];
        for (int32_t v = 0; v < s.n_nodes; ++v)
            map[v] = -1;
        shape next;
        shape_init(&next);
        for (int64_t f = s.piece_faces[k]; f < s.piece_faces[k + 1]; ++f) {
            uint32_t v[64];
            int n = (int)(s.face_offsets[f + 1] - s.face_offsets[f]);
            for (int j = 0; j < n; ++j) {
                uint32_t g = s.face_nodes[s.face_offsets[f] + j];
                if (map[g] < 0)
                    map[g] = (int32_t)add_node(&next, s.x[3 * g], s.x[3 * g + 1], s.x[3 * g + 2]);
                v[j] = (uint32_t)map[g];
            }
            add_face(&next, v, n, pf_v3(0, 0, 0));
        }
        pf_split_release(&s);
        *cur = next;
    }
}

static void random_convex(shape *s, rng *r, int kind)
{
    if (kind == 0) { /* tet */
        pf_vec3 p[4];
        do
            for (int i = 0; i < 4; ++i)
                p[i] = pf_v3(uniform_in(r, -1, 1), uniform_in(r, -1, 1), uniform_in(r, -1, 1));
        while (fabs(pf_v3_dot(pf_v3_sub(p[1], p[0]),
                              pf_v3_cross(pf_v3_sub(p[2], p[0]), pf_v3_sub(p[3], p[0])))) < 0.05);
        make_tet(s, p);
    } else if (kind == 1) { /* box */
        static named_cell c;
        double a = uniform_in(r, 0.2, 2), b = uniform_in(r, 0.2, 2);
        double xy[] = {0, 0, a, 0, a, b, 0, b};
        cell_single_prism(&c, "box", xy, 4, uniform_in(r, 0.2, 2));
        *s = c.s;
    } else if (kind == 2) { /* triangular prism */
        static named_cell c;
        double xy[6];
        do
            for (int i = 0; i < 6; ++i)
                xy[i] = uniform_in(r, -1, 1);
        while ((xy[2] - xy[0]) * (xy[5] - xy[1]) - (xy[3] - xy[1]) * (xy[4] - xy[0]) < 0.1);
        cell_single_prism(&c, "prism", xy, 3, uniform_in(r, 0.2, 2));
        *s = c.s;
    } else {
        random_cut_cube(s, r);
    }
    transform(s, random_rotation(r), pf_v3(uniform_in(r, -5, 5), uniform_in(r, -5, 5), uniform_in(r, -5, 5)));
}

static pf_plane plane_through(const shape *s, uint32_t a, uint32_t b, uint32_t c, int *ok)
{
    pf_vec3 pa = pf_v3_load(s->x + 3 * a), pb = pf_v3_load(s->x + 3 * b),
            pc = pf_v3_load(s->x + 3 * c);
    pf_vec3 n = pf_v3_cross(pf_v3_sub(pb, pa), pf_v3_sub(pc, pa));
    *ok = pf_v3_norm(n) > 1e-6 * pf_v3_dot(pf_v3_sub(pb, pa), pf_v3_sub(pb, pa));
    return pf_plane_from_point_normal(pa, n);
}

static void test_random_convex(void **state)
{
    (void)state;
    rng r = {12345};
    static shape s;
    char what[128];
    int n = 0;
    for (int cell = 0; cell < 300; ++cell) {
        int kind = cell % 4;
        random_convex(&s, &r, kind);
        pf_polyhedron p = view(&s);
        pf_vec3 lo, hi;
        pf_polyhedron_bounds(&p, &lo, &hi);
        double tol = 1e-10 * pf_v3_dist(lo, hi);
        for (int trial = 0; trial < 12; ++trial) {
            pf_plane pl;
            if (trial % 3 == 2) {
                int ok;
                uint32_t a = (uint32_t)rand_int(&r, s.nn), b = (uint32_t)rand_int(&r, s.nn),
                         c = (uint32_t)rand_int(&r, s.nn);
                pl = plane_through(&s, a, b, c, &ok);
                if (!ok || a == b || b == c || a == c)
                    continue;
            } else {
                pf_vec3 t = pf_v3_load(s.x + 3 * rand_int(&r, s.nn));
                pf_vec3 q = pf_v3_load(s.x + 3 * rand_int(&r, s.nn));
                pf_vec3 at = pf_v3_add(t, pf_v3_scale(pf_v3_sub(q, t), uniform01(&r)));
                pl = pf_plane_from_point_normal(at, random_unit(&r));
            }
            snprintf(what, sizeof what, "convex kind %d cell %d trial %d", kind, cell, trial);
            outcome o = check_split(&s, pl, NULL, what);
            double area = convex_section(&s, pl, tol);
            CHECKF(fabs(o.cap[0] - area) <= 1e-12 * (pf_v3_dist(lo, hi) * pf_v3_dist(lo, hi)),
                   "%s: cap %.17g, section %.17g", what, o.cap[0], area);
            assert_true(o.pieces[0] <= 1 && o.pieces[1] <= 1);
            ++n;
        }
    }
    print_message("convex splits: %d\n", n);
    assert_true(n > 2500);
}

/* ---- non-convex cells, planes through vertices -------------------------------------------------- */

static int plane_contains_face(const shape *s, pf_plane pl, double tol)
{
    for (int32_t f = 0; f < s->nf; ++f) {
        int all = 1;
        for (int64_t k = s->off[f]; k < s->off[f + 1] && all; ++k)
            all = fabs(pf_plane_signed_distance(pl, pf_v3_load(s->x + 3 * s->fn[k]))) <= tol;
        if (all)
            return 1;
    }
    return 0;
}

/* Cap area against the derivative of the volume below with respect to the plane's offset. */
static void check_cap_derivative(const shape *s, pf_plane pl, double cap, const char *what)
{
    pf_polyhedron p = view(s);
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(&p, &lo, &hi);
    double len = pf_v3_dist(lo, hi), h = 1e-6 * len;
    pf_plane up = pl, down = pl;
    up.d += h;
    down.d -= h;
    outcome a = check_split(s, up, NULL, what), b = check_split(s, down, NULL, what);
    double deriv = (a.volume[0] - b.volume[0]) / (2 * h);
    CHECKF(fabs(deriv - cap) <= 1e-5 * len * len, "%s: cap %.12g, dV/dd %.12g", what, cap, deriv);
}

static void test_random_nonconvex(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    rng r = {777};
    char what[128];
    int n = 0, derivs = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        for (int rotated = 0; rotated < 2; ++rotated) {
            static shape s;
            s = cells[i].s;
            if (rotated)
                transform(&s, random_rotation(&r), pf_v3(uniform_in(&r, -3, 3), 0.5, -2));
            pf_polyhedron p = view(&s);
            pf_vec3 lo, hi;
            pf_polyhedron_bounds(&p, &lo, &hi);
            double tol = 1e-10 * pf_v3_dist(lo, hi);
            for (int trial = 0; trial < 150; ++trial) {
                int ok;
                uint32_t a = (uint32_t)rand_int(&r, s.nn), b = (uint32_t)rand_int(&r, s.nn),
                         c = (uint32_t)rand_int(&r, s.nn);
                if (a == b || b == c || a == c)
                    continue;
                pf_plane pl = plane_through(&s, a, b, c, &ok);
                if (!ok)
                    continue;
                snprintf(what, sizeof what, "%s%s vertices %u %u %u", cells[i].name,
                         rotated ? " rotated" : "", a, b, c);
                outcome o = check_split(&s, pl, NULL, what);
                ++n;
                if (trial % 5 == 0 && !plane_contains_face(&s, pl, tol)) {
                    check_cap_derivative(&s, pl, o.cap[0], what);
                    ++derivs;
                }
            }
        }
    }
    assert_true(n > 1200);
    assert_true(derivs > 100);
}

/* Grid-aligned cells, diagonal planes through grid vertices: x + y = c, x - y = c, x + y + z = c,
 * x + z = c ... with every integer c that meets the cell. */
static void test_diagonal_vertex_planes(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    static const int dirs[][3] = {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {0, 1, -1}, {1, 1, 1},
                                  {1, -1, 1}, {1, 1, -1}, {2, 1, 0}, {1, 2, 1}};
    char what[128];
    int n = 0;
    for (int i = 0; i < N_CELLS; ++i) {
        if (!cells[i].has_vox)
            continue;
        for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; ++d)
            for (int c = -6; c <= 10; ++c) {
                pf_vec3 nrm = pf_v3(dirs[d][0], dirs[d][1], dirs[d][2]);
                pf_plane pl = {pf_v3_normalize(nrm), c / pf_v3_norm(nrm)};
                int below = 0, above = 0;
                for (int32_t k = 0; k < cells[i].s.nn; ++k) {
                    double v = pf_plane_signed_distance(pl, pf_v3_load(cells[i].s.x + 3 * k));
                    below |= v < -1e-9;
                    above |= v > 1e-9;
                }
                if (!below || !above)
                    continue;
                snprintf(what, sizeof what, "%s plane %d %d %d = %d", cells[i].name, dirs[d][0],
                         dirs[d][1], dirs[d][2], c);
                outcome o = check_split(&cells[i].s, pl, NULL, what);
                if (!plane_contains_face(&cells[i].s, pl, 1e-9))
                    check_cap_derivative(&cells[i].s, pl, o.cap[0], what);
                ++n;
            }
    }
    assert_true(n > 60);
}

/* Two hexes sharing a (non-planar-free, randomly perturbed) face, numbered differently: every
 * new node on the shared face's edges is bit-identical in both splits. */
static void test_shared_edges_bit_identical(void **state)
{
    (void)state;
    rng r = {4242};
    int total_shared = 0;
    for (int trial = 0; trial < 200; ++trial) {
        double g[3][2][2][3]; /* grid points (i, j, k), i in 0..2 */
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) {
                    g[i][j][k][0] = i + (i == 1 ? 0 : uniform_in(&r, -0.1, 0.1)) + 1000.0;
                    g[i][j][k][1] = j + uniform_in(&r, -0.1, 0.1) - 77.0;
                    g[i][j][k][2] = k + uniform_in(&r, -0.1, 0.1);
                }
        /* the shared face i = 1 stays planar: x = 1001 */
        shape cell[2];
        for (int h = 0; h < 2; ++h) {
            shape *s = &cell[h];
            shape_init(s);
            uint32_t id[2][2][2];
            for (int q = 0; q < 8; ++q) {
                int qq = h ? 7 - q : q; /* reverse node numbering in the second cell */
                int i = qq & 1, j = (qq >> 1) & 1, k = qq >> 2;
                id[i][j][k] = add_node(s, g[h + i][j][k][0], g[h + i][j][k][1], g[h + i][j][k][2]);
            }
            pf_vec3 c = pf_v3(h + 1000.5, -76.5, 0.5);
            uint32_t faces[6][4] = {
                {id[0][0][0], id[0][1][0], id[0][1][1], id[0][0][1]},
                {id[1][0][0], id[1][1][0], id[1][1][1], id[1][0][1]},
                {id[0][0][0], id[1][0][0], id[1][0][1], id[0][0][1]},
                {id[0][1][0], id[1][1][0], id[1][1][1], id[0][1][1]},
                {id[0][0][0], id[1][0][0], id[1][1][0], id[0][1][0]},
                {id[0][0][1], id[1][0][1], id[1][1][1], id[0][1][1]},
            };
            for (int f = 0; f < 6; ++f) {
                /* non-planar perturbed side faces would fail validation: split them in two
                 * triangles */
                uint32_t t1[3] = {faces[f][0], faces[f][1], faces[f][2]};
                uint32_t t2[3] = {faces[f][0], faces[f][2], faces[f][3]};
                pf_vec3 m = pf_v3(0, 0, 0);
                for (int v = 0; v < 4; ++v)
                    m = pf_v3_add(m, pf_v3_load(s->x + 3 * faces[f][v]));
                pf_vec3 outw = pf_v3_sub(pf_v3_scale(m, 0.25), c);
                add_face(s, t1, 3, outw);
                add_face(s, t2, 3, outw);
            }
        }
        pf_plane pl = pf_plane_from_point_normal(
            pf_v3(1000.8 + uniform_in(&r, 0, 0.4), -76.5 + uniform_in(&r, -0.3, 0.3), 0.5),
            random_unit(&r));
        pf_split s[2];
        pf_error err = {0};
        for (int h = 0; h < 2; ++h) {
            pf_polyhedron p = view(&cell[h]);
            assert_int_equal(pf_poly_split(&p, cell[h].nn, &pl, NULL, &s[h], &err), PF_OK);
        }
        int shared = 0;
        for (int32_t a = s[0].n_input_nodes; a < s[0].n_nodes; ++a) {
            int32_t ia = a - s[0].n_input_nodes;
            const double *e0 = s[0].x + 3 * s[0].new_edge[2 * ia];
            const double *e1 = s[0].x + 3 * s[0].new_edge[2 * ia + 1];
            for (int32_t b = s[1].n_input_nodes; b < s[1].n_nodes; ++b) {
                int32_t ib = b - s[1].n_input_nodes;
                const double *f0 = s[1].x + 3 * s[1].new_edge[2 * ib];
                const double *f1 = s[1].x + 3 * s[1].new_edge[2 * ib + 1];
                if (memcmp(e0, f0, 3 * sizeof(double)) || memcmp(e1, f1, 3 * sizeof(double)))
                    continue;
                /* the same edge, its ends in the same (lexicographic) order in both cells */
                assert_memory_equal(s[0].x + 3 * a, s[1].x + 3 * b, 3 * sizeof(double));
                assert_true(s[0].new_t[ia] == s[1].new_t[ib]);
                ++shared;
            }
        }
        total_shared += shared;
        pf_split_release(&s[0]);
        pf_split_release(&s[1]);
        for (int h = 0; h < 2; ++h)
            check_split(&cell[h], pl, NULL, "shared-edge hex");
    }
    assert_true(total_shared > 100);
}

/* Planes at tiny distances: slivers cut off a corner or along a face, both above tol. */
static void test_slivers(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    char what[128];
    for (int e = 3; e <= 8; ++e) {
        double eps = pow(10.0, -e);
        /* corner tet of the box at the origin: volume eps^3 / 6 */
        pf_plane pl = pf_plane_from_point_normal(pf_v3(eps, 0, 0), pf_v3(1, 1, 1));
        snprintf(what, sizeof what, "corner sliver %g", eps);
        outcome o = check_split(&cells[0].s, pl, NULL, what);
        assert_int_equal(o.pieces[0], 1);
        assert_near(o.volume[0], eps * eps * eps / 6, 1e-9 * eps * eps * eps);
        /* thin slab along the bottom face of the L: volume 3 eps */
        pl = pf_plane_from_point_normal(pf_v3(0, 0, eps), pf_v3(0, 0, 1));
        snprintf(what, sizeof what, "slab sliver %g", eps);
        o = check_split(&cells[1].s, pl, NULL, what);
        assert_near(o.volume[0], 3 * eps, 1e-12);
        assert_near(o.cap[0], 3, 1e-12);
        /* nearly parallel to the frame's top: a wedge */
        pf_vec3 nrm = pf_v3_normalize(pf_v3(eps, 0, 1));
        pl = pf_plane_from_point_normal(pf_v3(1.5, 1.5, 2 - 2 * eps), nrm);
        snprintf(what, sizeof what, "frame wedge %g", eps);
        o = check_split(&cells[3].s, pl, NULL, what);
        assert_near(o.cap[1], 8 / nrm.z, 1e-9);
    }
}

/* The tolerance override decides what is on the plane. */
static void test_tolerance(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0, 0, 0.01), pf_v3(0, 0, 1));
    pf_split_params prm = pf_split_params_default();
    outcome o = check_split(&cells[0].s, pl, &prm, "default tol");
    assert_int_equal(o.pieces[0], 1);
    assert_near(o.volume[0], 6 * 0.01, 1e-12);
    prm.tol = 0.02; /* the bottom nodes are now on the plane: nothing below */
    o = check_split(&cells[0].s, pl, &prm, "coarse tol");
    assert_int_equal(o.pieces[0], 0);
    assert_int_equal(o.pieces[1], 1);
    prm.tol = 0;
    prm.rel_tol = 0.01 / sqrt(9 + 4 + 4) * 1.5; /* relative to the diagonal sqrt(17) */
    o = check_split(&cells[0].s, pl, &prm, "coarse rel tol");
    assert_int_equal(o.pieces[0], 0);
}

static void test_invalid_inputs(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    pf_split s;
    pf_error err = {0};
    pf_plane pl = pf_plane_from_point_normal(pf_v3(1, 1, 1), pf_v3(0, 0, 1));
    shape open = cells[1].s;
    open.nf--; /* drop the last side face */
    pf_polyhedron p = view(&open);
    assert_int_equal(pf_poly_split(&p, open.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "not closed"));
    assert_null(s.x);
    p = view(&cells[1].s);
    pf_plane bad = {pf_v3(NAN, 0, 1), 0};
    assert_int_equal(pf_poly_split(&p, cells[1].s.nn, &bad, NULL, &s, &err), PF_ERR_INVALID);
    bad = (pf_plane){pf_v3(0, 0, 0), 0};
    assert_int_equal(pf_poly_split(&p, cells[1].s.nn, &bad, NULL, &s, &err), PF_ERR_INVALID);
    assert_int_equal(pf_poly_split(&p, 3, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "references node"));
    shape flat = cells[1].s; /* squash the L into z = 0 */
    for (int32_t i = 0; i < flat.nn; ++i)
        flat.x[3 * i + 2] = 0;
    p = view(&flat);
    pl = pf_plane_from_point_normal(pf_v3(0, 0, 0), pf_v3(0, 0, 1));
    assert_int_equal(pf_poly_split(&p, flat.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    shape nan = cells[1].s;
    nan.x[4] = NAN;
    p = view(&nan);
    assert_int_equal(pf_poly_split(&p, nan.nn, &pl, NULL, &s, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "non-finite"));
}

/* ---- cap polygons ------------------------------------------------------------------------------ */

static int convex_polygon(const double *x, const uint32_t *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i) {
        const double *a = x + 3 * v[i], *b = x + 3 * v[(i + 1) % n], *c = x + 3 * v[(i + 2) % n];
        if ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0)
            return 0;
    }
    return 1;
}

/* Regions of z = 0 given as loops of 2D points (and interior edges both ways): the polygons cover
 * the region's area exactly, each has positive area and distinct nodes, regions with holes come
 * out convex, and every output edge is an input edge or shared by two outputs in opposite
 * directions. */
static void check_cap_case(const double *xy, int nv, const uint32_t *edges, int ne, double area,
                           int min_polys, int convex)
{
    double x[3 * 64];
    for (int i = 0; i < nv; ++i) {
        x[3 * i] = xy[2 * i];
        x[3 * i + 1] = xy[2 * i + 1];
        x[3 * i + 2] = 0;
    }
    int64_t *off;
    uint32_t *nodes;
    int32_t np;
    pf_error err = {0};
    assert_int_equal(pf_split_cap_polygons(x, pf_v3(0, 0, 1), edges, ne, &off, &nodes, &np, &err),
                     PF_OK);
    assert_true(np >= min_polys);
    double sum = 0;
    int64_t balance[64][64];
    memset(balance, 0, sizeof balance);
    for (int i = 0; i < ne; ++i)
        balance[edges[2 * i]][edges[2 * i + 1]]--;
    for (int32_t p = 0; p < np; ++p) {
        int64_t n = off[p + 1] - off[p];
        const uint32_t *v = nodes + off[p];
        pf_vec3 a = pf_polygon_area_vector(x, v, n);
        assert_true(a.z > 0);
        sum += a.z;
        if (convex)
            assert_true(convex_polygon(x, v, n));
        for (int64_t i = 0; i < n; ++i) {
            for (int64_t j = 0; j < i; ++j)
                assert_int_not_equal(v[i], v[j]);
            balance[v[i]][v[(i + 1) % n]]++;
        }
    }
    for (int i = 0; i < nv; ++i)
        for (int j = 0; j < nv; ++j)
            assert_int_equal(balance[i][j], balance[j][i]);
    assert_near(sum, area, 1e-13);
    pf_free(off);
    pf_free(nodes);
}

static void test_cap_polygons(void **state)
{
    (void)state;
    /* square with a diamond hole touching it at (2,0) */
    const double a[] = {0, 0, 2, 0, 4, 0, 4, 4, 0, 4, 1, 1, 2, 2, 3, 1};
    const uint32_t ae[] = {0, 1, 1, 2, 2, 3, 3, 4, 4, 0, 1, 5, 5, 6, 6, 7, 7, 1};
    check_cap_case(a, 8, ae, 9, 16 - 2, 2, 1);
    /* two squares touching at a corner */
    const double b[] = {0, 0, 1, 0, 1, 1, 0, 1, 2, 1, 2, 2, 1, 2};
    const uint32_t be[] = {0, 1, 1, 2, 2, 3, 3, 0, 2, 4, 4, 5, 5, 6, 6, 2};
    check_cap_case(b, 7, be, 8, 2, 2, 0);
    /* rectangle with two square holes */
    const double c[] = {0, 0, 5, 0, 5, 3, 0, 3, 1, 1, 1, 2, 2, 2, 2, 1, 3, 1, 3, 2, 4, 2, 4, 1};
    const uint32_t ce[] = {0, 1, 1, 2,  2, 3, 3, 0, 4, 5, 5, 6, 6, 7,
                           7, 4, 8, 9, 9, 10, 10, 11, 11, 8};
    check_cap_case(c, 12, ce, 12, 13, 3, 1);
    /* non-convex L without holes: one polygon, as given */
    const double d[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    const uint32_t de[] = {0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 0};
    check_cap_case(d, 6, de, 6, 3, 1, 0);
    /* square cut along its diagonal by an interior edge given both ways */
    const double e[] = {0, 0, 2, 0, 2, 2, 0, 2};
    const uint32_t ee[] = {0, 1, 1, 2, 2, 3, 3, 0, 0, 2, 2, 0};
    check_cap_case(e, 4, ee, 6, 4, 2, 1);
    /* an open boundary is refused */
    int64_t *off;
    uint32_t *nodes;
    int32_t np;
    pf_error err = {0};
    double x[] = {0, 0, 0, 1, 0, 0, 1, 1, 0};
    const uint32_t open[] = {0, 1, 1, 2};
    assert_int_equal(pf_split_cap_polygons(x, pf_v3(0, 0, 1), open, 2, &off, &nodes, &np, &err),
                     PF_ERR_NUMERIC);
}

/* Planes through a vertex, nearly parallel to a face (tilts from 1e-6 down to 1e-14 of the
 * size): nodes of that face fall on either side or within tol; whatever the classes, the pieces
 * close and conserve volume. */
static void test_near_parallel(void **state)
{
    (void)state;
    static named_cell cells[N_CELLS];
    all_cells(cells);
    rng r = {99};
    char what[128];
    int n = 0;
    for (int i = 0; i < N_CELLS; ++i)
        for (int e = 6; e <= 14; ++e)
            for (int trial = 0; trial < 12; ++trial) {
                const shape *c = &cells[i].s;
                int32_t f = rand_int(&r, c->nf);
                pf_vec3 a = pf_v3_normalize(
                    pf_polygon_area_vector(c->x, c->fn + c->off[f], c->off[f + 1] - c->off[f]));
                pf_vec3 tilt = pf_v3_scale(random_unit(&r), pow(10.0, -e));
                pf_vec3 at = pf_v3_load(c->x + 3 * c->fn[c->off[f] + rand_int(&r, 3)]);
                pf_plane pl = pf_plane_from_point_normal(at, pf_v3_add(a, tilt));
                snprintf(what, sizeof what, "%s face %d tilt 1e-%d trial %d", cells[i].name,
                         (int)f, e, trial);
                check_split(c, pl, NULL, what);
                ++n;
            }
    assert_true(n > 600);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_inputs_are_valid, setup, teardown),
        cmocka_unit_test_setup_teardown(test_miss_and_touch, setup, teardown),
        cmocka_unit_test_setup_teardown(test_axis_planes_exact, setup, teardown),
        cmocka_unit_test_setup_teardown(test_named_topologies, setup, teardown),
        cmocka_unit_test_setup_teardown(test_prisms_tilted, setup, teardown),
        cmocka_unit_test_setup_teardown(test_random_convex, setup, teardown),
        cmocka_unit_test_setup_teardown(test_random_nonconvex, setup, teardown),
        cmocka_unit_test_setup_teardown(test_diagonal_vertex_planes, setup, teardown),
        cmocka_unit_test_setup_teardown(test_shared_edges_bit_identical, setup, teardown),
        cmocka_unit_test_setup_teardown(test_slivers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_near_parallel, setup, teardown),
        cmocka_unit_test_setup_teardown(test_tolerance, setup, teardown),
        cmocka_unit_test_setup_teardown(test_invalid_inputs, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cap_polygons, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
