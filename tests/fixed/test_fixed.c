/*
 * Fixed-point kinematics tests: the integer path (kinematics_q.h) against the
 * double-precision core (itself checked against a long-double reference in
 * tests/core) and against that long-double reference directly; the sine
 * table and sine/cosine; an edge-case table of poses, encoder readings and
 * parameter blocks at the representable limits; validation and null
 * pointers. The f32 core is measured on the same poses for comparison.
 *
 * Measured maxima are printed as "measured: ..." lines; docs/fixed-point.md
 * quotes them. Every bound asserted here is stated there.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"
#include "reference.h"

#define LEGACY_FIXED_PATHS
#include "legacy_golden.h"
#include "legacy_paths.h"

/* The library's formulation in this build (the test itself compiles the
 * split multiply below whatever the library uses). */
#ifdef AACMM_Q_SPLIT_MUL
#define LIB_SPLIT_MUL 1
#else
#define LIB_SPLIT_MUL 0
#endif

/* The split 32 x 32 -> 64 multiply that the Cortex-M0+ build uses, compiled
 * here on the host so it is tested in every build (the library itself uses
 * it only on ARMv6-M, or everywhere with -DAACMM_Q_SPLIT_MUL, as in the
 * sanitizer build). */
#ifndef AACMM_Q_SPLIT_MUL
#define AACMM_Q_SPLIT_MUL 1
#endif
#include "fixed_sincos.h"

#ifndef FIXED_TEST_POSES
#define FIXED_TEST_POSES 1000000L /* the plain builds; the ASan build uses fewer */
#endif

#define PI 3.14159265358979323846
#define TWO_PI_LD 6.283185307179586476925286766559005768L

/* Bounds asserted below (the targets; docs/fixed-point.md). */
#define BOUND_POINT_MM 1e-4   /* per coordinate */
#define BOUND_JAC 1e-4        /* per entry, mm/rad or mm/mm */
#define BOUND_SINCOS 1.0e-9   /* absolute, Q30 LSB is 9.3e-10 */
#define BOUND_PARAM_QUANT 1e-4 /* end to end, including parameter quantisation */

#define Q48_TO_MM(x) ((double)(x) * 0x1p-48)

/* ------------------------------------------------------------------------ */
/* Helpers                                                                   */
/* ------------------------------------------------------------------------ */

/* The exact angle of a binary angle, signed, as a double (|error| < 1e-15). */
static double bam_rad(uint32_t b)
{
    int64_t s = (b >= 0x80000000u) ? (int64_t)b - (INT64_C(1) << 32) : (int64_t)b;
    return (double)s * (2.0 * PI / 4294967296.0);
}

static long double bam_rad_ld(uint32_t b)
{
    int64_t s = (b >= 0x80000000u) ? (int64_t)b - (INT64_C(1) << 32) : (int64_t)b;
    return (long double)s * (TWO_PI_LD / 4294967296.0L);
}

static void random_bam_pose(test_rng_t *g, uint32_t th[6])
{
    int i;
    for (i = 0; i < 6; i++) {
        th[i] = (uint32_t)(rng_next(g) >> 32);
    }
}

/* Table 1 with every parameter perturbed (as in tests/core), so that no
 * Jacobian term vanishes by symmetry. */
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

/* Fixed-point model plus the double model of exactly its parameters. */
typedef struct {
    aacmm_params_q_t pq;
    aacmm_model_q_t mq;
    aacmm_params_f64_t pd; /* the exact values the fixed block stands for */
    aacmm_model_f64_t md;
} pair_t;

static void make_pair_q(pair_t *m, const aacmm_params_q_t *pq)
{
    m->pq = *pq;
    assert_int_equal(aacmm_model_q_init(&m->mq, pq), AACMM_OK);
    assert_int_equal(aacmm_params_q_to_f64(&m->pd, pq), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(&m->md, &m->pd), AACMM_OK);
}

static void make_pair(pair_t *m, const aacmm_params_f64_t *p)
{
    aacmm_params_q_t pq;
    assert_int_equal(aacmm_params_q_from_f64(&pq, p), AACMM_OK);
    make_pair_q(m, &pq);
}

typedef struct {
    double point; /* max |error| per point coordinate, mm */
    double jac;   /* max |error| per Jacobian entry */
    int jac_col;  /* column of the worst Jacobian entry */
} err_t;

/* Fixed point and Jacobian for one BAM pose against the double core on the
 * same parameters and the exact angles; accumulates the maxima. Also checks
 * that aacmm_point_q gives the same point bit for bit. */
static void compare_pose(const pair_t *m, const uint32_t th[6], err_t *e, int check_point_only)
{
    int64_t pq[3], pq2[3], jq[AACMM_JAC_SIZE];
    double thd[6], pd[3], jd[AACMM_JAC_SIZE];
    int i;
    for (i = 0; i < 6; i++) {
        thd[i] = bam_rad(th[i]);
    }
    assert_int_equal(aacmm_point_jacobian_q(&m->mq, th, pq, jq), AACMM_OK);
    assert_int_equal(aacmm_point_jacobian_f64(&m->md, thd, pd, jd), AACMM_OK);
    if (check_point_only) {
        assert_int_equal(aacmm_point_q(&m->mq, th, pq2), AACMM_OK);
        assert_memory_equal(pq, pq2, sizeof pq);
    }
    for (i = 0; i < 3; i++) {
        double d = fabs(Q48_TO_MM(pq[i]) - pd[i]);
        if (d > e->point) {
            e->point = d;
        }
    }
    for (i = 0; i < AACMM_JAC_SIZE; i++) {
        double d = fabs(Q48_TO_MM(jq[i]) - jd[i]);
        if (d > e->jac) {
            e->jac = d;
            e->jac_col = i % AACMM_JAC_COLS;
        }
    }
}

/* ------------------------------------------------------------------------ */
/* Sine and cosine                                                           */
/* ------------------------------------------------------------------------ */

static void test_sin_table(void **state)
{
    /* The table is not public; its values are visible through the nodes:
     * at angle k * 2^22 the remainder is 0 and sincos returns the entries. */
    int k;
    (void)state;
    for (k = 0; k < 1024; k++) {
        int32_t s, c;
        long double want = sinl((long double)k * (TWO_PI_LD / 1024.0L)) * 1073741824.0L;
        long double wantc = cosl((long double)k * (TWO_PI_LD / 1024.0L)) * 1073741824.0L;
        aacmm_sincos_q((uint32_t)k << 22, &s, &c);
        /* correctly rounded: within half an LSB (plus the reference's own error) */
        if (fabsl((long double)s - want) > 0.5L + 1e-6L || fabsl((long double)c - wantc) > 0.5L + 1e-6L) {
            fail_msg("node %d: sin %d cos %d, want %.3Lf %.3Lf", k, s, c, want, wantc);
        }
    }
}

