/*
 * aacmm fixed-point kinematics: the float core's operations (encoder counts to
 * angles, probe point, full 3 x P Jacobian in the column order of
 * kinematics.h, batch entry points) in integer arithmetic only, for
 * controllers without an FPU (Cortex-M0/M0+, small M3 parts), for any arm
 * the float core models: N = 4..7 joints, standard or modified DH, Hayati
 * betas, a tip l or a tip vector (kinematics.h has the model and the
 * columns). See docs/fixed-point.md for the design, the error analysis and
 * the measured accuracy, size, stack and speed.
 *
 * Files:
 *   firmware/src/fixed_sincos.c, .h    aacmm_sincos_q, its table, the multiply
 *   firmware/src/kinematics_q.c        model set-up, point, Jacobian, batches
 *   firmware/src/encoder.c             (shared core) counts -> binary angles
 *   firmware/src/kinematics_q_convert.c  double -> fixed parameter conversion:
 *                                      the ONLY file of this path that uses
 *                                      floating point. It is meant for the host
 *                                      (or a loader with an FPU) and is NOT part
 *                                      of the Cortex-M0+ integer-only build,
 *                                      whose objects are checked to reference no
 *                                      floating-point helper at all.
 * No float or double type appears in the integer-only files.
 *
 * Number formats (Qn: a signed two's complement integer x standing for
 * x * 2^-n; BAM: binary angle, a uint32 where 2^32 is one turn):
 *
 *   what                         type      format   unit    range
 *   joint / offset / alpha /     uint32_t  BAM      turn    any value; wraps mod 2^32
 *     beta angle
 *   sine, cosine, unit axes      int32_t   Q30      1       [-2, 2); |value| <= 1 + 2^-24
 *   lengths d, a, l, tip t       int32_t   Q18      mm      |x| <= 8000 mm (see below)
 *   positions, probe point       int64_t   Q48      mm      |x| <= 8000 mm (+ tiny)
 *   Jacobian entries (output)    int64_t   Q48      mm/rad, mm/mm  |x| <= 8000
 *   p - o for the cross products int32_t   Q18      mm      |x| <= 8000 mm (Q17 on ARMv6-M)
 *
 * Resolution: BAM 1.46e-9 rad; Q30 9.3e-10; Q18 3.8e-6 mm; Q48 3.6e-15 mm.
 * Axes: each rotation (Rz, Rx, Ry) turns unit vectors with a sine/cosine off
 * by <= 1 LSB and rounds each component by <= 1/2 LSB (1 LSB on ARMv6-M), so
 * after the paper's six joints (12 rotations) a component is off by at most
 * ~24 LSB (< 2^-25), after the most of the general model (7 joints, 6
 * betas: 20 rotations) ~60 LSB (< 2^-24); measured, a few LSB. The
 * overflow bounds below only need |axis component| < 1.02.
 * The outputs keep the internal Q48 because it is exact (no rounding step):
 * value in mm = x * 2^-48 (ldexp(x, -48)); the int64 range is +-32768 mm.
 *
 * Rounding: every narrowing step that reaches an output is round-half-up,
 * (x + 2^(k-1)) >> k with an arithmetic shift (the source checks at compile
 * time that >> of a negative value is arithmetic). The only exceptions are
 * the Q39 intermediates inside aacmm_sincos_q (truncated, < 2^-39 each, see
 * there). Widening steps (Q30 -> Q48 for the unit columns, the Q30 x Q18 ->
 * Q48 products) are exact.
 *
 * Two formulations, chosen by the multiplier. With a native 32 x 32 -> 64-bit
 * product (hosts; ARMv7-M's SMULL) sums of products are exact in 64 bits and
 * rounded once, as written below. On ARMv6-M (Cortex-M0/M0+: no long
 * multiply; or any build with -DAACMM_Q_SPLIT_MUL) each Q30 x Q30 product of
 * the frame step and each product of the angle columns is rounded on its own,
 * in 32-bit arithmetic from four 16 x 16 MULS, and the sine uses 32-bit
 * products throughout: marked "ARMv6-M" below. Both meet the accuracy bounds
 * below; the tests run both at full size.
 *
 * Saturate or wrap: binary angles wrap (that is their meaning: adding a theta
 * offset is a uint32 addition mod 2^32). Nothing else saturates or wraps:
 * aacmm_model_q_init(_arm) only accepts parameter blocks whose total reach
 * sum(|d_i|) + sum(|a_i|) + |l| (or + |t_x| + |t_y| + |t_z|) is at most
 * AACMM_Q_REACH_MAX_MM, and that bound keeps every intermediate of every
 * function below inside its type for every possible input (the probe point
 * and every origin are sums of those lengths times unit axes, in either
 * convention; the bounds are worked out at each function). No function can
 * overflow for a model built by aacmm_model_q_init(_arm).
 *
 * Why 8000 mm: the paper's arm has a total reach (sum of |lengths|) of
 * 2290.4 mm; the largest commercial portable arms (4.5 m measuring volume)
 * stay near 2.5 m. 8000 mm leaves a 3x margin while keeping a probe-to-origin
 * vector in an int32 Q18 for the Jacobian's cross products.
 *
 * Accuracy (docs/fixed-point.md has the measured numbers): against a
 * double-precision reference, at most 1e-4 mm per point coordinate and 1e-4
 * (mm/rad or mm/mm) per Jacobian entry anywhere in the representable range
 * (the test suite checks both over 10^6 random poses and an edge-case table,
 * and every shape of the general model).
 *
 * Ownership and state as in kinematics.h: the caller owns every buffer,
 * nothing is allocated, no global state, every function is reentrant.
 */
