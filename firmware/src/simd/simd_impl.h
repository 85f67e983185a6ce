/*
 * The batch kernel across SIMD lanes, written once for every vector width and
 * both precisions (GNU C vector extensions: the compiler emits SSE2, AVX2,
 * AVX-512 or NEON code from this one source, as the including file's target
 * allows).
 *
 * Included by simd_f64.c and simd_f32.c once per instruction set, after they
 * define:
 *   REAL, LIT(x), TYPE(name)   as for kinematics_impl.h
 *   VR      a vector of W REAL (vector_size(W * sizeof(REAL)))
 *   VU      a vector of W unsigned integers as wide as REAL
 *   W       the number of lanes
 *   SIGN_BIT  the sign bit of REAL as a VU lane value
 *   VK(name)  name suffixed with the instruction set and the precision
 *   VK(fma)   a * b + c on VR, fused (one rounding) in the kernels with FMA,
 *             else the product rounded, then the sum (simd_isa.h)
 * and the sine/cosine constants (sincos_f64.h / sincos_f32.h).
 *
 * Each lane holds one pose; the arithmetic of a lane is the per-pose core's
 * (sincos_eval.h and chain_impl.h: the same reduction, polynomials, chain
 * and cross products in the same order), with a * b + c fused where the
 * kernel has FMA: a kernel without FMA gives the per-pose core's results bit
 * for bit, and every kernel with FMA gives the same results as every other
 * one with FMA.
 *
 * This file holds what does not depend on the arm's shape; simd_shape.h,
 * included twice at the end, the rest: once for the paper's shape (VK(name)
 * suffixed _paper: its constants compiled in) and once for any shape
 * (suffixed _any), and VK(name) dispatches on the model between the two.
 */

static inline VR VK(splat)(REAL s)
{
    const VR zero = {LIT(0.0)};
    return s - zero; /* folds to a broadcast (x - 0 is x, -0 included) */
}

/* F(a, b, c) of sincos_eval.h and chain_impl.h on lanes: each argument a
 * vector, or a scalar broadcast to all lanes. */
#define V_IS_VR(x) __builtin_types_compatible_p(__typeof__(x), VR)
#define V_AS_VR(x)                                                                                 \
    __builtin_choose_expr(V_IS_VR(x), (x),                                                         \
                          VK(splat)(__builtin_choose_expr(V_IS_VR(x), LIT(0.0), (x))))
#define VF(a, b, c) VK(fma)(V_AS_VR(a), V_AS_VR(b), V_AS_VR(c))

/*
 * Sine and cosine of every lane: the per-pose sincos_inline with the table
 * lookups replaced by selects. k = round(x 2/pi) is read from the low bits of
 * x 2/pi + 1.5 2^(p-1) (the rounding constant puts the integer there), so no
 * float-to-integer conversion is needed; the quadrant's swap and sign flips
 * are bit operations (a sign flip by XOR equals the core's multiplication by
 * -1 exactly).
 */
static inline void VK(sincos)(VR x, VR *s, VR *c)
{
    SINCOS_EVAL(VR, VF, x, kr, sr, cr);
    /* bit 1 of q (sine) and of q + 1 (cosine) shifted to the sign bit; the
     * masks and the XOR fold into one three-input logic instruction */
    enum { TO_SIGN = (int)sizeof(UREAL) * 8 - 2 };
    const VU q = (VU)kr;
    const VU one = q - q + 1u;
    const VU swap = (q - q) - (q & one); /* all ones in odd quadrants */
    const VU si = ((VU)sr & ~swap) | ((VU)cr & swap);
    const VU ci = ((VU)cr & ~swap) | ((VU)sr & swap);
    *s = (VR)(si ^ ((q << TO_SIGN) & SIGN_BIT));
    *c = (VR)(ci ^ (((q + one) << TO_SIGN) & SIGN_BIT));
}

/* Interleaving rounds of a block of SEG entry vectors (simd_shape.h). */
#if SIMD_SEGMENTS
static inline void VK(regroup)(VR *v)
{
    VR t[SEG];
    int s, i;
    for (s = 1; s < SEG; s *= 2) {
        for (i = 0; i < SEG / 2; i++) {
            t[2 * i] = ZIPLO(v[i], v[i + SEG / 2]);
            t[2 * i + 1] = ZIPHI(v[i], v[i + SEG / 2]);
        }
        for (i = 0; i < SEG; i++) {
            v[i] = t[i];
        }
    }
}
#endif

