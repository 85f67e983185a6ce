/*
 * Fixed-point kinematics: model set-up, probe point, 3 x P Jacobian, batches,
 * for every arm shape (aacmm/kinematics.h).
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

aacmm_status_t aacmm_arm_q_validate(const aacmm_arm_q_t *arm)
{
    int64_t reach;
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
    /* At most 17 * 2^31 < 2^36: the sum cannot overflow. */
    reach = abs64(arm->tip_q18[0]) + abs64(arm->tip_q18[1]) + abs64(arm->tip_q18[2]);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (i < n) {
            reach += abs64(arm->d_q18[i]) + abs64(arm->a_q18[i]);
            if (!arm->shape.beta[i] && arm->beta_bam[i] != 0u) {
                return AACMM_ERR_RANGE;
            }
        } else if (arm->theta_offset_bam[i] != 0u || arm->alpha_bam[i] != 0u ||
                   arm->d_q18[i] != 0 || arm->a_q18[i] != 0 || arm->beta_bam[i] != 0u) {
            return AACMM_ERR_RANGE;
        }
    }
    if (arm->shape.tip == (uint8_t)AACMM_TIP_Z && (arm->tip_q18[0] != 0 || arm->tip_q18[1] != 0)) {
        return AACMM_ERR_RANGE;
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

aacmm_status_t aacmm_arm_q_from_params(aacmm_arm_q_t *arm, const aacmm_params_q_t *params)
{
    int i;
    if (arm == NULL || params == NULL) {
        return AACMM_ERR_NULL;
    }
    (void)aacmm_shape_paper(&arm->shape);
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        const int in = i < AACMM_JOINTS;
        arm->theta_offset_bam[i] = in ? params->theta_offset_bam[i] : 0u;
        arm->alpha_bam[i] = in ? params->alpha_bam[i] : 0u;
        arm->d_q18[i] = in ? params->d_q18[i] : 0;
        arm->a_q18[i] = in ? params->a_q18[i] : 0;
        arm->beta_bam[i] = 0u;
    }
    arm->tip_q18[0] = 0;
    arm->tip_q18[1] = 0;
    arm->tip_q18[2] = params->l_q18;
    return AACMM_OK;
}

aacmm_status_t aacmm_arm_default_q(aacmm_arm_q_t *arm)
{
    aacmm_params_q_t p;
    (void)aacmm_params_default_q(&p);
    return aacmm_arm_q_from_params(arm, &p);
}

aacmm_status_t aacmm_model_q_init_arm(aacmm_model_q_t *model, const aacmm_arm_q_t *arm)
{
    aacmm_status_t st;
    int i;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_arm_q_validate(arm);
    if (st != AACMM_OK) {
        return st;
    }
    model->arm = *arm;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        model->sin_alpha_q30[i] = 0;
        model->cos_alpha_q30[i] = AACMM_Q_ONE_Q30;
        model->sin_beta_q30[i] = 0;
        model->cos_beta_q30[i] = AACMM_Q_ONE_Q30;
        model->col_beta[i] = 0u;
        if (i < (int)arm->shape.joints) {
            aacmm_fixed_sincos(arm->alpha_bam[i], &model->sin_alpha_q30[i],
                               &model->cos_alpha_q30[i]);
        }
        if (arm->shape.beta[i]) {
            aacmm_fixed_sincos(arm->beta_bam[i], &model->sin_beta_q30[i], &model->cos_beta_q30[i]);
            model->col_beta[i] = (uint8_t)aacmm_shape_col_beta(&arm->shape, i);
        }
    }
    model->n_params = (uint8_t)aacmm_shape_params(&arm->shape);
    model->col_tip = (uint8_t)aacmm_shape_col_tip(&arm->shape);
    model->paper = (uint8_t)aacmm_shape_is_paper(&arm->shape);
    return AACMM_OK;
}

aacmm_status_t aacmm_model_q_init(aacmm_model_q_t *model, const aacmm_params_q_t *params)
{
    aacmm_arm_q_t arm;
    aacmm_status_t st;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_params_q_validate(params);
    if (st != AACMM_OK) {
        return st;
    }
    (void)aacmm_arm_q_from_params(&arm, params);
    return aacmm_model_q_init_arm(model, &arm);
}

/* ------------------------------------------------------------------------ */
/* Chain                                                                     */
/* ------------------------------------------------------------------------ */

/*
 * Q30 values are held in qv_t: int64_t where registers are 64 bits wide (the
 * products below then need no sign extension), int32_t on 32-bit targets
 * (half the memory, and the M0+ multiply helper takes the sign-extended word
 * anyway). The values, and so the results, are the same either way: a Q30
 * axis component never leaves the int32 range.
 */
#if SIZE_MAX > 0xFFFFFFFFu
typedef int64_t qv_t;
/* On 64-bit hosts the two loops below are unrolled (six joints: the loop
 * bookkeeping is a tenth of the work); the M0+ build (-Os) keeps them. */
