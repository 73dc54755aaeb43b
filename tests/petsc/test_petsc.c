/* petsc: the simulator on the petsc solver (PETSc's CG + GAMG, one process here; tests/petsc/
 * mpi.sh runs 1, 2 and 4 ranks) against CHOLMOD's direct solves: the static cantilever with DG
 * degree 2 and with CG to 1e-8 relative, corotated drops onto the ground to 1e-6 of the largest
 * displacement, the rigid near-null space at work, the errors, the partition of the rows over
 * ranks, and the checkpoint of every rank assembling its own elements against the one-process
 * simulator's. Built with -DPF_PETSC=ON. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/sim.h>

#include "solve/solve_petsc.h"

/* The cantilever of data/scenes/cantilever.json (E 1e5, nu 0.3, clamped at x = 0, traction
 * (0, 0, -1) on x = 4), static, with the method given as JSON. */
static const char CANTILEVER[] =
    "{\"material\": {\"E\": 100000, \"nu\": 0.3, \"density\": 1}, \"method\": %s,"
    " \"gravity\": [0, 0, 0], \"fixed\": [{\"box\": [[-0.001, -1, -1], [0.001, 2, 2]]}],"
    " \"loads\": [{\"plane\": {\"point\": [4, 0, 0], \"normal\": [1, 0, 0], \"tol\": 1e-6},"
    " \"traction\": [0, 0, -1]}], \"static\": true}";

/* A corotated drop from 0.05 above the ground, spinning, E low enough to deform visibly. */
static const char DROP[] = "{\"material\": {\"E\": 2000, \"nu\": 0.3, \"density\": 1}, \"method\": "
                           "%s, \"time\": {\"frames\": %d, \"dt\": 0.02}, \"corotation\": true}";

static void parse(pf_scene *sc, const char *fmt, const char *method, int frames)
{
    char json[1024];
    snprintf(json, sizeof json, fmt, method, frames);
    pf_error err = {0};
    if (pf_scene_parse(sc, json, strlen(json), "case.json", &err) < 0)
        fail_msg("%s", err.msg);
}

static void make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, lo, hi, nx, ny, nz, &err), PF_OK);
}

/* Runs the scene on the mesh with the solver method and returns the nodal displacements of
 * every frame [frames][3 n_nodes] (the static solution for a static scene), and the stats. */
