/*
 * The fixed-point path for the general arm model (issue 26): every shape of
 * tests/core/reference_arm.h (N = 4..7, standard / modified / mixed DH, with
 * and without betas, tip l or a tip vector, and the three shipped shapes)
 * against the double core on exactly the fixed path's parameters and
 * angles, and the shipped shapes against the independent long-double
 * reference; batches, counts, validation, conversion. Built twice, as
 * test_fixed.c: with the 64-bit products (test-fixed-gcc/-clang) and with
 * the ARMv6-M formulation (-DAACMM_Q_SPLIT_MUL: test-fixed-split, -san).
 *
 * Bounds: today's accuracy class of the fixed path on the paper's arm
 * (1e-4 mm per point coordinate, 1e-4 per Jacobian entry, for a reach of
 * 2290.4 mm), scaled by the arm's reach where it is longer; and, as for the
 * paper's arm, at least as accurate as single precision on the same poses.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"
#include "reference_arm.h"

#ifdef AACMM_Q_SPLIT_MUL
#define AACMM_Q_TEST_SPLIT 1
#else
#define AACMM_Q_TEST_SPLIT 0
#endif

#ifndef FIXED_TEST_POSES
#define FIXED_TEST_POSES 1000000L
#endif
/* poses per arm: 3000 in the plain builds, 300 in the sanitizer one */
#define POSES_PER_ARM ((int)(FIXED_TEST_POSES / 333L))

#define PAPER_REACH_MM 2290.4
#define BOUND_POINT_MM 1e-4
#define BOUND_JAC 1e-4
#define Q48_TO_MM(x) ((double)(x) * 0x1p-48)

static double reach_scale(const aacmm_arm_f64_t *arm)
{
    const double r = ref_arm_reach(arm) / PAPER_REACH_MM;
    return r > 1.0 ? r : 1.0;
}

static double bam_rad(uint32_t b)
{
    int64_t s = (b >= 0x80000000u) ? (int64_t)b - (INT64_C(1) << 32) : (int64_t)b;
    return (double)s * (2.0 * 3.14159265358979323846 / 4294967296.0);
}

/* A fixed model of arm and the double model of exactly its values. */
typedef struct {
    aacmm_arm_q_t aq;
    aacmm_model_q_t mq;
    aacmm_arm_f64_t ad; /* the values the fixed block stands for */
    aacmm_model_f64_t md;
} pair_t;

static void make_pair(pair_t *m, const aacmm_arm_f64_t *arm)
{
    assert_int_equal(aacmm_arm_q_from_f64(&m->aq, arm), AACMM_OK);
    assert_int_equal(aacmm_model_q_init_arm(&m->mq, &m->aq), AACMM_OK);
    assert_int_equal(aacmm_arm_q_to_f64(&m->ad, &m->aq), AACMM_OK);
    assert_int_equal(aacmm_model_init_arm_f64(&m->md, &m->ad), AACMM_OK);
    assert_int_equal(m->mq.n_params, m->md.n_params);
    assert_int_equal(m->mq.col_tip, m->md.col_tip);
    assert_memory_equal(m->mq.col_beta, m->md.col_beta, sizeof m->mq.col_beta);
    assert_int_equal(m->mq.paper, m->md.paper);
}

/* Every arm: fixed against double on the same numbers, and f32 on the same
 * (float-rounded) numbers for the "at least as accurate" check. */
