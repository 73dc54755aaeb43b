/* pf-sim's side of a run on MPI ranks (sim_distrib_out.h): the start, and the run with every
 * rank assembling its own elements. */
#include "sim_distrib_out.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

/* The run's state on pf-sim's side: the options' context. */
typedef struct distrib_ctx {
    pf_cli_distrib_run *d;
    pf_run_counts base; /* the restored checkpoint's counters (zero: a new run) */
    pf_buffer checkpoint;
} distrib_ctx;

/* The whole run's counts in res: a restored run's include the checkpoint's, and not the set-up's
 * definiteness tests of the process that continues (as on one process). */
static pf_sim_distrib_result whole(const distrib_ctx *c, const pf_sim_distrib_result *res)
{
    pf_sim_distrib_result r = *res;
    if (!c->d->restore)
        return r;
    r.steps += (int64_t)c->base.steps;
    r.iterations += (int32_t)c->base.pcg_iterations;
    r.factorisations = (int32_t)c->base.factorisations;
    return r;
}

/* The counters of a CKPT header, as STAT counts them (pf_sim_distrib_stats_entries). */
static pf_run_counts counts_of(const pf_scene *scene, const pf_sim_distrib_result *r)
{
    return (pf_run_counts){.steps = (uint64_t)r->steps,
                           .factorisations = (uint64_t)r->factorisations,
                           .solves = (uint64_t)(scene->is_static ? 1 : r->steps),
                           .pcg_iterations = (uint64_t)r->iterations};
}

static pf_status frame_out(void *ctx, const pf_sim_distrib_result *res, pf_error *err)
{
    const pf_cli_distrib_run *d = ((distrib_ctx *)ctx)->d;
    return res->frame >= d->first_written
               ? pf_cli_write_frame(d->out, d->mesh, (uint32_t)res->frame, res->time, res->u,
                                    res->von_mises, err)
               : PF_OK;
}

static pf_status checkpoint_out(void *ctx, const pf_sim_distrib_result *res, const void *state,
                                size_t size, pf_error *err)
{
    distrib_ctx *c = ctx;
    pf_cli_distrib_run *d = c->d;
    pf_sim_distrib_result r = whole(c, res);
    pf_checkpoint_header h = {.mesh_id = d->mesh->id,
                              .frame = (uint32_t)res->frame,
                              .every = (uint32_t)d->checkpoint_every,
                              .counts = counts_of(d->scene, &r)};
    c->checkpoint.size = 0;
    PF_TRY(pf_stream_encode_checkpoint_header(&h, &c->checkpoint, err));
    PF_TRY(pf_buffer_append(&c->checkpoint, state, size, err));
    PF_TRY(pf_stream_write_chunk(d->out, "CKPT", pf_stream_tag_version("CKPT"), c->checkpoint.data,
                                 c->checkpoint.size, err));
    d->checkpoints++;
    return PF_OK;
}

static pf_status write_stat(const pf_cli_distrib_run *d, const pf_sim_distrib_result *res,
                            pf_error *err)
{
    pf_stats_data s = {0};
    pf_status st = pf_sim_distrib_stats_entries(d->scene, d->mesh->n_elems, res, &s, err);
    if (st >= 0)
        st = pf_stream_write_stats(d->out, &s, err);
    pf_stats_data_release(&s);
    return st;
}

static void summary(const pf_sim_distrib_result *res, int32_t elements, const pf_scene *scene)
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

static pf_status write_stats(const pf_cli_distrib_run *d, const pf_sim_distrib_result *res,
                             pf_error *err)
{
    char *json = NULL;
    PF_TRY(pf_sim_distrib_stats_json(d->scene, res, pf_time_seconds() - d->wall0,
                                     pf_cpu_seconds() - d->cpu0, &json, err));
    pf_status st = pf_write_file_atomic(d->stats_path, json, strlen(json), "statistics", err);
    pf_free(json);
    return st;
}

/* The options of the run: frames, checkpoints and the state to continue from. */
static pf_status options(distrib_ctx *c, pf_sim_distrib_options *opt, pf_error *err)
{
    pf_cli_distrib_run *d = c->d;
    *opt = (pf_sim_distrib_options){.frame = frame_out,
                                    .checkpoint = checkpoint_out,
                                    .ctx = c,
                                    .checkpoint_every = d->checkpoint_every};
    if (!d->restore)
        return PF_OK;
    pf_checkpoint_header h = {0};
    PF_TRY(pf_stream_checkpoint_header(d->restore, &h, err));
    PF_CHECK(h.have_counts, err, PF_ERR_UNSUPPORTED,
             "%s: chunk CKPT at byte %llu: a version 1 checkpoint, without the run's counters for "
             "its STAT chunk (an older pf-sim wrote it): rerun",
             d->resume_path, (unsigned long long)d->restore->offset);
    c->base = h.counts;
    opt->restore = h.state;
    opt->restore_size = (size_t)h.state_size;
    return PF_OK;
}

