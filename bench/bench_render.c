/* Rendering speed: frames per second against triangle count and image size.
 *
 * The scene is the default view of pf-render: a closed torus (pf_surface_make_torus, 4 r^2
 * triangles for r segments around the tube) with the shadowed ground, 4x multisampling. Each frame
 * rebuilds the triangle list from the vertex positions (what pf-render does per frame), renders and
 * reads back, and is written as a PNG (timed apart: it is CPU-bound and does not depend on
 * llvmpipe; the fastest of three writes of the last frame).
 *
 * CSV on stdout, after a comment line describing the machine:
 *   triangles,width,height,threads,frames,geometry_ms,draw_ms,png_ms,fps_draw,fps
 * fps_draw = 1000 / (geometry_ms + draw_ms), fps = 1000 / (geometry_ms + draw_ms + png_ms): what
 * pf-render delivers. threads: LP_NUM_THREADS or "auto" (one per core).
 * Usage: bench_render [--quick]   (--quick: 1k and 100k triangles at 1280x720 only) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/io.h>
#include <pf/render.h>

#include "machine.h"

typedef struct result {
    int frames;
    double geometry_ms, draw_ms, png_ms;
} result;

static int fail(const pf_error *err)
{
    fprintf(stderr, "bench_render: %s\n", err->msg);
    return 1;
}

/* Renders frames until a second has passed (at least 3, the first one, which compiles the
 * shaders, not counted). */
static int measure(const pf_surface *s, int32_t w, int32_t h, result *out)
{
    pf_error err = {0};
    pf_render_params p = pf_render_params_default();
    p.width = w;
    p.height = h;
    pf_renderer *r = NULL;
    if (pf_renderer_create(&r, &p, &err) != PF_OK)
        return fail(&err);
    pf_render_geometry g = {0};
    pf_paint paint = pf_paint_default();
    uint8_t *rgb = pf_alloc_array(3 * (size_t)w, (size_t)h);
    memset(out, 0, sizeof *out);
    pf_render_view v;
    for (int k = -1; k < 3 || out->geometry_ms + out->draw_ms < 1000; ++k) {
        double t0 = pf_time_seconds();
        pf_render_geometry_clear(&g);
        g.closed = true;
        if (pf_render_add_surface(&g, s, NULL, &paint, &err) != PF_OK)
            return fail(&err);
        double t1 = pf_time_seconds();
        if (k < 0)
            v = pf_render_view_default(g.lo, g.hi, (double)w / h);
        if (pf_renderer_draw(r, &g, &v, rgb, &err) != PF_OK)
            return fail(&err);
        double t2 = pf_time_seconds();
        if (k < 0)
            continue;
        out->frames++;
        out->geometry_ms += 1e3 * (t1 - t0);
        out->draw_ms += 1e3 * (t2 - t1);
    }
    out->png_ms = INFINITY;
    for (int k = 0; k < 3; ++k) {
        double t0 = pf_time_seconds();
        if (pf_png_write("bench_render.png", rgb, w, h, 3, &err) != PF_OK)
            return fail(&err);
        out->png_ms = fmin(out->png_ms, 1e3 * (pf_time_seconds() - t0));
    }
    remove("bench_render.png");
    out->geometry_ms /= out->frames;
    out->draw_ms /= out->frames;
    pf_free(rgb);
    pf_render_geometry_release(&g);
    pf_renderer_destroy(&r);
    return 0;
}

int main(int argc, char **argv)
{
    bool quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    static const int32_t TRIS[] = {1000, 10000, 100000, 1000000};
    static const int32_t SIZES[][2] = {{640, 360}, {1280, 720}, {1920, 1080}};
    const char *threads = getenv("LP_NUM_THREADS");
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# %s\n", machine);
    printf("triangles,width,height,threads,frames,geometry_ms,draw_ms,png_ms,fps_draw,fps\n");
    for (size_t t = 0; t < sizeof TRIS / sizeof TRIS[0]; ++t) {
        if (quick && TRIS[t] != 1000 && TRIS[t] != 100000)
            continue;
        /* 2 r segments around z, r around the tube: 4 r^2 triangles */
        int32_t res = (int32_t)lround(sqrt(TRIS[t] / 4.0));
        pf_surface s = {0};
        pf_error err = {0};
        if (pf_surface_make_torus(&s, 1, 0.35, 2 * res, res, &err) != PF_OK)
            return fail(&err);
        for (size_t k = 0; k < sizeof SIZES / sizeof SIZES[0]; ++k) {
            if (quick && SIZES[k][0] != 1280)
                continue;
            result r;
            if (measure(&s, SIZES[k][0], SIZES[k][1], &r))
                return 1;
            double frame_ms = r.geometry_ms + r.draw_ms;
            printf("%d,%d,%d,%s,%d,%.2f,%.2f,%.2f,%.2f,%.2f\n", (int)s.n_tris, (int)SIZES[k][0],
                   (int)SIZES[k][1], threads ? threads : "auto", r.frames, r.geometry_ms, r.draw_ms,
                   r.png_ms, 1e3 / frame_ms, 1e3 / (frame_ms + r.png_ms));
            fflush(stdout);
        }
        pf_surface_release(&s);
    }
    return 0;
}
