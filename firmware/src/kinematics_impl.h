/*
 * The kinematics core, written once for both floating-point precisions.
 *
 * Included by kinematics_f32.c and kinematics_f64.c after they define:
 *   REAL       float or double
 *   SFX(name)  name##_f32 or name##_f64
 *   LIT(x)     a literal of type REAL (x##f or x)
 *   ROUND_MANT(m)   a 64-bit mantissa with bit 63 set, rounded once to REAL
 *   POW2(e)    2^e as a REAL, built from its bits (e within the normal range)
 * and the Taylor coefficients and pi/2 split constants for REAL.
 *
 * No other floating type appears here, so the float build uses only
 * single-precision operations.
 */
#include "sincos_eval.h"

/* ------------------------------------------------------------------------ */
/* Parameters                                                                */
/* ------------------------------------------------------------------------ */

/* 300, 65.5, 792.7, 65.5, 883.2, 0 mm: the paper's d. */
#define PAPER_D_MM {LIT(300.0), LIT(65.5), LIT(792.7), LIT(65.5), LIT(883.2), LIT(0.0)}

aacmm_status_t SFX(aacmm_params_default)(TYPE(aacmm_params) *params)
{
    static const REAL d_mm[AACMM_JOINTS] = PAPER_D_MM;
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        params->theta_offset_rad[i] = LIT(0.0);
        params->alpha_rad[i] = LIT(1.5707963267948966); /* 90 degrees */
        params->d_mm[i] = d_mm[i];
        params->a_mm[i] = LIT(0.0);
    }
    params->l_mm = LIT(183.5);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_arm_from_params)(TYPE(aacmm_arm) *arm, const TYPE(aacmm_params) *params)
{
    int i;
    if (arm == NULL || params == NULL) {
        return AACMM_ERR_NULL;
    }
    (void)aacmm_shape_paper(&arm->shape);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        const int in = i < AACMM_JOINTS;
        arm->theta_offset_rad[i] = in ? params->theta_offset_rad[i] : LIT(0.0);
        arm->alpha_rad[i] = in ? params->alpha_rad[i] : LIT(0.0);
        arm->d_mm[i] = in ? params->d_mm[i] : LIT(0.0);
        arm->a_mm[i] = in ? params->a_mm[i] : LIT(0.0);
        arm->beta_rad[i] = LIT(0.0);
    }
    arm->tip_mm[0] = LIT(0.0);
    arm->tip_mm[1] = LIT(0.0);
    arm->tip_mm[2] = params->l_mm;
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_arm_default)(TYPE(aacmm_arm) *arm)
{
    TYPE(aacmm_params) p;
    (void)SFX(aacmm_params_default)(&p);
    return SFX(aacmm_arm_from_params)(arm, &p);
}

/* AACMM_OK if |x| <= limit, else the reason it is not. */
static aacmm_status_t SFX(check_value)(REAL x, REAL limit)
{
    if (x <= limit && x >= -limit) {
        return AACMM_OK;
    }
    return isnan(x) ? AACMM_ERR_NOT_FINITE : (isinf(x) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE);
}

/* AACMM_OK if x is exactly zero (either sign), else the reason it is not. */
static aacmm_status_t SFX(check_zero)(REAL x)
{
    if (x <= LIT(0.0) && x >= LIT(0.0)) {
        return AACMM_OK;
    }
    return isnan(x) ? AACMM_ERR_NOT_FINITE : (isinf(x) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE);
}

aacmm_status_t SFX(aacmm_params_validate)(const TYPE(aacmm_params) *params)
{
    const REAL len_max = (REAL)AACMM_LENGTH_MAX_MM;
    const REAL ang_max = (REAL)AACMM_PARAM_ANGLE_MAX_RAD;
    aacmm_status_t st;
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        if ((st = SFX(check_value)(params->theta_offset_rad[i], ang_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->alpha_rad[i], ang_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->d_mm[i], len_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->a_mm[i], len_max)) != AACMM_OK) {
            return st;
        }
    }
    return SFX(check_value)(params->l_mm, len_max);
}

