/*
 * aacmm kinematics core: encoder counts -> joint angles -> probe point, and
 * the analytic 3 x P Jacobian of the point with respect to every structural
 * parameter, for any serial arm of N revolute joints, 4 <= N <= 7.
 *
 * ---- The model ------------------------------------------------------------
 *
 * The probe point is [x y z 1]^T = A_1 A_2 ... A_N [t_x t_y t_z 1]^T, one
 * transform per joint i = 1..N in that joint's convention:
 *
 *   standard DH (the paper's Eq. 1-2, Gao, Wang, Zhou 2013):
 *     A_i = [Ry(beta_i)] Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
 *   modified DH (Craig's convention; alpha_i, a_i describe the link from
 *   axis i-1 to axis i, so they come first):
 *     A_i = Rx(alpha_i) Tx(a_i) [Ry(beta_i)] Rz(theta_i) Tz(d_i)
 *
 * with theta_i = joint reading_i + theta_offset_i. Lengths are in mm, angles
 * in rad. Conventions may differ from joint to joint.
 *
 * Hayati's beta. Where the axes of joints i-1 and i are parallel or nearly
 * so, the common normal of DH is ill-defined: a tiny misalignment moves it
 * (and d) by a large amount, so DH is singular there and calibration
 * ill-conditioned (the paper's section 2.1). Hayati and Mirmirani (1985,
 * "Improving the absolute positioning accuracy of robot manipulators",
 * J. Robotic Systems 2(4); as given in Mooring, Roth, Driels, "Fundamentals
 * of manipulator calibration", 1991) add a rotation Ry(beta) about the y
 * axis after the twist Rx(alpha) between the two parallel axes:
 * Rz(theta) Tx(a) Rx(alpha) Ry(beta). So alpha and beta together describe
 * the small tilt of the second axis in both directions. Here a beta is
 * declared on joint i (2 <= i <= N: joint 1 has no previous axis) and
 * Ry(beta_i) is applied immediately before Rz(theta_i) in the product above:
 *   standard DH: it closes A_{i-1} = Rz(theta_{i-1}) Tz(d_{i-1})
 *                Tx(a_{i-1}) Rx(alpha_{i-1}) Ry(beta_i), Hayati's placement
 *                after the twist alpha_{i-1} between the axes of joints i-1
 *                and i (written at the start of A_i above, the same product);
 *   modified DH: it follows Rx(alpha_i) Tx(a_i), the twist and offset
 *                between the same two axes: Hayati's order of the link
 *                part, Tx(a) Rx(alpha) Ry(beta), in the convention that puts
 *                the link first. (The MicroScribe SDK's model is modified DH
 *                with a beta at its parallel hinges; its text was not found
 *                to confirm the placement.)
 * Hayati drops the d of that link, which a parallel pair makes redundant;
 * this core keeps every d (set it to 0 and hold it fixed in a calibration, or
 * let the identifiability analysis name the redundant direction).
 *
 * Probe tip: AACMM_TIP_Z puts it at (0, 0, l) in frame N (the paper's l, one
 * parameter); AACMM_TIP_XYZ at (t_x, t_y, t_z) (three parameters).
 *
 * ---- Parameters and Jacobian columns (generalises the paper's Eq. 10) -----
 *
 * The parameter vector, and the columns of the 3 x P Jacobian, in this
 * order (N joints, B declared betas, T = 1 or 3 tip parameters):
 *
 *   columns              parameters                         unit of dp/dq
 *   0 .. N-1             theta_1 .. theta_N (offsets)        mm/rad
 *   N .. 2N-1            alpha_1 .. alpha_N                  mm/rad
 *   2N .. 3N-1           d_1 .. d_N                          mm/mm
 *   3N .. 4N-1           a_1 .. a_N                          mm/mm
 *   4N .. 4N+B-1         beta of each joint declaring one,   mm/rad
 *                        in joint order
 *   4N+B .. 4N+B+T-1     the tip: l (AACMM_TIP_Z) or         mm/mm
 *                        t_x, t_y, t_z (AACMM_TIP_XYZ)
 *
 * P = 4N + B + T <= AACMM_PARAMS_MAX (37). For the paper's arm (N = 6,
 * standard DH, no beta, tip l) these are exactly the paper's 25 columns in
 * its order (AACMM_COL_THETA(i) .. AACMM_COL_L below). The Jacobian is
 * row-major, rows x, y, z: entry (r, c) is jac[r * P + c]. Blocks of
 * parameters added later (issue 27: encoder harmonics, thermal expansion)
 * follow the tip, so every column above keeps its index.
 *
 * Each column is geometric, not a finite difference. With the frame (x, y,
 * z axes, origin o) running down the chain, a parameter that acts at some
 * point of the product moves everything after it:
 *     a rotation about an axis u through a point o:  dp/dq = u x (p - o)
 *     a translation along an axis u:                 dp/dq = u
 * where u, o are the frame's at that point of the product: theta_i about
 * z (after Ry(beta_i)), alpha_i about x (standard: after Rz(theta_i);
 * modified: before it), beta_i about y (the frame's y before Ry, which Ry
 * keeps), d_i along that same z, a_i along that same x, the tip along the
 * axes of frame N. For joint 1 in standard DH, dp/dtheta_1 = z_0 x p has an
 * exactly zero z component.
 *
 * ---- Precisions, paths, ownership ------------------------------------------
 *
 * Every function exists in single precision (suffix _f32, for the Cortex-M4F
 * FPU: float arithmetic only, no double-precision helpers) and double
 * precision (suffix _f64, for host analysis), compiled from one source
 * (firmware/src/kinematics_impl.h). The fixed-point path for FPU-less parts
 * is kinematics_q.h; batch kernels across SIMD lanes are simd.h.
 *
 * The paper's shape (N = 6, standard DH everywhere, no beta, tip l: any
 * model of that shape, whatever its values) runs a chain specialised at
 * compile time; every other shape runs the general chain. Both are one
 * template (firmware/src/chain_impl.h), so they perform the same operations
 * in the same order, and the paper's arm gives bit for bit what this core
 * gave before the general model (tested against golden values of commit
 * aa8b712 on every path).
 *
 * Ownership: the caller owns every struct and buffer; nothing is allocated,
 * nothing is kept between calls, no global state is touched. All functions
 * are reentrant. Costs are stated per call for one pose.
 */
