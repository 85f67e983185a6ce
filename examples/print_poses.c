/*
 * Prints the probe point and the 3x25 Jacobian for a few poses of the paper's
 * arm, from raw 32-bit encoder counts, in double and single precision. A
 * first look at the core; `make demo` runs it.
 */
#include <stdint.h>
#include <stdio.h>

#include "aacmm/kinematics.h"

static const char *const col_names[AACMM_JAC_COLS] = {
    "th1", "th2", "th3", "th4", "th5", "th6", "al1", "al2", "al3", "al4", "al5", "al6", "d1",
    "d2",  "d3",  "d4",  "d5",  "d6",  "a1",  "a2",  "a3",  "a4",  "a5",  "a6",  "l"};

int main(void)
{
    /* Raw readings of six 32-bit absolute encoders (2^32 counts per turn). */
    static const struct {
        const char *name;
        uint32_t counts[AACMM_JOINTS];
    } poses[] = {
        {"zero pose (all joints at 0)", {0u, 0u, 0u, 0u, 0u, 0u}},
        {"quarter turns", {0x40000000u, 0xC0000000u, 0x40000000u, 0u, 0x40000000u, 0u}},
        {"a measuring pose", {0x12345678u, 0xE0000000u, 0x30000000u, 0xF0000000u, 0x2AAAAAABu, 0x9ABCDEF0u}},
    };
    aacmm_params_f64_t params;
    aacmm_params_f32_t params32;
    aacmm_model_f64_t model;
    aacmm_model_f32_t model32;
    aacmm_encoder_config_t enc;
    size_t k;
    int r, c;

    if (aacmm_params_default_f64(&params) != AACMM_OK || aacmm_model_init_f64(&model, &params) != AACMM_OK ||
        aacmm_params_default_f32(&params32) != AACMM_OK ||
        aacmm_model_init_f32(&model32, &params32) != AACMM_OK || aacmm_encoder_default(&enc) != AACMM_OK) {
        fprintf(stderr, "print_poses: could not set up the default model\n");
        return 1;
    }
    printf("aacmm kinematics core: the paper's arm (Table 1), 32-bit encoders\n");
    for (k = 0; k < sizeof poses / sizeof poses[0]; k++) {
        double th[AACMM_JOINTS], p[3], J[AACMM_JAC_SIZE];
        float thf[AACMM_JOINTS], pf[3], Jf[AACMM_JAC_SIZE];
        aacmm_status_t st = aacmm_encoder_to_angles_f64(&enc, poses[k].counts, th);
        if (st == AACMM_OK) {
            st = aacmm_point_jacobian_f64(&model, th, p, J);
        }
        if (st == AACMM_OK) {
            st = aacmm_encoder_to_angles_f32(&enc, poses[k].counts, thf);
        }
        if (st == AACMM_OK) {
            st = aacmm_point_jacobian_f32(&model32, thf, pf, Jf);
        }
        if (st != AACMM_OK) {
            fprintf(stderr, "print_poses: %s\n", aacmm_status_str(st));
            return 1;
        }
        printf("\n== %s\n   counts:", poses[k].name);
        for (c = 0; c < AACMM_JOINTS; c++) {
            printf(" 0x%08lx", (unsigned long)poses[k].counts[c]);
        }
        printf("\n   angles [deg]:");
        for (c = 0; c < AACMM_JOINTS; c++) {
            printf(" %9.4f", th[c] * 57.29577951308232);
        }
        printf("\n   point  [mm] double: x %12.6f  y %12.6f  z %12.6f\n", p[0], p[1], p[2]);
        printf("   point  [mm] single: x %12.6f  y %12.6f  z %12.6f\n", (double)pf[0], (double)pf[1],
               (double)pf[2]);
        printf("   Jacobian (double; mm/rad for th, al; mm/mm for d, a, l):\n");
        for (c = 0; c < AACMM_JAC_COLS; c++) {
            printf("     %-4s", col_names[c]);
            for (r = 0; r < 3; r++) {
                printf(" %11.4f", J[r * AACMM_JAC_COLS + c]);
            }
            printf("%s", (c % 2 == 1 || c == AACMM_JAC_COLS - 1) ? "\n" : "   |");
        }
    }
    return 0;
}
