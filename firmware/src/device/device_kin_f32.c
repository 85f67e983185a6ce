/* Kinematics backend: the single-precision float core. */
#include "device_kin.h"

#include <stddef.h>

#include "aacmm/proto.h"

uint32_t aacmm_device_kin_flags(void)
{
    return 0u; /* floating point, single precision */
}

aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_arm_f64_t *arm)
{
    aacmm_arm_f32_t a;
    int i;
    if (model == NULL || arm == NULL) {
        return AACMM_ERR_NULL;
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
    return aacmm_model_init_arm_f32(model, &a);
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
    if (jac != NULL) {
        st = aacmm_point_jacobian_f32(model, theta, p, jac);
    } else {
        st = aacmm_point_f32(model, theta, p);
    }
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
