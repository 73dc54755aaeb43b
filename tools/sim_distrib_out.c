/* pf-sim's output of a run with every rank assembling its own elements (sim_distrib_out.h). */
#include "sim_distrib_out.h"

#include <stdio.h>

pf_status pf_cli_distrib_stat(pf_stream_writer *out, const pf_scene *scene, int32_t elements,
                              const pf_sim_distrib_result *res, pf_error *err)
{
    pf_stats_data d = {0};
    pf_status st = pf_sim_distrib_stats_entries(scene, elements, res, &d, err);
    if (st >= 0)
        st = pf_stream_write_stats(out, &d, err);
    pf_stats_data_release(&d);
    return st;
}

void pf_cli_distrib_summary(const pf_sim_distrib_result *res, int32_t elements,
                            const pf_scene *scene)
{
    bool cg = scene->method == PF_METHOD_CG;
    char penalty[64] = "";
    if (!cg && res->penalty_doublings > 0)
        snprintf(penalty, sizeof penalty, ", penalty %g (%d doublings)", res->penalty,
                 (int)res->penalty_doublings);
    else if (!cg)
        snprintf(penalty, sizeof penalty, ", penalty %g", res->penalty);
    fprintf(stderr,
            "pf-sim: %s, %d elements, %lld unknowns%s, assembled on %d ranks; solver petsc: %d "
            "iterations%s, residual %.3g%s\n",
            cg ? "cg" : "dg", (int)elements, (long long)res->dofs, penalty, (int)res->ranks,
            (int)res->iterations, res->steps > 0 ? " in all" : "", res->residual,
            res->steps > 0 ? " at most" : "");
    char contact[64] = "";
    if (pf_scene_has_contact(scene))
        snprintf(contact, sizeof contact, "; %lld contacts at the boundary nodes",
                 (long long)res->contacts);
    if (res->steps > 0)
        fprintf(stderr,
                "pf-sim: %lld steps, %.2f iterations per step%s; kinetic energy %.6g at the last "
                "frame\n",
                (long long)res->steps, (double)res->iterations / (double)res->steps, contact,
                res->kinetic);
    for (int32_t r = 0; r < res->ranks; ++r)
        fprintf(stderr,
                "pf-sim: rank %d: %d elements assembled, set-up %.3f s cpu, %.3f s cpu in all, "
                "peak RSS %.1f MB\n",
                (int)r, (int)res->rank[r].elements, res->rank[r].setup_cpu_seconds,
                res->rank[r].cpu_seconds, res->rank[r].peak_rss_mb);
}