#ifndef AACMM_KINEMATICS_Q_H
#define AACMM_KINEMATICS_Q_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_Q_TRIG_FRAC 30 /* sine, cosine, axes: Q30 */
#define AACMM_Q_LEN_FRAC 18  /* structural lengths: Q18 */
#define AACMM_Q_POS_FRAC 48  /* internal positions: Q48 */
#define AACMM_Q_OUT_FRAC 48  /* point and Jacobian outputs: Q48 */

#define AACMM_Q_ONE_Q30 ((int32_t)1 << AACMM_Q_TRIG_FRAC) /* 1.0 in Q30 */

/* Total reach limit: sum(|d_i|) + sum(|a_i|) + |l| <= 8000 mm. A single
 * length is then also at most 8000 mm. In Q18: 8000 * 2^18 = 2 097 152 000,
 * which an int32 holds (2^31 - 1 = 2 147 483 647). */
#define AACMM_Q_REACH_MAX_MM 8000
#define AACMM_Q_REACH_MAX_Q18 ((int64_t)AACMM_Q_REACH_MAX_MM << AACMM_Q_LEN_FRAC)

/* Binary angle of a quarter and a half turn. */
#define AACMM_BAM_QUARTER UINT32_C(0x40000000)
#define AACMM_BAM_HALF UINT32_C(0x80000000)

/* ------------------------------------------------------------------------ */
/* Parameters                                                                */
/* ------------------------------------------------------------------------ */

/*
 * The paper's arm's 25 structural parameters in fixed point (the form of the
 * device's parameter set today; aacmm_arm_q_t is the general form).
 *   theta_offset_bam, alpha_bam: BAM (uint32, 2^32 = one turn). Every value is
 *                    valid; 0x80000000 is half a turn, 0xC0000000 is -1/4 turn.
 *   d_q18, a_q18, l_q18: int32 Q18 mm (resolution 2^-18 mm = 3.8 nm).
 * Valid when the total reach is within AACMM_Q_REACH_MAX_MM (see
 * aacmm_params_q_validate). Build it with aacmm_params_q_from_f64 (host side
 * or at load time) or fill it directly.
 */
typedef struct {
    uint32_t theta_offset_bam[AACMM_JOINTS];
    uint32_t alpha_bam[AACMM_JOINTS];
    int32_t d_q18[AACMM_JOINTS];
    int32_t a_q18[AACMM_JOINTS];
    int32_t l_q18;
} aacmm_params_q_t;

/*
 * Any arm in fixed point: the shape of kinematics.h and, per joint i < N,
 * the angles in BAM and the lengths in Q18 as above; beta_bam where the
 * shape declares a beta (0 elsewhere); tip_q18 = (t_x, t_y, t_z), with t_x =
 * t_y = 0 for AACMM_TIP_Z (t_z is l). Entries from index N on must be 0.
 * Valid when the shape is and the total reach is within
 * AACMM_Q_REACH_MAX_MM (aacmm_arm_q_validate).
 */
