/* The CG method (harmonic paper sec. 6): set-up cost per element, sensitivity to the MFS
 * parameters, time per corotated step.
 *
 *   bench_cg          CSV per element of sliced spheres and tori (res 4 and 8):
 *                     mesh,element,kind,convex,nodes,basis_ms,integrate_ms,setup_ms
 *                     (setup = basis + K_e and M_e; wall clock; one core when run with
 *                     OPENBLAS_NUM_THREADS=1, as bench/results/cg_setup.csv was)
 *   bench_cg sweep    CSV per MFS parameter set: the median boundary error of the sliced
 *                     sphere's harmonic cells and the cantilever's tip error against the DG
 *                     limit (the 4 x 1 x 1 beam turned by 30 degrees about z, sliced at res 9):
 *                     xi,edge_samples,median_kernels,median_boundary_error,tip,tip_error
 *   bench_cg step     CSV per mesh: time per corotated semi-implicit Euler step
 *                     mesh,elements,harmonic,dofs,assemble_ms,factor_ms,solve_ms,step_ms
 *   bench_cg refine   CSV per mesh of the cantilever (4 x 1 x 1, static, as in tests/test_cg.c):
 *                     uniform hex grids against octrees of the beam's surface (refined toward
 *                     it, coarse inside; harmonic cells where coarse meets fine) and sliced
 *                     octrees of the beam turned by 30 degrees (harmonic cut cells); the tip
 *                     error against the DG limit per DOF count (harmonic paper fig. 6 in 3D):
 *                     mesh,refine,elements,harmonic,dofs,tip,tip_error,setup_s,solve_s */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/fem.h>
#include <pf/sim.h>

static int slice_shape(pf_mesh *m, bool torus, int res)
{
    pf_error err = {0};
    pf_surface s = {0};
    pf_status st = torus ? pf_surface_make_torus(&s, 1, 0.4, 32, 16, &err)
                         : pf_surface_make_sphere(&s, 1, 16, 32, &err);
    pf_slice_params p = pf_slice_params_default();
    p.grid.res = res;
    if (st >= 0)
        st = pf_mesh_slice(m, &s, &p, NULL, &err);
    if (st >= 0)
        st = pf_mesh_derive(m, &err);
    pf_surface_release(&s);
    if (st < 0)
        fprintf(stderr, "bench_cg: %s\n", err.msg);
    return st < 0 ? -1 : 0;
}

/* Convex when no node of the element lies beyond the plane of one of its faces (1e-9 of its
 * size). */
static bool elem_convex(const pf_mesh *m, int32_t e, const pf_cg *cg)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        const uint32_t *idx = m->face_nodes + m->face_offsets[f];
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        pf_vec3 a = pf_polygon_area_vector(m->x, idx, n);
        if (m->elem_faces[q] & PF_FACE_REVERSED)
            a = pf_v3_scale(a, -1);
        pf_plane pl = pf_plane_from_point_normal(pf_v3_load(m->x + 3 * (size_t)idx[0]), a);
        for (int32_t p = 0; p < k; ++p)
            if (pf_plane_signed_distance(pl, pf_v3_load(m->x + 3 * (size_t)nodes[p])) >
                1e-9 * cg->size[e])
                return false;
    }
    return true;
}

