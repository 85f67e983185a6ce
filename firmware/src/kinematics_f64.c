/* Double-precision kinematics: the shared template with REAL = double. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "aacmm_internal.h"

#define REAL double
#define SFX(name) name##_f64
#define TYPE(name) name##_f64_t
#define LIT(x) x
#define ROUND_MANT(m) ((double)(m))
#define POW2(e) pow2_f64(e)

/* 2^e for -1022 <= e <= 1023, exact: the bits of a double with a zero
 * mantissa. Cheaper than ldexp, which is a library call. */
static inline double pow2_f64(int e)
{
    uint64_t bits = (uint64_t)(e + 1023) << 52;
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}

#include "sincos_f64.h"

#include "kinematics_impl.h"

#include "template_end.h"
