/* Penalty contact: cost per step against obstacle size and embedded-surface size, and one scene
 * with a large embedded surface split into solve, contact and embedding.
 *
 * Usage: bench_contact sweep   CSV: case, elements, obstacle_triangles, surface_vertices,
 *                              contact_points, contacts_per_step, contact_ms, embed_ms (per step)
 *        bench_contact scene [vertices]  (default 200000) CSV: one row: elements, unknowns,
 *                              vertices, steps, contacts_per_step, setup_s, growths,
 *                              solve_ms (factorisation + solves), assemble_ms, contact_ms,
 *                              embed_ms (per step), embed_weights_s
 *
 * sweep: a unit cube of 6^3 hexes, DG degree 1, corotated, 4 steps. "obstacle": its boundary
 * nodes against a sphere mesh obstacle (radius 2) of 360 .. 400k triangles whose top cap the
 * cube's bottom already presses 0.03 deep; "surface": the vertices of an embedded sphere of 1k ..
 * 200k vertices (MLS weights) against a plane obstacle its bottom presses. scene: a sphere surface
 * of the given vertex count voxelized at 16 cells (about 2k hexes), MLS weights, on a ground plane
 * 0.2 % of its size above its lowest point, 3 steps. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/embed.h>
#include <pf/mesh.h>
#include <pf/sim.h>

static int fail(const pf_error *err)
{
    fprintf(stderr, "bench_contact: %s\n", err->msg);
    return 1;
}

static void base_scene(pf_scene *sc, int substeps)
{
    pf_scene_default(sc);
    sc->ground = false;
    sc->frames = 1;
    sc->substeps = substeps;
}

/* One frame of the scene; per-step stats out. */
static pf_status run(const pf_scene *sc, const pf_mesh *m, const pf_surface *s, const pf_weights *w,
                     pf_sim_stats *out, pf_error *err)
{
    pf_sim *sim = NULL;
    PF_TRY(pf_sim_create_embedded(&sim, sc, m, s, w, err));
    pf_status st = pf_sim_frame(sim, err);
    *out = *pf_sim_get_stats(sim);
    pf_sim_destroy(&sim);
    return st;
}

