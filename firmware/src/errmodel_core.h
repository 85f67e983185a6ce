/*
 * The error model's shared steps (aacmm/kinematics.h), for one precision:
 * included by errmodel_impl.h (the per-pose core) and simd/simd_em_impl.h
 * (the batch kernels), so both correct the angles and extend the Jacobian
 * with the same operations. Needs REAL, LIT, TYPE, EM(name) (a suffix for
 * the names), EM_PUB(name) (the public names of the precision) and
 * EM_SINCOS(x, s, c) (the core's sine and cosine).
 */
/* cos kq, sin kq (k = 1 .. K) of each corrected joint, for the Jacobian. */
typedef struct {
    REAL cs[AACMM_JOINTS_MAX][2 * AACMM_HARMONICS_MAX]; /* cos kq at 2(k-1), sin kq at 2(k-1)+1 */
} EM(em_trig_t);

/* q_out = corrected readings (a structurally checked em of n joints,
 * checked readings); trig, if not NULL, receives cos kq, sin kq. Joints with
 * K = 0 are copied. A correction beyond AACMM_HARMONIC_SUM_MAX_RAD, which a
 * valid em cannot give, or a NaN one (a NaN or infinite coefficient) stops
 * it: AACMM_ERR_RANGE or AACMM_ERR_NOT_FINITE, the per-pose guard that
 * stands in for validating every coefficient at every pose. */
static inline aacmm_status_t EM(em_correct)(const TYPE(aacmm_errmodel) *em, int n,
                                            const REAL *theta_rad, REAL *q_out,
                                            EM(em_trig_t) *trig)
{
    const REAL hmax = (REAL)AACMM_HARMONIC_SUM_MAX_RAD;
    int i, k;
    for (i = 0; i < n; i++) {
        const int kk = (int)em->harmonics[i];
        const REAL q = theta_rad[i];
        REAL s1, c1, ck, sk, cm, sm, delta;
        if (kk == 0) {
            q_out[i] = q;
            continue;
        }
        EM_SINCOS(q, &s1, &c1);
        /* k = 1; then the Chebyshev recurrence from (cos 0q, sin 0q) = (1, 0) */
        cm = LIT(1.0);
        sm = LIT(0.0);
        ck = c1;
        sk = s1;
        delta = em->c_rad[i][0] * ck + em->s_rad[i][0] * sk;
        if (trig != NULL) {
            trig->cs[i][0] = ck;
            trig->cs[i][1] = sk;
        }
        for (k = 1; k < kk; k++) {
            const REAL cn = LIT(2.0) * c1 * ck - cm;
            const REAL sn = LIT(2.0) * c1 * sk - sm;
            cm = ck;
            sm = sk;
            ck = cn;
            sk = sn;
            delta += em->c_rad[i][k] * ck + em->s_rad[i][k] * sk;
            if (trig != NULL) {
                trig->cs[i][2 * k] = ck;
                trig->cs[i][2 * k + 1] = sk;
            }
        }
        if (!(delta <= hmax && delta >= -hmax)) {
            return (delta > hmax || delta < -hmax) ? AACMM_ERR_RANGE : AACMM_ERR_NOT_FINITE;
        }
        q_out[i] = q + delta;
    }
    return AACMM_OK;
}

/* The fields that size arrays and loops: joints, K_i, cte_columns (the
 * per-pose check; aacmm_errmodel_validate_* checks the values). */
static inline aacmm_status_t EM(em_shape_ok)(const TYPE(aacmm_errmodel) *em, int joints)
{
    int i;
    if ((int)em->joints != joints || em->cte_columns > 1u) {
        return AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (em->harmonics[i] > (i < joints ? AACMM_HARMONICS_MAX : 0)) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

/* The thermal factors 1 + cte (T - tref) of n links (checked temperatures,
 * a valid em). */
static void EM(em_factors)(const TYPE(aacmm_errmodel) *em, int n, const REAL *temp_c,
                            REAL *dt, REAL *f)
{
    int i;
    for (i = 0; i < n; i++) {
        dt[i] = temp_c[i] - em->tref_c[i];
        f[i] = LIT(1.0) + em->cte_per_k[i] * dt[i];
    }
}

/* The chain's 3 x P Jacobian in jac (row width P) made the extended 3 x
 * (P + E) one: the rows moved apart (last first: each destination lies at or
 * after its source), the harmonic columns from the theta columns and trig,
 * and with temperatures (dt, f not NULL) the cte columns and the length
 * columns' factors. model: the one at the reference temperatures (L0). */
static inline void EM(em_extend)(const TYPE(aacmm_model) *model, const TYPE(aacmm_errmodel) *em,
                                 const EM(em_trig_t) *trig, const REAL *dt, const REAL *f,
                                 REAL *jac)
{
    const int n = (int)model->arm.shape.joints;
    const int np = (int)model->n_params;
    int i, k, r, w, col;
    w = np + EM_PUB(aacmm_errmodel_cols)(em);
    for (r = AACMM_JAC_ROWS - 1; r > 0 && w > np; r--) {
        memmove(jac + r * w, jac + r * np, (size_t)np * sizeof(REAL));
    }
    /* d p / d c_ik = (d p / d theta_i) cos kq;  d p / d s_ik = ... sin kq */
    col = np;
    for (i = 0; i < n; i++) {
        const int kk = (int)em->harmonics[i];
        for (k = 0; k < kk; k++) {
            for (r = 0; r < AACMM_JAC_ROWS; r++) {
                const REAL jt = jac[r * w + AACMM_ARM_COL_THETA(n, i)];
                jac[r * w + col] = jt * trig->cs[i][2 * k];
                jac[r * w + col + 1] = jt * trig->cs[i][2 * k + 1];
            }
            col += 2;
        }
    }
    if (em->cte_columns) {
        const int ct = (int)model->col_tip, nt = (int)model->arm.shape.tip;
        for (i = 0; i < n; i++) {
            for (r = 0; r < AACMM_JAC_ROWS; r++) {
                REAL v = LIT(0.0);
                if (dt != NULL) {
                    /* d p / d cte_i = sum over link i's lengths of dp/dL L0 dT */
                    v = jac[r * w + AACMM_ARM_COL_D(n, i)] * model->arm.d_mm[i] +
                        jac[r * w + AACMM_ARM_COL_A(n, i)] * model->arm.a_mm[i];
                    if (i == n - 1) {
                        for (k = 0; k < nt; k++) {
                            v += jac[r * w + ct + k] * model->arm.tip_mm[3 - nt + k];
                        }
                    }
                    v *= dt[i];
                }
                jac[r * w + col + i] = v;
            }
        }
    }
    if (dt != NULL) {
        /* the length columns of the parameters L0: dp/dL times the factor */
        const int ct = (int)model->col_tip, nt = (int)model->arm.shape.tip;
        for (r = 0; r < AACMM_JAC_ROWS; r++) {
            for (i = 0; i < n; i++) {
                jac[r * w + AACMM_ARM_COL_D(n, i)] *= f[i];
                jac[r * w + AACMM_ARM_COL_A(n, i)] *= f[i];
            }
            for (k = 0; k < nt; k++) {
                jac[r * w + ct + k] *= f[n - 1];
            }
        }
    }
}
