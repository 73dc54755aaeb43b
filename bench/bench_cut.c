/* Cutting (pf_mesh_cut, pf_sim_cut, the scene's "cuts"; issue 16).
 *
 *   bench_cut table           CSV per mesh and method: the cost of a cut per split element, as
 *                             the harmonic paper's table 1 gives it (t_init: ms to compute the
 *                             shape functions and stiffness of a polyhedral element): "bar", its
 *                             Bar Cut (the 5 x 1 x 1 bar of 10 x 2 x 2 hexes, 99 nodes / 40
 *                             elements -> 391 / 63; here four oblique planes), and "tets", its
 *                             Dino Cut (5.6k nodes / 19k tets -> 9.3k / 21k; here a Kuhn box of
 *                             24 x 12 x 11 cells, 3.9k nodes / 19k tets, cut by three oblique
 *                             planes). The cuts are made one after the other: method "mesh" is
 *                             pf_mesh_cut alone (the new mesh); "dg" (degree 1) and "cg" are
 *                             pf_sim_cut on a simulator of the mesh, the whole transaction, with
 *                             its parts (new mesh and the rest, the method on the new mesh,
 *                             the rest of the set-up, state transfer), the fraction of DG
 *                             integrals copied instead of computed over the cuts, CG's harmonic
 *                             and closed-form elements after, and the paper's t_init over our ms
 *                             per split element (the paper's figure is CG's: compare the cg row):
 *                             mesh,method,elems_before,nodes_before,elems_after,nodes_after,cuts,
 *                             split_elems,ms_per_split,mesh_ms,method_ms,setup_ms,transfer_ms,
 *                             reused,harmonic,closed_form,paper_ms,paper_over_ours
 *   bench_cut steps           CSV per mesh and method (bar and the 1.2k tets, DG degree 1 and CG):
 *                             CPU ms per step over 10 frames of a clamped mesh sagging under
 *                             gravity, then the table's planes, the first frame after (its
 *                             factorisation), and 10 frames more; the factorisations in the
 *                             steps before and after (not counting the first frame after):
 *                             mesh,method,elems_before,elems_after,bodies,steps,
 *                             ms_per_step_before,first_frame_ms_per_step,ms_per_step_after,
 *                             after_over_before,factorisations_before,factorisations_after
 *   bench_cut progressive     CSV per frame: a blade (the scene's "cuts") sweeping down through
 *                             a bar of 13 x 8 x 8 Kuhn cells (4,992 tets) clamped at x = 0 and
 *                             sagging under gravity, DG degree 1, one step per frame, 24 frames
 *                             (with "large": 17 x 11 x 11 cells, 12,342 tets, about 4 CPU
 *                             minutes: bench/results/cut_progressive_large.csv): elements, nodes,
 *                             elements split after the frame, its cut's CPU ms (search, cut, new
 *                             set-up, transfer), the frame's CPU ms per step, the factorisations
 *                             in it (a step after a cut factorises anew), their CPU ms, PCG
 *                             iterations, bodies after the frame:
 *                             frame,elems,nodes,split,cut_ms,step_ms,factorisations,factor_ms,
 *                             pcg_iterations,bodies
 *   any of them ... quick     smaller cases (a check that the program runs)
 *
 * Timings are CPU seconds of the process (pf_sim_stats' parts, bench_cpu_seconds around calls),
 * so that a busy machine biases them little; the first line says what machine and load they were
 * taken on, the last (a comment) the CPU and wall seconds of the whole run. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/cut.h>
#include <pf/sim.h>

#include "machine.h"

/* The harmonic paper's table 1, t_init (ms per polyhedral element, Core2 Duo 2.4 GHz). */
static const double PAPER_BAR_MS = 688, PAPER_DINO_MS = 48;

static int fail(const pf_error *err)
{
    fprintf(stderr, "bench_cut: %s\n", err->msg);
    return 1;
}

/* A mesh to cut and the planes that cut it, one after the other. */
typedef struct cut_case {
    const char *name;
    bool tets;
    int nx, ny, nz;
    pf_vec3 hi; /* the box [0, hi] */
    int n_planes;
    pf_vec3 point[4], normal[4];
    double paper_ms;
} cut_case;

