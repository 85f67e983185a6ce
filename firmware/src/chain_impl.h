/*
 * The kinematic chain and its Jacobian, written once for one pose (the
 * per-pose core, kinematics_impl.h) and for a vector of poses across SIMD
 * lanes (simd/simd_impl.h), so both run the same operations in the same
 * order; and written once for every arm shape (aacmm/kinematics.h):
 *
 *   CH_GENERAL 0  the paper's shape (6 joints, standard DH, no beta, tip l)
 *                 as compile-time constants: the chain of the core before the
 *                 general model, operation for operation;
 *   CH_GENERAL 1  any shape, read from the model: joint count, convention
 *                 and beta per joint, tip kind. For a model of the paper's
 *                 shape it performs the same operations as CH_GENERAL 0
 *                 (the tests run it on the paper's arm and compare bit for
 *                 bit).
 *
 * Included after defining:
 *   CH_T            the element type: REAL, or a vector of REAL
 *   CH(name)        a suffix for the generated type and functions
 *   CH_GENERAL      0 or 1, above
 *   CH_SPLAT(x)     a REAL (a model value) as a CH_T
 *   CH_SINCOS(x, s, c)   sine and cosine of a CH_T
 *   CH_FMA(a, b, c) a * b + c: fused (one rounding) in the kernels with
 *                   fused multiply-add, else the product rounded, then the sum
 * and TYPE(name), LIT(x) of the precision template, and optionally
 *   CH_STEP_PARAM   more parameters of the chain (", type name")
 *   CH_STEP(i)      a statement run at the end of joint i of the pass down the
 *                   chain (the batch kernels write the previous group's
 *                   Jacobians there, so the stores overlap the arithmetic);
 *                   it may read ch_nj, the joint count
 *   CH_INLINE       the chain's storage class (default static inline)
 *   CH_OUT(e, v)    what becomes of Jacobian entry e = v (default: jac[e] = v;
 *                   the fused Monte Carlo sums accumulate it instead)
 *   CH_FUSE_CHAIN   1: the frames and origins use CH_FMA too (default 0)
 *   CH_DIRECT_DA    1: the d and a columns go to jac during the pass (below)
 *   CH_JSTORE(e, v), CH_JLOAD(e)   with CH_DIRECT_DA, how entry e is written
 *                   and read back (default jac[e]; the tiled batch kernels
 *                   address the caller's tile)
 * The includer #undefs the CH_ macros afterwards (CH_GENERAL and CH
 * between two inclusions).
 *
 * Each CH_FMA is placed so that, unfused, the arithmetic is exactly the plain
 * u.y v.z - u.z v.y and a u + b v of the per-pose core before the fused
 * kernels existed: a kernel without FMA rounds as it always did, and one with
 * FMA rounds exactly as every other kernel with FMA. The chain of frames
 * (lin2) is fused only with CH_FUSE_CHAIN.
 */

/* A 3-vector. Small structs passed by value stay in registers, where the
 * indexed arrays of a loop over coordinates would not. */
typedef struct {
    CH_T x, y, z;
} CH(vec3);

/* The shape: constants for the paper's, the model's fields otherwise. */
#if CH_GENERAL
#define CH_NJ ((int)model->arm.shape.joints)
#define CH_NP ((int)model->n_params)
#define CH_CAP AACMM_JOINTS_MAX
#define CH_MODIFIED(i) (model->arm.shape.convention[i] == (uint8_t)AACMM_DH_MODIFIED)
#define CH_HAS_BETA(i) (model->arm.shape.beta[i] != 0u)
#define CH_TIP_XYZ (model->arm.shape.tip == (uint8_t)AACMM_TIP_XYZ)
#define CH_COL_BETA(i) ((int)model->col_beta[i])
#define CH_COL_TIP ((int)model->col_tip)
#else
#define CH_NJ AACMM_JOINTS
#define CH_NP AACMM_JAC_COLS
#define CH_CAP AACMM_JOINTS
#define CH_MODIFIED(i) 0
#define CH_HAS_BETA(i) 0
#define CH_TIP_XYZ 0
#define CH_COL_BETA(i) 0
#define CH_COL_TIP AACMM_COL_L
#endif
#define CH_E(r, col) ((r) * CH_NP + (col)) /* entry (row r, column col) */