typedef struct {
    aacmm_shape_t shape;
    uint32_t theta_offset_bam[AACMM_JOINTS_MAX];
    uint32_t alpha_bam[AACMM_JOINTS_MAX];
    int32_t d_q18[AACMM_JOINTS_MAX];
    int32_t a_q18[AACMM_JOINTS_MAX];
    uint32_t beta_bam[AACMM_JOINTS_MAX];
    int32_t tip_q18[3];
} aacmm_arm_q_t;

/*
 * A prepared model: the arm plus the Q30 sine and cosine of each alpha and
 * beta. Build it with aacmm_model_q_init(_arm); the fields may be read (as
 * aacmm_model_f64_t's: n_params P, col_beta, col_tip, paper), never written.
 * 284 bytes.
 */
typedef struct {
    aacmm_arm_q_t arm;
    int32_t sin_alpha_q30[AACMM_JOINTS_MAX];
    int32_t cos_alpha_q30[AACMM_JOINTS_MAX];
    int32_t sin_beta_q30[AACMM_JOINTS_MAX];
    int32_t cos_beta_q30[AACMM_JOINTS_MAX];
    uint8_t n_params;
    uint8_t col_beta[AACMM_JOINTS_MAX];
    uint8_t col_tip;
    uint8_t paper;
} aacmm_model_q_t;

/*
 * AACMM_ERR_NULL for NULL; AACMM_ERR_RANGE if the total reach
 * sum(|d_i|) + sum(|a_i|) + |l| (arm: + |t_x| + |t_y| + |t_z|, over the N
 * joints; summed exactly in int64, |INT32_MIN| = 2^31 included) exceeds
 * AACMM_Q_REACH_MAX_Q18, and (arm) for an invalid shape (aacmm_shape_validate),
 * a non-zero beta where none is declared, a non-zero t_x or t_y with
 * AACMM_TIP_Z, or a non-zero entry from index N on; else AACMM_OK. Angles are
 * never out of range. Integer only. Cost: O(N).
 */
aacmm_status_t aacmm_params_q_validate(const aacmm_params_q_t *params);
aacmm_status_t aacmm_arm_q_validate(const aacmm_arm_q_t *arm);

/* The paper's 25 parameters as a general arm (copied, not validated).
 * AACMM_ERR_NULL or AACMM_OK. Integer only. */
aacmm_status_t aacmm_arm_q_from_params(aacmm_arm_q_t *arm, const aacmm_params_q_t *params);

/*
 * Validate the parameters (as aacmm_arm_q_validate / aacmm_params_q_validate)
 * and, if valid, build *model with sin/cos(alpha_i) and sin/cos(beta_i) from
 * aacmm_sincos_q (Q30); _init from the paper's 25 parameters (the paper's
 * shape), _init_arm from any arm. On error *model is left unchanged. Integer
 * only (runs on the M0+). Cost: N + B aacmm_sincos_q.
 */
aacmm_status_t aacmm_model_q_init(aacmm_model_q_t *model, const aacmm_params_q_t *params);
aacmm_status_t aacmm_model_q_init_arm(aacmm_model_q_t *model, const aacmm_arm_q_t *arm);

/*
 * The paper's Table 1 (as aacmm_params_default_f64) in fixed point, exactly:
 * d = (300, 65.5, 792.7, 65.5, 883.2, 0) mm rounded to Q18 (792.7 and 883.2
 * are not dyadic: error <= 2^-19 mm), a = 0, alpha = a quarter turn
 * (0x40000000), offsets 0, l = 183.5 mm; _arm: the same as a general arm.
 * Integer only. AACMM_ERR_NULL or AACMM_OK.
 */
aacmm_status_t aacmm_params_default_q(aacmm_params_q_t *params);
aacmm_status_t aacmm_arm_default_q(aacmm_arm_q_t *arm);

/* ---- host / load-time conversion (kinematics_q_convert.c, uses double) --- */

/*
 * Convert a double parameter set into the fixed-point block, once.
 *   - First the float core's own validation (aacmm_params_validate_f64):
 *     AACMM_ERR_NOT_FINITE for NaN/inf, AACMM_ERR_RANGE beyond its limits.
 *   - Lengths: round-to-nearest (half away from zero) of x * 2^18; a length
 *     with |x| > AACMM_Q_REACH_MAX_MM, or a total reach of the rounded values
 *     above AACMM_Q_REACH_MAX_Q18, gives AACMM_ERR_RANGE.
 *   - Angles (|x| <= 2 pi after the core check): BAM = round(x * 2^32 / 2 pi)
 *     mod 2^32 (x = -pi and x = pi both give 0x80000000). Error <= 2^-33 turn
 *     (0.73 nrad) plus double rounding (< 1e-15 rad).
 * On error *out is left unchanged. AACMM_ERR_NULL for NULL arguments.
 * Not for the integer-only build. Cost: 25 conversions.
 */
