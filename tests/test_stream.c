/* stream: byte-exact round trip and pass-through, the documented layout, hostile payloads decoded
 * from memory (counts, offsets, indices, numbers), and the writer. Damaged streams (signature,
 * truncation, sizes, CRC, versions, tags) are test_stream_damage.c's. */
#define _POSIX_C_SOURCE 200809L /* pipe, fdopen: a non-seekable input, as from a shell pipe */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <pf/io.h>

#include "test_stream_util.h"

/* ---- a stream with every kind of chunk
 * ----------------------------------------------------------- */

typedef struct fixture {
    pf_mesh mesh;
    pf_surface surf;
    pf_weights wght;
    pf_frame_data frames[3];
    pf_stress_data stress[2]; /* von Mises of frame 1, the full tensor of frame 2 */
    pf_stats_data stats;      /* texts and numbers, one replaced after it was set */
} fixture;

static const char SCENE[] = "{\"gravity\": [0, 0, -9.81], \"name\": \"caf\xc3\xa9\"}";
static const char COMMAND[] = "pf-sim sc\xc3\xa8ne.json --frames 3";
static const unsigned char XTRA[] = {0, 1, 2, 0xff, 0x89, 'P', 'F', 'S'};
static const char *const FIXTURE_TAGS[] = {"INFO", "SCEN", "MESH", "SURF", "WGHT", "XTRA", "FRAM",
                                           "FRAM", "STRS", "FRAM", "STRS", "zero", "STAT", "END_"};
enum { FIXTURE_CHUNKS = 14 };

