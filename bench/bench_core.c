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
 *
 * Issue 26: with BENCH_LEGACY (mk/core.mk builds the core of commit aa8b712
 * into this binary, bench_legacy.c), every figure of the paper's arm is also
 * measured on that core, its runs alternating with today's in the same
 * process (core.legacy.*: both figures, today's over the old, and whether
 * it is within 10 %, judged on the process's CPU time, which excludes the
 * waits for a core of a shared machine); then ns per pose of the general
 * model for N = 5, 6, 7
 * joints (core.arm.*), every kernel, both precisions, both layouts.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#if BENCH_LEGACY
#include "bench_legacy.h"
#endif

#define NPOSE 1024
#define NBIG 1000000
#define PI 3.14159265358979323846

static double th64[NPOSE * AACMM_JOINTS_MAX], p64[NPOSE * 3], j64[NPOSE * AACMM_JAC_SIZE_MAX];
static float th32[NPOSE * AACMM_JOINTS_MAX], p32[NPOSE * 3], j32[NPOSE * AACMM_JAC_SIZE_MAX];
/* Tiled Jacobians (aacmm/simd.h), 64-byte aligned: an entry of a tile's poses
 * is one cache line. */
static double jt64[AACMM_SIMD_TILED_ENTRIES(NPOSE, AACMM_SIMD_TILE_F64, AACMM_PARAMS_MAX) + 1]
    __attribute__((aligned(64)));
static float jt32[AACMM_SIMD_TILED_ENTRIES(NPOSE, AACMM_SIMD_TILE_F32, AACMM_PARAMS_MAX)]
    __attribute__((aligned(64)));
static uint32_t counts[NPOSE * 6];
static aacmm_arm_encoders_t encs;
static double sums_abs[AACMM_JAC_SIZE_MAX], sums_sq[AACMM_JAC_SIZE_MAX];
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
    aacmm_batch_counts_f64(&m64, &encs, NPOSE, counts, p64, j64, NULL);
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

/* Best ns per pose of fn over `runs` runs of >= 0.2 s (wall; the CPU time of
 * the same runs, best of them, in last_cpu_ns). */
