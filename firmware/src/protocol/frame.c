#include "aacmm/frame.h"

#include "aacmm/crc32.h"
#include "aacmm/le_bytes.h"

aacmm_status_t aacmm_frame_encode(const uint8_t *body, size_t body_len, uint8_t *out,
                                  size_t out_cap, size_t *out_len)
{
    aacmm_cobs_encoder_t enc;
    aacmm_status_t st;
    uint8_t crc_le[AACMM_FRAME_CRC_BYTES];
    uint32_t crc;
    size_t n;

    if (body == NULL || out == NULL || out_len == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    if (body_len < AACMM_FRAME_MIN_BODY || body_len > AACMM_FRAME_MAX_BODY) {
        return AACMM_ERR_LENGTH;
    }
    if (out_cap < 3u) {
        return AACMM_ERR_BUFFER;
    }
    crc = aacmm_crc32(body, body_len);
    aacmm_le_put_u32(crc_le, crc);

    out[0] = 0u;
    st = aacmm_cobs_encoder_init(&enc, out + 1, out_cap - 2u);
    if (st != AACMM_OK) {
        return st;
    }
    aacmm_cobs_encoder_put(&enc, body, body_len);
    aacmm_cobs_encoder_put(&enc, crc_le, sizeof crc_le);
    st = aacmm_cobs_encoder_finish(&enc, &n);
    if (st != AACMM_OK) {
        return st;
    }
    out[1u + n] = 0u;
    *out_len = n + 2u;
    return AACMM_OK;
}

/* The state of the frame in progress: empty, as after a delimiter. */
static void deframer_restart(aacmm_deframer_t *d)
{
    d->len = 0u;
    d->wire_bytes = 0u;
    d->remaining = 0u;
    d->zero_pending = 0u;
    d->discarding = 0u;
}

void aacmm_deframer_init(aacmm_deframer_t *d)
{
    if (d == NULL) {
        return;
    }
    deframer_restart(d);
    d->delivered = 0u;
    d->last_error = AACMM_OK;
    d->stats.frames_ok = 0u;
    d->stats.crc_errors = 0u;
    d->stats.cobs_errors = 0u;
    d->stats.oversize = 0u;
    d->stats.runts = 0u;
    d->stats.bytes_dropped = 0u;
}

static void deframer_reject(aacmm_deframer_t *d, aacmm_status_t why, uint32_t *counter)
{
    (*counter)++;
    d->stats.bytes_dropped += (uint32_t)d->wire_bytes;
    d->last_error = why;
}

static void deframer_store(aacmm_deframer_t *d, uint8_t b)
{
    if (d->len < sizeof d->buf) {
        d->buf[d->len++] = b;
    } else {
        d->discarding = 1u;
        deframer_reject(d, AACMM_ERR_LENGTH, &d->stats.oversize);
    }
}

/* Handle the 0x00 that ends a frame. Returns 1 if a good body is in buf. */
static int deframer_end(aacmm_deframer_t *d)
{
    uint32_t crc_rx;
    size_t body_len;

    if (d->wire_bytes == 0u) {
        return 0; /* empty frame: a delimiter after a delimiter */
    }
    if (d->discarding != 0u) {
        return 0; /* counted when the overflow happened */
    }
    if (d->remaining != 0u) {
        deframer_reject(d, AACMM_ERR_FRAME, &d->stats.cobs_errors);
        return 0;
    }
    if (d->len < AACMM_FRAME_MIN_BODY + AACMM_FRAME_CRC_BYTES) {
        deframer_reject(d, AACMM_ERR_LENGTH, &d->stats.runts);
        return 0;
    }
    body_len = d->len - AACMM_FRAME_CRC_BYTES;
    crc_rx = aacmm_le_get_u32(&d->buf[body_len]);
    if (crc_rx != aacmm_crc32(d->buf, body_len)) {
        deframer_reject(d, AACMM_ERR_CRC, &d->stats.crc_errors);
        return 0;
    }
    d->stats.frames_ok++;
    return 1;
}

size_t aacmm_deframer_feed(aacmm_deframer_t *d, const uint8_t *data, size_t len,
                           const uint8_t **body, size_t *body_len)
{
    size_t i;
    if (body != NULL) {
        *body = NULL;
    }
    if (body_len != NULL) {
        *body_len = 0u;
    }
    if (d == NULL || body == NULL || body_len == NULL || (data == NULL && len != 0u)) {
        return 0u;
    }
    if (d->delivered != 0u) {
        d->delivered = 0u;
        deframer_restart(d);
    }
    for (i = 0; i < len; i++) {
        uint8_t b = data[i];
        if (b == 0u) {
            int ok = deframer_end(d);
            if (ok != 0) {
                *body = d->buf;
                *body_len = d->len - AACMM_FRAME_CRC_BYTES;
                d->delivered = 1u;
                return i + 1u;
            }
            deframer_restart(d);
            continue;
        }
        if (d->wire_bytes < (size_t)0xFFFFFFFFu) {
            d->wire_bytes++;
        }
        if (d->discarding != 0u) {
            d->stats.bytes_dropped++;
            continue;
        }
        if (d->remaining == 0u) {
            /* b is a code byte: starts a new piece. */
            if (d->zero_pending != 0u) {
                deframer_store(d, 0u);
                if (d->discarding != 0u) {
                    continue;
                }
            }
            d->remaining = (uint8_t)(b - 1u);
            d->zero_pending = (b != 0xFFu) ? 1u : 0u;
        } else {
            deframer_store(d, b);
            d->remaining--;
        }
    }
    return len;
}
