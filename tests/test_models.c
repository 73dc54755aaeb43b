/* models: the real surfaces in data/models through slicing and voxelization.
 *
 * The Stanford bunny (data/models/bunny.obj, a scanned surface: thin ears, a curved underside, no
 * symmetry the grid could line up with) meets the acceptance of the meshing issue: the sliced
 * elements' volumes sum to the enclosed volume and the boundary faces' areas to the surface area,
 * both to 1e-9 relative (exact arithmetic would give equality; rounding adds a few ulp per element,
 * ~1e-13 here, so only a lost or doubled piece, at least 5 % of a cell or ~1e-5 of the solid, can
 * break it); every element is valid; none is below the merge threshold.
 *
 * The voxelization is checked against the slicing, an independent computation: sliced without
 * merging, every piece lies in one grid cell, so the solid fraction of every cell is known. A cell
 * whose fraction is 1 (wholly inside) has its centre inside and must be a voxel; a cell without
 * solid has its centre outside and must not be one; only cells the surface crosses may go either
 * way. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/io.h>
#include <pf/mesh.h>

#define BUNNY PF_TEST_DATA_DIR "/../../data/models/bunny.obj"

static void load_bunny(pf_surface *s, pf_surface_stats *ss)
{
    pf_error err = {0};
    if (pf_import_surface(BUNNY, s, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(pf_surface_compute_stats(s, ss, &err), PF_OK);
}

/* The file is what data/models/README.md says it is. */
static void bunny_is_closed_and_manifold(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_surface s = {0};
    pf_surface_stats ss;
    load_bunny(&s, &ss);
    assert_int_equal(ss.n_tris, 3674);
    assert_int_equal(ss.n_verts, 1839);
    assert_true(ss.closed && ss.manifold);
    /* the README quotes 6 significant digits */
    assert_true(fabs(ss.volume - 0.194288) <= 5e-7);
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void slices_the_bunny(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_surface s = {0};
    pf_surface_stats ss;
    load_bunny(&s, &ss);
    for (int32_t res = 16; res <= 32; res *= 2) {
        pf_slice_params p = pf_slice_params_default();
        p.grid.res = res;
        pf_mesh m = {0};
        pf_slice_stats st;
        pf_error err = {0};
        if (pf_mesh_slice(&m, &s, &p, &st, &err) != PF_OK)
            fail_msg("res %d: %s", (int)res, err.msg);
        if (pf_mesh_validate(&m, NULL, &err) != PF_OK)
            fail_msg("res %d: invalid mesh: %s", (int)res, err.msg);
        double cell = st.grid.h * st.grid.h * st.grid.h;
        double volume = 0, smallest = INFINITY, area = 0;
        for (int32_t e = 0; e < m.n_elems; ++e) {
            double v = pf_mesh_elem_volume(&m, e);
            volume += v;
            smallest = fmin(smallest, v);
        }
        for (int32_t f = 0; f < m.n_faces; ++f)
            if (m.face_elems[2 * f] < 0 || m.face_elems[2 * f + 1] < 0)
                area += pf_polygon_area(m.x, m.face_nodes + m.face_offsets[f],
                                        m.face_offsets[f + 1] - m.face_offsets[f]);
        printf("bunny res %2d: %5d elements (%d hexes, %d polyhedra), %d merged, volume error "
               "%.1e, area error %.1e, smallest %.3f cells, %.3f s\n",
               (int)res, (int)m.n_elems, (int)st.kinds[PF_ELEM_HEX], (int)st.kinds[PF_ELEM_POLY],
               (int)st.merged, fabs(volume / ss.volume - 1), fabs(area / ss.area - 1),
               smallest / cell, st.seconds);
        assert_true(fabs(volume / ss.volume - 1) < 1e-9);
        assert_true(fabs(area / ss.area - 1) < 1e-9);
        /* the bunny is one body: every piece has a neighbour to merge into */
        assert_int_equal(st.isolated_slivers, 0);
        assert_true(smallest >= p.merge * cell);
        assert_true(st.kinds[PF_ELEM_HEX] > 0 && st.kinds[PF_ELEM_POLY] > 0);
        pf_mesh_release(&m);
    }
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Index of the grid cell holding element e: the centre of its nodes' bounding box, which lies
 * inside the cell (a piece of a cell lies in the cell). */
static size_t cell_of(const pf_mesh *m, int32_t e, const pf_grid *g)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
            for (int c = 0; c < 3; ++c) {
                lo[c] = fmin(lo[c], m->x[3 * (size_t)m->face_nodes[q] + c]);
                hi[c] = fmax(hi[c], m->x[3 * (size_t)m->face_nodes[q] + c]);
            }
    }
    const double o[3] = {g->origin.x, g->origin.y, g->origin.z};
    int32_t idx[3];
    for (int c = 0; c < 3; ++c) {
        idx[c] = (int32_t)floor((0.5 * (lo[c] + hi[c]) - o[c]) / g->h);
        assert_true(idx[c] >= 0 && idx[c] < g->n[c]);
    }
    return ((size_t)idx[2] * g->n[1] + idx[1]) * g->n[0] + idx[0];
}