#ifndef AACMM_KINEMATICS_H
#define AACMM_KINEMATICS_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Limits of the general model: size caller buffers with these ---- */
#define AACMM_JOINTS_MIN 4
#define AACMM_JOINTS_MAX 7
#define AACMM_BETAS_MAX (AACMM_JOINTS_MAX - 1) /* joints 2 .. N */
#define AACMM_TIP_MAX 3
/* Parameters (Jacobian columns) of the largest model: 4 * 7 + 6 + 3 = 37. */
#define AACMM_PARAMS_MAX (4 * AACMM_JOINTS_MAX + AACMM_BETAS_MAX + AACMM_TIP_MAX)
#define AACMM_JAC_ROWS 3
#define AACMM_JAC_SIZE_MAX (AACMM_JAC_ROWS * AACMM_PARAMS_MAX) /* 111 entries */

/* Column index of each parameter of an N-joint model with B betas. */
#define AACMM_ARM_COL_THETA(n, i) (i)             /* joint i = 0 .. n-1 */
#define AACMM_ARM_COL_ALPHA(n, i) ((n) + (i))
#define AACMM_ARM_COL_D(n, i) (2 * (n) + (i))
#define AACMM_ARM_COL_A(n, i) (3 * (n) + (i))
#define AACMM_ARM_COL_BETA(n, k) (4 * (n) + (k))  /* the k-th declared beta, k = 0 .. b-1 */
#define AACMM_ARM_COL_TIP(n, b) (4 * (n) + (b))   /* l, or t_x (then t_y, t_z) */

/* ---- The paper's arm (6 joints, 25 parameters): today's wire format, the
 * stored parameter record, aacmm_params_*_t below ---- */
#define AACMM_JOINTS 6
#define AACMM_JAC_COLS 25
#define AACMM_JAC_SIZE (AACMM_JAC_ROWS * AACMM_JAC_COLS) /* 75 entries */

/* Column index of each structural parameter of the paper's arm (i = 0..5). */
#define AACMM_COL_THETA(i) (i)
#define AACMM_COL_ALPHA(i) (6 + (i))
#define AACMM_COL_D(i) (12 + (i))
#define AACMM_COL_A(i) (18 + (i))
#define AACMM_COL_L 24

/* Validity limits. Lengths beyond 10 m or angles beyond one turn are not an
 * arm; rejecting them also keeps every intermediate far from overflow. */
#define AACMM_LENGTH_MAX_MM 10000.0                 /* |d|, |a|, |l|, |t_x|, |t_y|, |t_z| */
#define AACMM_PARAM_ANGLE_MAX_RAD 6.283185307179586 /* |theta_offset|, |alpha|, |beta| <= 2 pi */
#define AACMM_JOINT_ANGLE_MAX_RAD 1024.0            /* |joint angle| accepted by the point functions */

/* ------------------------------------------------------------------------ */
/* Shape of an arm                                                           */
/* ------------------------------------------------------------------------ */

typedef enum {
    AACMM_DH_STANDARD = 0, /* Rz(theta) Tz(d) Tx(a) Rx(alpha): the paper's Eq. 1 */
    AACMM_DH_MODIFIED = 1  /* Rx(alpha) Tx(a) Rz(theta) Tz(d): Craig's */
} aacmm_dh_convention_t;

typedef enum {
    AACMM_TIP_Z = 1,  /* tip (0, 0, l) in frame N: one parameter */
    AACMM_TIP_XYZ = 3 /* tip (t_x, t_y, t_z) in frame N: three parameters */
} aacmm_tip_kind_t;

/*
 * What an arm is made of, independent of its values and precision.
 *   joints:      N, AACMM_JOINTS_MIN .. AACMM_JOINTS_MAX
 *   tip:         AACMM_TIP_Z or AACMM_TIP_XYZ (the value is the number of
 *                tip parameters)
 *   convention:  per joint, AACMM_DH_STANDARD or AACMM_DH_MODIFIED
 *   beta:        per joint, 1 if it declares a Hayati beta, else 0; never
 *                joint 1 (index 0)
 * Entries from index N on must be 0. Zero-initialise, then set.
 */
