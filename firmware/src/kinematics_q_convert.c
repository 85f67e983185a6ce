/*
 * Double <-> fixed-point parameter conversion, run once on the host (or by a
 * loader with an FPU). This is the only file of the fixed-point path that uses
 * floating point; it is deliberately NOT part of the Cortex-M0+ integer-only
 * build (see kinematics_q.h and mk/fixed.mk).
 */
#include <math.h>
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"

#define TWO_PI 6.283185307179586476925286766559
#define TWO_POW_32 4294967296.0
#define TWO_POW_18 262144.0

/* Round half away from zero to int64; |x| must be below 2^62. */
static int64_t round_i64(double x)
{
    return (x < 0.0) ? -(int64_t)(0.5 - x) : (int64_t)(x + 0.5);
}

/* |x| <= 2 pi (checked by the core validation): x / 2 pi in [-1, 1] turns. */
static uint32_t rad_to_bam(double x)
{
    int64_t b = round_i64(x / TWO_PI * TWO_POW_32); /* |b| <= 2^32 */
    return (uint32_t)((uint64_t)b & UINT64_C(0xFFFFFFFF));
}

static aacmm_status_t len_to_q18(double x, int32_t *out)
{
    if (!(x <= (double)AACMM_Q_REACH_MAX_MM && x >= -(double)AACMM_Q_REACH_MAX_MM)) {
        return AACMM_ERR_RANGE;
    }
    /* |x| <= 8000 mm: |x * 2^18| <= 2 097 152 000 < 2^31. */
    *out = (int32_t)round_i64(x * TWO_POW_18);
    return AACMM_OK;
}

aacmm_status_t aacmm_params_q_from_f64(aacmm_params_q_t *out, const aacmm_params_f64_t *in)
{
    aacmm_params_q_t q;
    aacmm_status_t st;
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_params_validate_f64(in);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        q.theta_offset_bam[i] = rad_to_bam(in->theta_offset_rad[i]);
        q.alpha_bam[i] = rad_to_bam(in->alpha_rad[i]);
        if ((st = len_to_q18(in->d_mm[i], &q.d_q18[i])) != AACMM_OK ||
            (st = len_to_q18(in->a_mm[i], &q.a_q18[i])) != AACMM_OK) {
            return st;
        }
    }
    if ((st = len_to_q18(in->l_mm, &q.l_q18)) != AACMM_OK) {
        return st;
    }
    st = aacmm_params_q_validate(&q); /* the total reach */
    if (st != AACMM_OK) {
        return st;
    }
    *out = q;
    return AACMM_OK;
}

aacmm_status_t aacmm_params_q_from_f32(aacmm_params_q_t *out, const aacmm_params_f32_t *in)
{
    aacmm_params_f64_t d;
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        d.theta_offset_rad[i] = (double)in->theta_offset_rad[i];
        d.alpha_rad[i] = (double)in->alpha_rad[i];
        d.d_mm[i] = (double)in->d_mm[i];
        d.a_mm[i] = (double)in->a_mm[i];
    }
    d.l_mm = (double)in->l_mm;
    return aacmm_params_q_from_f64(out, &d);
}

/* Signed BAM in (-2^31, 2^31] times 2 pi / 2^32. */
static double bam_to_rad(uint32_t b)
{
    double s = (b > UINT32_C(0x80000000)) ? -(double)(UINT32_C(0xFFFFFFFF) - b + 1u) : (double)b;
    return s * (TWO_PI / TWO_POW_32);
}

aacmm_status_t aacmm_params_q_to_f64(aacmm_params_f64_t *out, const aacmm_params_q_t *in)
{
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        out->theta_offset_rad[i] = bam_to_rad(in->theta_offset_bam[i]);
        out->alpha_rad[i] = bam_to_rad(in->alpha_bam[i]);
        out->d_mm[i] = (double)in->d_q18[i] / TWO_POW_18;
        out->a_mm[i] = (double)in->a_q18[i] / TWO_POW_18;
    }
    out->l_mm = (double)in->l_q18 / TWO_POW_18;
    return AACMM_OK;
}

aacmm_status_t aacmm_arm_q_from_f64(aacmm_arm_q_t *out, const aacmm_arm_f64_t *in)
{
    aacmm_arm_q_t q;
    aacmm_status_t st;
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_arm_validate_f64(in);
    if (st != AACMM_OK) {
        return st;
    }
    q.shape = in->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        q.theta_offset_bam[i] = rad_to_bam(in->theta_offset_rad[i]);
        q.alpha_bam[i] = rad_to_bam(in->alpha_rad[i]);
        q.beta_bam[i] = rad_to_bam(in->beta_rad[i]);
        if ((st = len_to_q18(in->d_mm[i], &q.d_q18[i])) != AACMM_OK ||
            (st = len_to_q18(in->a_mm[i], &q.a_q18[i])) != AACMM_OK) {
            return st;
        }
    }
    for (i = 0; i < 3; i++) {
        if ((st = len_to_q18(in->tip_mm[i], &q.tip_q18[i])) != AACMM_OK) {
            return st;
        }
    }
    st = aacmm_arm_q_validate(&q); /* the total reach */
    if (st != AACMM_OK) {
        return st;
    }
    *out = q;
    return AACMM_OK;
}

