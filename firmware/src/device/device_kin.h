/*
 * The device's kinematics seam: the three functions the device application
 * needs from a kinematics backend. Exactly one backend is linked, chosen at
 * build time:
 *
 *   device_kin_f32.c  single-precision float core (default; Cortex-M4F FPU)
 *   device_kin_q.c    fixed-point core (aacmm/kinematics_q.h) for FPU-less
 *                     parts; built with -DAACMM_DEVICE_KIN_FIXED, which also
 *                     switches aacmm_device_model_t in aacmm/device.h
 *
 * Not part of the public API.
 */
#ifndef AACMM_DEVICE_KIN_H
#define AACMM_DEVICE_KIN_H

#include <stdint.h>

#include "aacmm/device.h"
#include "aacmm/kinematics.h"
#include "aacmm/proto.h"

/* AACMM_BUILD_KIN_* flags of the linked backend (0 for the float core). O(1). */
uint32_t aacmm_device_kin_flags(void);

/*
 * Prepare *model from a double-precision arm (already range checked by
 * aacmm_arm_validate_f64) and the parameter set's error model err (wire
 * units, aacmm/proto.h; checked by the codec). The error model is converted
 * with aacmm_device_errmodel_f64 and validated by the core
 * (aacmm_errmodel_validate_*). A set with the thermal block is
 * AACMM_ERR_UNSUPPORTED (the device reads no link temperatures yet). On
 * error *model is unchanged. Returns AACMM_OK or the core's error. Cost: one
 * model set-up.
 */
aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_arm_f64_t *arm,
                                     const aacmm_error_model_t *err);

/* The wire error model of an n-joint set in the core's double form: c, s
 * times AACMM_HARMONIC_UNIT_RAD, cte times AACMM_CTE_UNIT_PER_K, every
 * link's tref ref_temp times AACMM_TEMP_UNIT_C (20 degC without the thermal
 * block), no cte columns. AACMM_ERR_NULL, AACMM_ERR_RANGE (n) or the core's
 * validation. O(N K). */
static inline aacmm_status_t aacmm_device_errmodel_f64(aacmm_errmodel_f64_t *out,
                                                       const aacmm_error_model_t *err, int n)
{
    aacmm_status_t st;
    int i;
    int k;
    if (out == NULL || err == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_errmodel_default_f64(out, n);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < n; i++) {
        out->harmonics[i] = err->harmonics[i];
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            out->c_rad[i][k] = (double)err->harm_cos[i][k] * AACMM_HARMONIC_UNIT_RAD;
            out->s_rad[i][k] = (double)err->harm_sin[i][k] * AACMM_HARMONIC_UNIT_RAD;
        }
        if (err->thermal != 0u) {
            out->cte_per_k[i] = (double)err->cte[i] * AACMM_CTE_UNIT_PER_K;
            out->tref_c[i] = (double)err->ref_temp * AACMM_TEMP_UNIT_C;
        }
    }
    return aacmm_errmodel_validate_f64(out);
}

/* 1 if err corrects anything (a K_i > 0 or the thermal block), else 0. */
static inline int aacmm_device_errmodel_any(const aacmm_error_model_t *err)
{
    int i;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (err->harmonics[i] != 0u) {
            return 1;
        }
    }
    return err->thermal != 0u;
}

/* A computed point in the forms the device sends. */
typedef struct {
    int32_t point_100nm[3]; /* wire unit 1e-4 mm, rounded half away from zero, clamped */
    uint8_t clipped;        /* 1 if a coordinate was clamped to the int32 range */
    double point_mm[3];     /* the backend's own result in mm (only if asked for) */
} aacmm_device_point_t;

/*
 * Point and, if jac is not NULL, the 3 x P Jacobian (float32, as on the
 * wire; P = the model's parameters) for the model's N raw readings, with
 * the encoders enc (enc->joints = N). With an error model the readings are
 * corrected first (aacmm_point_em_* of the core) and the Jacobian holds the
 * structural columns at the corrected readings (the first P columns of the
 * core's extended Jacobian, bit for bit); the harmonic columns follow on the
 * host from the theta columns (docs/protocol.md 2.3). point_mm is filled
 * only when want_mm is non-zero (COMPUTE; the fixed-point backend avoids
 * double arithmetic otherwise). Errors: AACMM_ERR_RANGE (a reading >= its
 * counts per revolution) or the core's; *out and jac are not written on
 * error. Cost: one encoder conversion + one point (+ Jacobian) evaluation.
 */
aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_arm_encoders_t *enc,
                                        const uint32_t *counts, int want_mm,
                                        aacmm_device_point_t *out, float jac[AACMM_JAC_SIZE_MAX]);

#endif /* AACMM_DEVICE_KIN_H */
