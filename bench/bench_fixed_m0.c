/*
 * Fixed-point vs soft-float single precision on a Cortex-M0 (no FPU),
 * bare metal under QEMU's BBC micro:bit model (nRF51, Cortex-M0) with
 * -icount shift=0: every guest instruction advances the virtual clock by
 * exactly 1 ns, and SysTick (16 MHz) reads that clock, so 1 tick = 62.5
 * instructions. The figures are therefore exact, deterministic instruction
 * counts per pose (not cycles: on a real M0+ loads, stores and taken branches
 * take 2 cycles, the multiplier 1). Both paths are the -Os builds of
 * `make firmware` (-mcpu=cortex-m0plus -mthumb -mfloat-abi=soft); the float
 * path's arithmetic goes through libgcc's soft-float helpers.
 *
 * Output: one JSON object per line via semihosting; run by `make
 * bench-fixed-m0`. Self-contained start-up code: vector table, .data/.bss
 * set-up, semihosting exit.
 */
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"

#include "bare_metal.h"

#define NPOSE 64 /* poses in the working set */
#define REPS 4   /* passes over it: 256 poses per figure */

static uint32_t bam[NPOSE * 6];
static float rad[NPOSE * 6];
static int64_t pq[3], jq[AACMM_JAC_SIZE];
static float pf[3], jf[AACMM_JAC_SIZE];
static aacmm_model_q_t mq;
static aacmm_model_f32_t mf;
static aacmm_encoder_config_t enc;
static aacmm_arm_encoders_t encs; /* the same, in the arm form of the batches */

typedef void (*pose_fn)(int k);

static void q_point(int k) { (void)aacmm_point_q(&mq, bam + 6 * k, pq); }
static void q_point_jac(int k) { (void)aacmm_point_jacobian_q(&mq, bam + 6 * k, pq, jq); }
static void q_counts_jac(int k)
{
    (void)aacmm_batch_counts_q(&mq, &encs, 1u, bam + 6 * k, pq, jq, (size_t *)0);
}
static void f_point(int k) { (void)aacmm_point_f32(&mf, rad + 6 * k, pf); }
static void f_point_jac(int k) { (void)aacmm_point_jacobian_f32(&mf, rad + 6 * k, pf, jf); }
static void f_counts_jac(int k)
{
    (void)aacmm_batch_counts_f32(&mf, &encs, 1u, bam + 6 * k, pf, jf, (size_t *)0);
}
static void empty(int k) { (void)k; }

/* SysTick ticks for REPS passes over the working set (< 2^24: checked). */
static uint32_t ticks(pose_fn fn)
{
    uint32_t t0, t1;
    int r, k;
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = 5u; /* enable, processor clock */
    t0 = SYST_CVR;
    for (r = 0; r < REPS; r++) {
        for (k = 0; k < NPOSE; k++) {
            fn(k);
        }
    }
    t1 = SYST_CVR;
    SYST_CSR = 0u;
    return (t0 - t1) & 0xFFFFFFu;
}

static void report(const char *name, const char *what, pose_fn fn, uint32_t base)
{
    /* 62.5 instructions per tick; the empty loop's ticks are subtracted. */
    uint32_t t = ticks(fn) - base;
    uint32_t per_pose = (uint32_t)(((uint64_t)t * 125u / 2u + (REPS * NPOSE) / 2) / (REPS * NPOSE));
    put("{\"bench\": \"");
    put(name);
    put("\", \"what\": \"");
    put(what);
    put("\", \"instructions_per_pose\": ");
    put_u32(per_pose);
    put(", \"cpu\": \"cortex-m0 (qemu microbit, -icount shift=0)\", \"build\": \"-Os soft-float\"}\n");
}

int main(void)
{
    aacmm_params_q_t q;
    aacmm_params_f32_t p;
    uint64_t s = UINT64_C(0x243F6A8885A308D3);
    uint32_t base;
    int i;
    aacmm_params_default_q(&q);
    aacmm_params_default_f32(&p);
    aacmm_model_q_init(&mq, &q);
    aacmm_model_init_f32(&mf, &p);
    aacmm_encoder_default(&enc);
    aacmm_arm_encoders_from_config(&encs, &enc);
    for (i = 0; i < NPOSE * 6; i++) {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        bam[i] = (uint32_t)((s * UINT64_C(2685821657736338717)) >> 32);
    }
    for (i = 0; i < NPOSE; i++) {
        aacmm_encoder_to_angles_f32(&enc, bam + 6 * i, rad + 6 * i);
    }
    /* Sanity: the two paths agree on the working set (to the f32 error). */
    {
        float worst = 0.0f;
        int k, r;
        for (k = 0; k < NPOSE; k++) {
            q_point(k);
            f_point(k);
            for (r = 0; r < 3; r++) {
                float e = (float)pq[r] * 0x1p-48f - pf[r];
                e = e < 0.0f ? -e : e;
                worst = e > worst ? e : worst;
            }
        }
        put("{\"bench\": \"fixed.m0_check\", \"what\": \"max |fixed - f32| point on the M0, nm\", "
            "\"max_nm\": ");
        put_u32((uint32_t)(worst * 1e6f));
        put("}\n");
    }
    base = ticks(empty);
    report("fixed.m0_point_q", "probe point, fixed point", q_point, base);
    report("fixed.m0_point_f32", "probe point, soft-float single", f_point, base);
    report("fixed.m0_point_jacobian_q", "probe point + 3x25 Jacobian, fixed point", q_point_jac,
           base);
    report("fixed.m0_point_jacobian_f32", "probe point + 3x25 Jacobian, soft-float single",
           f_point_jac, base);
    report("fixed.m0_counts_point_jacobian_q", "32-bit counts -> point + Jacobian, fixed point",
           q_counts_jac, base);
    report("fixed.m0_counts_point_jacobian_f32",
           "32-bit counts -> angles -> point + Jacobian, soft-float single", f_counts_jac, base);
    return 0;
}
