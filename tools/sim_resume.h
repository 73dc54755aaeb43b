/* pf-sim --resume: where a cut pf-sim stream can be continued from, and its prefix copied. */
#ifndef PF_TOOLS_SIM_RESUME_H
#define PF_TOOLS_SIM_RESUME_H

#include <stdio.h>

#include <pf/io.h>

typedef struct pf_resume_point {
    uint64_t offset;            /* the last complete CKPT chunk's byte offset */
    uint64_t end;               /* the byte after it: the prefix copied */
    uint32_t frame;             /* the frame it follows */
    uint32_t every;             /* the run's frames between checkpoints */
    int64_t frames;             /* complete FRAM chunks in the stream */
    bool complete;              /* the stream ends with its END_ chunk */
    char cut[PF_ERROR_MSG_MAX]; /* otherwise how it ends: the reader's message */
} pf_resume_point;

/* Reads the stream f (named name) to its end or its first damage and finds the last checkpoint of
 * the pf-sim run that wrote it. The stream's last INFO chunk must be pf-sim's, of this pf
 * version, and followed by the SCEN chunk. PF_ERR_FORMAT naming the stream: not written by
 * pf-sim, written by another version, or cut before its first checkpoint (then with the command
 * to rerun). */
pf_status pf_resume_find(FILE *f, const char *name, pf_resume_point *p, pf_error *err);

/* Reads the stream again from in (a reader on its start) and writes its chunks up to p->end to w
 * byte for byte, feeding state the chunks a simulation needs (MESH, SURF, WGHT, SCEN) and checking
 * the frames against it. *ckpt: the last chunk, the CKPT, valid until in's next read. */
pf_status pf_resume_copy(pf_stream_reader *in, const pf_resume_point *p, pf_stream_writer *w,
                         pf_stream_state *state, pf_chunk *ckpt, pf_error *err);

#endif
