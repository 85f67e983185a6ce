/* Which batch kernel this build and this CPU can run (aacmm/simd.h). */
#include <stddef.h>

#include "aacmm/simd.h"
#include "simd_target.h"

int aacmm_kernel_available(aacmm_kernel_t kernel)
{
    switch (kernel) {
    case AACMM_KERNEL_SCALAR:
        return 1;
    case AACMM_KERNEL_VEC128:
        return SIMD_VECTOR_EXT;
#if SIMD_X86
    case AACMM_KERNEL_AVX2:
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case AACMM_KERNEL_AVX512:
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") &&
               __builtin_cpu_supports("fma");
#endif
    default:
        return 0;
    }
}

aacmm_kernel_t aacmm_kernel_best(void)
{
    static const aacmm_kernel_t widest_first[] = {AACMM_KERNEL_AVX512, AACMM_KERNEL_AVX2,
                                                  AACMM_KERNEL_VEC128};
    size_t i;
    for (i = 0; i < sizeof widest_first / sizeof widest_first[0]; i++) {
        if (aacmm_kernel_available(widest_first[i])) {
            return widest_first[i];
        }
    }
    return AACMM_KERNEL_SCALAR;
}

const char *aacmm_kernel_name(aacmm_kernel_t kernel)
{
    switch (kernel) {
    case AACMM_KERNEL_SCALAR: return "scalar";
    case AACMM_KERNEL_VEC128: return "vec128";
    case AACMM_KERNEL_AVX2: return "avx2";
    case AACMM_KERNEL_AVX512: return "avx512";
    default: return "unknown";
    }
}

int aacmm_kernel_fused(aacmm_kernel_t kernel)
{
    return kernel == AACMM_KERNEL_AVX2 || kernel == AACMM_KERNEL_AVX512;
}

unsigned aacmm_kernel_lanes(aacmm_kernel_t kernel, int single)
{
    static const unsigned bytes[AACMM_KERNEL_COUNT] = {0u, 16u, 32u, 64u};
    if ((int)kernel < 0 || (int)kernel >= AACMM_KERNEL_COUNT) {
        return 0u;
    }
    if (kernel == AACMM_KERNEL_SCALAR) {
        return 1u;
    }
    return bytes[kernel] / (single ? 4u : 8u);
}
