/*
 * Kinematics core benchmark: ns per pose on one core, one JSON object per
 * line. Each figure is the best of 5 runs of at least 0.2 s over a working set
 * of 1024 random poses (the outputs stay in cache, as in a Monte Carlo loop).
 */
#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "aacmm/kinematics.h"

#define NPOSE 1024
#define PI 3.14159265358979323846

static double th64[NPOSE * 6], p64[NPOSE * 3], j64[NPOSE * AACMM_JAC_SIZE];
static float th32[NPOSE * 6], p32[NPOSE * 3], j32[NPOSE * AACMM_JAC_SIZE];
static uint32_t counts[NPOSE * 6];
static volatile double sink;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef void (*bench_fn)(void);

static aacmm_model_f64_t m64;
static aacmm_model_f32_t m32;
static aacmm_encoder_config_t enc;

static void run_point_f64(void) { aacmm_batch_angles_f64(&m64, NPOSE, th64, p64, NULL, NULL); }
static void run_point_jac_f64(void) { aacmm_batch_angles_f64(&m64, NPOSE, th64, p64, j64, NULL); }
static void run_point_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, NULL, NULL); }
static void run_point_jac_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, j32, NULL); }
static void run_counts_jac_f64(void)
{
    aacmm_batch_counts_f64(&m64, &enc, NPOSE, counts, p64, j64, NULL);
}

static void measure(const char *name, const char *what, bench_fn fn)
{
    double best = 1e30;
    int rep;
    for (rep = 0; rep < 5; rep++) {
        long iters = 0;
        double t0 = now_s(), t1;
        do {
            fn();
            iters++;
            t1 = now_s();
        } while (t1 - t0 < 0.2);
        if ((t1 - t0) / (double)iters < best) {
            best = (t1 - t0) / (double)iters;
        }
    }
    sink = p64[0] + (double)p32[0] + j64[5] + (double)j32[5];
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"ns_per_pose\": %.2f, \"poses_per_s\": %.0f, "
           "\"threads\": 1}\n",
           name, what, best * 1e9 / NPOSE, NPOSE / best);
}

int main(void)
{
    aacmm_params_f64_t p;
    aacmm_params_f32_t pf;
    uint64_t s = UINT64_C(0x243F6A8885A308D3);
    int i;
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
    measure("core.point_f64", "probe point, double", run_point_f64);
    measure("core.point_jacobian_f64", "probe point + 3x25 Jacobian, double", run_point_jac_f64);
    measure("core.point_f32", "probe point, single", run_point_f32);
    measure("core.point_jacobian_f32", "probe point + 3x25 Jacobian, single", run_point_jac_f32);
    measure("core.counts_point_jacobian_f64", "32-bit counts -> angles -> point + Jacobian, double",
            run_counts_jac_f64);
    return 0;
}
