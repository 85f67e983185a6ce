/*
 * Serial framing of the aacmm link protocol (see docs/protocol.md).
 *
 * On the wire one frame is
 *
 *     0x00  COBS( body || CRC32(body) as 4 bytes little-endian )  0x00
 *
 * body is one encoded message (aacmm/proto.h), 3 .. AACMM_FRAME_MAX_BODY
 * bytes. The CRC is CRC-32/ISO-HDLC (aacmm/crc32.h, check 0xCBF43926) over
 * the body bytes. The leading 0x00 flushes any torn frame or garbage in the
 * receiver; empty frames (consecutive 0x00) are ignored without an error.
 *
 * The receiver (aacmm_deframer_t) takes bytes in any chunking, removes the
 * stuffing on the fly into its own buffer and checks the CRC at each 0x00. A
 * frame that is malformed, too short, too long or fails the CRC is dropped,
 * counted in the caller-owned statistics, and reception continues at the next
 * 0x00: one bad frame never costs more than itself.
 */
#ifndef AACMM_FRAME_H
#define AACMM_FRAME_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/cobs.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_FRAME_MAX_BODY 512u /* largest message body (header + payload) */
#define AACMM_FRAME_MIN_BODY 3u   /* the message header */
#define AACMM_FRAME_CRC_BYTES 4u
/* Largest unstuffed frame content: body + CRC. */
#define AACMM_FRAME_MAX_RAW (AACMM_FRAME_MAX_BODY + AACMM_FRAME_CRC_BYTES)
/* Largest frame on the wire, both delimiters included (521 bytes). */
#define AACMM_FRAME_MAX_WIRE (AACMM_COBS_MAX_ENCODED(AACMM_FRAME_MAX_RAW) + 2u)

/*
 * Encode one frame (both delimiters included) of body[0 .. body_len-1] into
 * out. body_len must be AACMM_FRAME_MIN_BODY .. AACMM_FRAME_MAX_BODY
 * (AACMM_ERR_LENGTH otherwise). out needs at most AACMM_FRAME_MAX_WIRE bytes;
 * AACMM_ERR_BUFFER if out_cap is too small (*out_len = 0). AACMM_ERR_NULL for
 * NULL pointers. body and out must not overlap. Cost: O(body_len).
 */
aacmm_status_t aacmm_frame_encode(const uint8_t *body, size_t body_len, uint8_t *out,
                                  size_t out_cap, size_t *out_len);

/* Anomaly counters; the library increments them and never clears them. */
typedef struct {
    uint32_t frames_ok;      /* frames delivered with a good CRC */
    uint32_t crc_errors;     /* well-stuffed frames whose CRC did not match */
    uint32_t cobs_errors;    /* torn or malformed stuffing (code runs past the 0x00) */
    uint32_t oversize;       /* frames longer than AACMM_FRAME_MAX_RAW, dropped */
    uint32_t runts;          /* frames shorter than header + CRC */
    uint32_t bytes_dropped;  /* bytes discarded with rejected frames */
} aacmm_deframer_stats_t;

/* Receiver state, owned by the caller. Fields are private except stats. */
typedef struct {
    uint8_t buf[AACMM_FRAME_MAX_RAW]; /* unstuffed bytes of the frame in progress */
    size_t len;                       /* bytes in buf */
    size_t wire_bytes;                /* stuffed bytes seen since the last 0x00 */
    uint8_t remaining;                /* data bytes left in the current COBS piece */
    uint8_t zero_pending;             /* a zero follows when the next piece starts */
    uint8_t discarding;               /* frame overflowed: skip to the next 0x00 */
    uint8_t delivered;                /* buf holds a delivered body; reset on next byte */
    aacmm_status_t last_error;        /* reason of the most recent rejection */
    aacmm_deframer_stats_t stats;
} aacmm_deframer_t;

/* Reset the receiver and zero its statistics. No-op on NULL. O(1). */
void aacmm_deframer_init(aacmm_deframer_t *d);

/*
 * Feed received bytes data[0 .. len-1] (any chunking). Processing stops just
 * after the first frame that completes with a good CRC: then *body points to
 * its body inside d (valid until the next call that feeds d) and *body_len is
 * its length (AACMM_FRAME_MIN_BODY .. AACMM_FRAME_MAX_BODY). Otherwise *body is
 * NULL and *body_len 0. Returns the number of bytes consumed (<= len); call
 * again with the rest. Rejected frames only update d->stats and
 * d->last_error. With NULL d, body or body_len nothing is consumed (returns 0).
 * Cost: O(bytes consumed) plus one CRC over the frame at its delimiter.
 */
size_t aacmm_deframer_feed(aacmm_deframer_t *d, const uint8_t *data, size_t len,
                           const uint8_t **body, size_t *body_len);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_FRAME_H */
