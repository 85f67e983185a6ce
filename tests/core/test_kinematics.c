/*
 * Kinematics core tests: forward kinematics and Jacobian against an
 * independent long-double reference, the paper's identities, a pose worked
 * out by hand, single against double precision, and the encoder edge cases.
 *
 * Measured maxima are printed as "measured: ..." lines so the docs can quote
 * them; every bound asserted here is stated in docs/kinematics.md.
 *
 * The accuracy tests run once per batch kernel this CPU can run (aacmm/simd.h:
 * scalar, vec128, avx2, avx512): their point and Jacobian calls go through
 * the kernel under test (k_point_f64 and friends below). A last group checks
 * the batch kernels against the scalar one over 10^6 poses and their batch
 * semantics (tails, the stop at the first bad pose, *done).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/analysis.h"
#include "aacmm/kinematics.h"
#include "aacmm/simd.h"
#include "reference.h"

#define LEGACY_FLOAT_PATHS
#include "legacy_golden.h"
#include "legacy_paths.h"

#define PI 3.14159265358979323846

/* The sanitizer build divides the large pose counts by this (it runs every
 * accuracy test once per batch kernel, about ten times slower). */
#ifndef CORE_TEST_DIV
#define CORE_TEST_DIV 1
#endif
#define TWO_PI_LD 6.283185307179586476925286766559005768L

/* Bounds asserted below (and quoted in docs/kinematics.md). */
#define BOUND_F64_POINT_MM 1e-10        /* core f64 vs long-double reference */
#define BOUND_F64_JAC_REF 1e-10         /* core f64 Jacobian vs reference finite differences */
#define BOUND_FD_ANGLE_MM_PER_RAD 2e-6  /* core f64 Jacobian vs double central differences */
#define BOUND_FD_LENGTH 1e-8            /* same, length columns (the point is affine in them) */
#define BOUND_F32_POINT_MM 1e-3         /* f32 vs f64 point, per coordinate */
#define BOUND_F32_JAC 2e-3              /* f32 vs f64 Jacobian, per entry */

/* Agreement of every batch kernel with the scalar one (docs/kinematics.md). */
#define BOUND_SIMD_POINT_MM 1e-12     /* per coordinate, absolute */
#define BOUND_SIMD_JAC 1e-12          /* per entry, relative to max(1, |entry|) */
#define BOUND_SIMD_F32 1e-3          /* f32 lanes vs f32 scalar, absolute (mm, mm/rad, mm/mm) */

/* The kernel the accuracy tests run on (set by main for each group run). */
static aacmm_kernel_t kernel = AACMM_KERNEL_SCALAR;

/* One pose through the kernel under test: the per-pose core for the scalar
 * kernel, a batch of one (lanes filled with copies) for the others. */
static aacmm_status_t k_point_f64(const aacmm_model_f64_t *m, const double th[6], double p[3])
{
    if (kernel == AACMM_KERNEL_SCALAR) {
        return aacmm_point_f64(m, th, p);
    }
    return aacmm_simd_batch_angles_f64(kernel, m, 1u, th, p, NULL, NULL);
}

static aacmm_status_t k_point_jacobian_f64(const aacmm_model_f64_t *m, const double th[6],
                                           double p[3], double J[AACMM_JAC_SIZE])
{
    if (kernel == AACMM_KERNEL_SCALAR) {
        return aacmm_point_jacobian_f64(m, th, p, J);
    }
    return aacmm_simd_batch_angles_f64(kernel, m, 1u, th, p, J, NULL);
}

static aacmm_status_t k_point_jacobian_f32(const aacmm_model_f32_t *m, const float th[6],
                                           float p[3], float J[AACMM_JAC_SIZE])
{
    if (kernel == AACMM_KERNEL_SCALAR) {
        return aacmm_point_jacobian_f32(m, th, p, J);
    }
    return aacmm_simd_batch_angles_f32(kernel, m, 1u, th, p, J, NULL);
}

static void random_pose(test_rng_t *g, double th[6])
{
    int i;
    for (i = 0; i < 6; i++) {
        th[i] = rng_uniform(g, -PI, PI);
    }
}

static void default_model(aacmm_model_f64_t *m)
{
    aacmm_params_f64_t p;
    assert_int_equal(aacmm_params_default_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(m, &p), AACMM_OK);
}

/* A model with every parameter perturbed away from the symmetric Table 1
 * values, so no term of the Jacobian vanishes by accident. */
static void perturbed_params(aacmm_params_f64_t *p)
{
    int i;
    aacmm_params_default_f64(p);
    for (i = 0; i < 6; i++) {
        p->theta_offset_rad[i] = 0.01 * (i + 1);
        p->alpha_rad[i] += 0.002 * (i - 2.5);
        p->d_mm[i] += 0.3 * i;
        p->a_mm[i] = 1.5 - 0.4 * i;
    }
    p->l_mm += 0.7;
}

/* ------------------------------------------------------------------------ */

static void test_point_matches_reference(void **state)
{
    aacmm_params_f64_t pr;
    aacmm_model_f64_t m;
    test_rng_t g = {UINT64_C(0x9E3779B97F4A7C15)};
    double worst = 0.0;
    int k, set;
    (void)state;
    for (set = 0; set < 2; set++) {
        if (set == 0) {
            aacmm_params_default_f64(&pr);
        } else {
            perturbed_params(&pr);
        }
        assert_int_equal(aacmm_model_init_f64(&m, &pr), AACMM_OK);
        for (k = 0; k < 100000 / CORE_TEST_DIV; k++) {
            double th[6], p[3];
            long double q[25], pref[3];
            int r;
            random_pose(&g, th);
            assert_int_equal(k_point_f64(&m, th, p), AACMM_OK);
            ref_params(&pr, th, q);
            ref_point(q, pref);
            for (r = 0; r < 3; r++) {
                double e = (double)fabsl((long double)p[r] - pref[r]);
                if (e > worst) {
                    worst = e;
                }
            }
        }
    }
    printf("measured: f64 point vs long-double reference, %d poses: max %.3g mm\n",
           2 * (100000 / CORE_TEST_DIV), worst);
    assert_true(worst <= BOUND_F64_POINT_MM);
}

/* The point computed by aacmm_point_jacobian_f64 equals aacmm_point_f64. */
static void test_point_jacobian_same_point(void **state)
{
    aacmm_model_f64_t m;
    test_rng_t g = {12345u};
    int k;
    (void)state;
    default_model(&m);
    for (k = 0; k < 1000; k++) {
        double th[6], p1[3], p2[3], J[AACMM_JAC_SIZE];
        random_pose(&g, th);
        assert_int_equal(k_point_f64(&m, th, p1), AACMM_OK);
        assert_int_equal(k_point_jacobian_f64(&m, th, p2, J), AACMM_OK);
        assert_memory_equal(p1, p2, sizeof p1);
    }
}

/* The core's Jacobian against central finite differences of the core's own
 * forward kinematics, in double, over 10^4 random poses and all 25
 * parameters. Step 1e-6 rad for angles (truncation ~ h^2 |p'''| / 6 ~ 4e-10
 * mm, rounding ~ eps |p| / h ~ 4e-7 mm) and 1e-3 mm for lengths (the point is
 * affine in d, a, l, so only rounding remains, ~ 4e-10). */
static void test_jacobian_vs_central_differences(void **state)
{
    aacmm_params_f64_t pr;
    aacmm_model_f64_t m;
    test_rng_t g = {UINT64_C(0xC0FFEE)};
    double worst_angle = 0.0, worst_length = 0.0;
    int k, c, r;
    (void)state;
    perturbed_params(&pr);
    assert_int_equal(aacmm_model_init_f64(&m, &pr), AACMM_OK);
    for (k = 0; k < 10000 / CORE_TEST_DIV; k++) {
        double th[6], p[3], J[AACMM_JAC_SIZE];
        random_pose(&g, th);
        assert_int_equal(k_point_jacobian_f64(&m, th, p, J), AACMM_OK);
        for (c = 0; c < AACMM_JAC_COLS; c++) {
            aacmm_params_f64_t pp = pr, pm = pr;
            double thp[6], thm[6], fp[3], fm[3];
            aacmm_model_f64_t mp, mm;
            int is_angle = c < 12;
            double h = is_angle ? 1e-6 : 1e-3;
            memcpy(thp, th, sizeof thp);
            memcpy(thm, th, sizeof thm);
            if (c < 6) {
                thp[c] += h;
                thm[c] -= h;
            } else if (c < 12) {
                pp.alpha_rad[c - 6] += h;
                pm.alpha_rad[c - 6] -= h;
            } else if (c < 18) {
                pp.d_mm[c - 12] += h;
                pm.d_mm[c - 12] -= h;
            } else if (c < 24) {
                pp.a_mm[c - 18] += h;
                pm.a_mm[c - 18] -= h;
            } else {
                pp.l_mm += h;
                pm.l_mm -= h;
            }
            assert_int_equal(aacmm_model_init_f64(&mp, &pp), AACMM_OK);
            assert_int_equal(aacmm_model_init_f64(&mm, &pm), AACMM_OK);
            assert_int_equal(k_point_f64(&mp, thp, fp), AACMM_OK);
            assert_int_equal(k_point_f64(&mm, thm, fm), AACMM_OK);
            for (r = 0; r < 3; r++) {
                double fd = (fp[r] - fm[r]) / (2.0 * h);
                double e = fabs(fd - J[r * AACMM_JAC_COLS + c]);
                if (is_angle && e > worst_angle) {
                    worst_angle = e;
                }
                if (!is_angle && e > worst_length) {
                    worst_length = e;
                }
            }
        }
    }
    printf("measured: f64 Jacobian vs central differences, %d poses: angle columns max %.3g "
           "mm/rad, length columns max %.3g mm/mm\n",
           10000 / CORE_TEST_DIV, worst_angle, worst_length);
    assert_true(worst_angle <= BOUND_FD_ANGLE_MM_PER_RAD);
    assert_true(worst_length <= BOUND_FD_LENGTH);
}

