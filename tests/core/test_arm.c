/*
 * Tests of the general arm model (issue 26): N = 4 .. 7 joints, standard and
 * modified DH, Hayati betas, tip l or a tip vector, on every path of the
 * floating-point core (per-pose f64 and f32, batches, every batch kernel
 * across SIMD lanes in both Jacobian layouts, the analysis sums and the
 * perturbed points), against the independent reference of
 * tests/core/reference_arm.h (4x4 products in complex long double, the
 * Jacobian by complex step). The paper's arm itself is held bit for bit to
 * the core before the general model by test_kinematics.c's golden tests.
 *
 * Every bound is printed with its measured value; CORE_TEST_DIV (the
 * sanitizer build) divides the pose counts.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "reference_arm.h"

#define PI 3.14159265358979323846

#ifndef CORE_TEST_DIV
#define CORE_TEST_DIV 1
#endif

/* The bound in double: point and Jacobian entries within 1e-12 (mm,
 * mm/rad, mm/mm) of the reference, or within 4 units in the last place of
 * the arm's reach R where that is coarser: for R from 2048 to 4096 mm one
 * unit is 4.5e-13, and the points and angle columns, of magnitude up to R,
 * carry a few roundings of that size however they are formed (measured on
 * the 7-axis shape, 2.8 m, over 2 10^4 poses: point 1.18e-12, Jacobian
 * 1.5e-12, about 3 units; compensated sums of the origins took the point to
 * 0.65e-12 but the Jacobian only to 1.14e-12, its cross products' own
 * rounding, so they are not used). The paper's arm is within 1e-12. */
#define BOUND_F64_MM 1e-12
#define BOUND_F64_ULPS 4.0
/* Single precision: today's classes for the paper's arm (1e-3 mm per point
 * coordinate, 2e-3 per Jacobian entry against double, reach 2290.4 mm),
 * scaled by the arm's reach where it is longer. */
#define PAPER_REACH_MM 2290.4
#define BOUND_F32_POINT_MM 1e-3
#define BOUND_F32_JAC 2e-3
/* Kernels with FMA against the scalar one: as test_kinematics.c. */
#define BOUND_SIMD 1e-12

/* max(1e-12, 4 ulp(R)) for the arm's reach R. */
static double bound_f64(const aacmm_arm_f64_t *arm)
{
    int e;
    (void)frexp(ref_arm_reach(arm), &e); /* R = f 2^e, 1/2 <= f < 1: ulp(R) = 2^(e - 53) */
    return fmax(BOUND_F64_MM, BOUND_F64_ULPS * ldexp(1.0, e - 53));
}

static double reach_scale(const aacmm_arm_f64_t *arm)
{
    const double r = ref_arm_reach(arm) / PAPER_REACH_MM;
    return r > 1.0 ? r : 1.0;
}

static void random_poses(test_rng_t *g, double *th, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        th[i] = rng_uniform(g, -PI, PI);
    }
}

static void arm_to_f32(const aacmm_arm_f64_t *a, aacmm_arm_f32_t *f)
{
    int i;
    f->shape = a->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        f->theta_offset_rad[i] = (float)a->theta_offset_rad[i];
        f->alpha_rad[i] = (float)a->alpha_rad[i];
        f->d_mm[i] = (float)a->d_mm[i];
        f->a_mm[i] = (float)a->a_mm[i];
        f->beta_rad[i] = (float)a->beta_rad[i];
    }
    for (i = 0; i < 3; i++) {
        f->tip_mm[i] = (float)a->tip_mm[i];
    }
}

/* The float arm widened back to double (the values single precision runs). */
static void arm_from_f32(const aacmm_arm_f32_t *f, aacmm_arm_f64_t *a)
{
    int i;
    a->shape = f->shape;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        a->theta_offset_rad[i] = (double)f->theta_offset_rad[i];
        a->alpha_rad[i] = (double)f->alpha_rad[i];
        a->d_mm[i] = (double)f->d_mm[i];
        a->a_mm[i] = (double)f->a_mm[i];
        a->beta_rad[i] = (double)f->beta_rad[i];
    }
    for (i = 0; i < 3; i++) {
        a->tip_mm[i] = (double)f->tip_mm[i];
    }
}

/* ------------------------------------------------------------------------ */

/* Double precision, per pose, against the reference: point and Jacobian
 * within bound_f64 for every arm (the arms of the paper's shape among the
 * random ones run the paper's chain, the others the general chain); the
 * shipped shapes over more poses. */
static void test_f64_vs_reference(void **state)
{
    double worst = 0.0; /* the largest error in units of its arm's bound */
    double worst_p = 0.0, worst_j = 0.0;
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k++) {
        aacmm_arm_f64_t arm;
        aacmm_model_f64_t m;
        char label[80];
        test_rng_t g = {UINT64_C(0x1234) + (uint64_t)k};
        double arm_p = 0.0, arm_j = 0.0;
        int np, t, c, r, poses;
        ref_test_arm(k, &arm, label, sizeof label);
        poses = (k >= N_RANDOM_ARMS ? 2000 : 120) / CORE_TEST_DIV;
        assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
        np = (int)m.n_params;
        assert_int_equal(np, aacmm_shape_params(&arm.shape));
        assert_int_equal(m.paper, aacmm_shape_is_paper(&arm.shape));
        for (t = 0; t < poses; t++) {
            double th[AACMM_JOINTS_MAX], p[3], p2[3], J[AACMM_JAC_SIZE_MAX];
            long double q[AACMM_PARAMS_MAX], pr[3], Jr[AACMM_JAC_SIZE_MAX];
            random_poses(&g, th, arm.shape.joints);
            assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            assert_int_equal(aacmm_point_f64(&m, th, p2), AACMM_OK);
            assert_memory_equal(p, p2, sizeof p);
            ref_arm_vector(&arm, th, q);
            ref_arm_point_jacobian(&arm.shape, q, pr, Jr);
            for (r = 0; r < 3; r++) {
                arm_p = fmax(arm_p, (double)fabsl((long double)p[r] - pr[r]));
                for (c = 0; c < np; c++) {
                    arm_j = fmax(arm_j, (double)fabsl((long double)J[r * np + c] - Jr[r * np + c]));
                }
            }
        }
        if (k >= N_RANDOM_ARMS || getenv("AACMM_TEST_VERBOSE") != NULL) {
            printf("measured: f64 vs reference, %s (P = %d, reach %.0f mm), %d poses: point "
                   "max %.3g mm, Jacobian max %.3g (bound %.3g)\n",
                   label, np, ref_arm_reach(&arm), poses, arm_p, arm_j, bound_f64(&arm));
        }
        worst_p = fmax(worst_p, arm_p);
        worst_j = fmax(worst_j, arm_j);
        worst = fmax(worst, fmax(arm_p, arm_j) / bound_f64(&arm));
    }
    printf("measured: f64 vs reference, %d random arms (N = 4..7, standard/modified/mixed, "
           "+-beta, tip z/xyz; reach up to 3 m) and 3 shipped shapes: point max %.3g mm, "
           "Jacobian max %.3g; largest error %.3g of its arm's bound (max(1e-12, 4 ulp of the "
           "reach))\n",
           N_RANDOM_ARMS, worst_p, worst_j, worst);
    assert_true(worst <= 1.0);
}

