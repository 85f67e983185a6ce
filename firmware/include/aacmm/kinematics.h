/*
 * aacmm kinematics core: encoder counts -> joint angles -> probe point, and
 * the analytic 3x25 Jacobian of the point with respect to every structural
 * parameter of the arm.
 *
 * Model (Gao, Wang, Zhou 2013, Eq. 1-3): standard Denavit-Hartenberg,
 *
 *     T_{i-1,i} = Rot(z, theta_i) Trans(0, 0, d_i) Trans(a_i, 0, 0) Rot(x, alpha_i)
 *     [x y z 1]^T = T_{0,1} T_{1,2} ... T_{5,6} [0 0 l 1]^T
 *
 * where theta_i = joint reading_i + theta_offset_i. Lengths are in mm, angles
 * in rad. The Jacobian is 3 rows (x, y, z) by 25 columns, row-major, columns in
 * the paper's Eq. 10 order:
 *
 *     theta_1..6 (mm/rad), alpha_1..6 (mm/rad), d_1..6, a_1..6, l (mm/mm)
 *
 * so entry (row r, column c) is jac[r * AACMM_JAC_COLS + c].
 *
 * Precision: every function exists in single precision (suffix _f32, for the
 * Cortex-M4F FPU: float arithmetic only, no double-precision helpers) and
 * double precision (suffix _f64, for host analysis). Both are compiled from one
 * source (kinematics_impl.h). The fixed-point path for FPU-less parts lives in
 * kinematics_q.h.
 *
 * Ownership: the caller owns every struct and buffer; nothing is allocated,
 * nothing is kept between calls, no global state is touched. All functions are
 * reentrant. Costs are stated per call for one pose.
 */
#ifndef AACMM_KINEMATICS_H
#define AACMM_KINEMATICS_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define AACMM_JOINTS 6
#define AACMM_JAC_ROWS 3
#define AACMM_JAC_COLS 25
#define AACMM_JAC_SIZE (AACMM_JAC_ROWS * AACMM_JAC_COLS) /* 75 entries */

/* Column index of each structural parameter in the Jacobian (joint i = 0..5). */
#define AACMM_COL_THETA(i) (i)
#define AACMM_COL_ALPHA(i) (6 + (i))
#define AACMM_COL_D(i) (12 + (i))
#define AACMM_COL_A(i) (18 + (i))
#define AACMM_COL_L 24

/* Validity limits. Lengths beyond 10 m or angles beyond one turn are not an
 * arm; rejecting them also keeps every intermediate far from overflow. */
#define AACMM_LENGTH_MAX_MM 10000.0
#define AACMM_PARAM_ANGLE_MAX_RAD 6.283185307179586 /* |theta_offset|, |alpha| <= 2 pi */
#define AACMM_JOINT_ANGLE_MAX_RAD 1024.0            /* |joint angle| accepted by the point functions */

/* ------------------------------------------------------------------------ */
/* Structural parameters                                                     */
/* ------------------------------------------------------------------------ */

/* One arm's structural parameters, double precision. Units: mm and rad. */
typedef struct {
    double theta_offset_rad[AACMM_JOINTS]; /* added to each joint reading; |x| <= 2 pi */
    double alpha_rad[AACMM_JOINTS];        /* DH twist; |x| <= 2 pi */
    double d_mm[AACMM_JOINTS];             /* DH offset along z_{i-1}; |x| <= 10000 */
    double a_mm[AACMM_JOINTS];             /* DH length along x_i; |x| <= 10000 */
    double l_mm;                           /* probe length along z_6; |x| <= 10000 */
} aacmm_params_f64_t;

/* The same in single precision. */
typedef struct {
    float theta_offset_rad[AACMM_JOINTS];
    float alpha_rad[AACMM_JOINTS];
    float d_mm[AACMM_JOINTS];
    float a_mm[AACMM_JOINTS];
    float l_mm;
} aacmm_params_f32_t;

/*
 * Fill *params with the paper's Table 1: d = (300, 65.5, 792.7, 65.5, 883.2, 0)
 * mm, a = 0, alpha = pi/2 for all joints, theta offsets 0, l = 183.5 mm.
 * Returns AACMM_ERR_NULL if params is NULL, else AACMM_OK. Cost: O(1).
 */
aacmm_status_t aacmm_params_default_f64(aacmm_params_f64_t *params);
aacmm_status_t aacmm_params_default_f32(aacmm_params_f32_t *params);

/*
 * Check every field: AACMM_ERR_NOT_FINITE for NaN/inf, AACMM_ERR_RANGE for a
 * value outside the limits above, AACMM_ERR_NULL for a NULL pointer, else
 * AACMM_OK. Cost: 25 comparisons.
 */
aacmm_status_t aacmm_params_validate_f64(const aacmm_params_f64_t *params);
aacmm_status_t aacmm_params_validate_f32(const aacmm_params_f32_t *params);