/* a u + b v. Fused only with CH_FUSE_CHAIN: the points of the kernels with
 * FMA then drift further from the scalar ones along the arm (measured up to
 * 1.14e-12 mm over 10^6 poses, against 0.68e-12 with the fused operations
 * only in the sine, cosine and cross products); the Monte Carlo sums, which
 * output no point, take the saving. */
#if CH_FUSE_CHAIN
#define CH_LIN(a, u, bv) CH_FMA(a, u, bv)
#else
#define CH_LIN(a, u, bv) ((a) * (u) + (bv))
#endif
static inline CH(vec3) CH(lin2)(CH_T a, CH(vec3) u, CH_T b, CH(vec3) v)
{
    CH(vec3) r;
    r.x = CH_LIN(a, u.x, b * v.x);
    r.y = CH_LIN(a, u.y, b * v.y);
    r.z = CH_LIN(a, u.z, b * v.z);
    return r;
}

/* u x v, each component a product minus a product */
static inline CH(vec3) CH(cross)(CH(vec3) u, CH(vec3) v)
{
    CH(vec3) r;
    r.x = CH_FMA(u.y, v.z, -(u.z * v.y));
    r.y = CH_FMA(u.z, v.x, -(u.x * v.z));
    r.z = CH_FMA(u.x, v.y, -(u.y * v.x));
    return r;
}

/*
 * One pass down the chain. The running frame has axes X, Y, Z and origin O
 * in the base frame; with c, s the cosine and sine of theta_i, ca, sa those
 * of alpha_i and cb, sb those of beta_i, each elementary transform is
 *     Rz(theta):  X' = c X + s Y,     Y' = -s X + c Y
 *     Rx(alpha):  Y' = ca Y + sa Z,   Z' = -sa Y + ca Z
 *     Ry(beta):   X' = cb X - sb Z,   Z' = sb X + cb Z
 *     Tz(d):      O' = O + d Z;       Tx(a): O' = O + a X
 * and a standard joint, Eq. 2 of the paper, is
 *     x_i = c x_{i-1} + s y_{i-1}
 *     u   = -s x_{i-1} + c y_{i-1}        (y axis after Rot(z, theta_i))
 *     y_i = ca u + sa z_{i-1}
 *     z_i = -sa u + ca z_{i-1}
 *     o_i = o_{i-1} + d_i z_{i-1} + a_i x_i
 * The probe is p = o_N + l z_N, or o_N + t_x x_N + t_y y_N + t_z z_N. Per
 * joint the pass keeps the (axis, point) of each rotation column and the
 * axes of the two translation columns (aacmm/kinematics.h):
 *     theta_i: (zt, ot)  d_i: zt     standard: zt = z_{i-1}, ot = o_{i-1}
 *     alpha_i: (xa, oa)  a_i: xa               xa = x_i,     oa = o_i
 *     beta_i:  (yb, ot)                        yb = y_{i-1}
 *                                    modified: xa = x_{i-1}, yb = y after
 *                                              Rx, zt = z_i, oa = ot = o
 *                                              after Tx(a_i)
 * (Rx about x_{i-1} through o_{i-1} and through o_{i-1} + a_i x_{i-1} is
 * the same rotation; the second point serves theta and beta too.) Inlined
 * with jac constant NULL or not, so the point-only path does no Jacobian
 * work.
 */
#ifndef CH_STEP
#define CH_STEP_PARAM
#define CH_STEP(i)
#endif
#ifndef CH_OUT
#define CH_OUT(e, v) (jac[e] = (v))
#endif
#ifndef CH_INLINE
#define CH_INLINE static inline
#endif
#ifndef CH_FUSE_CHAIN
#define CH_FUSE_CHAIN 0
#endif
/* The d and a columns of the Jacobian are zt and xa themselves: with
 * CH_DIRECT_DA 1 they are written to the output during the pass and read back
 * from there (CH_JSTORE, CH_JLOAD: default jac[e], and CH_OUT must then store
 * to the same place), instead of being kept in arrays and copied after it:
 * 36 vector stores and loads fewer per group of poses in the batch kernels
 * (simd_f64.c says where it pays). Default 0. */
