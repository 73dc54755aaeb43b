/* pf-sim's output of a run with every rank assembling its own elements (pf_sim_distrib_run). */
#ifndef PF_TOOLS_SIM_DISTRIB_OUT_H
#define PF_TOOLS_SIM_DISTRIB_OUT_H

#include <pf/io.h>
#include <pf/sim.h>

/* The run's STAT chunk (pf_sim_distrib_stats_entries) for scene on a mesh of elements. */
pf_status pf_cli_distrib_stat(pf_stream_writer *out, const pf_scene *scene, int32_t elements,
                              const pf_sim_distrib_result *res, pf_error *err);

/* The summary on stderr: the scene's method, unknowns, DG's penalty, solve, and per rank its
 * elements, set-up CPU and peak memory; for dynamics the steps, iterations per step, contacts
 * and the last frame's kinetic energy. */
void pf_cli_distrib_summary(const pf_sim_distrib_result *res, int32_t elements,
                            const pf_scene *scene);

#endif
