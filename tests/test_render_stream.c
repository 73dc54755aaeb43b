/* render_stream: the frames of a stream as images (pf_render_stream), through its hooks: one image
 * per frame in range, each on its own mesh across a mesh change, the same bytes for a range as in
 * the whole run, obstacles asked for at each frame's time, the scene hook at each SCEN, the rest
 * image of a stream without frames, and a frame naming an unknown mesh refused. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <pf/io.h>
#include <pf/render.h>

enum { W = 64, H = 48, MAX_IMAGES = 8 };

/* What the hooks saw. */
typedef struct seen {
    int images;
    uint32_t index[MAX_IMAGES];
    uint8_t *rgb[MAX_IMAGES]; /* copies, [3 W H] */
    int scenes;
    int32_t scene_mesh_nodes; /* the mesh the state held at the latest SCEN */
    int obstacle_calls;
    double last_time;
} seen;

static void on_scene(void *ctx, const pf_stream_state *st)
{
    seen *s = ctx;
    ++s->scenes;
    s->scene_mesh_nodes = st->have_mesh ? st->mesh.n_nodes : -1;
}

static pf_status add_obstacles(void *ctx, const pf_stream_state *st, double t,
                               pf_render_geometry *g, pf_error *err)
{
    (void)st, (void)g, (void)err;
    seen *s = ctx;
    ++s->obstacle_calls;
    s->last_time = t;
    return PF_OK;
}

static pf_status on_image(void *ctx, uint32_t index, const uint8_t *rgb, pf_error *err)
{
    seen *s = ctx;
    PF_CHECK(s->images < MAX_IMAGES, err, PF_ERR_INVALID, "too many images");
    s->index[s->images] = index;
    s->rgb[s->images] = malloc(3 * W * H);
    memcpy(s->rgb[s->images++], rgb, 3 * W * H);
    return PF_OK;
}

static void seen_release(seen *s)
{
    for (int k = 0; k < s->images; ++k)
        free(s->rgb[k]);
    memset(s, 0, sizeof *s);
}

/* A stream with a mesh change and a SCEN after each MESH: mesh 1 = 2 hexes, mesh 2 = 3 hexes over
 * the same box, frames 0 1 on mesh 1, 2 3 on mesh 2 (frame 3 naming last_frame_mesh). */
static FILE *mesh_stream(uint64_t last_frame_mesh, int first_mesh)
{
    pf_error err = {0};
    FILE *f = tmpfile();
    assert_non_null(f);
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "two", &err), PF_OK);
    for (int which = first_mesh; which <= 2; ++which) {
        pf_mesh m = {0};
        assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), which + 1, 1, 1, &err),
                         PF_OK);
        m.id = (uint64_t)which;
        assert_int_equal(pf_stream_write_mesh(w, &m, &err), PF_OK);
        assert_int_equal(pf_stream_write_scene(w, "{}", 2, &err), PF_OK);
        pf_frame_data fr = {0};
        assert_int_equal(pf_frame_data_alloc(&fr, m.n_nodes, &err), PF_OK);
        for (uint32_t k = 0; k < 2; ++k) {
            fr.index = 2 * (uint32_t)(which - 1) + k;
            fr.mesh_id = fr.index == 3 ? last_frame_mesh : m.id;
            fr.time = 0.25 * fr.index;
            for (int32_t i = 0; i < 3 * m.n_nodes; ++i)
                fr.u[i] = i % 3 == 2 ? -0.05 * fr.index * m.x[i - 2] : 0;
            assert_int_equal(pf_stream_write_frame(w, &fr, &err), PF_OK);
        }
        pf_frame_data_release(&fr);
        pf_mesh_release(&m);
    }
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    rewind(f);
    return f;
}

static FILE *two_mesh_stream(uint64_t last_frame_mesh)
{
    return mesh_stream(last_frame_mesh, 1);
}

/* A fixed camera (with the automatic one the framing depends on every frame of the stream). */
static const pf_camera *camera;
static const pf_camera FIXED = {{-1, -3, 2.5}, {1, 0.5, 0.3}, {0, 0, 1}, 40};

/* Renders f (survey first) for frames first..last into dir; the status of the drawing pass. */
static pf_status render(FILE *f, const char *dir, int64_t first, int64_t last, seen *s,
                        pf_error *err)
{
    pf_render_stream_params p = pf_render_stream_params_default();
    p.width = W, p.height = H, p.mode = PF_RENDER_MODE_MESH;
    p.first = first, p.last = last, p.out_dir = dir;
    if (camera)
        p.has_camera = true, p.camera = *camera;
    p.hooks = (pf_render_stream_hooks){
        .ctx = s, .on_scene = on_scene, .add_obstacles = add_obstacles, .on_image = on_image};
    pf_render_stream *rs = NULL;
    assert_int_equal(pf_render_stream_create(&rs, &p, err), PF_OK);
    rewind(f);
    pf_render_stream_survey(rs, f, "two");
    rewind(f);
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "two", err), PF_OK);
    pf_status st = PF_OK;
    for (bool end = false; st == PF_OK && !end;) {
        pf_chunk c;
        st = pf_stream_read_chunk(r, &c, &end, err);
        if (st == PF_OK && !end)
            st = pf_render_stream_take(rs, &c, err);
    }
    pf_stream_reader_destroy(&r);
    pf_error later = {0};
    pf_status fs = pf_render_stream_finish(rs, st == PF_OK, "two", st == PF_OK ? err : &later);
    assert_int_equal(pf_render_stream_written(rs), s->images);
    pf_render_stream_destroy(&rs);
    assert_null(rs);
    return st != PF_OK ? st : fs;
}