static double *run(const pf_scene *scene, const pf_mesh *mesh, pf_solver_method method, int frames,
                   pf_sim_stats *stats)
{
    pf_scene sc = *scene;
    sc.solver.method = method;
    pf_vec3 lo, hi;
    pf_mesh_bounds(mesh, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_error err = {0};
    pf_sim *sim = NULL;
    if (pf_sim_create(&sim, &sc, mesh, &err) < 0)
        fail_msg("%s: %s", pf_solver_method_name(method), err.msg);
    size_t nn = 3 * (size_t)mesh->n_nodes;
    double *u = malloc((size_t)frames * nn * sizeof *u);
    if (sc.is_static) {
        if (pf_sim_solve_static(sim, &err) < 0)
            fail_msg("static, %s: %s", pf_solver_method_name(method), err.msg);
        pf_sim_nodal_displacements(sim, u);
    } else {
        pf_sim_set_rigid_velocity(sim, (pf_vec3){0.5, 1, 0}, pf_v3_scale(pf_v3_add(lo, hi), 0.5),
                                  (pf_vec3){0, 0, 0});
        for (int f = 0; f < frames; ++f) {
            if (pf_sim_frame(sim, &err) < 0)
                fail_msg("frame %d, %s: %s", f + 1, pf_solver_method_name(method), err.msg);
            pf_sim_nodal_displacements(sim, u + (size_t)f * nn);
        }
    }
    *stats = *pf_sim_get_stats(sim);
    pf_sim_destroy(&sim);
    return u;
}

/* The largest difference between petsc's and direct's displacements relative to the largest
 * displacement; also the tip (mean vertical displacement of the nodes at x = 4) of both. */
static double compare(const pf_scene *sc, const pf_mesh *m, int frames, const char *name,
                      double *tip_direct, double *tip_petsc)
{
    pf_sim_stats sd, sp;
    double *ud = run(sc, m, PF_SOLVER_DIRECT, frames, &sd);
    double *up = run(sc, m, PF_SOLVER_PETSC, frames, &sp);
    size_t total = (size_t)frames * 3 * (size_t)m->n_nodes;
    double largest = 0, diff = 0;
    for (size_t q = 0; q < total; ++q) {
        largest = fmax(largest, fabs(ud[q]));
        diff = fmax(diff, fabs(ud[q] - up[q]));
    }
    double td = 0, tp = 0;
    int count = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (fabs(m->x[3 * i] - 4) < 1e-12) {
            td += ud[3 * i + 2], tp += up[3 * i + 2];
            ++count;
        }
    if (tip_direct)
        *tip_direct = count ? td / count : 0;
    if (tip_petsc)
        *tip_petsc = count ? tp / count : 0;
    assert_int_equal(sp.solver.method, PF_SOLVER_PETSC);
    printf("%s: %lld unknowns, largest displacement %.4e, petsc - direct %.2e (%.1e relative); "
           "GAMG %lld solves, %.1f iterations mean, %d max\n",
           name, (long long)sp.dofs, largest, diff, diff / largest, (long long)sp.solver.solves,
           (double)sp.solver.iterations / (double)sp.solver.solves, (int)sp.solver.max_iterations);
    assert_true(largest > 0);
    free(ud);
    free(up);
    return diff / largest;
}

/* The static cantilever: the tolerance 1e-10 on ||b - A x|| / ||b|| leaves an error of at most
 * 1e-10 times the condition of K; measured 3e-12 (DG) relative, asserted 1e-8 as the issue asks. */
static void cantilever(const char *method, int refine, const char *name)
{
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 4 * refine, refine, refine);
    pf_scene sc;
    parse(&sc, CANTILEVER, method, 0);
    double td, tp;
    double rel = compare(&sc, &m, 1, name, &td, &tp);
    printf("%s: tip direct %.15e, petsc %.15e (%.1e relative)\n", name, td, tp,
           fabs(tp - td) / fabs(td));
    assert_true(td < 0);
    assert_true(fabs(tp - td) <= 1e-8 * fabs(td));
    assert_true(rel <= 1e-8);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void cantilever_dg2(void **state)
{
    (void)state;
    cantilever("{\"name\": \"dg\", \"degree\": 2, \"flux\": \"ip\", \"penalty\": 0}", 4,
               "DG degree 2 IP cantilever, 16 x 4 x 4");
}

static void cantilever_cg(void **state)
{
    (void)state;
    cantilever("{\"name\": \"cg\"}", 4, "CG cantilever, 16 x 4 x 4");
}

/* A spinning box dropped onto the ground with corotation: the matrix changes every step (the
 * rotations) and when contacts come and go; frames within 1e-6 of the largest displacement, as
 * pcg is held to against direct (test_sim_solver). */
static void drop(const char *method, const char *name)
{
    pf_mesh m = {0};
    make_box(&m, (pf_vec3){0, 0, 0.05}, (pf_vec3){1, 0.5, 0.55}, 4, 2, 2);
    pf_scene sc;
    int frames = 12;
    parse(&sc, DROP, method, frames);
    sc.ground = true;
    sc.ground_auto = false;
    sc.ground_point = (pf_vec3){0, 0, 0};
    sc.ground_normal = (pf_vec3){0, 0, 1};
    double rel = compare(&sc, &m, frames, name, NULL, NULL);
    assert_true(rel <= 1e-6);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

static void drop_dg(void **state)
{
    (void)state;
    drop("{\"name\": \"dg\", \"degree\": 1}", "corotated DG drop, 12 frames");
}

static void drop_cg(void **state)
{
    (void)state;
    drop("{\"name\": \"cg\"}", "corotated CG drop, 12 frames");
}

/* Multigrid with the rigid modes as near-null space: CG's iterations on the cantilever stay
 * nearly constant as the mesh is refined twice (8 times the unknowns each time); asserted to
 * grow by less than half from the coarsest to the finest (CG alone grows like the square root
 * of the condition, 4 x over two halvings of h). */
static void gamg_iterations_flat(void **state)
{
    (void)state;
    int64_t its[3];
    for (int r = 0; r < 3; ++r) {
        int refine = 2 << r;
        pf_mesh m = {0};
        make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 4 * refine, refine, refine);
        pf_scene sc;
        parse(&sc, CANTILEVER, "{\"name\": \"cg\"}", 0);
        pf_sim_stats st;
        free(run(&sc, &m, PF_SOLVER_PETSC, 1, &st));
        its[r] = st.solver.iterations;
        printf("CG cantilever %d x %d x %d, %lld unknowns: %lld GAMG iterations\n", 4 * refine,
               refine, refine, (long long)st.dofs, (long long)its[r]);
        pf_scene_release(&sc);
        pf_mesh_release(&m);
    }
    assert_true(its[0] > 0);
    assert_true(2 * its[2] < 3 * its[0]);
}

/* A 6 x 6 diagonal system: dependent near-null vectors refused, a right-hand side of zero, a
 * matrix changed during a skipped solve, a tolerance out of range. */
static void errors(void **state)
{
    (void)state;
    pf_block_matrix a = {0};
    pf_error err = {0};
    int32_t sizes[2] = {3, 3}, pairs[2] = {0, 1};
    assert_int_equal(pf_block_matrix_create(&a, 2, sizes, 1, pairs, &err), PF_OK);
    double d[6] = {4, 4, 4, 4, 4, 4};
    pf_block_matrix_add_diagonal(&a, d);
    pf_solver_params p = pf_solver_params_default();
    p.method = PF_SOLVER_PETSC;
    pf_solver *s = NULL;
    assert_int_equal(pf_solver_create(&s, &a, &p, false, &err), PF_OK);
    double v[12] = {1, 0, 0, 1, 0, 0, 2, 0, 0, 2, 0, 0};
    assert_int_equal(pf_solver_set_near_null_space(s, 2, v, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "combination"));
    double b[6] = {4, 8, 12, 16, 20, 24}, x[6] = {0};
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_NEW, b, x, NULL, &err), PF_OK);
    for (int k = 0; k < 6; ++k)
        assert_true(fabs(x[k] - (k + 1)) < 1e-12);
    /* b = 0: x = 0 exactly, whatever the guess; the next solve still sees the new values */
    double zero[6] = {0};
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_NEW, zero, x, NULL, &err), PF_OK);
    for (int k = 0; k < 6; ++k)
        assert_true(x[k] == 0);
    pf_block_matrix_add_diagonal(&a, d); /* A = 8 I */
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_DRIFTED, zero, x, NULL, &err), PF_OK);
    assert_int_equal(pf_solver_solve(s, &a, PF_MATRIX_SAME, b, x, NULL, &err), PF_OK);
    for (int k = 0; k < 6; ++k)
        assert_true(fabs(x[k] - 0.5 * (k + 1)) < 1e-12);
    pf_solver_destroy(&s);
    p.tolerance = 2;
    assert_int_equal(pf_solver_create(&s, &a, &p, false, &err), PF_ERR_INVALID);
    assert_null(s);
    pf_block_matrix_release(&a);
}

