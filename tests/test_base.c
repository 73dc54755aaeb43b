/* base: errors, allocation counter, arena, buffer, whole-file reading. */
#define _POSIX_C_SOURCE 200809L /* mkstemp */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <pf/base.h>

static pf_status fails_with_check(int value, pf_error *err)
{
    PF_CHECK(value > 0, err, PF_ERR_INVALID, "value %d is not positive", value);
    return PF_OK;
}

static pf_status propagates(int value, pf_error *err)
{
    PF_TRY(fails_with_check(value, err));
    return PF_WARN;
}

static void test_check_and_try(void **state)
{
    (void)state;
    pf_error err = {0};
    assert_int_equal(propagates(3, &err), PF_WARN); /* warnings pass through PF_TRY */
    assert_int_equal(propagates(-2, &err), PF_ERR_INVALID);
    assert_string_equal(err.msg, "value -2 is not positive");
    assert_int_equal(err.status, PF_ERR_INVALID);
    assert_non_null(strstr(err.src_file, "test_base.c"));
    pf_error_prefix(&err, "mesh.pfs");
    assert_string_equal(err.msg, "mesh.pfs: value -2 is not positive");
    assert_int_equal(fails_with_check(-1, NULL), PF_ERR_INVALID); /* NULL context is allowed */
    assert_string_equal(pf_status_name(PF_ERR_FORMAT), "format error");
}

static void test_long_messages_are_cut(void **state)
{
    (void)state;
    pf_error err = {0};
    char long_text[2000];
    memset(long_text, 'a', sizeof long_text - 1);
    long_text[sizeof long_text - 1] = '\0';
    pf_error_set(&err, PF_ERR_IO, __FILE__, __LINE__, "%s", long_text);
    assert_int_equal(strlen(err.msg), PF_ERROR_MSG_MAX - 1);
    pf_error_prefix(&err, "%s", long_text);
    assert_int_equal(strlen(err.msg), PF_ERROR_MSG_MAX - 1);
}

static void test_alloc_counter(void **state)
{
    (void)state;
    int64_t before = pf_alloc_live_bytes();
    double *a = pf_alloc_array(100, sizeof *a);
    assert_non_null(a);
    assert_int_equal(pf_alloc_live_bytes() - before, 800);
    a = pf_realloc_array(a, 10, sizeof *a);
    assert_int_equal(pf_alloc_live_bytes() - before, 80);
    unsigned char *z = pf_calloc(33, 1);
    for (int i = 0; i < 33; ++i)
        assert_int_equal(z[i], 0);
    assert_int_equal(((uintptr_t)z) % 16, 0);
    PF_FREE(a);
    assert_null(a);
    pf_free(z);
    pf_free(NULL);
    assert_int_equal(pf_alloc_live_bytes(), before);
}

static void test_overflow_is_refused(void **state)
{
    (void)state;
    size_t product;
    assert_true(pf_mul_overflows(SIZE_MAX / 2 + 1, 2, &product));
    assert_false(pf_mul_overflows(SIZE_MAX / 2, 2, &product));
    assert_null(pf_alloc_array(SIZE_MAX / 4, 8));
    assert_null(pf_calloc(SIZE_MAX / 2, 3));
    assert_null(pf_alloc(SIZE_MAX - 4));
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_arena(void **state)
{
    (void)state;
    pf_arena arena;
    pf_error err = {0};
    assert_int_equal(pf_arena_init(&arena, 1024, &err), PF_OK);
    size_t mark = pf_arena_mark(&arena);
    double *a = pf_arena_push(&arena, 10, sizeof *a);
    char *b = pf_arena_push(&arena, 3, 1);
    double *c = pf_arena_push(&arena, 1, sizeof *c);
    assert_non_null(a);
    assert_non_null(b);
    assert_int_equal((uintptr_t)c % 16, 0);
    assert_null(pf_arena_push(&arena, 1000, 1)); /* full: NULL, not a crash */
    assert_null(pf_arena_push(&arena, SIZE_MAX / 2, 4));
    pf_arena_reset(&arena, mark);
    assert_ptr_equal(pf_arena_push(&arena, 1, 1), a);
    assert_int_equal(arena.peak, 80 + 16 + 16);
    pf_arena_release(&arena);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_buffer(void **state)
{
    (void)state;
    pf_buffer b = {0};
    pf_error err = {0};
    for (int i = 0; i < 1000; ++i)
        assert_int_equal(pf_buffer_append(&b, &i, sizeof i, &err), PF_OK);
    assert_int_equal(b.size, 4000);
    int v;
    memcpy(&v, b.data + 4 * 777, sizeof v);
    assert_int_equal(v, 777);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A whole file read into a buffer, appended after what it holds; the limit, a directory and a
 * missing file are errors naming the path. 200,000 bytes cross the 64 KiB read pieces. */
static void test_read_file(void **state)
{
    (void)state;
    char path[] = "pf_base_test_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    enum { N = 200000 };
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    for (int i = 0; i < N; ++i)
        assert_int_equal(fputc('a' + i % 26, f), 'a' + i % 26);
    assert_int_equal(fclose(f), 0);

    pf_buffer b = {0};
    pf_error err = {0};
    assert_int_equal(pf_buffer_append(&b, "x", 1, &err), PF_OK);
    assert_int_equal(pf_buffer_read_file(&b, path, N, &err), PF_OK);
    assert_int_equal(b.size, N + 1);
    assert_int_equal(b.data[0], 'x');
    assert_int_equal(b.data[1 + 70001], 'a' + 70001 % 26);
    pf_buffer_release(&b);

    assert_int_equal(pf_buffer_read_file(&b, path, N - 1, &err), PF_ERR_TOO_LARGE);
    char expected[128];
    snprintf(expected, sizeof expected, "%s: larger than %d bytes", path, N - 1);
    assert_string_equal(err.msg, expected);
    pf_buffer_release(&b);

    assert_int_equal(pf_buffer_read_file(&b, ".", 100, &err), PF_ERR_IO);
    assert_memory_equal(err.msg, ".: cannot read: ", 16);
    pf_buffer_release(&b);

    assert_int_equal(remove(path), 0);
    assert_int_equal(pf_buffer_read_file(&b, path, 100, &err), PF_ERR_IO);
    snprintf(expected, sizeof expected, "%s: cannot open: ", path);
    assert_memory_equal(err.msg, expected, strlen(expected));
    assert_int_equal(b.size, 0);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_and_try),  cmocka_unit_test(test_long_messages_are_cut),
        cmocka_unit_test(test_alloc_counter),  cmocka_unit_test(test_overflow_is_refused),
        cmocka_unit_test(test_arena),          cmocka_unit_test(test_buffer),
        cmocka_unit_test(test_read_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
