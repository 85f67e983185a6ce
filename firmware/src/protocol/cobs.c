#include "aacmm/cobs.h"

aacmm_status_t aacmm_cobs_encoder_init(aacmm_cobs_encoder_t *enc, uint8_t *out, size_t cap)
{
    if (enc == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    if (cap == 0u) {
        return AACMM_ERR_BUFFER;
    }
    enc->out = out;
    enc->cap = cap;
    enc->code_pos = 0u;
    enc->pos = 1u;
    enc->code = 1u;
    enc->overflow = 0u;
    return AACMM_OK;
}

static void cobs_close_piece(aacmm_cobs_encoder_t *enc)
{
    enc->out[enc->code_pos] = enc->code;
    enc->code_pos = enc->pos;
    enc->code = 1u;
    if (enc->pos < enc->cap) {
        enc->pos++;
    } else {
        enc->overflow = 1u;
    }
}

void aacmm_cobs_encoder_put(aacmm_cobs_encoder_t *enc, const uint8_t *data, size_t len)
{
    size_t i;
    if (enc == NULL || data == NULL || enc->out == NULL) {
        return;
    }
    for (i = 0; i < len && enc->overflow == 0u; i++) {
        /* A full piece (code 0xFF) is closed lazily, only when more input
         * follows, so that input ending on a 254-byte boundary gets no extra
         * code byte (the canonical encoding, as produced by other COBS
         * implementations such as the Python "cobs" package). */
        if (enc->code == 0xFFu) {
            cobs_close_piece(enc);
            if (enc->overflow != 0u) {
                break;
            }
        }
        if (data[i] == 0u) {
            cobs_close_piece(enc);
        } else {
            if (enc->pos >= enc->cap) {
                enc->overflow = 1u;
                break;
            }
            enc->out[enc->pos++] = data[i];
            enc->code++;
        }
    }
}

aacmm_status_t aacmm_cobs_encoder_finish(aacmm_cobs_encoder_t *enc, size_t *out_len)
{
    if (enc == NULL || out_len == NULL || enc->out == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    if (enc->overflow != 0u || enc->code_pos >= enc->cap) {
        return AACMM_ERR_BUFFER;
    }
    enc->out[enc->code_pos] = enc->code;
    *out_len = enc->pos;
    return AACMM_OK;
}

aacmm_status_t aacmm_cobs_encode(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_cap,
                                 size_t *out_len)
{
    aacmm_cobs_encoder_t enc;
    aacmm_status_t st;
    if (out_len == NULL || (in == NULL && in_len != 0u)) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    st = aacmm_cobs_encoder_init(&enc, out, out_cap);
    if (st != AACMM_OK) {
        return st;
    }
    if (in_len != 0u) {
        aacmm_cobs_encoder_put(&enc, in, in_len);
    }
    return aacmm_cobs_encoder_finish(&enc, out_len);
}

aacmm_status_t aacmm_cobs_decode(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_cap,
                                 size_t *out_len)
{
    size_t i = 0u;
    size_t o = 0u;
    if (in == NULL || out == NULL || out_len == NULL) {
        return AACMM_ERR_NULL;
    }
    *out_len = 0u;
    if (in_len == 0u) {
        return AACMM_ERR_FRAME;
    }
    while (i < in_len) {
        uint8_t code = in[i++];
        size_t n;
        if (code == 0u) {
            return AACMM_ERR_FRAME;
        }
        n = (size_t)code - 1u;
        if (n > in_len - i) {
            return AACMM_ERR_FRAME;
        }
        if (n > out_cap - o) {
            return AACMM_ERR_BUFFER;
        }
        while (n-- > 0u) {
            if (in[i] == 0u) {
                return AACMM_ERR_FRAME;
            }
            out[o++] = in[i++];
        }
        if (code != 0xFFu && i < in_len) {
            if (o >= out_cap) {
                return AACMM_ERR_BUFFER;
            }
            out[o++] = 0u;
        }
    }
    *out_len = o;
    return AACMM_OK;
}
