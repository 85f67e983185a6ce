/*
 * A deliberately floating-point object for the Cortex-M0+: test-fixed-m0p
 * builds it and requires the symbol check to REJECT it, so the check that
 * guards the integer-only path is known to be able to fail. Not linked
 * anywhere.
 */
#include <math.h>

float canary_f32(float x);
double canary_f64(double x);
int canary_d2i(double x);

float canary_f32(float x)
{
    return sinf(x) * 2.5f + x / 3.0f;
}

double canary_f64(double x)
{
    return x * 3.0 + 1.0;
}

int canary_d2i(double x)
{
    return (int)x;
}
