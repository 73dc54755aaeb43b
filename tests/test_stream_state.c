/* stream_state: the reader state every frame-reading tool shares (pf_stream_state): a mesh change
 * mid-stream (a new MESH with a fresh id, recomputed WGHT, frames on each mesh), and the id checks
 * of WGHT, STRS and FRAM against the latest MESH and SURF.
 *
 * Also writes the tool tests' streams:
 *   test_stream_state --write-two-meshes FILE      a 2 x 1 x 1 hex box (mesh 1, 12 nodes), then
 *       the same box with its second hex split in halves (mesh 2, 16 nodes, 3 hexes); a triangle
 *       (SURF) embedded in each (WGHT per mesh); frames 0 and 1 on mesh 1, 2 and 3 on mesh 2, each
 *       with its STRS
 *   test_stream_state --write-unknown-mesh FILE    the same with frame 3 naming mesh 9
 *   test_stream_state --write-bare FILE            the same as --write-two-meshes without SURF
 *       and WGHT (the tools then draw and export the meshes' boundaries) */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include <pf/io.h>

static void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

/* ---- the two meshes -------------------------------------------------------------------------- */

/* Mesh 1: hexes [0,1] and [1,2] along x, unit section. Mesh 2: the same with the second hex split
 * by the plane x = 1.5 (a 3-cell grid whose node columns x = 0, 1, 2, 3 move to 0, 1, 1.5, 2). */
static void make_mesh(pf_mesh *m, int which)
{
    pf_error err = {0};
    int32_t nx = which == 1 ? 2 : 3;
    assert_int_equal(pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(nx, 1, 1), nx, 1, 1, &err), PF_OK);
    if (which == 2)
        for (int32_t i = 0; i < m->n_nodes; ++i)
            if (m->x[3 * i] > 1.5)
                m->x[3 * i] = 1 + 0.5 * (m->x[3 * i] - 1);
    m->id = (uint64_t)which;
}

/* The triangle on the corners (0,0,0), (2,0,0), (2,1,1), each vertex following its node. */
static void make_embedding(const pf_mesh *m, pf_surface *s, pf_weights *w)
{
    pf_error err = {0};
    int32_t nx = m->id == 1 ? 3 : 4; /* nodes along x */
    const uint32_t corner[3] = {0, (uint32_t)(nx - 1), (uint32_t)(nx - 1 + nx + 2 * nx)};
    if (s) {
        assert_int_equal(pf_surface_alloc(s, 3, 1, &err), PF_OK);
        s->id = 5;
        for (int v = 0; v < 3; ++v) {
            memcpy(s->x + 3 * v, m->x + 3 * corner[v], 3 * sizeof(double));
            s->tri[v] = (uint32_t)v;
        }
    }
    assert_int_equal(pf_weights_alloc(w, 3, m->n_nodes, 3, &err), PF_OK);
    w->surface_id = 5;
    w->mesh_id = m->id;
    for (int v = 0; v < 3; ++v) {
        w->col[v] = corner[v];
        w->val[v] = 1;
        w->row_offsets[v + 1] = v + 1;
    }
}

/* Frame k on mesh m (sagging along x, u_z = -0.01 k x) and its von Mises stress 100 k + e. */
static void write_frame(pf_stream_writer *wr, const pf_mesh *m, uint32_t k, uint64_t id)
{
    pf_error err = {0};
    pf_frame_data fr = {0};
    pf_stress_data st = {0};
    assert_int_equal(pf_frame_data_alloc(&fr, m->n_nodes, &err), PF_OK);
    assert_int_equal(pf_stress_data_alloc(&st, m->n_elems, 1, &err), PF_OK);
    fr.mesh_id = id;
    st.mesh_id = m->id;
    fr.index = st.frame = k;
    fr.time = 0.5 * k;
    for (int32_t i = 0; i < 3 * m->n_nodes; ++i)
        fr.u[i] = i % 3 == 2 ? -0.01 * k * m->x[i - 2] : 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        st.values[e] = 100.0 * k + e;
    assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
    if (id == m->id)
        assert_int_equal(pf_stream_write_stress(wr, &st, &err), PF_OK);
    pf_stress_data_release(&st);
    pf_frame_data_release(&fr);
}

