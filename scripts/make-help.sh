#!/bin/sh
# Prints `make help`: every target documented with a "#> NAME  TEXT" comment
# line in the Makefile and the mk/ fragments (in file order, one section per
# fragment), then the lists the fragments build up.
# Usage: make-help.sh "TEST_SUITES" "BENCH_TARGETS" "FIRMWARE_TARGETS" "DEMO_STEPS" FILE...
set -u
suites=$1 benches=$2 firmware=$3 demo=$4
shift 4
echo "aacmm make targets (README.md, docs/):"
awk '
    FNR == 1 { shown = 0 }
    /^#> / {
        if (!shown && FILENAME != "Makefile") { printf "%s:\n", FILENAME; shown = 1 }
        name = $2
        text = $0
        sub(/^#> +[^ ]+ +/, "", text)
        printf "  %-24s %s\n", name, text
    }
' "$@"
wrap() { echo "$1:"; echo "$2" | tr -s ' ' | fold -s -w 90 | sed 's/^ *//; s/ *$//; s/^/  /'; }
wrap "test suites (make test runs them all; each runs alone too)" "$suites"
wrap "benchmarks (make bench)" "$benches"
wrap "firmware builds (make firmware)" "$firmware"
wrap "demo steps (make demo)" "$demo"
