/* The run's statistics as JSON (pf-sim --stats FILE): the simulator's and the solver's counters
 * and timings for pipelines and render farms. Keys are documented in docs/scene.md, "Run
 * statistics"; times are seconds, wall-clock unless the key says cpu. */
#include <pf/sim.h>

#include <math.h>

#include <cjson/cJSON.h>

#include "scene_json.h"
#include "sim_internal.h"

static void add_int(cJSON *o, const char *key, int64_t v)
{
    cJSON_AddNumberToObject(o, key, (double)v);
}

static cJSON *wall_cpu(cJSON *o, const char *key, double wall, double cpu)
{
    cJSON *t = cJSON_AddObjectToObject(o, key);
    cJSON_AddNumberToObject(t, "wall", wall);
    cJSON_AddNumberToObject(t, "cpu", cpu);
    return t;
}

static void add_solver(cJSON *root, const pf_solver_stats *ss)
{
    cJSON *s = cJSON_AddObjectToObject(root, "solver");
    cJSON_AddStringToObject(s, "method", pf_solver_method_name(ss->method));
    add_int(s, "solves", ss->solves);
    add_int(s, "factorisations", ss->factorisations);
    cJSON *reasons = cJSON_AddObjectToObject(s, "factorisations_by_reason");
    for (int k = 0; k < PF_REFACTOR_REASONS; ++k)
        add_int(reasons, pf_refactor_reason_name((pf_refactor_reason)k), ss->by_reason[k]);
    add_int(s, "pcg_solves", ss->pcg_solves);
    add_int(s, "pcg_iterations", ss->iterations);
    cJSON_AddNumberToObject(s, "pcg_iterations_mean",
                            ss->pcg_solves ? (double)ss->iterations / (double)ss->pcg_solves : 0);
    add_int(s, "pcg_iterations_max", ss->max_iterations);
    cJSON_AddNumberToObject(s, "factorisation_cost_in_iterations", ss->factor_iterations);
    add_int(s, "matrix_nnz", ss->matrix_nnz);
    add_int(s, "factor_nnz", ss->factor_nnz);
}

pf_status pf_sim_stats_json(const pf_sim *sim, double wall_seconds, double cpu_seconds, char **json,
                            pf_error *err)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    cJSON *root = cJSON_CreateObject();
    if (root) {
        add_int(root, "frames", pf_sim_frame_index(sim));
        cJSON_AddNumberToObject(root, "simulated_time", pf_sim_time(sim));
        add_int(root, "steps", st->steps);
        add_int(root, "dofs", st->dofs);
        cJSON_AddNumberToObject(root, "penalty", st->penalty);
        add_int(root, "penalty_doublings", st->penalty_doublings);
        add_int(root, "fixed_faces", st->fixed_faces);
        add_int(root, "loaded_faces", st->loaded_faces);
        add_int(root, "contact_points", st->contact_points);
        add_int(root, "contact_samples", st->contact_samples);
        add_int(root, "contacts", st->contacts);
        cJSON *ind = cJSON_AddObjectToObject(root, "error_indicator");
        cJSON_AddNumberToObject(ind, "value", pf_sim_error_indicator(sim));
        cJSON_AddStringToObject(ind, "measure", pf_sim_error_measure(sim, NULL));
        cJSON *cg = cJSON_AddObjectToObject(root, "cg");
        add_int(cg, "closed_form_elements", st->closed_form_elems);
        add_int(cg, "harmonic_elements", st->harmonic_elems);
        add_int(cg, "kernels", st->kernels);
        add_int(cg, "basis_reused", st->basis_reused);
        add_int(cg, "basis_computed", st->basis_computed);
        add_int(root, "integrals_reused", st->integrals_reused);
        add_int(root, "integrals_computed", st->integrals_computed);
        cJSON *sec = cJSON_AddObjectToObject(root, "seconds");
        wall_cpu(sec, "run", wall_seconds, cpu_seconds);
        wall_cpu(sec, "setup", st->setup_seconds, st->setup_cpu_seconds);
        cJSON_AddNumberToObject(sec, "basis", st->basis_seconds);
        wall_cpu(sec, "assembly", st->assemble_seconds, st->assemble_cpu_seconds);
        cJSON_AddNumberToObject(sec, "contact_search", st->contact_seconds);
        cJSON_AddNumberToObject(sec, "contact_positions", st->embed_seconds);
        wall_cpu(sec, "factorisation", st->solver.factor_seconds, st->solver.factor_cpu_seconds);
        wall_cpu(sec, "solves", st->solver.solve_seconds, st->solver.solve_cpu_seconds);
        add_solver(root, &st->solver);
        cJSON *changes = cJSON_AddObjectToObject(root, "mesh_changes");
        add_int(changes, "changes", st->refinements);
        add_int(changes, "elements", st->elements);
        add_int(changes, "elements_split", st->elements_split);
        add_int(changes, "elements_merged", st->elements_merged);
        add_int(changes, "integrals_reused", st->integrals_reused);
        add_int(changes, "integrals_computed", st->integrals_computed);
        add_int(changes, "embed_rows", st->embed_rows);
        add_int(changes, "embed_rows_computed", st->embed_rows_computed);
        cJSON_AddNumberToObject(changes, "embed_seconds", st->refine_embed_seconds);
        cJSON_AddNumberToObject(changes, "seconds", st->refine_seconds);
        cJSON *cuts = cJSON_AddObjectToObject(root, "cuts");
        add_int(cuts, "cuts", st->cuts);
        add_int(cuts, "elements_cut", st->elements_cut);
        add_int(cuts, "bodies", st->bodies);
        cJSON_AddNumberToObject(cuts, "dropped_volume", st->dropped_volume);
        cJSON_AddNumberToObject(cuts, "dropped_mass", st->dropped_mass);
        add_int(cuts, "uncapped_faces", st->uncapped_faces);
        cJSON_AddNumberToObject(cuts, "seconds", st->cut_seconds);
    }
    return pf_sim_json_print(root, "the run's statistics", json, err);
}

