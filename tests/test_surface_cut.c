/* surface_cut: the embedded surface cut along the faces a mesh cut opened, and the visibility
 * rule of the embedding.
 *
 * Fixtures: a bar of unit hexes cut along the grid plane x = 2 by hand, as pf_mesh_cut leaves
 * it (the faces on the cut opened into two boundary faces, one per side, the nodes on them
 * duplicated except at the crack front), and pf_mesh_cut's own cuts: through and partially
 * through the hexes of a bar, a bar of tetrahedra, a sliced sphere with its own surface, and a
 * second cut of a cut bar. Surfaces: boxes, spheres with poles or whole meridians on the cut.
 * Oracles: topology (closed, manifold, the number of pieces, front vertices shared, positions
 * behind the front duplicated), volumes (the split triangles tile the input's exactly and the
 * two sides' caps cancel: the embedded surface's volume is unchanged to round-off, 1e-12
 * relative leaves room for the sums over ~100 triangles; a surface that is the mesh's own
 * boundary closes to the mesh's volume), cap areas (the section's, analytic for boxes), affine
 * fields (MLS and bary reproduce them exactly: 1e-12 of the model size is round-off with room)
 * and rigid motions of one side (a vertex moves with it exactly when it is on that side: no
 * weight crosses the cut, checked to 1e-12; without the visibility rule the same check fails
 * for a quarter of the vertices, which the box test asserts). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "test_check.h"
#include <pf/cut.h>
#include <pf/embed.h>
#include <pf/mesh.h>

#define CUT_X 2.0
#define PI    3.14159265358979323846

/* ---- fixtures ----------------------------------------------------------------------------------
 */

typedef struct cut_fixture {
    pf_mesh m;
    pf_cut_result cut;
    double cut_x;    /* the plane x = cut_x */
    bool real;       /* cut by pf_mesh_cut */
    uint8_t *node_b; /* [m.n_nodes] 1 for nodes of side B (x > CUT_X) only, 2 for shared */
} cut_fixture;

static void fixture_release(cut_fixture *f)
{
    pf_mesh_release(&f->m);
    if (f->real) {
        pf_cut_result_release(&f->cut);
    } else {
        pf_free(f->cut.opened);
        pf_free(f->cut.cut_face);
    }
    free(f->node_b);
    memset(f, 0, sizeof *f);
}

static pf_vec3 face_centroid(const pf_mesh *m, int32_t f)
{
    int64_t o = m->face_offsets[f];
    return pf_polygon_centroid(m->x, m->face_nodes + o, m->face_offsets[f + 1] - o);
}

static pf_vec3 elem_centroid(const pf_mesh *m, int32_t e)
{
    pf_vec3 c = pf_v3(0, 0, 0);
    int n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k, ++n)
        c = pf_v3_add(c, face_centroid(m, PF_FACE_INDEX(m->elem_faces[k])));
    return pf_v3_scale(c, 1.0 / n);
}

/* The side of every node, by the elements using it (side_b[e]: element e is on side B). */
static void node_sides(cut_fixture *fx, const uint8_t *side_b)
{
    const pf_mesh *m = &fx->m;
    fx->node_b = calloc((size_t)m->n_nodes, 1);
    uint8_t *node_a = calloc((size_t)m->n_nodes, 1);
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
                if (side_b[e])
                    fx->node_b[m->face_nodes[j]] = 1;
                else
                    node_a[m->face_nodes[j]] = 1;
            }
        }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (fx->node_b[i] && node_a[i])
            fx->node_b[i] = 2;
    free(node_a);
}

/* src (derived) cut by pf_mesh_cut along x = cut_x in every element the plane crosses whose
 * centroid has y < y_front. */
static void make_real_cut_ex(cut_fixture *fx, const pf_mesh *src, double cut_x, double y_front,
                             const uint8_t *src_cut_face, double side_x)
{
    memset(fx, 0, sizeof *fx);
    fx->cut_x = cut_x;
    fx->real = true;
    pf_cut_request *req = malloc(sizeof *req * (size_t)src->n_elems);
    int32_t n = 0;
    for (int32_t e = 0; e < src->n_elems; ++e) {
        double lo = INFINITY, hi = -INFINITY;
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(src->elem_faces[k]);
            for (int64_t j = src->face_offsets[f]; j < src->face_offsets[f + 1]; ++j) {
                lo = fmin(lo, src->x[3 * src->face_nodes[j]]);
                hi = fmax(hi, src->x[3 * src->face_nodes[j]]);
            }
        }
        if (lo < cut_x && hi > cut_x && elem_centroid(src, e).y < y_front)
            req[n++] =
                (pf_cut_request){e, pf_plane_from_point_normal(pf_v3(cut_x, 0, 0), pf_v3(1, 0, 0))};
    }
    pf_error err = {0};
    pf_cut_params cp = {0};
    cp.src_cut_face = src_cut_face;
    pf_status st = pf_mesh_cut(src, req, n, &cp, &fx->m, &fx->cut, &err);
    CHECKF(st == PF_OK, "pf_mesh_cut: %s", err.msg);
    assert_true(fx->cut.n_opened > 0);
    uint8_t *side_b = calloc((size_t)fx->m.n_elems, 1);
    for (int32_t e = 0; e < fx->m.n_elems; ++e)
        side_b[e] = elem_centroid(&fx->m, e).x > side_x;
    fx->cut_x = side_x;
    node_sides(fx, side_b);
    free(side_b);
    free(req);
}

