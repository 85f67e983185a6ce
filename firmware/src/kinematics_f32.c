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

#include "sincos_f32.h"

#include "kinematics_impl.h"

#include "template_end.h"