typedef struct {
    uint8_t joints;
    uint8_t tip;
    uint8_t convention[AACMM_JOINTS_MAX];
    uint8_t beta[AACMM_JOINTS_MAX];
} aacmm_shape_t;

/* Fill *shape with the paper's: 6 standard joints, no beta, tip l.
 * AACMM_ERR_NULL or AACMM_OK. */
aacmm_status_t aacmm_shape_paper(aacmm_shape_t *shape);

/*
 * AACMM_OK for a valid shape; AACMM_ERR_NULL for NULL; AACMM_ERR_RANGE for
 * joints outside 4..7, an unknown tip kind or convention, a beta flag other
 * than 0/1, a beta on joint 1, or a non-zero entry from index N on.
 * Cost: O(N).
 */
aacmm_status_t aacmm_shape_validate(const aacmm_shape_t *shape);

/* P = 4N + B + T for a valid shape, else the (negative) status of
 * aacmm_shape_validate. Cost: O(N). */
int aacmm_shape_params(const aacmm_shape_t *shape);

/* The Jacobian column of joint i's beta (i = 0 .. N-1), or -1 if joint i
 * declares none or i is out of range; the first tip column
 * (AACMM_ARM_COL_TIP). Both -1 for an invalid shape. Cost: O(N). */
int aacmm_shape_col_beta(const aacmm_shape_t *shape, int joint);
int aacmm_shape_col_tip(const aacmm_shape_t *shape);

/* 1 if *shape is the paper's (6 standard joints, no beta, tip l), else 0. */
int aacmm_shape_is_paper(const aacmm_shape_t *shape);

/* ------------------------------------------------------------------------ */
/* Structural parameters                                                     */
/* ------------------------------------------------------------------------ */

/*
 * One arm: its shape and structural parameters, double precision (mm, rad).
 * Joint i = 0 .. N-1 is the paper's joint i + 1.
 *   theta_offset_rad  added to each joint reading           |x| <= 2 pi
 *   alpha_rad         twist about x                          |x| <= 2 pi
 *   d_mm              offset along z                         |x| <= 10000
 *   a_mm              length along x                         |x| <= 10000
 *   beta_rad          Hayati's twist about y, where declared |x| <= 2 pi
 *                     (0 where not)
 *   tip_mm            (t_x, t_y, t_z) in frame N; for AACMM_TIP_Z t_x = t_y
 *                     = 0 and t_z is the paper's l           |x| <= 10000
 * Entries from index N on must be 0.
 */
typedef struct {
    aacmm_shape_t shape;
    double theta_offset_rad[AACMM_JOINTS_MAX];
    double alpha_rad[AACMM_JOINTS_MAX];
    double d_mm[AACMM_JOINTS_MAX];
    double a_mm[AACMM_JOINTS_MAX];
    double beta_rad[AACMM_JOINTS_MAX];
    double tip_mm[3];
} aacmm_arm_f64_t;

/* The same in single precision. */
typedef struct {
    aacmm_shape_t shape;
    float theta_offset_rad[AACMM_JOINTS_MAX];
    float alpha_rad[AACMM_JOINTS_MAX];
    float d_mm[AACMM_JOINTS_MAX];
    float a_mm[AACMM_JOINTS_MAX];
    float beta_rad[AACMM_JOINTS_MAX];
    float tip_mm[3];
} aacmm_arm_f32_t;

/*
 * The paper's arm in the 25-parameter form of its Table 1 and of the wire
 * format and stored record (6 joints, standard DH, tip l); the general form
 * is aacmm_arm_*_t. Units: mm and rad.
 */
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
 * aacmm_arm_default_* fills the same arm in the general form.
 * Returns AACMM_ERR_NULL if the pointer is NULL, else AACMM_OK. Cost: O(1).
 */
aacmm_status_t aacmm_params_default_f64(aacmm_params_f64_t *params);
aacmm_status_t aacmm_params_default_f32(aacmm_params_f32_t *params);
aacmm_status_t aacmm_arm_default_f64(aacmm_arm_f64_t *arm);
aacmm_status_t aacmm_arm_default_f32(aacmm_arm_f32_t *arm);

/*
 * Check every field: AACMM_ERR_NOT_FINITE for NaN/inf, AACMM_ERR_RANGE for a
 * value outside the limits above (and, for an arm, an invalid shape as
 * aacmm_shape_validate, a non-zero beta where none is declared, a non-zero
 * t_x or t_y with AACMM_TIP_Z, or a non-zero entry from index N on),
 * AACMM_ERR_NULL for a NULL pointer, else AACMM_OK. The shape is checked
 * first, then the values in the parameter order. Cost: O(N).
 */
aacmm_status_t aacmm_params_validate_f64(const aacmm_params_f64_t *params);
aacmm_status_t aacmm_params_validate_f32(const aacmm_params_f32_t *params);
aacmm_status_t aacmm_arm_validate_f64(const aacmm_arm_f64_t *arm);
aacmm_status_t aacmm_arm_validate_f32(const aacmm_arm_f32_t *arm);

/* The paper's 25 parameters as a general arm (the paper's shape; the values
 * copied, not validated). AACMM_ERR_NULL or AACMM_OK. Cost: O(1). */
