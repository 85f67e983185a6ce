/*
 * The kinematic chain and its Jacobian, written once for one pose (the
 * per-pose core, kinematics_impl.h) and for a vector of poses across SIMD
 * lanes (simd/simd_impl.h), so both run the same operations in the same
 * order.
 *
 * Included after defining:
 *   CH_T            the element type: REAL, or a vector of REAL
 *   CH(name)        a suffix for the generated type and functions
 *   CH_SPLAT(x)     a REAL (a model value) as a CH_T
 *   CH_SINCOS(x, s, c)   sine and cosine of a CH_T
 *   CH_FMA(a, b, c) a * b + c: fused (one rounding) in the kernels with
 *                   fused multiply-add, else the product rounded, then the sum
 * and TYPE(name), LIT(x) of the precision template, and optionally
 *   CH_STEP_PARAM   more parameters of the chain (", type name")
 *   CH_STEP(i)      a statement run at the end of joint i of the pass down the
 *                   chain (the batch kernels write the previous group's
 *                   Jacobians there, so the stores overlap the arithmetic)
 *   CH_INLINE       the chain's storage class (default static inline)
 *   CH_OUT(e, v)    what becomes of Jacobian entry e = v (default: jac[e] = v;
 *                   the fused Monte Carlo sums accumulate it instead)
 *   CH_FUSE_CHAIN   1: the frames and origins use CH_FMA too (default 0)
 *   CH_DIRECT_DA    1: the d and a columns go to jac during the pass (below)
 *   CH_JSTORE(e, v), CH_JLOAD(e)   with CH_DIRECT_DA, how entry e is written
 *                   and read back (default jac[e]; the tiled batch kernels
 *                   address the caller's tile)
 * The includer #undefs the CH_ macros afterwards.
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
 * One pass down the chain. Frame i has axes x_i, y_i, z_i and origin o_i in
 * the base frame; with c, s the cosine and sine of theta_i and ca, sa those
 * of alpha_i, Eq. 2 gives
 *     x_i = c x_{i-1} + s y_{i-1}
 *     u   = -s x_{i-1} + c y_{i-1}        (y axis after Rot(z, theta_i))
 *     y_i = ca u + sa z_{i-1}
 *     z_i = -sa u + ca z_{i-1}
 *     o_i = o_{i-1} + d_i z_{i-1} + a_i x_i
 * and the probe is p = o_6 + l z_6. The Jacobian columns use z_{i-1}, o_{i-1},
 * x_i and o_i, kept from the pass. Inlined with jac constant NULL or not, so
 * the point-only path does no Jacobian work.
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
/* The d and a columns of the Jacobian are z_{i-1} and x_i themselves: with
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
#define CH_JD(r, i) CH_JLOAD((r) * AACMM_JAC_COLS + AACMM_COL_D(i))
#define CH_JA(r, i) CH_JLOAD((r) * AACMM_JAC_COLS + AACMM_COL_A(i))
#if CH_DIRECT_DA
#define CH_KEEP_ZX(i, zv, xv)                                                                      \
    if (jac != NULL) {                                                                             \
        CH_JSTORE(0 * AACMM_JAC_COLS + AACMM_COL_D(i), (zv).x);                                    \
        CH_JSTORE(1 * AACMM_JAC_COLS + AACMM_COL_D(i), (zv).y);                                    \
        CH_JSTORE(2 * AACMM_JAC_COLS + AACMM_COL_D(i), (zv).z);                                    \
        CH_JSTORE(0 * AACMM_JAC_COLS + AACMM_COL_A(i), (xv).x);                                    \
        CH_JSTORE(1 * AACMM_JAC_COLS + AACMM_COL_A(i), (xv).y);                                    \
        CH_JSTORE(2 * AACMM_JAC_COLS + AACMM_COL_A(i), (xv).z);                                    \
    }
#else
#define CH_KEEP_ZX(i, zv, xv)                                                                      \
    zprev[i] = (zv);                                                                               \
    xs[i] = (xv)
#endif
CH_INLINE void CH(chain)(const TYPE(aacmm_model) *model, const CH_T theta_rad[AACMM_JOINTS],
                             CH_T p_mm[3], CH_T *jac CH_STEP_PARAM)
{
    const CH_T zero = CH_SPLAT(LIT(0.0));
    const CH_T one = CH_SPLAT(LIT(1.0));
    CH(vec3) X, Y, Z, O;
    CH(vec3) oprev[AACMM_JOINTS], os[AACMM_JOINTS];
#if !CH_DIRECT_DA
    CH(vec3) zprev[AACMM_JOINTS], xs[AACMM_JOINTS];
#endif
    CH(vec3) p;
    int i;

    /* Joint 1 from the base frame (x, y, z the unit axes, o = 0): the
     * general step below with its products by 0 and 1 done, which are exact
     * (only the sign of a zero result could differ). */
    {
        const CH_T sa = CH_SPLAT(model->sin_alpha[0]);
        const CH_T ca = CH_SPLAT(model->cos_alpha[0]);
        const CH_T a = CH_SPLAT(model->params.a_mm[0]);
        CH_T s, c;
        CH(vec3) z0;
        CH_SINCOS(theta_rad[0] + model->params.theta_offset_rad[0], &s, &c);
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
        O.z = CH_SPLAT(model->params.d_mm[0]);
        CH_KEEP_ZX(0, z0, X);
        os[0] = O;
        CH_STEP(0);
    }
    for (i = 1; i < AACMM_JOINTS; i++) {
        const CH_T sa = CH_SPLAT(model->sin_alpha[i]);
        const CH_T ca = CH_SPLAT(model->cos_alpha[i]);
        CH_T s, c;
        CH(vec3) u, step;
        const CH(vec3) zi = Z;
        CH_SINCOS(theta_rad[i] + model->params.theta_offset_rad[i], &s, &c);
        oprev[i] = O;
        u = CH(lin2)(-s, X, c, Y);
        X = CH(lin2)(c, X, s, Y);
        Y = CH(lin2)(ca, u, sa, Z);
        Z = CH(lin2)(-sa, u, ca, Z);
        step = CH(lin2)(CH_SPLAT(model->params.d_mm[i]), zi, CH_SPLAT(model->params.a_mm[i]), X);
        O.x += step.x;
        O.y += step.y;
        O.z += step.z;
        CH_KEEP_ZX(i, zi, X);
        os[i] = O;
        CH_STEP(i);
    }
    {
        const CH_T l = CH_SPLAT(model->params.l_mm);
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
    for (i = 0; i < AACMM_JOINTS; i++) {
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
        /* d p / d theta_i = z_{i-1} x (p - o_{i-1}); for joint 1, z_0 x p */
        if (i == 0) {
            jt.x = -p.y;
            jt.y = p.x;
            jt.z = zero;
        } else {
            v.x = p.x - oprev[i].x;
            v.y = p.y - oprev[i].y;
            v.z = p.z - oprev[i].z;
            jt = CH(cross)(zp, v);
        }
        CH_OUT(0 * AACMM_JAC_COLS + AACMM_COL_THETA(i), jt.x);
        CH_OUT(1 * AACMM_JAC_COLS + AACMM_COL_THETA(i), jt.y);
        CH_OUT(2 * AACMM_JAC_COLS + AACMM_COL_THETA(i), jt.z);
        /* d p / d alpha_i = x_i x (p - o_i) */
        ja = CH(cross)(xi, w);
        CH_OUT(0 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i), ja.x);
        CH_OUT(1 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i), ja.y);
        CH_OUT(2 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i), ja.z);
        /* d p / d d_i = z_{i-1};  d p / d a_i = x_i (already in jac with
         * CH_DIRECT_DA) */
#if !CH_DIRECT_DA
        CH_OUT(0 * AACMM_JAC_COLS + AACMM_COL_D(i), zp.x);
        CH_OUT(1 * AACMM_JAC_COLS + AACMM_COL_D(i), zp.y);
        CH_OUT(2 * AACMM_JAC_COLS + AACMM_COL_D(i), zp.z);
        CH_OUT(0 * AACMM_JAC_COLS + AACMM_COL_A(i), xi.x);
        CH_OUT(1 * AACMM_JAC_COLS + AACMM_COL_A(i), xi.y);
        CH_OUT(2 * AACMM_JAC_COLS + AACMM_COL_A(i), xi.z);
#endif
    }
    /* d p / d l = z_6 */
    CH_OUT(0 * AACMM_JAC_COLS + AACMM_COL_L, Z.x);
    CH_OUT(1 * AACMM_JAC_COLS + AACMM_COL_L, Z.y);
    CH_OUT(2 * AACMM_JAC_COLS + AACMM_COL_L, Z.z);
}
#undef CH_LIN
#undef CH_JD
#undef CH_JA
#undef CH_JSTORE
#undef CH_JLOAD
#undef CH_KEEP_ZX

