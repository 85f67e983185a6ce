/*
 * Instantiates the batch kernel (simd_impl.h) for every instruction set of
 * this build and defines the public entry points of one precision, which
 * dispatch on the caller's aacmm_kernel_t.
 *
 * Included by simd_f64.c and simd_f32.c after they define REAL, LIT(x),
 * TYPE(name), UREAL (the unsigned integer as wide as REAL), SIGN_BIT, PSFX(name)
 * (name##_f64 or name##_f32), LANES_16B, LANES_32B, LANES_64B (lanes of a
 * 16-, 32- and 64-byte vector, as plain numbers), SIMD_REAL_BYTES (sizeof
 * REAL), MM_SFX(name) (name##_pd or name##_ps),
 * MM256, MM512 (the intrinsics' vector types),
 * the sine/cosine constants and, for double, SIMD_ABS_SUMS.
 *
 * The AVX2 and AVX-512 instances are compiled under target attributes
 * (GCC: #pragma GCC target; clang: #pragma clang attribute), so the object
 * runs on the architecture's baseline and the wide kernels are only called
 * after aacmm_kernel_available() has seen the CPU support them.
 */

/* No contraction by the compiler: the only fused multiply-adds are the
 * explicit ones (VK(fma): the intrinsics in the AVX2 and AVX-512
 * instances, a * b + c rounded twice in vec128), at the places sincos_eval.h
 * and chain_impl.h chose, so every kernel with FMA rounds like every other one,
 * and vec128 like the per-pose core built without contraction (the Python
 * extension's and the core tests' build). Clang ignores the pragma under
 * -ffp-contract=fast: build these files without it. GCC also compiles the
 * kernels at -O3 whatever the command line says: at -O2 it copies vectors in
 * 16-byte pieces and reads them back whole (a store-forwarding stall), which
 * cost the AVX2 kernel 2.5x. */
#if defined(__clang__)
#pragma float_control(push)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC push_options
#pragma GCC optimize("O3", "fp-contract=off")
#endif

#define SIMD_PRAGMA_STR(x) _Pragma(#x)
#define SIMD_PRAGMA(x) SIMD_PRAGMA_STR(x)

#if SIMD_VECTOR_EXT

/* Interleave (zip) index lists for __builtin_shufflevector, by lane count:
 * ZIPLO(a, b) = a0 b0 a1 b1 ..., ZIPHI(a, b) = the second halves. */
#define ZIPLO_2 0, 2
#define ZIPHI_2 1, 3
#define ZIPLO_4 0, 4, 1, 5
#define ZIPHI_4 2, 6, 3, 7
#define ZIPLO_8 0, 8, 1, 9, 2, 10, 3, 11
#define ZIPHI_8 4, 12, 5, 13, 6, 14, 7, 15
#define ZIPLO_16 0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23
#define ZIPHI_16 8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31
/* Index lists for the points (simd_impl.h's store_points): output vector k
 * of a group's points, in pose-major (x, y, z) order, is
 * shuffle(shuffle(x, y, XYZ_A_W_k), z, XYZ_B_W_k). */