/* The two-mesh stream; bad_id: frame 3 names mesh 9; bare: no SURF and WGHT. */
static void write_stream(FILE *f, bool bad_id, bool bare)
{
    pf_error err = {0};
    pf_mesh m1 = {0}, m2 = {0};
    pf_surface s = {0};
    pf_weights w1 = {0}, w2 = {0};
    make_mesh(&m1, 1);
    make_mesh(&m2, 2);
    make_embedding(&m1, &s, &w1);
    make_embedding(&m2, NULL, &w2);
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "two meshes", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(wr, "test_stream_state", "0", "", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m1, &err), PF_OK);
    if (!bare) {
        assert_int_equal(pf_stream_write_surface(wr, &s, &err), PF_OK);
        assert_int_equal(pf_stream_write_weights(wr, &w1, &err), PF_OK);
    }
    write_frame(wr, &m1, 0, 1);
    write_frame(wr, &m1, 1, 1);
    /* the change: a new MESH and recomputed WGHT before the first frame on it */
    assert_int_equal(pf_stream_write_mesh(wr, &m2, &err), PF_OK);
    if (!bare)
        assert_int_equal(pf_stream_write_weights(wr, &w2, &err), PF_OK);
    write_frame(wr, &m2, 2, 2);
    write_frame(wr, &m2, 3, bad_id ? 9 : 2);
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_weights_release(&w1);
    pf_weights_release(&w2);
    pf_surface_release(&s);
    pf_mesh_release(&m1);
    pf_mesh_release(&m2);
}

static void write_two_meshes(FILE *f, bool bad_id)
{
    write_stream(f, bad_id, false);
}

/* Feeds every chunk of f to s (frames checked by their header alone when skip); the first
 * failure's status. */
static pf_status feed(FILE *f, pf_stream_state *s, bool skip, pf_error *err)
{
    rewind(f);
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "in.pfs", err), PF_OK);
    pf_status st = PF_OK;
    for (;;) {
        pf_chunk c;
        bool end = false;
        st = pf_stream_read_chunk(r, &c, &end, err);
        if (st < 0 || end)
            break;
        if (skip && strcmp(c.tag, "FRAM") == 0) {
            uint32_t index;
            st = pf_stream_state_skip_frame(s, &c, &index, err);
        } else {
            st = pf_stream_state_take(s, &c, err);
        }
        if (st < 0)
            break;
    }
    pf_stream_reader_destroy(&r);
    return st;
}

/* ---- tests ----------------------------------------------------------------------------------- */

static void check_two_meshes(bool skip)
{
    FILE *f = tmpfile();
    assert_non_null(f);
    write_two_meshes(f, false);
    pf_stream_state s = {0};
    pf_error err = {0};
    assert_int_equal(feed(f, &s, skip, &err), PF_OK);
    /* the latest of everything: mesh 2 and its weights, the last STRS */
    assert_true(s.have_mesh && s.have_surface && s.have_weights && s.have_stress);
    assert_int_equal(s.mesh.id, 2);
    assert_int_equal(s.mesh.n_nodes, 16);
    assert_int_equal(s.weights.mesh_id, 2);
    assert_int_equal(s.weights.col[2], 15);
    assert_int_equal(s.stress.frame, 3);
    assert_int_equal(s.mesh_serial, 2);
    assert_int_equal(s.surface_serial, 1);
    /* each mesh and the frames on it */
    assert_int_equal(s.n_meshes, 2);
    assert_int_equal(s.n_frames, 4);
    const pf_stream_mesh_use *u1 = pf_stream_state_find_mesh(&s, 1);
    const pf_stream_mesh_use *u2 = pf_stream_state_find_mesh(&s, 2);
    assert_non_null(u1);
    assert_non_null(u2);
    assert_null(pf_stream_state_find_mesh(&s, 9));
    assert_int_equal(u1->n_nodes, 12);
    assert_int_equal(u1->n_elems, 2);
    assert_int_equal(u1->n_frames, 2);
    assert_int_equal(u1->first_frame, 0);
    assert_int_equal(u1->last_frame, 1);
    assert_int_equal(u2->n_nodes, 16);
    assert_int_equal(u2->n_elems, 3);
    assert_int_equal(u2->n_frames, 2);
    assert_int_equal(u2->first_frame, 2);
    assert_int_equal(u2->last_frame, 3);
    assert_true(u1->offset < u2->offset);
    pf_stream_state_release(&s);
    assert_null(s.meshes);
    fclose(f);
}

static void test_two_meshes(void **state)
{
    (void)state;
    check_two_meshes(false);
}

static void test_two_meshes_skipped_frames(void **state)
{
    (void)state;
    check_two_meshes(true);
}

static void test_unknown_mesh(void **state)
{
    (void)state;
    for (int skip = 0; skip < 2; ++skip) {
        FILE *f = tmpfile();
        assert_non_null(f);
        write_two_meshes(f, true);
        pf_stream_state s = {0};
        pf_error err = {0};
        assert_int_equal(feed(f, &s, skip, &err), PF_ERR_FORMAT);
        expect_msg(&err, "in.pfs: chunk FRAM at byte ");
        expect_msg(&err, "frame 3 refers to mesh 9, which no MESH chunk before it declares");
        assert_int_equal(s.n_frames, 3); /* the frames before it were taken */
        pf_stream_state_release(&s);
        fclose(f);
    }
}

