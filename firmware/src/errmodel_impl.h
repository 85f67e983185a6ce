/*
 * The error model (encoder harmonics, thermal expansion; aacmm/kinematics.h)
 * for both floating-point precisions: included at the end of
 * kinematics_impl.h, so it shares its REAL, SFX, TYPE, LIT, check_value,
 * check_angles, sincos_inline and chain.
 */
#define EM(name) SFX(name)
#define EM_PUB(name) SFX(name)
#define EM_SINCOS SFX(sincos_inline)
#include "errmodel_core.h"

aacmm_status_t SFX(aacmm_errmodel_default)(TYPE(aacmm_errmodel) *em, int joints)
{
    int i, k;
    if (em == NULL) {
        return AACMM_ERR_NULL;
    }
    if (joints < AACMM_JOINTS_MIN || joints > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    em->joints = (uint8_t)joints;
    em->cte_columns = 0u;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        em->harmonics[i] = 0u;
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            em->c_rad[i][k] = LIT(0.0);
            em->s_rad[i][k] = LIT(0.0);
        }
        em->cte_per_k[i] = LIT(0.0);
        em->tref_c[i] = (REAL)AACMM_TEMP_REF_DEFAULT_C;
    }
    return AACMM_OK;
}

/* AACMM_OK for a temperature within AACMM_TEMP_MIN_C .. AACMM_TEMP_MAX_C. */
static aacmm_status_t SFX(check_temp)(REAL t)
{
    if (t >= (REAL)AACMM_TEMP_MIN_C && t <= (REAL)AACMM_TEMP_MAX_C) {
        return AACMM_OK;
    }
    return isnan(t) ? AACMM_ERR_NOT_FINITE : (isinf(t) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE);
}