aacmm_status_t SFX(aacmm_arm_validate)(const TYPE(aacmm_arm) *arm)
{
    const REAL len_max = (REAL)AACMM_LENGTH_MAX_MM;
    const REAL ang_max = (REAL)AACMM_PARAM_ANGLE_MAX_RAD;
    aacmm_status_t st;
    int i, n;
    if (arm == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_shape_validate(&arm->shape);
    if (st != AACMM_OK) {
        return st;
    }
    n = (int)arm->shape.joints;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (i < n) {
            st = SFX(check_value)(arm->theta_offset_rad[i], ang_max);
            if (st == AACMM_OK) {
                st = SFX(check_value)(arm->alpha_rad[i], ang_max);
            }
            if (st == AACMM_OK) {
                st = SFX(check_value)(arm->d_mm[i], len_max);
            }
            if (st == AACMM_OK) {
                st = SFX(check_value)(arm->a_mm[i], len_max);
            }
            if (st == AACMM_OK) {
                st = arm->shape.beta[i] ? SFX(check_value)(arm->beta_rad[i], ang_max)
                                        : SFX(check_zero)(arm->beta_rad[i]);
            }
        } else {
            st = SFX(check_zero)(arm->theta_offset_rad[i]);
            if (st == AACMM_OK) {
                st = SFX(check_zero)(arm->alpha_rad[i]);
            }
            if (st == AACMM_OK) {
                st = SFX(check_zero)(arm->d_mm[i]);
            }
            if (st == AACMM_OK) {
                st = SFX(check_zero)(arm->a_mm[i]);
            }
            if (st == AACMM_OK) {
                st = SFX(check_zero)(arm->beta_rad[i]);
            }
        }
        if (st != AACMM_OK) {
            return st;
        }
    }
    for (i = 0; i < 3; i++) {
        st = (arm->shape.tip == (uint8_t)AACMM_TIP_XYZ || i == 2)
                 ? SFX(check_value)(arm->tip_mm[i], len_max)
                 : SFX(check_zero)(arm->tip_mm[i]);
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_arm_get_vector)(const TYPE(aacmm_arm) *arm, REAL *v)
{
    int i, n, k;
    if (arm == NULL || v == NULL) {
        return AACMM_ERR_NULL;
    }
    if (aacmm_shape_validate(&arm->shape) != AACMM_OK) {
        return AACMM_ERR_RANGE;
    }
    n = (int)arm->shape.joints;
    k = 4 * n;
    for (i = 0; i < n; i++) {
        v[AACMM_ARM_COL_THETA(n, i)] = arm->theta_offset_rad[i];
        v[AACMM_ARM_COL_ALPHA(n, i)] = arm->alpha_rad[i];
        v[AACMM_ARM_COL_D(n, i)] = arm->d_mm[i];
        v[AACMM_ARM_COL_A(n, i)] = arm->a_mm[i];
    }
    for (i = 0; i < n; i++) {
        if (arm->shape.beta[i]) {
            v[k++] = arm->beta_rad[i];
        }
    }
    if (arm->shape.tip == (uint8_t)AACMM_TIP_XYZ) {
        v[k++] = arm->tip_mm[0];
        v[k++] = arm->tip_mm[1];
    }
    v[k] = arm->tip_mm[2];
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_arm_set_vector)(TYPE(aacmm_arm) *arm, const REAL *v)
{
    int i, n, k;
    if (arm == NULL || v == NULL) {
        return AACMM_ERR_NULL;
    }
    if (aacmm_shape_validate(&arm->shape) != AACMM_OK) {
        return AACMM_ERR_RANGE;
    }
    n = (int)arm->shape.joints;
    k = 4 * n;
    for (i = 0; i < n; i++) {
        arm->theta_offset_rad[i] = v[AACMM_ARM_COL_THETA(n, i)];
        arm->alpha_rad[i] = v[AACMM_ARM_COL_ALPHA(n, i)];
        arm->d_mm[i] = v[AACMM_ARM_COL_D(n, i)];
        arm->a_mm[i] = v[AACMM_ARM_COL_A(n, i)];
    }
    for (i = 0; i < n; i++) {
        if (arm->shape.beta[i]) {
            arm->beta_rad[i] = v[k++];
        }
    }
    if (arm->shape.tip == (uint8_t)AACMM_TIP_XYZ) {
        arm->tip_mm[0] = v[k++];
        arm->tip_mm[1] = v[k++];
    }
    arm->tip_mm[2] = v[k];
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_model_init_arm)(TYPE(aacmm_model) *model, const TYPE(aacmm_arm) *arm)
{
    aacmm_status_t st;
    int i;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(aacmm_arm_validate)(arm);
    if (st != AACMM_OK) {
        return st;
    }
    model->arm = *arm;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        model->sin_alpha[i] = LIT(0.0);
        model->cos_alpha[i] = LIT(1.0);
        model->sin_beta[i] = LIT(0.0);
        model->cos_beta[i] = LIT(1.0);
        model->col_beta[i] = 0u;
        if (i < (int)arm->shape.joints) {
            SFX(aacmm_sincos)(arm->alpha_rad[i], &model->sin_alpha[i], &model->cos_alpha[i]);
        }
        if (arm->shape.beta[i]) {
            SFX(aacmm_sincos)(arm->beta_rad[i], &model->sin_beta[i], &model->cos_beta[i]);
            model->col_beta[i] = (uint8_t)aacmm_shape_col_beta(&arm->shape, i);
        }
    }
    model->n_params = (uint8_t)aacmm_shape_params(&arm->shape);
    model->col_tip = (uint8_t)aacmm_shape_col_tip(&arm->shape);
    model->paper = (uint8_t)aacmm_shape_is_paper(&arm->shape);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_model_init)(TYPE(aacmm_model) *model, const TYPE(aacmm_params) *params)
{
    TYPE(aacmm_arm) arm;
    aacmm_status_t st;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(aacmm_params_validate)(params);
    if (st != AACMM_OK) {
        return st;
    }
    (void)SFX(aacmm_arm_from_params)(&arm, params);
    return SFX(aacmm_model_init_arm)(model, &arm);
}