aacmm_status_t aacmm_params_q_from_f64(aacmm_params_q_t *out, const aacmm_params_f64_t *in);

/* The same from single precision (each value widened to double exactly). */
aacmm_status_t aacmm_params_q_from_f32(aacmm_params_q_t *out, const aacmm_params_f32_t *in);

/* The same for any arm: first aacmm_arm_validate_f64 / _f32, then each
 * length, angle (theta offsets, alphas, betas) and tip value converted as
 * above, then aacmm_arm_q_validate (the total reach). */
aacmm_status_t aacmm_arm_q_from_f64(aacmm_arm_q_t *out, const aacmm_arm_f64_t *in);
aacmm_status_t aacmm_arm_q_from_f32(aacmm_arm_q_t *out, const aacmm_arm_f32_t *in);

/*
 * The exact values a fixed-point block stands for, in double: lengths
 * x_q18 * 2^-18 (exact), angles as signed BAM * 2 pi / 2^32 in (-pi, pi]
 * (0x80000000 gives +pi; error < 1e-15 rad). Lets host code (and the tests)
 * evaluate the float core on exactly the fixed path's parameters.
 * AACMM_ERR_NULL or AACMM_OK; no validation. Not for the integer-only build.
 */
aacmm_status_t aacmm_params_q_to_f64(aacmm_params_f64_t *out, const aacmm_params_q_t *in);
aacmm_status_t aacmm_arm_q_to_f64(aacmm_arm_f64_t *out, const aacmm_arm_q_t *in);

/* ------------------------------------------------------------------------ */
/* Sine and cosine of a binary angle                                          */
/* ------------------------------------------------------------------------ */

/*
 * *s = sin(angle), *c = cos(angle) in Q30 for angle in BAM (2^32 = one turn).
 * Method: a table of sin(k pi / 512), k = 0..1023, in Q30 (one full turn,
 * 4 KB, so the node's cosine is entry k + 256 mod 1024 and no quadrant logic
 * is needed); the nearest of the 1024 nodes, x_k, is looked up and the
 * remainder delta = angle - x_k (|delta| <= 2^21 BAM = 3.07e-3 rad) is applied
 * by the angle-addition formulas
 *     sin = s_k + (c_k A - s_k B),  cos = c_k - (s_k A + c_k B),
 *     A = delta - delta^3 / 6 (sin delta), B = delta^2 / 2 (1 - cos delta),
 * with delta, A, B in Q39 (int32, |delta| <= 1.69e9; these small
 * intermediates are truncated, each off by < 2^-39 = 1.8e-12) and both
 * products summed in one int64 (|sum| <= 2^61) before one round-half-up shift
 * by 39. Truncation of the series: delta^4 / 24 <= 3.7e-12. Each table entry
 * is rounded to nearest (0.5 LSB), so the error is at most about 1 LSB of Q30
 * (9.3e-10); measured maximum in docs/fixed-point.md. ARMv6-M: delta is
 * still exact, B and delta^3/6 come from the 16-bit halves of delta (within
 * 2 and 3 x 2^-39) and each of the four products from three 16 x 16 MULS,
 * summed in Q38 (within 3 x 2^-38 each) before one round-half-up shift by 8:
 * at most 0.04 LSB more, so still below 1e-9. Exact at the quarter turns:
 * sin/cos of 0, 0x40000000, 0x80000000, 0xC0000000 are exactly 0 or +-2^30.
 * |*s|, |*c| <= 2^30 + 1. Nothing saturates; the angle wraps by nature.
 * Integer only; 8 multiplies 32x32->64 (ARMv6-M: 21 MULS 32x32->32).
 * s or c must not be NULL.
 */
void aacmm_sincos_q(uint32_t angle_bam, int32_t *s, int32_t *c);

/* ------------------------------------------------------------------------ */
/* Forward kinematics and Jacobian                                           */
/* ------------------------------------------------------------------------ */

