/* stream: byte-exact round trip and pass-through, the documented layout, and every kind of damaged
 * input (signature, truncation, sizes, CRC, versions, tags, counts, offsets, indices, numbers). */
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

/* ---- helpers --------------------------------------------------------------------------------- */

static void expect_msg(const pf_error *err, const char *needle)
{
    if (!strstr(err->msg, needle))
        fail_msg("message '%s' lacks '%s'", err->msg, needle);
}

/* CRC-32 bit by bit (reflected polynomial 0xedb88320, initial and final xor 0xffffffff): an
 * oracle independent of zlib. */
static uint32_t crc32_bitwise(const unsigned char *p, size_t n)
{
    uint32_t crc = 0xffffffffu;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int b = 0; b < 8; ++b)
            crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

/* The test's own little-endian access, so that the layout is checked against the spec. */
static uint64_t rd(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i)
        v = v << 8 | p[i];
    return v;
}

static void wr(unsigned char *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; ++i, v >>= 8)
        p[i] = (unsigned char)v;
}

static void wr_f64(unsigned char *p, double d)
{
    uint64_t bits;
    memcpy(&bits, &d, sizeof bits);
    wr(p, bits, 8);
}

/* Every byte of f from its start. */
static void slurp(FILE *f, pf_buffer *out)
{
    pf_error err = {0};
    unsigned char piece[4096];
    out->size = 0;
    rewind(f);
    for (size_t n; (n = fread(piece, 1, sizeof piece, f)) > 0;)
        assert_int_equal(pf_buffer_append(out, piece, n, &err), PF_OK);
    rewind(f);
}

static FILE *file_with(const unsigned char *bytes, size_t n)
{
    bytes = bytes ? bytes : (const unsigned char *)""; /* never NULL, even for no bytes */
    FILE *f = tmpfile();
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    rewind(f);
    return f;
}

/* A pipe holding the bytes with its writing end closed: read like `cat file | tool`. */
static FILE *pipe_with(const unsigned char *bytes, size_t n)
{
    bytes = bytes ? bytes : (const unsigned char *)"";
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    assert_true(n < 65536); /* Linux pipe capacity: the write below cannot block */
    assert_int_equal(write(fd[1], bytes, n), (ssize_t)n);
    close(fd[1]);
    FILE *f = fdopen(fd[0], "rb");
    assert_non_null(f);
    return f;
}

/* Offsets of the chunk headers in a stream, walked with the spec's framing. */
static int chunk_offsets(const pf_buffer *b, size_t *offs, int max)
{
    int n = 0;
    for (size_t pos = PF_STREAM_SIGNATURE_BYTES; pos + 16 <= b->size && n < max; ++n) {
        offs[n] = pos;
        pos += 16 + (size_t)rd(b->data + pos + 8, 8) + 4;
    }
    return n;
}

typedef struct chunk_record {
    char tag[5];
    uint32_t version;
    uint64_t size;
    uint32_t crc;
} chunk_record;

typedef struct read_result {
    pf_status status;
    pf_error err;
    int n;                /* chunks returned, END_ included */
    chunk_record rec[32]; /* the first of them */
    int64_t live_at_failure;
} read_result;

static pf_status decode_known(const pf_chunk *c, pf_error *err)
{
    pf_status s = PF_OK;
    if (strcmp(c->tag, "MESH") == 0) {
        pf_mesh m = {0};
        s = pf_stream_decode_mesh(c, &m, err);
        pf_mesh_release(&m);
    } else if (strcmp(c->tag, "SURF") == 0) {
        pf_surface v = {0};
        s = pf_stream_decode_surface(c, &v, err);
        pf_surface_release(&v);
    } else if (strcmp(c->tag, "WGHT") == 0) {
        pf_weights w = {0};
        s = pf_stream_decode_weights(c, &w, err);
        pf_weights_release(&w);
    } else if (strcmp(c->tag, "FRAM") == 0) {
        pf_frame_data fr = {0};
        s = pf_stream_decode_frame(c, &fr, err);
        pf_frame_data_release(&fr);
    } else if (strcmp(c->tag, "STRS") == 0) {
        pf_stress_data st = {0};
        s = pf_stream_decode_stress(c, &st, err);
        pf_stress_data_release(&st);
    } else if (strcmp(c->tag, "INFO") == 0) {
        pf_info_data d = {0};
        s = pf_stream_decode_info(c, &d, err);
        pf_info_data_release(&d);
    } else if (strcmp(c->tag, "SCEN") == 0) {
        char *json = NULL;
        size_t n = 0;
        s = pf_stream_decode_scene(c, &json, &n, err);
        pf_free(json);
    } else if (strcmp(c->tag, "END_") == 0) {
        pf_end_data d;
        s = pf_stream_decode_end(c, &d, err);
    }
    return s;
}

