/*
 * The kinematics core, written once for both floating-point precisions.
 *
 * Included by kinematics_f32.c and kinematics_f64.c after they define:
 *   REAL       float or double
 *   SFX(name)  name##_f32 or name##_f64
 *   LIT(x)     a literal of type REAL (x##f or x)
 *   ROUND_MANT(m)   a 64-bit mantissa with bit 63 set, rounded once to REAL
 *   POW2(e)    2^e as a REAL, built from its bits (e within the normal range)
 * and the Taylor coefficients and pi/2 split constants for REAL.
 *
 * No other floating type appears here, so the float build uses only
 * single-precision operations.
 */

/* ------------------------------------------------------------------------ */
/* Parameters                                                                */
/* ------------------------------------------------------------------------ */

aacmm_status_t SFX(aacmm_params_default)(TYPE(aacmm_params) *params)
{
    static const REAL d_mm[AACMM_JOINTS] = {LIT(300.0), LIT(65.5), LIT(792.7),
                                            LIT(65.5),  LIT(883.2), LIT(0.0)};
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        params->theta_offset_rad[i] = LIT(0.0);
        params->alpha_rad[i] = LIT(1.5707963267948966); /* 90 degrees */
        params->d_mm[i] = d_mm[i];
        params->a_mm[i] = LIT(0.0);
    }
    params->l_mm = LIT(183.5);
    return AACMM_OK;
}

/* AACMM_OK if |x| <= limit, else the reason it is not. */
static aacmm_status_t SFX(check_value)(REAL x, REAL limit)
{
    if (x <= limit && x >= -limit) {
        return AACMM_OK;
    }
    return isnan(x) ? AACMM_ERR_NOT_FINITE : (isinf(x) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE);
}

aacmm_status_t SFX(aacmm_params_validate)(const TYPE(aacmm_params) *params)
{
    const REAL len_max = (REAL)AACMM_LENGTH_MAX_MM;
    const REAL ang_max = (REAL)AACMM_PARAM_ANGLE_MAX_RAD;
    aacmm_status_t st;
    int i;
    if (params == NULL) {
        return AACMM_ERR_NULL;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        if ((st = SFX(check_value)(params->theta_offset_rad[i], ang_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->alpha_rad[i], ang_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->d_mm[i], len_max)) != AACMM_OK ||
            (st = SFX(check_value)(params->a_mm[i], len_max)) != AACMM_OK) {
            return st;
        }
    }
    return SFX(check_value)(params->l_mm, len_max);
}