static cut_case bar_case(void)
{
    return (cut_case){.name = "bar",
                      .nx = 10,
                      .ny = 2,
                      .nz = 2,
                      .hi = {5, 1, 1},
                      .n_planes = 4,
                      .point = {{1.3, 0.5, 0.5}, {2.6, 0.5, 0.5}, {3.8, 0.5, 0.5}, {4.4, 0.5, 0.5}},
                      .normal = {{1, 0.3, 0.2}, {1, -0.4, 0.3}, {0.5, 0.2, -1}, {1, 0.6, -0.5}},
                      .paper_ms = PAPER_BAR_MS};
}

/* Kuhn tets of nx * ny * nz cells of side 0.1 cut by two oblique planes through thirds of x. */
static cut_case tets_case(int nx, int ny, int nz)
{
    double lx = 0.1 * nx, ly = 0.1 * ny, lz = 0.1 * nz;
    return (cut_case){.name = "tets",
                      .tets = true,
                      .nx = nx,
                      .ny = ny,
                      .nz = nz,
                      .hi = {lx, ly, lz},
                      .n_planes = 3,
                      .point = {{0.37 * lx, 0.5 * ly, 0.5 * lz},
                                {0.68 * lx, 0.5 * ly, 0.5 * lz},
                                {0.16 * lx, 0.5 * ly, 0.5 * lz}},
                      .normal = {{1, 0.35, 0.25}, {1, -0.3, 0.4}, {1, 0.2, -0.3}},
                      .paper_ms = PAPER_DINO_MS};
}

static pf_status make_mesh(const cut_case *c, pf_mesh *m, pf_error *err)
{
    pf_vec3 lo = pf_v3(0, 0, 0);
    PF_TRY(c->tets ? pf_mesh_make_box_tets(m, lo, c->hi, c->nx, c->ny, c->nz, err)
                   : pf_mesh_make_box(m, lo, c->hi, c->nx, c->ny, c->nz, err));
    return pf_mesh_derive(m, err);
}

/* The elements of m with nodes strictly on both sides of the plane (beyond 1e-9 of the mesh's
 * size), each with that plane: req[*k] (req holds m->n_elems). */
static void plane_requests(const pf_mesh *m, pf_vec3 point, pf_vec3 normal, pf_cut_request *req,
                           int32_t *k)
{
    pf_plane pl = {pf_v3_normalize(normal), 0};
    pl.d = pf_v3_dot(pl.n, point);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    double tol = 1e-9 * pf_v3_dist(lo, hi);
    *k = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        bool below = false, above = false;
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
                double s = pf_v3_dot(pl.n, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j])) - pl.d;
                below |= s<-tol, above |= s> tol;
            }
        }
        if (below && above)
            req[(*k)++] = (pf_cut_request){.elem = e, .plane = pl};
    }
}

/* pf_mesh_cut alone: the case's planes one after the other, each cut's opened faces carried into
 * the next. */