/* A tighter check: the Jacobian against central differences of the
 * long-double reference (rounding ~1e-19 |p| / h is negligible there). */
static void test_jacobian_vs_reference_differences(void **state)
{
    aacmm_params_f64_t pr;
    aacmm_model_f64_t m;
    test_rng_t g = {777u};
    double worst = 0.0;
    int k, c, r;
    (void)state;
    perturbed_params(&pr);
    assert_int_equal(aacmm_model_init_f64(&m, &pr), AACMM_OK);
    for (k = 0; k < 2000; k++) {
        double th[6], p[3], J[AACMM_JAC_SIZE];
        long double q[25];
        random_pose(&g, th);
        assert_int_equal(k_point_jacobian_f64(&m, th, p, J), AACMM_OK);
        ref_params(&pr, th, q);
        for (c = 0; c < AACMM_JAC_COLS; c++) {
            /* five-point stencil: truncation ~ h^4 |p^(5)| / 30, negligible
             * at h = 1e-4; rounding ~ 1e-19 |p| / h ~ 2e-12 */
            static const long double step[4] = {2, 1, -1, -2};
            static const long double weight[4] = {-1, 8, -8, 1};
            long double h = 1e-4L, fd[3] = {0, 0, 0};
            int s;
            for (s = 0; s < 4; s++) {
                long double qs[25], f[3];
                memcpy(qs, q, sizeof qs);
                qs[c] += step[s] * h;
                ref_point(qs, f);
                for (r = 0; r < 3; r++) {
                    fd[r] += weight[s] * f[r];
                }
            }
            for (r = 0; r < 3; r++) {
                double e = (double)fabsl(fd[r] / (12 * h) - (long double)J[r * AACMM_JAC_COLS + c]);
                if (e > worst) {
                    worst = e;
                }
            }
        }
    }
    printf("measured: f64 Jacobian vs long-double reference differences, 2000 poses: max %.3g\n",
           worst);
    assert_true(worst <= BOUND_F64_JAC_REF);
}

/* Eq. 11-13: the d, a and l columns are unit vectors; and d f_z / d theta_1
 * is exactly zero (theta_1 turns about the vertical base axis). */
static void test_paper_identities(void **state)
{
    aacmm_params_f64_t pr;
    aacmm_model_f64_t m;
    test_rng_t g = {99u};
    double worst = 0.0;
    int k, c, set;
    (void)state;
    for (set = 0; set < 2; set++) {
        if (set == 0) {
            aacmm_params_default_f64(&pr);
        } else {
            perturbed_params(&pr);
        }
        assert_int_equal(aacmm_model_init_f64(&m, &pr), AACMM_OK);
        for (k = 0; k < 10000; k++) {
            double th[6], p[3], J[AACMM_JAC_SIZE];
            random_pose(&g, th);
            assert_int_equal(k_point_jacobian_f64(&m, th, p, J), AACMM_OK);
            for (c = AACMM_COL_D(0); c <= AACMM_COL_L; c++) {
                double nx = J[c], ny = J[AACMM_JAC_COLS + c], nz = J[2 * AACMM_JAC_COLS + c];
                double e = fabs(sqrt(nx * nx + ny * ny + nz * nz) - 1.0);
                if (e > worst) {
                    worst = e;
                }
            }
            /* Exactly zero: compared bitwise apart from the sign of zero. */
            assert_true(fabs(J[2 * AACMM_JAC_COLS + AACMM_COL_THETA(0)]) <= 0.0);
        }
    }
    printf("measured: | |column| - 1 | for d, a, l columns: max %.3g\n", worst);
    assert_true(worst <= 1e-12);
}

/*
 * The zero pose with the paper's Table 1, worked by hand.
 * With theta = 0, a = 0 and alpha = 90 deg, each step of the chain is
 * Trans(0, 0, d_i) then Rot(x, 90 deg), which keeps x_i = (1, 0, 0) and turns
 * the z axis by +90 deg about x each time:
 *   z0 = (0,0,1), z1 = (0,-1,0), z2 = (0,0,-1), z3 = (0,1,0), z4 = (0,0,1),
 *   z5 = (0,-1,0), z6 = (0,0,-1).
 * Origins o_i = o_{i-1} + d_i z_{i-1}:
 *   o1 = (0, 0, 300), o2 = (0, -65.5, 300), o3 = (0, -65.5, -492.7),
 *   o4 = (0, 0, -492.7), o5 = (0, 0, 390.5), o6 = o5 (d6 = 0).
 * Probe p = o6 + l z6 = (0, 0, 390.5 - 183.5) = (0, 0, 207).
 * Columns (u x v with u = (1,0,0) is (0, -v_z, v_y)):
 *   theta: z0 x (0,0,207) = 0;  z1 x (0,0,-93) = (93,0,0);
 *          z2 x (0,65.5,-93) = (65.5,0,0);  z3 x (0,65.5,699.7) = (699.7,0,0);
 *          z4 x (0,0,699.7) = 0;  z5 x (0,0,-183.5) = (183.5,0,0)
 *   alpha: x_i x (p - o_i): (0,93,0), (0,93,65.5), (0,-699.7,65.5),
 *          (0,-699.7,0), (0,183.5,0), (0,183.5,0)
 *   d_i = z_{i-1};  a_i = (1,0,0);  l = z6 = (0,0,-1).
 * cos(pi/2) is 6e-17 in double, not 0, so the comparison allows 1e-9.
 */
static void test_zero_pose_by_hand(void **state)
{
    static const double p_expect[3] = {0.0, 0.0, 207.0};
    static const double theta_col[6][3] = {{0, 0, 0},    {93, 0, 0}, {65.5, 0, 0},
                                           {699.7, 0, 0}, {0, 0, 0},  {183.5, 0, 0}};
    static const double alpha_col[6][3] = {{0, 93, 0},      {0, 93, 65.5}, {0, -699.7, 65.5},
                                           {0, -699.7, 0},  {0, 183.5, 0}, {0, 183.5, 0}};
    static const double z_axes[7][3] = {{0, 0, 1}, {0, -1, 0}, {0, 0, -1}, {0, 1, 0},
                                        {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
    aacmm_model_f64_t m;
    const double th[6] = {0, 0, 0, 0, 0, 0};
    double p[3], J[AACMM_JAC_SIZE];
    int i, r;
    (void)state;
    default_model(&m);
    assert_int_equal(k_point_jacobian_f64(&m, th, p, J), AACMM_OK);
    for (r = 0; r < 3; r++) {
        assert_true(fabs(p[r] - p_expect[r]) < 1e-9);
        for (i = 0; i < 6; i++) {
            assert_true(fabs(J[r * AACMM_JAC_COLS + AACMM_COL_THETA(i)] - theta_col[i][r]) < 1e-9);
            assert_true(fabs(J[r * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] - alpha_col[i][r]) < 1e-9);
            assert_true(fabs(J[r * AACMM_JAC_COLS + AACMM_COL_D(i)] - z_axes[i][r]) < 1e-9);
            assert_true(fabs(J[r * AACMM_JAC_COLS + AACMM_COL_A(i)] - (r == 0 ? 1.0 : 0.0)) < 1e-9);
        }
        assert_true(fabs(J[r * AACMM_JAC_COLS + AACMM_COL_L] - z_axes[6][r]) < 1e-9);
    }
}

/* Single precision against double over 10^6 random poses. */
static void test_f32_vs_f64(void **state)
{
    aacmm_params_f64_t pd;
    aacmm_params_f32_t pf;
    aacmm_model_f64_t md;
    aacmm_model_f32_t mf;
    test_rng_t g = {2024u};
    double worst_p = 0.0, worst_j = 0.0;
    long k;
    int i, r;
    (void)state;
    aacmm_params_default_f64(&pd);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_model_init_f64(&md, &pd), AACMM_OK);
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_OK);
    /* Compare against the double model of the same (float-rounded) numbers so
     * the difference is arithmetic error only. */
    for (i = 0; i < 6; i++) {
        pd.alpha_rad[i] = (double)pf.alpha_rad[i];
        pd.d_mm[i] = (double)pf.d_mm[i];
    }
    assert_int_equal(aacmm_model_init_f64(&md, &pd), AACMM_OK);
    for (k = 0; k < 1000000L / CORE_TEST_DIV; k++) {
        double thd[6], p64[3], J64[AACMM_JAC_SIZE];
        float thf[6], p32[3], J32[AACMM_JAC_SIZE];
        for (i = 0; i < 6; i++) {
            thf[i] = (float)rng_uniform(&g, -PI, PI);
            thd[i] = (double)thf[i];
        }
        assert_int_equal(k_point_jacobian_f64(&md, thd, p64, J64), AACMM_OK);
        assert_int_equal(k_point_jacobian_f32(&mf, thf, p32, J32), AACMM_OK);
        for (r = 0; r < 3; r++) {
            double e = fabs((double)p32[r] - p64[r]);
            if (e > worst_p) {
                worst_p = e;
            }
        }
        for (i = 0; i < AACMM_JAC_SIZE; i++) {
            double e = fabs((double)J32[i] - J64[i]);
            if (e > worst_j) {
                worst_j = e;
            }
        }
    }
    printf("measured: f32 vs f64, %ld poses: point max %.3g mm, Jacobian max %.3g\n",
           1000000L / CORE_TEST_DIV, worst_p,
           worst_j);
    assert_true(worst_p <= BOUND_F32_POINT_MM);
    assert_true(worst_j <= BOUND_F32_JAC);
}

