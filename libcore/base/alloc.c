/* Allocation with a live-byte counter, the scratch arena and the growable buffer. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <pf/base.h>

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Each block carries its size in a 16-byte header so pf_free can keep the count exact; 16 keeps
 * the user pointer aligned for any scalar and SSE type. */
enum { HEADER = 16 };

static _Atomic int64_t live_bytes;

int pf_mul_overflows(size_t a, size_t b, size_t *product)
{
    if (b != 0 && a > SIZE_MAX / b)
        return 1;
    *product = a * b;
    return 0;
}

void *pf_alloc(size_t bytes)
{
    if (bytes > SIZE_MAX - HEADER)
        return NULL;
    unsigned char *block = malloc(bytes + HEADER);
    if (!block)
        return NULL;
    memcpy(block, &bytes, sizeof bytes);
    atomic_fetch_add(&live_bytes, (int64_t)bytes);
    return block + HEADER;
}

void *pf_alloc_array(size_t count, size_t size)
{
    size_t bytes;
    if (pf_mul_overflows(count, size, &bytes))
        return NULL;
    return pf_alloc(bytes);
}

void *pf_calloc(size_t count, size_t size)
{
    size_t bytes;
    if (pf_mul_overflows(count, size, &bytes))
        return NULL;
    void *p = pf_alloc(bytes);
    if (p)
        memset(p, 0, bytes);
    return p;
}

void *pf_realloc_array(void *p, size_t count, size_t size)
{
    size_t bytes;
    if (pf_mul_overflows(count, size, &bytes) || bytes > SIZE_MAX - HEADER)
        return NULL;
    if (!p)
        return pf_alloc(bytes);
    unsigned char *block = (unsigned char *)p - HEADER;
    size_t old;
    memcpy(&old, block, sizeof old);
    unsigned char *grown = realloc(block, bytes + HEADER);
    if (!grown)
        return NULL;
    memcpy(grown, &bytes, sizeof bytes);
    atomic_fetch_add(&live_bytes, (int64_t)bytes - (int64_t)old);
    return grown + HEADER;
}

void pf_free(void *p)
{
    if (!p)
        return;
    unsigned char *block = (unsigned char *)p - HEADER;
    size_t bytes;
    memcpy(&bytes, block, sizeof bytes);
    atomic_fetch_sub(&live_bytes, (int64_t)bytes);
    free(block);
}

int64_t pf_alloc_live_bytes(void)
{
    return atomic_load(&live_bytes);
}

pf_status pf_arena_init(pf_arena *a, size_t capacity, pf_error *err)
{
    memset(a, 0, sizeof *a);
    a->base = pf_alloc(capacity);
    PF_CHECK(a->base || capacity == 0, err, PF_ERR_NOMEM, "cannot allocate a %zu-byte arena",
             capacity);
    a->capacity = capacity;
    return PF_OK;
}

void pf_arena_release(pf_arena *a)
{
    pf_free(a->base);
    memset(a, 0, sizeof *a);
}

void *pf_arena_push(pf_arena *a, size_t count, size_t size)
{
    size_t bytes;
    if (pf_mul_overflows(count, size, &bytes) || bytes > SIZE_MAX - 15)
        return NULL;
    bytes = (bytes + 15) & ~(size_t)15;
    if (bytes > a->capacity - a->top)
        return NULL;
    void *p = a->base + a->top;
    a->top += bytes;
    if (a->top > a->peak)
        a->peak = a->top;
    return p;
}

pf_status pf_buffer_reserve(pf_buffer *b, size_t capacity, pf_error *err)
{
    if (capacity <= b->capacity)
        return PF_OK;
    size_t grown = b->capacity ? b->capacity : 256;
    while (grown < capacity)
        grown = grown > SIZE_MAX / 2 ? capacity : grown * 2;
    unsigned char *data = pf_realloc_array(b->data, grown, 1);
    PF_CHECK(data, err, PF_ERR_NOMEM, "cannot grow a buffer to %zu bytes", grown);
    b->data = data;
    b->capacity = grown;
    return PF_OK;
}

pf_status pf_buffer_append(pf_buffer *b, const void *bytes, size_t n, pf_error *err)
{
    PF_CHECK(n <= SIZE_MAX - b->size, err, PF_ERR_TOO_LARGE, "buffer size overflows");
    PF_TRY(pf_buffer_reserve(b, b->size + n, err));
    if (n)
        memcpy(b->data + b->size, bytes, n);
    b->size += n;
    return PF_OK;
}

void pf_buffer_release(pf_buffer *b)
{
    pf_free(b->data);
    memset(b, 0, sizeof *b);
}

double pf_time_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double pf_cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
