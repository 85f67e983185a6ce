/* Host analysis helpers over the double-precision kinematics core.
 *
 * No FMA contraction here (the Python extension and the tests build with
 * -ffp-contract=off; GCC is told so for other builds): the scaled sums must
 * round x * scale and + offset separately, as numpy does. */
#include <math.h>
#include <stddef.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=off")
#endif

aacmm_status_t aacmm_abs_jacobian_sums_scaled_f64(const aacmm_model_f64_t *model, size_t n,
                                                  const double *theta_rad,
                                                  const double scale[AACMM_JOINTS],
                                                  const double offset[AACMM_JOINTS],
                                                  double abs_sum[AACMM_JAC_SIZE],
                                                  double sq_sum[AACMM_JAC_SIZE], size_t *done)
{
    double sa[AACMM_JAC_SIZE], sq[AACMM_JAC_SIZE];
    aacmm_status_t st = AACMM_OK;
    size_t k;
    int j;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || abs_sum == NULL || sq_sum == NULL || (n > 0u && theta_rad == NULL) ||
        ((scale == NULL) != (offset == NULL))) {
        return AACMM_ERR_NULL;
    }
    /* Local accumulators: the compiler keeps them out of the aliasing
     * question with the caller's arrays and vectorises the inner loop. */
    for (j = 0; j < AACMM_JAC_SIZE; j++) {
        sa[j] = 0.0;
        sq[j] = 0.0;
    }
    for (k = 0; k < n; k++) {
        double jac[AACMM_JAC_SIZE], p[3], th[AACMM_JOINTS];
        const double *pose = theta_rad + k * AACMM_JOINTS;
        if (scale != NULL && offset != NULL) {
            for (j = 0; j < AACMM_JOINTS; j++) {
                th[j] = pose[j] * scale[j];
                th[j] += offset[j];
            }
            pose = th;
        }
        st = aacmm_point_jacobian_f64(model, pose, p, jac);
        if (st != AACMM_OK) {
            break;
        }
        for (j = 0; j < AACMM_JAC_SIZE; j++) {
            sa[j] += fabs(jac[j]);
            sq[j] += jac[j] * jac[j];
        }
    }
    for (j = 0; j < AACMM_JAC_SIZE; j++) {
        abs_sum[j] += sa[j];
        sq_sum[j] += sq[j];
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

aacmm_status_t aacmm_abs_jacobian_sums_f64(const aacmm_model_f64_t *model, size_t n,
                                           const double *theta_rad, double abs_sum[AACMM_JAC_SIZE],
                                           double sq_sum[AACMM_JAC_SIZE], size_t *done)
{
    return aacmm_abs_jacobian_sums_scaled_f64(model, n, theta_rad, NULL, NULL, abs_sum, sq_sum,
                                              done);
}

void aacmm_params_perturb_f64(const aacmm_params_f64_t *nominal,
                              const double delta[AACMM_N_PARAMS], aacmm_params_f64_t *out)
{
    int i;
    *out = *nominal;
    for (i = 0; i < AACMM_JOINTS; i++) {
        out->theta_offset_rad[i] += delta[AACMM_COL_THETA(i)];
        out->alpha_rad[i] += delta[AACMM_COL_ALPHA(i)];
        out->d_mm[i] += delta[AACMM_COL_D(i)];
        out->a_mm[i] += delta[AACMM_COL_A(i)];
    }
    out->l_mm += delta[AACMM_COL_L];
}

aacmm_status_t aacmm_perturbed_points_f64(const aacmm_params_f64_t *nominal, size_t n_trials,
                                          const double *delta, size_t n_poses,
                                          const double *theta_rad, double *p_mm, size_t *done)
{
    size_t t, k;
    if (done != NULL) {
        *done = 0u;
    }
    if (nominal == NULL) {
        return AACMM_ERR_NULL;
    }
    if (n_trials > 0u && (delta == NULL || (n_poses > 0u && (theta_rad == NULL || p_mm == NULL)))) {
        return AACMM_ERR_NULL;
    }
    for (t = 0; t < n_trials; t++) {
        aacmm_params_f64_t prm;
        aacmm_model_f64_t model;
        aacmm_status_t st;
        aacmm_params_perturb_f64(nominal, delta + t * AACMM_N_PARAMS, &prm);
        st = aacmm_model_init_f64(&model, &prm);
        if (st != AACMM_OK) {
            return st;
        }
        for (k = 0; k < n_poses; k++) {
            st = aacmm_point_f64(&model, theta_rad + k * AACMM_JOINTS,
                                 p_mm + (t * n_poses + k) * 3u);
            if (st != AACMM_OK) {
                return st;
            }
        }
        if (done != NULL) {
            *done = t + 1u;
        }
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_counts_to_angles_f64(const aacmm_encoder_config_t *encoders, size_t n,
                                          const uint32_t *reading_counts, double *theta_rad,
                                          size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (encoders == NULL || (n > 0u && (reading_counts == NULL || theta_rad == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        aacmm_status_t st = aacmm_encoder_to_angles_f64(encoders, reading_counts + k * AACMM_JOINTS,
                                                        theta_rad + k * AACMM_JOINTS);
        if (st != AACMM_OK) {
            return st;
        }
        if (done != NULL) {
            *done = k + 1u;
        }
    }
    return AACMM_OK;
}