static void fixture_make(fixture *fx)
{
    pf_error err = {0};
    memset(fx, 0, sizeof *fx);
    /* Coordinates like 1/3 and 0.1 are not short binary fractions: all 64 bits matter. */
    assert_int_equal(
        pf_mesh_make_box(&fx->mesh, pf_v3(-0.5, 0.1, 1.0 / 3), pf_v3(0.7, 0.9, 2.0), 2, 1, 1, &err),
        PF_OK);
    fx->mesh.id = 0x0123456789abcdefull; /* every byte of the u64 different */
    assert_int_equal(pf_surface_make_sphere(&fx->surf, 0.3, 3, 5, &err), PF_OK);
    fx->surf.id = 42;
    int32_t rows = fx->surf.n_verts, cols = fx->mesh.n_nodes;
    assert_int_equal(pf_weights_alloc(&fx->wght, rows, cols, 3 * (int64_t)rows, &err), PF_OK);
    fx->wght.surface_id = fx->surf.id;
    fx->wght.mesh_id = fx->mesh.id;
    int64_t k = 0;
    for (int32_t i = 0; i < rows; ++i) { /* row i has i % 3 entries: row 0 is empty */
        for (int32_t j = 0; j < i % 3; ++j, ++k) {
            fx->wght.col[k] = (uint32_t)((i + 5 * j) % cols);
            fx->wght.val[k] = 1.0 / (j + 1) + i * 1e-3;
        }
        fx->wght.row_offsets[i + 1] = k;
    }
    for (int f = 0; f < 3; ++f) {
        pf_frame_data *fr = &fx->frames[f];
        assert_int_equal(pf_frame_data_alloc(fr, fx->mesh.n_nodes, &err), PF_OK);
        fr->mesh_id = fx->mesh.id;
        fr->index = (uint32_t)f;
        fr->time = f / 30.0;
        for (int32_t i = 0; i < 3 * fr->n_nodes; ++i)
            fr->u[i] = sin(0.37 * i + f) * 1e-2;
    }
    fx->frames[2].u[0] = -0.0;     /* the sign of zero survives */
    fx->frames[2].u[1] = 4.9e-324; /* so does the smallest subnormal */
    assert_int_equal(pf_stress_data_alloc(&fx->stress[0], fx->mesh.n_elems, 1, &err), PF_OK);
    assert_int_equal(pf_stress_data_alloc(&fx->stress[1], fx->mesh.n_elems, 6, &err), PF_OK);
    for (int s = 0; s < 2; ++s) {
        fx->stress[s].mesh_id = fx->mesh.id;
        fx->stress[s].frame = (uint32_t)(s + 1);
        for (int64_t i = 0; i < (int64_t)fx->stress[s].n_elems * fx->stress[s].components; ++i)
            fx->stress[s].values[i] = 1.5e6 * (double)(i + 1) - 3.0 / 7.0;
    }
    pf_stats_data *d = &fx->stats;
    assert_int_equal(pf_stats_data_set_text(d, "method", "cg", &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(d, "error_indicator", 1.0 / 3, &err), PF_OK);
    assert_int_equal(pf_stats_data_set_text(d, "note", "", &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(d, "zero", -0.0, &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(d, "tiny", 4.9e-324, &err), PF_OK);
    assert_int_equal(pf_stats_data_set_text(d, "method", "dg caf\xc3\xa9", &err), PF_OK);
    assert_int_equal(pf_stats_data_set_number(d, "steps", 9007199254740992.0, &err), PF_OK);
}

static void fixture_release(fixture *fx)
{
    pf_mesh_release(&fx->mesh);
    pf_surface_release(&fx->surf);
    pf_weights_release(&fx->wght);
    for (int f = 0; f < 3; ++f)
        pf_frame_data_release(&fx->frames[f]);
    pf_stress_data_release(&fx->stress[0]);
    pf_stress_data_release(&fx->stress[1]);
    pf_stats_data_release(&fx->stats);
}

static void write_fixture(const fixture *fx, FILE *f, bool finish)
{
    pf_error err = {0};
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "test", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(w, "test_stream", "1.2.3", COMMAND, &err), PF_OK);
    assert_int_equal(pf_stream_write_scene(w, SCENE, strlen(SCENE), &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(w, &fx->mesh, &err), PF_OK);
    assert_int_equal(pf_stream_write_surface(w, &fx->surf, &err), PF_OK);
    assert_int_equal(pf_stream_write_weights(w, &fx->wght, &err), PF_OK);
    assert_int_equal(pf_stream_write_chunk(w, "XTRA", 3, XTRA, sizeof XTRA, &err), PF_OK);
    for (int k = 0; k < 3; ++k) {
        assert_int_equal(pf_stream_write_frame(w, &fx->frames[k], &err), PF_OK);
        if (k > 0)
            assert_int_equal(pf_stream_write_stress(w, &fx->stress[k - 1], &err), PF_OK);
    }
    assert_int_equal(pf_stream_write_chunk(w, "zero", 1, NULL, 0, &err), PF_OK);
    assert_int_equal(pf_stream_write_stats(w, &fx->stats, &err), PF_OK);
    if (finish)
        assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    assert_null(w);
}

#define ASSERT_SAME_ARRAY(a, b, n) assert_memory_equal((a), (b), (size_t)(n) * sizeof *(a))

/* Decodes c, compares it bit for bit with what was written, and re-encodes it into re. */
static void check_chunk(const fixture *fx, const pf_chunk *c, int *frame, int *stress,
                        pf_buffer *re)
{
    pf_error err = {0};
    if (strcmp(c->tag, "INFO") == 0) {
        pf_info_data d = {0};
        assert_int_equal(pf_stream_decode_info(c, &d, &err), PF_OK);
        assert_string_equal(d.producer, "test_stream");
        assert_string_equal(d.version, "1.2.3");
        assert_string_equal(d.command, COMMAND);
        assert_int_equal(pf_stream_encode_info(d.producer, d.version, d.command, re, &err), PF_OK);
        pf_info_data_release(&d);
    } else if (strcmp(c->tag, "SCEN") == 0) {
        char *json = NULL;
        size_t n = 0;
        assert_int_equal(pf_stream_decode_scene(c, &json, &n, &err), PF_OK);
        assert_int_equal(n, strlen(SCENE));
        assert_string_equal(json, SCENE);
        assert_int_equal(pf_stream_encode_scene(json, n, re, &err), PF_OK);
        pf_free(json);
    } else if (strcmp(c->tag, "MESH") == 0) {
        const pf_mesh *a = &fx->mesh;
        pf_mesh m = {0};
        assert_int_equal(pf_stream_decode_mesh(c, &m, &err), PF_OK);
        assert_true(m.id == a->id);
        assert_int_equal(m.n_nodes, a->n_nodes);
        assert_int_equal(m.n_faces, a->n_faces);
        assert_int_equal(m.n_elems, a->n_elems);
        ASSERT_SAME_ARRAY(m.x, a->x, 3 * a->n_nodes);
        ASSERT_SAME_ARRAY(m.face_offsets, a->face_offsets, a->n_faces + 1);
        ASSERT_SAME_ARRAY(m.face_nodes, a->face_nodes, a->face_offsets[a->n_faces]);
        ASSERT_SAME_ARRAY(m.elem_offsets, a->elem_offsets, a->n_elems + 1);
        ASSERT_SAME_ARRAY(m.elem_faces, a->elem_faces, a->elem_offsets[a->n_elems]);
        assert_int_equal(pf_mesh_validate(&m, NULL, &err), PF_OK);
        assert_int_equal(pf_stream_encode_mesh(&m, re, &err), PF_OK);
        pf_mesh_release(&m);
    } else if (strcmp(c->tag, "SURF") == 0) {
        pf_surface s = {0};
        assert_int_equal(pf_stream_decode_surface(c, &s, &err), PF_OK);
        assert_true(s.id == fx->surf.id);
        assert_int_equal(s.n_verts, fx->surf.n_verts);
        assert_int_equal(s.n_tris, fx->surf.n_tris);
        ASSERT_SAME_ARRAY(s.x, fx->surf.x, 3 * s.n_verts);
        ASSERT_SAME_ARRAY(s.tri, fx->surf.tri, 3 * s.n_tris);
        assert_int_equal(pf_stream_encode_surface(&s, re, &err), PF_OK);
        pf_surface_release(&s);
    } else if (strcmp(c->tag, "WGHT") == 0) {
        const pf_weights *a = &fx->wght;
        pf_weights w = {0};
        assert_int_equal(pf_stream_decode_weights(c, &w, &err), PF_OK);
        assert_true(w.surface_id == a->surface_id && w.mesh_id == a->mesh_id);
        assert_int_equal(w.rows, a->rows);
        assert_int_equal(w.cols, a->cols);
        ASSERT_SAME_ARRAY(w.row_offsets, a->row_offsets, a->rows + 1);
        ASSERT_SAME_ARRAY(w.col, a->col, a->row_offsets[a->rows]);
        ASSERT_SAME_ARRAY(w.val, a->val, a->row_offsets[a->rows]);
        assert_int_equal(pf_stream_encode_weights(&w, re, &err), PF_OK);
        pf_weights_release(&w);
    } else if (strcmp(c->tag, "FRAM") == 0) {
        const pf_frame_data *a = &fx->frames[(*frame)++];
        pf_frame_data f = {0};
        assert_int_equal(pf_stream_decode_frame(c, &f, &err), PF_OK);
        assert_true(f.mesh_id == a->mesh_id && f.index == a->index);
        assert_memory_equal(&f.time, &a->time, sizeof f.time);
        assert_int_equal(f.n_nodes, a->n_nodes);
        ASSERT_SAME_ARRAY(f.u, a->u, 3 * a->n_nodes);
        assert_int_equal(pf_stream_encode_frame(&f, re, &err), PF_OK);
        pf_frame_data_release(&f);
    } else if (strcmp(c->tag, "STRS") == 0) {
        const pf_stress_data *a = &fx->stress[(*stress)++];
        pf_stress_data s = {0};
        assert_int_equal(pf_stream_decode_stress(c, &s, &err), PF_OK);
        assert_true(s.mesh_id == a->mesh_id && s.frame == a->frame);
        assert_int_equal(s.n_elems, a->n_elems);
        assert_int_equal(s.components, a->components);
        ASSERT_SAME_ARRAY(s.values, a->values, a->n_elems * a->components);
        assert_int_equal(pf_stream_encode_stress(&s, re, &err), PF_OK);
        pf_stress_data_release(&s);
    } else if (strcmp(c->tag, "END_") == 0) {
        pf_end_data d;
        assert_int_equal(pf_stream_decode_end(c, &d, &err), PF_OK);
        assert_true(d.chunk_count == FIXTURE_CHUNKS - 1 && d.frame_count == 3);
        assert_int_equal(pf_stream_encode_end(&d, re, &err), PF_OK);
    } else if (strcmp(c->tag, "STAT") == 0) {
        pf_stats_data d = {0};
        assert_int_equal(pf_stream_decode_stats(c, &d, &err), PF_OK);
        assert_int_equal(d.n, fx->stats.n);
        for (int32_t i = 0; i < d.n; ++i) {
            const pf_stat_entry *a = &fx->stats.entries[i], *b = &d.entries[i];
            assert_string_equal(b->key, a->key);
            assert_true((a->text == NULL) == (b->text == NULL));
            if (a->text)
                assert_string_equal(b->text, a->text);
            else
                assert_memory_equal(&b->value, &a->value, sizeof a->value);
        }
        assert_string_equal(d.entries[0].text, "dg caf\xc3\xa9"); /* replaced in place */
        assert_int_equal(pf_stream_encode_stats(&d, re, &err), PF_OK);
        pf_stats_data_release(&d);
    } else if (strcmp(c->tag, "XTRA") == 0) {
        assert_int_equal(c->version, 3);
        assert_int_equal(c->size, sizeof XTRA);
        assert_memory_equal(c->payload, XTRA, sizeof XTRA);
        assert_int_equal(pf_stream_check_version(c, &err), PF_OK); /* unknown: any version */
        assert_int_equal(pf_buffer_append(re, c->payload, c->size, &err), PF_OK);
    } else {
        assert_string_equal(c->tag, "zero");
        assert_int_equal(c->size, 0);
        assert_null(c->payload);
    }
}

/* The byte layout the spec promises, read with the test's own little-endian code. */
static void check_layout(const fixture *fx, const pf_buffer *b)
{
    static const unsigned char SIG[8] = {0x89, 'P', 'F', 'S', '\r', '\n', 0x1a, '\n'};
    assert_memory_equal(b->data, SIG, 8);
    size_t offs[FIXTURE_CHUNKS + 1];
    assert_int_equal(chunk_offsets(b, offs, FIXTURE_CHUNKS + 1), FIXTURE_CHUNKS);
    const unsigned char *mesh = b->data + offs[2];
    assert_memory_equal(mesh, "MESH", 4);
    assert_int_equal(rd(mesh + 4, 4), 1);
    const unsigned char *p = mesh + 16;
    uint64_t size = rd(mesh + 8, 8);
    assert_int_equal(rd(p + size, 4), crc32_bitwise(p, (size_t)size));
    assert_true(rd(p, 8) == fx->mesh.id);
    assert_int_equal(rd(p + 8, 4), fx->mesh.n_nodes);
    assert_int_equal(rd(p + 12, 4), fx->mesh.n_faces);
    assert_int_equal(rd(p + 16, 4), fx->mesh.n_elems);
    uint64_t bits;
    memcpy(&bits, &fx->mesh.x[1], sizeof bits);
    assert_true(rd(p + 20 + 8, 8) == bits);
    size_t nn = (size_t)fx->mesh.n_nodes, nf = (size_t)fx->mesh.n_faces;
    size_t ne = (size_t)fx->mesh.n_elems, nfn = (size_t)fx->mesh.face_offsets[nf];
    size_t nef = (size_t)fx->mesh.elem_offsets[ne];
    assert_int_equal(size, 20 + 24 * nn + 8 * (nf + 1) + 4 * nfn + 8 * (ne + 1) + 4 * nef);
    const unsigned char *end = b->data + offs[FIXTURE_CHUNKS - 1];
    assert_memory_equal(end, "END_", 4);
    assert_int_equal(rd(end + 8, 8), 16);
    assert_int_equal(rd(end + 16, 8), FIXTURE_CHUNKS - 1);
    assert_int_equal(rd(end + 24, 8), 3);
    assert_int_equal(offs[FIXTURE_CHUNKS - 1] + 36, b->size);
}

static void test_round_trip_is_byte_exact(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx);
    FILE *f = tmpfile();
    assert_non_null(f);
    write_fixture(&fx, f, true);
    pf_buffer bytes = {0}, re = {0};
    slurp(f, &bytes);
    check_layout(&fx, &bytes);
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "round.pfs", &err), PF_OK);
    int frame = 0, stress = 0, i = 0;
    for (;; ++i) {
        pf_chunk c;
        bool end = false;
        assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
        if (end)
            break;
        assert_true(i < FIXTURE_CHUNKS);
        assert_string_equal(c.tag, FIXTURE_TAGS[i]);
        assert_int_equal(c.crc, crc32_bitwise(c.payload, (size_t)c.size));
        re.size = 0;
        check_chunk(&fx, &c, &frame, &stress, &re);
        assert_int_equal(re.size, c.size);
        if (c.size)
            assert_memory_equal(re.data, c.payload, re.size);
    }
    assert_int_equal(i, FIXTURE_CHUNKS);
    uint64_t chunks, frames;
    pf_stream_reader_counts(r, &chunks, &frames);
    assert_true(chunks == FIXTURE_CHUNKS - 1 && frames == 3);
    bool end = false;
    pf_chunk c;
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK); /* end stays reported */
    assert_true(end);
    pf_stream_reader_destroy(&r);
    assert_null(r);
    fclose(f);
    pf_buffer_release(&bytes);
    pf_buffer_release(&re);
    fixture_release(&fx);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A tool passing every chunk on (from a pipe) writes the very same bytes. */
