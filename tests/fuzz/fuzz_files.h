/* Files for the fuzz targets of parsers that read paths (the importers): the input's bytes are
 * written into a private temporary directory, parsed from there, and removed. */
#ifndef PF_FUZZ_FILES_H
#define PF_FUZZ_FILES_H

/* The including file defines _POSIX_C_SOURCE 200809L (mkdtemp) before its first include. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct fuzz_dir {
    char dir[64];
    char path[4][128]; /* files written, removed by fuzz_dir_close */
    int n;
} fuzz_dir;

static inline void fuzz_require(int ok, const char *target, const char *what)
{
    if (!ok) {
        fprintf(stderr, "%s: property violated: %s\n", target, what);
        abort();
    }
}

static inline void fuzz_dir_open(fuzz_dir *d, const char *target)
{
    memset(d, 0, sizeof *d);
    snprintf(d->dir, sizeof d->dir, "/tmp/pf-fuzz-XXXXXX");
    fuzz_require(mkdtemp(d->dir) != NULL, target, "a temporary directory");
}

/* Writes bytes to DIR/name and returns its path. */
static inline const char *fuzz_dir_write(fuzz_dir *d, const char *name, const uint8_t *bytes,
                                         size_t n, const char *target)
{
    fuzz_require(d->n < 4, target, "at most 4 files");
    char *path = d->path[d->n++], dir[sizeof d->dir];
    memcpy(dir, d->dir, sizeof dir);
    snprintf(path, sizeof d->path[0], "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    fuzz_require(f != NULL && fwrite(bytes, 1, n, f) == n && fclose(f) == 0, target,
                 "the input is written to a file");
    return path;
}

static inline void fuzz_dir_close(fuzz_dir *d)
{
    for (int i = 0; i < d->n; ++i)
        unlink(d->path[i]);
    rmdir(d->dir);
}

#endif
