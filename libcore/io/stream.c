/* The pf stream: framing (signature, chunk headers, CRC-32), the reader and the writer, and the
 * table of known chunks. Payload codecs are in stream_codec.c; docs/stream-format.md is the spec.
 */
#include <pf/io.h>

#include <errno.h>
#include <string.h>

#include <zlib.h>

#include "stream_bytes.h"

static const unsigned char SIGNATURE[PF_STREAM_SIGNATURE_BYTES] = {0x89, 'P',  'F',  'S',
                                                                   '\r', '\n', 0x1a, '\n'};

/* The chunk header as it lies on disk. Byte arrays only: no padding, no host byte order. */
typedef struct chunk_header {
    unsigned char tag[4];
    unsigned char version[4]; /* u32 */
    unsigned char size[8];    /* u64 payload bytes */
} chunk_header;
_Static_assert(sizeof(chunk_header) == PF_STREAM_HEADER_BYTES, "chunk header is 16 bytes");

/* The payload buffer of a reader on a pipe starts at this size and doubles as bytes arrive. */
enum { FIRST_PIECE = 64 * 1024 };

/* ---- the chunk table ------------------------------------------------------------------------- */

typedef struct tag_entry {
    char tag[5];
    uint32_t version;    /* the newest version this pf reads and writes */
    uint32_t oldest;     /* the oldest version it still reads (0: the same) */
    bool critical;       /* a consumer that cannot decode it must stop */
    bool mesh_dependent; /* refers to the latest MESH: dropped or recomputed with a new MESH */
} tag_entry;

/* SURF 2 adds the part of each triangle (model or cap); a surface without caps is still written
 * as SURF 1, byte for byte. CKPT 2 adds the run's counters to the header (pf_run_counts). */
static const tag_entry TAGS[] = {
    {"INFO", 1, 0, false, false}, {"SCEN", 1, 0, true, false},  {"MESH", 1, 0, true, false},
    {"SURF", 2, 1, true, false},  {"WGHT", 1, 0, true, true},   {"FRAM", 1, 0, true, true},
    {"STRS", 1, 0, false, true},  {"END_", 1, 0, true, false},  {"GRPS", 1, 0, false, true},
    {"CKPT", 2, 1, false, true},  {"STAT", 1, 0, false, false},
};

static const tag_entry *find_tag(const char *tag)
{
    if (!tag || strlen(tag) != 4)
        return NULL;
    for (size_t i = 0; i < sizeof TAGS / sizeof TAGS[0]; ++i)
        if (memcmp(TAGS[i].tag, tag, 4) == 0)
            return &TAGS[i];
    return NULL;
}

bool pf_stream_tag_is_known(const char *tag)
{
    return find_tag(tag) != NULL;
}

bool pf_stream_tag_is_critical(const char *tag)
{
    const tag_entry *t = find_tag(tag);
    return t && t->critical;
}

bool pf_stream_tag_is_mesh_dependent(const char *tag)
{
    const tag_entry *t = find_tag(tag);
    return t && t->mesh_dependent;
}

uint32_t pf_stream_tag_version(const char *tag)
{
    const tag_entry *t = find_tag(tag);
    return t ? t->version : 0;
}

bool pf_stream_version_is_read(const char *tag, uint32_t version)
{
    const tag_entry *t = find_tag(tag);
    return t && version <= t->version && version >= (t->oldest ? t->oldest : t->version);
}

pf_status pf_stream_check_version(const pf_chunk *c, pf_error *err)
{
    const tag_entry *t = find_tag(c->tag);
    if (!t || pf_stream_version_is_read(c->tag, c->version))
        return PF_OK;
    if (t->oldest)
        return pf_stream_chunk_error(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__, c,
                                     "version %u not supported (this pf reads %u to %u)",
                                     c->version, t->oldest, t->version);
    return pf_stream_chunk_error(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__, c,
                                 "version %u not supported (this pf reads %u)", c->version,
                                 t->version);
}

/* ---- shared helpers -------------------------------------------------------------------------- */

uint32_t pf_stream_crc32(const unsigned char *p, uint64_t n)
{
    return pf_stream_crc32_continue((uint32_t)crc32(0L, Z_NULL, 0), p, n);
}