pf_status pf_sim_distrib_stats_json(const pf_scene *scene, const pf_sim_distrib_result *res,
                                    double wall_seconds, double cpu_seconds, char **json,
                                    pf_error *err)
{
    bool dynamic = !scene->is_static;
    int64_t solves = dynamic ? res->steps : 1;
    cJSON *root = cJSON_CreateObject();
    if (root) {
        add_int(root, "frames", dynamic ? res->frame : 1);
        cJSON_AddNumberToObject(root, "simulated_time", res->time);
        add_int(root, "steps", res->steps);
        add_int(root, "dofs", res->dofs);
        if (pf_scene_has_contact(scene))
            add_int(root, "contacts", res->contacts);
        cJSON_AddNumberToObject(root, "penalty", res->penalty);
        add_int(root, "penalty_doublings", res->penalty_doublings);
        cJSON *ind = cJSON_AddObjectToObject(root, "error_indicator");
        cJSON_AddNumberToObject(ind, "value", res->error_indicator);
        cJSON_AddStringToObject(ind, "measure", scene->method == PF_METHOD_CG
                                                    ? "basis_boundary_error"
                                                    : "node_jump_over_displacement");
        const pf_sim_distrib_rank *r0 = res->ranks > 0 ? &res->rank[0] : NULL;
        cJSON *sec = cJSON_AddObjectToObject(root, "seconds"); /* rank 0's */
        wall_cpu(sec, "run", wall_seconds, cpu_seconds);
        cJSON_AddNumberToObject(sec, "setup_cpu", r0 ? r0->setup_cpu_seconds : 0);
        cJSON_AddNumberToObject(sec, "assembly_cpu", r0 ? r0->assembly_cpu_seconds : 0);
        cJSON_AddNumberToObject(sec, "solves_cpu", r0 ? r0->solve_cpu_seconds : 0);
        cJSON *s = cJSON_AddObjectToObject(root, "solver");
        cJSON_AddStringToObject(s, "method", "petsc");
        add_int(s, "solves", solves);
        add_int(s, "factorisations", res->factorisations);
        add_int(s, "pcg_iterations", res->iterations);
        cJSON_AddNumberToObject(s, "pcg_iterations_mean",
                                solves > 0 ? (double)res->iterations / (double)solves : 0);
        cJSON_AddNumberToObject(s, "residual_max", res->residual);
        cJSON *ranks = cJSON_AddArrayToObject(root, "ranks");
        for (int32_t k = 0; ranks && k < res->ranks; ++k) {
            const pf_sim_distrib_rank *r = &res->rank[k];
            cJSON *o = cJSON_CreateObject();
            if (!o || !cJSON_AddItemToArray(ranks, o)) {
                cJSON_Delete(o);
                break;
            }
            add_int(o, "elements", r->elements);
            cJSON_AddNumberToObject(o, "setup_cpu", r->setup_cpu_seconds);
            cJSON_AddNumberToObject(o, "assembly_cpu", r->assembly_cpu_seconds);
            cJSON_AddNumberToObject(o, "solves_cpu", r->solve_cpu_seconds);
            cJSON_AddNumberToObject(o, "cpu", r->cpu_seconds);
            cJSON_AddNumberToObject(o, "peak_rss_mb", r->peak_rss_mb);
        }
    }
    return pf_sim_json_print(root, "the run's statistics", json, err);
}