static int table_mesh(const cut_case *c)
{
    pf_error err = {0};
    pf_mesh m = {0}, next = {0};
    if (make_mesh(c, &m, &err) < 0)
        return fail(&err);
    int32_t n0 = m.n_elems, nodes0 = m.n_nodes;
    int64_t split = 0;
    double cpu = 0;
    uint8_t *cut_face = NULL;
    pf_status st = PF_OK;
    for (int i = 0; i < c->n_planes && st >= 0; ++i) {
        pf_cut_request *req = pf_alloc_array((size_t)m.n_elems + 1, sizeof *req);
        if (!req) {
            st = pf_error_set(&err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
            break;
        }
        int32_t k = 0;
        plane_requests(&m, c->point[i], c->normal[i], req, &k);
        pf_cut_params p = {.src_cut_face = cut_face};
        pf_cut_result r = {0};
        double c0 = bench_cpu_seconds();
        st = pf_mesh_cut(&m, req, k, &p, &next, &r, &err);
        cpu += bench_cpu_seconds() - c0;
        pf_free(req);
        if (st < 0)
            break;
        split += r.n_split;
        pf_free(cut_face);
        cut_face = r.cut_face; /* kept for the next cut */
        r.cut_face = NULL;
        pf_cut_result_release(&r);
        pf_mesh_release(&m);
        m = next;
        next = (pf_mesh){0};
    }
    pf_free(cut_face);
    if (st < 0) {
        pf_mesh_release(&m);
        return fail(&err);
    }
    double ms = split > 0 ? 1e3 * cpu / (double)split : 0;
    printf("%s,mesh,%d,%d,%d,%d,%d,%lld,%.4f,%.4f,0,0,0,0,0,0,%g,%.1f\n", c->name, (int)n0,
           (int)nodes0, (int)m.n_elems, (int)m.n_nodes, c->n_planes, (long long)split, ms, ms,
           c->paper_ms, ms > 0 ? c->paper_ms / ms : 0.0);
    fflush(stdout);
    pf_mesh_release(&m);
    return 0;
}

/* The bar and the tets clamped at x = 0, sagging under gravity, no ground. */
static const char SCENE[] = "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, "
                            "0]}}], \"ground\": false, \"material\": {\"E\": 1e6},"
                            " \"damping\": {\"beta\": 0.02}}";

static pf_status make_sim(const cut_case *c, bool cg, pf_mesh *m, pf_scene *sc, pf_sim **sim,
                          pf_error *err)
{
    PF_TRY(make_mesh(c, m, err));
    PF_TRY(pf_scene_parse(sc, SCENE, strlen(SCENE), "bench.json", err));
    sc->method = cg ? PF_METHOD_CG : PF_METHOD_DG;
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(sc, lo, hi);
    return pf_sim_create(sim, sc, m, err);
}

/* The case's planes cut the simulator's mesh one after the other (pf_sim_cut); *split the
 * elements split, *cpu the CPU seconds of the calls. */
static pf_status sim_cuts(pf_sim *sim, const cut_case *c, int64_t *split, double *cpu,
                          pf_error *err)
{
    *split = 0, *cpu = 0;
    for (int i = 0; i < c->n_planes; ++i) {
        const pf_mesh *m = pf_sim_mesh(sim);
        pf_cut_request *req = pf_alloc_array((size_t)m->n_elems + 1, sizeof *req);
        PF_CHECK(req, err, PF_ERR_NOMEM, "out of memory");
        int32_t k = 0;
        plane_requests(m, c->point[i], c->normal[i], req, &k);
        pf_cut_result r = {0};
        double c0 = bench_cpu_seconds();
        pf_status st = pf_sim_cut(sim, req, k, &r, err);
        *cpu += bench_cpu_seconds() - c0;
        pf_free(req);
        PF_TRY(st);
        *split += r.n_split;
        pf_cut_result_release(&r);
    }
    return PF_OK;
}

static int table_sim(const cut_case *c, bool cg)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_scene sc = {0};
    pf_sim *sim = NULL;
    int64_t split = 0;
    double cpu = 0;
    pf_sim_stats s0 = {0}, s1 = {0};
    pf_status st = make_sim(c, cg, &m, &sc, &sim, &err);
    if (st >= 0) {
        s0 = *pf_sim_get_stats(sim);
        st = sim_cuts(sim, c, &split, &cpu, &err);
    }
    if (st < 0) {
        pf_sim_destroy(&sim);
        pf_scene_release(&sc);
        pf_mesh_release(&m);
        return fail(&err);
    }
    s1 = *pf_sim_get_stats(sim);
    const pf_mesh *now = pf_sim_mesh(sim);
    double per = split > 0 ? 1e3 / (double)split : 0, ms = per * cpu;
    /* the new mesh: the transaction's time less its parts */
    double method = s1.refine_method_seconds - s0.refine_method_seconds;
    double setup = s1.refine_setup_seconds - s0.refine_setup_seconds;
    double transfer = s1.refine_transfer_seconds - s0.refine_transfer_seconds;
    int64_t reused = s1.integrals_reused - s0.integrals_reused;
    int64_t computed = s1.integrals_computed - s0.integrals_computed;
    printf("%s,%s,%d,%d,%d,%d,%d,%lld,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d,%d,%g,%.1f\n", c->name,
           cg ? "cg" : "dg", (int)m.n_elems, (int)m.n_nodes, (int)now->n_elems, (int)now->n_nodes,
           c->n_planes, (long long)split, ms, per * (cpu - method - setup - transfer), per * method,
           per * setup, per * transfer,
           cg || reused + computed == 0 ? 0.0 : (double)reused / (double)(reused + computed),
           (int)s1.harmonic_elems, (int)s1.closed_form_elems, c->paper_ms,
           ms > 0 ? c->paper_ms / ms : 0.0);
    fflush(stdout);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return 0;
}

