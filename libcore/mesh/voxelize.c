/* Voxelization: the grid cells inside a surface (or overlapping it) as a hex mesh. */
#include <pf/mesh.h>

#include "mesh_internal.h"

#include <math.h>
#include <string.h>

pf_voxelize_params pf_voxelize_params_default(void)
{
    return (pf_voxelize_params){.res = 32, .mode = PF_VOXEL_INSIDE, .inside = PF_INSIDE_AUTO};
}

pf_status pf_grid_fit(pf_vec3 lo, pf_vec3 hi, const pf_voxelize_params *p, pf_grid *grid,
                      pf_error *err)
{
    pf_vec3 extent = pf_v3_sub(hi, lo);
    double longest = pf_v3_max_abs(extent);
    PF_CHECK(pf_v3_isfinite(lo) && pf_v3_isfinite(hi) && longest > 0, err, PF_ERR_INVALID,
             "the surface has an empty or non-finite bounding box");
    PF_CHECK(p->cell > 0 || p->res > 0, err, PF_ERR_INVALID, "grid needs res > 0 or cell > 0");
    double h = p->cell > 0 ? p->cell : longest / p->res;
    pf_vec3 origin = p->origin;
    for (int a = 0; a < 3; ++a) {
        double e = pf_v3_get(extent, a), o = pf_v3_get(lo, a);
        double start;
        if (p->has_origin) {
            /* The given origin is a grid point; start at the grid plane at or below lo. */
            double g = pf_v3_get(p->origin, a);
            start = g + floor((o - g) / h) * h;
        } else {
            /* Centred: the margin beyond the box is the same on both sides. */
            double n = fmax(1, ceil(e / h - 1e-9));
            start = o - 0.5 * (n * h - e);
        }
        double n = ceil((o + e - start) / h - 1e-9);
        n = fmax(n, 1);
        PF_CHECK(n <= 4096, err, PF_ERR_TOO_LARGE,
                 "grid of %.0f cells along an axis (at most 4096): use a larger cell", n);
        grid->n[a] = (int32_t)n;
        if (a == 0)
            origin.x = start;
        else if (a == 1)
            origin.y = start;
        else
            origin.z = start;
    }
    grid->origin = origin;
    grid->h = h;
    return PF_OK;
}

static pf_vec3 cell_centre(const pf_grid *g, int32_t i, int32_t j, int32_t k)
{
    return pf_v3(g->origin.x + (i + 0.5) * g->h, g->origin.y + (j + 0.5) * g->h,
                 g->origin.z + (k + 0.5) * g->h);
}

/* Votes of one axis: one ray per row of cells along axis a, starting a cell before the grid. */
static pf_status vote_along_axis(ray_voter *rv, const pf_grid *g, int a, uint8_t *votes,
                                 pf_error *err)
{
    int b = (a + 1) % 3, c = (a + 2) % 3;
    int32_t len = g->n[a];
    double span = (len + 2) * g->h;
    pf_vec3 dir = pf_v3(a == 0, a == 1, a == 2);
    for (int32_t v = 0; v < g->n[c]; ++v)
        for (int32_t u = 0; u < g->n[b]; ++u) {
            int32_t idx[3];
            idx[a] = -1, idx[b] = u, idx[c] = v;
            PF_TRY(pf_ray_voter_cast(rv, cell_centre(g, idx[0], idx[1], idx[2]), dir, span, err));
            for (int32_t w = 0; w < len; ++w) {
                idx[a] = w;
                size_t cell = ((size_t)idx[2] * g->n[1] + idx[1]) * g->n[0] + idx[0];
                votes[cell] += pf_ray_voter_inside_at(rv, (w + 1) * g->h); /* cell w's centre */
            }
        }
    return PF_OK;
}

static pf_status classify_by_rays(const pf_surface *s, const pf_grid *g, uint8_t *inside,
                                  pf_error *err)
{
    ray_voter rv;
    PF_TRY(pf_ray_voter_create(&rv, s, 1e-7 * g->h, err));
    size_t cells = (size_t)g->n[0] * g->n[1] * g->n[2];
    memset(inside, 0, cells);
    pf_status st = PF_OK;
    for (int a = 0; a < 3 && st == PF_OK; ++a)
        st = vote_along_axis(&rv, g, a, inside, err);
    for (size_t i = 0; i < cells; ++i)
        inside[i] = inside[i] >= RAY_VOTES_INSIDE;
    pf_ray_voter_release(&rv);
    return st;
}

pf_status pf_surface_classify_cells(const pf_surface *s, const pf_grid *grid, uint8_t *inside,
                                    pf_inside_method *method, pf_error *err)
{
    return pf_surface_classify_cells_by(s, grid, PF_INSIDE_AUTO, inside, method, err);
}

