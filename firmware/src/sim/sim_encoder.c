/*
 * Simulated absolute encoders (aacmm_sim.h): the slave end of a BiSS-C or SSI
 * data line, one clock at a time, and a master that samples it. Integer only.
 */
#include <stddef.h>

#include "aacmm_sim.h"

/* ---- the slave: one line level per clock --------------------------------- */

typedef struct {
    uint8_t interface;
    uint8_t bits;
    uint32_t position; /* as sent (Gray-coded for SSI Gray) */
    uint8_t ne, nw;    /* BiSS status bits, 1 = fine */
    unsigned lead;     /* BiSS: clocks high before the Ack */
    unsigned ack;      /* BiSS: clocks of Ack (low) */
    unsigned clock;    /* clocks given so far */
    unsigned crc;      /* BiSS: CRC shift register */
} slave_t;

/* BiSS: the slave shifts each covered bit into its CRC register as it sends
 * it, then sends the register inverted, MSB first. */
static unsigned biss_level(slave_t *s)
{
    unsigned k = s->clock;
    unsigned start = s->lead + s->ack;
    unsigned data = start + 2u; /* first position bit */
    unsigned covered = s->bits + 2u;
    unsigned bit;
    if (k < s->lead) {
        return 1u; /* idle */
    }
    if (k < start) {
        return 0u; /* Ack: latching the position */
    }
    if (k == start) {
        return 1u; /* start */
    }
    if (k == start + 1u) {
        return 0u; /* CDS: no register communication */
    }
    if (k < data + covered) {
        unsigned i = k - data;
        if (i < s->bits) {
            bit = (unsigned)(s->position >> (s->bits - 1u - i)) & 1u;
        } else {
            bit = i == s->bits ? s->ne : s->nw;
        }
        {
            unsigned fb = ((s->crc >> 5) & 1u) ^ bit;
            s->crc = (s->crc << 1) & 0x3Fu;
            if (fb != 0u) {
                s->crc ^= AACMM_BISS_CRC_POLY;
            }
        }
        return bit;
    }
    if (k < data + covered + AACMM_BISS_CRC_BITS) {
        bit = ((s->crc >> 5) & 1u) ^ 1u; /* inverted */
        s->crc = (s->crc << 1) & 0x3Fu;
        return bit;
    }
    return 0u; /* timeout: held low */
}

/* SSI: idle high at the latching edge, the position MSB first, then low for
 * the monoflop time. */
static unsigned ssi_level(const slave_t *s)
{
    unsigned k = s->clock;
    if (k == 0u) {
        return 1u;
    }
    if (k <= s->bits) {
        return (unsigned)(s->position >> (s->bits - k)) & 1u;
    }
    return 0u;
}

static unsigned slave_clock(slave_t *s)
{
    unsigned level = s->interface == AACMM_ENC_BISS_C ? biss_level(s) : ssi_level(s);
    s->clock++;
    return level;
}

/* ---- the master ---------------------------------------------------------- */

static void put_sample(aacmm_enc_frame_t *f, unsigned k, unsigned level)
{
    uint8_t mask = (uint8_t)(0x80u >> (k % 8u));
    if (level != 0u) {
        f->line[k / 8u] = (uint8_t)(f->line[k / 8u] | mask);
    } else {
        f->line[k / 8u] = (uint8_t)(f->line[k / 8u] & (uint8_t)~mask);
    }
}

void aacmm_sim_encoder_frame(const aacmm_enc_joint_config_t *cfg, uint32_t position,
                             uint8_t inject, uint32_t variant, aacmm_enc_frame_t *out)
{
    slave_t s;
    unsigned n;
    unsigned k;
    unsigned flip = 0xFFFFu; /* clock whose level is inverted on the line */
    unsigned data_start;
    int biss;
    size_t i;
    if (cfg == NULL || out == NULL) {
        return;
    }
    for (i = 0; i < sizeof out->line; i++) {
        out->line[i] = 0u;
    }
    out->n_bits = 0u;
    n = aacmm_enc_clocks(cfg);
    if (n == 0u) {
        return;
    }
    biss = cfg->interface == AACMM_ENC_BISS_C;
    s.interface = cfg->interface;
    s.bits = cfg->bits;
    s.position = cfg->bits >= 32u ? position : position & ((UINT32_C(1) << cfg->bits) - 1u);
    if (cfg->interface == AACMM_ENC_SSI_GRAY) {
        s.position ^= s.position >> 1;
    }
    s.ne = 1u;
    s.nw = 1u;
    s.lead = 1u + (variant & 1u);        /* 1..2 clocks idle */
    s.ack = 1u + ((variant >> 1) % 3u);  /* 1..3 clocks of Ack */
    s.clock = 0u;
    s.crc = 0u;
    data_start = s.lead + s.ack + 2u;
    if (biss) {
        switch (inject) {
        case AACMM_SIM_ENC_BIT_FLIP:
            flip = data_start + (variant >> 3) % (cfg->bits + 2u);
            break;
        case AACMM_SIM_ENC_ERROR_BIT:
            s.ne = 0u;
            break;
        case AACMM_SIM_ENC_WARNING:
            s.nw = 0u;
            break;
        case AACMM_SIM_ENC_NO_START:
            s.ack = n; /* the Ack outlasts the capture */
            break;
        default:
            break;
        }
    } else if (inject == AACMM_SIM_ENC_FRAMING) {
        flip = cfg->bits + 1u; /* the monoflop bit high */
    }
    if (inject == AACMM_SIM_ENC_NO_ANSWER) {
        return;
    }
    if (inject == AACMM_SIM_ENC_SHORT) {
        /* stop before the last bit of the frame: BiSS inside the CRC, SSI
         * before the monoflop bit */
        n = biss ? data_start + cfg->bits + 2u + (variant >> 3) % AACMM_BISS_CRC_BITS
                 : 1u + (variant >> 3) % (cfg->bits + 1u);
    }
    for (k = 0; k < n; k++) {
        unsigned level = slave_clock(&s);
        if (inject == AACMM_SIM_ENC_STUCK_LOW) {
            level = 0u;
        } else if (inject == AACMM_SIM_ENC_STUCK_HIGH) {
            level = 1u;
        } else if (k == flip) {
            level ^= 1u;
        }
        put_sample(out, k, level);
    }
    out->n_bits = (uint8_t)n;
}

