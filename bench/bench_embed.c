/* Embedding weights: time against surface vertices and mesh size, both methods.
 *
 * A sphere of radius 0.45 (its vertex count set by the bands) embedded in a hex grid of n^3
 * cells over [-0.5, 0.5]^3. CSV on stdout: method, cells, nodes, vertices, seconds, entries,
 * microseconds per vertex. Usage: bench_embed [max_vertices] (default 2000000). */
#include <stdio.h>
#include <stdlib.h>

#include <pf/embed.h>
#include <pf/mesh.h>

int main(int argc, char **argv)
{
    long max_verts = argc > 1 ? strtol(argv[1], NULL, 10) : 2000000;
    static const int cells[] = {8, 16, 32};
    static const int bands[] = {71, 224, 708}; /* 2 bands^2 vertices: 10k, 100k, 1M */
    pf_error err = {0};
    printf("method,cells,nodes,vertices,seconds,entries,us_per_vertex\n");
    for (int c = 0; c < 3; ++c) {
        pf_mesh m = {0};
        if (pf_mesh_make_box(&m, pf_v3(-0.5, -0.5, -0.5), pf_v3(0.5, 0.5, 0.5), cells[c],
                             cells[c], cells[c], &err) < 0 ||
            pf_mesh_derive(&m, &err) < 0) {
            fprintf(stderr, "bench_embed: %s\n", err.msg);
            return 1;
        }
        for (int b = 0; b < 3; ++b) {
            if (2L * bands[b] * bands[b] > max_verts)
                continue;
            pf_surface s = {0};
            if (pf_surface_make_sphere(&s, 0.45, bands[b], 2 * bands[b], &err) < 0) {
                fprintf(stderr, "bench_embed: %s\n", err.msg);
                return 1;
            }
            for (int method = 0; method < 2; ++method) {
                pf_embed_params p = pf_embed_params_default();
                p.method = (pf_embed_method)method;
                pf_weights w = {0};
                pf_embed_stats st;
                if (pf_embed_compute(&m, &s, &p, &w, &st, &err) < 0) {
                    fprintf(stderr, "bench_embed: %s\n", err.msg);
                    return 1;
                }
                printf("%s,%d,%d,%d,%.4f,%lld,%.3f\n", pf_embed_method_name(p.method),
                       cells[c] * cells[c] * cells[c], (int)m.n_nodes, (int)s.n_verts,
                       st.seconds, (long long)st.nnz, 1e6 * st.seconds / s.n_verts);
                fflush(stdout);
                pf_weights_release(&w);
            }
            pf_surface_release(&s);
        }
        pf_mesh_release(&m);
    }
    return 0;
}