aacmm_status_t aacmm_arm_from_params_f64(aacmm_arm_f64_t *arm, const aacmm_params_f64_t *params);
aacmm_status_t aacmm_arm_from_params_f32(aacmm_arm_f32_t *arm, const aacmm_params_f32_t *params);

/*
 * The arm's parameters as a vector in the Jacobian column order (P values,
 * P = aacmm_shape_params), and back: _set_vector writes v[0 .. P-1] into
 * *arm's values, keeping its shape (nothing is validated; a model init does
 * that). Both need a valid shape: AACMM_ERR_RANGE otherwise (nothing
 * written), AACMM_ERR_NULL for NULL. Cost: O(P).
 */
aacmm_status_t aacmm_arm_get_vector_f64(const aacmm_arm_f64_t *arm, double *v);
aacmm_status_t aacmm_arm_set_vector_f64(aacmm_arm_f64_t *arm, const double *v);
aacmm_status_t aacmm_arm_get_vector_f32(const aacmm_arm_f32_t *arm, float *v);
aacmm_status_t aacmm_arm_set_vector_f32(aacmm_arm_f32_t *arm, const float *v);

/*
 * A prepared model: the validated arm plus the sines and cosines of its
 * alphas and betas, computed once so that each pose needs only the N joint
 * sines and cosines. Build it with aacmm_model_init_*; the fields may be
 * read (arm: the parameters; n_params: P; col_beta[i]: joint i's beta
 * column, 0 if none; col_tip: the first tip column; paper: 1 for the
 * paper's shape), never written.
 */
typedef struct {
    aacmm_arm_f64_t arm;
    double sin_alpha[AACMM_JOINTS_MAX];
    double cos_alpha[AACMM_JOINTS_MAX];
    double sin_beta[AACMM_JOINTS_MAX];
    double cos_beta[AACMM_JOINTS_MAX];
    uint8_t n_params;
    uint8_t col_beta[AACMM_JOINTS_MAX];
    uint8_t col_tip;
    uint8_t paper;
} aacmm_model_f64_t;

typedef struct {
    aacmm_arm_f32_t arm;
    float sin_alpha[AACMM_JOINTS_MAX];
    float cos_alpha[AACMM_JOINTS_MAX];
    float sin_beta[AACMM_JOINTS_MAX];
    float cos_beta[AACMM_JOINTS_MAX];
    uint8_t n_params;
    uint8_t col_beta[AACMM_JOINTS_MAX];
    uint8_t col_tip;
    uint8_t paper;
} aacmm_model_f32_t;

/*
 * Validate the parameters (aacmm_arm_validate_* / aacmm_params_validate_*)
 * and, if valid, build *model from them: _init_arm from any arm, _init from
 * the paper's 25-parameter form (a model of the paper's shape). On error
 * *model is left unchanged. Cost: N + B sine/cosine pairs.
 */
aacmm_status_t aacmm_model_init_arm_f64(aacmm_model_f64_t *model, const aacmm_arm_f64_t *arm);
aacmm_status_t aacmm_model_init_arm_f32(aacmm_model_f32_t *model, const aacmm_arm_f32_t *arm);
aacmm_status_t aacmm_model_init_f64(aacmm_model_f64_t *model, const aacmm_params_f64_t *params);
aacmm_status_t aacmm_model_init_f32(aacmm_model_f32_t *model, const aacmm_params_f32_t *params);

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

/*
 * Per-joint encoder description, for the paper's six joints (the wire
 * format and the stored record); aacmm_arm_encoders_t below is the same for
 * N joints.
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

/* The encoders of an N-joint arm: as aacmm_encoder_config_t for joints
 * 0 .. joints-1 (joints = N, 1 .. AACMM_JOINTS_MAX; entries past it are
 * ignored). */
typedef struct {
    uint8_t joints;
    uint64_t counts_per_rev[AACMM_JOINTS_MAX];
    uint32_t zero_offset_counts[AACMM_JOINTS_MAX];
    int8_t direction[AACMM_JOINTS_MAX];
} aacmm_arm_encoders_t;

/*
 * Fill the encoders with 2^32 counts per revolution, zero offset 0 and
 * direction +1 on every joint (readings are then binary angles); the arm
 * form for `joints` joints (1 .. AACMM_JOINTS_MAX, else AACMM_ERR_RANGE).
 * AACMM_ERR_NULL or AACMM_OK.
 */
aacmm_status_t aacmm_encoder_default(aacmm_encoder_config_t *config);
aacmm_status_t aacmm_arm_encoders_default(aacmm_arm_encoders_t *enc, int joints);

/* The six joints of a config as arm encoders (joints = 6; copied, not
 * validated). AACMM_ERR_NULL or AACMM_OK. */
aacmm_status_t aacmm_arm_encoders_from_config(aacmm_arm_encoders_t *enc,
                                              const aacmm_encoder_config_t *config);

/*
 * AACMM_ERR_RANGE if any counts_per_rev is outside 2 .. 2^32, a zero offset is
 * >= its counts_per_rev, a direction is not +1/-1, or (arm form) joints is
 * outside 1 .. AACMM_JOINTS_MAX; AACMM_ERR_NULL for NULL; else AACMM_OK.
 * Cost: O(joints).
 */
