/*
 * Fixed-point kinematics: model set-up, probe point, 3x25 Jacobian, batches.
 * Integer arithmetic only (built for the Cortex-M0+ and checked for any
 * floating-point helper). Formats, rounding and bounds: kinematics_q.h.
 */
#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"
#include "fixed_sincos.h"

/* ------------------------------------------------------------------------ */
/* Parameters                                                                */
/* ------------------------------------------------------------------------ */

static int64_t abs64(int32_t x)
{
    return (x < 0) ? -(int64_t)x : (int64_t)x;
}

aacmm_status_t aacmm_params_q_validate(const aacmm_params_q_t *params)
{
    int64_t reach;
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    /* At most 13 * 2^31 < 2^35: the sum cannot overflow. */
    reach = abs64(params->l_q18);
    for (i = 0; i < AACMM_JOINTS; i++) {
        reach += abs64(params->d_q18[i]) + abs64(params->a_q18[i]);
    }
    return (reach <= AACMM_Q_REACH_MAX_Q18) ? AACMM_OK : AACMM_ERR_RANGE;
}

aacmm_status_t aacmm_params_default_q(aacmm_params_q_t *params)
{
    /* 300, 65.5, 792.7, 65.5, 883.2, 0 mm in Q18, rounded to nearest:
     * 792.7 * 2^18 = 207801548.8, 883.2 * 2^18 = 231525580.8. */
    static const int32_t d_q18[AACMM_JOINTS] = {78643200, 17170432, 207801549,
                                                17170432, 231525581, 0};
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        params->theta_offset_bam[i] = 0u;
        params->alpha_bam[i] = AACMM_BAM_QUARTER; /* 90 degrees */
        params->d_q18[i] = d_q18[i];
        params->a_q18[i] = 0;
    }
    params->l_q18 = 48103424; /* 183.5 mm */
    return AACMM_OK;
}

