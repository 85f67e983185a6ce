/*
 * The error model (aacmm/kinematics.h) through the batch kernels, for one
 * precision (aacmm/simd.h: aacmm_simd_batch_angles_em_*). Included by
 * simd_instances.h inside its no-contraction region, so the corrected
 * angles and the extended columns are those of the per-pose core
 * (errmodel_core.h, the same source) bit for bit with every kernel.
 *
 * Poses go in groups of SIMD_EM_GROUP: their corrected angles into a local
 * array, the group through the kernel into the caller's buffers (the
 * Jacobians at row width P, packed at the start of the group's space), then
 * each pose's Jacobian, last first, moved to its place at row width P + E
 * and extended.
 */
#define EM(name) PSFX(name##_simd)
#define EM_PUB(name) PSFX(name)
#define EM_SINCOS(x, s, c) PSFX(aacmm_sincos)(x, s, c)
#include "../errmodel_core.h"

#define SIMD_EM_GROUP 64u

/* A reading is finite and within AACMM_JOINT_ANGLE_MAX_RAD (aacmm_point_*). */
static aacmm_status_t PSFX(em_check_angles)(const REAL *theta_rad, int joints)
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    int i;
    for (i = 0; i < joints; i++) {
        const REAL x = theta_rad[i];
        if (!(x <= lim && x >= -lim)) {
            return (isnan(x) || isinf(x)) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

aacmm_status_t PSFX(aacmm_simd_batch_angles_em)(aacmm_kernel_t kernel,
                                                const TYPE(aacmm_model) *model,
                                                const TYPE(aacmm_errmodel) *em, size_t n,
                                                const REAL *theta_rad, const REAL *temp_c,
                                                REAL *p_mm, REAL *jac, size_t *done)
{
    REAL q[SIMD_EM_GROUP * AACMM_JOINTS_MAX];
    REAL dt[AACMM_JOINTS_MAX], f[AACMM_JOINTS_MAX];
    TYPE(aacmm_model) at_t;
    EM(em_trig_t) trig;
    size_t nj, jp, jw, base, k, d;
    aacmm_status_t st;
    int e;
    if (em == NULL && temp_c == NULL) {
        return PSFX(aacmm_simd_batch_angles)(kernel, model, n, theta_rad, p_mm, jac, done);
    }
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || em == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    if (!aacmm_kernel_available(kernel)) {
        return AACMM_ERR_UNSUPPORTED;
    }
    /* the error model and the batch's temperatures, once */
    st = PSFX(aacmm_model_at_temperature)(&at_t, model, em, temp_c);
    if (st != AACMM_OK) {
        return st;
    }
    nj = model->arm.shape.joints;
    if (temp_c != NULL) {
        EM(em_factors)(em, (int)nj, temp_c, dt, f);
    }
    e = PSFX(aacmm_errmodel_cols)(em);
    jp = (size_t)AACMM_JAC_ROWS * model->n_params;
    jw = (size_t)AACMM_JAC_ROWS * ((size_t)model->n_params + (size_t)e);
    for (base = 0; base < n; base += SIMD_EM_GROUP) {
        const size_t g = (n - base < SIMD_EM_GROUP) ? n - base : SIMD_EM_GROUP;
        const REAL *th = theta_rad + base * nj;
        REAL *jg = (jac != NULL) ? jac + base * jw : NULL;
        /* the readings checked (as the kernel would), then corrected; a bad
         * pose ends the group (and the batch) after the poses before it */
        size_t ok = g;
        aacmm_status_t bad = AACMM_OK;
        for (k = 0; k < g; k++) {
            bad = PSFX(em_check_angles)(th + k * nj, (int)nj);
            if (bad != AACMM_OK) {
                ok = k;
                break;
            }
            (void)EM(em_correct)(em, (int)nj, th + k * nj, q + k * nj, NULL); /* valid em */
        }
        if (ok > 0u) {
            st = PSFX(aacmm_simd_batch_angles)(kernel, &at_t, ok, q, p_mm + base * 3u, jg, &d);
            if (st != AACMM_OK) {
                return st; /* not reached: the corrected angles are valid */
            }
        }
        if (jg != NULL) {
            for (k = ok; k-- > 0u;) {
                REAL *jk = jg + k * jw;
                if (jw != jp) {
                    memmove(jk, jg + k * jp, jp * sizeof(REAL));
                }
                (void)EM(em_correct)(em, (int)nj, th + k * nj, q, &trig);
                EM(em_extend)(model, em, &trig, temp_c != NULL ? dt : NULL, f, jk);
            }
        }
        if (done != NULL) {
            *done = base + ok;
        }
        if (bad != AACMM_OK) {
            return bad;
        }
    }
    return AACMM_OK;
}

#undef SIMD_EM_GROUP
#undef EM
#undef EM_PUB
#undef EM_SINCOS
