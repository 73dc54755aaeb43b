/* Strict JSON syntax check for scene files: cJSON builds the tree, this decides validity and says
 * where a text goes wrong. */
#include "scene_json.h"

#include <pf/sim.h>

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

/* 1-based line and column of text[pos]; columns count UTF-8 characters, not bytes. */
static void line_col(const char *text, size_t pos, long *line, long *col)
{
    *line = 1;
    *col = 1;
    for (size_t i = 0; i < pos; ++i) {
        unsigned char c = (unsigned char)text[i];
        if (c == '\n') {
            ++*line;
            *col = 1;
        } else if ((c & 0xC0) != 0x80) {
            ++*col;
        }
    }
}

pf_status pf_scene_json_error_at(const char *text, size_t len, size_t pos, const char *name,
                                 const char *what, pf_error *err)
{
    /* the excerpt is cut on a character boundary */
    long line, col;
    line_col(text, pos, &line, &col);
    size_t n = 0;
    while (pos + n < len && n < 20 && text[pos + n] != '\n' && text[pos + n] != '\r')
        ++n;
    while (n > 0 && pos + n < len && ((unsigned char)text[pos + n] & 0xC0) == 0x80)
        --n;
    char excerpt[24];
    for (size_t i = 0; i < n; ++i) {
        unsigned char c = (unsigned char)text[pos + i];
        excerpt[i] = c < 0x20 || c == 0x7f ? ' ' : (char)c;
    }
    excerpt[n] = '\0';
    if (what && n > 0)
        return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s:%ld:%ld: %s near '%s'",
                            name, line, col, what, excerpt);
    if (what)
        return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s:%ld:%ld: %s", name, line,
                            col, what);
    if (n == 0)
        return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                            "%s:%ld:%ld: JSON syntax error at end of %s", name, line, col,
                            pos >= len ? "text" : "line");
    return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                        "%s:%ld:%ld: JSON syntax error near '%s'", name, line, col, excerpt);
}

/* JSON whitespace (RFC 8259). */
static bool is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

static bool only_whitespace(const char *text, size_t len)
{
    for (size_t i = 0; i < len; ++i)
        if (!is_space(text[i]))
            return false;
    return true;
}

/* cJSON says that a text is invalid but not precisely where (it often stops one token late, or
 * at the end of the text), and it is lax: it reads "-.5", "01" and "1.", control bytes in
 * strings, and lets a malformed \u escape through as an empty string. So this scanner of the
 * strict JSON grammar (RFC 8259) decides validity, before cJSON builds the tree, and finds the
 * first byte that cannot continue a valid document: the offending byte for structure (a missing
 * comma, a trailing comma, a stray bracket), the start of the token for a bad literal or number,
 * the offending escape in a string. It also refuses "\u0000", which would cut a C string. */
enum { JSON_MAX_DEPTH = 1000 }; /* cJSON's nesting limit */

typedef struct scanner {
    const char *t;
    size_t len, pos;
    int depth;
    const char *why; /* a specific reason, or NULL for "JSON syntax error near ..." */
} scanner;

static bool scan_value(scanner *sc);

static void scan_space(scanner *sc)
{
    while (sc->pos < sc->len && is_space(sc->t[sc->pos]))
        ++sc->pos;
}

static bool scan_char(scanner *sc, char c)
{
    if (sc->pos < sc->len && sc->t[sc->pos] == c) {
        ++sc->pos;
        return true;
    }
    return false;
}

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}
static bool is_alnum(char c)
{
    return is_digit(c) || ((c | 0x20) >= 'a' && (c | 0x20) <= 'z');
}

static bool scan_digits(scanner *sc)
{
    size_t start = sc->pos;
    while (sc->pos < sc->len && is_digit(sc->t[sc->pos]))
        ++sc->pos;
    return sc->pos > start;
}

static bool scan_literal(scanner *sc, const char *word)
{
    size_t n = strlen(word);
    if (sc->len - sc->pos < n || memcmp(sc->t + sc->pos, word, n) != 0 ||
        (sc->pos + n < sc->len && is_alnum(sc->t[sc->pos + n])))
        return false;
    sc->pos += n;
    return true;
}

/* RFC 8259: -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?; on failure pos is the token start. */
static bool scan_number(scanner *sc)
{
    size_t start = sc->pos;
    scan_char(sc, '-');
    bool ok = scan_char(sc, '0') || scan_digits(sc);
    if (ok && scan_char(sc, '.'))
        ok = scan_digits(sc);
    if (ok && (scan_char(sc, 'e') || scan_char(sc, 'E'))) {
        if (!scan_char(sc, '+'))
            scan_char(sc, '-');
        ok = scan_digits(sc);
    }
    /* "01", "1.5x": the number runs on */
    if (ok && sc->pos < sc->len && (is_alnum(sc->t[sc->pos]) || sc->t[sc->pos] == '.'))
        ok = false;
    if (!ok)
        sc->pos = start;
    return ok;
}

/* The 4 hex digits after "\u" at t[at]; -1 when they are not 4 hex digits. */
static long scan_hex4(const scanner *sc, size_t at)
{
    long v = 0;
    for (size_t i = at; i < at + 4; ++i) {
        char h = i < sc->len ? sc->t[i] : '\0';
        int lower = h | 0x20;
        int d = is_digit(h) ? h - '0' : lower >= 'a' && lower <= 'f' ? lower - 'a' + 10 : -1;
        if (d < 0)
            return -1;
        v = 16 * v + d;
    }
    return v;
}