static void check_sincos(uint32_t b, double *worst)
{
    int32_t s, c;
    long double x = bam_rad_ld(b);
    double es, ec;
    aacmm_sincos_q(b, &s, &c);
    es = (double)fabsl((long double)s * 0x1p-30L - sinl(x));
    ec = (double)fabsl((long double)c * 0x1p-30L - cosl(x));
    if (es > *worst) {
        *worst = es;
    }
    if (ec > *worst) {
        *worst = ec;
    }
    assert_true(s <= AACMM_Q_ONE_Q30 && s >= -AACMM_Q_ONE_Q30);
    assert_true(c <= AACMM_Q_ONE_Q30 && c >= -AACMM_Q_ONE_Q30);
}

static void test_sincos_accuracy(void **state)
{
    test_rng_t g = {UINT64_C(0x5EED5EED)};
    double worst = 0.0;
    long k;
    uint32_t n;
    (void)state;
    for (k = 0; k < 4 * FIXED_TEST_POSES; k++) {
        check_sincos((uint32_t)(rng_next(&g) >> 32), &worst);
    }
    /* every node, the interval ends on both sides, and their neighbours */
    for (n = 0; n < 1024u; n++) {
        uint32_t node = n << 22;
        check_sincos(node, &worst);
        check_sincos(node + 1u, &worst);
        check_sincos(node - 1u, &worst);
        check_sincos(node + (1u << 21), &worst);
        check_sincos(node + (1u << 21) - 1u, &worst);
        check_sincos(node - (1u << 21), &worst);
        check_sincos(node - (1u << 21) - 1u, &worst);
    }
    printf("measured: aacmm_sincos_q error vs sinl/cosl, %ld random + 7168 structured angles: "
           "max %.3g (%.3f LSB of Q30)\n",
           4 * FIXED_TEST_POSES, worst, worst * 1073741824.0);
    assert_true(worst <= BOUND_SINCOS);
}

static void check_mul(int32_t a, int32_t b)
{
    int64_t want = (int64_t)a * (int64_t)b;
    int64_t got = aacmm_fixed_mul(a, b);
    if (got != want) {
        fail_msg("aacmm_fixed_mul(%ld, %ld) = %lld, want %lld", (long)a, (long)b, (long long)got,
                 (long long)want);
    }
}

/* The 32-bit form of aacmm_fixed_mul_q30 (the M0+'s, compiled here) against
 * (a b + 2^29) >> 30 with the native product, for operands within its range
 * |a|, |b| <= 2^30 + 2^14. */
static void check_mul_q30(int32_t a, int32_t b)
{
    int32_t want = (int32_t)(((int64_t)a * b + ((int64_t)1 << 29)) >> 30);
    int32_t got = aacmm_fixed_mul_q30(a, b);
    if (got != want) {
        fail_msg("aacmm_fixed_mul_q30(%ld, %ld) = %ld, want %ld", (long)a, (long)b, (long)got,
                 (long)want);
    }
}

static void test_split_multiply_q30(void **state)
{
    static const int32_t lim = (1 << 30) + (1 << 14);
    static const int32_t edge[] = {0,          1,          -1,        32767,      -32768,
                                   32768,      -32769,     65535,     -65536,     (1 << 29),
                                   (1 << 30) - 1, (1 << 30), (1 << 30) + 1, -(1 << 30) + 1,
                                   -(1 << 30), -(1 << 30) - 1, lim,    -lim,       lim - 1,
                                   -lim + 1,   0x3FFF8000, -0x3FFF8000, 0x3FFF7FFF};
    test_rng_t g = {4242u};
    size_t i, j;
    long k;
    (void)state;
    for (i = 0; i < sizeof edge / sizeof edge[0]; i++) {
        for (j = 0; j < sizeof edge / sizeof edge[0]; j++) {
            check_mul_q30(edge[i], edge[j]);
        }
    }
    for (k = 0; k < FIXED_TEST_POSES; k++) {
        uint64_t r = rng_next(&g);
        /* uniform in [-lim, lim], and smaller magnitudes */
        int32_t a = (int32_t)((int64_t)(r >> 32) % (2 * (int64_t)lim + 1) - lim);
        int32_t b = (int32_t)((int64_t)(uint32_t)r % (2 * (int64_t)lim + 1) - lim);
        check_mul_q30(a, b);
        check_mul_q30(a >> (r & 31u), b);
    }
}

static void test_split_multiply(void **state)
{
    static const int32_t edge[] = {0,      1,       -1,      2,         -2,        32767,
                                   -32768, 32768,   -32769,  65535,     -65535,    65536,
                                   -65536, 65537,   1 << 30, -(1 << 30), INT32_MAX, INT32_MIN,
                                   INT32_MIN + 1, 0x7FFF8000, -0x7FFF8000, 0x0000FFFF, 0x7FFF0001};
    test_rng_t g = {99991u};
    size_t i, j;
    long k;
    (void)state;
    assert_int_equal(AACMM_FIXED_SPLIT_MUL, 1);
    for (i = 0; i < sizeof edge / sizeof edge[0]; i++) {
        for (j = 0; j < sizeof edge / sizeof edge[0]; j++) {
            check_mul(edge[i], edge[j]);
        }
    }
    for (k = 0; k < FIXED_TEST_POSES; k++) {
        uint64_t r = rng_next(&g);
        /* full-range words, and words near a power of two */
        int32_t a = (int32_t)(uint32_t)(r >> 32);
        int32_t b = (int32_t)(uint32_t)r;
        check_mul(a, b);
        check_mul((int32_t)(a >> (r & 31u)), b);
    }
}

