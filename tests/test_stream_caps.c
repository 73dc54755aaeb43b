/* stream_caps: what a cut leaves in a pf stream. The SURF chunk's triangle parts (version 2,
 * written only for a surface with caps; version 1 byte for byte otherwise), its damaged forms,
 * and a stream whose MESH, SURF and WGHT all change between frames (a bar of two hexes, then the
 * two boxes the cut between them makes, the new surface capped where they separated): the reader
 * state keeps every frame on the surface and weights in force at it, and refuses weights of
 * another mesh or surface. The drawing of caps (own colour, flat, not bending the model's normals)
 * and their export (OBJ groups, PLY face property) are checked on the same surface.
 *
 * Also writes the tool tests' streams and reads their images:
 *   test_stream_caps --write-cut FILE        the cut stream: mesh 1 (the bar, 12 nodes) with
 *       surface 1 (its 8 corners, 12 triangles), frames 0 and 1; mesh 2 (two boxes, 16 nodes) with
 *       surface 2 (two closed boxes, 24 triangles, 4 of them caps at x = 1), frames 2 and 3 in
 *       which the second box rises; a STRS after every frame
 *   test_stream_caps --write-cut-bare FILE   the same without SURF and WGHT
 *   test_stream_caps --count-near PNG RRGGBB the pixels of PNG whose linear chromaticity is
 *       within 0.04 of the sRGB colour's, and not darker than 2 % (printed) */
#define _POSIX_C_SOURCE 200809L /* mkstemp, fdopen */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/cut.h>
#include <pf/io.h>
#include <pf/render.h>

static void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

/* ---- the cut bar ----------------------------------------------------------------------------- */

/* The corners of the box [x0, x1] x [0, 1] x [0, 1] in hex order (bottom 0-1-2-3, top 4-7). */
static void box_corners(double x0, double x1, double *x)
{
    static const int CX[8] = {0, 1, 1, 0, 0, 1, 1, 0}, CY[8] = {0, 0, 1, 1, 0, 0, 1, 1};
    for (int k = 0; k < 8; ++k) {
        x[3 * k] = CX[k] ? x1 : x0;
        x[3 * k + 1] = CY[k];
        x[3 * k + 2] = k >= 4;
    }
}

/* The 12 outward triangles of a box on corners base + 0..7; the last two are the face x = x1
 * (right), the two before them x = x0 (left). */
static const uint32_t BOX_TRIS[36] = {0, 3, 2, 0, 2, 1, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                      3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};

/* Mesh 1: the bar [0, 2] as two hexes sharing the face x = 1 (12 nodes). Mesh 2: the two boxes a
 * cut along that face makes: the same hexes on 16 nodes, the face x = 1 twice (one per box). */
static void make_mesh(pf_mesh *m, int which)
{
    pf_error err = {0};
    double x[48];
    box_corners(0, 1, x);
    box_corners(1, 2, x + 24);
    if (which == 1) {
        /* nodes 8..11: the corners x = 2 of the second box; its x = 1 corners are 1, 2, 5, 6 */
        const double far[12] = {2, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1};
        memcpy(x + 24, far, sizeof far);
        const uint32_t hexes[16] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 8, 9, 2, 5, 10, 11, 6};
        assert_int_equal(pf_mesh_from_hexes(m, x, 12, hexes, 2, &err), PF_OK);
    } else {
        const uint32_t hexes[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
        assert_int_equal(pf_mesh_from_hexes(m, x, 16, hexes, 2, &err), PF_OK);
    }
    m->id = (uint64_t)which;
}

/* Surface 1: the bar's 8 corners, embedded in mesh 1. Surface 2: each box closed, its face on the
 * cut as caps, embedded in mesh 2 (vertex i on node i). */