static double measure_runs(bench_fn fn, int runs)
{
    double best = 1e30, best_cpu = 1e30;
    int rep;
    for (rep = 0; rep < runs; rep++) {
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

static double measure_ns(bench_fn fn)
{
    return measure_runs(fn, 5);
}

/* The old core's run of the same figure (NULL: none), measured alternately
 * with today's: run after run of each, best of 5 each, so both see the same
 * load. */
static bench_fn legacy_fn;

#if BENCH_LEGACY
#define LEGACY_COMMIT "aa8b712"
#define LEGACY_TARGET 1.10 /* today's paper's arm within 10 % of the old core */
static double legacy_ns, legacy_cpu_ns;

static double measure_ns_vs_legacy(bench_fn fn)
{
    double best_new = 1e30, best_old = 1e30, cpu_new = 1e30, cpu_old = 1e30, ns;
    int rep;
    if (legacy_fn == NULL) {
        return measure_ns(fn);
    }
    for (rep = 0; rep < 5; rep++) {
        ns = measure_runs(fn, 1);
        best_new = ns < best_new ? ns : best_new;
        cpu_new = last_cpu_ns < cpu_new ? last_cpu_ns : cpu_new;
        ns = measure_runs(legacy_fn, 1);
        best_old = ns < best_old ? ns : best_old;
        cpu_old = last_cpu_ns < cpu_old ? last_cpu_ns : cpu_old;
    }
    legacy_ns = best_old;
    legacy_cpu_ns = cpu_old;
    last_cpu_ns = cpu_new;
    return best_new;
}

static void print_legacy(const char *name, const char *what, const char *kernel, double ns,
                         double cpu_ns)
{
    if (legacy_fn == NULL) {
        return;
    }
    /* judged on the CPU time: on a loaded machine the wall time includes the
     * waits for a core, which do not alternate as evenly as the runs do */
    printf("{\"bench\": \"core.legacy.%s\", \"what\": \"%s: today's core against commit %s's, "
           "runs alternating in one process\", \"kernel\": \"%s\", \"commit\": \"%s\", "
           "\"ns_per_pose\": %.2f, \"ns_per_pose_old\": %.2f, \"cpu_ns_per_pose\": %.2f, "
           "\"cpu_ns_per_pose_old\": %.2f, \"new_over_old\": %.3f, \"new_over_old_wall\": %.3f, "
           "\"target_max\": %.2f, \"within_target\": %s, \"threads\": 1}\n",
           name, what, LEGACY_COMMIT, kernel, LEGACY_COMMIT, ns, legacy_ns, cpu_ns, legacy_cpu_ns,
           cpu_ns / legacy_cpu_ns, ns / legacy_ns, LEGACY_TARGET,
           cpu_ns / legacy_cpu_ns <= LEGACY_TARGET ? "true" : "false");
}
#else
static double measure_ns_vs_legacy(bench_fn fn)
{
    return measure_ns(fn);
}

static void print_legacy(const char *name, const char *what, const char *kernel, double ns,
                         double cpu_ns)
{
    (void)name;
    (void)what;
    (void)kernel;
    (void)ns;
    (void)cpu_ns;
}
#endif

static double measure(const char *name, const char *what, bench_fn fn)
{
    double ns = measure_ns_vs_legacy(fn);
    const double cpu = last_cpu_ns;
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"kernel\": \"scalar\", \"ns_per_pose\": %.2f, "
           "\"cpu_ns_per_pose\": %.2f, \"poses_per_s\": %.0f, \"threads\": 1}\n",
           name, what, ns, cpu, 1e9 / ns);
    print_legacy(name + 5, what, "scalar", ns, cpu); /* name without "core." */
    return ns;
}

static void measure_simd(const char *name, const char *what, bench_fn fn, double scalar_ns,
                         double target_ns, int single)
{
    double ns = measure_ns_vs_legacy(fn);
    const double cpu = last_cpu_ns;
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"kernel\": \"%s\", \"lanes\": %u, "
           "\"ns_per_pose\": %.2f, \"cpu_ns_per_pose\": %.2f, \"poses_per_s\": %.0f, "
           "\"scalar_ns_per_pose\": %.2f, \"speedup_vs_scalar\": %.2f, ",
           name, what, aacmm_kernel_name(kern), aacmm_kernel_lanes(kern, single), ns, cpu, 1e9 / ns,
           scalar_ns, scalar_ns / ns);
    if (target_ns > 0.0) {
        printf("\"target_ns_per_pose\": %.0f, ", target_ns);
    }
    printf("\"threads\": 1}\n");
    print_legacy(name + 5, what, aacmm_kernel_name(kern), ns, cpu);
}

/* ---- the old core's runs (BENCH_LEGACY) ---- */
#if BENCH_LEGACY
static void old_point_f64(void) { legacy_bench_angles_f64(-1, NPOSE, th64, p64, NULL); }
static void old_point_jac_f64(void) { legacy_bench_angles_f64(-1, NPOSE, th64, p64, j64); }
static void old_point_f32(void) { legacy_bench_angles_f32(-1, NPOSE, th32, p32, NULL); }
static void old_point_jac_f32(void) { legacy_bench_angles_f32(-1, NPOSE, th32, p32, j32); }
static void old_counts_jac_f64(void) { legacy_bench_counts_f64(NPOSE, counts, p64, j64); }
static void old_sums_f64(void) { legacy_bench_sums_f64(-1, NPOSE, th64, sums_abs, sums_sq); }
static void old_simd_point_f64(void) { legacy_bench_angles_f64((int)kern, NPOSE, th64, p64, NULL); }
static void old_simd_point_jac_f64(void) { legacy_bench_angles_f64((int)kern, NPOSE, th64, p64, j64); }
static void old_simd_point_jac_f32(void) { legacy_bench_angles_f32((int)kern, NPOSE, th32, p32, j32); }
static void old_simd_tiled_f64(void) { legacy_bench_tiled_f64((int)kern, NPOSE, th64, p64, jt64); }
static void old_simd_tiled_f64_unaligned(void)
{
    legacy_bench_tiled_f64((int)kern, NPOSE, th64, p64, jt64 + 1);
}
static void old_simd_tiled_f32(void) { legacy_bench_tiled_f32((int)kern, NPOSE, th32, p32, jt32); }
static void old_simd_sums_f64(void) { legacy_bench_sums_f64((int)kern, NPOSE, th64, sums_abs, sums_sq); }
#define OLD(fn) (legacy_fn = (fn))
#else
#define OLD(fn) (legacy_fn = NULL)
#endif