uint32_t pf_stream_crc32_continue(uint32_t start, const unsigned char *p, uint64_t n)
{
    uLong crc = start;
    while (n > 0) {
        uInt piece = n > (1u << 30) ? (1u << 30) : (uInt)n;
        crc = crc32(crc, p, piece);
        p += piece;
        n -= piece;
    }
    return (uint32_t)crc;
}

pf_status pf_stream_chunk_error(pf_error *err, pf_status code, const char *src_file, int src_line,
                                const pf_chunk *c, const char *fmt, ...)
{
    char detail[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(detail, sizeof detail, fmt, ap);
    va_end(ap);
    return pf_error_set(err, code, src_file, src_line, "%s%schunk %s at byte %llu: %s",
                        c->source ? c->source : "", c->source ? ": " : "", c->tag,
                        (unsigned long long)c->offset, detail);
}

static bool tag_is_printable(const unsigned char *tag)
{
    for (int i = 0; i < 4; ++i)
        if (tag[i] < 0x20 || tag[i] > 0x7e)
            return false;
    return true;
}

static char *copy_name(const char *name)
{
    const char *s = name ? name : "stream";
    size_t n = strlen(s) + 1;
    char *copy = pf_alloc(n);
    if (copy)
        memcpy(copy, s, n);
    return copy;
}

static const char *plural(uint64_t n, const char *one, const char *many)
{
    return n == 1 ? one : many;
}

/* ---- reader ---------------------------------------------------------------------------------- */

struct pf_stream_reader {
    FILE *f; /* borrowed */
    char *name;
    uint64_t pos;           /* bytes consumed since the start of the stream */
    bool sized;             /* the input's length is known (a seekable file) */
    uint64_t length;        /* bytes of the stream when sized */
    unsigned char *payload; /* [capacity] */
    size_t capacity;
    uint64_t chunks, frames; /* returned so far, END_ excluded */
    char last_tag[5];
    uint64_t last_offset;
    bool seen_end; /* END_ was returned */
    bool failed;
    pf_error failure; /* the error every call repeats after a failure */
};

/* Bytes actually read (fewer only at the end of input or on an error). */
static size_t read_bytes(pf_stream_reader *r, void *dst, size_t n)
{
    size_t got = n ? fread(dst, 1, n, r->f) : 0;
    r->pos += got;
    return got;
}

static pf_status read_failed(const pf_stream_reader *r, pf_error *err)
{
    return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: read error at byte %llu: %s",
                        r->name, (unsigned long long)r->pos, strerror(errno));
}

/* Length of the stream when f is seekable; the position is left where it was. */
static void measure_input(pf_stream_reader *r)
{
    long start = ftell(r->f);
    if (start < 0 || fseek(r->f, 0, SEEK_END) != 0)
        return;
    long end = ftell(r->f);
    if (fseek(r->f, start, SEEK_SET) != 0 || end < start)
        return;
    r->sized = true;
    r->length = (uint64_t)(end - start);
}

pf_status pf_stream_reader_create(pf_stream_reader **out, FILE *f, const char *name, pf_error *err)
{
    *out = NULL;
    pf_stream_reader *r = pf_calloc(1, sizeof *r);
    char *label = copy_name(name);
    if (!r || !label) {
        pf_free(r);
        pf_free(label);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    r->f = f;
    r->name = label;
    measure_input(r);
    unsigned char sig[PF_STREAM_SIGNATURE_BYTES];
    size_t got = read_bytes(r, sig, sizeof sig);
    pf_status s = PF_OK;
    if (got < sizeof sig && ferror(f))
        s = read_failed(r, err);
    else if (got == 0)
        s = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                         "%s: empty input, expected a pf stream", r->name);
    else if (got < sizeof sig || memcmp(sig, SIGNATURE, sizeof sig) != 0)
        s = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                         "%s: not a pf stream (bad signature)%s", r->name,
                         got == sizeof sig && memcmp(sig, SIGNATURE, 4) == 0
                             ? ": its line-ending bytes were altered, as by a text-mode transfer"
                             : "");
    if (s < 0) {
        pf_stream_reader_destroy(&r);
        return s;
    }
    *out = r;
    return PF_OK;
}

void pf_stream_reader_destroy(pf_stream_reader **r)
{
    if (!r || !*r)
        return;
    pf_free((*r)->payload);
    pf_free((*r)->name);
    pf_free(*r);
    *r = NULL;
}

