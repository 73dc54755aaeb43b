/* pf/io.h: the pf stream (reader, writer, chunk codecs), surface and volume-mesh importers, and
 * exporters for ParaView (.vtu/.pvd) and Blender/Houdini (OBJ/PLY).
 *
 * The stream format is specified in docs/stream-format.md.
 */
#ifndef PF_IO_H
#define PF_IO_H

#include <stdbool.h>
#include <stdio.h>

#include <pf/base.h>
#include <pf/geom.h>
#include <pf/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== pf stream ================================================================================
 */

/* A pf stream is a signature followed by chunks (docs/stream-format.md):
 *
 *   signature  8 bytes  0x89 'P' 'F' 'S' '\r' '\n' 0x1a '\n'
 *   chunk      tag[4] | u32 version | u64 payload bytes | payload | u32 CRC-32 of the payload
 *
 * all little-endian, ending with an END_ chunk. The reader checks the framing, sizes and CRCs and
 * hands out raw chunks (known or not, any version) so that tools can pass on what they do not
 * consume; the codecs turn payloads into pf data and back, checking every count, offset, index and
 * number, and refuse versions they do not read (PF_ERR_UNSUPPORTED). Every error message names the
 * input, the chunk tag and the byte offset of the chunk header. */

enum {
    PF_STREAM_SIGNATURE_BYTES = 8, /* the signature at byte 0 */
    PF_STREAM_HEADER_BYTES = 16,   /* tag, version, payload size */
    PF_STREAM_CRC_BYTES = 4,       /* after the payload */
};

/* One chunk as read from a stream. */
typedef struct pf_chunk {
    char tag[5];            /* 4 printable ASCII characters and a terminating NUL */
    uint32_t version;       /* the chunk's own version */
    uint64_t size;          /* payload bytes */
    uint64_t offset;        /* byte offset of the chunk header from the start of the stream */
    unsigned char *payload; /* [size] bytes, owned by the reader, valid until its next read */
    uint32_t crc;           /* CRC-32 of the payload (already checked by the reader) */
    const char *source;     /* the stream's name for messages (borrowed from the reader, valid
                               while it lives); NULL for a chunk made by hand: no name */
} pf_chunk;

/* ---- the chunk table ----------------------------------------------------------------------------
 * Known tags: INFO SCEN MESH SURF WGHT FRAM STRS END_ GRPS CKPT STAT. Critical: a tool that
 * consumes such a chunk and cannot decode it (an unknown version) must stop rather than skip it
 * (SCEN MESH SURF WGHT FRAM END_). Mesh-dependent: refers to the nodes or elements of the latest
 * MESH and is dropped or recomputed by a tool that emits a new MESH (WGHT FRAM STRS GRPS CKPT).
 * Unknown tags are neither; tools pass them on byte for byte. tag is a NUL-terminated string;
 * anything but 4 characters is unknown. */
bool pf_stream_tag_is_known(const char *tag);
bool pf_stream_tag_is_critical(const char *tag);
bool pf_stream_tag_is_mesh_dependent(const char *tag);
/* The newest version of a known chunk that this pf reads and writes; 0 for an unknown tag. */
uint32_t pf_stream_tag_version(const char *tag);
/* Whether this pf's decoder reads version of the known chunk tag (SURF, CKPT: 1 and 2, others:
 * pf_stream_tag_version only); false for an unknown tag. */
bool pf_stream_version_is_read(const char *tag, uint32_t version);
/* PF_ERR_UNSUPPORTED (naming chunk, offset and versions) when c is a known chunk of a version this
 * pf does not read; PF_OK otherwise, unknown tags included. */
pf_status pf_stream_check_version(const pf_chunk *c, pf_error *err);

/* ---- reader ---------------------------------------------------------------------------------- */
typedef struct pf_stream_reader pf_stream_reader;

/* Reads and checks the signature from f (borrowed: f must outlive the reader; the reader never
 * closes it). name labels every message ("mesh.pfs", "stdin"); it is copied. Seekable inputs have
 * every chunk size checked against the bytes left in the file; for pipes the payload buffer grows
 * only as bytes actually arrive, so a damaged size never allocates more than the input holds.
 * Statuses: PF_ERR_FORMAT "NAME: empty input, expected a pf stream" or "NAME: not a pf stream (bad
 * signature)"; PF_ERR_IO; PF_ERR_NOMEM. On failure *r is NULL. */
pf_status pf_stream_reader_create(pf_stream_reader **r, FILE *f, const char *name, pf_error *err);

