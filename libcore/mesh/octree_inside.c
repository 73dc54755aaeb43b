/* Whole octree leaves inside or outside the surface, by their centres (pf_mesh_octree without
 * slice): ray crossings or the winding number (octree_internal.h). */
#include "octree_internal.h"

#include <math.h>
#include <stdlib.h>

typedef struct sort_key {
    uint64_t key;
    int32_t leaf;
} sort_key;

static int compare_key(const void *pa, const void *pb)
{
    const sort_key *a = pa, *b = pb;
    return (a->key > b->key) - (a->key < b->key);
}

/* Centre of leaf l along axis a in half lattice units (2 c + size). */
static int32_t half_centre(const octree *oc, const leaf *l, int a)
{
    return 2 * l->c[a] + cell_size(oc, l->level);
}

static double centre_coord(const octree *oc, const leaf *l, int a)
{
    return oc->o[a] + half_centre(oc, l, a) * (0.5 * oc->h);
}

/* One ray per row of leaves along each axis (leaves sorted by their two other centre coordinates
 * and then along the axis), from a cell before the lattice. */
pf_status pf_octree_classify_by_rays(octree *oc, pf_error *err)
{
    int32_t nl = oc->n_leaves;
    ray_voter rv;
    PF_TRY(pf_ray_voter_create(&rv, oc->s, 1e-7 * oc->h, err));
    sort_key *keys = pf_alloc_array((size_t)nl, sizeof *keys);
    uint8_t *votes = pf_calloc((size_t)nl, 1);
    pf_status st = PF_OK;
    if (!keys || !votes)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for centres");
    for (int a = 0; a < 3 && st >= 0; ++a) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int32_t q = 0; q < nl; ++q) {
            const leaf *l = &oc->leaves[q];
            keys[q] = (sort_key){(uint64_t)half_centre(oc, l, b) << 40 |
                                     (uint64_t)half_centre(oc, l, c) << 20 |
                                     (uint64_t)half_centre(oc, l, a),
                                 q};
        }
        qsort(keys, (size_t)nl, sizeof *keys, compare_key);
        pf_vec3 dir = pf_v3(a == 0, a == 1, a == 2);
        double start = oc->o[a] - oc->h, span = (oc->n + 2) * oc->h;
        for (int32_t r0 = 0, r1; st >= 0 && r0 < nl; r0 = r1) {
            for (r1 = r0 + 1; r1 < nl && keys[r1].key >> 20 == keys[r0].key >> 20; ++r1)
                ;
            const leaf *first = &oc->leaves[keys[r0].leaf];
            double org[3];
            org[a] = start;
            org[b] = centre_coord(oc, first, b);
            org[c] = centre_coord(oc, first, c);
            st = pf_ray_voter_cast(&rv, pf_v3_load(org), dir, span, err);
            for (int32_t q = r0; st >= 0 && q < r1; ++q) {
                double t = centre_coord(oc, &oc->leaves[keys[q].leaf], a) - start;
                votes[keys[q].leaf] += pf_ray_voter_inside_at(&rv, t);
            }
        }
    }
    for (int32_t q = 0; st >= 0 && q < nl; ++q)
        oc->leaves[q].inside = votes[q] >= RAY_VOTES_INSIDE;
    pf_free(keys), pf_free(votes);
    pf_ray_voter_release(&rv);
    return st;
}

void pf_octree_classify_by_winding(octree *oc)
{
    for (int32_t q = 0; q < oc->n_leaves; ++q) {
        leaf *l = &oc->leaves[q];
        pf_vec3 p = pf_v3(centre_coord(oc, l, 0), centre_coord(oc, l, 1), centre_coord(oc, l, 2));
        /* orientation-agnostic, as pf_surface_classify_cells */
        l->inside = fabs(pf_winding_number(oc->s->x, oc->s->tri, oc->s->n_tris, p)) >= 0.5;
    }
}