void pf_stream_reader_counts(const pf_stream_reader *r, uint64_t *chunks, uint64_t *frames)
{
    if (chunks)
        *chunks = r->chunks;
    if (frames)
        *frames = r->frames;
}

static pf_status grow_payload(pf_stream_reader *r, size_t capacity, pf_error *err)
{
    if (capacity <= r->capacity)
        return PF_OK;
    unsigned char *p = pf_realloc_array(r->payload, capacity, 1);
    PF_CHECK(p, err, PF_ERR_NOMEM, "%s: cannot allocate %zu bytes for a chunk payload", r->name,
             capacity);
    r->payload = p;
    r->capacity = capacity;
    return PF_OK;
}

/* Truncation inside chunk c: the input ended after `got` of its payload and CRC bytes. */
static pf_status truncated_inside(const pf_stream_reader *r, const pf_chunk *c, uint64_t got,
                                  pf_error *err)
{
    if (ferror(r->f))
        return read_failed(r, err);
    char where[96];
    if (got < c->size)
        snprintf(where, sizeof where, "the input ended after %llu of its %llu payload bytes",
                 (unsigned long long)got, (unsigned long long)c->size);
    else
        snprintf(where, sizeof where, "the input ended inside its CRC");
    return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                        "%s: truncated inside chunk %s at byte %llu: %s; %llu %s read", r->name,
                        c->tag, (unsigned long long)c->offset, where, (unsigned long long)r->frames,
                        plural(r->frames, "frame", "frames"));
}

/* Reads size payload bytes. A sized input was checked to hold them, so the buffer is allocated at
 * once; on a pipe it grows by doubling only once the bytes before have arrived, so memory stays
 * within twice what the input really delivered whatever the header claims. */
static pf_status read_payload(pf_stream_reader *r, const pf_chunk *c, pf_error *err)
{
    size_t want = (size_t)c->size, got = 0;
    if (r->sized)
        PF_TRY(grow_payload(r, want, err));
    while (got < want) {
        if (got == r->capacity) {
            size_t next = r->capacity < FIRST_PIECE ? FIRST_PIECE : r->capacity;
            next = next > want / 2 ? want : 2 * next;
            PF_TRY(grow_payload(r, next, err));
        }
        size_t piece = (r->capacity < want ? r->capacity : want) - got;
        size_t n = read_bytes(r, r->payload + got, piece);
        got += n;
        if (n < piece)
            return truncated_inside(r, c, got, err);
    }
    return PF_OK;
}

/* Checks the size in a chunk header against what the input and this machine can hold. */
static pf_status check_size(const pf_stream_reader *r, const pf_chunk *c, pf_error *err)
{
    if (c->size > (uint64_t)PTRDIFF_MAX - PF_STREAM_CRC_BYTES)
        return pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__,
                            "%s: chunk %s at byte %llu claims %llu payload bytes, more than this "
                            "machine can address (damaged size?)",
                            r->name, c->tag, (unsigned long long)c->offset,
                            (unsigned long long)c->size);
    uint64_t left = r->sized && r->length > r->pos ? r->length - r->pos : 0;
    if (r->sized && c->size + PF_STREAM_CRC_BYTES > left)
        return pf_error_set(
            err, PF_ERR_FORMAT, __FILE__, __LINE__,
            "%s: truncated inside chunk %s at byte %llu: it claims %llu payload "
            "bytes (%llu with its CRC), only %llu bytes remain (cut short, or a "
            "damaged size); %llu %s read",
            r->name, c->tag, (unsigned long long)c->offset, (unsigned long long)c->size,
            (unsigned long long)c->size + PF_STREAM_CRC_BYTES, (unsigned long long)left,
            (unsigned long long)r->frames, plural(r->frames, "frame", "frames"));
    return PF_OK;
}

/* The end of input where a chunk header should start. */
static pf_status end_of_input(pf_stream_reader *r, bool *end, pf_error *err)
{
    if (ferror(r->f))
        return read_failed(r, err);
    if (r->seen_end) {
        *end = true;
        return PF_OK;
    }
    if (r->chunks == 0)
        return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                            "%s: truncated after the signature at byte %llu (no chunks, no END_ "
                            "chunk)",
                            r->name, (unsigned long long)r->pos);
    return pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                        "%s: truncated after chunk %s #%llu at byte %llu (no END_ chunk); %llu %s "
                        "read",
                        r->name, r->last_tag, (unsigned long long)r->chunks,
                        (unsigned long long)r->last_offset, (unsigned long long)r->frames,
                        plural(r->frames, "frame", "frames"));
}