pf_status pf_surface_classify_cells_by(const pf_surface *s, const pf_grid *grid,
                                       pf_inside_method want, uint8_t *inside,
                                       pf_inside_method *method, pf_error *err)
{
    PF_CHECK(want == PF_INSIDE_AUTO || want == PF_INSIDE_RAYS || want == PF_INSIDE_WINDING, err,
             PF_ERR_INVALID, "unknown inside test %d", (int)want);
    pf_surface_stats st;
    PF_TRY(pf_surface_compute_stats(s, &st, err));
    if (want == PF_INSIDE_RAYS || (want == PF_INSIDE_AUTO && st.closed)) {
        *method = PF_INSIDE_RAYS;
        return classify_by_rays(s, grid, inside, err);
    }
    *method = PF_INSIDE_WINDING;
    /* The tree's value (error below 2e-2 of a turn) decides wherever it is more than 0.05 from
     * the threshold; nearer, the exact sum does: the same cells as the exact sum everywhere, in
     * O(log n) per cell but for the few near the surface. */
    pf_winding_tree *wt = NULL;
    PF_TRY(pf_winding_tree_create(&wt, s->x, s->n_verts, s->tri, s->n_tris, err));
    for (int32_t k = 0; k < grid->n[2]; ++k)
        for (int32_t j = 0; j < grid->n[1]; ++j)
            for (int32_t i = 0; i < grid->n[0]; ++i) {
                pf_vec3 c = cell_centre(grid, i, j, k);
                double w = pf_winding_tree_eval(wt, c);
                if (fabs(fabs(w) - 0.5) < 0.05)
                    w = pf_winding_number(s->x, s->tri, s->n_tris, c);
                /* Orientation-agnostic: an inward-facing open surface counts too. */
                inside[((size_t)k * grid->n[1] + j) * grid->n[0] + i] = fabs(w) >= 0.5;
            }
    pf_winding_tree_destroy(&wt);
    return PF_OK;
}

/* Separating-axis test of a triangle against an axis-aligned box, strict: touching is not
 * overlapping (a triangle lying in a cell face plane overlaps neither cell by itself). Axes: the
 * three box normals, the triangle normal, and the nine cross products of edges. */
int pf_triangle_overlaps_box(pf_vec3 t0, pf_vec3 t1, pf_vec3 t2, pf_vec3 centre, double half)
{
    pf_vec3 v[3] = {pf_v3_sub(t0, centre), pf_v3_sub(t1, centre), pf_v3_sub(t2, centre)};
    pf_vec3 e[3] = {pf_v3_sub(v[1], v[0]), pf_v3_sub(v[2], v[1]), pf_v3_sub(v[0], v[2])};
    pf_vec3 axes[13] = {pf_v3(1, 0, 0), pf_v3(0, 1, 0), pf_v3(0, 0, 1), pf_v3_cross(e[0], e[1])};
    int n_axes = 4;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            axes[n_axes++] = pf_v3_cross(pf_v3(i == 0, i == 1, i == 2), e[j]);
    for (int k = 0; k < n_axes; ++k) {
        pf_vec3 ax = axes[k];
        if (pf_v3_max_abs(ax) == 0)
            continue;
        double p0 = pf_v3_dot(ax, v[0]), p1 = pf_v3_dot(ax, v[1]), p2 = pf_v3_dot(ax, v[2]);
        double lo = fmin(p0, fmin(p1, p2)), hi = fmax(p0, fmax(p1, p2));
        double r = half * (fabs(ax.x) + fabs(ax.y) + fabs(ax.z));
        if (lo >= r || hi <= -r)
            return 0;
    }
    return 1;
}

static void mark_overlapping_cells(const pf_surface *s, const pf_grid *g, uint8_t *selected)
{
    double half = 0.5 * g->h;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        pf_vec3 p[3];
        for (int q = 0; q < 3; ++q)
            p[q] = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * t + q]);
        pf_vec3 lo = pf_v3_min(p[0], pf_v3_min(p[1], p[2]));
        pf_vec3 hi = pf_v3_max(p[0], pf_v3_max(p[1], p[2]));
        int32_t a[3], b[3];
        for (int ax = 0; ax < 3; ++ax) {
            double o = pf_v3_get(g->origin, ax);
            a[ax] = (int32_t)fmax(0, floor((pf_v3_get(lo, ax) - o) / g->h));
            b[ax] = (int32_t)fmin(g->n[ax] - 1, floor((pf_v3_get(hi, ax) - o) / g->h));
        }
        for (int32_t k = a[2]; k <= b[2]; ++k)
            for (int32_t j = a[1]; j <= b[1]; ++j)
                for (int32_t i = a[0]; i <= b[0]; ++i) {
                    size_t cell = ((size_t)k * g->n[1] + j) * g->n[0] + i;
                    if (!selected[cell] &&
                        pf_triangle_overlaps_box(p[0], p[1], p[2], cell_centre(g, i, j, k), half))
                        selected[cell] = 1;
                }
    }
}

