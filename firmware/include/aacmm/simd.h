/*
 * aacmm batch kernels across SIMD lanes, with the instruction set chosen at
 * run time: many poses at once for host analysis (Monte Carlo, uncertainty,
 * calibration). Host only; the firmware images use the per-pose core
 * (kinematics.h).
 *
 * One kernel source (firmware/src/simd/simd_impl.h, GNU C vector extensions)
 * is compiled for several instruction sets inside one object, each under its
 * own target attribute, so the object itself needs no more than the
 * baseline of its architecture (x86-64: SSE2; arm64: NEON):
 *
 *   kernel               lanes (double / float)  FMA  needs
 *   AACMM_KERNEL_SCALAR  1 / 1                   no   nothing: the per-pose core
 *   AACMM_KERNEL_VEC128  2 / 4                   no   a GNU C compiler (SSE2 on x86-64, NEON on arm64)
 *   AACMM_KERNEL_AVX2    4 / 8                   yes  x86 with AVX2 and FMA
 *   AACMM_KERNEL_AVX512  8 / 16                  yes  x86 with AVX-512F
 *
 * The caller picks the kernel (aacmm_kernel_best(), or its own choice, e.g.
 * from an environment variable) and passes it to every call: no global
 * state, every function is reentrant and disjoint slices of a batch may run
 * on several threads at once.
 *
 * Results: each lane runs the per-pose core's operations in the same order.
 * The kernels with FMA fuse a * b + c at the same few places (the sine and
 * cosine polynomials and the Jacobian's cross products: one rounding instead
 * of two; never in the chain of frames, where a difference would grow along
 * the arm), so they agree bit for bit with each other and within the core's
 * own rounding error with the scalar kernel (points within 1e-12 mm over 10^6
 * poses, tested; docs/kinematics.md); the kernels without FMA agree bit for
 * bit with the scalar kernel. The error behaviour is the per-pose batch's:
 * validation, the first bad pose stops the batch, *done.
 */
#ifndef AACMM_SIMD_H
#define AACMM_SIMD_H

#include <stddef.h>

#include "aacmm/kinematics.h"
#include "aacmm/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    AACMM_KERNEL_SCALAR = 0, /* the per-pose core, pose after pose */
    AACMM_KERNEL_VEC128 = 1, /* 128-bit vectors: SSE2 (x86-64) or NEON (arm64) */
    AACMM_KERNEL_AVX2 = 2,   /* 256-bit AVX2 + FMA */
    AACMM_KERNEL_AVX512 = 3  /* 512-bit AVX-512F (+ FMA) */
} aacmm_kernel_t;

#define AACMM_KERNEL_COUNT 4

/*
 * 1 if the kernel is compiled into this build and the running CPU (and its
 * operating system) supports its instructions, else 0 (also for values
 * outside the enum). The scalar kernel is always available. Cost: O(1).
 */
int aacmm_kernel_available(aacmm_kernel_t kernel);

/* The widest available kernel. Cost: O(1). */
aacmm_kernel_t aacmm_kernel_best(void);

/* "scalar", "vec128", "avx2", "avx512"; "unknown" for other values. */
const char *aacmm_kernel_name(aacmm_kernel_t kernel);

/* 1 for the kernels that fuse multiply-adds (avx2, avx512), else 0. Cost: O(1). */
int aacmm_kernel_fused(aacmm_kernel_t kernel);

/* Poses per vector: lanes of the kernel in double (single = 0) or single
 * precision (single = 1); 0 for values outside the enum. */
unsigned aacmm_kernel_lanes(aacmm_kernel_t kernel, int single);

/*
 * aacmm_batch_angles_f64 / _f32 (kinematics.h) with the given kernel, for a
 * model of any shape: n poses theta_rad[n*N] (rad) in, n points p_mm[n*3]
 * and, if jac is not NULL, n Jacobians jac[n*3P] (pose after pose,
 * row-major; N = model->arm.shape.joints, P = model->n_params; the paper's
 * arm: 6 and 25) out. Validation, the stop at the first invalid pose
 * (AACMM_ERR_RANGE, AACMM_ERR_NOT_FINITE) and *done as there.
 * AACMM_ERR_UNSUPPORTED if the kernel is not available.
 * Cost: per pose, the per-pose cost divided by about the number of lanes
 * (the paper's shape runs kernels with its constants compiled in; other
 * shapes the general kernels: docs/kinematics.md has both per N).
 */
