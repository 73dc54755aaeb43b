/* Meshes for the refinement and coarsening tests (include after <cmocka.h>, <string.h> and
 * <pf/mesh.h>): prisms over polygons, convex or not. */
#ifndef PF_TEST_PRISM_H
#define PF_TEST_PRISM_H

/* One element: the prism z in [0, 1] over the counter-clockwise polygon xy[n]. */
static inline pf_mesh make_prism(const double *xy, int n)
{
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_mesh_alloc(&m, 2 * n, n + 2, 6 * (int64_t)n, 1, n + 2, &err), PF_OK);
    for (int i = 0; i < n; ++i)
        for (int z = 0; z < 2; ++z) {
            m.x[3 * (i + z * n)] = xy[2 * i];
            m.x[3 * (i + z * n) + 1] = xy[2 * i + 1];
            m.x[3 * (i + z * n) + 2] = z;
        }
    int64_t k = 0;
    for (int i = 0; i < n; ++i) /* bottom, seen from below */
        m.face_nodes[k++] = (uint32_t)(n - 1 - i);
    m.face_offsets[1] = k;
    for (int i = 0; i < n; ++i)
        m.face_nodes[k++] = (uint32_t)(n + i);
    m.face_offsets[2] = k;
    for (int i = 0; i < n; ++i) {
        uint32_t a = (uint32_t)i, b = (uint32_t)((i + 1) % n);
        uint32_t q[4] = {a, b, b + (uint32_t)n, a + (uint32_t)n};
        memcpy(m.face_nodes + k, q, sizeof q);
        k += 4;
        m.face_offsets[3 + i] = k;
    }
    for (int f = 0; f < n + 2; ++f)
        m.elem_faces[f] = (uint32_t)f;
    m.elem_offsets[1] = n + 2;
    return m;
}

#endif