/*
 * A prepared model: the parameters plus the per-joint sine and cosine of alpha,
 * computed once so that each pose needs only the six joint sines and cosines.
 * Treat as opaque; build it with aacmm_model_init_*.
 */
typedef struct {
    aacmm_params_f64_t params;
    double sin_alpha[AACMM_JOINTS];
    double cos_alpha[AACMM_JOINTS];
} aacmm_model_f64_t;

typedef struct {
    aacmm_params_f32_t params;
    float sin_alpha[AACMM_JOINTS];
    float cos_alpha[AACMM_JOINTS];
} aacmm_model_f32_t;

/*
 * Validate *params (as aacmm_params_validate_*) and, if valid, copy them into
 * *model with their alpha sines and cosines. On error *model is left unchanged.
 * Cost: 6 sine/cosine pairs.
 */
aacmm_status_t aacmm_model_init_f64(aacmm_model_f64_t *model, const aacmm_params_f64_t *params);
aacmm_status_t aacmm_model_init_f32(aacmm_model_f32_t *model, const aacmm_params_f32_t *params);

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

/*
 * Per-joint encoder description.
 *   counts_per_rev: resolution, 2 .. 2^32 (2^32 = 4294967296 for a full
 *                   32-bit absolute encoder).
 *   zero_offset_counts: the reading at which the joint angle is zero;
 *                   must be < counts_per_rev.
 *   direction:      +1 if counts increase with the DH angle, -1 if they
 *                   decrease.
 */
typedef struct {
    uint64_t counts_per_rev[AACMM_JOINTS];
    uint32_t zero_offset_counts[AACMM_JOINTS];
    int8_t direction[AACMM_JOINTS];
} aacmm_encoder_config_t;

/*
 * Fill *config with 2^32 counts per revolution, zero offset 0 and direction
 * +1 on every joint (readings are then binary angles). AACMM_ERR_NULL or
 * AACMM_OK.
 */
aacmm_status_t aacmm_encoder_default(aacmm_encoder_config_t *config);

/*
 * AACMM_ERR_RANGE if any counts_per_rev is outside 2 .. 2^32, a zero offset is
 * >= its counts_per_rev, or a direction is not +1/-1; AACMM_ERR_NULL for NULL;
 * else AACMM_OK. Cost: O(6).
 */
aacmm_status_t aacmm_encoder_validate(const aacmm_encoder_config_t *config);

/*
 * Signed joint position in counts:
 *     delta = (reading - zero_offset) mod counts_per_rev, in 0 .. cpr-1
 *     s     = delta        if 2 * delta <  cpr
 *           = delta - cpr  otherwise              (so s is in [-cpr/2, cpr/2))
 *     counts_out = direction * s                  (in [-cpr/2, cpr/2])
 * Wrap-around is handled exactly: a reading just below the zero offset gives
 * a small negative count. Readings must be < counts_per_rev (an absolute
 * encoder never reports more); otherwise AACMM_ERR_RANGE and nothing is
 * written. The config must be valid (aacmm_encoder_validate); invalid configs
 * give AACMM_ERR_RANGE. Cost: O(6), integer only.
 */
aacmm_status_t aacmm_encoder_signed_counts(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           int64_t counts_out[AACMM_JOINTS]);

/*
 * Joint angles in rad, in [-pi, pi], from raw readings (see
 * aacmm_encoder_signed_counts for the mapping and errors).
 * Accuracy: for every resolution the result is the exact value
 * s * 2 pi / cpr correctly rounded to the output type: |s| times 2 pi to 128
 * bits, divided by cpr in integer arithmetic (the exact value lies within 1.5
 * units of the quotient's last bit), the top 64 bits plus a sticky bit
 * rounded once; when the quotient lies one or two units under a rounding
 * midpoint the angle is formed again with 2 pi to 192 bits. Exception: an
 * exact angle within 1.5 2^-180 (relative) of a midpoint, which no reading is
 * expected to meet (docs/kinematics.md). The _f32 variant uses no double
 * arithmetic.
 * Cost: O(6); per joint a 4-limb product, for non-power-of-two resolutions 5
 * 64/32-bit divisions, two rounding checks, one int-to-float conversion.
 */
aacmm_status_t aacmm_encoder_to_angles_f64(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           double theta_rad[AACMM_JOINTS]);
aacmm_status_t aacmm_encoder_to_angles_f32(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           float theta_rad[AACMM_JOINTS]);

/*
 * Binary angles (uint32, 2^32 = one turn, 0 = zero angle, wrapping) from raw
 * readings, for the fixed-point path: round(s * 2^32 / cpr) mod 2^32 with
 * s from aacmm_encoder_signed_counts. Exact for power-of-two resolutions;
 * otherwise rounded to nearest (error <= 1/2 of 2^-32 turn, 0.73 nrad).
 * Errors as aacmm_encoder_signed_counts. Cost: O(6), one 64-bit division per
 * joint for non-power-of-two resolutions.
 */