static void make_real_cut(cut_fixture *fx, const pf_mesh *src, double cut_x, double y_front)
{
    make_real_cut_ex(fx, src, cut_x, y_front, NULL, cut_x);
}

/* The bar [0, nx] x [0, ny] x [0, nz] of unit hexes cut along x = CUT_X where y < y_front (the
 * crack front is the line x = CUT_X, y = y_front; y_front >= ny: cut through). */
static void make_cut_bar(cut_fixture *fx, int nx, int ny, int nz, double y_front)
{
    memset(fx, 0, sizeof *fx);
    fx->cut_x = CUT_X;
    pf_error err = {0};
    pf_mesh src = {0};
    assert_int_equal(pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(nx, ny, nz), nx, ny, nz, &err),
                     PF_OK);
    assert_int_equal(pf_mesh_derive(&src, &err), PF_OK);
    int32_t nn = src.n_nodes, nf = src.n_faces;
    int32_t *copy = malloc(sizeof *copy * (size_t)nn);
    int32_t n_copies = 0;
    for (int32_t i = 0; i < nn; ++i) {
        const double *x = src.x + 3 * i;
        copy[i] = x[0] == CUT_X && x[1] < y_front - 1e-9 ? nn + n_copies++ : -1;
    }
    uint8_t *open = calloc((size_t)nf, 1), *side_b = calloc((size_t)src.n_elems, 1);
    int32_t n_open = 0;
    for (int32_t e = 0; e < src.n_elems; ++e)
        side_b[e] = elem_centroid(&src, e).x > CUT_X;
    for (int32_t f = 0; f < nf; ++f) {
        pf_vec3 c = face_centroid(&src, f);
        int32_t e0 = src.face_elems[2 * f], e1 = src.face_elems[2 * f + 1];
        if (e0 >= 0 && e1 >= 0 && side_b[e0] != side_b[e1] && c.y < y_front)
            open[f] = 1, n_open++;
    }
    int64_t n_fn = src.face_offsets[nf];
    for (int32_t f = 0; f < nf; ++f)
        if (open[f])
            n_fn += src.face_offsets[f + 1] - src.face_offsets[f];
    pf_mesh *m = &fx->m;
    assert_int_equal(pf_mesh_alloc(m, nn + n_copies, nf + n_open, n_fn, src.n_elems,
                                   src.elem_offsets[src.n_elems], &err),
                     PF_OK);
    memcpy(m->x, src.x, sizeof(double) * 3 * (size_t)nn);
    for (int32_t i = 0; i < nn; ++i)
        if (copy[i] >= 0)
            memcpy(m->x + 3 * copy[i], src.x + 3 * i, 3 * sizeof(double));
    int32_t *new_face = malloc(sizeof *new_face * (size_t)nf);
    int32_t f_out = 0;
    int64_t o = 0;
    /* the faces as they are; a face of side B only takes the copies */
    for (int32_t f = 0; f < nf; ++f, ++f_out) {
        int32_t e0 = src.face_elems[2 * f], e1 = src.face_elems[2 * f + 1];
        int b_only = (e0 < 0 || side_b[e0]) && (e1 < 0 || side_b[e1]);
        for (int64_t j = src.face_offsets[f]; j < src.face_offsets[f + 1]; ++j) {
            uint32_t a = src.face_nodes[j];
            m->face_nodes[o++] = b_only && copy[a] >= 0 ? (uint32_t)copy[a] : a;
        }
        m->face_offsets[f_out + 1] = o;
    }
    /* side B's copies of the opened faces */
    for (int32_t f = 0; f < nf; ++f) {
        new_face[f] = -1;
        if (!open[f])
            continue;
        for (int64_t j = src.face_offsets[f]; j < src.face_offsets[f + 1]; ++j) {
            uint32_t a = src.face_nodes[j];
            m->face_nodes[o++] = copy[a] >= 0 ? (uint32_t)copy[a] : a;
        }
        new_face[f] = f_out;
        m->face_offsets[++f_out] = o;
    }
    for (int32_t e = 0; e < src.n_elems; ++e) {
        m->elem_offsets[e + 1] = src.elem_offsets[e + 1];
        for (int64_t k = src.elem_offsets[e]; k < src.elem_offsets[e + 1]; ++k) {
            uint32_t entry = src.elem_faces[k];
            int32_t f = PF_FACE_INDEX(entry);
            if (side_b[e] && open[f])
                entry = (uint32_t)new_face[f] | (entry & PF_FACE_REVERSED);
            m->elem_faces[k] = entry;
        }
    }
    m->id = src.id + 1;
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
    fx->cut.opened = pf_alloc_array((size_t)m->n_faces, 1);
    fx->cut.cut_face = pf_alloc_array((size_t)m->n_faces, 1);
    for (int32_t f = 0; f < m->n_faces; ++f)
        fx->cut.opened[f] = fx->cut.cut_face[f] = f < nf ? open[f] : 1;
    fx->cut.n_opened = n_open;
    fx->cut.n_duplicated = n_copies;
    node_sides(fx, side_b);
    free(copy);
    free(open);
    free(side_b);
    free(new_face);
    pf_mesh_release(&src);
}

