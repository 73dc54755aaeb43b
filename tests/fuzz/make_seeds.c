/* Writes the seed corpus of the stream fuzzer into a directory: tiny valid streams with every kind
 * of chunk, and damaged ones that reach each check of the reader and the decoders (damaged payloads
 * get a correct CRC, so that the decoder, not the CRC, meets them). Deterministic: running it again
 * rewrites the same bytes. Usage: fuzz_stream_seeds DIR */
#define _POSIX_C_SOURCE 200809L /* open_memstream */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/io.h>

typedef struct bytes {
    unsigned char *data;
    size_t size;
} bytes;

static void die(const char *what, const pf_error *err)
{
    fprintf(stderr, "fuzz_stream_seeds: %s%s%s\n", what, err ? ": " : "", err ? err->msg : "");
    exit(1);
}

static void check(pf_status s, const char *what, const pf_error *err)
{
    if (s != PF_OK)
        die(what, err);
}

/* CRC-32 bit by bit (reflected polynomial 0xedb88320). */
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

static uint64_t rd(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i)
        v = v << 8 | p[i];
    return v;
}

static void wr(unsigned char *p, uint64_t v, int n)
{
    for (int i = 0; i < n; ++i, v >>= 8)
        p[i] = (unsigned char)v;
}

/* Offset of the k-th chunk header (from 0). */
static size_t chunk_at(const bytes *b, int k)
{
    size_t pos = PF_STREAM_SIGNATURE_BYTES;
    for (int i = 0; i < k; ++i)
        pos += 16 + (size_t)rd(b->data + pos + 8, 8) + 4;
    return pos;
}

static void fix_crc(bytes *b, size_t chunk)
{
    size_t size = (size_t)rd(b->data + chunk + 8, 8);
    wr(b->data + chunk + 16 + size, crc32_bitwise(b->data + chunk + 16, size), 4);
}

static const double TET_X[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const uint32_t TET[] = {0, 1, 2, 3};
static const uint32_t TET_TRI[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

enum {
    FULL_INFO,
    FULL_SCEN,
    FULL_MESH,
    FULL_SURF,
    FULL_WGHT,
    FULL_XTRA,
    FULL_FRAM0,
    FULL_STRS1,
    FULL_FRAM1,
    FULL_STRS6,
    FULL_STAT,
    FULL_END
};

/* The SURF of full_stream with its last triangle a cap (SURF version 2). */
static bool with_cap;

/* INFO SCEN MESH SURF WGHT XTRA FRAM STRS(1) FRAM STRS(6) END_ on one tetrahedron. */
static bytes full_stream(bool finish)
{
    pf_error err = {0};
    bytes b = {0};
    FILE *f = open_memstream((char **)&b.data, &b.size);
    pf_stream_writer *w = NULL;
    check(pf_stream_writer_create(&w, f, "seed", &err), "writer", &err);
    check(pf_stream_write_info(w, "seed", "1", "seed --all", &err), "INFO", &err);
    check(pf_stream_write_scene(w, "{\"dt\": 0.01}", 12, &err), "SCEN", &err);
    pf_mesh m = {0};
    check(pf_mesh_from_tets(&m, TET_X, 4, TET, 1, &err), "tet", &err);
    m.id = 1;
    check(pf_stream_write_mesh(w, &m, &err), "MESH", &err);
    pf_surface s = {0};
    check(pf_surface_alloc(&s, 4, 4, &err), "surface", &err);
    s.id = 2;
    memcpy(s.x, TET_X, sizeof TET_X);
    memcpy(s.tri, TET_TRI, sizeof TET_TRI);
    if (with_cap) {
        s.tri_part = pf_calloc(4, 1);
        if (!s.tri_part)
            die("surface parts", NULL);
        s.tri_part[3] = PF_SURFACE_CAP;
    }
    check(pf_stream_write_surface(w, &s, &err), "SURF", &err);
    pf_weights wt = {0};
    check(pf_weights_alloc(&wt, 4, 4, 4, &err), "weights", &err);
    wt.surface_id = 2;
    wt.mesh_id = 1;
    for (int i = 0; i < 4; ++i) {
        wt.row_offsets[i + 1] = i + 1;
        wt.col[i] = (uint32_t)i;
        wt.val[i] = 1.0;
    }
    check(pf_stream_write_weights(w, &wt, &err), "WGHT", &err);
    check(pf_stream_write_chunk(w, "XTRA", 2, "\x01\x02\x03", 3, &err), "XTRA", &err);
    for (int k = 0; k < 2; ++k) {
        pf_frame_data fr = {0};
        check(pf_frame_data_alloc(&fr, 4, &err), "frame", &err);
        fr.mesh_id = 1;
        fr.index = (uint32_t)k;
        fr.time = 0.01 * k;
        for (int i = 0; i < 12; ++i)
            fr.u[i] = 0.001 * i * k;
        check(pf_stream_write_frame(w, &fr, &err), "FRAM", &err);
        pf_frame_data_release(&fr);
        pf_stress_data st = {0};
        check(pf_stress_data_alloc(&st, 1, k ? 6 : 1, &err), "stress", &err);
        st.mesh_id = 1;
        st.frame = (uint32_t)k;
        for (int i = 0; i < st.components; ++i)
            st.values[i] = 1e3 * (i + 1);
        check(pf_stream_write_stress(w, &st, &err), "STRS", &err);
        pf_stress_data_release(&st);
    }
    pf_stats_data sd = {0};
    check(pf_stats_data_set_text(&sd, "method", "dg", &err), "stats", &err);
    check(pf_stats_data_set_number(&sd, "error_indicator", 0.0125, &err), "stats", &err);
    check(pf_stream_write_stats(w, &sd, &err), "STAT", &err);
    pf_stats_data_release(&sd);
    if (finish)
        check(pf_stream_writer_finish(w, &err), "END_", &err);
    pf_stream_writer_destroy(&w);
    fclose(f);
    pf_mesh_release(&m);
    pf_surface_release(&s);
    pf_weights_release(&wt);
    return b;
}

static void save(const char *dir, const char *name, const bytes *b)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b->data, 1, b->size, f) != b->size || fclose(f) != 0)
        die(path, NULL);
}

