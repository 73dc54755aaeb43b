/* stream_damage: every kind of damaged stream is an error that names what is wrong, never a crash
 * or a silent success: empty input and bad signatures, truncation after and inside chunks (every
 * byte), huge sizes, CRC mismatches (every flipped byte), versions, tags, and END_. */
#define _POSIX_C_SOURCE 200809L /* pipe, fdopen: a non-seekable input, as from a shell pipe */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <pf/io.h>

#include "test_stream_util.h"

/* ---- a small stream for damage tests: INFO, a one-tet MESH, two FRAMs, END_
 * ---------------------- */

enum { SMALL_INFO, SMALL_MESH, SMALL_FRAME0, SMALL_FRAME1, SMALL_END, SMALL_CHUNKS };

static void small_stream(pf_buffer *out, bool finish)
{
    static const double X[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const uint32_t TET[] = {0, 1, 2, 3};
    pf_error err = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_from_tets(&m, X, 4, TET, 1, &err), PF_OK);
    m.id = 3;
    FILE *f = tmpfile();
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "small", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(w, "t", "1", "t --x", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(w, &m, &err), PF_OK);
    for (uint32_t k = 0; k < 2; ++k) {
        pf_frame_data fr = {0};
        assert_int_equal(pf_frame_data_alloc(&fr, 4, &err), PF_OK);
        fr.mesh_id = 3;
        fr.index = k;
        fr.time = 0.25 * k;
        for (int i = 0; i < 12; ++i)
            fr.u[i] = 0.01 * i * (k + 1);
        assert_int_equal(pf_stream_write_frame(w, &fr, &err), PF_OK);
        pf_frame_data_release(&fr);
    }
    if (finish)
        assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    slurp(f, out);
    fclose(f);
    pf_mesh_release(&m);
}

/* Recomputes the CRC of the chunk at off after its payload was edited. */
static void fix_crc(pf_buffer *b, size_t off)
{
    size_t size = (size_t)rd(b->data + off + 8, 8);
    wr(b->data + off + 16 + size, crc32_bitwise(b->data + off + 16, size), 4);
}

