/*
 * The shape-dependent half of the batch kernels (simd_impl.h): the chain
 * instances, the loads of the joint angles, the stores of the Jacobians and
 * the three batch loops, written once for both kinds of model:
 *
 *   SH_GENERAL 0  the paper's shape (6 joints, 25 parameters) as
 *                 compile-time constants: the kernels of the core before the
 *                 general model, operation for operation;
 *   SH_GENERAL 1  any shape (aacmm/kinematics.h), the joint count N and the
 *                 Jacobian's 3 P entries read from the model.
 *
 * Included by simd_impl.h twice per instruction set, after it defines
 * SH_GENERAL and SH(name) (name suffixed with the instruction set, the
 * precision and the shape); everything simd_impl.h lists is in scope. The
 * functions below take the joint count nj and the Jacobian size jn as
 * arguments in both instances; the paper's instance ignores them and uses
 * its constants (SH_NJV, SH_JNV), so it is compiled with them whether or not
 * a call is inlined.
 */
#if SH_GENERAL
#define SH_NJV nj
#define SH_JNV jn
#define SH_NJ_CAP AACMM_JOINTS_MAX
#define SH_JN_CAP AACMM_JAC_SIZE_MAX
#define SH_NJ(m) ((size_t)(m)->arm.shape.joints)
#define SH_JN(m) ((size_t)AACMM_JAC_ROWS * (size_t)(m)->n_params)
#else
#define SH_NJV ((size_t)AACMM_JOINTS)
#define SH_JNV ((size_t)AACMM_JAC_SIZE)
#define SH_NJ_CAP AACMM_JOINTS
#define SH_JN_CAP AACMM_JAC_SIZE
#define SH_NJ(m) ((size_t)AACMM_JOINTS)
#define SH_JN(m) ((size_t)AACMM_JAC_SIZE)
#endif

/*
 * Jacobians: jn entry vectors (a lane per pose) to the poses' rows of jn
 * values (pose l's entry e to jac[l * jn + e]; jn = 3 P, 75 for the paper's
 * arm).
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
 * the last jn mod SEG entries form one more block, padded, after them (J
 * holds SH_JAC_VECS(jn) vectors, at most SH_JAC_VECS_CAP).
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
#define SH_JAC_WHOLE(jn) ((jn) / SEG)
#define SH_JAC_REST(jn) ((jn) % SEG)
#define SH_JAC_VECS(jn) ((SH_JAC_WHOLE(jn) + (SH_JAC_REST(jn) > 0)) * SEG)
#define SH_JAC_VECS_CAP ((SH_JN_CAP / SEG + 1) * SEG)

static inline void SH(regroup_jacobians)(VR *J, size_t jn)
{
    const size_t whole = SH_JAC_WHOLE(SH_JNV), rest = SH_JAC_REST(SH_JNV);
    const size_t vecs = SH_JAC_VECS(SH_JNV);
    size_t b, t;
    (void)jn;
    for (t = rest; t < SEG && rest > 0u; t++) {
        J[whole * SEG + t] = J[0]; /* padding (finite values) */
    }
    for (b = 0; b < vecs / SEG; b++) {
        VK(regroup)(J + b * SEG);
    }
}

/* Row l of the m poses of a regrouped group to row. */
static inline void SH(store_jacobian)(const VR *J, size_t jn, size_t l, size_t m, REAL *row)
{
    enum { PER = W / SEG, BYTES = SEG * (int)sizeof(REAL) };
    const size_t whole = SH_JAC_WHOLE(SH_JNV), rest = SH_JAC_REST(SH_JNV);
    const size_t k = l / PER, at = (l % PER) * (size_t)BYTES;
    size_t b, t;
    (void)jn;
    for (b = 0; b < whole; b++) {
        memcpy(row + b * SEG, (const char *)&J[b * SEG + k] + at, (size_t)BYTES);
    }
    if (rest > 0u && l + 1u < m) {
        memcpy(row + whole * SEG, (const char *)&J[whole * SEG + k] + at, (size_t)BYTES);
    } else {
        for (t = 0; t < rest; t++) {
            row[whole * SEG + t] = J[whole * SEG + k][(l % PER) * SEG + t];
        }
    }
}
#else
#define SH_JAC_VECS_CAP SH_JN_CAP
static inline void SH(regroup_jacobians)(VR *J, size_t jn)
{
    (void)J;
    (void)jn;
}