void pf_sim_run_counts(const pf_sim *sim, pf_run_counts *c)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    c->steps = (uint64_t)st->steps;
    c->factorisations = (uint64_t)st->factorisations;
    c->solves = (uint64_t)st->solver.solves;
    c->pcg_iterations = (uint64_t)st->solver.iterations;
}

/* What a STAT chunk holds of a run, whichever path made it. */
typedef struct run_entries {
    double indicator; /* non-finite: left out */
    int32_t elements, frames, mesh_changes, cuts;
    int64_t dofs;
    double time;
    pf_run_counts counts;
    pf_solver_method solver;
} run_entries;

static pf_status set_entries(const pf_scene *sc, const run_entries *r, pf_stats_data *d,
                             pf_error *err)
{
    bool dg = sc->method == PF_METHOD_DG;
    PF_TRY(pf_stats_data_set_text(d, "method", dg ? "dg" : "cg", err));
    if (dg) {
        PF_TRY(pf_stats_data_set_number(d, "degree", sc->degree, err));
        PF_TRY(pf_stats_data_set_text(d, "flux", sc->flux == PF_FLUX_BZ ? "bz" : "ip", err));
    }
    if (isfinite(r->indicator))
        PF_TRY(pf_stats_data_set_number(d, "error_indicator", r->indicator, err));
    PF_TRY(pf_stats_data_set_text(d, "error_measure", pf_method_ops_of(sc->method)->error_measure,
                                  err));
    PF_TRY(pf_stats_data_set_number(d, "elements", r->elements, err));
    PF_TRY(pf_stats_data_set_number(d, "unknowns", (double)r->dofs, err));
    PF_TRY(pf_stats_data_set_number(d, "frames", r->frames, err));
    if (isfinite(r->time))
        PF_TRY(pf_stats_data_set_number(d, "simulated_time", r->time, err));
    PF_TRY(pf_stats_data_set_number(d, "steps", (double)r->counts.steps, err));
    PF_TRY(pf_stats_data_set_number(d, "factorisations", (double)r->counts.factorisations, err));
    PF_TRY(pf_stats_data_set_number(d, "solves", (double)r->counts.solves, err));
    PF_TRY(pf_stats_data_set_number(d, "pcg_iterations", (double)r->counts.pcg_iterations, err));
    PF_TRY(pf_stats_data_set_text(d, "solver", pf_solver_method_name(r->solver), err));
    PF_TRY(pf_stats_data_set_number(d, "mesh_changes", r->mesh_changes, err));
    return pf_stats_data_set_number(d, "cuts", r->cuts, err);
}

pf_status pf_sim_stats_entries(const pf_sim *sim, const pf_run_counts *counts, pf_stats_data *d,
                               pf_error *err)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    run_entries r = {.indicator = pf_sim_error_indicator(sim),
                     .elements = pf_sim_mesh(sim)->n_elems,
                     .frames = pf_sim_frame_index(sim),
                     .mesh_changes = st->refinements,
                     .cuts = st->cuts,
                     .dofs = st->dofs,
                     .time = pf_sim_time(sim),
                     .solver = st->solver.method};
    pf_sim_run_counts(sim, &r.counts);
    if (counts)
        r.counts = *counts;
    return set_entries(sim->scene, &r, d, err);
}

pf_status pf_sim_distrib_stats_entries(const pf_scene *scene, int32_t elements,
                                       const pf_sim_distrib_result *res, pf_stats_data *d,
                                       pf_error *err)
{
    bool dynamic = !scene->is_static;
    run_entries r = {.indicator = res->error_indicator,
                     .elements = elements,
                     .frames = dynamic ? res->frame : 1,
                     .dofs = res->dofs,
                     .time = res->time,
                     .counts = {.steps = (uint64_t)res->steps,
                                .factorisations = (uint64_t)res->factorisations,
                                .solves = (uint64_t)(dynamic ? res->steps : 1),
                                .pcg_iterations = (uint64_t)res->iterations},
                     .solver = PF_SOLVER_PETSC};
    return set_entries(scene, &r, d, err);
}
