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

void pf_sim_run_counts(const pf_sim *sim, pf_run_counts *c)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    c->steps = (uint64_t)st->steps;
    c->factorisations = (uint64_t)st->factorisations;
    c->solves = (uint64_t)st->solver.solves;
    c->pcg_iterations = (uint64_t)st->solver.iterations;
}

pf_status pf_sim_stats_entries(const pf_sim *sim, const pf_run_counts *counts, pf_stats_data *d,
                               pf_error *err)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    const pf_scene *sc = sim->scene;
    bool dg = sc->method == PF_METHOD_DG;
    pf_run_counts own;
    pf_sim_run_counts(sim, &own);
    if (!counts)
        counts = &own;
    PF_TRY(pf_stats_data_set_text(d, "method", dg ? "dg" : "cg", err));
    if (dg) {
        PF_TRY(pf_stats_data_set_number(d, "degree", sc->degree, err));
        PF_TRY(pf_stats_data_set_text(d, "flux", sc->flux == PF_FLUX_BZ ? "bz" : "ip", err));
    }
    double indicator = pf_sim_error_indicator(sim);
    if (isfinite(indicator))
        PF_TRY(pf_stats_data_set_number(d, "error_indicator", indicator, err));
    PF_TRY(pf_stats_data_set_text(d, "error_measure", pf_sim_error_measure(sim, NULL), err));
    PF_TRY(pf_stats_data_set_number(d, "elements", pf_sim_mesh(sim)->n_elems, err));
    PF_TRY(pf_stats_data_set_number(d, "unknowns", (double)st->dofs, err));
    PF_TRY(pf_stats_data_set_number(d, "frames", pf_sim_frame_index(sim), err));
    if (isfinite(pf_sim_time(sim)))
        PF_TRY(pf_stats_data_set_number(d, "simulated_time", pf_sim_time(sim), err));
    PF_TRY(pf_stats_data_set_number(d, "steps", (double)counts->steps, err));
    PF_TRY(pf_stats_data_set_number(d, "factorisations", (double)counts->factorisations, err));
    PF_TRY(pf_stats_data_set_number(d, "solves", (double)counts->solves, err));
    PF_TRY(pf_stats_data_set_number(d, "pcg_iterations", (double)counts->pcg_iterations, err));
    PF_TRY(pf_stats_data_set_text(d, "solver", pf_solver_method_name(st->solver.method), err));
    PF_TRY(pf_stats_data_set_number(d, "mesh_changes", st->refinements, err));
    return pf_stats_data_set_number(d, "cuts", st->cuts, err);
}