/*
 * Probe point p_q48 = (x, y, z) in the base frame, Q48 mm (int64), for the N
 * joint angles theta_bam[0 .. N-1] (BAM, e.g. from aacmm_encoder_to_bam; N =
 * model->arm.shape.joints); the model's theta offsets are added mod 2^32.
 * Every uint32 is a valid angle, so the only error is AACMM_ERR_NULL (then
 * nothing is written). The model must come from aacmm_model_q_init(_arm).
 *
 * Chain (docs/fixed-point.md), with c, s = aacmm_sincos_q(theta_i + offset_i)
 * and ca, sa (cb, sb) the model's Q30 sin/cos alpha (beta); for a standard
 * joint:
 *     u   = c y - s x         Q30 x Q30 -> Q60 int64 sum, round >> 30 -> Q30 int32
 *     x_i = c x + s y         (same)
 *     y_i = ca u + sa z       (same; not formed for the last joint with tip l)
 *     z_i = ca z - sa u       (same)
 *     o_i = o_{i-1} + d z_{i-1} + a x_i   Q18 x Q30 -> Q48, summed exactly in
 *                                         int64 (no rounding at all)
 *     p   = o_N + l z_N                   exact in Q48 (the output)
 * and for a modified joint, and the Ry(beta) before a joint's Rz(theta), the
 * same kinds of steps in the order of kinematics.h: each rotation two
 * products per axis component, each translation an exact Q48 sum; a tip
 * vector is p = o_N + t_x x_N + t_y y_N + t_z z_N, exact.
 * ARMv6-M: each rotation's components are the sums of two products each
 * rounded half up to Q30 (aacmm_fixed_mul_q30, exact per product, 32-bit
 * arithmetic): within 1 LSB instead of 1/2.
 * Standard joint 1 starts from the identity frame; its step skips the zero
 * products (same result). Bounds: Q30 axis components stay within 1 + 2^-24
 * (see the top), so each Q60 sum is below 2^61.1; |o_i|, |p| are at most the
 * total reach 8000 mm (times 1 + 2^-24) = 2^60.97 in Q48 < 2^63.
 * Cost: N aacmm_sincos_q (8 multiplies each) + about 25 multiplies 32x32->64
 * per joint (+ 12 per beta, + 6 for a tip vector); the paper's arm: 6
 * sincos + 154 multiplies (ARMv6-M: 36 of them, the positions; the frame
 * steps are 114 products of four MULS each).
 */
aacmm_status_t aacmm_point_q(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                             int64_t p_q48[3]);

/*
 * Probe point (as aacmm_point_q, identical result) and the full 3 x P
 * Jacobian, Q48 int64, row-major jac_q48[row * P + col] (P =
 * model->n_params, at most AACMM_PARAMS_MAX; 25 for the paper's arm) in the
 * column order of kinematics.h (AACMM_ARM_COL_*; AACMM_COL_* for the paper's
 * arm):
 *     rotation columns (theta, alpha, beta; mm/rad): u x (p - o) with the
 *         axis u and point o of kinematics.h (the paper's arm: theta_i
 *         z_{i-1} x (p - o_{i-1}), alpha_i x_i x (p - o_i)):
 *         the vector v = p - o (Q48) is rounded half up to Q18 int32
 *         (|v| <= 8000 mm, so |v| * 2^18 < 2^31), and each component of the
 *         cross product is the exact int64 difference of two Q30 x Q18 = Q48
 *         products (< 2^62): the output. Rounding error <= 2 x 2^-19 mm/rad,
 *         from v. ARMv6-M: v is rounded half up to Q17 (|v| * 2^17 < 2^30)
 *         and each product to Q17 (aacmm_fixed_mul_q30), so an entry is
 *         within 2^-18 + 2 x 2^-18 = 1.1e-5 mm/rad of the exact cross product
 *         of the rounded axes. For a standard joint 1, theta_1 is z_0 x p =
 *         (-p_y, p_x, 0) exactly.
 *     translation columns (d, a, tip; mm/mm): the Q30 axes times 2^18 (exact).
 * AACMM_ERR_NULL if any pointer is NULL (nothing written), else AACMM_OK.
 * jac_q48 holds 3 P values (AACMM_JAC_SIZE_MAX at most). Cost: aacmm_point_q
 * + about 11 multiplies per rotation column; the paper's arm: + 66.
 */
aacmm_status_t aacmm_point_jacobian_q(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                                      int64_t p_q48[3], int64_t *jac_q48);

