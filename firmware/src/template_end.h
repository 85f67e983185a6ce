/*
 * Ends a file that instantiated a precision template (kinematics_impl.h,
 * simd/simd_impl.h): removes the template's parameter macros, so several such
 * files can be compiled as one translation unit (the Python extension's
 * unity build) without one file's definitions leaking into the next.
 */
#undef REAL
#undef UREAL
#undef LIT
#undef SFX
#undef TYPE
#undef PSFX
#undef ROUND_MANT
#undef POW2
#undef SIGN_BIT
#undef SIMD_ABS_SUMS
#undef ROUND_MAGIC
#undef TWO_OVER_PI
#undef PIO2_1
#undef PIO2_2
#undef PIO2_3
#undef SIN_POLY
#undef COS_POLY
#undef PLAIN_FMA
#undef MM_SFX
#undef MM128
#undef MM256
#undef MM512