static void test_frames_on_their_meshes(void **state)
{
    (void)state;
    char dir[] = "/tmp/pf_render_stream_XXXXXX";
    assert_non_null(mkdtemp(dir));
    FILE *f = two_mesh_stream(2);
    pf_error err = {0};
    seen all = {0}, part = {0};
    assert_int_equal(render(f, dir, 0, UINT32_MAX, &all, &err), PF_OK);
    assert_int_equal(all.images, 4);
    for (int k = 0; k < 4; ++k)
        assert_int_equal(all.index[k], k);
    /* a scene hook per SCEN of the drawing pass, with the MESH before it */
    assert_int_equal(all.scenes, 2);
    assert_int_equal(all.scene_mesh_nodes, 16);
    assert_int_equal(all.obstacle_calls, 4);
    assert_true(all.last_time == 0.75);
    /* the mesh change shows: frame 2 draws three hexes, frame 1 two */
    assert_true(memcmp(all.rgb[1], all.rgb[2], 3 * W * H) != 0);
    /* a range across the change: the whole run's bytes */
    assert_int_equal(render(f, dir, 1, 2, &part, &err), PF_OK);
    assert_int_equal(part.images, 2);
    assert_int_equal(part.index[0], 1);
    assert_memory_equal(part.rgb[0], all.rgb[1], 3 * W * H);
    assert_memory_equal(part.rgb[1], all.rgb[2], 3 * W * H);
    /* frame 2 on its own mesh: through a fixed camera, after frames 0 and 1 on mesh 1, the bytes
     * of a stream holding mesh 2 and its frames only */
    camera = &FIXED;
    seen fixed = {0}, alone = {0};
    FILE *g = mesh_stream(2, 2);
    assert_int_equal(render(f, dir, 0, UINT32_MAX, &fixed, &err), PF_OK);
    assert_int_equal(render(g, dir, 2, 2, &alone, &err), PF_OK);
    camera = NULL;
    assert_int_equal(fixed.images, 4);
    assert_int_equal(alone.images, 1);
    assert_memory_equal(fixed.rgb[2], alone.rgb[0], 3 * W * H);
    seen_release(&fixed);
    seen_release(&alone);
    fclose(g);
    for (int k = 0; k < 4; ++k) {
        char path[64];
        snprintf(path, sizeof path, "%s/frame_%05d.png", dir, k);
        assert_int_equal(unlink(path), 0);
    }
    assert_int_equal(rmdir(dir), 0);
    seen_release(&all);
    seen_release(&part);
    fclose(f);
}

static void test_unknown_mesh_refused(void **state)
{
    (void)state;
    char dir[] = "/tmp/pf_render_stream_XXXXXX";
    assert_non_null(mkdtemp(dir));
    FILE *f = two_mesh_stream(7);
    pf_error err = {0};
    seen s = {0};
    assert_int_equal(render(f, dir, 0, UINT32_MAX, &s, &err), PF_ERR_FORMAT);
    if (!strstr(err.msg, "two: chunk FRAM at byte") ||
        !strstr(err.msg, "frame 3 refers to mesh 7, which no MESH chunk before it declares"))
        fail_msg("message: %s", err.msg);
    assert_int_equal(s.images, 3); /* the frames before it */
    for (int k = 0; k < 3; ++k) {
        char path[64];
        snprintf(path, sizeof path, "%s/frame_%05d.png", dir, k);
        assert_int_equal(unlink(path), 0);
    }
    assert_int_equal(rmdir(dir), 0);
    seen_release(&s);
    fclose(f);
}

static void test_rest_image(void **state)
{
    (void)state;
    char dir[] = "/tmp/pf_render_stream_XXXXXX";
    assert_non_null(mkdtemp(dir));
    pf_error err = {0};
    FILE *f = tmpfile();
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "rest", &err), PF_OK);
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(1, 1, 1), 1, 1, 1, &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(w, &m, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    seen s = {0};
    assert_int_equal(render(f, dir, 0, UINT32_MAX, &s, &err), PF_OK);
    assert_int_equal(s.images, 1);
    assert_int_equal(s.index[0], 0);
    char path[64];
    snprintf(path, sizeof path, "%s/frame_00000.png", dir);
    assert_int_equal(unlink(path), 0);
    assert_int_equal(rmdir(dir), 0);
    seen_release(&s);
    pf_mesh_release(&m);
    fclose(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frames_on_their_meshes),
        cmocka_unit_test(test_unknown_mesh_refused),
        cmocka_unit_test(test_rest_image),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
