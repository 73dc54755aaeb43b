/* libFuzzer target for the pf stream: reads every chunk of arbitrary bytes, decodes every known
 * chunk, and checks the properties any input must keep:
 * - no crash, no undefined behaviour, no leak (pf's live-byte counter returns to where it was);
 * - a payload a decoder accepts re-encodes to the very same bytes;
 * - a stream that reads cleanly to its END_ passes through a writer byte for byte;
 * - the reader state (pf_stream_state) takes chunks until one is refused with a reason, and what
 *   it holds stays consistent: weights and stress refer to its latest mesh and surface;
 * - the reader gives the same verdict on a seekable input (sizes checked against the file length)
 *   and on a pipe (the payload buffer grows as bytes arrive), after the same number of chunks.
 * A violated property aborts, which libFuzzer and the replay driver report. */
#define _GNU_SOURCE /* fopencookie (a pipe-like stream from memory), fmemopen, open_memstream */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

#include <pf/io.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void require(int ok, const char *what)
{
    if (!ok) {
        fprintf(stderr, "fuzz_stream: property violated: %s\n", what);
        abort();
    }
}

/* Decodes c if its tag is known; when that succeeds, re-encodes into re (emptied first). Returns
 * whether there is something in re to compare. */
static int decode_and_reencode(const pf_chunk *c, pf_buffer *re)
{
    pf_error err = {0};
    pf_status s = PF_OK;
    re->size = 0;
    if (!pf_stream_tag_is_known(c->tag))
        return 0;
    if (strcmp(c->tag, "MESH") == 0) {
        pf_mesh m = {0};
        if ((s = pf_stream_decode_mesh(c, &m, &err)) == PF_OK)
            require(pf_stream_encode_mesh(&m, re, &err) == PF_OK, "decoded MESH re-encodes");
        pf_mesh_release(&m);
    } else if (strcmp(c->tag, "SURF") == 0) {
        pf_surface v = {0};
        if ((s = pf_stream_decode_surface(c, &v, &err)) == PF_OK)
            require(pf_stream_encode_surface(&v, re, &err) == PF_OK, "decoded SURF re-encodes");
        /* a version 2 SURF without caps re-encodes as version 1: nothing to compare */
        bool same = s != PF_OK || pf_stream_surface_version(&v) == c->version;
        pf_surface_release(&v);
        if (!same)
            return 0;
    } else if (strcmp(c->tag, "WGHT") == 0) {
        pf_weights w = {0};
        if ((s = pf_stream_decode_weights(c, &w, &err)) == PF_OK)
            require(pf_stream_encode_weights(&w, re, &err) == PF_OK, "decoded WGHT re-encodes");
        pf_weights_release(&w);
    } else if (strcmp(c->tag, "FRAM") == 0) {
        pf_frame_data f = {0};
        if ((s = pf_stream_decode_frame(c, &f, &err)) == PF_OK)
            require(pf_stream_encode_frame(&f, re, &err) == PF_OK, "decoded FRAM re-encodes");
        pf_frame_data_release(&f);
    } else if (strcmp(c->tag, "STRS") == 0) {
        pf_stress_data t = {0};
        if ((s = pf_stream_decode_stress(c, &t, &err)) == PF_OK)
            require(pf_stream_encode_stress(&t, re, &err) == PF_OK, "decoded STRS re-encodes");
        pf_stress_data_release(&t);
    } else if (strcmp(c->tag, "INFO") == 0) {
        pf_info_data d = {0};
        if ((s = pf_stream_decode_info(c, &d, &err)) == PF_OK)
            require(pf_stream_encode_info(d.producer, d.version, d.command, re, &err) == PF_OK,
                    "decoded INFO re-encodes");
        pf_info_data_release(&d);
    } else if (strcmp(c->tag, "SCEN") == 0) {
        char *json = NULL;
        size_t n = 0;
        if ((s = pf_stream_decode_scene(c, &json, &n, &err)) == PF_OK)
            require(pf_stream_encode_scene(json, n, re, &err) == PF_OK, "decoded SCEN re-encodes");
        pf_free(json);
    } else if (strcmp(c->tag, "GRPS") == 0 && c->size >= 20) {
        /* the groups of a mesh with the counts the header names (the decoder checks them) */
        pf_mesh m = {0};
        m.id = (uint64_t)c->payload[0] | (uint64_t)c->payload[1] << 8 |
               (uint64_t)c->payload[2] << 16 | (uint64_t)c->payload[3] << 24 |
               (uint64_t)c->payload[4] << 32 | (uint64_t)c->payload[5] << 40 |
               (uint64_t)c->payload[6] << 48 | (uint64_t)c->payload[7] << 56;
        uint32_t counts[2];
        for (int k = 0; k < 2; ++k)
            counts[k] = (uint32_t)c->payload[8 + 4 * k] | (uint32_t)c->payload[9 + 4 * k] << 8 |
                        (uint32_t)c->payload[10 + 4 * k] << 16 |
                        (uint32_t)c->payload[11 + 4 * k] << 24;
        m.n_elems = counts[0] > INT32_MAX ? -1 : (int32_t)counts[0];
        m.n_faces = counts[1] > INT32_MAX ? -1 : (int32_t)counts[1];
        if ((s = pf_stream_decode_groups(c, &m, &err)) == PF_OK)
            require(pf_stream_encode_groups(&m, re, &err) == PF_OK, "decoded GRPS re-encodes");
        pf_mesh_groups_release(&m);
    } else if (strcmp(c->tag, "STAT") == 0) {
        pf_stats_data d = {0};
        if ((s = pf_stream_decode_stats(c, &d, &err)) == PF_OK)
            require(pf_stream_encode_stats(&d, re, &err) == PF_OK, "decoded STAT re-encodes");
        pf_stats_data_release(&d);
    } else if (strcmp(c->tag, "END_") == 0) {
        pf_end_data d;
        if ((s = pf_stream_decode_end(c, &d, &err)) == PF_OK)
            require(pf_stream_encode_end(&d, re, &err) == PF_OK, "decoded END_ re-encodes");
    }
    require(s == PF_OK || err.msg[0] != '\0', "a failed decode says why");
    return s == PF_OK;
}

