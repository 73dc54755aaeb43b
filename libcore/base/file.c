/* Reading a whole file into a buffer: the one way pf reads a small input file (a scene, a camera,
 * a text mesh) whole, so that every reader reports the same errors and works on pipes. */
#include <pf/base.h>

#include <errno.h>
#include <stdio.h>
#include <string.h>

enum { READ_PIECE = 64 * 1024 };

static pf_status append_stream(pf_buffer *b, FILE *f, const char *path, size_t max_bytes,
                               pf_error *err)
{
    char piece[READ_PIECE];
    size_t start = b->size;
    for (size_t n; (n = fread(piece, 1, sizeof piece, f)) > 0;) {
        PF_CHECK(n <= max_bytes && b->size - start <= max_bytes - n, err, PF_ERR_TOO_LARGE,
                 "%s: larger than %zu bytes", path, max_bytes);
        PF_TRY(pf_buffer_append(b, piece, n, err));
    }
    PF_CHECK(!ferror(f), err, PF_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
    return PF_OK;
}

pf_status pf_buffer_read_file(pf_buffer *b, const char *path, size_t max_bytes, pf_error *err)
{
    PF_CHECK(path, err, PF_ERR_INVALID, "no file name");
    FILE *f = fopen(path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    pf_status st = append_stream(b, f, path, max_bytes, err);
    fclose(f);
    if (st == PF_ERR_NOMEM)
        pf_error_prefix(err, "%s", path);
    return st;
}
