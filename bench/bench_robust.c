/* The cost of robustness: pf_mesh_slice in the exact mode (robust off) and the robust mode, on
 * closed surfaces (where the robust mode only checks that the surface is clean, looks for
 * overlapping parts, and slices it as the exact mode does), on the same surfaces with one
 * triangle removed (the robust mode then orients, contours the winding-number solid on the
 * lattice of h / 2 and slices that), and on the real models of Debian's assimp-testmodels when
 * installed (robust only: the exact mode refuses them). One thread.
 *
 * CSV on stdout: shape,triangles,res,mode,elements,contour_triangles,contour_seconds,seconds,
 * cpu_seconds,volume: wall-clock seconds of the whole call (contour_seconds: the contour's share)
 * and CPU seconds, each the best of three runs, after two comment lines, the second the machine
 * and its load. --quick: one resolution, no real models. */
#include <stdio.h>
#include <string.h>

#include <pf/io.h>
#include <pf/mesh.h>

#include "machine.h"

static int run(const char *shape, const pf_surface *s, int32_t res, bool robust)
{
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    p.robust = robust;
    double best = 1e300, best_cpu = 1e300, volume = 0;
    pf_slice_stats st;
    int32_t elements = 0;
    for (int rep = 0; rep < 3; ++rep) {
        pf_mesh m = {0};
        pf_error err = {0};
        double cpu0 = bench_cpu_seconds();
        pf_status status = pf_mesh_slice(&m, s, &p, &st, &err);
        double cpu = bench_cpu_seconds() - cpu0;
        if (status != PF_OK) {
            fprintf(stderr, "bench_robust: %s %d: %s\n", shape, (int)res, err.msg);
            return 1;
        }
        elements = m.n_elems;
        volume = pf_mesh_volume(&m);
        best = st.seconds < best ? st.seconds : best;
        best_cpu = cpu < best_cpu ? cpu : best_cpu;
        pf_mesh_release(&m);
    }
    printf("%s,%d,%d,%s,%d,%d,%.4f,%.4f,%.4f,%.9g\n", shape, (int)s->n_tris, (int)res,
           robust ? (st.contoured ? "robust-contour" : "robust") : "exact", (int)elements,
           (int)st.contour.n_tris, st.contour.seconds, best, best_cpu, volume);
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    printf("# pf_mesh_slice exact and robust, one thread; best of 3 runs\n");
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# %s\n", machine);
    printf("shape,triangles,res,mode,elements,contour_triangles,contour_seconds,seconds,"
           "cpu_seconds,volume\n");
    static const int32_t resolutions[] = {16, 32};
    int n_res = quick ? 1 : 2;
    pf_error err = {0};
    int rc = 0;
    for (int k = 0; k < 3 && rc == 0; ++k) {
        pf_surface s = {0};
        const char *name = k == 0 ? "sphere" : k == 1 ? "torus" : "bunny";
        pf_status st = k == 0   ? pf_surface_make_sphere(&s, 1, 50, 100, &err)
                       : k == 1 ? pf_surface_make_torus(&s, 1, 0.4, 100, 50, &err)
                                : pf_import_surface(PF_MODELS_DIR "/bunny.obj", &s, &err);
        if (st != PF_OK) {
            fprintf(stderr, "bench_robust: %s\n", err.msg);
            return 1;
        }
        char open_name[64];
        snprintf(open_name, sizeof open_name, "%s-minus-a-face", name);
        for (int r = 0; r < n_res && rc == 0; ++r) {
            rc |= run(name, &s, resolutions[r], false);
            rc |= run(name, &s, resolutions[r], true);
            s.n_tris -= 1;
            rc |= run(open_name, &s, resolutions[r], true);
            s.n_tris += 1;
        }
        pf_surface_release(&s);
    }
    static const char *models[] = {"PLY/Wuson.ply", "OBJ/spider.obj", "Collada/teapots.DAE",
                                   "Collada/duck.dae",
                                   "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"};
    for (int k = 0; k < 5 && !quick && rc == 0; ++k) {
        char path[256];
        snprintf(path, sizeof path, "/usr/share/assimp/models/%s", models[k]);
        pf_surface s = {0};
        if (pf_import_surface(path, &s, &err) != PF_OK) {
            fprintf(stderr, "bench_robust: %s (assimp-testmodels not installed?)\n", err.msg);
            continue;
        }
        pf_surface_fix_params fp = pf_surface_fix_params_default();
        fp.up = strstr(path, ".DAE") || strstr(path, ".dae") || strstr(path, ".glb") ? PF_UP_Y
                                                                                     : PF_UP_Z;
        if (pf_surface_fix(&s, &fp, NULL, &err) != PF_OK) {
            fprintf(stderr, "bench_robust: %s: %s\n", path, err.msg);
            pf_surface_release(&s);
            return 1;
        }
        const char *name = strrchr(models[k], '/') + 1;
        for (int r = 0; r < (k == 4 ? 1 : 2) && rc == 0; ++r)
            rc |= run(name, &s, resolutions[r], true);
        pf_surface_release(&s);
    }
    return rc;
}
