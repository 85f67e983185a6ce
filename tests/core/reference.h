/*
 * Independent reference for the kinematics tests: the paper's Eq. 2 and Eq. 3
 * taken literally (4x4 homogeneous matrices multiplied in order), in long
 * double with the C library's sinl/cosl. It shares no code with the core.
 */
#ifndef AACMM_TEST_REFERENCE_H
#define AACMM_TEST_REFERENCE_H

#include <math.h>
#include <stdint.h>

#include "aacmm/kinematics.h"

/* Probe point from the 25 structural parameters, in the Eq. 10 order:
 * q[0..5] theta (joint angle including offset), q[6..11] alpha, q[12..17] d,
 * q[18..23] a, q[24] l. */
static inline void ref_point(const long double q[25], long double p[3])
{
    long double T[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    int i, r, c, k;
    for (i = 0; i < 6; i++) {
        long double ct = cosl(q[i]), st = sinl(q[i]);
        long double ca = cosl(q[6 + i]), sa = sinl(q[6 + i]);
        long double d = q[12 + i], a = q[18 + i];
        /* Eq. 2 */
        long double A[4][4] = {{ct, -st * ca, st * sa, a * ct},
                               {st, ct * ca, -ct * sa, a * st},
                               {0, sa, ca, d},
                               {0, 0, 0, 1}};
        long double N[4][4];
        for (r = 0; r < 4; r++) {
            for (c = 0; c < 4; c++) {
                long double acc = 0;
                for (k = 0; k < 4; k++) {
                    acc += T[r][k] * A[k][c];
                }
                N[r][c] = acc;
            }
        }
        for (r = 0; r < 4; r++) {
            for (c = 0; c < 4; c++) {
                T[r][c] = N[r][c];
            }
        }
    }
    /* Eq. 3: the probe at (0, 0, l, 1) in frame 6. */
    for (r = 0; r < 3; r++) {
        p[r] = T[r][2] * q[24] + T[r][3];
    }
}

/* The 25-parameter vector for a model's parameters and joint readings. */
static inline void ref_params(const aacmm_params_f64_t *pr, const double theta[6], long double q[25])
{
    int i;
    for (i = 0; i < 6; i++) {
        q[i] = (long double)theta[i] + (long double)pr->theta_offset_rad[i];
        q[6 + i] = (long double)pr->alpha_rad[i];
        q[12 + i] = (long double)pr->d_mm[i];
        q[18 + i] = (long double)pr->a_mm[i];
    }
    q[24] = (long double)pr->l_mm;
}

/* Deterministic xorshift64* generator: tests must be reproducible. */
typedef struct {
    uint64_t s;
} test_rng_t;

static inline uint64_t rng_next(test_rng_t *g)
{
    g->s ^= g->s >> 12;
    g->s ^= g->s << 25;
    g->s ^= g->s >> 27;
    return g->s * UINT64_C(2685821657736338717);
}

/* Uniform in [lo, hi). */
static inline double rng_uniform(test_rng_t *g, double lo, double hi)
{
    return lo + (hi - lo) * ((double)(rng_next(g) >> 11) * 0x1.0p-53);
}

#endif