static int table(bool quick)
{
    printf("mesh,method,elems_before,nodes_before,elems_after,nodes_after,cuts,split_elems,"
           "ms_per_split,mesh_ms,method_ms,setup_ms,transfer_ms,reused,harmonic,closed_form,"
           "paper_ms,paper_over_ours\n");
    cut_case cases[2] = {bar_case(), quick ? tets_case(4, 3, 3) : tets_case(24, 12, 11)};
    for (int i = 0; i < 2; ++i)
        for (int method = 0; method < 3; ++method)
            if (method == 0 ? table_mesh(&cases[i]) : table_sim(&cases[i], method == 2))
                return 1;
    return 0;
}

/* CPU ms per step over frames frames, and the factorisations in them. */
static pf_status ms_per_step(pf_sim *sim, const pf_scene *sc, int frames, double *ms,
                             int64_t *factorisations, pf_error *err)
{
    int64_t f0 = pf_sim_get_stats(sim)->solver.factorisations;
    double c0 = bench_cpu_seconds();
    for (int f = 0; f < frames; ++f)
        PF_TRY(pf_sim_frame(sim, err));
    *ms = 1e3 * (bench_cpu_seconds() - c0) / (frames * sc->substeps);
    *factorisations = pf_sim_get_stats(sim)->solver.factorisations - f0;
    return PF_OK;
}

static int steps_case(const cut_case *c, bool cg, bool quick)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_scene sc = {0};
    pf_sim *sim = NULL;
    int frames = quick ? 2 : 10;
    int64_t split = 0, fb = 0, ff = 0, fa = 0;
    double before = 0, first = 0, after = 0, cpu = 0;
    pf_status st = make_sim(c, cg, &m, &sc, &sim, &err);
    if (st >= 0)
        st = ms_per_step(sim, &sc, frames, &before, &fb, &err);
    if (st >= 0)
        st = sim_cuts(sim, c, &split, &cpu, &err);
    if (st >= 0)
        st = ms_per_step(sim, &sc, 1, &first, &ff, &err);
    if (st >= 0)
        st = ms_per_step(sim, &sc, frames, &after, &fa, &err);
    if (st >= 0) {
        int steps = frames * sc.substeps;
        printf("%s,%s,%d,%d,%d,%d,%.3f,%.3f,%.3f,%.2f,%lld,%lld\n", c->name, cg ? "cg" : "dg",
               (int)m.n_elems, (int)pf_sim_mesh(sim)->n_elems, (int)pf_sim_get_stats(sim)->bodies,
               steps, before, first, after, before > 0 ? after / before : 0.0, (long long)fb,
               (long long)fa);
        fflush(stdout);
    }
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return st < 0 ? fail(&err) : 0;
}

static int steps(bool quick)
{
    printf("mesh,method,elems_before,elems_after,bodies,steps,ms_per_step_before,"
           "first_frame_ms_per_step,ms_per_step_after,after_over_before,factorisations_before,"
           "factorisations_after\n");
    cut_case cases[2] = {bar_case(), quick ? tets_case(4, 3, 3) : tets_case(8, 5, 5)};
    for (int i = 0; i < 2; ++i)
        for (int cg = 0; cg < 2; ++cg)
            if (steps_case(&cases[i], cg, quick))
                return 1;
    return 0;
}

/* A blade across the bar (y from -0.1 to its width + 0.1), a little tilted, sweeping down from
 * above it to below it between a tenth and four fifths of the run. */
