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
 *   VK(fma)   a * b + c on VR, fused (one rounding) in the kernels with FMA,
 *             else the product rounded, then the sum (simd_isa.h)
 * and the sine/cosine constants (sincos_f64.h / sincos_f32.h).
 *
 * Each lane holds one pose; the arithmetic of a lane is the per-pose core's
 * (sincos_eval.h and chain_impl.h: the same reduction, polynomials, chain
 * and cross products in the same order), with a * b + c fused where the
 * kernel has FMA: a kernel without FMA gives the per-pose core's results bit
 * for bit, and every kernel with FMA gives the same results as every other
 * one with FMA.
 */

static inline VR VK(splat)(REAL s)
{
    const VR zero = {LIT(0.0)};
    return s - zero; /* folds to a broadcast (x - 0 is x, -0 included) */
}

/* F(a, b, c) of sincos_eval.h and chain_impl.h on lanes: each argument a
 * vector, or a scalar broadcast to all lanes. */
#define V_IS_VR(x) __builtin_types_compatible_p(__typeof__(x), VR)
#define V_AS_VR(x)                                                                                 \
    __builtin_choose_expr(V_IS_VR(x), (x),                                                         \
                          VK(splat)(__builtin_choose_expr(V_IS_VR(x), LIT(0.0), (x))))
#define VF(a, b, c) VK(fma)(V_AS_VR(a), V_AS_VR(b), V_AS_VR(c))

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
    SINCOS_EVAL(VR, VF, x, kr, sr, cr);
    /* bit 1 of q (sine) and of q + 1 (cosine) shifted to the sign bit; the
     * masks and the XOR fold into one three-input logic instruction */
    enum { TO_SIGN = (int)sizeof(UREAL) * 8 - 2 };
    const VU q = (VU)kr;
    const VU one = q - q + 1u;
    const VU swap = (q - q) - (q & one); /* all ones in odd quadrants */
    const VU si = ((VU)sr & ~swap) | ((VU)cr & swap);
    const VU ci = ((VU)cr & ~swap) | ((VU)sr & swap);
    *s = (VR)(si ^ ((q << TO_SIGN) & SIGN_BIT));
    *c = (VR)(ci ^ (((q + one) << TO_SIGN) & SIGN_BIT));
}

/*
 * Jacobians: 75 entry vectors (a lane per pose) to the poses' rows of 75
 * values (pose l's entry e to jac[l * 75 + e]).
 *
 * Blocks of SEG consecutive entries are regrouped in registers by log2(SEG)
 * rounds of interleaving (a perfect shuffle of the block's SEG vectors:
 * t[2i], t[2i+1] = the two halves of zip(v[i], v[i + SEG/2])), which leaves
 * vector k of the block holding poses k W/SEG .. (k + 1) W/SEG - 1, SEG
 * entries each in order: SEG = W would be a full transpose; the 16-byte
 * segments used (simd_isa.h: SEG = 2 doubles or 4 floats) spend one or two
 * rounds of shuffles (on the port that also does half the arithmetic)
 * instead of three or four, for more, narrower stores: measured faster, with
 * AVX2 and AVX-512, in both precisions. The blocks are regrouped in place;
 * the last 75 mod SEG entries form one more block, padded, after them (J
 * holds JAC_VECS vectors).
 *
 * A group's rows are written during the NEXT group's pass down the chain
 * (CH_STEP, a few poses after each joint), pose after pose, each row in
 * order: the stores drain while the arithmetic runs instead of stalling it
 * in one burst, and they form one sequential write stream (measured: stores
 * to W interleaved streams cost up to twice as much). A pose's padded last
 * segment runs into the next pose's first entries, which that pose's first
 * segment overwrites right after; the last pose of a group stores its rest
 * entry by entry (nothing past the output is written).
 */
#if SIMD_SEGMENTS
#define JAC_WHOLE (AACMM_JAC_SIZE / SEG)
#define JAC_REST (AACMM_JAC_SIZE % SEG)
#define JAC_VECS ((JAC_WHOLE + (JAC_REST > 0)) * SEG)

