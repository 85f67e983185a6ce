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

/* AACMM_BUILD_KIN_* flags of the linked backend (0 for the float core). O(1). */
uint32_t aacmm_device_kin_flags(void);

/*
 * Prepare *model from a double-precision arm (already range checked by
 * aacmm_arm_validate_f64). On error *model is unchanged. Returns AACMM_OK
 * or the core's error. Cost: one model set-up.
 */
aacmm_status_t aacmm_device_kin_load(aacmm_device_model_t *model, const aacmm_arm_f64_t *arm);

/* A computed point in the forms the device sends. */
typedef struct {
    int32_t point_100nm[3]; /* wire unit 1e-4 mm, rounded half away from zero, clamped */
    uint8_t clipped;        /* 1 if a coordinate was clamped to the int32 range */
    double point_mm[3];     /* the backend's own result in mm (only if asked for) */
} aacmm_device_point_t;

/*
 * Point and, if jac is not NULL, the 3 x P Jacobian (float32, as on the
 * wire; P = the model's parameters) for the model's N raw readings, with
 * the encoders enc (enc->joints = N). point_mm is filled
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
