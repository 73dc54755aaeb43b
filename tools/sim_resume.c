/* pf-sim --resume: the last checkpoint of a cut pf-sim stream, and the copy of the stream up to it.
 *
 * A pf-sim stream is the input's chunks, pf-sim's INFO, SCEN, then per frame FRAM, STRS and,
 * every N frames and after the last, CKPT (docs/stream-format.md). Everything up to a CKPT is what
 * the uninterrupted run wrote up to there, so the resumed stream starts with those bytes, copied
 * as they are, and the simulator restored from the CKPT writes the rest. */
#include "sim_resume.h"

#include <string.h>

#include <pf/sim.h>

/* The stream's pf-sim INFO: the command line to rerun and the version that wrote it. */
typedef struct scan {
    pf_info_data info; /* the latest INFO */
    bool info_is_sim;  /* ... is pf-sim's */
    bool prev_info;    /* the chunk before is that INFO */
    bool sim_scene;    /* pf-sim's SCEN followed its INFO */
    bool later_info;   /* an INFO after pf-sim's SCEN: another tool rewrote the stream */
    bool have_checkpoint;
    bool refines;      /* pf-sim's scene refines: its mesh changes between frames */
    bool mesh_changed; /* a MESH after pf-sim's SCEN: pf-sim refined the mesh */
} scan;

/* Whether the scene of pf-sim's SCEN refines ("refine" key). A scene that does not parse is left
 * to the resume's own reading of it, which names the problem. */
static bool scene_refines(const pf_chunk *c)
{
    char *json = NULL;
    size_t size = 0;
    pf_error ignored = {0};
    pf_scene scene = {0};
    bool refines = pf_stream_decode_scene(c, &json, &size, &ignored) >= 0 &&
                   pf_scene_parse(&scene, json, size, "SCEN", &ignored) >= 0 &&
                   pf_scene_changes_mesh(&scene);
    pf_scene_release(&scene);
    pf_free(json);
    return refines;
}

static pf_status take(scan *s, const pf_chunk *c, pf_resume_point *p, pf_error *err)
{
    bool info = strcmp(c->tag, "INFO") == 0;
    if (info) {
        if (s->sim_scene)
            s->later_info = true;
        pf_info_data_release(&s->info);
        PF_TRY(pf_stream_decode_info(c, &s->info, err));
        s->info_is_sim = strcmp(s->info.producer, "pf-sim") == 0;
    } else if (strcmp(c->tag, "SCEN") == 0) {
        s->sim_scene = s->prev_info && s->info_is_sim;
        s->refines = s->sim_scene && scene_refines(c);
    } else if (strcmp(c->tag, "MESH") == 0) {
        s->mesh_changed = s->mesh_changed || (s->sim_scene && !s->later_info);
    } else if (strcmp(c->tag, "FRAM") == 0) {
        ++p->frames;
    } else if (strcmp(c->tag, "CKPT") == 0 && s->sim_scene && !s->later_info) {
        pf_checkpoint_header h;
        PF_TRY(pf_stream_checkpoint_header(c, &h, err));
        p->frame = h.frame;
        p->every = h.every;
        p->offset = c->offset;
        p->end = c->offset + PF_STREAM_HEADER_BYTES + c->size + PF_STREAM_CRC_BYTES;
        s->have_checkpoint = true;
    }
    s->prev_info = info;
    return PF_OK;
}

/* Why the stream cannot be resumed, once read. A cut stream without a checkpoint after pf-sim's
 * INFO may be pf-sim's cut early (its input's chunks come first) as well as another tool's. */
