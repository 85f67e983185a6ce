/*
 * The batch kernel across SIMD lanes, written once for every vector width and
 * both precisions (GNU C vector extensions: the compiler emits SSE2, AVX2,
 * AVX-512 or NEON code from this one source, as the including file's target
 * allows).
 *
 * Included by simd_f64.c and simd_f32.c once per instruction set, after they
 * define:
 *   REAL, LIT(x), TYPE(name)   as for kinematics_impl.h
 *   VR      a vector of W REAL (vector_size(W * sizeof(REAL)))
 *   VU      a vector of W unsigned integers as wide as REAL
 *   W       the number of lanes
 *   SIGN_BIT  the sign bit of REAL as a VU lane value
 *   VK(name)  name suffixed with the instruction set and the precision
 * and the sine/cosine constants (sincos_f64.h / sincos_f32.h).
 *
 * Each lane holds one pose; the arithmetic of a lane is the per-pose core's
 * (kinematics_impl.h: the same reduction, polynomials, chain and cross
 * products in the same order), so a lane differs from the scalar result only
 * where the compiler fuses a multiply and an add (FMA) differently.
 */

static inline VR VK(splat)(REAL s)
{
    VR v = {LIT(0.0)};
    return v + s;
}

/*
 * Sine and cosine of every lane: the per-pose sincos_inline with the table
 * lookups replaced by selects. k = round(x 2/pi) is read from the low bits of
 * x 2/pi + 1.5 2^(p-1) (the rounding constant puts the integer there), so no
 * float-to-integer conversion is needed; the quadrant's swap and sign flips
 * are bit operations (a sign flip by XOR equals the core's multiplication by
 * -1 exactly).
 */
static inline void VK(sincos)(VR x, VR *s, VR *c)
{
    const VR kr = x * TWO_OVER_PI + ROUND_MAGIC;
    const VU q = (VU)kr;
    const VR kf = kr - ROUND_MAGIC;
    const VR r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    const VR z = r * r;
    const VR sr = r + r * z * SIN_POLY(z);
    const VR cr = LIT(1.0) - (LIT(0.5) * z - z * z * COS_POLY(z));
    const VU one = q - q + 1u;
    const VU swap = (q - q) - (q & one); /* all ones in odd quadrants */
    VU si = ((VU)sr & ~swap) | ((VU)cr & swap);
    VU ci = ((VU)cr & ~swap) | ((VU)sr & swap);
    si ^= ((q >> 1) & one) * SIGN_BIT;
    ci ^= (((q + one) >> 1) & one) * SIGN_BIT;
    *s = (VR)si;
    *c = (VR)ci;
}

/* One pass down the chain for W poses: the per-pose chain, lane by lane. */
#define CH_T VR
#define CH(name) VK(name)
#define CH_SPLAT(x) VK(splat)(x)
#define CH_SINCOS(x, s, c) VK(sincos)(x, s, c)
#include "../chain_impl.h"
#undef CH_T
#undef CH
#undef CH_SPLAT
#undef CH_SINCOS

/* AACMM_OK if every angle of the pose is finite and within the limit, else
 * the reason (the per-pose core's check_angles). */