aacmm_status_t SFX(aacmm_model_init)(TYPE(aacmm_model) *model, const TYPE(aacmm_params) *params)
{
    aacmm_status_t st;
    int i;
    if (model == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(aacmm_params_validate)(params);
    if (st != AACMM_OK) {
        return st;
    }
    model->params = *params;
    for (i = 0; i < AACMM_JOINTS; i++) {
        SFX(aacmm_sincos)(params->alpha_rad[i], &model->sin_alpha[i], &model->cos_alpha[i]);
    }
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Sine and cosine                                                           */
/* ------------------------------------------------------------------------ */

static inline void SFX(sincos_inline)(REAL x, REAL *s, REAL *c)
{
    /* Quadrant signs, indexed by bit 1 of the quadrant (sine) and of the
     * quadrant + 1 (cosine): a table instead of a switch, because random
     * joint angles make a quadrant branch mispredict half the time. */
    static const REAL sign[2] = {LIT(1.0), LIT(-1.0)};
    /* k = x / (pi/2) rounded to nearest: adding and subtracting 1.5 * 2^(p-1)
     * rounds in the FPU's default round-to-nearest mode without a branch.
     * |x| <= 2048 keeps |k| <= 1304, so k * PIO2_1 and k * PIO2_2 are exact
     * (each constant has few significant bits). */
    REAL kf = (x * TWO_OVER_PI + ROUND_MAGIC) - ROUND_MAGIC;
    uint32_t q = (uint32_t)(int32_t)kf;
    REAL r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3; /* |r| <= pi/4 (+tiny) */
    REAL z = r * r;
    REAL v[2];
    v[0] = r + r * z * SIN_POLY(z);                            /* sin r */
    v[1] = LIT(1.0) - (LIT(0.5) * z - z * z * COS_POLY(z));    /* cos r */
    *s = v[q & 1u] * sign[(q >> 1) & 1u];
    *c = v[(q & 1u) ^ 1u] * sign[((q + 1u) >> 1) & 1u];
}

void SFX(aacmm_sincos)(REAL x, REAL *s, REAL *c)
{
    SFX(sincos_inline)(x, s, c);
}

/* ------------------------------------------------------------------------ */
/* Forward kinematics and Jacobian                                           */
/* ------------------------------------------------------------------------ */

static aacmm_status_t SFX(check_angles)(const REAL theta_rad[AACMM_JOINTS])
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    int i;
    for (i = 0; i < AACMM_JOINTS; i++) {
        aacmm_status_t st = SFX(check_value)(theta_rad[i], lim);
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

/* A 3-vector. Small structs passed by value stay in registers, where the
 * indexed arrays of a loop over coordinates would not. */
typedef struct {
    REAL x, y, z;
} SFX(vec3);

/* a u + b v */
static inline SFX(vec3) SFX(lin2)(REAL a, SFX(vec3) u, REAL b, SFX(vec3) v)
{
    SFX(vec3) r;
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
static inline void SFX(chain)(const TYPE(aacmm_model) *model, const REAL theta_rad[AACMM_JOINTS],
                              REAL p_mm[3], REAL *jac)
{
    SFX(vec3) X = {LIT(1.0), LIT(0.0), LIT(0.0)};
    SFX(vec3) Y = {LIT(0.0), LIT(1.0), LIT(0.0)};
    SFX(vec3) Z = {LIT(0.0), LIT(0.0), LIT(1.0)};
    SFX(vec3) O = {LIT(0.0), LIT(0.0), LIT(0.0)};
    SFX(vec3) zprev[AACMM_JOINTS], oprev[AACMM_JOINTS], xs[AACMM_JOINTS], os[AACMM_JOINTS];
    SFX(vec3) p;
    int i;

    for (i = 0; i < AACMM_JOINTS; i++) {
        const REAL sa = model->sin_alpha[i];
        const REAL ca = model->cos_alpha[i];
        REAL s, c;
        SFX(vec3) u, step;
        SFX(sincos_inline)(theta_rad[i] + model->params.theta_offset_rad[i], &s, &c);
        zprev[i] = Z;
        oprev[i] = O;
        u = SFX(lin2)(-s, X, c, Y);
        X = SFX(lin2)(c, X, s, Y);
        Y = SFX(lin2)(ca, u, sa, Z);
        Z = SFX(lin2)(-sa, u, ca, Z);
        step = SFX(lin2)(model->params.d_mm[i], zprev[i], model->params.a_mm[i], X);
        O.x += step.x;
        O.y += step.y;
        O.z += step.z;
        xs[i] = X;
        os[i] = O;
    }
    p = SFX(lin2)(LIT(1.0), O, model->params.l_mm, Z);
    p_mm[0] = p.x;
    p_mm[1] = p.y;
    p_mm[2] = p.z;
    if (jac == NULL) {
        return;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        const SFX(vec3) zp = zprev[i];
        const SFX(vec3) xi = xs[i];
        SFX(vec3) v, w;
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

aacmm_status_t SFX(aacmm_point)(const TYPE(aacmm_model) *model, const REAL theta_rad[AACMM_JOINTS],
                                REAL p_mm[3])
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, NULL);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_point_jacobian)(const TYPE(aacmm_model) *model,
                                         const REAL theta_rad[AACMM_JOINTS], REAL p_mm[3],
                                         REAL jac[AACMM_JAC_SIZE])
{
    aacmm_status_t st;
    if (model == NULL || theta_rad == NULL || p_mm == NULL || jac == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(check_angles)(theta_rad);
    if (st != AACMM_OK) {
        return st;
    }
    SFX(chain)(model, theta_rad, p_mm, jac);
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Encoders                                                                  */
/* ------------------------------------------------------------------------ */

aacmm_status_t SFX(aacmm_encoder_to_angles)(const aacmm_encoder_config_t *config,
                                            const uint32_t reading_counts[AACMM_JOINTS],
                                            REAL theta_rad[AACMM_JOINTS])
{
    int64_t s[AACMM_JOINTS];
    REAL out[AACMM_JOINTS];
    aacmm_status_t st;
    int i;
    if (theta_rad == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_encoder_signed_counts(config, reading_counts, s);
    if (st != AACMM_OK) {
        return st;
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        if (s[i] == 0) {
            out[i] = LIT(0.0);
        } else {
            uint64_t mant;
            int e;
            REAL mag;
            aacmm_internal_angle_exact((uint32_t)(s[i] < 0 ? -s[i] : s[i]),
                                       config->counts_per_rev[i], &mant, &e);
            mag = ROUND_MANT(mant) * POW2(e); /* one rounding, then an exact scaling */
            out[i] = (s[i] < 0) ? -mag : mag;
        }
    }
    for (i = 0; i < AACMM_JOINTS; i++) {
        theta_rad[i] = out[i];
    }
    return AACMM_OK;
}

/* ------------------------------------------------------------------------ */
/* Batches                                                                   */
/* ------------------------------------------------------------------------ */

/* Pose k of a batch: its point (and Jacobian if jac is not NULL) into the
 * k-th slots, then *done = k + 1. Inlined, so each branch calls a chain
 * specialised for its jac. */
static inline void SFX(batch_pose)(const TYPE(aacmm_model) *model, const REAL *th, size_t k,
                                   REAL *p_mm, REAL *jac, size_t *done)
{
    if (jac != NULL) {
        SFX(chain)(model, th, p_mm + k * 3u, jac + k * AACMM_JAC_SIZE);
    } else {
        SFX(chain)(model, th, p_mm + k * 3u, NULL);
    }
    if (done != NULL) {
        *done = k + 1u;
    }
}

aacmm_status_t SFX(aacmm_batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        aacmm_status_t st = SFX(check_angles)(th);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, p_mm, jac, done);
    }
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_batch_counts)(const TYPE(aacmm_model) *model,
                                       const aacmm_encoder_config_t *encoders, size_t n,
                                       const uint32_t *reading_counts, REAL *p_mm, REAL *jac,
                                       size_t *done)
{
    size_t k;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || encoders == NULL ||
        (n > 0u && (reading_counts == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    for (k = 0; k < n; k++) {
        REAL th[AACMM_JOINTS];
        aacmm_status_t st =
            SFX(aacmm_encoder_to_angles)(encoders, reading_counts + k * AACMM_JOINTS, th);
        if (st != AACMM_OK) {
            return st;
        }
        SFX(batch_pose)(model, th, k, p_mm, jac, done);
    }
    return AACMM_OK;
}