/* The fused Monte Carlo sums: per entry and lane, the sums of |J| and J^2;
 * keep clears the sign bit, and whole lanes past the group's last pose. */
typedef struct {
    VR *sa, *sq;
    VU keep;
} VK(sums);

/* Jacobian entry e = v: stored in jac, or (acc not NULL) added to the sums
 * instead (no store and reload of the entries). */
static inline void VK(out)(VR *jac, VK(sums) *acc, int e, VR v)
{
    if (acc != NULL) {
        const VR a = (VR)((VU)v & acc->keep);
        acc->sa[e] += a;
        acc->sq[e] = VF(a, a, acc->sq[e]);
    } else {
        jac[e] = v;
    }
}

/* Tiled layout helpers (aacmm_simd_batch_angles_tiled_*): an entry's W lanes
 * to and from the tile (unaligned: the caller's buffer need not be). */
static inline void VK(store_entry)(REAL *dst, VR v)
{
    memcpy(dst, &v, sizeof v);
}

static inline VR VK(load_entry)(const REAL *src)
{
    VR v;
    memcpy(&v, src, sizeof v);
    return v;
}

/* The points of m <= W poses (x, y, z vectors) to p_mm[l * 3 + r]: for a
 * full group, three vector stores of the lanes regrouped by two shuffles
 * each. */
static inline void VK(store_points)(const VR P[3], size_t m, REAL *p_mm)
{
    size_t l;
#if SIMD_SEGMENTS
    if (m == (size_t)W) {
        const VR o0 = XYZ(P[0], P[1], P[2], 0), o1 = XYZ(P[0], P[1], P[2], 1),
                 o2 = XYZ(P[0], P[1], P[2], 2);
        memcpy(p_mm, &o0, sizeof o0);
        memcpy(p_mm + W, &o1, sizeof o1);
        memcpy(p_mm + 2 * W, &o2, sizeof o2);
        return;
    }
#endif
    for (l = 0; l < m; l++) {
        p_mm[l * 3u + 0u] = P[0][l];
        p_mm[l * 3u + 1u] = P[1][l];
        p_mm[l * 3u + 2u] = P[2][l];
    }
}

/* The shape-dependent half, twice. */
#define SH_GENERAL 0
#define SH(name) VK(name##_paper)
#include "simd_shape.h"
#undef SH_GENERAL
#undef SH
#define SH_GENERAL 1
#define SH(name) VK(name##_any)
#include "simd_shape.h"
#undef SH_GENERAL
#undef SH

/* The batch loops for the model's shape: the paper's kernels for a model of
 * the paper's shape, the general ones for the others. (Each shape's loop is
 * its own function, not inlined here: the paper's is then placed and
 * compiled as before the general model.) */
static aacmm_status_t VK(batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    return model->paper ? VK(batch_angles_paper)(model, n, theta_rad, p_mm, jac, done)
                        : VK(batch_angles_any)(model, n, theta_rad, p_mm, jac, done);
}

static aacmm_status_t VK(batch_tiled)(const TYPE(aacmm_model) *model, size_t n,
                                      const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    return model->paper ? VK(batch_tiled_paper)(model, n, theta_rad, p_mm, jac, done)
                        : VK(batch_tiled_any)(model, n, theta_rad, p_mm, jac, done);
}

#ifdef SIMD_ABS_SUMS
static aacmm_status_t VK(abs_sums)(const TYPE(aacmm_model) *model, size_t n,
                                   const REAL *theta_rad, const REAL *scale, const REAL *offset,
                                   REAL *abs_sum, REAL *sq_sum, size_t *done)
{
    return model->paper
               ? VK(abs_sums_paper)(model, n, theta_rad, scale, offset, abs_sum, sq_sum, done)
               : VK(abs_sums_any)(model, n, theta_rad, scale, offset, abs_sum, sq_sum, done);
}
#endif

#undef V_IS_VR
#undef V_AS_VR
#undef VF