static int per_element(void)
{
    printf("mesh,element,kind,convex,nodes,basis_ms,integrate_ms,setup_ms\n");
    const int res[2] = {4, 8};
    for (int r = 0; r < 2; ++r)
        for (int t = 0; t < 2; ++t) {
            pf_mesh m = {0};
            if (slice_shape(&m, t, res[r]) < 0)
                return 1;
            pf_cg cg;
            pf_error err = {0};
            pf_cg_params params = pf_cg_params_default();
            params.basis.no_check_stats = true; /* as pf-sim: only setup_ms is reported */
            if (pf_cg_create(&cg, &m, 1e5, 0.3, 1000, &params, &err) < 0) {
                fprintf(stderr, "bench_cg: %s\n", err.msg);
                return 1;
            }
            for (int32_t e = 0; e < m.n_elems; ++e) {
                pf_basis_kind kind = pf_basis_elem_kind(&cg.basis, e);
                double basis_ms = cg.basis.stats[e].setup_ms;
                printf("%s%d,%d,%s,%d,%d,%.4f,%.4f,%.4f\n", t ? "torus" : "sphere", res[r], (int)e,
                       pf_basis_kind_name(kind), elem_convex(&m, e, &cg) ? 1 : 0,
                       (int)pf_basis_elem_nodes(&cg.basis, e, NULL), basis_ms, cg.elem_ms[e],
                       basis_ms + cg.elem_ms[e]);
            }
            pf_cg_release(&cg);
            pf_mesh_release(&m);
        }
    return 0;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Tip deflection of the turned cantilever by the fem API with the given basis parameters: fixed
 * nodes on the end x' = 0, traction (0, 0, -1) on x' = 4, static solve. */
static double turned_cantilever(const pf_mesh *m, const pf_cg_params *params)
{
    const double angle = 30 * 3.14159265358979323846 / 180;
    pf_vec3 axis = {cos(angle), sin(angle), 0};
    pf_plane root = pf_plane_from_point_normal(pf_v3(0, 0, 0), axis);
    pf_plane tip = pf_plane_from_point_normal(pf_v3_scale(axis, 4), axis);
    pf_error err = {0};
    pf_cg cg;
    if (pf_cg_create(&cg, m, 1e5, 0.3, 1, params, &err) < 0) {
        fprintf(stderr, "bench_cg: %s\n", err.msg);
        return NAN;
    }
    uint8_t *fixed = calloc((size_t)m->n_nodes, 1);
    double *load = calloc(3 * (size_t)m->n_nodes, sizeof *load);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        fixed[i] = fabs(pf_plane_signed_distance(root, pf_v3_load(m->x + 3 * i))) < 1e-9;
    pf_boundary bd;
    pf_boundary_extract(m, &bd, &err);
    for (int32_t q = 0; q < bd.n_faces; ++q) {
        const uint32_t *idx = m->face_nodes + m->face_offsets[bd.face[q]];
        int64_t n = m->face_offsets[bd.face[q] + 1] - m->face_offsets[bd.face[q]];
        if (fabs(pf_plane_signed_distance(tip, pf_polygon_centroid(m->x, idx, n))) < 1e-9)
            pf_cg_add_traction(&cg, m, &bd, q, pf_v3(0, 0, -1), load);
    }
    pf_block_matrix k = {0};
    pf_cg_map map;
    pf_cg_pattern(&cg, fixed, &k, &map, &err);
    size_t nf = 3 * (size_t)map.n_free;
    double *f = calloc(nf, sizeof *f), *u = calloc(nf, sizeof *u);
    double *scratch = malloc(pf_cg_scratch_size(&cg) * sizeof *scratch);
    pf_cg_assemble_stiffness(&cg, &map, NULL, m->x, NULL, scratch, &k, f);
    for (int32_t i = 0; i < map.n_free; ++i)
        for (int c = 0; c < 3; ++c)
            f[3 * i + c] += load[3 * (size_t)map.block_node[i] + c];
    pf_cholesky *chol = NULL;
    double w = 0;
    int count = 0;
    if (pf_cholesky_create(&chol, &k, &err) >= 0 && pf_cholesky_factor(chol, &k, NULL, &err) >= 0 &&
        pf_cholesky_solve(chol, f, u, &err) >= 0)
        for (int32_t i = 0; i < map.n_free; ++i)
            if (fabs(pf_plane_signed_distance(
                    tip, pf_v3_load(m->x + 3 * (size_t)map.block_node[i]))) < 1e-9)
                w += u[3 * i + 2], ++count;
    pf_cholesky_destroy(&chol);
    free(f);
    free(u);
    free(scratch);
    free(fixed);
    free(load);
    pf_boundary_release(&bd);
    pf_cg_map_release(&map);
    pf_block_matrix_release(&k);
    pf_cg_release(&cg);
    return count ? w / count : NAN;
}

static int sweep(void)
{
    /* The DG limit of tests/test_cg.c: IP degree 2 on 16 x 4 x 4 hexes. */
    const double limit = -2.630794e-03;
    pf_mesh sphere = {0}, beam = {0};
    if (slice_shape(&sphere, false, 4) < 0)
        return 1;
    {
        pf_error err = {0};
        pf_mesh box = {0};
        pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(4, 1, 1), 1, 1, 1, &err);
        pf_boundary bd;
        pf_boundary_extract(&box, &bd, &err);
        pf_surface s = {0};
        int32_t nt = (int32_t)bd.tri_offsets[bd.n_faces];
        pf_surface_alloc(&s, box.n_nodes, nt, &err);
        double a = 30 * 3.14159265358979323846 / 180;
        for (int32_t i = 0; i < box.n_nodes; ++i) {
            const double *x = box.x + 3 * i;
            s.x[3 * i] = cos(a) * x[0] - sin(a) * x[1];
            s.x[3 * i + 1] = sin(a) * x[0] + cos(a) * x[1];
            s.x[3 * i + 2] = x[2];
        }
        memcpy(s.tri, bd.tri, 3 * (size_t)nt * sizeof *s.tri);
        pf_slice_params p = pf_slice_params_default();
        p.grid.res = 9;
        if (pf_mesh_slice(&beam, &s, &p, NULL, &err) < 0 || pf_mesh_derive(&beam, &err) < 0) {
            fprintf(stderr, "bench_cg: %s\n", err.msg);
            return 1;
        }
        pf_surface_release(&s);
        pf_boundary_release(&bd);
        pf_mesh_release(&box);
    }
    printf("xi,edge_samples,median_kernels,median_boundary_error,tip,tip_error\n");
    const double xis[] = {0.05, 0.1, 0.15, 0.2};
    const int samples[] = {2, 3, 5};
    for (size_t a = 0; a < sizeof xis / sizeof *xis; ++a)
        for (size_t b = 0; b < sizeof samples / sizeof *samples; ++b) {
            pf_cg_params p = pf_cg_params_default();
            p.basis.xi = xis[a];
            p.basis.edge_samples = samples[b];
            pf_basis basis;
            pf_error err = {0};
            if (pf_basis_create(&basis, &sphere, &p.basis, &err) < 0) {
                fprintf(stderr, "bench_cg: %s\n", err.msg);
                return 1;
            }
            double be[4096], nk[4096];
            int n = 0;
            for (int32_t e = 0; e < basis.n_elems && n < 4096; ++e)
                if (pf_basis_elem_kind(&basis, e) == PF_BASIS_HARMONIC) {
                    be[n] = basis.stats[e].boundary_error;
                    nk[n++] = basis.stats[e].n_kernels;
                }
            qsort(be, (size_t)n, sizeof *be, cmp);
            qsort(nk, (size_t)n, sizeof *nk, cmp);
            pf_basis_release(&basis);
            double w = turned_cantilever(&beam, &p);
            printf("%g,%d,%g,%.5f,%.6e,%.5f\n", xis[a], samples[b], n ? nk[n / 2] : 0,
                   n ? be[n / 2] : 0, w, fabs(w / limit - 1));
            fflush(stdout);
        }
    pf_mesh_release(&sphere);
    pf_mesh_release(&beam);
    return 0;
}