/* A closed box surface lo..hi (the generator's four vertices per side welded). */
static void make_closed_box(pf_surface *s, pf_vec3 lo, pf_vec3 hi)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_make_box(s, lo, hi, &err), PF_OK);
    pf_surface_repair_report rep;
    assert_int_equal(pf_surface_repair(s, NULL, &rep, &err), PF_OK);
    assert_true(rep.closed);
    s->id = 40;
}

/* ---- checks ---------------------------------------------------------------------------------- */

static pf_surface_stats stats_of(const pf_surface *s)
{
    pf_surface_stats st;
    pf_error err = {0};
    assert_int_equal(pf_surface_compute_stats(s, &st, &err), PF_OK);
    return st;
}

static void print_boundary(const pf_surface *s)
{
    for (int32_t t = 0; t < s->n_tris; ++t)
        for (int q = 0; q < 3; ++q) {
            uint32_t a = s->tri[3 * t + q], b = s->tri[3 * t + (q + 1) % 3];
            int found = 0;
            for (int32_t u = 0; u < s->n_tris && !found; ++u)
                for (int r = 0; r < 3; ++r)
                    found |= s->tri[3 * u + r] == b && s->tri[3 * u + (r + 1) % 3] == a;
            if (!found)
                print_error("open edge %u (%g %g %g) -> %u (%g %g %g) of triangle %d part %d\n", a,
                            s->x[3 * a], s->x[3 * a + 1], s->x[3 * a + 2], b, s->x[3 * b],
                            s->x[3 * b + 1], s->x[3 * b + 2], t, s->tri_part[t]);
        }
}

/* Connected components of triangles through shared edges. */
static int components(const pf_surface *s)
{
    int32_t *parent = malloc(sizeof *parent * (size_t)s->n_verts);
    for (int32_t i = 0; i < s->n_verts; ++i)
        parent[i] = i;
    for (int32_t t = 0; t < s->n_tris; ++t)
        for (int q = 0; q < 3; ++q) {
            int32_t a = (int32_t)s->tri[3 * t + q], b = (int32_t)s->tri[3 * t + (q + 1) % 3];
            while (parent[a] != a)
                a = parent[a];
            while (parent[b] != b)
                b = parent[b];
            parent[a > b ? a : b] = a < b ? a : b;
        }
    int used = 0;
    uint8_t *u = calloc((size_t)s->n_verts, 1);
    for (int32_t t = 0; t < 3 * s->n_tris; ++t)
        u[s->tri[t]] = 1;
    for (int32_t i = 0; i < s->n_verts; ++i)
        used += u[i] && parent[i] == i;
    free(u);
    free(parent);
    return used;
}

/* Affine field a + G x on all nodes: every vertex moves by a + G x (to 1e-12 of the model size)
 * and every row sums to 1 (to 1e-12). */
