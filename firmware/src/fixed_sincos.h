/*
 * Fixed-point sine and cosine of a binary angle, inlined into the chain.
 * Integer arithmetic only. Internal to the fixed-point path; the public entry
 * point is aacmm_sincos_q (kinematics_q.h), which documents the method.
 */
#ifndef AACMM_FIXED_SINCOS_H
#define AACMM_FIXED_SINCOS_H

#include <stdint.h>

/* sin(k pi / 512) in Q30, k = 0..1023, rounded to nearest (fixed_sincos.c). */
extern const int32_t aacmm_fixed_sin_table[1024];

/* Right shifts of negative values must be arithmetic (C99 leaves it to the
 * implementation; gcc, clang and armcc all shift arithmetically). */
typedef char aacmm_fixed_asr_check[((-5) >> 1) == -3 ? 1 : -1];

/*
 * Signed 32 x 32 -> 64-bit product, exact. ARMv6-M (Cortex-M0/M0+) has no
 * long multiply: the compiler would call __aeabi_lmul, a full 64 x 64-bit
 * multiply of about 45 instructions. Four 16 x 16-bit MULS with the halves
 * and a few shifts and adds do it in about 35 (-Os keeps it out of line);
 * measured on the M0: 9% fewer instructions per pose than __aeabi_lmul. Elsewhere (the host, ARMv7-M
 * with SMULL) the plain C product is one instruction. AACMM_Q_SPLIT_MUL forces
 * the split form, so the host tests can run it too (the ASan build does).
 */
#if defined(__ARM_ARCH_6M__) || defined(AACMM_Q_SPLIT_MUL)
#define AACMM_FIXED_SPLIT_MUL 1
static inline int64_t aacmm_fixed_mul(int32_t a, int32_t b)
{
    const int32_t ah = a >> 16; /* signed high halves (arithmetic shift) */
    const int32_t bh = b >> 16;
    const uint32_t al = (uint32_t)a & 0xFFFFu; /* unsigned low halves */
    const uint32_t bl = (uint32_t)b & 0xFFFFu;
    const uint32_t ll = al * bl;         /* < 2^32 */
    const int32_t hl = ah * (int32_t)bl; /* in [-2^31 + 2^15, 2^31): no overflow */
    const int32_t lh = (int32_t)al * bh;
    const int32_t hh = ah * bh;          /* |.| <= 2^30 */
    /* a b = hh 2^32 + (hl + lh) 2^16 + ll; multiplications by powers of two
     * (left shifts of negative values are undefined in C) */
    return (int64_t)hh * INT64_C(4294967296) + ((int64_t)hl + lh) * INT64_C(65536) + (int64_t)ll;
}
#else
#define AACMM_FIXED_SPLIT_MUL 0
static inline int64_t aacmm_fixed_mul(int32_t a, int32_t b)
{
    return (int64_t)a * b;
}
#endif

/*
 * a b / 2^30 rounded half up, for Q30 a, b with |a|, |b| <= 2^30 + 2^14:
 * (a b + 2^29) >> 30, exactly. Where the split multiply is used (ARMv6-M, or
 * AACMM_Q_SPLIT_MUL) it is formed in 32-bit arithmetic from four 16 x 16
 * MULS: with a = ah 2^15 + al, b = bh 2^15 + bl (al, bl in 0 .. 2^15-1),
 *     a b + 2^29 = ah bh 2^30 + (ah bl + al bh) 2^15 + al bl + 2^29
 * and floor((m 2^15 + x) / 2^30) = floor((m + floor(x / 2^15)) / 2^15); no
 * partial sum leaves int32 for operands in that range. Elsewhere it is the
 * native 64-bit product; the tests check that both agree.
 */
