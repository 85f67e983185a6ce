/*
 * Entry points into the core of commit aa8b712 built into the benchmark
 * (bench_legacy.c): the paper's arm, Table 1, in both precisions; kernel -1
 * is the per-pose core's batch, 0.. an aacmm_kernel_t. Each returns the
 * aacmm_status_t of the call. Plain types only: the old headers are not in
 * scope of bench_core.c.
 */
#ifndef AACMM_BENCH_LEGACY_H
#define AACMM_BENCH_LEGACY_H

#include <stddef.h>
#include <stdint.h>

void legacy_bench_init(void);
int legacy_bench_angles_f64(int kernel, size_t n, const double *th, double *p, double *j);
int legacy_bench_angles_f32(int kernel, size_t n, const float *th, float *p, float *j);
int legacy_bench_tiled_f64(int kernel, size_t n, const double *th, double *p, double *jt);
int legacy_bench_tiled_f32(int kernel, size_t n, const float *th, float *p, float *jt);
int legacy_bench_sums_f64(int kernel, size_t n, const double *th, double *s, double *q);
int legacy_bench_counts_f64(size_t n, const uint32_t *counts, double *p, double *j);

#endif
