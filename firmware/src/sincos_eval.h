/*
 * The floating-point part of the sine and cosine, written once for the
 * per-pose core (kinematics_impl.h: scalars) and the batch kernels
 * (simd/simd_impl.h: vectors of lanes), so both round alike. Needs the
 * constants of sincos_f64.h or sincos_f32.h.
 *
 * SINCOS_EVAL(T, F, x, kr, sr, cr) declares, for x of type T:
 *   kr  x 2/pi + ROUND_MAGIC rounded: k = round(x 2/pi) is kr - ROUND_MAGIC,
 *       and its low bits are k's (two's complement)
 *   sr, cr  sin r and cos r, r = x - k pi/2 (|r| <= pi/4 + tiny)
 * with F(a, b, c) = a * b + c, fused or not (chain_impl.h's CH_FMA). Unfused,
 * every operation rounds as in the plain form
 *   k = (x 2/pi + M) - M;  r = ((x - k P1) - k P2) - k P3;  z = r^2;
 *   sin r = r + r z S(z);  cos r = 1 - (z/2 - z^2 C(z))
 * (the negations are exact, so -k P + x is x - k P bit for bit). The
 * reduction is exact for |x| <= 2048: |k| <= 1304 and PIO2_1, PIO2_2 have
 * few significant bits, so k P1 and k P2 are exact.
 */
#define SINCOS_EVAL(T, F, x, kr, sr, cr)                                                           \
    const T kr = F((x), TWO_OVER_PI, ROUND_MAGIC);                                                 \
    const T kr##_nk = ROUND_MAGIC - kr; /* -k, exact */                                           \
    const T kr##_r = F(kr##_nk, PIO2_3, F(kr##_nk, PIO2_2, F(kr##_nk, PIO2_1, (x))));              \
    const T kr##_z = kr##_r * kr##_r;                                                              \
    const T sr = F(kr##_r * kr##_z, SIN_POLY(kr##_z, F), kr##_r);                                  \
    const T cr = LIT(1.0) + F(kr##_z * kr##_z, COS_POLY(kr##_z, F), -(LIT(0.5) * kr##_z))