static inline void VK(regroup)(VR *v)
{
    VR t[SEG];
    int s, i;
    for (s = 1; s < SEG; s *= 2) {
        for (i = 0; i < SEG / 2; i++) {
            t[2 * i] = ZIPLO(v[i], v[i + SEG / 2]);
            t[2 * i + 1] = ZIPHI(v[i], v[i + SEG / 2]);
        }
        for (i = 0; i < SEG; i++) {
            v[i] = t[i];
        }
    }
}

static inline void VK(regroup_jacobians)(VR J[JAC_VECS])
{
    int b, t;
    for (t = JAC_REST; t < SEG && JAC_REST > 0; t++) {
        J[JAC_WHOLE * SEG + t] = J[0]; /* padding (finite values) */
    }
    for (b = 0; b < JAC_VECS / SEG; b++) {
        VK(regroup)(J + b * SEG);
    }
}

/* Row l of the m poses of a regrouped group to row. */
static inline void VK(store_jacobian)(const VR J[JAC_VECS], size_t l, size_t m, REAL *row)
{
    enum { PER = W / SEG, BYTES = SEG * (int)sizeof(REAL) };
    const size_t k = l / PER, at = (l % PER) * (size_t)BYTES;
    int b, t;
    for (b = 0; b < JAC_WHOLE; b++) {
        memcpy(row + b * SEG, (const char *)&J[(size_t)b * SEG + k] + at, (size_t)BYTES);
    }
    if (JAC_REST > 0 && l + 1u < m) {
        memcpy(row + JAC_WHOLE * SEG, (const char *)&J[JAC_WHOLE * SEG + k] + at, (size_t)BYTES);
    } else {
        for (t = 0; t < JAC_REST; t++) {
            row[JAC_WHOLE * SEG + t] = J[JAC_WHOLE * SEG + k][(l % PER) * SEG + (size_t)t];
        }
    }
}
#else
#define JAC_VECS AACMM_JAC_SIZE
static inline void VK(regroup_jacobians)(VR J[JAC_VECS])
{
    (void)J;
}

static inline void VK(store_jacobian)(const VR J[JAC_VECS], size_t l, size_t m, REAL *row)
{
    int e;
    (void)m;
    for (e = 0; e < AACMM_JAC_SIZE; e++) {
        row[e] = J[e][l];
    }
}
#endif

/* A regrouped group whose rows are still to be written: m poses to dst; next
 * is the first pose not written yet. */
typedef struct {
    const VR *J;
    size_t m, next;
    REAL *dst;
} VK(pending);

/* Writes the pending rows up to (not including) pose end. */
static inline void VK(write_pending)(VK(pending) *pend, size_t end)
{
    size_t l;
    if (end > pend->m) {
        end = pend->m;
    }
    for (l = pend->next; l < end; l++) {
        VK(store_jacobian)(pend->J, l, pend->m, pend->dst + l * AACMM_JAC_SIZE);
    }
    if (end > pend->next) {
        pend->next = end;
    }
}

/* The fused Monte Carlo sums: per entry and lane, the sums of |J| and J^2;
 * keep clears the sign bit, and whole lanes past the group's last pose. */
typedef struct {
    VR *sa, *sq;
    VU keep;
} VK(sums);

/* Jacobian entry e = v: stored in jac, or (acc not NULL) added to the sums
 * instead (no store and reload of the entries). */
static inline void VK(out)(VR *jac, VK(sums) *acc, int e, VR v)
{
    if (acc != NULL) {
        const VR a = (VR)((VU)v & acc->keep);
        acc->sa[e] += a;
        acc->sq[e] = VF(a, a, acc->sq[e]);
    } else {
        jac[e] = v;
    }
}

/* Tiled layout helpers (aacmm_simd_batch_angles_tiled_*): an entry's W lanes
 * to and from the tile (unaligned: the caller's buffer need not be), and the
 * part of a tile's lines for joint i of the pass (NULL: none). */
static inline void VK(store_entry)(REAL *dst, VR v)
{
    memcpy(dst, &v, sizeof v);
}

static inline VR VK(load_entry)(const REAL *src)
{
    VR v;
    memcpy(&v, src, sizeof v);
    return v;
}

enum { VK(tile_lines) = (AACMM_JAC_SIZE * (int)TILE * (int)sizeof(REAL) + 63) / 64 };

