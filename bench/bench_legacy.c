/*
 * The core of commit aa8b712 (the last before the general arm model of issue
 * 26) inside the benchmark, for side-by-side figures in one process: this
 * file is compiled against that commit's headers (mk/core.mk extracts its
 * firmware/ with git archive into build/core/legacy/), linked with its
 * sources, and every aacmm_ symbol of the result is renamed legacy_aacmm_
 * (objcopy --redefine-syms), so the old and today's core live side by side.
 * bench_core.c calls only these legacy_bench_* entry points (plain types:
 * it cannot include the old headers). Not part of any product.
 */
#include <stddef.h>
#include <stdint.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "bench_legacy.h"

static aacmm_model_f64_t m64;
static aacmm_model_f32_t m32;
static aacmm_encoder_config_t enc;

void legacy_bench_init(void)
{
    aacmm_params_f64_t p;
    aacmm_params_f32_t pf;
    (void)aacmm_params_default_f64(&p);
    (void)aacmm_params_default_f32(&pf);
    (void)aacmm_model_init_f64(&m64, &p);
    (void)aacmm_model_init_f32(&m32, &pf);
    (void)aacmm_encoder_default(&enc);
}

int legacy_bench_angles_f64(int kernel, size_t n, const double *th, double *p, double *j)
{
    if (kernel < 0) {
        return (int)aacmm_batch_angles_f64(&m64, n, th, p, j, NULL);
    }
    return (int)aacmm_simd_batch_angles_f64((aacmm_kernel_t)kernel, &m64, n, th, p, j, NULL);
}

int legacy_bench_angles_f32(int kernel, size_t n, const float *th, float *p, float *j)
{
    if (kernel < 0) {
        return (int)aacmm_batch_angles_f32(&m32, n, th, p, j, NULL);
    }
    return (int)aacmm_simd_batch_angles_f32((aacmm_kernel_t)kernel, &m32, n, th, p, j, NULL);
}

int legacy_bench_tiled_f64(int kernel, size_t n, const double *th, double *p, double *jt)
{
    return (int)aacmm_simd_batch_angles_tiled_f64((aacmm_kernel_t)kernel, &m64, n, th, p, jt,
                                                  NULL);
}

int legacy_bench_tiled_f32(int kernel, size_t n, const float *th, float *p, float *jt)
{
    return (int)aacmm_simd_batch_angles_tiled_f32((aacmm_kernel_t)kernel, &m32, n, th, p, jt,
                                                  NULL);
}

int legacy_bench_sums_f64(int kernel, size_t n, const double *th, double *s, double *q)
{
    if (kernel < 0) {
        return (int)aacmm_abs_jacobian_sums_f64(&m64, n, th, s, q, NULL);
    }
    return (int)aacmm_simd_abs_jacobian_sums_f64((aacmm_kernel_t)kernel, &m64, n, th, s, q, NULL);
}

int legacy_bench_counts_f64(size_t n, const uint32_t *counts, double *p, double *j)
{
    return (int)aacmm_batch_counts_f64(&m64, &enc, n, counts, p, j, NULL);
}