static void check_affine(const pf_mesh *m, const pf_surface *s, const pf_weights *w)
{
    pf_mat3 g = {{{0.3, -0.2, 0.1}, {0.05, 0.4, -0.3}, {-0.1, 0.2, 0.25}}};
    pf_vec3 a = pf_v3(0.7, -0.4, 0.2);
    double *u = malloc(sizeof(double) * 3 * (size_t)m->n_nodes);
    double *out = malloc(sizeof(double) * 3 * (size_t)s->n_verts);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        pf_v3_store(pf_v3_add(a, pf_m3_mulv(g, pf_v3_load(m->x + 3 * i))), u + 3 * i);
    pf_weights_apply(w, s->x, u, out);
    for (int32_t i = 0; i < s->n_verts; ++i) {
        pf_vec3 x = pf_v3_load(s->x + 3 * i);
        pf_vec3 want = pf_v3_add(x, pf_v3_add(a, pf_m3_mulv(g, x)));
        CHECKF(pf_v3_dist(want, pf_v3_load(out + 3 * i)) <= 1e-12 * 5, "vertex %d off by %g", i,
               pf_v3_dist(want, pf_v3_load(out + 3 * i)));
        double sum = 0;
        for (int64_t k = w->row_offsets[i]; k < w->row_offsets[i + 1]; ++k)
            sum += w->val[k];
        assert_near(sum, 1, 1e-12);
    }
    free(u);
    free(out);
}

/* Moves side B's nodes rigidly (shared front nodes stay): every vertex either moves exactly
 * rigidly (side B) or not at all (side A), to 1e-12 (checked when expect). moved[v] (may be
 * NULL) receives 1 for the ones that moved; returns the number of vertices that did neither. */
static int rigid_side_b(const cut_fixture *fx, const pf_surface *s, const pf_weights *w,
                        uint8_t *moved, bool expect)
{
    const pf_mesh *m = &fx->m;
    double c = cos(0.3), sn = sin(0.3);
    pf_mat3 r = {{{c - 1, -sn, 0}, {sn, c - 1, 0}, {0, 0, 0}}}; /* R - I about z */
    pf_vec3 t = pf_v3(0.5, -0.25, 0.125);
    double *u = calloc(3 * (size_t)m->n_nodes, sizeof(double));
    double *out = malloc(sizeof(double) * 3 * (size_t)s->n_verts);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (fx->node_b[i] == 1)
            pf_v3_store(pf_v3_add(t, pf_m3_mulv(r, pf_v3_load(m->x + 3 * i))), u + 3 * i);
    pf_weights_apply(w, s->x, u, out);
    int mixed = 0;
    for (int32_t i = 0; i < s->n_verts; ++i) {
        pf_vec3 x = pf_v3_load(s->x + 3 * i), got = pf_v3_load(out + 3 * i);
        pf_vec3 rigid = pf_v3_add(x, pf_v3_add(t, pf_m3_mulv(r, x)));
        double still = pf_v3_dist(got, x), along = pf_v3_dist(got, rigid);
        if (expect)
            CHECKF(still <= 1e-12 || along <= 1e-12,
                   "vertex %d at (%g %g %g) neither still (%g) nor rigid with side B (%g)", i, x.x,
                   x.y, x.z, still, along);
        mixed += still > 1e-12 && along > 1e-12;
        if (moved)
            moved[i] = along <= 1e-12;
    }
    free(u);
    free(out);
    return mixed;
}

/* Every triangle's vertices on its own side: corners of a triangle lying at x < CUT_X (or a cap
 * facing +x, the outward side of piece A) do not move with side B, those of triangles at
 * x > CUT_X (caps facing -x) do. */
static void check_triangle_sides(const pf_surface *s, const uint8_t *moved, double cut_x)
{
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *v = s->tri + 3 * t;
        pf_vec3 a = pf_v3_load(s->x + 3 * v[0]), b = pf_v3_load(s->x + 3 * v[1]),
                c = pf_v3_load(s->x + 3 * v[2]);
        double cx = (a.x + b.x + c.x) / 3;
        pf_vec3 n = pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a));
        int side = 0;
        if (s->tri_part && s->tri_part[t] == PF_SURFACE_CAP)
            side = n.x > 0 ? -1 : 1;
        else if (fabs(cx - cut_x) > 1e-9)
            side = cx < cut_x ? -1 : 1;
        for (int q = 0; q < 3 && side != 0; ++q) {
            pf_vec3 x = pf_v3_load(s->x + 3 * v[q]);
            if (fabs(x.x - cut_x) > 1e-9 && (x.x < cut_x) != (side < 0))
                continue; /* a corner across the plane: checked by its own triangles */
            CHECKF(moved[v[q]] == (side > 0),
                   "triangle %d (side %d) has vertex %u of the other side", t, side, v[q]);
        }
    }
}