static void test_pass_through_is_byte_for_byte(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx);
    FILE *f = tmpfile();
    write_fixture(&fx, f, true);
    pf_buffer in = {0}, out = {0};
    slurp(f, &in);
    fclose(f);
    FILE *src = pipe_with(in.data, in.size), *dst = tmpfile();
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_reader_create(&r, src, "stdin", &err), PF_OK);
    assert_int_equal(pf_stream_writer_create(&w, dst, "stdout", &err), PF_OK);
    for (bool end = false;;) {
        pf_chunk c;
        assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
        if (end)
            break;
        if (strcmp(c.tag, "END_") != 0)
            assert_int_equal(pf_stream_write_raw(w, &c, &err), PF_OK);
    }
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    slurp(dst, &out);
    assert_int_equal(out.size, in.size);
    assert_memory_equal(out.data, in.data, in.size);
    pf_stream_reader_destroy(&r);
    pf_stream_writer_destroy(&w);
    fclose(src);
    fclose(dst);
    pf_buffer_release(&in);
    pf_buffer_release(&out);
    fixture_release(&fx);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_tag_table(void **state)
{
    (void)state;
    static const char *const KNOWN[] = {"INFO", "SCEN", "MESH", "SURF",
                                        "WGHT", "FRAM", "STRS", "END_"};
    for (int i = 0; i < 8; ++i) {
        assert_true(pf_stream_tag_is_known(KNOWN[i]));
        /* SURF 2: triangle parts (caps), tests/test_stream_caps.c */
        assert_int_equal(pf_stream_tag_version(KNOWN[i]), strcmp(KNOWN[i], "SURF") == 0 ? 2 : 1);
    }
    /* CKPT 2: the run's counters; STAT: a run's statistics, a record like INFO */
    assert_int_equal(pf_stream_tag_version("CKPT"), 2);
    assert_true(pf_stream_version_is_read("CKPT", 1) && pf_stream_version_is_read("CKPT", 2));
    assert_int_equal(pf_stream_tag_version("STAT"), 1);
    assert_true(pf_stream_tag_is_known("STAT"));
    assert_false(pf_stream_tag_is_critical("STAT") || pf_stream_tag_is_mesh_dependent("STAT"));
    static const char *const UNKNOWN[] = {"XTRA", "mesh", "MES", "MESHX", ""};
    for (int i = 0; i < 5; ++i) {
        assert_false(pf_stream_tag_is_known(UNKNOWN[i]));
        assert_false(pf_stream_tag_is_critical(UNKNOWN[i]));
        assert_false(pf_stream_tag_is_mesh_dependent(UNKNOWN[i]));
        assert_int_equal(pf_stream_tag_version(UNKNOWN[i]), 0);
    }
    assert_false(pf_stream_tag_is_known(NULL));
    assert_true(pf_stream_tag_is_critical("MESH") && pf_stream_tag_is_critical("FRAM"));
    assert_false(pf_stream_tag_is_critical("INFO") || pf_stream_tag_is_critical("STRS"));
    const char *dependent[] = {"WGHT", "FRAM", "STRS"};
    for (int i = 0; i < 3; ++i)
        assert_true(pf_stream_tag_is_mesh_dependent(dependent[i]));
    const char *independent[] = {"INFO", "SCEN", "MESH", "SURF", "END_"};
    for (int i = 0; i < 5; ++i)
        assert_false(pf_stream_tag_is_mesh_dependent(independent[i]));
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* The check value of CRC-32 is crc("123456789") = 0xcbf43926; the writer stores it after the
 * payload, little-endian. */
static void test_crc_check_value(void **state)
{
    (void)state;
    assert_int_equal(crc32_bitwise((const unsigned char *)"123456789", 9), 0xcbf43926u);
    FILE *f = tmpfile();
    pf_error err = {0};
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "crc", &err), PF_OK);
    assert_int_equal(pf_stream_write_chunk(w, "TEST", 1, "123456789", 9, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    pf_buffer b = {0};
    slurp(f, &b);
    assert_int_equal(b.size, 8 + 16 + 9 + 4);
    assert_int_equal(rd(b.data + 8 + 16 + 9, 4), 0xcbf43926u);
    fclose(f);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- hostile payloads, decoded from memory
 * ------------------------------------------------------- */

static pf_chunk chunk_of(const char *tag, const pf_buffer *b)
{
    pf_chunk c = {.version = 1, .size = b->size, .offset = 1184, .payload = b->data};
    memcpy(c.tag, tag, 5);
    return c;
}

/* Byte offsets of the arrays in a MESH payload, from the spec. */
typedef struct mesh_layout {
    size_t x, face_offsets, face_nodes, elem_offsets, elem_faces, end;
} mesh_layout;

static mesh_layout layout_of(const pf_mesh *m)
{
    mesh_layout l;
    l.x = 20;
    l.face_offsets = l.x + 24 * (size_t)m->n_nodes;
    l.face_nodes = l.face_offsets + 8 * ((size_t)m->n_faces + 1);
    l.elem_offsets = l.face_nodes + 4 * (size_t)m->face_offsets[m->n_faces];
    l.elem_faces = l.elem_offsets + 8 * ((size_t)m->n_elems + 1);
    l.end = l.elem_faces + 4 * (size_t)m->elem_offsets[m->n_elems];
    return l;
}

/* Decodes the edited payload, expecting failure with a message and no memory left behind. */
static void expect_mesh_refused(const pf_buffer *b, pf_status code, const char *needle)
{
    pf_chunk c = chunk_of("MESH", b);
    pf_mesh m = {0};
    pf_error err = {0};
    int64_t live = pf_alloc_live_bytes();
    assert_int_equal(pf_stream_decode_mesh(&c, &m, &err), code);
    expect_msg(&err, "chunk MESH at byte 1184: ");
    expect_msg(&err, needle);
    assert_null(m.x);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void box_payload(pf_mesh *m, pf_buffer *b)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), PF_OK);
    assert_int_equal(pf_stream_encode_mesh(m, b, &err), PF_OK);
    assert_int_equal(b->size, layout_of(m).end);
}