/* A \u escape at t[pos] (the backslash): one code unit, or a UTF-16 surrogate pair. */
static bool scan_unicode_escape(scanner *sc)
{
    long u = scan_hex4(sc, sc->pos + 2);
    if (u < 0) {
        sc->why = "bad \\u escape in a string";
        return false;
    }
    /* a C string would end there: "d\u0000t" would silently read as "d" */
    if (u == 0) {
        sc->why = "\\u0000 in a string";
        return false;
    }
    if (u >= 0xDC00 && u <= 0xDFFF) {
        sc->why = "unpaired UTF-16 surrogate in a string";
        return false;
    }
    if (u >= 0xD800 && u <= 0xDBFF) {
        long low = sc->pos + 7 < sc->len && sc->t[sc->pos + 6] == '\\' && sc->t[sc->pos + 7] == 'u'
                       ? scan_hex4(sc, sc->pos + 8)
                       : -1;
        if (low < 0xDC00 || low > 0xDFFF) {
            sc->why = "unpaired UTF-16 surrogate in a string";
            return false;
        }
        sc->pos += 6;
    }
    sc->pos += 6;
    return true;
}

/* On failure pos is the offending escape or control byte, or the opening quote when the string
 * does not end. */
static bool scan_string(scanner *sc)
{
    size_t start = sc->pos++;
    while (sc->pos < sc->len && sc->t[sc->pos] != '"') {
        char c = sc->t[sc->pos];
        if ((unsigned char)c < 0x20) {
            sc->why = "control character in a string (write it as an escape)";
            return false;
        }
        if (c != '\\') {
            ++sc->pos;
            continue;
        }
        char e = sc->pos + 1 < sc->len ? sc->t[sc->pos + 1] : '\0';
        if (e == 'u') {
            if (!scan_unicode_escape(sc))
                return false;
        } else if (e && strchr("\"\\/bfnrt", e)) {
            sc->pos += 2;
        } else {
            sc->why = "bad escape in a string";
            return false;
        }
    }
    if (sc->pos >= sc->len) {
        sc->pos = start;
        sc->why = "unterminated string";
        return false;
    }
    ++sc->pos;
    return true;
}

/* "[" or "{" already seen; items separated by commas up to close. */
static bool scan_container(scanner *sc, char close, bool keyed)
{
    if (++sc->depth > JSON_MAX_DEPTH) {
        sc->why = "JSON nested too deeply";
        return false;
    }
    ++sc->pos;
    scan_space(sc);
    if (scan_char(sc, close)) {
        --sc->depth;
        return true;
    }
    for (;;) {
        if (keyed) {
            scan_space(sc);
            if (sc->pos >= sc->len || sc->t[sc->pos] != '"' || !scan_string(sc))
                return false;
            scan_space(sc);
            if (!scan_char(sc, ':'))
                return false;
        }
        if (!scan_value(sc))
            return false;
        scan_space(sc);
        if (scan_char(sc, close)) {
            --sc->depth;
            return true;
        }
        if (!scan_char(sc, ','))
            return false;
    }
}

static bool scan_value(scanner *sc)
{
    scan_space(sc);
    char c = sc->pos < sc->len ? sc->t[sc->pos] : '\0';
    switch (c) {
    case '{':
        return scan_container(sc, '}', true);
    case '[':
        return scan_container(sc, ']', false);
    case '"':
        return scan_string(sc);
    case 't':
        return scan_literal(sc, "true");
    case 'f':
        return scan_literal(sc, "false");
    case 'n':
        return scan_literal(sc, "null");
    default:
        return (c == '-' || is_digit(c)) && scan_number(sc);
    }
}

/* Offset of the first invalid byte of text[0, len) and a reason (NULL: generic); false when the
 * scanner finds the text valid. */
static bool locate_syntax_error(const char *text, size_t len, size_t *pos, const char **why)
{
    scanner sc = {.t = text, .len = len};
    bool ok = scan_value(&sc);
    if (ok) {
        scan_space(&sc);
        ok = sc.pos == len;
    }
    *pos = sc.pos;
    *why = sc.why;
    return !ok;
}

pf_status pf_scene_json_check(const char *text, size_t len, const char *name, size_t *start,
                              pf_error *err)
{
    *start = 0;
    const char *nul = len ? memchr(text, '\0', len) : NULL;
    if (nul) {
        long line, col;
        line_col(text, (size_t)(nul - text), &line, &col);
        return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                            "%s:%ld:%ld: NUL byte in the text", name, line, col);
    }
    /* A UTF-8 byte-order mark is not JSON but editors write it; positions stay file-relative. */
    size_t skip = len >= 3 && !memcmp(text, "\xEF\xBB\xBF", 3) ? 3 : 0;
    if (only_whitespace(text + skip, len - skip))
        return pf_scene_json_error_at(
            text, len, len, name, "JSON syntax error: no JSON value (the empty scene is {})", err);
    size_t pos = 0;
    const char *why = NULL;
    if (locate_syntax_error(text + skip, len - skip, &pos, &why))
        return pf_scene_json_error_at(text, len, skip + pos, name, why, err);
    *start = skip;
    return PF_OK;
}
