/* The cells of the basis tests (test_basis.c, test_basis_face.c): one-element meshes of closed
 * polyhedra (cube, octree cell, corner-cut cube, L-shape from merged cubes) and a coarsely sliced
 * sphere. */
#ifndef PF_TEST_BASIS_MESHES_H
#define PF_TEST_BASIS_MESHES_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include <pf/mesh.h>
#include <pf/split.h>

/* A one-element mesh from a closed polyhedron given with outward faces. */
static inline void mesh_from_poly(pf_mesh *m, const double *x, int32_t nn, const int64_t *off,
                                  const uint32_t *fn, int32_t nf)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_alloc(m, nn, nf, off[nf], 1, nf, &err), PF_OK);
    memcpy(m->x, x, 3 * (size_t)nn * sizeof *x);
    memcpy(m->face_offsets, off, ((size_t)nf + 1) * sizeof *off);
    memcpy(m->face_nodes, fn, (size_t)off[nf] * sizeof *fn);
    for (int32_t f = 0; f < nf; ++f)
        m->elem_faces[f] = (uint32_t)f;
    m->elem_offsets[1] = nf;
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

static const uint32_t CUBE_FACES[24] = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4,
                                        1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};
static const int64_t CUBE_OFF[7] = {0, 4, 8, 12, 16, 20, 24};

static inline void cube_nodes(double *x, pf_vec3 lo, double h)
{
    for (int v = 0; v < 8; ++v) {
        int i = (v == 1 || v == 2 || v == 5 || v == 6), j = (v == 2 || v == 3 || v == 6 || v == 7);
        x[3 * v] = lo.x + i * h, x[3 * v + 1] = lo.y + j * h, x[3 * v + 2] = lo.z + (v >= 4) * h;
    }
}

/* Cube [0, 2]^3 whose top face is split into four quads (an octree neighbour of depth + 1):
 * the side faces get the top edges' midpoints as fifth nodes. */
static inline void make_octree_cell(pf_mesh *m)
{
    double x[13 * 3];
    cube_nodes(x, pf_v3(0, 0, 0), 2);
    const double mids[5][3] = {{1, 0, 2}, {2, 1, 2}, {1, 2, 2}, {0, 1, 2}, {1, 1, 2}};
    memcpy(x + 24, mids, sizeof mids);
    const uint32_t fn[] = {0, 3, 2,  1, 0, 1, 5,  8,  4, 1, 2, 6,  9,  5, 2, 3,  7,  10, 6,  3,
                           0, 4, 11, 7, 4, 8, 12, 11, 8, 5, 9, 12, 12, 9, 6, 10, 11, 12, 10, 7};
    const int64_t off[] = {0, 4, 9, 14, 19, 24, 28, 32, 36, 40};
    mesh_from_poly(m, x, 13, off, fn, 9);
}

/* The unit cube with the corner (1, 1, 1) cut off by the plane x + y + z = 2.4 (pf_poly_split). */
static inline void make_corner_cut(pf_mesh *m)
{
    double x[24];
    cube_nodes(x, pf_v3(0, 0, 0), 1);
    pf_polyhedron p = {x, 6, CUBE_OFF, CUBE_FACES};
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0.8, 0.8, 0.8), pf_v3(1, 1, 1));
    pf_split sp = {0};
    pf_error err = {0};
    assert_int_equal(pf_poly_split(&p, 8, &pl, NULL, &sp, &err), PF_OK);
    assert_int_equal(sp.n_pieces, 2);
    int32_t k = sp.piece_side[0] < 0 ? 0 : 1; /* the piece below keeps seven corners */
    int64_t f0 = sp.piece_faces[k], f1 = sp.piece_faces[k + 1];
    int64_t off[32];
    uint32_t fn[256];
    int32_t nf = 0;
    off[0] = 0;
    for (int64_t f = f0; f < f1; ++f) {
        int64_t len = sp.face_offsets[f + 1] - sp.face_offsets[f];
        memcpy(fn + off[nf], sp.face_nodes + sp.face_offsets[f], (size_t)len * sizeof *fn);
        off[nf + 1] = off[nf] + len;
        ++nf;
    }
    /* Node 6 (the cut corner) is referenced by no face: drop it, renumbering above it. */
    double xs[3 * 16];
    int32_t nn = 0, map[16];
    for (int32_t v = 0; v < sp.n_nodes; ++v) {
        bool used = false;
        for (int64_t q = 0; q < off[nf]; ++q)
            used |= fn[q] == (uint32_t)v;
        map[v] = used ? nn : -1;
        if (used)
            memcpy(xs + 3 * nn++, sp.x + 3 * v, 3 * sizeof *xs);
    }
    for (int64_t q = 0; q < off[nf]; ++q)
        fn[q] = (uint32_t)map[fn[q]];
    mesh_from_poly(m, xs, nn, off, fn, nf);
    pf_split_release(&sp);
}

