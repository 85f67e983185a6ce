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

#include "simd_instances.h"

#undef LANES_16B
#undef LANES_32B
#undef LANES_64B
#include "../template_end.h"