/* ------------------------------------------------------------------------ */
/* Sine and cosine                                                           */
/* ------------------------------------------------------------------------ */

/* a * b + c, the product rounded: the per-pose core fuses nothing (its
 * arithmetic is the plain one of the firmware and of every host kernel
 * without FMA; sincos_eval.h, chain_impl.h). */
#define PLAIN_FMA(a, b, c) ((a) * (b) + (c))

static inline void SFX(sincos_inline)(REAL x, REAL *s, REAL *c)
{
    /* Quadrant signs, indexed by bit 1 of the quadrant (sine) and of the
     * quadrant + 1 (cosine): a table instead of a switch, because random
     * joint angles make a quadrant branch mispredict half the time. */
    static const REAL sign[2] = {LIT(1.0), LIT(-1.0)};
    /* k = x / (pi/2) rounded to nearest (adding and subtracting 1.5 * 2^(p-1)
     * rounds in the FPU's default round-to-nearest mode without a branch),
     * r = x - k pi/2 with |r| <= pi/4 (+tiny), sin r and cos r: sincos_eval.h */
    SINCOS_EVAL(REAL, PLAIN_FMA, x, kr, sr, cr);
    const uint32_t q = (uint32_t)(int32_t)(kr - ROUND_MAGIC);
    REAL v[2];
    v[0] = sr;
    v[1] = cr;
    *s = v[q & 1u] * sign[(q >> 1) & 1u];
    *c = v[(q & 1u) ^ 1u] * sign[((q + 1u) >> 1) & 1u];
}

void SFX(aacmm_sincos)(REAL x, REAL *s, REAL *c)
{
    SFX(sincos_inline)(x, s, c);
}

/* ------------------------------------------------------------------------ */
/* Forward kinematics and Jacobian                                           */
/* ------------------------------------------------------------------------ */

