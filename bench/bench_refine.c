/* Cost of pf_mesh_refine per split element on hex boxes.
 *
 * CSV on stdout: box,elements,kind,requests,split,children,dst_elements,dst_nodes,cpu_ms,
 * base_ms,ms_per_split. Boxes of unit cubes, 20x6x6 (the brief's bar) and 40x12x12 (8 times as
 * many elements); kinds octs and halves (normal (1, 0.3, 0.2): not along a box axis, so every
 * child is a general polyhedron and neighbours get crossed faces); requests: every element, or
 * every 10th in index order (the same 72 elements' worth of work on both boxes when 72 are
 * asked for). cpu_ms: CPU time of one call, best of 7; base_ms: the same call without requests
 * (the O(mesh) copy, index and derive), best of 7 interleaved with those; ms_per_split = (cpu_ms -
 * base_ms) / split. One thread. */
#include <stdio.h>
#include <stdlib.h>

#include <pf/mesh.h>
#include <pf/refine.h>

#include "machine.h"

static double timed_call(const pf_mesh *src, const pf_refine_request *req, int32_t n, pf_mesh *dst,
                         pf_refine_result *res)
{
    pf_error err = {0};
    pf_mesh_release(dst);
    pf_refine_result_release(res);
    double t0 = bench_cpu_seconds();
    pf_status st = pf_mesh_refine(src, req, n, dst, res, &err);
    double t = bench_cpu_seconds() - t0;
    if (st != PF_OK) {
        fprintf(stderr, "bench_refine: %s\n", err.msg);
        exit(1);
    }
    return t;
}

static void run(int nx, int ny, int nz, pf_split_kind kind, int every, int32_t max_req)
{
    pf_mesh src = {0}, dst = {0};
    pf_refine_result res = {0};
    pf_error err = {0};
    if (pf_mesh_make_box(&src, pf_v3(0, 0, 0), pf_v3(nx, ny, nz), nx, ny, nz, &err) != PF_OK) {
        fprintf(stderr, "bench_refine: %s\n", err.msg);
        exit(1);
    }
    pf_refine_request *req = calloc((size_t)src.n_elems, sizeof *req);
    int32_t n = 0;
    for (int32_t e = 0; e < src.n_elems && n < max_req; e += every)
        req[n++] = (pf_refine_request){.elem = e, .kind = kind, .normal = pf_v3(1, 0.3, 0.2)};
    /* interleaved, so that both see the same state of a shared machine */
    double base = 1e300, t = 1e300;
    for (int rep = 0; rep < 7; ++rep) {
        double b = timed_call(&src, NULL, 0, &dst, &res);
        double r = timed_call(&src, req, n, &dst, &res);
        base = b < base ? b : base;
        t = r < t ? r : t;
    }
    printf("%dx%dx%d,%d,%s,%d,%d,%d,%d,%d,%.3f,%.3f,%.4f\n", nx, ny, nz, (int)src.n_elems,
           kind == PF_SPLIT_OCTS ? "octs" : "halves", (int)n, (int)res.n_split, (int)res.n_children,
           (int)dst.n_elems, (int)dst.n_nodes, 1e3 * t, 1e3 * base,
           res.n_split ? 1e3 * (t - base) / res.n_split : 0.0);
    fflush(stdout);
    pf_refine_result_release(&res);
    pf_mesh_release(&dst);
    pf_mesh_release(&src);
    free(req);
}

int main(void)
{
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# pf_mesh_refine, CPU time, best of 7, one thread\n# %s\n", machine);
    printf("box,elements,kind,requests,split,children,dst_elements,dst_nodes,cpu_ms,base_ms,"
           "ms_per_split\n");
    for (int k = 0; k < 2; ++k) {
        pf_split_kind kind = k ? PF_SPLIT_HALVES : PF_SPLIT_OCTS;
        run(20, 6, 6, kind, 1, 1 << 30);
        run(20, 6, 6, kind, 10, 72);
        run(40, 12, 12, kind, 80, 72);
    }
    return 0;
}
