/*
 * aacmm host analysis helpers: tight C loops over the kinematics core for the
 * Monte Carlo error-transfer study (paper Table 2) and for uncertainty
 * propagation. Host only (double precision); not part of the firmware image.
 *
 * Every function calls the core (aacmm_point_jacobian_f64, aacmm_point_f64,
 * aacmm_model_init_arm_f64) pose by pose, for a model of any shape, and keeps
 * only small fixed-size state on the stack, so the working set stays in L1
 * whatever n is. Ownership: the
 * caller owns every buffer; nothing is allocated, nothing is kept between
 * calls, no global state is touched; all functions are reentrant, so disjoint
 * slices of one batch may run on several threads at once.
 */
#ifndef AACMM_ANALYSIS_H
#define AACMM_ANALYSIS_H

#include <stddef.h>
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Number of structural parameters of the paper's arm, in the Jacobian column
 * order (a general model has its own P, aacmm_shape_params). */
#define AACMM_N_PARAMS AACMM_JAC_COLS

/*
 * Accumulate, over n poses theta_rad[n*N] (rad, readings as for
 * aacmm_point_jacobian_f64; N = model->arm.shape.joints), the sum of |J| and
 * the sum of J^2 for each of the 3 P Jacobian entries (row-major, as jac in
 * kinematics.h; P = model->n_params, 3 P <= AACMM_JAC_SIZE_MAX):
 *     abs_sum[k] += |J_k|,   sq_sum[k] += J_k^2.
 * The sums are added to what the arrays hold, so the caller zeroes them first
 * and may call again to extend a run. Stops at the first invalid pose (errors
 * as aacmm_point_f64: AACMM_ERR_RANGE, AACMM_ERR_NOT_FINITE); the poses before
 * it are accumulated and *done (if not NULL) receives their number (n on
 * success). AACMM_ERR_NULL for a NULL model or sum array, or a NULL theta_rad
 * with n > 0. Cost: n times (point + Jacobian + 6 P flops).
 */
aacmm_status_t aacmm_abs_jacobian_sums_f64(const aacmm_model_f64_t *model, size_t n,
                                           const double *theta_rad, double *abs_sum,
                                           double *sq_sum, size_t *done);

/*
 * aacmm_abs_jacobian_sums_f64 on the poses theta[k*N + i] =
 * theta_rad[k*N + i] * scale[i] + offset[i] (the product rounded, then the
 * sum: the values of forming them first with two separate operations), formed
 * pose by pose: a Monte Carlo run draws unit deviates and saves a pass over
 * its poses. scale and offset (N values each) are both NULL (no scaling) or
 * both given, else AACMM_ERR_NULL. Errors and *done otherwise as there.
 */
aacmm_status_t aacmm_abs_jacobian_sums_scaled_f64(const aacmm_model_f64_t *model, size_t n,
                                                  const double *theta_rad, const double *scale,
                                                  const double *offset, double *abs_sum,
                                                  double *sq_sum, size_t *done);

/*
 * *out = *nominal with delta[25] added in the Jacobian column order:
 * theta_offset_i += delta[i], alpha_i += delta[6 + i], d_i += delta[12 + i],
 * a_i += delta[18 + i], l += delta[24]. Not validated (aacmm_model_init_f64
 * does that). Pointers must not be NULL. Cost: 25 additions.
 */
void aacmm_params_perturb_f64(const aacmm_params_f64_t *nominal,
                              const double delta[AACMM_N_PARAMS], aacmm_params_f64_t *out);

/*
 * The same for any arm: *out = *nominal (its shape) with delta[0 .. P-1]
 * added to its parameters in the Jacobian column order (kinematics.h), each
 * value + delta rounded once. Not validated beyond the shape (a model init
 * does that): AACMM_ERR_RANGE for an invalid shape, AACMM_ERR_NULL for NULL,
 * else AACMM_OK. Cost: P additions.
 */
aacmm_status_t aacmm_arm_perturb_f64(const aacmm_arm_f64_t *nominal, const double *delta,
                                     aacmm_arm_f64_t *out);

/*
 * Probe points of an arm whose parameters are nominal + delta, for n_trials
 * parameter draws and n_poses poses: for trial t the model is built from
 * nominal + delta[t*P .. t*P + P-1] (aacmm_arm_perturb_f64; P the nominal
 * shape's parameter count, the Jacobian column order) and
 * p_mm[(t*n_poses + k)*3 + r] receives the point of pose k (theta_rad[k*N ..
 * k*N + N-1]). Stops at the first trial whose perturbed parameters are
 * invalid (AACMM_ERR_RANGE / AACMM_ERR_NOT_FINITE, as aacmm_model_init_arm_f64)
 * or the first invalid pose; *done (if not NULL) receives the number of
 * trials fully written (n_trials on success). AACMM_ERR_RANGE for an invalid
 * nominal shape; AACMM_ERR_NULL for NULL pointers (theta_rad, delta, p_mm
 * may be NULL only when there is nothing to compute). Cost: n_trials * (N + B
 * sine/cosine pairs + n_poses point evaluations).
 */
aacmm_status_t aacmm_perturbed_points_f64(const aacmm_arm_f64_t *nominal, size_t n_trials,
                                          const double *delta, size_t n_poses,
                                          const double *theta_rad, double *p_mm, size_t *done);

/*
 * Joint angles in rad for n poses of raw readings reading_counts[n*N]
 * (aacmm_arm_encoders_to_angles_f64 pose by pose, written to
 * theta_rad[n*N]; N = encoders->joints). Stops at the first invalid pose with
 * its error (AACMM_ERR_RANGE for a reading >= counts_per_rev or invalid
 * encoders); *done (if not NULL) receives the number of poses written.
 * AACMM_ERR_NULL for NULL pointers (arrays may be NULL when n = 0).
 * Cost: n times the single-pose cost.
 */
aacmm_status_t aacmm_counts_to_angles_f64(const aacmm_arm_encoders_t *encoders, size_t n,
                                          const uint32_t *reading_counts, double *theta_rad,
                                          size_t *done);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_ANALYSIS_H */