/* |got - want| in units of ulp(got) (the spacing of the result's own format at it). */
static double result_ulps(double got, long double want)
{
    double a = fabs(got);
    return (double)(fabsl((long double)got - want) / (long double)(nextafter(a, 2.0) - a));
}

static double result_ulps_f32(float got, long double want)
{
    float a = fabsf(got);
    return (double)(fabsl((long double)got - want) / (long double)(nextafterf(a, 2.0f) - a));
}

static void test_sincos_accuracy(void **state)
{
    test_rng_t g = {5u};
    double worst64 = 0.0, worst32 = 0.0, rel64 = 0.0, rel32 = 0.0, rel32_small = 0.0;
    int k;
    (void)state;
    for (k = 0; k < 2000000; k++) {
        double x = (k < 1000000) ? rng_uniform(&g, -4.0, 4.0) : rng_uniform(&g, -2048.0, 2048.0);
        float xf = (float)x;
        double s, c;
        float sf, cf;
        long double es, ec;
        aacmm_sincos_f64(x, &s, &c);
        aacmm_sincos_f32(xf, &sf, &cf);
        /* Error in units of the larger of the value's ulp and the ulp of 2^-3
         * (values near zero are judged on an absolute scale). */
        es = fabsl((long double)s - sinl((long double)x)) /
             (long double)fmax(fabs(s) > 0.125 ? nextafter(fabs(s), 2.0) - fabs(s) : 0x1p-56, 0x1p-56);
        ec = fabsl((long double)c - cosl((long double)x)) /
             (long double)fmax(fabs(c) > 0.125 ? nextafter(fabs(c), 2.0) - fabs(c) : 0x1p-56, 0x1p-56);
        if ((double)es > worst64) {
            worst64 = (double)es;
        }
        if ((double)ec > worst64) {
            worst64 = (double)ec;
        }
        es = fabsl((long double)sf - sinl((long double)xf)) /
             (long double)fmaxf(fabsf(sf) > 0.125f ? nextafterf(fabsf(sf), 2.0f) - fabsf(sf) : 0x1p-27f, 0x1p-27f);
        ec = fabsl((long double)cf - cosl((long double)xf)) /
             (long double)fmaxf(fabsf(cf) > 0.125f ? nextafterf(fabsf(cf), 2.0f) - fabsf(cf) : 0x1p-27f, 0x1p-27f);
        if ((double)es > worst32) {
            worst32 = (double)es;
        }
        if ((double)ec > worst32) {
            worst32 = (double)ec;
        }
        /* The other metric: in units of the result's own ulp, also near zero. */
        rel64 = fmax(rel64, result_ulps(s, sinl((long double)x)));
        rel64 = fmax(rel64, result_ulps(c, cosl((long double)x)));
        {
            double r32 = fmax(result_ulps_f32(sf, sinl((long double)xf)),
                              result_ulps_f32(cf, cosl((long double)xf)));
            if (k < 1000000) {
                rel32_small = fmax(rel32_small, r32);
            }
            rel32 = fmax(rel32, r32);
        }
    }
    printf("measured: sincos error, |x| <= 2048, in units of max(ulp(result), 2^-56 or 2^-27 "
           "below 1/8): f64 max %.3f, f32 max %.3f\n",
           worst64, worst32);
    printf("measured: sincos error in ulps of the result itself: f64 max %.3f (|x| <= 2048); f32 "
           "max %.3f (|x| <= 4), %.1f (|x| <= 2048: results near zero)\n",
           rel64, rel32_small, rel32);
    assert_true(worst64 <= 2.0);
    assert_true(worst32 <= 2.0);
    assert_true(rel64 <= 2.0);
    assert_true(rel32_small <= 2.0);
}

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

/* The signed count, computed the slow obvious way (independent of the core). */
static int64_t expect_signed(uint64_t cpr, uint32_t zero, int dir, uint32_t reading)
{
    int64_t delta = ((int64_t)reading - (int64_t)zero) % (int64_t)cpr;
    if (delta < 0) {
        delta += (int64_t)cpr;
    }
    if (2 * delta >= (int64_t)cpr) {
        delta -= (int64_t)cpr;
    }
    return dir < 0 ? -delta : delta;
}

/* 1 if got is the correct rounding of ref (or ref is too close to a midpoint
 * between two doubles for a long double to tell, and got is one of them). */
static int correctly_rounded_f64(double got, long double ref, int *ambiguous)
{
    double nearest = (double)ref;
    double other = (ref > (long double)nearest) ? nextafter(nearest, (double)INFINITY) : nextafter(nearest, -(double)INFINITY);
    long double mid = ((long double)nearest + (long double)other) / 2;
    long double ulp_ld = fabsl(ref) * 0x1p-62L; /* 2 long-double ulps: the reference's own error */
    if (fabsl(ref - mid) <= ulp_ld) {
        (*ambiguous)++;
        return memcmp(&got, &nearest, sizeof got) == 0 || memcmp(&got, &other, sizeof got) == 0;
    }
    return memcmp(&got, &nearest, sizeof got) == 0;
}

static int correctly_rounded_f32(float got, long double ref, int *ambiguous)
{
    float nearest = (float)ref;
    float other = (ref > (long double)nearest) ? nextafterf(nearest, INFINITY) : nextafterf(nearest, -INFINITY);
    long double mid = ((long double)nearest + (long double)other) / 2;
    long double ulp_ld = fabsl(ref) * 0x1p-62L;
    if (fabsl(ref - mid) <= ulp_ld) {
        (*ambiguous)++;
        return memcmp(&got, &nearest, sizeof got) == 0 || memcmp(&got, &other, sizeof got) == 0;
    }
    return memcmp(&got, &nearest, sizeof got) == 0;
}

typedef struct {
    uint64_t cpr;
    uint32_t zero;
    int8_t dir;
    uint32_t reading;
    int64_t expect_s;
} encoder_case_t;

