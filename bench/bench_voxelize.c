/* Voxelization speed: pf_mesh_voxelize (inside mode) against grid resolution (cells along the
 * longest side), for both inside tests:
 *   - rays: a closed surface, signed crossings along the grid rows in x, y and z (Embree), a cell
 *     inside where two of three agree; O(rows x crossings), so the cost per cell falls as the
 *     rows get longer;
 *   - winding: open surfaces (the bunny and a sphere, each with one triangle missing), the winding
 *     number at every cell centre; O(cells x triangles).
 * Surfaces: generated spheres (1k and 10k triangles) and the Stanford bunny (data/models).
 *
 * CSV on stdout: surface,triangles,test,res,cells,voxels,seconds,cpu_seconds,cells_per_second:
 * wall-clock and CPU seconds of pf_mesh_voxelize (building the hex mesh included; Embree may
 * build its BVH on several threads, the CPU seconds count them all), each the best of three runs
 * (of one when a run takes over 2 CPU seconds), and grid cells classified per CPU second; after
 * two comment lines, the second the machine and its load.
 * --quick: one resolution per series. */
#include <stdio.h>
#include <string.h>

#include <pf/io.h>
#include <pf/mesh.h>

#include "machine.h"

static int run(const char *name, const pf_surface *s, pf_inside_method test, int32_t res)
{
    pf_voxelize_params p = pf_voxelize_params_default();
    p.res = res;
    p.inside = test;
    double best = 0, best_cpu = 0;
    pf_grid g = {0};
    int32_t voxels = 0;
    for (int rep = 0; rep < 3 && best_cpu < 2; ++rep) {
        pf_mesh m = {0};
        pf_error err = {0};
        pf_inside_method used;
        double t0 = pf_time_seconds(), c0 = bench_cpu_seconds();
        if (pf_mesh_voxelize(&m, s, &p, &g, &used, &err) != PF_OK) {
            fprintf(stderr, "bench_voxelize: %s %d: %s\n", name, (int)res, err.msg);
            return 1;
        }
        double t = pf_time_seconds() - t0, c = bench_cpu_seconds() - c0;
        if (rep == 0 || t < best)
            best = t;
        if (rep == 0 || c < best_cpu)
            best_cpu = c;
        voxels = m.n_elems;
        pf_mesh_release(&m);
    }
    double cells = (double)g.n[0] * g.n[1] * g.n[2];
    printf("%s,%d,%s,%d,%.0f,%d,%.4f,%.4f,%.0f\n", name, (int)s->n_tris,
           test == PF_INSIDE_RAYS ? "rays" : "winding", (int)res, cells, (int)voxels, best,
           best_cpu, cells / best_cpu);
    fflush(stdout);
    return 0;
}

/* The surface without its last triangle: open, with one small hole. */
static void drop_last_triangle(pf_surface *s)
{
    s->n_tris--;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    printf("# pf_mesh_voxelize, inside mode; best of 3 runs (1 when over 2 CPU s)\n");
    char machine[512]; /* wall-clock times on a shared machine depend on its load */
    bench_describe_machine(machine, sizeof machine);
    printf("# %s\n", machine);
    printf("surface,triangles,test,res,cells,voxels,seconds,cpu_seconds,cells_per_second\n");
    static const int32_t ray_res[] = {16, 32, 64, 128};
    static const int32_t winding_res[] = {8, 16, 32};
    int failed = 0;
    pf_error err = {0};
    pf_surface s = {0};

    /* closed surfaces: rays */
    static const int32_t bands[] = {16, 50}; /* 960 and 9800 triangles */
    for (int b = 0; b < 2; ++b) {
        if (pf_surface_make_sphere(&s, 1, bands[b], 2 * bands[b], &err) != PF_OK)
            return fprintf(stderr, "bench_voxelize: %s\n", err.msg), 1;
        for (int r = quick ? 2 : 0; r < (quick ? 3 : 4); ++r)
            failed |= run("sphere", &s, PF_INSIDE_RAYS, ray_res[r]);
        pf_surface_release(&s);
    }
    if (pf_import_surface(PF_MODELS_DIR "/bunny.obj", &s, &err) != PF_OK)
        return fprintf(stderr, "bench_voxelize: %s\n", err.msg), 1;
    for (int r = quick ? 2 : 0; r < (quick ? 3 : 4); ++r)
        failed |= run("bunny", &s, PF_INSIDE_RAYS, ray_res[r]);

    /* open surfaces: the winding number (the bunny and the small sphere with a triangle
     * missing) */
    drop_last_triangle(&s);
    for (int r = quick ? 1 : 0; r < (quick ? 2 : 3); ++r)
        failed |= run("bunny-open", &s, PF_INSIDE_WINDING, winding_res[r]);
    s.n_tris++;
    pf_surface_release(&s);
    if (pf_surface_make_sphere(&s, 1, bands[0], 2 * bands[0], &err) != PF_OK)
        return fprintf(stderr, "bench_voxelize: %s\n", err.msg), 1;
    drop_last_triangle(&s);
    for (int r = quick ? 1 : 0; r < (quick ? 2 : 3); ++r)
        failed |= run("sphere-open", &s, PF_INSIDE_WINDING, winding_res[r]);
    s.n_tris++;
    pf_surface_release(&s);
    return failed;
}
