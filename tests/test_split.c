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

#include "test_split_cells.h"

/* ---- tests ----------------------------------------------------------------------------------- */

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
        cmocka_unit_test_setup_teardown(test_near_parallel, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cap_polygons, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
