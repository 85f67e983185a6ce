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

aacmm_status_t SFX(aacmm_params_default)(TYPE(aacmm_params) *params)
{
    static const REAL d_mm[AACMM_JOINTS] = {LIT(300.0), LIT(65.5), LIT(792.7),
                                            LIT(65.5),  LIT(883.2), LIT(0.0)};
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

/* AACMM_OK if |x| <= limit, else the reason it is not. */
static aacmm_status_t SFX(check_value)(REAL x, REAL limit)
{
    if (x <= limit && x >= -limit) {
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

aacmm_status_t SFX(aacmm_model_init)(TYPE(aacmm_model) *model, const TYPE(aacmm_params) *params)
{
    aacmm_status_t st;
    int i;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(aacmm_params_validate)(params);
    if (st != AACMM_OK) {
        return st;
    }
    model->params = *params;
    for (i = 0; i < AACMM_JOINTS; i++) {
        SFX(aacmm_sincos)(params->alpha_rad[i], &model->sin_alpha[i], &model->cos_alpha[i]);
    }
    return AACMM_OK;
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

static aacmm_status_t SFX(check_angles)(const REAL theta_rad[AACMM_JOINTS])
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    int i;
    for (i = 0; i < AACMM_JOINTS; i++) {
        aacmm_status_t st = SFX(check_value)(theta_rad[i], lim);
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

#define CH_T REAL
#define CH(name) SFX(name)
#define CH_SPLAT(x) (x)
#define CH_SINCOS(x, s, c) SFX(sincos_inline)(x, s, c)
#define CH_FMA(a, b, c) PLAIN_FMA(a, b, c)
#include "chain_impl.h"
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

aacmm_status_t SFX(aacmm_point)(const TYPE(aacmm_model) *model, const REAL theta_rad[AACMM_JOINTS],
                                REAL p_mm[3])
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, NULL);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_point_jacobian)(const TYPE(aacmm_model) *model,
                                         const REAL theta_rad[AACMM_JOINTS], REAL p_mm[3],
                                         REAL jac[AACMM_JAC_SIZE])
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL || jac == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, jac);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

aacmm_status_t SFX(aacmm_encoder_to_angles)(const aacmm_encoder_config_t *config,
                                            const uint32_t reading_counts[AACMM_JOINTS],
                                            REAL theta_rad[AACMM_JOINTS])
{
    int64_t s[AACMM_JOINTS];
    REAL out[AACMM_JOINTS];
    aacmm_status_t st;
    int i;
    if (theta_rad == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_signed_counts(config, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        if (s[i] == 0) {
            out[i] = LIT(0.0);
        } else {
            uint64_t mant;
            int e;
            REAL mag;
            aacmm_internal_angle_exact((uint32_t)(s[i] < 0 ? -s[i] : s[i]),
                                       config->counts_per_rev[i], &mant, &e);
            mag = ROUND_MANT(mant) * POW2(e); /* one rounding, then an exact scaling */
            out[i] = (s[i] < 0) ? -mag : mag;
        }
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        theta_rad[i] = out[i];
    }
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Batches                                                                   */
/* ------------------------------------------------------------------------ */

/* Pose k of a batch: its point (and Jacobian if jac is not NULL) into the
 * k-th slots, then *done = k + 1. Inlined, so each branch calls a chain
 * specialised for its jac. */
static inline void SFX(batch_pose)(const TYPE(aacmm_model) *model, const REAL *th, size_t k,
                                   REAL *p_mm, REAL *jac, size_t *done)
{
    if (jac != NULL) {
        SFX(chain)(model, th, p_mm + k * 3u, jac + k * AACMM_JAC_SIZE);
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
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        aacmm_status_t st = SFX(check_angles)(th);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, p_mm, jac, done);
    }
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_batch_counts)(const TYPE(aacmm_model) *model,
                                       const aacmm_encoder_config_t *encoders, size_t n,
                                       const uint32_t *reading_counts, REAL *p_mm, REAL *jac,
                                       size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || encoders == NULL ||
        (n > 0u && (reading_counts == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        REAL th[AACMM_JOINTS];
        aacmm_status_t st =
            SFX(aacmm_encoder_to_angles)(encoders, reading_counts + k * AACMM_JOINTS, th);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, p_mm, jac, done);
    }
    return AACMM_OK;
}