static aacmm_status_t SFX(check_angles)(const REAL *theta_rad, int joints)
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    int i;
    for (i = 0; i < joints; i++) {
        aacmm_status_t st = SFX(check_value)(theta_rad[i], lim);
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

/* The chain twice from one template (chain_impl.h): SFX(chain_paper) for the
 * paper's shape, its shape constants folded in at compile time, and
 * SFX(chain_any) for every shape, read from the model. */
#define CH_T REAL
#define CH_SPLAT(x) (x)
#define CH_SINCOS(x, s, c) SFX(sincos_inline)(x, s, c)
#define CH_FMA(a, b, c) PLAIN_FMA(a, b, c)
#define CH(name) SFX(name##_paper)
#define CH_GENERAL 0
#include "chain_impl.h"
#undef CH
#undef CH_GENERAL
#define CH(name) SFX(name##_any)
#define CH_GENERAL 1
#include "chain_impl.h"
#undef CH_GENERAL
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#undef CH_FMA
#undef CH_STEP_PARAM
#undef CH_STEP
#undef CH_OUT
#undef CH_INLINE
#undef CH_T
#undef CH
#undef CH_SPLAT
#undef CH_SINCOS

/* One pose through the chain of the model's shape. Inlined (always: -Os
 * would keep it out of line, a call more per pose on the Cortex-M4F), so
 * each caller gets chains specialised for its jac (NULL or not). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void SFX(chain)(const TYPE(aacmm_model) *model, const REAL *theta_rad, REAL p_mm[3],
                              REAL *jac)
{
    if (model->paper) {
        SFX(chain_paper)(model, theta_rad, p_mm, jac);
    } else {
        SFX(chain_any)(model, theta_rad, p_mm, jac);
    }
}

aacmm_status_t SFX(aacmm_point)(const TYPE(aacmm_model) *model, const REAL *theta_rad,
                                REAL p_mm[3])
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad, (int)model->arm.shape.joints);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, NULL);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_point_jacobian)(const TYPE(aacmm_model) *model, const REAL *theta_rad,
                                         REAL p_mm[3], REAL *jac)
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL || jac == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad, (int)model->arm.shape.joints);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, jac);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

/* Angles of `joints` signed counts s at the resolutions cpr. */
static void SFX(angles_of_counts)(const uint64_t *cpr, int joints, const int64_t *s,
                                  REAL *theta_rad)
{
    int i;
    for (i = 0; i < joints; i++) {
        if (s[i] == 0) {
            theta_rad[i] = LIT(0.0);
        } else {
            uint64_t mant;
            int e;
            REAL mag;
            aacmm_internal_angle_exact((uint32_t)(s[i] < 0 ? -s[i] : s[i]), cpr[i], &mant, &e);
            mag = ROUND_MANT(mant) * POW2(e); /* one rounding, then an exact scaling */
            theta_rad[i] = (s[i] < 0) ? -mag : mag;
        }
    }
}

aacmm_status_t SFX(aacmm_encoder_to_angles)(const aacmm_encoder_config_t *config,
                                            const uint32_t reading_counts[AACMM_JOINTS],
                                            REAL theta_rad[AACMM_JOINTS])
{
    int64_t s[AACMM_JOINTS];
    aacmm_status_t st;
    if (theta_rad == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_signed_counts(config, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(angles_of_counts)(config->counts_per_rev, AACMM_JOINTS, s, theta_rad);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_arm_encoders_to_angles)(const aacmm_arm_encoders_t *enc,
                                                 const uint32_t *reading_counts, REAL *theta_rad)
{
    int64_t s[AACMM_JOINTS_MAX];
    aacmm_status_t st;
    if (theta_rad == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_arm_encoders_signed_counts(enc, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(angles_of_counts)(enc->counts_per_rev, (int)enc->joints, s, theta_rad);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Batches                                                                   */
/* ------------------------------------------------------------------------ */

/* Pose k of a batch: its point (and Jacobian of jn entries if jac is not
 * NULL) into the k-th slots, then *done = k + 1. Inlined, so each branch
 * calls a chain specialised for its jac. */
static inline void SFX(batch_pose)(const TYPE(aacmm_model) *model, const REAL *th, size_t k,
                                   size_t jn, REAL *p_mm, REAL *jac, size_t *done)
{
    if (jac != NULL) {
        SFX(chain)(model, th, p_mm + k * 3u, jac + k * jn);
    } else {
        SFX(chain)(model, th, p_mm + k * 3u, NULL);
    }
    if (done != NULL) {
        *done = k + 1u;
    }
}

aacmm_status_t SFX(aacmm_batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    size_t k, nj, jn;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    for (k = 0; k < n; k++) {
        const REAL *th = theta_rad + k * nj;
        aacmm_status_t st = SFX(check_angles)(th, (int)nj);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, jn, p_mm, jac, done);
    }
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_batch_counts)(const TYPE(aacmm_model) *model,
                                       const aacmm_arm_encoders_t *encoders, size_t n,
                                       const uint32_t *reading_counts, REAL *p_mm, REAL *jac,
                                       size_t *done)
{
    size_t k, nj, jn;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || encoders == NULL ||
        (n > 0u && (reading_counts == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    if (encoders->joints != nj) {
        return AACMM_ERR_RANGE;
    }
    for (k = 0; k < n; k++) {
        REAL th[AACMM_JOINTS_MAX];
        aacmm_status_t st =
            SFX(aacmm_arm_encoders_to_angles)(encoders, reading_counts + k * nj, th);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, jn, p_mm, jac, done);
    }
    return AACMM_OK;
}

#include "errmodel_impl.h"