aacmm_status_t SFX(aacmm_errmodel_validate)(const TYPE(aacmm_errmodel) *em)
{
    const REAL hmax = (REAL)AACMM_HARMONIC_SUM_MAX_RAD;
    aacmm_status_t st;
    int i, k, n;
    if (em == NULL) {
        return AACMM_ERR_NULL;
    }
    n = (int)em->joints;
    if (n < AACMM_JOINTS_MIN || n > AACMM_JOINTS_MAX || em->cte_columns > 1u) {
        return AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        const int kk = (int)em->harmonics[i];
        REAL sum = LIT(0.0);
        if (kk > AACMM_HARMONICS_MAX || (i >= n && kk != 0)) {
            return AACMM_ERR_RANGE;
        }
        for (k = 0; k < AACMM_HARMONICS_MAX; k++) {
            const REAL c = em->c_rad[i][k], s = em->s_rad[i][k];
            if (k < kk) {
                if ((st = SFX(check_value)(c, hmax)) != AACMM_OK ||
                    (st = SFX(check_value)(s, hmax)) != AACMM_OK) {
                    return st;
                }
                sum += (c < LIT(0.0) ? -c : c) + (s < LIT(0.0) ? -s : s);
            } else if ((st = SFX(check_zero)(c)) != AACMM_OK ||
                       (st = SFX(check_zero)(s)) != AACMM_OK) {
                return st;
            }
        }
        if (sum > hmax) {
            return AACMM_ERR_RANGE;
        }
        st = (i < n) ? SFX(check_value)(em->cte_per_k[i], (REAL)AACMM_CTE_MAX_PER_K)
                     : SFX(check_zero)(em->cte_per_k[i]);
        if (st == AACMM_OK) {
            st = SFX(check_temp)(em->tref_c[i]);
        }
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

int SFX(aacmm_errmodel_cols)(const TYPE(aacmm_errmodel) *em)
{
    int i, cols = 0;
    if (em == NULL) {
        return (int)AACMM_ERR_NULL;
    }
    if (em->joints < AACMM_JOINTS_MIN || em->joints > AACMM_JOINTS_MAX || em->cte_columns > 1u) {
        return (int)AACMM_ERR_RANGE;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (em->harmonics[i] > AACMM_HARMONICS_MAX || (i >= em->joints && em->harmonics[i] != 0u)) {
            return (int)AACMM_ERR_RANGE;
        }
        cols += 2 * (int)em->harmonics[i];
    }
    return cols + (int)em->cte_columns * (int)em->joints;
}

static aacmm_status_t SFX(check_temps)(const REAL *temp_c, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        const aacmm_status_t st = SFX(check_temp)(temp_c[i]);
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

/* *out = *model scaled by the factors f (n links; the tip with link n). */
static aacmm_status_t SFX(em_scale)(TYPE(aacmm_model) *out, const TYPE(aacmm_model) *model,
                                    int n, const REAL *f)
{
    const REAL len_max = (REAL)AACMM_LENGTH_MAX_MM;
    TYPE(aacmm_model) m = *model;
    aacmm_status_t st = AACMM_OK;
    int i;
    for (i = 0; i < n && st == AACMM_OK; i++) {
        m.arm.d_mm[i] = model->arm.d_mm[i] * f[i];
        m.arm.a_mm[i] = model->arm.a_mm[i] * f[i];
        if ((st = SFX(check_value)(m.arm.d_mm[i], len_max)) == AACMM_OK) {
            st = SFX(check_value)(m.arm.a_mm[i], len_max);
        }
    }
    for (i = 0; i < 3 && st == AACMM_OK; i++) {
        m.arm.tip_mm[i] = model->arm.tip_mm[i] * f[n - 1];
        st = SFX(check_value)(m.arm.tip_mm[i], len_max);
    }
    if (st == AACMM_OK) {
        *out = m;
    }
    return st;
}

/* The checks of every pose: the em's shape (joint count, K, cte_columns;
 * its values are checked by aacmm_errmodel_validate_*, once, and at each pose
 * by em_correct's guard on the correction and em_scale's on the lengths),
 * the readings, the temperatures (if any). */
static aacmm_status_t SFX(em_check)(const TYPE(aacmm_model) *model,
                                    const TYPE(aacmm_errmodel) *em, const REAL *theta_rad,
                                    const REAL *temp_c)
{
    const int n = (int)model->arm.shape.joints;
    aacmm_status_t st = EM(em_shape_ok)(em, n);
    if (st != AACMM_OK) {
        return st;
    }
    st = SFX(check_angles)(theta_rad, n);
    if (st == AACMM_OK && temp_c != NULL) {
        int i;
        st = SFX(check_temps)(temp_c, n);
        for (i = 0; i < n && st == AACMM_OK; i++) {
            st = SFX(check_value)(em->cte_per_k[i], (REAL)AACMM_CTE_MAX_PER_K);
            if (st == AACMM_OK) {
                st = SFX(check_temp)(em->tref_c[i]);
            }
        }
    }
    return st;
}

aacmm_status_t SFX(aacmm_errmodel_angles)(const TYPE(aacmm_errmodel) *em, const REAL *theta_rad,
                                          REAL *q_out)
{
    aacmm_status_t st;
    if (em == NULL || theta_rad == NULL || q_out == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(aacmm_errmodel_validate)(em);
    if (st == AACMM_OK) {
        st = SFX(check_angles)(theta_rad, (int)em->joints);
    }
    if (st == AACMM_OK) {
        st = EM(em_correct)(em, (int)em->joints, theta_rad, q_out, NULL);
    }
    return st;
}

aacmm_status_t SFX(aacmm_model_at_temperature)(TYPE(aacmm_model) *out,
                                               const TYPE(aacmm_model) *model,
                                               const TYPE(aacmm_errmodel) *em, const REAL *temp_c)
{
    REAL dt[AACMM_JOINTS_MAX], f[AACMM_JOINTS_MAX];
    aacmm_status_t st;
    int n;
    if (out == NULL || model == NULL || em == NULL) {
        return AACMM_ERR_NULL;
    }
    n = (int)model->arm.shape.joints;
    st = SFX(aacmm_errmodel_validate)(em);
    if (st == AACMM_OK && (int)em->joints != n) {
        st = AACMM_ERR_RANGE;
    }
    if (st != AACMM_OK) {
        return st;
    }
    if (temp_c == NULL) {
        if (out != model) {
            *out = *model;
        }
        return AACMM_OK;
    }
    st = SFX(check_temps)(temp_c, n);
    if (st != AACMM_OK) {
        return st;
    }
    EM(em_factors)(em, n, temp_c, dt, f);
    return SFX(em_scale)(out, model, n, f);
}

/*
 * One checked pose with the error model: point and, if jac is not NULL, the
 * extended Jacobian of row width w = P + E. The chain writes its 3 x P at
 * row width P; the rows are then moved apart (last first: each destination
 * lies at or after its source) and the error model's columns filled in.
 */
static aacmm_status_t SFX(em_pose)(const TYPE(aacmm_model) *model,
                                   const TYPE(aacmm_errmodel) *em, const REAL *theta_rad,
                                   const REAL *temp_c, REAL p_mm[3], REAL *jac)
{
    const int n = (int)model->arm.shape.joints;
    REAL q[AACMM_JOINTS_MAX];
    REAL dt[AACMM_JOINTS_MAX], f[AACMM_JOINTS_MAX];
    EM(em_trig_t) trig;
    TYPE(aacmm_model) scaled;
    const TYPE(aacmm_model) *m = model;
    if (temp_c != NULL) {
        aacmm_status_t st;
        EM(em_factors)(em, n, temp_c, dt, f);
        st = SFX(em_scale)(&scaled, model, n, f);
        if (st != AACMM_OK) {
            return st;
        }
        m = &scaled;
    }
    {
        const aacmm_status_t st = EM(em_correct)(em, n, theta_rad, q, jac != NULL ? &trig : NULL);
        if (st != AACMM_OK) {
            return st;
        }
    }
    if (jac == NULL) {
        SFX(chain)(m, q, p_mm, NULL);
        return AACMM_OK;
    }
    SFX(chain)(m, q, p_mm, jac);
    EM(em_extend)(model, em, &trig, temp_c != NULL ? dt : NULL, f, jac);
    return AACMM_OK;
}

aacmm_status_t SFX(aacmm_point_em)(const TYPE(aacmm_model) *model, const TYPE(aacmm_errmodel) *em,
                                   const REAL *theta_rad, const REAL *temp_c, REAL p_mm[3])
{
    aacmm_status_t st;
    if (em == NULL) {
        return SFX(aacmm_point)(model, theta_rad, p_mm);
    }
    if (model == NULL || theta_rad == NULL || p_mm == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(em_check)(model, em, theta_rad, temp_c);
    if (st != AACMM_OK) {
        return st;
    }
    return SFX(em_pose)(model, em, theta_rad, temp_c, p_mm, NULL);
}

aacmm_status_t SFX(aacmm_point_jacobian_em)(const TYPE(aacmm_model) *model,
                                            const TYPE(aacmm_errmodel) *em, const REAL *theta_rad,
                                            const REAL *temp_c, REAL p_mm[3], REAL *jac)
{
    aacmm_status_t st;
    if (em == NULL) {
        return SFX(aacmm_point_jacobian)(model, theta_rad, p_mm, jac);
    }
    if (model == NULL || theta_rad == NULL || p_mm == NULL || jac == NULL) {
        return AACMM_ERR_NULL;
    }
    st = SFX(em_check)(model, em, theta_rad, temp_c);
    if (st != AACMM_OK) {
        return st;
    }
    return SFX(em_pose)(model, em, theta_rad, temp_c, p_mm, jac);
}

aacmm_status_t SFX(aacmm_batch_angles_em)(const TYPE(aacmm_model) *model,
                                          const TYPE(aacmm_errmodel) *em, size_t n,
                                          const REAL *theta_rad, const REAL *temp_c, REAL *p_mm,
                                          REAL *jac, size_t *done)
{
    size_t k, nj, jn;
    int e;
    if (em == NULL) {
        return SFX(aacmm_batch_angles)(model, n, theta_rad, p_mm, jac, done);
    }
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    {
        const aacmm_status_t st = SFX(aacmm_errmodel_validate)(em);
        if (st != AACMM_OK) {
            return st;
        }
    }
    e = SFX(aacmm_errmodel_cols)(em);
    nj = model->arm.shape.joints;
    jn = (size_t)AACMM_JAC_ROWS * ((size_t)model->n_params + (size_t)e);
    for (k = 0; k < n; k++) {
        const REAL *th = theta_rad + k * nj;
        const REAL *tc = temp_c != NULL ? temp_c + k * nj : NULL;
        aacmm_status_t st = SFX(em_check)(model, em, th, tc);
        if (st == AACMM_OK) {
            st = SFX(em_pose)(model, em, th, tc, p_mm + k * 3u, jac != NULL ? jac + k * jn : NULL);
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

#undef EM
#undef EM_PUB
#undef EM_SINCOS
