/* pf-sim's summary lines and its STAT chunk (sim_summary.h). */
#include "sim_summary.h"

#include <stdio.h>

/* The solver line: method, factorisations by reason, PCG iterations, CPU beside wall seconds. */
void pf_cli_solver_summary(const pf_solver_stats *ss)
{
    if (ss->method == PF_SOLVER_PETSC) {
        int ranks = 1;
        pf_error ignored = {0};
        pf_petsc_initialize(NULL, NULL, NULL, &ranks, &ignored); /* initialised: the size */
        fprintf(stderr,
                "pf-sim: solver petsc on %d ranks: %lld solves, %.1f iterations mean, %d max; "
                "solves %.3f s wall / %.3f s cpu (rank 0); %lld factorisations on rank 0 "
                "(definiteness tests), %.3f s\n",
                ranks, (long long)ss->solves,
                ss->solves ? (double)ss->iterations / (double)ss->solves : 0.0,
                (int)ss->max_iterations, ss->solve_seconds, ss->solve_cpu_seconds,
                (long long)ss->factorisations, ss->factor_seconds);
        return;
    }
    fprintf(stderr, "pf-sim: solver %s: %lld solves, %lld factorisations (",
            pf_solver_method_name(ss->method), (long long)ss->solves,
            (long long)ss->factorisations);
    const char *sep = "";
    for (int k = 0; k < PF_REFACTOR_REASONS; ++k)
        if (ss->by_reason[k]) {
            fprintf(stderr, "%s%lld %s", sep, (long long)ss->by_reason[k],
                    pf_refactor_reason_name((pf_refactor_reason)k));
            sep = ", ";
        }
    fprintf(stderr,
            "), pcg %lld solves, %.1f iterations mean, %d max; factor %.3f s wall / %.3f s cpu, "
            "solves %.3f s wall / %.3f s cpu; a factorisation costs %.0f iterations\n",
            (long long)ss->pcg_solves,
            ss->pcg_solves ? (double)ss->iterations / (double)ss->pcg_solves : 0.0,
            (int)ss->max_iterations, ss->factor_seconds, ss->factor_cpu_seconds, ss->solve_seconds,
            ss->solve_cpu_seconds, ss->factor_iterations);
}

void pf_cli_sim_summary(const pf_sim *sim, bool embedded, int32_t input_elems)
{
    const pf_sim_stats *st = pf_sim_get_stats(sim);
    bool is_cg = st->closed_form_elems + st->harmonic_elems > 0; /* dg counts neither */
    char samples[64] = "";
    if (st->contact_samples > 0)
        snprintf(samples, sizeof samples, " and %d samples on large triangles",
                 (int)st->contact_samples);
    if (is_cg)
        fprintf(stderr,
                "pf-sim: cg, %d elements (%d closed forms, MFS skipped; %d harmonic, %lld "
                "kernels, basis %.3f s), %lld unknowns, %lld steps; ",
                (int)st->elements, (int)st->closed_form_elems, (int)st->harmonic_elems,
                (long long)st->kernels, st->basis_seconds, (long long)st->dofs,
                (long long)st->steps);
    else
        fprintf(stderr,
                "pf-sim: dg, %d elements, %lld unknowns, penalty %g (%d doublings), %lld steps; ",
                (int)st->elements, (long long)st->dofs, st->penalty, (int)st->penalty_doublings,
                (long long)st->steps);
    fprintf(stderr,
            "setup %.3f s wall / %.3f s cpu, assembly %.3f s wall / %.3f s cpu, factorisation "
            "%.3f s (%lld), solves %.3f s; contact at %d %s%s: %lld contacts, search %.3f s, "
            "positions %.3f s\n",
            st->setup_seconds, st->setup_cpu_seconds, st->assemble_seconds,
            st->assemble_cpu_seconds, st->factor_seconds, (long long)st->factorisations,
            st->solve_seconds, (int)st->contact_points, embedded ? "surface vertices" : "nodes",
            samples, (long long)st->contacts, st->contact_seconds, st->embed_seconds);
    const char *meaning;
    pf_sim_error_measure(sim, &meaning);
    fprintf(stderr, "pf-sim: error indicator %.3g (%s)\n", pf_sim_error_indicator(sim), meaning);
    if (st->refinements > 0)
        fprintf(stderr,
                "pf-sim: mesh changes: %d (%lld elements split, %lld groups merged back; %d -> "
                "%d elements), %.3f s cpu; integrals %lld reused, %lld computed; shape "
                "functions %lld reused, %lld built; embedding rows %lld of %lld recomputed "
                "(%.3f s cpu)\n",
                (int)st->refinements, (long long)st->elements_split, (long long)st->elements_merged,
                (int)input_elems, (int)st->elements, st->refine_seconds,
                (long long)st->integrals_reused, (long long)st->integrals_computed,
                (long long)st->basis_reused, (long long)st->basis_computed,
                (long long)st->embed_rows_computed, (long long)st->embed_rows,
                st->refine_embed_seconds);
    if (st->cuts > 0)
        fprintf(stderr,
                "pf-sim: cuts: %d (%lld elements split), %d bodies, %.3g dropped (volume %.3g), "
                "%.3f s cpu\n",
                (int)st->cuts, (long long)st->elements_cut, (int)st->bodies, st->dropped_mass,
                st->dropped_volume, st->cut_seconds);
    if (st->uncapped_faces > 0)
        fprintf(stderr,
                "pf-sim: warning: %d opened faces left without a cap (their boundary inside the "
                "embedded surface did not close): the rendered surface has holes there\n",
                (int)st->uncapped_faces);
    pf_cli_solver_summary(&st->solver);
}

pf_status pf_cli_write_stat(pf_stream_writer *w, const pf_sim *sim, const pf_run_counts *counts,
                            pf_error *err)
{
    pf_stats_data d = {0};
    pf_status st = pf_sim_stats_entries(sim, counts, &d, err);
    if (st >= 0)
        st = pf_stream_write_stats(w, &d, err);
    pf_stats_data_release(&d);
    return st;
}