static void test_mesh_counts_beyond_the_payload(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_buffer b = {0};
    box_payload(&m, &b);
    mesh_layout l = layout_of(&m);
    wr(b.data + 8, 0xffffffffu, 4);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "too short for 4294967295 nodes");
    wr(b.data + 8, (uint64_t)m.n_nodes, 4);
    wr(b.data + 12, 0xffffffffu, 4);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "too short for 4294967296 face offsets");
    wr(b.data + 12, (uint64_t)m.n_faces, 4);
    wr(b.data + 16, 0xfffffff0u, 4);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "element offsets");
    wr(b.data + 16, (uint64_t)m.n_elems, 4);
    /* The last offset is the length of face_nodes: 2^62 entries cannot be in the payload. */
    wr(b.data + l.face_offsets + 8 * (size_t)m.n_faces, 1ull << 62, 8);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "too short for 4611686018427387904 face node entries");
    wr(b.data + l.face_offsets + 8 * (size_t)m.n_faces, (uint64_t)m.face_offsets[m.n_faces], 8);
    wr(b.data + l.elem_offsets + 8 * (size_t)m.n_elems, (uint64_t)m.elem_offsets[m.n_elems] + 1, 8);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "too short for 13 element face entries");
    wr(b.data + l.elem_offsets + 8 * (size_t)m.n_elems, (uint64_t)m.elem_offsets[m.n_elems], 8);
    /* Short and long payloads. */
    pf_buffer cut = {.data = b.data, .size = 10, .capacity = 10};
    expect_mesh_refused(&cut, PF_ERR_FORMAT, "payload of 10 bytes too short for 1 header");
    cut.size = b.size - 1;
    expect_mesh_refused(&cut, PF_ERR_FORMAT, "too short for 12 element face entries");
    pf_error err = {0};
    assert_int_equal(pf_buffer_append(&b, "\0\0\0\0", 4, &err), PF_OK);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "4 trailing bytes");
    pf_buffer_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_mesh_non_finite_coordinate(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_buffer b = {0};
    box_payload(&m, &b);
    mesh_layout l = layout_of(&m);
    wr_f64(b.data + l.x + 24 * 5 + 8, NAN);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "node 5 has a non-finite coordinate");
    wr_f64(b.data + l.x + 24 * 5 + 8, 0.0);
    wr_f64(b.data + l.x + 24 * 11 + 16, -INFINITY);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "node 11 has a non-finite coordinate");
    pf_buffer_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_mesh_index_out_of_range(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_buffer b = {0};
    box_payload(&m, &b);
    mesh_layout l = layout_of(&m);
    char want[96];
    /* Entry 9 of face_nodes belongs to the face whose offsets enclose it. */
    int32_t face = 0;
    while (m.face_offsets[face + 1] <= 9)
        ++face;
    wr(b.data + l.face_nodes + 4 * 9, 12, 4);
    snprintf(want, sizeof want, "face %d lists node 12, beyond the 12 nodes", (int)face);
    expect_mesh_refused(&b, PF_ERR_FORMAT, want);
    wr(b.data + l.face_nodes + 4 * 9, m.face_nodes[9], 4);
    /* Entry 8 of elem_faces is in element 1; the reversal bit is not part of the index. */
    wr(b.data + l.elem_faces + 4 * 8, 11u | PF_FACE_REVERSED, 4);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "element 1 lists face 11, beyond the 11 faces");
    wr(b.data + l.elem_faces + 4 * 8, 10u | PF_FACE_REVERSED, 4);
    pf_chunk c = chunk_of("MESH", &b);
    pf_mesh d = {0};
    pf_error err = {0};
    assert_int_equal(pf_stream_decode_mesh(&c, &d, &err), PF_OK); /* in range: the decoder's job
                                                                      ends; validation's begins */
    assert_int_equal(d.elem_faces[8], 10u | PF_FACE_REVERSED);
    pf_mesh_release(&d);
    pf_buffer_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_mesh_offsets_must_start_at_zero_and_not_decrease(void **state)
{
    (void)state;
    pf_mesh m = {0};
    pf_buffer b = {0};
    box_payload(&m, &b);
    mesh_layout l = layout_of(&m);
    wr(b.data + l.face_offsets + 8 * 3, (uint64_t)m.face_offsets[2] - 1, 8);
    char want[96];
    snprintf(want, sizeof want, "face_offsets[3] = %lld is less than face_offsets[2] = %lld",
             (long long)m.face_offsets[2] - 1, (long long)m.face_offsets[2]);
    expect_mesh_refused(&b, PF_ERR_FORMAT, want);
    wr(b.data + l.face_offsets + 8 * 3, (uint64_t)m.face_offsets[3], 8);
    wr(b.data + l.elem_offsets, 1, 8);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "elem_offsets[0] is 1, must be 0");
    wr(b.data + l.elem_offsets, 0, 8);
    wr(b.data + l.elem_offsets + 8, UINT64_MAX, 8);
    expect_mesh_refused(&b, PF_ERR_FORMAT, "elem_offsets[2] = 12 is less than elem_offsets[1]");
    pf_buffer_release(&b);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Decodes payload b as tag, expecting code and a message fragment; nothing may stay allocated. */
