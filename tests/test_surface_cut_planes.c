/* surface_cut under several whole planes, as pf-cut --plane applies them: every element a plane
 * crosses or touches and their neighbours are requested (the sliver rule may leave an element
 * whole on one side, the crack then follows its faces), the cut faces carried from cut to cut,
 * and the embedded surface cut after each plane.
 *
 * Two ways, both checked: the surface cut by the latest plane's faces after each plane, as
 * pf-cut --plane does ("in turn"), and the uncut surface cut by every face opened so far in one
 * call, as the simulator does after each change ("at once").
 *
 * Models: a sliced sphere (its own boundary as the render surface) and the bunny
 * (data/models/bunny.obj) sliced coarsely. Planes: random (a fixed generator and seeds), through
 * the middle half of the model's box, any direction.
 * Oracle: topology. A closed input cut by planes and capped stays closed and edge-manifold:
 * every edge used by exactly two triangles, consistently oriented. The counts of open
 * (boundary) and non-manifold edges after 1, 2 and 3 planes are printed per seed; they must be
 * zero for the seeds listed as closing (the others are printed so that progress shows). When a
 * cut surface is closed, its enclosed volume equals the cut mesh's: the render surface is the
 * mesh's boundary (slicing makes exact polyhedra at the surface), so to round-off (1e-9
 * relative: sums over ~10^4 triangles and polyhedra) plus the volume of pieces the cut
 * reports dropped. Whatever the topology, no vertex moves with two bodies: every node a vertex's
 * weights name lies in one body (the cut duplicates nodes, so each lies in one). */
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

#include "test_bodies.h"
#include "test_check.h"
#include <pf/cut.h>
#include <pf/embed.h>
#include <pf/io.h>
#include <pf/mesh.h>

#define MAX_PLANES 3

typedef struct model {
    pf_surface surf;
    pf_mesh mesh;
} model;

enum { IN_TURN, AT_ONCE, N_WAYS };
static const char *const way_name[N_WAYS] = {"in turn", "at once"};

typedef struct cut_count {
    int64_t open, nonmanifold; /* -1: the cut failed */
    double vol_err;            /* |surface volume - mesh volume - dropped| / mesh volume */
    int32_t two_bodies;        /* vertices weighted on nodes of two bodies */
} cut_count;