/* Reads the next chunk into *c, its CRC checked. Tags must be 4 printable ASCII characters; any
 * tag and any version is returned (use the codecs to decode, pf_stream_write_raw to pass on). The
 * END_ chunk is returned like the others (its counts checked against the chunks before it when it
 * is version 1); the read after it sets *end = true when the input ends there, and any byte after
 * END_ is a format error. Errors (PF_ERR_FORMAT unless said otherwise), each naming the input:
 * - input ends after a chunk without END_: "truncated after chunk FRAM #12 at byte N (no END_
 *   chunk); 3 frames read" (#12: the chunk's ordinal, from 1);
 * - input ends inside a chunk, or a size claims more bytes than the file holds: "truncated inside
 *   chunk FRAM at byte N ..."; a size beyond this machine's address space: PF_ERR_TOO_LARGE;
 * - "chunk MESH at byte N: CRC mismatch (stored 0x..., computed 0x...)";
 * - a tag that is not 4 printable ASCII characters; END_ counts that disagree; PF_ERR_IO, NOMEM.
 * Chunks returned before an error stay valid for the caller (they were complete and checked); after
 * an error every later call fails with the same message. */
pf_status pf_stream_read_chunk(pf_stream_reader *r, pf_chunk *c, bool *end, pf_error *err);

/* Chunks (END_ excluded) and FRAM chunks returned so far. */
void pf_stream_reader_counts(const pf_stream_reader *r, uint64_t *chunks, uint64_t *frames);

/* Frees the reader and its payload buffer and sets *r to NULL; safe on NULL. Does not close f. */
void pf_stream_reader_destroy(pf_stream_reader **r);

/* ---- writer ---------------------------------------------------------------------------------- */
typedef struct pf_stream_writer pf_stream_writer;

/* Writes the signature to f (borrowed, never closed). name labels messages ("stdout"); copied.
 * Statuses: PF_ERR_IO, PF_ERR_NOMEM. On failure *w is NULL. */
pf_status pf_stream_writer_create(pf_stream_writer **w, FILE *f, const char *name, pf_error *err);

/* Writes one chunk (header, payload of size bytes, CRC) and flushes f, so that a reader at the
 * other end of a pipe gets it at once. tag: 4 printable ASCII characters, not END_ (written by
 * pf_stream_writer_finish). payload may be NULL when size is 0. PF_ERR_INVALID for a bad tag or
 * a write after finish; PF_ERR_IO when f fails, and for every write after that (the output ends
 * inside a chunk and reads as truncated). */
pf_status pf_stream_write_chunk(pf_stream_writer *w, const char *tag, uint32_t version,
                                const void *payload, uint64_t size, pf_error *err);

/* Passes a chunk from a reader on byte for byte (same tag, version, payload and CRC).
 * PF_ERR_INVALID when c is END_ or its crc does not match its payload. */
pf_status pf_stream_write_raw(pf_stream_writer *w, const pf_chunk *c, pf_error *err);

/* Writes END_ with the number of chunks and of FRAM chunks written before it, and flushes. Later
 * writes fail. Without it a stream reads as truncated. */
pf_status pf_stream_writer_finish(pf_stream_writer *w, pf_error *err);

/* Frees the writer and sets *w to NULL; safe on NULL. Writes nothing (no END_), closes nothing. */
void pf_stream_writer_destroy(pf_stream_writer **w);

/* ---- chunk data ---------------------------------------------------------------------------------
 * The codecs below encode by appending a payload to a pf_buffer (its earlier contents are kept)
 * and decode from a chunk into a struct that the caller zero-initialised or released; the struct is
 * zero again after a failed decode. Encoders fail with PF_ERR_INVALID on data the decoder would
 * refuse (counts, indices, non-finite numbers), so a written stream always reads back. Decoders
 * fail with PF_ERR_INVALID when c has another tag, PF_ERR_UNSUPPORTED on an unknown version, and
 * PF_ERR_FORMAT (naming chunk, offset and entity) on bytes that do not form a valid payload. A
 * decoder checks memory safety and ranges only: a decoded mesh still wants pf_mesh_validate. */

/* INFO: who wrote the stream. */
typedef struct pf_info_data {
    char *producer; /* tool name, NUL-terminated UTF-8 */
    char *version;  /* producer version */
    char *command;  /* command line */
} pf_info_data;
void pf_info_data_release(pf_info_data *d);

/* END_: counts of the chunks before it. */
typedef struct pf_end_data {
    uint64_t chunk_count; /* chunks before END_, signature excluded */
    uint64_t frame_count; /* FRAM chunks among them */
} pf_end_data;

/* FRAM: nodal displacements of one frame. */
typedef struct pf_frame_data {
    uint64_t mesh_id; /* the MESH whose nodes these are */
    uint32_t index;   /* frame number */
    double time;      /* simulated time, seconds */
    int32_t n_nodes;
    double *u; /* [3 * n_nodes] displacements, model units */
} pf_frame_data;
pf_status pf_frame_data_alloc(pf_frame_data *f, int32_t n_nodes, pf_error *err);
void pf_frame_data_release(pf_frame_data *f);