static void test_sincos_exact_points(void **state)
{
    static const struct {
        uint32_t b;
        int32_t s, c;
    } cases[] = {
        {0x00000000u, 0, AACMM_Q_ONE_Q30},  {0x40000000u, AACMM_Q_ONE_Q30, 0},
        {0x80000000u, 0, -AACMM_Q_ONE_Q30}, {0xC0000000u, -AACMM_Q_ONE_Q30, 0},
    };
    size_t k;
    int32_t s, c, s2, c2;
    (void)state;
    for (k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        aacmm_sincos_q(cases[k].b, &s, &c);
        assert_int_equal(s, cases[k].s);
        assert_int_equal(c, cases[k].c);
    }
    /* 0xFFFFFFFF is -1 BAM: sin = -1.46e-9 (about -1.6 LSB), cos = 1 */
    aacmm_sincos_q(0xFFFFFFFFu, &s, &c);
    assert_true(s == -2 || s == -1);
    assert_int_equal(c, AACMM_Q_ONE_Q30);
    /* symmetry: sin(-x) = -sin(x), cos(-x) = cos(x) to within 1 LSB (the
     * table is symmetric; the truncated Q39 intermediates are not quite) */
    {
        test_rng_t g = {17u};
        int n;
        for (n = 0; n < 100000; n++) {
            uint32_t b = (uint32_t)(rng_next(&g) >> 32);
            aacmm_sincos_q(b, &s, &c);
            aacmm_sincos_q(0u - b, &s2, &c2);
            assert_true(s2 + s <= 1 && s2 + s >= -1);
            assert_true(c2 - c <= 1 && c2 - c >= -1);
        }
    }
}

/* ------------------------------------------------------------------------ */
/* Random poses                                                              */
/* ------------------------------------------------------------------------ */

/*
 * The main accuracy test: FIXED_TEST_POSES (10^6) random binary-angle poses
 * on the paper's arm. For each pose:
 *   fixed:  point and Jacobian from aacmm_point_jacobian_q
 *   ref:    the double core on the exact values of the fixed parameters and
 *           the exact angles (arithmetic error of the fixed path)
 *   ref0:   the double core on the original double parameters (error
 *           including the quantisation of the parameters)
 *   f32:    the single-precision core on the same poses (angles rounded to
 *           float), against the double core on the same float inputs
 *           (arithmetic error, as in tests/core) and against ref0 (end to end).
 */
static void random_poses_on(const aacmm_params_f64_t *p0, long n, uint64_t seed, const char *name)
{
    pair_t m;
    aacmm_model_f64_t m0;
    aacmm_params_f32_t pf;
    aacmm_params_f64_t pfd;
    aacmm_model_f32_t mf;
    aacmm_model_f64_t mfd;
    test_rng_t g;
    err_t e = {0.0, 0.0, 0}, e_total = {0.0, 0.0, 0};
    double f32_p = 0.0, f32_j = 0.0, f32_tp = 0.0, f32_tj = 0.0;
    long k;
    int i;
    g.s = seed;
    make_pair(&m, p0);
    assert_int_equal(aacmm_model_init_f64(&m0, p0), AACMM_OK);
    for (i = 0; i < 6; i++) {
        pf.theta_offset_rad[i] = (float)p0->theta_offset_rad[i];
        pf.alpha_rad[i] = (float)p0->alpha_rad[i];
        pf.d_mm[i] = (float)p0->d_mm[i];
        pf.a_mm[i] = (float)p0->a_mm[i];
        pfd.theta_offset_rad[i] = (double)pf.theta_offset_rad[i];
        pfd.alpha_rad[i] = (double)pf.alpha_rad[i];
        pfd.d_mm[i] = (double)pf.d_mm[i];
        pfd.a_mm[i] = (double)pf.a_mm[i];
    }
    pf.l_mm = (float)p0->l_mm;
    pfd.l_mm = (double)pf.l_mm;
    assert_int_equal(aacmm_model_init_f32(&mf, &pf), AACMM_OK);
    assert_int_equal(aacmm_model_init_f64(&mfd, &pfd), AACMM_OK);

    for (k = 0; k < n; k++) {
        uint32_t th[6];
        int64_t pq[3], jq[AACMM_JAC_SIZE];
        double thd[6], p0d[3], j0d[AACMM_JAC_SIZE], pfdd[3], jfd[AACMM_JAC_SIZE];
        float thf[6], p32[3], j32[AACMM_JAC_SIZE];
        random_bam_pose(&g, th);
        compare_pose(&m, th, &e, k < 1000);
        /* totals against the original parameters */
        for (i = 0; i < 6; i++) {
            thd[i] = bam_rad(th[i]);
            thf[i] = (float)thd[i];
        }
        assert_int_equal(aacmm_point_jacobian_q(&m.mq, th, pq, jq), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_f64(&m0, thd, p0d, j0d), AACMM_OK);
        assert_int_equal(aacmm_point_jacobian_f32(&mf, thf, p32, j32), AACMM_OK);
        for (i = 0; i < 6; i++) {
            thd[i] = (double)thf[i];
        }
        assert_int_equal(aacmm_point_jacobian_f64(&mfd, thd, pfdd, jfd), AACMM_OK);
        for (i = 0; i < 3; i++) {
            double a = fabs(Q48_TO_MM(pq[i]) - p0d[i]);
            double b = fabs((double)p32[i] - pfdd[i]);
            double c = fabs((double)p32[i] - p0d[i]);
            e_total.point = a > e_total.point ? a : e_total.point;
            f32_p = b > f32_p ? b : f32_p;
            f32_tp = c > f32_tp ? c : f32_tp;
        }
        for (i = 0; i < AACMM_JAC_SIZE; i++) {
            double a = fabs(Q48_TO_MM(jq[i]) - j0d[i]);
            double b = fabs((double)j32[i] - jfd[i]);
            double c = fabs((double)j32[i] - j0d[i]);
            e_total.jac = a > e_total.jac ? a : e_total.jac;
            f32_j = b > f32_j ? b : f32_j;
            f32_tj = c > f32_tj ? c : f32_tj;
        }
    }
    printf("measured: %s, %ld random poses: fixed vs double on the same parameters: point max "
           "%.3g mm, Jacobian max %.3g (column %d)\n",
           name, n, e.point, e.jac, e.jac_col);
    printf("measured: %s: fixed vs double on the original parameters (with quantisation): point "
           "max %.3g mm, Jacobian max %.3g\n",
           name, e_total.point, e_total.jac);
    printf("measured: %s: f32 on the same poses: vs double on the same float inputs: point max "
           "%.3g mm, Jacobian max %.3g; vs double on exact angles and parameters: point max %.3g "
           "mm, Jacobian max %.3g\n",
           name, f32_p, f32_j, f32_tp, f32_tj);
    assert_true(e.point <= BOUND_POINT_MM);
    assert_true(e.jac <= BOUND_JAC);
    assert_true(e_total.point <= BOUND_PARAM_QUANT);
    assert_true(e_total.jac <= BOUND_PARAM_QUANT);
    /* "at least as accurate as single precision": on every pose set */
    assert_true(e.point <= f32_p && e.jac <= f32_j);
}

