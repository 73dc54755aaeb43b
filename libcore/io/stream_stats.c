/* The STAT chunk: a run's statistics as named entries, docs/stream-format.md.
 *
 *   u32 n | n x (u32 key_len | u8 key[key_len] | u8 kind | value)
 *   kind 0: f64 value (finite); kind 1: u32 len | u8 text[len] (UTF-8, no NUL)
 *
 * Named entries rather than a fixed layout: a reader shows entries it does not know by their
 * names, and a producer adds a statistic without a new chunk version. Keys are 1 to 64 bytes of
 * [a-z0-9_], unique within the chunk, so that they print as JSON keys and words without escapes. */
#include <pf/io.h>

#include <math.h>
#include <string.h>

#include "stream_bytes.h"

enum { KIND_NUMBER = 0, KIND_TEXT = 1, KEY_MAX = 64, ENTRY_MIN_BYTES = 10 };

#define STATS_FAIL(c, err, ...)                                                                    \
    pf_stream_chunk_error((err), PF_ERR_FORMAT, __FILE__, __LINE__, (c), __VA_ARGS__)

/* 1 to KEY_MAX bytes of [a-z0-9_]. */
static bool key_is_valid(const unsigned char *k, size_t n)
{
    if (n == 0 || n > KEY_MAX)
        return false;
    for (size_t i = 0; i < n; ++i)
        if (!((k[i] >= 'a' && k[i] <= 'z') || (k[i] >= '0' && k[i] <= '9') || k[i] == '_'))
            return false;
    return true;
}

static char *copy_string(const void *s, size_t n)
{
    char *c = pf_alloc(n + 1);
    if (c) {
        if (n)
            memcpy(c, s, n);
        c[n] = '\0';
    }
    return c;
}

static pf_stat_entry *find(const pf_stats_data *d, const char *key, size_t n)
{
    for (int32_t i = 0; i < d->n; ++i)
        if (strlen(d->entries[i].key) == n && memcmp(d->entries[i].key, key, n) == 0)
            return &d->entries[i];
    return NULL;
}

const pf_stat_entry *pf_stats_data_find(const pf_stats_data *d, const char *key)
{
    return find(d, key, strlen(key));
}

/* The entry of key (n bytes), appended empty when d has none; its old text freed. */
static pf_status slot(pf_stats_data *d, const char *key, size_t n, pf_stat_entry **e, pf_error *err)
{
    PF_CHECK(key_is_valid((const unsigned char *)key, n), err, PF_ERR_INVALID,
             "STAT: key '%.*s' is not 1 to %d characters of a-z, 0-9 and _", (int)(n < 80 ? n : 80),
             key, (int)KEY_MAX);
    *e = find(d, key, n);
    if (*e) {
        pf_free((*e)->text);
        (*e)->text = NULL;
        return PF_OK;
    }
    PF_CHECK(d->n < INT32_MAX, err, PF_ERR_TOO_LARGE, "STAT: too many entries");
    if (d->n == d->cap) {
        int32_t cap = d->cap ? (d->cap > INT32_MAX / 2 ? INT32_MAX : 2 * d->cap) : 16;
        pf_stat_entry *grown = pf_realloc_array(d->entries, (size_t)cap, sizeof *grown);
        PF_CHECK(grown, err, PF_ERR_NOMEM, "out of memory");
        d->entries = grown;
        d->cap = cap;
    }
    pf_stat_entry *x = &d->entries[d->n];
    memset(x, 0, sizeof *x);
    x->key = copy_string(key, n);
    PF_CHECK(x->key, err, PF_ERR_NOMEM, "out of memory");
    d->n++;
    *e = x;
    return PF_OK;
}

pf_status pf_stats_data_set_number(pf_stats_data *d, const char *key, double value, pf_error *err)
{
    PF_CHECK(isfinite(value), err, PF_ERR_INVALID, "STAT: %s is not finite", key);
    pf_stat_entry *e = NULL;
    PF_TRY(slot(d, key, strlen(key), &e, err));
    e->value = value;
    return PF_OK;
}

pf_status pf_stats_data_set_text(pf_stats_data *d, const char *key, const char *text, pf_error *err)
{
    size_t n = strlen(text);
    PF_CHECK(pf_stream_utf8_invalid_at((const unsigned char *)text, n) == n && n <= UINT32_MAX, err,
             PF_ERR_INVALID, "STAT: the text of %s is not UTF-8", key);
    char *copy = copy_string(text, n);
    PF_CHECK(copy, err, PF_ERR_NOMEM, "out of memory");
    pf_stat_entry *e = NULL;
    pf_status st = slot(d, key, strlen(key), &e, err);
    if (st < 0) {
        pf_free(copy);
        return st;
    }
    e->text = copy;
    e->value = 0;
    return PF_OK;
}

void pf_stats_data_release(pf_stats_data *d)
{
    for (int32_t i = 0; i < d->n; ++i) {
        pf_free(d->entries[i].key);
        pf_free(d->entries[i].text);
    }
    pf_free(d->entries);
    memset(d, 0, sizeof *d);
}