static void test_every_arm(void **state)
{
    double worst_p = 0.0, worst_j = 0.0; /* in units of the scaled bound */
    double worst_abs_p = 0.0, worst_abs_j = 0.0;
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k++) {
        aacmm_arm_f64_t arm;
        aacmm_arm_f32_t af;
        aacmm_model_f32_t mf;
        pair_t m;
        char label[80];
        test_rng_t g = {UINT64_C(0xF1) + (uint64_t)k};
        double wp = 0.0, wj = 0.0, wf = 0.0, scale;
        int np, t, i, nj;
        ref_test_arm(k, &arm, label, sizeof label);
        make_pair(&m, &arm);
        scale = reach_scale(&m.ad);
        np = (int)m.mq.n_params;
        nj = (int)arm.shape.joints;
        /* single precision of the same arm, for comparison */
        af.shape = m.ad.shape;
        for (i = 0; i < AACMM_JOINTS_MAX; i++) {
            af.theta_offset_rad[i] = (float)m.ad.theta_offset_rad[i];
            af.alpha_rad[i] = (float)m.ad.alpha_rad[i];
            af.d_mm[i] = (float)m.ad.d_mm[i];
            af.a_mm[i] = (float)m.ad.a_mm[i];
            af.beta_rad[i] = (float)m.ad.beta_rad[i];
        }
        for (i = 0; i < 3; i++) {
            af.tip_mm[i] = (float)m.ad.tip_mm[i];
        }
        assert_int_equal(aacmm_model_init_arm_f32(&mf, &af), AACMM_OK);
        for (t = 0; t < POSES_PER_ARM; t++) {
            uint32_t bam[AACMM_JOINTS_MAX];
            double th[AACMM_JOINTS_MAX], pd[3], jd[AACMM_JAC_SIZE_MAX];
            float thf[AACMM_JOINTS_MAX], pf[3];
            int64_t pq[3], pq2[3], jq[AACMM_JAC_SIZE_MAX];
            for (i = 0; i < nj; i++) {
                bam[i] = (uint32_t)(rng_next(&g) >> 32);
                th[i] = bam_rad(bam[i]);
                thf[i] = (float)th[i];
            }
            assert_int_equal(aacmm_point_jacobian_q(&m.mq, bam, pq, jq), AACMM_OK);
            assert_int_equal(aacmm_point_q(&m.mq, bam, pq2), AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            assert_int_equal(aacmm_point_jacobian_f64(&m.md, th, pd, jd), AACMM_OK);
            assert_int_equal(aacmm_point_f32(&mf, thf, pf), AACMM_OK);
            for (i = 0; i < 3; i++) {
                wp = fmax(wp, fabs(Q48_TO_MM(pq[i]) - pd[i]));
                wf = fmax(wf, fabs((double)pf[i] - pd[i]));
            }
            for (i = 0; i < 3 * np; i++) {
                wj = fmax(wj, fabs(Q48_TO_MM(jq[i]) - jd[i]));
            }
            if (arm.shape.convention[0] == AACMM_DH_STANDARD) {
                assert_true(jq[2 * np] == 0);
            }
        }
        if (k >= N_RANDOM_ARMS) {
            printf("measured: fixed vs f64, %s (reach %.0f mm), %d poses: point max %.3g mm, "
                   "Jacobian max %.3g (bounds %.3g, %.3g); f32 point max %.3g\n",
                   label, ref_arm_reach(&m.ad), POSES_PER_ARM, wp, wj, BOUND_POINT_MM * scale,
                   BOUND_JAC * scale, wf);
        }
        /* at least as accurate as single precision on the same poses */
        assert_true(wp <= wf);
        worst_abs_p = fmax(worst_abs_p, wp);
        worst_abs_j = fmax(worst_abs_j, wj);
        worst_p = fmax(worst_p, wp / (BOUND_POINT_MM * scale));
        worst_j = fmax(worst_j, wj / (BOUND_JAC * scale));
    }
    printf("measured: fixed (%s) vs f64 on the same parameters, %d arms x %d poses: point max "
           "%.3g mm, Jacobian max %.3g; %.3g and %.3g of today's bounds scaled by reach\n",
           AACMM_Q_TEST_SPLIT ? "ARMv6-M formulation" : "64-bit products", N_ARMS,
           POSES_PER_ARM, worst_abs_p, worst_abs_j, worst_p, worst_j);
    assert_true(worst_p <= 1.0);
    assert_true(worst_j <= 1.0);
}

/* The shipped shapes against the independent long-double reference, end to
 * end: the fixed path on its converted parameters and binary angles, the
 * reference on the original double values and the exact angles. */