static uint64_t next_random(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

static double uniform(uint64_t *s)
{
    return (double)(next_random(s) >> 11) * (1.0 / 9007199254740992.0);
}

static pf_plane random_plane(uint64_t *s, pf_vec3 lo, pf_vec3 hi)
{
    pf_vec3 c = pf_v3_scale(pf_v3_add(lo, hi), 0.5), d = pf_v3_sub(hi, lo);
    pf_vec3 p = pf_v3(c.x + (uniform(s) - 0.5) * 0.5 * d.x, c.y + (uniform(s) - 0.5) * 0.5 * d.y,
                      c.z + (uniform(s) - 0.5) * 0.5 * d.z);
    pf_vec3 n;
    do
        n = pf_v3(2 * uniform(s) - 1, 2 * uniform(s) - 1, 2 * uniform(s) - 1);
    while (pf_v3_norm(n) > 1 || pf_v3_norm(n) < 0.1);
    return pf_plane_from_point_normal(p, n);
}

static void slice_model(model *md, int32_t res)
{
    pf_error err = {0};
    pf_slice_params sp = pf_slice_params_default();
    sp.grid.res = res;
    CHECKF(pf_mesh_slice(&md->mesh, &md->surf, &sp, NULL, &err) == PF_OK, "slice: %s", err.msg);
    CHECKF(pf_mesh_derive(&md->mesh, &err) == PF_OK, "derive: %s", err.msg);
}

static void make_sphere(model *md)
{
    pf_error err = {0};
    memset(md, 0, sizeof *md);
    assert_int_equal(pf_surface_make_sphere(&md->surf, 1, 12, 24, &err), PF_OK);
    md->surf.id = 9;
    slice_model(md, 8);
}

static bool make_bunny(model *md)
{
    pf_error err = {0};
    memset(md, 0, sizeof *md);
    if (pf_import_surface(PF_TEST_DATA_DIR "/../../data/models/bunny.obj", &md->surf, &err) !=
        PF_OK)
        return false;
    md->surf.id = 9;
    slice_model(md, 8);
    return true;
}

static void model_release(model *md)
{
    pf_surface_release(&md->surf);
    pf_mesh_release(&md->mesh);
}

static double mesh_volume(const pf_mesh *m)
{
    double v = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        v += pf_mesh_elem_volume(m, e);
    return v;
}

/* The vertices of w whose weights name nodes of two bodies of m (or a node of two bodies). */
static int32_t vertices_on_two_bodies(const pf_mesh *m, const pf_weights *w)
{
    int32_t *elem_body = malloc(sizeof *elem_body * ((size_t)m->n_elems + 1));
    int32_t *node_body = malloc(sizeof *node_body * ((size_t)m->n_nodes + 1));
    element_bodies(m, elem_body);
    node_bodies(m, elem_body, node_body);
    int32_t count = 0;
    for (int32_t v = 0; v < w->rows; ++v) {
        bool two = false;
        for (int64_t q = w->row_offsets[v]; q < w->row_offsets[v + 1]; ++q)
            two |= w->val[q] != 0 && (node_body[w->col[q]] < 0 ||
                                      node_body[w->col[q]] != node_body[w->col[w->row_offsets[v]]]);
        count += two;
    }
    free(elem_body), free(node_body);
    return count;
}

/* The surface of a cut: counts of what *s is after the cut of m whose result is res. */
static pf_status surface_cut_count(const pf_surface *s, const pf_mesh *m, const pf_cut_result *res,
                                   double dropped, pf_surface *out, cut_count *got, pf_error *err)
{
    pf_weights cw = {0};
    pf_surface_cut_stats cs;
    pf_status st = pf_surface_cut(s, m, res, NULL, out, &cw, &cs, err);
    if (st < 0)
        return st;
    pf_surface_stats ss;
    st = pf_surface_compute_stats(out, &ss, err);
    double vol = mesh_volume(m);
    *got = (cut_count){ss.n_boundary_edges, ss.n_nonmanifold_edges + ss.n_flipped_edges,
                       fabs(ss.volume - vol - dropped) / vol, vertices_on_two_bodies(m, &cw)};
    pf_weights_release(&cw);
    return st;
}

/* One plane through the whole mesh as pf-cut applies it; m, s[IN_TURN] and *cut_face replaced,
 * s[AT_ONCE] the uncut surface; got[] the counts of both ways. */
static pf_status cut_plane(pf_mesh *m, pf_surface *s, uint8_t **cut_face, pf_plane pl,
                           double *dropped, cut_count *got, pf_error *err)
{
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    double tol = 1e-9 * pf_v3_norm(pf_v3_sub(hi, lo));
    pf_cut_request *req = malloc(sizeof *req * ((size_t)m->n_elems + 1));
    uint8_t *touch = calloc((size_t)m->n_elems + 1, 1);
    for (int32_t e = 0; e < m->n_elems; ++e) {
        double dlo = INFINITY, dhi = -INFINITY;
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t i = m->face_offsets[f]; i < m->face_offsets[f + 1]; ++i) {
                double d =
                    pf_plane_signed_distance(pl, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[i]));
                dlo = fmin(dlo, d), dhi = fmax(dhi, d);
            }
        }
        touch[e] = dlo <= tol && dhi >= -tol;
    }
    int32_t n = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        bool near = touch[e];
        for (int64_t q = m->elem_offsets[e]; !near && q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
            near = (a >= 0 && touch[a]) || (b >= 0 && touch[b]);
        }
        if (near)
            req[n++] = (pf_cut_request){e, pl};
    }
    free(touch);
    pf_cut_params p = {.src_cut_face = *cut_face};
    pf_mesh out = {0};
    pf_cut_result res = {0};
    pf_status st = pf_mesh_cut(m, req, n, &p, &out, &res, err);
    free(req);
    if (st < 0)
        return st;
    *dropped += res.dropped_volume;
    pf_surface turn = {0}, once = {0};
    pf_cut_result all = res;
    all.opened = res.cut_face;
    st = surface_cut_count(&s[IN_TURN], &out, &res, *dropped, &turn, &got[IN_TURN], err);
    if (st >= 0)
        st = surface_cut_count(&s[AT_ONCE], &out, &all, *dropped, &once, &got[AT_ONCE], err);
    pf_surface_release(&once);
    pf_free(*cut_face);
    *cut_face = res.cut_face;
    res.cut_face = NULL;
    pf_cut_result_release(&res);
    pf_mesh_release(m);
    *m = out;
    if (st >= 0) {
        pf_surface_release(&s[IN_TURN]);
        s[IN_TURN] = turn;
    } else {
        pf_surface_release(&turn);
    }
    return st;
}

