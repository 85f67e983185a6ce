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
 * and TYPE(name), LIT(x) of the precision template. The includer #undefs
 * the CH_ macros afterwards.
 */

/* A 3-vector. Small structs passed by value stay in registers, where the
 * indexed arrays of a loop over coordinates would not. */
typedef struct {
    CH_T x, y, z;
} CH(vec3);

/* a u + b v */
static inline CH(vec3) CH(lin2)(CH_T a, CH(vec3) u, CH_T b, CH(vec3) v)
{
    CH(vec3) r;
    r.x = a * u.x + b * v.x;
    r.y = a * u.y + b * v.y;
    r.z = a * u.z + b * v.z;
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
static inline void CH(chain)(const TYPE(aacmm_model) *model, const CH_T theta_rad[AACMM_JOINTS],
                             CH_T p_mm[3], CH_T *jac)
{
    const CH_T zero = CH_SPLAT(LIT(0.0));
    const CH_T one = CH_SPLAT(LIT(1.0));
    CH(vec3) X = {one, zero, zero};
    CH(vec3) Y = {zero, one, zero};
    CH(vec3) Z = {zero, zero, one};
    CH(vec3) O = {zero, zero, zero};
    CH(vec3) zprev[AACMM_JOINTS], oprev[AACMM_JOINTS], xs[AACMM_JOINTS], os[AACMM_JOINTS];
    CH(vec3) p;
    int i;

    for (i = 0; i < AACMM_JOINTS; i++) {
        const CH_T sa = CH_SPLAT(model->sin_alpha[i]);
        const CH_T ca = CH_SPLAT(model->cos_alpha[i]);
        CH_T s, c;
        CH(vec3) u, step;
        CH_SINCOS(theta_rad[i] + model->params.theta_offset_rad[i], &s, &c);
        zprev[i] = Z;
        oprev[i] = O;
        u = CH(lin2)(-s, X, c, Y);
        X = CH(lin2)(c, X, s, Y);
        Y = CH(lin2)(ca, u, sa, Z);
        Z = CH(lin2)(-sa, u, ca, Z);
        step = CH(lin2)(CH_SPLAT(model->params.d_mm[i]), zprev[i], CH_SPLAT(model->params.a_mm[i]),
                        X);
        O.x += step.x;
        O.y += step.y;
        O.z += step.z;
        xs[i] = X;
        os[i] = O;
    }
    p = CH(lin2)(one, O, CH_SPLAT(model->params.l_mm), Z);
    p_mm[0] = p.x;
    p_mm[1] = p.y;
    p_mm[2] = p.z;
    if (jac == NULL) {
        return;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        const CH(vec3) zp = zprev[i];
        const CH(vec3) xi = xs[i];
        CH(vec3) v, w;
        v.x = p.x - oprev[i].x;
        v.y = p.y - oprev[i].y;
        v.z = p.z - oprev[i].z;
        w.x = p.x - os[i].x;
        w.y = p.y - os[i].y;
        w.z = p.z - os[i].z;
        /* d p / d theta_i = z_{i-1} x (p - o_{i-1}) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = zp.y * v.z - zp.z * v.y;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = zp.z * v.x - zp.x * v.z;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_THETA(i)] = zp.x * v.y - zp.y * v.x;
        /* d p / d alpha_i = x_i x (p - o_i) */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = xi.y * w.z - xi.z * w.y;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = xi.z * w.x - xi.x * w.z;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_ALPHA(i)] = xi.x * w.y - xi.y * w.x;
        /* d p / d d_i = z_{i-1};  d p / d a_i = x_i */
        jac[0 * AACMM_JAC_COLS + AACMM_COL_D(i)] = zp.x;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_D(i)] = zp.y;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_D(i)] = zp.z;
        jac[0 * AACMM_JAC_COLS + AACMM_COL_A(i)] = xi.x;
        jac[1 * AACMM_JAC_COLS + AACMM_COL_A(i)] = xi.y;
        jac[2 * AACMM_JAC_COLS + AACMM_COL_A(i)] = xi.z;
    }
    /* d p / d l = z_6 */
    jac[0 * AACMM_JAC_COLS + AACMM_COL_L] = Z.x;
    jac[1 * AACMM_JAC_COLS + AACMM_COL_L] = Z.y;
    jac[2 * AACMM_JAC_COLS + AACMM_COL_L] = Z.z;
}

