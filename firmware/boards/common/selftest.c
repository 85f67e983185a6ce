/*
 * On-target self-test and cost benchmark, run under QEMU with semihosting
 * (-semihosting-config enable=on,target=native; linked with rdimon.specs).
 *
 * 1. Clock calibration: a loop of a known instruction count timed with the
 *    board's tick counter gives the instructions per tick (under QEMU with
 *    -icount shift=0 every instruction is 1 ns of virtual time).
 * 2. Golden vectors (golden.h, generated on the host by gen_golden.py from
 *    the double-precision core): every kinematics path built into the image
 *    (SELFTEST_F32: aacmm_point_jacobian_f32; SELFTEST_Q:
 *    aacmm_point_jacobian_q) is checked against its bound:
 *        float:  1e-3 mm per point coordinate, 2e-3 per Jacobian entry
 *        fixed:  1e-4 mm per point coordinate, 1e-4 per Jacobian entry
 * 3. Cost: instructions per call (point only, point + full Jacobian, and
 *    encoder counts -> point + Jacobian), the minimum over a few timed runs
 *    of BENCH_CALLS calls each, less the loop's own cost (an empty call).
 * 4. Stack: the stack below main's frame is painted, one point + Jacobian
 *    call is made, and the untouched part is measured.
 * 5. The general arm model (issue 26): with both paths built in, point and
 *    point + Jacobian instructions for arms of 5, 6 and 7 joints (the general
 *    chains; the paper's arm above runs its own), and the float and the fixed
 *    path checked against each other on them (1e-3 mm per coordinate, scaled
 *    by the arm's reach).
 *
 * SELFTEST_CANARY: a build whose every error is inflated past its bound; it
 * must fail (run_selftest.py --expect-fail), showing that the checks can.
 *
 * Output: human-readable lines, then one JSON object per path (lines
 * starting with '{'). Exit status 0 when every check passed, 1 otherwise,
 * 2 on a fault (HardFault etc.), read by tests/boards/run_selftest.py.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "board.h"
#include "board_startup.h"
#include "golden.h"
#ifdef SELFTEST_Q
#include "aacmm/kinematics_q.h"
#endif

#ifndef BOARD_KIN_PRIMARY
#define BOARD_KIN_PRIMARY "f32"
#endif

#define BENCH_CALLS 32u
#define BENCH_RUNS 5u
#define CAL_LOOPS 200000u

#define BOUND_F32_POINT_MM 1e-3
#define BOUND_F32_JAC 2e-3
#define BOUND_Q_POINT_MM 1e-4
#define BOUND_Q_JAC 1e-4

extern void initialise_monitor_handles(void);
extern uint32_t __stack_limit;

static int failures;

void board_fault_hook(uint32_t ipsr)
{
    printf("selftest: fault, exception %lu\n", (unsigned long)ipsr);
    exit(2);
}

/* ---- clock calibration ---- */

/* 2 * loops + 1 instructions (subs + bne per pass, the last bne not taken
 * counts once; plus the mov). */
__attribute__((noinline)) static void spin(uint32_t loops)
{
#if defined(__thumb2__)
    __asm__ volatile("1:\n\tsubs %0, %0, #1\n\tbne 1b" : "+l"(loops)::"cc");
#else
    /* GCC hands Thumb-1 inline assembly over in divided syntax, where the
     * 16-bit flag-setting subtract is spelt "sub". */
    __asm__ volatile("1:\n\tsub %0, #1\n\tbne 1b" : "+l"(loops)::"cc");
#endif
}

/* Instructions per tick, times 1000. */
static uint32_t calibrate(void)
{
    uint64_t t0, t1, t2;
    t0 = board_ticks();
    spin(CAL_LOOPS);
    t1 = board_ticks();
    spin(2u * CAL_LOOPS);
    t2 = board_ticks();
    /* The second run minus the first: exactly 2 * CAL_LOOPS instructions
     * more, with the call and timer-read overheads cancelled. */
    return (uint32_t)((2000ull * CAL_LOOPS) / ((t2 - t1) - (t1 - t0)));
}

