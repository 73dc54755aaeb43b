/* Octree meshing speed: pf_mesh_octree on generated spheres and tori (10k triangles) at
 * increasing depth, cells only (centre test) and sliced, min depth 2. One thread. The element
 * count should grow about 4x per level (the surface's area), not 8x (the volume).
 *
 * CSV on stdout: shape,triangles,slice,depth,leaves,surface_leaves,elements,growth,hexes,
 * polyhedra,split_faces,seconds,elements_per_second (growth: elements / elements one level up;
 * seconds: the best of three runs). Two comment lines first, the second the machine's load
 * average (Linux; -1 elsewhere). --quick: depths 4 and 5 only. */
#include <stdio.h>
#include <string.h>

#include <pf/mesh.h>

static int run(const char *shape, const pf_surface *s, bool slice, int32_t depth, int32_t *prev)
{
    pf_octree_params p = pf_octree_params_default();
    p.depth = depth;
    p.slice = slice;
    double best = 1e300;
    pf_octree_stats st;
    int32_t elements = 0;
    for (int rep = 0; rep < 3; ++rep) {
        pf_mesh m = {0};
        pf_error err = {0};
        if (pf_mesh_octree(&m, s, &p, &st, &err) != PF_OK) {
            fprintf(stderr, "bench_octree: %s depth %d: %s\n", shape, (int)depth, err.msg);
            return 1;
        }
        elements = m.n_elems;
        if (st.seconds < best)
            best = st.seconds;
        pf_mesh_release(&m);
    }
    printf("%s,%d,%d,%d,%d,%d,%d,%.2f,%d,%d,%d,%.4f,%.0f\n", shape, (int)s->n_tris, (int)slice,
           (int)depth, (int)st.leaves, (int)st.surface_leaves, (int)elements,
           *prev ? (double)elements / *prev : 0.0, (int)st.kinds[PF_ELEM_HEX],
           (int)st.kinds[PF_ELEM_POLY], (int)st.split_faces, best, elements / best);
    fflush(stdout);
    *prev = elements;
    return 0;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    printf("# pf_mesh_octree, min depth 2, one thread; best of 3 runs (wall clock)\n");
    /* wall-clock times on a shared machine depend on its load: record it beside them */
    FILE *load = fopen("/proc/loadavg", "r");
    double l1 = -1;
    if (load) {
        if (fscanf(load, "%lf", &l1) != 1)
            l1 = -1;
        fclose(load);
    }
    printf("# load average at start: %.2f\n", l1);
    printf("shape,triangles,slice,depth,leaves,surface_leaves,elements,growth,hexes,polyhedra,"
           "split_faces,seconds,elements_per_second\n");
    int failed = 0;
    for (int shape = 0; shape < 2; ++shape) {
        pf_surface s = {0};
        pf_error err = {0};
        pf_status st = shape == 0 ? pf_surface_make_sphere(&s, 1, 50, 100, &err)
                                  : pf_surface_make_torus(&s, 1, 0.35, 100, 50, &err);
        if (st != PF_OK)
            return fprintf(stderr, "bench_octree: %s\n", err.msg), 1;
        for (int slice = 0; slice < 2; ++slice) {
            int32_t prev = 0;
            for (int32_t depth = 4; depth <= (quick ? 5 : 7); ++depth)
                failed |= run(shape ? "torus" : "sphere", &s, slice, depth, &prev);
        }
        pf_surface_release(&s);
    }
    return failed;
}