#define UNROLL_JOINTS _Pragma("GCC unroll 6")
#else
typedef int32_t qv_t;
#define UNROLL_JOINTS
#endif

/* Q30 3-vector (axes) and Q48 3-vector (positions). Small structs passed by
 * value stay in registers. */
typedef struct {
    qv_t x, y, z;
} vec3_q30;

typedef struct {
    int64_t x, y, z;
} vec3_q48;

/* The small helpers of the chain are inlined wherever they are used: -Os
 * would otherwise keep them out of line once two chains use them (each call
 * passing 3-vectors by value), which cost the paper's chain 40 % on the
 * Cortex-M4F (measured, bench-boards). */
#if defined(__GNUC__)
#define Q_INLINE static inline __attribute__((always_inline))
#else
#define Q_INLINE static inline
#endif

/* 32 x 32 -> 64-bit product (operands within the int32 range). */
#if AACMM_FIXED_SPLIT_MUL
#define MUL(a, b) aacmm_fixed_mul((int32_t)(a), (int32_t)(b))
#else
#define MUL(a, b) ((int64_t)(a) * (int64_t)(b))
#endif

/*
 * Two formulations of the frame step and the angle columns, chosen by the
 * multiplier (fixed_sincos.h): with a native 32 x 32 -> 64-bit product (hosts,
 * ARMv7-M's SMULL) the sums of products are exact in 64 bits and rounded
 * once; on ARMv6-M (Cortex-M0/M0+, no long multiply; or AACMM_Q_SPLIT_MUL)
 * every product is rounded on its own in 32-bit arithmetic
 * (aacmm_fixed_mul_q30, four 16 x 16 MULS), which costs a third of the
 * instructions of the split 64-bit product. kinematics_q.h gives the bounds
 * of both; the tests run both (the split one in test-fixed-split and the
 * sanitizer build).
 */
#if AACMM_FIXED_SPLIT_MUL

/* a u + b v for Q30 a, b, u, v: each product rounded half up to Q30, then
 * summed: within 1 LSB of the exact value. */
Q_INLINE vec3_q30 lin2_q30(qv_t a, vec3_q30 u, qv_t b, vec3_q30 v)
{
    vec3_q30 r;
    const int32_t a32 = (int32_t)a, b32 = (int32_t)b;
    r.x = (qv_t)aacmm_fixed_mul_q30(a32, (int32_t)u.x) + aacmm_fixed_mul_q30(b32, (int32_t)v.x);
    r.y = (qv_t)aacmm_fixed_mul_q30(a32, (int32_t)u.y) + aacmm_fixed_mul_q30(b32, (int32_t)v.y);
    r.z = (qv_t)aacmm_fixed_mul_q30(a32, (int32_t)u.z) + aacmm_fixed_mul_q30(b32, (int32_t)v.z);
    return r;
}

/* p - o for the angle columns in Q17 (|p - o| <= 8000 mm: |.| < 2^30, an
 * operand aacmm_fixed_mul_q30 takes): (p + 2^30 - o) >> 31 rounds half up;
 * PH_HALF is the 2^30 added to p once. */
#define PH_HALF ((int64_t)1 << 30)
#define PO_SHIFT 31

/* Cross product a x b of a Q30 axis and a Q17 vector: each product rounded
 * half up to Q17, the difference (within 1 LSB of Q17, 7.6e-6, of the exact
 * value; |a x b| <= |a| |b| < 2^30 + 2^7: no int32 overflow) returned in
 * Q48, the output format (times 2^31, exact). */
#define CROSS_Q17(a1, b1, a2, b2)                                                                 \
    ((int64_t)(aacmm_fixed_mul_q30((int32_t)(a1), (int32_t)(b1)) -                               \
               aacmm_fixed_mul_q30((int32_t)(a2), (int32_t)(b2))) *                               \
     ((int64_t)1 << 31))
Q_INLINE void cross_q48(vec3_q30 a, vec3_q30 b, int64_t *out, int stride)
{
    out[0 * stride] = CROSS_Q17(a.y, b.z, a.z, b.y);
    out[1 * stride] = CROSS_Q17(a.z, b.x, a.x, b.z);
    out[2 * stride] = CROSS_Q17(a.x, b.y, a.y, b.x);
}

#else

/* a u + b v for Q30 a, b, u, v: exact Q60 sum in int64 (|.| < 2^61 for the
 * unit-bounded operands here), rounded half up to Q30. */
Q_INLINE vec3_q30 lin2_q30(qv_t a, vec3_q30 u, qv_t b, vec3_q30 v)
{
    vec3_q30 r;
    r.x = (qv_t)AACMM_FIXED_RND(MUL(a, u.x) + MUL(b, v.x), 30);
    r.y = (qv_t)AACMM_FIXED_RND(MUL(a, u.y) + MUL(b, v.y), 30);
    r.z = (qv_t)AACMM_FIXED_RND(MUL(a, u.z) + MUL(b, v.z), 30);
    return r;
}