#define XYZ_A_2_0 0, 2
#define XYZ_B_2_0 0, 1
#define XYZ_A_2_1 0, 1
#define XYZ_B_2_1 2, 1
#define XYZ_A_2_2 3, 0
#define XYZ_B_2_2 0, 3
#define XYZ_A_4_0 0, 4, 0, 1
#define XYZ_B_4_0 0, 1, 4, 3
#define XYZ_A_4_1 5, 0, 2, 6
#define XYZ_B_4_1 0, 5, 2, 3
#define XYZ_A_4_2 0, 3, 7, 0
#define XYZ_B_4_2 6, 1, 2, 7
#define XYZ_A_8_0 0, 8, 0, 1, 9, 0, 2, 10
#define XYZ_B_8_0 0, 1, 8, 3, 4, 9, 6, 7
#define XYZ_A_8_1 0, 3, 11, 0, 4, 12, 0, 5
#define XYZ_B_8_1 10, 1, 2, 11, 4, 5, 12, 7
#define XYZ_A_8_2 13, 0, 6, 14, 0, 7, 15, 0
#define XYZ_B_8_2 0, 13, 2, 3, 14, 5, 6, 15
#define XYZ_A_16_0 0, 16, 0, 1, 17, 0, 2, 18, 0, 3, 19, 0, 4, 20, 0, 5
#define XYZ_B_16_0 0, 1, 16, 3, 4, 17, 6, 7, 18, 9, 10, 19, 12, 13, 20, 15
#define XYZ_A_16_1 21, 0, 6, 22, 0, 7, 23, 0, 8, 24, 0, 9, 25, 0, 10, 26
#define XYZ_B_16_1 0, 21, 2, 3, 22, 5, 6, 23, 8, 9, 24, 11, 12, 25, 14, 15
#define XYZ_A_16_2 0, 11, 27, 0, 12, 28, 0, 13, 29, 0, 14, 30, 0, 15, 31, 0
#define XYZ_B_16_2 26, 1, 2, 27, 4, 5, 28, 7, 8, 29, 10, 11, 30, 13, 14, 31
/* A vector of W values p[0], p[s], p[2 s], ... as an initialiser. */
#define LANES_INIT_2(p, s) {(p)[0], (p)[s]}
#define LANES_INIT_4(p, s) {(p)[0], (p)[s], (p)[2 * (s)], (p)[3 * (s)]}
#define LANES_INIT_8(p, s)                                                                         \
    {(p)[0],         (p)[s],         (p)[2 * (s)],   (p)[3 * (s)],                                 \
     (p)[4 * (s)],   (p)[5 * (s)],   (p)[6 * (s)],   (p)[7 * (s)]}
#define LANES_INIT_16(p, s)                                                                        \
    {(p)[0],          (p)[s],          (p)[2 * (s)],    (p)[3 * (s)],                              \
     (p)[4 * (s)],    (p)[5 * (s)],    (p)[6 * (s)],    (p)[7 * (s)],                              \
     (p)[8 * (s)],    (p)[9 * (s)],    (p)[10 * (s)],   (p)[11 * (s)],                             \
     (p)[12 * (s)],   (p)[13 * (s)],   (p)[14 * (s)],   (p)[15 * (s)]}
#define LANES_INIT(p, s) ZIP_IDX(LANES_INIT, LANES)(p, s)
#define ZIP_IDX_(name, n) name##_##n
#define ZIP_IDX(name, n) ZIP_IDX_(name, n)
#if SIMD_SHUFFLE
#define ZIPLO(a, b) __builtin_shufflevector(a, b, ZIP_IDX(ZIPLO, LANES))
#define ZIPHI(a, b) __builtin_shufflevector(a, b, ZIP_IDX(ZIPHI, LANES))
#define XYZ(x, y, z, k)                                                                            \
    __builtin_shufflevector(__builtin_shufflevector(x, y, ZIP_IDX(ZIP_IDX(XYZ_A, LANES), k)), z,  \
                            ZIP_IDX(ZIP_IDX(XYZ_B, LANES), k))
#endif

/* ---- 128-bit: SSE2 on x86-64, NEON on arm64; no FMA ---- */
#define ISA(name) PSFX(name##_vec128)
#define ISA_BYTES 16
#define ISA_LANES LANES_16B
#define ISA_FMA(a, b, c) ((a) * (b) + (c))
#include "simd_isa.h"

#endif /* SIMD_VECTOR_EXT */

#if SIMD_X86

/* ---- 256-bit AVX2 + FMA ---- */
#define ISA(name) PSFX(name##_avx2)
#define ISA_BYTES 32
#define ISA_LANES LANES_32B
#define ISA_TARGET "avx2,fma"
#define ISA_FMA(a, b, c) ((VR)MM_SFX(_mm256_fmadd)((MM256)(a), (MM256)(b), (MM256)(c)))
#include "simd_isa.h"

/* ---- 512-bit AVX-512F ---- */
#define ISA(name) PSFX(name##_avx512)
#define ISA_BYTES 64
#define ISA_LANES LANES_64B
#define ISA_TARGET "avx512f,avx2,fma,prfchw"
#define ISA_FMA(a, b, c) ((VR)MM_SFX(_mm512_fmadd)((MM512)(a), (MM512)(b), (MM512)(c)))
#define ISA_GATHER(p) GATHER512(p)
#include "simd_isa.h"

#endif /* SIMD_X86 */

/* ---- public entry points: dispatch on the caller's kernel ---- */