aacmm_status_t aacmm_encoder_validate(const aacmm_encoder_config_t *config);
aacmm_status_t aacmm_arm_encoders_validate(const aacmm_arm_encoders_t *enc);

/*
 * Signed joint position in counts, per joint:
 *     delta = (reading - zero_offset) mod counts_per_rev, in 0 .. cpr-1
 *     s     = delta        if 2 * delta <  cpr
 *           = delta - cpr  otherwise              (so s is in [-cpr/2, cpr/2))
 *     counts_out = direction * s                  (in [-cpr/2, cpr/2])
 * Wrap-around is handled exactly: a reading just below the zero offset gives
 * a small negative count. Readings must be < counts_per_rev (an absolute
 * encoder never reports more); otherwise AACMM_ERR_RANGE and nothing is
 * written. The encoders must be valid (aacmm_encoder_validate /
 * aacmm_arm_encoders_validate); invalid ones give AACMM_ERR_RANGE. Arrays
 * hold 6 values (config form) or enc->joints (arm form). Cost: O(joints),
 * integer only.
 */
aacmm_status_t aacmm_encoder_signed_counts(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           int64_t counts_out[AACMM_JOINTS]);
aacmm_status_t aacmm_arm_encoders_signed_counts(const aacmm_arm_encoders_t *enc,
                                                const uint32_t *reading_counts,
                                                int64_t *counts_out);

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
 * expected to meet (docs/kinematics.md). The _f32 variants use no double
 * arithmetic.
 * Cost: O(joints); per joint a 4-limb product, for non-power-of-two
 * resolutions 5 64/32-bit divisions, two rounding checks, one int-to-float
 * conversion.
 */
aacmm_status_t aacmm_encoder_to_angles_f64(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           double theta_rad[AACMM_JOINTS]);
aacmm_status_t aacmm_encoder_to_angles_f32(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[AACMM_JOINTS],
                                           float theta_rad[AACMM_JOINTS]);
aacmm_status_t aacmm_arm_encoders_to_angles_f64(const aacmm_arm_encoders_t *enc,
                                                const uint32_t *reading_counts, double *theta_rad);
aacmm_status_t aacmm_arm_encoders_to_angles_f32(const aacmm_arm_encoders_t *enc,
                                                const uint32_t *reading_counts, float *theta_rad);

/*
 * Binary angles (uint32, 2^32 = one turn, 0 = zero angle, wrapping) from raw
 * readings, for the fixed-point path: round(s * 2^32 / cpr) mod 2^32 with
 * s from aacmm_encoder_signed_counts. Exact for power-of-two resolutions;
 * otherwise rounded to nearest (error <= 1/2 of 2^-32 turn, 0.73 nrad).
 * Errors as aacmm_encoder_signed_counts. Cost: O(joints), one 64-bit
 * division per joint for non-power-of-two resolutions.
 */
aacmm_status_t aacmm_encoder_to_bam(const aacmm_encoder_config_t *config,
                                    const uint32_t reading_counts[AACMM_JOINTS],
                                    uint32_t angle_bam[AACMM_JOINTS]);
aacmm_status_t aacmm_arm_encoders_to_bam(const aacmm_arm_encoders_t *enc,
                                         const uint32_t *reading_counts, uint32_t *angle_bam);

/* ------------------------------------------------------------------------ */
/* Forward kinematics and Jacobian                                           */
/* ------------------------------------------------------------------------ */

/*
 * Probe point p_mm = (x, y, z) in the base frame for the N joint readings
 * theta_rad[0 .. N-1] (N = model->arm.shape.joints; the model's theta
 * offsets are added). Joint angles must be finite and
 * |theta| <= AACMM_JOINT_ANGLE_MAX_RAD, else AACMM_ERR_RANGE (or
 * AACMM_ERR_NOT_FINITE) and p_mm is not written; AACMM_ERR_NULL for a NULL
 * pointer. The model must come from aacmm_model_init_*.
 * Cost: N sine/cosine pairs + about 20 N flops (+ 12 per beta, + 12 for a
 * tip vector); the paper's arm: 6 pairs + about 120 flops.
 */
aacmm_status_t aacmm_point_f64(const aacmm_model_f64_t *model, const double *theta_rad,
                               double p_mm[3]);
aacmm_status_t aacmm_point_f32(const aacmm_model_f32_t *model, const float *theta_rad,
                               float p_mm[3]);

/*
 * Probe point and the full 3 x P Jacobian in one pass (the columns at the
 * top). jac must hold 3 P values (P = model->n_params; at most
 * AACMM_JAC_SIZE_MAX; the paper's arm: AACMM_JAC_SIZE = 75); it is written
 * row-major, jac[r * P + c]. Each column is geometric, not a finite
 * difference (top of this file); for the paper's arm:
 *     d p / d theta_i = z_{i-1} x (p - o_{i-1})
 *     d p / d alpha_i = x_i x (p - o_i)
 *     d p / d d_i     = z_{i-1}
 *     d p / d a_i     = x_i
 *     d p / d l       = z_6
 * d p_z / d theta_1 is exactly 0 when joint 1 is standard DH. Errors as
 * aacmm_point_*; on error nothing is written. Cost: the point + about 35 N
 * flops (+ 15 per beta); the paper's arm: 6 pairs + about 330 flops.
 */