static void make_surface(const pf_mesh *m, pf_surface *s, pf_weights *w)
{
    pf_error err = {0};
    int which = (int)m->id, boxes = which == 1 ? 1 : 2;
    assert_int_equal(pf_surface_alloc(s, 8 * boxes, 12 * boxes, &err), PF_OK);
    s->id = (uint64_t)which;
    if (which == 1) {
        box_corners(0, 2, s->x);
    } else {
        box_corners(0, 1, s->x);
        box_corners(1, 2, s->x + 24);
        s->tri_part = pf_calloc(24, 1);
        assert_non_null(s->tri_part);
        s->tri_part[10] = s->tri_part[11] = PF_SURFACE_CAP; /* the first box's x = 1 */
        s->tri_part[20] = s->tri_part[21] = PF_SURFACE_CAP; /* the second box's x = 1 */
    }
    for (int b = 0; b < boxes; ++b)
        for (int k = 0; k < 36; ++k)
            s->tri[36 * b + k] = BOX_TRIS[k] + 8 * (uint32_t)b;
    const uint32_t node1[8] = {0, 8, 9, 3, 4, 10, 11, 7}; /* surface 1's corners in mesh 1 */
    assert_int_equal(pf_weights_alloc(w, s->n_verts, m->n_nodes, s->n_verts, &err), PF_OK);
    w->surface_id = s->id;
    w->mesh_id = m->id;
    for (int v = 0; v < s->n_verts; ++v) {
        w->col[v] = which == 1 ? node1[v] : (uint32_t)v;
        w->val[v] = 1;
        w->row_offsets[v + 1] = v + 1;
    }
}

/* Frame k: on mesh 1 a sag u_z = -0.01 k x; on mesh 2 the second box (nodes 8..15) rises by
 * 0.8 (k - 1) and moves 0.2 (k - 1) along x. STRS 100 k + e. */
static void write_frame(pf_stream_writer *wr, const pf_mesh *m, uint32_t k)
{
    pf_error err = {0};
    pf_frame_data fr = {0};
    pf_stress_data st = {0};
    assert_int_equal(pf_frame_data_alloc(&fr, m->n_nodes, &err), PF_OK);
    assert_int_equal(pf_stress_data_alloc(&st, m->n_elems, 1, &err), PF_OK);
    fr.mesh_id = st.mesh_id = m->id;
    fr.index = st.frame = k;
    fr.time = 0.25 * k;
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        double *u = fr.u + 3 * i;
        u[0] = u[1] = u[2] = 0;
        if (m->id == 1)
            u[2] = -0.01 * k * m->x[3 * i];
        else if (i >= 8)
            u[0] = 0.2 * (k - 1), u[2] = 0.8 * (k - 1);
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        st.values[e] = 100.0 * k + e;
    assert_int_equal(pf_stream_write_frame(wr, &fr, &err), PF_OK);
    assert_int_equal(pf_stream_write_stress(wr, &st, &err), PF_OK);
    pf_stress_data_release(&st);
    pf_frame_data_release(&fr);
}

typedef struct cut_bar {
    pf_mesh m[2];
    pf_surface s[2];
    pf_weights w[2];
} cut_bar;

static void cut_bar_make(cut_bar *b)
{
    memset(b, 0, sizeof *b);
    for (int k = 0; k < 2; ++k) {
        make_mesh(&b->m[k], k + 1);
        make_surface(&b->m[k], &b->s[k], &b->w[k]);
    }
}

static void cut_bar_release(cut_bar *b)
{
    for (int k = 0; k < 2; ++k) {
        pf_mesh_release(&b->m[k]);
        pf_surface_release(&b->s[k]);
        pf_weights_release(&b->w[k]);
    }
}

/* The cut stream: MESH SURF WGHT, frames 0 1, then MESH SURF WGHT, frames 2 3 (bare: no SURF and
 * WGHT). */
static void write_cut(FILE *f, bool bare)
{
    pf_error err = {0};
    cut_bar b;
    cut_bar_make(&b);
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "cut", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(wr, "test_stream_caps", "0", "", &err), PF_OK);
    for (int k = 0; k < 2; ++k) {
        assert_int_equal(pf_stream_write_mesh(wr, &b.m[k], &err), PF_OK);
        if (!bare) {
            assert_int_equal(pf_stream_write_surface(wr, &b.s[k], &err), PF_OK);
            assert_int_equal(pf_stream_write_weights(wr, &b.w[k], &err), PF_OK);
        }
        write_frame(wr, &b.m[k], (uint32_t)(2 * k));
        write_frame(wr, &b.m[k], (uint32_t)(2 * k + 1));
    }
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    cut_bar_release(&b);
}

/* A chunk made by hand around a payload. */
static pf_chunk hand_chunk(const char *tag, uint32_t version, pf_buffer *payload)
{
    pf_chunk c = {
        .version = version, .size = payload->size, .payload = payload->data, .offset = 40};
    memcpy(c.tag, tag, 5);
    return c;
}

