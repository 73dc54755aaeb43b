/* pf/base.h: status codes, error context, allocation with a live-byte counter, scratch arena.
 *
 * Every fallible pf function returns a pf_status and, on failure, fills a caller-provided
 * pf_error with a one-line message that says where the problem is ("stream chunk MESH at byte
 * 1184: face 17 has 2 nodes"). Negative statuses are fatal, positive ones are warnings.
 */
#ifndef PF_BASE_H
#define PF_BASE_H

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pf_status {
    PF_OK = 0,
    PF_WARN = 1,             /* completed, with a warning in the pf_error message */
    PF_ERR_NOMEM = -1,       /* allocation failed */
    PF_ERR_IO = -2,          /* read/write failed at the OS level */
    PF_ERR_FORMAT = -3,      /* input bytes or text are malformed */
    PF_ERR_INVALID = -4,     /* well-formed input that violates a requirement */
    PF_ERR_NUMERIC = -5,     /* a numerical failure (NaN, singular system, divergence) */
    PF_ERR_TOO_LARGE = -6,   /* a size or count beyond what the input or memory allows */
    PF_ERR_UNSUPPORTED = -7, /* a feature or version this build does not handle */
} pf_status;

enum { PF_ERROR_MSG_MAX = 512 };

/* Error context, owned by the caller, filled by the callee on failure. Zero-initialise it. */
typedef struct pf_error {
    pf_status status;
    char msg[PF_ERROR_MSG_MAX]; /* human-readable, one line, no trailing newline */
    const char *src_file;       /* where in pf the error was raised (for debugging) */
    int src_line;
} pf_error;

/* Short name of a status ("format error"). Never NULL. */
const char *pf_status_name(pf_status s);

