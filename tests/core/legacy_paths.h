/*
 * Every kinematics path on the paper's arm, reduced to one 64-bit hash per
 * path: the bytes of every output (points, Jacobians, sums, angles, status
 * codes and done counts) of many poses, FNV-1a. Compiled twice:
 *
 *   - by tests/core/legacy_golden_main.c against the core of commit aa8b712
 *     (scripts/legacy-golden.sh builds it from `git archive aa8b712
 *     firmware`), whose output is tests/core/legacy_golden.h;
 *   - by the test suites (tests/core/test_kinematics.c, tests/fixed/
 *     test_fixed.c) against today's core, which must give the same hashes:
 *     the paper's arm computes bit for bit what it computed before the
 *     general model (issue 26).
 *
 * So this file uses only calls whose meaning did not change for the paper's
 * arm; where a signature changed (the encoder set of the counts batches, the
 * nominal parameters of the perturbed points), LEGACY_NEW_API (defined when
 * the header declares AACMM_JOINTS_MAX) selects today's spelling of the same
 * call.
 *
 * Inputs: the paper's Table 1 and a perturbed arm (every parameter moved, so
 * no term vanishes), edge poses (zero, quarter and half turns, the angle
 * limits) and seeded random poses, in batches of odd sizes (full SIMD groups,
 * tails); encoder readings at 2^32, 2^26 and 3600 counts per turn.
 */
#ifndef AACMM_TEST_LEGACY_PATHS_H
#define AACMM_TEST_LEGACY_PATHS_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "aacmm/kinematics.h"
#ifdef AACMM_JOINTS_MAX
#define LEGACY_NEW_API 1
#else
#define LEGACY_NEW_API 0
#endif

#define LEGACY_POSES 4096 /* poses per path and model */

#if LEGACY_NEW_API
/* 1: run the general chains on the paper's arm (the models' paper flag
 * cleared after init; the perturbed-points paths build their own models and
 * keep the paper's chains): they must give the same hashes. */
int legacy_force_general; /* one test file per binary includes this header */
#endif
#define LEGACY_BATCH 509  /* a prime: every kernel gets full groups and a tail */
#define LEGACY_PI 3.14159265358979323846

typedef struct {
    uint64_t h;
} legacy_hash_t;

static void legacy_mix(legacy_hash_t *g, const void *data, size_t n)
{
    const unsigned char *p = (const unsigned char *)data;
    size_t i;
    for (i = 0; i < n; i++) {
        g->h ^= p[i];
        g->h *= UINT64_C(0x100000001B3);
    }
}

static void legacy_mix_int(legacy_hash_t *g, long v)
{
    int64_t x = (int64_t)v;
    legacy_mix(g, &x, sizeof x);
}

static legacy_hash_t legacy_start(void)
{
    legacy_hash_t g;
    g.h = UINT64_C(0xCBF29CE484222325);
    return g;
}

/* xorshift64*, as tests/core/reference.h */
static uint64_t legacy_rng(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return *s * UINT64_C(2685821657736338717);
}

/* Table 1 (which = 0) or the perturbed arm (which = 1). */
static void legacy_params(aacmm_params_f64_t *p, int which)
{
    int i;
    aacmm_params_default_f64(p);
    if (which == 0) {
        return;
    }
    for (i = 0; i < 6; i++) {
        p->theta_offset_rad[i] = 0.01 * (i + 1) - 0.035;
        p->alpha_rad[i] += 0.002 * (i - 2.5);
        p->d_mm[i] += 0.3 * i - 0.7;
        p->a_mm[i] = 1.5 - 0.4 * i;
    }
    p->l_mm += 0.7;
}

/* Encoder configuration c: 0 = 2^32 counts, offset 0, +1; 1 = 2^26 counts
 * with offsets and mixed directions; 2 = 3600 counts (not a power of two). */
static void legacy_encoders(aacmm_encoder_config_t *e, int c)
{
    int i;
    aacmm_encoder_default(e);
    for (i = 0; i < 6; i++) {
        if (c == 1) {
            e->counts_per_rev[i] = UINT64_C(1) << 26;
            e->zero_offset_counts[i] = (uint32_t)(12345u * (unsigned)(i + 1));
            e->direction[i] = (int8_t)((i % 2) ? -1 : 1);
        } else if (c == 2) {
            e->counts_per_rev[i] = 3600u;
            e->zero_offset_counts[i] = (uint32_t)(100u * (unsigned)i);
            e->direction[i] = (int8_t)((i % 3) ? 1 : -1);
        }
    }
}