/* The block graph of DG elements on an nx x ny x nz grid of hexes (face neighbours), blocks of
 * 12 unknowns (degree 1). */
static void grid_pattern(pf_block_matrix *a, int nx, int ny, int nz)
{
    int32_t nb = nx * ny * nz, *sizes = malloc((size_t)nb * sizeof *sizes);
    int32_t *pairs = malloc(6 * (size_t)nb * sizeof *pairs), n_pairs = 0;
    for (int32_t b = 0; b < nb; ++b) {
        sizes[b] = 12;
        int x = b % nx, y = b / nx % ny, z = b / (nx * ny);
        int32_t next[3] = {x + 1 < nx ? b + 1 : -1, y + 1 < ny ? b + nx : -1,
                           z + 1 < nz ? b + nx * ny : -1};
        for (int d = 0; d < 3; ++d)
            if (next[d] >= 0) {
                pairs[2 * n_pairs] = b;
                pairs[2 * n_pairs++ + 1] = next[d];
            }
    }
    pf_error err = {0};
    assert_int_equal(pf_block_matrix_create(a, nb, sizes, n_pairs, pairs, &err), PF_OK);
    free(sizes);
    free(pairs);
}

/* The rows of a 32 x 4 x 4 beam of DG elements over 4 ranks: whole blocks, each part one
 * contiguous range of PETSc rows in pf's order, balanced, the same twice, and a small cut. The
 * best partition of the beam into 4 is 3 cross-sections of 16 faces (48 coupled pairs cut);
 * asserted within 2x of it. Splitting the element order (x fastest) into 4 ranges, the row
 * distribution before the graph partition, gives 4 layers along z and cuts 3 x 128 = 384 of the
 * 1,264 couplings. */
