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

/* The sums for a model of the paper's shape (nj = 6, jn = 75 constants) or
 * any (read from the model): one loop, instantiated for each so the paper's
 * runs with its constants as before the general model. Local accumulators:
 * the compiler keeps them out of the aliasing question with the caller's
 * arrays and vectorises the inner loop. */
#define SUMS_LOOP(nj, jn)                                                                          \
    for (j = 0; j < (jn); j++) {                                                                   \
        sa[j] = 0.0;                                                                               \
        sq[j] = 0.0;                                                                               \
    }                                                                                              \
    for (k = 0; k < n; k++) {                                                                      \
        double jac[AACMM_JAC_SIZE_MAX], p[3], th[AACMM_JOINTS_MAX];                                \
        const double *pose = theta_rad + k * (size_t)(nj);                                         \
        if (scale != NULL && offset != NULL) {                                                     \
            for (j = 0; j < (nj); j++) {                                                           \
                th[j] = pose[j] * scale[j];                                                        \
                th[j] += offset[j];                                                                \
            }                                                                                      \
            pose = th;                                                                             \
        }                                                                                          \
        st = aacmm_point_jacobian_f64(model, pose, p, jac);                                        \
        if (st != AACMM_OK) {                                                                      \
            break;                                                                                 \
        }                                                                                          \
        for (j = 0; j < (jn); j++) {                                                               \
            sa[j] += fabs(jac[j]);                                                                 \
            sq[j] += jac[j] * jac[j];                                                              \
        }                                                                                          \
    }                                                                                              \
    for (j = 0; j < (jn); j++) {                                                                   \
        abs_sum[j] += sa[j];                                                                       \
        sq_sum[j] += sq[j];                                                                        \
    }

aacmm_status_t aacmm_abs_jacobian_sums_scaled_f64(const aacmm_model_f64_t *model, size_t n,
                                                  const double *theta_rad, const double *scale,
                                                  const double *offset, double *abs_sum,
                                                  double *sq_sum, size_t *done)
{
    double sa[AACMM_JAC_SIZE_MAX], sq[AACMM_JAC_SIZE_MAX];
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
    if (model->paper) {
        SUMS_LOOP(AACMM_JOINTS, AACMM_JAC_SIZE)
    } else {
        const int nj = (int)model->arm.shape.joints, jn = AACMM_JAC_ROWS * (int)model->n_params;
        SUMS_LOOP(nj, jn)
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}
#undef SUMS_LOOP

aacmm_status_t aacmm_abs_jacobian_sums_f64(const aacmm_model_f64_t *model, size_t n,
                                           const double *theta_rad, double *abs_sum,
                                           double *sq_sum, size_t *done)
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

aacmm_status_t aacmm_arm_perturb_f64(const aacmm_arm_f64_t *nominal, const double *delta,
                                     aacmm_arm_f64_t *out)
{
    double v[AACMM_PARAMS_MAX];
    int np, c;
    if (nominal == NULL || delta == NULL || out == NULL) {
        return AACMM_ERR_NULL;
    }
    np = aacmm_shape_params(&nominal->shape);
    if (np < 0) {
        return AACMM_ERR_RANGE;
    }
    (void)aacmm_arm_get_vector_f64(nominal, v);
    for (c = 0; c < np; c++) {
        v[c] += delta[c];
    }
    *out = *nominal;
    return aacmm_arm_set_vector_f64(out, v);
}

aacmm_status_t aacmm_perturbed_points_f64(const aacmm_arm_f64_t *nominal, size_t n_trials,
                                          const double *delta, size_t n_poses,
                                          const double *theta_rad, double *p_mm, size_t *done)
{
    size_t t, k, np, nj;
    if (done != NULL) {
        *done = 0u;
    }
    if (nominal == NULL) {
        return AACMM_ERR_NULL;
    }
    if (n_trials > 0u && (delta == NULL || (n_poses > 0u && (theta_rad == NULL || p_mm == NULL)))) {
        return AACMM_ERR_NULL;
    }
    if (aacmm_shape_validate(&nominal->shape) != AACMM_OK) {
        return AACMM_ERR_RANGE;
    }
    np = (size_t)aacmm_shape_params(&nominal->shape);
    nj = nominal->shape.joints;
    for (t = 0; t < n_trials; t++) {
        aacmm_arm_f64_t prm;
        aacmm_model_f64_t model;
        aacmm_status_t st;
        (void)aacmm_arm_perturb_f64(nominal, delta + t * np, &prm);
        st = aacmm_model_init_arm_f64(&model, &prm);
        if (st != AACMM_OK) {
            return st;
        }
        for (k = 0; k < n_poses; k++) {
            st = aacmm_point_f64(&model, theta_rad + k * nj, p_mm + (t * n_poses + k) * 3u);
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

aacmm_status_t aacmm_counts_to_angles_f64(const aacmm_arm_encoders_t *encoders, size_t n,
                                          const uint32_t *reading_counts, double *theta_rad,
                                          size_t *done)
{
    size_t k, nj;
    if (done != NULL) {
        *done = 0u;
    }
    if (encoders == NULL || (n > 0u && (reading_counts == NULL || theta_rad == NULL))) {
        return AACMM_ERR_NULL;
    }
    nj = encoders->joints;
    for (k = 0; k < n; k++) {
        aacmm_status_t st = aacmm_arm_encoders_to_angles_f64(encoders, reading_counts + k * nj,
                                                             theta_rad + k * nj);
        if (st != AACMM_OK) {
            return st;
        }
        if (done != NULL) {
            *done = k + 1u;
        }
    }
    return AACMM_OK;
}