/* The paper's arm against the same reference, on its own chain and on the
 * general one: within 1e-12 flat (the bound; its reach, 2290 mm, is
 * the scale of the paper's tests). */
static void test_paper_vs_reference(void **state)
{
    const int poses = 2000 / CORE_TEST_DIV;
    double worst[2] = {0.0, 0.0};
    int general;
    (void)state;
    for (general = 0; general < 2; general++) {
        aacmm_arm_f64_t arm;
        aacmm_model_f64_t m;
        test_rng_t g = {UINT64_C(0xBEEF)};
        int t, c, r;
        assert_int_equal(aacmm_arm_default_f64(&arm), AACMM_OK);
        assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
        assert_int_equal(m.paper, 1);
        if (general) {
            m.paper = 0; /* tests only: run the general chain */
        }
        for (t = 0; t < poses; t++) {
            double th[6], p[3], J[AACMM_JAC_SIZE];
            long double q[AACMM_JAC_COLS], pr[3], Jr[AACMM_JAC_SIZE];
            random_poses(&g, th, 6);
            assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            ref_arm_vector(&arm, th, q);
            ref_arm_point_jacobian(&arm.shape, q, pr, Jr);
            for (r = 0; r < 3; r++) {
                worst[general] = fmax(worst[general], (double)fabsl((long double)p[r] - pr[r]));
                for (c = 0; c < AACMM_JAC_COLS; c++) {
                    worst[general] =
                        fmax(worst[general],
                             (double)fabsl((long double)J[r * AACMM_JAC_COLS + c] -
                                           Jr[r * AACMM_JAC_COLS + c]));
                }
            }
        }
    }
    printf("measured: the paper's arm vs the reference, %d poses: max %.3g (its chain), %.3g "
           "(the general chain), point and Jacobian (bound 1e-12)\n",
           poses, worst[0], worst[1]);
    assert_true(worst[0] <= BOUND_F64_MM && worst[1] <= BOUND_F64_MM);
}

/* The Jacobian against central differences of the core's own point: an
 * independent check of the column order and of each column's meaning (the
 * difference takes the parameter through aacmm_arm_set_vector_f64). */
static void test_f64_vs_central_differences(void **state)
{
    const int poses = 40 / CORE_TEST_DIV;
    double worst = 0.0;
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k++) {
        aacmm_arm_f64_t arm;
        aacmm_model_f64_t m;
        char label[80];
        test_rng_t g = {UINT64_C(0x777) + (uint64_t)k};
        int np, t, c, r;
        ref_test_arm(k, &arm, label, sizeof label);
        assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
        np = (int)m.n_params;
        for (t = 0; t < poses; t++) {
            double th[AACMM_JOINTS_MAX], p[3], J[AACMM_JAC_SIZE_MAX], v[AACMM_PARAMS_MAX];
            random_poses(&g, th, arm.shape.joints);
            assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            assert_int_equal(aacmm_arm_get_vector_f64(&arm, v), AACMM_OK);
            for (c = 0; c < np; c++) {
                const int angle = c < 2 * (int)arm.shape.joints ||
                                  (c >= 4 * (int)arm.shape.joints && c < m.col_tip);
                const double h = angle ? 1e-6 : 1e-3;
                double fp[3], fm[3];
                int sgn;
                for (sgn = 0; sgn < 2; sgn++) {
                    aacmm_arm_f64_t a2 = arm;
                    aacmm_model_f64_t m2;
                    double v2[AACMM_PARAMS_MAX];
                    memcpy(v2, v, sizeof v2);
                    v2[c] += sgn ? -h : h;
                    assert_int_equal(aacmm_arm_set_vector_f64(&a2, v2), AACMM_OK);
                    assert_int_equal(aacmm_model_init_arm_f64(&m2, &a2), AACMM_OK);
                    assert_int_equal(aacmm_point_f64(&m2, th, sgn ? fm : fp), AACMM_OK);
                }
                for (r = 0; r < 3; r++) {
                    worst = fmax(worst, fabs((fp[r] - fm[r]) / (2.0 * h) - J[r * np + c]));
                }
            }
        }
    }
    printf("measured: f64 Jacobian vs central differences of the f64 point, %d arms x %d "
           "poses: max %.3g (bound 1e-6: the rounding of the quotient)\n",
           N_ARMS, poses, worst);
    assert_true(worst <= 1e-6);
}

/* The d, a and tip columns are unit vectors; dp_z/dtheta_1 is exactly 0 for
 * a standard joint 1; a parallel pair's theta columns show the ill-defined
 * DH direction the beta resolves (checked in the calibration of part C). */
static void test_identities(void **state)
{
    double worst = 0.0;
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k++) {
        aacmm_arm_f64_t arm;
        aacmm_model_f64_t m;
        char label[80];
        test_rng_t g = {UINT64_C(0x99) + (uint64_t)k};
        int np, n, t, c;
        ref_test_arm(k, &arm, label, sizeof label);
        assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
        np = (int)m.n_params;
        n = (int)arm.shape.joints;
        for (t = 0; t < 200; t++) {
            double th[AACMM_JOINTS_MAX], p[3], J[AACMM_JAC_SIZE_MAX];
            random_poses(&g, th, n);
            assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            for (c = 2 * n; c < np; c++) {
                if (c >= 4 * n && c < m.col_tip) {
                    continue; /* the beta columns are rotations */
                }
                worst = fmax(worst, fabs(sqrt(J[c] * J[c] + J[np + c] * J[np + c] +
                                              J[2 * np + c] * J[2 * np + c]) -
                                         1.0));
            }
            if (arm.shape.convention[0] == AACMM_DH_STANDARD) {
                assert_true(fabs(J[2 * np + 0]) <= 0.0);
            }
        }
    }
    printf("measured: | |column| - 1 | for the d, a and tip columns: max %.3g\n", worst);
    assert_true(worst <= 1e-12);
}