/* STRS: per-element stress of one frame. */
typedef struct pf_stress_data {
    uint64_t mesh_id;
    uint32_t frame; /* the FRAM index it belongs to */
    int32_t n_elems;
    int32_t components; /* 1: von Mises; 6: xx yy zz xy yz zx */
    double *values;     /* [n_elems * components], element-major, stress units of the scene */
} pf_stress_data;
/* PF_ERR_INVALID unless components is 1 or 6 and n_elems >= 0. */
pf_status pf_stress_data_alloc(pf_stress_data *s, int32_t n_elems, int32_t components,
                               pf_error *err);
void pf_stress_data_release(pf_stress_data *s);

/* ---- codecs ---------------------------------------------------------------------------------- */
pf_status pf_stream_encode_info(const char *producer, const char *version, const char *command,
                                pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_scene(const char *json, size_t size, pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_mesh(const pf_mesh *m, pf_buffer *out, pf_error *err);
/* SURF: version 1 for a surface without cap triangles (tri_part NULL or all PF_SURFACE_MODEL),
 * version 2 (with the part of each triangle) otherwise: pf_stream_surface_version says which
 * layout pf_stream_encode_surface writes. pf_stream_decode_surface reads both; a version 1 chunk
 * gives tri_part NULL, a version 2 chunk the parts as stored. */
uint32_t pf_stream_surface_version(const pf_surface *s);
pf_status pf_stream_encode_surface(const pf_surface *s, pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_weights(const pf_weights *w, pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_frame(const pf_frame_data *f, pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_stress(const pf_stress_data *s, pf_buffer *out, pf_error *err);
pf_status pf_stream_encode_end(const pf_end_data *d, pf_buffer *out, pf_error *err);

/* Strings must be valid UTF-8 without NUL bytes. */
pf_status pf_stream_decode_info(const pf_chunk *c, pf_info_data *d, pf_error *err);
/* *json: a NUL-terminated copy of the scene (pf_free it), *size its length; NUL bytes refused. */
pf_status pf_stream_decode_scene(const pf_chunk *c, char **json, size_t *size, pf_error *err);
/* Offsets start at 0, never decrease and end at the array lengths; node, face, vertex and column
 * indices are in range; coordinates, displacements, weights and stresses are finite. */
pf_status pf_stream_decode_mesh(const pf_chunk *c, pf_mesh *m, pf_error *err);
pf_status pf_stream_decode_surface(const pf_chunk *c, pf_surface *s, pf_error *err);
pf_status pf_stream_decode_weights(const pf_chunk *c, pf_weights *w, pf_error *err);
pf_status pf_stream_decode_frame(const pf_chunk *c, pf_frame_data *f, pf_error *err);
/* The index of a FRAM chunk from its header alone, without decoding its displacements: a reader
 * that wants a range of frames skips the others cheaply. Checks the tag, version and header
 * size only (pf_stream_decode_frame checks the rest). */
pf_status pf_stream_frame_index(const pf_chunk *c, uint32_t *index, pf_error *err);
pf_status pf_stream_decode_stress(const pf_chunk *c, pf_stress_data *s, pf_error *err);
/* CKPT: pf-sim's checkpoint, a header (version 1: 16 bytes; version 2: 48, with the run's
 * counters) and the simulator's state (pf_sim_checkpoint). */
enum { PF_CHECKPOINT_HEADER_BYTES = 48, PF_CHECKPOINT_HEADER_BYTES_V1 = 16 };
/* What a run did up to a checkpoint, so that a resumed run's STAT counts the whole run. */
typedef struct pf_run_counts {
    uint64_t steps;          /* time steps */
    uint64_t factorisations; /* numeric factorisations, set-up included */
    uint64_t solves;         /* linear solves */
    uint64_t pcg_iterations; /* PCG iterations, all solves */
} pf_run_counts;
typedef struct pf_checkpoint_header {
    uint64_t mesh_id;           /* the MESH simulated */
    uint32_t frame;             /* the FRAM index it follows */
    uint32_t every;             /* the run's frames between checkpoints */
    pf_run_counts counts;       /* the run's counters at the checkpoint (version 2) */
    bool have_counts;           /* decode: false for a version 1 chunk (counts zero) */
    const unsigned char *state; /* decode: the simulator's state in the payload (borrowed) */
    uint64_t state_size;
} pf_checkpoint_header;
/* Checks the tag, version (1 or 2) and header size only (pf_sim_restore checks the state). */
pf_status pf_stream_checkpoint_header(const pf_chunk *c, pf_checkpoint_header *h, pf_error *err);
/* Appends the version 2 header's 48 bytes (state, state_size and have_counts unused). */
pf_status pf_stream_encode_checkpoint_header(const pf_checkpoint_header *h, pf_buffer *out,
                                             pf_error *err);
pf_status pf_stream_decode_end(const pf_chunk *c, pf_end_data *d, pf_error *err);

/* GRPS: the regions (Gmsh physical groups) of a mesh, docs/stream-format.md. The encoder writes
 * m's groups (PF_ERR_INVALID when m has none or a tag names no group of its dimension); the
 * decoder gives them to m, the mesh the chunk names (its id, element and face counts checked:
 * PF_ERR_FORMAT naming the chunk otherwise), replacing groups m had. */
pf_status pf_stream_encode_groups(const pf_mesh *m, pf_buffer *out, pf_error *err);
pf_status pf_stream_decode_groups(const pf_chunk *c, pf_mesh *m, pf_error *err);

/* STAT: a run's statistics (pf-sim writes one before END_), docs/stream-format.md. Named
 * entries, each a number or a text; keys are 1 to 64 characters of a-z, 0-9 and _, unique. The
 * set functions replace the value of a key already present (keeping its place) or append it;
 * PF_ERR_INVALID for a bad key, a non-finite number or a text that is not UTF-8 without NUL. */
typedef struct pf_stat_entry {
    char *key;    /* NUL-terminated */
    char *text;   /* a text value (NUL-terminated UTF-8), or NULL for a number */
    double value; /* the number (text NULL), finite */
} pf_stat_entry;
typedef struct pf_stats_data {
    int32_t n, cap;
    pf_stat_entry *entries; /* [n] in stream order */
} pf_stats_data;
pf_status pf_stats_data_set_number(pf_stats_data *d, const char *key, double value, pf_error *err);
pf_status pf_stats_data_set_text(pf_stats_data *d, const char *key, const char *text,
                                 pf_error *err);
/* The entry of key, or NULL. */
const pf_stat_entry *pf_stats_data_find(const pf_stats_data *d, const char *key);
void pf_stats_data_release(pf_stats_data *d);
pf_status pf_stream_encode_stats(const pf_stats_data *d, pf_buffer *out, pf_error *err);
/* Every count measured against the bytes left before allocating; keys, kinds, texts and numbers
 * checked: PF_ERR_FORMAT naming the chunk, its offset and the entry. */
pf_status pf_stream_decode_stats(const pf_chunk *c, pf_stats_data *d, pf_error *err);

/* ---- encode and write in one call (the writer reuses one scratch buffer) --------------------- */
pf_status pf_stream_write_info(pf_stream_writer *w, const char *producer, const char *version,
                               const char *command, pf_error *err);
pf_status pf_stream_write_scene(pf_stream_writer *w, const char *json, size_t size, pf_error *err);
/* MESH, followed by its GRPS when the mesh has groups. */
pf_status pf_stream_write_mesh(pf_stream_writer *w, const pf_mesh *m, pf_error *err);
pf_status pf_stream_write_surface(pf_stream_writer *w, const pf_surface *s, pf_error *err);
pf_status pf_stream_write_weights(pf_stream_writer *w, const pf_weights *wt, pf_error *err);
pf_status pf_stream_write_frame(pf_stream_writer *w, const pf_frame_data *f, pf_error *err);
pf_status pf_stream_write_stress(pf_stream_writer *w, const pf_stress_data *s, pf_error *err);
pf_status pf_stream_write_stats(pf_stream_writer *w, const pf_stats_data *d, pf_error *err);

/* ==== reader state: the latest MESH, SURF, WGHT, STRS and SCEN of a stream ======================
 * Every tool that reads frames keeps the same picture of a stream, and a mesh change mid-stream
 * (refinement, cutting: a new MESH with a fresh id before the next FRAM) is handled the same way
 * everywhere. Feed each chunk to pf_stream_state_take (FRAM chunks to pf_stream_state_frame or,
 * to skip a frame without decoding it, pf_stream_state_skip_frame). The state decodes and checks:
 * - MESH replaces the latest mesh and is recorded in the list of meshes; the weights and stress
 *   of the previous mesh are dropped (mesh-dependent chunks refer to the latest MESH);
 * - SURF replaces the latest surface, is recorded in the list of surfaces and drops the weights
 *   (a cut writes a new MESH, a new SURF with its caps and their WGHT between two frames);
 * - GRPS gives the latest MESH its groups when it names it (id, element and face counts); the
 *   groups of another mesh, or of a version this pf does not read, are ignored (not critical);
 * - WGHT must name the latest SURF and the latest MESH by id, with their vertex and node counts;
 * - STRS must name the latest MESH with its element count;
 * - FRAM must name the latest MESH with its node count; a frame of an earlier mesh or of a mesh no
 *   MESH chunk declared is an error;
 * - SCEN is kept verbatim (the scene JSON) for the tool to parse;
 * - INFO, END_ and unknown chunks leave the state as it is.
 * Errors are PF_ERR_FORMAT naming the input, the chunk and its byte offset ("in.pfs: chunk FRAM at
 * byte 1184: frame 3 refers to mesh 7, which no MESH chunk before it declares"), or the decoders'
 * statuses. After an error the state still holds what it held before the failing chunk.
 * Zero-initialise (pf_stream_state s = {0};) and release with pf_stream_state_release. */

/* One MESH of the stream and the frames that used it. */
typedef struct pf_stream_mesh_use {
    uint64_t id;                      /* the mesh id */
    uint64_t offset;                  /* byte offset of its MESH chunk */
    int32_t n_nodes, n_faces, n_elems;
    int64_t n_frames;                 /* FRAM chunks on this mesh */
    uint32_t first_frame, last_frame; /* their smallest and largest index (n_frames > 0) */
} pf_stream_mesh_use;

/* One SURF of the stream and the frames drawn on it: those that came while the weights of this
 * surface in the latest mesh were in force. */
typedef struct pf_stream_surface_use {
    uint64_t id;                      /* the surface id */
    uint64_t offset;                  /* byte offset of its SURF chunk */
    uint32_t version;                 /* of its SURF chunk (2: with triangle parts) */
    int32_t n_verts, n_tris, n_caps;  /* n_caps: triangles of part PF_SURFACE_CAP */
    int64_t n_frames;                 /* FRAM chunks on this surface */
    uint32_t first_frame, last_frame; /* their smallest and largest index (n_frames > 0) */
} pf_stream_surface_use;

typedef struct pf_stream_state {
    pf_mesh mesh;              /* the latest MESH (valid when have_mesh) */
    bool have_mesh;
    pf_surface surface;        /* the latest SURF */
    bool have_surface;
    pf_weights weights;        /* WGHT of the latest SURF in the latest MESH */
    bool have_weights;
    pf_stress_data stress;     /* the latest STRS, of the latest MESH */
    bool have_stress;
    char *scene_json;          /* the latest SCEN, NUL-terminated (scene_size bytes before it) */
    size_t scene_size;
    bool have_scene;
    uint64_t mesh_serial;      /* incremented by every MESH: a tool's caches keyed by it */
    uint64_t surface_serial;   /* incremented by every SURF */
    uint64_t scene_serial;     /* incremented by every SCEN */
    pf_stream_mesh_use *meshes; /* [n_meshes] every MESH so far, in stream order */
    int32_t n_meshes, cap_meshes;
    pf_stream_surface_use *surfaces; /* [n_surfaces] every SURF so far, in stream order */
    int32_t n_surfaces, cap_surfaces;
    int64_t n_frames;          /* FRAM chunks accepted */
} pf_stream_state;

/* Takes one chunk into the state (FRAM chunks included: decoded, checked and counted, then
 * dropped; use pf_stream_state_frame to keep the displacements). */
pf_status pf_stream_state_take(pf_stream_state *s, const pf_chunk *c, pf_error *err);

/* Decodes a FRAM chunk into f (zeroed or released by the caller; zero again after a failure) and
 * checks it against the latest MESH; counts it in that mesh's pf_stream_mesh_use and, when the
 * weights of the latest SURF are in force, in that surface's pf_stream_surface_use. */
pf_status pf_stream_state_frame(pf_stream_state *s, const pf_chunk *c, pf_frame_data *f,
                                pf_error *err);

/* The same checks and counting from the FRAM header alone (mesh id, index, node count), without
 * decoding the displacements: for frames a tool skips (--frames). *index: the frame's index. */
pf_status pf_stream_state_skip_frame(pf_stream_state *s, const pf_chunk *c, uint32_t *index,
                                     pf_error *err);

/* The use record of mesh id (NULL when no MESH declared it). With repeated ids, the latest. */
const pf_stream_mesh_use *pf_stream_state_find_mesh(const pf_stream_state *s, uint64_t id);

/* Frees everything the state holds and zeroes it; safe on a zeroed state. */
void pf_stream_state_release(pf_stream_state *s);

/* ==== files that appear whole or not at all ====================================================
 * Written to "path.part", renamed over path when complete (libcore/io/atomic_file.c). */
typedef struct pf_atomic_file {
    FILE *f;          /* open on part, for writing (binary mode) */
    const char *path; /* borrowed: the final name */
    char *part;       /* path + ".part", owned */
} pf_atomic_file;

/* Creates (truncates) "path.part" for writing. path is borrowed until commit or abort.
 * PF_ERR_IO "PATH.part: cannot create: REASON", PF_ERR_NOMEM. a is zeroed after a failure. */
pf_status pf_atomic_file_open(pf_atomic_file *a, const char *path, pf_error *err);

/* Flushes and closes the file and renames it over path. Any failure of the writes before (the
 * stream's error flag), of the flush, the close or the rename removes the .part file and returns
 * PF_ERR_IO "PATH: cannot write WHAT: REASON" (what: "VTU file", "PNG", ...). a is zeroed. */
pf_status pf_atomic_file_commit(pf_atomic_file *a, const char *what, pf_error *err);

/* Closes and removes the .part file without touching path; safe on a zeroed a. a is zeroed. */
void pf_atomic_file_abort(pf_atomic_file *a);

/* ==== importers and exporters ==================================================================
 * Importers name the file and the line (text formats) or the reason assimp gives in every error,
 * refuse non-finite coordinates and out-of-range indices before building anything, and leave their
 * output zeroed after a failure. Exporters write each file to "path.part" and rename it over path,
 * so a file is either absent, the old one, or complete. */

/* Writes size bytes to path atomically: to "path.part", renamed over path when complete, so
 * path is either the old file or the whole new one. PF_ERR_IO "PATH: cannot write WHAT: REASON". */
pf_status pf_write_file_atomic(const char *path, const void *data, size_t size, const char *what,
                               pf_error *err);

/* True when path names a volume mesh by its extension (.msh, .node, .ele, case-insensitive), or
 * is the stem of a TetGen pair: no file of that name, STEM.node beside it. */
bool pf_import_is_volume_path(const char *path);

/* A Gmsh .msh file, format 2.x or 4.1, ASCII: the tetrahedra (type 4) and hexahedra (type 5) of
 * every entity become elements, second-order ones (types 11, 12, 17) by their corners;
 * lower-dimensional elements are skipped; nodes no element uses are dropped, the others keep the
 * file's order. Node tags may be sparse and in any order. PF_ERR_FORMAT "file:line: reason" on a
 * malformed file (a node index out of range, a count larger than the file, NaN coordinates,
 * truncated or unterminated sections, an empty file, ...), PF_ERR_UNSUPPORTED "file:line: ..." on
 * binary files, other versions and other 3D elements (prisms, pyramids), PF_ERR_INVALID when the
 * file holds no tetrahedron or hexahedron, PF_ERR_IO when it cannot be read. m is overwritten
 * (zeroed or released first by the caller). */
pf_status pf_import_msh(const char *path, pf_mesh *m, pf_error *err);

/* A TetGen mesh: stem.node + stem.ele (path is either file or the stem); 4- or 10-node tets (the
 * first four corners are used), indices from 0 or 1 as the .node file's first index says; points
 * numbered consecutively; '#' comments. Same statuses as pf_import_msh, each message naming the
 * .node or .ele file and the line. */
pf_status pf_import_tetgen(const char *path, pf_mesh *m, pf_error *err);

/* A volume mesh by extension (.msh, or .node/.ele or a stem with both files beside it).
 * PF_ERR_UNSUPPORTED for any other path; otherwise the statuses of the reader it calls. */
pf_status pf_import_volume(const char *path, pf_mesh *m, pf_error *err);

/* An index list file (a scene region's "nodes_file" or "elements_file", docs/scene.md): one
 * decimal index per line, numbered from 0 as in the stream's MESH, blank lines and '#' comments
 * ignored, repeats allowed. *indices [*n] in file order (pf_alloc'd, pf_free it). what ("node",
 * "element") names the indices in messages. PF_ERR_IO naming the file when it cannot be read;
 * PF_ERR_FORMAT "path:LINE: expected node, found 'x'" for a token that is not an integer or a
 * second token on a line, and for a file without indices; PF_ERR_INVALID "path:LINE: node 12
 * out of range: the mesh has 8 nodes, numbered from 0" for an index outside [0, count). */
pf_status pf_import_index_list(const char *path, int64_t count, const char *what,
                               int32_t **indices, int32_t *n, pf_error *err);

/* A triangle surface from a file: OBJ, OFF, PLY (ASCII and binary) and STL (ASCII and binary),
 * chosen by extension (case-insensitive), through pf's own readers in double precision; any other
 * format assimp reads (glTF, DAE, FBX, ...) through assimp, whose coordinates are single precision
 * (float). All meshes of the scene, in world coordinates (assimp's node transforms applied),
 * polygons triangulated, identical vertex positions joined by exact equality (so a surface whose
 * file splits vertices by normal or UV, or STL's per-triangle corners, is still closed),
 * degenerate triangles dropped (no area threshold: any scale is kept), and so are vertices no
 * triangle uses. s->id = 1. Every count a file announces is checked against its size before
 * anything is allocated. PF_ERR_IO when the file cannot be opened; PF_ERR_FORMAT "path:LINE: ..."
 * (text) or "path: byte B: ..." (binary), or with assimp's reason, for a malformed file, one with
 * no triangle, an index out of range or a non-finite coordinate; PF_ERR_TOO_LARGE beyond INT32_MAX
 * vertices or triangles or for a polygon of more than 4096 vertices. Prints nothing. s is zeroed
 * after a failure. */
pf_status pf_import_surface(const char *path, pf_surface *s, pf_error *err);

/* Which reader pf_import_surface_ex used. */
typedef struct pf_surface_import_info {
    const char *reader;    /* static: "obj", "off", "ply", "stl" (pf's own) or "assimp" */
    bool single_precision; /* the coordinates went through float (assimp): about 7 digits */
    /* The up axis the file declares where assimp reports one: FBX's UpAxis / UpAxisSign
     * metadata, +y for glTF (its specification) and Collada (assimp turns every Collada file to
     * +y, whatever its <up_axis>); PF_UP_Z with up_source NULL for every other file (OBJ, PLY,
     * STL, OFF and most others carry no up axis). up_source (static) says where it came from. */
    pf_up_axis up;
    const char *up_source;
} pf_surface_import_info;

/* pf_import_surface, also saying which reader it used in *info (may be NULL). */
pf_status pf_import_surface_ex(const char *path, pf_surface *s, pf_surface_import_info *info,
                               pf_error *err);

/* pf_import_surface_ex followed by pf_surface_fix with fix (NULL: the defaults), where
 * fix->up == PF_UP_AUTO takes the file's own up axis (info->up). What every pf tool does to a
 * surface file. info and report may be NULL; s is released on failure; errors name path. */
pf_status pf_import_surface_fixed(const char *path, const pf_surface_fix_params *fix,
                                  pf_surface *s, pf_surface_import_info *info,
                                  pf_surface_fix_report *report, pf_error *err);

/* A mesh (and optionally one frame) as a VTK unstructured grid (.vtu, XML, ASCII data): every
 * element a VTK_POLYHEDRON cell (tets as VTK_TETRA and hexes as VTK_HEXAHEDRON where the face
 * structure allows it); points at rest; point data "displacement" when u is given ([3 n_nodes]);
 * cell data "kind" (0 tet, 1 hex, 2 polyhedron) and "volume", plus "stress" (von Mises, or 6
 * components xx yy zz xy yz zx) when stress is given. Binary (zlib-compressed, appended), as
 * pf_export_vtu_with with the default pf_vtu_params; ASCII numbers are printed with %.17g.
 * Polyhedron faces are written outward. Statuses: PF_ERR_INVALID (naming path and entity) for an
 * index out of range, a non-finite position, displacement or stress, or a stress whose element
 * count or components (1 or 6) do not fit; PF_ERR_IO "path: ...: reason" (no .part left);
 * PF_ERR_NOMEM. */
pf_status pf_export_vtu(const char *path, const pf_mesh *m, const double *u,
                        const pf_stress_data *stress, pf_error *err);

/* How pf_export_vtu_with writes. Zero values are the defaults (pf_vtu_params_default). */
typedef struct pf_vtu_params {
    /* false (default): binary, every array zlib-compressed (vtkZLibDataCompressor, UInt64
     * headers) in one raw <AppendedData> section after the XML; true: ASCII, inline, %.17g. */
    bool ascii;
    /* Every element as the tetrahedra of pf_polyhedron_tetrahedra (VTK_TETRA cells) instead of one
     * cell: VTK assumes polyhedron cells are convex, so its volumes and integrals over pf's
     * non-convex cells are wrong; the tetrahedra's are exact. Adds cell data "element" (the
     * element a tet comes from); "kind" and "stress" are the element's, "volume" the tet's. New
     * points (cone apexes, cut nodes) get the element's affine least-squares fit of its nodes'
     * displacements. */
    bool tets;
} pf_vtu_params;
pf_vtu_params pf_vtu_params_default(void);

/* pf_export_vtu with params (NULL: the defaults). Statuses as pf_export_vtu, plus those of
 * pf_polyhedron_tetrahedra (prefixed with the path and element) with tets. */
pf_status pf_export_vtu_with(const char *path, const pf_mesh *m, const double *u,
                             const pf_stress_data *stress, const pf_vtu_params *params,
                             pf_error *err);

/* A ParaView .pvd collection naming n files (relative to the .pvd's directory, XML-escaped) with
 * their times. PF_ERR_INVALID for a missing name or a non-finite time; PF_ERR_IO as above. */
pf_status pf_export_pvd(const char *path, const char *const *files, const double *times, int32_t n,
                        pf_error *err);

/* A triangle surface at positions x [3 n_verts] (NULL: s->x) as Wavefront OBJ (v, vn and f a//a
 * lines, 1-based, positions %.17g, normals %.9g) or binary little-endian PLY (float32 positions x
 * y z and normals nx ny nz per vertex, uint32 indices) for
 * Blender/Houdini sequences. A surface with caps (tri_part, PF_SURFACE_CAP) gets "g cap" /
 * "usemtl cap" runs (and "g model") and flat cap normals in OBJ, a face property "uchar part" in
 * PLY; vertex normals from pf_surface_part_normals. PF_ERR_INVALID for an index out of range or a
 * non-finite position (for PLY also one beyond float32's range); PF_ERR_IO as above. */
pf_status pf_export_obj(const char *path, const pf_surface *s, const double *x, pf_error *err);
pf_status pf_export_ply(const char *path, const pf_surface *s, const double *x, pf_error *err);

/* ---- USD ------------------------------------------------------------------------------------
 * One text USD stage (.usda) of an animated triangle surface: a Mesh prim "/pf/surface" (up axis
 * Z) whose points and vertex normals are time samples, the time code being the frame index and
 * timeCodesPerSecond derived from the frames' times (24 for a single frame); faceVertexCounts /
 * faceVertexIndices sampled at the first frame and again whenever the triangles change; an
 * optional per-triangle primvar "stress" (interpolation uniform); a GeomSubset "cap" (family
 * materialBind) of the cap triangles, sampled with the topology, when some sample has caps. Values
 * as float32 (%.9g). */
typedef struct pf_usd_writer pf_usd_writer;

/* path is copied; nothing is written before pf_usd_writer_finish. PF_ERR_NOMEM. */
pf_status pf_usd_writer_create(pf_usd_writer **w, const char *path, pf_error *err);
/* A sample at time code `code` (greater than the last one) and time seconds: the triangles of s
 * at positions x [3 n_verts] (NULL: s->x), stress [n_tris] or NULL. Kept in memory (as text).
 * PF_ERR_INVALID for a decreasing code, an index out of range, a position that is not a finite
 * float or a non-finite stress; PF_ERR_NOMEM. */
pf_status pf_usd_writer_add(pf_usd_writer *w, double code, double time, const pf_surface *s,
                            const double *x, const double *stress, pf_error *err);
/* Writes the stage (temp file + rename). PF_ERR_INVALID without samples; PF_ERR_IO. */
pf_status pf_usd_writer_finish(pf_usd_writer *w, pf_error *err);
void pf_usd_writer_destroy(pf_usd_writer **w);

/* ==== PNG ======================================================================================
 * 8-bit RGB and RGBA images as PNG files. The writer is deterministic: no time stamp (tIME) or text
 * chunks, the sRGB chunk, zlib level 6 with the default strategy, window and memory level, and the
 * Paeth filter on every row, all set explicitly, so the same pixels give the same bytes. */

/* An image in memory: rows top to bottom, channels interleaved. */
typedef struct pf_image {
    int32_t width, height;
    int32_t channels; /* 3 (RGB) or 4 (RGBA) */
    uint8_t *pixels;  /* [height * width * channels] */
} pf_image;

void pf_image_release(pf_image *img);

/* Writes pixels (width x height, channels 3 or 4, rows top to bottom) to path: first to
 * "path.part", then renamed over path, so that path is either absent, the old file, or complete.
 * PF_ERR_INVALID on bad sizes; PF_ERR_IO naming the file (nothing is left at path.part). */
pf_status pf_png_write(const char *path, const uint8_t *pixels, int32_t width, int32_t height,
                       int32_t channels, pf_error *err);

/* Reads any PNG (palette, grey, 16-bit and interlaced included) into 8-bit sRGB RGBA (channels =
 * 4) as libpng's simplified reader converts it: 8-bit sRGB files exactly, grey replicated, missing
 * alpha 255, 16-bit and gamma-tagged files converted to 8-bit sRGB. img zeroed or released;
 * zero again after a failure. PF_ERR_IO when path cannot be opened; PF_ERR_FORMAT (naming the
 * file and libpng's reason) when it is not a readable PNG; PF_ERR_TOO_LARGE beyond 2^30 pixels. */
pf_status pf_png_read(const char *path, pf_image *img, pf_error *err);

#ifdef __cplusplus
}
#endif
#endif
