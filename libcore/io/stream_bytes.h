/* Little-endian byte access for the pf stream, independent of host byte order and struct layout,
 * and the CRC-32 of payloads. Private to io/stream*.c and sim/sim_state.c (the CKPT payload). */
#ifndef PF_IO_STREAM_BYTES_H
#define PF_IO_STREAM_BYTES_H

#include <stdint.h>
#include <string.h>

static inline uint32_t le_get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline uint64_t le_get_u64(const unsigned char *p)
{
    return (uint64_t)le_get_u32(p) | (uint64_t)le_get_u32(p + 4) << 32;
}

/* IEEE 754 binary64 travels as the u64 of its bits: every value, -0.0 and NaN payloads included,
 * round-trips bit for bit. */
static inline double le_get_f64(const unsigned char *p)
{
    uint64_t bits = le_get_u64(p);
    double v;
    memcpy(&v, &bits, sizeof v);
    return v;
}

static inline void le_put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static inline void le_put_u64(unsigned char *p, uint64_t v)
{
    le_put_u32(p, (uint32_t)v);
    le_put_u32(p + 4, (uint32_t)(v >> 32));
}

static inline void le_put_f64(unsigned char *p, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    le_put_u64(p, bits);
}

/* zlib's CRC-32 (polynomial 0xedb88320, reflected) of n bytes, in pieces that fit zlib's uInt. */
uint32_t pf_stream_crc32(const unsigned char *p, uint64_t n);
/* The CRC-32 of the bytes before (start) followed by these n: crc(a b) = continue(crc(a), b). */
uint32_t pf_stream_crc32_continue(uint32_t start, const unsigned char *p, uint64_t n);

/* Index of the first byte of s[0..n) that is NUL or breaks UTF-8 (RFC 3629), n when none. */
size_t pf_stream_utf8_invalid_at(const unsigned char *s, size_t n);

/* Writes "SOURCE: chunk TAG at byte N: " (no "SOURCE: " when c->source is NULL) followed by the
 * message into err; returns code. */
pf_status pf_stream_chunk_error(pf_error *err, pf_status code, const char *src_file, int src_line,
                                const pf_chunk *c, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 6, 7)))
#endif
    ;

#endif