/* Hand-worked: a 4-joint standard arm, all theta and alpha 0, a_i = 100 mm,
 * d_i = 10 mm, tip (1, 2, 3): every frame is the base frame, so p = (400 +
 * 1, 2, 40 + 3); with beta_3 = 90 deg (joint 3 tilted about y before its
 * Rz) the frames from joint 3 on have x = -z_0, z = x_0: o_2 = (200, 0, 20),
 * then o_3 = o_2 + d_3 z + a_3 x = (210, 0, -80), o_4 = (220, 0, -180),
 * p = o_4 + 1 x + 2 y + 3 z = (223, 2, -181). The same arm in modified DH
 * (Rx Tx [Ry] Rz Tz: a first) gives the same point without beta, and with
 * it o after Tx(a_3) = (300, 0, 20), Ry: x = -z_0, z = x_0, o_3 = (310, 0,
 * 20), Tx(a_4): (310, 0, -80), Tz(d_4): (320, 0, -80), p = (323, 2, -81). */
static void test_hand_worked(void **state)
{
    static const double want[4][3] = {
        {401, 2, 43}, {223, 2, -181}, {401, 2, 43}, {323, 2, -81}};
    int conv, beta, i, r;
    (void)state;
    for (conv = 0; conv < 2; conv++) {
        for (beta = 0; beta < 2; beta++) {
            aacmm_arm_f64_t arm;
            aacmm_model_f64_t m;
            const double th[4] = {0, 0, 0, 0};
            double p[3], J[AACMM_JAC_SIZE_MAX];
            memset(&arm, 0, sizeof arm);
            arm.shape.joints = 4;
            arm.shape.tip = AACMM_TIP_XYZ;
            for (i = 0; i < 4; i++) {
                arm.shape.convention[i] = (uint8_t)conv;
                arm.a_mm[i] = 100.0;
                arm.d_mm[i] = 10.0;
            }
            if (beta) {
                arm.shape.beta[2] = 1;
                arm.beta_rad[2] = PI / 2;
            }
            arm.tip_mm[0] = 1.0;
            arm.tip_mm[1] = 2.0;
            arm.tip_mm[2] = 3.0;
            assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
            assert_int_equal(m.n_params, 16 + beta + 3);
            assert_int_equal(m.col_tip, 16 + beta);
            assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            for (r = 0; r < 3; r++) {
                assert_true(fabs(p[r] - want[2 * conv + beta][r]) < 1e-9);
            }
            if (beta) {
                /* d p / d beta_3 = y x (p - o) at the rotation: y = (0, 1, 0),
                 * o = o_2 (standard) or o_2 + a_3 x (modified) */
                const double o_x = conv ? 300.0 : 200.0;
                const double w[3] = {p[0] - o_x, p[1], p[2] - 20.0};
                const double db[3] = {w[2], 0.0, -w[0]};
                for (r = 0; r < 3; r++) {
                    assert_true(fabs(J[r * m.n_params + 16] - db[r]) < 1e-9);
                }
            }
        }
    }
}

/* Single precision against double on the same float-rounded numbers, every
 * arm: within today's classes scaled by the arm's reach. */
static void test_f32_vs_f64(void **state)
{
    const int poses = 5000 / CORE_TEST_DIV;
    double worst_p = 0.0, worst_j = 0.0; /* in units of the scaled bound */
    int k;
    (void)state;
    for (k = 0; k < N_ARMS; k++) {
        aacmm_arm_f64_t arm, arm64;
        aacmm_arm_f32_t arm32;
        aacmm_model_f64_t md;
        aacmm_model_f32_t mf;
        char label[80];
        test_rng_t g = {UINT64_C(0x2024) + (uint64_t)k};
        double sp = 0.0, sj = 0.0, scale;
        int np, t, i;
        ref_test_arm(k, &arm, label, sizeof label);
        arm_to_f32(&arm, &arm32);
        arm_from_f32(&arm32, &arm64);
        scale = reach_scale(&arm64);
        assert_int_equal(aacmm_model_init_arm_f32(&mf, &arm32), AACMM_OK);
        assert_int_equal(aacmm_model_init_arm_f64(&md, &arm64), AACMM_OK);
        np = (int)md.n_params;
        for (t = 0; t < poses; t++) {
            double thd[AACMM_JOINTS_MAX], p64[3], J64[AACMM_JAC_SIZE_MAX];
            float thf[AACMM_JOINTS_MAX], p32[3], J32[AACMM_JAC_SIZE_MAX];
            for (i = 0; i < (int)arm.shape.joints; i++) {
                thf[i] = (float)rng_uniform(&g, -PI, PI);
                thd[i] = (double)thf[i];
            }
            assert_int_equal(aacmm_point_jacobian_f64(&md, thd, p64, J64), AACMM_OK);
            assert_int_equal(aacmm_point_jacobian_f32(&mf, thf, p32, J32), AACMM_OK);
            for (i = 0; i < 3; i++) {
                sp = fmax(sp, fabs((double)p32[i] - p64[i]));
            }
            for (i = 0; i < 3 * np; i++) {
                sj = fmax(sj, fabs((double)J32[i] - J64[i]));
            }
        }
        if (k >= N_RANDOM_ARMS) {
            printf("measured: f32 vs f64, %s, %d poses: point max %.3g mm (bound %.3g), "
                   "Jacobian max %.3g (bound %.3g)\n",
                   label, poses, sp, BOUND_F32_POINT_MM * scale, sj, BOUND_F32_JAC * scale);
        }
        worst_p = fmax(worst_p, sp / (BOUND_F32_POINT_MM * scale));
        worst_j = fmax(worst_j, sj / (BOUND_F32_JAC * scale));
    }
    printf("measured: f32 vs f64, %d arms x %d poses: point max %.3g, Jacobian max %.3g of "
           "today's bound scaled by reach\n",
           N_ARMS, poses, worst_p, worst_j);
    assert_true(worst_p <= 1.0);
    assert_true(worst_j <= 1.0);
}