static int step_time(void)
{
    printf("mesh,elements,harmonic,dofs,assemble_ms,factor_ms,solve_ms,step_ms\n");
    const int res[2] = {4, 8};
    for (int r = 0; r < 2; ++r)
        for (int t = 0; t < 2; ++t) {
            pf_mesh m = {0};
            if (slice_shape(&m, t, res[r]) < 0)
                return 1;
            pf_scene sc;
            pf_scene_default(&sc);
            sc.method = PF_METHOD_CG;
            sc.frames = 1;
            sc.substeps = 10;
            pf_vec3 lo, hi;
            pf_mesh_bounds(&m, &lo, &hi);
            pf_scene_resolve(&sc, lo, hi);
            pf_error err = {0};
            pf_sim *sim = NULL;
            if (pf_sim_create(&sim, &sc, &m, &err) < 0 || pf_sim_frame(sim, &err) < 0) {
                fprintf(stderr, "bench_cg: %s\n", err.msg);
                return 1;
            }
            const pf_sim_stats *st = pf_sim_get_stats(sim);
            double n = (double)st->steps;
            printf("%s%d,%d,%d,%lld,%.3f,%.3f,%.3f,%.3f\n", t ? "torus" : "sphere", res[r],
                   (int)m.n_elems, (int)st->harmonic_elems, (long long)st->dofs,
                   1e3 * st->assemble_seconds / n, 1e3 * st->factor_seconds / n,
                   1e3 * st->solve_seconds / n,
                   1e3 * (st->assemble_seconds + st->factor_seconds + st->solve_seconds) / n);
            fflush(stdout);
            pf_sim_destroy(&sim);
            pf_scene_release(&sc);
            pf_mesh_release(&m);
        }
    return 0;
}