static void partition(void **state)
{
    (void)state;
    pf_error err = {0};
    assert_int_equal(pf_petsc_initialize(NULL, NULL, NULL, NULL, &err), PF_OK);
    pf_block_matrix a = {0};
    grid_pattern(&a, 32, 4, 4);
    int64_t *row = malloc((size_t)a.n * sizeof *row), *again = malloc((size_t)a.n * sizeof *row);
    int64_t count[4], count_again[4];
    assert_int_equal(pf_petsc_partition_rows(&a, 1, row, count, &err), PF_OK);
    assert_int_equal(count[0], a.n);
    for (int64_t i = 0; i < a.n; ++i)
        assert_int_equal(row[i], i);
    assert_int_equal(pf_petsc_partition_rows(&a, 4, row, count, &err), PF_OK);
    assert_int_equal(pf_petsc_partition_rows(&a, 4, again, count_again, &err), PF_OK);
    assert_memory_equal(row, again, (size_t)a.n * sizeof *row);
    int64_t start[5] = {0}, total = 0;
    for (int r = 0; r < 4; ++r) {
        printf("part %d: %lld rows\n", r, (long long)count[r]);
        /* PT-Scotch balances to 1 % through PETSc; here that is within one block (12 of 1,536) */
        assert_true(llabs(count[r] - a.n / 4) <= 12);
        start[r + 1] = start[r] + count[r];
        total += count[r];
    }
    assert_int_equal(total, a.n);
    int32_t *part = malloc((size_t)a.n_blocks * sizeof *part);
    uint8_t *seen = calloc((size_t)a.n, 1);
    for (int32_t b = 0; b < a.n_blocks; ++b) {
        int64_t first = row[a.block_start[b]];
        part[b] = 0;
        while (first >= start[part[b] + 1])
            ++part[b];
        for (int64_t i = a.block_start[b]; i < a.block_start[b + 1]; ++i) {
            assert_int_equal(row[i], first + (i - a.block_start[b]));
            assert_true(row[i] >= 0 && row[i] < start[part[b] + 1] && !seen[row[i]]);
            seen[row[i]] = 1;
        }
        if (b > 0 && part[b] == part[b - 1]) /* pf's order within a part */
            assert_true(first > row[a.block_start[b - 1]]);
    }
    int64_t cut = 0, pairs = 0;
    for (int32_t j = 0; j < a.n_blocks; ++j)
        for (int64_t k = a.adj_offsets[j]; k < a.adj_offsets[j + 1] - 1; ++k, ++pairs)
            cut += part[a.adj[k]] != part[j];
    printf("4 parts of %d blocks: %lld of %lld couplings cut\n", (int)a.n_blocks, (long long)cut,
           (long long)pairs);
    assert_true(cut <= 96);
    free(part);
    free(seen);
    free(row);
    free(again);
    pf_block_matrix_release(&a);
}

/* A clamped beam swinging under gravity (no contact: every rank assembles its own elements). */
static const char SWING[] =
    "{\"material\": {\"E\": 2000, \"nu\": 0.3, \"density\": 1}, \"method\": %s,"
    " \"gravity\": [0, 0, -1], \"fixed\": [{\"box\": [[-0.001, -1, -1], [0.001, 2, 2]]}],"
    " \"ground\": false, \"time\": {\"frames\": %d, \"dt\": 0.02}, \"corotation\": true,"
    " \"solver\": {\"method\": \"petsc\"}}";