static void test_empty_input_and_bad_signature(void **state)
{
    (void)state;
    read_result res;
    read_all(file_with(NULL, 0), "mesh.pfs", &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, "mesh.pfs: empty input, expected a pf stream");
    read_all(pipe_with(NULL, 0), "stdin", &res);
    assert_string_equal(res.err.msg, "stdin: empty input, expected a pf stream");

    /* A directory opens, but reading it fails: an i/o error, not a format error. */
    read_all(fopen(".", "rb"), "dir", &res);
    assert_int_equal(res.status, PF_ERR_IO);
    expect_msg(&res.err, "dir: read error at byte 0");

    static const char TEXT[] = "solid cube\nfacet normal 0 0 1\n";
    read_all(file_with((const unsigned char *)TEXT, sizeof TEXT - 1), "cube.stl", &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, "cube.stl: not a pf stream (bad signature)");
    read_all(file_with((const unsigned char *)"\x89PF", 3), "short", &res);
    expect_msg(&res.err, "short: not a pf stream (bad signature)");
    /* A text-mode transfer turned "\r\n" into "\n": the hint says so. */
    static const unsigned char MANGLED[] = {0x89, 'P', 'F', 'S', '\n', 0x1a, '\n', 'I', 'N'};
    read_all(file_with(MANGLED, sizeof MANGLED), "mangled", &res);
    expect_msg(&res.err, "mangled: not a pf stream (bad signature)");
    expect_msg(&res.err, "text-mode");
    /* A signature and nothing else. */
    pf_buffer b = {0};
    small_stream(&b, true);
    read_bytes(&b, 8, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, "t.pfs: truncated after the signature at byte 8");
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A stream without END_ (a producer that died): every chunk before is returned, then the error. */
static void test_truncated_after_a_chunk(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, false);
    size_t offs[8];
    assert_int_equal(chunk_offsets(&b, offs, 8), SMALL_CHUNKS - 1);
    char want[160];
    snprintf(want, sizeof want,
             "t.pfs: truncated after chunk FRAM #4 at byte %zu (no END_ chunk); 2 frames read",
             offs[SMALL_FRAME1]);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_FORMAT);
        assert_string_equal(res.err.msg, want);
        assert_int_equal(res.n, 4); /* INFO MESH FRAM FRAM all decoded before the error */
    }
    /* Cut after the first frame: one frame read. */
    read_result res;
    read_bytes(&b, offs[SMALL_FRAME1], false, &res);
    snprintf(want, sizeof want,
             "truncated after chunk FRAM #3 at byte %zu (no END_ chunk); 1 frame read",
             offs[SMALL_FRAME0]);
    expect_msg(&res.err, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_truncated_inside_a_chunk(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    size_t cut = offs[SMALL_MESH] + 16 + 50; /* 50 bytes into the MESH payload */
    char want[96];
    snprintf(want, sizeof want, "t.pfs: truncated inside chunk MESH at byte %zu", offs[SMALL_MESH]);
    read_result res;
    read_bytes(&b, cut, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, want);
    expect_msg(&res.err, "only 50 bytes remain");
    assert_int_equal(res.n, 1);
    read_bytes(&b, cut, true, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, want);
    expect_msg(&res.err, "the input ended after 50 of its");
    /* Inside the header of the second frame, and inside its CRC. */
    read_bytes(&b, offs[SMALL_FRAME1] + 10, true, &res);
    snprintf(want, sizeof want,
             "truncated inside the header of chunk FRAM at byte %zu; 1 frame read",
             offs[SMALL_FRAME1]);
    expect_msg(&res.err, want);
    read_bytes(&b, offs[SMALL_END] - 2, true, &res);
    snprintf(want, sizeof want, "truncated inside chunk FRAM at byte %zu", offs[SMALL_FRAME1]);
    expect_msg(&res.err, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A size claiming 2^60 bytes: refused before allocating, from a file and from a pipe. */
static void test_huge_size_is_refused_without_allocating(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    wr(b.data + offs[SMALL_MESH] + 8, 1ull << 60, 8);
    char want[96];
    snprintf(want, sizeof want, "truncated inside chunk MESH at byte %zu", offs[SMALL_MESH]);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_FORMAT);
        expect_msg(&res.err, want);
        expect_msg(&res.err, "1152921504606846976");
        /* A file is measured first: nothing allocated for the payload. A pipe's buffer grows
         * only as bytes arrive: at most 128 KiB (twice the 64 KiB first piece) here, while the
         * whole input is under 1 KiB. */
        assert_true(res.live_at_failure < 256 * 1024);
    }
    /* Beyond any address space: PF_ERR_TOO_LARGE, naming the chunk. */
    wr(b.data + offs[SMALL_MESH] + 8, UINT64_MAX - 2, 8);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_TOO_LARGE);
        expect_msg(&res.err, "chunk MESH at byte");
    }
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_crc_mismatch_is_named(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    size_t payload = offs[SMALL_MESH] + 16, size = (size_t)rd(b.data + offs[SMALL_MESH] + 8, 8);
    uint32_t stored = (uint32_t)rd(b.data + payload + size, 4);
    b.data[payload + 33] ^= 0x10;
    uint32_t computed = crc32_bitwise(b.data + payload, size);
    char want[160];
    snprintf(want, sizeof want,
             "t.pfs: chunk MESH at byte %zu: CRC mismatch (stored 0x%08lx, computed 0x%08lx)",
             offs[SMALL_MESH], (unsigned long)stored, (unsigned long)computed);
    read_result res;
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, want);
    assert_int_equal(res.n, 1);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* After a failure every later read repeats it. */
