/*
 * The shape of an arm (aacmm_shape_t, aacmm/kinematics.h): joints,
 * conventions, betas, tip kind, and the parameter count and column layout
 * that follow from it. Integer only: shared by every precision and the
 * fixed-point path.
 */
#include "aacmm/kinematics.h"

aacmm_status_t aacmm_shape_paper(aacmm_shape_t *shape)
{
    int i;
    if (shape == NULL) {
        return AACMM_ERR_NULL;
    }
    shape->joints = AACMM_JOINTS;
    shape->tip = (uint8_t)AACMM_TIP_Z;
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        shape->convention[i] = (uint8_t)AACMM_DH_STANDARD;
        shape->beta[i] = 0u;
    }
    return AACMM_OK;
}

aacmm_status_t aacmm_shape_validate(const aacmm_shape_t *shape)
{
    int i, n;
    if (shape == NULL) {
        return AACMM_ERR_NULL;
    }
    n = (int)shape->joints;
    if (n < AACMM_JOINTS_MIN || n > AACMM_JOINTS_MAX) {
        return AACMM_ERR_RANGE;
    }
    if (shape->tip != (uint8_t)AACMM_TIP_Z && shape->tip != (uint8_t)AACMM_TIP_XYZ) {
        return AACMM_ERR_RANGE;
    }
    if (shape->beta[0] != 0u) {
        return AACMM_ERR_RANGE; /* joint 1 has no previous axis */
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (i < n) {
            if (shape->convention[i] != (uint8_t)AACMM_DH_STANDARD &&
                shape->convention[i] != (uint8_t)AACMM_DH_MODIFIED) {
                return AACMM_ERR_RANGE;
            }
            if (shape->beta[i] > 1u) {
                return AACMM_ERR_RANGE;
            }
        } else if (shape->convention[i] != 0u || shape->beta[i] != 0u) {
            return AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

/* Betas declared before joint i (a valid shape). */
static int betas_before(const aacmm_shape_t *shape, int joint)
{
    int i, b = 0;
    for (i = 0; i < joint; i++) {
        b += shape->beta[i];
    }
    return b;
}

int aacmm_shape_params(const aacmm_shape_t *shape)
{
    const aacmm_status_t st = aacmm_shape_validate(shape);
    if (st != AACMM_OK) {
        return (int)st;
    }
    return 4 * (int)shape->joints + betas_before(shape, (int)shape->joints) + (int)shape->tip;
}

int aacmm_shape_col_beta(const aacmm_shape_t *shape, int joint)
{
    if (aacmm_shape_validate(shape) != AACMM_OK || joint < 0 || joint >= (int)shape->joints ||
        shape->beta[joint] == 0u) {
        return -1;
    }
    return AACMM_ARM_COL_BETA((int)shape->joints, betas_before(shape, joint));
}

int aacmm_shape_col_tip(const aacmm_shape_t *shape)
{
    if (aacmm_shape_validate(shape) != AACMM_OK) {
        return -1;
    }
    return AACMM_ARM_COL_TIP((int)shape->joints, betas_before(shape, (int)shape->joints));
}

int aacmm_shape_is_paper(const aacmm_shape_t *shape)
{
    aacmm_shape_t paper;
    int i;
    if (shape == NULL) {
        return 0;
    }
    (void)aacmm_shape_paper(&paper);
    if (shape->joints != paper.joints || shape->tip != paper.tip) {
        return 0;
    }
    for (i = 0; i < AACMM_JOINTS_MAX; i++) {
        if (shape->convention[i] != paper.convention[i] || shape->beta[i] != paper.beta[i]) {
            return 0;
        }
    }
    return 1;
}
