/* Single-precision batch kernels across SIMD lanes (aacmm/simd.h). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "simd_target.h"

#include "../sincos_f32.h"

#define REAL float
#define UREAL uint32_t
#define LIT(x) x##f
#define TYPE(name) name##_f32_t
#define PSFX(name) name##_f32
#define SIGN_BIT UINT32_C(0x80000000)

#define LANES_16B 4
#define LANES_32B 8
#define LANES_64B 16

#include "simd_instances.h"

#undef LANES_16B
#undef LANES_32B
#undef LANES_64B
#include "../template_end.h"