static void expect_refused(const char *tag, const pf_buffer *b, pf_status code, const char *needle)
{
    pf_chunk c = chunk_of(tag, b);
    pf_error err = {0};
    int64_t live = pf_alloc_live_bytes();
    pf_status s = decode_known(&c, &err);
    if (s != code || !strstr(err.msg, needle))
        fail_msg("%s: status %d, message '%s'; expected %d with '%s'", tag, s, err.msg, code,
                 needle);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_other_chunks_refuse_bad_payloads(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx);
    pf_error err = {0};
    pf_buffer b = {0};
    /* SURF: header 16 bytes, x, then tri. */
    assert_int_equal(pf_stream_encode_surface(&fx.surf, &b, &err), PF_OK);
    size_t tri = 16 + 24 * (size_t)fx.surf.n_verts;
    wr(b.data + tri + 4 * 7, (uint64_t)fx.surf.n_verts, 4);
    char want[96];
    snprintf(want, sizeof want, "triangle 2 lists vertex %d, beyond", (int)fx.surf.n_verts);
    expect_refused("SURF", &b, PF_ERR_FORMAT, want);
    wr(b.data + tri + 4 * 7, 0, 4);
    wr_f64(b.data + 16 + 24 * 3, NAN);
    expect_refused("SURF", &b, PF_ERR_FORMAT, "vertex 3 has a non-finite coordinate");
    wr(b.data + 12, 0xffffffffu, 4);
    expect_refused("SURF", &b, PF_ERR_FORMAT, "too short for 4294967295 triangles");
    /* WGHT: header 24, row_offsets[rows + 1], col[nnz], val[nnz]. */
    b.size = 0;
    assert_int_equal(pf_stream_encode_weights(&fx.wght, &b, &err), PF_OK);
    size_t col = 24 + 8 * ((size_t)fx.wght.rows + 1),
           nnz = (size_t)fx.wght.row_offsets[fx.wght.rows];
    wr(b.data + col, 99, 4); /* entry 0 is in row 1 (row 0 is empty) */
    expect_refused("WGHT", &b, PF_ERR_FORMAT, "row 1 lists node 99, beyond the 12 nodes");
    wr(b.data + col, 0, 4);
    wr_f64(b.data + col + 4 * nnz + 8 * 2, INFINITY); /* entry 2: row 2 */
    expect_refused("WGHT", &b, PF_ERR_FORMAT, "row 2 has a non-finite weight");
    wr(b.data + 24 + 8, 5, 8);
    expect_refused("WGHT", &b, PF_ERR_FORMAT, "row_offsets[2] = 1 is less than row_offsets[1] = 5");
    /* FRAM: header 24 (mesh id, index, time, n_nodes), then u. */
    b.size = 0;
    assert_int_equal(pf_stream_encode_frame(&fx.frames[1], &b, &err), PF_OK);
    wr_f64(b.data + 24 + 24 * 2, NAN);
    expect_refused("FRAM", &b, PF_ERR_FORMAT, "frame 1: node 2 has a non-finite displacement");
    wr_f64(b.data + 12, INFINITY);
    expect_refused("FRAM", &b, PF_ERR_FORMAT, "frame 1 has a non-finite time");
    wr_f64(b.data + 12, 0.5);
    wr(b.data + 20, 0xffffffffu, 4);
    expect_refused("FRAM", &b, PF_ERR_FORMAT, "too short for 4294967295 node displacements");
    /* STRS: header 20 (mesh id, frame, n_elems, components), then values. */
    b.size = 0;
    assert_int_equal(pf_stream_encode_stress(&fx.stress[1], &b, &err), PF_OK);
    wr(b.data + 16, 3, 4);
    expect_refused("STRS", &b, PF_ERR_FORMAT, "3 stress components, must be 1");
    wr(b.data + 16, 6, 4);
    wr_f64(b.data + 20 + 8 * 7, NAN);
    expect_refused("STRS", &b, PF_ERR_FORMAT, "element 1 has a non-finite stress");
    /* INFO: three u32-length-prefixed strings. */
    b.size = 0;
    assert_int_equal(pf_stream_encode_info("ab", "1", "", &b, &err), PF_OK);
    assert_int_equal(b.size, 4 + 2 + 4 + 1 + 4);
    b.data[5] = 0xc0; /* "a\xc0": a truncated two-byte sequence */
    expect_refused("INFO", &b, PF_ERR_FORMAT, "the producer string is not valid UTF-8");
    b.data[4] = 0xc0;
    b.data[5] = 0xaf; /* the overlong encoding of '/' */
    expect_refused("INFO", &b, PF_ERR_FORMAT, "not valid UTF-8");
    b.data[4] = 0xc3;
    b.data[5] = 'b'; /* a lead byte followed by no continuation byte */
    expect_refused("INFO", &b, PF_ERR_FORMAT, "(byte 0 of 2)");
    b.data[4] = 'a';
    b.data[5] = 0;
    expect_refused("INFO", &b, PF_ERR_FORMAT, "without NUL (byte 1 of 2)");
    b.data[5] = 'b';
    wr(b.data + 6, 1000, 4);
    expect_refused("INFO", &b, PF_ERR_FORMAT, "too short for 1000 version string bytes");
    /* SCEN and END_. */
    b.size = 0;
    assert_int_equal(pf_buffer_append(&b, "{\"a\":\0}", 7, &err), PF_OK);
    expect_refused("SCEN", &b, PF_ERR_FORMAT, "NUL byte at payload byte 5");
    expect_refused("END_", &b, PF_ERR_FORMAT, "too short for 1 counts");
    pf_buffer_release(&b);
    fixture_release(&fx);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* ---- the writer ------------------------------------------------------------------------------ */

static void test_writer_refuses_what_no_reader_would_take(void **state)
{
    (void)state;
    fixture fx;
    fixture_make(&fx);
    FILE *f = tmpfile();
    pf_error err = {0};
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "out.pfs", &err), PF_OK);
    assert_int_equal(pf_stream_write_chunk(w, "END_", 1, NULL, 0, &err), PF_ERR_INVALID);
    expect_msg(&err, "pf_stream_writer_finish");
    assert_int_equal(pf_stream_write_chunk(w, "ME\nH", 1, NULL, 0, &err), PF_ERR_INVALID);
    assert_int_equal(pf_stream_write_chunk(w, "MESHY", 1, NULL, 0, &err), PF_ERR_INVALID);
    /* A pass-through chunk whose CRC does not match its payload. */
    pf_chunk c = {.tag = "XTRA", .version = 1, .size = 3, .payload = (unsigned char *)"abc"};
    c.crc = crc32_bitwise(c.payload, 3) ^ 1;
    assert_int_equal(pf_stream_write_raw(w, &c, &err), PF_ERR_INVALID);
    c.crc ^= 1;
    assert_int_equal(pf_stream_write_raw(w, &c, &err), PF_OK);
    /* Data the decoder would refuse. */
    fx.mesh.x[7] = NAN;
    assert_int_equal(pf_stream_write_mesh(w, &fx.mesh, &err), PF_ERR_INVALID);
    expect_msg(&err, "mesh 81985529216486895: node 2 has a non-finite coordinate");
    fx.mesh.x[7] = 0;
    fx.mesh.face_nodes[0] = 12;
    assert_int_equal(pf_stream_write_mesh(w, &fx.mesh, &err), PF_ERR_INVALID);
    expect_msg(&err, "face_nodes entry 0 is 12, beyond the 12 available");
    fx.mesh.face_nodes[0] = 0;
    fx.mesh.face_offsets[2] = fx.mesh.face_offsets[1] - 1;
    assert_int_equal(pf_stream_write_mesh(w, &fx.mesh, &err), PF_ERR_INVALID);
    expect_msg(&err, "face_offsets[2]");
    fx.stress[0].components = 3;
    assert_int_equal(pf_stream_write_stress(w, &fx.stress[0], &err), PF_ERR_INVALID);
    fx.frames[0].time = NAN;
    assert_int_equal(pf_stream_write_frame(w, &fx.frames[0], &err), PF_ERR_INVALID);
    fx.wght.col[0] = 12;
    assert_int_equal(pf_stream_write_weights(w, &fx.wght, &err), PF_ERR_INVALID);
    fx.surf.tri[5] = (uint32_t)fx.surf.n_verts;
    assert_int_equal(pf_stream_write_surface(w, &fx.surf, &err), PF_ERR_INVALID);
    assert_int_equal(pf_stream_write_info(w, "bad\xff", "1", "", &err), PF_ERR_INVALID);
    assert_int_equal(pf_stream_write_scene(w, "{\0}", 3, &err), PF_ERR_INVALID);
    /* Nothing after END_. */
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    assert_int_equal(pf_stream_write_chunk(w, "XTRA", 1, "x", 1, &err), PF_ERR_INVALID);
    expect_msg(&err, "after the END_ chunk");
    pf_stream_writer_destroy(&w);
    /* What was refused left no trace: the stream is the signature, XTRA and END_ counting 1. */
    rewind(f);
    read_result res;
    read_all(f, "out.pfs", &res);
    assert_int_equal(res.status, PF_OK);
    assert_int_equal(res.n, 2);
    assert_string_equal(res.rec[0].tag, "XTRA");
    fixture_release(&fx);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Payloads of megabytes through a pipe: the reader's buffer grows piece by piece as the bytes
 * arrive (a child process writes, as the producer of a shell pipe would) and every byte survives.
 */
