/*
 * Encoder readings to signed counts, binary angles and the exact radian
 * product. Integer arithmetic only: shared by every precision.
 */
#include "aacmm/kinematics.h"

#include "aacmm_internal.h"

#define CPR_MAX (UINT64_C(1) << 32)

/* floor(2 pi * 2^189) as six 32-bit limbs, most significant first; the first
 * n limbs are floor(2 pi * 2^(32 n - 3)). (The hex digits of pi: C90FDAA2
 * 2168C234 C4C6628B 80DC1CD1 are also those of RFC 2409's primes.) */
static const uint32_t two_pi_limbs[6] = {0xC90FDAA2u, 0x2168C234u, 0xC4C6628Bu,
                                         0x80DC1CD1u, 0x29024E08u, 0x8A67CC74u};

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

/* The per-joint arrays of either encoder form. */
typedef struct {
    const uint64_t *cpr;
    const uint32_t *zero;
    const int8_t *dir;
    int joints;
} enc_view_t;

static enc_view_t view_config(const aacmm_encoder_config_t *c)
{
    enc_view_t v;
    v.cpr = c->counts_per_rev;
    v.zero = c->zero_offset_counts;
    v.dir = c->direction;
    v.joints = AACMM_JOINTS;
    return v;
}

static enc_view_t view_arm(const aacmm_arm_encoders_t *e)
{
    enc_view_t v;
    v.cpr = e->counts_per_rev;
    v.zero = e->zero_offset_counts;
    v.dir = e->direction;
    v.joints = (int)e->joints;
    return v;
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

aacmm_status_t aacmm_arm_encoders_default(aacmm_arm_encoders_t *enc, int joints)
{
    int i;
    if (enc == NULL) {
        return AACMM_ERR_NULL;
    }
    if (joints < 1 || joints > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    enc->joints = (uint8_t)joints;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        enc->counts_per_rev[i] = CPR_MAX;
        enc->zero_offset_counts[i] = 0u;
        enc->direction[i] = 1;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_arm_encoders_from_config(aacmm_arm_encoders_t *enc,
                                              const aacmm_encoder_config_t *config)
{
    int i;
    if (enc == NULL || config == NULL) {
        return AACMM_ERR_NULL;
    }
    (void)aacmm_arm_encoders_default(enc, AACMM_JOINTS);
    for (i = 0; i < AACMM_JOINTS; i++) {
        enc->counts_per_rev[i] = config->counts_per_rev[i];
        enc->zero_offset_counts[i] = config->zero_offset_counts[i];
        enc->direction[i] = config->direction[i];
    }
    return AACMM_OK;
}

static aacmm_status_t validate(enc_view_t v)
{
    int i;
    if (v.joints < 1 || v.joints > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    for (i = 0; i < v.joints; i++) {
        uint64_t cpr = v.cpr[i];
        if (cpr < 2u || cpr > CPR_MAX) {
            return AACMM_ERR_RANGE;
        }
        if ((uint64_t)v.zero[i] >= cpr) {
            return AACMM_ERR_RANGE;
        }
        if (v.dir[i] != 1 && v.dir[i] != -1) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_encoder_validate(const aacmm_encoder_config_t *config)
{
    if (config == NULL) {
        return AACMM_ERR_NULL;
    }
    return validate(view_config(config));
}

aacmm_status_t aacmm_arm_encoders_validate(const aacmm_arm_encoders_t *enc)
{
    if (enc == NULL) {
        return AACMM_ERR_NULL;
    }
    return validate(view_arm(enc));
}

static aacmm_status_t signed_counts(enc_view_t v, const uint32_t *reading_counts,
                                    int64_t *counts_out)
{
    int64_t tmp[AACMM_JOINTS_MAX];
    int i;
    aacmm_status_t st;
    if (reading_counts == NULL || counts_out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = validate(v);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < v.joints; i++) {
        uint64_t cpr = v.cpr[i];
        uint64_t reading = reading_counts[i];
        uint64_t zero = v.zero[i];
        uint64_t delta;
        int64_t s;
        if (reading >= cpr) {
            return AACMM_ERR_RANGE;
        }
        /* Both operands are < cpr, so one conditional add of cpr wraps. */
        delta = (reading >= zero) ? reading - zero : reading + (cpr - zero);
        s = (2u * delta < cpr) ? (int64_t)delta : (int64_t)delta - (int64_t)cpr;
        tmp[i] = (v.dir[i] < 0) ? -s : s;
    }
    for (i = 0; i < v.joints; i++) {
        counts_out[i] = tmp[i];
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_encoder_signed_counts(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           int64_t counts_out[AACMM_JOINTS])
{
    if (config == NULL) {
        return AACMM_ERR_NULL;
    }
    return signed_counts(view_config(config), reading_counts, counts_out);
}

aacmm_status_t aacmm_arm_encoders_signed_counts(const aacmm_arm_encoders_t *enc,
                                                const uint32_t *reading_counts,
                                                int64_t *counts_out)
{
    if (enc == NULL) {
        return AACMM_ERR_NULL;
    }
    return signed_counts(view_arm(enc), reading_counts, counts_out);
}

static aacmm_status_t to_bam(enc_view_t v, const uint32_t *reading_counts, uint32_t *angle_bam)
{
    int64_t s[AACMM_JOINTS_MAX];
    int i;
    aacmm_status_t st;
    if (angle_bam == NULL) {
        return AACMM_ERR_NULL;
    }
    st = signed_counts(v, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < v.joints; i++) {
        uint64_t cpr = v.cpr[i];
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

aacmm_status_t aacmm_encoder_to_bam(const aacmm_encoder_config_t *config,
                                    const uint32_t reading_counts[AACMM_JOINTS],
                                    uint32_t angle_bam[AACMM_JOINTS])
{
    if (config == NULL) {
        return AACMM_ERR_NULL;
    }
    return to_bam(view_config(config), reading_counts, angle_bam);
}

aacmm_status_t aacmm_arm_encoders_to_bam(const aacmm_arm_encoders_t *enc,
                                         const uint32_t *reading_counts, uint32_t *angle_bam)
{
    if (enc == NULL) {
        return AACMM_ERR_NULL;
    }
    return to_bam(view_arm(enc), reading_counts, angle_bam);
}


/* Limbs of a long number: 32 bits each, most significant first. */
#define ANGLE_LIMBS_MAX 7 /* magnitude (1 limb) x 6 limbs of 2 pi */

/* Bit `idx` (0 = least significant) of the long number q of nq limbs. */
static uint32_t limb_bits(const uint32_t *q, int nq, int idx)
{
    return q[nq - 1 - idx / 32] >> (idx % 32);
}

/*
 * 1 if the exact value, which lies in [Q, Q + 1.5) units of Q's last bit, may
 * be on the other side of the midpoint between two results rounded to `pos`
 * significant bits: if the bits of Q below the kept ones read 0111...1 or
 * 0111...10 (the midpoint 1000...0 minus one or two units). Q's top bit is
 * bit top_bit.
 */
static int near_midpoint(const uint32_t *q, int nq, int top_bit, int pos)
{
    const int d = top_bit - pos; /* the first bit not kept: must be 0, all below 1 */
    const int limb = d / 32;
    const int bit = d % 32;
    const uint32_t mask = (bit == 31) ? 0xFFFFFFFFu : ((UINT32_C(1) << (bit + 1)) - 1u);
    const uint32_t want = (UINT32_C(1) << bit) - 1u; /* ones below bit d, zero at d */
    int i;
    if (d < 2) {
        return 1; /* too few bits below the rounding point to decide */
    }
    for (i = 0; i < limb; i++) {
        if ((q[nq - 1 - i] | (i == 0 ? 1u : 0u)) != 0xFFFFFFFFu) {
            return 0;
        }
    }
    return ((limb_bits(q, nq, 32 * limb) | (limb == 0 ? 1u : 0u)) & mask) == want;
}

/*
 * |s| * 2 pi / cpr with the first n limbs of 2 pi: *mant (bit 63 set, bit 0
 * the sticky bit) and *exp2 as aacmm_internal_angle_exact; returns 1 if that
 * rounds correctly to float and double (the decision is certain), 0 if the
 * exact value may lie on the other side of a rounding midpoint.
 */
static int angle_with_limbs(uint32_t magnitude, uint64_t cpr, int n, uint64_t *mant, int *exp2)
{
    uint32_t q[ANGLE_LIMBS_MAX] = {0};
    const int nq = n + 1;
    uint64_t carry = 0u;
    int i, top_bit, e;
    /* P = magnitude * floor(2 pi 2^(32 n - 3)), exact, n + 1 limbs. The exact
     * value magnitude * 2 pi 2^(32 n - 3) lies in [P, P + magnitude). */
    for (i = n - 1; i >= 0; i--) {
        const uint64_t t = (uint64_t)magnitude * two_pi_limbs[i] + carry;
        q[i + 1] = (uint32_t)(t & 0xFFFFFFFFu);
        carry = t >> 32;
    }
    q[0] = (uint32_t)carry;
    e = -(32 * n - 3);
    if ((cpr & (cpr - 1u)) == 0u) {
        e -= 63 - clz64(cpr); /* a power of two: an exponent change */
    } else {
        /* Q = floor(P / cpr), long division (cpr < 2^32): the exact quotient
         * lies in [Q, Q + 1 + magnitude / cpr) c [Q, Q + 1.5). */
        uint64_t r = 0u;
        for (i = 0; i < nq; i++) {
            const uint64_t cur = (r << 32) | q[i];
            q[i] = (uint32_t)(cur / cpr);
            r = cur % cpr;
        }
    }
    /* the top bit of Q, counted from its least significant bit */
    for (i = 0; i < nq && q[i] == 0u; i++) {
    }
    top_bit = 32 * (nq - i) - 1 - (clz64(q[i]) - 32);
    /* the 64 bits from the top (Q has at least 32 n - 32 >= 96 bits here):
     * limbs of bits lo .. lo + 95 combined, lo = top_bit - 63 */
    {
        const int lo = top_bit - 63;
        const int sh = lo % 32;
        const int k = nq - 1 - lo / 32; /* the limb holding bit lo */
        uint64_t m = ((uint64_t)q[k - 1] << 32 | q[k]) >> sh;
        if (sh != 0) {
            m |= (uint64_t)q[k - 2] << (64 - sh);
        }
        /* The exact value is strictly above Q (2 pi is irrational), so some
         * bit below the kept ones is set: the sticky bit. */
        *mant = m | 1u;
        *exp2 = e + lo;
    }
    /* rounding to double keeps 53 bits, to float 24 */
    return !near_midpoint(q, nq, top_bit, 53) && !near_midpoint(q, nq, top_bit, 24);
}

void aacmm_internal_angle_exact(uint32_t magnitude, uint64_t cpr, uint64_t *mant, int *exp2)
{
    /* 2 pi to 128 bits decides almost every reading; a reading whose exact
     * value lies within 1.5 units of the 128-bit quotient's last bit of a
     * rounding midpoint (about 1 in 2^70) is redone with 192 bits. */
    if (!angle_with_limbs(magnitude, cpr, 4, mant, exp2)) {
        (void)angle_with_limbs(magnitude, cpr, 6, mant, exp2);
    }
}
