/* Kinematics backend: the single-precision float core. */
#include "device_kin.h"

#include <stddef.h>

#include "aacmm/proto.h"

uint32_t aacmm_device_kin_flags(void)
{
    return 0u; /* floating point, single precision */
}

aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_params_f64_t *params)
{
    aacmm_params_f32_t p;
    int i;
    if (model == NULL || params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        p.theta_offset_rad[i] = (float)params->theta_offset_rad[i];
        p.alpha_rad[i] = (float)params->alpha_rad[i];
        p.d_mm[i] = (float)params->d_mm[i];
        p.a_mm[i] = (float)params->a_mm[i];
    }
    p.l_mm = (float)params->l_mm;
    return aacmm_model_init_f32(model, &p);
}

aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_encoder_config_t *enc,
                                        const uint32_t counts[AACMM_JOINTS], int want_mm,
                                        aacmm_device_point_t *out, float jac[AACMM_JAC_SIZE])
{
    float theta[AACMM_JOINTS];
    float p[3];
    aacmm_status_t st;
    int i;
    if (model == NULL || enc == NULL || counts == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_to_angles_f32(enc, counts, theta);
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