/* ---- helpers ---- */

static double absd(double x)
{
    return x < 0.0 ? -x : x;
}

/* A nonnegative double as an integer number of 1e-9 units, saturated at
 * 4e9 (newlib-nano's printf has neither floats nor long long). */
static unsigned long nano(double x)
{
    double v = x * 1e9 + 0.5;
    return v < 4e9 ? (unsigned long)v : 4000000000ul;
}

static void check(const char *what, double worst, double bound)
{
    int ok;
#ifdef SELFTEST_CANARY
    worst += 2.0 * bound;
#endif
    ok = worst <= bound;
    printf("  %-12s max error %lu e-9, bound %lu e-9: %s\n", what, nano(worst), nano(bound),
           ok ? "ok" : "FAIL");
    if (!ok) {
        failures++;
    }
}

/* Stack painting: fill from the stack limit up to below the current frame,
 * then find the lowest word that changed. */
#define PAINT 0xA5C3E1F0u
static uint32_t *paint_stack(void)
{
    uint32_t *p = &__stack_limit;
    uint32_t *sp = (uint32_t *)__builtin_frame_address(0) - 64; /* margin for this frame */
    while (p < sp) {
        *p++ = PAINT;
    }
    return sp;
}

static uint32_t stack_used_below(const uint32_t *top)
{
    const uint32_t *p = &__stack_limit;
    while (p < top && *p == PAINT) {
        p++;
    }
    return (uint32_t)((uintptr_t)top - (uintptr_t)p);
}

typedef struct {
    uint64_t ticks_point;
    uint64_t ticks_point_jac;
    uint64_t ticks_counts_point_jac;
    uint64_t ticks_empty;
    uint32_t stack_point_jac;
} bench_t;

static volatile uint32_t sink;

__attribute__((noinline)) static void empty_call(const void *model, uint32_t i)
{
    (void)model;
    sink = i;
}

static uint64_t time_empty(const void *model)
{
    uint64_t best = UINT64_MAX;
    uint32_t r, i;
    for (r = 0; r < BENCH_RUNS; r++) {
        uint64_t t0 = board_ticks(), dt;
        for (i = 0; i < BENCH_CALLS; i++) {
            empty_call(model, i);
        }
        dt = board_ticks() - t0;
        if (dt < best) {
            best = dt;
        }
    }
    return best;
}

/* Instructions per call, from the best run of BENCH_CALLS calls. */
static unsigned long per_call(uint64_t ticks, uint64_t empty, uint32_t milli_ipt)
{
    uint64_t net = ticks > empty ? ticks - empty : 0u;
    return (unsigned long)((net * milli_ipt) / (1000ull * BENCH_CALLS));
}

static void report(const char *path, const bench_t *b, uint32_t milli_ipt)
{
    printf("{\"bench\": \"boards\", \"board\": \"%s\", \"path\": \"%s\", \"primary\": %s, "
           "\"tick_hz\": %lu, \"insn_per_tick_x1000\": %lu, "
           "\"insn_point\": %lu, \"insn_point_jacobian\": %lu, "
           "\"insn_counts_point_jacobian\": %lu, \"stack_point_jacobian_bytes\": %lu, "
           "\"calls\": %u, \"runs\": %u}\n",
           board_name, path, strcmp(path, BOARD_KIN_PRIMARY) == 0 ? "true" : "false",
           (unsigned long)board_tick_hz, (unsigned long)milli_ipt,
           per_call(b->ticks_point, b->ticks_empty, milli_ipt),
           per_call(b->ticks_point_jac, b->ticks_empty, milli_ipt),
           per_call(b->ticks_counts_point_jac, b->ticks_empty, milli_ipt),
           (unsigned long)b->stack_point_jac, BENCH_CALLS, BENCH_RUNS);
}