static inline void SH(store_jacobian)(const VR *J, size_t jn, size_t l, size_t m, REAL *row)
{
    size_t e;
    (void)m;
    (void)jn;
    for (e = 0; e < SH_JNV; e++) {
        row[e] = J[e][l];
    }
}
#endif

/* A regrouped group whose rows are still to be written: m poses to dst (jn
 * entries each); next is the first pose not written yet. */
typedef struct {
    const VR *J;
    size_t m, next, jn;
    REAL *dst;
} SH(pending);

/* Writes the pending rows up to (not including) pose end. */
static inline void SH(write_pending)(SH(pending) *pend, size_t end)
{
    const size_t jn = pend->jn;
    size_t l;
    (void)jn;
    if (end > pend->m) {
        end = pend->m;
    }
    for (l = pend->next; l < end; l++) {
        SH(store_jacobian)(pend->J, jn, l, pend->m, pend->dst + l * SH_JNV);
    }
    if (end > pend->next) {
        pend->next = end;
    }
}

/* The lines of one tile of jn entries (tiled layout), and the part of them
 * to prefetch at joint i of nj (NULL ahead: none). */
static inline int SH(tile_lines)(size_t jn)
{
    (void)jn;
    return (int)((SH_JNV * TILE * sizeof(REAL) + 63u) / 64u);
}

static inline void SH(prefetch_part)(const char *ahead, int i, size_t nj, size_t jn)
{
    const int lines = SH(tile_lines)(jn);
    const int part = (lines + (int)SH_NJV - 1) / (int)SH_NJV;
    int b;
    (void)nj;
    if (ahead == NULL) {
        return;
    }
    for (b = i * part; b < (i + 1) * part && b < lines; b++) {
        __builtin_prefetch(ahead + (size_t)b * 64u, 1, 3);
    }
}

/* One pass down the chain for W poses: the per-pose chain, lane by lane. */
#define CH_GENERAL SH_GENERAL
#define CH_T VR
#define CH(name) SH(name)
#define CH_SPLAT(x) VK(splat)(x)
#define CH_SINCOS(x, s, c) VK(sincos)(x, s, c)
#define CH_FMA(a, b, c) VF(a, b, c)
#define CH_DIRECT_DA SIMD_DIRECT_DA
#define CH_STEP_PARAM , SH(pending) *pend, VK(sums) *acc
#define CH_STEP(i) /* the pending rows, spread over the joints */                                 \
    if (pend != NULL) {                                                                            \
        SH(write_pending)(pend, ((size_t)(i) + 1u) * (size_t)W / (size_t)ch_nj);                   \
    }
#define CH_OUT(e, v) VK(out)(jac, acc, e, v)
#define CH_INLINE static inline __attribute__((always_inline))
#include "../chain_impl.h"
/* The chain again, fused throughout, for the Monte Carlo sums (no points
 * out: chain_impl.h's CH_FUSE_CHAIN): SH(chain_sums). */
#undef CH
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#define CH(name) SH(name##_sums)
#define CH_FUSE_CHAIN 1
#define CH_DIRECT_DA 0 /* CH_OUT adds to the sums: nothing to read back */
#include "../chain_impl.h"
/* The chain again for the tiled layout (SH(chain_tiled)): entry e of the
 * group's poses is one vector store to tile[e * TILE] (tile: the group's first
 * lane in its tile), the d and a columns during the pass (CH_DIRECT_DA), the
 * rest at the end. When the output is not 64-byte aligned, every store spans
 * two lines, and CH_STEP prefetches for writing a share of the tile that a
 * group two tiles on will fill (a sixth for the paper's six joints), so its
 * lines are in L1 when the stores come (measured, docs/kinematics.md: AVX-512
 * double 24 ns per pose with, 32 without; on an aligned output the prefetch
 * cost 0.8 ns and is not done). */
#undef CH
#undef CH_FUSE_CHAIN
#undef CH_DIRECT_DA
#undef CH_STEP_PARAM
#undef CH_STEP
#undef CH_OUT
#define CH(name) SH(name##_tiled)
#define CH_FUSE_CHAIN 0
#define CH_DIRECT_DA 1
#define CH_JSTORE(e, v) VK(store_entry)(tile + (size_t)(e) * (size_t)TILE, v)
#define CH_JLOAD(e) VK(load_entry)(tile + (size_t)(e) * (size_t)TILE)
#define CH_OUT(e, v) CH_JSTORE(e, v)
#define CH_STEP_PARAM , REAL *tile, const char *ahead
#define CH_STEP(i) SH(prefetch_part)(ahead, i, (size_t)ch_nj, SH_JN(model))
#include "../chain_impl.h"
#undef CH_GENERAL
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
static inline aacmm_status_t SH(check_pose)(const REAL *th, size_t nj)
{
    const REAL lim = (REAL)AACMM_JOINT_ANGLE_MAX_RAD;
    size_t i;
    (void)nj;
    for (i = 0; i < SH_NJV; i++) {
        const REAL x = th[i];
        if (!(x <= lim && x >= -lim)) {
            return isnan(x) || isinf(x) ? AACMM_ERR_NOT_FINITE : AACMM_ERR_RANGE;
        }
    }
    return AACMM_OK;
}

