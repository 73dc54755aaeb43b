/* Shared by the cutting tests (test_cut.c, test_sim_cut.c, test_crack_contact.c): the elements a
 * plane meets, as cut requests. Include after <cmocka.h> and <math.h>. */
#ifndef PF_TEST_CUT_REQUESTS_H
#define PF_TEST_CUT_REQUESTS_H

#include <pf/cut.h>
#include <pf/mesh.h>

/* The smallest and largest signed distance of element e's nodes to the plane. */
static inline void plane_range(const pf_mesh *m, int32_t e, pf_plane pl, double *lo, double *hi)
{
    *lo = INFINITY, *hi = -INFINITY;
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            double d =
                pf_plane_signed_distance(pl, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j]));
            *lo = fmin(*lo, d), *hi = fmax(*hi, d);
        }
    }
}

/* Requests pl on every element of m whose nodes lie on both sides of it by more than -tol (tol
 * > 0: also the elements it touches); returns their count. */
static inline int32_t requests_meeting(const pf_mesh *m, pf_plane pl, double tol,
                                       pf_cut_request *req)
{
    int32_t k = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        double lo, hi;
        plane_range(m, e, pl, &lo, &hi);
        if (lo < tol && hi > -tol)
            req[k++] = (pf_cut_request){.elem = e, .plane = pl};
    }
    return k;
}

#endif
