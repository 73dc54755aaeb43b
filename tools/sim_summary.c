/* pf-sim's solver summary line (sim_summary.h). */
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
