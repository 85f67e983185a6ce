/*
 * The error model in fixed point (aacmm/kinematics_q.h has the formats,
 * rounding and bounds). Included at the end of kinematics_q.c: it uses its
 * MUL, aacmm_fixed_* helpers and the public point functions. Integer only.
 */

aacmm_status_t aacmm_errmodel_q_default(aacmm_errmodel_q_t *em, int joints)
{
    int i, k;
    if (em == NULL) {
        return AACMM_ERR_NULL;
    }
    if (joints < AACMM_JOINTS_MIN || joints > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    em->joints = (uint8_t)joints;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        em->harmonics[i] = 0u;
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            em->c_q36[i][k] = 0;
            em->s_q36[i][k] = 0;
        }
        em->cte_q40[i] = 0;
        em->tref_q8[i] = AACMM_Q_TEMP_REF_DEFAULT;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_errmodel_q_validate(const aacmm_errmodel_q_t *em)
{
    int i, k, n;
    if (em == NULL) {
        return AACMM_ERR_NULL;
    }
    n = (int)em->joints;
    if (n < AACMM_JOINTS_MIN || n > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        const int kk = (int)em->harmonics[i];
        int64_t sum = 0; /* at most 8 * 2^31: no overflow */
        if (kk > AACMM_HARMONICS_MAX || (i >= n && kk != 0)) {
            return AACMM_ERR_RANGE;
        }
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            if (k < kk) {
                sum += abs64(em->c_q36[i][k]) + abs64(em->s_q36[i][k]);
            } else if (em->c_q36[i][k] != 0 || em->s_q36[i][k] != 0) {
                return AACMM_ERR_RANGE;
            }
        }
        if (sum > (int64_t)AACMM_Q_HARMONIC_SUM_MAX || abs64(em->cte_q40[i]) > AACMM_Q_CTE_MAX ||
            (i >= n && em->cte_q40[i] != 0) || em->tref_q8[i] < AACMM_Q_TEMP_MIN ||
            em->tref_q8[i] > AACMM_Q_TEMP_MAX) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

int aacmm_errmodel_q_cols(const aacmm_errmodel_q_t *em)
{
    int i, cols = 0;
    if (em == NULL) {
        return (int)AACMM_ERR_NULL;
    }
    if (em->joints < AACMM_JOINTS_MIN || em->joints > AACMM_JOINTS_MAX) {
        return (int)AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (em->harmonics[i] > AACMM_HARMONICS_MAX || (i >= em->joints && em->harmonics[i] != 0u)) {
            return (int)AACMM_ERR_RANGE;
        }
        cols += 2 * (int)em->harmonics[i];
    }
    return cols;
}

/* cos kq, sin kq (Q30) of each corrected joint: [i][2(k-1)], [i][2(k-1)+1] */
typedef struct {
    int32_t cs[AACMM_JOINTS_MAX][2 * AACMM_HARMONICS_MAX];
} em_trig_q;

/* 2 a b - c for Q30 a, b, c: the recurrence's step, the product rounded
 * half up to Q30 before doubling on ARMv6-M, to Q29 of the exact Q60
 * product elsewhere (the same value but for the last bit). */
/* The result is a cosine or sine (|.| <= 1 + 8 LSB) but 2 a b alone may not
 * fit int32 (a = b = 1 at a reading of 0: 2^31), so the step runs in int64. */
Q_INLINE int32_t cheb_q30(int32_t a, int32_t b, int32_t c)
{
#if AACMM_FIXED_SPLIT_MUL
    return (int32_t)(2 * (int64_t)aacmm_fixed_mul_q30(a, b) - (int64_t)c);
#else
    return (int32_t)(AACMM_FIXED_RND(MUL(a, b), 29) - (int64_t)c);
#endif
}

/* c x for a coefficient c (Q36 turn) and a Q30 x, summed: ARMv6-M each
 * rounded half up to Q36 turn (int32 sums, |.| <= 0.1 rad + 8 LSB < 2^31);
 * elsewhere exact in Q66 turn (int64, |.| < 2^61). */
#if AACMM_FIXED_SPLIT_MUL
typedef int32_t hsum_t;
#define HTERM(c, x) aacmm_fixed_mul_q30((c), (x))
#define HSUM_TO_BAM(sum) ((uint32_t)(((sum) + 8) >> 4))
#else
typedef int64_t hsum_t;
#define HTERM(c, x) MUL((c), (x))
#define HSUM_TO_BAM(sum) ((uint32_t)(int32_t)AACMM_FIXED_RND((sum), 34))
#endif

/* The corrected readings of a valid em of n joints (K = 0: copied), with
 * cos kq, sin kq by the recurrence; q_out[n .. 6] = 0. */
static void em_correct_q(const aacmm_errmodel_q_t *em, int n, const uint32_t *theta_bam,
                         uint32_t *q_out)
{
    int i, k;
    for (i = 0; i < n; i++) {
        const int kk = (int)em->harmonics[i];
        const int32_t *cc = em->c_q36[i], *ss = em->s_q36[i];
        int32_t s1, c1, ck, sk, cm, sm;
        hsum_t sum;
        if (kk == 0) {
            q_out[i] = theta_bam[i];
            continue;
        }
        aacmm_fixed_sincos(theta_bam[i], &s1, &c1);
        sum = HTERM(cc[0], c1) + HTERM(ss[0], s1);
        if (kk == 2) {
            /* the loop below for K = 2, straight (the same operations) */
            sum += HTERM(cc[1], cheb_q30(c1, c1, AACMM_Q_ONE_Q30)) + HTERM(ss[1], cheb_q30(c1, s1, 0));
            q_out[i] = theta_bam[i] + HSUM_TO_BAM(sum);
            continue;
        }
        ck = c1;
        sk = s1;
        cm = AACMM_Q_ONE_Q30;
        sm = 0;
        for (k = 1; k < kk; k++) {
            const int32_t cn = cheb_q30(c1, ck, cm);
            const int32_t sn = cheb_q30(c1, sk, sm);
            cm = ck;
            sm = sk;
            ck = cn;
            sk = sn;
            sum += HTERM(cc[k], ck) + HTERM(ss[k], sk);
        }
        /* to BAM, rounded half up; added mod 2^32 (two's complement) */
        q_out[i] = theta_bam[i] + HSUM_TO_BAM(sum);
    }
    for (; i < AACMM_JOINTS_MAX; i++) {
        q_out[i] = 0u;
    }
}

/* em_correct_q and, from the same sine and cosine, cos kq, sin kq of each
 * corrected joint for the harmonic columns (the same operations: the same
 * corrected readings). */
static void em_correct_trig_q(const aacmm_errmodel_q_t *em, int n, const uint32_t *theta_bam,
                              uint32_t *q_out, em_trig_q *trig)
{
    int i, k;
    for (i = 0; i < n; i++) {
        const int kk = (int)em->harmonics[i];
        const int32_t *cc = em->c_q36[i], *ss = em->s_q36[i];
        int32_t s1, c1, ck, sk, cm = AACMM_Q_ONE_Q30, sm = 0;
        hsum_t sum;
        if (kk == 0) {
            q_out[i] = theta_bam[i];
            continue;
        }
        aacmm_fixed_sincos(theta_bam[i], &s1, &c1);
        sum = HTERM(cc[0], c1) + HTERM(ss[0], s1);
        ck = c1;
        sk = s1;
        trig->cs[i][0] = ck;
        trig->cs[i][1] = sk;
        for (k = 1; k < kk; k++) {
            const int32_t cn = cheb_q30(c1, ck, cm);
            const int32_t sn = cheb_q30(c1, sk, sm);
            cm = ck;
            sm = sk;
            ck = cn;
            sk = sn;
            sum += HTERM(cc[k], ck) + HTERM(ss[k], sk);
            trig->cs[i][2 * k] = ck;
            trig->cs[i][2 * k + 1] = sk;
        }
        q_out[i] = theta_bam[i] + HSUM_TO_BAM(sum);
    }
    for (; i < AACMM_JOINTS_MAX; i++) {
        q_out[i] = 0u;
    }
}

/* e_i = cte_i (T_i - tref_i) in Q30 for n links (checked temperatures). */
static void em_factors_q(const aacmm_errmodel_q_t *em, int n, const int32_t *temp_q8, int32_t *e30)
{
    int i;
    for (i = 0; i < n; i++) {
        /* |cte| < 2^30.03, |dT| <= 125 * 256 < 2^15: |Q48 product| < 2^46 */
        const int64_t e48 = MUL(em->cte_q40[i], temp_q8[i] - em->tref_q8[i]);
        e30[i] = (int32_t)AACMM_FIXED_RND(e48, 18);
    }
}

/* L0 + round(L0 e) for a Q18 length and a Q30 e (|e| <= 2^27). */
static int32_t scale_q18(int32_t l0, int32_t e30)
{
    return l0 + (int32_t)AACMM_FIXED_RND(MUL(l0, e30), 30);
}

static aacmm_status_t em_scale_q(aacmm_model_q_t *out, const aacmm_model_q_t *model, int n,
                                 const int32_t *e30)
{
    aacmm_arm_q_t a = model->arm;
    int i;
    for (i = 0; i < n; i++) {
        a.d_q18[i] = scale_q18(model->arm.d_q18[i], e30[i]);
        a.a_q18[i] = scale_q18(model->arm.a_q18[i], e30[i]);
    }
    for (i = 0; i < 3; i++) {
        a.tip_q18[i] = scale_q18(model->arm.tip_q18[i], e30[n - 1]);
    }
    if (aacmm_arm_q_validate(&a) != AACMM_OK) {
        return AACMM_ERR_RANGE;
    }
    *out = *model;
    out->arm = a;
    return AACMM_OK;
}

static aacmm_status_t check_temps_q(const int32_t *temp_q8, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        if (temp_q8[i] < AACMM_Q_TEMP_MIN || temp_q8[i] > AACMM_Q_TEMP_MAX) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

/* The per-pose check: the fields that size loops and arrays (joints, K_i)
 * and the temperatures; the coefficients' bounds are the precondition
 * (aacmm_errmodel_q_validate, once, as the model's init). */
static aacmm_status_t em_check_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                 const int32_t *temp_q8)
{
    aacmm_status_t st = AACMM_OK;
    int i;
    if (em->joints != model->arm.shape.joints) {
        return AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (em->harmonics[i] > (i < (int)em->joints ? AACMM_HARMONICS_MAX : 0)) {
            return AACMM_ERR_RANGE;
        }
    }
    if (st == AACMM_OK && temp_q8 != NULL) {
        st = check_temps_q(temp_q8, (int)em->joints);
    }
    return st;
}

aacmm_status_t aacmm_model_q_at_temperature(aacmm_model_q_t *out, const aacmm_model_q_t *model,
                                            const aacmm_errmodel_q_t *em, const int32_t *temp_q8)
{
    int32_t e30[AACMM_JOINTS_MAX];
    aacmm_status_t st;
    if (out == NULL || model == NULL || em == NULL) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_errmodel_q_validate(em);
    if (st == AACMM_OK) {
        st = em_check_q(model, em, temp_q8);
    }
    if (st != AACMM_OK) {
        return st;
    }
    if (temp_q8 == NULL) {
        if (out != model) {
            *out = *model;
        }
        return AACMM_OK;
    }
    em_factors_q(em, (int)em->joints, temp_q8, e30);
    return em_scale_q(out, model, (int)em->joints, e30);
}

/* Q48 -> Q18 (Q17 on ARMv6-M) of a theta column entry, rounded half up;
 * times a Q30 cosine or sine: Q48. */
#if AACMM_FIXED_SPLIT_MUL
#define HCOL_NARROW(x) ((int32_t)(((x) + PH_HALF) >> PO_SHIFT))
#define HCOL_MUL(t, c) ((int64_t)aacmm_fixed_mul_q30((t), (c)) * ((int64_t)1 << 31))
#else
#define HCOL_NARROW(x) ((int32_t)(((x) + PH_HALF) >> PO_SHIFT))
#define HCOL_MUL(t, c) MUL((t), (c))
#endif

/* Q48 unit column (a Q30 axis times 2^18) times 1 + e (Q30): Q48. */
static int64_t scale_col_q48(int64_t col, int32_t e30)
{
    const int32_t axis = (int32_t)(col >> 18); /* exact */
    return AACMM_FIXED_RND(MUL(axis, AACMM_Q_ONE_Q30 + e30), 12);
}

/* One checked pose: the point and, if jac is not NULL, the Jacobian: with
 * ext the extended 3 x (P + E), else the 3 x P of the corrected pose. */
static aacmm_status_t em_pose_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                const uint32_t *theta_bam, const int32_t *temp_q8,
                                int64_t p_q48[3], int64_t *jac, int ext)
{
    const int n = (int)model->arm.shape.joints;
    const int np = (int)model->n_params;
    uint32_t q[AACMM_JOINTS_MAX];
    int32_t e30[AACMM_JOINTS_MAX];
    em_trig_q trig;
    aacmm_model_q_t scaled;
    const aacmm_model_q_t *m = model;
    int i, k, r, w, col;
    if (temp_q8 != NULL) {
        aacmm_status_t st;
        em_factors_q(em, n, temp_q8, e30);
        st = em_scale_q(&scaled, model, n, e30);
        if (st != AACMM_OK) {
            return st;
        }
        m = &scaled;
    }
    w = (jac != NULL && ext) ? np + aacmm_errmodel_q_cols(em) : np;
    if (w > np) {
        em_correct_trig_q(em, n, theta_bam, q, &trig);
    } else {
        em_correct_q(em, n, theta_bam, q);
    }
    if (jac == NULL) {
        return aacmm_point_q(m, q, p_q48);
    }
    (void)aacmm_point_jacobian_q(m, q, p_q48, jac);
    /* rows apart, last first (each destination at or after its source) */
    if (w > np) {
        for (r = AACMM_JAC_ROWS - 1; r > 0; r--) {
            for (k = np; k-- > 0;) {
                jac[r * w + k] = jac[r * np + k];
            }
        }
    }
    col = np;
    for (i = 0; i < n && w > np; i++) {
        const int kk = (int)em->harmonics[i];
        if (kk == 0) {
            continue;
        }
        for (r = 0; r < AACMM_JAC_ROWS; r++) {
            const int32_t t = HCOL_NARROW(jac[r * w + AACMM_ARM_COL_THETA(n, i)]);
            for (k = 0; k < kk; k++) {
                jac[r * w + col + 2 * k] = HCOL_MUL(t, trig.cs[i][2 * k]);
                jac[r * w + col + 2 * k + 1] = HCOL_MUL(t, trig.cs[i][2 * k + 1]);
            }
        }
        col += 2 * kk;
    }
    if (temp_q8 != NULL) {
        const int ct = (int)model->col_tip, nt = (int)model->arm.shape.tip;
        for (r = 0; r < AACMM_JAC_ROWS; r++) {
            for (i = 0; i < n; i++) {
                jac[r * w + AACMM_ARM_COL_D(n, i)] =
                    scale_col_q48(jac[r * w + AACMM_ARM_COL_D(n, i)], e30[i]);
                jac[r * w + AACMM_ARM_COL_A(n, i)] =
                    scale_col_q48(jac[r * w + AACMM_ARM_COL_A(n, i)], e30[i]);
            }
            for (k = 0; k < nt; k++) {
                jac[r * w + ct + k] = scale_col_q48(jac[r * w + ct + k], e30[n - 1]);
            }
        }
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_point_em_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                const uint32_t *theta_bam, const int32_t *temp_q8,
                                int64_t p_q48[3])
{
    aacmm_status_t st;
    if (em == NULL) {
        return aacmm_point_q(model, theta_bam, p_q48);
    }
    if (model == NULL || theta_bam == NULL || p_q48 == NULL) {
        return AACMM_ERR_NULL;
    }
    st = em_check_q(model, em, temp_q8);
    return (st != AACMM_OK) ? st : em_pose_q(model, em, theta_bam, temp_q8, p_q48, NULL, 0);
}

aacmm_status_t aacmm_point_jacobian_em_q(const aacmm_model_q_t *model,
                                         const aacmm_errmodel_q_t *em, const uint32_t *theta_bam,
                                         const int32_t *temp_q8, int64_t p_q48[3],
                                         int64_t *jac_q48)
{
    aacmm_status_t st;
    if (em == NULL) {
        return aacmm_point_jacobian_q(model, theta_bam, p_q48, jac_q48);
    }
    if (model == NULL || theta_bam == NULL || p_q48 == NULL || jac_q48 == NULL) {
        return AACMM_ERR_NULL;
    }
    st = em_check_q(model, em, temp_q8);
    return (st != AACMM_OK) ? st : em_pose_q(model, em, theta_bam, temp_q8, p_q48, jac_q48, 1);
}

aacmm_status_t aacmm_point_jacobian_corrected_q(const aacmm_model_q_t *model,
                                                const aacmm_errmodel_q_t *em,
                                                const uint32_t *theta_bam, const int32_t *temp_q8,
                                                int64_t p_q48[3], int64_t *jac_q48)
{
    aacmm_status_t st;
    if (em == NULL) {
        return aacmm_point_jacobian_q(model, theta_bam, p_q48, jac_q48);
    }
    if (model == NULL || theta_bam == NULL || p_q48 == NULL || jac_q48 == NULL) {
        return AACMM_ERR_NULL;
    }
    st = em_check_q(model, em, temp_q8);
    if (st != AACMM_OK) {
        return st;
    }
    if (temp_q8 == NULL) {
        /* the device's case: the corrected readings through the plain path */
        uint32_t q[AACMM_JOINTS_MAX];
        em_correct_q(em, (int)em->joints, theta_bam, q);
        return aacmm_point_jacobian_q(model, q, p_q48, jac_q48);
    }
    return em_pose_q(model, em, theta_bam, temp_q8, p_q48, jac_q48, 0);
}

aacmm_status_t aacmm_errmodel_q_correct(const aacmm_model_q_t *model,
                                        const aacmm_errmodel_q_t *em, const uint32_t *theta_bam,
                                        uint32_t *q_out)
{
    aacmm_status_t st;
    if (model == NULL || em == NULL || theta_bam == NULL || q_out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = em_check_q(model, em, NULL);
    if (st != AACMM_OK) {
        return st;
    }
    em_correct_q(em, (int)em->joints, theta_bam, q_out);
    return AACMM_OK;
}

aacmm_status_t aacmm_batch_bam_em_q(const aacmm_model_q_t *model, const aacmm_errmodel_q_t *em,
                                    size_t n, const uint32_t *theta_bam, const int32_t *temp_q8,
                                    int64_t *p_q48, int64_t *jac_q48, size_t *done)
{
    size_t k, nj, jn;
    aacmm_status_t st;
    if (em == NULL) {
        return aacmm_batch_bam_q(model, n, theta_bam, p_q48, jac_q48, done);
    }
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_bam == NULL || p_q48 == NULL))) {
        return AACMM_ERR_NULL;
    }
    st = aacmm_errmodel_q_validate(em); /* once per batch */
    if (st == AACMM_OK) {
        st = em_check_q(model, em, NULL);
    }
    if (st != AACMM_OK) {
        return st;
    }
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * ((size_t)model->n_params + (size_t)aacmm_errmodel_q_cols(em));
    for (k = 0; k < n; k++) {
        const int32_t *tc = (temp_q8 != NULL) ? temp_q8 + k * nj : NULL;
        st = (tc != NULL) ? check_temps_q(tc, (int)nj) : AACMM_OK;
        if (st == AACMM_OK) {
            st = em_pose_q(model, em, theta_bam + k * nj, tc, p_q48 + k * 3u,
                           jac_q48 != NULL ? jac_q48 + k * jn : NULL, 1);
        }
        if (st != AACMM_OK) {
            return st;
        }
        if (done != NULL) {
            *done = k + 1u;
        }
    }
    return AACMM_OK;
}

#undef HTERM
#undef HSUM_TO_BAM
#undef HCOL_NARROW
#undef HCOL_MUL