/* ---- the general model for N = 5, 6, 7 (core.arm.*) ---- */

/* The arms of the per-N figures: 5 joints, modified DH with a beta at the
 * parallel hinges (the MicroScribe's layout); 6 joints, the paper's
 * geometry with a tip vector (so the general chain, not the paper's); 7
 * joints of commercial proportions, standard DH, a tip vector. */
static void bench_arm(int joints, aacmm_arm_f64_t *a, const char **shape)
{
    static const double pi2 = 1.5707963267948966;
    int i;
    memset(a, 0, sizeof *a);
    a->shape.joints = (uint8_t)joints;
    if (joints == 5) {
        static const double alpha[5] = {0.0, 1.5707963267948966, 0.001, 1.5707963267948966,
                                        -1.5707963267948966};
        static const double d[5] = {210.0, 0.0, 0.0, 260.0, 0.0};
        static const double aa[5] = {0.0, 24.0, 260.0, 0.0, 0.0};
        for (i = 0; i < 5; i++) {
            a->shape.convention[i] = AACMM_DH_MODIFIED;
            a->alpha_rad[i] = alpha[i];
            a->d_mm[i] = d[i];
            a->a_mm[i] = aa[i];
        }
        a->shape.beta[2] = 1;
        a->beta_rad[2] = 4e-4;
        a->shape.tip = AACMM_TIP_Z;
        a->tip_mm[2] = 95.0;
        *shape = "5 joints, modified DH, a beta on joint 3, tip l (P = 22)";
    } else if (joints == 6) {
        static const double d[6] = {300.0, 65.5, 792.7, 65.5, 883.2, 0.0};
        for (i = 0; i < 6; i++) {
            a->alpha_rad[i] = pi2;
            a->d_mm[i] = d[i];
        }
        a->shape.tip = AACMM_TIP_XYZ;
        a->tip_mm[0] = 5.0;
        a->tip_mm[1] = -3.0;
        a->tip_mm[2] = 183.5;
        *shape = "6 joints, the paper's geometry with a tip vector: the general chain (P = 27)";
    } else {
        static const double alpha[7] = {1.5707963267948966, -1.5707963267948966,
                                        1.5707963267948966, -1.5707963267948966,
                                        1.5707963267948966, -1.5707963267948966, 0.0};
        static const double d[7] = {180.0, 0.0, 1200.0, 0.0, 1000.0, 0.0, 150.0};
        static const double aa[7] = {0.0, 80.0, 0.0, 80.0, 0.0, 0.0, 0.0};
        for (i = 0; i < 7; i++) {
            a->alpha_rad[i] = alpha[i];
            a->d_mm[i] = d[i];
            a->a_mm[i] = aa[i];
        }
        a->shape.tip = AACMM_TIP_XYZ;
        a->tip_mm[0] = 12.0;
        a->tip_mm[1] = -5.0;
        a->tip_mm[2] = 110.0;
        *shape = "7 joints of commercial proportions, standard DH, tip vector (P = 31)";
    }
}

static aacmm_model_f64_t am64;
static aacmm_model_f32_t am32;
static void run_arm_jac_f64(void) { aacmm_simd_batch_angles_f64(kern, &am64, NPOSE, th64, p64, j64, NULL); }
static void run_arm_jac_f32(void) { aacmm_simd_batch_angles_f32(kern, &am32, NPOSE, th32, p32, j32, NULL); }
static void run_arm_tiled_f64(void)
{
    aacmm_simd_batch_angles_tiled_f64(kern, &am64, NPOSE, th64, p64, jt64, NULL);
}
static void run_arm_tiled_f32(void)
{
    aacmm_simd_batch_angles_tiled_f32(kern, &am32, NPOSE, th32, p32, jt32, NULL);
}
static void run_arm_point_f64(void) { aacmm_simd_batch_angles_f64(kern, &am64, NPOSE, th64, p64, NULL, NULL); }

