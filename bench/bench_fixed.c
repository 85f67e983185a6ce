/*
 * Fixed-point kinematics benchmark, one JSON object per line (as
 * bench_core): host ns per pose for the integer path next to the f32 core on
 * the same poses. Each figure is the best of 5 runs of at least 0.2 s over a
 * working set of 1024 random poses.
 *
 * With arguments "--callgrind PATH N" it instead runs one batch of N poses
 * through PATH once, for bench/callgrind_count.sh to count instructions:
 *   PATH = f32         aacmm_batch_angles_f32, point + Jacobian from float rad
 *          q           aacmm_batch_bam_q, point + Jacobian from binary angles
 *          f32-counts  aacmm_batch_counts_f32, from 32-bit encoder counts
 *          q-counts    aacmm_batch_counts_q, from 32-bit encoder counts
 *          f32-point, q-point   point only
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"

#define NPOSE 1024
#define PI 3.14159265358979323846

static float th32[NPOSE * 6], p32[NPOSE * 3], j32[NPOSE * AACMM_JAC_SIZE];
static uint32_t bam[NPOSE * 6];
static int64_t pq[NPOSE * 3], jq[NPOSE * AACMM_JAC_SIZE];
static volatile double sink;

static aacmm_model_f32_t m32;
static aacmm_model_q_t mq;
static aacmm_encoder_config_t enc;
static aacmm_arm_encoders_t encs; /* the same, in the arm form of the batches */

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef void (*bench_fn)(void);

static void run_point_q(void) { aacmm_batch_bam_q(&mq, NPOSE, bam, pq, NULL, NULL); }
static void run_point_jac_q(void) { aacmm_batch_bam_q(&mq, NPOSE, bam, pq, jq, NULL); }
static void run_counts_jac_q(void) { aacmm_batch_counts_q(&mq, &encs, NPOSE, bam, pq, jq, NULL); }
static void run_point_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, NULL, NULL); }
static void run_point_jac_f32(void) { aacmm_batch_angles_f32(&m32, NPOSE, th32, p32, j32, NULL); }
static void run_counts_jac_f32(void)
{
    aacmm_batch_counts_f32(&m32, &encs, NPOSE, bam, p32, j32, NULL);
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
    sink = (double)pq[0] + (double)jq[5] + (double)p32[0] + (double)j32[5];
    printf("{\"bench\": \"%s\", \"what\": \"%s\", \"ns_per_pose\": %.2f, \"poses_per_s\": %.0f, "
           "\"threads\": 1}\n",
           name, what, best * 1e9 / NPOSE, NPOSE / best);
}

static void setup(void)
{
    aacmm_params_f32_t pf;
    aacmm_params_q_t q;
    uint64_t s = UINT64_C(0x243F6A8885A308D3);
    int i;
    aacmm_params_default_f32(&pf);
    aacmm_params_default_q(&q);
    aacmm_model_init_f32(&m32, &pf);
    aacmm_model_q_init(&mq, &q);
    aacmm_encoder_default(&enc);
    aacmm_arm_encoders_from_config(&encs, &enc);
    for (i = 0; i < NPOSE * 6; i++) {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        bam[i] = (uint32_t)((s * UINT64_C(2685821657736338717)) >> 32);
    }
    /* the same poses as signed angles in rad, float */
    aacmm_encoder_to_angles_f32(&enc, bam, th32); /* first pose; the rest below */
    for (i = 0; i < NPOSE; i++) {
        aacmm_encoder_to_angles_f32(&enc, bam + 6 * i, th32 + 6 * i);
    }
}

/* One batch of n poses (cycled from the working set) through one path. */
static int callgrind_run(const char *path, long n)
{
    long k;
    int ok = 1;
    for (k = 0; k < n; k += NPOSE) {
        size_t m = (size_t)((n - k) < NPOSE ? (n - k) : NPOSE);
        if (strcmp(path, "f32") == 0) {
            ok &= aacmm_batch_angles_f32(&m32, m, th32, p32, j32, NULL) == AACMM_OK;
        } else if (strcmp(path, "q") == 0) {
            ok &= aacmm_batch_bam_q(&mq, m, bam, pq, jq, NULL) == AACMM_OK;
        } else if (strcmp(path, "f32-counts") == 0) {
            ok &= aacmm_batch_counts_f32(&m32, &encs, m, bam, p32, j32, NULL) == AACMM_OK;
        } else if (strcmp(path, "q-counts") == 0) {
            ok &= aacmm_batch_counts_q(&mq, &encs, m, bam, pq, jq, NULL) == AACMM_OK;
        } else if (strcmp(path, "f32-point") == 0) {
            ok &= aacmm_batch_angles_f32(&m32, m, th32, p32, NULL, NULL) == AACMM_OK;
        } else if (strcmp(path, "q-point") == 0) {
            ok &= aacmm_batch_bam_q(&mq, m, bam, pq, NULL, NULL) == AACMM_OK;
        } else {
            fprintf(stderr, "bench_fixed: unknown path %s\n", path);
            return 2;
        }
    }
    sink = (double)pq[0] + (double)p32[0];
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    setup();
    if (argc == 4 && strcmp(argv[1], "--callgrind") == 0) {
        return callgrind_run(argv[2], strtol(argv[3], NULL, 10));
    }
    measure("fixed.point_q", "probe point, fixed point (integer only)", run_point_q);
    measure("fixed.point_jacobian_q", "probe point + 3x25 Jacobian, fixed point", run_point_jac_q);
    measure("fixed.counts_point_jacobian_q",
            "32-bit counts -> binary angles -> point + Jacobian, fixed point", run_counts_jac_q);
    measure("fixed.ref_point_f32", "probe point, single (same poses)", run_point_f32);
    measure("fixed.ref_point_jacobian_f32", "probe point + 3x25 Jacobian, single (same poses)",
            run_point_jac_f32);
    measure("fixed.ref_counts_point_jacobian_f32",
            "32-bit counts -> angles -> point + Jacobian, single (same poses)", run_counts_jac_f32);
    return 0;
}