static int sweep(void)
{
    pf_error err = {0};
    pf_mesh m = {0};
    if (pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 6, 6, 6, &err) < 0)
        return fail(&err);
    printf("case,elements,obstacle_triangles,surface_vertices,contact_points,contacts_per_step,"
           "contact_ms,embed_ms\n");
    static const int bands[] = {10, 32, 100, 316}; /* 2 n^2 triangles / n^2 vertices */
    for (int b = 0; b < 4; ++b) {
        pf_scene sc;
        base_scene(&sc, 4);
        pf_obstacle *o = pf_calloc(1, sizeof *o);
        if (!o)
            return 1;
        sc.obstacles = o;
        sc.n_obstacles = 1;
        o->kind = PF_OBSTACLE_MESH;
        if (pf_surface_make_sphere(&o->surface, 2, bands[b], 2 * bands[b], &err) < 0)
            return fail(&err);
        for (int32_t i = 0; i < o->surface.n_verts; ++i) {
            o->surface.x[3 * i] += 0.5;
            o->surface.x[3 * i + 1] += 0.5;
            o->surface.x[3 * i + 2] += -1.97;
        }
        pf_scene_resolve(&sc, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
        pf_sim_stats st;
        if (run(&sc, &m, NULL, NULL, &st, &err) < 0)
            return fail(&err);
        printf("obstacle,%d,%d,0,%d,%.1f,%.4f,%.4f\n", (int)m.n_elems, (int)o->surface.n_tris,
               (int)st.contact_points, (double)st.contacts / st.steps,
               1e3 * st.contact_seconds / st.steps, 1e3 * st.embed_seconds / st.steps);
        fflush(stdout);
        pf_scene_release(&sc);
    }
    static const int verts[] = {22, 71, 224, 316}; /* 2 n^2 vertices: 1k, 10k, 100k, 200k */
    for (int b = 0; b < 4; ++b) {
        pf_surface s = {0};
        if (pf_surface_make_sphere(&s, 0.45, verts[b], 2 * verts[b], &err) < 0)
            return fail(&err);
        for (int32_t i = 0; i < s.n_verts; ++i)
            for (int c = 0; c < 3; ++c)
                s.x[3 * i + c] += 0.5;
        pf_weights w = {0};
        if (pf_embed_compute(&m, &s, NULL, &w, NULL, &err) < 0)
            return fail(&err);
        pf_scene sc;
        base_scene(&sc, 4);
        pf_obstacle *o = pf_calloc(1, sizeof *o);
        if (!o)
            return 1;
        sc.obstacles = o;
        sc.n_obstacles = 1;
        o->kind = PF_OBSTACLE_PLANE;
        o->point = pf_v3(0, 0, 0.06);
        o->normal = pf_v3(0, 0, 1);
        pf_scene_resolve(&sc, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
        pf_sim_stats st;
        if (run(&sc, &m, &s, &w, &st, &err) < 0)
            return fail(&err);
        printf("surface,%d,0,%d,%d,%.1f,%.4f,%.4f\n", (int)m.n_elems, (int)s.n_verts,
               (int)st.contact_points, (double)st.contacts / st.steps,
               1e3 * st.contact_seconds / st.steps, 1e3 * st.embed_seconds / st.steps);
        fflush(stdout);
        pf_scene_release(&sc);
        pf_weights_release(&w);
        pf_surface_release(&s);
    }
    pf_mesh_release(&m);
    return 0;
}

static int scene(long vertices)
{
    pf_error err = {0};
    int n = (int)sqrt((double)vertices / 2);
    pf_surface s = {0};
    if (pf_surface_make_sphere(&s, 0.5, n, 2 * n, &err) < 0)
        return fail(&err);
    pf_mesh m = {0};
    pf_voxelize_params vp = pf_voxelize_params_default();
    vp.res = 16;
    if (pf_mesh_voxelize(&m, &s, &vp, NULL, NULL, &err) < 0)
        return fail(&err);
    pf_weights w = {0};
    pf_embed_stats es;
    if (pf_embed_compute(&m, &s, NULL, &w, &es, &err) < 0)
        return fail(&err);
    pf_scene sc;
    pf_scene_default(&sc);
    sc.frames = 1;
    sc.substeps = 3;
    sc.ground_auto = false;
    sc.ground_point = pf_v3(0, 0, -0.5 + 0.002);
    pf_vec3 lo, hi;
    pf_mesh_bounds(&m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim_stats st;
    if (run(&sc, &m, &s, &w, &st, &err) < 0)
        return fail(&err);
    printf("elements,unknowns,vertices,steps,contacts_per_step,setup_s,factorisations,solve_ms,"
           "assemble_ms,contact_ms,embed_ms,embed_weights_s\n");
    double k = 1e3 / (double)st.steps;
    printf("%d,%lld,%d,%lld,%.1f,%.3f,%d,%.2f,%.2f,%.3f,%.3f,%.3f\n", (int)m.n_elems,
           (long long)st.dofs, (int)s.n_verts, (long long)st.steps, (double)st.contacts / st.steps,
           st.setup_seconds, (int)st.factorisations, k * (st.factor_seconds + st.solve_seconds),
           k * st.assemble_seconds, k * st.contact_seconds, k * st.embed_seconds, es.seconds);
    pf_scene_release(&sc);
    pf_weights_release(&w);
    pf_mesh_release(&m);
    pf_surface_release(&s);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "sweep"))
        return sweep();
    if (argc > 1 && !strcmp(argv[1], "scene"))
        return scene(argc > 2 ? strtol(argv[2], NULL, 10) : 200000);
    fprintf(stderr, "usage: bench_contact sweep | scene [vertices]\n");
    return 2;
}
