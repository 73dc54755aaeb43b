/* Harmonic basis setup: time and boundary error per element against cell complexity.
 *
 *   bench_basis            CSV per element on stdout:
 *                          mesh,element,kind,faces,nodes,kernels,collocation,setup_ms,boundary_error
 *   bench_basis sweep      CSV per parameter set over the coarse meshes and the cube (the paper's
 * fig. 3 question: how sensitive are the functions to xi and to the kernel count?):
 *                          xi,edge_samples,face_spacing,median_kernels,median_setup_ms,
 *                          median_boundary_error,max_boundary_error
 *   bench_basis cost       CSV per edge_samples (1-6) over the harmonic cells of up to 16 nodes
 *                          of the finer meshes (the set-up target's cells): what an error costs
 *                          edge_samples,median_kernels,median_setup_ms,median_boundary_error,
 *                          max_boundary_error
 *
 * Meshes: a sphere and a torus sliced by pf_mesh_slice at two resolutions (cells cut by the
 * surface are general convex / non-convex polyhedra with 5-30 nodes), and the unit cube with MFS
 * forced (the reference cell). One core, wall clock of pf_basis_create per element. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/basis.h>
#include <pf/mesh.h>

typedef struct scenario {
    const char *name;
    pf_mesh m;
    bool force;
} scenario;

static int make_scenarios(scenario *s)
{
    pf_error err = {0};
    int n = 0;
    const int res[2] = {4, 8};
    for (int r = 0; r < 2; ++r) {
        pf_surface sf = {0};
        pf_slice_params p = pf_slice_params_default();
        p.grid.res = res[r];
        if (pf_surface_make_sphere(&sf, 1, 16, 32, &err) != PF_OK)
            return -1;
        s[n].name = r ? "sphere8" : "sphere4";
        if (pf_mesh_slice(&s[n].m, &sf, &p, NULL, &err) != PF_OK)
            return -1;
        pf_surface_release(&sf);
        ++n;
        if (pf_surface_make_torus(&sf, 1, 0.4, 32, 16, &err) != PF_OK)
            return -1;
        s[n].name = r ? "torus8" : "torus4";
        if (pf_mesh_slice(&s[n].m, &sf, &p, NULL, &err) != PF_OK)
            return -1;
        pf_surface_release(&sf);
        ++n;
    }
    s[n].name = "cube_mfs";
    s[n].force = true;
    if (pf_mesh_make_box(&s[n].m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 1, 1, 1, &err) != PF_OK)
        return -1;
    ++n;
    for (int i = 0; i < n; ++i)
        if (pf_mesh_derive(&s[i].m, &err) != PF_OK)
            return -1;
    return n;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Medians of the kernel count, set-up time and boundary error, and the largest boundary error,
 * over the harmonic cells of at most max_nodes nodes of the coarse (fine = false) or the fine
 * meshes and the cube, built with p. */
typedef struct medians {
    double kernels, setup_ms, boundary, max_boundary;
} medians;

static medians measure(scenario *s, int ns, pf_basis_params p, bool fine, int32_t max_nodes)
{
    static double k[100000], t[100000], be[100000];
    int n = 0;
    medians out = {0};
    for (int i = 0; i < ns; ++i) {
        if ((strchr(s[i].name, '8') != NULL) != fine)
            continue;
        pf_error err = {0};
        pf_basis bs;
        p.force_mfs = s[i].force;
        if (pf_basis_create(&bs, &s[i].m, &p, &err) != PF_OK) {
            fprintf(stderr, "bench_basis: %s\n", err.msg);
            exit(1);
        }
        for (int32_t e = 0; e < bs.n_elems && n < 100000; ++e)
            if (bs.kind[e] == PF_BASIS_HARMONIC && bs.stats[e].n_nodes <= max_nodes) {
                k[n] = bs.stats[e].n_kernels;
                t[n] = bs.stats[e].setup_ms;
                be[n] = bs.stats[e].boundary_error;
                out.max_boundary = fmax(out.max_boundary, be[n]);
                ++n;
            }
        pf_basis_release(&bs);
    }
    qsort(k, (size_t)n, sizeof *k, cmp);
    qsort(t, (size_t)n, sizeof *t, cmp);
    qsort(be, (size_t)n, sizeof *be, cmp);
    out.kernels = k[n / 2], out.setup_ms = t[n / 2], out.boundary = be[n / 2];
    return out;
}

static void sweep(scenario *s, int ns)
{
    printf("xi,edge_samples,face_spacing,median_kernels,median_setup_ms,median_boundary_error,"
           "max_boundary_error\n");
    const double xis[] = {0.05, 0.1, 0.2};
    const int edges[] = {2, 3, 4, 5};
    const double fsps[] = {1, 1.5, 2};
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 4; ++b)
            for (int c = 0; c < 3; ++c) {
                pf_basis_params p = pf_basis_params_default();
                p.xi = xis[a];
                p.edge_samples = edges[b];
                p.face_spacing = fsps[c];
                /* the coarse meshes only: 36 parameter sets */
                medians r = measure(s, ns, p, false, PF_BASIS_MAX_NODES);
                printf("%g,%d,%g,%g,%.4f,%.5f,%.5f\n", p.xi, (int)p.edge_samples, p.face_spacing,
                       r.kernels, r.setup_ms, r.boundary, r.max_boundary);
                fflush(stdout);
            }
}

/* Medians over the harmonic cells of at most 16 nodes of the res-8 meshes, per edge_samples. */
static void cost(scenario *s, int ns)
{
    printf(
        "edge_samples,median_kernels,median_setup_ms,median_boundary_error,max_boundary_error\n");
    for (int32_t es = 1; es <= 6; ++es) {
        pf_basis_params p = pf_basis_params_default();
        p.edge_samples = es;
        medians r = measure(s, ns, p, true, 16);
        printf("%d,%g,%.4f,%.5f,%.5f\n", (int)es, r.kernels, r.setup_ms, r.boundary,
               r.max_boundary);
        fflush(stdout);
    }
}

int main(int argc, char **argv)
{
    scenario s[8];
    memset(s, 0, sizeof s);
    int ns = make_scenarios(s);
    if (ns < 0) {
        fprintf(stderr, "bench_basis: could not build the meshes\n");
        return 1;
    }
    if (argc > 1 && strcmp(argv[1], "sweep") == 0) {
        sweep(s, ns);
    } else if (argc > 1 && strcmp(argv[1], "cost") == 0) {
        cost(s, ns);
    } else {
        printf("mesh,element,kind,faces,nodes,kernels,collocation,setup_ms,boundary_error\n");
        for (int i = 0; i < ns; ++i) {
            pf_error err = {0};
            pf_basis bs;
            pf_basis_params p = pf_basis_params_default();
            p.force_mfs = s[i].force;
            if (pf_basis_create(&bs, &s[i].m, &p, &err) != PF_OK) {
                fprintf(stderr, "bench_basis: %s: %s\n", s[i].name, err.msg);
                return 1;
            }
            for (int32_t e = 0; e < bs.n_elems; ++e) {
                const pf_basis_elem_stats *st = &bs.stats[e];
                printf("%s,%d,%s,%d,%d,%d,%d,%.4f,%.6f\n", s[i].name, (int)e,
                       pf_basis_kind_name((pf_basis_kind)bs.kind[e]), (int)st->n_faces,
                       (int)st->n_nodes, (int)st->n_kernels, (int)st->n_collocation, st->setup_ms,
                       st->boundary_error);
            }
            pf_basis_release(&bs);
        }
    }
    for (int i = 0; i < ns; ++i)
        pf_mesh_release(&s[i].m);
    return 0;
}
