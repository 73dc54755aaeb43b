/* Line tokenizer shared by the text mesh importers. */
#include "text_reader.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Longest token taken as a number: far beyond any %.17g output or 64-bit integer. */
enum { NUMBER_MAX = 64 };

static bool is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

pf_status pf_text_reader_open(text_reader *r, const char *path, char comment, pf_error *err)
{
    memset(r, 0, sizeof *r);
    pf_buffer b = {0};
    pf_status s = pf_buffer_read_file(&b, path, SIZE_MAX, err);
    if (s == PF_OK && b.size == 0)
        s = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s:1: empty file", path);
    if (s < 0) {
        pf_buffer_release(&b);
        return s;
    }
    r->path = path;
    r->data = (char *)b.data;
    r->size = b.size;
    r->comment = comment;
    return PF_OK;
}

void pf_text_reader_close(text_reader *r)
{
    pf_free(r->data);
    memset(r, 0, sizeof *r);
}

bool pf_text_reader_next_line(text_reader *r)
{
    size_t pos = r->next;
    int64_t no = r->line_no;
    while (pos < r->size) {
        const char *start = r->data + pos;
        const char *nl = memchr(start, '\n', r->size - pos);
        size_t len = nl ? (size_t)(nl - start) : r->size - pos;
        pos += len + (nl ? 1 : 0);
        ++no;
        if (r->comment) {
            const char *c = memchr(start, r->comment, len);
            if (c)
                len = (size_t)(c - start);
        }
        size_t i = 0;
        while (i < len && is_blank(start[i]))
            ++i;
        if (i == len)
            continue;
        r->line = start;
        r->line_len = len;
        r->cursor = i;
        r->next = pos;
        r->line_no = no;
        return true;
    }
    return false;
}

const char *pf_text_reader_token(text_reader *r, size_t *len)
{
    size_t i = r->cursor;
    while (i < r->line_len && is_blank(r->line[i]))
        ++i;
    size_t start = i;
    while (i < r->line_len && !is_blank(r->line[i]))
        ++i;
    r->cursor = i;
    *len = i - start;
    return i > start ? r->line + start : NULL;
}

bool pf_text_reader_at_line_end(text_reader *r)
{
    while (r->cursor < r->line_len && is_blank(r->line[r->cursor]))
        ++r->cursor;
    return r->cursor == r->line_len;
}

bool pf_text_reader_line_is(const text_reader *r, const char *word)
{
    size_t a = 0, b = r->line_len, n = strlen(word);
    while (a < b && is_blank(r->line[a]))
        ++a;
    while (b > a && is_blank(r->line[b - 1]))
        --b;
    return b - a == n && memcmp(r->line + a, word, n) == 0;
}

pf_status pf_text_reader_fail(const text_reader *r, pf_error *err, pf_status code,
                           const char *src_file, int src_line, const char *fmt, ...)
{
    if (!err)
        return code;
    char reason[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(reason, sizeof reason, fmt, ap);
    va_end(ap);
    return pf_error_set(err, code, src_file, src_line, "%s:%lld: %s", r->path,
                        (long long)(r->line_no > 0 ? r->line_no : 1), reason);
}

/* A token quoted for a message: printable ASCII only, cut at 24 characters. */
static void quote_token(const char *tok, size_t len, char out[32])
{
    size_t n = len < 24 ? len : 24;
    for (size_t i = 0; i < n; ++i)
        out[i] = tok[i] >= 0x20 && tok[i] < 0x7f ? tok[i] : '?';
    if (len > n) {
        memcpy(out + n, "...", 3);
        n += 3;
    }
    out[n] = '\0';
}

/* The next token copied into buf as a C string, or an error naming what was expected. */
static pf_status number_token(text_reader *r, char buf[NUMBER_MAX + 1], const char *what,
                              pf_error *err)
{
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    TEXT_CHECK(tok, r, err, PF_ERR_FORMAT, "expected %s at the end of the line", what);
    char shown[32];
    quote_token(tok, len, shown);
    TEXT_CHECK(len <= NUMBER_MAX && !memchr(tok, '\0', len), r, err, PF_ERR_FORMAT,
               "expected %s, found '%s'", what, shown);
    memcpy(buf, tok, len);
    buf[len] = '\0';
    return PF_OK;
}

pf_status pf_text_reader_int(text_reader *r, int64_t *v, const char *what, pf_error *err)
{
    char buf[NUMBER_MAX + 1], *end;
    PF_TRY(number_token(r, buf, what, err));
    errno = 0;
    long long value = strtoll(buf, &end, 10);
    char shown[32];
    quote_token(buf, strlen(buf), shown);
    TEXT_CHECK(end != buf && *end == '\0', r, err, PF_ERR_FORMAT, "expected %s, found '%s'", what,
               shown);
    TEXT_CHECK(errno != ERANGE, r, err, PF_ERR_FORMAT, "%s %s is out of range", what, shown);
    *v = (int64_t)value;
    return PF_OK;
}

pf_status pf_text_reader_double(text_reader *r, double *v, const char *what, pf_error *err)
{
    char buf[NUMBER_MAX + 1], *end;
    PF_TRY(number_token(r, buf, what, err));
    double value = strtod(buf, &end);
    char shown[32];
    quote_token(buf, strlen(buf), shown);
    TEXT_CHECK(end != buf && *end == '\0', r, err, PF_ERR_FORMAT, "expected %s, found '%s'", what,
               shown);
    /* strtod turns "nan", "inf" and overflowing literals into non-finite values: refused here so
     * that no later stage ever sees them. Underflow to 0 or a subnormal is harmless. */
    TEXT_CHECK(isfinite(value), r, err, PF_ERR_FORMAT, "%s is not finite (%s)", what, shown);
    *v = value;
    return PF_OK;
}

pf_status pf_text_reader_expect_line_end(text_reader *r, const char *what, pf_error *err)
{
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    if (!tok)
        return PF_OK;
    char shown[32];
    quote_token(tok, len, shown);
    return TEXT_FAIL(r, err, PF_ERR_FORMAT, "unexpected '%s' after %s", shown, what);
}

pf_status pf_text_reader_check_count(const text_reader *r, int64_t count, int64_t tokens,
                                  const char *what, pf_error *err)
{
    TEXT_CHECK(count >= 0, r, err, PF_ERR_FORMAT, "negative number of %s (%lld)", what,
               (long long)count);
    /* count entries take at least 2 tokens count - 1 bytes (the last may end the file). */
    uint64_t room = tokens > 0 ? ((uint64_t)text_reader_bytes_left(r) + 1) / (2 * (uint64_t)tokens)
                               : UINT64_MAX;
    TEXT_CHECK((uint64_t)count <= room, r, err, PF_ERR_FORMAT,
               "%lld %s announced, more than the rest of the file can hold", (long long)count,
               what);
    TEXT_CHECK(count <= INT32_MAX, r, err, PF_ERR_TOO_LARGE, "%lld %s: more than pf handles",
               (long long)count, what);
    return PF_OK;
}