aacmm_status_t aacmm_point_jacobian_f64(const aacmm_model_f64_t *model, const double *theta_rad,
                                        double p_mm[3], double *jac);
aacmm_status_t aacmm_point_jacobian_f32(const aacmm_model_f32_t *model, const float *theta_rad,
                                        float p_mm[3], float *jac);

/*
 * Batch entry points for host analysis: n poses in, n points (n*3 values) and,
 * if jac is not NULL, n Jacobians (n*3P values, pose after pose) out.
 *   _angles: theta_rad holds n*N joint readings in rad, pose after pose.
 *   _counts: reading_counts holds n*N raw encoder readings, converted with
 *            aacmm_arm_encoders_to_angles_* first; encoders->joints must be
 *            N (else AACMM_ERR_RANGE, nothing written).
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
                                      const aacmm_arm_encoders_t *encoders, size_t n,
                                      const uint32_t *reading_counts, double *p_mm, double *jac,
                                      size_t *done);
aacmm_status_t aacmm_batch_counts_f32(const aacmm_model_f32_t *model,
                                      const aacmm_arm_encoders_t *encoders, size_t n,
                                      const uint32_t *reading_counts, float *p_mm, float *jac,
                                      size_t *done);

/* ------------------------------------------------------------------------ */
/* Error model: encoder harmonics and thermal expansion (issue 27)           */
/* ------------------------------------------------------------------------ */

/*
 * What DH cannot describe, applied before the kinematics in every path (this
 * file: f64, f32; kinematics_q.h: fixed point; simd.h: batches). It lives in
 * a struct of its own, passed by pointer beside the model: the model (and
 * every structure a device already allocates) is unchanged, and a caller
 * without an error model calls the functions above.
 *
 * 1. Joint angle harmonics (an encoder's eccentricity and its harmonic
 *    errors). Joint i's reading q_i (rad, before the theta offset) becomes
 *        q'_i = q_i + sum_{k=1..K_i} (c_ik cos(k q_i) + s_ik sin(k q_i))
 *    with K_i = harmonics[i] in 0 .. AACMM_HARMONICS_MAX (4), chosen per
 *    joint (a hinge that never turns far may carry fewer terms). The chain
 *    then runs on q'_i + theta_offset_i. sin q_i, cos q_i come from one
 *    aacmm_sincos_* of the reading; sin kq, cos kq for k = 2..K from them by
 *    the Chebyshev recurrence
 *        cos(k+1)q = 2 cos q cos kq - cos(k-1)q
 *        sin(k+1)q = 2 cos q sin kq - sin(k-1)q
 *    (no further trigonometric call). A joint with K_i = 0 keeps its reading
 *    untouched (bit for bit: no addition of zero). A constant term would be
 *    the theta offset, so there is none.
 *    Derivative of the corrected angle: dq'/dq = 1 + sum_k k (s_ik cos kq -
 *    c_ik sin kq); the parameter Jacobian does not need it (it differentiates
 *    with respect to the parameters at a fixed reading); a propagation of
 *    encoder noise through the correction would (the factor is within
 *    1 +- 4 AACMM_HARMONIC_SUM_MAX_RAD).
 *
 * 2. Thermal expansion. Per link i a coefficient of thermal expansion
 *    cte_per_k[i] (1/K) and a reference temperature tref_c[i] (degC, default
 *    20); given the link temperatures T_i (degC, valid
 *    AACMM_TEMP_MIN_C .. AACMM_TEMP_MAX_C), every length of link i is scaled:
 *        L = L0 (1 + cte_i (T_i - tref_i))
 *    where the lengths of link i are d_i and a_i of joint i's transform A_i
 *    (in either convention: for modified DH a_i is the offset between axes
 *    i-1 and i, carried by that transform), and the tip (l, or t_x, t_y, t_z)
 *    belongs to link N. L0 are the model's lengths (its values at the
 *    reference temperatures). Passing no temperatures (NULL) means every link
 *    at its reference temperature: nothing is scaled (bit for bit).
 *
 * ---- Extended Jacobian columns ---------------------------------------------
 *
 * The error model's columns follow the model's P columns (kinematics.h), so
 * every structural column keeps its index; E = aacmm_errmodel_cols:
 *     P + 2 (sum of K_j over joints j < i) + 2 (k - 1)      c_ik  mm/rad
 *     the same + 1                                          s_ik  mm/rad
 *   (joint after joint, k = 1 .. K_i, c before s; joints with K_i = 0 have
 *   none), then, if cte_columns is 1, one column per link i = 1 .. N:
 *     P + 2 sum(K) + i                                      cte_i mm K
 * Analytically, from the columns of the chain run at the corrected angles:
 *     d p / d c_ik   = (d p / d theta_i) cos(k q_i)
 *     d p / d s_ik   = (d p / d theta_i) sin(k q_i)
 *     d p / d cte_i  = sum over link i's lengths L of (d p / d L) L0 (T_i - tref_i)
 * With temperatures, the length columns (d, a, tip) are those of the
 * parameters L0: the chain's d p / d L times (1 + cte_i (T_i - tref_i)).
 * The extended Jacobian is 3 x (P + E), row-major, jac[r * (P + E) + c];
 * size it with AACMM_EXT_JAC_SIZE_MAX.
 */