static void legacy_readings(uint32_t *r, int n, const aacmm_encoder_config_t *e, uint64_t seed)
{
    uint64_t s = seed;
    int k, i;
    for (k = 0; k < n; k++) {
        for (i = 0; i < 6; i++) {
            r[k * 6 + i] = (uint32_t)((legacy_rng(&s) >> 32) % e->counts_per_rev[i]);
        }
    }
}

#endif /* AACMM_TEST_LEGACY_PATHS_H */

/* ---- the floating-point paths (core, analysis, SIMD kernels) ------------ */
#if defined(LEGACY_FLOAT_PATHS) && !defined(AACMM_TEST_LEGACY_FLOAT_DONE)
#define AACMM_TEST_LEGACY_FLOAT_DONE
#include "aacmm/analysis.h"
#include "aacmm/simd.h"

enum {
    LEGACY_F64_POINT,      /* aacmm_point_f64, pose by pose */
    LEGACY_F64_POINT_JAC,  /* aacmm_point_jacobian_f64 */
    LEGACY_F64_BATCH,      /* aacmm_batch_angles_f64, points only and with Jacobians */
    LEGACY_F64_COUNTS,     /* encoder angles, aacmm_batch_counts_f64, counts_to_angles */
    LEGACY_F32_POINT_JAC,  /* aacmm_point_f32, aacmm_point_jacobian_f32, encoder angles f32 */
    LEGACY_F32_BATCH,      /* aacmm_batch_angles_f32, aacmm_batch_counts_f32 */
    LEGACY_SUMS,           /* aacmm_abs_jacobian_sums(_scaled)_f64, perturbed points */
    LEGACY_SCALAR_PATHS,
    LEGACY_SIMD_F64 = 0,   /* per kernel: row-major, points only, tiled (aligned, not) */
    LEGACY_SIMD_F32,       /* the same in single precision */
    LEGACY_SIMD_SUMS,      /* the fused sums, scaled sums, perturbed points */
    LEGACY_SIMD_PATHS
};

static const char *const legacy_scalar_names[LEGACY_SCALAR_PATHS] = {
    "f64_point", "f64_point_jacobian", "f64_batch", "f64_counts",
    "f32_point_jacobian", "f32_batch", "analysis_sums"};
static const char *const legacy_simd_names[LEGACY_SIMD_PATHS] = {"simd_f64", "simd_f32",
                                                                  "simd_sums"};

/* The poses: 16 edge poses, then seeded uniform poses in [-pi, pi). */
static void legacy_poses(double *th, int n, uint64_t seed)
{
    static const double e[16][6] = {
        {0, 0, 0, 0, 0, 0},
        {LEGACY_PI, LEGACY_PI, LEGACY_PI, LEGACY_PI, LEGACY_PI, LEGACY_PI},
        {-LEGACY_PI, -LEGACY_PI, -LEGACY_PI, -LEGACY_PI, -LEGACY_PI, -LEGACY_PI},
        {LEGACY_PI / 2, -LEGACY_PI / 2, LEGACY_PI / 2, -LEGACY_PI / 2, LEGACY_PI / 2,
         -LEGACY_PI / 2},
        {0, LEGACY_PI, 0, LEGACY_PI, 0, 0},
        {0, 0, 0, 0, LEGACY_PI / 2, 0},
        {1e-9, -1e-9, 3.0, -3.0, 2.0, -2.0},
        {1024.0, -1024.0, 1000.0, -999.5, 512.25, 0.5},
        {6.283185307179586, -6.283185307179586, 12.566, -12.566, 100.0, -100.0},
        {0.7853981633974483, 2.356194490192345, -0.7853981633974483, -2.356194490192345,
         3.9269908169872414, -3.9269908169872414},
        {1.0, 2.0, 3.0, 4.0, 5.0, 6.0},
        {-1.0, -2.0, -3.0, -4.0, -5.0, -6.0},
        {0.1, 0.2, 0.3, 0.4, 0.5, 0.6},
        {2.5, -0.5, 1.5, -2.5, 0.25, -1.75},
        {1e-300, -1e-300, 5e-324, -5e-324, 0.0, -0.0},
        {-0.0, -0.0, -0.0, -0.0, -0.0, -0.0},
    };
    uint64_t s = seed;
    int k, i;
    for (k = 0; k < n; k++) {
        for (i = 0; i < 6; i++) {
            th[k * 6 + i] = k < 16 ? e[k][i]
                                   : -LEGACY_PI + 2.0 * LEGACY_PI *
                                                      (double)(legacy_rng(&s) >> 11) * 0x1.0p-53;
        }
    }
}