static inline aacmm_status_t VK(check_pose)(const REAL *th)
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    int i;
    for (i = 0; i < AACMM_JOINTS; i++) {
        const REAL x = th[i];
        if (!(x <= lim && x >= -lim)) {
            return isnan(x) || isinf(x) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

/* Number of leading valid poses among th[0 .. m-1] (m if all are), and the
 * status of the first invalid one in *st. */
static inline size_t VK(valid_prefix)(const REAL *th, size_t m, aacmm_status_t *st)
{
    size_t l;
    for (l = 0; l < m; l++) {
        *st = VK(check_pose)(th + l * AACMM_JOINTS);
        if (*st != AACMM_OK) {
            return l;
        }
    }
    *st = AACMM_OK;
    return m;
}

/* The joint angles of W poses th[0 .. W*6-1] as six lane vectors, each built
 * in registers from W scalar loads (a vector initialiser: writing the lanes
 * into memory and reading the vector back would stall on store forwarding). */
static inline void VK(load)(const REAL *th, VR out[AACMM_JOINTS])
{
    int i;
    for (i = 0; i < AACMM_JOINTS; i++) {
        out[i] = (VR)LANES_INIT(th + i, AACMM_JOINTS);
    }
}

/* The same for m <= W poses: lanes past m repeat the last pose, so they
 * compute something harmless. */
static inline void VK(load_part)(const REAL *th, size_t m, VR out[AACMM_JOINTS])
{
    REAL buf[W * AACMM_JOINTS];
    size_t l;
    for (l = 0; l < (size_t)W; l++) {
        memcpy(buf + l * AACMM_JOINTS, th + (l < m ? l : m - 1u) * AACMM_JOINTS,
               AACMM_JOINTS * sizeof(REAL));
    }
    VK(load)(buf, out);
}

#ifdef ZIPLO
/* Transposes the W x W matrix whose rows are v[0 .. W-1], in place:
 * log2(W) rounds of interleaving v[i] with v[i + W/2] (a perfect shuffle),
 * which the compiler maps to the instruction set's unpack/permute
 * instructions. */
static inline void VK(transpose)(VR v[W])
{
    VR t[W];
    int s, i;
    for (s = 1; s < W; s *= 2) {
        for (i = 0; i < W / 2; i++) {
            t[2 * i] = ZIPLO(v[i], v[i + W / 2]);
            t[2 * i + 1] = ZIPHI(v[i], v[i + W / 2]);
        }
        for (i = 0; i < W; i++) {
            v[i] = t[i];
        }
    }
}
#endif

/* Jacobian entries J[e] (one vector per entry, a lane per pose) to m <= W
 * poses' row-major Jacobians. Blocks of W entries are transposed in
 * registers, so each pose gets W consecutive entries in one vector store, and
 * the stores go pose after pose (one sequential write stream: measured
 * faster than W interleaved ones). The blocks are transposed in J itself
 * (each copy of 75 vectors costs a store and a load per vector). The last 75
 * mod W entries form one more
 * block, padded: its vector store runs W - 75 mod W entries into the next
 * pose's slot, which that pose's first block overwrites right after; the
 * group's last pose, whose successor may not be written, stores them lane by
 * lane instead. */
static inline void VK(store_jacobians)(VR J[AACMM_JAC_SIZE], size_t m, REAL *jac)
{
    size_t l;
    int e;
#ifdef ZIPLO
    enum { BLOCKS = AACMM_JAC_SIZE / W, REST = AACMM_JAC_SIZE % W };
    VR tail[W];
    int b, i;
    for (b = 0; b < BLOCKS; b++) {
        VK(transpose)(J + b * W); /* in place: no copy of the block */
    }
    if (REST > 0) {
        for (i = 0; i < W; i++) {
            tail[i] = (i < REST) ? J[BLOCKS * W + i] : J[0];
        }
        VK(transpose)(tail);
    }
    for (l = 0; l < m; l++) {
        REAL *dst = jac + l * AACMM_JAC_SIZE;
        for (b = 0; b < BLOCKS; b++) {
            memcpy(dst + b * W, &J[b * W + (int)l], sizeof J[0]);
        }
        if (REST > 0 && l + 1u < m) {
            memcpy(dst + BLOCKS * W, &tail[l], sizeof tail[l]);
        } else {
            for (e = 0; e < REST; e++) {
                dst[BLOCKS * W + e] = tail[l][e];
            }
        }
    }
#else
    for (l = 0; l < m; l++) {
        for (e = 0; e < AACMM_JAC_SIZE; e++) {
            jac[l * AACMM_JAC_SIZE + (size_t)e] = J[e][l];
        }
    }
#endif
}

/* 1 if every lane of the six angle vectors is finite and within the limit:
 * a vector test, so a whole group of valid poses skips the pose-by-pose
 * check (NaN fails the comparisons). */
static inline int VK(in_range)(const VR t[AACMM_JOINTS])
{
    const VR lim = VK(splat)((REAL)AACMM_JOINT_ANGLE_MAX_RAD);
    VU ok = (VU)(t[0] <= lim) & (VU)(t[0] >= -lim);
    UREAL all = ~(UREAL)0;
    int i, l;
    for (i = 1; i < AACMM_JOINTS; i++) {
        ok &= (VU)(t[i] <= lim) & (VU)(t[i] >= -lim);
    }
    for (l = 0; l < W; l++) {
        all &= ok[l];
    }
    return all == ~(UREAL)0;
}

/* The angles of the first valid poses among th[0 .. want-1] (want <= W) as
 * lane vectors in t; returns how many (all of them unless one is invalid,
 * whose status goes to *st; else *st = AACMM_OK). */
static inline size_t VK(load_valid)(const REAL *th, size_t want, VR t[AACMM_JOINTS],
                                    aacmm_status_t *st)
{
    size_t m;
    if (want == (size_t)W) {
        VK(load)(th, t);
        if (VK(in_range)(t)) {
            *st = AACMM_OK;
            return want;
        }
    }
    m = VK(valid_prefix)(th, want, st);
    if (m > 0u) {
        VK(load_part)(th, m, t);
    }
    return m;
}

/* Points (and Jacobians) of m <= W valid poses (angles in t) into their slots. */
static inline void VK(group)(const TYPE(aacmm_model) *model, const VR t[AACMM_JOINTS], size_t m,
                             REAL *p_mm, REAL *jac)
{
    VR P[3];
    size_t l;
    if (jac == NULL) {
        VK(chain)(model, t, P, NULL);
    } else {
        VR J[AACMM_JAC_SIZE];
        VK(chain)(model, t, P, J);
        VK(store_jacobians)(J, m, jac);
    }
    for (l = 0; l < m; l++) {
        p_mm[l * 3u + 0u] = P[0][l];
        p_mm[l * 3u + 1u] = P[1][l];
        p_mm[l * 3u + 2u] = P[2][l];
    }
}

/* aacmm_simd_batch_angles_* for this instruction set (arguments checked by
 * the caller). */
static aacmm_status_t VK(batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    size_t k = 0;
    while (k < n) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        VR t[AACMM_JOINTS];
        aacmm_status_t st;
        const size_t m = VK(load_valid)(th, want, t, &st);
        if (m > 0u) {
            VK(group)(model, t, m, p_mm + k * 3u, jac == NULL ? NULL : jac + k * AACMM_JAC_SIZE);
            k += m;
            if (done != NULL) {
                *done = k;
            }
        }
        if (st != AACMM_OK) {
            return st;
        }
    }
    return AACMM_OK;
}

#ifdef SIMD_ABS_SUMS
/* aacmm_simd_abs_jacobian_sums_scaled_f64 for this instruction set
 * (arguments checked by the caller; scale and offset NULL: no scaling):
 * per-lane sums of |J| and J^2 over the poses, added up lane by lane at the
 * end; lanes past the last pose of a group are masked out. Scaled poses are
 * formed a group at a time in a small buffer (x * scale rounded, then
 * + offset, as the scalar kernel does). */
static aacmm_status_t VK(abs_sums)(const TYPE(aacmm_model) *model, size_t n,
                                   const REAL *theta_rad, const REAL *scale, const REAL *offset,
                                   REAL abs_sum[AACMM_JAC_SIZE], REAL sq_sum[AACMM_JAC_SIZE],
                                   size_t *done)
{
    VR sa[AACMM_JAC_SIZE], sq[AACMM_JAC_SIZE];
    const VR zero = VK(splat)(LIT(0.0));
    const VU no_sign = ~((VU)zero | SIGN_BIT);
    REAL buf[W * AACMM_JOINTS];
    aacmm_status_t st = AACMM_OK;
    size_t k = 0, l;
    int e;
    for (e = 0; e < AACMM_JAC_SIZE; e++) {
        sa[e] = zero;
        sq[e] = zero;
    }
    while (k < n) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        VR t[AACMM_JOINTS];
        size_t m;
        if (scale != NULL && offset != NULL) {
            size_t j;
            for (j = 0; j < want * AACMM_JOINTS; j++) {
                buf[j] = th[j] * scale[j % AACMM_JOINTS];
                buf[j] += offset[j % AACMM_JOINTS];
            }
            th = buf;
        }
        m = VK(load_valid)(th, want, t, &st);
        if (m > 0u) {
            VR J[AACMM_JAC_SIZE], P[3];
            VU keep = no_sign;
            VK(chain)(model, t, P, J);
            for (l = m; l < (size_t)W; l++) {
                keep[l] = 0u;
            }
            for (e = 0; e < AACMM_JAC_SIZE; e++) {
                const VR a = (VR)((VU)J[e] & keep);
                sa[e] += a;
                sq[e] += a * a;
            }
            k += m;
        }
        if (st != AACMM_OK) {
            break;
        }
    }
    for (e = 0; e < AACMM_JAC_SIZE; e++) {
        REAL s = LIT(0.0), q = LIT(0.0);
        for (l = 0; l < (size_t)W; l++) {
            s += sa[e][l];
            q += sq[e][l];
        }
        abs_sum[e] += s;
        sq_sum[e] += q;
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}
#endif /* SIMD_ABS_SUMS */
