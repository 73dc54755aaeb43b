/* Files that appear whole or not at all: written to "path.part", renamed over path when complete.
 * Private to io/. */
#ifndef PF_IO_ATOMIC_FILE_H
#define PF_IO_ATOMIC_FILE_H

#include <stdio.h>

#include <pf/base.h>

typedef struct pf_atomic_file {
    FILE *f;          /* open on part, for writing (binary mode) */
    const char *path; /* borrowed: the final name */
    char *part;       /* path + ".part", owned */
} pf_atomic_file;

/* Creates (truncates) "path.part" for writing. path is borrowed until commit or abort.
 * PF_ERR_IO "PATH.part: cannot create: REASON", PF_ERR_NOMEM. a is zeroed after a failure. */
pf_status pf_atomic_file_open(pf_atomic_file *a, const char *path, pf_error *err);

/* Flushes and closes the file and renames it over path. Any failure of the writes before (the
 * stream's error flag), of the flush, the close or the rename removes the .part file and returns
 * PF_ERR_IO "PATH: cannot write WHAT: REASON" (what: "VTU file", "PNG", ...). a is zeroed. */
pf_status pf_atomic_file_commit(pf_atomic_file *a, const char *what, pf_error *err);

/* Closes and removes the .part file without touching path; safe on a zeroed a. a is zeroed. */
void pf_atomic_file_abort(pf_atomic_file *a);

#endif