/* ---- SURF version 2 -------------------------------------------------------------------------- */

static void test_caps_round_trip(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    const pf_surface *s = &b.s[1];
    assert_int_equal(pf_surface_count_caps(s), 4);
    assert_int_equal(pf_stream_surface_version(s), 2);
    pf_buffer buf = {0};
    assert_int_equal(pf_stream_encode_surface(s, &buf, &err), PF_OK);
    /* version 1's layout, then one byte per triangle */
    assert_int_equal(buf.size, 16 + 24 * 16 + 13 * 24);
    assert_memory_equal(buf.data + 16 + 24 * 16 + 12 * 24, s->tri_part, 24);
    pf_chunk c = hand_chunk("SURF", 2, &buf);
    pf_surface d = {0};
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_OK);
    assert_int_equal(d.id, 2);
    assert_int_equal(d.n_tris, 24);
    assert_non_null(d.tri_part);
    assert_memory_equal(d.tri_part, s->tri_part, 24);
    assert_memory_equal(d.tri, s->tri, sizeof(uint32_t) * 72);
    assert_memory_equal(d.x, s->x, sizeof(double) * 48);
    pf_surface_release(&d);
    /* through a writer and a reader: the chunk says version 2 */
    FILE *f = tmpfile();
    pf_stream_writer *wr = NULL;
    assert_int_equal(pf_stream_writer_create(&wr, f, "t", &err), PF_OK);
    assert_int_equal(pf_stream_write_surface(wr, s, &err), PF_OK);
    assert_int_equal(pf_stream_write_surface(wr, &b.s[0], &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
    pf_stream_writer_destroy(&wr);
    rewind(f);
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "t", &err), PF_OK);
    bool end = false;
    for (uint32_t want = 2; want >= 1; --want) {
        assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
        assert_int_equal(c.version, want);
        assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_OK);
        assert_int_equal(pf_surface_count_caps(&d), want == 2 ? 4 : 0);
        assert_true((d.tri_part != NULL) == (want == 2));
        pf_surface_release(&d);
    }
    pf_stream_reader_destroy(&r);
    fclose(f);
    pf_buffer_release(&buf);
    cut_bar_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A surface without caps (parts NULL or all the model's) is written as before: SURF version 1,
 * the same bytes. */
static void test_no_caps_is_version_1(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    pf_surface *s = &b.s[1];
    pf_buffer with = {0}, without = {0};
    memset(s->tri_part, PF_SURFACE_MODEL, 24);
    assert_int_equal(pf_stream_surface_version(s), 1);
    assert_int_equal(pf_stream_encode_surface(s, &with, &err), PF_OK);
    PF_FREE(s->tri_part);
    assert_int_equal(pf_stream_surface_version(s), 1);
    assert_int_equal(pf_stream_encode_surface(s, &without, &err), PF_OK);
    assert_int_equal(with.size, 16 + 24 * 16 + 12 * 24);
    assert_int_equal(with.size, without.size);
    assert_memory_equal(with.data, without.data, with.size);
    pf_chunk c = hand_chunk("SURF", 1, &with);
    pf_surface d = {0};
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_OK);
    assert_null(d.tri_part);
    pf_surface_release(&d);
    /* a version 2 chunk without caps (not what pf writes) reads, its parts kept */
    unsigned char zeros[24] = {0};
    assert_int_equal(pf_buffer_append(&with, zeros, 24, &err), PF_OK);
    c = hand_chunk("SURF", 2, &with);
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_OK);
    assert_non_null(d.tri_part);
    assert_int_equal(pf_surface_count_caps(&d), 0);
    pf_surface_release(&d);
    pf_buffer_release(&with);
    pf_buffer_release(&without);
    cut_bar_release(&b);
}