static void test_reader_repeats_its_error(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    b.data[b.size - 1] ^= 1; /* END_'s CRC */
    FILE *f = file_with(b.data, b.size);
    pf_error err = {0}, again = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "t.pfs", &err), PF_OK);
    pf_chunk c;
    bool end = false;
    pf_status s;
    while ((s = pf_stream_read_chunk(r, &c, &end, &err)) == PF_OK && !end)
        ;
    assert_int_equal(s, PF_ERR_FORMAT);
    expect_msg(&err, "chunk END_");
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &again), PF_ERR_FORMAT);
    assert_string_equal(again.msg, err.msg);
    assert_false(end);
    pf_stream_reader_destroy(&r);
    fclose(f);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_versions_and_tags(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    /* Version 7 of MESH: read (it could be passed on), refused when decoded. */
    wr(b.data + offs[SMALL_MESH] + 4, 7, 4);
    FILE *f = file_with(b.data, b.size);
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "t.pfs", &err), PF_OK);
    pf_chunk c;
    bool end = false;
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_int_equal(c.version, 7);
    pf_mesh m = {0};
    assert_int_equal(pf_stream_decode_mesh(&c, &m, &err), PF_ERR_UNSUPPORTED);
    char want[96];
    /* A chunk from a reader names the stream first, so every decoder message names the input. */
    snprintf(want, sizeof want,
             "t.pfs: chunk MESH at byte %zu: version 7 not supported (this pf reads 1)",
             offs[SMALL_MESH]);
    assert_string_equal(err.msg, want);
    assert_int_equal(pf_stream_check_version(&c, &err), PF_ERR_UNSUPPORTED);
    pf_stream_reader_destroy(&r);
    fclose(f);
    /* A tag that is not printable ASCII. */
    wr(b.data + offs[SMALL_MESH] + 4, 1, 4);
    b.data[offs[SMALL_MESH] + 2] = 0x01;
    read_result res;
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    snprintf(want, sizeof want, "t.pfs: bad chunk tag 0x4d450148 at byte %zu", offs[SMALL_MESH]);
    expect_msg(&res.err, want);
    b.data[offs[SMALL_MESH] + 2] = 0x7f;
    read_bytes(&b, b.size, true, &res);
    expect_msg(&res.err, "bad chunk tag");
    /* Decoding a chunk as the wrong kind is a caller's mistake. */
    pf_chunk info = {.tag = "INFO", .version = 1, .size = 0, .offset = 8};
    assert_int_equal(pf_stream_decode_mesh(&info, &m, &err), PF_ERR_INVALID);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_end_must_match_and_close_the_stream(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    read_result res;
    /* END_ counts one chunk too many: a chunk was dropped on the way. */
    wr(b.data + offs[SMALL_END] + 16, SMALL_CHUNKS, 8);
    fix_crc(&b, offs[SMALL_END]);
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, "counts 5 chunks and 2 frames, the stream had 4 and 2");
    wr(b.data + offs[SMALL_END] + 16, SMALL_CHUNKS - 1, 8);
    fix_crc(&b, offs[SMALL_END]);
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_OK);
    /* An END_ one byte too long. */
    pf_buffer longer = {0};
    pf_error err = {0};
    size_t end_crc = offs[SMALL_END] + 16 + 16;
    assert_int_equal(pf_buffer_append(&longer, b.data, end_crc, &err), PF_OK);
    assert_int_equal(pf_buffer_append(&longer, "\0\0\0\0\0", 5, &err), PF_OK);
    wr(longer.data + offs[SMALL_END] + 8, 17, 8);
    fix_crc(&longer, offs[SMALL_END]);
    read_bytes(&longer, longer.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    char want[96];
    snprintf(want, sizeof want, "t.pfs: chunk END_ at byte %zu: 1 trailing bytes", offs[SMALL_END]);
    expect_msg(&res.err, want);
    pf_buffer_release(&longer);
    /* Bytes after END_. */
    assert_int_equal(pf_buffer_append(&b, "\x89PFS", 4, &err), PF_OK);
    read_bytes(&b, b.size, true, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    snprintf(want, sizeof want, "t.pfs: unexpected data at byte %zu, after the END_ chunk",
             b.size - 4);
    assert_string_equal(res.err.msg, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Every prefix of a valid stream is an error (never a crash, never a clean end), from a file and
 * from a pipe; only the whole stream ends cleanly. */
static void test_every_truncation_is_an_error(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe)
        for (size_t n = 0; n <= b.size; ++n) {
            read_result res;
            read_bytes(&b, n, through_pipe, &res);
            if (n < b.size && res.status != PF_ERR_FORMAT)
                fail_msg("prefix of %zu bytes: status %d, message '%s'", n, res.status,
                         res.err.msg);
            if (n == b.size)
                assert_int_equal(res.status, PF_OK);
        }
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Every byte of a valid stream altered: detected by the signature, the framing, the CRC, the END_
 * counts or the decoders. The CRC covers payloads only, so one change is not detectable: a tag
 * altered into another printable tag reads as an unknown chunk (it can never become another known
 * tag: all known tags differ in at least two characters). The test checks that it is exactly that.
 */
static void test_every_flipped_byte_is_detected(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    read_result ref;
    read_bytes(&b, b.size, false, &ref);
    assert_int_equal(ref.status, PF_OK);
    assert_int_equal(ref.n, SMALL_CHUNKS);
    static const unsigned char MASKS[] = {0x01, 0x20, 0x80, 0xff};
    int renamed = 0;
    for (size_t pos = 0; pos < b.size; ++pos)
        for (size_t m = 0; m < sizeof MASKS; ++m) {
            b.data[pos] ^= MASKS[m];
            read_result res;
            read_bytes(&b, b.size, pos % 2 == 1, &res);
            b.data[pos] ^= MASKS[m];
            if (res.status < 0)
                continue;
            /* Undetected: must be a tag byte, the chunk otherwise identical, its tag unknown. */
            int k = 0;
            while (k < SMALL_CHUNKS - 1 && offs[k + 1] <= pos)
                ++k;
            if (pos < offs[k] || pos >= offs[k] + 4)
                fail_msg("byte %zu ^ 0x%02x went undetected", pos, MASKS[m]);
            assert_int_equal(res.n, SMALL_CHUNKS);
            for (int i = 0; i < SMALL_CHUNKS; ++i) {
                assert_int_equal(res.rec[i].size, ref.rec[i].size);
                assert_int_equal(res.rec[i].crc, ref.rec[i].crc);
                if (i == k) {
                    assert_false(pf_stream_tag_is_known(res.rec[i].tag));
                    assert_string_not_equal(res.rec[i].tag, "FRAM");
                } else {
                    assert_string_equal(res.rec[i].tag, ref.rec[i].tag);
                }
            }
            renamed++;
        }
    /* Exactly the 8 bytes of the INFO and MESH tags under the masks 0x01 and 0x20, which keep an
     * upper-case letter printable (0x80 and 0xff do not). A renamed FRAM is caught by the END_
     * counts, a renamed END_ as a truncation. */
    assert_int_equal(renamed, 8 * 2);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_empty_input_and_bad_signature),
        cmocka_unit_test(test_truncated_after_a_chunk),
        cmocka_unit_test(test_truncated_inside_a_chunk),
        cmocka_unit_test(test_huge_size_is_refused_without_allocating),
        cmocka_unit_test(test_crc_mismatch_is_named),
        cmocka_unit_test(test_reader_repeats_its_error),
        cmocka_unit_test(test_versions_and_tags),
        cmocka_unit_test(test_end_must_match_and_close_the_stream),
        cmocka_unit_test(test_every_truncation_is_an_error),
        cmocka_unit_test(test_every_flipped_byte_is_detected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
