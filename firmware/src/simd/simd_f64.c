/* Double-precision batch kernels across SIMD lanes (aacmm/simd.h). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "simd_target.h"

#include "../sincos_f64.h"

#define REAL double
#define UREAL uint64_t
#define LIT(x) x
#define TYPE(name) name##_f64_t
#define PSFX(name) name##_f64
#define SIGN_BIT UINT64_C(0x8000000000000000)
#define SIMD_ABS_SUMS

#define LANES_16B 2
#define LANES_32B 4
#define LANES_64B 8

/* No fused multiply-add anywhere in the kernels: each lane rounds every
 * operation as the per-pose core does in a build without FMA (the Python
 * extension's, and the core tests'), so the lanes give the scalar kernel's
 * results bit for bit. (Measured with FMA: up to 1.4e-12 mm apart over 10^6
 * poses, for 10-30 % more speed.) Clang ignores the pragma under
 * -ffp-contract=fast: build these files without it. */
#if defined(__clang__)
#pragma float_control(push)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
#endif

#include "simd_instances.h"

#if defined(__clang__)
#pragma float_control(pop)
#elif defined(__GNUC__)
#pragma GCC pop_options
#endif

#undef LANES_16B
#undef LANES_32B
#undef LANES_64B
#include "../template_end.h"