/* Number of leading valid poses among th[0 .. m-1] (m if all are), and the
 * status of the first invalid one in *st. */
static inline size_t SH(valid_prefix)(const REAL *th, size_t nj, size_t m, aacmm_status_t *st)
{
    size_t l;
    for (l = 0; l < m; l++) {
        *st = SH(check_pose)(th + l * SH_NJV, nj);
        if (*st != AACMM_OK) {
            return l;
        }
    }
    *st = AACMM_OK;
    return m;
}

/* The joint angles of W poses th[0 .. W*nj-1] as nj lane vectors: for the
 * paper's shape a gather each in the AVX-512 kernel (the loads go to the load
 * ports; not in AVX2, see simd_f64.c), else built in registers from W scalar
 * loads (a vector initialiser: writing the lanes into memory and reading the
 * vector back would stall on store forwarding). */
static inline void SH(load)(const REAL *th, size_t nj, VR *out)
{
    size_t i;
    (void)nj;
#if defined(ISA_GATHER) && !SH_GENERAL
    for (i = 0; i < SH_NJV; i++) {
        out[i] = (VR)ISA_GATHER(th + i);
    }
#else
    for (i = 0; i < SH_NJV; i++) {
        out[i] = (VR)LANES_INIT(th + i, SH_NJV);
    }
#endif
}

/* The same for m <= W poses: lanes past m repeat the last pose, so they
 * compute something harmless. */
static inline void SH(load_part)(const REAL *th, size_t nj, size_t m, VR *out)
{
    REAL buf[W * SH_NJ_CAP];
    size_t l;
    for (l = 0; l < (size_t)W; l++) {
        memcpy(buf + l * SH_NJV, th + (l < m ? l : m - 1u) * SH_NJV, SH_NJV * sizeof(REAL));
    }
    SH(load)(buf, nj, out);
}

/* 1 if every lane of the nj angle vectors is finite and within the limit:
 * a vector test, so a whole group of valid poses skips the pose-by-pose
 * check (NaN fails the comparisons). */
