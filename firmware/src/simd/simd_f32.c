/* Single-precision batch kernels across SIMD lanes (aacmm/simd.h). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "simd_target.h"
#if SIMD_X86
#include <immintrin.h>
#endif

#include "../sincos_f32.h"
#include "../sincos_eval.h"

#define REAL float
#define UREAL uint32_t
#define LIT(x) x##f
#define TYPE(name) name##_f32_t
#define PSFX(name) name##_f32
#define SIGN_BIT UINT32_C(0x80000000)

#define SIMD_REAL_BYTES 4
/* Not in single precision: measured 20.4-21.6 against 18.8-19.6 ns per pose
 * (AVX-512, same runs as simd_f64.c's). */
#define SIMD_DIRECT_DA 0
#define MM_SFX(name) name##_ps
#define MM256 __m256
#define MM512 __m512
/* The lanes of W poses' angle i (stride 6 REAL: the paper's shape; the
 * general kernels load the lanes one by one) in one gather (AVX-512 only:
 * QEMU 7.2's TCG, which runs the vcan test VM, returns wrong lanes for the
 * AVX2 gather, so the AVX2 kernel builds its vectors from scalar loads). */
#define GATHER512(p)                                                                               \
    _mm512_i32gather_ps(                                                                           \
        _mm512_set_epi32(90, 84, 78, 72, 66, 60, 54, 48, 42, 36, 30, 24, 18, 12, 6, 0), (p), 4)
#define LANES_16B 4
#define LANES_32B 8
#define LANES_64B 16

/* Poses per tile of the tiled Jacobian layout (aacmm/simd.h). */
#define TILE ((size_t)AACMM_SIMD_TILE_F32)
#include "simd_instances.h"
#undef TILE

#undef GATHER512
#undef LANES_16B
#undef LANES_32B
#undef LANES_64B
#undef SIMD_REAL_BYTES
#undef SIMD_DIRECT_DA
#include "../template_end.h"
