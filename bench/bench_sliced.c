/* Harmonic functions on sliced cells: boundary error and set-up time per cell against the
 * sampling settings (pf/basis.h, "Sliced cells"), on a sliced sphere, torus and the bunny.
 *
 *   bench_sliced           CSV, one row per harmonic cell and setting:
 *                          mesh,setting,xi,grading,patch_angle,element,nodes,faces,kernels,
 *                          setup_ms,boundary_error
 *   bench_sliced summary [MESH...]
 *                          CSV, one row per mesh (sphere, sphere32, torus, bunny; default all)
 *                          and setting: median, worst-decile and largest boundary error, median
 *                          and largest kernels and set-up time per cell, CPU seconds of the
 *                          whole basis: mesh,setting,xi,grading,patch_angle,cells,median_error,
 *                          decile_error,max_error,median_kernels,max_kernels,median_setup_ms,
 *                          max_setup_ms,cpu_seconds
 *
 * Meshes: the unit sphere of 8 x 16 facets sliced 6 cells across (what `pf-slice sphere.obj
 * --res 6` gives for the sphere of the accuracy target), pf-shape's default sphere (32 x 64
 * facets, "sphere32") sliced 6 across, the torus of pf-shape (R 1, r 0.35, 32 x 16 segments)
 * sliced 6 across, and data/models/bunny.obj sliced 6 across. Settings: SETTINGS below (the
 * uniform functions, the defaults and their budget and grading varied, the accurate preset).
 * One core; set-up times are wall clock per cell (the check-point statistics excluded), CPU
 * seconds for the whole mesh. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/basis.h>
#include <pf/io.h>
#include <pf/mesh.h>

#include "machine.h"

typedef struct setting {
    const char *name;
    pf_basis_sliced sliced;
    double xi, grading, patch_angle;
    int32_t edge_samples, max_kernels;
} setting;

/* uniform: pf_basis_params_uniform; default: pf_basis_params_default (the sliced-cell settings
 * on patch cells, 400 kernels at most); accurate: pf_basis_params_accurate (every cell graded,
 * no budget). xi is the sliced cells' offset (sliced_xi) except for uniform. */