/* The edge-case table. */
static const encoder_case_t encoder_cases[] = {
    {UINT64_C(1) << 32, 0u, 1, 0xFFFFFFFFu, -1},                  /* wrap at 2^32 */
    {UINT64_C(1) << 32, 0u, 1, 0x7FFFFFFFu, 0x7FFFFFFF},          /* just below a half turn */
    {UINT64_C(1) << 32, 0u, 1, 0x80000000u, -(INT64_C(1) << 31)}, /* half turn maps to -pi */
    {UINT64_C(1) << 32, 0u, -1, 0x80000000u, INT64_C(1) << 31},   /* ... and to +pi reversed */
    {UINT64_C(1) << 32, 10u, 1, 5u, -5},                          /* zero offset above reading */
    {UINT64_C(1) << 32, 0xFFFFFFF0u, 1, 0x10u, 0x20},             /* offset near top, reading wrapped */
    {UINT64_C(1) << 32, 0u, -1, 1u, -1},                          /* direction -1 */
    {UINT64_C(1) << 26, 0u, 1, (1u << 26) - 1u, -1},              /* 26-bit wrap */
    {UINT64_C(1) << 26, 1000u, -1, 999u, 1},                      /* 26-bit, reversed, below zero */
    {3600u, 3500u, 1, 100u, 200},                                 /* non power of two, wrap */
    {3600u, 100u, 1, 3500u, -200},
    {3600u, 0u, 1, 1800u, -1800},
    {3600u, 0u, 1, 1799u, 1799},
    {2u, 0u, 1, 1u, -1},                                          /* smallest resolution */
    {2u, 1u, 1, 1u, 0},
    {0xFFFFFFFFu, 0u, 1, 0xFFFFFFFEu, -1},                        /* largest non power of two */
    {0xFFFFFFFFu, 0u, 1, 0x7FFFFFFFu, 0x7FFFFFFF},
    {0xFFFFFFFFu, 0u, 1, 0x80000000u, -0x7FFFFFFF},
    {0xFFFFFFFFu, 0xFFFFFFFEu, -1, 0u, -1},
    {1000u, 0u, -1, 999u, 1},
};

static void set_all(aacmm_encoder_config_t *c, uint64_t cpr, uint32_t zero, int8_t dir)
{
    int i;
    for (i = 0; i < 6; i++) {
        c->counts_per_rev[i] = cpr;
        c->zero_offset_counts[i] = zero;
        c->direction[i] = dir;
    }
}

static void test_encoder_edge_table(void **state)
{
    size_t k;
    int ambiguous = 0;
    (void)state;
    for (k = 0; k < sizeof encoder_cases / sizeof encoder_cases[0]; k++) {
        const encoder_case_t *t = &encoder_cases[k];
        aacmm_encoder_config_t c;
        uint32_t rd[6];
        int64_t s[6];
        double a64[6];
        float a32[6];
        int i;
        set_all(&c, t->cpr, t->zero, t->dir);
        for (i = 0; i < 6; i++) {
            rd[i] = t->reading;
        }
        assert_int_equal(aacmm_encoder_signed_counts(&c, rd, s), AACMM_OK);
        assert_int_equal(aacmm_encoder_to_angles_f64(&c, rd, a64), AACMM_OK);
        assert_int_equal(aacmm_encoder_to_angles_f32(&c, rd, a32), AACMM_OK);
        for (i = 0; i < 6; i++) {
            long double ref = (long double)t->expect_s * TWO_PI_LD / (long double)t->cpr;
            if (s[i] != t->expect_s) {
                fail_msg("case %zu: signed counts %lld, expected %lld", k, (long long)s[i],
                         (long long)t->expect_s);
            }
            assert_true(s[i] == expect_signed(t->cpr, t->zero, t->dir, t->reading));
            assert_true(correctly_rounded_f64(a64[i], ref, &ambiguous));
            assert_true(correctly_rounded_f32(a32[i], ref, &ambiguous));
        }
    }
}

/* Every power-of-two resolution 2^1 .. 2^32 and a spread of others: the
 * angle is the correctly rounded exact value, in both precisions. */
static void test_encoder_angles_exact(void **state)
{
    test_rng_t g = {31337u};
    int ambiguous = 0;
    long checked = 0;
    int n, k;
    (void)state;
    for (n = 1; n <= 64; n++) {
        uint64_t cpr;
        if (n <= 32) {
            cpr = UINT64_C(1) << n;
        } else {
            /* non powers of two: small, mid-size, and near 2^32 */
            cpr = (n < 40) ? (uint64_t)(3 + (rng_next(&g) % 5000u))
                           : (uint64_t)(2 + (rng_next(&g) % UINT64_C(0xFFFFFFFE)));
            if ((cpr & (cpr - 1u)) == 0u) {
                cpr++;
            }
        }
        for (k = 0; k < 4000; k++) {
            aacmm_encoder_config_t c;
            uint32_t rd[6];
            double a64[6];
            float a32[6];
            int i;
            for (i = 0; i < 6; i++) {
                c.counts_per_rev[i] = cpr;
                c.zero_offset_counts[i] = (uint32_t)(rng_next(&g) % cpr);
                c.direction[i] = (rng_next(&g) & 1u) ? 1 : -1;
                rd[i] = (uint32_t)(rng_next(&g) % cpr);
            }
            if (k < 6) { /* the extremes of the reading range */
                rd[0] = 0u;
                rd[1] = (uint32_t)(cpr - 1u);
                rd[2] = (uint32_t)(cpr / 2u);
            }
            assert_int_equal(aacmm_encoder_to_angles_f64(&c, rd, a64), AACMM_OK);
            assert_int_equal(aacmm_encoder_to_angles_f32(&c, rd, a32), AACMM_OK);
            for (i = 0; i < 6; i++) {
                int64_t s = expect_signed(cpr, c.zero_offset_counts[i], c.direction[i], rd[i]);
                long double ref = (long double)s * TWO_PI_LD / (long double)cpr;
                if (!correctly_rounded_f64(a64[i], ref, &ambiguous)) {
                    fail_msg("cpr %llu s %lld: f64 %a, reference %La", (unsigned long long)cpr,
                             (long long)s, a64[i], ref);
                }
                if (!correctly_rounded_f32(a32[i], ref, &ambiguous)) {
                    fail_msg("cpr %llu s %lld: f32 %a, reference %La", (unsigned long long)cpr,
                             (long long)s, (double)a32[i], ref);
                }
                assert_true(fabs(a64[i]) <= PI);
                checked++;
            }
        }
    }
    printf("measured: %ld encoder angles correctly rounded in f64 and f32 (%d too close to a "
           "rounding midpoint for the long-double reference to decide)\n",
           checked, ambiguous);
}

static void test_encoder_bam(void **state)
{
    test_rng_t g = {4242u};
    int n, k;
    (void)state;
    for (n = 1; n <= 48; n++) {
        uint64_t cpr = (n <= 32) ? (UINT64_C(1) << n) : (uint64_t)(3 + (rng_next(&g) % UINT64_C(0xFFFFFFF0)));
        if (n > 32 && (cpr & (cpr - 1u)) == 0u) {
            cpr++;
        }
        for (k = 0; k < 2000; k++) {
            aacmm_encoder_config_t c;
            uint32_t rd[6], bam[6];
            int i;
            for (i = 0; i < 6; i++) {
                c.counts_per_rev[i] = cpr;
                c.zero_offset_counts[i] = (uint32_t)(rng_next(&g) % cpr);
                c.direction[i] = (rng_next(&g) & 1u) ? 1 : -1;
                rd[i] = (uint32_t)(rng_next(&g) % cpr);
            }
            assert_int_equal(aacmm_encoder_to_bam(&c, rd, bam), AACMM_OK);
            for (i = 0; i < 6; i++) {
                int64_t s = expect_signed(cpr, c.zero_offset_counts[i], c.direction[i], rd[i]);
                /* The exact binary angle s * 2^32 / cpr as a long double, and
                 * the result read as a signed turn fraction. */
                long double exact = (long double)s * 0x1p32L / (long double)cpr;
                long double got = (long double)(int32_t)bam[i];
                if (fabsl(exact) >= 0x1p31L) {
                    /* half turn: +pi and -pi are the same binary angle */
                    assert_true(bam[i] == 0x80000000u);
                    continue;
                }
                if (n <= 32) {
                    assert_true(fabsl(got - exact) <= 0.0L); /* exact for powers of two */
                } else {
                    assert_true(fabsl(got - exact) <= 0.5L);
                }
            }
        }
    }
}

static void test_encoder_invalid(void **state)
{
    aacmm_encoder_config_t c;
    uint32_t rd[6] = {0, 0, 0, 0, 0, 0};
    int64_t s[6];
    double a[6];
    float af[6];
    uint32_t bam[6];
    (void)state;
    assert_int_equal(aacmm_encoder_default(&c), AACMM_OK);
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_OK);
    assert_int_equal(aacmm_encoder_default(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_validate(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_to_angles_f64(NULL, rd, a), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_to_angles_f64(&c, NULL, a), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_to_angles_f64(&c, rd, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_to_angles_f32(&c, rd, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_to_bam(&c, rd, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_encoder_signed_counts(&c, rd, NULL), AACMM_ERR_NULL);

    c.counts_per_rev[2] = 1u;
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_encoder_to_angles_f64(&c, rd, a), AACMM_ERR_RANGE);
    c.counts_per_rev[2] = (UINT64_C(1) << 32) + 1u;
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_ERR_RANGE);
    c.counts_per_rev[2] = 0u;
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_ERR_RANGE);
    aacmm_encoder_default(&c);
    c.direction[5] = 0;
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_ERR_RANGE);
    aacmm_encoder_default(&c);
    c.counts_per_rev[1] = 1000u;
    c.zero_offset_counts[1] = 1000u; /* must be < cpr */
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_ERR_RANGE);
    c.zero_offset_counts[1] = 999u;
    assert_int_equal(aacmm_encoder_validate(&c), AACMM_OK);
    /* a reading >= cpr is rejected and nothing is written */
    rd[1] = 1000u;
    a[0] = 42.0;
    af[0] = 42.0f;
    bam[0] = 42u;
    assert_int_equal(aacmm_encoder_to_angles_f64(&c, rd, a), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_encoder_to_angles_f32(&c, rd, af), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_encoder_to_bam(&c, rd, bam), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_encoder_signed_counts(&c, rd, s), AACMM_ERR_RANGE);
    assert_true(a[0] > 41.0 && af[0] > 41.0f && bam[0] == 42u);
}