static void legacy_params_f32(aacmm_params_f32_t *q, const aacmm_params_f64_t *p)
{
    int i;
    for (i = 0; i < 6; i++) {
        q->theta_offset_rad[i] = (float)p->theta_offset_rad[i];
        q->alpha_rad[i] = (float)p->alpha_rad[i];
        q->d_mm[i] = (float)p->d_mm[i];
        q->a_mm[i] = (float)p->a_mm[i];
    }
    q->l_mm = (float)p->l_mm;
}

static double legacy_th[LEGACY_POSES * 6], legacy_p[LEGACY_POSES * 3],
    legacy_j[LEGACY_POSES * AACMM_JAC_SIZE];
static double legacy_jt[AACMM_SIMD_TILED_SIZE(LEGACY_POSES, AACMM_SIMD_TILE_F64) + 8];
static float legacy_thf[LEGACY_POSES * 6], legacy_pf[LEGACY_POSES * 3],
    legacy_jf[LEGACY_POSES * AACMM_JAC_SIZE];
static float legacy_jtf[AACMM_SIMD_TILED_SIZE(LEGACY_POSES, AACMM_SIMD_TILE_F32) + 16];
static uint32_t legacy_r[LEGACY_POSES * 6];

static void legacy_models(int which, aacmm_params_f64_t *p, aacmm_model_f64_t *m,
                          aacmm_model_f32_t *mf)
{
    aacmm_params_f32_t pf;
    legacy_params(p, which);
    legacy_params_f32(&pf, p);
    (void)aacmm_model_init_f64(m, p);
    (void)aacmm_model_init_f32(mf, &pf);
#if LEGACY_NEW_API
    if (legacy_force_general) {
        m->paper = 0u;
        mf->paper = 0u;
    }
#endif
}

static void legacy_float_poses(int which)
{
    int i;
    legacy_poses(legacy_th, LEGACY_POSES, UINT64_C(0x9E3779B97F4A7C15) + (uint64_t)which);
    for (i = 0; i < LEGACY_POSES * 6; i++) {
        legacy_thf[i] = (float)legacy_th[i];
    }
}

#if LEGACY_NEW_API
static aacmm_status_t legacy_counts_f64(const aacmm_model_f64_t *m,
                                        const aacmm_encoder_config_t *e, size_t n,
                                        const uint32_t *r, double *p, double *j, size_t *done)
{
    aacmm_arm_encoders_t s;
    (void)aacmm_arm_encoders_from_config(&s, e);
    return aacmm_batch_counts_f64(m, &s, n, r, p, j, done);
}
static aacmm_status_t legacy_counts_f32(const aacmm_model_f32_t *m,
                                        const aacmm_encoder_config_t *e, size_t n,
                                        const uint32_t *r, float *p, float *j, size_t *done)
{
    aacmm_arm_encoders_t s;
    (void)aacmm_arm_encoders_from_config(&s, e);
    return aacmm_batch_counts_f32(m, &s, n, r, p, j, done);
}
static aacmm_status_t legacy_counts_to_angles(const aacmm_encoder_config_t *e, size_t n,
                                              const uint32_t *r, double *th, size_t *done)
{
    aacmm_arm_encoders_t s;
    (void)aacmm_arm_encoders_from_config(&s, e);
    return aacmm_counts_to_angles_f64(&s, n, r, th, done);
}
static aacmm_status_t legacy_perturbed(int kernel, const aacmm_params_f64_t *nominal, size_t nt,
                                       const double *delta, size_t np, const double *th,
                                       double *p, size_t *done)
{
    aacmm_arm_f64_t arm;
    (void)aacmm_arm_from_params_f64(&arm, nominal);
    if (kernel < 0) {
        return aacmm_perturbed_points_f64(&arm, nt, delta, np, th, p, done);
    }
    return aacmm_simd_perturbed_points_f64((aacmm_kernel_t)kernel, &arm, nt, delta, np, th, p,
                                           done);
}
#else
#define legacy_counts_f64 aacmm_batch_counts_f64
#define legacy_counts_f32 aacmm_batch_counts_f32
#define legacy_counts_to_angles aacmm_counts_to_angles_f64
static aacmm_status_t legacy_perturbed(int kernel, const aacmm_params_f64_t *nominal, size_t nt,
                                       const double *delta, size_t np, const double *th,
                                       double *p, size_t *done)
{
    if (kernel < 0) {
        return aacmm_perturbed_points_f64(nominal, nt, delta, np, th, p, done);
    }
    return aacmm_simd_perturbed_points_f64((aacmm_kernel_t)kernel, nominal, nt, delta, np, th, p,
                                           done);
}
#endif