/* The model cut by n_planes random planes of seed; counts after plane k in got[k][way]. */
static void cut_seed(const model *md, uint64_t seed, int n_planes, cut_count (*got)[N_WAYS])
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_surface s[N_WAYS] = {{0}};
    assert_int_equal(pf_mesh_copy(&m, &md->mesh, &err), PF_OK);
    for (int w = 0; w < N_WAYS; ++w) {
        assert_int_equal(pf_surface_alloc(&s[w], md->surf.n_verts, md->surf.n_tris, &err), PF_OK);
        memcpy(s[w].x, md->surf.x, 3 * (size_t)s[w].n_verts * sizeof *s[w].x);
        memcpy(s[w].tri, md->surf.tri, 3 * (size_t)s[w].n_tris * sizeof *s[w].tri);
        s[w].id = md->surf.id;
    }
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    uint64_t rs = 0x9e3779b97f4a7c15ull * (seed + 1);
    uint8_t *cut_face = NULL;
    double dropped = 0;
    bool failed = false;
    for (int k = 0; k < n_planes; ++k) {
        pf_plane pl = random_plane(&rs, lo, hi);
        for (int w = 0; w < N_WAYS; ++w)
            got[k][w] = (cut_count){-1, -1, INFINITY, 0};
        if (failed || cut_plane(&m, s, &cut_face, pl, &dropped, got[k], &err) < 0) {
            if (!failed)
                print_message("seed %d plane %d: %s\n", (int)seed, k + 1, err.msg);
            failed = true;
        }
    }
    pf_free(cut_face);
    pf_mesh_release(&m);
    for (int w = 0; w < N_WAYS; ++w)
        pf_surface_release(&s[w]);
}

/* Cuts every seed with 1 .. MAX_PLANES planes, prints the counts of both ways; every seed has no
 * open edge after open_planes planes; must[way][seed] planes close every seed (0: none asserted
 * yet). */
static void run_seeds(const char *name, const model *md, int n_seeds, const int *const must[N_WAYS],
                      int open_planes)
{
    int closed[N_WAYS][MAX_PLANES] = {{0}};
    bool fail = false;
    for (int seed = 0; seed < n_seeds; ++seed) {
        cut_count got[MAX_PLANES][N_WAYS];
        cut_seed(md, (uint64_t)seed, MAX_PLANES, got);
        for (int w = 0; w < N_WAYS; ++w) {
            print_message("%s seed %2d %s: open/non-manifold after 1, 2, 3 planes:", name, seed,
                          way_name[w]);
            for (int k = 0; k < MAX_PLANES; ++k) {
                const cut_count *c = &got[k][w];
                print_message(" %4lld/%lld", (long long)c->open, (long long)c->nonmanifold);
                CHECKF(c->two_bodies == 0, "%s seed %d plane %d %s: %d vertices on two bodies",
                       name, seed, k + 1, way_name[w], (int)c->two_bodies);
                if (c->open == 0 && c->nonmanifold == 0) {
                    closed[w][k]++;
                    CHECKF(c->vol_err <= 1e-9, "%s seed %d plane %d %s: closed, volume off by %.3g",
                           name, seed, k + 1, way_name[w], c->vol_err);
                }
            }
            print_message("\n");
            for (int k = 0; k < open_planes; ++k)
                if (got[k][w].open != 0) {
                    print_error("%s seed %d %s: open after %d planes\n", name, seed, way_name[w],
                                k + 1);
                    fail = true;
                }
            for (int k = 0; k < must[w][seed]; ++k)
                if (got[k][w].open != 0 || got[k][w].nonmanifold != 0) {
                    print_error("%s seed %d %s: not closed after %d planes\n", name, seed,
                                way_name[w], k + 1);
                    fail = true;
                }
        }
    }
    for (int w = 0; w < N_WAYS; ++w)
        print_message("%s %s: closed after 1, 2, 3 planes: %d, %d, %d of %d seeds\n", name,
                      way_name[w], closed[w][0], closed[w][1], closed[w][2], n_seeds);
    assert_false(fail);
}

static void test_sphere_planes(void **state)
{
    (void)state;
    model md;
    make_sphere(&md);
    static const int turn[24] = {3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3,
                                 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3};
    static const int once[24] = {3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3,
                                 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3};
    run_seeds("sphere", &md, 24, (const int *const[N_WAYS]){turn, once}, 1);
    model_release(&md);
}

static void test_bunny_planes(void **state)
{
    (void)state;
    model md;
    if (!make_bunny(&md))
        skip();
    static const int turn[12] = {3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3};
    static const int once[12] = {3, 3, 2, 3, 3, 3, 3, 3, 3, 3, 3, 3};
    run_seeds("bunny", &md, 12, (const int *const[N_WAYS]){turn, once}, 1);
    model_release(&md);
}