static void run_cut(const cut_fixture *fx, const pf_surface *s, const pf_embed_params *p,
                    pf_surface *out, pf_weights *w, pf_surface_cut_stats *st)
{
    pf_error err = {0};
    pf_status status = pf_surface_cut(s, &fx->m, &fx->cut, p, out, w, st, &err);
    CHECKF(status == PF_OK, "pf_surface_cut: %s", err.msg);
    assert_true(out->id == s->id + 1);
    assert_true(w->surface_id == out->id && w->mesh_id == fx->m.id);
    assert_int_equal(w->rows, out->n_verts);
    assert_int_equal(w->cols, fx->m.n_nodes);
    assert_non_null(out->tri_part);
}

/* The closed checks of a cut through: closed, manifold, two pieces, the volume unchanged, caps
 * of the section's area on each side, affine fields, no weight across the cut. */
static void check_cut_through(const cut_fixture *fx, const pf_surface *s, const pf_surface *out,
                              const pf_weights *w, const pf_surface_cut_stats *st,
                              double section_area)
{
    pf_surface_stats in = stats_of(s), got = stats_of(out);
    CHECKF(got.closed && got.manifold,
           "cut surface: %lld boundary, %lld non-manifold, %lld flipped",
           (long long)got.n_boundary_edges, (long long)got.n_nonmanifold_edges,
           (long long)got.n_flipped_edges);
    assert_near(got.volume, in.volume, 1e-12 * fabs(in.volume));
    assert_int_equal(components(out), 2);
    assert_near(st->cap_area, 2 * section_area, 1e-12 * section_area);
    int32_t caps = 0;
    for (int32_t t = 0; t < out->n_tris; ++t)
        caps += out->tri_part[t] == PF_SURFACE_CAP;
    assert_int_equal(caps, st->n_cap_tris);
    check_affine(&fx->m, out, w);
    uint8_t *moved = malloc((size_t)out->n_verts);
    rigid_side_b(fx, out, w, moved, true);
    check_triangle_sides(out, moved, fx->cut_x);
    free(moved);
}

/* ---- tests -------------------------------------------------------------------------------------
 */

/* A box inside a 4 x 2 x 1 bar cut through at x = 2: the eight triangles of its four long sides
 * are split, the section's eight points (on four edges, four diagonals) and the two where it
 * crosses the edge between the two opened faces (y = 1) are duplicated; each side is capped by
 * the 1.4 x 0.6 section. MLS (NULL parameters) and bary. */
static void test_box_cut_through(void **state)
{
    (void)state;
    cut_fixture fx;
    make_cut_bar(&fx, 4, 2, 1, 10);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(3.7, 1.65, 0.8));
    for (int method = 0; method < 2; ++method) {
        pf_embed_params p = pf_embed_params_default();
        p.method = method ? PF_EMBED_BARY : PF_EMBED_MLS;
        pf_surface out = {0};
        pf_weights w = {0};
        pf_surface_cut_stats st;
        run_cut(&fx, &s, method ? &p : NULL, &out, &w, &st);
        assert_int_equal(st.n_split_tris, 8);
        assert_int_equal(st.n_duplicated, 10);
        check_cut_through(&fx, &s, &out, &w, &st, 1.4 * 0.6);
        if (method == 0) { /* the check can fail: MLS without the visibility rule mixes sides */
            pf_weights plain = {0};
            pf_error err = {0};
            assert_int_equal(pf_embed_compute(&fx.m, &out, NULL, &plain, NULL, &err), PF_OK);
            assert_true(rigid_side_b(&fx, &out, &plain, NULL, false) > out.n_verts / 4);
            pf_weights_release(&plain);
        }
        pf_surface_release(&out);
        pf_weights_release(&w);
    }
    pf_surface_release(&s);
    fixture_release(&fx);
}

/* A sphere centred on the cut: its poles lie on the plane (vertices duplicated, not split
 * edges). The cap is the section polygon: its area is that of the 20-gon through the crossings,
 * computed here from the surface's own section (the split points and the poles). */
static void sphere_on_cut(int n_lon)
{
    cut_fixture fx;
    make_cut_bar(&fx, 4, 2, 1, 10);
    pf_surface s = {0};
    pf_error err = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 0.4, 8, n_lon, &err), PF_OK);
    for (int32_t i = 0; i < s.n_verts; ++i) {
        s.x[3 * i] += CUT_X;
        s.x[3 * i + 1] += 1;
        s.x[3 * i + 2] += 0.5;
    }
    s.id = 3;
    pf_surface out = {0};
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(&fx, &s, NULL, &out, &w, &st);
    /* the section: the cap triangles facing +x, whose area the stats report for both sides */
    double area = 0;
    for (int32_t t = 0; t < out.n_tris; ++t)
        if (out.tri_part[t] == PF_SURFACE_CAP) {
            const uint32_t *v = out.tri + 3 * t;
            pf_vec3 a = pf_v3_load(out.x + 3 * v[0]);
            pf_vec3 n = pf_v3_cross(pf_v3_sub(pf_v3_load(out.x + 3 * v[1]), a),
                                    pf_v3_sub(pf_v3_load(out.x + 3 * v[2]), a));
            area += n.x > 0 ? 0.5 * n.x : 0;
        }
    assert_true(area > 0.9 * PI * 0.4 * 0.4 * 0.9 && area < PI * 0.4 * 0.4);
    check_cut_through(&fx, &s, &out, &w, &st, area);
    pf_surface_release(&out);
    pf_weights_release(&w);
    pf_surface_release(&s);
    fixture_release(&fx);
}