/* ------------------------------------------------------------------------ */
/* Batches and kernels                                                       */
/* ------------------------------------------------------------------------ */

static double rel_diff(const double *a, const double *b, size_t n)
{
    double worst = 0.0;
    size_t i;
    for (i = 0; i < n; i++) {
        worst = fmax(worst, fabs(a[i] - b[i]) / fmax(1.0, fabs(b[i])));
    }
    return worst;
}

/* Every kernel and both layouts against the per-pose core, for every arm:
 * batches of odd sizes (full groups and tails) equal pose-by-pose results
 * bit for bit for the kernels without FMA, within 1e-12 for those with;
 * single precision within the scaled f32 bound (bit for bit without FMA);
 * the tiled layout equal to the row-major one bit for bit, padding lanes
 * copying the last pose; the fused sums within 1e-12 relative; a bad pose
 * stops every batch at its index. */
static void test_kernels(void **state)
{
    enum { B = 203 };
    static double th[B * AACMM_JOINTS_MAX], P0[B * 3], P1[B * 3], J0[B * AACMM_JAC_SIZE_MAX],
        J1[B * AACMM_JAC_SIZE_MAX], Jt[AACMM_SIMD_TILED_ENTRIES(B, 8u, AACMM_PARAMS_MAX) + 1];
    static float thf[B * AACMM_JOINTS_MAX], Pf0[B * 3], Pf1[B * 3],
        Jf0[B * AACMM_JAC_SIZE_MAX], Jf1[B * AACMM_JAC_SIZE_MAX],
        Jft[AACMM_SIMD_TILED_ENTRIES(B, 16u, AACMM_PARAMS_MAX) + 1];
    double worst_p = 0.0, worst_j = 0.0, worst_f = 0.0, worst_s = 0.0;
    int kk;
    (void)state;
    for (kk = 0; kk < AACMM_KERNEL_COUNT; kk++) {
        const aacmm_kernel_t kern = (aacmm_kernel_t)kk;
        const int fused = aacmm_kernel_fused(kern);
        int k;
        if (!aacmm_kernel_available(kern)) {
            printf("kernel %s: not available on this CPU\n", aacmm_kernel_name(kern));
            continue;
        }
        for (k = 0; k < N_ARMS; k += (CORE_TEST_DIV > 1 ? 5 : 1)) {
            aacmm_arm_f64_t arm, arm64;
            aacmm_arm_f32_t arm32;
            aacmm_model_f64_t m, m64;
            aacmm_model_f32_t mf;
            char label[80];
            test_rng_t g = {UINT64_C(0x51) + (uint64_t)k};
            size_t done = 0u, l, e, jn, nj;
            double s0[AACMM_JAC_SIZE_MAX] = {0}, q0[AACMM_JAC_SIZE_MAX] = {0};
            double s1[AACMM_JAC_SIZE_MAX] = {0}, q1[AACMM_JAC_SIZE_MAX] = {0};
            int n, off;
            ref_test_arm(k, &arm, label, sizeof label);
            arm_to_f32(&arm, &arm32);
            arm_from_f32(&arm32, &arm64);
            assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
            assert_int_equal(aacmm_model_init_arm_f64(&m64, &arm64), AACMM_OK);
            assert_int_equal(aacmm_model_init_arm_f32(&mf, &arm32), AACMM_OK);
            nj = arm.shape.joints;
            jn = 3u * m.n_params;
            random_poses(&g, th, (int)(B * nj));
            for (l = 0; l < B * nj; l++) {
                thf[l] = (float)th[l];
            }
            /* the per-pose core */
            for (l = 0; l < B; l++) {
                assert_int_equal(aacmm_point_jacobian_f64(&m, th + l * nj, P0 + 3 * l, J0 + jn * l),
                                 AACMM_OK);
                assert_int_equal(aacmm_point_jacobian_f32(&mf, thf + l * nj, Pf0 + 3 * l,
                                                          Jf0 + jn * l),
                                 AACMM_OK);
            }
            /* row-major, in batches of every size from the start and at offsets */
            for (off = 0; off < 3; off++) {
                for (n = 0; n + off <= B; n += (n < 20 ? 1 : 37)) {
                    assert_int_equal(aacmm_simd_batch_angles_f64(kern, &m, (size_t)n,
                                                                 th + nj * (size_t)off, P1, J1,
                                                                 &done),
                                     AACMM_OK);
                    assert_int_equal((int)done, n);
                    for (l = 0; l < 3u * (size_t)n; l++) {
                        worst_p = fmax(worst_p, fabs(P1[l] - P0[3 * (size_t)off + l]));
                    }
                    worst_j = fmax(worst_j, rel_diff(J1, J0 + jn * (size_t)off, jn * (size_t)n));
                    if (!fused) {
                        assert_memory_equal(P1, P0 + 3 * off, sizeof(double) * 3u * (size_t)n);
                        assert_memory_equal(J1, J0 + jn * (size_t)off,
                                            sizeof(double) * jn * (size_t)n);
                    }
                    assert_int_equal(aacmm_simd_batch_angles_f32(kern, &mf, (size_t)n,
                                                                 thf + nj * (size_t)off, Pf1,
                                                                 Jf1, &done),
                                     AACMM_OK);
                    for (l = 0; l < 3u * (size_t)n; l++) {
                        worst_f = fmax(worst_f, fabs((double)Pf1[l] - (double)Pf0[3 * (size_t)off + l]) /
                                                    (BOUND_F32_POINT_MM * reach_scale(&arm64)));
                    }
                    for (l = 0; l < jn * (size_t)n; l++) {
                        worst_f = fmax(worst_f,
                                       fabs((double)Jf1[l] - (double)Jf0[jn * (size_t)off + l]) /
                                           (BOUND_F32_JAC * reach_scale(&arm64)));
                    }
                    if (!fused) {
                        assert_memory_equal(Pf1, Pf0 + 3 * off, sizeof(float) * 3u * (size_t)n);
                        assert_memory_equal(Jf1, Jf0 + jn * (size_t)off,
                                            sizeof(float) * jn * (size_t)n);
                    }
                }
            }
            /* points only: the same points */
            assert_int_equal(aacmm_simd_batch_angles_f64(kern, &m, B, th, P1, J1, NULL), AACMM_OK);
            assert_int_equal(aacmm_simd_batch_angles_f64(kern, &m, B, th, P0, NULL, NULL),
                             AACMM_OK);
            assert_memory_equal(P0, P1, sizeof(double) * 3u * B);
            assert_int_equal(aacmm_simd_batch_angles_f32(kern, &mf, B, thf, Pf1, Jf1, NULL),
                             AACMM_OK);
            /* tiled == row-major with the same kernel, bit for bit, at an
             * aligned and an unaligned output; padding lanes copy the last pose */
            for (off = 0; off < 2; off++) {
                for (n = 1; n <= B; n += (n < 40 ? 1 : 29)) {
                    const size_t tf = 8u, tg = 16u;
                    assert_int_equal(aacmm_simd_batch_angles_tiled_f64(kern, &m, (size_t)n, th, P0,
                                                                       Jt + off, &done),
                                     AACMM_OK);
                    assert_int_equal((int)done, n);
                    assert_memory_equal(P0, P1, sizeof(double) * 3u * (size_t)n);
                    for (l = 0; l < ((size_t)n + tf - 1u) / tf * tf; l++) {
                        const size_t src = l < (size_t)n ? l : (size_t)n - 1u;
                        for (e = 0; e < jn; e++) {
                            assert_memory_equal(&Jt[(size_t)off + (l / tf) * tf * jn + e * tf + l % tf],
                                                &J1[src * jn + e], sizeof(double));
                        }
                    }
                    assert_int_equal(aacmm_simd_batch_angles_tiled_f32(kern, &mf, (size_t)n, thf,
                                                                       Pf0, Jft + off, &done),
                                     AACMM_OK);
                    assert_memory_equal(Pf0, Pf1, sizeof(float) * 3u * (size_t)n);
                    for (l = 0; l < ((size_t)n + tg - 1u) / tg * tg; l++) {
                        const size_t src = l < (size_t)n ? l : (size_t)n - 1u;
                        for (e = 0; e < jn; e++) {
                            assert_memory_equal(&Jft[(size_t)off + (l / tg) * tg * jn + e * tg + l % tg],
                                                &Jf1[src * jn + e], sizeof(float));
                        }
                    }
                }
            }
            /* the fused sums against the scalar ones, and the scaled form */
            assert_int_equal(aacmm_abs_jacobian_sums_f64(&m, B, th, s0, q0, NULL), AACMM_OK);
            assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kern, &m, B, th, s1, q1, &done),
                             AACMM_OK);
            assert_int_equal((int)done, B);
            for (e = 0; e < jn; e++) {
                worst_s = fmax(worst_s, fabs(s1[e] - s0[e]) / fmax(1.0, s0[e]));
                worst_s = fmax(worst_s, fabs(q1[e] - q0[e]) / fmax(1.0, q0[e]));
            }
            {
                double scale[AACMM_JOINTS_MAX], offset[AACMM_JOINTS_MAX];
                static double unit[B * AACMM_JOINTS_MAX], formed[B * AACMM_JOINTS_MAX];
                double s2[AACMM_JAC_SIZE_MAX] = {0}, q2[AACMM_JAC_SIZE_MAX] = {0};
                double s3[AACMM_JAC_SIZE_MAX] = {0}, q3[AACMM_JAC_SIZE_MAX] = {0};
                for (l = 0; l < nj; l++) {
                    scale[l] = 6.2 - 0.1 * (double)l;
                    offset[l] = -3.1 + 0.1 * (double)l;
                }
                for (l = 0; l < B * nj; l++) {
                    unit[l] = (double)(uint32_t)rng_next(&g) * 0x1p-32;
                    formed[l] = unit[l] * scale[l % nj];
                    formed[l] += offset[l % nj];
                }
                assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kern, &m, B, formed, s2, q2,
                                                                  NULL),
                                 AACMM_OK);
                assert_int_equal(aacmm_simd_abs_jacobian_sums_scaled_f64(kern, &m, B, unit, scale,
                                                                         offset, s3, q3, NULL),
                                 AACMM_OK);
                assert_memory_equal(s2, s3, sizeof s2);
                assert_memory_equal(q2, q3, sizeof q2);
            }
            /* the first bad pose stops every batch */
            th[nj * 77 + nj - 1] = (double)NAN;
            assert_int_equal(aacmm_simd_batch_angles_f64(kern, &m, B, th, P1, J1, &done),
                             AACMM_ERR_NOT_FINITE);
            assert_int_equal((int)done, 77);
            assert_int_equal(aacmm_simd_batch_angles_tiled_f64(kern, &m, B, th, P1, Jt, &done),
                             AACMM_ERR_NOT_FINITE);
            assert_int_equal((int)done, 77);
            assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kern, &m, B, th, s1, q1, &done),
                             AACMM_ERR_NOT_FINITE);
            assert_int_equal((int)done, 77);
            thf[nj * 5] = 2000.0f;
            assert_int_equal(aacmm_simd_batch_angles_f32(kern, &mf, B, thf, Pf1, Jf1, &done),
                             AACMM_ERR_RANGE);
            assert_int_equal((int)done, 5);
        }
    }
    printf("measured: kernels vs the per-pose core, general arms: point max %.3g mm, Jacobian "
           "max %.3g (relative to max(1, |entry|); 0 without FMA, asserted); f32 max %.3g of the "
           "scaled bound; |J| sums max %.3g relative\n",
           worst_p, worst_j, worst_f, worst_s);
    assert_true(worst_p <= BOUND_SIMD);
    assert_true(worst_j <= BOUND_SIMD);
    assert_true(worst_f <= 1.0);
    assert_true(worst_s <= 1e-12);
}

