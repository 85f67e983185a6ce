/*
 * Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999): removes every
 * 0x00 from a byte string so that 0x00 can delimit frames on a serial link.
 *
 * Encoding: the input is split at each zero; each piece of up to 254 non-zero
 * bytes is written as one code byte (piece length + 1) followed by the piece.
 * A code of 0xFF means "254 bytes, no zero follows". The implicit zero after
 * the final piece is dropped. An empty input encodes to the single byte 0x01.
 * Encoded size is at most n + n / 254 + 1 (AACMM_COBS_MAX_ENCODED).
 *
 * No heap; the caller owns every buffer. Worst-case costs are O(n).
 */
#ifndef AACMM_COBS_H
#define AACMM_COBS_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest COBS encoding of n input bytes (no delimiter). */
#define AACMM_COBS_MAX_ENCODED(n) ((n) + (n) / 254u + 1u)

/*
 * Incremental encoder: write bytes one at a time into a caller buffer, so a
 * frame can be encoded from several pieces (payload, then CRC) without a
 * scratch copy. Fields are private; use the functions below.
 */
typedef struct {
    uint8_t *out;     /* caller buffer */
    size_t cap;       /* its size in bytes */
    size_t pos;       /* next write index */
    size_t code_pos;  /* index of the pending code byte */
    uint8_t code;     /* current code value (1 + bytes in the current piece) */
    uint8_t overflow; /* 1 once a write did not fit */
} aacmm_cobs_encoder_t;

/*
 * Start encoding into out[0 .. cap-1]. Reserves the first code byte.
 * AACMM_ERR_NULL for NULL pointers, AACMM_ERR_BUFFER if cap is 0. O(1).
 */
aacmm_status_t aacmm_cobs_encoder_init(aacmm_cobs_encoder_t *enc, uint8_t *out, size_t cap);

/* Append len raw bytes. Overflow is sticky and reported by _finish. O(len). */
void aacmm_cobs_encoder_put(aacmm_cobs_encoder_t *enc, const uint8_t *data, size_t len);

/*
 * Close the encoding and give its length (no delimiter written).
 * AACMM_ERR_BUFFER if any byte did not fit (then *out_len is 0). O(1).
 */
aacmm_status_t aacmm_cobs_encoder_finish(aacmm_cobs_encoder_t *enc, size_t *out_len);

/*
 * One-shot encode of in[0 .. in_len-1] into out (no delimiter). in may be NULL
 * only if in_len is 0. in and out must not overlap.
 * AACMM_ERR_NULL, AACMM_ERR_BUFFER (out too small; *out_len = 0) or AACMM_OK.
 * Cost: O(in_len).
 */
aacmm_status_t aacmm_cobs_encode(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_cap,
                                 size_t *out_len);

/*
 * One-shot decode of a complete encoding (without its delimiter).
 * AACMM_ERR_FRAME if the input contains 0x00, is empty, or a code byte runs
 * past the end; AACMM_ERR_BUFFER if the result does not fit out_cap;
 * AACMM_ERR_NULL for NULL pointers. Never reads past in[in_len-1] nor writes
 * past out[out_cap-1]. in and out must not overlap. Cost: O(in_len).
 */
aacmm_status_t aacmm_cobs_decode(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_cap,
                                 size_t *out_len);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_COBS_H */
