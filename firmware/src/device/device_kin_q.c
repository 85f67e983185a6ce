/*
 * Kinematics backend: the fixed-point core (aacmm/kinematics_q.h), for parts
 * without an FPU. Build with -DAACMM_DEVICE_KIN_FIXED.
 *
 * Per sample everything is integer: counts -> binary angles
 * (aacmm_encoder_to_bam), point in Q48 mm (aacmm_point_q), and the wire
 * point in 1e-4 mm by an exact integer rounding. Floating point appears only
 * where the protocol asks for it: the float32 Jacobian entries and COMPUTE's
 * float64 point (conversions only), and aacmm_params_q_from_f64 when a
 * parameter set is loaded (once per SET_PARAMS / start-up).
 */
#include "device_kin.h"

#include <stddef.h>

#include "aacmm/kinematics_q.h"

#ifndef AACMM_DEVICE_KIN_FIXED
#error "device_kin_q.c needs -DAACMM_DEVICE_KIN_FIXED (aacmm_device_model_t is the Q model)"
#endif

#define Q48_TO_MM 3.552713678800501e-15 /* 2^-48 */
#define Q48_TO_MM_F 3.5527137e-15f

uint32_t aacmm_device_kin_flags(void)
{
    return AACMM_BUILD_KIN_FIXED;
}

aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_arm_f64_t *arm,
                                     const aacmm_error_model_t *err)
{
    aacmm_arm_q_t q;
    aacmm_errmodel_f64_t e;
    aacmm_errmodel_q_t eq;
    aacmm_model_q_t m;
    aacmm_status_t st;
    if (model == NULL || arm == NULL || err == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_device_errmodel_f64(&e, err, (int)arm->shape.joints);
    if (st == AACMM_OK) {
        st = aacmm_errmodel_q_from_f64(&eq, &e);
    }
    if (st == AACMM_OK) {
        st = aacmm_arm_q_from_f64(&q, arm);
    }
    if (st == AACMM_OK) {
        st = aacmm_model_q_init_arm(&m, &q);
    }
    if (st != AACMM_OK) {
        return st;
    }
    model->m = m;
    model->em = eq;
    model->corrected = (uint8_t)aacmm_device_errmodel_any(err);
    model->thermal = (uint8_t)(err->thermal != 0u);
    return AACMM_OK;
}

aacmm_status_t aacmm_device_kin_at_temperature(const aacmm_device_model_t *model,
                                               aacmm_device_thermal_t *at,
                                               const int16_t temp[AACMM_JOINTS_MAX])
{
    int32_t t[AACMM_JOINTS_MAX];
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
        t[i] = i < n ? aacmm_device_temp_q8(temp[i]) : AACMM_Q_TEMP_REF_DEFAULT;
    }
    at->valid = 0u;
    st = aacmm_model_q_at_temperature(&at->m, &model->m, &model->em, t);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        /* the core's e_i (kinematics_q.h, "Thermal"): the exact Q48 product
         * rounded half up to Q30 */
        const int64_t e48 = (int64_t)model->em.cte_q40[i] * (int64_t)(t[i] - model->em.tref_q8[i]);
        at->e30[i] = (int32_t)((e48 + ((int64_t)1 << 17)) >> 18);
        at->temp_q8[i] = t[i];
        at->temp[i] = i < n ? temp[i] : (int16_t)0;
    }
    at->valid = 1u;
    return AACMM_OK;
}

/* A length column of the chain's Jacobian on the scaled model (a Q30 axis
 * times 2^18, exactly) as the column of the parameter L0: times 1 + e
 * (e Q30), rounded half up to Q48 -- kinematics_q.h, "Thermal", the core's
 * operations. */
static int64_t length_col_l0(int64_t col, int32_t e30)
{
    const int64_t axis = col >> 18; /* exact */
    const int64_t v = axis * ((int64_t)AACMM_Q_ONE_Q30 + (int64_t)e30);
    return (v + ((int64_t)1 << 11)) >> 12;
}

/* round(v * 10^4 / 2^48), half away from zero, exactly, for |v| < 2^62.
 * The fixed path's reach limit (8000 mm) keeps the result far inside int32. */