aacmm_status_t aacmm_encoder_to_bam(const aacmm_encoder_config_t *config,
                                    const uint32_t reading_counts[AACMM_JOINTS],
                                    uint32_t angle_bam[AACMM_JOINTS]);

/* ------------------------------------------------------------------------ */
/* Forward kinematics and Jacobian                                           */
/* ------------------------------------------------------------------------ */

/*
 * Probe point p_mm = (x, y, z) in the base frame for joint readings theta_rad
 * (the theta offsets of the model are added). Joint angles must be finite and
 * |theta| <= AACMM_JOINT_ANGLE_MAX_RAD, else AACMM_ERR_RANGE (or
 * AACMM_ERR_NOT_FINITE) and p_mm is not written. The model must come from
 * aacmm_model_init_*. Cost: 6 sine/cosine pairs + about 120 flops.
 */
aacmm_status_t aacmm_point_f64(const aacmm_model_f64_t *model, const double theta_rad[AACMM_JOINTS],
                               double p_mm[3]);
aacmm_status_t aacmm_point_f32(const aacmm_model_f32_t *model, const float theta_rad[AACMM_JOINTS],
                               float p_mm[3]);

/*
 * Probe point and the full 3x25 Jacobian in one pass (see the column order at
 * the top). jac must hold AACMM_JAC_SIZE values; it is written row-major.
 * Each column is geometric, not a finite difference:
 *     d p / d theta_i = z_{i-1} x (p - o_{i-1})
 *     d p / d alpha_i = x_i x (p - o_i)
 *     d p / d d_i     = z_{i-1}
 *     d p / d a_i     = x_i
 *     d p / d l       = z_6
 * d p_z / d theta_1 is exactly 0. Errors as aacmm_point_*; on error nothing is
 * written. Cost: 6 sine/cosine pairs + about 330 flops.
 */
aacmm_status_t aacmm_point_jacobian_f64(const aacmm_model_f64_t *model,
                                        const double theta_rad[AACMM_JOINTS], double p_mm[3],
                                        double jac[AACMM_JAC_SIZE]);
aacmm_status_t aacmm_point_jacobian_f32(const aacmm_model_f32_t *model,
                                        const float theta_rad[AACMM_JOINTS], float p_mm[3],
                                        float jac[AACMM_JAC_SIZE]);

/*
 * Batch entry points for host analysis: n poses in, n points (n*3 values) and,
 * if jac is not NULL, n Jacobians (n*75 values, pose after pose) out.
 *   _angles: theta_rad holds n*6 joint readings in rad.
 *   _counts: reading_counts holds n*6 raw encoder readings, converted with
 *            aacmm_encoder_to_angles_* first.
 * Stops at the first invalid pose and returns its error; *done (if not NULL)
 * receives the number of poses fully written before it (n on success). n = 0
 * is valid and writes nothing. Cost: n times the single-pose cost.
 */
aacmm_status_t aacmm_batch_angles_f64(const aacmm_model_f64_t *model, size_t n,
                                      const double *theta_rad, double *p_mm, double *jac,
                                      size_t *done);
aacmm_status_t aacmm_batch_angles_f32(const aacmm_model_f32_t *model, size_t n,
                                      const float *theta_rad, float *p_mm, float *jac,
                                      size_t *done);
aacmm_status_t aacmm_batch_counts_f64(const aacmm_model_f64_t *model,
                                      const aacmm_encoder_config_t *encoders, size_t n,
                                      const uint32_t *reading_counts, double *p_mm, double *jac,
                                      size_t *done);
aacmm_status_t aacmm_batch_counts_f32(const aacmm_model_f32_t *model,
                                      const aacmm_encoder_config_t *encoders, size_t n,
                                      const uint32_t *reading_counts, float *p_mm, float *jac,
                                      size_t *done);

/*
 * Sine and cosine of x in rad, as used by the kinematics (own implementation:
 * Cody-Waite reduction by pi/2 and Taylor polynomials on [-pi/4, pi/4]).
 * Valid for |x| <= 2048. Error: _f64 within 2 ulp of the result (measured
 * 1.55); _f32 within 2 ulp of the result for |x| <= 4 (measured 1.44), and
 * for |x| up to 2048 within 2 units of max(ulp(result), 2^-27), i.e. within
 * 1.5e-8 absolute for results near zero (measured 1.49 such units; up to
 * 255 ulp of a result near zero). docs/kinematics.md has both metrics.
 * Cost: about 25 flops, no branches but the quadrant.
 */
void aacmm_sincos_f64(double x, double *s, double *c);
void aacmm_sincos_f32(float x, float *s, float *c);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_KINEMATICS_H */
