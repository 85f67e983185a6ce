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

/* pi/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 33 significant bits. */
#define ROUND_MAGIC 0x1.8p52
#define TWO_OVER_PI 0.63661977236758134
#define PIO2_1 0x1.921fb544p+0
#define PIO2_2 0x1.0b4611a6p-34
#define PIO2_3 0x1.3198a2e037073p-69

/* Taylor series on |r| <= pi/4: truncation error < 5e-17 relative. */
#define SIN_POLY(z)                                                                               \
    (-1.0 / 6.0 +                                                                                 \
     (z) * (1.0 / 120.0 +                                                                         \
            (z) * (-1.0 / 5040.0 +                                                                \
                   (z) * (1.0 / 362880.0 +                                                        \
                          (z) * (-1.0 / 39916800.0 +                                              \
                                 (z) * (1.0 / 6227020800.0 + (z) * (-1.0 / 1307674368000.0)))))))
#define COS_POLY(z)                                                                               \
    (1.0 / 24.0 +                                                                                 \
     (z) * (-1.0 / 720.0 +                                                                        \
            (z) * (1.0 / 40320.0 +                                                                \
                   (z) * (-1.0 / 3628800.0 +                                                      \
                          (z) * (1.0 / 479001600.0 +                                              \
                                 (z) * (-1.0 / 87178291200.0 + (z) * (1.0 / 20922789888000.0)))))))

#include "kinematics_impl.h"
