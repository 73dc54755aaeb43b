/* pf-sim's summary lines on stderr (the solver's: method, factorisations by reason, PCG
 * iterations, CPU beside wall seconds; PETSc: ranks and rank 0's share) and its STAT chunk. */
#ifndef PF_TOOLS_SIM_SUMMARY_H
#define PF_TOOLS_SIM_SUMMARY_H

#include <pf/io.h>
#include <pf/sim.h>
#include <pf/solve.h>

void pf_cli_solver_summary(const pf_solver_stats *ss);

/* pf-sim's summary on stderr: method, elements, unknowns, steps, timings, contact, the error
 * indicator, mesh changes, cuts and the solver line. embedded: contact at the embedded surface's
 * vertices; input_elems: the elements of the input mesh (before mesh changes). */
void pf_cli_sim_summary(const pf_sim *sim, bool embedded, int32_t input_elems);

/* The run's STAT chunk (pf_sim_stats_entries; counts NULL: the simulator's own) to w. */
pf_status pf_cli_write_stat(pf_stream_writer *w, const pf_sim *sim, const pf_run_counts *counts,
                            pf_error *err);

#endif
