/* pf-sim's side of a run on MPI ranks: their start, and a run with every rank assembling its own
 * elements (pf_sim_distrib_run_with): its frames, checkpoints, statistics and summary. */
#ifndef PF_TOOLS_SIM_DISTRIB_OUT_H
#define PF_TOOLS_SIM_DISTRIB_OUT_H

#include <pf/io.h>
#include <pf/sim.h>

/* What pf-sim gives such a run (borrowed). */
typedef struct pf_cli_distrib_run {
    pf_stream_writer *out;
    const pf_scene *scene; /* resolved, its files read */
    const pf_mesh *mesh;   /* derived */
    int64_t first_written; /* --frames A:B: frames before A are not written */
    int32_t checkpoint_every;
    const pf_chunk *restore; /* the CKPT chunk to continue from (NULL: the start) */
    const char *resume_path; /* the stream it is in, for messages */
    bool quiet;
    const char *stats_path; /* --stats FILE, or NULL */
    double wall0, cpu0;     /* the clocks at the start */
    int32_t checkpoints;    /* CKPT chunks written (out) */
} pf_cli_distrib_run;

/* The run: frames written as they come (FRAM, STRS), a CKPT chunk after frames 0, N, 2N, ... and
 * the last (the one-process run's payload: pf_sim_distrib_checkpoint_fn), STAT (also after a
 * diverged frame), the summary on stderr unless quiet, --stats. A restored run continues the
 * checkpoint's counters. */
pf_status pf_cli_distrib_simulate(pf_cli_distrib_run *d, pf_error *err);

/* argv without PETSc's options (one dash and a lower-case letter or '_', with the word after as
 * their value when it starts with no dash; -h and -q are pf-sim's) into kept [argc + 1],
 * NULL-terminated; returns their count. */
int pf_cli_without_petsc_options(int argc, char **argv, char **kept);
/* The rank of this process as an MPI launcher set it (-1: not launched by one). */
int pf_cli_launcher_rank(void);
/* Under mpirun: PETSc and MPI up, ranks > 0 serve rank 0 until it finalises and exit there;
 * rank 0 returns to run pf-sim. Not under mpirun: nothing. */
void pf_cli_start_mpi(int *argc, char ***argv);

#endif
