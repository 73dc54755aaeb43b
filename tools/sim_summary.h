/* pf-sim's solver summary line on stderr: method, factorisations by reason, PCG iterations, CPU
 * beside wall seconds (PETSc: ranks and rank 0's share). */
#ifndef PF_TOOLS_SIM_SUMMARY_H
#define PF_TOOLS_SIM_SUMMARY_H

#include <pf/solve.h>

void pf_cli_solver_summary(const pf_solver_stats *ss);

#endif