static void test_caps_damaged(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    pf_buffer buf = {0};
    assert_int_equal(pf_stream_encode_surface(&b.s[1], &buf, &err), PF_OK);
    pf_surface d = {0};
    /* truncated: a part missing */
    buf.size -= 1;
    pf_chunk c = hand_chunk("SURF", 2, &buf);
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_ERR_FORMAT);
    expect_msg(&err, "chunk SURF at byte 40: payload of 711 bytes too short for 24 triangle parts");
    assert_null(d.tri_part);
    /* the parts of version 2 in a version 1 chunk: trailing bytes */
    buf.size += 1;
    c = hand_chunk("SURF", 1, &buf);
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_ERR_FORMAT);
    expect_msg(&err, "chunk SURF at byte 40: 24 trailing bytes after the last field");
    /* a part that is neither */
    buf.data[buf.size - 24 + 5] = 7;
    c = hand_chunk("SURF", 2, &buf);
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_ERR_FORMAT);
    expect_msg(&err, "chunk SURF at byte 40: triangle 5 has part 7 (0: model, 1: cap)");
    /* a version from the future */
    c = hand_chunk("SURF", 3, &buf);
    assert_int_equal(pf_stream_decode_surface(&c, &d, &err), PF_ERR_UNSUPPORTED);
    expect_msg(&err, "chunk SURF at byte 40: version 3 not supported (this pf reads 1 to 2)");
    assert_true(pf_stream_version_is_read("SURF", 1) && pf_stream_version_is_read("SURF", 2));
    assert_false(pf_stream_version_is_read("SURF", 0) || pf_stream_version_is_read("MESH", 2));
    /* the encoder refuses what the decoder would */
    b.s[1].tri_part[3] = 9;
    buf.size = 0;
    assert_int_equal(pf_stream_encode_surface(&b.s[1], &buf, &err), PF_ERR_INVALID);
    expect_msg(&err, "surface 2: triangle 3 has part 9");
    pf_buffer_release(&buf);
    cut_bar_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- the reader state through a cut ---------------------------------------------------------- */

/* What the state held at one frame. */
typedef struct seen {
    uint32_t index;
    uint64_t mesh, surface;
    bool weights;
    int32_t caps;
} seen;

/* Feeds f to s (frames by header alone when skip), recording each frame's picture. */
static pf_status feed(FILE *f, pf_stream_state *s, bool skip, seen *out, int *n, pf_error *err)
{
    rewind(f);
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "cut.pfs", err), PF_OK);
    pf_status st = PF_OK;
    *n = 0;
    for (bool end = false; st == PF_OK && !end;) {
        pf_chunk c;
        st = pf_stream_read_chunk(r, &c, &end, err);
        if (st != PF_OK || end)
            break;
        uint32_t index = 0;
        if (skip && strcmp(c.tag, "FRAM") == 0)
            st = pf_stream_state_skip_frame(s, &c, &index, err);
        else
            st = pf_stream_state_take(s, &c, err);
        if (st == PF_OK && strcmp(c.tag, "FRAM") == 0)
            out[(*n)++] = (seen){index, s->mesh.id, s->surface.id, s->have_weights,
                                 pf_surface_count_caps(&s->surface)};
    }
    pf_stream_reader_destroy(&r);
    return st;
}

static void check_cut_stream(bool skip)
{
    FILE *f = tmpfile();
    write_cut(f, false);
    pf_stream_state s = {0};
    pf_error err = {0};
    seen at[8];
    int n = 0;
    assert_int_equal(feed(f, &s, skip, at, &n, &err), PF_OK);
    assert_int_equal(n, 4);
    for (int k = 0; k < 4; ++k) {
        assert_int_equal(at[k].mesh, k < 2 ? 1 : 2);
        assert_int_equal(at[k].surface, k < 2 ? 1 : 2);
        assert_true(at[k].weights);
        assert_int_equal(at[k].caps, k < 2 ? 0 : 4);
    }
    /* every surface with its caps and the frames drawn on it */
    assert_int_equal(s.n_surfaces, 2);
    assert_int_equal(s.surface_serial, 2);
    const pf_stream_surface_use *u = s.surfaces;
    assert_int_equal(u[0].id, 1);
    assert_int_equal(u[0].version, 1);
    assert_int_equal(u[0].n_tris, 12);
    assert_int_equal(u[0].n_caps, 0);
    assert_int_equal(u[0].n_frames, 2);
    assert_int_equal(u[0].first_frame, 0);
    assert_int_equal(u[0].last_frame, 1);
    assert_int_equal(u[1].id, 2);
    assert_int_equal(u[1].version, 2);
    assert_int_equal(u[1].n_verts, 16);
    assert_int_equal(u[1].n_caps, 4);
    assert_int_equal(u[1].n_frames, 2);
    assert_int_equal(u[1].first_frame, 2);
    assert_int_equal(u[1].last_frame, 3);
    assert_true(u[0].offset < s.meshes[1].offset && s.meshes[1].offset < u[1].offset);
    assert_int_equal(s.n_meshes, 2);
    assert_int_equal(s.meshes[1].n_frames, 2);
    pf_stream_state_release(&s);
    assert_null(s.surfaces);
    fclose(f);
}