static void test_large_chunks_through_a_pipe(void **state)
{
    (void)state;
    enum { BIG = 3 << 20, NODES = 100000 };
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    pid_t child = fork();
    assert_true(child >= 0);
    if (child == 0) {
        close(fd[0]);
        FILE *out = fdopen(fd[1], "wb");
        pf_error err = {0};
        pf_stream_writer *w = NULL;
        unsigned char *big = pf_alloc(BIG);
        pf_frame_data fr = {0};
        int ok = out && big && pf_frame_data_alloc(&fr, NODES, &err) == PF_OK &&
                 pf_stream_writer_create(&w, out, "pipe", &err) == PF_OK;
        for (size_t i = 0; ok && i < BIG; ++i)
            big[i] = (unsigned char)(i * 2654435761u >> 13);
        for (int32_t i = 0; ok && i < 3 * NODES; ++i)
            fr.u[i] = i * 1e-6;
        ok = ok && pf_stream_write_chunk(w, "XTRA", 1, big, BIG, &err) == PF_OK &&
             pf_stream_write_frame(w, &fr, &err) == PF_OK &&
             pf_stream_writer_finish(w, &err) == PF_OK;
        _exit(ok && fclose(out) == 0 ? 0 : 1);
    }
    close(fd[1]);
    FILE *in = fdopen(fd[0], "rb");
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, in, "stdin", &err), PF_OK);
    pf_chunk c;
    bool end = false;
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_string_equal(c.tag, "XTRA");
    assert_int_equal(c.size, BIG);
    for (size_t i = 0; i < BIG; ++i)
        if (c.payload[i] != (unsigned char)(i * 2654435761u >> 13))
            fail_msg("payload byte %zu differs", i);
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    pf_frame_data fr = {0};
    assert_int_equal(pf_stream_decode_frame(&c, &fr, &err), PF_OK);
    assert_int_equal(fr.n_nodes, NODES);
    for (int32_t i = 0; i < 3 * NODES; ++i)
        assert_true(fr.u[i] == i * 1e-6);
    pf_frame_data_release(&fr);
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK); /* END_ */
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_true(end);
    pf_stream_reader_destroy(&r);
    fclose(in);
    int status = 0;
    assert_int_equal(waitpid(child, &status, 0), child);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* An output that fails mid-chunk (a full disk) fails every later write too. */
