/* Checkpoints: the simulator's state as bytes and back (pf/sim.h, pf_sim_checkpoint), the payload
 * of the stream's CKPT chunk (docs/stream-format.md), from which pf-sim --resume continues a run
 * with the same bits as the run that wrote it.
 *
 * What the next frames depend on: the displacement and velocity unknowns, time and frame, the
 * energy check's accumulators, and the solver's history (the factor PCG iterates on and its age,
 * the contact set that tells whether the matrix changed). The history is not stored: a checkpoint
 * is a restart point (restart_point), after which both the run that continues and the run
 * restored from the bytes factorise afresh. Nor is the warm start's history (the velocity trend,
 * the warp's last rotations): both runs forget it at the restart point.
 *
 * A fingerprint (CRC-32) of the scene as resolved (its JSON with 17 significant digits, the solver
 * left out: a run may continue on another solver, whose frames differ in the last bits), the mesh's
 * node positions and the mesh obstacles' triangles ties the state to what made it: restoring into
 * another scene, mesh or obstacle file is refused rather than continued with other bits.
 *
 * A simulator that refines (the scene's "refine" key) or whose mesh changed is not checkpointed:
 * the state would need the current mesh and the refinement's bookkeeping (levels, families, calm
 * counters), which a CKPT does not hold. */
#include <pf/io.h>
#include <pf/sim.h>

#include <math.h>
#include <string.h>

#include "../io/stream_bytes.h"
#include "sim_internal.h"

enum { HEADER_BYTES = 68, FLAG_ENERGY_STARTED = 1 };

/* Drops the solver's factor and marks the matrix as new, so that the next step factorises as the
 * first step of a fresh simulator does: from here on the run depends on the stored state alone. */
static void restart_point(pf_sim *s)
{
    pf_solver_reset(s->solver);
    pf_sim_forget_trend(s);
    s->assembled = false;
}

/* CRC-32 of n doubles' bits in little-endian order, continued from crc (zlib's crc32 chains:
 * crc32(crc32(0, a), b) = crc32(0, a b)). */
static uint32_t crc_doubles(uint32_t crc, const double *x, size_t n)
{
    unsigned char buf[8 * 64];
    for (size_t k = 0; k < n;) {
        size_t m = n - k < 64 ? n - k : 64;
        for (size_t i = 0; i < m; ++i)
            le_put_f64(buf + 8 * i, x[k + i]);
        crc = pf_stream_crc32_continue(crc, buf, 8 * m);
        k += m;
    }
    return crc;
}

pf_status pf_sim_state_fingerprint(const pf_scene *scene, const pf_mesh *mesh, uint32_t *out,
                                   pf_error *err)
{
    /* not the solver: a run may continue on another one (pf-sim --resume --solver) */
    pf_scene plain = *scene;
    plain.solver = pf_solver_params_default();
    char *json = NULL;
    PF_TRY(pf_scene_to_json(&plain, &json, err));
    uint32_t crc = pf_stream_crc32((const unsigned char *)json, strlen(json));
    pf_free(json);
    crc = crc_doubles(crc, mesh->x, 3 * (size_t)mesh->n_nodes);
    for (int32_t i = 0; i < scene->n_obstacles; ++i) {
        const pf_surface *s = &scene->obstacles[i].surface;
        crc = crc_doubles(crc, s->x, 3 * (size_t)s->n_verts);
        unsigned char b[4];
        for (size_t k = 0; k < 3 * (size_t)s->n_tris; ++k) {
            le_put_u32(b, s->tri[k]);
            crc = pf_stream_crc32_continue(crc, b, 4);
        }
    }
    *out = crc;
    return PF_OK;
}

pf_status pf_sim_state_encode(const pf_sim_saved *st, const double *u, const double *v,
                              pf_buffer *out, pf_error *err)
{
    size_t n = (size_t)st->n, size = HEADER_BYTES + 16 * n;
    PF_TRY(pf_buffer_reserve(out, out->size + size, err));
    unsigned char *p = out->data + out->size;
    le_put_u64(p, st->mesh_id);
    le_put_u32(p + 8, (uint32_t)st->frame);
    le_put_u32(p + 12, st->print);
    le_put_f64(p + 16, st->time);
    le_put_u64(p + 24, (uint64_t)st->n);
    le_put_u32(p + 32, st->energy_started ? FLAG_ENERGY_STARTED : 0);
    le_put_f64(p + 36, st->kinetic0);
    le_put_f64(p + 44, st->work);
    le_put_f64(p + 52, st->fixed_energy);
    le_put_f64(p + 60, st->energy_floor);
    for (size_t q = 0; q < n; ++q) {
        le_put_f64(p + HEADER_BYTES + 8 * q, u[q]);
        le_put_f64(p + HEADER_BYTES + 8 * (n + q), v[q]);
    }
    out->size += size;
    return PF_OK;
}