static void test_random_poses_table1(void **state)
{
    aacmm_params_f64_t p;
    (void)state;
    aacmm_params_default_f64(&p);
    random_poses_on(&p, FIXED_TEST_POSES, UINT64_C(0x9E3779B97F4A7C15), "Table 1 arm");
}

static void test_random_poses_perturbed(void **state)
{
    aacmm_params_f64_t p;
    (void)state;
    perturbed_params(&p);
    random_poses_on(&p, FIXED_TEST_POSES / 4, UINT64_C(0xC0FFEE), "perturbed arm");
}

/* The fixed point against the independent long-double reference of
 * tests/core (4x4 matrices, sinl/cosl): shares no code with either path. */
static void test_vs_long_double_reference(void **state)
{
    aacmm_params_f64_t p;
    pair_t m;
    test_rng_t g = {777u};
    double worst = 0.0;
    long k;
    (void)state;
    perturbed_params(&p);
    make_pair(&m, &p);
    for (k = 0; k < FIXED_TEST_POSES / 10; k++) {
        uint32_t th[6];
        int64_t pq[3];
        long double q[25], pr[3];
        int i;
        random_bam_pose(&g, th);
        assert_int_equal(aacmm_point_q(&m.mq, th, pq), AACMM_OK);
        for (i = 0; i < 6; i++) {
            q[i] = bam_rad_ld(th[i]) + bam_rad_ld(m.pq.theta_offset_bam[i]);
            q[6 + i] = bam_rad_ld(m.pq.alpha_bam[i]);
            q[12 + i] = (long double)m.pq.d_q18[i] * 0x1p-18L;
            q[18 + i] = (long double)m.pq.a_q18[i] * 0x1p-18L;
        }
        q[24] = (long double)m.pq.l_q18 * 0x1p-18L;
        ref_point(q, pr);
        for (i = 0; i < 3; i++) {
            double e = (double)fabsl((long double)pq[i] * 0x1p-48L - pr[i]);
            worst = e > worst ? e : worst;
        }
    }
    printf("measured: fixed point vs long-double reference, %ld poses: max %.3g mm\n",
           FIXED_TEST_POSES / 10, worst);
    assert_true(worst <= BOUND_POINT_MM);
}

/* ------------------------------------------------------------------------ */
/* Edge cases                                                                */
/* ------------------------------------------------------------------------ */

/* Poses: zero, wrap, quarter/half turns, the fully stretched and folded arm,
 * wrist singularities. Angles are BAM. */
#define Q1 0x40000000u
#define H2 0x80000000u
#define Q3 0xC0000000u
#define M1 0xFFFFFFFFu
static const uint32_t edge_poses[][6] = {
    {0, 0, 0, 0, 0, 0},                                /* zero pose (Table 1: folded) */
    {M1, M1, M1, M1, M1, M1},                          /* -1 BAM everywhere */
    {1, 1, 1, 1, 1, 1},                                /* +1 BAM */
    {Q1, Q1, Q1, Q1, Q1, Q1},                          /* quarter turns */
    {H2, H2, H2, H2, H2, H2},                          /* half turns */
    {Q3, Q3, Q3, Q3, Q3, Q3},                          /* three-quarter turns */
    {0x7FFFFFFFu, 0x80000001u, 0x7FFFFFFFu, 0x80000001u, 0x7FFFFFFFu, 0x80000001u},
    {0, H2, 0, H2, 0, 0},                              /* Table 1: fully stretched */
    {0, H2, 0, 0, 0, 0},                               /* elbow straight, wrist folded */
    {Q1, H2, Q3, 0, Q1, 0},                            /* wrist singular (theta_5 = 90) */
    {0, 0, 0, 0, 0, H2},                               /* only the last joint */
    {0x003FFFFFu, 0x00400000u, 0x00200000u, 0x001FFFFFu, 0xFFE00000u, 0xFFDFFFFFu}, /* node edges */
    {Q1 - 1u, Q1 + 1u, H2 - 1u, H2 + 1u, Q3 - 1u, Q3 + 1u},
};

static void edge_poses_on(const pair_t *m, err_t *e)
{
    size_t k;
    for (k = 0; k < sizeof edge_poses / sizeof edge_poses[0]; k++) {
        compare_pose(m, edge_poses[k], e, 1);
    }
}

/* Parameter blocks at the representable limits, each with the edge poses and
 * 10^4 random poses. */
static void limit_params(int which, aacmm_params_q_t *q)
{
    const int32_t L = (int32_t)AACMM_Q_REACH_MAX_Q18; /* 8000 mm in Q18 */
    int i;
    memset(q, 0, sizeof *q);
    for (i = 0; i < 6; i++) {
        q->alpha_bam[i] = AACMM_BAM_QUARTER;
    }
    switch (which) {
    case 0: /* the whole reach in the probe: l = 8000 mm */
        q->l_q18 = L;
        break;
    case 1: /* the whole reach in d_1 = -8000 mm */
        q->d_q18[0] = -L;
        break;
    case 2: /* reach split over all 13 lengths, alternating signs, sum exactly 8000 mm */
        for (i = 0; i < 6; i++) {
            q->d_q18[i] = (i & 1) ? -(L / 13) : L / 13;
            q->a_q18[i] = (i & 1) ? L / 13 : -(L / 13);
        }
        q->l_q18 = L - 12 * (L / 13);
        break;
    case 3: { /* Table 1 lengths tripled, a_3 takes the rest up to the limit;
               * extreme angles */
        int32_t rest = L;
        aacmm_params_default_q(q);
        q->l_q18 *= 3;
        rest -= q->l_q18;
        for (i = 0; i < 6; i++) {
            q->d_q18[i] *= 3;
            rest -= q->d_q18[i];
            q->alpha_bam[i] = (i & 1) ? 0xFFFFFFFFu : 0x80000001u;
            q->theta_offset_bam[i] = (i & 1) ? 0x7FFFFFFFu : 0x80000000u;
        }
        q->a_q18[2] = -rest;
        break;
    }
    default: /* alpha 0 and +-2 pi (BAM 0), every a at the limit share */
        for (i = 0; i < 6; i++) {
            q->alpha_bam[i] = 0u;
            q->a_q18[i] = L / 6;
            q->theta_offset_bam[i] = (uint32_t)i * 0x2AAAAAABu;
        }
        break;
    }
    assert_int_equal(aacmm_params_q_validate(q), AACMM_OK);
}

