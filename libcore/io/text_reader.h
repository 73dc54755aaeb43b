/* A line tokenizer for the text mesh formats (.msh, .node, .ele): the whole file in memory, one
 * line at a time, whitespace-separated tokens, and messages that start with "path:LINE: ".
 *
 * Tokens never run across a line end, so every number is attributed to the line it sits on, and a
 * NUL byte or any other junk inside a token makes that token invalid rather than ending it early.
 */
#ifndef PF_IO_TEXT_READER_H
#define PF_IO_TEXT_READER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <pf/base.h>

typedef struct text_reader {
    const char *path; /* borrowed: labels every message */
    char *data;       /* [size] bytes of the file, owned */
    size_t size;
    size_t next;      /* offset of the line after the current one */
    const char *line; /* the current line, without its end of line and comment; not terminated */
    size_t line_len;
    size_t cursor;   /* offset of the next token within line */
    int64_t line_no; /* 1-based number of the current line; the last line once the file ended */
    char comment;    /* the rest of a line from this character on is ignored; '\0' for none */
} text_reader;

/* Reads the whole file at path. PF_ERR_IO "path: cannot read: reason"; PF_ERR_FORMAT
 * "path:1: empty file" for a file of 0 bytes. r is zeroed after a failure. */
pf_status pf_text_reader_open(text_reader *r, const char *path, char comment, pf_error *err);
void pf_text_reader_close(text_reader *r);

/* Moves to the next line that holds a token; false (and nothing moved) at the end of the file. */
bool pf_text_reader_next_line(text_reader *r);

/* Bytes after the current line: an upper bound on what the rest of the file can hold. */
static inline size_t text_reader_bytes_left(const text_reader *r)
{
    return r->size - r->next;
}

/* True when the current line is exactly word (surrounding blanks aside). */
bool pf_text_reader_line_is(const text_reader *r, const char *word);

/* True when only blanks are left on the current line. */
bool pf_text_reader_at_line_end(text_reader *r);

/* The next token of the current line (blank-delimited, not NUL-terminated) and its length; NULL
 * when the line has no more. */
const char *pf_text_reader_token(text_reader *r, size_t *len);

/* The next token of the current line as a decimal integer / a finite number. PF_ERR_FORMAT
 * "path:LINE: expected WHAT, found 'tok'" (or "... at the end of the line"), and "path:LINE: WHAT
 * is not finite (tok)" for NaN or infinite values. */
pf_status pf_text_reader_int(text_reader *r, int64_t *v, const char *what, pf_error *err);
pf_status pf_text_reader_double(text_reader *r, double *v, const char *what, pf_error *err);

/* PF_ERR_FORMAT unless the current line has no token left: "path:LINE: unexpected 'tok' after
 * WHAT". */
pf_status pf_text_reader_expect_line_end(text_reader *r, const char *what, pf_error *err);

/* A count read from the file before anything is allocated from it: non-negative, at most what
 * the bytes left can hold when each entry has at least tokens tokens (each a character and a
 * separator), and at most INT32_MAX. PF_ERR_FORMAT "path:LINE: N WHAT announced, more than the
 * rest of the file can hold"; PF_ERR_TOO_LARGE beyond INT32_MAX. */
pf_status pf_text_reader_check_count(const text_reader *r, int64_t count, int64_t tokens,
                                  const char *what, pf_error *err);

/* Sets err to "path:LINE: " followed by the formatted message and returns code. */
pf_status pf_text_reader_fail(const text_reader *r, pf_error *err, pf_status code,
                           const char *src_file, int src_line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 6, 7)))
#endif
    ;

#define TEXT_FAIL(r, err, code, ...)                                                               \
    pf_text_reader_fail((r), (err), (code), __FILE__, __LINE__, __VA_ARGS__)

/* Returns code with a "path:LINE: " message from the current function when cond is false. */
#define TEXT_CHECK(cond, r, err, code, ...)                                                        \
    do {                                                                                           \
        if (!(cond))                                                                               \
            return TEXT_FAIL((r), (err), (code), __VA_ARGS__);                                     \
    } while (0)

#endif