/* Elements of src merged by group: faces between two elements of a group disappear. */
static inline void merge_cells(const pf_mesh *src, const int32_t *group, int32_t n_groups,
                               pf_mesh *m)
{
    pf_error err = {0};
    int32_t nf = 0, map[256];
    int64_t nfn = 0, nef = 0;
    for (int32_t f = 0; f < src->n_faces; ++f) {
        int32_t a = src->face_elems[2 * f], b = src->face_elems[2 * f + 1];
        bool inner = a >= 0 && b >= 0 && group[a] == group[b];
        map[f] = inner ? -1 : nf++;
        if (!inner) {
            nfn += src->face_offsets[f + 1] - src->face_offsets[f];
            nef += (a >= 0) + (b >= 0);
        }
    }
    assert_int_equal(pf_mesh_alloc(m, src->n_nodes, nf, nfn, n_groups, nef, &err), PF_OK);
    memcpy(m->x, src->x, 3 * (size_t)src->n_nodes * sizeof *m->x);
    for (int32_t f = 0; f < src->n_faces; ++f)
        if (map[f] >= 0) {
            int64_t len = src->face_offsets[f + 1] - src->face_offsets[f];
            memcpy(m->face_nodes + m->face_offsets[map[f]], src->face_nodes + src->face_offsets[f],
                   (size_t)len * sizeof *m->face_nodes);
            m->face_offsets[map[f] + 1] = m->face_offsets[map[f]] + len;
        }
    int64_t at = 0;
    for (int32_t g = 0; g < n_groups; ++g) {
        for (int32_t e = 0; e < src->n_elems; ++e)
            if (group[e] == g)
                for (int64_t q = src->elem_offsets[e]; q < src->elem_offsets[e + 1]; ++q) {
                    int32_t f = PF_FACE_INDEX(src->elem_faces[q]);
                    if (map[f] >= 0)
                        m->elem_faces[at++] =
                            (uint32_t)map[f] | (src->elem_faces[q] & PF_FACE_REVERSED);
                }
        m->elem_offsets[g + 1] = at;
    }
    assert_int_equal(pf_mesh_validate(m, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* A 2 x 2 x 1 block of unit cubes: cells 0, 1, 2 merged into an L (element 0), cell 3 alone
 * (element 1, a closed-form hex). */
static inline void make_l_mesh(pf_mesh *m)
{
    pf_error err = {0};
    pf_mesh box = {0};
    assert_int_equal(pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(2, 2, 1), 2, 2, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&box, &err), PF_OK);
    /* Cell order of the box: x fastest; cell 3 is (1, 1). */
    int32_t group[4] = {0, 0, 0, 1};
    merge_cells(&box, group, 2, m);
    pf_mesh_release(&box);
}

/* The unit sphere of 8 x 16 facets sliced by a grid of res cells across. */
static inline void make_sphere_mesh_res(pf_mesh *m, int32_t res)
{
    pf_error err = {0};
    pf_surface s = {0};
    assert_int_equal(pf_surface_make_sphere(&s, 1, 8, 16, &err), PF_OK);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    assert_int_equal(pf_mesh_slice(m, &s, &p, NULL, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
    pf_surface_release(&s);
}

static inline void make_sphere_mesh(pf_mesh *m)
{
    make_sphere_mesh_res(m, 3);
}

#endif