#define TIME_BEST(best, k, body)                                                                    \
    do {                                                                                           \
        uint32_t r_, i_;                                                                           \
        (best) = UINT64_MAX;                                                                       \
        for (r_ = 0; r_ < BENCH_RUNS; r_++) {                                                      \
            uint64_t t0_ = board_ticks(), dt_;                                                     \
            for (i_ = 0; i_ < BENCH_CALLS; i_++) {                                                 \
                (k) = i_ % GOLDEN_N;                                                               \
                body;                                                                              \
            }                                                                                      \
            dt_ = board_ticks() - t0_;                                                             \
            if (dt_ < (best)) {                                                                    \
                (best) = dt_;                                                                      \
            }                                                                                      \
        }                                                                                          \
    } while (0)

/* Encoder readings for the counts benchmark: 2^32 counts per turn, so the
 * binary angles double as readings. */
static aacmm_encoder_config_t enc;

/* ---- float path ---- */
#ifdef SELFTEST_F32
static aacmm_model_f32_t model_f32;
static float out_p32[3], out_j32[AACMM_JAC_SIZE_MAX];

__attribute__((noinline)) static uint32_t stack_f32(void)
{
    uint32_t *top = paint_stack();
    (void)aacmm_point_jacobian_f32(&model_f32, golden_theta_f32[7], out_p32, out_j32);
    return stack_used_below(top);
}

static void run_f32(uint32_t milli_ipt)
{
    aacmm_params_f32_t params;
    double wp = 0.0, wj = 0.0;
    uint32_t k, i;
    bench_t b;
    printf("float path (aacmm_point_jacobian_f32), %u golden poses:\n", GOLDEN_N);
    aacmm_params_default_f32(&params);
    if (aacmm_model_init_f32(&model_f32, &params) != AACMM_OK) {
        printf("  model init failed\n");
        failures++;
        return;
    }
    for (k = 0; k < GOLDEN_N; k++) {
        float p[3], j[AACMM_JAC_SIZE], p2[3];
        if (aacmm_point_jacobian_f32(&model_f32, golden_theta_f32[k], p, j) != AACMM_OK ||
            aacmm_point_f32(&model_f32, golden_theta_f32[k], p2) != AACMM_OK) {
            printf("  pose %lu: error status\n", (unsigned long)k);
            failures++;
            continue;
        }
        for (i = 0; i < 3; i++) {
            double e = absd((double)p[i] - golden_p_f32ref[k][i]);
            double e2 = absd((double)p2[i] - golden_p_f32ref[k][i]);
            wp = e > wp ? e : wp;
            wp = e2 > wp ? e2 : wp;
        }
        for (i = 0; i < AACMM_JAC_SIZE; i++) {
            double e = absd((double)j[i] - golden_j_f32ref[k][i]);
            wj = e > wj ? e : wj;
        }
    }
    check("point (mm)", wp, BOUND_F32_POINT_MM);
    check("Jacobian", wj, BOUND_F32_JAC);

    b.ticks_empty = time_empty(&model_f32);
    TIME_BEST(b.ticks_point, k, (void)aacmm_point_f32(&model_f32, golden_theta_f32[k], out_p32));
    TIME_BEST(b.ticks_point_jac, k,
              (void)aacmm_point_jacobian_f32(&model_f32, golden_theta_f32[k], out_p32, out_j32));
    TIME_BEST(b.ticks_counts_point_jac, k, {
        float th[AACMM_JOINTS];
        (void)aacmm_encoder_to_angles_f32(&enc, golden_bam[k], th);
        (void)aacmm_point_jacobian_f32(&model_f32, th, out_p32, out_j32);
    });
    b.stack_point_jac = stack_f32();
    report("f32", &b, milli_ipt);
}
#endif

/* ---- fixed path ---- */
#ifdef SELFTEST_Q
static aacmm_model_q_t model_q;
static int64_t out_pq[3], out_jq[AACMM_JAC_SIZE_MAX];