static void arm_figures(void)
{
    static const struct {
        const char *what, *precision, *layout;
        bench_fn fn;
    } figs[] = {
        {"point only", "double", "none", run_arm_point_f64},
        {"point + Jacobian", "double", "row-major", run_arm_jac_f64},
        {"point + Jacobian", "double", "tiled", run_arm_tiled_f64},
        {"point + Jacobian", "single", "row-major", run_arm_jac_f32},
        {"point + Jacobian", "single", "tiled", run_arm_tiled_f32},
    };
    int joints, k;
    size_t f;
    for (joints = 5; joints <= 7; joints++) {
        aacmm_arm_f64_t a;
        aacmm_arm_f32_t af;
        const char *shape = "";
        int i;
        bench_arm(joints, &a, &shape);
        af.shape = a.shape;
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            af.theta_offset_rad[i] = (float)a.theta_offset_rad[i];
            af.alpha_rad[i] = (float)a.alpha_rad[i];
            af.d_mm[i] = (float)a.d_mm[i];
            af.a_mm[i] = (float)a.a_mm[i];
            af.beta_rad[i] = (float)a.beta_rad[i];
        }
        for (i = 0; i < 3; i++) {
            af.tip_mm[i] = (float)a.tip_mm[i];
        }
        if (aacmm_model_init_arm_f64(&am64, &a) != AACMM_OK ||
            aacmm_model_init_arm_f32(&am32, &af) != AACMM_OK) {
            printf("{\"bench\": \"core.arm\", \"joints\": %d, \"error\": \"model init\"}\n", joints);
            continue;
        }
        for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
            kern = (aacmm_kernel_t)k;
            if (!aacmm_kernel_available(kern)) {
                continue;
            }
            for (f = 0; f < sizeof figs / sizeof figs[0]; f++) {
                const int single = figs[f].precision[0] == 's';
                double ns;
                if (kern == AACMM_KERNEL_SCALAR && strcmp(figs[f].layout, "tiled") == 0) {
                    continue; /* the scalar kernel's tiled layout is its row-major plus a copy */
                }
                ns = measure_runs(figs[f].fn, 3);
                printf("{\"bench\": \"core.arm.%s_%s%s\", \"what\": \"batch %s, %s, %s, general "
                       "model\", \"joints\": %d, \"params\": %d, \"shape\": \"%s\", \"kernel\": "
                       "\"%s\", \"lanes\": %u, \"ns_per_pose\": %.2f, \"cpu_ns_per_pose\": %.2f, "
                       "\"threads\": 1}\n",
                       strcmp(figs[f].what, "point only") == 0 ? "point" : "point_jacobian",
                       single ? "f32" : "f64",
                       strcmp(figs[f].layout, "tiled") == 0 ? "_tiled" : "", figs[f].what,
                       figs[f].precision, figs[f].layout, joints, (int)am64.n_params, shape,
                       aacmm_kernel_name(kern), aacmm_kernel_lanes(kern, single), ns, last_cpu_ns);
            }
        }
    }
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
    aacmm_arm_encoders_from_config(&encs, &enc);
#if BENCH_LEGACY
    legacy_bench_init();
#else
    printf("{\"bench\": \"core.legacy\", \"skipped\": \"the benchmark was built without the core "
           "of commit aa8b712 (no git history here)\"}\n");
#endif
    for (i = 0; i < NPOSE * AACMM_JOINTS_MAX; i++) {
        uint32_t c;
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        c = (uint32_t)((s * UINT64_C(2685821657736338717)) >> 32);
        if (i < NPOSE * 6) {
            counts[i] = c;
        }
        th64[i] = -PI + 2.0 * PI * (double)c * 0x1p-32;
        th32[i] = (float)th64[i];
    }
