/*
 * Internal helpers shared by the float, double and fixed-point paths.
 * Not part of the public API.
 */
#ifndef AACMM_INTERNAL_H
#define AACMM_INTERNAL_H

#include <stdint.h>

#include "aacmm/kinematics.h"

/*
 * |angle| of a signed count s at resolution cpr as a normalised binary
 * floating value: |s| * 2 pi / cpr = mant * 2^exp2, where mant has bit 63 set
 * and bit 0 is a sticky bit (set if any lower bit of the exact quotient was
 * non-zero), so converting mant to float or double rounds correctly.
 * magnitude must be >= 1 and <= cpr/2; cpr in 2 .. 2^32.
 */
void aacmm_internal_angle_exact(uint32_t magnitude, uint64_t cpr, uint64_t *mant, int *exp2);

#endif /* AACMM_INTERNAL_H */