static void test_cut_stream(void **state)
{
    (void)state;
    check_cut_stream(false);
    check_cut_stream(true);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Weights must name the latest MESH and SURF: after the cut's MESH and SURF, the old surface's
 * weights, or the new surface's on the old mesh, are refused naming the chunk. A frame before the
 * new weights is on the new mesh without a surface (drawn as the mesh boundary). */
static void test_cut_stale_weights(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_weights stale = {0};
    pf_error err = {0};
    /* the new surface's weights on the old mesh */
    assert_int_equal(pf_weights_alloc(&stale, 16, 12, 0, &err), PF_OK);
    memset(stale.row_offsets, 0, 17 * sizeof *stale.row_offsets);
    stale.surface_id = 2;
    stale.mesh_id = 1;
    for (int what = 0; what < 3; ++what) {
        FILE *f = tmpfile();
        pf_stream_writer *wr = NULL;
        assert_int_equal(pf_stream_writer_create(&wr, f, "t", &err), PF_OK);
        assert_int_equal(pf_stream_write_mesh(wr, &b.m[0], &err), PF_OK);
        assert_int_equal(pf_stream_write_surface(wr, &b.s[0], &err), PF_OK);
        assert_int_equal(pf_stream_write_weights(wr, &b.w[0], &err), PF_OK);
        write_frame(wr, &b.m[0], 0);
        assert_int_equal(pf_stream_write_mesh(wr, &b.m[1], &err), PF_OK);
        assert_int_equal(pf_stream_write_surface(wr, &b.s[1], &err), PF_OK);
        if (what == 0)
            assert_int_equal(pf_stream_write_weights(wr, &b.w[0], &err), PF_OK);
        else if (what == 1)
            assert_int_equal(pf_stream_write_weights(wr, &stale, &err), PF_OK);
        write_frame(wr, &b.m[1], 1);
        assert_int_equal(pf_stream_writer_finish(wr, &err), PF_OK);
        pf_stream_writer_destroy(&wr);
        pf_stream_state s = {0};
        seen at[4];
        int n = 0;
        pf_status st = feed(f, &s, false, at, &n, &err);
        if (what == 2) { /* no weights yet: the frame is on mesh 2, the surface not drawn */
            assert_int_equal(st, PF_OK);
            assert_int_equal(n, 2);
            assert_false(at[1].weights);
            assert_int_equal(s.surfaces[1].n_frames, 0);
        } else {
            assert_int_equal(st, PF_ERR_FORMAT);
            expect_msg(&err, "cut.pfs: chunk WGHT at byte");
            expect_msg(&err, what == 0 ? "weights for surface 1 with 8 vertices, but the latest "
                                         "SURF is another"
                                       : "weights for mesh 1 with 12 nodes, but the latest MESH "
                                         "is mesh 2 with 16 nodes");
            assert_int_equal(n, 1);
            assert_int_equal(s.surface.id, 2);
            assert_false(s.have_weights);
        }
        pf_stream_state_release(&s);
        fclose(f);
    }
    pf_weights_release(&stale);
    cut_bar_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- drawing and export of caps -------------------------------------------------------------- */

/* Caps on vertices of their own, flat and in the cap colour; the model's normals only from the
 * model's triangles. */
static void test_draw_caps(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    pf_render_geometry g = {0};
    pf_paint p = pf_paint_default();
    const pf_surface *s = &b.s[1];
    assert_int_equal(pf_render_add_surface(&g, s, NULL, &p, &err), PF_OK);
    assert_int_equal(g.n_tris, 24);
    assert_int_equal(g.n_verts, 16 + 3 * 4);
    int caps = 0;
    for (int64_t t = 0; t < g.n_tris; ++t) {
        const pf_render_vertex *v = &g.verts[g.tri[3 * t]];
        bool cap = s->tri_part[t] == PF_SURFACE_CAP;
        assert_memory_equal(v->color, cap ? p.cap_rgb : p.rgb, sizeof v->color);
        if (cap) { /* flat: +x for the first box's cap, -x for the second's */
            ++caps;
            for (int k = 0; k < 3; ++k) {
                const pf_render_vertex *w = &g.verts[g.tri[3 * t + k]];
                assert_true(g.tri[3 * t + k] >= 16);
                assert_float_equal(w->normal[0], t < 12 ? 1 : -1, 1e-7);
                assert_float_equal(w->normal[1], 0, 1e-7);
                assert_float_equal(w->normal[2], 0, 1e-7);
            }
        }
    }
    assert_int_equal(caps, 4);
    /* vertex 1, (1, 0, 0), of the first box: its model triangles (bottom and front) sum to
     * (0, -1, -1) / 2; its caps would have added +x */
    assert_float_equal(g.verts[1].normal[0], 0, 1e-7);
    /* the cap colour is not the model's */
    assert_true(fabsf(p.cap_rgb[0] - p.rgb[0]) + fabsf(p.cap_rgb[1] - p.rgb[1]) > 0.2f);
    pf_render_geometry_release(&g);
    /* exports: the parts normals agree (model first), the PLY carries a face property */
    double n[48];
    assert_int_equal(pf_surface_part_normals(s, NULL, n, &err), PF_OK);
    assert_float_equal(n[3], 0, 1e-15);
    pf_surface plain = b.s[0];
    double n1[24], n2[24];
    pf_surface_vertex_normals(&plain, NULL, n1);
    assert_int_equal(pf_surface_part_normals(&plain, NULL, n2, &err), PF_OK);
    assert_memory_equal(n1, n2, sizeof n1);
    cut_bar_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Without an embedded surface the cut shows in the mesh boundary: the two boxes have 12 boundary
 * faces (the bar 10), the two on the cut opposite to each other. The same for the bar cut by
 * pf_mesh_cut along that face (its cut_face marks them). */
static void test_cut_faces_in_boundary(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    pf_mesh cut = {0};
    pf_cut_result res;
    pf_cut_request req[2];
    for (int e = 0; e < 2; ++e)
        req[e] = (pf_cut_request){e, {pf_v3(1, 0, 0), 1}}; /* the plane x = 1 */
    assert_int_equal(pf_mesh_derive(&b.m[0], &err), PF_OK);
    assert_int_equal(pf_mesh_cut(&b.m[0], req, 2, NULL, &cut, &res, &err), PF_OK);
    assert_int_equal(res.n_bodies, 2);
    const pf_mesh *meshes[3] = {&b.m[0], &b.m[1], &cut};
    for (int k = 0; k < 3; ++k) {
        pf_boundary bd = {0};
        assert_int_equal(pf_boundary_extract(meshes[k], &bd, &err), PF_OK);
        assert_int_equal(bd.n_faces, k ? 12 : 10);
        int marked = 0;
        for (int32_t i = 0; k == 2 && i < bd.n_faces; ++i)
            marked += res.cut_face[bd.face[i]];
        assert_int_equal(marked, k == 2 ? 2 : 0);
        int on_cut = 0;
        for (int32_t i = 0; i < bd.n_faces; ++i) {
            bool all = true;
            for (int64_t t = bd.tri_offsets[i]; t < bd.tri_offsets[i + 1]; ++t)
                for (int c = 0; c < 3; ++c)
                    all = all && meshes[k]->x[3 * bd.tri[3 * t + c]] == 1;
            on_cut += all;
        }
        assert_int_equal(on_cut, k ? 2 : 0);
        pf_boundary_release(&bd);
    }
    pf_cut_result_release(&res);
    pf_mesh_release(&cut);
    cut_bar_release(&b);
}

static void test_export_caps(void **state)
{
    (void)state;
    cut_bar b;
    cut_bar_make(&b);
    pf_error err = {0};
    char obj[] = "/tmp/pf_caps_XXXXXX", ply[64];
    int fd = mkstemp(obj);
    assert_true(fd >= 0);
    fclose(fdopen(fd, "w"));
    snprintf(ply, sizeof ply, "%s.ply", obj);
    assert_int_equal(pf_export_obj(obj, &b.s[1], NULL, &err), PF_OK);
    assert_int_equal(pf_export_ply(ply, &b.s[1], NULL, &err), PF_OK);
    /* OBJ: runs of faces under "g model" / "g cap" with their materials; caps on their normals
     * 17 .. 20 (after the 16 vertices' own) */
    FILE *f = fopen(obj, "r");
    char line[256];
    int groups = 0, caps = 0, vn = 0, cap_normals_ok = 0;
    const char *part = "";
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "vn ", 3) == 0)
            ++vn;
        if (strncmp(line, "g ", 2) == 0) {
            ++groups;
            part = strcmp(line, "g cap\n") == 0 ? "cap" : "model";
            assert_true(fgets(line, sizeof line, f));
            char want[32];
            snprintf(want, sizeof want, "usemtl %s\n", part);
            assert_string_equal(line, want);
        }
        unsigned a, na, bb, nb, c, nc;
        if (sscanf(line, "f %u//%u %u//%u %u//%u", &a, &na, &bb, &nb, &c, &nc) == 6 &&
            strcmp(part, "cap") == 0) {
            ++caps;
            cap_normals_ok += na == nb && nb == nc && na == 16u + (unsigned)caps;
        }
    }
    fclose(f);
    assert_int_equal(vn, 20);
    assert_int_equal(groups, 5); /* model, cap, model, cap, model */
    assert_int_equal(caps, 4);
    assert_int_equal(cap_normals_ok, 4);
    /* PLY: the face element has a uchar "part", the last byte of each 14-byte record */
    f = fopen(ply, "rb");
    static char data[4096];
    size_t size = fread(data, 1, sizeof data, f);
    fclose(f);
    char *end = strstr(data, "end_header\n");
    assert_non_null(end);
    assert_non_null(strstr(data, "property list uchar uint vertex_indices\nproperty uchar part\n"));
    const unsigned char *faces = (const unsigned char *)end + 11 + 16 * 24;
    assert_int_equal(size, (size_t)((const char *)faces - data) + 24 * 14);
    for (int t = 0; t < 24; ++t)
        assert_int_equal(faces[14 * t + 13], b.s[1].tri_part[t]);
    remove(obj);
    remove(ply);
    cut_bar_release(&b);
}