aacmm_status_t aacmm_arm_q_from_f32(aacmm_arm_q_t *out, const aacmm_arm_f32_t *in)
{
    aacmm_arm_f64_t d;
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    d.shape = in->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        d.theta_offset_rad[i] = (double)in->theta_offset_rad[i];
        d.alpha_rad[i] = (double)in->alpha_rad[i];
        d.d_mm[i] = (double)in->d_mm[i];
        d.a_mm[i] = (double)in->a_mm[i];
        d.beta_rad[i] = (double)in->beta_rad[i];
    }
    for (i = 0; i < 3; i++) {
        d.tip_mm[i] = (double)in->tip_mm[i];
    }
    return aacmm_arm_q_from_f64(out, &d);
}

aacmm_status_t aacmm_arm_q_to_f64(aacmm_arm_f64_t *out, const aacmm_arm_q_t *in)
{
    int i;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    out->shape = in->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        out->theta_offset_rad[i] = bam_to_rad(in->theta_offset_bam[i]);
        out->alpha_rad[i] = bam_to_rad(in->alpha_bam[i]);
        out->beta_rad[i] = bam_to_rad(in->beta_bam[i]);
        out->d_mm[i] = (double)in->d_q18[i] / TWO_POW_18;
        out->a_mm[i] = (double)in->a_q18[i] / TWO_POW_18;
    }
    for (i = 0; i < 3; i++) {
        out->tip_mm[i] = (double)in->tip_q18[i] / TWO_POW_18;
    }
    return AACMM_OK;
}

/* ---- the error model (kinematics_q.h) ---- */

#define TWO_POW_36 68719476736.0
#define TWO_POW_40 1099511627776.0

/* round(x) for |x| < 2^31 (the callers' validated ranges), half away from 0 */
static int32_t round_i32(double x)
{
    return (int32_t)round_i64(x);
}

aacmm_status_t aacmm_errmodel_q_from_f64(aacmm_errmodel_q_t *out, const aacmm_errmodel_f64_t *in)
{
    aacmm_errmodel_q_t q;
    aacmm_status_t st;
    int i, k;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_errmodel_validate_f64(in); /* |c|, |s| <= 0.1 rad, |cte| <= 1e-3 */
    if (st != AACMM_OK) {
        return st;
    }
    q.joints = in->joints;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        q.harmonics[i] = in->harmonics[i];
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            q.c_q36[i][k] = round_i32(in->c_rad[i][k] / TWO_PI * TWO_POW_36);
            q.s_q36[i][k] = round_i32(in->s_rad[i][k] / TWO_PI * TWO_POW_36);
        }
        q.cte_q40[i] = round_i32(in->cte_per_k[i] * TWO_POW_40);
        q.tref_q8[i] = round_i32(in->tref_c[i] * 256.0);
    }
    st = aacmm_errmodel_q_validate(&q); /* the rounded sums */
    if (st == AACMM_OK) {
        *out = q;
    }
    return st;
}

aacmm_status_t aacmm_errmodel_q_to_f64(aacmm_errmodel_f64_t *out, const aacmm_errmodel_q_t *in)
{
    int i, k;
    if (out == NULL || in == NULL) {
        return AACMM_ERR_NULL;
    }
    out->joints = in->joints;
    out->cte_columns = 0u;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        out->harmonics[i] = in->harmonics[i];
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            out->c_rad[i][k] = (double)in->c_q36[i][k] / TWO_POW_36 * TWO_PI;
            out->s_rad[i][k] = (double)in->s_q36[i][k] / TWO_POW_36 * TWO_PI;
        }
        out->cte_per_k[i] = (double)in->cte_q40[i] / TWO_POW_40;
        out->tref_c[i] = (double)in->tref_q8[i] / 256.0;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_temp_q8_from_f64(int32_t *out, const double *temp_c, size_t n)
{
    size_t i;
    if (n > 0u && (out == NULL || temp_c == NULL)) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < n; i++) {
        const double t = temp_c[i];
        if (isnan(t) || isinf(t)) {
            return AACMM_ERR_NOT_FINITE;
        }
        if (!(t >= AACMM_TEMP_MIN_C && t <= AACMM_TEMP_MAX_C)) {
            return AACMM_ERR_RANGE;
        }
    }
    for (i = 0; i < n; i++) {
        out[i] = round_i32(temp_c[i] * 256.0);
    }
    return AACMM_OK;
}