/* The perturbation draws of the perturbed-points paths (some invalid: the
 * trial that stops the batch is part of what is hashed). */
static void legacy_deltas(double *delta, int trials, uint64_t seed)
{
    uint64_t s = seed;
    int t, c;
    for (t = 0; t < trials; t++) {
        for (c = 0; c < AACMM_JAC_COLS; c++) {
            delta[t * AACMM_JAC_COLS + c] =
                ((double)(legacy_rng(&s) >> 11) * 0x1.0p-53 - 0.5) * (c < 12 ? 2e-3 : 0.5);
        }
    }
}

static const double legacy_scale[6] = {6.2, 6.1, 6.0, 5.9, 5.8, 5.7};
static const double legacy_offset[6] = {-3.1, -3.0, -2.9, -2.8, -2.7, -2.6};

/* Scalar path `path` (LEGACY_F64_POINT ...) on both arms. */
static uint64_t legacy_scalar_hash(int path)
{
    legacy_hash_t g = legacy_start();
    int which;
    for (which = 0; which < 2; which++) {
        aacmm_params_f64_t prm;
        aacmm_model_f64_t m;
        aacmm_model_f32_t mf;
        int k, c, b;
        legacy_models(which, &prm, &m, &mf);
        legacy_float_poses(which);
        switch (path) {
        case LEGACY_F64_POINT:
            for (k = 0; k < LEGACY_POSES; k++) {
                double p[3];
                legacy_mix_int(&g, aacmm_point_f64(&m, legacy_th + 6 * k, p));
                legacy_mix(&g, p, sizeof p);
            }
            break;
        case LEGACY_F64_POINT_JAC:
            for (k = 0; k < LEGACY_POSES; k++) {
                double p[3], j[AACMM_JAC_SIZE];
                legacy_mix_int(&g, aacmm_point_jacobian_f64(&m, legacy_th + 6 * k, p, j));
                legacy_mix(&g, p, sizeof p);
                legacy_mix(&g, j, sizeof j);
            }
            break;
        case LEGACY_F64_BATCH:
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                size_t done = 0u;
                legacy_mix_int(&g, aacmm_batch_angles_f64(&m, n, legacy_th + 6 * b, legacy_p,
                                                          legacy_j, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_p, n * 3u * sizeof(double));
                legacy_mix(&g, legacy_j, n * AACMM_JAC_SIZE * sizeof(double));
                legacy_mix_int(&g, aacmm_batch_angles_f64(&m, n, legacy_th + 6 * b, legacy_p,
                                                          NULL, &done));
                legacy_mix(&g, legacy_p, n * 3u * sizeof(double));
            }
            break;
        case LEGACY_F64_COUNTS:
            for (c = 0; c < 3; c++) {
                aacmm_encoder_config_t e;
                size_t done = 0u;
                legacy_encoders(&e, c);
                legacy_readings(legacy_r, LEGACY_POSES, &e, UINT64_C(77) + (uint64_t)c);
                for (k = 0; k < LEGACY_POSES; k++) {
                    double th[6];
                    uint32_t bam[6];
                    legacy_mix_int(&g, aacmm_encoder_to_angles_f64(&e, legacy_r + 6 * k, th));
                    legacy_mix(&g, th, sizeof th);
                    legacy_mix_int(&g, aacmm_encoder_to_bam(&e, legacy_r + 6 * k, bam));
                    legacy_mix(&g, bam, sizeof bam);
                }
                legacy_mix_int(&g, legacy_counts_f64(&m, &e, LEGACY_POSES, legacy_r, legacy_p,
                                                     legacy_j, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_p, sizeof legacy_p);
                legacy_mix(&g, legacy_j, sizeof legacy_j);
                legacy_mix_int(&g, legacy_counts_to_angles(&e, LEGACY_POSES, legacy_r, legacy_th,
                                                           &done));
                legacy_mix(&g, legacy_th, sizeof legacy_th);
                legacy_r[6 * 100 + 3] = 0xFFFFFFFFu; /* at or above every resolution but 2^32 */
                legacy_mix_int(&g, legacy_counts_f64(&m, &e, LEGACY_POSES, legacy_r, legacy_p,
                                                     NULL, &done));
                legacy_mix_int(&g, (long)done);
            }
            break;
        case LEGACY_F32_POINT_JAC:
            for (k = 0; k < LEGACY_POSES; k++) {
                float p[3], j[AACMM_JAC_SIZE];
                legacy_mix_int(&g, aacmm_point_f32(&mf, legacy_thf + 6 * k, p));
                legacy_mix(&g, p, sizeof p);
                legacy_mix_int(&g, aacmm_point_jacobian_f32(&mf, legacy_thf + 6 * k, p, j));
                legacy_mix(&g, p, sizeof p);
                legacy_mix(&g, j, sizeof j);
            }
            for (c = 0; c < 3; c++) {
                aacmm_encoder_config_t e;
                legacy_encoders(&e, c);
                legacy_readings(legacy_r, 512, &e, UINT64_C(99) + (uint64_t)c);
                for (k = 0; k < 512; k++) {
                    float th[6];
                    legacy_mix_int(&g, aacmm_encoder_to_angles_f32(&e, legacy_r + 6 * k, th));
                    legacy_mix(&g, th, sizeof th);
                }
            }
            break;
        case LEGACY_F32_BATCH:
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                size_t done = 0u;
                legacy_mix_int(&g, aacmm_batch_angles_f32(&mf, n, legacy_thf + 6 * b, legacy_pf,
                                                          legacy_jf, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_pf, n * 3u * sizeof(float));
                legacy_mix(&g, legacy_jf, n * AACMM_JAC_SIZE * sizeof(float));
            }
            for (c = 0; c < 3; c++) {
                aacmm_encoder_config_t e;
                size_t done = 0u;
                legacy_encoders(&e, c);
                legacy_readings(legacy_r, LEGACY_POSES, &e, UINT64_C(55) + (uint64_t)c);
                legacy_mix_int(&g, legacy_counts_f32(&mf, &e, LEGACY_POSES, legacy_r, legacy_pf,
                                                     legacy_jf, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_pf, sizeof legacy_pf);
                legacy_mix(&g, legacy_jf, sizeof legacy_jf);
            }
            break;
        case LEGACY_SUMS: {
            static double unit[LEGACY_POSES * 6], delta[40 * AACMM_JAC_COLS];
            double s[AACMM_JAC_SIZE], q[AACMM_JAC_SIZE];
            uint64_t rs = 1234u;
            size_t done = 0u;
            memset(s, 0, sizeof s);
            memset(q, 0, sizeof q);
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                legacy_mix_int(&g, aacmm_abs_jacobian_sums_f64(&m, n, legacy_th + 6 * b, s, q,
                                                               &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, s, sizeof s);
                legacy_mix(&g, q, sizeof q);
            }
            for (k = 0; k < LEGACY_POSES * 6; k++) {
                unit[k] = (double)(uint32_t)legacy_rng(&rs) * 0x1p-32;
            }
            legacy_mix_int(&g, aacmm_abs_jacobian_sums_scaled_f64(&m, LEGACY_POSES, unit,
                                                                  legacy_scale, legacy_offset, s,
                                                                  q, &done));
            legacy_mix(&g, s, sizeof s);
            legacy_mix(&g, q, sizeof q);
            legacy_deltas(delta, 40, UINT64_C(4242) + (uint64_t)which);
            legacy_mix_int(&g, legacy_perturbed(-1, &prm, 40, delta, 100, legacy_th, legacy_p,
                                                &done));
            legacy_mix_int(&g, (long)done);
            legacy_mix(&g, legacy_p, 40u * 100u * 3u * sizeof(double) < sizeof legacy_p
                                         ? 40u * 100u * 3u * sizeof(double)
                                         : sizeof legacy_p);
            delta[17 * AACMM_JAC_COLS + 14] = 1e9; /* trial 17 invalid: the stop */
            legacy_mix_int(&g, legacy_perturbed(-1, &prm, 40, delta, 10, legacy_th, legacy_p,
                                                &done));
            legacy_mix_int(&g, (long)done);
            break;
        }
        default:
            break;
        }
    }
    return g.h;
}

/* SIMD path `path` with kernel `kern` (available) on both arms. */
static uint64_t legacy_simd_hash(int path, aacmm_kernel_t kern)
{
    legacy_hash_t g = legacy_start();
    int which;
    for (which = 0; which < 2; which++) {
        aacmm_params_f64_t prm;
        aacmm_model_f64_t m;
        aacmm_model_f32_t mf;
        int b, off;
        size_t done = 0u;
        legacy_models(which, &prm, &m, &mf);
        legacy_float_poses(which);
        switch (path) {
        case LEGACY_SIMD_F64:
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                const size_t tiled = AACMM_SIMD_TILED_SIZE(n, AACMM_SIMD_TILE_F64);
                legacy_mix_int(&g, aacmm_simd_batch_angles_f64(kern, &m, n, legacy_th + 6 * b,
                                                               legacy_p, legacy_j, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_p, n * 3u * sizeof(double));
                legacy_mix(&g, legacy_j, n * AACMM_JAC_SIZE * sizeof(double));
                legacy_mix_int(&g, aacmm_simd_batch_angles_f64(kern, &m, n, legacy_th + 6 * b,
                                                               legacy_p, NULL, &done));
                legacy_mix(&g, legacy_p, n * 3u * sizeof(double));
                for (off = 0; off < 2; off++) {
                    legacy_mix_int(&g, aacmm_simd_batch_angles_tiled_f64(
                                           kern, &m, n, legacy_th + 6 * b, legacy_p,
                                           legacy_jt + off, &done));
                    legacy_mix(&g, legacy_p, n * 3u * sizeof(double));
                    legacy_mix(&g, legacy_jt + off, tiled * sizeof(double));
                }
            }
            legacy_th[6 * 1000 + 3] = 2000.0; /* the stop at a bad pose */
            legacy_mix_int(&g, aacmm_simd_batch_angles_f64(kern, &m, 1500, legacy_th, legacy_p,
                                                           legacy_j, &done));
            legacy_mix_int(&g, (long)done);
            legacy_mix(&g, legacy_j, 1000u * AACMM_JAC_SIZE * sizeof(double));
            break;
        case LEGACY_SIMD_F32:
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                const size_t tiled = AACMM_SIMD_TILED_SIZE(n, AACMM_SIMD_TILE_F32);
                legacy_mix_int(&g, aacmm_simd_batch_angles_f32(kern, &mf, n, legacy_thf + 6 * b,
                                                               legacy_pf, legacy_jf, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_pf, n * 3u * sizeof(float));
                legacy_mix(&g, legacy_jf, n * AACMM_JAC_SIZE * sizeof(float));
                legacy_mix_int(&g, aacmm_simd_batch_angles_f32(kern, &mf, n, legacy_thf + 6 * b,
                                                               legacy_pf, NULL, &done));
                legacy_mix(&g, legacy_pf, n * 3u * sizeof(float));
                for (off = 0; off < 2; off++) {
                    legacy_mix_int(&g, aacmm_simd_batch_angles_tiled_f32(
                                           kern, &mf, n, legacy_thf + 6 * b, legacy_pf,
                                           legacy_jtf + off, &done));
                    legacy_mix(&g, legacy_pf, n * 3u * sizeof(float));
                    legacy_mix(&g, legacy_jtf + off, tiled * sizeof(float));
                }
            }
            break;
        case LEGACY_SIMD_SUMS: {
            static double unit[LEGACY_POSES * 6], delta[40 * AACMM_JAC_COLS];
            double s[AACMM_JAC_SIZE], q[AACMM_JAC_SIZE];
            uint64_t rs = 4321u;
            int k;
            memset(s, 0, sizeof s);
            memset(q, 0, sizeof q);
            for (b = 0; b < LEGACY_POSES; b += LEGACY_BATCH) {
                const size_t n = (size_t)(LEGACY_POSES - b < LEGACY_BATCH ? LEGACY_POSES - b
                                                                          : LEGACY_BATCH);
                legacy_mix_int(&g, aacmm_simd_abs_jacobian_sums_f64(kern, &m, n,
                                                                    legacy_th + 6 * b, s, q,
                                                                    &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, s, sizeof s);
                legacy_mix(&g, q, sizeof q);
            }
            for (k = 0; k < LEGACY_POSES * 6; k++) {
                unit[k] = (double)(uint32_t)legacy_rng(&rs) * 0x1p-32;
            }
            legacy_mix_int(&g, aacmm_simd_abs_jacobian_sums_scaled_f64(
                                   kern, &m, LEGACY_POSES, unit, legacy_scale, legacy_offset, s,
                                   q, &done));
            legacy_mix(&g, s, sizeof s);
            legacy_mix(&g, q, sizeof q);
            legacy_deltas(delta, 40, UINT64_C(4242) + (uint64_t)which);
            legacy_mix_int(&g, legacy_perturbed((int)kern, &prm, 40, delta, 100, legacy_th,
                                                legacy_p, &done));
            legacy_mix_int(&g, (long)done);
            legacy_mix(&g, legacy_p, 40u * 100u * 3u * sizeof(double));
            break;
        }
        default:
            break;
        }
    }
    return g.h;
}
#endif /* LEGACY_FLOAT_PATHS */

/* ---- the fixed-point path ----------------------------------------------- */
#if defined(LEGACY_FIXED_PATHS) && !defined(AACMM_TEST_LEGACY_FIXED_DONE)
#define AACMM_TEST_LEGACY_FIXED_DONE
#include "aacmm/kinematics_q.h"

enum { LEGACY_Q_POINT, LEGACY_Q_BATCH, LEGACY_Q_COUNTS, LEGACY_Q_PARAMS, LEGACY_Q_PATHS };
static const char *const legacy_q_names[LEGACY_Q_PATHS] = {"q_point", "q_batch", "q_counts",
                                                           "q_params"};

static uint32_t legacy_bam[LEGACY_POSES * 6], legacy_rq[LEGACY_POSES * 6];
static int64_t legacy_pq[LEGACY_POSES * 3], legacy_jq[LEGACY_POSES * AACMM_JAC_SIZE];

#if LEGACY_NEW_API
static aacmm_status_t legacy_counts_q(const aacmm_model_q_t *m, const aacmm_encoder_config_t *e,
                                      size_t n, const uint32_t *r, int64_t *p, int64_t *j,
                                      size_t *done)
{
    aacmm_arm_encoders_t s;
    (void)aacmm_arm_encoders_from_config(&s, e);
    return aacmm_batch_counts_q(m, &s, n, r, p, j, done);
}
#else
#define legacy_counts_q aacmm_batch_counts_q
#endif

/* Fixed arm `which`: 0 Table 1 (aacmm_params_default_q), 1 the perturbed
 * arm converted from double, 2 a block at the reach limit. */
static aacmm_status_t legacy_params_q(aacmm_params_q_t *q, int which)
{
    aacmm_params_f64_t p;
    int i;
    if (which == 0) {
        return aacmm_params_default_q(q);
    }
    legacy_params(&p, 1);
    if (which == 2) {
        for (i = 0; i < 6; i++) {
            p.d_mm[i] = (i % 2 ? -1.0 : 1.0) * (600.0 + 10.0 * i);
            p.a_mm[i] = (i % 2 ? 1.0 : -1.0) * (40.0 + 5.0 * i);
            p.alpha_rad[i] = -3.0 + 1.1 * i;
        }
        p.l_mm = 8000.0 - 3750.0 - 315.0 - 1e-3;
    }
    return aacmm_params_q_from_f64(q, &p);
}

static uint64_t legacy_q_hash(int path)
{
    legacy_hash_t g = legacy_start();
    int which;
    for (which = 0; which < 3; which++) {
        aacmm_params_q_t q;
        aacmm_model_q_t m;
        uint64_t s = UINT64_C(0xB5AD4ECEDA1CE2A9) + (uint64_t)which;
        int k, i, c;
        size_t done = 0u;
        legacy_mix_int(&g, legacy_params_q(&q, which));
        legacy_mix_int(&g, aacmm_model_q_init(&m, &q));
#if LEGACY_NEW_API
        if (legacy_force_general) {
            m.paper = 0u;
        }
#endif
        for (k = 0; k < LEGACY_POSES; k++) {
            for (i = 0; i < 6; i++) {
                legacy_bam[k * 6 + i] =
                    k < 8 ? (uint32_t)((uint64_t)k * UINT64_C(0x20000000) + (uint64_t)i)
                          : (uint32_t)(legacy_rng(&s) >> 32);
            }
        }
        switch (path) {
        case LEGACY_Q_POINT:
            for (k = 0; k < LEGACY_POSES; k++) {
                int64_t p[3], j[AACMM_JAC_SIZE];
                legacy_mix_int(&g, aacmm_point_q(&m, legacy_bam + 6 * k, p));
                legacy_mix(&g, p, sizeof p);
                legacy_mix_int(&g, aacmm_point_jacobian_q(&m, legacy_bam + 6 * k, p, j));
                legacy_mix(&g, p, sizeof p);
                legacy_mix(&g, j, sizeof j);
            }
            break;
        case LEGACY_Q_BATCH:
            legacy_mix_int(&g, aacmm_batch_bam_q(&m, LEGACY_POSES, legacy_bam, legacy_pq,
                                                 legacy_jq, &done));
            legacy_mix_int(&g, (long)done);
            legacy_mix(&g, legacy_pq, sizeof legacy_pq);
            legacy_mix(&g, legacy_jq, sizeof legacy_jq);
            legacy_mix_int(&g, aacmm_batch_bam_q(&m, LEGACY_POSES, legacy_bam, legacy_pq, NULL,
                                                 &done));
            legacy_mix(&g, legacy_pq, sizeof legacy_pq);
            break;
        case LEGACY_Q_COUNTS:
            for (c = 0; c < 3; c++) {
                aacmm_encoder_config_t e;
                legacy_encoders(&e, c);
                legacy_readings(legacy_rq, LEGACY_POSES, &e, UINT64_C(31) + (uint64_t)c);
                legacy_mix_int(&g, legacy_counts_q(&m, &e, LEGACY_POSES, legacy_rq, legacy_pq,
                                                   legacy_jq, &done));
                legacy_mix_int(&g, (long)done);
                legacy_mix(&g, legacy_pq, sizeof legacy_pq);
                legacy_mix(&g, legacy_jq, sizeof legacy_jq);
            }
            break;
        case LEGACY_Q_PARAMS: {
            /* the conversion and its round trip */
            aacmm_params_f64_t back;
            legacy_mix(&g, q.theta_offset_bam, sizeof q.theta_offset_bam);
            legacy_mix(&g, q.alpha_bam, sizeof q.alpha_bam);
            legacy_mix(&g, q.d_q18, sizeof q.d_q18);
            legacy_mix(&g, q.a_q18, sizeof q.a_q18);
            legacy_mix(&g, &q.l_q18, sizeof q.l_q18);
            legacy_mix_int(&g, aacmm_params_q_to_f64(&back, &q));
            legacy_mix(&g, back.theta_offset_rad, sizeof back.theta_offset_rad);
            legacy_mix(&g, back.alpha_rad, sizeof back.alpha_rad);
            legacy_mix(&g, back.d_mm, sizeof back.d_mm);
            legacy_mix(&g, back.a_mm, sizeof back.a_mm);
            legacy_mix(&g, &back.l_mm, sizeof back.l_mm);
            legacy_mix_int(&g, aacmm_params_q_validate(&q));
            for (k = 0; k < 64; k++) {
                int32_t sn, cs;
                aacmm_sincos_q((uint32_t)(legacy_rng(&s) >> 32), &sn, &cs);
                legacy_mix(&g, &sn, sizeof sn);
                legacy_mix(&g, &cs, sizeof cs);
            }
            break;
        }
        default:
            break;
        }
    }
    return g.h;
}
#endif /* LEGACY_FIXED_PATHS */