static void voxelizes_the_bunny_within_its_sliced_cells(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_surface s = {0};
    pf_surface_stats ss;
    load_bunny(&s, &ss);
    for (int32_t res = 16; res <= 32; res *= 2) {
        pf_error err = {0};
        pf_slice_params sp = pf_slice_params_default();
        sp.grid.res = res;
        sp.merge = 0; /* every piece stays in its cell */
        pf_mesh sliced = {0}, vox = {0};
        pf_slice_stats st;
        assert_int_equal(pf_mesh_slice(&sliced, &s, &sp, &st, &err), PF_OK);
        pf_grid g;
        pf_inside_method method;
        assert_int_equal(pf_mesh_voxelize(&vox, &s, &sp.grid, &g, &method, &err), PF_OK);
        assert_int_equal(method, PF_INSIDE_RAYS);
        assert_true(g.h == st.grid.h && g.n[0] == st.grid.n[0] && g.n[1] == st.grid.n[1] &&
                    g.n[2] == st.grid.n[2] && g.origin.x == st.grid.origin.x);
        size_t cells = (size_t)g.n[0] * g.n[1] * g.n[2];
        double *fraction = pf_calloc(cells, sizeof *fraction);
        uint8_t *voxel = pf_calloc(cells, 1);
        assert_non_null(fraction);
        assert_non_null(voxel);
        double h3 = g.h * g.h * g.h;
        for (int32_t e = 0; e < sliced.n_elems; ++e)
            fraction[cell_of(&sliced, e, &g)] += pf_mesh_elem_volume(&sliced, e) / h3;
        for (int32_t e = 0; e < vox.n_elems; ++e) {
            size_t c = cell_of(&vox, e, &g);
            assert_int_equal(voxel[c], 0); /* one hex per cell */
            voxel[c] = 1;
        }
        /* a full cell's fraction is 1 up to the rounding of 6 face terms, ~1e-15 */
        int64_t full = 0, crossed = 0, missed_full = 0, in_empty = 0, crossed_voxels = 0;
        for (size_t c = 0; c < cells; ++c) {
            bool is_full = fraction[c] > 1 - 1e-12, is_empty = fraction[c] == 0;
            full += is_full;
            crossed += !is_full && !is_empty;
            missed_full += is_full && !voxel[c];
            in_empty += is_empty && voxel[c];
            crossed_voxels += !is_full && !is_empty && voxel[c];
        }
        printf("bunny res %2d: %d voxels: %lld full cells, %lld of %lld crossed cells, volume "
               "%.6f (solid %.6f)\n",
               (int)res, (int)vox.n_elems, (long long)full, (long long)crossed_voxels,
               (long long)crossed, vox.n_elems * h3, ss.volume);
        assert_int_equal(missed_full, 0);
        assert_int_equal(in_empty, 0);
        /* the crossed cells are a shell around the solid: some of them must be voxels */
        assert_true(crossed_voxels > 0 && crossed_voxels < crossed);
        pf_free(fraction);
        pf_free(voxel);
        pf_mesh_release(&sliced);
        pf_mesh_release(&vox);
    }
    pf_surface_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(bunny_is_closed_and_manifold),
        cmocka_unit_test(slices_the_bunny),
        cmocka_unit_test(voxelizes_the_bunny_within_its_sliced_cells),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