static const setting SETTINGS[] = {
    {"uniform", PF_BASIS_SLICED_OFF, 0.1, 0.2, 60, 2, 400},
    {"default", PF_BASIS_SLICED_AUTO, 0.2, 0.2, 60, 2, 400},
    {"default-kernels200", PF_BASIS_SLICED_AUTO, 0.2, 0.2, 60, 2, 200},
    {"default-kernels800", PF_BASIS_SLICED_AUTO, 0.2, 0.2, 60, 2, 800},
    {"default-grading0.3", PF_BASIS_SLICED_AUTO, 0.2, 0.3, 60, 2, 400},
    {"accurate", PF_BASIS_SLICED_ALL, 0.2, 0.2, 60, 2, -1},
};
enum { N_SETTINGS = sizeof SETTINGS / sizeof *SETTINGS };

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int slice(const char *name, pf_mesh *m)
{
    pf_error err = {0};
    pf_surface s = {0};
    pf_status st;
    if (strcmp(name, "sphere") == 0)
        st = pf_surface_make_sphere(&s, 1, 8, 16, &err);
    else if (strcmp(name, "sphere32") == 0)
        st = pf_surface_make_sphere(&s, 1, 32, 64, &err);
    else if (strcmp(name, "torus") == 0)
        st = pf_surface_make_torus(&s, 1, 0.35, 32, 16, &err);
    else
        st = pf_import_surface(PF_MODELS_DIR "/bunny.obj", &s, &err);
    if (st != PF_OK) {
        fprintf(stderr, "bench_sliced: %s: %s\n", name, err.msg);
        return -1;
    }
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = 6;
    st = pf_mesh_slice(m, &s, &p, NULL, &err);
    pf_surface_release(&s);
    if (st == PF_OK)
        st = pf_mesh_derive(m, &err);
    if (st != PF_OK) {
        fprintf(stderr, "bench_sliced: slicing %s: %s\n", name, err.msg);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    bool summary = argc > 1 && strcmp(argv[1], "summary") == 0;
    const char *meshes[] = {"sphere", "sphere32", "torus", "bunny"};
    char machine[256];
    bench_describe_machine(machine, sizeof machine);
    printf("# harmonic functions on sliced cells against the sampling settings; %s\n", machine);
    if (summary)
        printf("mesh,setting,xi,grading,patch_angle,cells,median_error,decile_error,max_error,"
               "median_kernels,max_kernels,median_setup_ms,max_setup_ms,cpu_seconds\n");
    else
        printf("mesh,setting,xi,grading,patch_angle,element,nodes,faces,kernels,setup_ms,"
               "boundary_error\n");
    for (int mi = 0; mi < 4; ++mi) {
        bool wanted = argc <= 2;
        for (int a = 2; a < argc; ++a)
            wanted = wanted || strcmp(argv[a], meshes[mi]) == 0;
        if (!wanted)
            continue;
        pf_mesh m = {0};
        if (slice(meshes[mi], &m) != 0)
            return 1;
        for (int si = 0; si < N_SETTINGS; ++si) {
            const setting *sg = &SETTINGS[si];
            if (sg->max_kernels < 0 && strcmp(meshes[mi], "sphere32") == 0)
                continue; /* unbudgeted: single cells of the fine sphere take many minutes */
            pf_basis_params p = pf_basis_params_default();
            p.sliced = sg->sliced;
            if (sg->sliced == PF_BASIS_SLICED_ALL)
                p.xi = sg->xi;
            p.sliced_xi = sg->xi;
            p.max_kernels = sg->max_kernels;
            p.grading = sg->grading;
            p.patch_angle = sg->patch_angle;
            p.edge_samples = sg->edge_samples;
            pf_error err = {0};
            pf_basis b;
            double c0 = pf_cpu_seconds();
            if (pf_basis_create(&b, &m, &p, &err) != PF_OK) {
                fprintf(stderr, "bench_sliced: %s: %s\n", meshes[mi], err.msg);
                return 1;
            }
            double cpu = pf_cpu_seconds() - c0;
            double *be = malloc(sizeof(double) * (size_t)(b.n_elems + 1));
            double *kn = malloc(sizeof(double) * (size_t)(b.n_elems + 1));
            double *ms = malloc(sizeof(double) * (size_t)(b.n_elems + 1));
            if (!be || !kn || !ms)
                return 1;
            int32_t n = 0;
            for (int32_t e = 0; e < b.n_elems; ++e) {
                const pf_basis_elem_stats *st = &b.stats[e];
                if (b.kind[e] != PF_BASIS_HARMONIC)
                    continue;
                be[n] = st->boundary_error, kn[n] = st->n_kernels, ms[n] = st->setup_ms, ++n;
                if (!summary)
                    printf("%s,%s,%g,%g,%g,%d,%d,%d,%d,%.3f,%.6f\n", meshes[mi], sg->name, sg->xi,
                           sg->grading, sg->patch_angle, (int)e, (int)st->n_nodes, (int)st->n_faces,
                           (int)st->n_kernels, st->setup_ms, st->boundary_error);
            }
            if (summary && n > 0) {
                qsort(be, (size_t)n, sizeof *be, cmp);
                qsort(kn, (size_t)n, sizeof *kn, cmp);
                qsort(ms, (size_t)n, sizeof *ms, cmp);
                printf("%s,%s,%g,%g,%g,%d,%.5f,%.5f,%.5f,%g,%g,%.3f,%.3f,%.2f\n", meshes[mi],
                       sg->name, sg->xi, sg->grading, sg->patch_angle, (int)n, be[n / 2],
                       be[(9 * n) / 10], be[n - 1], kn[n / 2], kn[n - 1], ms[n / 2], ms[n - 1],
                       cpu);
            }
            fflush(stdout);
            free(be);
            free(kn);
            free(ms);
            pf_basis_release(&b);
        }
        pf_mesh_release(&m);
    }
    return 0;
}