/* A copy of the full stream with one edit, saved under name. */
typedef void edit_fn(bytes *b);

static void save_edited(const char *dir, const char *name, edit_fn *edit)
{
    bytes b = full_stream(true);
    edit(&b);
    save(dir, name, &b);
    free(b.data);
}

static void payload_flip(bytes *b)
{
    b->data[chunk_at(b, FULL_MESH) + 16 + 30] ^= 0x04;
}
static void huge_size(bytes *b)
{
    wr(b->data + chunk_at(b, FULL_MESH) + 8, 1ull << 60, 8);
}
static void version7(bytes *b)
{
    wr(b->data + chunk_at(b, FULL_MESH) + 4, 7, 4);
}
static void bad_tag(bytes *b)
{
    b->data[chunk_at(b, FULL_SURF) + 1] = 0x07;
}
static void cut_mesh(bytes *b)
{
    b->size = chunk_at(b, FULL_MESH) + 40;
}
static void cut_crc(bytes *b)
{
    b->size = chunk_at(b, FULL_END) - 2;
}

static void end_miscount(bytes *b)
{
    size_t end = chunk_at(b, FULL_END);
    wr(b->data + end + 16, 3, 8);
    fix_crc(b, end);
}

/* MESH payload: id u64, n_nodes u32 @8, n_faces u32 @12, n_elems u32 @16, x @20 (4 nodes),
 * face_offsets @116 (5 u64), face_nodes @156 (12 u32), elem_offsets @204 (2 u64),
 * elem_faces @220 (4 u32). */
static void mesh_edit(bytes *b, size_t at, uint64_t value, int width)
{
    size_t c = chunk_at(b, FULL_MESH);
    wr(b->data + c + 16 + at, value, width);
    fix_crc(b, c);
}
static void mesh_huge_nodes(bytes *b)
{
    mesh_edit(b, 8, 0xffffffffu, 4);
}
static void mesh_huge_faces(bytes *b)
{
    mesh_edit(b, 12, 0xffffffffu, 4);
}
static void mesh_nan(bytes *b)
{
    mesh_edit(b, 20 + 8 * 4, 0x7ff8000000000000ull, 8);
}
static void mesh_decreasing(bytes *b)
{
    mesh_edit(b, 116 + 8 * 2, 2, 8);
}
static void mesh_nonzero_start(bytes *b)
{
    mesh_edit(b, 204, 1, 8);
}
static void mesh_node_range(bytes *b)
{
    mesh_edit(b, 156 + 4 * 5, 4, 4);
}
static void mesh_face_range(bytes *b)
{
    mesh_edit(b, 220 + 4 * 3, 0x80000004u, 4);
}
static void mesh_last_offset(bytes *b)
{
    mesh_edit(b, 116 + 8 * 4, 1ull << 62, 8);
}