/* Writes chunks by hand: mesh 1, mesh 2, then the chunk under test. */
static void test_stale_references(void **state)
{
    (void)state;
    pf_mesh m1 = {0}, m2 = {0};
    pf_surface sf = {0};
    pf_weights w1 = {0};
    make_mesh(&m1, 1);
    make_mesh(&m2, 2);
    make_embedding(&m1, &sf, &w1);
    for (int what = 0; what < 4; ++what) {
        FILE *f = tmpfile();
        pf_error err = {0};
        pf_stream_writer *wr = NULL;
        assert_int_equal(pf_stream_writer_create(&wr, f, "x", &err), PF_OK);
        assert_int_equal(pf_stream_write_mesh(wr, &m1, &err), PF_OK);
        assert_int_equal(pf_stream_write_surface(wr, &sf, &err), PF_OK);
        assert_int_equal(pf_stream_write_weights(wr, &w1, &err), PF_OK);
        assert_int_equal(pf_stream_write_mesh(wr, &m2, &err), PF_OK);
        if (what == 0) /* a frame of the replaced mesh */
            write_frame(wr, &m1, 0, 1);
        else if (what == 1) /* weights for the replaced mesh */
            assert_int_equal(pf_stream_write_weights(wr, &w1, &err), PF_OK);
        else if (what == 2) { /* the right id with the old node count */
            pf_mesh fake = m1;
            fake.id = 2;
            write_frame(wr, &fake, 0, 2);
        } else { /* stress of the replaced mesh */
            pf_stress_data st = {0};
            assert_int_equal(pf_stress_data_alloc(&st, m1.n_elems, 1, &err), PF_OK);
            st.mesh_id = 1;
            for (int32_t e = 0; e < m1.n_elems; ++e)
                st.values[e] = 1;
            assert_int_equal(pf_stream_write_stress(wr, &st, &err), PF_OK);
            pf_stress_data_release(&st);
        }
        assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
        pf_stream_writer_destroy(&wr);
        pf_stream_state s = {0};
        assert_int_equal(feed(f, &s, false, &err), PF_ERR_FORMAT);
        static const char *const NEEDLE[4] = {
            "chunk FRAM at byte", "chunk WGHT at byte", "chunk FRAM at byte", "chunk STRS at byte"};
        expect_msg(&err, NEEDLE[what]);
        static const char *const WHY[4] = {
            "frame 0 refers to mesh 1 (MESH at byte 8), which a later MESH replaced",
            "weights for mesh 1 with 12 nodes, but the latest MESH is mesh 2 with 16 nodes",
            "frame 0 has 12 nodes, but its MESH",
            "stress of frame 0 for mesh 1 with 2 elements, but the latest MESH is mesh 2"};
        expect_msg(&err, WHY[what]);
        /* the new MESH dropped the weights of the old one */
        assert_false(s.have_weights);
        assert_int_equal(s.mesh.id, 2);
        pf_stream_state_release(&s);
        fclose(f);
    }
    pf_weights_release(&w1);
    pf_surface_release(&sf);
    pf_mesh_release(&m1);
    pf_mesh_release(&m2);
}

static void test_weights_need_surface(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_weights w = {0};
    make_mesh(&m, 1);
    make_embedding(&m, NULL, &w);
    FILE *f = tmpfile();
    pf_error err = {0};
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "x", &err), PF_OK);
    assert_int_equal(pf_stream_write_scene(wr, "{}", 2, &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(wr, &m, &err), PF_OK);
    assert_int_equal(pf_stream_write_weights(wr, &w, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    pf_stream_state s = {0};
    assert_int_equal(feed(f, &s, false, &err), PF_ERR_FORMAT);
    expect_msg(&err, "chunk WGHT at byte");
    expect_msg(&err, "weights for surface 5 with 3 vertices, but the latest SURF is missing");
    assert_true(s.have_scene);
    assert_string_equal(s.scene_json, "{}");
    assert_int_equal(s.scene_serial, 1);
    pf_stream_state_release(&s);
    fclose(f);
    pf_weights_release(&w);
    pf_mesh_release(&m);
}

static int write_file(const char *path, bool bad_id, bool bare)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 1;
    write_stream(f, bad_id, bare);
    return fclose(f) == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-two-meshes") == 0)
        return write_file(argv[2], false, false);
    if (argc == 3 && strcmp(argv[1], "--write-unknown-mesh") == 0)
        return write_file(argv[2], true, false);
    if (argc == 3 && strcmp(argv[1], "--write-bare") == 0)
        return write_file(argv[2], false, true);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_meshes),
        cmocka_unit_test(test_two_meshes_skipped_frames),
        cmocka_unit_test(test_unknown_mesh),
        cmocka_unit_test(test_stale_references),
        cmocka_unit_test(test_weights_need_surface),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