/* Stores a printf-formatted message in err (which may be NULL) and returns s. */
pf_status pf_error_set(pf_error *err, pf_status s, const char *src_file, int src_line,
                       const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

/* Prepends "prefix: " to an existing message, e.g. the file name a tool was reading. */
void pf_error_prefix(pf_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Returns code from the current function with a message when cond is false. */
#define PF_CHECK(cond, err, code, ...)                                                             \
    do {                                                                                           \
        if (!(cond))                                                                               \
            return pf_error_set((err), (code), __FILE__, __LINE__, __VA_ARGS__);                   \
    } while (0)

/* Propagates a fatal status from a call whose error context is already filled. */
#define PF_TRY(expr)                                                                               \
    do {                                                                                           \
        pf_status pf_try_status_ = (expr);                                                         \
        if (pf_try_status_ < 0)                                                                    \
            return pf_try_status_;                                                                 \
    } while (0)

/* ---- allocation ----------------------------------------------------------------------------
 * All pf memory goes through these so that tests can assert that nothing leaks: the process-wide
 * live-byte counter is the one piece of shared state in pf, updated atomically (thread-safe).
 * pf_alloc_array checks count * size for overflow and returns NULL on overflow or exhaustion.
 * pf_free(NULL) does nothing. Memory is aligned to 16 bytes. */
void *pf_alloc(size_t bytes);
void *pf_calloc(size_t count, size_t size);
void *pf_alloc_array(size_t count, size_t size);
void *pf_realloc_array(void *p, size_t count, size_t size);
void pf_free(void *p);
/* Bytes currently allocated through pf_alloc* and not yet freed. */
int64_t pf_alloc_live_bytes(void);

/* Frees *p and sets it to NULL. */
#define PF_FREE(p)                                                                                 \
    do {                                                                                           \
        pf_free(p);                                                                                \
        (p) = NULL;                                                                                \
    } while (0)

/* Allocates an array of n elements of *p's type into p; evaluates to non-zero on success. */
#define PF_ALLOC_N(p, n) (((p) = pf_alloc_array((size_t)(n), sizeof(*(p)))) != NULL || (n) == 0)

/* true when a * b overflows size_t; otherwise stores the product. */
int pf_mul_overflows(size_t a, size_t b, size_t *product);

/* ---- scratch arena ---------------------------------------------------------------------------
 * A stack of scratch memory for element loops and time steps: push, use, pop back to a mark.
 * Steady-state loops allocate nothing once the arena is large enough. Not thread-safe: one arena
 * per thread. */
typedef struct pf_arena {
    unsigned char *base; /* [capacity] bytes */
    size_t capacity;
    size_t top;  /* bytes in use */
    size_t peak; /* largest top seen: the capacity a loop needs */
} pf_arena;

pf_status pf_arena_init(pf_arena *a, size_t capacity, pf_error *err);
void pf_arena_release(pf_arena *a);
/* count * size bytes aligned to 16, or NULL when the arena is full or the product overflows. */
void *pf_arena_push(pf_arena *a, size_t count, size_t size);
static inline size_t pf_arena_mark(const pf_arena *a)
{
    return a->top;
}
static inline void pf_arena_reset(pf_arena *a, size_t mark)
{
    a->top = mark;
}

/* ---- growable array of bytes (for writers and builders) ------------------------------------ */
typedef struct pf_buffer {
    unsigned char *data; /* [size] bytes, capacity >= size */
    size_t size;
    size_t capacity;
} pf_buffer;

pf_status pf_buffer_append(pf_buffer *b, const void *bytes, size_t n, pf_error *err);
pf_status pf_buffer_reserve(pf_buffer *b, size_t capacity, pf_error *err);
void pf_buffer_release(pf_buffer *b);
/* Appends the whole file at path to b, reading to its end (so pipes and process substitution
 * work). PF_ERR_IO "path: cannot open: reason" or "path: cannot read: reason" (a directory opens
 * but cannot be read); PF_ERR_TOO_LARGE "path: larger than N bytes" when more than max_bytes
 * arrive (the bytes read so far stay in b); PF_ERR_NOMEM naming path. */
pf_status pf_buffer_read_file(pf_buffer *b, const char *path, size_t max_bytes, pf_error *err);

/* Wall-clock seconds from a monotonic clock, for timing reports. */
double pf_time_seconds(void);
/* CPU seconds this process has used, all threads (on a shared machine the honest cost beside
 * the wall time). */
double pf_cpu_seconds(void);

/* The median of v[0..n) (the mean of the middle two for even n; 0 for n <= 0); sorts v. */
double pf_median(double *v, int64_t n);

/* Progress of a long computation: done out of total (any unit, 0 <= done <= total, total > 0),
 * reported now and then from the thread that called the computation; ctx is the caller's. */
typedef void (*pf_progress_fn)(void *ctx, double done, double total);

/* Progress of a computation made of named phases (a simulator's set-up: "element integrals",
 * "face integrals", "basis functions", "element matrices", "symbolic analysis", "numeric
 * factorisation"). phase is a static string; done counts the phase's items out of total
 * (elements, faces; 1 for a phase reported only at its start and end). Every phase is reported
 * first with done = 0 and last with done = total; done never decreases in between. */
typedef struct pf_progress_event {
    const char *phase;
    int64_t done, total;
} pf_progress_event;

/* Called from the thread that called the computation, often (up to once per item): it must be
 * cheap, and throttling what it prints is its own business. user is the hook's. */
typedef void (*pf_progress_event_fn)(void *user, const pf_progress_event *ev);

/* A callback and its context, borrowed by whatever it is handed to; zero value: none. */
typedef struct pf_progress_hook {
    pf_progress_event_fn fn;
    void *user;
} pf_progress_hook;

/* Reports phase at done of total through h; nothing when h or h->fn is NULL. */
void pf_progress_post(const pf_progress_hook *h, const char *phase, int64_t done, int64_t total);

/* OpenBLAS's thread count for a stretch of BLAS / LAPACK calls (base/blas_threads.c says why pf
 * runs its own calls on one: results independent of the core count, and small products).
 * pf_blas_threads_set sets it to threads (> 0) unless the user set OPENBLAS_NUM_THREADS,
 * GOTO_NUM_THREADS or OMP_NUM_THREADS (force: even then) or the BLAS is not OpenBLAS, and returns
 * what pf_blas_threads_restore needs to put the count back. Process-wide, not reentrant across
 * threads. */
typedef struct pf_blas_threads {
    int before; /* the count replaced; 0: unchanged */
} pf_blas_threads;
pf_blas_threads pf_blas_threads_set(int threads, bool force);
void pf_blas_threads_restore(pf_blas_threads saved);
/* True when the process's BLAS is OpenBLAS, whose count pf_blas_threads_set can change. */
bool pf_blas_threads_settable(void);

#ifdef __cplusplus
}
#endif
#endif