pf_status pf_sim_checkpoint(pf_sim *s, pf_buffer *out, pf_error *err)
{
    PF_CHECK(!pf_scene_changes_mesh(s->scene) && !s->owned_mesh, err, PF_ERR_UNSUPPORTED,
             "checkpoint of a simulator whose mesh changes (refinement): not supported yet");
    pf_sim_saved st = {.mesh_id = s->mesh->id,
                       .frame = s->frame,
                       .time = s->time,
                       .n = s->n,
                       .energy_started = s->energy_started,
                       .kinetic0 = s->kinetic0,
                       .work = s->work,
                       .fixed_energy = s->fixed_energy,
                       .energy_floor = s->energy_floor};
    PF_TRY(pf_sim_state_fingerprint(s->scene, s->mesh, &st.print, err));
    PF_TRY(pf_sim_state_encode(&st, s->u, s->v, out, err));
    restart_point(s);
    return PF_OK;
}

/* The first non-finite value of x [n], or -1. */
static int64_t first_non_finite(const unsigned char *x, size_t n)
{
    for (size_t q = 0; q < n; ++q)
        if (!isfinite(le_get_f64(x + 8 * q)))
            return (int64_t)q;
    return -1;
}

pf_status pf_sim_state_decode(const void *bytes, size_t size, const pf_scene *scene,
                              const pf_mesh *mesh, int64_t n_unknowns, pf_sim_saved *st,
                              const unsigned char **values, pf_error *err)
{
    const unsigned char *p = bytes;
    size_t n = (size_t)n_unknowns;
    PF_CHECK(size >= HEADER_BYTES, err, PF_ERR_FORMAT,
             "checkpoint of %zu bytes, shorter than its %d-byte header", size, (int)HEADER_BYTES);
    uint64_t mesh_id = le_get_u64(p), stored_n = le_get_u64(p + 24);
    uint32_t frame = le_get_u32(p + 8), print = le_get_u32(p + 12), flags = le_get_u32(p + 32);
    PF_CHECK(mesh_id == mesh->id, err, PF_ERR_FORMAT,
             "checkpoint of mesh %llu, the simulated mesh is %llu", (unsigned long long)mesh_id,
             (unsigned long long)mesh->id);
    PF_CHECK(stored_n == (uint64_t)n_unknowns, err, PF_ERR_FORMAT,
             "checkpoint of %llu unknowns, the simulator has %lld (another method or degree)",
             (unsigned long long)stored_n, (long long)n_unknowns);
    PF_CHECK(size == HEADER_BYTES + 16 * n, err, PF_ERR_FORMAT,
             "checkpoint of %zu bytes, %zu expected for %zu unknowns", size,
             (size_t)HEADER_BYTES + 16 * n, n);
    PF_CHECK(frame <= (uint32_t)INT32_MAX && (flags & ~(uint32_t)FLAG_ENERGY_STARTED) == 0, err,
             PF_ERR_FORMAT, "checkpoint: frame %lu or flags 0x%lx out of range",
             (unsigned long)frame, (unsigned long)flags);
    double t = le_get_f64(p + 16), e[4];
    for (int k = 0; k < 4; ++k)
        e[k] = le_get_f64(p + 36 + 8 * k);
    PF_CHECK(isfinite(t) && isfinite(e[0]) && isfinite(e[1]) && isfinite(e[2]) && isfinite(e[3]),
             err, PF_ERR_FORMAT, "checkpoint: non-finite time or energy");
    int64_t bad = first_non_finite(p + HEADER_BYTES, 2 * n);
    PF_CHECK(bad < 0, err, PF_ERR_FORMAT, "checkpoint: non-finite %s at unknown %lld",
             bad < (int64_t)n ? "displacement" : "velocity",
             (long long)(bad % (int64_t)(n ? n : 1)));
    uint32_t expected;
    PF_TRY(pf_sim_state_fingerprint(scene, mesh, &expected, err));
    PF_CHECK(print == expected, err, PF_ERR_INVALID,
             "checkpoint made with another scene, mesh or obstacle surface (fingerprint 0x%08lx, "
             "this run's 0x%08lx)",
             (unsigned long)print, (unsigned long)expected);
    *st = (pf_sim_saved){.mesh_id = mesh_id,
                         .frame = (int32_t)frame,
                         .print = print,
                         .time = t,
                         .n = n_unknowns,
                         .energy_started = flags & FLAG_ENERGY_STARTED,
                         .kinetic0 = e[0],
                         .work = e[1],
                         .fixed_energy = e[2],
                         .energy_floor = e[3]};
    *values = p + HEADER_BYTES;
    return PF_OK;
}

double pf_sim_state_value(const unsigned char *values, int64_t q)
{
    return le_get_f64(values + 8 * q);
}

pf_status pf_sim_restore(pf_sim *s, const void *bytes, size_t size, pf_error *err)
{
    pf_sim_saved st;
    const unsigned char *values;
    PF_TRY(pf_sim_state_decode(bytes, size, s->scene, s->mesh, s->n, &st, &values, err));
    for (int64_t q = 0; q < s->n; ++q) {
        s->u[q] = pf_sim_state_value(values, q);
        s->v[q] = pf_sim_state_value(values, s->n + q);
    }
    s->frame = st.frame;
    s->time = st.time;
    s->energy_started = st.energy_started;
    s->kinetic0 = st.kinetic0;
    s->work = st.work;
    s->fixed_energy = st.fixed_energy;
    s->energy_floor = st.energy_floor;
    restart_point(s);
    return PF_OK;
}
