/*
 * Which instruction sets the batch kernels are compiled for in this build
 * (internal to firmware/src/simd).
 *
 *   SIMD_VECTOR_EXT  1 with a GNU C compiler (GCC, clang): vector extensions
 *   SIMD_X86         1 on x86 with a GNU C compiler: AVX2 and AVX-512 kernels
 *                    are compiled too, each under a target attribute
 *   SIMD_SHUFFLE     1 if __builtin_shufflevector is available
 */
#ifndef AACMM_SIMD_TARGET_H
#define AACMM_SIMD_TARGET_H

#if defined(__GNUC__)
#define SIMD_VECTOR_EXT 1
#else
#define SIMD_VECTOR_EXT 0
#endif

#if SIMD_VECTOR_EXT && (defined(__x86_64__) || defined(__i386__))
#define SIMD_X86 1
#else
#define SIMD_X86 0
#endif

/* __builtin_shufflevector (clang; GCC 12 and later): the Jacobian stores
 * transpose blocks in registers with it, else they go lane by lane. */
#if defined(__has_builtin)
#if __has_builtin(__builtin_shufflevector)
#define SIMD_SHUFFLE 1
#endif
#endif
#ifndef SIMD_SHUFFLE
#define SIMD_SHUFFLE 0
#endif

#endif /* AACMM_SIMD_TARGET_H */