static pf_status read_header(pf_stream_reader *r, pf_chunk *c, bool *end, pf_error *err)
{
    chunk_header h;
    c->offset = r->pos;
    c->source = r->name;
    size_t got = read_bytes(r, &h, sizeof h);
    if (got == 0)
        return end_of_input(r, end, err);
    PF_CHECK(!r->seen_end, err, PF_ERR_FORMAT,
             "%s: unexpected data at byte %llu, after the END_ chunk", r->name,
             (unsigned long long)c->offset);
    if (got < sizeof h && ferror(r->f))
        return read_failed(r, err);
    if (got >= 4 && tag_is_printable(h.tag))
        PF_CHECK(got == sizeof h, err, PF_ERR_FORMAT,
                 "%s: truncated inside the header of chunk %.4s at byte %llu; %llu %s read",
                 r->name, (const char *)h.tag, (unsigned long long)c->offset,
                 (unsigned long long)r->frames, plural(r->frames, "frame", "frames"));
    PF_CHECK(got == sizeof h, err, PF_ERR_FORMAT,
             "%s: truncated inside a chunk header at byte %llu; %llu %s read", r->name,
             (unsigned long long)c->offset, (unsigned long long)r->frames,
             plural(r->frames, "frame", "frames"));
    PF_CHECK(tag_is_printable(h.tag), err, PF_ERR_FORMAT,
             "%s: bad chunk tag 0x%02x%02x%02x%02x at byte %llu (not 4 printable ASCII "
             "characters: a damaged stream)",
             r->name, h.tag[0], h.tag[1], h.tag[2], h.tag[3], (unsigned long long)c->offset);
    memcpy(c->tag, h.tag, 4);
    c->tag[4] = '\0';
    c->version = le_get_u32(h.version);
    c->size = le_get_u64(h.size);
    return PF_OK;
}

/* END_ version 1 must count the chunks before it; other versions are left to the codecs. */
static pf_status check_end(const pf_stream_reader *r, const pf_chunk *c, pf_error *err)
{
    if (c->version != pf_stream_tag_version("END_"))
        return PF_OK;
    pf_end_data d;
    pf_status s = pf_stream_decode_end(c, &d, err);
    if (s < 0) {
        pf_error_prefix(err, "%s", r->name);
        return s;
    }
    PF_CHECK(d.chunk_count == r->chunks && d.frame_count == r->frames, err, PF_ERR_FORMAT,
             "%s: chunk END_ at byte %llu counts %llu chunks and %llu frames, the stream had "
             "%llu and %llu (chunks lost or added)",
             r->name, (unsigned long long)c->offset, (unsigned long long)d.chunk_count,
             (unsigned long long)d.frame_count, (unsigned long long)r->chunks,
             (unsigned long long)r->frames);
    return PF_OK;
}

static pf_status read_chunk(pf_stream_reader *r, pf_chunk *c, bool *end, pf_error *err)
{
    PF_TRY(read_header(r, c, end, err));
    if (*end)
        return PF_OK;
    PF_TRY(check_size(r, c, err));
    PF_TRY(read_payload(r, c, err));
    unsigned char stored[PF_STREAM_CRC_BYTES];
    size_t got = read_bytes(r, stored, sizeof stored);
    if (got < sizeof stored)
        return truncated_inside(r, c, c->size + got, err);
    c->payload = c->size ? r->payload : NULL;
    c->crc = le_get_u32(stored);
    uint32_t computed = pf_stream_crc32(c->payload, c->size);
    PF_CHECK(computed == c->crc, err, PF_ERR_FORMAT,
             "%s: chunk %s at byte %llu: CRC mismatch (stored 0x%08lx, computed 0x%08lx)", r->name,
             c->tag, (unsigned long long)c->offset, (unsigned long)c->crc, (unsigned long)computed);
    if (strcmp(c->tag, "END_") == 0) {
        PF_TRY(check_end(r, c, err));
        r->seen_end = true;
        return PF_OK;
    }
    r->chunks++;
    r->frames += strcmp(c->tag, "FRAM") == 0;
    memcpy(r->last_tag, c->tag, sizeof r->last_tag);
    r->last_offset = c->offset;
    return PF_OK;
}