/* Counts batches and the analysis helpers for general arms: counts ->
 * angles -> point equals the per-pose conversion and core; the perturbed
 * points equal a model built from nominal + delta, on every kernel. */
static void test_counts_and_analysis(void **state)
{
    enum { B = 37, T = 5 };
    int k, kk;
    (void)state;
    for (k = 0; k < N_ARMS; k += 3) {
        aacmm_arm_f64_t arm;
        aacmm_model_f64_t m;
        aacmm_arm_encoders_t enc;
        char label[80];
        test_rng_t g = {UINT64_C(0x3141) + (uint64_t)k};
        static uint32_t counts[B * AACMM_JOINTS_MAX];
        static double th[B * AACMM_JOINTS_MAX], P[B * 3], J[B * AACMM_JAC_SIZE_MAX];
        static double delta[T * AACMM_PARAMS_MAX], Pp[T * B * 3], Pq[T * B * 3];
        size_t done = 0u, l, nj, np;
        int i;
        ref_test_arm(k, &arm, label, sizeof label);
        assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
        nj = arm.shape.joints;
        np = m.n_params;
        assert_int_equal(aacmm_arm_encoders_default(&enc, (int)nj), AACMM_OK);
        enc.counts_per_rev[nj - 1] = 3600u;
        enc.zero_offset_counts[0] = 17u;
        enc.direction[1] = -1;
        for (l = 0; l < B * nj; l++) {
            counts[l] = (uint32_t)rng_next(&g);
            if (l % nj == nj - 1) {
                counts[l] %= 3600u;
            }
        }
        assert_int_equal(aacmm_batch_counts_f64(&m, &enc, B, counts, P, J, &done), AACMM_OK);
        assert_int_equal((int)done, B);
        assert_int_equal(aacmm_counts_to_angles_f64(&enc, B, counts, th, &done), AACMM_OK);
        for (l = 0; l < B; l++) {
            double a[AACMM_JOINTS_MAX], p[3], Jk[AACMM_JAC_SIZE_MAX];
            assert_int_equal(aacmm_arm_encoders_to_angles_f64(&enc, counts + nj * l, a), AACMM_OK);
            assert_memory_equal(a, th + nj * l, sizeof(double) * nj);
            assert_int_equal(aacmm_point_jacobian_f64(&m, a, p, Jk), AACMM_OK);
            assert_memory_equal(p, P + 3 * l, sizeof p);
            assert_memory_equal(Jk, J + 3 * np * l, sizeof(double) * 3 * np);
        }
        /* encoders of another joint count: refused */
        enc.joints = (uint8_t)(nj == 7 ? 6 : nj + 1);
        assert_int_equal(aacmm_batch_counts_f64(&m, &enc, B, counts, P, J, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 0);
        enc.joints = (uint8_t)nj;
        counts[nj * 9 + nj - 1] = 3600u; /* at the resolution: out of range */
        assert_int_equal(aacmm_batch_counts_f64(&m, &enc, B, counts, P, J, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 9);
        /* perturbed points */
        for (l = 0; l < T * np; l++) {
            delta[l] = rng_uniform(&g, -1e-3, 1e-3);
        }
        assert_int_equal(aacmm_perturbed_points_f64(&arm, T, delta, B, th, Pp, &done), AACMM_OK);
        assert_int_equal((int)done, T);
        for (i = 0; i < T; i++) {
            aacmm_arm_f64_t a2;
            aacmm_model_f64_t m2;
            assert_int_equal(aacmm_arm_perturb_f64(&arm, delta + (size_t)i * np, &a2), AACMM_OK);
            assert_int_equal(aacmm_model_init_arm_f64(&m2, &a2), AACMM_OK);
            for (l = 0; l < B; l++) {
                double p[3];
                assert_int_equal(aacmm_point_f64(&m2, th + nj * l, p), AACMM_OK);
                assert_memory_equal(p, Pp + ((size_t)i * B + l) * 3u, sizeof p);
            }
        }
        for (kk = 0; kk < AACMM_KERNEL_COUNT; kk++) {
            const aacmm_kernel_t kern = (aacmm_kernel_t)kk;
            if (!aacmm_kernel_available(kern)) {
                continue;
            }
            assert_int_equal(aacmm_simd_perturbed_points_f64(kern, &arm, T, delta, B, th, Pq,
                                                             &done),
                             AACMM_OK);
            assert_int_equal((int)done, T);
            if (!aacmm_kernel_fused(kern)) {
                assert_memory_equal(Pq, Pp, sizeof Pq);
            } else {
                for (l = 0; l < T * B * 3; l++) {
                    assert_true(fabs(Pq[l] - Pp[l]) <= BOUND_SIMD);
                }
            }
        }
        delta[2 * np + 2 * nj] = 1e9; /* trial 2: d_1 far out of range */
        assert_int_equal(aacmm_perturbed_points_f64(&arm, T, delta, B, th, Pp, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 2);
    }
}

/* ------------------------------------------------------------------------ */
/* Shapes, validation, vectors                                               */
/* ------------------------------------------------------------------------ */

static void test_shapes(void **state)
{
    aacmm_shape_t s;
    int i;
    (void)state;
    assert_int_equal(aacmm_shape_paper(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_shape_paper(&s), AACMM_OK);
    assert_int_equal(aacmm_shape_validate(&s), AACMM_OK);
    assert_int_equal(aacmm_shape_params(&s), AACMM_JAC_COLS);
    assert_int_equal(aacmm_shape_col_tip(&s), AACMM_COL_L);
    assert_int_equal(aacmm_shape_is_paper(&s), 1);
    for (i = 0; i < 6; i++) {
        assert_int_equal(aacmm_shape_col_beta(&s, i), -1);
        assert_int_equal(AACMM_ARM_COL_THETA(6, i), AACMM_COL_THETA(i));
        assert_int_equal(AACMM_ARM_COL_ALPHA(6, i), AACMM_COL_ALPHA(i));
        assert_int_equal(AACMM_ARM_COL_D(6, i), AACMM_COL_D(i));
        assert_int_equal(AACMM_ARM_COL_A(6, i), AACMM_COL_A(i));
    }
    assert_int_equal(AACMM_ARM_COL_TIP(6, 0), AACMM_COL_L);
    assert_int_equal(AACMM_PARAMS_MAX, 37);
    assert_int_equal(AACMM_JAC_SIZE_MAX, 111);
    /* 7 joints, betas on joints 3 and 5, tip vector: P = 28 + 2 + 3 */
    memset(&s, 0, sizeof s);
    s.joints = 7;
    s.tip = AACMM_TIP_XYZ;
    s.beta[2] = 1;
    s.beta[4] = 1;
    s.convention[6] = AACMM_DH_MODIFIED;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_OK);
    assert_int_equal(aacmm_shape_params(&s), 33);
    assert_int_equal(aacmm_shape_col_beta(&s, 2), 28);
    assert_int_equal(aacmm_shape_col_beta(&s, 4), 29);
    assert_int_equal(aacmm_shape_col_beta(&s, 3), -1);
    assert_int_equal(aacmm_shape_col_beta(&s, 7), -1);
    assert_int_equal(aacmm_shape_col_beta(&s, -1), -1);
    assert_int_equal(aacmm_shape_col_tip(&s), 30);
    assert_int_equal(aacmm_shape_is_paper(&s), 0);
    /* the largest model */
    for (i = 1; i < 7; i++) {
        s.beta[i] = 1;
    }
    assert_int_equal(aacmm_shape_params(&s), AACMM_PARAMS_MAX);
    /* bad shapes */
    s.joints = 3;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_shape_params(&s), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_shape_col_tip(&s), -1);
    s.joints = 8;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.joints = 6; /* joint 7's beta flag set past N */
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.beta[6] = 0;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE); /* joint 7's convention */
    s.convention[6] = 0;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_OK);
    s.beta[0] = 1; /* beta on joint 1 */
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.beta[0] = 0;
    s.beta[3] = 2;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.beta[3] = 1;
    s.convention[2] = 2; /* unknown convention */
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.convention[2] = 0;
    s.tip = 2; /* unknown tip kind */
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    s.tip = 0;
    assert_int_equal(aacmm_shape_validate(&s), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_shape_validate(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_shape_params(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_shape_is_paper(NULL), 0);
}

static void test_arm_validation(void **state)
{
    aacmm_arm_f64_t a, good;
    aacmm_arm_f32_t af;
    aacmm_model_f64_t m, before;
    aacmm_model_f32_t mf;
    aacmm_params_f64_t p;
    (void)state;
    assert_int_equal(aacmm_arm_default_f64(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_validate_f64(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_model_init_arm_f64(NULL, &good), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_default_f64(&good), AACMM_OK);
    assert_int_equal(aacmm_arm_validate_f64(&good), AACMM_OK);
    assert_int_equal(aacmm_model_init_arm_f64(&m, NULL), AACMM_ERR_NULL);
    /* the paper's arm from its 25 parameters, and its default, are the same */
    assert_int_equal(aacmm_params_default_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_arm_from_params_f64(&a, &p), AACMM_OK);
    assert_memory_equal(&a, &good, sizeof a);
    assert_int_equal(aacmm_model_init_arm_f64(&m, &good), AACMM_OK);
    assert_int_equal(m.paper, 1);
    assert_int_equal(m.n_params, 25);
    before = m;
#define EXPECT(field_stmt, status)                                                                 \
    do {                                                                                           \
        a = good;                                                                                  \
        field_stmt;                                                                                \
        assert_int_equal(aacmm_arm_validate_f64(&a), status);                                      \
        assert_int_equal(aacmm_model_init_arm_f64(&m, &a), status);                                \
        if ((status) != AACMM_OK) {                                                                \
            assert_memory_equal(&m, &before, sizeof m); /* unchanged on error */                   \
        }                                                                                          \
        m = before;                                                                                \
    } while (0)
    EXPECT(a.shape.joints = 3, AACMM_ERR_RANGE);
    EXPECT(a.shape.joints = 8, AACMM_ERR_RANGE);
    EXPECT(a.shape.beta[0] = 1, AACMM_ERR_RANGE);
    EXPECT(a.shape.convention[1] = 7, AACMM_ERR_RANGE);
    EXPECT(a.shape.tip = 2, AACMM_ERR_RANGE);
    EXPECT(a.d_mm[3] = (double)NAN, AACMM_ERR_NOT_FINITE);
    EXPECT(a.alpha_rad[0] = (double)INFINITY, AACMM_ERR_NOT_FINITE);
    EXPECT(a.a_mm[5] = 10000.5, AACMM_ERR_RANGE);
    EXPECT(a.theta_offset_rad[2] = -6.3, AACMM_ERR_RANGE);
    EXPECT(a.beta_rad[2] = 0.01, AACMM_ERR_RANGE);              /* no beta declared there */
    EXPECT((a.shape.beta[2] = 1, a.beta_rad[2] = 6.3), AACMM_ERR_RANGE);
    EXPECT((a.shape.beta[2] = 1, a.beta_rad[2] = (double)NAN), AACMM_ERR_NOT_FINITE);
    EXPECT(a.tip_mm[0] = 1.0, AACMM_ERR_RANGE);                 /* x with tip l */
    EXPECT(a.tip_mm[1] = (double)NAN, AACMM_ERR_NOT_FINITE);
    EXPECT(a.tip_mm[2] = -2e4, AACMM_ERR_RANGE);
    EXPECT((a.shape.tip = AACMM_TIP_XYZ, a.tip_mm[0] = 2e4), AACMM_ERR_RANGE);
    EXPECT(a.d_mm[6] = 1.0, AACMM_ERR_RANGE);                   /* past N */
    EXPECT(a.beta_rad[6] = -0.0, AACMM_OK);                     /* -0 is zero */
    EXPECT((a.shape.tip = AACMM_TIP_XYZ, a.tip_mm[0] = 5.0, a.tip_mm[1] = -3.0), AACMM_OK);
    EXPECT((a.shape.joints = 7, a.d_mm[6] = 100.0, a.shape.beta[6] = 1, a.beta_rad[6] = 1e-3),
           AACMM_OK);
#undef EXPECT
    assert_int_equal(aacmm_arm_default_f32(&af), AACMM_OK);
    af.beta_rad[3] = NAN;
    assert_int_equal(aacmm_model_init_arm_f32(&mf, &af), AACMM_ERR_NOT_FINITE);
    af.beta_rad[3] = 0.0f;
    af.shape.joints = 9;
    assert_int_equal(aacmm_model_init_arm_f32(&mf, &af), AACMM_ERR_RANGE);
}

/* a and b hold the same double (bitwise). */
static int same(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* The parameter vector: the documented column order, and a round trip. */
static void test_vectors(void **state)
{
    aacmm_arm_f64_t a, b;
    double v[AACMM_PARAMS_MAX], w[AACMM_PARAMS_MAX];
    aacmm_params_f64_t p;
    int i;
    (void)state;
    assert_int_equal(aacmm_params_default_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_arm_from_params_f64(&a, &p), AACMM_OK);
    assert_int_equal(aacmm_arm_get_vector_f64(&a, v), AACMM_OK);
    for (i = 0; i < 6; i++) {
        assert_true(same(v[AACMM_COL_THETA(i)], 0.0));
        assert_memory_equal(&v[AACMM_COL_ALPHA(i)], &p.alpha_rad[i], sizeof(double));
        assert_memory_equal(&v[AACMM_COL_D(i)], &p.d_mm[i], sizeof(double));
        assert_memory_equal(&v[AACMM_COL_A(i)], &p.a_mm[i], sizeof(double));
    }
    assert_memory_equal(&v[AACMM_COL_L], &p.l_mm, sizeof(double));
    /* a 5-joint arm with betas on joints 2 and 4 and a tip vector */
    memset(&a, 0, sizeof a);
    a.shape.joints = 5;
    a.shape.tip = AACMM_TIP_XYZ;
    a.shape.beta[1] = 1;
    a.shape.beta[3] = 1;
    for (i = 0; i < 5; i++) {
        a.theta_offset_rad[i] = 0.1 * i;
        a.alpha_rad[i] = 1.0 + i;
        a.d_mm[i] = 10.0 + i;
        a.a_mm[i] = 20.0 + i;
    }
    a.beta_rad[1] = 0.01;
    a.beta_rad[3] = 0.03;
    a.tip_mm[0] = 7.0;
    a.tip_mm[1] = 8.0;
    a.tip_mm[2] = 9.0;
    assert_int_equal(aacmm_arm_get_vector_f64(&a, v), AACMM_OK);
    for (i = 0; i < 5; i++) {
        assert_true(same(v[AACMM_ARM_COL_THETA(5, i)], 0.1 * i));
        assert_true(same(v[AACMM_ARM_COL_ALPHA(5, i)], 1.0 + i));
        assert_true(same(v[AACMM_ARM_COL_D(5, i)], 10.0 + i));
        assert_true(same(v[AACMM_ARM_COL_A(5, i)], 20.0 + i));
    }
    assert_true(same(v[20], 0.01) && same(v[21], 0.03));
    assert_true(same(v[22], 7.0) && same(v[23], 8.0) && same(v[24], 9.0));
    memset(&b, 0, sizeof b);
    b.shape = a.shape;
    assert_int_equal(aacmm_arm_set_vector_f64(&b, v), AACMM_OK);
    assert_memory_equal(&a, &b, sizeof a);
    assert_int_equal(aacmm_arm_get_vector_f64(&b, w), AACMM_OK);
    assert_memory_equal(v, w, sizeof(double) * 25);
    b.shape.joints = 2;
    assert_int_equal(aacmm_arm_get_vector_f64(&b, w), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_set_vector_f64(&b, v), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_get_vector_f64(NULL, w), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_perturb_f64(&b, v, &a), AACMM_ERR_RANGE);
}

static void test_arm_encoders(void **state)
{
    aacmm_arm_encoders_t e;
    aacmm_encoder_config_t c;
    uint32_t r[7] = {0, 1, 2, 3, 4, 5, 0xFFFFFFFFu};
    int64_t s[7];
    double th[7];
    float thf[7];
    uint32_t bam[7], bam6[6];
    (void)state;
    assert_int_equal(aacmm_arm_encoders_default(NULL, 6), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_encoders_default(&e, 0), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_encoders_default(&e, 8), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_encoders_default(&e, 7), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_validate(&e), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_signed_counts(&e, r, s), AACMM_OK);
    assert_true(s[6] == -1 && s[5] == 5);
    assert_int_equal(aacmm_arm_encoders_to_angles_f64(&e, r, th), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_to_angles_f32(&e, r, thf), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_to_bam(&e, r, bam), AACMM_OK);
    assert_true(bam[6] == 0xFFFFFFFFu && th[6] < 0.0 && thf[6] < 0.0f);
    /* the six-joint config form gives the same as the arm form */
    assert_int_equal(aacmm_encoder_default(&c), AACMM_OK);
    c.counts_per_rev[2] = 3600u;
    c.zero_offset_counts[2] = 100u;
    c.direction[4] = -1;
    assert_int_equal(aacmm_arm_encoders_from_config(&e, &c), AACMM_OK);
    assert_int_equal(e.joints, 6);
    assert_int_equal(aacmm_encoder_to_bam(&c, r, bam6), AACMM_OK);
    assert_int_equal(aacmm_arm_encoders_to_bam(&e, r, bam), AACMM_OK);
    assert_memory_equal(bam, bam6, sizeof bam6);
    e.direction[3] = 0;
    assert_int_equal(aacmm_arm_encoders_validate(&e), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_encoders_to_angles_f64(&e, r, th), AACMM_ERR_RANGE);
    e.direction[3] = 1;
    e.joints = 0;
    assert_int_equal(aacmm_arm_encoders_validate(&e), AACMM_ERR_RANGE);
    e.joints = 6;
    r[2] = 3600u;
    assert_int_equal(aacmm_arm_encoders_to_angles_f64(&e, r, th), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_arm_encoders_validate(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_encoders_to_bam(&e, r, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_arm_encoders_from_config(&e, NULL), AACMM_ERR_NULL);
}

/* Angle checks and nulls of the general entry points. */
static void test_bad_inputs(void **state)
{
    aacmm_arm_f64_t arm;
    aacmm_model_f64_t m;
    double th[7] = {0, 0, 0, 0, 0, 0, 0}, p[3] = {1, 2, 3}, J[AACMM_JAC_SIZE_MAX];
    size_t done = 9u;
    (void)state;
    ref_shipped_arm(0, &arm);
    assert_int_equal(aacmm_model_init_arm_f64(&m, &arm), AACMM_OK);
    th[6] = (double)NAN; /* the 7th joint is checked */
    assert_int_equal(aacmm_point_f64(&m, th, p), AACMM_ERR_NOT_FINITE);
    assert_true(p[0] > 0.5 && p[0] < 1.5);
    th[6] = 1024.5;
    assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_batch_angles_f64(&m, 1, th, p, J, &done), AACMM_ERR_RANGE);
    assert_int_equal((int)done, 0);
    th[6] = -1024.0;
    assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_OK);
    assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_perturbed_points_f64(NULL, 1, th, 1, th, p, NULL), AACMM_ERR_NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shapes),
        cmocka_unit_test(test_arm_validation),
        cmocka_unit_test(test_vectors),
        cmocka_unit_test(test_arm_encoders),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_hand_worked),
        cmocka_unit_test(test_f64_vs_reference),
        cmocka_unit_test(test_paper_vs_reference),
        cmocka_unit_test(test_f64_vs_central_differences),
        cmocka_unit_test(test_identities),
        cmocka_unit_test(test_f32_vs_f64),
        cmocka_unit_test(test_kernels),
        cmocka_unit_test(test_counts_and_analysis),
    };
    return cmocka_run_group_tests_name("general arm model", tests, NULL, NULL);
}