/*
 * Batch entry points: n poses in, n points (n*3 Q48 values) and, if jac_q48
 * is not NULL, n Jacobians (n*3P Q48 values, pose after pose) out.
 *   _bam:    theta_bam holds n*N binary angles.
 *   _counts: reading_counts holds n*N raw encoder readings, converted with
 *            aacmm_arm_encoders_to_bam (shared core, integer only: exact for
 *            power-of-two resolutions, nearest BAM otherwise); encoders->joints
 *            must be N (else AACMM_ERR_RANGE, nothing written). Readings at or
 *            above their resolution, or invalid encoders, give
 *            AACMM_ERR_RANGE.
 * Stops at the first invalid pose and returns its error; *done (if not NULL)
 * receives the number of poses fully written before it (n on success). n = 0
 * is valid and writes nothing. AACMM_ERR_NULL for a NULL model/encoders, or
 * NULL arrays with n > 0. Cost: n times the single-pose cost.
 */
aacmm_status_t aacmm_batch_bam_q(const aacmm_model_q_t *model, size_t n, const uint32_t *theta_bam,
                                 int64_t *p_q48, int64_t *jac_q48, size_t *done);
aacmm_status_t aacmm_batch_counts_q(const aacmm_model_q_t *model,
                                    const aacmm_arm_encoders_t *encoders, size_t n,
                                    const uint32_t *reading_counts, int64_t *p_q48,
                                    int64_t *jac_q48, size_t *done);

/* ------------------------------------------------------------------------ */
/* Error model: encoder harmonics and thermal expansion (issue 27)           */
/* ------------------------------------------------------------------------ */

/*
 * The error model of kinematics.h (its formulas, column order and the link
 * each length belongs to) in integer arithmetic, beside the fixed model:
 * nothing is added to aacmm_model_q_t (the device's structures keep their
 * size). Formats:
 *
 *   what                      type     format        unit     range
 *   c_ik, s_ik                int32_t  Q36 turn      turn     per joint sum |c| + |s|
 *                                      (2^-36 turn =          <= AACMM_Q_HARMONIC_SUM_MAX
 *                                      9.1e-11 rad)           (0.1 rad)
 *   cte                       int32_t  Q40           1/K      |x| <= AACMM_Q_CTE_MAX (1e-3)
 *   temperatures, tref        int32_t  Q8            degC     AACMM_Q_TEMP_MIN .. _MAX
 *                                      (1/256 degC)           (-40 .. 85 degC)
 *   cos kq, sin kq            int32_t  Q30           1        |x| <= 1 + 2^-27
 *   harmonic columns          int64_t  Q48           mm/rad   as the theta columns
 *
 * Correction of joint i (K_i > 0): s, c = aacmm_sincos_q(reading); cos kq,
 * sin kq by the recurrence of kinematics.h, each product rounded half up to
 * Q30 (|error| grows by <= 1 LSB + twice the previous per step: < 8 LSB at
 * k = 4); the sum of c_ik cos kq + s_ik sin kq is exact in int64 (Q66 turn;
 * |sum| <= AACMM_Q_HARMONIC_SUM_MAX 2^30 (1 + 2^-27) < 2^61) and rounded
 * half up once to BAM (>> 34), added to the reading mod 2^32: within 0.5 BAM
 * (0.73 nrad) plus the Q30 errors times 0.1 rad. ARMv6-M: each product
 * rounded half up to Q36 turn (aacmm_fixed_mul_q30), summed in int32 (|sum|
 * <= 0.1 rad + 8 LSB < 2^31), rounded half up to BAM (>> 4): within 4.5 BAM
 * more.
 * Harmonic columns: the theta column (Q48) rounded half up to Q18 int32
 * (|.| <= 8000 mm/rad < 2^31) times cos kq (Q30): Q48, exact; within
 * 2^-19 mm/rad (1.9e-6) of the product of the column and cos kq. ARMv6-M:
 * Q17 and aacmm_fixed_mul_q30 (within 2^-17, 7.6e-6).
 * Thermal: e_i = cte_i (T_i - tref_i), exact in int64 (Q48, |e| <= 0.125),
 * rounded half up to Q30; each length L0 (Q18) becomes L0 + round(L0 e_i)
 * (the Q48 product rounded half up to Q18: within 2^-19 mm of the exact
 * scaling of L0); the scaled arm must pass aacmm_arm_q_validate (the total
 * reach), else AACMM_ERR_RANGE. With temperatures the length columns are
 * those of L0: the Q30 axis times (2^30 + e_i), rounded half up to Q48
 * (within 2^-49). The fixed path has no cte columns (calibration runs in
 * double; kinematics.h).
 * Saturation: none is needed: validation bounds every sum above; angles wrap.
 */
