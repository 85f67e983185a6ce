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
    model->thermal = (uint8_t)(err->thermal != 0u);
    return AACMM_OK;
}

aacmm_status_t aacmm_device_kin_at_temperature(const aacmm_device_model_t *model,
                                               aacmm_device_thermal_t *at,
                                               const int16_t temp[AACMM_JOINTS_MAX])
{
    float t[AACMM_JOINTS_MAX];
    aacmm_status_t st;
    int n;
    int i;
    int same;
    if (model == NULL || at == NULL || temp == NULL) {
        return AACMM_ERR_NULL;
    }
    n = (int)model->m.arm.shape.joints;
    same = aacmm_device_temps_cached(&at->valid, at->temp, temp, n);
    if (same < 0) {
        return (aacmm_status_t)same;
    }
    if (same) {
        return AACMM_OK; /* the cache is at these temperatures */
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        t[i] = i < n ? (float)temp[i] / 100.0f : (float)AACMM_TEMP_REF_DEFAULT_C;
    }
    at->valid = 0u;
    st = aacmm_model_at_temperature_f32(&at->m, &model->m, &model->em, t);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        at->temp_c[i] = t[i];
        at->temp[i] = i < n ? temp[i] : (int16_t)0;
        /* the core's factor (kinematics.h, "Thermal expansion"), the same
         * operations: dT first, then 1 + cte dT */
        {
            const float dt = t[i] - model->em.tref_c[i];
            at->f[i] = 1.0f + model->em.cte_per_k[i] * dt;
        }
    }
    at->valid = 1u;
    return AACMM_OK;
}

/* The 3 x P Jacobian of the point at at's temperatures: the chain's on the
 * cached scaled model at the corrected readings, its length columns (d, a of
 * link i, the tip with link N) times link i's factor f_i: the columns of the
 * parameters L0, as the first P columns of aacmm_point_jacobian_em_f32 (the
 * same products, bit for bit), without its extended Jacobian on the stack. */
static aacmm_status_t jacobian_at(const aacmm_device_model_t *model,
                                  const aacmm_device_thermal_t *at, const float *theta,
                                  float p[3], float jac[AACMM_JAC_SIZE_MAX])
{
    const int n = (int)model->m.arm.shape.joints;
    const int np = (int)model->m.n_params;
    const int ct = (int)model->m.col_tip;
    const int nt = (int)model->m.arm.shape.tip;
    float q[AACMM_JOINTS_MAX];
    aacmm_status_t st = aacmm_errmodel_angles_f32(&model->em, theta, q);
    int r;
    int i;
    if (st == AACMM_OK) {
        st = aacmm_point_jacobian_f32(&at->m, q, p, jac);
    }
    if (st != AACMM_OK) {
        return st;
    }
    for (r = 0; r < AACMM_JAC_ROWS; r++) {
        for (i = 0; i < n; i++) {
            jac[r * np + AACMM_ARM_COL_D(n, i)] *= at->f[i];
            jac[r * np + AACMM_ARM_COL_A(n, i)] *= at->f[i];
        }
        for (i = 0; i < nt; i++) {
            jac[r * np + ct + i] *= at->f[n - 1];
        }
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_device_thermal_t *at,
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
    if (at != NULL && at->valid == 0u) {
        return AACMM_ERR_RANGE;
    }
    st = aacmm_arm_encoders_to_angles_f32(enc, counts, theta);
    if (st != AACMM_OK) {
        return st;
    }
    if (at != NULL && jac != NULL) {
        st = jacobian_at(model, at, theta, p, jac);
    } else if (model->corrected != 0u) {
        /* the corrected readings, then the plain chain: the point of
         * aacmm_point_em_f32 and the first P columns of its extended
         * Jacobian, bit for bit (kinematics.h), without the extended
         * Jacobian's buffer on the stack */
        st = aacmm_errmodel_angles_f32(&model->em, theta, theta);
    }
    if (st == AACMM_OK && !(at != NULL && jac != NULL)) {
        /* at temperatures: the cached scaled model (aacmm_point_em_f32 runs
         * the chain on the same scaled lengths) */
        const aacmm_model_f32_t *m = at != NULL ? &at->m : &model->m;
        st = jac != NULL ? aacmm_point_jacobian_f32(m, theta, p, jac) : aacmm_point_f32(m, theta, p);
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