/* Each operation's instance per kernel, indexed by aacmm_kernel_t; NULL
 * where this build has none (the public function then runs the scalar one,
 * which only happens for a kernel aacmm_kernel_available() refused). */
#if SIMD_X86
#define SIMD_TABLE(op, scalar)                                                                     \
    { scalar, PSFX(op##_vec128), PSFX(op##_avx2), PSFX(op##_avx512) }
#elif SIMD_VECTOR_EXT
#define SIMD_TABLE(op, scalar) { scalar, PSFX(op##_vec128), NULL, NULL }
#else
#define SIMD_TABLE(op, scalar) { scalar, NULL, NULL, NULL }
#endif

typedef aacmm_status_t (*PSFX(batch_angles_fn))(const TYPE(aacmm_model) *, size_t, const REAL *,
                                                REAL *, REAL *, size_t *);
static const PSFX(batch_angles_fn) PSFX(batch_angles_table)[AACMM_KERNEL_COUNT] =
    SIMD_TABLE(batch_angles, PSFX(aacmm_batch_angles));

aacmm_status_t PSFX(aacmm_simd_batch_angles)(aacmm_kernel_t kernel, const TYPE(aacmm_model) *model,
                                             size_t n, const REAL *theta_rad, REAL *p_mm,
                                             REAL *jac, size_t *done)
{
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || (n > 0u && (theta_rad == NULL || p_mm == NULL))) {
        return AACMM_ERR_NULL;
    }
    if (!aacmm_kernel_available(kernel) || PSFX(batch_angles_table)[kernel] == NULL) {
        return AACMM_ERR_UNSUPPORTED;
    }
    return PSFX(batch_angles_table)[kernel](model, n, theta_rad, p_mm, jac, done);
}

/* The tiled layout for the scalar kernel: each pose through the per-pose
 * core, its 3 P entries to its lane. */
static aacmm_status_t PSFX(batch_tiled_scalar)(const TYPE(aacmm_model) *model, size_t n,
                                               const REAL *theta_rad, REAL *p_mm, REAL *jac,
                                               size_t *done)
{
    const size_t nj = model->arm.shape.joints, jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    REAL row[AACMM_JAC_SIZE_MAX];
    size_t l, e;
    for (l = 0; l < n; l++) {
        REAL *lane = jac + (l / TILE) * TILE * jn + l % TILE;
        const aacmm_status_t st =
            PSFX(aacmm_batch_angles)(model, 1u, theta_rad + l * nj, p_mm + l * 3u, row, NULL);
        if (st != AACMM_OK) {
            *done = l;
            return st;
        }
        for (e = 0; e < jn; e++) {
            lane[e * TILE] = row[e];
        }
    }
    *done = n;
    return AACMM_OK;
}

typedef aacmm_status_t (*PSFX(batch_tiled_fn))(const TYPE(aacmm_model) *, size_t, const REAL *,
                                               REAL *, REAL *, size_t *);
static const PSFX(batch_tiled_fn) PSFX(batch_tiled_table)[AACMM_KERNEL_COUNT] =
    SIMD_TABLE(batch_tiled, PSFX(batch_tiled_scalar));

aacmm_status_t PSFX(aacmm_simd_batch_angles_tiled)(aacmm_kernel_t kernel,
                                                   const TYPE(aacmm_model) *model, size_t n,
                                                   const REAL *theta_rad, REAL *p_mm,
                                                   REAL *jac_tiled, size_t *done)
{
    size_t k = 0, l, e, jn;
    aacmm_status_t st;
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL ||
        (n > 0u && (theta_rad == NULL || p_mm == NULL || jac_tiled == NULL))) {
        return AACMM_ERR_NULL;
    }
    if (!aacmm_kernel_available(kernel) || PSFX(batch_tiled_table)[kernel] == NULL) {
        return AACMM_ERR_UNSUPPORTED;
    }
    jn = (size_t)AACMM_JAC_ROWS * model->n_params;
    st = PSFX(batch_tiled_table)[kernel](model, n, theta_rad, p_mm, jac_tiled, &k);
    if (st == AACMM_OK && n % TILE != 0u) { /* the last tile's padding lanes */
        REAL *last = jac_tiled + ((n - 1u) / TILE) * TILE * jn;
        for (e = 0; e < jn; e++) {
            for (l = n % TILE; l < TILE; l++) {
                last[e * TILE + l] = last[e * TILE + (n - 1u) % TILE];
            }
        }
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

#ifdef SIMD_ABS_SUMS
typedef aacmm_status_t (*PSFX(abs_sums_fn))(const TYPE(aacmm_model) *, size_t, const REAL *,
                                            const REAL *, const REAL *, REAL *, REAL *, size_t *);
static const PSFX(abs_sums_fn) PSFX(abs_sums_table)[AACMM_KERNEL_COUNT] =
    SIMD_TABLE(abs_sums, PSFX(aacmm_abs_jacobian_sums_scaled));

aacmm_status_t PSFX(aacmm_simd_abs_jacobian_sums_scaled)(
    aacmm_kernel_t kernel, const TYPE(aacmm_model) *model, size_t n, const REAL *theta_rad,
    const REAL *scale, const REAL *offset, REAL *abs_sum, REAL *sq_sum, size_t *done)
{
    if (done != NULL) {
        *done = 0u;
    }
    if (model == NULL || abs_sum == NULL || sq_sum == NULL || (n > 0u && theta_rad == NULL) ||
        ((scale == NULL) != (offset == NULL))) {
        return AACMM_ERR_NULL;
    }
    if (!aacmm_kernel_available(kernel) || PSFX(abs_sums_table)[kernel] == NULL) {
        return AACMM_ERR_UNSUPPORTED;
    }
    return PSFX(abs_sums_table)[kernel](model, n, theta_rad, scale, offset, abs_sum, sq_sum, done);
}

aacmm_status_t PSFX(aacmm_simd_abs_jacobian_sums)(aacmm_kernel_t kernel,
                                                  const TYPE(aacmm_model) *model, size_t n,
                                                  const REAL *theta_rad,
                                                  REAL *abs_sum, REAL *sq_sum, size_t *done)
{
    return PSFX(aacmm_simd_abs_jacobian_sums_scaled)(kernel, model, n, theta_rad, NULL, NULL,
                                                     abs_sum, sq_sum, done);
}

aacmm_status_t PSFX(aacmm_simd_perturbed_points)(aacmm_kernel_t kernel,
                                                 const TYPE(aacmm_arm) *nominal,
                                                 size_t n_trials, const REAL *delta,
                                                 size_t n_poses, const REAL *theta_rad,
                                                 REAL *p_mm, size_t *done)
{
    size_t t, np;
    if (done != NULL) {
        *done = 0u;
    }
    if (nominal == NULL) {
        return AACMM_ERR_NULL;
    }
    if (aacmm_shape_validate(&nominal->shape) != AACMM_OK) {
        return AACMM_ERR_RANGE;
    }
    np = (size_t)aacmm_shape_params(&nominal->shape);
    if (n_trials > 0u && (delta == NULL || (n_poses > 0u && (theta_rad == NULL || p_mm == NULL)))) {
        return AACMM_ERR_NULL;
    }
    if (!aacmm_kernel_available(kernel)) {
        return AACMM_ERR_UNSUPPORTED;
    }
    if (kernel == AACMM_KERNEL_SCALAR) {
        return PSFX(aacmm_perturbed_points)(nominal, n_trials, delta, n_poses, theta_rad, p_mm,
                                            done);
    }
    for (t = 0; t < n_trials; t++) {
        TYPE(aacmm_arm) prm;
        TYPE(aacmm_model) model;
        aacmm_status_t st;
        st = PSFX(aacmm_arm_perturb)(nominal, delta + t * np, &prm);
        if (st == AACMM_OK) {
            st = PSFX(aacmm_model_init_arm)(&model, &prm);
        }
        if (st == AACMM_OK) {
            st = PSFX(aacmm_simd_batch_angles)(kernel, &model, n_poses, theta_rad,
                                               p_mm + t * n_poses * 3u, NULL, NULL);
        }
        if (st != AACMM_OK) {
            return st;
        }
        if (done != NULL) {
            *done = t + 1u;
        }
    }
    return AACMM_OK;
}
#endif /* SIMD_ABS_SUMS */

#undef SIMD_TABLE

#include "simd_em_impl.h"

#if defined(__clang__)
#pragma float_control(pop)
#elif defined(__GNUC__)
#pragma GCC pop_options
#endif
