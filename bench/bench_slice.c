/* Slicing speed: pf_mesh_slice on generated spheres and tori against triangle count and grid
 * resolution (cells along the longest side), and on the Stanford bunny (data/models, a scanned
 * surface). One thread. The target of the meshing issue: a 100k-triangle surface at 64 cells in
 * under 2 s.
 *
 * CSV on stdout: shape,triangles,res,elements,hexes,polyhedra,merged,splits,seconds,cpu_seconds,
 * elements_per_second: wall-clock and CPU seconds of pf_mesh_slice, each the best of three runs,
 * and elements per CPU second (the CPU time is what the call costs on an idle machine; the wall
 * clock of a busy one also counts waiting for a core), after two comment lines, the second the
 * machine and its load. */
#include <stdio.h>
#include <string.h>

#include <pf/io.h>
#include <pf/mesh.h>

#include "machine.h"

static int run(const char *shape, const pf_surface *s, int32_t res)
{
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    double best = 1e300, best_cpu = 1e300;
    pf_slice_stats st;
    int32_t elements = 0;
    for (int rep = 0; rep < 3; ++rep) {
        pf_mesh m = {0};
        pf_error err = {0};
        double cpu0 = bench_cpu_seconds();
        pf_status status = pf_mesh_slice(&m, s, &p, &st, &err);
        double cpu = bench_cpu_seconds() - cpu0;
        if (status != PF_OK) {
            fprintf(stderr, "bench_slice: %s %d: %s\n", shape, (int)res, err.msg);
            return 1;
        }
        elements = m.n_elems;
        if (st.seconds < best)
            best = st.seconds;
        if (cpu < best_cpu)
            best_cpu = cpu;
        pf_mesh_release(&m);
    }
    printf("%s,%d,%d,%d,%d,%d,%d,%lld,%.4f,%.4f,%.0f\n", shape, (int)s->n_tris, (int)res,
           (int)elements, (int)st.kinds[PF_ELEM_HEX], (int)st.kinds[PF_ELEM_POLY], (int)st.merged,
           (long long)st.splits, best, best_cpu, elements / best_cpu);
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    printf("# pf_mesh_slice, one thread; best of 3 runs\n");
    char machine[512]; /* wall-clock times on a shared machine depend on its load */
    bench_describe_machine(machine, sizeof machine);
    printf("# %s\n", machine);
    printf("shape,triangles,res,elements,hexes,polyhedra,merged,splits,seconds,cpu_seconds,"
           "elements_per_second\n");
    static const int32_t bands[] = {16, 50, 158};      /* 1k, 10k, 100k triangles */
    static const int32_t resolutions[] = {16, 32, 64};
    int failed = 0;
    for (int b = quick ? 2 : 0; b < 3; ++b) {
        pf_surface s = {0};
        pf_error err = {0};
        if (pf_surface_make_sphere(&s, 1, bands[b], 2 * bands[b], &err) != PF_OK)
            return fprintf(stderr, "bench_slice: %s\n", err.msg), 1;
        for (int r = quick ? 2 : 0; r < 3; ++r)
            failed |= run("sphere", &s, resolutions[r]);
        pf_surface_release(&s);
        if (pf_surface_make_torus(&s, 1, 0.35, 2 * bands[b], bands[b], &err) != PF_OK)
            return fprintf(stderr, "bench_slice: %s\n", err.msg), 1;
        for (int r = quick ? 2 : 0; r < 3; ++r)
            failed |= run("torus", &s, resolutions[r]);
        pf_surface_release(&s);
    }
    pf_surface bunny = {0};
    pf_error err = {0};
    if (pf_import_surface(PF_MODELS_DIR "/bunny.obj", &bunny, &err) != PF_OK)
        return fprintf(stderr, "bench_slice: %s\n", err.msg), 1;
    for (int r = quick ? 2 : 0; r < 3; ++r)
        failed |= run("bunny", &bunny, resolutions[r]);
    pf_surface_release(&bunny);
    return failed;
}
