/* The ray-vote inside test of the voxelizer and of the octree's whole leaves: three axis-parallel
 * rays per point, each giving the winding number there as minus the sum of the signs of the
 * crossings before it (entering is -1); a point is inside when at least two rays say so, which
 * survives a ray grazing an edge or slipping through a crack of an almost closed surface. */
#include "mesh_internal.h"

pf_status pf_ray_voter_create(ray_voter *v, const pf_surface *s, double merge_eps, pf_error *err)
{
    *v = (ray_voter){.merge_eps = merge_eps, .cap = 256};
    PF_TRY(pf_rayscene_create(&v->rs, s->x, s->n_verts, s->tri, s->n_tris, err));
    v->buf = pf_alloc_array((size_t)v->cap, sizeof *v->buf);
    if (!v->buf) {
        pf_ray_voter_release(v);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for ray crossings");
    }
    return PF_OK;
}

pf_status pf_ray_voter_cast(ray_voter *v, pf_vec3 org, pf_vec3 dir, double span, pf_error *err)
{
    v->n = v->next = 0;
    v->winding = 0;
    for (;;) {
        int64_t n;
        PF_TRY(pf_rayscene_crossings(v->rs, org, dir, span, v->merge_eps, v->buf, v->cap, &n,
                                     err));
        if (n <= v->cap) {
            v->n = n;
            return PF_OK;
        }
        pf_crossing *grown = pf_realloc_array(v->buf, (size_t)n, sizeof *grown);
        PF_CHECK(grown, err, PF_ERR_NOMEM, "out of memory for ray crossings");
        v->buf = grown;
        v->cap = n;
    }
}

bool pf_ray_voter_inside_at(ray_voter *v, double t)
{
    while (v->next < v->n && v->buf[v->next].t < t)
        v->winding -= v->buf[v->next++].sign;
    return v->winding != 0;
}

void pf_ray_voter_release(ray_voter *v)
{
    pf_rayscene_destroy(&v->rs);
    pf_free(v->buf);
    *v = (ray_voter){0};
}