__attribute__((noinline)) static uint32_t stack_q(void)
{
    uint32_t *top = paint_stack();
    (void)aacmm_point_jacobian_q(&model_q, golden_bam[7], out_pq, out_jq);
    return stack_used_below(top);
}

/* A fixed-point output (Q AACMM_Q_OUT_FRAC) in double. */
static double q_to_d(int64_t x)
{
    return (double)x / (double)((uint64_t)1 << AACMM_Q_OUT_FRAC);
}

static void run_q(uint32_t milli_ipt)
{
    aacmm_params_q_t params;
    double wp = 0.0, wj = 0.0;
    uint32_t k, i;
    bench_t b;
    printf("fixed path (aacmm_point_jacobian_q), %u golden poses:\n", GOLDEN_N);
    aacmm_params_default_q(&params);
    if (aacmm_model_q_init(&model_q, &params) != AACMM_OK) {
        printf("  model init failed\n");
        failures++;
        return;
    }
    for (k = 0; k < GOLDEN_N; k++) {
        int64_t p[3], j[AACMM_JAC_SIZE], p2[3];
        if (aacmm_point_jacobian_q(&model_q, golden_bam[k], p, j) != AACMM_OK ||
            aacmm_point_q(&model_q, golden_bam[k], p2) != AACMM_OK) {
            printf("  pose %lu: error status\n", (unsigned long)k);
            failures++;
            continue;
        }
        for (i = 0; i < 3; i++) {
            double e = absd(q_to_d(p[i]) - golden_p_qref[k][i]);
            wp = e > wp ? e : wp;
            if (p2[i] != p[i]) {
                printf("  pose %lu: point_q differs from point_jacobian_q\n", (unsigned long)k);
                failures++;
            }
        }
        for (i = 0; i < AACMM_JAC_SIZE; i++) {
            double e = absd(q_to_d(j[i]) - golden_j_qref[k][i]);
            wj = e > wj ? e : wj;
        }
    }
    check("point (mm)", wp, BOUND_Q_POINT_MM);
    check("Jacobian", wj, BOUND_Q_JAC);

    b.ticks_empty = time_empty(&model_q);
    TIME_BEST(b.ticks_point, k, (void)aacmm_point_q(&model_q, golden_bam[k], out_pq));
    TIME_BEST(b.ticks_point_jac, k,
              (void)aacmm_point_jacobian_q(&model_q, golden_bam[k], out_pq, out_jq));
    TIME_BEST(b.ticks_counts_point_jac, k, {
        uint32_t th[AACMM_JOINTS];
        (void)aacmm_encoder_to_bam(&enc, golden_bam[k], th);
        (void)aacmm_point_jacobian_q(&model_q, th, out_pq, out_jq);
    });
    b.stack_point_jac = stack_q();
    report("q", &b, milli_ipt);
}
#endif


/* ---- the general arm model: N = 5, 6, 7 (both paths built in) ---- */
#if defined(SELFTEST_F32) && defined(SELFTEST_Q)
/* 2^32 / (2 pi) and 2^18: BAM and Q18 of the arms below, exact for their
 * values (the lengths are dyadic, the alphas quarter turns or given in BAM). */
#define Q18(mm) ((int32_t)((mm) * 262144))
#define BAM_QUARTER 0x40000000u
#define BAM_MINUS_QUARTER 0xC0000000u
#define BAM_MILLIRAD 683565u  /* 0.001 rad */
#define BAM_BETA 273426u      /* 4e-4 rad */

/* The arms of bench/bench_core.c's per-N figures, in both forms: 5 joints
 * modified DH with a beta on joint 3, tip l; 6 joints the paper's geometry
 * (lengths rounded to 1/8 mm) with a tip vector; 7 joints of commercial
 * proportions, standard DH, tip vector. */