typedef struct outcome {
    pf_status status; /* of the read that stopped it */
    long chunks;      /* chunks returned */
    int clean;        /* ended after an END_ of the version this pf writes */
} outcome;

/* Feeds c to the state while it accepts chunks (frames alternately decoded and checked by their
 * header); its invariants after each. */
static void take_into_state(pf_stream_state *st, bool *refused, const pf_chunk *c, long ordinal)
{
    if (*refused)
        return;
    pf_error err = {0};
    pf_status s;
    if (strcmp(c->tag, "FRAM") == 0 && ordinal % 2) {
        uint32_t index;
        s = pf_stream_state_skip_frame(st, c, &index, &err);
    } else {
        s = pf_stream_state_take(st, c, &err);
    }
    *refused = s != PF_OK;
    require(s == PF_OK || err.msg[0] != '\0', "a refused chunk says why");
    require(!st->have_weights || (st->have_mesh && st->have_surface &&
                                  st->weights.mesh_id == st->mesh.id &&
                                  st->weights.cols == st->mesh.n_nodes &&
                                  st->weights.surface_id == st->surface.id &&
                                  st->weights.rows == st->surface.n_verts),
            "the state's weights belong to its mesh and surface");
    require(!st->have_stress || (st->have_mesh && st->stress.n_elems == st->mesh.n_elems),
            "the state's stress belongs to its mesh");
    require(st->have_mesh == (st->n_meshes > 0), "every mesh is listed");
}

/* Reads the stream, passing every chunk but END_ on to w (when not NULL). */
static outcome read_stream(FILE *in, pf_stream_writer *w, pf_buffer *re)
{
    outcome o = {PF_OK, 0, 0};
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    if ((o.status = pf_stream_reader_create(&r, in, "fuzz", &err)) != PF_OK) {
        require(r == NULL && err.msg[0] != '\0', "a refused stream says why");
        return o;
    }
    int end_v1 = 0;
    pf_stream_state st = {0};
    bool refused = false;
    for (;;) {
        pf_chunk c;
        bool end = false;
        if ((o.status = pf_stream_read_chunk(r, &c, &end, &err)) != PF_OK) {
            require(err.msg[0] != '\0', "a read error says why");
            break;
        }
        if (end) {
            o.clean = end_v1;
            break;
        }
        o.chunks++;
        take_into_state(&st, &refused, &c, o.chunks);
        if (decode_and_reencode(&c, re))
            require(re->size == c.size &&
                        (c.size == 0 || memcmp(re->data, c.payload, re->size) == 0),
                    "encode(decode(payload)) == payload");
        if (strcmp(c.tag, "END_") == 0)
            end_v1 = c.version == pf_stream_tag_version("END_");
        else if (w)
            require(pf_stream_write_raw(w, &c, &err) == PF_OK, "a chunk read passes through");
    }
    pf_stream_state_release(&st);
    pf_stream_reader_destroy(&r);
    return o;
}

/* A read-only stream over memory that cannot seek, handing out bytes in uneven pieces: to the
 * reader it looks like a pipe. */
typedef struct pipe_cookie {
    const uint8_t *data;
    size_t size, pos, calls;
} pipe_cookie;

static ssize_t pipe_read(void *cookie, char *buf, size_t n)
{
    pipe_cookie *p = cookie;
    size_t piece = 1 + (p->calls++ * 977) % 4096; /* 1 .. 4096 bytes */
    if (piece > n)
        piece = n;
    if (piece > p->size - p->pos)
        piece = p->size - p->pos;
    memcpy(buf, p->data + p->pos, piece);
    p->pos += piece;
    return (ssize_t)piece;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0; /* fmemopen refuses an empty buffer; the unit tests cover empty input */
    int64_t live = pf_alloc_live_bytes();
    pf_buffer re = {0};
    pf_error err = {0};

    /* As a file, passing every chunk on. */
    FILE *in = fmemopen((void *)data, size, "rb");
    char *out_bytes = NULL;
    size_t out_size = 0;
    FILE *out = open_memstream(&out_bytes, &out_size);
    require(in && out, "memory streams open");
    pf_stream_writer *w = NULL;
    require(pf_stream_writer_create(&w, out, "out", &err) == PF_OK, "writer starts");
    outcome as_file = read_stream(in, w, &re);
    if (as_file.clean) {
        require(pf_stream_writer_finish(w, &err) == PF_OK, "writer finishes");
        require(out_size == size && memcmp(out_bytes, data, size) == 0,
                "a clean stream passes through byte for byte");
    }
    pf_stream_writer_destroy(&w);
    fclose(in);
    fclose(out);
    free(out_bytes);

    /* As a pipe. */
    pipe_cookie cookie = {data, size, 0, 0};
    cookie_io_functions_t io = {.read = pipe_read};
    in = fopencookie(&cookie, "rb", io);
    require(in != NULL, "pipe stream opens");
    outcome as_pipe = read_stream(in, NULL, &re);
    fclose(in);
    require(as_pipe.status == as_file.status && as_pipe.chunks == as_file.chunks &&
                as_pipe.clean == as_file.clean,
            "a file and a pipe with the same bytes read the same");

    pf_buffer_release(&re);
    require(pf_alloc_live_bytes() == live, "no pf memory left behind");
    return 0;
}