/* Reads f to its end, decoding every known chunk; closes f. */
static void read_all(FILE *f, const char *name, read_result *out)
{
    memset(out, 0, sizeof *out);
    pf_stream_reader *r = NULL;
    out->status = pf_stream_reader_create(&r, f, name, &out->err);
    for (bool end = false; out->status == PF_OK && !end;) {
        pf_chunk c;
        out->status = pf_stream_read_chunk(r, &c, &end, &out->err);
        if (out->status < 0)
            out->live_at_failure = pf_alloc_live_bytes();
        if (out->status < 0 || end)
            break;
        if (out->n < 32) {
            chunk_record *k = &out->rec[out->n];
            memcpy(k->tag, c.tag, 5);
            k->version = c.version;
            k->size = c.size;
            k->crc = c.crc;
        }
        out->n++;
        out->status = decode_known(&c, &out->err);
    }
    pf_stream_reader_destroy(&r);
    fclose(f);
}

static void read_bytes(const pf_buffer *b, size_t n, bool through_pipe, read_result *out)
{
    read_all(through_pipe ? pipe_with(b->data, n) : file_with(b->data, n), "t.pfs", out);
}

/* ---- a stream with every kind of chunk
 * ----------------------------------------------------------- */

typedef struct fixture {
    pf_mesh mesh;
    pf_surface surf;
    pf_weights wght;
    pf_frame_data frames[3];
    pf_stress_data stress[2]; /* von Mises of frame 1, the full tensor of frame 2 */
} fixture;

static const char SCENE[] = "{\"gravity\": [0, 0, -9.81], \"name\": \"caf\xc3\xa9\"}";
static const char COMMAND[] = "pf-sim sc\xc3\xa8ne.json --frames 3";
static const unsigned char XTRA[] = {0, 1, 2, 0xff, 0x89, 'P', 'F', 'S'};
static const char *const FIXTURE_TAGS[] = {"INFO", "SCEN", "MESH", "SURF", "WGHT", "XTRA", "FRAM",
                                           "FRAM", "STRS", "FRAM", "STRS", "zero", "END_"};
enum { FIXTURE_CHUNKS = 13 };

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

/* ---- a small stream for damage tests: INFO, a one-tet MESH, two FRAMs, END_
 * ---------------------- */

enum { SMALL_INFO, SMALL_MESH, SMALL_FRAME0, SMALL_FRAME1, SMALL_END, SMALL_CHUNKS };

static void small_stream(pf_buffer *out, bool finish)
{
    static const double X[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const uint32_t TET[] = {0, 1, 2, 3};
    pf_error err = {0};
    pf_mesh m = {0};
    assert_int_equal(pf_mesh_from_tets(&m, X, 4, TET, 1, &err), PF_OK);
    m.id = 3;
    FILE *f = tmpfile();
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, f, "small", &err), PF_OK);
    assert_int_equal(pf_stream_write_info(w, "t", "1", "t --x", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(w, &m, &err), PF_OK);
    for (uint32_t k = 0; k < 2; ++k) {
        pf_frame_data fr = {0};
        assert_int_equal(pf_frame_data_alloc(&fr, 4, &err), PF_OK);
        fr.mesh_id = 3;
        fr.index = k;
        fr.time = 0.25 * k;
        for (int i = 0; i < 12; ++i)
            fr.u[i] = 0.01 * i * (k + 1);
        assert_int_equal(pf_stream_write_frame(w, &fr, &err), PF_OK);
        pf_frame_data_release(&fr);
    }
    if (finish)
        assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    slurp(f, out);
    fclose(f);
    pf_mesh_release(&m);
}

/* Recomputes the CRC of the chunk at off after its payload was edited. */
static void fix_crc(pf_buffer *b, size_t off)
{
    size_t size = (size_t)rd(b->data + off + 8, 8);
    wr(b->data + off + 16 + size, crc32_bitwise(b->data + off + 16, size), 4);
}

