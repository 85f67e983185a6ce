/*
 * Constants of the double-precision sine and cosine (Cody-Waite reduction by
 * pi/2, Taylor polynomials on [-pi/4, pi/4]): one definition shared by the
 * per-pose core (kinematics_f64.c) and the batch kernels across SIMD lanes
 * (simd/simd_impl.h), so both reduce and evaluate the same way. No include
 * guard: these are template parameters, removed again by template_end.h.
 */
/* pi/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 33 significant bits. */
#define ROUND_MAGIC 0x1.8p52
#define TWO_OVER_PI 0.63661977236758134
#define PIO2_1 0x1.921fb544p+0
#define PIO2_2 0x1.0b4611a6p-34
#define PIO2_3 0x1.3198a2e037073p-69

/* Taylor series on |r| <= pi/4: truncation error < 5e-17 relative. Horner's
 * scheme with F(a, b, c) = a * b + c (sincos_eval.h). */
#define SIN_POLY(z, F)                                                                             \
    F(z,                                                                                           \
      F(z,                                                                                         \
        F(z, F(z, F(z, F(z, -1.0 / 1307674368000.0, 1.0 / 6227020800.0), -1.0 / 39916800.0),      \
               1.0 / 362880.0),                                                                    \
          -1.0 / 5040.0),                                                                          \
        1.0 / 120.0),                                                                              \
      -1.0 / 6.0)
#define COS_POLY(z, F)                                                                             \
    F(z,                                                                                           \
      F(z,                                                                                         \
        F(z, F(z, F(z, F(z, 1.0 / 20922789888000.0, -1.0 / 87178291200.0), 1.0 / 479001600.0),    \
               -1.0 / 3628800.0),                                                                  \
          1.0 / 40320.0),                                                                          \
        -1.0 / 720.0),                                                                             \
      1.0 / 24.0)
