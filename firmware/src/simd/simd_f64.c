/* Double-precision batch kernels across SIMD lanes (aacmm/simd.h). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "simd_target.h"
#if SIMD_X86
#include <immintrin.h>
#endif

#include "../sincos_f64.h"
#include "../sincos_eval.h"

#define REAL double
#define UREAL uint64_t
#define LIT(x) x
#define TYPE(name) name##_f64_t
#define PSFX(name) name##_f64
#define SIGN_BIT UINT64_C(0x8000000000000000)
#define SIMD_ABS_SUMS
/* The d and a columns written during the pass down the chain (chain_impl.h's
 * CH_DIRECT_DA): measured 33.2-34.4 against 34.8-35.2 ns per pose for the
 * AVX-512 point + Jacobian, best of 2 runs at each of 8 code placements. */
#define SIMD_DIRECT_DA 1

#define SIMD_REAL_BYTES 8
#define MM_SFX(name) name##_pd
#define MM256 __m256d
#define MM512 __m512d
/* The lanes of W poses' angle i (stride 6 REAL: the paper's shape; the
 * general kernels load the lanes one by one) in one gather (AVX-512 only:
 * QEMU 7.2's TCG, which runs the vcan test VM, returns wrong lanes for the
 * AVX2 gather, so the AVX2 kernel builds its vectors from scalar loads). */
#define GATHER512(p) _mm512_i64gather_pd(_mm512_set_epi64(42, 36, 30, 24, 18, 12, 6, 0), (p), 8)
#define LANES_16B 2
#define LANES_32B 4
#define LANES_64B 8

/* Poses per tile of the tiled Jacobian layout (aacmm/simd.h). */
#define TILE ((size_t)AACMM_SIMD_TILE_F64)
#include "simd_instances.h"
#undef TILE

#undef GATHER512
#undef LANES_16B
#undef LANES_32B
#undef LANES_64B
#undef SIMD_REAL_BYTES
#undef SIMD_DIRECT_DA
#include "../template_end.h"