static void test_writer_stops_after_a_failed_write(void **state)
{
    (void)state;
    char space[64];
    FILE *f = fmemopen(space, sizeof space, "wb"); /* room for 64 bytes, then writes fail */
    assert_non_null(f);
    setvbuf(f, NULL, _IONBF, 0);
    pf_error err = {0};
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "full.pfs", &err), PF_OK);
    static const char BIG[100] = {0};
    assert_int_equal(pf_stream_write_chunk(w, "XTRA", 1, BIG, sizeof BIG, &err), PF_ERR_IO);
    expect_msg(&err, "full.pfs: cannot write chunk XTRA at byte 8");
    assert_int_equal(pf_stream_write_chunk(w, "XTRA", 1, "x", 1, &err), PF_ERR_IO);
    expect_msg(&err, "an earlier write failed");
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_ERR_IO);
    pf_stream_writer_destroy(&w);
    fclose(f);
    /* No room even for the signature. */
    f = fmemopen(space, 4, "wb");
    assert_non_null(f);
    setvbuf(f, NULL, _IONBF, 0);
    assert_int_equal(pf_stream_writer_create(&w, f, "tiny.pfs", &err), PF_ERR_IO);
    expect_msg(&err, "tiny.pfs: cannot write the signature");
    assert_null(w);
    fclose(f);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A reader on a pipe gets each chunk as soon as the writer returns: the writer flushes. */
