/* Shared by the split tests (test_split.c, test_split_nonconvex.c): random numbers, the named
 * cells (box, L, U, frame, star, corner-cut cube, prisms, tets) with their voxel oracles, the check
 * of a split against them, and the fixtures that check no allocation outlives a test. Include after
 * <cmocka.h>, <math.h>, <stdio.h>, <string.h>, "test_check.h" and "test_random.h". */
#ifndef PF_TEST_SPLIT_CELLS_H
#define PF_TEST_SPLIT_CELLS_H

#include <pf/geom.h>
#include <pf/mesh.h>
#include <pf/split.h>

/* ---- random numbers -------------------------------------------------------------------------- */

static inline double uniform_in(rng *r, double lo, double hi) { return lo + (hi - lo) * uniform01(r); }

static inline int32_t rand_int(rng *r, int32_t n) { return (int32_t)(uniform01(r) * n); }

static inline pf_vec3 random_unit(rng *r)
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

static inline void shape_init(shape *s)
{
    s->nn = 0;
    s->nf = 0;
    s->off[0] = 0;
}

static inline uint32_t add_node(shape *s, double x, double y, double z)
{
    assert_true(s->nn < MAXN);
    s->x[3 * s->nn] = x;
    s->x[3 * s->nn + 1] = y;
    s->x[3 * s->nn + 2] = z;
    return (uint32_t)s->nn++;
}

/* Adds a face, reversed when its Newell normal points against `outward` (unless zero). */
static inline void add_face(shape *s, const uint32_t *v, int n, pf_vec3 outward)
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

static inline pf_polyhedron view(const shape *s)
{
    return (pf_polyhedron){.x = s->x, .n_faces = s->nf, .face_offsets = s->off,
                           .face_nodes = s->fn};
}

/* Prism z in [0, h] over polygons (CCW in xy) sharing edges: bottom and top copies of each, and
 * a side quad on every edge not shared by two polygons. */
static inline void make_prism(shape *s, const double *xy, int nv, const int *poff, const int *pv,
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

static inline void fill_prism_voxels(named_cell *c, const int (*cells)[2], int n, int layers)
{
    memset(&c->vox, 0, sizeof c->vox);
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < layers; ++k)
            c->vox.on[cells[i][0]][cells[i][1]][k] = 1;
    c->has_vox = 1;
}

/* Area and first moments of a simple polygon (shoelace). */
static inline void polygon_moments(const double *xy, int n, double *a, double *sx, double *sy)
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

static inline void cell_single_prism(named_cell *c, const char *name, const double *xy, int nv, double h)
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

static inline void cell_box(named_cell *c)
{
    static const double xy[] = {0, 0, 3, 0, 3, 2, 0, 2};
    static const int cells[][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {1, 1}, {2, 1}};
    cell_single_prism(c, "box", xy, 4, 2);
    fill_prism_voxels(c, cells, 6, 2);
}

static inline void cell_l(named_cell *c)
{
    static const double xy[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    static const int cells[][2] = {{0, 0}, {1, 0}, {0, 1}};
    cell_single_prism(c, "L-prism", xy, 6, 2);
    fill_prism_voxels(c, cells, 3, 2);
}

static inline void cell_u(named_cell *c)
{
    static const double xy[] = {0, 0, 3, 0, 3, 3, 2, 3, 2, 1, 1, 1, 1, 3, 0, 3};
    static const int cells[][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {0, 2}, {2, 1}, {2, 2}};
    cell_single_prism(c, "U-prism", xy, 8, 2);
    fill_prism_voxels(c, cells, 7, 2);
}

/* Square frame: 3x3 minus the centre, a box with a square through-hole along z. */
static inline void cell_frame(named_cell *c)
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

static inline void cell_star(named_cell *c)
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
static inline void cell_corner_cut(named_cell *c)
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

static inline void make_tet(shape *s, const pf_vec3 *p)
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

static inline void transform(shape *s, pf_mat3 r, pf_vec3 t)
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

static inline pf_polyhedron pf_piece_view(const pf_split *s, int32_t k)
{
    return (pf_polyhedron){.x = s->x,
                           .n_faces = (int32_t)(s->piece_faces[k + 1] - s->piece_faces[k]),
                           .face_offsets = s->face_offsets + s->piece_faces[k],
                           .face_nodes = s->face_nodes};
}

/* One-element mesh of piece k, validated. */
static inline void validate_piece(const pf_split *s, int32_t k, const char *what)
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

static inline outcome check_split(const shape *c, pf_plane pl, const pf_split_params *prm,
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
static inline void voxel_oracle(const voxels *v, int axis, double c, double *below, double *cap)
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


static int64_t live0;

static inline int setup(void **state)
{
    (void)state;
    live0 = pf_alloc_live_bytes();
    return 0;
}

static inline int teardown(void **state)
{
    (void)state;
    assert_int_equal(pf_alloc_live_bytes(), live0);
    return 0;
}

static inline void all_cells(named_cell *cells)
{
    cell_box(&cells[0]);
    cell_l(&cells[1]);
    cell_u(&cells[2]);
    cell_frame(&cells[3]);
    cell_corner_cut(&cells[4]);
    cell_star(&cells[5]);
}
enum { N_CELLS = 6 };

static inline pf_plane plane_through(const shape *s, uint32_t a, uint32_t b, uint32_t c, int *ok)
{
    pf_vec3 pa = pf_v3_load(s->x + 3 * a), pb = pf_v3_load(s->x + 3 * b),
            pc = pf_v3_load(s->x + 3 * c);
    pf_vec3 n = pf_v3_cross(pf_v3_sub(pb, pa), pf_v3_sub(pc, pa));
    *ok = pf_v3_norm(n) > 1e-6 * pf_v3_dot(pf_v3_sub(pb, pa), pf_v3_sub(pb, pa));
    return pf_plane_from_point_normal(pa, n);
}

#endif
