/* pf-sim's output of a distributed static solve (pf_sim_distrib_static). */
#ifndef PF_TOOLS_SIM_DISTRIB_OUT_H
#define PF_TOOLS_SIM_DISTRIB_OUT_H

#include <pf/io.h>
#include <pf/sim.h>

/* Frame 0 (FRAM and STRS) of mesh m from the result, as pf-sim writes a static frame. */
pf_status pf_cli_distrib_frame(pf_stream_writer *out, const pf_mesh *m,
                               const pf_sim_distrib_result *res, pf_error *err);

/* The summary on stderr: the method (cg: CG, else DG), unknowns, DG's penalty, solve, and per
 * rank its elements, set-up CPU and peak memory. */
void pf_cli_distrib_summary(const pf_sim_distrib_result *res, int32_t elements, bool cg);

#endif
