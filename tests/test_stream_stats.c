/* stream: the STAT chunk (a run's statistics) byte by byte against docs/stream-format.md, hostile
 * and truncated payloads, a stream cut inside it, and the CKPT header of versions 1 and 2. The
 * byte-exact round trip of STAT is test_stream.c's. */
#define _POSIX_C_SOURCE 200809L /* pipe, fdopen (test_stream_util.h) */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/io.h>

#include "test_stream_util.h"

/* A STAT chunk made by hand (not by the reader) at byte 1184 of "run.pfs". */
static pf_chunk stat_chunk(unsigned char *payload, size_t size)
{
    pf_chunk c = {.tag = "STAT", .version = 1, .size = size, .payload = payload};
    c.offset = 1184;
    c.source = "run.pfs";
    return c;
}

/* Appends an entry as the spec lays it out, with the test's own little-endian code. */
static size_t put_key(unsigned char *p, const char *key, unsigned kind)
{
    size_t n = strlen(key);
    wr(p, n, 4);
    memcpy(p + 4, key, n);
    p[4 + n] = (unsigned char)kind;
    return 5 + n;
}

static size_t put_number(unsigned char *p, const char *key, double v)
{
    size_t n = put_key(p, key, 0);
    wr_f64(p + n, v);
    return n + 8;
}

static size_t put_text(unsigned char *p, const char *key, const char *text)
{
    size_t n = put_key(p, key, 1), nt = strlen(text);
    wr(p + n, nt, 4);
    memcpy(p + n + 4, text, nt);
    return n + 4 + nt;
}