static void payload_edit(bytes *b, int chunk, size_t at, uint64_t value, int width)
{
    size_t c = chunk_at(b, chunk);
    wr(b->data + c + 16 + at, value, width);
    fix_crc(b, c);
}
static void surf_range(bytes *b)
{
    payload_edit(b, FULL_SURF, 16 + 24 * 4 + 4 * 7, 9, 4);
}
static void wght_col(bytes *b)
{
    payload_edit(b, FULL_WGHT, 24 + 8 * 5 + 4, 77, 4);
}
static void fram_nan(bytes *b)
{
    payload_edit(b, FULL_FRAM1, 24 + 8 * 5, 0xfff0000000000000ull, 8);
}
static void strs_components(bytes *b)
{
    payload_edit(b, FULL_STRS6, 16, 3, 4);
}
/* SURF version 2 (with_cap): the parts after the 4 vertices and 4 triangles */
static void surf_part(bytes *b)
{
    payload_edit(b, FULL_SURF, 16 + 24 * 4 + 12 * 4 + 1, 7, 1);
}
static void info_utf8(bytes *b)
{
    payload_edit(b, FULL_INFO, 4, 0xff, 1);
}
static void info_length(bytes *b)
{
    payload_edit(b, FULL_INFO, 0, 0xfffffff0u, 4);
}
/* STAT: u32 n, then the first entry's key length */
static void stat_key_length(bytes *b)
{
    payload_edit(b, FULL_STAT, 4, 0xfffffff0u, 4);
}
static void stat_count(bytes *b)
{
    payload_edit(b, FULL_STAT, 0, 0xffffffffu, 4);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: fuzz_stream_seeds DIR\n");
        return 2;
    }
    const char *dir = argv[1];
    bytes full = full_stream(true), open = full_stream(false);
    save(dir, "valid-all-chunks.pfs", &full);
    save(dir, "no-end.pfs", &open);
    free(full.data);
    free(open.data);

    pf_error err = {0};
    bytes b = {0};
    FILE *f = open_memstream((char **)&b.data, &b.size);
    pf_stream_writer *w = NULL;
    check(pf_stream_writer_create(&w, f, "seed", &err), "writer", &err);
    check(pf_stream_writer_finish(w, &err), "END_", &err);
    pf_stream_writer_destroy(&w);
    fclose(f);
    save(dir, "valid-empty.pfs", &b);
    free(b.data);

    pf_mesh m = {0};
    check(pf_mesh_make_box(&m, pf_v3(0, 0, 0), pf_v3(2, 1, 1), 2, 1, 1, &err), "box", &err);
    b = (bytes){0};
    f = open_memstream((char **)&b.data, &b.size);
    check(pf_stream_writer_create(&w, f, "seed", &err), "writer", &err);
    check(pf_stream_write_mesh(w, &m, &err), "MESH", &err);
    check(pf_stream_writer_finish(w, &err), "END_", &err);
    pf_stream_writer_destroy(&w);
    fclose(f);
    save(dir, "valid-two-hexes.pfs", &b);
    free(b.data);
    pf_mesh_release(&m);

    static const struct {
        const char *name;
        edit_fn *edit;
    } EDITS[] = {
        {"crc-mismatch.pfs", payload_flip},
        {"size-2e60.pfs", huge_size},
        {"mesh-version-7.pfs", version7},
        {"bad-tag.pfs", bad_tag},
        {"cut-inside-mesh.pfs", cut_mesh},
        {"cut-inside-crc.pfs", cut_crc},
        {"end-miscount.pfs", end_miscount},
        {"mesh-nodes-ffffffff.pfs", mesh_huge_nodes},
        {"mesh-faces-ffffffff.pfs", mesh_huge_faces},
        {"mesh-nan.pfs", mesh_nan},
        {"mesh-offsets-decrease.pfs", mesh_decreasing},
        {"mesh-offsets-start.pfs", mesh_nonzero_start},
        {"mesh-node-range.pfs", mesh_node_range},
        {"mesh-face-range.pfs", mesh_face_range},
        {"mesh-last-offset-2e62.pfs", mesh_last_offset},
        {"surf-vertex-range.pfs", surf_range},
        {"wght-column-range.pfs", wght_col},
        {"fram-infinite.pfs", fram_nan},
        {"strs-3-components.pfs", strs_components},
        {"info-bad-utf8.pfs", info_utf8},
        {"info-length.pfs", info_length},
        {"stat-key-length.pfs", stat_key_length},
        {"stat-count-ffffffff.pfs", stat_count},
    };
    for (size_t i = 0; i < sizeof EDITS / sizeof EDITS[0]; ++i)
        save_edited(dir, EDITS[i].name, EDITS[i].edit);
    /* the caps of a cut: SURF version 2, valid and with a part that is neither */
    with_cap = true;
    bytes caps = full_stream(true);
    save(dir, "valid-caps.pfs", &caps);
    free(caps.data);
    save_edited(dir, "surf-part-7.pfs", surf_part);
    with_cap = false;
    static const unsigned char TEXT[] = "solid cube\nendsolid cube\n";
    bytes text = {(unsigned char *)TEXT, sizeof TEXT - 1};
    save(dir, "not-a-stream.stl", &text);
    return 0;
}