#ifndef CH_DIRECT_DA
#define CH_DIRECT_DA 0
#endif
#ifndef CH_JSTORE
#define CH_JSTORE(e, v) (jac[e] = (v))
#define CH_JLOAD(e) (jac[e])
#endif
#define CH_JD(r, i) CH_JLOAD(CH_E(r, AACMM_ARM_COL_D(ch_nj, i)))
#define CH_JA(r, i) CH_JLOAD(CH_E(r, AACMM_ARM_COL_A(ch_nj, i)))
#if CH_DIRECT_DA
#define CH_KEEP_ZX(i, zv, xv)                                                                      \
    if (jac != NULL) {                                                                             \
        CH_JSTORE(CH_E(0, AACMM_ARM_COL_D(ch_nj, i)), (zv).x);                                     \
        CH_JSTORE(CH_E(1, AACMM_ARM_COL_D(ch_nj, i)), (zv).y);                                     \
        CH_JSTORE(CH_E(2, AACMM_ARM_COL_D(ch_nj, i)), (zv).z);                                     \
        CH_JSTORE(CH_E(0, AACMM_ARM_COL_A(ch_nj, i)), (xv).x);                                     \
        CH_JSTORE(CH_E(1, AACMM_ARM_COL_A(ch_nj, i)), (xv).y);                                     \
        CH_JSTORE(CH_E(2, AACMM_ARM_COL_A(ch_nj, i)), (xv).z);                                     \
    }
#else
#define CH_KEEP_ZX(i, zv, xv)                                                                      \
    zprev[i] = (zv);                                                                               \
    xs[i] = (xv)
#endif
#define CH_OUT3(col, v)                                                                            \
    do {                                                                                           \
        CH_OUT(CH_E(0, col), (v).x);                                                               \
        CH_OUT(CH_E(1, col), (v).y);                                                               \
        CH_OUT(CH_E(2, col), (v).z);                                                               \
    } while (0)

