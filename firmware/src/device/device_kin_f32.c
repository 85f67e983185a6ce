/* Kinematics backend: the single-precision float core. */
#include "device_kin.h"

#include <stddef.h>

#include "aacmm/proto.h"

uint32_t aacmm_device_kin_flags(void)
{
    return 0u; /* floating point, single precision */
}

aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_arm_f64_t *arm,
                                     const aacmm_error_model_t *err)
{
    aacmm_arm_f32_t a;
    aacmm_errmodel_f64_t e;
    aacmm_model_f32_t m;
    aacmm_errmodel_f32_t ef;
    aacmm_status_t st;
    int i;
    int k;
    if (model == NULL || arm == NULL || err == NULL) {
        return AACMM_ERR_NULL;
    }
    if (err->thermal != 0u) {
        return AACMM_ERR_UNSUPPORTED; /* no link temperatures on the device yet */
    }
    st = aacmm_device_errmodel_f64(&e, err, (int)arm->shape.joints);
    if (st != AACMM_OK) {
        return st;
    }
    st = aacmm_errmodel_default_f32(&ef, (int)arm->shape.joints);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        ef.harmonics[i] = e.harmonics[i];
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            ef.c_rad[i][k] = (float)e.c_rad[i][k];
            ef.s_rad[i][k] = (float)e.s_rad[i][k];
        }
        ef.cte_per_k[i] = (float)e.cte_per_k[i];
        ef.tref_c[i] = (float)e.tref_c[i];
    }
    st = aacmm_errmodel_validate_f32(&ef);
    if (st != AACMM_OK) {
        return st;
    }
    a.shape = arm->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        a.theta_offset_rad[i] = (float)arm->theta_offset_rad[i];
        a.alpha_rad[i] = (float)arm->alpha_rad[i];
        a.d_mm[i] = (float)arm->d_mm[i];
        a.a_mm[i] = (float)arm->a_mm[i];
        a.beta_rad[i] = (float)arm->beta_rad[i];
    }
    for (i = 0; i < 3; i++) {
        a.tip_mm[i] = (float)arm->tip_mm[i];
    }
    st = aacmm_model_init_arm_f32(&m, &a);
    if (st != AACMM_OK) {
        return st;
    }
    model->m = m;
    model->em = ef;
    model->corrected = (uint8_t)aacmm_device_errmodel_any(err);
    return AACMM_OK;
}

aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_arm_encoders_t *enc,
                                        const uint32_t *counts, int want_mm,
                                        aacmm_device_point_t *out, float jac[AACMM_JAC_SIZE_MAX])
{
    float theta[AACMM_JOINTS_MAX];
    float p[3];
    aacmm_status_t st;
    int i;
    if (model == NULL || enc == NULL || counts == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_arm_encoders_to_angles_f32(enc, counts, theta);
    if (st != AACMM_OK) {
        return st;
    }
    if (model->corrected != 0u) {
        /* the corrected readings, then the plain chain: the point of
         * aacmm_point_em_f32 and the first P columns of its extended
         * Jacobian, bit for bit (kinematics.h), without the extended
         * Jacobian's buffer on the stack */
        st = aacmm_errmodel_angles_f32(&model->em, theta, theta);
        if (st != AACMM_OK) {
            return st;
        }
    }
    st = jac != NULL ? aacmm_point_jacobian_f32(&model->m, theta, p, jac)
                     : aacmm_point_f32(&model->m, theta, p);
    if (st != AACMM_OK) {
        return st;
    }
    out->clipped = 0u;
    for (i = 0; i < 3; i++) {
        int clipped = 0;
        out->point_100nm[i] = aacmm_point_mm_to_wire((double)p[i], &clipped);
        if (clipped) {
            out->clipped = 1u;
        }
        if (want_mm) {
            out->point_mm[i] = (double)p[i];
        }
    }
    return AACMM_OK;
}