/* The spec's layout: u32 n, then key length, key, kind, value or text length and text. */
static void test_stat_layout(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_stats_data d = {0};
    assert_int_equal(pf_stats_data_set_text(&d, "method", "dg", &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(&d, "error_indicator", 0.015625, &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(&d, "steps", 120, &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(&d, "steps", 121, &err), PF_OK); /* replaced */
    assert_int_equal(d.n, 3);
    assert_non_null(pf_stats_data_find(&d, "steps"));
    assert_true(pf_stats_data_find(&d, "steps")->value == 121);
    assert_null(pf_stats_data_find(&d, "step"));
    pf_buffer b = {0};
    assert_int_equal(pf_stream_encode_stats(&d, &b, &err), PF_OK);
    unsigned char want[128];
    size_t n = 4;
    wr(want, 3, 4);
    n += put_text(want + n, "method", "dg");
    n += put_number(want + n, "error_indicator", 0.015625);
    n += put_number(want + n, "steps", 121);
    /* 4 + (9 + 6 + 2) + (5 + 15 + 8) + (5 + 5 + 8) */
    assert_int_equal(n, 4 + 17 + 28 + 18);
    assert_int_equal(b.size, n);
    assert_memory_equal(b.data, want, n);
    pf_buffer_release(&b);
    pf_stats_data_release(&d);
    assert_int_equal(d.n, 0);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* What no reader would take is refused by the setters and the encoder. */
static void test_stat_writer_refuses(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_stats_data d = {0};
    static const char *const BAD_KEYS[] = {"",
                                           "Method",
                                           "a b",
                                           "caf\xc3\xa9",
                                           "x-y",
                                           "k12345678901234567890123456789012345678901234567890"
                                           "12345678901234"};
    for (size_t i = 0; i < sizeof BAD_KEYS / sizeof *BAD_KEYS; ++i)
        assert_int_equal(pf_stats_data_set_number(&d, BAD_KEYS[i], 1, &err), PF_ERR_INVALID);
    assert_int_equal(pf_stats_data_set_number(&d, "nan", NAN, &err), PF_ERR_INVALID);
    assert_int_equal(pf_stats_data_set_number(&d, "inf", INFINITY, &err), PF_ERR_INVALID);
    assert_int_equal(pf_stats_data_set_text(&d, "bad", "\xc3(", &err), PF_ERR_INVALID);
    assert_int_equal(d.n, 0);
    /* 64 characters is the longest key */
    assert_int_equal(
        pf_stats_data_set_number(
            &d, "k123456789012345678901234567890123456789012345678901234567890123", 1, &err),
        PF_OK);
    assert_int_equal(d.n, 1);
    pf_stats_data_release(&d);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void expect_refused(unsigned char *p, size_t size, const char *needle)
{
    pf_chunk c = stat_chunk(p, size);
    pf_error err = {0};
    pf_stats_data d = {0};
    assert_int_equal(pf_stream_decode_stats(&c, &d, &err), PF_ERR_FORMAT);
    expect_msg(&err, "run.pfs: chunk STAT at byte 1184: ");
    expect_msg(&err, needle);
    assert_int_equal(d.n, 0);
    assert_null(d.entries);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Every prefix of a valid payload is refused with a message naming the chunk, and nothing
 * leaks; the whole payload decodes. */
static void test_stat_truncated_payloads(void **state)
{
    (void)state;
    unsigned char p[128];
    size_t n = 4;
    wr(p, 3, 4);
    n += put_text(p + n, "method", "cg");
    n += put_number(p + n, "error_indicator", 0.07);
    n += put_text(p + n, "error_measure", "basis_boundary_error");
    for (size_t cut = 0; cut < n; ++cut)
        expect_refused(p, cut, "");
    pf_chunk c = stat_chunk(p, n);
    pf_error err = {0};
    pf_stats_data d = {0};
    assert_int_equal(pf_stream_decode_stats(&c, &d, &err), PF_OK);
    assert_int_equal(d.n, 3);
    assert_true(pf_stats_data_find(&d, "error_indicator")->value == 0.07);
    assert_string_equal(pf_stats_data_find(&d, "error_measure")->text, "basis_boundary_error");
    pf_stats_data_release(&d);
    expect_refused(p, 3, "shorter than its 4-byte count");
    expect_refused(p, 4 + 17 + 22, "error_indicator: truncated number");
    expect_refused(p, n - 1, "runs past the payload");
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Counts, keys, kinds, numbers and texts that the spec forbids. */
static void test_stat_hostile_payloads(void **state)
{
    (void)state;
    unsigned char p[256];
    /* a count no payload of this size can hold: refused before allocating */
    wr(p, 0xffffffffu, 4);
    put_number(p + 4, "steps", 1);
    expect_refused(p, 4 + 18, "4294967295 entries cannot fit in 18 bytes");
    /* a key length past the payload */
    wr(p, 1, 4);
    size_t n = 4 + put_number(p + 4, "steps", 1);
    wr(p + 4, 4000, 4);
    expect_refused(p, n, "entry 0 at payload byte 4: a key of 4000 bytes runs past the payload");
    /* keys: empty, upper case, repeated */
    n = 4 + put_number(p + 4, "", 1);
    expect_refused(p, n, "the key is not 1 to 64 characters");
    n = 4 + put_number(p + 4, "Steps", 1);
    expect_refused(p, n, "the key is not");
    wr(p, 2, 4);
    n = 4 + put_number(p + 4, "steps", 1);
    n += put_text(p + n, "steps", "x");
    expect_refused(p, n, "entry 1: key 'steps' repeated");
    /* kinds other than 0 and 1; numbers that are not finite */
    wr(p, 1, 4);
    n = 4 + put_number(p + 4, "steps", 1);
    p[4 + 4 + 5] = 2;
    expect_refused(p, n, "steps: kind 2 (0: number, 1: text)");
    n = 4 + put_number(p + 4, "steps", NAN);
    expect_refused(p, n, "steps: not a finite number");
    n = 4 + put_number(p + 4, "steps", -INFINITY);
    expect_refused(p, n, "steps: not a finite number");
    /* texts: a NUL byte, invalid UTF-8, a length past the payload */
    n = 4 + put_text(p + 4, "method", "dx");
    p[n - 1] = 0;
    expect_refused(p, n, "method: the text is not UTF-8 without NUL");
    n = 4 + put_text(p + 4, "method", "\xc3(");
    expect_refused(p, n, "method: the text is not UTF-8 without NUL");
    n = 4 + put_text(p + 4, "method", "dg");
    wr(p + 4 + 4 + 6 + 1, 0x7fffffff, 4);
    expect_refused(p, n, "method: a text of 2147483647 bytes runs past the payload");
    /* trailing bytes after the last entry */
    n = 4 + put_number(p + 4, "steps", 1);
    p[n] = 0;
    expect_refused(p, n + 1, "1 trailing bytes after the last entry");
    /* a version this pf does not read */
    n = 4 + put_number(p + 4, "steps", 1);
    pf_chunk c = stat_chunk(p, n);
    c.version = 2;
    pf_error err = {0};
    pf_stats_data d = {0};
    assert_int_equal(pf_stream_decode_stats(&c, &d, &err), PF_ERR_UNSUPPORTED);
    expect_msg(&err, "chunk STAT at byte 1184: version 2 not supported (this pf reads 1)");
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A stream cut inside its STAT chunk, or with a damaged one, says so naming the chunk; the
 * chunks before it stay read. */
static void test_stat_in_a_damaged_stream(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_stats_data d = {0};
    assert_int_equal(pf_stats_data_set_number(&d, "error_indicator", 0.25, &err), PF_OK);
    FILE *f = tmpfile();
    assert_non_null(f);
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "t", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(w, "pf-sim", "1", "pf-sim", &err), PF_OK);
    assert_int_equal(pf_stream_write_stats(w, &d, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    pf_stats_data_release(&d);
    pf_buffer b = {0};
    slurp(f, &b);
    fclose(f);
    size_t offs[4];
    assert_int_equal(chunk_offsets(&b, offs, 4), 3);
    char at[64];
    snprintf(at, sizeof at, "chunk STAT at byte %zu", offs[1]);
    for (int pipe = 0; pipe < 2; ++pipe) {
        read_result res;
        read_bytes(&b, offs[1] + 30, pipe, &res); /* inside the payload */
        assert_int_equal(res.status, PF_ERR_FORMAT);
        expect_msg(&res.err, "truncated inside chunk STAT");
        assert_int_equal(res.n, 1); /* INFO */
    }
    b.data[offs[1] + 16 + 8] ^= 0x40; /* a byte of the key: the CRC no longer matches */
    read_result res;
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, at);
    expect_msg(&res.err, "CRC mismatch");
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* CKPT version 2 carries the run's counters after the 16 bytes of version 1; both decode. */
static void test_checkpoint_header_versions(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_checkpoint_header h = {.mesh_id = 7,
                              .frame = 12,
                              .every = 4,
                              .counts = {.steps = 60,
                                         .factorisations = 61,
                                         .solves = 62,
                                         .pcg_iterations = 0x0102030405060708ull}};
    pf_buffer b = {0};
    assert_int_equal(pf_stream_encode_checkpoint_header(&h, &b, &err), PF_OK);
    assert_int_equal(b.size, 48);
    assert_true(rd(b.data, 8) == 7 && rd(b.data + 8, 4) == 12 && rd(b.data + 12, 4) == 4);
    assert_true(rd(b.data + 16, 8) == 60 && rd(b.data + 24, 8) == 61 && rd(b.data + 32, 8) == 62);
    assert_true(rd(b.data + 40, 8) == 0x0102030405060708ull);
    unsigned char state_bytes[3] = {1, 2, 3};
    assert_int_equal(pf_buffer_append(&b, state_bytes, 3, &err), PF_OK);
    pf_chunk c = {.tag = "CKPT", .version = 2, .size = b.size, .payload = b.data, .offset = 99};
    pf_checkpoint_header g;
    assert_int_equal(pf_stream_checkpoint_header(&c, &g, &err), PF_OK);
    assert_true(g.have_counts && g.mesh_id == 7 && g.frame == 12 && g.every == 4);
    assert_memory_equal(&g.counts, &h.counts, sizeof h.counts);
    assert_true(g.state == b.data + 48 && g.state_size == 3);
    c.version = 1; /* the same bytes read as version 1: the state starts at byte 16 */
    assert_int_equal(pf_stream_checkpoint_header(&c, &g, &err), PF_OK);
    assert_false(g.have_counts);
    assert_true(g.counts.steps == 0 && g.state == b.data + 16 && g.state_size == 35);
    c.size = 47; /* version 2 needs its 48 bytes */
    c.version = 2;
    assert_int_equal(pf_stream_checkpoint_header(&c, &g, &err), PF_ERR_FORMAT);
    expect_msg(&err, "chunk CKPT at byte 99");
    c.version = 3;
    assert_int_equal(pf_stream_checkpoint_header(&c, &g, &err), PF_ERR_UNSUPPORTED);
    expect_msg(&err, "version 3 not supported (this pf reads 1 to 2)");
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stat_layout),
        cmocka_unit_test(test_stat_writer_refuses),
        cmocka_unit_test(test_stat_truncated_payloads),
        cmocka_unit_test(test_stat_hostile_payloads),
        cmocka_unit_test(test_stat_in_a_damaged_stream),
        cmocka_unit_test(test_checkpoint_header_versions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
