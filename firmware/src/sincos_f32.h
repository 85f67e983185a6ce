/*
 * Constants of the single-precision sine and cosine (Cody-Waite reduction by
 * pi/2, Taylor polynomials on [-pi/4, pi/4]): one definition shared by the
 * per-pose core (kinematics_f32.c) and the batch kernels across SIMD lanes
 * (simd/simd_impl.h), so both reduce and evaluate the same way. No include
 * guard: these are template parameters, removed again by template_end.h.
 */
/* pi/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 12 significant bits. */
#define ROUND_MAGIC 0x1.8p23f
#define TWO_OVER_PI 0.636619772f
#define PIO2_1 0x1.92p+0f
#define PIO2_2 0x1.fb4p-12f
#define PIO2_3 0x1.4442d2p-24f

/* Taylor series on |r| <= pi/4: truncation error < 2e-9 relative. Horner's
 * scheme with F(a, b, c) = a * b + c (sincos_eval.h). */
#define SIN_POLY(z, F)                                                                             \
    F(z, F(z, F(z, 1.0f / 362880.0f, -1.0f / 5040.0f), 1.0f / 120.0f), -1.0f / 6.0f)
#define COS_POLY(z, F)                                                                             \
    F(z, F(z, F(z, -1.0f / 3628800.0f, 1.0f / 40320.0f), -1.0f / 720.0f), 1.0f / 24.0f)
