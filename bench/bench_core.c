/*
 * Kinematics core benchmark: ns per pose on one core, one JSON object per
 * line. Each figure is the best of 5 runs of at least 0.2 s over a working set
 * of 1024 random poses (the outputs stay in cache, as in a Monte Carlo loop).
 *
 * First the per-pose core pose after pose (core.*: the scalar kernel, built
 * with this machine's -march as before issue 17), then every batch kernel
 * across SIMD lanes this CPU runs (core.simd.*, aacmm/simd.h; Jacobians
 * row-major and tiled) with its ratio to the scalar figure of the same run,
 * then large outputs (10^6 poses, far
 * beyond the caches): bytes written per second beside this machine's memory
 * write bandwidth (a plain memset of a buffer as large).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"

#define NPOSE 1024
#define NBIG 1000000
#define PI 3.14159265358979323846

static double th64[NPOSE * 6], p64[NPOSE * 3], j64[NPOSE * AACMM_JAC_SIZE];
static float th32[NPOSE * 6], p32[NPOSE * 3], j32[NPOSE * AACMM_JAC_SIZE];
/* Tiled Jacobians (aacmm/simd.h), 64-byte aligned: an entry of a tile's poses
 * is one cache line. */
static double jt64[AACMM_SIMD_TILED_SIZE(NPOSE, AACMM_SIMD_TILE_F64) + 1] __attribute__((aligned(64)));
static float jt32[AACMM_SIMD_TILED_SIZE(NPOSE, AACMM_SIMD_TILE_F32)] __attribute__((aligned(64)));
static uint32_t counts[NPOSE * 6];
static double sums_abs[AACMM_JAC_SIZE], sums_sq[AACMM_JAC_SIZE];
static volatile double sink;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU time of this process: on a machine shared with other jobs the wall
 * figures include waiting for a core; the CPU figures do not (but still
 * include a busy sibling hyperthread). */
static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double last_cpu_ns; /* CPU ns per pose of the last measure_ns() */

typedef void (*bench_fn)(void);

static aacmm_model_f64_t m64;
static aacmm_model_f32_t m32;
static aacmm_encoder_config_t enc;
static aacmm_kernel_t kern;

static void run_point_f64(void) { aacmm_batch_angles_f64(&m64, NPOSE, th64, p64, NULL, NULL); }
static void run_point_jac_f64(void) { aacmm_batch_angles_f64(&m64, NPOSE, th64, p64, j64, NULL); }
static void run_point_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, NULL, NULL); }
static void run_point_jac_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, j32, NULL); }
static void run_counts_jac_f64(void)
{
    aacmm_batch_counts_f64(&m64, &enc, NPOSE, counts, p64, j64, NULL);
}
static void run_sums_f64(void)
{
    aacmm_abs_jacobian_sums_f64(&m64, NPOSE, th64, sums_abs, sums_sq, NULL);
}
static void run_simd_point_f64(void)
{
    aacmm_simd_batch_angles_f64(kern, &m64, NPOSE, th64, p64, NULL, NULL);
}
static void run_simd_point_jac_f64(void)
{
    aacmm_simd_batch_angles_f64(kern, &m64, NPOSE, th64, p64, j64, NULL);
}
static void run_simd_point_jac_f32(void)
{
    aacmm_simd_batch_angles_f32(kern, &m32, NPOSE, th32, p32, j32, NULL);
}
static void run_simd_tiled_f64(void)
{
    aacmm_simd_batch_angles_tiled_f64(kern, &m64, NPOSE, th64, p64, jt64, NULL);
}
static void run_simd_tiled_f64_unaligned(void) /* 8 bytes past a line: every store spans two */
{
    aacmm_simd_batch_angles_tiled_f64(kern, &m64, NPOSE, th64, p64, jt64 + 1, NULL);
}
static void run_simd_tiled_f32(void)
{
    aacmm_simd_batch_angles_tiled_f32(kern, &m32, NPOSE, th32, p32, jt32, NULL);
}
static void run_simd_sums_f64(void)
{
    aacmm_simd_abs_jacobian_sums_f64(kern, &m64, NPOSE, th64, sums_abs, sums_sq, NULL);
}

