/*
 * Absolute-encoder frame decoding (aacmm/encoder_frame.h): BiSS-C and SSI.
 */
#include "aacmm/encoder_frame.h"

#include <stddef.h>

static unsigned sample(const aacmm_enc_frame_t *f, unsigned k)
{
    return (unsigned)(f->line[k / 8u] >> (7u - k % 8u)) & 1u;
}

/* Read n (<= 32) samples from k on, MSB first. */
static uint32_t field(const aacmm_enc_frame_t *f, unsigned k, unsigned n)
{
    uint32_t v = 0u;
    unsigned i;
    for (i = 0; i < n; i++) {
        v = (v << 1) | (uint32_t)sample(f, k + i);
    }
    return v;
}

aacmm_status_t aacmm_enc_config_validate(const aacmm_enc_joint_config_t *cfg)
{
    if (cfg == NULL) {
        return AACMM_ERR_NULL;
    }
    if (cfg->interface != AACMM_ENC_BISS_C && cfg->interface != AACMM_ENC_SSI_BINARY &&
        cfg->interface != AACMM_ENC_SSI_GRAY) {
        return AACMM_ERR_RANGE;
    }
    if (cfg->bits < 1u || cfg->bits > AACMM_ENC_BITS_MAX) {
        return AACMM_ERR_RANGE;
    }
    return AACMM_OK;
}

uint8_t aacmm_enc_clocks(const aacmm_enc_joint_config_t *cfg)
{
    if (aacmm_enc_config_validate(cfg) != AACMM_OK) {
        return 0u;
    }
    return cfg->interface == AACMM_ENC_BISS_C ? AACMM_BISS_CLOCKS(cfg->bits)
                                              : AACMM_SSI_CLOCKS(cfg->bits);
}

uint8_t aacmm_biss_crc6(uint64_t data, unsigned n)
{
    /* Bit-serial division: shift each message bit into the register's
     * feedback, the register holding the remainder. */
    unsigned crc = 0u;
    unsigned i;
    if (n > 64u) {
        n = 64u;
    }
    for (i = n; i > 0u; i--) {
        unsigned in = (unsigned)(data >> (i - 1u)) & 1u;
        unsigned fb = ((crc >> 5) & 1u) ^ in;
        crc = (crc << 1) & 0x3Fu;
        if (fb != 0u) {
            crc ^= AACMM_BISS_CRC_POLY;
        }
    }
    return (uint8_t)crc;
}

uint32_t aacmm_gray_to_binary(uint32_t gray)
{
    gray ^= gray >> 16;
    gray ^= gray >> 8;
    gray ^= gray >> 4;
    gray ^= gray >> 2;
    gray ^= gray >> 1;
    return gray;
}

static uint8_t decode_biss(const aacmm_enc_frame_t *f, unsigned n, unsigned bits,
                           uint32_t *position, uint8_t *warning)
{
    unsigned k = 0u;
    unsigned d;
    uint32_t pos;
    unsigned ne;
    unsigned nw;
    unsigned crc_rx;
    /* Idle high before the Ack, then the Ack low, then the start bit. */
    while (k < n && sample(f, k) == 1u) {
        k++;
    }
    while (k < n && sample(f, k) == 0u) {
        k++;
    }
    if (k >= n) {
        return (uint8_t)AACMM_ENC_FAULT_TIMEOUT; /* no start bit */
    }
    d = k + 2u; /* after start and CDS */
    if (d + bits + 2u + AACMM_BISS_CRC_BITS > n) {
        return (uint8_t)AACMM_ENC_FAULT_TIMEOUT; /* the capture ends inside the frame */
    }
    pos = field(f, d, bits);
    ne = sample(f, d + bits);
    nw = sample(f, d + bits + 1u);
    crc_rx = (unsigned)field(f, d + bits + 2u, AACMM_BISS_CRC_BITS);
    {
        uint64_t covered = ((uint64_t)pos << 2) | ((uint64_t)ne << 1) | (uint64_t)nw;
        if ((aacmm_biss_crc6(covered, bits + 2u) ^ 0x3Fu) != crc_rx) {
            return (uint8_t)AACMM_ENC_FAULT_CRC;
        }
    }
    if (ne == 0u) {
        return (uint8_t)AACMM_ENC_FAULT_ERROR_BIT;
    }
    *position = pos;
    *warning = (uint8_t)(nw == 0u ? 1u : 0u);
    return (uint8_t)AACMM_ENC_FAULT_NONE;
}

static uint8_t decode_ssi(const aacmm_enc_frame_t *f, unsigned n, unsigned bits, int gray,
                          uint32_t *position)
{
    uint32_t raw;
    if (n < bits + 2u) {
        return (uint8_t)AACMM_ENC_FAULT_TIMEOUT;
    }
    if (sample(f, 0u) != 1u || sample(f, bits + 1u) != 0u) {
        return (uint8_t)AACMM_ENC_FAULT_FRAMING;
    }
    raw = field(f, 1u, bits);
    *position = gray ? aacmm_gray_to_binary(raw) : raw;
    return (uint8_t)AACMM_ENC_FAULT_NONE;
}

uint8_t aacmm_enc_decode(const aacmm_enc_joint_config_t *cfg, const aacmm_enc_frame_t *frame,
                         uint32_t *position, uint8_t *warning)
{
    unsigned n;
    unsigned k;
    unsigned ones = 0u;
    uint8_t fault;
    if (position == NULL || warning == NULL) {
        return (uint8_t)AACMM_ENC_FAULT_FRAMING;
    }
    *position = 0u;
    *warning = 0u;
    if (frame == NULL || aacmm_enc_config_validate(cfg) != AACMM_OK) {
        return (uint8_t)AACMM_ENC_FAULT_FRAMING;
    }
    n = frame->n_bits > AACMM_ENC_FRAME_MAX_BITS ? AACMM_ENC_FRAME_MAX_BITS : frame->n_bits;
    if (n == 0u) {
        return (uint8_t)AACMM_ENC_FAULT_TIMEOUT;
    }
    for (k = 0; k < n; k++) {
        ones += sample(frame, k);
    }
    if (ones == n) {
        return (uint8_t)AACMM_ENC_FAULT_STUCK_HIGH;
    }
    if (ones == 0u) {
        return (uint8_t)AACMM_ENC_FAULT_STUCK_LOW;
    }
    if (cfg->interface == AACMM_ENC_BISS_C) {
        fault = decode_biss(frame, n, cfg->bits, position, warning);
    } else {
        fault = decode_ssi(frame, n, cfg->bits, cfg->interface == AACMM_ENC_SSI_GRAY, position);
    }
    if (fault != (uint8_t)AACMM_ENC_FAULT_NONE) {
        *position = 0u;
        *warning = 0u;
    }
    return fault;
}
