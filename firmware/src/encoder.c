/*
 * Encoder readings to signed counts, binary angles and the exact radian
 * product. Integer arithmetic only: shared by every precision.
 */
#include "aacmm/kinematics.h"

#include "aacmm_internal.h"

#define CPR_MAX (UINT64_C(1) << 32)

/* 2 pi in Q61, round-to-nearest of 2 pi * 2^61 (relative error < 4e-20). */
#define TWO_PI_Q61 UINT64_C(0xC90FDAA22168C235)

/* Leading zeros of x (64 for 0). GCC and clang have an instruction for it
 * (CLZ on ARMv7-M, LZCNT/BSR on x86); elsewhere, halving in at most 6 steps. */
static int clz64(uint64_t x)
{
#if defined(__GNUC__)
    return (x == 0u) ? 64 : __builtin_clzll((unsigned long long)x);
#else
    int n = 0;
    int step;
    if (x == 0u) {
        return 64;
    }
    for (step = 32; step > 0; step >>= 1) {
        if ((x >> (64 - step)) == 0u) {
            x <<= step;
            n += step;
        }
    }
    return n;
#endif
}

aacmm_status_t aacmm_encoder_default(aacmm_encoder_config_t *config)
{
    int i;
    if (config == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        config->counts_per_rev[i] = CPR_MAX;
        config->zero_offset_counts[i] = 0u;
        config->direction[i] = 1;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_encoder_validate(const aacmm_encoder_config_t *config)
{
    int i;
    if (config == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        uint64_t cpr = config->counts_per_rev[i];
        if (cpr < 2u || cpr > CPR_MAX) {
            return AACMM_ERR_RANGE;
        }
        if ((uint64_t)config->zero_offset_counts[i] >= cpr) {
            return AACMM_ERR_RANGE;
        }
        if (config->direction[i] != 1 && config->direction[i] != -1) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_encoder_signed_counts(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           int64_t counts_out[AACMM_JOINTS])
{
    int64_t tmp[AACMM_JOINTS];
    int i;
    aacmm_status_t st;
    if (reading_counts == NULL || counts_out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_validate(config);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        uint64_t cpr = config->counts_per_rev[i];
        uint64_t reading = reading_counts[i];
        uint64_t zero = config->zero_offset_counts[i];
        uint64_t delta;
        int64_t s;
        if (reading >= cpr) {
            return AACMM_ERR_RANGE;
        }
        /* Both operands are < cpr, so one conditional add of cpr wraps. */
        delta = (reading >= zero) ? reading - zero : reading + (cpr - zero);
        s = (2u * delta < cpr) ? (int64_t)delta : (int64_t)delta - (int64_t)cpr;
        tmp[i] = (config->direction[i] < 0) ? -s : s;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        counts_out[i] = tmp[i];
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_encoder_to_bam(const aacmm_encoder_config_t *config,
                                    const uint32_t reading_counts[AACMM_JOINTS],
                                    uint32_t angle_bam[AACMM_JOINTS])
{
    int64_t s[AACMM_JOINTS];
    int i;
    aacmm_status_t st;
    if (angle_bam == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_signed_counts(config, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        uint64_t cpr = config->counts_per_rev[i];
        uint64_t mag = (uint64_t)(s[i] < 0 ? -s[i] : s[i]); /* <= 2^31 */
        uint64_t q;
        if ((cpr & (cpr - 1u)) == 0u) {
            /* cpr = 2^n: an exact shift by 32 - n. */
            q = mag << (clz64(cpr) - 31); /* cpr = 2^n: shift by 32 - n */
        } else {
            /* cpr < 2^32 here, mag <= 2^31: (mag << 32) < 2^63, no overflow. */
            q = ((mag << 32) + cpr / 2u) / cpr;
        }
        /* Two's complement negation mod 2^32 gives the wrapped binary angle. */
        angle_bam[i] = (uint32_t)((s[i] < 0 ? (0u - q) : q) & 0xFFFFFFFFu);
    }
    return AACMM_OK;
}


/* Shift the 96-bit value top:low32 left until bit 63 of top is set,
 * lowering *e by the shift. Requires top:low32 != 0. */
static void normalise96(uint64_t *top, uint64_t *low32, int *e)
{
    int k;
    if (*top == 0u) {
        *top = *low32;
        *low32 = 0u;
        *e -= 32;
    }
    k = clz64(*top);
    if (k >= 32) {
        *top = (*top << k) | (*low32 << (k - 32));
        *low32 = 0u;
    } else if (k > 0) {
        *top = (*top << k) | (*low32 >> (32 - k));
        *low32 = (*low32 << k) & 0xFFFFFFFFu;
    }
    *e -= k;
}

void aacmm_internal_angle_exact(uint32_t magnitude, uint64_t cpr, uint64_t *mant, int *exp2)
{
    /* P = magnitude * 2pi*2^61 as a 96-bit value top:low32 (top = bits 95..32). */
    uint64_t lo = (uint64_t)magnitude * (TWO_PI_Q61 & 0xFFFFFFFFu);
    uint64_t hi = (uint64_t)magnitude * (TWO_PI_Q61 >> 32);
    uint64_t top = hi + (lo >> 32); /* < 2^64: hi <= (2^32-1)^2, lo>>32 < 2^32 */
    uint64_t low32 = lo & 0xFFFFFFFFu;
    int sticky = 0;
    /* The value is (top * 2^32 + low32) * 2^(e - 32), about top * 2^e. */
    int e = -61 + 32;

    /* Put the leading one at bit 95 first, so that the quotient below keeps
     * at least 64 significant bits (dividend >= 2^95, divisor < 2^32). */
    normalise96(&top, &low32, &e);
    if ((cpr & (cpr - 1u)) == 0u) {
        /* Power of two 2^n: dividing is an exponent change by n. */
        e -= 63 - clz64(cpr);
    } else {
        /* cpr < 2^32: schoolbook division of three 32-bit limbs by one. */
        uint64_t r = (top >> 32) % cpr;
        uint64_t q2 = (top >> 32) / cpr;
        uint64_t cur = (r << 32) | (top & 0xFFFFFFFFu);
        uint64_t q1 = cur / cpr;
        uint64_t q0;
        r = cur % cpr;
        cur = (r << 32) | low32;
        q0 = cur / cpr;
        r = cur % cpr;
        sticky = (r != 0u);
        top = (q2 << 32) | q1;
        low32 = q0;
        normalise96(&top, &low32, &e);
    }
    if (low32 != 0u) {
        sticky = 1;
    }
    /* Bit 0 carries the sticky bit: 64 bits hold at least 11 more than a
     * double's 53, so rounding mant to float or double is then correct. */
    *mant = top | (uint64_t)sticky;
    *exp2 = e;
}