/* The last checkpoint's state a run of pf_sim_distrib_run_with heard. */
static pf_status keep_state(void *ctx, const pf_sim_distrib_result *res, const void *state,
                            size_t size, pf_error *err)
{
    (void)res, (void)err;
    pf_buffer *b = ctx;
    b->size = 0;
    return pf_buffer_append(b, state, size, err);
}

/* Value k of a state's unknowns (after the 68-byte header: u, then v). */
static double state_value(const pf_buffer *b, size_t k)
{
    double x;
    memcpy(&x, b->data + 68 + 8 * k, 8); /* little-endian, as this machine */
    return x;
}

/* The checkpoint of every rank assembling its own elements (one rank here; tests/petsc/mpi.sh
 * resumes 2 and 4) is the one-process simulator's: the same header, the unknowns and velocities
 * in the same order to 1e-8 of the largest (PETSc's CG to 1e-10 against CHOLMOD; measured after 4
 * frames: DG u 3.1e-11, v 8.1e-11, CG u 1.4e-10, v 4.8e-10), and pf_sim_restore takes it. */
static void distrib_checkpoint(void **state)
{
    (void)state;
    const char *methods[] = {"{\"name\": \"dg\", \"degree\": 1, \"flux\": \"ip\"}",
                             "{\"name\": \"cg\"}"};
    for (int k = 0; k < 2; ++k) {
        pf_scene sc;
        parse(&sc, SWING, methods[k], 4);
        pf_mesh m = {0};
        make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){4, 1, 1}, 8, 2, 2);
        pf_error err = {0};
        assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
        pf_vec3 lo, hi;
        pf_mesh_bounds(&m, &lo, &hi);
        pf_scene_resolve(&sc, lo, hi);
        pf_buffer mine = {0}, one = {0};
        pf_sim_distrib_options opt = {
            .checkpoint = keep_state, .ctx = &mine, .checkpoint_every = 4};
        pf_sim_distrib_result res;
        if (pf_sim_distrib_run_with(&sc, &m, &opt, &res, &err) < 0)
            fail_msg("%s", err.msg);
        pf_sim_distrib_result_release(&res);
        sc.solver.method = PF_SOLVER_DIRECT; /* not in the fingerprint */
        pf_sim *sim = NULL;
        assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
        for (int f = 0; f < 4; ++f)
            assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
        assert_int_equal(pf_sim_checkpoint(sim, &one, &err), PF_OK);
        assert_int_equal(mine.size, one.size);
        assert_memory_equal(mine.data, one.data, 36); /* mesh, frame, fingerprint, time, n */
        size_t n = (one.size - 68) / 16;
        double largest[2] = {0, 0}, diff[2] = {0, 0};
        for (size_t q = 0; q < 2 * n; ++q) {
            largest[q >= n] = fmax(largest[q >= n], fabs(state_value(&one, q)));
            diff[q >= n] = fmax(diff[q >= n], fabs(state_value(&one, q) - state_value(&mine, q)));
        }
        printf("%s checkpoint of every rank's assembly: %zu unknowns, u %.1e, v %.1e of the "
               "largest (%.2g, %.2g) from the one-process one's\n",
               k ? "cg" : "dg", n, diff[0] / largest[0], diff[1] / largest[1], largest[0],
               largest[1]);
        assert_true(largest[0] > 1e-3 && diff[0] <= 1e-8 * largest[0]);
        assert_true(largest[1] > 0.03 && diff[1] <= 1e-8 * largest[1]);
        assert_int_equal(pf_sim_restore(sim, mine.data, mine.size, &err), PF_OK);
        assert_int_equal(pf_sim_frame_index(sim), 4);
        pf_sim_destroy(&sim);
        pf_buffer_release(&mine);
        pf_buffer_release(&one);
        pf_mesh_release(&m);
        pf_scene_release(&sc);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(cantilever_dg2),
        cmocka_unit_test(cantilever_cg),
        cmocka_unit_test(drop_dg),
        cmocka_unit_test(drop_cg),
        cmocka_unit_test(gamg_iterations_flat),
        cmocka_unit_test(errors),
        cmocka_unit_test(partition),
        cmocka_unit_test(distrib_checkpoint),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    pf_petsc_finalize(failed ? 1 : 0);
    return failed;
}