static void test_empty_input_and_bad_signature(void **state)
{
    (void)state;
    read_result res;
    read_all(file_with(NULL, 0), "mesh.pfs", &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, "mesh.pfs: empty input, expected a pf stream");
    read_all(pipe_with(NULL, 0), "stdin", &res);
    assert_string_equal(res.err.msg, "stdin: empty input, expected a pf stream");

    /* A directory opens, but reading it fails: an i/o error, not a format error. */
    read_all(fopen(".", "rb"), "dir", &res);
    assert_int_equal(res.status, PF_ERR_IO);
    expect_msg(&res.err, "dir: read error at byte 0");

    static const char TEXT[] = "solid cube\nfacet normal 0 0 1\n";
    read_all(file_with((const unsigned char *)TEXT, sizeof TEXT - 1), "cube.stl", &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, "cube.stl: not a pf stream (bad signature)");
    read_all(file_with((const unsigned char *)"\x89PF", 3), "short", &res);
    expect_msg(&res.err, "short: not a pf stream (bad signature)");
    /* A text-mode transfer turned "\r\n" into "\n": the hint says so. */
    static const unsigned char MANGLED[] = {0x89, 'P', 'F', 'S', '\n', 0x1a, '\n', 'I', 'N'};
    read_all(file_with(MANGLED, sizeof MANGLED), "mangled", &res);
    expect_msg(&res.err, "mangled: not a pf stream (bad signature)");
    expect_msg(&res.err, "text-mode");
    /* A signature and nothing else. */
    pf_buffer b = {0};
    small_stream(&b, true);
    read_bytes(&b, 8, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, "t.pfs: truncated after the signature at byte 8");
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A stream without END_ (a producer that died): every chunk before is returned, then the error. */
static void test_truncated_after_a_chunk(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, false);
    size_t offs[8];
    assert_int_equal(chunk_offsets(&b, offs, 8), SMALL_CHUNKS - 1);
    char want[160];
    snprintf(want, sizeof want,
             "t.pfs: truncated after chunk FRAM #4 at byte %zu (no END_ chunk); 2 frames read",
             offs[SMALL_FRAME1]);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_FORMAT);
        assert_string_equal(res.err.msg, want);
        assert_int_equal(res.n, 4); /* INFO MESH FRAM FRAM all decoded before the error */
    }
    /* Cut after the first frame: one frame read. */
    read_result res;
    read_bytes(&b, offs[SMALL_FRAME1], false, &res);
    snprintf(want, sizeof want,
             "truncated after chunk FRAM #3 at byte %zu (no END_ chunk); 1 frame read",
             offs[SMALL_FRAME0]);
    expect_msg(&res.err, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_truncated_inside_a_chunk(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    size_t cut = offs[SMALL_MESH] + 16 + 50; /* 50 bytes into the MESH payload */
    char want[96];
    snprintf(want, sizeof want, "t.pfs: truncated inside chunk MESH at byte %zu", offs[SMALL_MESH]);
    read_result res;
    read_bytes(&b, cut, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, want);
    expect_msg(&res.err, "only 50 bytes remain");
    assert_int_equal(res.n, 1);
    read_bytes(&b, cut, true, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, want);
    expect_msg(&res.err, "the input ended after 50 of its");
    /* Inside the header of the second frame, and inside its CRC. */
    read_bytes(&b, offs[SMALL_FRAME1] + 10, true, &res);
    snprintf(want, sizeof want,
             "truncated inside the header of chunk FRAM at byte %zu; 1 frame read",
             offs[SMALL_FRAME1]);
    expect_msg(&res.err, want);
    read_bytes(&b, offs[SMALL_END] - 2, true, &res);
    snprintf(want, sizeof want, "truncated inside chunk FRAM at byte %zu", offs[SMALL_FRAME1]);
    expect_msg(&res.err, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* A size claiming 2^60 bytes: refused before allocating, from a file and from a pipe. */
static void test_huge_size_is_refused_without_allocating(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    wr(b.data + offs[SMALL_MESH] + 8, 1ull << 60, 8);
    char want[96];
    snprintf(want, sizeof want, "truncated inside chunk MESH at byte %zu", offs[SMALL_MESH]);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_FORMAT);
        expect_msg(&res.err, want);
        expect_msg(&res.err, "1152921504606846976");
        /* A file is measured first: nothing allocated for the payload. A pipe's buffer grows
         * only as bytes arrive: at most 128 KiB (twice the 64 KiB first piece) here, while the
         * whole input is under 1 KiB. */
        assert_true(res.live_at_failure < 256 * 1024);
    }
    /* Beyond any address space: PF_ERR_TOO_LARGE, naming the chunk. */
    wr(b.data + offs[SMALL_MESH] + 8, UINT64_MAX - 2, 8);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe) {
        read_result res;
        read_bytes(&b, b.size, through_pipe, &res);
        assert_int_equal(res.status, PF_ERR_TOO_LARGE);
        expect_msg(&res.err, "chunk MESH at byte");
    }
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_crc_mismatch_is_named(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    size_t payload = offs[SMALL_MESH] + 16, size = (size_t)rd(b.data + offs[SMALL_MESH] + 8, 8);
    uint32_t stored = (uint32_t)rd(b.data + payload + size, 4);
    b.data[payload + 33] ^= 0x10;
    uint32_t computed = crc32_bitwise(b.data + payload, size);
    char want[160];
    snprintf(want, sizeof want,
             "t.pfs: chunk MESH at byte %zu: CRC mismatch (stored 0x%08lx, computed 0x%08lx)",
             offs[SMALL_MESH], (unsigned long)stored, (unsigned long)computed);
    read_result res;
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    assert_string_equal(res.err.msg, want);
    assert_int_equal(res.n, 1);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* After a failure every later read repeats it. */
static void test_reader_repeats_its_error(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    b.data[b.size - 1] ^= 1; /* END_'s CRC */
    FILE *f = file_with(b.data, b.size);
    pf_error err = {0}, again = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "t.pfs", &err), PF_OK);
    pf_chunk c;
    bool end = false;
    pf_status s;
    while ((s = pf_stream_read_chunk(r, &c, &end, &err)) == PF_OK && !end)
        ;
    assert_int_equal(s, PF_ERR_FORMAT);
    expect_msg(&err, "chunk END_");
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &again), PF_ERR_FORMAT);
    assert_string_equal(again.msg, err.msg);
    assert_false(end);
    pf_stream_reader_destroy(&r);
    fclose(f);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_versions_and_tags(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    /* Version 7 of MESH: read (it could be passed on), refused when decoded. */
    wr(b.data + offs[SMALL_MESH] + 4, 7, 4);
    FILE *f = file_with(b.data, b.size);
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, f, "t.pfs", &err), PF_OK);
    pf_chunk c;
    bool end = false;
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_int_equal(pf_stream_read_chunk(r, &c, &end, &err), PF_OK);
    assert_int_equal(c.version, 7);
    pf_mesh m = {0};
    assert_int_equal(pf_stream_decode_mesh(&c, &m, &err), PF_ERR_UNSUPPORTED);
    char want[96];
    /* A chunk from a reader names the stream first, so every decoder message names the input. */
    snprintf(want, sizeof want,
             "t.pfs: chunk MESH at byte %zu: version 7 not supported (this pf reads 1)",
             offs[SMALL_MESH]);
    assert_string_equal(err.msg, want);
    assert_int_equal(pf_stream_check_version(&c, &err), PF_ERR_UNSUPPORTED);
    pf_stream_reader_destroy(&r);
    fclose(f);
    /* A tag that is not printable ASCII. */
    wr(b.data + offs[SMALL_MESH] + 4, 1, 4);
    b.data[offs[SMALL_MESH] + 2] = 0x01;
    read_result res;
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    snprintf(want, sizeof want, "t.pfs: bad chunk tag 0x4d450148 at byte %zu", offs[SMALL_MESH]);
    expect_msg(&res.err, want);
    b.data[offs[SMALL_MESH] + 2] = 0x7f;
    read_bytes(&b, b.size, true, &res);
    expect_msg(&res.err, "bad chunk tag");
    /* Decoding a chunk as the wrong kind is a caller's mistake. */
    pf_chunk info = {.tag = "INFO", .version = 1, .size = 0, .offset = 8};
    assert_int_equal(pf_stream_decode_mesh(&info, &m, &err), PF_ERR_INVALID);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