#define AACMM_Q_HARM_FRAC 36 /* harmonic coefficients: 2^-36 turn */
#define AACMM_Q_CTE_FRAC 40  /* cte: Q40 1/K */
#define AACMM_Q_TEMP_FRAC 8  /* temperatures: Q8 degC */
/* 0.1 rad in 2^-36 turn, rounded down: 0.1 / (2 pi) * 2^36 = 1093704440.9 */
#define AACMM_Q_HARMONIC_SUM_MAX INT32_C(1093704440)
/* 1e-3 / K in Q40, rounded down: 1099511627.8 */
#define AACMM_Q_CTE_MAX INT32_C(1099511627)
#define AACMM_Q_TEMP_MIN INT32_C(-10240) /* -40 degC in Q8 */
#define AACMM_Q_TEMP_MAX INT32_C(21760)  /* 85 degC in Q8 */
#define AACMM_Q_TEMP_REF_DEFAULT INT32_C(5120) /* 20 degC in Q8 */

/*
 * The error model in fixed point (the fields of aacmm_errmodel_f64_t without
 * cte_columns). harmonics[i] = K_i 0 .. AACMM_HARMONICS_MAX, 0 from index N
 * on; c_q36 / s_q36[i][k - 1], 0 past K_i; cte_q40 0 from N on; tref_q8 in
 * range. 288 bytes.
 */
