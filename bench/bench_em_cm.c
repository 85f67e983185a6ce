/*
 * Instructions of the error model (issue 27) on the two Cortex-M cores,
 * bare metal under QEMU with -icount shift=0 (every guest instruction is
 * 1 ns of virtual time; SysTick runs on the processor clock):
 *   Cortex-M0 (QEMU microbit, 16 MHz: 62.5 instructions per tick): the
 *     fixed-point path, the -Os M0+ objects of `make firmware`;
 *   Cortex-M4F (QEMU mps2-an386, 25 MHz: 40 instructions per tick): the
 *     single-precision path on the FPU, the -Os M4F objects.
 * The paper's arm (Table 1) with K = 2 harmonics on every joint (the
 * coefficients 10-30 arcsec, a one-head encoder's), against the same calls
 * without the error model; "per reading" is per pose of six joint readings.
 * Output: one JSON object per line via semihosting (make bench-em-m0,
 * make bench-em-m4f). Exact, deterministic instruction counts (not cycles).
 */
#include <stdint.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"

#include "bare_metal.h"

#if defined(__ARM_ARCH_6M__)
#define CPU "cortex-m0 (qemu microbit, -icount shift=0)"
#define PATH "fixed point, -Os"
#define IPT_NUM 125u /* 62.5 instructions per tick */
#define IPT_DEN 2u
#else
#define CPU "cortex-m4f (qemu mps2-an386, -icount shift=0)"
#define PATH "f32 on the FPU, -Os"
#define IPT_NUM 40u
#define IPT_DEN 1u
#endif

#define NPOSE 64
#define REPS 4
#define JMAX (3 * (AACMM_JAC_COLS + 2 * 2 * 6))

static uint32_t bam[NPOSE * 6];
#if defined(__ARM_ARCH_6M__)
static int64_t pq[3], jq[JMAX];
static aacmm_model_q_t mq;
static aacmm_errmodel_q_t em2, em0;
static int32_t temps[6] = {7168, 7168, 7168, 7168, 7168, 7168}; /* 28 degC */
static int32_t temps2[6] = {5376, 5440, 5504, 5568, 5632, 5696}; /* 21 .. 22.25 degC */
static aacmm_model_q_t mq_t;
#else
static float rad[NPOSE * 6];
static float pf[3], jf[JMAX];
static aacmm_model_f32_t mf;
static aacmm_errmodel_f32_t em2, em0;
static float temps[6] = {28.0f, 28.0f, 28.0f, 28.0f, 28.0f, 28.0f};
static float temps2[6] = {21.0f, 21.25f, 21.5f, 21.75f, 22.0f, 22.25f};
static aacmm_model_f32_t mf_t;
#endif

typedef void (*pose_fn)(int k);

#if defined(__ARM_ARCH_6M__)
static void plain_point(int k) { (void)aacmm_point_q(&mq, bam + 6 * k, pq); }
static void plain_jac(int k) { (void)aacmm_point_jacobian_q(&mq, bam + 6 * k, pq, jq); }
static void em0_jac(int k) { (void)aacmm_point_jacobian_em_q(&mq, &em0, bam + 6 * k, 0, pq, jq); }
static void em2_point(int k) { (void)aacmm_point_em_q(&mq, &em2, bam + 6 * k, 0, pq); }
static void em2_jac(int k) { (void)aacmm_point_jacobian_em_q(&mq, &em2, bam + 6 * k, 0, pq, jq); }
static void em2_jac_t(int k)
{
    (void)aacmm_point_jacobian_em_q(&mq, &em2, bam + 6 * k, temps, pq, jq);
}
static volatile int32_t sink;
static void sincos6(int k)
{
    int32_t a, b, i;
    for (i = 0; i < 6; i++) {
        aacmm_sincos_q(bam[6 * k + i], &a, &b);
        sink = a + b;
    }
}
/* The device's fixed path (firmware/src/device/device_kin_q.c): the corrected
 * readings, then the plain point and 3x25 Jacobian (= aacmm_point_jacobian_corrected_q
 * bit for bit, with a smaller stack). */
static uint32_t qc[6];
static void em2_jac_p(int k)
{
    (void)aacmm_errmodel_q_correct(&mq, &em2, bam + 6 * k, qc);
    (void)aacmm_point_jacobian_q(&mq, qc, pq, jq);
}
/* The device's rescale on a change of link temperature (device_kin_q.c:
 * aacmm_model_q_at_temperature into its cache), alternating two sets. */
static void rescale(int k)
{
    (void)aacmm_model_q_at_temperature(&mq_t, &mq, &em2, (k & 1) != 0 ? temps : temps2);
}
#else
static void plain_point(int k) { (void)aacmm_point_f32(&mf, rad + 6 * k, pf); }
static void plain_jac(int k) { (void)aacmm_point_jacobian_f32(&mf, rad + 6 * k, pf, jf); }
static void em0_jac(int k) { (void)aacmm_point_jacobian_em_f32(&mf, &em0, rad + 6 * k, 0, pf, jf); }
static void em2_point(int k) { (void)aacmm_point_em_f32(&mf, &em2, rad + 6 * k, 0, pf); }
static void em2_jac(int k) { (void)aacmm_point_jacobian_em_f32(&mf, &em2, rad + 6 * k, 0, pf, jf); }
static void em2_jac_t(int k)
{
    (void)aacmm_point_jacobian_em_f32(&mf, &em2, rad + 6 * k, temps, pf, jf);
}
/* The device's f32 path (firmware/src/device/device_kin_f32.c): the
 * corrected readings, then the plain point and 3x25 Jacobian. */
