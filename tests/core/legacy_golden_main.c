/*
 * Prints tests/core/legacy_golden.h: the hash of every kinematics path of
 * tests/core/legacy_paths.h, for the core this program is linked with.
 * scripts/legacy-golden.sh builds it against the core of commit aa8b712 (the
 * last one before the general arm model of issue 26) and against today's,
 * and the test suites compare today's hashes with the header.
 *
 * Usage: legacy_golden float|fixed|fixed-split
 */
#include <stdio.h>
#include <string.h>

#define LEGACY_FLOAT_PATHS
#define LEGACY_FIXED_PATHS
#include "legacy_paths.h"

int main(int argc, char **argv)
{
    int k, i;
    if (argc != 2) {
        fprintf(stderr, "usage: legacy_golden float|fixed|fixed-split\n");
        return 2;
    }
    if (strcmp(argv[1], "float") == 0) {
        for (i = 0; i < LEGACY_SCALAR_PATHS; i++) {
            printf("#define LEGACY_GOLDEN_%s UINT64_C(0x%016llx)\n", legacy_scalar_names[i],
                   (unsigned long long)legacy_scalar_hash(i));
        }
        for (k = 0; k < AACMM_KERNEL_COUNT; k++) {
            for (i = 0; i < LEGACY_SIMD_PATHS; i++) {
                if (!aacmm_kernel_available((aacmm_kernel_t)k)) {
                    /* the test suites then check this kernel's point and
                     * Jacobian paths against its fused peer's golden */
                    if (i == 0) {
                        printf("/* kernel %s: not available where this was generated */\n",
                               aacmm_kernel_name((aacmm_kernel_t)k));
                    }
                    continue;
                }
                printf("#define LEGACY_GOLDEN_%s_%s UINT64_C(0x%016llx)\n", legacy_simd_names[i],
                       aacmm_kernel_name((aacmm_kernel_t)k),
                       (unsigned long long)legacy_simd_hash(i, (aacmm_kernel_t)k));
            }
        }
        return 0;
    }
    if (strcmp(argv[1], "fixed") == 0 || strcmp(argv[1], "fixed-split") == 0) {
        const char *sfx = strcmp(argv[1], "fixed") == 0 ? "" : "_split";
        for (i = 0; i < LEGACY_Q_PATHS; i++) {
            printf("#define LEGACY_GOLDEN_%s%s UINT64_C(0x%016llx)\n", legacy_q_names[i], sfx,
                   (unsigned long long)legacy_q_hash(i));
        }
        return 0;
    }
    fprintf(stderr, "legacy_golden: unknown set %s\n", argv[1]);
    return 2;
}
