#!/bin/sh
# Runs each named make target as one test suite, keeps going past failures, and
# ends with one line: "suites: N passed, M failed". Exit status 1 if any failed.
set -u
passed=0
failed=0
failed_names=""
for suite in "$@"; do
    echo "=== suite $suite"
    if make --no-print-directory "$suite"; then
        passed=$((passed + 1))
    else
        failed=$((failed + 1))
        failed_names="$failed_names $suite"
    fi
done
[ -z "$failed_names" ] || echo "failed suites:$failed_names"
echo "suites: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