static void test_shipped_vs_reference(void **state)
{
    int which;
    (void)state;
    for (which = 0; which < 3; which++) {
        aacmm_arm_f64_t arm;
        pair_t m;
        test_rng_t g = {UINT64_C(0x5EED) + (uint64_t)which};
        double wp = 0.0, wj = 0.0, scale;
        int np, t, i, c;
        ref_shipped_arm(which, &arm);
        make_pair(&m, &arm);
        scale = reach_scale(&arm);
        np = (int)m.mq.n_params;
        for (t = 0; t < POSES_PER_ARM / 10; t++) {
            uint32_t bam[AACMM_JOINTS_MAX];
            double th[AACMM_JOINTS_MAX];
            int64_t pq[3], jq[AACMM_JAC_SIZE_MAX];
            long double q[AACMM_PARAMS_MAX], pr[3], jr[AACMM_JAC_SIZE_MAX];
            for (i = 0; i < (int)arm.shape.joints; i++) {
                bam[i] = (uint32_t)(rng_next(&g) >> 32);
                th[i] = bam_rad(bam[i]);
            }
            assert_int_equal(aacmm_point_jacobian_q(&m.mq, bam, pq, jq), AACMM_OK);
            ref_arm_vector(&arm, th, q);
            ref_arm_point_jacobian(&arm.shape, q, pr, jr);
            for (i = 0; i < 3; i++) {
                wp = fmax(wp, (double)fabsl((long double)Q48_TO_MM(pq[i]) - pr[i]));
                for (c = 0; c < np; c++) {
                    wj = fmax(wj, (double)fabsl((long double)Q48_TO_MM(jq[i * np + c]) -
                                                jr[i * np + c]));
                }
            }
        }
        printf("measured: fixed vs long-double reference (parameters quantised), shipped shape "
               "%d, %d poses: point max %.3g mm, Jacobian max %.3g (bound %.3g)\n",
               which, POSES_PER_ARM / 10, wp, wj, BOUND_POINT_MM * scale);
        assert_true(wp <= BOUND_POINT_MM * scale);
        assert_true(wj <= BOUND_JAC * scale);
    }
}

/* Batches equal single calls; counts with 2^32 counts per turn are the BAM
 * path; encoders of another joint count are refused. */
