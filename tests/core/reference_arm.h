/*
 * Independent reference for the general arm model (aacmm/kinematics.h): the
 * product A_1 ... A_N [t 1]^T taken literally, each A_i the product of its
 * elementary 4x4 matrices in the documented order,
 *     standard DH:  [Ry(beta_i)] Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
 *     modified DH:  Rx(alpha_i) Tx(a_i) [Ry(beta_i)] Rz(theta_i) Tz(d_i)
 * in complex long double, with the C library's csinl/ccosl. It shares no
 * code with the core (which runs a frame recursion, not matrix products).
 *
 * The Jacobian is the complex-step derivative: every function here is
 * analytic in the parameters, so dp/dq_c = Im p(q + i h e_c) / h to the
 * rounding of long double (no difference is taken, so no cancellation),
 * with h = 1e-40.
 *
 * Also the test models: random arms of every shape, and three models shaped
 * like the ones issue 26 ships (a 7-axis arm of commercial proportions, a
 * 5-axis arm with parallel hinges and a beta, a 4-axis arm).
 */
#ifndef AACMM_TEST_REFERENCE_ARM_H
#define AACMM_TEST_REFERENCE_ARM_H

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "reference.h"

typedef long double complex ref_c_t;

/* T = T * E for 4x4 matrices. */
static inline void ref_mul4(ref_c_t T[4][4], ref_c_t E[4][4])
{
    ref_c_t N[4][4];
    int r, c, k;
    for (r = 0; r < 4; r++) {
        for (c = 0; c < 4; c++) {
            ref_c_t acc = 0;
            for (k = 0; k < 4; k++) {
                acc += T[r][k] * E[k][c];
            }
            N[r][c] = acc;
        }
    }
    memcpy(T, N, sizeof N);
}