static void test_edge_table(void **state)
{
    aacmm_params_f64_t p;
    pair_t m;
    err_t e = {0.0, 0.0, 0};
    int which;
    (void)state;
    aacmm_params_default_f64(&p);
    make_pair(&m, &p);
    edge_poses_on(&m, &e);
    perturbed_params(&p);
    make_pair(&m, &p);
    edge_poses_on(&m, &e);
    printf("measured: edge poses (Table 1 and perturbed arm): point max %.3g mm, Jacobian max "
           "%.3g\n",
           e.point, e.jac);
    assert_true(e.point <= BOUND_POINT_MM);
    assert_true(e.jac <= BOUND_JAC);

    e.point = e.jac = 0.0;
    for (which = 0; which < 5; which++) {
        aacmm_params_q_t q;
        test_rng_t g;
        long k;
        g.s = (uint64_t)(1000 + which);
        limit_params(which, &q);
        make_pair_q(&m, &q);
        edge_poses_on(&m, &e);
        for (k = 0; k < FIXED_TEST_POSES / 100; k++) {
            uint32_t th[6];
            random_bam_pose(&g, th);
            compare_pose(&m, th, &e, 0);
        }
    }
    printf("measured: parameters at the representable limits (reach 8000 mm), edge poses + %ld "
           "random poses each: point max %.3g mm, Jacobian max %.3g (column %d)\n",
           FIXED_TEST_POSES / 100, e.point, e.jac, e.jac_col);
    assert_true(e.point <= BOUND_POINT_MM);
    assert_true(e.jac <= BOUND_JAC);
}

/* Random parameter blocks anywhere in the valid range. */
static void test_random_params(void **state)
{
    test_rng_t g = {4711u};
    err_t e = {0.0, 0.0, 0};
    int set;
    (void)state;
    for (set = 0; set < 40; set++) {
        aacmm_params_q_t q;
        pair_t m;
        int64_t budget = AACMM_Q_REACH_MAX_Q18;
        long k;
        int i;
        /* lengths drawn so that the total reach lands anywhere up to the limit */
        int32_t *len[13];
        for (i = 0; i < 6; i++) {
            len[i] = &q.d_q18[i];
            len[6 + i] = &q.a_q18[i];
            q.alpha_bam[i] = (uint32_t)(rng_next(&g) >> 32);
            q.theta_offset_bam[i] = (uint32_t)(rng_next(&g) >> 32);
        }
        len[12] = &q.l_q18;
        for (i = 0; i < 13; i++) {
            int64_t cap = budget / (13 - i) * 2;
            int64_t v;
            cap = cap < budget ? cap : budget;
            v = (int64_t)(rng_next(&g) % (uint64_t)(cap + 1));
            budget -= v;
            *len[i] = (int32_t)((rng_next(&g) & 1u) ? -v : v);
        }
        make_pair_q(&m, &q);
        for (k = 0; k < FIXED_TEST_POSES / 200; k++) {
            uint32_t th[6];
            random_bam_pose(&g, th);
            compare_pose(&m, th, &e, 0);
        }
    }
    printf("measured: 40 random parameter blocks (reach up to 8000 mm) x %ld poses: point max "
           "%.3g mm, Jacobian max %.3g\n",
           FIXED_TEST_POSES / 200, e.point, e.jac);
    assert_true(e.point <= BOUND_POINT_MM);
    assert_true(e.jac <= BOUND_JAC);
}