static void test_sphere_poles_on_cut(void **state)
{
    (void)state;
    sphere_on_cut(10);
}

/* With 16 meridians, two of them lie in the cut plane: edges of the surface on the cut, between
 * triangles of either side. */
static void test_sphere_edges_on_cut(void **state)
{
    (void)state;
    sphere_on_cut(16);
}

/* The bar's own boundary as the surface (a sliced mesh's surface is its boundary): the cut's
 * section runs along the opened faces' outer edges and through mesh nodes; the caps are the
 * opened faces whole, and the capped surface encloses the two pieces: the bar's volume. */
static void test_boundary_surface(void **state)
{
    (void)state;
    cut_fixture fx;
    make_cut_bar(&fx, 4, 2, 1, 10);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0, 0, 0), pf_v3(4, 2, 1));
    pf_surface out = {0};
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(&fx, &s, NULL, &out, &w, &st);
    check_cut_through(&fx, &s, &out, &w, &st, 2.0);
    assert_near(stats_of(&out).volume, 8.0, 1e-12 * 8);
    pf_surface_release(&out);
    pf_weights_release(&w);
    pf_surface_release(&s);
    fixture_release(&fx);
}

/* A crack from y = 0 to the front y = 1 in a 4 x 2 x 1 bar; the box spans y 0.25 .. 1.75: the
 * surface stays one closed surface, the slit ends on the front, the caps of both sides meet
 * there (front vertices shared: each position on the front is one vertex), positions on the cut
 * behind the front are two vertices; affine fields reproduced; vertices of side A away from the
 * front (x < 2, y < 1 - support) do not move with side B. */
/* The checks of a partial cut with its front on the line x = cut_x, y = y_front. */
static void check_partial(const cut_fixture *fx, const pf_surface *s, double y_front,
                          double cap_area)
{
    pf_surface out = {0};
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(fx, s, NULL, &out, &w, &st);
    pf_surface_stats in = stats_of(s), got = stats_of(&out);
    if (!got.closed)
        print_boundary(&out);
    CHECKF(got.closed && got.manifold,
           "cut surface: %lld boundary, %lld non-manifold, %lld flipped",
           (long long)got.n_boundary_edges, (long long)got.n_nonmanifold_edges,
           (long long)got.n_flipped_edges);
    assert_int_equal(components(&out), 1);
    assert_near(got.volume, in.volume, 1e-12 * in.volume);
    assert_near(st.cap_area, cap_area, 1e-12);
    int front = 0, behind = 0;
    for (int32_t i = 0; i < out.n_verts; ++i) {
        const double *x = out.x + 3 * i;
        if (fabs(x[0] - fx->cut_x) > 1e-12)
            continue;
        int copies = 0;
        for (int32_t j = 0; j < out.n_verts; ++j)
            copies += memcmp(out.x + 3 * j, x, 3 * sizeof(double)) == 0;
        if (fabs(x[1] - y_front) <= 1e-12) {
            CHECKF(copies == 1, "front vertex %d at z %g has %d copies", i, x[2], copies);
            front++;
        } else if (x[1] < y_front) {
            CHECKF(copies == 2, "vertex %d on the cut (y %g z %g) has %d copies", i, x[1], x[2],
                   copies);
            behind++;
        }
    }
    assert_true(front >= 2 && behind >= 4);
    check_affine(&fx->m, &out, &w);
    pf_surface_release(&out);
    pf_weights_release(&w);
}

/* A crack from y = 0 to the front y = 1 in a 4 x 2 x 1 bar; the box spans y 0.25 .. 1.75 (its
 * bottom and top diagonals cross the plane on the front): the surface stays one closed surface,
 * the slit ends on the front, the caps of both sides meet there (front vertices shared: each
 * position on the front is one vertex), positions on the cut behind the front are two vertices;
 * the caps cover the section behind the front, 0.75 x 0.6 on each side; affine fields
 * reproduced. */
