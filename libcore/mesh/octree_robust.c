/* pf_mesh_octree: the checks, and the robust mode's replacement surface (see pf_mesh_slice)
 * before the octree is built over the original's bounding cube (octree.c). */
#include <pf/mesh.h>

#include "octree_internal.h"

#include <math.h>
#include <string.h>

pf_status pf_mesh_octree(pf_mesh *m, const pf_surface *s, const pf_octree_params *params,
                         pf_octree_stats *stats, pf_error *err)
{
    memset(m, 0, sizeof *m);
    pf_octree_params p = params ? *params : pf_octree_params_default();
    pf_octree_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    double t0 = pf_time_seconds();
    PF_CHECK(p.depth >= 1 && p.depth <= PF_OCTREE_MAX_DEPTH, err, PF_ERR_INVALID,
             "octree depth must be in 1 .. %d, got %d", PF_OCTREE_MAX_DEPTH, (int)p.depth);
    PF_CHECK(p.min_depth >= 0 && p.min_depth <= p.depth, err, PF_ERR_INVALID,
             "octree min depth must be in 0 .. depth (%d), got %d", (int)p.depth, (int)p.min_depth);
    PF_CHECK(p.merge >= 0 && p.merge < 1, err, PF_ERR_INVALID,
             "merge fraction must be in [0, 1), got %g", p.merge);
    pf_surface_stats ss;
    PF_TRY(pf_surface_compute_stats(s, &ss, err));
    PF_CHECK(s->n_tris > 0, err, PF_ERR_INVALID, "the surface has no triangles");
    bool clean = ss.closed && ss.manifold && ss.volume > 0;
    if (p.slice && clean && p.robust) {
        bool overlap;
        PF_TRY(pf_surface_parts_overlap(s, &overlap, err));
        clean = !overlap;
    }
    if (p.slice)
        PF_CHECK(clean || p.robust, err, PF_ERR_INVALID,
                 "slicing needs a closed, manifold, outward-oriented surface (%lld open edges, "
                 "%lld non-manifold, %lld flipped, volume %g); the robust mode slices the "
                 "winding-number solid of any surface, and without --slice open surfaces work",
                 (long long)ss.n_boundary_edges, (long long)ss.n_nonmanifold_edges,
                 (long long)ss.n_flipped_edges, ss.volume);
    if (!p.slice || clean)
        return pf_octree_mesh(m, s, &p, ss.lo, ss.hi, ss.closed, stats, err);
    /* robust: the winding-number solid's boundary on a lattice over the finest cells */
    double size = pf_v3_max_abs(pf_v3_sub(ss.hi, ss.lo));
    PF_CHECK(size > 0 && isfinite(size), err, PF_ERR_INVALID,
             "the surface has an empty or non-finite bounding box");
    int32_t n = 1 << p.depth;
    pf_grid grid = {.h = size / n, .n = {n, n, n}};
    grid.origin = pf_v3_sub(pf_v3_scale(pf_v3_add(ss.lo, ss.hi), 0.5),
                            pf_v3(0.5 * size, 0.5 * size, 0.5 * size));
    pf_surface replaced;
    pf_surface_fix_report orient;
    pf_winding_contour_stats contour;
    bool contoured;
    PF_TRY(pf_slice_winding_surface(s, &grid, p.contour_refine, &replaced, &orient, &contour,
                                    &contoured, err));
    pf_status st = pf_octree_mesh(m, &replaced, &p, ss.lo, ss.hi, true, stats, err);
    pf_surface_release(&replaced);
    stats->robust_used = true;
    stats->contoured = contoured;
    stats->orient = orient;
    stats->contour = contour;
    stats->seconds = pf_time_seconds() - t0;
    return st;
}