static void arm_pair(int joints, aacmm_arm_f32_t *af, aacmm_arm_q_t *aq)
{
    static const float pi2 = 1.5707963267948966f;
    int i;
    memset(af, 0, sizeof *af);
    memset(aq, 0, sizeof *aq);
    af->shape.joints = (uint8_t)joints;
    if (joints == 5) {
        static const float alpha[5] = {0.0f, 1.5707963267948966f, 0.001f, 1.5707963267948966f,
                                       -1.5707963267948966f};
        static const uint32_t alpha_bam[5] = {0u, BAM_QUARTER, BAM_MILLIRAD, BAM_QUARTER,
                                              BAM_MINUS_QUARTER};
        static const float d[5] = {210.0f, 0.0f, 0.0f, 260.0f, 0.0f};
        static const float a[5] = {0.0f, 24.0f, 260.0f, 0.0f, 0.0f};
        for (i = 0; i < 5; i++) {
            af->shape.convention[i] = AACMM_DH_MODIFIED;
            af->alpha_rad[i] = alpha[i];
            aq->alpha_bam[i] = alpha_bam[i];
            af->d_mm[i] = d[i];
            af->a_mm[i] = a[i];
        }
        af->shape.beta[2] = 1u;
        af->beta_rad[2] = 4e-4f;
        aq->beta_bam[2] = BAM_BETA;
        af->shape.tip = AACMM_TIP_Z;
        af->tip_mm[2] = 95.0f;
    } else if (joints == 6) {
        static const float d[6] = {300.0f, 65.5f, 792.75f, 65.5f, 883.25f, 0.0f};
        for (i = 0; i < 6; i++) {
            af->alpha_rad[i] = pi2;
            aq->alpha_bam[i] = BAM_QUARTER;
            af->d_mm[i] = d[i];
        }
        af->shape.tip = AACMM_TIP_XYZ;
        af->tip_mm[0] = 5.0f;
        af->tip_mm[1] = -3.0f;
        af->tip_mm[2] = 183.5f;
    } else {
        static const float d[7] = {180.0f, 0.0f, 1200.0f, 0.0f, 1000.0f, 0.0f, 150.0f};
        static const float a[7] = {0.0f, 80.0f, 0.0f, 80.0f, 0.0f, 0.0f, 0.0f};
        for (i = 0; i < 7; i++) {
            af->alpha_rad[i] = (i == 6) ? 0.0f : ((i % 2) ? -pi2 : pi2);
            aq->alpha_bam[i] = (i == 6) ? 0u : ((i % 2) ? BAM_MINUS_QUARTER : BAM_QUARTER);
            af->d_mm[i] = d[i];
            af->a_mm[i] = a[i];
        }
        af->shape.tip = AACMM_TIP_XYZ;
        af->tip_mm[0] = 12.0f;
        af->tip_mm[1] = -5.0f;
        af->tip_mm[2] = 110.0f;
    }
    aq->shape = af->shape;
    for (i = 0; i < joints; i++) {
        aq->d_q18[i] = Q18(af->d_mm[i]);
        aq->a_q18[i] = Q18(af->a_mm[i]);
    }
    for (i = 0; i < 3; i++) {
        aq->tip_q18[i] = Q18(af->tip_mm[i]);
    }
}

static aacmm_model_f32_t arm_f32;
static aacmm_model_q_t arm_q;
/* The poses: the golden binary angles, a seventh joint added, and the same
 * angles in rad (2^32 counts per turn, so they are readings too). */
static uint32_t arm_bam[GOLDEN_N][AACMM_JOINTS_MAX];
static float arm_theta[GOLDEN_N][AACMM_JOINTS_MAX];

