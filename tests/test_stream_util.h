/* Shared by the stream tests (test_stream.c, test_stream_damage.c): little-endian bytes, an
 * independent CRC-32, streams from memory through a file or a pipe, and a reader that decodes every
 * known chunk and records what it saw. Include after <cmocka.h>, <stdio.h> and <string.h>, with
 * _POSIX_C_SOURCE 200809L defined (pipe, fdopen). */
#ifndef PF_TEST_STREAM_UTIL_H
#define PF_TEST_STREAM_UTIL_H

#include <stdbool.h>
#include <stdint.h>
#include <sys/wait.h>
#include <unistd.h>

#include <pf/io.h>

static inline void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

/* CRC-32 bit by bit (reflected polynomial 0xedb88320, initial and final xor 0xffffffff): an
 * oracle independent of zlib. */
static inline uint32_t crc32_bitwise(const unsigned char *p, size_t n)
{
    uint32_t crc = 0xffffffffu;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int b = 0; b < 8; ++b)
            crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* The test's own little-endian access, so that the layout is checked against the spec. */
static inline uint64_t rd(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i)
        v = v << 8 | p[i];
    return v;
}

static inline void wr(unsigned char *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; ++i, v >>= 8)
        p[i] = (unsigned char)v;
}

static inline void wr_f64(unsigned char *p, double d)
{
    uint64_t bits;
    memcpy(&bits, &d, sizeof bits);
    wr(p, bits, 8);
}

/* Every byte of f from its start. */
static inline void slurp(FILE *f, pf_buffer *out)
{
    pf_error err = {0};
    unsigned char piece[4096];
    out->size = 0;
    rewind(f);
    for (size_t n; (n = fread(piece, 1, sizeof piece, f)) > 0;)
        assert_int_equal(pf_buffer_append(out, piece, n, &err), PF_OK);
    rewind(f);
}

static inline FILE *file_with(const unsigned char *bytes, size_t n)
{
    bytes = bytes ? bytes : (const unsigned char *)""; /* never NULL, even for no bytes */
    FILE *f = tmpfile();
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    rewind(f);
    return f;
}

/* A pipe holding the bytes with its writing end closed: read like `cat file | tool`. */
static inline FILE *pipe_with(const unsigned char *bytes, size_t n)
{
    bytes = bytes ? bytes : (const unsigned char *)"";
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    assert_true(n < 65536); /* Linux pipe capacity: the write below cannot block */
    assert_int_equal(write(fd[1], bytes, n), (ssize_t)n);
    close(fd[1]);
    FILE *f = fdopen(fd[0], "rb");
    assert_non_null(f);
    return f;
}

/* Offsets of the chunk headers in a stream, walked with the spec's framing. */
static inline int chunk_offsets(const pf_buffer *b, size_t *offs, int max)
{
    int n = 0;
    for (size_t pos = PF_STREAM_SIGNATURE_BYTES; pos + 16 <= b->size && n < max; ++n) {
        offs[n] = pos;
        pos += 16 + (size_t)rd(b->data + pos + 8, 8) + 4;
    }
    return n;
}

typedef struct chunk_record {
    char tag[5];
    uint32_t version;
    uint64_t size;
    uint32_t crc;
} chunk_record;

typedef struct read_result {
    pf_status status;
    pf_error err;
    int n;                /* chunks returned, END_ included */
    chunk_record rec[32]; /* the first of them */
    int64_t live_at_failure;
} read_result;

static inline pf_status decode_known(const pf_chunk *c, pf_error *err)
{
    pf_status s = PF_OK;
    if (strcmp(c->tag, "MESH") == 0) {
        pf_mesh m = {0};
        s = pf_stream_decode_mesh(c, &m, err);
        pf_mesh_release(&m);
    } else if (strcmp(c->tag, "SURF") == 0) {
        pf_surface v = {0};
        s = pf_stream_decode_surface(c, &v, err);
        pf_surface_release(&v);
    } else if (strcmp(c->tag, "WGHT") == 0) {
        pf_weights w = {0};
        s = pf_stream_decode_weights(c, &w, err);
        pf_weights_release(&w);
    } else if (strcmp(c->tag, "FRAM") == 0) {
        pf_frame_data fr = {0};
        s = pf_stream_decode_frame(c, &fr, err);
        pf_frame_data_release(&fr);
    } else if (strcmp(c->tag, "STRS") == 0) {
        pf_stress_data st = {0};
        s = pf_stream_decode_stress(c, &st, err);
        pf_stress_data_release(&st);
    } else if (strcmp(c->tag, "INFO") == 0) {
        pf_info_data d = {0};
        s = pf_stream_decode_info(c, &d, err);
        pf_info_data_release(&d);
    } else if (strcmp(c->tag, "SCEN") == 0) {
        char *json = NULL;
        size_t n = 0;
        s = pf_stream_decode_scene(c, &json, &n, err);
        pf_free(json);
    } else if (strcmp(c->tag, "STAT") == 0) {
        pf_stats_data d = {0};
        s = pf_stream_decode_stats(c, &d, err);
        pf_stats_data_release(&d);
    } else if (strcmp(c->tag, "END_") == 0) {
        pf_end_data d;
        s = pf_stream_decode_end(c, &d, err);
    }
    return s;
}

/* Reads f to its end, decoding every known chunk; closes f. */
static inline void read_all(FILE *f, const char *name, read_result *out)
{
    memset(out, 0, sizeof *out);
    pf_stream_reader *r = NULL;
    out->status = pf_stream_reader_create(&r, f, name, &out->err);
    for (bool end = false; out->status == PF_OK && !end;) {
        pf_chunk c;
        out->status = pf_stream_read_chunk(r, &c, &end, &out->err);
        if (out->status < 0)
            out->live_at_failure = pf_alloc_live_bytes();
        if (out->status < 0 || end)
            break;
        if (out->n < 32) {
            chunk_record *k = &out->rec[out->n];
            memcpy(k->tag, c.tag, 5);
            k->version = c.version;
            k->size = c.size;
            k->crc = c.crc;
        }
        out->n++;
        out->status = decode_known(&c, &out->err);
    }
    pf_stream_reader_destroy(&r);
    fclose(f);
}

static inline void read_bytes(const pf_buffer *b, size_t n, bool through_pipe, read_result *out)
{
    read_all(through_pipe ? pipe_with(b->data, n) : file_with(b->data, n), "t.pfs", out);
}

#endif