CH_INLINE void CH(chain)(const TYPE(aacmm_model) *model, const CH_T *theta_rad, CH_T p_mm[3],
                             CH_T *jac CH_STEP_PARAM)
{
    const CH_T zero = CH_SPLAT(LIT(0.0));
    const CH_T one = CH_SPLAT(LIT(1.0));
    const int ch_nj = CH_NJ;
    CH(vec3) X, Y, Z, O;
    /* per joint: ot (oprev: theta's point), oa (os: alpha's point) */
    CH(vec3) oprev[CH_CAP], os[CH_CAP];
#if !CH_DIRECT_DA
    CH(vec3) zprev[CH_CAP], xs[CH_CAP]; /* zt, xa */
#endif
#if CH_GENERAL
    CH(vec3) yb[CH_CAP]; /* beta's axis */
#endif
    CH(vec3) p;
    int i;

    if (!CH_MODIFIED(0)) {
        /* Joint 1 standard, from the base frame (x, y, z the unit axes, o =
         * 0): the general step below with its products by 0 and 1 done,
         * which are exact (only the sign of a zero result could differ). */
        const CH_T sa = CH_SPLAT(model->sin_alpha[0]);
        const CH_T ca = CH_SPLAT(model->cos_alpha[0]);
        const CH_T a = CH_SPLAT(model->arm.a_mm[0]);
        CH_T s, c;
        CH(vec3) z0;
        CH_SINCOS(theta_rad[0] + model->arm.theta_offset_rad[0], &s, &c);
        z0.x = zero;
        z0.y = zero;
        z0.z = one;
        oprev[0].x = zero;
        oprev[0].y = zero;
        oprev[0].z = zero;
        X.x = c; /* u = (-s, c, 0) */
        X.y = s;
        X.z = zero;
        Y.x = ca * -s;
        Y.y = ca * c;
        Y.z = sa;
        Z.x = -sa * -s;
        Z.y = -sa * c;
        Z.z = ca;
        O.x = a * c;
        O.y = a * s;
        O.z = CH_SPLAT(model->arm.d_mm[0]);
        CH_KEEP_ZX(0, z0, X);
        os[0] = O;
        CH_STEP(0);
        i = 1;
    } else {
        /* Joint 1 modified: the general step below from the base frame. */
        X.x = one;
        X.y = zero;
        X.z = zero;
        Y.x = zero;
        Y.y = one;
        Y.z = zero;
        Z.x = zero;
        Z.y = zero;
        Z.z = one;
        O.x = zero;
        O.y = zero;
        O.z = zero;
        i = 0;
    }
    for (; i < ch_nj; i++) {
        const CH_T sa = CH_SPLAT(model->sin_alpha[i]);
        const CH_T ca = CH_SPLAT(model->cos_alpha[i]);
        CH_T s, c;
        CH_SINCOS(theta_rad[i] + model->arm.theta_offset_rad[i], &s, &c);
        if (!CH_MODIFIED(i)) {
            /* [Ry(beta_i)] Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i) */
            CH(vec3) u, step, zi;
#if CH_GENERAL
            if (CH_HAS_BETA(i)) {
                const CH_T sb = CH_SPLAT(model->sin_beta[i]);
                const CH_T cb = CH_SPLAT(model->cos_beta[i]);
                const CH(vec3) xb = X;
                yb[i] = Y;
                X = CH(lin2)(cb, xb, -sb, Z);
                Z = CH(lin2)(sb, xb, cb, Z);
            }
#endif
            zi = Z;
            oprev[i] = O;
            u = CH(lin2)(-s, X, c, Y);
            X = CH(lin2)(c, X, s, Y);
            Y = CH(lin2)(ca, u, sa, Z);
            Z = CH(lin2)(-sa, u, ca, Z);
            step = CH(lin2)(CH_SPLAT(model->arm.d_mm[i]), zi, CH_SPLAT(model->arm.a_mm[i]), X);
            O.x += step.x;
            O.y += step.y;
            O.z += step.z;
            CH_KEEP_ZX(i, zi, X);
            os[i] = O;
        }
#if CH_GENERAL
        else {
            /* Rx(alpha_i) Tx(a_i) [Ry(beta_i)] Rz(theta_i) Tz(d_i) */
            const CH_T a = CH_SPLAT(model->arm.a_mm[i]);
            const CH_T d = CH_SPLAT(model->arm.d_mm[i]);
            const CH(vec3) xa = X;
            CH(vec3) y1, x2;
            y1 = CH(lin2)(ca, Y, sa, Z);
            Z = CH(lin2)(-sa, Y, ca, Z);
            O.x = CH_LIN(a, X.x, O.x);
            O.y = CH_LIN(a, X.y, O.y);
            O.z = CH_LIN(a, X.z, O.z);
            x2 = X;
            if (CH_HAS_BETA(i)) {
                const CH_T sb = CH_SPLAT(model->sin_beta[i]);
                const CH_T cb = CH_SPLAT(model->cos_beta[i]);
                yb[i] = y1;
                x2 = CH(lin2)(cb, X, -sb, Z);
                Z = CH(lin2)(sb, X, cb, Z);
            }
            oprev[i] = O;
            os[i] = O;
            X = CH(lin2)(c, x2, s, y1);
            Y = CH(lin2)(-s, x2, c, y1);
            O.x = CH_LIN(d, Z.x, O.x);
            O.y = CH_LIN(d, Z.y, O.y);
            O.z = CH_LIN(d, Z.z, O.z);
            CH_KEEP_ZX(i, Z, xa);
        }
#endif
        CH_STEP(i);
    }
    if (CH_TIP_XYZ) {
        const CH_T tx = CH_SPLAT(model->arm.tip_mm[0]);
        const CH_T ty = CH_SPLAT(model->arm.tip_mm[1]);
        const CH_T tz = CH_SPLAT(model->arm.tip_mm[2]);
        p.x = CH_LIN(tz, Z.x, CH_LIN(ty, Y.x, CH_LIN(tx, X.x, O.x)));
        p.y = CH_LIN(tz, Z.y, CH_LIN(ty, Y.y, CH_LIN(tx, X.y, O.y)));
        p.z = CH_LIN(tz, Z.z, CH_LIN(ty, Y.z, CH_LIN(tx, X.z, O.z)));
    } else {
        const CH_T l = CH_SPLAT(model->arm.tip_mm[2]);
        p.x = CH_LIN(l, Z.x, O.x); /* = 1 * O + l Z, as lin2 would */
        p.y = CH_LIN(l, Z.y, O.y);
        p.z = CH_LIN(l, Z.z, O.z);
    }
    p_mm[0] = p.x;
    p_mm[1] = p.y;
    p_mm[2] = p.z;
    if (jac == NULL) {
        return;
    }
    for (i = 0; i < ch_nj; i++) {
#if CH_DIRECT_DA
        const CH(vec3) zp = {CH_JD(0, i), CH_JD(1, i), CH_JD(2, i)};
        const CH(vec3) xi = {CH_JA(0, i), CH_JA(1, i), CH_JA(2, i)};
#else
        const CH(vec3) zp = zprev[i];
        const CH(vec3) xi = xs[i];
#endif
        CH(vec3) v, w, jt, ja;
        w.x = p.x - os[i].x;
        w.y = p.y - os[i].y;
        w.z = p.z - os[i].z;
        /* d p / d theta_i = zt x (p - ot); for standard joint 1, z_0 x p */
        if (i == 0 && !CH_MODIFIED(0)) {
            jt.x = -p.y;
            jt.y = p.x;
            jt.z = zero;
            v = w; /* unused: joint 1 declares no beta */
        } else {
            v.x = p.x - oprev[i].x;
            v.y = p.y - oprev[i].y;
            v.z = p.z - oprev[i].z;
            jt = CH(cross)(zp, v);
        }
        CH_OUT3(AACMM_ARM_COL_THETA(ch_nj, i), jt);
        /* d p / d alpha_i = xa x (p - oa) */
        ja = CH(cross)(xi, w);
        CH_OUT3(AACMM_ARM_COL_ALPHA(ch_nj, i), ja);
        /* d p / d d_i = zt;  d p / d a_i = xa (already in jac with
         * CH_DIRECT_DA) */
#if !CH_DIRECT_DA
        CH_OUT3(AACMM_ARM_COL_D(ch_nj, i), zp);
        CH_OUT3(AACMM_ARM_COL_A(ch_nj, i), xi);
#endif
#if CH_GENERAL
        /* d p / d beta_i = yb x (p - ot) */
        if (CH_HAS_BETA(i)) {
            const CH(vec3) jb = CH(cross)(yb[i], v);
            CH_OUT3(CH_COL_BETA(i), jb);
        }
#else
        (void)v;
#endif
    }
    /* d p / d l = z_N; or d p / d t = x_N, y_N, z_N */
    if (CH_TIP_XYZ) {
        CH_OUT3(CH_COL_TIP, X);
        CH_OUT3(CH_COL_TIP + 1, Y);
        CH_OUT3(CH_COL_TIP + 2, Z);
    } else {
        CH_OUT3(CH_COL_TIP, Z);
    }
}
#undef CH_LIN
#undef CH_JD
#undef CH_JA
#undef CH_JSTORE
#undef CH_JLOAD
#undef CH_KEEP_ZX
#undef CH_OUT3
#undef CH_NJ
#undef CH_NP
#undef CH_CAP
#undef CH_MODIFIED
#undef CH_HAS_BETA
#undef CH_TIP_XYZ
#undef CH_COL_BETA
#undef CH_COL_TIP
#undef CH_E