static inline void VK(prefetch_part)(const char *ahead, int i)
{
    enum { PART = (VK(tile_lines) + AACMM_JOINTS - 1) / AACMM_JOINTS };
    int b;
    if (ahead == NULL) {
        return;
    }
    for (b = i * PART; b < (i + 1) * PART && b < VK(tile_lines); b++) {
        __builtin_prefetch(ahead + (size_t)b * 64u, 1, 3);
    }
}

/* One pass down the chain for W poses: the per-pose chain, lane by lane. */
#define CH_T VR
#define CH(name) VK(name)
#define CH_SPLAT(x) VK(splat)(x)
#define CH_SINCOS(x, s, c) VK(sincos)(x, s, c)
#define CH_FMA(a, b, c) VF(a, b, c)
#define CH_DIRECT_DA SIMD_DIRECT_DA
#define CH_STEP_PARAM , VK(pending) *pend, VK(sums) *acc
#define CH_STEP(i) /* the pending rows, spread over the six joints */                             \
    if (pend != NULL) {                                                                            \
        VK(write_pending)(pend, ((size_t)(i) + 1u) * (size_t)W / AACMM_JOINTS);                    \
    }
#define CH_OUT(e, v) VK(out)(jac, acc, e, v)
#define CH_INLINE static inline __attribute__((always_inline))
#include "../chain_impl.h"
/* The chain again, fused throughout, for the Monte Carlo sums (no points
 * out: chain_impl.h's CH_FUSE_CHAIN): VK(chain_sums). */
#undef CH
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#define CH(name) VK(name##_sums)
#define CH_FUSE_CHAIN 1
#define CH_DIRECT_DA 0 /* CH_OUT adds to the sums: nothing to read back */
#include "../chain_impl.h"
/* The chain again for the tiled layout (VK(chain_tiled)): entry e of the
 * group's poses is one vector store to tile[e * TILE] (tile: the group's first
 * lane in its tile), the d and a columns during the pass (CH_DIRECT_DA), the
 * rest at the end. When the output is not 64-byte aligned, every store spans
 * two lines, and CH_STEP prefetches for writing a sixth of the tile that a
 * group two tiles on will fill, so its lines are in L1 when the stores come
 * (measured, docs/kinematics.md: AVX-512 double 24 ns per pose with, 32
 * without; on an aligned output the prefetch cost 0.8 ns and is not done). */
#undef CH
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#undef CH_STEP_PARAM
#undef CH_STEP
#undef CH_OUT
#define CH(name) VK(name##_tiled)
#define CH_FUSE_CHAIN 0
#define CH_DIRECT_DA 1
#define CH_JSTORE(e, v) VK(store_entry)(tile + (size_t)(e) * (size_t)TILE, v)
#define CH_JLOAD(e) VK(load_entry)(tile + (size_t)(e) * (size_t)TILE)
#define CH_OUT(e, v) CH_JSTORE(e, v)
#define CH_STEP_PARAM , REAL *tile, const char *ahead
#define CH_STEP(i) VK(prefetch_part)(ahead, i)
#include "../chain_impl.h"
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#undef CH_T
#undef CH
#undef CH_SPLAT
#undef CH_SINCOS
#undef CH_FMA
#undef CH_STEP_PARAM
#undef CH_STEP
#undef CH_OUT
#undef CH_INLINE

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

/* The joint angles of W poses th[0 .. W*6-1] as six lane vectors: a gather
 * each in the AVX-512 kernel (the loads go to the load ports; not in AVX2,
 * see simd_f64.c), else built in registers from W scalar loads (a vector
 * initialiser: writing the lanes into memory and reading the vector back
 * would stall on store forwarding). */