/* ------------------------------------------------------------------------ */
/* Invalid parameters, null pointers, bad angles, batches                    */
/* ------------------------------------------------------------------------ */

static void test_params_invalid(void **state)
{
    aacmm_params_f64_t p;
    aacmm_params_f32_t pf;
    aacmm_model_f64_t m, m_before;
    aacmm_model_f32_t mf;
    (void)state;
    assert_int_equal(aacmm_params_default_f64(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_default_f32(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_validate_f64(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_validate_f32(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_model_init_f64(NULL, &p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_default_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(&m, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(&m, &p), AACMM_OK);
    m_before = m;

    p.d_mm[3] = (double)NAN;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_NOT_FINITE);
    assert_int_equal(aacmm_model_init_f64(&m, &p), AACMM_ERR_NOT_FINITE);
    assert_memory_equal(&m, &m_before, sizeof m); /* unchanged on error */
    p.d_mm[3] = (double)INFINITY;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_NOT_FINITE);
    p.d_mm[3] = -10000.5;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_RANGE);
    p.d_mm[3] = -10000.0;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_OK);
    p.alpha_rad[0] = 6.3;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_RANGE);
    p.alpha_rad[0] = 0.0;
    p.theta_offset_rad[5] = -7.0;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_RANGE);
    p.theta_offset_rad[5] = 0.0;
    p.l_mm = 1e300;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_RANGE);
    p.l_mm = 0.0;
    p.a_mm[2] = -(double)INFINITY;
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_ERR_NOT_FINITE);

    assert_int_equal(aacmm_params_default_f32(&pf), AACMM_OK);
    pf.l_mm = NAN;
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_ERR_NOT_FINITE);
    pf.l_mm = 2e4f;
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_ERR_RANGE);
}