#define AACMM_HARMONICS_MAX 4
/* Per joint, sum over k of |c_ik| + |s_ik| <= 0.1 rad (5.7 deg): more is not
 * an encoder error, and the bound keeps the fixed path's sums in range. */
#define AACMM_HARMONIC_SUM_MAX_RAD 0.1
#define AACMM_TEMP_MIN_C (-40.0)
#define AACMM_TEMP_MAX_C 85.0
#define AACMM_TEMP_REF_DEFAULT_C 20.0
#define AACMM_CTE_MAX_PER_K 1e-3 /* |cte|; aluminium 23e-6, steel 12e-6, CFRP ~ 0 */
/* Error-model columns of the largest model: 2 * 4 * 7 + 7 = 63. */
#define AACMM_EM_COLS_MAX (2 * AACMM_HARMONICS_MAX * AACMM_JOINTS_MAX + AACMM_JOINTS_MAX)
/* Parameters of the largest extended model: 37 + 63 = 100 (300 entries). */
#define AACMM_EXT_PARAMS_MAX (AACMM_PARAMS_MAX + AACMM_EM_COLS_MAX)
#define AACMM_EXT_JAC_SIZE_MAX (AACMM_JAC_ROWS * AACMM_EXT_PARAMS_MAX)

/*
 * The error model, double precision.
 *   joints       N: must equal the model's joint count
 *   harmonics    K_i per joint, 0 .. AACMM_HARMONICS_MAX; 0 from index N on
 *   cte_columns  1: the extended Jacobian carries the N cte columns; 0: not
 *   c_rad, s_rad [i][k - 1] = c_ik, s_ik (rad); 0 for k > K_i and i >= N;
 *                per joint sum |c| + |s| <= AACMM_HARMONIC_SUM_MAX_RAD
 *   cte_per_k    per link (1/K), |x| <= AACMM_CTE_MAX_PER_K; 0 from N on
 *   tref_c       per link (degC), within AACMM_TEMP_MIN_C .. AACMM_TEMP_MAX_C
 * Zero-initialise and call aacmm_errmodel_default_*, then set. 520 bytes.
 */