static inline int SH(in_range)(const VR *t, size_t nj)
{
    const VR lim = VK(splat)((REAL)AACMM_JOINT_ANGLE_MAX_RAD);
#if SH_GENERAL
    VU ok = (VU)(lim <= lim); /* all ones; then every joint (nj >= 4, unknown to the compiler) */
    size_t i = 0;
#else
    VU ok = (VU)(t[0] <= lim) & (VU)(t[0] >= -lim);
    size_t i = 1;
#endif
    UREAL all = ~(UREAL)0;
    int l;
    (void)nj;
    for (; i < SH_NJV; i++) {
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
static inline size_t SH(load_valid)(const REAL *th, size_t nj, size_t want, VR *t,
                                    aacmm_status_t *st)
{
    size_t m;
    if (want == (size_t)W) {
        SH(load)(th, nj, t);
        if (SH(in_range)(t, nj)) {
            *st = AACMM_OK;
            return want;
        }
    }
    m = SH(valid_prefix)(th, nj, want, st);
    if (m > 0u) {
        SH(load_part)(th, nj, m, t);
    }
    return m;
}

/* aacmm_simd_batch_angles_* for this instruction set (arguments checked by
 * the caller). With Jacobians, two buffers alternate: the chain fills one
 * while the other's rows are written (pend). */
__attribute__((noinline)) static aacmm_status_t SH(batch_angles)(const TYPE(aacmm_model) *model, size_t n,
                                       const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    const size_t nj = SH_NJ(model), jn = SH_JN(model);
    VR J[2][SH_JAC_VECS_CAP];
    SH(pending) pend = {NULL, 0u, 0u, 0u, NULL};
    aacmm_status_t st = AACMM_OK;
    size_t k = 0;
    int cur = 0;
    (void)nj;
    (void)jn;
    pend.jn = jn;
    while (k < n) {
        const REAL *th = theta_rad + k * SH_NJV;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        VR t[SH_NJ_CAP], P[3];
        const size_t m = SH(load_valid)(th, nj, want, t, &st);
        if (m > 0u) {
            if (jac == NULL) {
                SH(chain)(model, t, P, NULL, NULL, NULL);
            } else {
                SH(chain)(model, t, P, J[cur], &pend, NULL);
                SH(write_pending)(&pend, pend.m);
                SH(regroup_jacobians)(J[cur], jn);
                pend.J = J[cur];
                pend.m = m;
                pend.next = 0u;
                pend.dst = jac + k * SH_JNV;
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
        SH(write_pending)(&pend, pend.m);
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

/* aacmm_simd_batch_angles_tiled_* for this instruction set (arguments
 * checked by the caller): a group of W poses is W consecutive lanes of one
 * tile (W divides TILE). Lanes past the last valid pose of a short group
 * repeat that pose (SH(load_part)); the caller's padding rule overwrites
 * those past the last pose. */
__attribute__((noinline)) static aacmm_status_t SH(batch_tiled)(const TYPE(aacmm_model) *model, size_t n,
                                      const REAL *theta_rad, REAL *p_mm, REAL *jac, size_t *done)
{
    const size_t nj = SH_NJ(model), jn = SH_JN(model);
    const size_t tiles = (n + (size_t)TILE - 1u) / (size_t)TILE;
    VR with_jac[1]; /* the chain's jac only says "Jacobians too": they go to the tile */
    const int misaligned = ((uintptr_t)jac & 63u) != 0u;
    aacmm_status_t st = AACMM_OK;
    size_t k = 0;
    (void)nj;
    (void)jn;
    while (k < n) {
        const REAL *th = theta_rad + k * SH_NJV;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        const size_t t = k / (size_t)TILE;
        VR ang[SH_NJ_CAP], P[3];
        const size_t m = SH(load_valid)(th, nj, want, ang, &st);
        if (m > 0u) {
            REAL *tile = jac + t * (size_t)TILE * SH_JNV + k % (size_t)TILE;
            const char *ahead = misaligned && t + 2u < tiles
                                     ? (const char *)(jac + (t + 2u) * (size_t)TILE * SH_JNV)
                                     : NULL;
            SH(chain_tiled)(model, ang, P, with_jac, tile, ahead);
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
__attribute__((noinline)) static aacmm_status_t SH(abs_sums)(const TYPE(aacmm_model) *model, size_t n,
                                   const REAL *theta_rad, const REAL *scale, const REAL *offset,
                                   REAL *abs_sum, REAL *sq_sum, size_t *done)
{
    const size_t nj = SH_NJ(model), jn = SH_JN(model);
    VR sa[SH_JN_CAP], sq[SH_JN_CAP];
    const VR zero = VK(splat)(LIT(0.0));
    const VU no_sign = ~((VU)zero | SIGN_BIT);
    REAL buf[W * SH_NJ_CAP];
    aacmm_status_t st = AACMM_OK;
    size_t k = 0, l, e;
    (void)nj;
    (void)jn;
    for (e = 0; e < SH_JNV; e++) {
        sa[e] = zero;
        sq[e] = zero;
    }
    while (k < n) {
        const REAL *th = theta_rad + k * SH_NJV;
        const size_t want = (n - k < (size_t)W) ? n - k : (size_t)W;
        VR t[SH_NJ_CAP];
        size_t m;
        if (scale != NULL && offset != NULL) {
            size_t j;
            for (j = 0; j < want * SH_NJV; j++) {
                buf[j] = th[j] * scale[j % SH_NJV];
                buf[j] += offset[j % SH_NJV];
            }
            th = buf;
        }
        m = SH(load_valid)(th, nj, want, t, &st);
        if (m > 0u) {
            VR P[3];
            VK(sums) acc;
            acc.sa = sa;
            acc.sq = sq;
            acc.keep = no_sign;
            for (l = m; l < (size_t)W; l++) {
                acc.keep[l] = 0u;
            }
            SH(chain_sums)(model, t, P, sa, NULL, &acc); /* jac unused: the entries go to acc */
            k += m;
        }
        if (st != AACMM_OK) {
            break;
        }
    }
    for (e = 0; e < SH_JNV; e++) {
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

#undef SH_NJV
#undef SH_JNV
#undef SH_NJ_CAP
#undef SH_JN_CAP
#undef SH_NJ
#undef SH_JN
#undef SH_JAC_WHOLE
#undef SH_JAC_REST
#undef SH_JAC_VECS
#undef SH_JAC_VECS_CAP