static void test_batches(void **state)
{
    enum { B = 29 };
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k += 7) {
        aacmm_arm_f64_t arm;
        pair_t m;
        aacmm_arm_encoders_t enc;
        char label[80];
        test_rng_t g = {UINT64_C(0xBA7) + (uint64_t)k};
        static uint32_t th[B * AACMM_JOINTS_MAX];
        static int64_t P[B * 3], J[B * AACMM_JAC_SIZE_MAX], P2[B * 3], J2[B * AACMM_JAC_SIZE_MAX];
        size_t done = 0u, l, nj, jn;
        ref_test_arm(k, &arm, label, sizeof label);
        make_pair(&m, &arm);
        nj = arm.shape.joints;
        jn = 3u * m.mq.n_params;
        for (l = 0; l < B * nj; l++) {
            th[l] = (uint32_t)(rng_next(&g) >> 32);
        }
        assert_int_equal(aacmm_batch_bam_q(&m.mq, B, th, P, J, &done), AACMM_OK);
        assert_int_equal((int)done, B);
        for (l = 0; l < B; l++) {
            int64_t p[3], j[AACMM_JAC_SIZE_MAX];
            assert_int_equal(aacmm_point_jacobian_q(&m.mq, th + nj * l, p, j), AACMM_OK);
            assert_memory_equal(p, P + 3 * l, sizeof p);
            assert_memory_equal(j, J + jn * l, sizeof(int64_t) * jn);
        }
        assert_int_equal(aacmm_arm_encoders_default(&enc, (int)nj), AACMM_OK);
        assert_int_equal(aacmm_batch_counts_q(&m.mq, &enc, B, th, P2, J2, &done), AACMM_OK);
        assert_int_equal((int)done, B);
        assert_memory_equal(P, P2, sizeof(int64_t) * 3 * B);
        assert_memory_equal(J, J2, sizeof(int64_t) * jn * B);
        enc.joints = (uint8_t)(nj - 1u);
        assert_int_equal(aacmm_batch_counts_q(&m.mq, &enc, B, th, P2, J2, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 0);
        enc.joints = (uint8_t)nj;
        enc.counts_per_rev[nj - 1] = 1u << 20;
        for (l = 0; l < B; l++) {
            th[nj * l + nj - 1] &= (1u << 20) - 1u;
        }
        th[nj * 11 + nj - 1] = 1u << 20;
        assert_int_equal(aacmm_batch_counts_q(&m.mq, &enc, B, th, P2, NULL, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 11);
    }
}

static void test_validation_and_conversion(void **state)
{
    aacmm_arm_q_t q, good;
    aacmm_arm_f64_t a, back;
    aacmm_model_q_t m, before;
    aacmm_params_q_t pq;
    (void)state;
    assert_int_equal(aacmm_arm_default_q(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_q_validate(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_default_q(&good), AACMM_OK);
    assert_int_equal(aacmm_params_default_q(&pq), AACMM_OK);
    assert_int_equal(aacmm_arm_q_from_params(&q, &pq), AACMM_OK);
    assert_memory_equal(&q, &good, sizeof q);
    assert_int_equal(aacmm_model_q_init_arm(&m, &good), AACMM_OK);
    assert_int_equal(m.paper, 1);
    assert_int_equal(m.n_params, 25);
    before = m;
#define EXPECT(stmt, status)                                                                       \
    do {                                                                                           \
        q = good;                                                                                  \
        stmt;                                                                                      \
        assert_int_equal(aacmm_arm_q_validate(&q), status);                                        \
        assert_int_equal(aacmm_model_q_init_arm(&m, &q), status);                                  \
        if ((status) != AACMM_OK) {                                                                \
            assert_memory_equal(&m, &before, sizeof m);                                            \
        }                                                                                          \
        m = before;                                                                                \
    } while (0)
    EXPECT(q.shape.joints = 8, AACMM_ERR_RANGE);
    EXPECT(q.shape.beta[0] = 1, AACMM_ERR_RANGE);
    EXPECT(q.shape.convention[3] = 5, AACMM_ERR_RANGE);
    EXPECT(q.shape.tip = 0, AACMM_ERR_RANGE);
    EXPECT(q.beta_bam[2] = 5u, AACMM_ERR_RANGE);          /* no beta declared */
    EXPECT(q.tip_q18[1] = 1, AACMM_ERR_RANGE);            /* y with tip l */
    EXPECT(q.d_q18[6] = 1, AACMM_ERR_RANGE);              /* past N */
    EXPECT(q.alpha_bam[6] = 1u, AACMM_ERR_RANGE);
    EXPECT(q.tip_q18[2] = INT32_MIN, AACMM_ERR_RANGE);    /* reach beyond 8000 mm */
    EXPECT((q.shape.tip = AACMM_TIP_XYZ, q.tip_q18[0] = 1 << 30, q.tip_q18[1] = 1 << 30),
           AACMM_ERR_RANGE); /* 2 x 4096 mm more: beyond the reach limit */
    EXPECT((q.shape.tip = AACMM_TIP_XYZ, q.tip_q18[0] = 1 << 20), AACMM_OK);
    EXPECT((q.shape.beta[3] = 1, q.beta_bam[3] = 0xFFFFFF00u), AACMM_OK);
#undef EXPECT
    /* conversion: range, round trip, errors left the output unchanged */
    ref_shipped_arm(1, &a);
    assert_int_equal(aacmm_arm_q_from_f64(&q, &a), AACMM_OK);
    assert_int_equal(aacmm_arm_q_to_f64(&back, &q), AACMM_OK);
    assert_memory_equal(&back.shape, &a.shape, sizeof a.shape);
    assert_true(fabs(back.beta_rad[2] - a.beta_rad[2]) < 1e-9);
    assert_true(fabs(back.tip_mm[2] - a.tip_mm[2]) < 4e-6);
    good = q;
    a.d_mm[1] = 8000.5; /* a length the fixed path cannot hold */
    assert_int_equal(aacmm_arm_q_from_f64(&q, &a), AACMM_ERR_RANGE);
    assert_memory_equal(&q, &good, sizeof q);
    a.d_mm[1] = (double)NAN;
    assert_int_equal(aacmm_arm_q_from_f64(&q, &a), AACMM_ERR_NOT_FINITE);
    a.d_mm[1] = 4000.0;
    a.a_mm[2] = 4000.0; /* total reach beyond 8000 mm */
    assert_int_equal(aacmm_arm_q_from_f64(&q, &a), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_q_from_f64(NULL, &a), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_q_to_f64(&back, NULL), AACMM_ERR_NULL);
    {
        aacmm_arm_f32_t af;
        assert_int_equal(aacmm_arm_default_f32(&af), AACMM_OK);
        assert_int_equal(aacmm_arm_q_from_f32(&q, &af), AACMM_OK);
        af.shape.beta[0] = 1;
        assert_int_equal(aacmm_arm_q_from_f32(&q, &af), AACMM_ERR_RANGE);
    }
}

/* The error model (issue 27) in fixed point against the double error model
 * on exactly its values (aacmm_errmodel_q_to_f64, Q8 temperatures): points
 * and the extended Jacobian within the fixed path's class; K = 0 without
 * temperatures, and every link at its reference temperature, bit for bit
 * the plain path; the batch equals the single calls; bad input refused. */
static void test_error_model(void **state)
{
    static const uint8_t kpat[AACMM_JOINTS_MAX] = {2, 4, 1, 0, 3, 2, 2};
    double worst_p = 0.0, worst_j = 0.0;
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k += 3) {
        aacmm_arm_f64_t arm;
        pair_t m;
        aacmm_errmodel_f64_t emd, emd_q;
        aacmm_errmodel_q_t emq, none;
        char label[80];
        test_rng_t g = {UINT64_C(0xE27) + (uint64_t)k};
        double scale;
        int nj, np, w, t, i, h;
        ref_test_arm(k, &arm, label, sizeof label);
        make_pair(&m, &arm);
        scale = reach_scale(&m.ad);
        nj = (int)arm.shape.joints;
        np = (int)m.mq.n_params;
        assert_int_equal(aacmm_errmodel_default_f64(&emd, nj), AACMM_OK);
        for (i = 0; i < nj; i++) {
            emd.harmonics[i] = kpat[i];
            for (h = 0; h < kpat[i]; h++) {
                emd.c_rad[i][h] = rng_uniform(&g, -2e-3, 2e-3);
                emd.s_rad[i][h] = rng_uniform(&g, -2e-3, 2e-3);
            }
            emd.cte_per_k[i] = rng_uniform(&g, -30e-6, 30e-6);
            emd.tref_c[i] = rng_uniform(&g, 15.0, 25.0);
        }
        assert_int_equal(aacmm_errmodel_q_from_f64(&emq, &emd), AACMM_OK);
        assert_int_equal(aacmm_errmodel_q_to_f64(&emd_q, &emq), AACMM_OK);
        assert_int_equal(aacmm_errmodel_q_default(&none, nj), AACMM_OK);
        w = np + aacmm_errmodel_q_cols(&emq);
        assert_int_equal(aacmm_errmodel_q_cols(&emq), aacmm_errmodel_cols_f64(&emd_q));
        for (t = 0; t < POSES_PER_ARM / 10; t++) {
            uint32_t bam[AACMM_JOINTS_MAX];
            int32_t tq[AACMM_JOINTS_MAX];
            double th[AACMM_JOINTS_MAX], tc[AACMM_JOINTS_MAX], pd[3];
            double jd[3 * (AACMM_PARAMS_MAX + 2 * AACMM_HARMONICS_MAX * AACMM_JOINTS_MAX)];
            int64_t pq[3], pq2[3], jq[3 * (AACMM_PARAMS_MAX + 2 * AACMM_HARMONICS_MAX * AACMM_JOINTS_MAX)];
            int64_t jq2[AACMM_JAC_SIZE_MAX];
            for (i = 0; i < nj; i++) {
                bam[i] = (uint32_t)(rng_next(&g) >> 32);
                th[i] = bam_rad(bam[i]);
                tq[i] = (int32_t)(rng_next(&g) % 32001u) - 10240; /* -40 .. 85 degC */
                tc[i] = (double)tq[i] / 256.0;
            }
            assert_int_equal(aacmm_point_jacobian_em_q(&m.mq, &emq, bam, tq, pq, jq), AACMM_OK);
            assert_int_equal(aacmm_point_em_q(&m.mq, &emq, bam, tq, pq2), AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            assert_int_equal(aacmm_point_jacobian_em_f64(&m.md, &emd_q, th, tc, pd, jd), AACMM_OK);
            /* the 3 x P Jacobian at the corrected readings: the extended one's
             * first P columns, row by row, bit for bit */
            assert_int_equal(aacmm_point_jacobian_corrected_q(&m.mq, &emq, bam, tq, pq2, jq2),
                             AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            for (i = 0; i < 3; i++) {
                assert_memory_equal(jq + i * w, jq2 + i * np, sizeof(int64_t) * (size_t)np);
            }
            assert_int_equal(aacmm_point_jacobian_corrected_q(&m.mq, &emq, bam, NULL, pq2, jq2),
                             AACMM_OK);
            {
                int64_t pe[3], je[3 * (AACMM_PARAMS_MAX + 56)];
                assert_int_equal(aacmm_point_jacobian_em_q(&m.mq, &emq, bam, NULL, pe, je),
                                 AACMM_OK);
                assert_memory_equal(pe, pq2, sizeof pe);
                for (i = 0; i < 3; i++) {
                    assert_memory_equal(je + i * w, jq2 + i * np, sizeof(int64_t) * (size_t)np);
                }
            }
            {
                /* the corrected readings alone, then the plain chain (the
                 * device's path): the same point and Jacobian, bit for bit */
                uint32_t qc[AACMM_JOINTS_MAX];
                int64_t pc[3], jc[AACMM_JAC_SIZE_MAX];
                assert_int_equal(aacmm_errmodel_q_correct(&m.mq, &emq, bam, qc), AACMM_OK);
                assert_int_equal(aacmm_point_jacobian_q(&m.mq, qc, pc, jc), AACMM_OK);
                assert_memory_equal(pc, pq2, sizeof pc);
                assert_memory_equal(jc, jq2, sizeof(int64_t) * (size_t)(3 * np));
            }
            for (i = 0; i < 3; i++) {
                worst_p = fmax(worst_p, fabs(Q48_TO_MM(pq[i]) - pd[i]) / scale);
            }
            for (i = 0; i < 3 * w; i++) {
                worst_j = fmax(worst_j, fabs(Q48_TO_MM(jq[i]) - jd[i]) / scale);
            }
            /* no correction, no temperatures: the plain path bit for bit */
            assert_int_equal(aacmm_point_jacobian_em_q(&m.mq, &none, bam, NULL, pq, jq), AACMM_OK);
            assert_int_equal(aacmm_point_jacobian_q(&m.mq, bam, pq2, jq2), AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            assert_memory_equal(jq, jq2, sizeof(int64_t) * 3u * (size_t)np);
            /* every link at its reference temperature: the same */
            assert_int_equal(aacmm_point_jacobian_em_q(&m.mq, &none, bam, none.tref_q8, pq, jq),
                             AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            assert_memory_equal(jq, jq2, sizeof(int64_t) * 3u * (size_t)np);
        }
        {
            /* the batch: the single calls; a bad temperature stops it */
            enum { B = 9 };
            static uint32_t thb[B * AACMM_JOINTS_MAX];
            static int32_t tb[B * AACMM_JOINTS_MAX];
            static int64_t P[B * 3], J[B * 3 * (AACMM_PARAMS_MAX + 56)];
            size_t done = 0u, l;
            for (l = 0; l < (size_t)(B * nj); l++) {
                thb[l] = (uint32_t)(rng_next(&g) >> 32);
                tb[l] = 5120 + (int32_t)(l % 7u) * 300;
            }
            assert_int_equal(aacmm_batch_bam_em_q(&m.mq, &emq, B, thb, tb, P, J, &done), AACMM_OK);
            assert_int_equal((int)done, B);
            for (l = 0; l < B; l++) {
                int64_t p[3], j[3 * (AACMM_PARAMS_MAX + 56)];
                assert_int_equal(aacmm_point_jacobian_em_q(&m.mq, &emq, thb + (size_t)nj * l,
                                                           tb + (size_t)nj * l, p, j),
                                 AACMM_OK);
                assert_memory_equal(p, P + 3 * l, sizeof p);
                assert_memory_equal(j, J + (size_t)(3 * w) * l, sizeof(int64_t) * 3u * (size_t)w);
            }
            tb[nj * 5 + 1] = AACMM_Q_TEMP_MAX + 1;
            assert_int_equal(aacmm_batch_bam_em_q(&m.mq, &emq, B, thb, tb, P, NULL, &done),
                             AACMM_ERR_RANGE);
            assert_int_equal((int)done, 5);
        }
    }
    print_message("error model, fixed vs double: worst point %.3g mm, Jacobian %.3g (bounds %g, %g)\n",
                  worst_p, worst_j, BOUND_POINT_MM, BOUND_JAC);
    assert_true(worst_p <= BOUND_POINT_MM);
    assert_true(worst_j <= BOUND_JAC);
    {
        /* validation and conversion */
        aacmm_errmodel_q_t e;
        aacmm_errmodel_f64_t d;
        aacmm_model_q_t mq, out;
        int32_t temps[6] = {5120, 5120, 5120, 5120, 5120, 5120};
        uint32_t bam[6] = {0u, 1u, 2u, 3u, 4u, 5u};
        int64_t p[3];
        double tc[2] = {20.0, 0.0};
        int32_t tq[2];
        assert_int_equal(aacmm_model_q_init_arm(&mq, &(aacmm_arm_q_t){0}), AACMM_ERR_RANGE);
        {
            aacmm_arm_q_t aq;
            assert_int_equal(aacmm_arm_default_q(&aq), AACMM_OK);
            assert_int_equal(aacmm_model_q_init_arm(&mq, &aq), AACMM_OK);
        }
        assert_int_equal(aacmm_errmodel_q_default(&e, 3), AACMM_ERR_RANGE);
        assert_int_equal(aacmm_errmodel_q_default(&e, 6), AACMM_OK);
        assert_int_equal(aacmm_point_em_q(&mq, &e, bam, temps, p), AACMM_OK);
        e.harmonics[1] = 5;
        assert_int_equal(aacmm_errmodel_q_validate(&e), AACMM_ERR_RANGE);
        assert_int_equal(aacmm_point_em_q(&mq, &e, bam, temps, p), AACMM_ERR_RANGE);
        e.harmonics[1] = 2;
        e.c_q36[1][0] = AACMM_Q_HARMONIC_SUM_MAX;
        assert_int_equal(aacmm_errmodel_q_validate(&e), AACMM_OK);
        e.s_q36[1][1] = 1;
        assert_int_equal(aacmm_errmodel_q_validate(&e), AACMM_ERR_RANGE);
        e.s_q36[1][1] = 0;
        e.c_q36[1][2] = 1; /* past K */
        assert_int_equal(aacmm_errmodel_q_validate(&e), AACMM_ERR_RANGE);
        e.c_q36[1][2] = 0;
        e.cte_q40[0] = AACMM_Q_CTE_MAX + 1;
        assert_int_equal(aacmm_errmodel_q_validate(&e), AACMM_ERR_RANGE);
        e.cte_q40[0] = 0;
        temps[3] = AACMM_Q_TEMP_MIN - 1;
        assert_int_equal(aacmm_point_em_q(&mq, &e, bam, temps, p), AACMM_ERR_RANGE);
        assert_int_equal(aacmm_model_q_at_temperature(&out, &mq, &e, temps), AACMM_ERR_RANGE);
        temps[3] = AACMM_Q_TEMP_MAX;
        assert_int_equal(aacmm_model_q_at_temperature(&out, &mq, &e, temps), AACMM_OK);
        e.joints = 5;
        assert_int_equal(aacmm_point_em_q(&mq, &e, bam, temps, p), AACMM_ERR_RANGE);
        assert_int_equal(aacmm_errmodel_default_f64(&d, 6), AACMM_OK);
        d.harmonics[0] = 1;
        d.c_rad[0][0] = (double)NAN;
        assert_int_equal(aacmm_errmodel_q_from_f64(&e, &d), AACMM_ERR_NOT_FINITE);
        tc[1] = (double)NAN;
        assert_int_equal(aacmm_temp_q8_from_f64(tq, tc, 2u), AACMM_ERR_NOT_FINITE);
        tc[1] = 85.01;
        assert_int_equal(aacmm_temp_q8_from_f64(tq, tc, 2u), AACMM_ERR_RANGE);
        tc[1] = -12.5;
        assert_int_equal(aacmm_temp_q8_from_f64(tq, tc, 2u), AACMM_OK);
        assert_int_equal(tq[0], 5120);
        assert_int_equal(tq[1], -3200);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_validation_and_conversion),
        cmocka_unit_test(test_every_arm),
        cmocka_unit_test(test_shipped_vs_reference),
        cmocka_unit_test(test_batches),
        cmocka_unit_test(test_error_model),
    };
    return cmocka_run_group_tests_name("fixed point, general arm model", tests, NULL, NULL);
}