#if defined(__GNUC__)
#define AACMM_FIXED_ALWAYS_INLINE __attribute__((always_inline))
#else
#define AACMM_FIXED_ALWAYS_INLINE
#endif
#if AACMM_FIXED_SPLIT_MUL
/* Inlined even at -Os: a call would cost a third of the product. */
static inline AACMM_FIXED_ALWAYS_INLINE int32_t aacmm_fixed_mul_q30(int32_t a, int32_t b)
{
    const int32_t ah = a >> 15;
    const int32_t bh = b >> 15;
    const int32_t al = a & 0x7FFF;
    const int32_t bl = b & 0x7FFF;
    const int32_t mid = ah * bl + al * bh + ((al * bl + ((int32_t)1 << 29)) >> 15);
    return ah * bh + (mid >> 15);
}
#else
static inline int32_t aacmm_fixed_mul_q30(int32_t a, int32_t b)
{
    return (int32_t)(((int64_t)a * b + ((int64_t)1 << 29)) >> 30);
}
#endif

/* Round-half-up narrowing: x * 2^-k rounded, (x + 2^(k-1)) >> k. */
#define AACMM_FIXED_RND(x, k) (((x) + ((int64_t)1 << ((k) - 1))) >> (k))

/* 2 pi * 2^28 rounded to nearest (1686629713.07) = K1 2^16 + K0: delta
 * [BAM] * this >> 21 is delta in rad, Q39. Relative error 4e-11. */
#define AACMM_FIXED_TWO_PI_Q28 INT32_C(1686629713)
#define AACMM_FIXED_TWO_PI_K1 INT32_C(25735)
#define AACMM_FIXED_TWO_PI_K0 INT32_C(60753)
/* 2^32 / 6 rounded (715827882.67): x * this >> 32 is x / 6. */
#define AACMM_FIXED_SIXTH_Q32 INT32_C(715827883)
/* 65536 / 6 rounded (10922.67): x * this >> 16 is x / 6 (relative error 3e-5). */
#define AACMM_FIXED_SIXTH_Q16 INT32_C(10923)

/* The nearest of the 1024 table nodes to a binary angle: its sine and
 * cosine (cos x = sin(x + a quarter turn)) in Q30, and the remainder in BAM,
 * in [-2^21, 2^21), returned. */
static inline int32_t aacmm_fixed_sincos_node(uint32_t angle, int32_t *s0, int32_t *c0)
{
    const uint32_t shifted = angle + (UINT32_C(1) << 21); /* wraps mod 2^32 */
    const uint32_t k = shifted >> 22;                     /* 0 .. 1023 */
    *s0 = aacmm_fixed_sin_table[k];
    *c0 = aacmm_fixed_sin_table[(k + 256u) & 1023u];
    return (int32_t)(shifted & UINT32_C(0x3FFFFF)) - ((int32_t)1 << 21);
}

#if !AACMM_FIXED_SPLIT_MUL
/*
 * Sine and cosine of a binary angle in Q30 with a native 64-bit product: the
 * nearest of 1024 table nodes and the angle-addition identity; A = sin d and
 * B = 1 - cos d of the remainder d and the four corrections are exact
 * 32 x 32 -> 64-bit products (docs/fixed-point.md).
 */
static inline void aacmm_fixed_sincos(uint32_t angle, int32_t *s_out, int32_t *c_out)
{
    int32_t s0, c0;
    const int32_t delta = aacmm_fixed_sincos_node(angle, &s0, &c0);
    /* delta in rad, Q39: |d| <= 2^21 * 804.25 = 1.687e9 < 2^31. The small
     * Q39 intermediates d, t, d6, A, B are truncated (floor): each is off by
     * less than 2^-39 = 1.8e-12, 1/500 of an LSB of the Q30 result. */
    const int32_t d = (int32_t)(aacmm_fixed_mul(delta, AACMM_FIXED_TWO_PI_Q28) >> 21);
    /* d^2 in Q39 (<= 5.2e6), d / 6 in Q39, A = sin d = d - d^3/6, B = d^2/2. */
    const int32_t t = (int32_t)(aacmm_fixed_mul(d, d) >> 39);
    const int32_t d6 = (int32_t)(aacmm_fixed_mul(d, AACMM_FIXED_SIXTH_Q32) >> 32);
    const int32_t A = d - (int32_t)(aacmm_fixed_mul(t, d6) >> 39);
    const int32_t B = t >> 1;
    /* |c0 A| <= 2^30 * 1.687e9 < 2^61: both sums fit an int64. The results
     * are rounded half up to Q30. */
    *s_out = s0 + (int32_t)AACMM_FIXED_RND(aacmm_fixed_mul(c0, A) - aacmm_fixed_mul(s0, B), 39);
    *c_out = c0 - (int32_t)AACMM_FIXED_RND(aacmm_fixed_mul(s0, A) + aacmm_fixed_mul(c0, B), 39);
}
#else
/*
 * x y / 2^31, for x in Q30 (|x| <= 2^30) and y in Q39 (|y| < 2^31), in Q38:
 * three 16 x 16 products of the halves, in 32-bit arithmetic,
 *     x = xh 2^15 + xl,  y = yh 2^16 + yl  (xl in 0 .. 2^15-1, yl in 0 .. 2^16-1)
 *     x y / 2^31 = xh yh + xh yl / 2^16 + xl yh / 2^15 + xl yl / 2^31,
 * each fraction truncated and the last (< 1) left away: at most 3 below the
 * exact value, 3 2^-38 = 0.012 LSB of Q30. No partial sum leaves int32.
 */
