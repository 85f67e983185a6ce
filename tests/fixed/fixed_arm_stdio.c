/*
 * A test tool (not part of any product build): the fixed-point path for any
 * arm, driven over stdin/stdout, so the host tests (tests/host/test_models.py)
 * can hold every shipped model's fixed-point point and Jacobian to its class.
 *
 * Input (whitespace separated; doubles as C99 hex floats, "%a", so nothing is
 * lost in the text):
 *   N tip                       joints, 0 = tip l, 1 = tip vector
 *   N conventions               0 standard, 1 modified
 *   N beta flags                0 / 1
 *   N theta offsets, N alphas, N d, N a, N betas (rad, mm), 3 tip values (mm)
 *   M                           poses
 *   M x N joint angles as binary angles (uint32, 2^32 = one turn)
 * The parameters go through aacmm_arm_q_from_f64 and aacmm_model_q_init_arm,
 * the poses through aacmm_point_jacobian_q.
 * Output: "ok P", then per pose one line of 3 + 3 P numbers, the point and the
 * row-major Jacobian in mm (mm/rad, mm/mm) as hex floats (each Q48 value
 * times 2^-48, exact). On any error: "error STATUS" and exit status 1.
 */

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "aacmm/kinematics.h"
#include "aacmm/kinematics_q.h"

static int fail(int status)
{
    printf("error %d\n", status);
    return 1;
}

static int read_doubles(double *out, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        if (scanf("%la", &out[i]) != 1) {
            return 0;
        }
    }
    return 1;
}

int main(void)
{
    aacmm_arm_f64_t arm;
    aacmm_arm_q_t q;
    aacmm_model_q_t model;
    unsigned joints, tip, v;
    unsigned long poses, k;
    int i, np, st;
    memset(&arm, 0, sizeof arm);
    if (scanf("%u %u", &joints, &tip) != 2 || joints < 1u || joints > AACMM_JOINTS_MAX) {
        return fail(-2);
    }
    arm.shape.joints = (uint8_t)joints;
    arm.shape.tip = (uint8_t)(tip ? AACMM_TIP_XYZ : AACMM_TIP_Z);
    for (i = 0; i < (int)joints; i++) {
        if (scanf("%u", &v) != 1) {
            return fail(-2);
        }
        arm.shape.convention[i] = (uint8_t)(v ? AACMM_DH_MODIFIED : AACMM_DH_STANDARD);
    }
    for (i = 0; i < (int)joints; i++) {
        if (scanf("%u", &v) != 1) {
            return fail(-2);
        }
        arm.shape.beta[i] = (uint8_t)(v != 0u);
    }
    if (!read_doubles(arm.theta_offset_rad, (int)joints) || !read_doubles(arm.alpha_rad, (int)joints) ||
        !read_doubles(arm.d_mm, (int)joints) || !read_doubles(arm.a_mm, (int)joints) ||
        !read_doubles(arm.beta_rad, (int)joints) || !read_doubles(arm.tip_mm, 3)) {
        return fail(-2);
    }
    st = (int)aacmm_arm_q_from_f64(&q, &arm);
    if (st != 0) {
        return fail(st);
    }
    st = (int)aacmm_model_q_init_arm(&model, &q);
    if (st != 0) {
        return fail(st);
    }
    np = (int)model.n_params;
    printf("ok %d\n", np);
    if (scanf("%lu", &poses) != 1) {
        return fail(-2);
    }
    for (k = 0; k < poses; k++) {
        uint32_t theta[AACMM_JOINTS_MAX];
        int64_t p[3], jac[AACMM_JAC_SIZE_MAX];
        for (i = 0; i < (int)joints; i++) {
            uint32_t t;
            if (scanf("%" SCNu32, &t) != 1) {
                return fail(-2);
            }
            theta[i] = t;
        }
        st = (int)aacmm_point_jacobian_q(&model, theta, p, jac);
        if (st != 0) {
            return fail(st);
        }
        for (i = 0; i < 3; i++) {
            printf("%a ", ldexp((double)p[i], -48));
        }
        for (i = 0; i < 3 * np; i++) {
            printf(i + 1 < 3 * np ? "%a " : "%a\n", ldexp((double)jac[i], -48));
        }
    }
    return 0;
}
