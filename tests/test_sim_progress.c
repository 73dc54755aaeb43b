/* sim_progress: the phases a simulator's set-up and factorisations report through the progress
 * hook (pf_sim_options.progress, pf/base.h), for DG and CG, and the solver's hook alone. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdbool.h>
#include <string.h>

#include <pf/sim.h>

enum { MAX_RUNS = 64 };

/* One run of a phase: from its done = 0 to its last event. */
typedef struct phase_run {
    const char *phase;
    int64_t total, last_done, events;
} phase_run;

/* What the hook heard, checked as it comes: a phase starts at done = 0, done never decreases
 * within a run, total stays, and a run ends at done = total before another starts. */
typedef struct recorder {
    phase_run runs[MAX_RUNS];
    int n;
} recorder;

static void record(void *user, const pf_progress_event *ev)
{
    recorder *r = user;
    assert_non_null(ev->phase);
    phase_run *cur = r->n > 0 ? &r->runs[r->n - 1] : NULL;
    if (!cur || cur->last_done == cur->total) { /* a run starts */
        assert_int_equal(ev->done, 0);
        assert_true(r->n < MAX_RUNS);
        r->runs[r->n++] = (phase_run){.phase = ev->phase, .total = ev->total, .last_done = 0};
        cur = &r->runs[r->n - 1];
    } else {
        assert_string_equal(ev->phase, cur->phase);
        assert_int_equal(ev->total, cur->total);
        assert_true(ev->done >= cur->last_done);
    }
    assert_true(ev->done <= ev->total);
    cur->last_done = ev->done;
    cur->events++;
}

/* The index of the first run of phase at or after from, -1 when none. */
static int find_run(const recorder *r, const char *phase, int from)
{
    for (int k = from; k < r->n; ++k)
        if (strcmp(r->runs[k].phase, phase) == 0)
            return k;
    return -1;
}

/* Every run ended (done = total), and the phases came in the order given, each with its total
 * (-1: any). Returns the index after the last. */
static int expect_phases(const recorder *r, const char *const *phases, const int64_t *totals,
                         int count)
{
    for (int k = 0; k < r->n; ++k)
        assert_int_equal(r->runs[k].last_done, r->runs[k].total);
    int at = 0;
    for (int k = 0; k < count; ++k) {
        int found = find_run(r, phases[k], at);
        if (found < 0)
            fail_msg("phase '%s' not reported", phases[k]);
        if (totals[k] >= 0)
            assert_int_equal(r->runs[found].total, totals[k]);
        at = found + 1;
    }
    return at;
}

static void box(pf_mesh *m)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, (pf_vec3){0, 0, 0}, (pf_vec3){2, 1, 1}, 4, 2, 2, &err),
                     PF_OK);
}

static void scene_for(pf_scene *sc, pf_method method)
{
    pf_scene_default(sc);
    sc->method = method;
    sc->gravity = (pf_vec3){0, -9.81, 0};
    sc->ground = false;
}

/* DG: the integrals over every element and face (each counted one by one: the hook hears
 * n + 1 events per phase), then CHOLMOD's analysis and the penalty search's factorisations. */