static int32_t q48_to_100nm(int64_t v)
{
    uint64_t m = v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    /* m * 10^4 / 2^24 = hi * 10^4 + (lo * 10^4) / 2^24, kept as an integer t
     * plus a fraction that cannot change the rounding below. */
    uint64_t hi = m >> 24;
    uint64_t lo = m & 0xFFFFFFu;
    uint64_t t = hi * 10000u + ((lo * 10000u) >> 24);
    uint64_t r = (t + (UINT64_C(1) << 23)) >> 24; /* half up on the magnitude */
    if (r > 0x7FFFFFFFu) {
        r = 0x7FFFFFFFu;
    }
    return v < 0 ? -(int32_t)r : (int32_t)r;
}

aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_device_thermal_t *at,
                                        const aacmm_arm_encoders_t *enc,
                                        const uint32_t *counts, int want_mm,
                                        aacmm_device_point_t *out, float jac[AACMM_JAC_SIZE_MAX])
{
    uint32_t bam[AACMM_JOINTS_MAX];
    int64_t p[3];
    aacmm_status_t st;
    int i;
    if (model == NULL || enc == NULL || counts == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    if (at != NULL && at->valid == 0u) {
        return AACMM_ERR_RANGE;
    }
    st = aacmm_arm_encoders_to_bam(enc, counts, bam);
    if (st != AACMM_OK) {
        return st;
    }
    if (jac != NULL) {
        int64_t jq[AACMM_JAC_SIZE_MAX];
        if (model->corrected != 0u) {
            /* the corrected readings, then the plain chain:
             * aacmm_point_jacobian_corrected_q bit for bit (kinematics_q.h) */
            st = aacmm_errmodel_q_correct(&model->m, &model->em, bam, bam);
        }
        if (st == AACMM_OK) {
            st = aacmm_point_jacobian_q(at != NULL ? &at->m : &model->m, bam, p, jq);
        }
        if (st != AACMM_OK) {
            return st;
        }
        if (at != NULL) {
            /* at the temperatures: the chain ran on the cached scaled model;
             * its length columns become those of L0, as in
             * aacmm_point_jacobian_corrected_q (bit for bit, without its
             * model copy on the stack) */
            const int n = (int)model->m.arm.shape.joints;
            const int np = (int)model->m.n_params;
            const int ct = (int)model->m.col_tip;
            const int nt = (int)model->m.arm.shape.tip;
            int r;
            for (r = 0; r < AACMM_JAC_ROWS; r++) {
                for (i = 0; i < n; i++) {
                    jq[r * np + AACMM_ARM_COL_D(n, i)] =
                        length_col_l0(jq[r * np + AACMM_ARM_COL_D(n, i)], at->e30[i]);
                    jq[r * np + AACMM_ARM_COL_A(n, i)] =
                        length_col_l0(jq[r * np + AACMM_ARM_COL_A(n, i)], at->e30[i]);
                }
                for (i = 0; i < nt; i++) {
                    jq[r * np + ct + i] = length_col_l0(jq[r * np + ct + i], at->e30[n - 1]);
                }
            }
        }
        for (i = 0; i < 3 * (int)model->m.n_params; i++) {
            jac[i] = (float)jq[i] * Q48_TO_MM_F;
        }
    } else {
        if (model->corrected != 0u) {
            /* the corrected readings, then the plain chain (at temperatures
             * on the cached scaled model): aacmm_point_em_q bit for bit */
            st = aacmm_errmodel_q_correct(&model->m, &model->em, bam, bam);
        }
        if (st == AACMM_OK) {
            st = aacmm_point_q(at != NULL ? &at->m : &model->m, bam, p);
        }
        if (st != AACMM_OK) {
            return st;
        }
    }
    out->clipped = 0u;
    for (i = 0; i < 3; i++) {
        out->point_100nm[i] = q48_to_100nm(p[i]);
        if (want_mm) {
            out->point_mm[i] = (double)p[i] * Q48_TO_MM;
        }
    }
    return AACMM_OK;
}