pf_status pf_stream_encode_stats(const pf_stats_data *d, pf_buffer *out, pf_error *err)
{
    uint64_t bytes = 4;
    for (int32_t i = 0; i < d->n; ++i) {
        const pf_stat_entry *e = &d->entries[i];
        size_t nk = strlen(e->key), nt = e->text ? strlen(e->text) : 0;
        PF_CHECK(key_is_valid((const unsigned char *)e->key, nk) && find(d, e->key, nk) == e, err,
                 PF_ERR_INVALID, "STAT: entry %d: key '%s' invalid or repeated", (int)i, e->key);
        PF_CHECK(e->text ? pf_stream_utf8_invalid_at((const unsigned char *)e->text, nt) == nt
                         : isfinite(e->value),
                 err, PF_ERR_INVALID, "STAT: %s: a non-finite number or a text not UTF-8", e->key);
        bytes += 5 + nk + (e->text ? 4 + nt : 8);
    }
    PF_CHECK(bytes < SIZE_MAX - out->size, err, PF_ERR_TOO_LARGE, "STAT: too large");
    PF_TRY(pf_buffer_reserve(out, out->size + (size_t)bytes, err));
    unsigned char *p = out->data + out->size;
    le_put_u32(p, (uint32_t)d->n);
    p += 4;
    for (int32_t i = 0; i < d->n; ++i) {
        const pf_stat_entry *e = &d->entries[i];
        size_t nk = strlen(e->key);
        le_put_u32(p, (uint32_t)nk);
        memcpy(p + 4, e->key, nk);
        p += 4 + nk;
        *p++ = e->text ? KIND_TEXT : KIND_NUMBER;
        if (e->text) {
            size_t nt = strlen(e->text);
            le_put_u32(p, (uint32_t)nt);
            if (nt)
                memcpy(p + 4, e->text, nt);
            p += 4 + nt;
        } else {
            le_put_f64(p, e->value);
            p += 8;
        }
    }
    out->size += (size_t)bytes;
    return PF_OK;
}

/* One entry at *p (left bytes) into d, checked; p and left advanced past it. */
static pf_status read_entry(const pf_chunk *c, int32_t i, const unsigned char **p, uint64_t *left,
                            pf_stats_data *d, pf_error *err)
{
    uint64_t at = c->size - *left; /* payload byte of the entry, for messages */
    if (*left < 5)
        return STATS_FAIL(c, err, "entry %d at payload byte %llu: truncated key length", (int)i,
                          (unsigned long long)at);
    uint64_t nk = le_get_u32(*p);
    if (nk > *left - 5)
        return STATS_FAIL(c, err,
                          "entry %d at payload byte %llu: a key of %llu bytes runs past "
                          "the payload",
                          (int)i, (unsigned long long)at, (unsigned long long)nk);
    const char *key = (const char *)*p + 4;
    if (!key_is_valid(*p + 4, (size_t)nk))
        return STATS_FAIL(c, err,
                          "entry %d at payload byte %llu: the key is not 1 to %d "
                          "characters of a-z, 0-9 and _",
                          (int)i, (unsigned long long)at, (int)KEY_MAX);
    if (find(d, key, (size_t)nk))
        return STATS_FAIL(c, err, "entry %d: key '%.*s' repeated", (int)i, (int)nk, key);
    unsigned kind = (*p)[4 + nk];
    *p += 5 + nk, *left -= 5 + nk;
    pf_stat_entry *e = NULL;
    if (kind == KIND_NUMBER) {
        if (*left < 8)
            return STATS_FAIL(c, err, "%.*s: truncated number", (int)nk, key);
        double v = le_get_f64(*p);
        if (!isfinite(v))
            return STATS_FAIL(c, err, "%.*s: not a finite number", (int)nk, key);
        PF_TRY(slot(d, key, (size_t)nk, &e, err));
        e->value = v;
        *p += 8, *left -= 8;
        return PF_OK;
    }
    if (kind != KIND_TEXT)
        return STATS_FAIL(c, err, "%.*s: kind %u (0: number, 1: text)", (int)nk, key, kind);
    if (*left < 4)
        return STATS_FAIL(c, err, "%.*s: truncated text length", (int)nk, key);
    uint64_t nt = le_get_u32(*p);
    if (nt > *left - 4)
        return STATS_FAIL(c, err, "%.*s: a text of %llu bytes runs past the payload", (int)nk, key,
                          (unsigned long long)nt);
    if (pf_stream_utf8_invalid_at(*p + 4, (size_t)nt) != nt)
        return STATS_FAIL(c, err, "%.*s: the text is not UTF-8 without NUL", (int)nk, key);
    char *text = copy_string(*p + 4, (size_t)nt);
    PF_CHECK(text, err, PF_ERR_NOMEM, "out of memory");
    pf_status st = slot(d, key, (size_t)nk, &e, err);
    if (st < 0) {
        pf_free(text);
        return st;
    }
    e->text = text;
    *p += 4 + nt, *left -= 4 + nt;
    return PF_OK;
}

pf_status pf_stream_decode_stats(const pf_chunk *c, pf_stats_data *d, pf_error *err)
{
    memset(d, 0, sizeof *d);
    PF_CHECK(strcmp(c->tag, "STAT") == 0, err, PF_ERR_INVALID, "not a STAT chunk");
    PF_TRY(pf_stream_check_version(c, err));
    if (c->size < 4)
        return STATS_FAIL(c, err, "payload of %llu bytes, shorter than its 4-byte count",
                          (unsigned long long)c->size);
    const unsigned char *p = c->payload;
    uint64_t n = le_get_u32(p), left = c->size - 4;
    if (n > left / ENTRY_MIN_BYTES) /* before allocating anything */
        return STATS_FAIL(c, err, "%llu entries cannot fit in %llu bytes (%d at least each)",
                          (unsigned long long)n, (unsigned long long)left, (int)ENTRY_MIN_BYTES);
    p += 4;
    pf_status st = PF_OK;
    for (int32_t i = 0; st == PF_OK && i < (int32_t)n; ++i)
        st = read_entry(c, i, &p, &left, d, err);
    if (st == PF_OK && left != 0)
        st = STATS_FAIL(c, err, "%llu trailing bytes after the last entry (payload of %llu bytes)",
                        (unsigned long long)left, (unsigned long long)c->size);
    if (st < 0)
        pf_stats_data_release(d);
    return st;
}