static pf_status check(const scan *s, const char *name, const pf_resume_point *p, pf_error *err)
{
    bool sim = s->info.producer && s->info_is_sim && !s->later_info;
    PF_CHECK(sim || p->cut[0], err, PF_ERR_FORMAT,
             "%s: not written by pf-sim: its last INFO chunk is %s's; --resume continues pf-sim's "
             "own output",
             name, s->info.producer ? s->info.producer : "nobody");
    PF_CHECK(sim || s->later_info, err, PF_ERR_FORMAT,
             "%s: cut before pf-sim's first checkpoint, or not written by pf-sim (no pf-sim INFO "
             "chunk before the cut: %s): nothing to resume from; rerun pf-sim",
             name, p->cut);
    PF_CHECK(sim, err, PF_ERR_FORMAT,
             "%s: not written by pf-sim: %s rewrote its output; --resume continues pf-sim's own "
             "output",
             name, s->info.producer);
    PF_CHECK(strcmp(s->info.version, PF_VERSION_STRING) == 0, err, PF_ERR_FORMAT,
             "%s: written by pf-sim %s; this is pf-sim %s, whose frames may differ in their last "
             "bits: resume it with pf-sim %s",
             name, s->info.version, PF_VERSION_STRING, s->info.version);
    PF_CHECK(!s->refines && !s->mesh_changed, err, PF_ERR_UNSUPPORTED,
             "%s: resuming a run whose mesh changed (refinement) is not supported yet (%s): "
             "rerun: %s",
             name,
             s->mesh_changed ? "pf-sim wrote a new MESH after its SCEN"
                             : "its scene refines, and pf-sim writes no checkpoint then",
             s->info.command);
    PF_CHECK(s->have_checkpoint || p->cut[0], err, PF_ERR_FORMAT,
             "%s: no CKPT chunk (written with --checkpoint-every 0): nothing to resume from", name);
    PF_CHECK(s->have_checkpoint, err, PF_ERR_FORMAT,
             "%s: cut before its first checkpoint (%lld complete frames, no complete CKPT chunk): "
             "nothing to resume from; rerun: %s",
             name, (long long)p->frames, s->info.command);
    return PF_OK;
}

pf_status pf_resume_find(FILE *f, const char *name, pf_resume_point *p, pf_error *err)
{
    memset(p, 0, sizeof *p);
    pf_stream_reader *in = NULL;
    if (pf_stream_reader_create(&in, f, name, err) < 0) {
        char msg[PF_ERROR_MSG_MAX];
        snprintf(msg, sizeof msg, "%s", err->msg);
        snprintf(err->msg, sizeof err->msg, "%.400s: nothing to resume from; rerun pf-sim", msg);
        return err->status;
    }
    scan s = {0};
    pf_status st = PF_OK;
    for (;;) {
        pf_chunk c;
        bool end = false;
        pf_error cut = {0};
        if (pf_stream_read_chunk(in, &c, &end, &cut) < 0) {
            /* the end of what can be used: a cut (or damage) */
            snprintf(p->cut, sizeof p->cut, "%s", cut.msg);
            break;
        }
        if (end) {
            p->complete = true;
            break;
        }
        st = take(&s, &c, p, err);
        if (st < 0)
            break;
    }
    if (st >= 0)
        st = check(&s, name, p, err);
    pf_info_data_release(&s.info);
    pf_stream_reader_destroy(&in);
    return st;
}

pf_status pf_resume_copy(pf_stream_reader *in, const pf_resume_point *p, pf_stream_writer *w,
                         pf_stream_state *state, pf_chunk *ckpt, pf_error *err)
{
    for (;;) {
        pf_chunk c;
        bool end = false;
        PF_TRY(pf_stream_read_chunk(in, &c, &end, err));
        PF_CHECK(!end && strcmp(c.tag, "END_") != 0 && c.offset <= p->offset, err, PF_ERR_IO,
                 "%s changed while being resumed: no CKPT chunk at byte %llu any more", c.source,
                 (unsigned long long)p->offset);
        PF_TRY(pf_stream_write_raw(w, &c, err));
        if (strcmp(c.tag, "FRAM") == 0) {
            uint32_t index;
            PF_TRY(pf_stream_state_skip_frame(state, &c, &index, err));
        } else if (strcmp(c.tag, "STRS") != 0 && strcmp(c.tag, "CKPT") != 0) {
            PF_TRY(pf_stream_state_take(state, &c, err)); /* MESH, SURF, WGHT, SCEN and ids */
        }
        if (c.offset == p->offset) {
            *ckpt = c;
            return PF_OK;
        }
    }
}