aacmm_status_t aacmm_simd_batch_angles_f64(aacmm_kernel_t kernel, const aacmm_model_f64_t *model,
                                           size_t n, const double *theta_rad, double *p_mm,
                                           double *jac, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_f32(aacmm_kernel_t kernel, const aacmm_model_f32_t *model,
                                           size_t n, const float *theta_rad, float *p_mm,
                                           float *jac, size_t *done);

/*
 * Tiled Jacobians: the same points and Jacobians, with the Jacobians in tiles
 * of AACMM_SIMD_TILE_F64 (8) or AACMM_SIMD_TILE_F32 (16) consecutive poses,
 * entry-major inside a tile: entry e (= row * P + column) of pose l is
 *     jac_tiled[(l / T) * 3P * T + e * T + l % T]      (T the tile size),
 * so an entry of a tile's poses is 64 contiguous bytes (one cache line when
 * jac_tiled is 64-byte aligned), as an array jac_tiled[tiles][3][P][T]. The
 * batch kernels then store each entry vector whole, without regrouping lanes
 * into pose rows: the layout for batch consumers that work entry by entry
 * (normal equations, sums over poses); the row-major layout above costs the
 * regrouping (docs/kinematics.md, "Speed").
 *
 * jac_tiled must hold AACMM_SIMD_TILED_ENTRIES(n, T, P) values (whole tiles;
 * AACMM_SIMD_TILED_SIZE(n, T) for the paper's arm; not NULL when n > 0);
 * p_mm, validation, the stop at the first invalid pose and *done as
 * aacmm_simd_batch_angles_*. The lanes of the last tile past pose n-1 are set
 * to pose n-1's entries (a tile holds no uninitialised values); after an
 * invalid pose, the entries from *done on are unspecified. Every kernel gives
 * the same values as aacmm_simd_batch_angles_* with that kernel, bit for bit.
 * Alignment: any (64 bytes runs fastest). Cost: per pose, below that of the
 * row-major call with the same kernel (scalar: the same plus the copy).
 */
#define AACMM_SIMD_TILE_F64 8
#define AACMM_SIMD_TILE_F32 16
#define AACMM_SIMD_TILED_ENTRIES(n, tile, params)                                                  \
    ((((n) + (tile) - 1u) / (tile)) * (tile) * AACMM_JAC_ROWS * (params))
#define AACMM_SIMD_TILED_SIZE(n, tile) AACMM_SIMD_TILED_ENTRIES(n, tile, AACMM_JAC_COLS)
aacmm_status_t aacmm_simd_batch_angles_tiled_f64(aacmm_kernel_t kernel,
                                                 const aacmm_model_f64_t *model, size_t n,
                                                 const double *theta_rad, double *p_mm,
                                                 double *jac_tiled, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_tiled_f32(aacmm_kernel_t kernel,
                                                 const aacmm_model_f32_t *model, size_t n,
                                                 const float *theta_rad, float *p_mm,
                                                 float *jac_tiled, size_t *done);

/*
 * aacmm_abs_jacobian_sums_f64 (analysis.h) with the given kernel: adds the
 * sums over n poses of |J| and J^2 (3 P entries each) to abs_sum and sq_sum.
 * The sums are accumulated per lane and added up at the end, so the rounding
 * of the sums depends on the kernel (not on anything else). Errors and *done
 * as there; AACMM_ERR_UNSUPPORTED if the kernel is not available.
 */
aacmm_status_t aacmm_simd_abs_jacobian_sums_f64(aacmm_kernel_t kernel,
                                                const aacmm_model_f64_t *model, size_t n,
                                                const double *theta_rad, double *abs_sum,
                                                double *sq_sum, size_t *done);

/*
 * aacmm_abs_jacobian_sums_scaled_f64 (analysis.h) with the given kernel: the
 * sums on the poses unit[k*N + i] * scale[i] + offset[i], formed a vector
 * group at a time (the product rounded, then the sum), equal bit for bit to
 * aacmm_simd_abs_jacobian_sums_f64 on poses formed first. scale and offset
 * (N values each) both NULL: no scaling. Errors and *done as there.
 */
aacmm_status_t aacmm_simd_abs_jacobian_sums_scaled_f64(aacmm_kernel_t kernel,
                                                       const aacmm_model_f64_t *model, size_t n,
                                                       const double *unit, const double *scale,
                                                       const double *offset, double *abs_sum,
                                                       double *sq_sum, size_t *done);

/*
 * aacmm_perturbed_points_f64 (analysis.h) with the given kernel: for each of
 * n_trials parameter draws (nominal + delta[t*P ..], Jacobian column order)
 * one model, evaluated at the n_poses poses across the lanes; p_mm[(t*n_poses
 * + k)*3 + r]. Errors and *done (trials written) as there;
 * AACMM_ERR_UNSUPPORTED if the kernel is not available.
 */
aacmm_status_t aacmm_simd_perturbed_points_f64(aacmm_kernel_t kernel,
                                               const aacmm_arm_f64_t *nominal, size_t n_trials,
                                               const double *delta, size_t n_poses,
                                               const double *theta_rad, double *p_mm,
                                               size_t *done);

/*
 * aacmm_batch_angles_em_* (kinematics.h: the error model's corrected angles,
 * the extended 3 x (P + E) Jacobians, jac[n 3 (P + E)]) with the given
 * kernel. One difference: temp_c holds ONE set of N link temperatures for
 * the whole batch (NULL: the reference temperatures), since the kernels run
 * one model (scaled once, aacmm_model_at_temperature_*). em NULL with temp_c
 * NULL: exactly aacmm_simd_batch_angles_* (em NULL with temperatures:
 * AACMM_ERR_NULL). Validation, the stop at the first invalid pose (the poses
 * before it written) and *done as there. Every kernel gives the values of
 * aacmm_batch_angles_em_* (per pose temperatures all equal to temp_c) run
 * through that kernel: the error model's own steps are the per-pose core's
 * source, bit for bit. Cost: the kernel's + per pose the correction (a
 * sine/cosine pair and 4 K flops per corrected joint) and, with a Jacobian,
 * one copy of 3 P values and the extension (6 K multiplies per corrected
 * joint), scalar.
 */
aacmm_status_t aacmm_simd_batch_angles_em_f64(aacmm_kernel_t kernel,
                                              const aacmm_model_f64_t *model,
                                              const aacmm_errmodel_f64_t *em, size_t n,
                                              const double *theta_rad, const double *temp_c,
                                              double *p_mm, double *jac, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_em_f32(aacmm_kernel_t kernel,
                                              const aacmm_model_f32_t *model,
                                              const aacmm_errmodel_f32_t *em, size_t n,
                                              const float *theta_rad, const float *temp_c,
                                              float *p_mm, float *jac, size_t *done);

#ifdef __cplusplus
}
#endif

#endif /* AACMM_SIMD_H */