/* Hand-worked zero pose of tests/core (Table 1): p = (0, 0, 207) mm. */
static void test_zero_pose_by_hand(void **state)
{
    static const double theta_col[6][3] = {{0, 0, 0},     {93, 0, 0}, {65.5, 0, 0},
                                           {699.7, 0, 0}, {0, 0, 0},  {183.5, 0, 0}};
    static const double z_axes[7][3] = {{0, 0, 1}, {0, -1, 0}, {0, 0, -1}, {0, 1, 0},
                                        {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
    aacmm_params_q_t q;
    aacmm_model_q_t m;
    const uint32_t th[6] = {0, 0, 0, 0, 0, 0};
    int64_t p[3], J[AACMM_JAC_SIZE];
    int i, r;
    (void)state;
    assert_int_equal(aacmm_params_default_q(&q), AACMM_OK);
    assert_int_equal(aacmm_model_q_init(&m, &q), AACMM_OK);
    assert_int_equal(aacmm_point_jacobian_q(&m, th, p, J), AACMM_OK);
    /* every axis is exactly +-1 or 0 here (sin/cos of quarter turns are
     * exact), so the only error is the Q18 rounding of 792.7 and 883.2 */
    assert_true(p[0] == 0 && p[1] == 0);
    assert_true(fabs(Q48_TO_MM(p[2]) - 207.0) < 4e-6);
    for (r = 0; r < 3; r++) {
        for (i = 0; i < 6; i++) {
            assert_true(fabs(Q48_TO_MM(J[r * AACMM_JAC_COLS + AACMM_COL_THETA(i)]) -
                             theta_col[i][r]) < 1e-5);
            assert_true(J[r * AACMM_JAC_COLS + AACMM_COL_D(i)] ==
                        (int64_t)z_axes[i][r] * (INT64_C(1) << 48));
            assert_true(J[r * AACMM_JAC_COLS + AACMM_COL_A(i)] == (r == 0 ? INT64_C(1) << 48 : 0));
        }
        assert_true(J[r * AACMM_JAC_COLS + AACMM_COL_L] == (int64_t)z_axes[6][r] * (INT64_C(1) << 48));
    }
    /* d p_z / d theta_1 is exactly zero for every pose (z_0 = (0, 0, 1)). */
    {
        test_rng_t g = {3u};
        int k;
        for (k = 0; k < 1000; k++) {
            uint32_t t[6];
            random_bam_pose(&g, t);
            assert_int_equal(aacmm_point_jacobian_q(&m, t, p, J), AACMM_OK);
            assert_true(J[2 * AACMM_JAC_COLS + AACMM_COL_THETA(0)] == 0);
        }
    }
}

/* ------------------------------------------------------------------------ */
/* Encoders and batches                                                      */
/* ------------------------------------------------------------------------ */

typedef struct {
    uint64_t cpr;
    uint32_t zero;
    int8_t dir;
    uint32_t reading;
} enc_case_t;

static const enc_case_t enc_cases[] = {
    {UINT64_C(1) << 32, 0u, 1, 0xFFFFFFFFu},         /* wrap at 2^32 */
    {UINT64_C(1) << 32, 0u, 1, 0x7FFFFFFFu},         /* just below a half turn */
    {UINT64_C(1) << 32, 0u, 1, 0x80000000u},         /* half turn */
    {UINT64_C(1) << 32, 0u, -1, 0x80000000u},        /* ... reversed */
    {UINT64_C(1) << 32, 10u, 1, 5u},                 /* zero offset above the reading */
    {UINT64_C(1) << 32, 0xFFFFFFF0u, 1, 0x10u},      /* offset near the top, wrapped */
    {UINT64_C(1) << 26, 0u, 1, (1u << 26) - 1u},     /* 26-bit wrap */
    {UINT64_C(1) << 26, 1000u, -1, 999u},            /* 26-bit, reversed, below zero */
    {UINT64_C(1) << 26, 0u, 1, 1u << 24},            /* 26-bit quarter turn */
    {3600u, 3500u, 1, 100u},                         /* non power of two, wrap */
    {3600u, 0u, 1, 1800u},
    {2u, 0u, 1, 1u},                                 /* smallest resolution */
    {0xFFFFFFFFu, 0u, 1, 0xFFFFFFFEu},               /* largest non power of two */
    {0xFFFFFFFFu, 0xFFFFFFFEu, -1, 0u},
};

static void test_encoder_counts(void **state)
{
    aacmm_params_f64_t p;
    pair_t m;
    test_rng_t g = {55u};
    double wp = 0.0, wj = 0.0;
    size_t k;
    (void)state;
    perturbed_params(&p);
    make_pair(&m, &p);
    for (k = 0; k < sizeof enc_cases / sizeof enc_cases[0]; k++) {
        aacmm_encoder_config_t c;
        uint32_t rd[6], bam[6];
        int64_t pq[3], jq[AACMM_JAC_SIZE], pq2[3], jq2[AACMM_JAC_SIZE];
        double pd[3], jd[AACMM_JAC_SIZE];
        size_t done = 99u;
        int i, rep;
        for (rep = 0; rep < 20; rep++) {
            for (i = 0; i < 6; i++) {
                c.counts_per_rev[i] = enc_cases[k].cpr;
                c.zero_offset_counts[i] = enc_cases[k].zero;
                c.direction[i] = enc_cases[k].dir;
                /* joint rep % 6 gets the edge reading, the others random ones */
                rd[i] = (i == rep % 6 || rep == 0)
                            ? enc_cases[k].reading
                            : (uint32_t)(rng_next(&g) % enc_cases[k].cpr);
            }
            {
                aacmm_arm_encoders_t ca;
                assert_int_equal(aacmm_arm_encoders_from_config(&ca, &c), AACMM_OK);
                assert_int_equal(aacmm_batch_counts_q(&m.mq, &ca, 1u, rd, pq, jq, &done),
                                 AACMM_OK);
            }
            assert_true(done == 1u);
            /* same as the two steps done by hand */
            assert_int_equal(aacmm_encoder_to_bam(&c, rd, bam), AACMM_OK);
            assert_int_equal(aacmm_point_jacobian_q(&m.mq, bam, pq2, jq2), AACMM_OK);
            assert_memory_equal(pq, pq2, sizeof pq);
            assert_memory_equal(jq, jq2, sizeof jq);
            /* against the double core's own counts path */
            {
                aacmm_arm_encoders_t ca;
                assert_int_equal(aacmm_arm_encoders_from_config(&ca, &c), AACMM_OK);
                assert_int_equal(aacmm_batch_counts_f64(&m.md, &ca, 1u, rd, pd, jd, NULL),
                                 AACMM_OK);
            }
            for (i = 0; i < 3; i++) {
                double e = fabs(Q48_TO_MM(pq[i]) - pd[i]);
                wp = e > wp ? e : wp;
            }
            for (i = 0; i < AACMM_JAC_SIZE; i++) {
                double e = fabs(Q48_TO_MM(jq[i]) - jd[i]);
                wj = e > wj ? e : wj;
            }
        }
    }
    printf("measured: encoder edge table through aacmm_batch_counts_q vs aacmm_batch_counts_f64: "
           "point max %.3g mm, Jacobian max %.3g\n",
           wp, wj);
    assert_true(wp <= BOUND_POINT_MM);
    assert_true(wj <= BOUND_JAC);
}

static void test_batches(void **state)
{
    aacmm_params_q_t q;
    aacmm_model_q_t m;
    aacmm_arm_encoders_t enc;
    test_rng_t g = {8u};
    enum { N = 50 };
    uint32_t th[N * 6];
    int64_t p[N * 3], J[N * AACMM_JAC_SIZE], p1[3], J1[AACMM_JAC_SIZE], pp[N * 3];
    size_t done = 77u;
    int k;
    (void)state;
    aacmm_params_default_q(&q);
    q.theta_offset_bam[2] = 0x01234567u;
    assert_int_equal(aacmm_model_q_init(&m, &q), AACMM_OK);
    for (k = 0; k < N; k++) {
        random_bam_pose(&g, th + 6 * k);
    }
    assert_int_equal(aacmm_batch_bam_q(&m, N, th, p, J, &done), AACMM_OK);
    assert_true(done == N);
    assert_int_equal(aacmm_batch_bam_q(&m, N, th, pp, NULL, NULL), AACMM_OK);
    assert_memory_equal(p, pp, sizeof p);
    for (k = 0; k < N; k++) {
        assert_int_equal(aacmm_point_jacobian_q(&m, th + 6 * k, p1, J1), AACMM_OK);
        assert_memory_equal(p1, p + 3 * k, sizeof p1);
        assert_memory_equal(J1, J + AACMM_JAC_SIZE * k, sizeof J1);
    }
    /* the counts path with 2^32 counts per turn is the BAM path */
    assert_int_equal(aacmm_arm_encoders_default(&enc, 6), AACMM_OK);
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, N, th, pp, NULL, &done), AACMM_OK);
    assert_true(done == N);
    assert_memory_equal(p, pp, sizeof p);
    /* n = 0 with NULL arrays is valid */
    done = 5u;
    assert_int_equal(aacmm_batch_bam_q(&m, 0u, NULL, NULL, NULL, &done), AACMM_OK);
    assert_true(done == 0u);
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, 0u, NULL, NULL, NULL, &done), AACMM_OK);
    /* stops at the first bad reading; earlier poses written */
    enc.counts_per_rev[3] = 1u << 20;
    for (k = 0; k < N; k++) {
        th[6 * k + 3] &= (1u << 20) - 1u;
    }
    th[6 * 7 + 3] = 1u << 20; /* pose 7: reading == resolution */
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, N, th, pp, J, &done), AACMM_ERR_RANGE);
    assert_true(done == 7u);
    /* invalid encoder configuration */
    enc.direction[0] = 0;
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, N, th, pp, J, &done), AACMM_ERR_RANGE);
    assert_true(done == 0u);
    /* null pointers */
    assert_int_equal(aacmm_batch_bam_q(NULL, N, th, p, J, &done), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_bam_q(&m, N, NULL, p, J, &done), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_bam_q(&m, N, th, NULL, J, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_counts_q(&m, NULL, N, th, p, J, &done), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_counts_q(NULL, &enc, N, th, p, J, &done), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, N, NULL, p, J, &done), AACMM_ERR_NULL);
    assert_int_equal(aacmm_batch_counts_q(&m, &enc, N, th, NULL, J, &done), AACMM_ERR_NULL);
}