pf_status pf_stream_read_chunk(pf_stream_reader *r, pf_chunk *c, bool *end, pf_error *err)
{
    memset(c, 0, sizeof *c);
    *end = false;
    if (r->failed) {
        if (err)
            *err = r->failure;
        return r->failure.status;
    }
    pf_error local = {0};
    pf_status s = read_chunk(r, c, end, &local);
    if (s < 0) {
        memset(c, 0, sizeof *c);
        r->failed = true;
        r->failure = local;
        if (err)
            *err = local;
    }
    return s;
}

/* ---- writer ---------------------------------------------------------------------------------- */

struct pf_stream_writer {
    FILE *f; /* borrowed */
    char *name;
    uint64_t pos;            /* bytes written since the start of the stream */
    uint64_t chunks, frames; /* written so far, END_ excluded */
    bool finished;
    bool broken;       /* a write failed: the output ends inside a chunk */
    pf_buffer scratch; /* payloads of the write_* helpers, reused chunk after chunk */
};

static pf_status write_failed(const pf_stream_writer *w, const char *what, pf_error *err)
{
    return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot write %s at byte %llu: %s",
                        w->name, what, (unsigned long long)w->pos, strerror(errno));
}

pf_status pf_stream_writer_create(pf_stream_writer **out, FILE *f, const char *name, pf_error *err)
{
    *out = NULL;
    pf_stream_writer *w = pf_calloc(1, sizeof *w);
    char *label = copy_name(name);
    if (!w || !label) {
        pf_free(w);
        pf_free(label);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    w->f = f;
    w->name = label;
    if (fwrite(SIGNATURE, 1, sizeof SIGNATURE, f) != sizeof SIGNATURE || fflush(f) != 0) {
        pf_status s = write_failed(w, "the signature", err);
        pf_stream_writer_destroy(&w);
        return s;
    }
    w->pos = sizeof SIGNATURE;
    *out = w;
    return PF_OK;
}

void pf_stream_writer_destroy(pf_stream_writer **w)
{
    if (!w || !*w)
        return;
    pf_buffer_release(&(*w)->scratch);
    pf_free((*w)->name);
    pf_free(*w);
    *w = NULL;
}

/* Header, payload and CRC, then a flush: a reader on a pipe sees the whole chunk at once. */
static pf_status emit(pf_stream_writer *w, const char *tag, uint32_t version, const void *payload,
                      uint64_t size, uint32_t crc, pf_error *err)
{
    PF_CHECK(!w->finished, err, PF_ERR_INVALID, "%s: chunk %s written after the END_ chunk",
             w->name, tag);
    PF_CHECK(!w->broken, err, PF_ERR_IO,
             "%s: chunk %s not written: an earlier write failed and left the stream incomplete",
             w->name, tag);
    PF_CHECK((uint64_t)(size_t)size == size && (size == 0 || payload), err, PF_ERR_INVALID,
             "%s: chunk %s: payload of %llu bytes not addressable", w->name, tag,
             (unsigned long long)size);
    chunk_header h;
    memcpy(h.tag, tag, 4);
    le_put_u32(h.version, version);
    le_put_u64(h.size, size);
    unsigned char trailer[PF_STREAM_CRC_BYTES];
    le_put_u32(trailer, crc);
    char what[32];
    snprintf(what, sizeof what, "chunk %s", tag);
    if (fwrite(&h, 1, sizeof h, w->f) != sizeof h ||
        (size && fwrite(payload, 1, (size_t)size, w->f) != (size_t)size) ||
        fwrite(trailer, 1, sizeof trailer, w->f) != sizeof trailer || fflush(w->f) != 0) {
        w->broken = true;
        return write_failed(w, what, err);
    }
    w->pos += sizeof h + size + sizeof trailer;
    if (strcmp(tag, "END_") != 0) {
        w->chunks++;
        w->frames += strcmp(tag, "FRAM") == 0;
    }
    return PF_OK;
}

static pf_status check_write_tag(const pf_stream_writer *w, const char *tag, pf_error *err)
{
    PF_CHECK(tag && strlen(tag) == 4 && tag_is_printable((const unsigned char *)tag), err,
             PF_ERR_INVALID, "%s: chunk tag '%s' is not 4 printable ASCII characters", w->name,
             tag ? tag : "(null)");
    PF_CHECK(strcmp(tag, "END_") != 0, err, PF_ERR_INVALID,
             "%s: END_ is written by pf_stream_writer_finish, not as a chunk", w->name);
    return PF_OK;
}

pf_status pf_stream_write_chunk(pf_stream_writer *w, const char *tag, uint32_t version,
                                const void *payload, uint64_t size, pf_error *err)
{
    PF_TRY(check_write_tag(w, tag, err));
    PF_CHECK(size == 0 || payload, err, PF_ERR_INVALID, "%s: chunk %s has no payload", w->name,
             tag);
    return emit(w, tag, version, payload, size,
                pf_stream_crc32((const unsigned char *)payload, size), err);
}

pf_status pf_stream_write_raw(pf_stream_writer *w, const pf_chunk *c, pf_error *err)
{
    PF_TRY(check_write_tag(w, c->tag, err));
    PF_CHECK(c->size == 0 || c->payload, err, PF_ERR_INVALID, "%s: chunk %s has no payload",
             w->name, c->tag);
    uint32_t crc = pf_stream_crc32(c->payload, c->size);
    PF_CHECK(crc == c->crc, err, PF_ERR_INVALID,
             "%s: chunk %s from byte %llu passed on with CRC 0x%08lx, its payload has 0x%08lx",
             w->name, c->tag, (unsigned long long)c->offset, (unsigned long)c->crc,
             (unsigned long)crc);
    return emit(w, c->tag, c->version, c->payload, c->size, crc, err);
}

pf_status pf_stream_writer_finish(pf_stream_writer *w, pf_error *err)
{
    pf_end_data d = {w->chunks, w->frames};
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_end(&d, &w->scratch, err));
    PF_TRY(emit(w, "END_", pf_stream_tag_version("END_"), w->scratch.data, w->scratch.size,
                pf_stream_crc32(w->scratch.data, w->scratch.size), err));
    w->finished = true;
    return PF_OK;
}