static void test_partial_cut(void **state)
{
    (void)state;
    cut_fixture fx;
    make_cut_bar(&fx, 4, 2, 1, 1.0);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(3.7, 1.75, 0.8));
    check_partial(&fx, &s, 1.0, 2 * 0.75 * 0.6);
    pf_surface_release(&s);
    fixture_release(&fx);
}

static void make_bar(pf_mesh *m, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(nx, ny, nz), nx, ny, nz, &err),
                     PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* pf_mesh_cut through the middle of the hexes of a 5 x 2 x 1 bar (x = 2.5): as the hand-made
 * cut, with the opened faces the caps between the halves of each hex. */
static void test_real_cut_through(void **state)
{
    (void)state;
    pf_mesh bar = {0};
    make_bar(&bar, 5, 2, 1);
    cut_fixture fx;
    make_real_cut(&fx, &bar, 2.5, 10);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(4.7, 1.65, 0.8));
    for (int method = 0; method < 2; ++method) {
        pf_embed_params p = pf_embed_params_default();
        p.method = method ? PF_EMBED_BARY : PF_EMBED_MLS;
        pf_surface out = {0};
        pf_weights w = {0};
        pf_surface_cut_stats st;
        run_cut(&fx, &s, &p, &out, &w, &st);
        assert_int_equal(st.n_split_tris, 8);
        assert_int_equal(st.n_duplicated, 10);
        check_cut_through(&fx, &s, &out, &w, &st, 1.4 * 0.6);
        pf_surface_release(&out);
        pf_weights_release(&w);
    }
    pf_surface_release(&s);
    fixture_release(&fx);
    pf_mesh_release(&bar);
}

/* The same on a bar of Kuhn tetrahedra cut at x = 2.4 (triangle and quadrilateral caps). */
static void test_real_cut_tets(void **state)
{
    (void)state;
    pf_mesh bar = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box_tets(&bar, pf_v3(0, 0, 0), pf_v3(5, 2, 1), 5, 2, 1, &err),
                     PF_OK);
    assert_int_equal(pf_mesh_derive(&bar, &err), PF_OK);
    cut_fixture fx;
    make_real_cut(&fx, &bar, 2.4, 10);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(4.7, 1.65, 0.8));
    pf_surface out = {0};
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(&fx, &s, NULL, &out, &w, &st);
    check_cut_through(&fx, &s, &out, &w, &st, 1.4 * 0.6);
    pf_surface_release(&out);
    pf_weights_release(&w);
    pf_surface_release(&s);
    fixture_release(&fx);
    pf_mesh_release(&bar);
}

/* Progressive: the bar cut at x = 2.5, its surface cut; the cut mesh cut again at x = 3.5 and the
 * cut surface (with its caps) cut again. Three closed pieces, the volume unchanged; the first
 * cut's vertices (their side known only from their caps) still take no node across it: moving
 * everything right of x = 2.5 rigidly leaves every vertex left of it, caps included, still. */
static void test_progressive_cut(void **state)
{
    (void)state;
    pf_mesh bar = {0};
    make_bar(&bar, 5, 2, 1);
    cut_fixture first, second;
    make_real_cut(&first, &bar, 2.5, 10);
    pf_surface s = {0}, once = {0}, twice = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(4.7, 1.65, 0.8));
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(&first, &s, NULL, &once, &w, &st);
    pf_weights_release(&w);
    make_real_cut_ex(&second, &first.m, 3.5, 10, first.cut.cut_face, 2.5);
    run_cut(&second, &once, NULL, &twice, &w, &st);
    pf_surface_stats got = stats_of(&twice);
    CHECKF(got.closed && got.manifold,
           "cut surface: %lld boundary, %lld non-manifold, %lld flipped",
           (long long)got.n_boundary_edges, (long long)got.n_nonmanifold_edges,
           (long long)got.n_flipped_edges);
    assert_near(got.volume, stats_of(&s).volume, 1e-12 * stats_of(&s).volume);
    assert_int_equal(components(&twice), 3);
    assert_near(st.cap_area, 2 * 1.4 * 0.6, 1e-12);
    check_affine(&second.m, &twice, &w);
    uint8_t *moved = malloc((size_t)twice.n_verts);
    rigid_side_b(&second, &twice, &w, moved, true);
    check_triangle_sides(&twice, moved, 2.5);
    free(moved);
    pf_weights_release(&w);
    pf_surface_release(&s);
    pf_surface_release(&once);
    pf_surface_release(&twice);
    fixture_release(&first);
    fixture_release(&second);
    pf_mesh_release(&bar);
}