/* p - o for the angle columns in Q18 (|p - o| <= 8000 mm: |.| < 2^31):
 * (p + 2^29 - o) >> 30 rounds half up. */
#define PH_HALF ((int64_t)1 << 29)
#define PO_SHIFT 30

/* Cross product a x b of a Q30 axis and a Q18 vector: each component is the
 * exact Q48 difference of two products (|.| < 2^62), the output format. */
Q_INLINE void cross_q48(vec3_q30 a, vec3_q30 b, int64_t *out, int stride)
{
    out[0 * stride] = MUL(a.y, b.z) - MUL(a.z, b.y);
    out[1 * stride] = MUL(a.z, b.x) - MUL(a.x, b.z);
    out[2 * stride] = MUL(a.x, b.y) - MUL(a.y, b.x);
}

#endif

/* (p + PH_HALF) - o, shifted down: p - o rounded half up (to Q17 or Q18, as
 * above). ph is p + PH_HALF, formed once. */
Q_INLINE vec3_q30 diff_po(vec3_q48 ph, vec3_q48 o)
{
    vec3_q30 r;
    r.x = (qv_t)((ph.x - o.x) >> PO_SHIFT);
    r.y = (qv_t)((ph.y - o.y) >> PO_SHIFT);
    r.z = (qv_t)((ph.z - o.z) >> PO_SHIFT);
    return r;
}

/* Q30 -> Q48: times 2^18, exact (a multiplication: left shifts of negative
 * values are undefined in C). */
#define Q30_TO_Q48(v) ((int64_t)(v) * ((int64_t)1 << 18))

/* The chain twice from one template (chain_q_impl.h): chain_paper_q for the
 * paper's shape, its constants compiled in, and chain_any_q for every shape;
 * chain_q runs the one of the model's shape. */
#define CQ(name) name##_paper_q
#define CQ_GENERAL 0
#include "chain_q_impl.h"
#undef CQ
#undef CQ_GENERAL
#define CQ(name) name##_any_q
#define CQ_GENERAL 1
#include "chain_q_impl.h"
#undef CQ
#undef CQ_GENERAL

Q_INLINE void chain_q(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                           int64_t p_q48[3], int64_t *jac)
{
    if (model->paper) {
        chain_paper_q(model, theta_bam, p_q48, jac);
    } else {
        chain_any_q(model, theta_bam, p_q48, jac);
    }
}

aacmm_status_t aacmm_point_q(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                             int64_t p_q48[3])
{
    if (model == NULL || theta_bam == NULL || p_q48 == NULL) {
        return AACMM_ERR_NULL;
    }
    chain_q(model, theta_bam, p_q48, NULL);
    return AACMM_OK;
}

aacmm_status_t aacmm_point_jacobian_q(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                                      int64_t p_q48[3], int64_t *jac_q48)
{
    if (model == NULL || theta_bam == NULL || p_q48 == NULL || jac_q48 == NULL) {
        return AACMM_ERR_NULL;
    }
    chain_q(model, theta_bam, p_q48, jac_q48);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Batches                                                                   */
/* ------------------------------------------------------------------------ */

aacmm_status_t aacmm_batch_bam_q(const aacmm_model_q_t *model, size_t n, const uint32_t *theta_bam,
                                 int64_t *p_q48, int64_t *jac_q48, size_t *done)
{
    size_t k, nj, jn;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_bam == NULL || p_q48 == NULL))) {
        return AACMM_ERR_NULL;
    }
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    for (k = 0; k < n; k++) {
        if (jac_q48 != NULL) {
            chain_q(model, theta_bam + k * nj, p_q48 + k * 3u, jac_q48 + k * jn);
        } else {
            chain_q(model, theta_bam + k * nj, p_q48 + k * 3u, NULL);
        }
    }
    if (done != NULL) {
        *done = n;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_batch_counts_q(const aacmm_model_q_t *model,
                                    const aacmm_arm_encoders_t *encoders, size_t n,
                                    const uint32_t *reading_counts, int64_t *p_q48,
                                    int64_t *jac_q48, size_t *done)
{
    size_t k, nj, jn;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || encoders == NULL ||
        (n > 0u && (reading_counts == NULL || p_q48 == NULL))) {
        return AACMM_ERR_NULL;
    }
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    if (encoders->joints != nj) {
        return AACMM_ERR_RANGE;
    }
    for (k = 0; k < n; k++) {
        uint32_t th[AACMM_JOINTS_MAX];
        aacmm_status_t st = aacmm_arm_encoders_to_bam(encoders, reading_counts + k * nj, th);
        if (st != AACMM_OK) {
            return st;
        }
        if (jac_q48 != NULL) {
            chain_q(model, th, p_q48 + k * 3u, jac_q48 + k * jn);
        } else {
            chain_q(model, th, p_q48 + k * 3u, NULL);
        }
        if (done != NULL) {
            *done = k + 1u;
        }
    }
    return AACMM_OK;
}

#include "errmodel_q_impl.h"