static inline void ref_rot(ref_c_t T[4][4], char axis, ref_c_t angle)
{
    const ref_c_t c = ccosl(angle), s = csinl(angle);
    ref_c_t E[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    if (axis == 'x') {
        E[1][1] = c;
        E[1][2] = -s;
        E[2][1] = s;
        E[2][2] = c;
    } else if (axis == 'y') {
        E[0][0] = c;
        E[0][2] = s;
        E[2][0] = -s;
        E[2][2] = c;
    } else {
        E[0][0] = c;
        E[0][1] = -s;
        E[1][0] = s;
        E[1][1] = c;
    }
    ref_mul4(T, E);
}

static inline void ref_trans(ref_c_t T[4][4], int axis, ref_c_t len)
{
    ref_c_t E[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    E[axis][3] = len;
    ref_mul4(T, E);
}

/* The probe point of an arm of shape s from its parameter vector q in the
 * Jacobian column order, whose theta entries are the whole joint angles
 * (reading + offset). */
static inline void ref_arm_point_c(const aacmm_shape_t *s, const ref_c_t *q, ref_c_t p[3])
{
    const int n = (int)s->joints;
    ref_c_t T[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    ref_c_t t[3];
    int i, r, kb = 4 * n;
    for (i = 0; i < n; i++) {
        const ref_c_t theta = q[i], alpha = q[n + i], d = q[2 * n + i], a = q[3 * n + i];
        const ref_c_t beta = s->beta[i] ? q[kb++] : 0;
        if (s->convention[i] == AACMM_DH_STANDARD) {
            if (s->beta[i]) {
                ref_rot(T, 'y', beta);
            }
            ref_rot(T, 'z', theta);
            ref_trans(T, 2, d);
            ref_trans(T, 0, a);
            ref_rot(T, 'x', alpha);
        } else {
            ref_rot(T, 'x', alpha);
            ref_trans(T, 0, a);
            if (s->beta[i]) {
                ref_rot(T, 'y', beta);
            }
            ref_rot(T, 'z', theta);
            ref_trans(T, 2, d);
        }
    }
    if (s->tip == AACMM_TIP_XYZ) {
        t[0] = q[kb];
        t[1] = q[kb + 1];
        t[2] = q[kb + 2];
    } else {
        t[0] = 0;
        t[1] = 0;
        t[2] = q[kb];
    }
    for (r = 0; r < 3; r++) {
        p[r] = T[r][0] * t[0] + T[r][1] * t[1] + T[r][2] * t[2] + T[r][3];
    }
}

/* The parameter vector of an arm at joint readings theta (theta entries:
 * reading + offset), in long double. */
static inline void ref_arm_vector(const aacmm_arm_f64_t *arm, const double *theta,
                                  long double *q)
{
    const int n = (int)arm->shape.joints;
    double v[AACMM_PARAMS_MAX];
    int c, np = aacmm_shape_params(&arm->shape), i;
    (void)aacmm_arm_get_vector_f64(arm, v);
    for (c = 0; c < np; c++) {
        q[c] = (long double)v[c];
    }
    for (i = 0; i < n; i++) {
        q[i] = (long double)theta[i] + (long double)arm->theta_offset_rad[i];
    }
}

/* Point and complex-step Jacobian (3 x P, row-major) of the reference. */
static inline void ref_arm_point_jacobian(const aacmm_shape_t *s, const long double *q,
                                          long double p[3], long double *J)
{
    const int np = aacmm_shape_params(s);
    const long double h = 1e-40L;
    ref_c_t qc[AACMM_PARAMS_MAX], pc[3];
    int c, r;
    for (c = 0; c < np; c++) {
        qc[c] = q[c];
    }
    ref_arm_point_c(s, qc, pc);
    for (r = 0; r < 3; r++) {
        p[r] = creall(pc[r]);
    }
    if (J == NULL) {
        return;
    }
    for (c = 0; c < np; c++) {
        qc[c] = q[c] + h * (ref_c_t)I;
        ref_arm_point_c(s, qc, pc);
        for (r = 0; r < 3; r++) {
            J[r * np + c] = cimagl(pc[r]) / h;
        }
        qc[c] = q[c];
    }
}

/* The total reach of an arm: the sum of |d|, |a| and |t| components, the
 * bound of every |p| and |p - o| (docs/fixed-point.md). */
static inline double ref_arm_reach(const aacmm_arm_f64_t *arm)
{
    double r = 0.0;
    int i;
    for (i = 0; i < (int)arm->shape.joints; i++) {
        r += fabs(arm->d_mm[i]) + fabs(arm->a_mm[i]);
    }
    return r + fabs(arm->tip_mm[0]) + fabs(arm->tip_mm[1]) + fabs(arm->tip_mm[2]);
}

/*
 * A random arm: n joints; conventions all standard (mode 0), all modified
 * (1) or mixed at random (2); betas (with_beta) on a random subset of joints
 * 2..n (at least one); tip kind tip. Lengths d within +-350 mm, a within
 * +-150 mm, tip within +-150 mm (z within 50..300), all scaled down so that
 * the total reach is at most 3000 mm (portable arms reach 1.2 to 2.5 m;
 * double precision's rounding grows with the reach); offsets within +-0.2
 * rad; alphas at random near 0, +-pi/2 or pi (the angles arms are built
 * with) or anywhere; betas within +-0.02 rad.
 */
static inline void ref_random_arm(test_rng_t *g, int n, int mode, int with_beta, int tip,
                                  aacmm_arm_f64_t *arm)
{
    static const double base_alpha[5] = {0.0, 1.5707963267948966, -1.5707963267948966,
                                         3.141592653589793, 0.0};
    int i, nb = 0;
    memset(arm, 0, sizeof *arm);
    arm->shape.joints = (uint8_t)n;
    arm->shape.tip = (uint8_t)tip;
    for (i = 0; i < n; i++) {
        const int which = (int)(rng_next(g) % 5u);
        arm->shape.convention[i] =
            (uint8_t)(mode == 2 ? (int)(rng_next(g) % 2u) : mode);
        arm->theta_offset_rad[i] = rng_uniform(g, -0.2, 0.2);
        arm->alpha_rad[i] = which < 4 ? base_alpha[which] + rng_uniform(g, -0.01, 0.01)
                                      : rng_uniform(g, -3.1, 3.1);
        arm->d_mm[i] = rng_uniform(g, -350.0, 350.0);
        arm->a_mm[i] = rng_uniform(g, -150.0, 150.0);
        if (with_beta && i > 0 && (rng_next(g) % 2u == 0u || (i == n - 1 && nb == 0))) {
            arm->shape.beta[i] = 1u;
            arm->beta_rad[i] = rng_uniform(g, -0.02, 0.02);
            nb++;
        }
    }
    if (tip == AACMM_TIP_XYZ) {
        arm->tip_mm[0] = rng_uniform(g, -150.0, 150.0);
        arm->tip_mm[1] = rng_uniform(g, -150.0, 150.0);
    }
    arm->tip_mm[2] = rng_uniform(g, 50.0, 300.0);
    {
        double reach = 0.0, f;
        for (i = 0; i < n; i++) {
            reach += fabs(arm->d_mm[i]) + fabs(arm->a_mm[i]);
        }
        reach += fabs(arm->tip_mm[0]) + fabs(arm->tip_mm[1]) + fabs(arm->tip_mm[2]);
        f = reach > 3000.0 ? 3000.0 / reach : 1.0;
        for (i = 0; i < n; i++) {
            arm->d_mm[i] *= f;
            arm->a_mm[i] *= f;
        }
        for (i = 0; i < 3; i++) {
            arm->tip_mm[i] *= f;
        }
    }
}

/*
 * Models shaped like the ones issue 26 ships (the host's model files, part
 * C, carry the published values and their sources; these only have their
 * shapes and proportions):
 *   0: 7 axes of commercial proportions (standard DH, 1.2 m + 1.0 m links,
 *      a handle roll as the 7th axis, a probe vector), reach about 2.5 m;
 *   1: 5 axes with two parallel hinges (modified DH, the MicroScribe's
 *      layout: base yaw, shoulder and elbow hinges parallel, so joint 3
 *      declares a beta; a two-axis wrist), tip l;
 *   2: 4 axes (standard DH: base yaw, two hinges, a probe roll), tip l.
 */
static inline void ref_shipped_arm(int which, aacmm_arm_f64_t *arm)
{
    static const double pi2 = 1.5707963267948966;
    memset(arm, 0, sizeof *arm);
    if (which == 0) {
        static const double alpha[7] = {pi2, -pi2, pi2, -pi2, pi2, -pi2, 0.0};
        static const double d[7] = {180.0, 0.0, 1200.0, 0.0, 1000.0, 0.0, 150.0};
        static const double a[7] = {0.0, 80.0, 0.0, 80.0, 0.0, 0.0, 0.0};
        int i;
        arm->shape.joints = 7;
        arm->shape.tip = AACMM_TIP_XYZ;
        for (i = 0; i < 7; i++) {
            arm->alpha_rad[i] = alpha[i];
            arm->d_mm[i] = d[i];
            arm->a_mm[i] = a[i];
        }
        arm->tip_mm[0] = 12.0;
        arm->tip_mm[1] = -5.0;
        arm->tip_mm[2] = 110.0;
    } else if (which == 1) {
        static const double alpha[5] = {0.0, pi2, 0.0, pi2, -pi2};
        static const double d[5] = {210.0, 0.0, 0.0, 260.0, 0.0};
        static const double a[5] = {0.0, 24.0, 260.0, 0.0, 0.0};
        int i;
        arm->shape.joints = 5;
        arm->shape.tip = AACMM_TIP_Z;
        for (i = 0; i < 5; i++) {
            arm->shape.convention[i] = AACMM_DH_MODIFIED;
            arm->alpha_rad[i] = alpha[i] + 1e-3 * (i % 2 ? 1.0 : -1.0) * (i > 0);
            arm->d_mm[i] = d[i];
            arm->a_mm[i] = a[i];
        }
        arm->shape.beta[2] = 1u; /* joint 3's hinge parallel to joint 2's */
        arm->beta_rad[2] = 4e-4;
        arm->tip_mm[2] = 95.0;
    } else {
        static const double alpha[4] = {pi2, 0.0, 0.0, 0.0};
        static const double d[4] = {120.0, 0.0, 0.0, 0.0};
        static const double a[4] = {0.0, 300.0, 280.0, 40.0};
        int i;
        arm->shape.joints = 4;
        arm->shape.tip = AACMM_TIP_Z;
        for (i = 0; i < 4; i++) {
            arm->alpha_rad[i] = alpha[i];
            arm->d_mm[i] = d[i];
            arm->a_mm[i] = a[i];
        }
        arm->tip_mm[2] = 60.0;
    }
}

/* The arms every test runs over: for each N = 4..7, each convention mode
 * (all standard, all modified, mixed), with and without betas, each tip
 * kind: ARMS_PER random ones; then the three shipped shapes. */
#define ARMS_PER 2
#define N_RANDOM_ARMS (4 * 3 * 2 * 2 * ARMS_PER)
#define N_ARMS (N_RANDOM_ARMS + 3)

static inline void ref_test_arm(int k, aacmm_arm_f64_t *arm, char *label, size_t cap)
{
    if (k < N_RANDOM_ARMS) {
        const int n = 4 + k / (3 * 2 * 2 * ARMS_PER);
        const int mode = (k / (2 * 2 * ARMS_PER)) % 3;
        const int beta = (k / (2 * ARMS_PER)) % 2;
        const int tip = (k / ARMS_PER) % 2 ? AACMM_TIP_XYZ : AACMM_TIP_Z;
        test_rng_t g = {UINT64_C(0xA5A5) + (uint64_t)k * UINT64_C(7919)};
        static const char *const modes[3] = {"standard", "modified", "mixed"};
        ref_random_arm(&g, n, mode, beta, tip, arm);
        snprintf(label, cap, "random N=%d %s%s tip %s", n, modes[mode], beta ? " +beta" : "",
                 tip == AACMM_TIP_XYZ ? "xyz" : "z");
    } else {
        static const char *const names[3] = {"7-axis commercial", "5-axis parallel hinges",
                                             "4-axis"};
        ref_shipped_arm(k - N_RANDOM_ARMS, arm);
        snprintf(label, cap, "shipped shape: %s", names[k - N_RANDOM_ARMS]);
    }
}

#endif /* AACMM_TEST_REFERENCE_ARM_H */