static void test_bad_angles_and_nulls(void **state)
{
    aacmm_model_f64_t m;
    aacmm_model_f32_t mf;
    aacmm_params_f32_t pf;
    double th[6] = {0, 0, 0, 0, 0, 0}, p[3] = {1, 2, 3}, J[AACMM_JAC_SIZE];
    float thf[6] = {0, 0, 0, 0, 0, 0}, pff[3], Jf[AACMM_JAC_SIZE];
    (void)state;
    default_model(&m);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_OK);
    assert_int_equal(aacmm_point_f64(NULL, th, p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_f64(&m, NULL, p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_f64(&m, th, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_f32(&mf, thf, pff, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_f32(&mf, NULL, pff), AACMM_ERR_NULL);
    th[4] = (double)NAN;
    assert_int_equal(aacmm_point_f64(&m, th, p), AACMM_ERR_NOT_FINITE);
    assert_true(p[0] > 0.5 && p[0] < 1.5); /* not written */
    th[4] = -(double)INFINITY;
    assert_int_equal(aacmm_point_jacobian_f64(&m, th, p, J), AACMM_ERR_NOT_FINITE);
    th[4] = 1025.0;
    assert_int_equal(aacmm_point_f64(&m, th, p), AACMM_ERR_RANGE);
    th[4] = -1024.0; /* the limit itself is accepted */
    assert_int_equal(aacmm_point_f64(&m, th, p), AACMM_OK);
    thf[0] = INFINITY;
    assert_int_equal(aacmm_point_jacobian_f32(&mf, thf, pff, Jf), AACMM_ERR_NOT_FINITE);
}

static void test_batches(void **state)
{
    enum { N = 50 };
    aacmm_model_f64_t m;
    aacmm_model_f32_t mf;
    aacmm_params_f32_t pf;
    aacmm_encoder_config_t enc;
    aacmm_arm_encoders_t encs;
    static double th[N * 6], P[N * 3], J[N * AACMM_JAC_SIZE];
    static float thf[N * 6], Pf[N * 3], Jf[N * AACMM_JAC_SIZE];
    static uint32_t counts[N * 6];
    test_rng_t g = {8u};
    size_t done = 99u;
    int k, i;
    (void)state;
    default_model(&m);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_OK);
    aacmm_encoder_default(&enc);
    enc.counts_per_rev[3] = 3600u;
    for (k = 0; k < N * 6; k++) {
        counts[k] = (uint32_t)rng_next(&g);
        if (k % 6 == 3) {
            counts[k] %= 3600u;
        }
    }
    assert_int_equal(aacmm_arm_encoders_from_config(&encs, &enc), AACMM_OK);
    /* counts batch == per-pose conversion + point_jacobian */
    assert_int_equal(aacmm_batch_counts_f64(&m, &encs, N, counts, P, J, &done), AACMM_OK);
    assert_int_equal((int)done, N);
    for (k = 0; k < N; k++) {
        double a[6], p[3], Jk[AACMM_JAC_SIZE];
        assert_int_equal(aacmm_encoder_to_angles_f64(&enc, counts + 6 * k, a), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_f64(&m, a, p, Jk), AACMM_OK);
        assert_memory_equal(p, P + 3 * k, sizeof p);
        assert_memory_equal(Jk, J + AACMM_JAC_SIZE * k, sizeof Jk);
        for (i = 0; i < 6; i++) {
            th[6 * k + i] = a[i];
            thf[6 * k + i] = (float)a[i];
        }
    }
    /* angle batch with and without Jacobians */
    assert_int_equal(aacmm_batch_angles_f64(&m, N, th, P, NULL, &done), AACMM_OK);
    assert_int_equal(aacmm_batch_angles_f32(&mf, N, thf, Pf, Jf, &done), AACMM_OK);
    assert_int_equal(aacmm_batch_counts_f32(&mf, &encs, N, counts, Pf, NULL, &done), AACMM_OK);
    assert_int_equal((int)done, N);
    /* the first bad pose stops the batch; done counts the good ones */
    th[6 * 17 + 2] = (double)NAN;
    assert_int_equal(aacmm_batch_angles_f64(&m, N, th, P, J, &done), AACMM_ERR_NOT_FINITE);
    assert_int_equal((int)done, 17);
    counts[6 * 9 + 3] = 3600u; /* out of range for this joint */
    assert_int_equal(aacmm_batch_counts_f64(&m, &encs, N, counts, P, J, &done), AACMM_ERR_RANGE);
    assert_int_equal((int)done, 9);
    assert_int_equal(aacmm_batch_counts_f32(&mf, &encs, N, counts, Pf, Jf, &done), AACMM_ERR_RANGE);
    assert_int_equal((int)done, 9);
    /* n = 0 is a no-op, NULL buffers allowed then */
    assert_int_equal(aacmm_batch_angles_f64(&m, 0, NULL, NULL, NULL, &done), AACMM_OK);
    assert_int_equal((int)done, 0);
    assert_int_equal(aacmm_batch_angles_f64(&m, 1, NULL, P, NULL, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_counts_f64(&m, NULL, 1, counts, P, NULL, NULL), AACMM_ERR_NULL);
}

static void test_status_strings(void **state)
{
    int code;
    (void)state;
    for (code = 0; code > (int)AACMM_STATUS_MIN_; code--) {
        assert_string_not_equal(aacmm_status_str((aacmm_status_t)code), "unknown status");
    }
    assert_string_equal(aacmm_status_str(AACMM_STATUS_MIN_), "unknown status");
}

/* ------------------------------------------------------------------------ */
/* Batch kernels across SIMD lanes (aacmm/simd.h)                            */
/* ------------------------------------------------------------------------ */

/* Largest |a - b| / max(1, |b|) over n values (relative for |b| >= 1). */
static double rel_diff(const double *a, const double *b, size_t n)
{
    double worst = 0.0;
    size_t i;
    for (i = 0; i < n; i++) {
        double e = fabs(a[i] - b[i]) / fmax(1.0, fabs(b[i]));
        if (e > worst) {
            worst = e;
        }
    }
    return worst;
}

static double abs_diff_f32(const float *a, const float *b, size_t n)
{
    double worst = 0.0;
    size_t i;
    for (i = 0; i < n; i++) {
        double e = fabs((double)a[i] - (double)b[i]);
        if (e > worst) {
            worst = e;
        }
    }
    return worst;
}

/* Every available kernel against the scalar one over 10^6 random poses, in
 * batches of 1000 (full groups and tails): points within 1e-12 mm, Jacobian
 * entries within 1e-12 relative; single precision within 1e-3 (the f32 bound
 * against f64); the fused |J| sums within 1e-12 relative of the scalar sums.
 * Built as in mk/core.mk (no FMA contraction), the kernels without FMA round
 * every operation as the scalar core does, so their points and Jacobians are
 * in fact equal bit for bit: asserted too. The kernels with FMA fuse at the
 * same places (aacmm/simd.h), so each one equals the first other fused kernel
 * available (AVX-512 against AVX2) bit for bit, in both precisions. */
static void test_simd_agrees_with_scalar(void **state)
{
    enum { B = 1000, BATCHES = 1000 / CORE_TEST_DIV };
    static double th[B * 6], p0[B * 3], p1[B * 3], pr0[B * 3], j0[B * AACMM_JAC_SIZE],
        j1[B * AACMM_JAC_SIZE];
    static float thf[B * 6], pf0[B * 3], pf1[B * 3], pfr[B * 3], jf0[B * AACMM_JAC_SIZE],
        jf1[B * AACMM_JAC_SIZE], jfr[B * AACMM_JAC_SIZE];
    aacmm_params_f64_t pr;
    aacmm_params_f32_t pf;
    aacmm_model_f64_t m;
    aacmm_model_f32_t mf;
    int k;
    int peer = -1; /* the first fused kernel available */
    (void)state;
    perturbed_params(&pr);
    assert_int_equal(aacmm_model_init_f64(&m, &pr), AACMM_OK);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_OK);
    for (k = 1; k < AACMM_KERNEL_COUNT; k++) {
        const aacmm_kernel_t kk = (aacmm_kernel_t)k;
        const int fused = aacmm_kernel_fused(kk);
        test_rng_t g = {UINT64_C(0x5EED) + (uint64_t)k};
        double worst_p = 0.0, worst_j = 0.0, worst_f = 0.0, worst_s = 0.0;
        double peer_d = 0.0; /* largest difference from the fused peer */
        double s0[AACMM_JAC_SIZE] = {0}, q0[AACMM_JAC_SIZE] = {0};
        double s1[AACMM_JAC_SIZE] = {0}, q1[AACMM_JAC_SIZE] = {0};
        int b, i;
        if (!aacmm_kernel_available(kk)) {
            printf("kernel %s: not available on this CPU\n", aacmm_kernel_name(kk));
            continue;
        }
        if (fused && peer < 0) {
            peer = k;
        }
        for (b = 0; b < BATCHES; b++) {
            size_t done = 0u;
            for (i = 0; i < B * 6; i++) {
                th[i] = rng_uniform(&g, -PI, PI);
                thf[i] = (float)th[i];
            }
            assert_int_equal(aacmm_batch_angles_f64(&m, B, th, p0, j0, NULL), AACMM_OK);
            assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, B, th, p1, j1, &done), AACMM_OK);
            assert_int_equal((int)done, B);
            for (i = 0; i < B * 3; i++) {
                worst_p = fmax(worst_p, fabs(p1[i] - p0[i]));
            }
            worst_j = fmax(worst_j, rel_diff(j1, j0, B * AACMM_JAC_SIZE));
            if (fused && peer != k) {
                assert_int_equal(aacmm_simd_batch_angles_f64((aacmm_kernel_t)peer, &m, B, th, pr0,
                                                             j0, NULL),
                                 AACMM_OK);
                for (i = 0; i < B * 3; i++) {
                    peer_d = fmax(peer_d, fabs(p1[i] - pr0[i]));
                }
                peer_d = fmax(peer_d, rel_diff(j1, j0, B * AACMM_JAC_SIZE));
            }
            if (b % 10 == 0) {
                assert_int_equal(aacmm_batch_angles_f32(&mf, B, thf, pf0, jf0, NULL), AACMM_OK);
                assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, B, thf, pf1, jf1, NULL),
                                 AACMM_OK);
                worst_f = fmax(worst_f, abs_diff_f32(pf1, pf0, B * 3));
                worst_f = fmax(worst_f, abs_diff_f32(jf1, jf0, B * AACMM_JAC_SIZE));
                if (fused && peer != k) {
                    assert_int_equal(aacmm_simd_batch_angles_f32((aacmm_kernel_t)peer, &mf, B, thf,
                                                                 pfr, jfr, NULL),
                                     AACMM_OK);
                    peer_d = fmax(peer_d, abs_diff_f32(pf1, pfr, B * 3));
                    peer_d = fmax(peer_d, abs_diff_f32(jf1, jfr, B * AACMM_JAC_SIZE));
                }
                /* points only: the same points as with the Jacobian */
                assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, B, th, pr0, NULL, NULL),
                                 AACMM_OK);
                assert_memory_equal(pr0, p1, sizeof pr0);
                assert_int_equal(aacmm_abs_jacobian_sums_f64(&m, B, th, s0, q0, NULL), AACMM_OK);
                assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, B, th, s1, q1, NULL),
                                 AACMM_OK);
            }
        }
        for (i = 0; i < AACMM_JAC_SIZE; i++) {
            worst_s = fmax(worst_s, fabs(s1[i] - s0[i]) / fmax(1.0, s0[i]));
            worst_s = fmax(worst_s, fabs(q1[i] - q0[i]) / fmax(1.0, q0[i]));
        }
        printf("measured: kernel %s%s vs scalar, %d poses: point max %.3g mm, Jacobian max %.3g "
               "(relative to max(1, |entry|)); f32 max %.3g (%d poses); |J| sums max %.3g "
               "(relative)\n",
               aacmm_kernel_name(kk), fused ? " (FMA)" : "", B * BATCHES, worst_p, worst_j,
               worst_f, B * BATCHES / 10, worst_s);
        assert_true(worst_p <= BOUND_SIMD_POINT_MM);
        assert_true(worst_j <= BOUND_SIMD_JAC);
        assert_true(worst_f <= BOUND_SIMD_F32);
        assert_true(worst_s <= 1e-12);
        if (!fused) {
            assert_true(worst_p <= 0.0 && worst_j <= 0.0 && worst_f <= 0.0); /* bit for bit */
        } else if (peer != k) {
            printf("measured: kernel %s vs %s (both FMA): max difference %.3g\n",
                   aacmm_kernel_name(kk), aacmm_kernel_name((aacmm_kernel_t)peer), peer_d);
            assert_true(peer_d <= 0.0); /* bit for bit */
        }
    }
}

/* The default model in both precisions and n random poses (th, and thf the
 * same angles rounded to float) for the batch tests. */
static void batch_setup(aacmm_model_f64_t *m, aacmm_model_f32_t *mf, double *th, float *thf,
                        int n, test_rng_t *g)
{
    aacmm_params_f32_t pf;
    int i;
    default_model(m);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_model_init_f32(mf, &pf), AACMM_OK);
    for (i = 0; i < n * 6; i++) {
        th[i] = rng_uniform(g, -PI, PI);
        thf[i] = (float)th[i];
    }
}

/* Batch semantics of every kernel: a pose's result does not depend on its
 * lane or its neighbours (bitwise, whatever the batch size and offset), the
 * first bad pose stops the batch with *done = the poses before it (written,
 * and summed), n = 0, NULL arguments, and a kernel this build or CPU cannot
 * run. */