/* Encodes into the writer's scratch buffer, then writes it as one chunk. */
static pf_status write_scratch(pf_stream_writer *w, const char *tag, pf_error *err)
{
    return pf_stream_write_chunk(w, tag, pf_stream_tag_version(tag), w->scratch.data,
                                 w->scratch.size, err);
}

pf_status pf_stream_write_info(pf_stream_writer *w, const char *producer, const char *version,
                               const char *command, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_info(producer, version, command, &w->scratch, err));
    return write_scratch(w, "INFO", err);
}

pf_status pf_stream_write_scene(pf_stream_writer *w, const char *json, size_t size, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_scene(json, size, &w->scratch, err));
    return write_scratch(w, "SCEN", err);
}

pf_status pf_stream_write_mesh(pf_stream_writer *w, const pf_mesh *m, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_mesh(m, &w->scratch, err));
    PF_TRY(write_scratch(w, "MESH", err));
    if (!m->elem_group)
        return PF_OK;
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_groups(m, &w->scratch, err));
    return write_scratch(w, "GRPS", err);
}

pf_status pf_stream_write_surface(pf_stream_writer *w, const pf_surface *s, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_surface(s, &w->scratch, err));
    return pf_stream_write_chunk(w, "SURF", pf_stream_surface_version(s), w->scratch.data,
                                 w->scratch.size, err);
}

pf_status pf_stream_write_weights(pf_stream_writer *w, const pf_weights *wt, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_weights(wt, &w->scratch, err));
    return write_scratch(w, "WGHT", err);
}

pf_status pf_stream_write_frame(pf_stream_writer *w, const pf_frame_data *f, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_frame(f, &w->scratch, err));
    return write_scratch(w, "FRAM", err);
}

pf_status pf_stream_write_stress(pf_stream_writer *w, const pf_stress_data *s, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_stress(s, &w->scratch, err));
    return write_scratch(w, "STRS", err);
}

pf_status pf_stream_write_stats(pf_stream_writer *w, const pf_stats_data *d, pf_error *err)
{
    w->scratch.size = 0;
    PF_TRY(pf_stream_encode_stats(d, &w->scratch, err));
    return write_scratch(w, "STAT", err);
}