/* Best ns per pose of fn over 5 runs of >= 0.2 s (wall; the CPU time of the
 * same runs, best of 5, in last_cpu_ns). */
static double measure_ns(bench_fn fn)
{
    double best = 1e30, best_cpu = 1e30;
    int rep;
    for (rep = 0; rep < 5; rep++) {
        long iters = 0;
        double t0 = now_s(), c0 = cpu_s(), t1;
        do {
            fn();
            iters++;
            t1 = now_s();
        } while (t1 - t0 < 0.2);
        if ((t1 - t0) / (double)iters < best) {
            best = (t1 - t0) / (double)iters;
        }
        if ((cpu_s() - c0) / (double)iters < best_cpu) {
            best_cpu = (cpu_s() - c0) / (double)iters;
        }
    }
    last_cpu_ns = best_cpu * 1e9 / NPOSE;
    sink = p64[0] + (double)p32[0] + j64[5] + (double)j32[5] + sums_abs[3] + jt64[7] +
           (double)jt32[7];
    return best * 1e9 / NPOSE;
}

static double measure(const char *name, const char *what, bench_fn fn)
{
    double ns = measure_ns(fn);
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"kernel\": \"scalar\", \"ns_per_pose\": %.2f, "
           "\"cpu_ns_per_pose\": %.2f, \"poses_per_s\": %.0f, \"threads\": 1}\n",
           name, what, ns, last_cpu_ns, 1e9 / ns);
    return ns;
}

static void measure_simd(const char *name, const char *what, bench_fn fn, double scalar_ns,
                         double target_ns, int single)
{
    double ns = measure_ns(fn);
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"kernel\": \"%s\", \"lanes\": %u, "
           "\"ns_per_pose\": %.2f, \"cpu_ns_per_pose\": %.2f, \"poses_per_s\": %.0f, "
           "\"scalar_ns_per_pose\": %.2f, \"speedup_vs_scalar\": %.2f, ",
           name, what, aacmm_kernel_name(kern), aacmm_kernel_lanes(kern, single), ns, last_cpu_ns,
           1e9 / ns, scalar_ns, scalar_ns / ns);
    if (target_ns > 0.0) {
        printf("\"target_ns_per_pose\": %.0f, ", target_ns);
    }
    printf("\"threads\": 1}\n");
}

/* Large outputs: 10^6 poses of point + Jacobian (624 MB) with the best
 * kernel, Jacobians row-major or tiled, and a memset of a buffer as large (the
 * write bandwidth the machine gives a single core). */
static void large_output(int tiled)
{
    const size_t jac_doubles = tiled ? AACMM_SIMD_TILED_SIZE((size_t)NBIG, AACMM_SIMD_TILE_F64)
                                     : (size_t)NBIG * AACMM_JAC_SIZE;
    const size_t out_doubles = (size_t)NBIG * 3u + jac_doubles;
    double *th = malloc((size_t)NBIG * 6u * sizeof(double));
    double *out = malloc(out_doubles * sizeof(double));
    double best_k = 1e30, best_m = 1e30, bytes;
    const char *name = tiled ? "core.simd.large_output_tiled" : "core.simd.large_output";
    int rep;
    size_t i;
    if (th == NULL || out == NULL) {
        free(th);
        free(out);
        printf("{\"bench\": \"%s\", \"error\": \"out of memory\"}\n", name);
        return;
    }
    for (i = 0; i < (size_t)NBIG * 6u; i++) {
        th[i] = th64[i % (NPOSE * 6)];
    }
    memset(out, 0, out_doubles * sizeof(double)); /* fault the pages in first */
    for (rep = 0; rep < 3; rep++) {
        double t0 = now_s(), t;
        if (tiled) {
            aacmm_simd_batch_angles_tiled_f64(kern, &m64, NBIG, th, out, out + (size_t)NBIG * 3u,
                                              NULL);
        } else {
            aacmm_simd_batch_angles_f64(kern, &m64, NBIG, th, out, out + (size_t)NBIG * 3u, NULL);
        }
        t = now_s() - t0;
        best_k = t < best_k ? t : best_k;
        t0 = now_s();
        memset(out, rep, out_doubles * sizeof(double));
        t = now_s() - t0;
        best_m = t < best_m ? t : best_m;
    }
    sink = out[12345];
    bytes = (double)out_doubles * (double)sizeof(double);
    printf("{\"bench\": \"%s\", \"what\": \"10^6 poses point + Jacobian, double, %s, "
           "output far beyond the caches\", \"kernel\": \"%s\", \"poses\": %d, \"bytes\": %.0f, "
           "\"ns_per_pose\": %.2f, \"bytes_written_per_s\": %.3e, \"memset_bytes_per_s\": %.3e, "
           "\"fraction_of_memset\": %.2f, \"threads\": 1}\n",
           name, tiled ? "Jacobians tiled" : "Jacobians row-major", aacmm_kernel_name(kern), NBIG,
           bytes, best_k * 1e9 / NBIG, bytes / best_k, bytes / best_m, best_m / best_k);
    free(th);
    free(out);
}