static void test_simd_batch_semantics(void **state)
{
    enum { N = 50 };
    static double th[N * 6], P[N * 3], J[N * AACMM_JAC_SIZE], P2[N * 3], J2[N * AACMM_JAC_SIZE];
    static float thf[N * 6], Pf[N * 3], Jf[N * AACMM_JAC_SIZE], Pf2[N * 3],
        Jf2[N * AACMM_JAC_SIZE];
    aacmm_model_f64_t m;
    aacmm_model_f32_t mf;
    test_rng_t g = {31u};
    int k, i;
    (void)state;
    batch_setup(&m, &mf, th, thf, N, &g);
    assert_int_equal(aacmm_kernel_available(AACMM_KERNEL_SCALAR), 1);
    assert_int_equal(aacmm_kernel_available((aacmm_kernel_t)7), 0);
    assert_int_equal(aacmm_simd_batch_angles_f64((aacmm_kernel_t)7, &m, N, th, P, J, NULL),
                     AACMM_ERR_UNSUPPORTED);
    assert_string_equal(aacmm_kernel_name((aacmm_kernel_t)7), "unknown");
    assert_int_equal((int)aacmm_kernel_lanes((aacmm_kernel_t)7, 0), 0);
    assert_true(aacmm_kernel_available(aacmm_kernel_best()));
    for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
        const aacmm_kernel_t kk = (aacmm_kernel_t)k;
        const int lanes = (int)aacmm_kernel_lanes(kk, 0);
        size_t done = 99u;
        int n, off;
        double s[AACMM_JAC_SIZE] = {0}, q[AACMM_JAC_SIZE] = {0};
        double s17[AACMM_JAC_SIZE] = {0}, q17[AACMM_JAC_SIZE] = {0};
        if (!aacmm_kernel_available(kk)) {
            assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, N, th, P, J, NULL),
                             AACMM_ERR_UNSUPPORTED);
            continue;
        }
        assert_int_equal((int)aacmm_kernel_lanes(kk, 1), k == 0 ? 1 : 2 * lanes);
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, N, th, P, J, &done), AACMM_OK);
        assert_int_equal((int)done, N);
        assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, N, thf, Pf, Jf, &done), AACMM_OK);
        for (off = 0; off < 3; off++) {
            for (n = 0; n + off <= N; n += (n < 20 ? 1 : 7)) {
                assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, (size_t)n, th + 6 * off, P2,
                                                             J2, &done),
                                 AACMM_OK);
                assert_int_equal((int)done, n);
                assert_memory_equal(P2, P + 3 * off, sizeof(double) * 3u * (size_t)n);
                assert_memory_equal(J2, J + AACMM_JAC_SIZE * off,
                                    sizeof(double) * AACMM_JAC_SIZE * (size_t)n);
                assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, (size_t)n, thf + 6 * off,
                                                             Pf2, Jf2, NULL),
                                 AACMM_OK);
                assert_memory_equal(Pf2, Pf + 3 * off, sizeof(float) * 3u * (size_t)n);
                assert_memory_equal(Jf2, Jf + AACMM_JAC_SIZE * off,
                                    sizeof(float) * AACMM_JAC_SIZE * (size_t)n);
            }
        }
        /* the first bad pose stops the batch; the poses before it are written */
        th[6 * 17 + 2] = (double)NAN;
        memset(P2, 0, sizeof P2);
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, N, th, P2, J2, &done),
                         AACMM_ERR_NOT_FINITE);
        assert_int_equal((int)done, 17);
        assert_memory_equal(P2, P, sizeof(double) * 3u * 17u);
        assert_memory_equal(J2, J, sizeof(double) * AACMM_JAC_SIZE * 17u);
        assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, N, th, s, q, &done),
                         AACMM_ERR_NOT_FINITE);
        assert_int_equal((int)done, 17);
        assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, 17u, th, s17, q17, &done),
                         AACMM_OK);
        assert_memory_equal(s, s17, sizeof s);
        assert_memory_equal(q, q17, sizeof q);
        th[6 * 17 + 2] = 1024.5;
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, N, th, P2, NULL, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 17);
        thf[6 * 3] = -INFINITY;
        assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, N, thf, Pf2, Jf2, &done),
                         AACMM_ERR_NOT_FINITE);
        assert_int_equal((int)done, 3);
        thf[6 * 3] = (float)th[6 * 3];
        th[6 * 17 + 2] = -1024.0; /* the limit itself is accepted */
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, N, th, P2, NULL, &done), AACMM_OK);
        th[6 * 17 + 2] = (double)thf[6 * 17 + 2];
        /* n = 0 and NULL arguments */
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, 0, NULL, NULL, NULL, &done),
                         AACMM_OK);
        assert_int_equal((int)done, 0);
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, NULL, 1, th, P, NULL, NULL),
                         AACMM_ERR_NULL);
        assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, 1, NULL, Pf, NULL, NULL),
                         AACMM_ERR_NULL);
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, 1, th, NULL, J, NULL),
                         AACMM_ERR_NULL);
        assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, 1, th, NULL, q, NULL),
                         AACMM_ERR_NULL);
        assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, 0, NULL, s, q, &done), AACMM_OK);
        assert_int_equal((int)done, 0);
        /* the scaled form: the sums of the poses formed first, bit for bit */
        {
            static const double scale[6] = {6.2, 6.1, 6.0, 5.9, 5.8, 5.7};
            static const double offset[6] = {-3.1, -3.0, -2.9, -2.8, -2.7, -2.6};
            double unit[N * 6], formed[N * 6];
            double s1[AACMM_JAC_SIZE] = {0}, q1[AACMM_JAC_SIZE] = {0};
            double s2[AACMM_JAC_SIZE] = {0}, q2[AACMM_JAC_SIZE] = {0};
            for (i = 0; i < N * 6; i++) {
                unit[i] = (double)(uint32_t)rng_next(&g) * 0x1p-32;
                formed[i] = unit[i] * scale[i % 6];
                formed[i] += offset[i % 6];
            }
            assert_int_equal(aacmm_simd_abs_jacobian_sums_f64(kk, &m, N, formed, s1, q1, NULL),
                             AACMM_OK);
            assert_int_equal(aacmm_simd_abs_jacobian_sums_scaled_f64(kk, &m, N, unit, scale, offset,
                                                                     s2, q2, &done),
                             AACMM_OK);
            assert_int_equal((int)done, N);
            assert_memory_equal(s1, s2, sizeof s1);
            assert_memory_equal(q1, q2, sizeof q1);
            assert_int_equal(aacmm_simd_abs_jacobian_sums_scaled_f64(kk, &m, N, unit, scale, NULL,
                                                                     s2, q2, NULL),
                             AACMM_ERR_NULL);
        }
    }
}

/* The tiled layout (aacmm_simd_batch_angles_tiled_*), every kernel, both
 * precisions: each entry of each pose where the layout puts it, equal bit for
 * bit to the row-major call with the same kernel, for every batch size (tile
 * boundaries, short last tiles), at an output address that is not 64-byte
 * aligned too; the padding lanes of the last tile copy its last pose; the
 * first bad pose stops the batch as in the row-major call; NULL and
 * unsupported-kernel errors. */
#define TILED_CHECK(REALT, T, tiled_fn, model, th, P, J, Pt, Jt, n, off)                         \
    do {                                                                                           \
        size_t done_ = 99u, l_, e_;                                                                \
        REALT *jt_ = (Jt) + (off);                                                                 \
        assert_int_equal(tiled_fn(kk, model, (size_t)(n), th, Pt, jt_, &done_), AACMM_OK);         \
        assert_int_equal((int)done_, (n));                                                         \
        assert_memory_equal(Pt, P, sizeof(REALT) * 3u * (size_t)(n));                             \
        for (l_ = 0; l_ < ((size_t)(n) + (T) - 1u) / (T) * (T); l_++) {                            \
            const size_t src_ = l_ < (size_t)(n) ? l_ : (size_t)(n) - 1u;                          \
            for (e_ = 0; e_ < AACMM_JAC_SIZE; e_++) {                                              \
                assert_memory_equal(&jt_[(l_ / (T)) * (T) * AACMM_JAC_SIZE + e_ * (T) + l_ % (T)], \
                                    &(J)[src_ * AACMM_JAC_SIZE + e_], sizeof(REALT));              \
            }                                                                                      \
        }                                                                                          \
    } while (0)

