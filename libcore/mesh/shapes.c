/* Generated models: hex and tet box grids, a torus and a sphere surface. */
#include <pf/mesh.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

/* The box grids: nodes numbered i fastest, then j, then k; cells the same way, each either one
 * hex or the 6 tetrahedra around its diagonal from corner 0 to corner 6 (Kuhn's subdivision,
 * which neighbouring cells cut alike on their shared faces). */
static pf_status make_grid(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int32_t nx, int32_t ny, int32_t nz,
                           bool tets, pf_error *err)
{
    int per_cell = tets ? 24 : 8; /* node indices per cell */
    PF_CHECK(nx > 0 && ny > 0 && nz > 0 && (int64_t)nx * ny * nz <= INT32_MAX / per_cell, err,
             PF_ERR_INVALID, "box grid needs 1..%d cells, got %d x %d x %d",
             (int)(INT32_MAX / per_cell), (int)nx, (int)ny, (int)nz);
    PF_CHECK(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z && pf_v3_isfinite(lo) && pf_v3_isfinite(hi),
             err, PF_ERR_INVALID, "box grid needs finite corners with lo < hi");
    static const int KUHN[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                   {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    int32_t n_nodes = (nx + 1) * (ny + 1) * (nz + 1), n_cells = nx * ny * nz;
    double *x = pf_alloc_array(3 * (size_t)n_nodes, sizeof *x);
    uint32_t *cells = pf_alloc_array((size_t)per_cell * (size_t)n_cells, sizeof *cells);
    pf_status s = PF_OK;
    if (!x || !cells) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate a box grid");
        goto done;
    }
#define NODE(i, j, k) ((uint32_t)(((k) * (ny + 1) + (j)) * (nx + 1) + (i)))
    for (int32_t k = 0; k <= nz; ++k)
        for (int32_t j = 0; j <= ny; ++j)
            for (int32_t i = 0; i <= nx; ++i) {
                /* Grid coordinates as lo + (hi - lo) * i / n: exact at both ends. */
                double *p = x + 3 * (size_t)NODE(i, j, k);
                p[0] = i == nx ? hi.x : lo.x + (hi.x - lo.x) * i / nx;
                p[1] = j == ny ? hi.y : lo.y + (hi.y - lo.y) * j / ny;
                p[2] = k == nz ? hi.z : lo.z + (hi.z - lo.z) * k / nz;
            }
    uint32_t *h = cells;
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                uint32_t c[8] = {NODE(i, j, k),
                                 NODE(i + 1, j, k),
                                 NODE(i + 1, j + 1, k),
                                 NODE(i, j + 1, k),
                                 NODE(i, j, k + 1),
                                 NODE(i + 1, j, k + 1),
                                 NODE(i + 1, j + 1, k + 1),
                                 NODE(i, j + 1, k + 1)};
                if (!tets)
                    for (int q = 0; q < 8; ++q)
                        *h++ = c[q];
                else
                    for (int t = 0; t < 6; ++t)
                        for (int q = 0; q < 4; ++q)
                            *h++ = c[KUHN[t][q]];
            }
#undef NODE
    s = tets ? pf_mesh_from_tets(m, x, n_nodes, cells, 6 * n_cells, err)
             : pf_mesh_from_hexes(m, x, n_nodes, cells, n_cells, err);
done:
    pf_free(x);
    pf_free(cells);
    return s;
}

pf_status pf_mesh_make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int32_t nx, int32_t ny, int32_t nz,
                           pf_error *err)
{
    return make_grid(m, lo, hi, nx, ny, nz, false, err);
}

pf_status pf_mesh_make_box_tets(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int32_t nx, int32_t ny,
                                int32_t nz, pf_error *err)
{
    return make_grid(m, lo, hi, nx, ny, nz, true, err);
}

