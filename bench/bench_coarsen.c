/* Cost of pf_mesh_coarsen on a 20x6x6 box of cubes (720 hexes, the bending bar's proportions):
 * k elements refined by octs (spread evenly: element i * 720 / k), then their children merged
 * back in one call (group = the refine result's parent). The cost per call is O(mesh) to read
 * and copy plus work proportional to the groups; the per-group cost is the slope in k. The
 * refinement's cost is printed beside it for scale.
 *
 * CSV on stdout: groups,elements_refined,nodes_refined,refine_ms,coarsen_ms,coarsen_ms_per_group
 * (CPU milliseconds, one thread, the best of 5 runs; coarsen_ms_per_group = coarsen_ms / groups).
 * Comment lines first: the machine and its load. Each run checks that the mesh came back. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/mesh.h>
#include <pf/refine.h>

#include "machine.h"

static int run(const pf_mesh *box, int32_t k)
{
    pf_refine_request *req = calloc((size_t)k + 1, sizeof *req);
    if (!req)
        return 1;
    for (int32_t i = 0; i < k; ++i)
        req[i] = (pf_refine_request){.elem = (int32_t)((int64_t)i * box->n_elems / k),
                                     .kind = PF_SPLIT_OCTS};
    double best_r = 1e300, best_c = 1e300;
    int32_t nodes = 0, elems = 0;
    for (int rep = 0; rep < 5; ++rep) {
        pf_mesh mid = {0}, back = {0};
        pf_refine_result rr;
        pf_coarsen_result cr;
        pf_error err = {0};
        double t0 = bench_cpu_seconds();
        if (pf_mesh_refine(box, req, k, &mid, &rr, &err) != PF_OK) {
            fprintf(stderr, "bench_coarsen: refine: %s\n", err.msg);
            free(req);
            return 1;
        }
        double t1 = bench_cpu_seconds();
        if (pf_mesh_coarsen(&mid, rr.parent, &back, &cr, &err) != PF_OK) {
            fprintf(stderr, "bench_coarsen: coarsen: %s\n", err.msg);
            free(req);
            return 1;
        }
        double t2 = bench_cpu_seconds();
        int ok = back.n_nodes == box->n_nodes && back.n_elems == box->n_elems &&
                 back.n_faces == box->n_faces && cr.n_merged == k;
        nodes = mid.n_nodes;
        elems = mid.n_elems;
        pf_refine_result_release(&rr);
        pf_coarsen_result_release(&cr);
        pf_mesh_release(&mid);
        pf_mesh_release(&back);
        if (!ok) {
            fprintf(stderr, "bench_coarsen: %d groups: the mesh did not come back\n", (int)k);
            free(req);
            return 1;
        }
        best_r = t1 - t0 < best_r ? t1 - t0 : best_r;
        best_c = t2 - t1 < best_c ? t2 - t1 : best_c;
    }
    printf("%d,%d,%d,%.3f,%.3f,%.4f\n", (int)k, (int)elems, (int)nodes, 1e3 * best_r, 1e3 * best_c,
           1e3 * best_c / k);
    fflush(stdout);
    free(req);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        printf("usage: bench_coarsen\nCSV of pf_mesh_coarsen's cost per merged group on a 20x6x6 "
               "box.\n");
        return 0;
    }
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# pf_mesh_refine by octs, then pf_mesh_coarsen back, on a 20x6x6 box; CPU ms, one "
           "thread, best of 5\n# %s\n",
           machine);
    printf("groups,elements_refined,nodes_refined,refine_ms,coarsen_ms,coarsen_ms_per_group\n");
    pf_mesh box = {0};
    pf_error err = {0};
    if (pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(20, 6, 6), 20, 6, 6, &err) != PF_OK) {
        fprintf(stderr, "bench_coarsen: %s\n", err.msg);
        return 1;
    }
    const int32_t ks[] = {1, 4, 16, 64, 180, 720};
    int failed = 0;
    for (size_t i = 0; i < sizeof ks / sizeof *ks && !failed; ++i)
        failed = run(&box, ks[i]);
    pf_mesh_release(&box);
    return failed;
}