/* ---- six joints, with corruption ----------------------------------------- */

static const uint8_t biss_faults[] = {
    AACMM_SIM_ENC_BIT_FLIP,   AACMM_SIM_ENC_ERROR_BIT, AACMM_SIM_ENC_WARNING,
    AACMM_SIM_ENC_STUCK_LOW,  AACMM_SIM_ENC_STUCK_HIGH, AACMM_SIM_ENC_NO_ANSWER,
    AACMM_SIM_ENC_NO_START,   AACMM_SIM_ENC_SHORT,
};
static const uint8_t ssi_faults[] = {
    AACMM_SIM_ENC_STUCK_LOW, AACMM_SIM_ENC_STUCK_HIGH, AACMM_SIM_ENC_NO_ANSWER,
    AACMM_SIM_ENC_SHORT,     AACMM_SIM_ENC_FRAMING,
};

static uint32_t next_random(aacmm_sim_encoders_t *e)
{
    uint32_t x = e->rng; /* xorshift32 */
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    e->rng = x;
    return x;
}

aacmm_status_t aacmm_sim_encoders_init(aacmm_sim_encoders_t *enc,
                                       const aacmm_sim_encoders_config_t *cfg)
{
    int j;
    size_t i;
    if (enc == NULL || cfg == NULL) {
        return AACMM_ERR_NULL;
    }
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        if (j == AACMM_JOINTS && cfg->joint[j].interface == (uint8_t)AACMM_ENC_COUNTS &&
            cfg->joint[j].bits == 0u) {
            continue; /* no seventh encoder */
        }
        if (aacmm_enc_config_validate(&cfg->joint[j]) != AACMM_OK) {
            return AACMM_ERR_RANGE;
        }
    }
    enc->cfg = *cfg;
    enc->rng = cfg->seed * 0x9E3779B9u ^ 0x6A09E667u;
    if (enc->rng == 0u) {
        enc->rng = 0x1234567u;
    }
    enc->frames = 0u;
    enc->next_kind = 0u;
    for (i = 0; i < AACMM_SIM_ENC_KINDS; i++) {
        enc->injected[i] = 0u;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_sim_encoders_frames(aacmm_sim_encoders_t *enc,
                                         const uint32_t counts[AACMM_JOINTS_MAX],
                                         aacmm_enc_frame_t frames[AACMM_JOINTS_MAX])
{
    int j;
    if (enc == NULL || counts == NULL || frames == NULL) {
        return AACMM_ERR_NULL;
    }
    for (j = 0; j < AACMM_JOINTS_MAX; j++) {
        uint8_t bits = enc->cfg.joint[j].bits;
        if (bits == 0u) {
            continue; /* no seventh encoder */
        }
        if (bits < 32u && counts[j] >= (UINT32_C(1) << bits)) {
            return AACMM_ERR_RANGE; /* would be sent truncated: a wrong reading */
        }
    }
    for (j = 0; j < AACMM_JOINTS; j++) {
        const aacmm_enc_joint_config_t *c = &enc->cfg.joint[j];
        uint8_t inject = AACMM_SIM_ENC_OK;
        enc->frames++;
        if (enc->cfg.fault_every != 0u && enc->frames % enc->cfg.fault_every == 0u) {
            if (c->interface == AACMM_ENC_BISS_C) {
                inject = biss_faults[enc->next_kind % (sizeof biss_faults)];
            } else {
                inject = ssi_faults[enc->next_kind % (sizeof ssi_faults)];
            }
            enc->next_kind++;
        }
        enc->injected[inject]++;
        aacmm_sim_encoder_frame(c, counts[j], inject, next_random(enc), &frames[j]);
    }
    /* The seventh joint (7-joint arm models): clean frames that leave the
     * first six joints' frame count, faults and random sequence as before. */
    if (enc->cfg.joint[AACMM_JOINTS].bits != 0u) {
        aacmm_sim_encoder_frame(&enc->cfg.joint[AACMM_JOINTS], counts[AACMM_JOINTS],
                                AACMM_SIM_ENC_OK, 0u, &frames[AACMM_JOINTS]);
    } else {
        frames[AACMM_JOINTS].n_bits = 0u; /* no seventh encoder: nothing answers */
    }
    return AACMM_OK;
}

uint8_t aacmm_sim_bits_for_cpr(uint64_t cpr)
{
    uint8_t b = 1u;
    while (b < 32u && (UINT64_C(1) << b) < cpr) {
        b++;
    }
    return b;
}