pf_status pf_surface_make_torus(pf_surface *s, double R, double r, int32_t n_major, int32_t n_minor,
                                pf_error *err)
{
    PF_CHECK(isfinite(R) && isfinite(r) && r > 0 && R > r, err, PF_ERR_INVALID,
             "torus needs 0 < r < R, got R = %g, r = %g", R, r);
    PF_CHECK(n_major >= 3 && n_minor >= 3 && (int64_t)n_major * n_minor <= INT32_MAX / 4, err,
             PF_ERR_INVALID, "torus needs at least 3 x 3 segments");
    PF_TRY(pf_surface_alloc(s, n_major * n_minor, 2 * n_major * n_minor, err));
    for (int32_t i = 0; i < n_major; ++i) {
        double u = 2 * PI * i / n_major;
        for (int32_t j = 0; j < n_minor; ++j) {
            double v = 2 * PI * j / n_minor;
            double *p = s->x + 3 * (size_t)(i * n_minor + j);
            p[0] = (R + r * cos(v)) * cos(u);
            p[1] = (R + r * cos(v)) * sin(u);
            p[2] = r * sin(v);
        }
    }
    uint32_t *t = s->tri;
    for (int32_t i = 0; i < n_major; ++i)
        for (int32_t j = 0; j < n_minor; ++j) {
            uint32_t a = (uint32_t)(i * n_minor + j);
            uint32_t b = (uint32_t)(((i + 1) % n_major) * n_minor + j);
            uint32_t c = (uint32_t)(((i + 1) % n_major) * n_minor + (j + 1) % n_minor);
            uint32_t d = (uint32_t)(i * n_minor + (j + 1) % n_minor);
            /* (u, v) increasing is outward-counter-clockwise on this parametrisation. */
            *t++ = a, *t++ = b, *t++ = c;
            *t++ = a, *t++ = c, *t++ = d;
        }
    return PF_OK;
}

pf_status pf_surface_make_sphere(pf_surface *s, double radius, int32_t n_lat, int32_t n_lon,
                                 pf_error *err)
{
    PF_CHECK(isfinite(radius) && radius > 0, err, PF_ERR_INVALID, "sphere needs a radius > 0");
    PF_CHECK(n_lat >= 2 && n_lon >= 3 && (int64_t)n_lat * n_lon <= INT32_MAX / 4, err,
             PF_ERR_INVALID, "sphere needs at least 2 bands and 3 segments");
    int32_t rings = n_lat - 1;
    PF_TRY(pf_surface_alloc(s, rings * n_lon + 2, 2 * n_lon * (n_lat - 1), err));
    uint32_t south = (uint32_t)(rings * n_lon), north = south + 1;
    for (int32_t i = 0; i < rings; ++i) {
        double theta = PI * (i + 1) / n_lat; /* from the south pole */
        for (int32_t j = 0; j < n_lon; ++j) {
            double phi = 2 * PI * j / n_lon;
            double *p = s->x + 3 * (size_t)(i * n_lon + j);
            p[0] = radius * sin(theta) * cos(phi);
            p[1] = radius * sin(theta) * sin(phi);
            p[2] = -radius * cos(theta);
        }
    }
    double *ps = s->x + 3 * (size_t)south;
    ps[0] = ps[1] = 0, ps[2] = -radius;
    double *pn = s->x + 3 * (size_t)north;
    pn[0] = pn[1] = 0, pn[2] = radius;
    uint32_t *t = s->tri;
    for (int32_t j = 0; j < n_lon; ++j) {
        uint32_t j1 = (uint32_t)((j + 1) % n_lon);
        *t++ = south, *t++ = j1, *t++ = (uint32_t)j;
        uint32_t top = (uint32_t)((rings - 1) * n_lon);
        *t++ = north, *t++ = top + (uint32_t)j, *t++ = top + j1;
        for (int32_t i = 0; i + 1 < rings; ++i) {
            uint32_t a = (uint32_t)(i * n_lon + j), b = (uint32_t)(i * n_lon) + j1;
            uint32_t c = b + (uint32_t)n_lon, d = a + (uint32_t)n_lon;
            *t++ = a, *t++ = b, *t++ = c;
            *t++ = a, *t++ = c, *t++ = d;
        }
    }
    return PF_OK;
}

pf_status pf_surface_make_box(pf_surface *s, pf_vec3 lo, pf_vec3 hi, pf_error *err)
{
    PF_CHECK(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z, err, PF_ERR_INVALID,
             "box: lo must be below hi along every axis");
    PF_TRY(pf_surface_alloc(s, 24, 12, err));
    for (int f = 0; f < 6; ++f) {
        int axis = f / 2, side = f % 2, a = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int q = 0; q < 4; ++q) {
            double p[3];
            p[axis] = side ? pf_v3_get(hi, axis) : pf_v3_get(lo, axis);
            p[a] = (q == 1 || q == 2) ? pf_v3_get(hi, a) : pf_v3_get(lo, a);
            p[c] = q >= 2 ? pf_v3_get(hi, c) : pf_v3_get(lo, c);
            memcpy(s->x + 3 * (4 * f + q), p, sizeof p);
        }
        /* corners 0 1 2 3 run counter-clockwise in (a, c), which faces +axis */
        uint32_t v = (uint32_t)(4 * f), t[6] = {v, v + 1, v + 2, v, v + 2, v + 3};
        for (int k = 0; k < 6; ++k)
            s->tri[6 * f + k] = side ? t[k] : t[5 - k];
    }
    return PF_OK;
}