/* ------------------------------------------------------------------------ */
/* Parameters: conversion, validation, null pointers                          */
/* ------------------------------------------------------------------------ */

static void test_conversion(void **state)
{
    aacmm_params_f64_t p, back;
    aacmm_params_f32_t pf;
    aacmm_params_q_t q, qd, qf;
    test_rng_t g = {21u};
    int k, i;
    (void)state;
    /* the default block is exactly the conversion of the double defaults */
    aacmm_params_default_f64(&p);
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
    assert_int_equal(aacmm_params_default_q(&qd), AACMM_OK);
    assert_memory_equal(&q, &qd, sizeof q);
    aacmm_params_default_f32(&pf);
    assert_int_equal(aacmm_params_q_from_f32(&qf, &pf), AACMM_OK);
    /* float pi/2 is 4.4e-8 rad above pi/2: 30 BAM */
    assert_true(qf.alpha_bam[0] - AACMM_BAM_QUARTER <= 32u && qf.l_q18 == q.l_q18);
    /* round trips: lengths within half a Q18 step, angles within half a BAM */
    for (k = 0; k < 10000; k++) {
        for (i = 0; i < 6; i++) {
            p.theta_offset_rad[i] = rng_uniform(&g, -2.0 * PI, 2.0 * PI);
            p.alpha_rad[i] = rng_uniform(&g, -2.0 * PI, 2.0 * PI);
            p.d_mm[i] = rng_uniform(&g, -600.0, 600.0);
            p.a_mm[i] = rng_uniform(&g, -600.0, 600.0);
        }
        p.l_mm = rng_uniform(&g, -600.0, 600.0);
        assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
        assert_int_equal(aacmm_params_q_to_f64(&back, &q), AACMM_OK);
        for (i = 0; i < 6; i++) {
            double da = remainder(back.alpha_rad[i] - p.alpha_rad[i], 2.0 * PI);
            double dt = remainder(back.theta_offset_rad[i] - p.theta_offset_rad[i], 2.0 * PI);
            assert_true(fabs(da) <= 0.5 * 2.0 * PI / 4294967296.0 + 1e-15);
            assert_true(fabs(dt) <= 0.5 * 2.0 * PI / 4294967296.0 + 1e-15);
            assert_true(fabs(back.d_mm[i] - p.d_mm[i]) <= 0x1p-19);
            assert_true(fabs(back.a_mm[i] - p.a_mm[i]) <= 0x1p-19);
        }
        assert_true(fabs(back.l_mm - p.l_mm) <= 0x1p-19);
    }
    /* angle edge values */
    aacmm_params_default_f64(&p);
    p.alpha_rad[0] = PI;
    p.alpha_rad[1] = -PI;
    p.alpha_rad[2] = 2.0 * PI;
    p.alpha_rad[3] = -2.0 * PI;
    p.alpha_rad[4] = -PI / 2.0;
    p.alpha_rad[5] = 0.0;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
    assert_true(q.alpha_bam[0] == H2 && q.alpha_bam[1] == H2);
    assert_true(q.alpha_bam[2] == 0u && q.alpha_bam[3] == 0u);
    assert_true(q.alpha_bam[4] == Q3 && q.alpha_bam[5] == 0u);
    /* lengths at the limit */
    aacmm_params_default_f64(&p);
    memset(p.d_mm, 0, sizeof p.d_mm);
    p.l_mm = -8000.0;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
    assert_true(q.l_q18 == -(int32_t)AACMM_Q_REACH_MAX_Q18);
}