static inline void VK(load)(const REAL *th, VR out[AACMM_JOINTS])
{
    int i;
#ifdef ISA_GATHER
    for (i = 0; i < AACMM_JOINTS; i++) {
        out[i] = (VR)ISA_GATHER(th + i);
    }
#else
    for (i = 0; i < AACMM_JOINTS; i++) {
        out[i] = (VR)LANES_INIT(th + i, AACMM_JOINTS);
    }
#endif
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

/* The points of m <= W poses (x, y, z vectors) to p_mm[l * 3 + r]: for a
 * full group, three vector stores of the lanes regrouped by two shuffles
 * each. */
static inline void VK(store_points)(const VR P[3], size_t m, REAL *p_mm)
{
    size_t l;
#if SIMD_SEGMENTS
    if (m == (size_t)W) {
        const VR o0 = XYZ(P[0], P[1], P[2], 0), o1 = XYZ(P[0], P[1], P[2], 1),
                 o2 = XYZ(P[0], P[1], P[2], 2);
        memcpy(p_mm, &o0, sizeof o0);
        memcpy(p_mm + W, &o1, sizeof o1);
        memcpy(p_mm + 2 * W, &o2, sizeof o2);
        return;
    }
#endif
    for (l = 0; l < m; l++) {
        p_mm[l * 3u + 0u] = P[0][l];
        p_mm[l * 3u + 1u] = P[1][l];
        p_mm[l * 3u + 2u] = P[2][l];
    }
}

/* aacmm_simd_batch_angles_* for this instruction set (arguments checked by
 * the caller). With Jacobians, two buffers alternate: the chain fills one
 * while the other's rows are written (pend). */
static aacmm_status_t VK(batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    VR J[2][JAC_VECS];
    VK(pending) pend = {NULL, 0u, 0u, NULL};
    aacmm_status_t st = AACMM_OK;
    size_t k = 0;
    int cur = 0;
    while (k < n) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        VR t[AACMM_JOINTS], P[3];
        const size_t m = VK(load_valid)(th, want, t, &st);
        if (m > 0u) {
            if (jac == NULL) {
                VK(chain)(model, t, P, NULL, NULL, NULL);
            } else {
                VK(chain)(model, t, P, J[cur], &pend, NULL);
                VK(write_pending)(&pend, pend.m);
                VK(regroup_jacobians)(J[cur]);
                pend.J = J[cur];
                pend.m = m;
                pend.next = 0u;
                pend.dst = jac + k * AACMM_JAC_SIZE;
                cur ^= 1;
            }
            VK(store_points)(P, m, p_mm + k * 3u);
            k += m;
        }
        if (st != AACMM_OK) {
            break;
        }
    }
    if (jac != NULL && pend.J != NULL) {
        VK(write_pending)(&pend, pend.m);
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

/* aacmm_simd_batch_angles_tiled_* for this instruction set (arguments
 * checked by the caller): a group of W poses is W consecutive lanes of one
 * tile (W divides TILE). Lanes past the last valid pose of a short group
 * repeat that pose (VK(load_part)); the caller's padding rule overwrites
 * those past the last pose. */
static aacmm_status_t VK(batch_tiled)(const TYPE(aacmm_model) *model, size_t n,
                                      const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    const size_t tiles = (n + (size_t)TILE - 1u) / (size_t)TILE;
    VR with_jac[1]; /* the chain's jac only says "Jacobians too": they go to the tile */
    const int misaligned = ((uintptr_t)jac & 63u) != 0u;
    aacmm_status_t st = AACMM_OK;
    size_t k = 0;
    while (k < n) {
        const REAL *th = theta_rad + k * AACMM_JOINTS;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        const size_t t = k / (size_t)TILE;
        VR ang[AACMM_JOINTS], P[3];
        const size_t m = VK(load_valid)(th, want, ang, &st);
        if (m > 0u) {
            REAL *tile = jac + t * (size_t)TILE * AACMM_JAC_SIZE + k % (size_t)TILE;
            const char *ahead = misaligned && t + 2u < tiles
                                     ? (const char *)(jac + (t + 2u) * (size_t)TILE * AACMM_JAC_SIZE)
                                     : NULL;
            VK(chain_tiled)(model, ang, P, with_jac, tile, ahead);
            VK(store_points)(P, m, p_mm + k * 3u);
            k += m;
        }
        if (st != AACMM_OK) {
            break;
        }
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
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
            VR P[3];
            VK(sums) acc;
            acc.sa = sa;
            acc.sq = sq;
            acc.keep = no_sign;
            for (l = m; l < (size_t)W; l++) {
                acc.keep[l] = 0u;
            }
            VK(chain_sums)(model, t, P, sa, NULL, &acc); /* jac unused: the entries go to acc */
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

#undef JAC_VECS
#undef JAC_WHOLE
#undef JAC_REST
#undef V_IS_VR
#undef V_AS_VR
#undef VF