/* The closed surface of the beam [0, 4] x [0, 1] x [0, 1] turned by angle (radians) about z. */
static int beam_surface(pf_surface *s, double angle)
{
    pf_error err = {0};
    pf_mesh box = {0};
    pf_boundary bd = {0};
    pf_status st = pf_mesh_make_box(&box, pf_v3(0, 0, 0), pf_v3(4, 1, 1), 1, 1, 1, &err);
    if (st >= 0)
        st = pf_boundary_extract(&box, &bd, &err);
    int32_t nt = st >= 0 ? (int32_t)bd.tri_offsets[bd.n_faces] : 0;
    if (st >= 0)
        st = pf_surface_alloc(s, box.n_nodes, nt, &err);
    if (st >= 0) {
        for (int32_t i = 0; i < box.n_nodes; ++i) {
            const double *x = box.x + 3 * i;
            s->x[3 * i] = cos(angle) * x[0] - sin(angle) * x[1];
            s->x[3 * i + 1] = sin(angle) * x[0] + cos(angle) * x[1];
            s->x[3 * i + 2] = x[2];
        }
        memcpy(s->tri, bd.tri, 3 * (size_t)nt * sizeof *s->tri);
    }
    pf_boundary_release(&bd);
    pf_mesh_release(&box);
    if (st < 0)
        fprintf(stderr, "bench_cg: %s\n", err.msg);
    return st < 0 ? -1 : 0;
}

/* One static cantilever solve by pf-sim's method "cg": clamped at x' = 0, traction (0, 0, -1)
 * on x' = 4 (x' the beam's axis at angle about z), E = 1e5, nu = 0.3; prints the CSV row. */