static inline int32_t aacmm_fixed_mul_q38(int32_t x, int32_t y)
{
    const int32_t xh = x >> 15;
    const int32_t xl = x & 0x7FFF;
    const int32_t yh = y >> 16;
    const int32_t yl = y & 0xFFFF;
    return xh * yh + ((xh * yl) >> 16) + ((xl * yh) >> 15);
}

/*
 * The same on ARMv6-M (no long multiply): every product is a 32-bit MULS of
 * 16-bit halves (21 in all), a quarter of the instructions of the eight split
 * 32 x 32 -> 64 products; d is still exact, B, the cube and the corrections
 * are within a few 2^-39 (docs/fixed-point.md, error budget).
 */
static inline void aacmm_fixed_sincos(uint32_t angle, int32_t *s_out, int32_t *c_out)
{
    int32_t s0, c0;
    const int32_t delta = aacmm_fixed_sincos_node(angle, &s0, &c0);
    /* d = floor(delta 2pi_Q28 / 2^21): delta in rad, Q39, exactly, from
     * delta = dh 2^11 + dl (dh in [-2^10, 2^10), dl in 0 .. 2^11-1) and
     * 2pi_Q28 = K1 2^16 + K0; |d| <= 1.687e9, every partial sum < 2^31. */
    const int32_t dh = delta >> 11;
    const int32_t dl = delta & 0x7FF;
    const int32_t d = dh * AACMM_FIXED_TWO_PI_K1 * 64 +
                      ((dl * AACMM_FIXED_TWO_PI_K1 * 32 + dh * AACMM_FIXED_TWO_PI_K0 +
                        ((dl * AACMM_FIXED_TWO_PI_K0) >> 11)) >>
                       10);
    /* |d| = uh 2^16 + ul. B = d^2 / 2^40 (d^2/2 in Q39) from uh^2 / 2^8 +
     * uh ul / 2^23, at most 2 below: 2 2^-39 rad. The cube d^3 / 6 (at most
     * 4.8e-9 rad) needs only 10 bits: from uh, within 3 2^-39 rad. */
    const int32_t u = d < 0 ? -d : d;
    const int32_t uh = u >> 16;
    const int32_t ul = u & 0xFFFF;
    const int32_t B = ((uh * uh) >> 8) + ((uh * ul) >> 23);
    const int32_t cube = ((((uh * uh) >> 15) * uh >> 15) * AACMM_FIXED_SIXTH_Q16) >> 16;
    const int32_t A = d < 0 ? d + cube : d - cube;
    /* The corrections in Q38 (each product at most 3 2^-38 low), rounded
     * half up to Q30. */
    *s_out = s0 + ((aacmm_fixed_mul_q38(c0, A) - aacmm_fixed_mul_q38(s0, B) + 128) >> 8);
    *c_out = c0 - ((aacmm_fixed_mul_q38(s0, A) + aacmm_fixed_mul_q38(c0, B) + 128) >> 8);
}

#endif

#endif /* AACMM_FIXED_SINCOS_H */