static int progressive(bool quick, bool large)
{
    pf_error err = {0};
    pf_mesh m = {0};
    pf_scene sc = {0};
    pf_sim *sim = NULL;
    int nx = quick ? 6 : large ? 17 : 13, nyz = quick ? 4 : large ? 11 : 8;
    int frames = quick ? 8 : 24;
    double lx = 0.1 * nx, l = 0.1 * nyz, x = 0.63 * lx;
    char json[1024];
    snprintf(json, sizeof json,
             "{\"fixed\": [{\"plane\": {\"point\": [0, 0, 0], \"normal\": [1, 0, 0]}}],"
             " \"ground\": false, \"material\": {\"E\": 1e6}, \"damping\": {\"beta\": 0.02},"
             " \"method\": {\"name\": \"dg\", \"degree\": 1},"
             " \"time\": {\"dt\": %.17g, \"frames\": %d, \"substeps\": 1},"
             " \"cuts\": [{\"blade\": [[%.17g, -0.1, %.17g], [%.17g, %.17g, %.17g]],"
             " \"path\": [{\"time\": %.17g, \"translation\": [0, 0, 0]},"
             " {\"time\": %.17g, \"translation\": [0, 0, %.17g]}]}]}",
             1.0 / 30, frames, x - 0.02, l + 0.05, x + 0.02, l + 0.1, l + 0.05, 0.1 * frames / 30.0,
             0.8 * frames / 30.0, -(l + 0.2));
    pf_status st = pf_mesh_make_box_tets(&m, pf_v3(0, 0, 0), pf_v3(lx, l, l), nx, nyz, nyz, &err);
    if (st >= 0)
        st = pf_mesh_derive(&m, &err);
    if (st >= 0)
        st = pf_scene_parse(&sc, json, strlen(json), "bench.json", &err);
    if (st >= 0) {
        pf_vec3 lo, hi;
        pf_mesh_bounds(&m, &lo, &hi);
        pf_scene_resolve(&sc, lo, hi);
        st = pf_sim_create(&sim, &sc, &m, &err);
    }
    if (st >= 0)
        printf("frame,elems,nodes,split,cut_ms,step_ms,factorisations,factor_ms,pcg_iterations,"
               "bodies\n");
    for (int f = 1; st >= 0 && f <= frames; ++f) {
        pf_sim_stats s0 = *pf_sim_get_stats(sim);
        double c0 = bench_cpu_seconds();
        st = pf_sim_frame(sim, &err);
        double cpu = bench_cpu_seconds() - c0;
        if (st < 0)
            break;
        const pf_sim_stats *s1 = pf_sim_get_stats(sim);
        const pf_mesh *now = pf_sim_mesh(sim);
        double cut = s1->cut_seconds - s0.cut_seconds;
        printf("%d,%d,%d,%lld,%.3f,%.3f,%lld,%.3f,%lld,%d\n", f, (int)now->n_elems,
               (int)now->n_nodes, (long long)(s1->elements_cut - s0.elements_cut), 1e3 * cut,
               1e3 * (cpu - cut) / sc.substeps,
               (long long)(s1->solver.factorisations - s0.solver.factorisations),
               1e3 * (s1->solver.factor_cpu_seconds - s0.solver.factor_cpu_seconds),
               (long long)(s1->solver.iterations - s0.solver.iterations), (int)s1->bodies);
        fflush(stdout);
    }
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    return st < 0 ? fail(&err) : 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("usage: bench_cut table|steps|progressive [quick|large]\n"
               "large: a larger mesh for progressive\n"
               "CSV on stdout (see the comment at the top of bench/bench_cut.c); plot with\n"
               "gnuplot bench/cut.gp\n");
        return 0;
    }
    const char *mode = argc > 1 ? argv[1] : "table";
    bool quick = argc > 2 && !strcmp(argv[2], "quick");
    bool large = argc > 2 && !strcmp(argv[2], "large");
    char machine[256];
    bench_describe_machine(machine, sizeof machine);
    printf("# cutting; %s\n", machine);
    double w0 = pf_time_seconds(), c0 = bench_cpu_seconds();
    int rc = 2;
    if (!strcmp(mode, "table"))
        rc = table(quick);
    else if (!strcmp(mode, "steps"))
        rc = steps(quick);
    else if (!strcmp(mode, "progressive"))
        rc = progressive(quick, large);
    else
        fprintf(stderr, "usage: bench_cut table|steps|progressive [quick|large]\n");
    if (rc == 0)
        printf("# %.1f CPU s, %.1f wall s\n", bench_cpu_seconds() - c0, pf_time_seconds() - w0);
    return rc;
}