static void test_end_must_match_and_close_the_stream(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    read_result res;
    /* END_ counts one chunk too many: a chunk was dropped on the way. */
    wr(b.data + offs[SMALL_END] + 16, SMALL_CHUNKS, 8);
    fix_crc(&b, offs[SMALL_END]);
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    expect_msg(&res.err, "counts 5 chunks and 2 frames, the stream had 4 and 2");
    wr(b.data + offs[SMALL_END] + 16, SMALL_CHUNKS - 1, 8);
    fix_crc(&b, offs[SMALL_END]);
    read_bytes(&b, b.size, false, &res);
    assert_int_equal(res.status, PF_OK);
    /* An END_ one byte too long. */
    pf_buffer longer = {0};
    pf_error err = {0};
    size_t end_crc = offs[SMALL_END] + 16 + 16;
    assert_int_equal(pf_buffer_append(&longer, b.data, end_crc, &err), PF_OK);
    assert_int_equal(pf_buffer_append(&longer, "\0\0\0\0\0", 5, &err), PF_OK);
    wr(longer.data + offs[SMALL_END] + 8, 17, 8);
    fix_crc(&longer, offs[SMALL_END]);
    read_bytes(&longer, longer.size, false, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    char want[96];
    snprintf(want, sizeof want, "t.pfs: chunk END_ at byte %zu: 1 trailing bytes", offs[SMALL_END]);
    expect_msg(&res.err, want);
    pf_buffer_release(&longer);
    /* Bytes after END_. */
    assert_int_equal(pf_buffer_append(&b, "\x89PFS", 4, &err), PF_OK);
    read_bytes(&b, b.size, true, &res);
    assert_int_equal(res.status, PF_ERR_FORMAT);
    snprintf(want, sizeof want, "t.pfs: unexpected data at byte %zu, after the END_ chunk",
             b.size - 4);
    assert_string_equal(res.err.msg, want);
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Every prefix of a valid stream is an error (never a crash, never a clean end), from a file and
 * from a pipe; only the whole stream ends cleanly. */
static void test_every_truncation_is_an_error(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    for (int through_pipe = 0; through_pipe < 2; ++through_pipe)
        for (size_t n = 0; n <= b.size; ++n) {
            read_result res;
            read_bytes(&b, n, through_pipe, &res);
            if (n < b.size && res.status != PF_ERR_FORMAT)
                fail_msg("prefix of %zu bytes: status %d, message '%s'", n, res.status,
                         res.err.msg);
            if (n == b.size)
                assert_int_equal(res.status, PF_OK);
        }
    pf_buffer_release(&b);
    assert_int_equal(pf_alloc_live_bytes(), 0);
}

/* Every byte of a valid stream altered: detected by the signature, the framing, the CRC, the END_
 * counts or the decoders. The CRC covers payloads only, so one change is not detectable: a tag
 * altered into another printable tag reads as an unknown chunk (it can never become another known
 * tag: all known tags differ in at least two characters). The test checks that it is exactly that.
 */
static void test_every_flipped_byte_is_detected(void **state)
{
    (void)state;
    pf_buffer b = {0};
    small_stream(&b, true);
    size_t offs[8];
    chunk_offsets(&b, offs, 8);
    read_result ref;
    read_bytes(&b, b.size, false, &ref);
    assert_int_equal(ref.status, PF_OK);
    assert_int_equal(ref.n, SMALL_CHUNKS);
    static const unsigned char MASKS[] = {0x01, 0x20, 0x80, 0xff};
    int renamed = 0;
    for (size_t pos = 0; pos < b.size; ++pos)
        for (size_t m = 0; m < sizeof MASKS; ++m) {
            b.data[pos] ^= MASKS[m];
            read_result res;
            read_bytes(&b, b.size, pos % 2 == 1, &res);
            b.data[pos] ^= MASKS[m];
            if (res.status < 0)
                continue;
            /* Undetected: must be a tag byte, the chunk otherwise identical, its tag unknown. */
            int k = 0;
            while (k < SMALL_CHUNKS - 1 && offs[k + 1] <= pos)
                ++k;
            if (pos < offs[k] || pos >= offs[k] + 4)
                fail_msg("byte %zu ^ 0x%02x went undetected", pos, MASKS[m]);
            assert_int_equal(res.n, SMALL_CHUNKS);
            for (int i = 0; i < SMALL_CHUNKS; ++i) {
                assert_int_equal(res.rec[i].size, ref.rec[i].size);
                assert_int_equal(res.rec[i].crc, ref.rec[i].crc);
                if (i == k) {
                    assert_false(pf_stream_tag_is_known(res.rec[i].tag));
                    assert_string_not_equal(res.rec[i].tag, "FRAM");
                } else {
                    assert_string_equal(res.rec[i].tag, ref.rec[i].tag);
                }
            }
            renamed++;
        }
    /* Exactly the 8 bytes of the INFO and MESH tags under the masks 0x01 and 0x20, which keep an
     * upper-case letter printable (0x80 and 0xff do not). A renamed FRAM is caught by the END_
     * counts, a renamed END_ as a truncation. */
    assert_int_equal(renamed, 8 * 2);
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
        cmocka_unit_test(test_empty_input_and_bad_signature),
        cmocka_unit_test(test_truncated_after_a_chunk),
        cmocka_unit_test(test_truncated_inside_a_chunk),
        cmocka_unit_test(test_huge_size_is_refused_without_allocating),
        cmocka_unit_test(test_crc_mismatch_is_named),
        cmocka_unit_test(test_reader_repeats_its_error),
        cmocka_unit_test(test_versions_and_tags),
        cmocka_unit_test(test_end_must_match_and_close_the_stream),
        cmocka_unit_test(test_every_truncation_is_an_error),
        cmocka_unit_test(test_every_flipped_byte_is_detected),
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