static int refine_row(const char *name, int refine, const pf_mesh *m, double angle, double limit)
{
    pf_scene sc;
    pf_scene_default(&sc);
    sc.method = PF_METHOD_CG;
    sc.E = 1e5;
    sc.nu = 0.3;
    sc.density = 1;
    sc.gravity = pf_v3(0, 0, 0);
    sc.is_static = true;
    sc.ground = false;
    pf_vec3 axis = {cos(angle), sin(angle), 0};
    pf_fixed fixed = {.region = {.kind = PF_REGION_PLANE,
                                 .plane = pf_plane_from_point_normal(pf_v3(0, 0, 0), axis),
                                 .tol = 1e-9}};
    pf_load load = {.region = {.kind = PF_REGION_PLANE,
                               .plane = pf_plane_from_point_normal(pf_v3_scale(axis, 4), axis),
                               .tol = 1e-9},
                    .traction = {0, 0, -1}};
    sc.fixed = &fixed;
    sc.n_fixed = 1;
    sc.loads = &load;
    sc.n_loads = 1;
    pf_error err = {0};
    pf_sim *sim = NULL;
    double t0 = pf_time_seconds();
    pf_status st = pf_sim_create(&sim, &sc, m, &err);
    double t1 = pf_time_seconds();
    if (st >= 0)
        st = pf_sim_solve_static(sim, &err);
    double t2 = pf_time_seconds();
    double *u = st >= 0 ? malloc(3 * (size_t)m->n_nodes * sizeof *u) : NULL;
    if (u) {
        pf_sim_nodal_displacements(sim, u);
        double w = 0;
        int count = 0;
        for (int32_t i = 0; i < m->n_nodes; ++i)
            if (fabs(pf_plane_signed_distance(load.region.plane, pf_v3_load(m->x + 3 * i))) < 1e-9)
                w += u[3 * i + 2], ++count;
        w /= count;
        const pf_sim_stats *ss = pf_sim_get_stats(sim);
        printf("%s,%d,%d,%d,%lld,%.6e,%.5f,%.3f,%.3f\n", name, refine, (int)m->n_elems,
               (int)ss->harmonic_elems, (long long)ss->dofs, w, fabs(w / limit - 1), t1 - t0,
               t2 - t1);
        fflush(stdout);
        free(u);
    }
    pf_sim_destroy(&sim);
    sc.fixed = NULL, sc.loads = NULL, sc.n_fixed = sc.n_loads = 0; /* borrowed */
    pf_scene_release(&sc);
    if (st < 0)
        fprintf(stderr, "bench_cg: %s: %s\n", name, err.msg);
    return st < 0 ? -1 : 0;
}

static int refine(void)
{
    /* The DG limit of tests/test_cg.c: IP degree 2 on 16 x 4 x 4 hexes. */
    const double limit = -2.630794e-03, angle = 30 * 3.14159265358979323846 / 180;
    printf("mesh,refine,elements,harmonic,dofs,tip,tip_error,setup_s,solve_s\n");
    pf_error err = {0};
    for (int r = 1; r <= 12; r += r < 4 ? r : 4) {
        pf_mesh m = {0};
        if (pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(4, 1, 1), 4 * r, r, r, &err) < 0 ||
            pf_mesh_derive(&m, &err) < 0) {
            fprintf(stderr, "bench_cg: %s\n", err.msg);
            return 1;
        }
        int st = refine_row("hex", r, &m, 0, limit);
        pf_mesh_release(&m);
        if (st < 0)
            return 1;
    }
    for (int t = 0; t < 2; ++t) {
        pf_surface s = {0};
        if (beam_surface(&s, t ? angle : 0) < 0)
            return 1;
        for (int d = 3; d <= (t ? 5 : 6); ++d) {
            pf_octree_params p = pf_octree_params_default();
            p.depth = d;
            p.min_depth = 2;
            p.slice = t == 1;
            pf_mesh m = {0};
            if (pf_mesh_octree(&m, &s, &p, NULL, &err) < 0) {
                fprintf(stderr, "bench_cg: %s\n", err.msg);
                pf_surface_release(&s);
                return 1;
            }
            int st = refine_row(t ? "octree_turned_sliced" : "octree", d, &m, t ? angle : 0, limit);
            pf_mesh_release(&m);
            if (st < 0) {
                pf_surface_release(&s);
                return 1;
            }
        }
        pf_surface_release(&s);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "refine"))
        return refine();
    if (argc > 1 && !strcmp(argv[1], "sweep"))
        return sweep();
    if (argc > 1 && !strcmp(argv[1], "step"))
        return step_time();
    return per_element();
}