/* Hex mesh of the selected cells, numbering only the grid nodes they use. */
static pf_status hexes_of_cells(pf_mesh *m, const pf_grid *g, const uint8_t *selected,
                                pf_error *err)
{
    int32_t nx = g->n[0], ny = g->n[1], nz = g->n[2];
    size_t n_grid_nodes = (size_t)(nx + 1) * (ny + 1) * (nz + 1);
    size_t cells = (size_t)nx * ny * nz;
    int64_t n_cells = 0;
    for (size_t c = 0; c < cells; ++c)
        n_cells += selected[c];
    PF_CHECK(n_cells > 0, err, PF_ERR_INVALID,
             "no grid cell is inside the surface (cell size %g): use a smaller cell or check "
             "that the surface is closed",
             g->h);
    PF_CHECK(n_cells <= INT32_MAX / 8, err, PF_ERR_TOO_LARGE, "too many cells");
    int32_t *node_id = pf_alloc_array(n_grid_nodes, sizeof *node_id);
    uint32_t *hex = pf_alloc_array(8 * (size_t)n_cells, sizeof *hex);
    double *x = NULL;
    pf_status st = PF_OK;
    if (!node_id || !hex) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for %lld cells",
                          (long long)n_cells);
        goto done;
    }
    for (size_t i = 0; i < n_grid_nodes; ++i)
        node_id[i] = -1;
    int32_t n_nodes = 0;
    uint32_t *h = hex;
#define GRID_NODE(i, j, k) (((size_t)(k) * (ny + 1) + (j)) * (nx + 1) + (i))
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                if (!selected[((size_t)k * ny + j) * nx + i])
                    continue;
                size_t corner[8] = {GRID_NODE(i, j, k),
                                    GRID_NODE(i + 1, j, k),
                                    GRID_NODE(i + 1, j + 1, k),
                                    GRID_NODE(i, j + 1, k),
                                    GRID_NODE(i, j, k + 1),
                                    GRID_NODE(i + 1, j, k + 1),
                                    GRID_NODE(i + 1, j + 1, k + 1),
                                    GRID_NODE(i, j + 1, k + 1)};
                for (int q = 0; q < 8; ++q) {
                    if (node_id[corner[q]] < 0)
                        node_id[corner[q]] = n_nodes++;
                    *h++ = (uint32_t)node_id[corner[q]];
                }
            }
    x = pf_alloc_array(3 * (size_t)n_nodes, sizeof *x);
    if (!x) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for nodes");
        goto done;
    }
    for (int32_t k = 0; k <= nz; ++k)
        for (int32_t j = 0; j <= ny; ++j)
            for (int32_t i = 0; i <= nx; ++i) {
                int32_t id = node_id[GRID_NODE(i, j, k)];
                if (id < 0)
                    continue;
                x[3 * (size_t)id + 0] = g->origin.x + i * g->h;
                x[3 * (size_t)id + 1] = g->origin.y + j * g->h;
                x[3 * (size_t)id + 2] = g->origin.z + k * g->h;
            }
#undef GRID_NODE
    st = pf_mesh_from_hexes(m, x, n_nodes, hex, (int32_t)n_cells, err);
done:
    pf_free(node_id);
    pf_free(hex);
    pf_free(x);
    return st;
}

pf_status pf_mesh_voxelize(pf_mesh *m, const pf_surface *s, const pf_voxelize_params *p,
                           pf_grid *grid_out, pf_inside_method *method_out, pf_error *err)
{
    memset(m, 0, sizeof *m);
    pf_surface_stats st;
    PF_TRY(pf_surface_compute_stats(s, &st, err));
    PF_CHECK(s->n_tris > 0, err, PF_ERR_INVALID, "the surface has no triangles");
    pf_grid g;
    PF_TRY(pf_grid_fit(st.lo, st.hi, p, &g, err));
    size_t cells = (size_t)g.n[0] * g.n[1] * g.n[2];
    uint8_t *selected = pf_alloc(cells);
    PF_CHECK(selected, err, PF_ERR_NOMEM, "out of memory for a %d x %d x %d grid", (int)g.n[0],
             (int)g.n[1], (int)g.n[2]);
    pf_inside_method method = p->inside;
    pf_status status = pf_surface_classify_cells_by(s, &g, p->inside, selected, &method, err);
    if (status == PF_OK && p->mode == PF_VOXEL_OVERLAP)
        mark_overlapping_cells(s, &g, selected);
    if (status == PF_OK)
        status = hexes_of_cells(m, &g, selected, err);
    pf_free(selected);
    if (grid_out)
        *grid_out = g;
    if (method_out)
        *method_out = method;
    return status;
}