static float qc[6];
static void em2_jac_p(int k)
{
    (void)aacmm_errmodel_angles_f32(&em2, rad + 6 * k, qc);
    (void)aacmm_point_jacobian_f32(&mf, qc, pf, jf);
}
/* The device's rescale on a change of link temperature (device_kin_f32.c:
 * aacmm_model_at_temperature_f32 into its cache), alternating two sets. */
static void rescale(int k)
{
    (void)aacmm_model_at_temperature_f32(&mf_t, &mf, &em2, (k & 1) != 0 ? temps : temps2);
}
#endif
static void empty(int k) { (void)k; }

static uint32_t ticks(pose_fn fn)
{
    uint32_t t0, t1;
    int r, k;
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = 5u;
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

static uint32_t per_pose(pose_fn fn, uint32_t base)
{
    const uint32_t t = ticks(fn) - base;
    return (uint32_t)(((uint64_t)t * IPT_NUM / IPT_DEN + (REPS * NPOSE) / 2) / (REPS * NPOSE));
}

static void report(const char *name, const char *what, uint32_t v)
{
    put("{\"bench\": \"");
    put(name);
    put("\", \"what\": \"");
    put(what);
    put("\", \"instructions_per_pose\": ");
    put_u32(v);
    put(", \"cpu\": \"" CPU "\", \"build\": \"" PATH "\"}\n");
}

int main(void)
{
    /* 10-30 arcsec (4.8e-5 .. 1.5e-4 rad) per coefficient, fixed pattern */
    static const int32_t coef_q36[4] = {1094000, -1640000, 547000, -820000}; /* 2^-36 turn */
    uint64_t s = UINT64_C(0x243F6A8885A308D3);
    uint32_t base, pp, pj, e2p, e2j, e2t, e0j;
    int i, k;
#if defined(__ARM_ARCH_6M__)
    aacmm_params_q_t q;
    aacmm_params_default_q(&q);
    aacmm_model_q_init(&mq, &q);
    aacmm_errmodel_q_default(&em2, 6);
    aacmm_errmodel_q_default(&em0, 6);
    for (i = 0; i < 6; i++) {
        em2.harmonics[i] = 2u;
        em2.cte_q40[i] = 25288767; /* 23e-6 / K, aluminium */
        for (k = 0; k < 2; k++) {
            em2.c_q36[i][k] = coef_q36[(i + k) % 4];
            em2.s_q36[i][k] = coef_q36[(i + k + 1) % 4];
        }
    }
#else
    aacmm_params_f32_t p;
    aacmm_encoder_config_t enc;
    aacmm_params_default_f32(&p);
    aacmm_model_init_f32(&mf, &p);
    aacmm_encoder_default(&enc);
    aacmm_errmodel_default_f32(&em2, 6);
    aacmm_errmodel_default_f32(&em0, 6);
    for (i = 0; i < 6; i++) {
        em2.harmonics[i] = 2u;
        em2.cte_per_k[i] = 23e-6f;
        for (k = 0; k < 2; k++) {
            em2.c_rad[i][k] = (float)coef_q36[(i + k) % 4] * 9.1432e-11f;
            em2.s_rad[i][k] = (float)coef_q36[(i + k + 1) % 4] * 9.1432e-11f;
        }
    }
#endif
    for (i = 0; i < NPOSE * 6; i++) {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        bam[i] = (uint32_t)((s * UINT64_C(2685821657736338717)) >> 32);
    }
#if !defined(__ARM_ARCH_6M__)
    for (i = 0; i < NPOSE; i++) {
        aacmm_encoder_to_angles_f32(&enc, bam + 6 * i, rad + 6 * i);
    }
#endif
    base = ticks(empty);
    pp = per_pose(plain_point, base);
    pj = per_pose(plain_jac, base);
    e0j = per_pose(em0_jac, base);
    e2p = per_pose(em2_point, base);
    e2j = per_pose(em2_jac, base);
    e2t = per_pose(em2_jac_t, base);
    report("em.point", "probe point, no error model", pp);
    report("em.point_jacobian", "probe point + 3x25 Jacobian, no error model", pj);
    report("em.point_jacobian_k0", "the same through the error model with K = 0", e0j);
    report("em.point_k2", "probe point, K = 2 on every joint", e2p);
    report("em.point_jacobian_k2", "probe point + 3x49 Jacobian, K = 2 on every joint", e2j);
    report("em.point_jacobian_k2_temps",
           "probe point + 3x49 Jacobian, K = 2, link temperatures (28 degC, 23e-6/K)", e2t);
    report("em.point_jacobian_corrected_k2",
           "probe point + the 3x25 Jacobian at the corrected readings, K = 2 on every joint "
           "(the device's sample and COMPUTE path)",
           per_pose(em2_jac_p, base));
    report("em.rescale_model",
           "the model scaled to new link temperatures (aacmm_model_at_temperature_f32 / "
           "aacmm_model_q_at_temperature, 6 links): the device's cost per change of temperature "
           "with the thermal block",
           per_pose(rescale, base));
#if defined(__ARM_ARCH_6M__)
    report("em.sincos_q_x6", "6 aacmm_sincos_q (the extra one per corrected joint), for scale",
           per_pose(sincos6, base));
#endif
    report("em.correction_per_reading", "the correction of 6 readings, K = 2: point_k2 - point",
           e2p - pp);
    return 0;
}