/* ---- for the tool tests ---------------------------------------------------------------------- */

static int write_file(const char *path, bool bare)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 1;
    write_cut(f, bare);
    return fclose(f) == 0 ? 0 : 1;
}

static void chromaticity(double r, double g, double b, double *c)
{
    double sum = r + g + b;
    c[0] = sum > 0 ? r / sum : 0;
    c[1] = sum > 0 ? g / sum : 0;
}

static int count_near(const char *path, const char *hex)
{
    unsigned long v = strtoul(hex, NULL, 16);
    double want[2], got[2];
    chromaticity(pf_srgb_to_linear((v >> 16 & 255) / 255.0),
                 pf_srgb_to_linear((v >> 8 & 255) / 255.0), pf_srgb_to_linear((v & 255) / 255.0),
                 want);
    pf_image img = {0};
    pf_error err = {0};
    if (pf_png_read(path, &img, &err) != PF_OK) {
        fprintf(stderr, "%s\n", err.msg);
        return 1;
    }
    long n = 0;
    for (int64_t i = 0; i < (int64_t)img.width * img.height; ++i) {
        const uint8_t *p = img.pixels + 4 * i;
        double r = pf_srgb_to_linear(p[0] / 255.0), g = pf_srgb_to_linear(p[1] / 255.0),
               b = pf_srgb_to_linear(p[2] / 255.0);
        chromaticity(r, g, b, got);
        n += r + g + b > 0.06 && fabs(got[0] - want[0]) < 0.04 && fabs(got[1] - want[1]) < 0.04;
    }
    pf_image_release(&img);
    printf("%ld\n", n);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-cut") == 0)
        return write_file(argv[2], false);
    if (argc == 3 && strcmp(argv[1], "--write-cut-bare") == 0)
        return write_file(argv[2], true);
    if (argc == 4 && strcmp(argv[1], "--count-near") == 0)
        return count_near(argv[2], argv[3]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_caps_round_trip),       cmocka_unit_test(test_no_caps_is_version_1),
        cmocka_unit_test(test_caps_damaged),          cmocka_unit_test(test_cut_stream),
        cmocka_unit_test(test_cut_stale_weights),     cmocka_unit_test(test_draw_caps),
        cmocka_unit_test(test_cut_faces_in_boundary), cmocka_unit_test(test_export_caps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