#if BENCH_LEGACY
    {
        /* the two cores compute the same points and Jacobians (this build
         * contracts multiply-adds, -ffp-contract=fast, as each compilation
         * sees fit, so to rounding, not bit for bit: the tests compare the
         * bits in the build without contraction) */
        static double p_old[NPOSE * 3], j_old[NPOSE * AACMM_JAC_SIZE];
        double dp = 0.0, dj = 0.0;
        run_point_jac_f64();
        legacy_bench_angles_f64(-1, NPOSE, th64, p_old, j_old);
        for (i = 0; i < NPOSE * 3; i++) {
            dp = fmax(dp, fabs(p64[i] - p_old[i]));
        }
        for (i = 0; i < NPOSE * AACMM_JAC_SIZE; i++) {
            dj = fmax(dj, fabs(j64[i] - j_old[i]));
        }
        printf("{\"bench\": \"core.legacy.check\", \"what\": \"max |today - %s| over the "
               "poses, point + Jacobian, double\", \"point_mm\": %.3g, \"jacobian\": %.3g}\n",
               LEGACY_COMMIT, dp, dj);
    }
#endif
    OLD(old_point_f64);
    sc_point = measure("core.point_f64", "probe point, double", run_point_f64);
    OLD(old_point_jac_f64);
    sc_jac = measure("core.point_jacobian_f64", "probe point + 3x25 Jacobian, double",
                     run_point_jac_f64);
    OLD(old_point_f32);
    measure("core.point_f32", "probe point, single", run_point_f32);
    OLD(old_point_jac_f32);
    sc_jac32 = measure("core.point_jacobian_f32", "probe point + 3x25 Jacobian, single",
                       run_point_jac_f32);
    OLD(old_counts_jac_f64);
    measure("core.counts_point_jacobian_f64", "32-bit counts -> angles -> point + Jacobian, double",
            run_counts_jac_f64);
    OLD(old_sums_f64);
    sc_sums = measure("core.abs_jacobian_sums_f64",
                      "fused |J| and J^2 sums (Monte Carlo accumulation), double", run_sums_f64);
    for (k = 1; k < AACMM_KERNEL_COUNT; k++) {
        kern = (aacmm_kernel_t)k;
        if (!aacmm_kernel_available(kern)) {
            printf("{\"bench\": \"core.simd\", \"kernel\": \"%s\", \"available\": false}\n",
                   aacmm_kernel_name(kern));
            continue;
        }
        OLD(old_simd_point_f64);
        measure_simd("core.simd.point_f64", "batch probe point, double", run_simd_point_f64,
                     sc_point, 0.0, 0);
        OLD(old_simd_point_jac_f64);
        measure_simd("core.simd.point_jacobian_f64", "batch probe point + 3x25 Jacobian, double",
                     run_simd_point_jac_f64, sc_jac, 25.0, 0);
        OLD(old_simd_point_jac_f32);
        measure_simd("core.simd.point_jacobian_f32", "batch probe point + 3x25 Jacobian, single",
                     run_simd_point_jac_f32, sc_jac32, 15.0, 1);
        OLD(old_simd_tiled_f64);
        measure_simd("core.simd.point_jacobian_tiled_f64",
                     "batch probe point + 3x25 Jacobian, double, Jacobians in tiles of 8 poses",
                     run_simd_tiled_f64, sc_jac, 25.0, 0);
        OLD(old_simd_tiled_f64_unaligned);
        measure_simd("core.simd.point_jacobian_tiled_f64_unaligned",
                     "the same, output 8 bytes past a 64-byte boundary", run_simd_tiled_f64_unaligned,
                     sc_jac, 25.0, 0);
        OLD(old_simd_tiled_f32);
        measure_simd("core.simd.point_jacobian_tiled_f32",
                     "batch probe point + 3x25 Jacobian, single, Jacobians in tiles of 16 poses",
                     run_simd_tiled_f32, sc_jac32, 15.0, 1);
        OLD(old_simd_sums_f64);
        measure_simd("core.simd.abs_jacobian_sums_f64",
                     "batch fused |J| and J^2 sums, double", run_simd_sums_f64, sc_sums, 25.0, 0);
    }
    legacy_fn = NULL;
    arm_figures();
    kern = aacmm_kernel_best();
    large_output(0);
    large_output(1);
    return 0;
}
