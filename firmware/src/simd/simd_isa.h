/*
 * Instantiates the batch kernel (simd_impl.h) for one instruction set.
 * Included by simd_instances.h after it defines:
 *   ISA(name)    name suffixed with the instruction set and the precision
 *   ISA_BYTES    the vector size in bytes
 *   ISA_LANES    the lanes of REAL in such a vector, as a plain number
 *   ISA_TARGET   (optional) the target attribute string ("avx2,fma"): the
 *                kernel is then compiled for it (GCC: #pragma GCC target;
 *                clang: #pragma clang attribute) while the rest of the object
 *                keeps the baseline
 *   ISA_FMA(a, b, c)  a * b + c on two vectors VR: fused (an intrinsic) or not
 * The ISA_ macros are removed at the end.
 */
#ifdef ISA_TARGET
#if defined(__clang__)
SIMD_PRAGMA(clang attribute push(__attribute__((target(ISA_TARGET))), apply_to = function))
#else
SIMD_PRAGMA(GCC push_options)
SIMD_PRAGMA(GCC target(ISA_TARGET))
#endif
#endif

typedef REAL ISA(vr) __attribute__((vector_size(ISA_BYTES)));
typedef UREAL ISA(vu) __attribute__((vector_size(ISA_BYTES)));
#define VR ISA(vr)
#define VU ISA(vu)
#define LANES ISA_LANES
#define W LANES
#define VK(name) ISA(name)
#if SIMD_SHUFFLE && ISA_LANES > 1
/* Jacobian rows are written in 16-byte segments (simd_impl.h): measured
 * faster than 32 or 64 bytes with AVX2 and AVX-512, in both precisions. */
#define SIMD_SEGMENTS 1
#if ISA_LANES * SIMD_REAL_BYTES > 16
#define SEG (16 / SIMD_REAL_BYTES)
#else
#define SEG ISA_LANES
#endif
#else
#define SIMD_SEGMENTS 0
#endif

static inline VR VK(fma)(VR a, VR b, VR c)
{
    return ISA_FMA(a, b, c);
}

#include "simd_impl.h"
#undef SIMD_SEGMENTS
#undef SEG
#undef VR
#undef VU
#undef LANES
#undef W
#undef VK

#ifdef ISA_TARGET
#if defined(__clang__)
SIMD_PRAGMA(clang attribute pop)
#else
SIMD_PRAGMA(GCC pop_options)
#endif
#undef ISA_TARGET
#endif
#undef ISA
#undef ISA_BYTES
#undef ISA_LANES
#undef ISA_FMA
#undef ISA_GATHER
