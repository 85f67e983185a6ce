#!/bin/sh
# Runs each named make target as one test suite, keeps going past failures, and
# ends with one line: "suites: N passed, M failed" (CI reads it). Exit status 1
# if any failed.
#
# Usage: run-suites.sh [--prepare TARGET] SUITE...
#
# Each suite's own output (compiler lines, pytest dots, fuzzer progress, ...)
# goes to $TEST_LOG_DIR/<suite>.log (default build/test-logs); the terminal
# gets one line per suite: name, result, seconds. A failed suite also shows
# where its log is and the last $TEST_TAIL lines of it (default 40).
# --prepare TARGET runs TARGET first the same way (not counted as a suite; if
# it fails, nothing else runs). TEST_VERBOSE=1 also streams every suite's
# output to the terminal. $TEST_LOG_DIR/summary.tsv lists name, result and
# seconds of the last run.
set -u
LOG_DIR=${TEST_LOG_DIR:-build/test-logs}
TAIL=${TEST_TAIL:-40}
VERBOSE=${TEST_VERBOSE:-0}

prepare=""
if [ "${1:-}" = "--prepare" ]; then
    prepare=${2:?--prepare needs a target}
    shift 2
fi

mkdir -p "$LOG_DIR" || exit 1
summary="$LOG_DIR/summary.tsv"
printf 'suite\tresult\tseconds\n' >"$summary"

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }

# run_target NAME: runs `make NAME` into its log; sets rc and secs. The
# suite's name is printed first, so a long suite shows what is running.
run_target() {
    log="$LOG_DIR/$1.log"
    if [ "$VERBOSE" = 1 ]; then
        echo "=== suite $1"
    else
        printf '  %-28s ' "$1"
    fi
    t0=$(now)
    if [ "$VERBOSE" = 1 ]; then
        rcfile="$LOG_DIR/.$1.rc"
        { make --no-print-directory "$1" 2>&1; echo $? >"$rcfile"; } | tee "$log"
        rc=$(cat "$rcfile")
        rm -f "$rcfile"
    else
        make --no-print-directory "$1" >"$log" 2>&1
        rc=$?
    fi
    secs=$(elapsed "$t0" "$(now)")
}

# report NAME RESULT: ends the suite's line (on failure: where its log is, and its tail).
report() {
    [ "$VERBOSE" = 1 ] && printf '  %-28s ' "$1"
    printf '%-5s %7s s\n' "$2" "$secs"
    printf '%s\t%s\t%s\n' "$1" "$2" "$secs" >>"$summary"
    if [ "$2" = FAIL ]; then
        echo "    log: $LOG_DIR/$1.log (last $TAIL lines:)"
        tail -n "$TAIL" "$LOG_DIR/$1.log" | sed 's/^/    | /'
    fi
}

echo "make test: $# suites; the output of each goes to $LOG_DIR/<suite>.log"
if [ -n "$prepare" ]; then
    run_target "$prepare"
    if [ "$rc" -ne 0 ]; then
        report "$prepare" FAIL
        echo "suites: 0 passed, $# failed"
        exit 1
    fi
    report "$prepare" ok
fi

passed=0
failed=0
failed_names=""
for suite in "$@"; do
    run_target "$suite"
    if [ "$rc" -eq 0 ]; then
        passed=$((passed + 1))
        report "$suite" pass
    else
        failed=$((failed + 1))
        failed_names="$failed_names $suite"
        report "$suite" FAIL
    fi
done
[ -z "$failed_names" ] || echo "failed suites:$failed_names"
echo "suites: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
