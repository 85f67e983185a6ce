/*
 * The fixed-point chain and its Jacobian (kinematics_q.h has the formulas,
 * formats and bounds), written once for both kinds of model, as the float
 * chain (chain_impl.h):
 *
 *   CQ_GENERAL 0  the paper's shape (6 standard joints, no beta, tip l) as
 *                 compile-time constants: the chain of the fixed path before
 *                 the general model, operation for operation;
 *   CQ_GENERAL 1  any shape, read from the model; for a model of the
 *                 paper's shape the same operations (tested bit for bit).
 *
 * Included by kinematics_q.c after it defines CQ(name), CQ_GENERAL, the
 * types vec3_q30 / vec3_q48 and the helpers lin2_q30, cross_q48, diff_po,
 * MUL, Q30_TO_Q48, UNROLL_JOINTS. Integer only.
 */
#if CQ_GENERAL
#define CQ_NJ ((int)model->arm.shape.joints)
#define CQ_NP ((int)model->n_params)
#define CQ_CAP AACMM_JOINTS_MAX
#define CQ_MODIFIED(i) (model->arm.shape.convention[i] == (uint8_t)AACMM_DH_MODIFIED)
#define CQ_HAS_BETA(i) (model->arm.shape.beta[i] != 0u)
#define CQ_TIP_XYZ (model->arm.shape.tip == (uint8_t)AACMM_TIP_XYZ)
#define CQ_COL_BETA(i) ((int)model->col_beta[i])
#define CQ_COL_TIP ((int)model->col_tip)
#define CQ_UNROLL
#else
#define CQ_NJ AACMM_JOINTS
#define CQ_NP AACMM_JAC_COLS
#define CQ_CAP AACMM_JOINTS
#define CQ_MODIFIED(i) 0
#define CQ_HAS_BETA(i) 0
#define CQ_TIP_XYZ 0
#define CQ_COL_BETA(i) 0
#define CQ_COL_TIP AACMM_COL_L
#define CQ_UNROLL UNROLL_JOINTS
#endif

/*
 * One pass down the chain. The paper's instance keeps the arrays of the
 * fixed path before the general model: z_0..z_N (zs), x_1..x_N (xs),
 * o_0..o_N (os), so that o_i serves both alpha_i and theta_{i+1}. The
 * general instance keeps per joint the (axis, point) of each rotation column
 * and the axes of the translation columns, as chain_impl.h:
 *     theta_i: (zt, ot), d_i: zt;  alpha_i: (xa, oa), a_i: xa;  beta_i: (yb, ot)
 * Frame N's y axis is formed only for a tip vector (or a following joint).
 * Inlined with jac constant NULL or not, so the point-only path does no
 * Jacobian work.
 */
