/* "Write to path.part, then rename": rename(2) replaces path atomically on POSIX file systems, so
 * a reader (ParaView watching a series, a render farm picking up frames) never sees half a file,
 * and a failed or interrupted export leaves the previous file intact. */
#include <pf/io.h>

#include <errno.h>
#include <stdbool.h>
#include <string.h>

#include <pf/base.h>

pf_status pf_atomic_file_open(pf_atomic_file *a, const char *path, pf_error *err)
{
    memset(a, 0, sizeof *a);
    size_t n = strlen(path);
    char *part = pf_alloc(n + sizeof ".part");
    PF_CHECK(part, err, PF_ERR_NOMEM, "%s: out of memory", path);
    memcpy(part, path, n);
    memcpy(part + n, ".part", sizeof ".part");
    FILE *f = fopen(part, "wb");
    if (!f) {
        pf_status s = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot create: %s",
                                   part, strerror(errno));
        pf_free(part);
        return s;
    }
    *a = (pf_atomic_file){.f = f, .path = path, .part = part};
    return PF_OK;
}

pf_status pf_atomic_file_commit(pf_atomic_file *a, const char *what, pf_error *err)
{
    /* errno of the first failing step; a stream error flag without errno set (a short fwrite
     * long ago) still reports something useful */
    char why[256] = "";
    errno = 0;
    bool ok = !ferror(a->f) && fflush(a->f) == 0;
    if (!ok)
        snprintf(why, sizeof why, "%s", errno ? strerror(errno) : "write error");
    errno = 0;
    if (fclose(a->f) != 0 && ok) {
        ok = false;
        snprintf(why, sizeof why, "%s", errno ? strerror(errno) : "close failed");
    }
    a->f = NULL;
    if (ok && rename(a->part, a->path) != 0) {
        ok = false;
        snprintf(why, sizeof why, "cannot rename %s: %s", a->part, strerror(errno));
    }
    pf_status s = PF_OK;
    if (!ok) {
        remove(a->part);
        s = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot write %s: %s", a->path,
                         what, why);
    }
    pf_free(a->part);
    memset(a, 0, sizeof *a);
    return s;
}

void pf_atomic_file_abort(pf_atomic_file *a)
{
    if (a->f) {
        fclose(a->f);
        remove(a->part);
    }
    pf_free(a->part);
    memset(a, 0, sizeof *a);
}

pf_status pf_write_file_atomic(const char *path, const void *data, size_t size, const char *what,
                               pf_error *err)
{
    pf_atomic_file a;
    PF_TRY(pf_atomic_file_open(&a, path, err));
    if (size)
        fwrite(data, 1, size, a.f); /* a short write sets the error flag commit checks */
    return pf_atomic_file_commit(&a, what, err);
}