static void test_writer_flushes_every_chunk(void **state)
{
    (void)state;
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    FILE *out = fdopen(fd[1], "wb"), *in = fdopen(fd[0], "rb");
    assert_true(out && in);
    pf_error err = {0};
    pf_stream_writer *w = NULL;
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_writer_create(&w, out, "pipe", &err), PF_OK);
    assert_int_equal(pf_stream_reader_create(&r, in, "pipe", &err), PF_OK);
    pf_frame_data fr = {0};
    assert_int_equal(pf_frame_data_alloc(&fr, 2, &err), PF_OK);
    for (uint32_t k = 0; k < 3; ++k) {
        fr.index = k;
        fr.time = k;
        for (int i = 0; i < 6; ++i)
            fr.u[i] = k + 0.5 * i;
        assert_int_equal(pf_stream_write_frame(w, &fr, &err), PF_OK);
        /* Were the frame still in the writer's stdio buffer, this read would block forever. */
        pf_chunk c;
        bool end = false;
        assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
        pf_frame_data got = {0};
        assert_int_equal(pf_stream_decode_frame(&c, &got, &err), PF_OK);
        assert_int_equal(got.index, k);
        assert_memory_equal(got.u, fr.u, sizeof(double) * 6);
        pf_frame_data_release(&got);
    }
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    fclose(out);
    pf_chunk c;
    bool end = false;
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_string_equal(c.tag, "END_");
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_true(end);
    pf_frame_data_release(&fr);
    pf_stream_writer_destroy(&w);
    pf_stream_reader_destroy(&r);
    fclose(in);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_is_byte_exact),
        cmocka_unit_test(test_pass_through_is_byte_for_byte),
        cmocka_unit_test(test_tag_table),
        cmocka_unit_test(test_crc_check_value),
        cmocka_unit_test(test_mesh_counts_beyond_the_payload),
        cmocka_unit_test(test_mesh_non_finite_coordinate),
        cmocka_unit_test(test_mesh_index_out_of_range),
        cmocka_unit_test(test_mesh_offsets_must_start_at_zero_and_not_decrease),
        cmocka_unit_test(test_other_chunks_refuse_bad_payloads),
        cmocka_unit_test(test_writer_refuses_what_no_reader_would_take),
        cmocka_unit_test(test_large_chunks_through_a_pipe),
        cmocka_unit_test(test_writer_stops_after_a_failed_write),
        cmocka_unit_test(test_writer_flushes_every_chunk),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