static void test_validation(void **state)
{
    aacmm_params_f64_t p;
    aacmm_params_q_t q, q_before;
    aacmm_model_q_t m, m_before;
    (void)state;
    aacmm_params_default_f64(&p);
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
    q_before = q;

    /* the double side: non-finite and out-of-range values, output untouched */
    p.d_mm[1] = (double)NAN;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_NOT_FINITE);
    p.d_mm[1] = -(double)INFINITY;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_NOT_FINITE);
    p.d_mm[1] = 65.5;
    p.alpha_rad[3] = (double)NAN;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_NOT_FINITE);
    p.alpha_rad[3] = 6.3; /* beyond 2 pi: the core's limit */
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    p.alpha_rad[3] = PI / 2.0;
    p.theta_offset_rad[0] = -7.0;
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    p.theta_offset_rad[0] = 0.0;
    p.a_mm[5] = 8000.001; /* one length beyond the fixed range */
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    p.a_mm[5] = -9999.0; /* valid for the float core, not representable here */
    assert_int_equal(aacmm_params_validate_f64(&p), AACMM_OK);
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    p.a_mm[5] = 5710.0; /* each length fine, total reach 8000.4 mm > 8000 */
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    {
        /* a_6 chosen so that the total reach of the rounded values is exactly
         * the limit: the other 12 lengths are Table 1's (all >= 0) */
        int64_t reach = q_before.l_q18;
        int i;
        for (i = 0; i < 6; i++) {
            reach += q_before.d_q18[i] + q_before.a_q18[i];
        }
        p.a_mm[5] = (double)(AACMM_Q_REACH_MAX_Q18 - reach) * 0x1p-18;
    }
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_OK);
    q_before = q;
    p.a_mm[5] += 0x1p-17; /* two Q18 steps over */
    assert_int_equal(aacmm_params_q_from_f64(&q, &p), AACMM_ERR_RANGE);
    assert_memory_equal(&q, &q_before, sizeof q); /* unchanged on error */
    assert_int_equal(aacmm_params_q_from_f64(NULL, &p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_q_from_f64(&q, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_q_from_f32(NULL, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_q_to_f64(NULL, &q), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_q_to_f64(&p, NULL), AACMM_ERR_NULL);

    /* the integer side */
    aacmm_params_default_q(&q);
    assert_int_equal(aacmm_model_q_init(&m, &q), AACMM_OK);
    m_before = m;
    q.l_q18 = INT32_MIN; /* |INT32_MIN| counted exactly */
    assert_int_equal(aacmm_params_q_validate(&q), AACMM_ERR_RANGE);
    assert_int_equal(aacmm_model_q_init(&m, &q), AACMM_ERR_RANGE);
    assert_memory_equal(&m, &m_before, sizeof m); /* unchanged on error */
    q.l_q18 = INT32_MAX;
    assert_int_equal(aacmm_params_q_validate(&q), AACMM_ERR_RANGE);
    memset(&q, 0, sizeof q);
    q.d_q18[4] = (int32_t)AACMM_Q_REACH_MAX_Q18;
    assert_int_equal(aacmm_params_q_validate(&q), AACMM_OK);
    q.a_q18[0] = -1; /* one LSB over the total */
    assert_int_equal(aacmm_params_q_validate(&q), AACMM_ERR_RANGE);
    {
        int i;
        for (i = 0; i < 6; i++) { /* 13 lengths at INT32_MIN: no overflow in the sum */
            q.d_q18[i] = INT32_MIN;
            q.a_q18[i] = INT32_MIN;
        }
        q.l_q18 = INT32_MIN;
        assert_int_equal(aacmm_params_q_validate(&q), AACMM_ERR_RANGE);
    }
    assert_int_equal(aacmm_params_q_validate(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_params_default_q(NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_model_q_init(NULL, &q), AACMM_ERR_NULL);
    assert_int_equal(aacmm_model_q_init(&m, NULL), AACMM_ERR_NULL);
}

static void test_nulls(void **state)
{
    aacmm_params_q_t q;
    aacmm_model_q_t m;
    const uint32_t th[6] = {1, 2, 3, 4, 5, 6};
    int64_t p[3] = {11, 22, 33}, J[AACMM_JAC_SIZE];
    (void)state;
    aacmm_params_default_q(&q);
    assert_int_equal(aacmm_model_q_init(&m, &q), AACMM_OK);
    assert_int_equal(aacmm_point_q(NULL, th, p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_q(&m, NULL, p), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_q(&m, th, NULL), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_q(NULL, th, p, J), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_q(&m, NULL, p, J), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_q(&m, th, NULL, J), AACMM_ERR_NULL);
    assert_int_equal(aacmm_point_jacobian_q(&m, th, p, NULL), AACMM_ERR_NULL);
    assert_true(p[0] == 11 && p[1] == 22 && p[2] == 33); /* nothing written */
}

/* The paper's arm (and the perturbed and limit blocks of
 * tests/core/legacy_paths.h) through the fixed-point path gives bit for bit
 * what the core of commit aa8b712 gave, in the formulation of this build
 * (64-bit products, or ARMv6-M's with AACMM_Q_SPLIT_MUL): the hashes of
 * tests/core/legacy_golden.h (scripts/legacy-golden.sh). */
static void legacy_golden_check(int general)
{
#if LIB_SPLIT_MUL
    static const uint64_t golden[LEGACY_Q_PATHS] = {
        LEGACY_GOLDEN_q_point_split, LEGACY_GOLDEN_q_batch_split, LEGACY_GOLDEN_q_counts_split,
        LEGACY_GOLDEN_q_params_split};
#else
    static const uint64_t golden[LEGACY_Q_PATHS] = {LEGACY_GOLDEN_q_point, LEGACY_GOLDEN_q_batch,
                                                    LEGACY_GOLDEN_q_counts, LEGACY_GOLDEN_q_params};
#endif
    int i;
    legacy_force_general = general;
    for (i = 0; i < LEGACY_Q_PATHS; i++) {
        const uint64_t h = legacy_q_hash(i);
        printf("legacy golden %s%s, %s chain %016llx %s\n", legacy_q_names[i],
               LIB_SPLIT_MUL ? " (ARMv6-M formulation)" : "", general ? "general" : "paper's",
               (unsigned long long)h, h == golden[i] ? "same" : "DIFFERS");
        assert_true(h == golden[i]);
    }
    legacy_force_general = 0;
}

static void test_legacy_golden(void **state)
{
    (void)state;
    legacy_golden_check(0);
}

/* The general chain (chain_q_impl.h, CQ_GENERAL 1) on the same models: the
 * same operations, so the same hashes. */
static void test_legacy_golden_general(void **state)
{
    (void)state;
    legacy_golden_check(1);
}


int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sin_table),
        cmocka_unit_test(test_sincos_accuracy),
        cmocka_unit_test(test_sincos_exact_points),
        cmocka_unit_test(test_split_multiply),
        cmocka_unit_test(test_split_multiply_q30),
        cmocka_unit_test(test_random_poses_table1),
        cmocka_unit_test(test_random_poses_perturbed),
        cmocka_unit_test(test_vs_long_double_reference),
        cmocka_unit_test(test_edge_table),
        cmocka_unit_test(test_random_params),
        cmocka_unit_test(test_zero_pose_by_hand),
        cmocka_unit_test(test_encoder_counts),
        cmocka_unit_test(test_batches),
        cmocka_unit_test(test_conversion),
        cmocka_unit_test(test_validation),
        cmocka_unit_test(test_nulls),
        cmocka_unit_test(test_legacy_golden),
        cmocka_unit_test(test_legacy_golden_general),
    };
    return cmocka_run_group_tests_name("fixed-point kinematics", tests, NULL, NULL);
}