int main(void)
{
    aacmm_params_f64_t p;
    aacmm_params_f32_t pf;
    uint64_t s = UINT64_C(0x243F6A8885A308D3);
    double sc_point, sc_jac, sc_jac32, sc_sums;
    int i, k;
    aacmm_params_default_f64(&p);
    aacmm_params_default_f32(&pf);
    aacmm_model_init_f64(&m64, &p);
    aacmm_model_init_f32(&m32, &pf);
    aacmm_encoder_default(&enc);
    for (i = 0; i < NPOSE * 6; i++) {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        counts[i] = (uint32_t)((s * UINT64_C(2685821657736338717)) >> 32);
        th64[i] = -PI + 2.0 * PI * (double)counts[i] * 0x1p-32;
        th32[i] = (float)th64[i];
    }
    sc_point = measure("core.point_f64", "probe point, double", run_point_f64);
    sc_jac = measure("core.point_jacobian_f64", "probe point + 3x25 Jacobian, double",
                     run_point_jac_f64);
    measure("core.point_f32", "probe point, single", run_point_f32);
    sc_jac32 = measure("core.point_jacobian_f32", "probe point + 3x25 Jacobian, single",
                       run_point_jac_f32);
    measure("core.counts_point_jacobian_f64", "32-bit counts -> angles -> point + Jacobian, double",
            run_counts_jac_f64);
    sc_sums = measure("core.abs_jacobian_sums_f64",
                      "fused |J| and J^2 sums (Monte Carlo accumulation), double", run_sums_f64);
    for (k = 1; k < AACMM_KERNEL_COUNT; k++) {
        kern = (aacmm_kernel_t)k;
        if (!aacmm_kernel_available(kern)) {
            printf("{\"bench\": \"core.simd\", \"kernel\": \"%s\", \"available\": false}\n",
                   aacmm_kernel_name(kern));
            continue;
        }
        measure_simd("core.simd.point_f64", "batch probe point, double", run_simd_point_f64,
                     sc_point, 0.0, 0);
        measure_simd("core.simd.point_jacobian_f64", "batch probe point + 3x25 Jacobian, double",
                     run_simd_point_jac_f64, sc_jac, 25.0, 0);
        measure_simd("core.simd.point_jacobian_f32", "batch probe point + 3x25 Jacobian, single",
                     run_simd_point_jac_f32, sc_jac32, 15.0, 1);
        measure_simd("core.simd.point_jacobian_tiled_f64",
                     "batch probe point + 3x25 Jacobian, double, Jacobians in tiles of 8 poses",
                     run_simd_tiled_f64, sc_jac, 25.0, 0);
        measure_simd("core.simd.point_jacobian_tiled_f64_unaligned",
                     "the same, output 8 bytes past a 64-byte boundary", run_simd_tiled_f64_unaligned,
                     sc_jac, 25.0, 0);
        measure_simd("core.simd.point_jacobian_tiled_f32",
                     "batch probe point + 3x25 Jacobian, single, Jacobians in tiles of 16 poses",
                     run_simd_tiled_f32, sc_jac32, 15.0, 1);
        measure_simd("core.simd.abs_jacobian_sums_f64",
                     "batch fused |J| and J^2 sums, double", run_simd_sums_f64, sc_sums, 25.0, 0);
    }
    kern = aacmm_kernel_best();
    large_output(0);
    large_output(1);
    return 0;
}