typedef struct {
    uint8_t joints;
    uint8_t harmonics[AACMM_JOINTS_MAX];
    int32_t c_q36[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    int32_t s_q36[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    int32_t cte_q40[AACMM_JOINTS_MAX];
    int32_t tref_q8[AACMM_JOINTS_MAX];
} aacmm_errmodel_q_t;

/* No correction for `joints` joints (4 .. 7, else AACMM_ERR_RANGE): K = 0,
 * cte 0, tref 20 degC. AACMM_ERR_NULL or AACMM_OK. Integer only. */
aacmm_status_t aacmm_errmodel_q_default(aacmm_errmodel_q_t *em, int joints);

/* AACMM_OK, AACMM_ERR_NULL, or AACMM_ERR_RANGE for joints outside 4 .. 7, a
 * K_i above AACMM_HARMONICS_MAX, a per-joint sum above
 * AACMM_Q_HARMONIC_SUM_MAX, a coefficient past K_i, a cte above
 * AACMM_Q_CTE_MAX, a tref out of range, a non-zero entry from N on.
 * Integer only. Cost: O(N K). */
aacmm_status_t aacmm_errmodel_q_validate(const aacmm_errmodel_q_t *em);

/* E = 2 sum(K_i) (no cte columns in fixed point), or a negative status for
 * NULL or invalid joints / K. */
int aacmm_errmodel_q_cols(const aacmm_errmodel_q_t *em);

/* *out = *model with its lengths at the link temperatures temp_q8[0 .. N-1]
 * (Q8 degC; NULL: a copy), as above. AACMM_ERR_NULL; AACMM_ERR_RANGE for an
 * invalid error model, a joint count mismatch, a temperature out of range or
 * a scaled reach beyond AACMM_Q_REACH_MAX_MM. *out unchanged on error; out
 * may equal model only with temp_q8 NULL. Integer only. Cost: 2N + 3 64-bit
 * products (ARMv6-M: aacmm_fixed_mul). */
aacmm_status_t aacmm_model_q_at_temperature(aacmm_model_q_t *out, const aacmm_model_q_t *model,
                                            const aacmm_errmodel_q_t *em,
                                            const int32_t *temp_q8);

/*
 * aacmm_point_q / aacmm_point_jacobian_q with the error model: the readings
 * corrected, the lengths at temp_q8 (NULL: the reference temperatures), the
 * extended 3 x (P + E) Jacobian (jac_q48 holds 3 (P + E) values, at most
 * 3 (AACMM_PARAMS_MAX + 2 AACMM_HARMONICS_MAX AACMM_JOINTS_MAX) = 279).
 * em NULL, or K = 0 everywhere with temp_q8 NULL: exactly aacmm_point_q /
 * aacmm_point_jacobian_q (bit for bit). The error model must have passed
 * aacmm_errmodel_q_validate (as the model its init): per pose the joint
 * count and every K_i are checked and the temperatures (out of range, or a
 * scaled reach beyond the limit: AACMM_ERR_RANGE); AACMM_ERR_NULL. Nothing
 * written on error. Integer only.
 * Cost per corrected joint: one aacmm_sincos_q, 2 (K - 1) + 2 K products for
 * the correction and 6 K for the columns (the paper's arm, K = 2 on every
 * joint: docs/fixed-point.md has the instructions on the Cortex-M0 and M4F);
 * with temperatures + a model copy (284 bytes of stack) and the scaling.
 */
aacmm_status_t aacmm_point_em_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                const uint32_t *theta_bam, const int32_t *temp_q8,
                                int64_t p_q48[3]);
aacmm_status_t aacmm_point_jacobian_em_q(const aacmm_model_q_t *model,
                                         const aacmm_errmodel_q_t *em, const uint32_t *theta_bam,
                                         const int32_t *temp_q8, int64_t p_q48[3],
                                         int64_t *jac_q48);

/* The point and the 3 x P structural Jacobian (the columns of
 * aacmm_point_jacobian_q, jac_q48 of 3 P values) at the corrected readings
 * and the link temperatures: the device's wire format. The harmonic columns
 * follow from its theta columns (times cos kq, sin kq of the readings) where
 * they are needed (a calibration on the host); the first 3 P entries of
 * aacmm_point_jacobian_em_q, row by row, bit for bit. Errors as
 * aacmm_point_jacobian_em_q. Cost: aacmm_point_jacobian_q + the correction
 * (docs/fixed-point.md: the paper's arm, K = 2 on every joint, on the M0). */
aacmm_status_t aacmm_point_jacobian_corrected_q(const aacmm_model_q_t *model,
                                                const aacmm_errmodel_q_t *em,
                                                const uint32_t *theta_bam, const int32_t *temp_q8,
                                                int64_t p_q48[3], int64_t *jac_q48);

/* The corrected readings alone: q_out[i] = joint i's reading plus its
 * harmonic correction (BAM, mod 2^32), i < N, the values
 * aacmm_point_jacobian_corrected_q runs the chain on without temperatures
 * (so aacmm_point_q / aacmm_point_jacobian_q of q_out are aacmm_point_em_q /
 * aacmm_point_jacobian_corrected_q, bit for bit, with a smaller stack: the
 * device's path). The same preconditions and per-pose checks (joint count,
 * K_i: AACMM_ERR_RANGE); AACMM_ERR_NULL. q_out may equal theta_bam. Integer
 * only. Cost: the correction alone. */
aacmm_status_t aacmm_errmodel_q_correct(const aacmm_model_q_t *model,
                                        const aacmm_errmodel_q_t *em, const uint32_t *theta_bam,
                                        uint32_t *q_out);

/* n poses of aacmm_point_jacobian_em_q (jac_q48 NULL: points only):
 * theta_bam[n N], temp_q8[n N] or NULL, p_q48[n 3], jac_q48[n 3 (P + E)];
 * stops at the first bad pose, *done as aacmm_batch_bam_q. */
aacmm_status_t aacmm_batch_bam_em_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                    size_t n, const uint32_t *theta_bam, const int32_t *temp_q8,
                                    int64_t *p_q48, int64_t *jac_q48, size_t *done);

/* Host / load time (kinematics_q_convert.c, uses double): the double error
 * model in fixed point (aacmm_errmodel_validate_f64 first; c, s as round(x /
 * (2 pi) 2^36), cte round(x 2^40), tref round(x 256), half away from zero;
 * then aacmm_errmodel_q_validate; its cte_columns is dropped), and back
 * (exact but for c, s: x 2 pi 2^-36, within 1e-16 relative). Temperatures
 * for the per-pose calls: aacmm_temp_q8_from_f64 (NaN: AACMM_ERR_NOT_FINITE,
 * out of range: AACMM_ERR_RANGE), n values. */
aacmm_status_t aacmm_errmodel_q_from_f64(aacmm_errmodel_q_t *out, const aacmm_errmodel_f64_t *in);
aacmm_status_t aacmm_errmodel_q_to_f64(aacmm_errmodel_f64_t *out, const aacmm_errmodel_q_t *in);
aacmm_status_t aacmm_temp_q8_from_f64(int32_t *out, const double *temp_c, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_KINEMATICS_Q_H */