static inline void CQ(chain)(const aacmm_model_q_t *model, const uint32_t *theta_bam,
                             int64_t p_q48[3], int64_t *jac)
{
    const int nj = CQ_NJ;
    vec3_q30 X, Y, Z;
    vec3_q48 O;
#if CQ_GENERAL
    vec3_q30 zt[CQ_CAP], xa[CQ_CAP], yb[CQ_CAP];
    vec3_q48 ot[CQ_CAP], oa[CQ_CAP];
#else
    vec3_q30 zs[AACMM_JOINTS + 1], xs[AACMM_JOINTS]; /* z_0..z_6, x_1..x_6 */
    vec3_q48 os[AACMM_JOINTS + 1];                    /* o_0..o_6 */
#endif
    vec3_q48 p, ph;
    int i;

    if (!CQ_MODIFIED(0)) {
        /* Joint 1 standard: x_0, y_0, z_0 = e_x, e_y, e_z; u = (-s, c, 0). */
        const qv_t sa = model->sin_alpha_q30[0];
        const qv_t ca = model->cos_alpha_q30[0];
        int32_t s32, c32;
        qv_t s, c;
        aacmm_fixed_sincos(theta_bam[0] + model->arm.theta_offset_bam[0], &s32, &c32);
        s = s32;
        c = c32;
        X.x = c;
        X.y = s;
        X.z = 0;
        Y.x = aacmm_fixed_mul_q30((int32_t)ca, (int32_t)-s);
        Y.y = aacmm_fixed_mul_q30((int32_t)ca, (int32_t)c);
        Y.z = sa;
        Z.x = aacmm_fixed_mul_q30((int32_t)sa, (int32_t)s);
        Z.y = aacmm_fixed_mul_q30((int32_t)-sa, (int32_t)c);
        Z.z = ca;
        /* o_1 = d_1 z_0 + a_1 x_1 */
        O.x = MUL(model->arm.a_q18[0], c);
        O.y = MUL(model->arm.a_q18[0], s);
        O.z = MUL(model->arm.d_q18[0], AACMM_Q_ONE_Q30);
#if CQ_GENERAL
        zt[0].x = 0;
        zt[0].y = 0;
        zt[0].z = AACMM_Q_ONE_Q30;
        ot[0].x = ot[0].y = ot[0].z = 0;
        xa[0] = X;
        oa[0] = O;
#else
        zs[0].x = 0;
        zs[0].y = 0;
        zs[0].z = AACMM_Q_ONE_Q30;
        os[0].x = os[0].y = os[0].z = 0;
        xs[0] = X;
        zs[1] = Z;
        os[1] = O;
#endif
        i = 1;
    } else {
        /* Joint 1 modified: the general step below from the base frame. */
        X.x = AACMM_Q_ONE_Q30;
        X.y = 0;
        X.z = 0;
        Y.x = 0;
        Y.y = AACMM_Q_ONE_Q30;
        Y.z = 0;
        Z.x = 0;
        Z.y = 0;
        Z.z = AACMM_Q_ONE_Q30;
        O.x = O.y = O.z = 0;
        i = 0;
    }
    CQ_UNROLL
    for (; i < nj; i++) {
        const qv_t sa = model->sin_alpha_q30[i];
        const qv_t ca = model->cos_alpha_q30[i];
        const qv_t d = model->arm.d_q18[i];
        const qv_t a = model->arm.a_q18[i];
        int32_t s32, c32;
        qv_t s, c;
        aacmm_fixed_sincos(theta_bam[i] + model->arm.theta_offset_bam[i], &s32, &c32);
        s = s32;
        c = c32;
        if (!CQ_MODIFIED(i)) {
            /* [Ry(beta_i)] Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i) */
            vec3_q30 u, zp;
#if CQ_GENERAL
            if (CQ_HAS_BETA(i)) {
                const qv_t sb = model->sin_beta_q30[i];
                const qv_t cb = model->cos_beta_q30[i];
                const vec3_q30 xb = X;
                yb[i] = Y;
                X = lin2_q30(cb, xb, -sb, Z);
                Z = lin2_q30(sb, xb, cb, Z);
            }
            zt[i] = Z;
            ot[i] = O;
#endif
            zp = Z;
            u = lin2_q30(c, Y, -s, X);
            X = lin2_q30(c, X, s, Y);
            if (i + 1 < nj || CQ_TIP_XYZ) {
                Y = lin2_q30(ca, u, sa, Z);
            }
            Z = lin2_q30(ca, Z, -sa, u);
            /* Q18 x Q30 = Q48, exact; |d z + a x| <= 2^31 * 2^30 * 2 = 2^62. */
            O.x += MUL(d, zp.x) + MUL(a, X.x);
            O.y += MUL(d, zp.y) + MUL(a, X.y);
            O.z += MUL(d, zp.z) + MUL(a, X.z);
#if CQ_GENERAL
            xa[i] = X;
            oa[i] = O;
#else
            xs[i] = X;
            zs[i + 1] = Z;
            os[i + 1] = O;
#endif
        }
#if CQ_GENERAL
        else {
            /* Rx(alpha_i) Tx(a_i) [Ry(beta_i)] Rz(theta_i) Tz(d_i) */
            vec3_q30 y1, x2;
            xa[i] = X;
            y1 = lin2_q30(ca, Y, sa, Z);
            Z = lin2_q30(ca, Z, -sa, Y);
            O.x += MUL(a, X.x);
            O.y += MUL(a, X.y);
            O.z += MUL(a, X.z);
            x2 = X;
            if (CQ_HAS_BETA(i)) {
                const qv_t sb = model->sin_beta_q30[i];
                const qv_t cb = model->cos_beta_q30[i];
                yb[i] = y1;
                x2 = lin2_q30(cb, X, -sb, Z);
                Z = lin2_q30(sb, X, cb, Z);
            }
            zt[i] = Z;
            ot[i] = O;
            oa[i] = O;
            X = lin2_q30(c, x2, s, y1);
            if (i + 1 < nj || CQ_TIP_XYZ) {
                Y = lin2_q30(c, y1, -s, x2);
            }
            O.x += MUL(d, Z.x);
            O.y += MUL(d, Z.y);
            O.z += MUL(d, Z.z);
        }
#endif
    }
    if (CQ_TIP_XYZ) {
        const qv_t tx = model->arm.tip_q18[0];
        const qv_t ty = model->arm.tip_q18[1];
        const qv_t tz = model->arm.tip_q18[2];
        p.x = O.x + MUL(tx, X.x) + MUL(ty, Y.x) + MUL(tz, Z.x);
        p.y = O.y + MUL(tx, X.y) + MUL(ty, Y.y) + MUL(tz, Z.y);
        p.z = O.z + MUL(tx, X.z) + MUL(ty, Y.z) + MUL(tz, Z.z);
    } else {
        const qv_t l = model->arm.tip_q18[2];
        p.x = O.x + MUL(l, Z.x);
        p.y = O.y + MUL(l, Z.y);
        p.z = O.z + MUL(l, Z.z);
    }
    p_q48[0] = p.x;
    p_q48[1] = p.y;
    p_q48[2] = p.z;
    if (jac == NULL) {
        return;
    }
    ph.x = p.x + PH_HALF;
    ph.y = p.y + PH_HALF;
    ph.z = p.z + PH_HALF;
#if CQ_GENERAL
    for (i = 0; i < nj; i++) {
        const vec3_q30 wa = diff_po(ph, oa[i]); /* p - o for alpha_i */
        /* d p / d theta_i = zt x (p - ot); for standard joint 1, z_0 x p */
        if (i == 0 && !CQ_MODIFIED(0)) {
            jac[0 * CQ_NP + AACMM_ARM_COL_THETA(nj, 0)] = -p.y;
            jac[1 * CQ_NP + AACMM_ARM_COL_THETA(nj, 0)] = p.x;
            jac[2 * CQ_NP + AACMM_ARM_COL_THETA(nj, 0)] = 0;
        } else {
            const vec3_q30 wt = CQ_MODIFIED(i) ? wa : diff_po(ph, ot[i]);
            cross_q48(zt[i], wt, jac + AACMM_ARM_COL_THETA(nj, i), CQ_NP);
            if (CQ_HAS_BETA(i)) {
                /* d p / d beta_i = yb x (p - ot) */
                cross_q48(yb[i], wt, jac + CQ_COL_BETA(i), CQ_NP);
            }
        }
        /* d p / d alpha_i = xa x (p - oa) */
        cross_q48(xa[i], wa, jac + AACMM_ARM_COL_ALPHA(nj, i), CQ_NP);
        /* d p / d d_i = zt;  d p / d a_i = xa  (Q30 -> Q48, exact) */
        jac[0 * CQ_NP + AACMM_ARM_COL_D(nj, i)] = Q30_TO_Q48(zt[i].x);
        jac[1 * CQ_NP + AACMM_ARM_COL_D(nj, i)] = Q30_TO_Q48(zt[i].y);
        jac[2 * CQ_NP + AACMM_ARM_COL_D(nj, i)] = Q30_TO_Q48(zt[i].z);
        jac[0 * CQ_NP + AACMM_ARM_COL_A(nj, i)] = Q30_TO_Q48(xa[i].x);
        jac[1 * CQ_NP + AACMM_ARM_COL_A(nj, i)] = Q30_TO_Q48(xa[i].y);
        jac[2 * CQ_NP + AACMM_ARM_COL_A(nj, i)] = Q30_TO_Q48(xa[i].z);
    }
#else
    /* d p / d theta_1 = z_0 x p = (-p_y, p_x, 0): exact, straight from Q48 */
    jac[0 * AACMM_JAC_COLS + AACMM_COL_THETA(0)] = -p.y;
    jac[1 * AACMM_JAC_COLS + AACMM_COL_THETA(0)] = p.x;
    jac[2 * AACMM_JAC_COLS + AACMM_COL_THETA(0)] = 0;
    UNROLL_JOINTS
    for (i = 0; i < AACMM_JOINTS; i++) {
        const vec3_q30 w = diff_po(ph, os[i + 1]); /* p - o_i (1-based i) */
        /* d p / d alpha_i = x_i x (p - o_i) */
        cross_q48(xs[i], w, jac + AACMM_COL_ALPHA(i), AACMM_JAC_COLS);
        /* d p / d theta_{i+1} = z_i x (p - o_i) */
        if (i + 1 < AACMM_JOINTS) {
            cross_q48(zs[i + 1], w, jac + AACMM_COL_THETA(i + 1), AACMM_JAC_COLS);
        }
        /* d p / d d_i = z_{i-1};  d p / d a_i = x_i  (Q30 -> Q48, exact) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_D(i)] = Q30_TO_Q48(zs[i].x);
        jac[1 * AACMM_JAC_COLS + AACMM_COL_D(i)] = Q30_TO_Q48(zs[i].y);
        jac[2 * AACMM_JAC_COLS + AACMM_COL_D(i)] = Q30_TO_Q48(zs[i].z);
        jac[0 * AACMM_JAC_COLS + AACMM_COL_A(i)] = Q30_TO_Q48(xs[i].x);
        jac[1 * AACMM_JAC_COLS + AACMM_COL_A(i)] = Q30_TO_Q48(xs[i].y);
        jac[2 * AACMM_JAC_COLS + AACMM_COL_A(i)] = Q30_TO_Q48(xs[i].z);
    }
#endif
    /* d p / d l = z_N; or d p / d t = x_N, y_N, z_N */
    if (CQ_TIP_XYZ) {
        jac[0 * CQ_NP + CQ_COL_TIP] = Q30_TO_Q48(X.x);
        jac[1 * CQ_NP + CQ_COL_TIP] = Q30_TO_Q48(X.y);
        jac[2 * CQ_NP + CQ_COL_TIP] = Q30_TO_Q48(X.z);
        jac[0 * CQ_NP + CQ_COL_TIP + 1] = Q30_TO_Q48(Y.x);
        jac[1 * CQ_NP + CQ_COL_TIP + 1] = Q30_TO_Q48(Y.y);
        jac[2 * CQ_NP + CQ_COL_TIP + 1] = Q30_TO_Q48(Y.z);
    }
    jac[0 * CQ_NP + CQ_COL_TIP + 2 * CQ_TIP_XYZ] = Q30_TO_Q48(Z.x);
    jac[1 * CQ_NP + CQ_COL_TIP + 2 * CQ_TIP_XYZ] = Q30_TO_Q48(Z.y);
    jac[2 * CQ_NP + CQ_COL_TIP + 2 * CQ_TIP_XYZ] = Q30_TO_Q48(Z.z);
}

#undef CQ_NJ
#undef CQ_NP
#undef CQ_CAP
#undef CQ_MODIFIED
#undef CQ_HAS_BETA
#undef CQ_TIP_XYZ
#undef CQ_COL_BETA
#undef CQ_COL_TIP
#undef CQ_UNROLL