typedef struct {
    uint8_t joints;
    uint8_t harmonics[AACMM_JOINTS_MAX];
    uint8_t cte_columns;
    double c_rad[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    double s_rad[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    double cte_per_k[AACMM_JOINTS_MAX];
    double tref_c[AACMM_JOINTS_MAX];
} aacmm_errmodel_f64_t;

/* The same in single precision. 264 bytes. */
typedef struct {
    uint8_t joints;
    uint8_t harmonics[AACMM_JOINTS_MAX];
    uint8_t cte_columns;
    float c_rad[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    float s_rad[AACMM_JOINTS_MAX][AACMM_HARMONICS_MAX];
    float cte_per_k[AACMM_JOINTS_MAX];
    float tref_c[AACMM_JOINTS_MAX];
} aacmm_errmodel_f32_t;

/* An error model that changes nothing for `joints` joints (4 .. 7, else
 * AACMM_ERR_RANGE): K = 0, cte 0, tref 20 degC on every link, no cte
 * columns. AACMM_ERR_NULL or AACMM_OK. Cost: O(1). */
aacmm_status_t aacmm_errmodel_default_f64(aacmm_errmodel_f64_t *em, int joints);
aacmm_status_t aacmm_errmodel_default_f32(aacmm_errmodel_f32_t *em, int joints);

/*
 * AACMM_OK for a valid error model; AACMM_ERR_NULL for NULL; AACMM_ERR_RANGE
 * for joints outside 4 .. 7, a K_i above AACMM_HARMONICS_MAX, a cte_columns
 * other than 0/1, a per-joint harmonic sum above AACMM_HARMONIC_SUM_MAX_RAD,
 * a cte or reference temperature out of range, a non-zero coefficient past
 * K_i or a non-zero cte from index N on (a tref there must still be in
 * range);
 * AACMM_ERR_NOT_FINITE for a NaN or infinite value. Cost: O(N K).
 */
aacmm_status_t aacmm_errmodel_validate_f64(const aacmm_errmodel_f64_t *em);
aacmm_status_t aacmm_errmodel_validate_f32(const aacmm_errmodel_f32_t *em);

/* E, the error model's Jacobian columns: 2 sum(K_i) + N cte_columns, or a
 * negative status for NULL or invalid joints, K_i or cte_columns (the values
 * are not checked). Cost: O(N). */
int aacmm_errmodel_cols_f64(const aacmm_errmodel_f64_t *em);
int aacmm_errmodel_cols_f32(const aacmm_errmodel_f32_t *em);

/*
 * The corrected joint angles: q_out[i] = q'_i (rad) of theta_rad[i] (above),
 * for i < N = em->joints. The error model is validated first
 * (aacmm_errmodel_validate_*), the readings checked as by aacmm_point_*.
 * q_out may equal theta_rad. Errors: AACMM_ERR_NULL, AACMM_ERR_RANGE /
 * AACMM_ERR_NOT_FINITE; on error q_out is not written past the joints
 * before the refused one.
 * Cost: per joint with K_i > 0 one sine/cosine pair + 4 K flops.
 */
aacmm_status_t aacmm_errmodel_angles_f64(const aacmm_errmodel_f64_t *em, const double *theta_rad,
                                         double *q_out);
aacmm_status_t aacmm_errmodel_angles_f32(const aacmm_errmodel_f32_t *em, const float *theta_rad,
                                         float *q_out);

/*
 * *out = *model with every length scaled to the link temperatures temp_c[0 ..
 * N-1] (degC), as in 2. above; the angles' sines and cosines are copied, not
 * recomputed (cheap: for a device, once per change of temperature, then
 * aacmm_point_em_* with temp_c NULL). temp_c NULL: a plain copy. Errors:
 * AACMM_ERR_NULL; AACMM_ERR_NOT_FINITE for a NaN temperature;
 * AACMM_ERR_RANGE for a temperature outside AACMM_TEMP_MIN_C ..
 * AACMM_TEMP_MAX_C, an invalid error model or a joint count mismatch, or a
 * scaled length beyond AACMM_LENGTH_MAX_MM. *out unchanged on error. out
 * may equal model only when temp_c is NULL. Cost: 2N + 3 multiplies.
 */
aacmm_status_t aacmm_model_at_temperature_f64(aacmm_model_f64_t *out,
                                              const aacmm_model_f64_t *model,
                                              const aacmm_errmodel_f64_t *em,
                                              const double *temp_c);
aacmm_status_t aacmm_model_at_temperature_f32(aacmm_model_f32_t *out,
                                              const aacmm_model_f32_t *model,
                                              const aacmm_errmodel_f32_t *em, const float *temp_c);

/*
 * Probe point of the model with the error model: the corrected angles
 * (aacmm_errmodel_angles_*) through the model at the link temperatures
 * temp_c[0 .. N-1] (degC; NULL: the reference temperatures). em NULL, or K
 * = 0 everywhere with temp_c NULL: exactly aacmm_point_* (bit for bit).
 * Per pose the error model's fields that size loops and arrays are checked
 * (joints equal to the model's, K_i, cte_columns: AACMM_ERR_RANGE), not
 * every value: validate it once with aacmm_errmodel_validate_* (the batches
 * do). What reaches the point is guarded at every pose: a correction beyond
 * AACMM_HARMONIC_SUM_MAX_RAD (AACMM_ERR_RANGE) or NaN (a NaN coefficient:
 * AACMM_ERR_NOT_FINITE), and with temperatures the temperatures, CTEs,
 * reference temperatures and scaled lengths (as
 * aacmm_model_at_temperature_*); readings as aacmm_point_*. Nothing written
 * on error. Cost: aacmm_point_* + per corrected joint one
 * sine/cosine pair + 4 K flops (+ a model copy and 2N + 3 multiplies with
 * temperatures).
 */
aacmm_status_t aacmm_point_em_f64(const aacmm_model_f64_t *model, const aacmm_errmodel_f64_t *em,
                                  const double *theta_rad, const double *temp_c, double p_mm[3]);
aacmm_status_t aacmm_point_em_f32(const aacmm_model_f32_t *model, const aacmm_errmodel_f32_t *em,
                                  const float *theta_rad, const float *temp_c, float p_mm[3]);

/*
 * Point and the extended 3 x (P + E) Jacobian (columns above; jac holds
 * 3 (P + E) values, at most AACMM_EXT_JAC_SIZE_MAX). em NULL: E = 0, exactly
 * aacmm_point_jacobian_*. The first P columns are those of
 * aacmm_point_jacobian_* at the corrected angles (the length columns scaled
 * by the thermal factor when temp_c is given), bit for bit. Errors as
 * aacmm_point_em_*. Cost: aacmm_point_em_* + the Jacobian + 6 K multiplies
 * per corrected joint (+ 3 (2N + T) for the length columns and 3 (2N + T)
 * multiply-adds for the cte columns, with temperatures).
 */
aacmm_status_t aacmm_point_jacobian_em_f64(const aacmm_model_f64_t *model,
                                           const aacmm_errmodel_f64_t *em, const double *theta_rad,
                                           const double *temp_c, double p_mm[3], double *jac);
aacmm_status_t aacmm_point_jacobian_em_f32(const aacmm_model_f32_t *model,
                                           const aacmm_errmodel_f32_t *em, const float *theta_rad,
                                           const float *temp_c, float p_mm[3], float *jac);

/*
 * Batches of aacmm_point_jacobian_em_* (jac NULL: points only): n poses
 * theta_rad[n N], temperatures temp_c[n N] (one set per pose; NULL: the
 * reference temperatures), points p_mm[n 3], Jacobians jac[n 3 (P + E)].
 * Stop at the first bad pose, *done as aacmm_batch_angles_*.
 */
aacmm_status_t aacmm_batch_angles_em_f64(const aacmm_model_f64_t *model,
                                         const aacmm_errmodel_f64_t *em, size_t n,
                                         const double *theta_rad, const double *temp_c,
                                         double *p_mm, double *jac, size_t *done);
aacmm_status_t aacmm_batch_angles_em_f32(const aacmm_model_f32_t *model,
                                         const aacmm_errmodel_f32_t *em, size_t n,
                                         const float *theta_rad, const float *temp_c, float *p_mm,
                                         float *jac, size_t *done);

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