/* The sphere's surface with the vertices its triangles above y = 0 share with those below given
 * copies of their own: open edges along the seam, but closed by position. */
static void seam_surface(const pf_surface *in, pf_surface *out)
{
    pf_error err = {0};
    assert_int_equal(pf_surface_alloc(out, 2 * in->n_verts, in->n_tris, &err), PF_OK);
    memcpy(out->x, in->x, 3 * (size_t)in->n_verts * sizeof *out->x);
    memcpy(out->x + 3 * (size_t)in->n_verts, in->x, 3 * (size_t)in->n_verts * sizeof *out->x);
    for (int32_t t = 0; t < in->n_tris; ++t) {
        const uint32_t *v = in->tri + 3 * (size_t)t;
        double y = (in->x[3 * (size_t)v[0] + 1] + in->x[3 * (size_t)v[1] + 1] +
                    in->x[3 * (size_t)v[2] + 1]) / 3;
        for (int q = 0; q < 3; ++q)
            out->tri[3 * (size_t)t + q] = v[q] + (y > 0 ? (uint32_t)in->n_verts : 0);
    }
    out->id = in->id;
}

static double cap_area(const pf_surface *s)
{
    double a = 0;
    for (int32_t t = 0; s->tri_part && t < s->n_tris; ++t) {
        if (s->tri_part[t] != PF_SURFACE_CAP)
            continue;
        const uint32_t *v = s->tri + 3 * (size_t)t;
        pf_vec3 x0 = pf_v3_load(s->x + 3 * (size_t)v[0]);
        a += 0.5 * pf_v3_norm(pf_v3_cross(pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[1]), x0),
                                          pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)v[2]), x0)));
    }
    return a;
}

/* A surface whose vertex copies do not join up (as an earlier cut may leave it) but that is
 * closed by position bounds the solid all the same: a plane across its seam caps it as it caps
 * the intact surface (the same cap area, to round-off), and the cut surface encloses the cut
 * mesh's volume (1e-9, as above). */
static void test_seam_closed_by_position(void **state)
{
    (void)state;
    model md;
    make_sphere(&md);
    pf_error err = {0};
    pf_surface seam = {0};
    seam_surface(&md.surf, &seam);
    pf_surface_stats ss;
    assert_int_equal(pf_surface_compute_stats(&seam, &ss, &err), PF_OK);
    assert_true(ss.n_boundary_edges > 0);
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0.1, 0.05, -0.07), pf_v3(0.3, 0.8, 0.5));
    double area[2], vol_err = 0;
    for (int k = 0; k < 2; ++k) {
        pf_mesh m = {0};
        pf_surface s = {0};
        const pf_surface *src = k ? &seam : &md.surf;
        assert_int_equal(pf_mesh_copy(&m, &md.mesh, &err), PF_OK);
        assert_int_equal(pf_surface_alloc(&s, src->n_verts, src->n_tris, &err), PF_OK);
        memcpy(s.x, src->x, 3 * (size_t)s.n_verts * sizeof *s.x);
        memcpy(s.tri, src->tri, 3 * (size_t)s.n_tris * sizeof *s.tri);
        s.id = src->id;
        uint8_t *cut_face = NULL;
        double dropped = 0;
        pf_surface both[N_WAYS] = {s, s};
        cut_count got[N_WAYS];
        CHECKF(cut_plane(&m, both, &cut_face, pl, &dropped, got, &err) >= 0, "cut: %s",
               err.msg);
        s = both[IN_TURN];
        assert_int_equal(got[IN_TURN].two_bodies, 0);
        area[k] = cap_area(&s);
        assert_int_equal(pf_surface_compute_stats(&s, &ss, &err), PF_OK);
        double vol = mesh_volume(&m);
        vol_err = fmax(vol_err, fabs(ss.volume - vol - dropped) / vol);
        pf_free(cut_face);
        pf_mesh_release(&m);
        pf_surface_release(&s);
    }
    print_message("cap area intact %.15g, seamed %.15g; volume off by %.3g\n", area[0], area[1],
                  vol_err);
    assert_true(area[0] > 0);
    assert_near(area[1], area[0], 1e-12 * area[0]);
    CHECKF(vol_err <= 1e-9, "volume off by %.3g", vol_err);
    pf_surface_release(&seam);
    model_release(&md);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_planes),
        cmocka_unit_test(test_bunny_planes),
        cmocka_unit_test(test_seam_closed_by_position),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
