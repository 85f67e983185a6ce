/* Single-precision kinematics: the shared template with REAL = float. Only
 * float arithmetic: on Cortex-M4F every operation maps to the FPU. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "aacmm_internal.h"

#define REAL float
#define SFX(name) name##_f32
#define TYPE(name) name##_f32_t
#define LIT(x) x##f
#define ROUND_MANT(m) round_mant_f32(m)
#define POW2(e) pow2_f32(e)

/* A float keeps 24 bits: the top 32 bits of the mantissa, with any set bit
 * below them folded into bit 0 as a sticky bit, round exactly as the whole
 * 64 would. A uint32 to float conversion is one instruction on the M4F
 * (vcvt), where a uint64 one is a library call. */
static inline float round_mant_f32(uint64_t m)
{
    uint32_t hi = (uint32_t)(m >> 32) | (uint32_t)((m & 0xFFFFFFFFu) != 0u);
    return (float)hi * 0x1p32f;
}

/* 2^e for -126 <= e <= 127, exact, from the bits of a float. */
static inline float pow2_f32(int e)
{
    uint32_t bits = (uint32_t)(e + 127) << 23;
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

/* pi/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 12 significant bits. */
#define ROUND_MAGIC 0x1.8p23f
#define TWO_OVER_PI 0.636619772f
#define PIO2_1 0x1.92p+0f
#define PIO2_2 0x1.fb4p-12f
#define PIO2_3 0x1.4442d2p-24f

/* Taylor series on |r| <= pi/4: truncation error < 2e-9 relative. */
#define SIN_POLY(z) (-1.0f / 6.0f + (z) * (1.0f / 120.0f + (z) * (-1.0f / 5040.0f + (z) * (1.0f / 362880.0f))))
#define COS_POLY(z)                                                                                \
    (1.0f / 24.0f + (z) * (-1.0f / 720.0f + (z) * (1.0f / 40320.0f + (z) * (-1.0f / 3628800.0f))))

#include "kinematics_impl.h"
