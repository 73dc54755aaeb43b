/* The bodies of a cut mesh for the tests: groups of elements joined by shared faces, and the body
 * of each node. */
#ifndef PF_TEST_BODIES_H
#define PF_TEST_BODIES_H

#include <stdint.h>

#include <pf/mesh.h>

/* The root of i in a union-find forest parent[], halving the paths it walks. */
static inline int32_t root_of(int32_t *parent, int32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

/* body[e]: the root element of e's group through shared faces (m derived). */
static inline void element_bodies(const pf_mesh *m, int32_t *body)
{
    for (int32_t e = 0; e < m->n_elems; ++e)
        body[e] = e;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (m->face_elems[2 * f] >= 0 && m->face_elems[2 * f + 1] >= 0)
            body[root_of(body, m->face_elems[2 * f])] = root_of(body, m->face_elems[2 * f + 1]);
    for (int32_t e = 0; e < m->n_elems; ++e)
        body[e] = root_of(body, e);
}

/* body[i]: the body of the elements using node i, -2 when they are in two bodies, -1 when none
 * uses it (m derived, elem_body from element_bodies). */
static inline void node_bodies(const pf_mesh *m, const int32_t *elem_body, int32_t *body)
{
    for (int32_t i = 0; i < m->n_nodes; ++i)
        body[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k) {
                uint32_t n = m->face_nodes[k];
                body[n] = body[n] == -1 || body[n] == elem_body[e] ? elem_body[e] : -2;
            }
        }
}

#endif
