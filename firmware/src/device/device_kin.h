/*
 * The device's kinematics seam: the four functions the device application
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
 * (aacmm_errmodel_validate_*); model->thermal says whether it has the
 * thermal block (whether the platform can read link temperatures is the
 * device's check, not the backend's). On error *model is unchanged.
 * Returns AACMM_OK or the core's error. Cost: one model set-up.
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

/*
 * *at = model's arm at the link temperatures temp[0 .. N-1] (AACMM_TEMP_UNIT_C,
 * each within AACMM_REF_TEMP_MIN .. AACMM_REF_TEMP_MAX, else AACMM_ERR_RANGE):
 * aacmm_model_at_temperature_f32 of temp / 100 (the float nearest each
 * reading in degC) or aacmm_model_q_at_temperature of temp in Q8 (rounded
 * exactly, half away from zero: aacmm_device_temp_q8). Nothing is recomputed
 * when *at is valid and already at temp (the cache of a device whose
 * temperatures do not change). Errors: AACMM_ERR_NULL, AACMM_ERR_RANGE (a
 * temperature, or a scaled length beyond the core's limit); at->valid is 0
 * afterwards. Cost: N comparisons; on a change 2N + 3 multiplies (the core's
 * scaling) and a model copy.
 */
aacmm_status_t aacmm_device_kin_at_temperature(const aacmm_device_model_t *model,
                                               aacmm_device_thermal_t *at,
                                               const int16_t temp[AACMM_JOINTS_MAX]);

/* A link temperature in AACMM_TEMP_UNIT_C as Q8 degC: round(t 256 / 100),
 * half away from zero, exactly (there are no ties: 25 does not divide 2).
 * Integer only. */
static inline int32_t aacmm_device_temp_q8(int16_t t)
{
    int32_t m = t < 0 ? -(int32_t)t : (int32_t)t;
    int32_t q = (2 * 64 * m + 25) / 50; /* floor(64 m / 25 + 1/2) */
    return t < 0 ? -q : q;
}

/* The shared first step of aacmm_device_kin_at_temperature: whether the
 * cache (its valid flag and the temperatures cached[0 .. n-1] it holds) is at
 * the n link temperatures temp[] (AACMM_TEMP_UNIT_C). Returns 1 (it is), 0
 * (recompute), or AACMM_ERR_RANGE for a temperature outside
 * AACMM_REF_TEMP_MIN .. AACMM_REF_TEMP_MAX, and then clears *valid. O(N). */
static inline int aacmm_device_temps_cached(uint8_t *valid, const int16_t *cached,
                                            const int16_t *temp, int n)
{
    int same = *valid != 0u;
    int i;
    for (i = 0; i < n; i++) {
        if (temp[i] < AACMM_REF_TEMP_MIN || temp[i] > AACMM_REF_TEMP_MAX) {
            *valid = 0u;
            return (int)AACMM_ERR_RANGE;
        }
        if (temp[i] != cached[i]) {
            same = 0;
        }
    }
    return same;
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
 * host from the theta columns (docs/protocol.md 2.3). at NULL: at the
 * reference temperatures (no scaling: the points of a set without the
 * thermal block, bit for bit). at not NULL (a valid
 * aacmm_device_kin_at_temperature of this model): the point of
 * aacmm_point_em_* at at's temperatures, bit for bit, from the cached
 * scaled model; the Jacobian is then the first P columns of
 * aacmm_point_jacobian_em_f32 / aacmm_point_jacobian_corrected_q at those
 * temperatures, bit for bit (the length columns those of the parameters L0,
 * kinematics.h; f32: the chain's columns on the cached model times the
 * cached factors).
 * point_mm is filled only when want_mm is non-zero (COMPUTE; the fixed-point
 * backend avoids double arithmetic otherwise). Errors: AACMM_ERR_RANGE (a
 * reading >= its counts per revolution, an invalid at) or the core's; *out
 * and jac are not written on error. Cost: one encoder conversion + one point
 * (+ Jacobian) evaluation (with at and jac: + 3 (2N + T) multiplies of the
 * length columns; Q: + the core's scaling of a model copy on the stack).
 */
aacmm_status_t aacmm_device_kin_compute(const aacmm_device_model_t *model,
                                        const aacmm_device_thermal_t *at,
                                        const aacmm_arm_encoders_t *enc,
                                        const uint32_t *counts, int want_mm,
                                        aacmm_device_point_t *out, float jac[AACMM_JAC_SIZE_MAX]);

#endif /* AACMM_DEVICE_KIN_H */
