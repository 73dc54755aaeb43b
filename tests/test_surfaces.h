/* Surfaces the meshing tests build by hand: boxes, several bodies in one surface, translated
 * copies. Include after cmocka.h (failures are cmocka assertions). */
#ifndef PF_TEST_SURFACES_H
#define PF_TEST_SURFACES_H

#include <string.h>

#include <pf/mesh.h>

/* A closed box surface [lo, hi], triangles outward. */
static inline void add_box(pf_surface *s, pf_vec3 lo, pf_vec3 hi)
{
    static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                    {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    pf_error err = {0};
    pf_surface old = *s;
    pf_surface grown = {0};
    assert_int_equal(pf_surface_alloc(&grown, old.n_verts + 8, old.n_tris + 12, &err), PF_OK);
    if (old.n_verts) {
        memcpy(grown.x, old.x, 3 * (size_t)old.n_verts * sizeof *grown.x);
        memcpy(grown.tri, old.tri, 3 * (size_t)old.n_tris * sizeof *grown.tri);
    }
    for (int v = 0; v < 8; ++v) {
        double *x = grown.x + 3 * (size_t)(old.n_verts + v);
        x[0] = v & 1 ? hi.x : lo.x;
        x[1] = v & 2 ? hi.y : lo.y;
        x[2] = v & 4 ? hi.z : lo.z;
    }
    for (int q = 0; q < 6; ++q) {
        uint32_t *t = grown.tri + 3 * (size_t)(old.n_tris + 2 * q);
        uint32_t b = (uint32_t)old.n_verts;
        const int *c = quads[q];
        t[0] = b + c[0], t[1] = b + c[1], t[2] = b + c[2];
        t[3] = b + c[0], t[4] = b + c[2], t[5] = b + c[3];
    }
    pf_surface_release(s);
    *s = grown;
}

/* Appends b's triangles to a (two separate bodies). */
static inline void append(pf_surface *a, const pf_surface *b)
{
    pf_error err = {0};
    pf_surface g = {0};
    assert_int_equal(pf_surface_alloc(&g, a->n_verts + b->n_verts, a->n_tris + b->n_tris, &err),
                     PF_OK);
    memcpy(g.x, a->x, 3 * (size_t)a->n_verts * sizeof *g.x);
    memcpy(g.x + 3 * (size_t)a->n_verts, b->x, 3 * (size_t)b->n_verts * sizeof *g.x);
    memcpy(g.tri, a->tri, 3 * (size_t)a->n_tris * sizeof *g.tri);
    for (int64_t k = 0; k < 3 * (int64_t)b->n_tris; ++k)
        g.tri[3 * (size_t)a->n_tris + k] = b->tri[k] + (uint32_t)a->n_verts;
    pf_surface_release(a);
    *a = g;
}

static inline void translate(pf_surface *s, pf_vec3 d)
{
    for (int32_t i = 0; i < s->n_verts; ++i) {
        s->x[3 * i] += d.x;
        s->x[3 * i + 1] += d.y;
        s->x[3 * i + 2] += d.z;
    }
}

#endif
