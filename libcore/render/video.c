/* MP4 output: raw RGB frames piped into ffmpeg (H.264, yuv420p). */
#define _POSIX_C_SOURCE 200809L /* fork, pipe, fdopen, waitpid */
#include <pf/render.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

struct pf_video {
    FILE *pipe;
    pid_t pid;
    char *path;
    size_t frame_bytes;
};

bool pf_video_available(void)
{
    const char *path = getenv("PATH");
    if (!path)
        return false;
    char buf[4096];
    for (const char *p = path;;) {
        const char *colon = strchr(p, ':');
        size_t n = colon ? (size_t)(colon - p) : strlen(p);
        if (n > 0 && n + sizeof "/ffmpeg" <= sizeof buf) {
            memcpy(buf, p, n);
            memcpy(buf + n, "/ffmpeg", sizeof "/ffmpeg");
            if (access(buf, X_OK) == 0)
                return true;
        }
        if (!colon)
            return false;
        p = colon + 1;
    }
}

pf_status pf_video_create(pf_video **v, const char *path, int32_t width, int32_t height, long fps,
                          pf_error *err)
{
    *v = NULL;
    PF_CHECK(width > 0 && height > 0 && fps > 0, err, PF_ERR_INVALID,
             "%s: bad video size %dx%d or rate %ld", path, (int)width, (int)height, fps);
    pf_video *vid = pf_calloc(1, sizeof *vid);
    char *copy = pf_alloc(strlen(path) + 1);
    if (!vid || !copy) {
        pf_free(vid);
        pf_free(copy);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    strcpy(copy, path);
    vid->path = copy;
    vid->frame_bytes = 3 * (size_t)width * (size_t)height;
    char size[32], rate[24];
    snprintf(size, sizeof size, "%dx%d", (int)width, (int)height);
    snprintf(rate, sizeof rate, "%ld", fps);
    int fd[2];
    if (pipe(fd) != 0) {
        pf_video_destroy(&vid);
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__,
                            "cannot create a pipe to ffmpeg: %s", strerror(errno));
    }
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]);
        close(fd[1]);
        pf_video_destroy(&vid);
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "cannot start ffmpeg: %s",
                            strerror(errno));
    }
    if (pid == 0) {
        dup2(fd[0], STDIN_FILENO);
        close(fd[0]);
        close(fd[1]);
        /* yuv420p needs even sizes: pad by one pixel where needed */
        char *const argv[] = {
            "ffmpeg",       "-y",       "-loglevel", "error",
            "-f",           "rawvideo", "-pix_fmt",  "rgb24",
            "-s",           size,       "-r",        rate,
            "-i",           "-",        "-vf",       "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-c:v",         "libx264",  "-pix_fmt",  "yuv420p",
            copy,           NULL};
        execvp("ffmpeg", argv);
        _exit(127);
    }
    close(fd[0]);
    vid->pid = pid;
    vid->pipe = fdopen(fd[1], "wb");
    if (!vid->pipe) {
        close(fd[1]);
        pf_error e2 = {0};
        pf_video_finish(vid, &e2);
        pf_video_destroy(&vid);
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "cannot write to ffmpeg: %s",
                            strerror(errno));
    }
    *v = vid;
    return PF_OK;
}

pf_status pf_video_write(pf_video *v, const uint8_t *rgb, pf_error *err)
{
    PF_CHECK(v->pipe && fwrite(rgb, 1, v->frame_bytes, v->pipe) == v->frame_bytes, err, PF_ERR_IO,
             "%s: cannot write to ffmpeg: %s", v->path, strerror(errno));
    return PF_OK;
}

pf_status pf_video_finish(pf_video *v, pf_error *err)
{
    if (!v->pid)
        return PF_OK;
    bool write_ok = !v->pipe || fclose(v->pipe) == 0;
    v->pipe = NULL;
    int status = 0;
    waitpid(v->pid, &status, 0);
    v->pid = 0;
    PF_CHECK(write_ok && WIFEXITED(status) && WEXITSTATUS(status) == 0, err, PF_ERR_IO,
             "%s: ffmpeg failed (exit status %d)", v->path,
             WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return PF_OK;
}

void pf_video_destroy(pf_video **v)
{
    if (!*v)
        return;
    pf_error ignored = {0};
    pf_video_finish(*v, &ignored);
    pf_free((*v)->path);
    pf_free(*v);
    *v = NULL;
}