static void dg_reports_its_phases(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    box(&m);
    pf_scene sc;
    scene_for(&sc, PF_METHOD_DG);
    recorder rec = {0};
    pf_sim_options opt = {.progress = {record, &rec}};
    pf_sim *sim = NULL;
    pf_error err = {0};
    assert_int_equal(pf_sim_create_with(&sim, &sc, &m, &opt, &err), PF_OK);
    const char *const phases[] = {"element integrals", "face integrals", "symbolic analysis",
                                  "numeric factorisation"};
    const int64_t totals[] = {m.n_elems, m.n_faces, 1, 1};
    expect_phases(&rec, phases, totals, 4);
    assert_int_equal(rec.runs[find_run(&rec, "element integrals", 0)].events, m.n_elems + 1);
    assert_int_equal(rec.runs[find_run(&rec, "face integrals", 0)].events, m.n_faces + 1);
    /* a frame's factorisation is heard too */
    int before = rec.n;
    assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    assert_true(find_run(&rec, "numeric factorisation", before) >= 0);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* CG: the shape functions and element matrices of every element, the analysis at set-up, and
 * the first factorisation in the first frame. */
static void cg_reports_its_phases(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    box(&m);
    pf_scene sc;
    scene_for(&sc, PF_METHOD_CG);
    recorder rec = {0};
    pf_sim_options opt = {.progress = {record, &rec}};
    pf_sim *sim = NULL;
    pf_error err = {0};
    assert_int_equal(pf_sim_create_with(&sim, &sc, &m, &opt, &err), PF_OK);
    const char *const phases[] = {"basis functions", "element matrices", "symbolic analysis"};
    const int64_t totals[] = {m.n_elems, m.n_elems, 1};
    expect_phases(&rec, phases, totals, 3);
    assert_int_equal(rec.runs[find_run(&rec, "element matrices", 0)].events, m.n_elems + 1);
    int before = rec.n;
    assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    assert_true(find_run(&rec, "numeric factorisation", before) >= 0);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The hook changes nothing: the same frame, bit for bit, with and without it. */
static void hook_changes_no_result(void **state)
{
    (void)state;
    pf_mesh m = {0};
    box(&m);
    double *u[2];
    for (int with = 0; with < 2; ++with) {
        pf_scene sc;
        scene_for(&sc, PF_METHOD_DG);
        recorder rec = {0};
        pf_sim_options opt = {.progress = {with ? record : NULL, &rec}};
        pf_sim *sim = NULL;
        pf_error err = {0};
        assert_int_equal(pf_sim_create_with(&sim, &sc, &m, &opt, &err), PF_OK);
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
        u[with] = pf_alloc_array(3 * (size_t)m.n_nodes, sizeof *u[with]);
        assert_non_null(u[with]);
        pf_sim_nodal_displacements(sim, u[with]);
        assert_int_equal(rec.n > 0, with);
        pf_sim_destroy(&sim);
        pf_scene_release(&sc);
    }
    assert_memory_equal(u[0], u[1], 3 * (size_t)m.n_nodes * sizeof *u[0]);
    pf_free(u[0]);
    pf_free(u[1]);
    pf_mesh_release(&m);
}

/* The solver alone: analysis at creation (params), a factorisation after pf_solver_set_progress,
 * and nothing once the hook is taken away. */
static void solver_reports_analysis_and_factorisation(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_block_matrix a = {0};
    const int32_t size[2] = {3, 3}, pairs[2] = {0, 1};
    assert_int_equal(pf_block_matrix_create(&a, 2, size, 1, pairs, &err), PF_OK);
    const double diag[6] = {4, 4, 4, 4, 4, 4};
    pf_block_matrix_add_diagonal(&a, diag);
    recorder rec = {0};
    pf_solver_params p = pf_solver_params_default();
    p.method = PF_SOLVER_DIRECT;
    p.progress = (pf_progress_hook){record, &rec};
    pf_solver *s = NULL;
    assert_int_equal(pf_solver_create(&s, &a, &p, false, &err), PF_OK);
    assert_int_equal(rec.n, 1);
    assert_string_equal(rec.runs[0].phase, "symbolic analysis");
    int64_t failed = -1;
    assert_int_equal(pf_solver_factor(s, &a, &failed, &err), PF_OK);
    assert_int_equal(rec.n, 2);
    assert_string_equal(rec.runs[1].phase, "numeric factorisation");
    assert_int_equal(rec.runs[1].events, 2);
    pf_solver_set_progress(s, NULL);
    assert_int_equal(pf_solver_factor(s, &a, &failed, &err), PF_OK);
    assert_int_equal(rec.n, 2);
    pf_solver_destroy(&s);
    pf_block_matrix_release(&a);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(dg_reports_its_phases),
        cmocka_unit_test(cg_reports_its_phases),
        cmocka_unit_test(hook_changes_no_result),
        cmocka_unit_test(solver_reports_analysis_and_factorisation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
