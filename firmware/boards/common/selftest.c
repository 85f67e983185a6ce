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
static float out_p32[3], out_j32[AACMM_JAC_SIZE];

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
static int64_t out_pq[3], out_jq[AACMM_JAC_SIZE];

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
    printf("self-test %s: %d failure(s)\n", failures ? "FAILED" : "passed", failures);
    exit(failures ? 1 : 0);
}
