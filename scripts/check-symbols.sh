#!/bin/sh
# check-symbols.sh PROFILE OBJECT...
# Fails if an ARM object references a helper its profile forbids.
#   m4f-float: single-precision code for Cortex-M4F with FPU. No double
#              arithmetic helpers (__aeabi_d*, *2d conversions), no soft-float
#              single helpers (__aeabi_f*), no double libm functions.
#   m0-fixed:  integer-only code for Cortex-M0+. No floating-point helper or
#              libm function of any kind.
set -eu
profile=$1
shift
case "$profile" in
m4f-float)
    pattern='^(__aeabi_d[a-z0-9]*|__aeabi_[a-z0-9]*2d|__aeabi_f[a-z0-9]*|__(add|sub|mul|div|extendsf|truncdf)[a-z0-9]*df[0-9]*|sin|cos|tan|sqrt|ldexp|frexp|exp|log|pow|atan2?|fabs|floor|ceil|round|fmod)$'
    ;;
m0-fixed)
    pattern='^(__(fix|float)[a-z]*[sd]f[a-z]*|__aeabi_[df][a-z0-9]*|__aeabi_[a-z0-9]*2[df]|__aeabi_[a-z0-9]*2[a-z]*f|__[a-z]*[sd]f[0-9]*|[a-z]+f|sin|cos|tan|sqrt|ldexp|frexp|exp|log|pow|atan2?|fabs|floor|ceil|round|fmod)$'
    ;;
*)
    echo "check-symbols: unknown profile '$profile'" >&2
    exit 2
    ;;
esac
status=0
for obj in "$@"; do
    bad=$(arm-none-eabi-nm -u "$obj" | awk '{print $2}' | grep -E "$pattern" || true)
    if [ -n "$bad" ]; then
        echo "check-symbols: $obj ($profile) references forbidden symbols:" >&2
        echo "$bad" | sed 's/^/  /' >&2
        status=1
    fi
done
exit $status