static void run_arms(uint32_t milli_ipt)
{
    int joints;
    for (joints = 5; joints <= 7; joints++) {
        aacmm_arm_f32_t af;
        aacmm_arm_q_t aq;
        double worst = 0.0, reach = 0.0, bound;
        uint64_t t_empty, t_fp, t_fj, t_qp, t_qj;
        uint32_t k, i;
        arm_pair(joints, &af, &aq);
        if (aacmm_model_init_arm_f32(&arm_f32, &af) != AACMM_OK ||
            aacmm_model_q_init_arm(&arm_q, &aq) != AACMM_OK) {
            printf("  arm of %d joints: model init failed\n", joints);
            failures++;
            continue;
        }
        for (i = 0; i < (uint32_t)joints; i++) {
            reach += absd((double)af.d_mm[i]) + absd((double)af.a_mm[i]);
        }
        reach += absd((double)af.tip_mm[0]) + absd((double)af.tip_mm[1]) +
                 absd((double)af.tip_mm[2]);
        bound = BOUND_F32_POINT_MM * (reach > 2290.4 ? reach / 2290.4 : 1.0);
        /* the two paths on the same binary angles (the BAM of the golden
         * poses; 2^32 counts per turn, so they are readings too) */
        for (k = 0; k < GOLDEN_N; k++) {
            float p[3];
            int64_t pq[3];
            for (i = 0; i < AACMM_JOINTS_MAX; i++) {
                arm_bam[k][i] = golden_bam[k][i % 6u] + 0x01000000u * i;
                arm_theta[k][i] = (float)(int32_t)arm_bam[k][i] * 1.4629180792671596e-09f;
            }
            (void)aacmm_point_q(&arm_q, arm_bam[k], pq);
            (void)aacmm_point_f32(&arm_f32, arm_theta[k], p);
            for (i = 0; i < 3; i++) {
                double e = absd((double)p[i] - q_to_d(pq[i]));
                worst = e > worst ? e : worst;
            }
        }
        printf("arm of %d joints (P = %u), float vs fixed path:\n", joints,
               (unsigned)arm_q.n_params);
        check("point (mm)", worst, bound);
        t_empty = time_empty(&arm_q);
        TIME_BEST(t_fp, k, (void)aacmm_point_f32(&arm_f32, arm_theta[k], out_p32));
        TIME_BEST(t_fj, k,
                  (void)aacmm_point_jacobian_f32(&arm_f32, arm_theta[k], out_p32, out_j32));
        TIME_BEST(t_qp, k, (void)aacmm_point_q(&arm_q, arm_bam[k], out_pq));
        TIME_BEST(t_qj, k, (void)aacmm_point_jacobian_q(&arm_q, arm_bam[k], out_pq, out_jq));
        printf("{\"bench\": \"boards.arm\", \"board\": \"%s\", \"joints\": %d, \"params\": %u, "
               "\"insn_point_f32\": %lu, \"insn_point_jacobian_f32\": %lu, \"insn_point_q\": %lu, "
               "\"insn_point_jacobian_q\": %lu, \"board_path\": \"%s\", \"calls\": %u, \"runs\": %u}\n",
               board_name, joints, (unsigned)arm_q.n_params, per_call(t_fp, t_empty, milli_ipt),
               per_call(t_fj, t_empty, milli_ipt), per_call(t_qp, t_empty, milli_ipt),
               per_call(t_qj, t_empty, milli_ipt), BOARD_KIN_PRIMARY, BENCH_CALLS, BENCH_RUNS);
    }
}
#endif

int main(void)
{
    uint32_t milli_ipt;
    initialise_monitor_handles();
    board_init();
    aacmm_encoder_default(&enc);
    milli_ipt = calibrate();
    printf("aacmm self-test on %s: tick %lu Hz, measured %lu.%03lu instructions per tick\n",
           board_name, (unsigned long)board_tick_hz, (unsigned long)(milli_ipt / 1000u),
           (unsigned long)(milli_ipt % 1000u));
#ifdef SELFTEST_F32
    run_f32(milli_ipt);
#endif
#ifdef SELFTEST_Q
    run_q(milli_ipt);
#endif
#if defined(SELFTEST_F32) && defined(SELFTEST_Q)
    run_arms(milli_ipt);
#endif
    printf("self-test %s: %d failure(s)\n", failures ? "FAILED" : "passed", failures);
    exit(failures ? 1 : 0);
}