/* pf_mesh_cut of the elements with y < 1 only: the crack front runs along y = 1. */
static void test_real_partial_cut(void **state)
{
    (void)state;
    pf_mesh bar = {0};
    make_bar(&bar, 5, 2, 1);
    cut_fixture fx;
    make_real_cut(&fx, &bar, 2.5, 1.0);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.3, 0.25, 0.2), pf_v3(4.7, 1.65, 0.8));
    check_partial(&fx, &s, 1.0, 2 * 0.75 * 0.6);
    pf_surface_release(&s);
    fixture_release(&fx);
    pf_mesh_release(&bar);
}

/* A sliced sphere cut by pf_mesh_cut along x = 0.1, its surface (the mesh's boundary) cut with
 * it: the capped surface encloses the cut mesh, to 1e-12 relative. */
static void test_sliced_sphere(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    s.id = 9;
    pf_mesh sliced = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = 6;
    assert_int_equal(pf_mesh_slice(&sliced, &s, &sp, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&sliced, &err), PF_OK);
    cut_fixture fx;
    make_real_cut(&fx, &sliced, 0.1, 10);
    pf_surface out = {0};
    pf_weights w = {0};
    pf_surface_cut_stats st;
    run_cut(&fx, &s, NULL, &out, &w, &st);
    pf_surface_stats got = stats_of(&out);
    if (!got.closed)
        print_boundary(&out);
    CHECKF(got.closed && got.manifold,
           "cut surface: %lld boundary, %lld non-manifold, %lld flipped",
           (long long)got.n_boundary_edges, (long long)got.n_nonmanifold_edges,
           (long long)got.n_flipped_edges);
    double vol = pf_mesh_volume(&fx.m);
    assert_near(got.volume, vol, 1e-12 * vol);
    assert_int_equal(components(&out), 2);
    check_affine(&fx.m, &out, &w);
    uint8_t *moved = malloc((size_t)out.n_verts);
    rigid_side_b(&fx, &out, &w, moved, true);
    free(moved);
    pf_surface_release(&out);
    pf_weights_release(&w);
    fixture_release(&fx);
    pf_mesh_release(&sliced);
    pf_surface_release(&s);
}

/* A surface away from the cut: returned as it was (a new id, parts all the model's), weights
 * as pf_embed_compute gives them with the same blocking faces. */
static void test_surface_missing_cut(void **state)
{
    (void)state;
    cut_fixture fx;
    make_cut_bar(&fx, 4, 2, 1, 10);
    pf_surface s = {0};
    make_closed_box(&s, pf_v3(0.2, 0.3, 0.3), pf_v3(1.4, 1.6, 0.7));
    pf_surface out = {0};
    pf_weights w = {0}, ref = {0};
    pf_surface_cut_stats st;
    run_cut(&fx, &s, NULL, &out, &w, &st);
    assert_int_equal(out.n_verts, s.n_verts);
    assert_int_equal(out.n_tris, s.n_tris);
    assert_memory_equal(out.x, s.x, sizeof(double) * 3 * (size_t)s.n_verts);
    assert_memory_equal(out.tri, s.tri, sizeof(uint32_t) * 3 * (size_t)s.n_tris);
    for (int32_t t = 0; t < out.n_tris; ++t)
        assert_int_equal(out.tri_part[t], PF_SURFACE_MODEL);
    assert_int_equal(st.n_split_tris + st.n_duplicated + st.n_cap_tris, 0);
    pf_embed_params p = pf_embed_params_default();
    p.blocking_faces = fx.cut.cut_face;
    pf_error err = {0};
    assert_int_equal(pf_embed_compute(&fx.m, &out, &p, &ref, NULL, &err), PF_OK);
    assert_int_equal(ref.row_offsets[ref.rows], w.row_offsets[w.rows]);
    assert_memory_equal(ref.col, w.col, sizeof(uint32_t) * (size_t)w.row_offsets[w.rows]);
    assert_memory_equal(ref.val, w.val, sizeof(double) * (size_t)w.row_offsets[w.rows]);
    pf_weights_release(&ref);
    pf_surface_release(&out);
    pf_weights_release(&w);
    pf_surface_release(&s);
    fixture_release(&fx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_cut_through),     cmocka_unit_test(test_sphere_poles_on_cut),
        cmocka_unit_test(test_sphere_edges_on_cut), cmocka_unit_test(test_boundary_surface),
        cmocka_unit_test(test_partial_cut),         cmocka_unit_test(test_surface_missing_cut),
        cmocka_unit_test(test_real_cut_through),    cmocka_unit_test(test_real_cut_tets),
        cmocka_unit_test(test_progressive_cut),     cmocka_unit_test(test_real_partial_cut),
        cmocka_unit_test(test_sliced_sphere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