aacmm_status_t aacmm_model_q_init(aacmm_model_q_t *model, const aacmm_params_q_t *params)
{
    aacmm_status_t st;
    int i;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_params_q_validate(params);
    if (st != AACMM_OK) {
        return st;
    }
    model->params = *params;
    for (i = 0; i < AACMM_JOINTS; i++) {
        aacmm_fixed_sincos(params->alpha_bam[i], &model->sin_alpha_q30[i],
                           &model->cos_alpha_q30[i]);
    }
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Chain                                                                     */
/* ------------------------------------------------------------------------ */

/* Q30 3-vector (axes) and Q48 3-vector (positions). Small structs passed by
 * value stay in registers. */
typedef struct {
    int32_t x, y, z;
} vec3_q30;

typedef struct {
    int64_t x, y, z;
} vec3_q48;

/* a u + b v for Q30 a, b, u, v: exact Q60 sum in int64 (|.| < 2^61 for the
 * unit-bounded operands here), rounded half up to Q30. */
static inline vec3_q30 lin2_q30(int32_t a, vec3_q30 u, int32_t b, vec3_q30 v)
{
    vec3_q30 r;
    r.x = (int32_t)AACMM_FIXED_RND((int64_t)a * u.x + (int64_t)b * v.x, 30);
    r.y = (int32_t)AACMM_FIXED_RND((int64_t)a * u.y + (int64_t)b * v.y, 30);
    r.z = (int32_t)AACMM_FIXED_RND((int64_t)a * u.z + (int64_t)b * v.z, 30);
    return r;
}

/* Q48 p - o rounded half up to Q18 int32 (|p - o| <= 8000 mm: < 2^31). */
static inline vec3_q30 diff_q18(vec3_q48 p, vec3_q48 o)
{
    vec3_q30 r;
    r.x = (int32_t)AACMM_FIXED_RND(p.x - o.x, 30);
    r.y = (int32_t)AACMM_FIXED_RND(p.y - o.y, 30);
    r.z = (int32_t)AACMM_FIXED_RND(p.z - o.z, 30);
    return r;
}

/* Q32 output of one cross-product component a1 b2 - a2 b1, a Q30, b Q18:
 * the Q48 difference (< 2^62) rounded half up by 16. */
static inline int64_t cross_q32(int32_t a1, int32_t b2, int32_t a2, int32_t b1)
{
    return AACMM_FIXED_RND((int64_t)a1 * b2 - (int64_t)a2 * b1, 16);
}

/*
 * One pass down the chain (kinematics_q.h has the formulas and bounds).
 * Inlined with jac constant NULL or not, so the point-only path does no
 * Jacobian work. Frame 6's y axis is never used, so it is not formed.
 */
static inline void chain_q(const aacmm_model_q_t *model, const uint32_t theta_bam[AACMM_JOINTS],
                           int64_t p_q32[3], int64_t *jac)
{
    vec3_q30 X = {AACMM_Q_ONE_Q30, 0, 0};
    vec3_q30 Y = {0, AACMM_Q_ONE_Q30, 0};
    vec3_q30 Z = {0, 0, AACMM_Q_ONE_Q30};
    vec3_q48 O = {0, 0, 0};
    vec3_q30 zprev[AACMM_JOINTS], xs[AACMM_JOINTS];
    vec3_q48 oprev[AACMM_JOINTS], os[AACMM_JOINTS];
    vec3_q48 p;
    const int64_t l = model->params.l_q18;
    int i;

    for (i = 0; i < AACMM_JOINTS; i++) {
        const int32_t sa = model->sin_alpha_q30[i];
        const int32_t ca = model->cos_alpha_q30[i];
        const int64_t d = model->params.d_q18[i];
        const int64_t a = model->params.a_q18[i];
        int32_t s, c;
        vec3_q30 u;
        aacmm_fixed_sincos(theta_bam[i] + model->params.theta_offset_bam[i], &s, &c);
        zprev[i] = Z;
        oprev[i] = O;
        u = lin2_q30(c, Y, -s, X);
        X = lin2_q30(c, X, s, Y);
        if (i + 1 < AACMM_JOINTS) {
            Y = lin2_q30(ca, u, sa, Z);
        }
        Z = lin2_q30(ca, Z, -sa, u);
        /* Q18 x Q30 = Q48, exact; |d z + a x| <= 2^31 * 2^30 * 2 = 2^62. */
        O.x += d * zprev[i].x + a * X.x;
        O.y += d * zprev[i].y + a * X.y;
        O.z += d * zprev[i].z + a * X.z;
        xs[i] = X;
        os[i] = O;
    }
    p.x = O.x + l * Z.x;
    p.y = O.y + l * Z.y;
    p.z = O.z + l * Z.z;
    p_q32[0] = AACMM_FIXED_RND(p.x, 16);
    p_q32[1] = AACMM_FIXED_RND(p.y, 16);
    p_q32[2] = AACMM_FIXED_RND(p.z, 16);
    if (jac == NULL) {
        return;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        const vec3_q30 zp = zprev[i];
        const vec3_q30 xi = xs[i];
        const vec3_q30 v = diff_q18(p, oprev[i]);
        const vec3_q30 w = diff_q18(p, os[i]);
        /* d p / d theta_i = z_{i-1} x (p - o_{i-1}) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = cross_q32(zp.y, v.z, zp.z, v.y);
        jac[1 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = cross_q32(zp.z, v.x, zp.x, v.z);
        jac[2 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = cross_q32(zp.x, v.y, zp.y, v.x);
        /* d p / d alpha_i = x_i x (p - o_i) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = cross_q32(xi.y, w.z, xi.z, w.y);
        jac[1 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = cross_q32(xi.z, w.x, xi.x, w.z);
        jac[2 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = cross_q32(xi.x, w.y, xi.y, w.x);
        /* d p / d d_i = z_{i-1};  d p / d a_i = x_i  (Q30 -> Q32, exact) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_D(i)] = (int64_t)zp.x * 4;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_D(i)] = (int64_t)zp.y * 4;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_D(i)] = (int64_t)zp.z * 4;
        jac[0 * AACMM_JAC_COLS + AACMM_COL_A(i)] = (int64_t)xi.x * 4;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_A(i)] = (int64_t)xi.y * 4;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_A(i)] = (int64_t)xi.z * 4;
    }
    /* d p / d l = z_6 */
    jac[0 * AACMM_JAC_COLS + AACMM_COL_L] = (int64_t)Z.x * 4;
    jac[1 * AACMM_JAC_COLS + AACMM_COL_L] = (int64_t)Z.y * 4;
    jac[2 * AACMM_JAC_COLS + AACMM_COL_L] = (int64_t)Z.z * 4;
}

aacmm_status_t aacmm_point_q(const aacmm_model_q_t *model, const uint32_t theta_bam[AACMM_JOINTS],
                             int64_t p_q32[3])
{
    if (model == NULL || theta_bam == NULL || p_q32 == NULL) {
        return AACMM_ERR_NULL;
    }
    chain_q(model, theta_bam, p_q32, NULL);
    return AACMM_OK;
}

aacmm_status_t aacmm_point_jacobian_q(const aacmm_model_q_t *model,
                                      const uint32_t theta_bam[AACMM_JOINTS], int64_t p_q32[3],
                                      int64_t jac_q32[AACMM_JAC_SIZE])
{
    if (model == NULL || theta_bam == NULL || p_q32 == NULL || jac_q32 == NULL) {
        return AACMM_ERR_NULL;
    }
    chain_q(model, theta_bam, p_q32, jac_q32);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Batches                                                                   */
/* ------------------------------------------------------------------------ */

aacmm_status_t aacmm_batch_bam_q(const aacmm_model_q_t *model, size_t n, const uint32_t *theta_bam,
                                 int64_t *p_q32, int64_t *jac_q32, size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_bam == NULL || p_q32 == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        if (jac_q32 != NULL) {
            chain_q(model, theta_bam + k * AACMM_JOINTS, p_q32 + k * 3u,
                    jac_q32 + k * AACMM_JAC_SIZE);
        } else {
            chain_q(model, theta_bam + k * AACMM_JOINTS, p_q32 + k * 3u, NULL);
        }
    }
    if (done != NULL) {
        *done = n;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_batch_counts_q(const aacmm_model_q_t *model,
                                    const aacmm_encoder_config_t *encoders, size_t n,
                                    const uint32_t *reading_counts, int64_t *p_q32,
                                    int64_t *jac_q32, size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || encoders == NULL ||
        (n > 0u && (reading_counts == NULL || p_q32 == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        uint32_t th[AACMM_JOINTS];
        aacmm_status_t st = aacmm_encoder_to_bam(encoders, reading_counts + k * AACMM_JOINTS, th);
        if (st != AACMM_OK) {
            return st;
        }
        if (jac_q32 != NULL) {
            chain_q(model, th, p_q32 + k * 3u, jac_q32 + k * AACMM_JAC_SIZE);
        } else {
            chain_q(model, th, p_q32 + k * 3u, NULL);
        }
        if (done != NULL) {
            *done = k + 1u;
        }
    }
    return AACMM_OK;
}