static void test_simd_tiled_layout(void **state)
{
    enum { N = 50 };
    static double th[N * 6], P[N * 3], J[N * AACMM_JAC_SIZE], Pt[N * 3];
    static double Jt[AACMM_SIMD_TILED_SIZE(N, AACMM_SIMD_TILE_F64) + 1];
    static float thf[N * 6], Pf[N * 3], Jf[N * AACMM_JAC_SIZE], Pft[N * 3];
    static float Jft[AACMM_SIMD_TILED_SIZE(N, AACMM_SIMD_TILE_F32) + 1];
    aacmm_model_f64_t m;
    aacmm_model_f32_t mf;
    test_rng_t g = {47u};
    int k, i, n;
    (void)state;
    batch_setup(&m, &mf, th, thf, N, &g);
    assert_int_equal(AACMM_SIMD_TILED_SIZE(17u, 8u), 3u * 8u * AACMM_JAC_SIZE);
    assert_int_equal(aacmm_simd_batch_angles_tiled_f64((aacmm_kernel_t)7, &m, N, th, Pt, Jt, NULL),
                     AACMM_ERR_UNSUPPORTED);
    for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
        const aacmm_kernel_t kk = (aacmm_kernel_t)k;
        size_t done = 99u;
        if (!aacmm_kernel_available(kk)) {
            assert_int_equal(aacmm_simd_batch_angles_tiled_f32(kk, &mf, N, thf, Pft, Jft, NULL),
                             AACMM_ERR_UNSUPPORTED);
            continue;
        }
        for (n = 1; n <= N; n++) {
            assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, (size_t)n, th, P, J, NULL),
                             AACMM_OK);
            assert_int_equal(aacmm_simd_batch_angles_f32(kk, &mf, (size_t)n, thf, Pf, Jf, NULL),
                             AACMM_OK);
            TILED_CHECK(double, (size_t)AACMM_SIMD_TILE_F64, aacmm_simd_batch_angles_tiled_f64, &m,
                        th, P, J, Pt, Jt, n, (size_t)(n % 2));
            TILED_CHECK(float, (size_t)AACMM_SIMD_TILE_F32, aacmm_simd_batch_angles_tiled_f32, &mf,
                        thf, Pf, Jf, Pft, Jft, n, (size_t)(n % 2));
        }
        /* the first bad pose stops the batch; the poses before it are written */
        th[6 * 17 + 4] = (double)NAN;
        assert_int_equal(aacmm_simd_batch_angles_tiled_f64(kk, &m, N, th, Pt, Jt, &done),
                         AACMM_ERR_NOT_FINITE);
        assert_int_equal((int)done, 17);
        th[6 * 17 + 4] = (double)thf[6 * 17 + 4];
        thf[6 * 5] = 2000.0f;
        assert_int_equal(aacmm_simd_batch_angles_tiled_f32(kk, &mf, N, thf, Pft, Jft, &done),
                         AACMM_ERR_RANGE);
        assert_int_equal((int)done, 5);
        thf[6 * 5] = (float)th[6 * 5];
        assert_int_equal(aacmm_simd_batch_angles_f64(kk, &m, 17u, th, P, J, NULL), AACMM_OK);
        for (i = 0; i < 17; i++) {
            int e;
            for (e = 0; e < AACMM_JAC_SIZE; e++) {
                assert_memory_equal(&Jt[(i / 8) * 8 * AACMM_JAC_SIZE + e * 8 + i % 8],
                                    &J[i * AACMM_JAC_SIZE + e], sizeof(double));
            }
        }
        /* n = 0 and NULL arguments */
        assert_int_equal(aacmm_simd_batch_angles_tiled_f64(kk, &m, 0, NULL, NULL, NULL, &done),
                         AACMM_OK);
        assert_int_equal((int)done, 0);
        assert_int_equal(aacmm_simd_batch_angles_tiled_f64(kk, &m, 1, th, Pt, NULL, NULL),
                         AACMM_ERR_NULL);
        assert_int_equal(aacmm_simd_batch_angles_tiled_f32(kk, NULL, 1, thf, Pft, Jft, NULL),
                         AACMM_ERR_NULL);
    }
}
#undef TILED_CHECK

/* The paper's arm computes bit for bit what the core of commit aa8b712 (the
 * last one before the general arm model) computed, on every path: the hash
 * of every output of tests/core/legacy_paths.h against the one that core
 * gave (tests/core/legacy_golden.h, scripts/legacy-golden.sh). Per batch
 * kernel available here; a fused kernel without a golden of its own (AVX-512
 * where the golden was made on a CPU without it) is held to its fused peer's
 * point and Jacobian hashes (the fused kernels agree bit for bit,
 * test_simd_agrees_with_scalar), its lane-order sums to nothing. Run on the
 * paper's chains, and (test_legacy_golden_general) on the general ones. */
static void legacy_golden_check(int general)
{
    static const uint64_t scalar_golden[LEGACY_SCALAR_PATHS] = {
        LEGACY_GOLDEN_f64_point,          LEGACY_GOLDEN_f64_point_jacobian,
        LEGACY_GOLDEN_f64_batch,          LEGACY_GOLDEN_f64_counts,
        LEGACY_GOLDEN_f32_point_jacobian, LEGACY_GOLDEN_f32_batch,
        LEGACY_GOLDEN_analysis_sums};
    static const uint64_t simd_golden[AACMM_KERNEL_COUNT][LEGACY_SIMD_PATHS] = {
        {LEGACY_GOLDEN_simd_f64_scalar, LEGACY_GOLDEN_simd_f32_scalar,
         LEGACY_GOLDEN_simd_sums_scalar},
        {LEGACY_GOLDEN_simd_f64_vec128, LEGACY_GOLDEN_simd_f32_vec128,
         LEGACY_GOLDEN_simd_sums_vec128},
        {LEGACY_GOLDEN_simd_f64_avx2, LEGACY_GOLDEN_simd_f32_avx2, LEGACY_GOLDEN_simd_sums_avx2},
#ifdef LEGACY_GOLDEN_simd_f64_avx512
        {LEGACY_GOLDEN_simd_f64_avx512, LEGACY_GOLDEN_simd_f32_avx512,
         LEGACY_GOLDEN_simd_sums_avx512},
#else
        {LEGACY_GOLDEN_simd_f64_avx2, LEGACY_GOLDEN_simd_f32_avx2, 0u},
#endif
    };
    int i, k;
    legacy_force_general = general;
    printf("legacy golden: %s\n", general ? "the general chains (paper flag cleared)"
                                           : "the paper's chains");
    for (i = 0; i < LEGACY_SCALAR_PATHS; i++) {
        const uint64_t h = legacy_scalar_hash(i);
        printf("legacy golden %-20s %016llx %s\n", legacy_scalar_names[i], (unsigned long long)h,
               h == scalar_golden[i] ? "same" : "DIFFERS");
        assert_true(h == scalar_golden[i]);
    }
    for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
        if (!aacmm_kernel_available((aacmm_kernel_t)k)) {
            printf("legacy golden: kernel %s not available on this CPU\n",
                   aacmm_kernel_name((aacmm_kernel_t)k));
            continue;
        }
        for (i = 0; i < LEGACY_SIMD_PATHS; i++) {
            char name[48];
            uint64_t h;
            snprintf(name, sizeof name, "%s_%s", legacy_simd_names[i],
                     aacmm_kernel_name((aacmm_kernel_t)k));
            if (simd_golden[k][i] == 0u) {
                printf("legacy golden %s: no golden (made on a CPU without the kernel)\n", name);
                continue;
            }
            h = legacy_simd_hash(i, (aacmm_kernel_t)k);
            printf("legacy golden %-20s %016llx %s\n", name, (unsigned long long)h,
                   h == simd_golden[k][i] ? "same" : "DIFFERS");
            assert_true(h == simd_golden[k][i]);
        }
    }
    legacy_force_general = 0;
}

static void test_legacy_golden(void **state)
{
    (void)state;
    legacy_golden_check(0);
}

/* The general chains (CH_GENERAL 1, SH_GENERAL 1) on the paper's arm: the
 * same operations, so the same hashes. */
static void test_legacy_golden_general(void **state)
{
    (void)state;
    legacy_golden_check(1);
}


int main(void)
{
    /* Accuracy tests: once per kernel (through k_point_f64 and friends). */
    const struct CMUnitTest accuracy[] = {
        cmocka_unit_test(test_point_matches_reference),
        cmocka_unit_test(test_point_jacobian_same_point),
        cmocka_unit_test(test_jacobian_vs_central_differences),
        cmocka_unit_test(test_jacobian_vs_reference_differences),
        cmocka_unit_test(test_paper_identities),
        cmocka_unit_test(test_zero_pose_by_hand),
        cmocka_unit_test(test_f32_vs_f64),
    };
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sincos_accuracy),
        cmocka_unit_test(test_encoder_edge_table),
        cmocka_unit_test(test_encoder_angles_exact),
        cmocka_unit_test(test_encoder_bam),
        cmocka_unit_test(test_encoder_invalid),
        cmocka_unit_test(test_params_invalid),
        cmocka_unit_test(test_bad_angles_and_nulls),
        cmocka_unit_test(test_batches),
        cmocka_unit_test(test_status_strings),
        cmocka_unit_test(test_simd_agrees_with_scalar),
        cmocka_unit_test(test_simd_batch_semantics),
        cmocka_unit_test(test_simd_tiled_layout),
        cmocka_unit_test(test_legacy_golden),
        cmocka_unit_test(test_legacy_golden_general),
    };
    int failed = 0, k;
    for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
        char name[64];
        kernel = (aacmm_kernel_t)k;
        if (!aacmm_kernel_available(kernel)) {
            printf("kernel %s: not available on this CPU (its accuracy tests cannot run here)\n",
                   aacmm_kernel_name(kernel));
            continue;
        }
        snprintf(name, sizeof name, "kinematics accuracy, kernel %s", aacmm_kernel_name(kernel));
        failed += cmocka_run_group_tests_name(name, accuracy, NULL, NULL);
    }
    kernel = AACMM_KERNEL_SCALAR;
    failed += cmocka_run_group_tests_name("kinematics", tests, NULL, NULL);
    return failed;
}