pf_status pf_cli_distrib_simulate(pf_cli_distrib_run *d, pf_error *err)
{
    distrib_ctx c = {.d = d};
    pf_sim_distrib_options opt;
    PF_TRY(options(&c, &opt, err));
    pf_sim_distrib_result res;
    pf_status st = pf_sim_distrib_run_with(d->scene, d->mesh, &opt, &res, err);
    if (st < 0 && d->restore && err->status != PF_ERR_NUMERIC)
        pf_error_prefix(err, "%s: chunk CKPT at byte %llu", d->resume_path,
                        (unsigned long long)d->restore->offset);
    pf_sim_distrib_result all = whole(&c, &res);
    bool ran = st >= 0 || err->status == PF_ERR_NUMERIC; /* also after a diverged frame */
    if (ran) {
        pf_error stat_err = {0};
        pf_status ss = write_stat(d, &all, &stat_err);
        if (ss < 0 && st >= 0) {
            *err = stat_err;
            st = ss;
        }
    }
    if (st >= 0 && !d->quiet)
        summary(&res, d->mesh->n_elems, d->scene);
    if (d->stats_path && ran) {
        pf_error stats_err = {0};
        pf_status ss = write_stats(d, &all, &stats_err);
        if (ss < 0 && st >= 0) {
            *err = stats_err;
            st = ss;
        }
    }
    pf_buffer_release(&c.checkpoint);
    pf_sim_distrib_result_release(&res);
    return st;
}

/* PETSc's options (one dash and a letter: -ksp_rtol 1e-12, -ksp_monitor) are PETSc's to read;
 * pf-sim's parser sees the rest. A word after such an option that does not start with a dash
 * is its value. */
int pf_cli_without_petsc_options(int argc, char **argv, char **kept)
{
    int n = 0;
    for (int k = 0; k < argc; ++k) {
        const char *a = argv[k];
        /* -h and -q are pf-sim's own (-q: --quiet; as PETSc's, it took the next word, a scene
         * file, as its value) */
        bool petsc = k > 0 && a[0] == '-' && ((a[1] >= 'a' && a[1] <= 'z') || a[1] == '_') &&
                     strcmp(a, "-h") != 0 && strcmp(a, "-q") != 0;
        if (!petsc) {
            kept[n++] = argv[k];
            continue;
        }
        if (k + 1 < argc && argv[k + 1][0] != '-')
            ++k;
    }
    kept[n] = NULL;
    return n;
}

/* The rank of this process as an MPI launcher set it (-1: not launched by one). */
int pf_cli_launcher_rank(void)
{
    static const char *const names[] = {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"};
    for (size_t k = 0; k < sizeof names / sizeof *names; ++k) {
        const char *v = getenv(names[k]);
        if (v && *v)
            return atoi(v);
    }
    return -1;
}

/* Under mpirun every rank starts here: PETSc and MPI come up, ranks > 0 serve rank 0's solves
 * until it finalises (pf/solve.h), and rank 0 runs pf-sim. An error on rank 0 ends it with the
 * message and exit 1, and its exit handler stops the serving ranks. */
void pf_cli_start_mpi(int *argc, char ***argv)
{
    int launched = pf_cli_launcher_rank();
    if (launched < 0)
        return;
    if (!pf_petsc_available()) {
        if (launched == 0)
            fprintf(stderr, "pf-sim: started by mpirun, but this pf was built without PETSc "
                            "(configure with -DPF_PETSC=ON after scripts/setup --petsc)\n");
        exit(PF_EXIT_INPUT);
    }
    pf_error err = {0};
    int rank = 0;
    if (pf_petsc_initialize(argc, argv, &rank, NULL, &err) < 0) {
        fprintf(stderr, "pf-sim: %s\n", err.msg);
        exit(PF_EXIT_INPUT);
    }
    if (rank > 0) {
        int code = PF_EXIT_INPUT;
        if (pf_petsc_serve(pf_sim_distrib_serve, &code, &err) < 0)
            fprintf(stderr, "pf-sim: rank %d: %s\n", rank, err.msg);
        exit(code);
    }
}
