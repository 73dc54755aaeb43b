/* Runs the fuzz target once on every file named on the command line, and on every regular file in
 * every directory named: the seed corpus as a regression test, without libFuzzer. Exit 0 when all
 * inputs ran (a violated property aborts), 1 when an input cannot be read or there is none. */
#define _POSIX_C_SOURCE 200809L /* opendir, stat */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include <pf/base.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return 0;
    }
    pf_buffer b = {0};
    pf_error err = {0};
    unsigned char piece[4096];
    int ok = 1;
    for (size_t n; ok && (n = fread(piece, 1, sizeof piece, f)) > 0;)
        ok = pf_buffer_append(&b, piece, n, &err) == PF_OK;
    ok = ok && !ferror(f);
    fclose(f);
    if (ok)
        LLVMFuzzerTestOneInput(b.data, b.size);
    else
        fprintf(stderr, "replay: cannot read %s\n", path);
    pf_buffer_release(&b);
    return ok;
}

/* Inputs run from path; -1 on a read failure. */
static long run_path(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        fprintf(stderr, "replay: no such file or directory: %s\n", path);
        return -1;
    }
    if (!S_ISDIR(st.st_mode))
        return run_file(path) ? 1 : -1;
    DIR *dir = opendir(path);
    if (!dir)
        return -1;
    long count = 0;
    for (struct dirent *e; count >= 0 && (e = readdir(dir)) != NULL;) {
        char child[4096];
        if (e->d_name[0] == '.' ||
            snprintf(child, sizeof child, "%s/%s", path, e->d_name) >= (int)sizeof child)
            continue;
        if (stat(child, &st) == 0 && S_ISREG(st.st_mode))
            count = run_file(child) ? count + 1 : -1;
    }
    closedir(dir);
    return count;
}

int main(int argc, char **argv)
{
    long total = 0;
    for (int i = 1; i < argc; ++i) {
        long n = run_path(argv[i]);
        if (n < 0)
            return 1;
        total += n;
    }
    printf("replay: %ld inputs ran\n", total);
    return total > 0 ? 0 : 1;
}
