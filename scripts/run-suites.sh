#!/bin/sh
# Runs each named make target as one test suite, keeps going past failures, and
# ends with one line: "suites: N passed, M failed" (CI reads it). Exit status 1
# if any failed.
#
# Usage: run-suites.sh [--prepare TARGETS] [--alone SUITES] SUITE...
#
# Each suite's own output (compiler lines, pytest dots, fuzzer progress, ...)
# goes to $TEST_LOG_DIR/<suite>.log (default build/test-logs); the terminal
# gets one line per suite as it ends: name, result, seconds. A failed suite
# also shows where its log is and the last $TEST_TAIL lines of it (default 40).
#
# --prepare TARGETS (one word or a quoted list) runs first, one at a time, the
# same way (not counted as suites; if one fails, nothing else runs). When suites
# run side by side, a line "build" then makes every prerequisite the suites have
# in make's database (one make, $TEST_JOBS jobs; each file once), so that two
# suites never build the same file.
#
# Suites run $TEST_JOBS at a time (default: 2, or 1 on a one-core machine):
# most are one Python or C process, and two cores take two of them. Each suite
# gets its own $XDG_RUNTIME_DIR ($TEST_LOG_DIR/run/<suite>), so simulators that
# two suites start never find each other. The suites named by --alone (a quoted
# list; those whose tests measure time against a browser or a VM) run after the
# others, one at a time. TEST_VERBOSE=1 runs everything one at a time and also
# streams every suite's output to the terminal. $TEST_LOG_DIR/summary.tsv lists
# name, result and seconds of the last run, in the order the suites were named.
set -u
LOG_DIR=${TEST_LOG_DIR:-build/test-logs}
TAIL=${TEST_TAIL:-40}
VERBOSE=${TEST_VERBOSE:-0}

prepare=""
alone=""
while :; do
    case "${1:-}" in
    --prepare) prepare=${2:?--prepare needs a target}; shift 2 ;;
    --alone) alone=${2?--alone needs a list}; shift 2 ;;
    *) break ;;
    esac
done

if [ -n "${TEST_JOBS:-}" ]; then
    JOBS=$TEST_JOBS
else
    JOBS=$(nproc 2>/dev/null || echo 1)
    [ "$JOBS" -gt 2 ] && JOBS=2
fi
case "$JOBS" in '' | *[!0-9]* | 0) echo "run-suites: TEST_JOBS must be a positive number" >&2; exit 2 ;; esac
[ "$VERBOSE" = 1 ] && JOBS=1

mkdir -p "$LOG_DIR/run" || exit 1
LOG_DIR=$(cd "$LOG_DIR" && pwd) # absolute: suites may change directory
summary="$LOG_DIR/summary.tsv"
results="$LOG_DIR/.results"
: >"$results"

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }

# suite_env NAME: the suite's own runtime folder (0700, as XDG asks).
suite_env() {
    rundir="$LOG_DIR/run/$1"
    rm -rf "$rundir" && mkdir -m 700 -p "$rundir"
}

# run_fg NAME [TARGET...]: runs `make NAME` (or `make TARGET...`) in the foreground
# into NAME's log; sets rc and secs.
run_fg() {
    name=$1
    shift
    [ "$#" -eq 0 ] && set -- "$name"
    log="$LOG_DIR/$name.log"
    suite_env "$name"
    if [ "$VERBOSE" = 1 ]; then
        echo "=== suite $name"
    fi
    t0=$(now)
    if [ "$VERBOSE" = 1 ]; then
        rcfile="$LOG_DIR/.$name.rc"
        { XDG_RUNTIME_DIR=$rundir make --no-print-directory "$@" 2>&1; echo $? >"$rcfile"; } | tee "$log"
        rc=$(cat "$rcfile")
        rm -f "$rcfile"
    else
        XDG_RUNTIME_DIR=$rundir make --no-print-directory "$@" >"$log" 2>&1
        rc=$?
    fi
    secs=$(elapsed "$t0" "$(now)")
}

# start_bg NAME: starts `make NAME` in the background; it leaves "RC SECONDS" in
# $LOG_DIR/.NAME.done when it ends.
start_bg() {
    suite_env "$1"
    rm -f "$LOG_DIR/.$1.done"
    (
        t0=$(now)
        XDG_RUNTIME_DIR=$rundir make --no-print-directory "$1" >"$LOG_DIR/$1.log" 2>&1
        r=$?
        echo "$r $(elapsed "$t0" "$(now)")" >"$LOG_DIR/.$1.tmp" && mv "$LOG_DIR/.$1.tmp" "$LOG_DIR/.$1.done"
    ) &
}

# report NAME RESULT: one line for the suite (on failure: where its log is, and its tail).
report() {
    printf '  %-28s %-5s %7s s\n' "$1" "$2" "$secs"
    printf '%s\t%s\t%s\n' "$1" "$2" "$secs" >>"$results"
    if [ "$2" = FAIL ]; then
        echo "    log: $LOG_DIR/$1.log (last $TAIL lines:)"
        tail -n "$TAIL" "$LOG_DIR/$1.log" | sed 's/^/    | /'
    fi
}

passed=0
failed=0
failed_names=""
# counted NAME: report a finished suite (rc and secs set) and count it.
counted() {
    if [ "$rc" -eq 0 ]; then
        passed=$((passed + 1))
        report "$1" pass
    else
        failed=$((failed + 1))
        failed_names="$failed_names $1"
        report "$1" FAIL
    fi
}

is_alone() {
    for a in $alone; do [ "$a" = "$1" ] && return 0; done
    return 1
}

# The summary in the order the suites were named (the terminal has them as they ended).
write_summary() {
    printf 'suite\tresult\tseconds\n' >"$summary"
    for s in $prepare build "$@"; do
        grep "^$s	" "$results" | tail -n 1 >>"$summary"
    done
    rm -f "$results"
}

echo "make test: $# suites, $JOBS at a time; the output of each goes to $LOG_DIR/<suite>.log"
for p in $prepare; do
    run_fg "$p"
    if [ "$rc" -ne 0 ]; then
        report "$p" FAIL
        echo "suites: 0 passed, $# failed"
        write_summary "$@"
        exit 1
    fi
    report "$p" ok
done

# What the suites build before they run (their prerequisites in make's
# database: files, `sim`, ...), built here one at a time: two suites that run
# side by side and share an object file must not both write it.
prerequisites() {
    make -pRrq : 2>/dev/null | awk -v names=" $* " '
        /^[A-Za-z0-9_.-]+:/ && $0 !~ /=/ {
            t = substr($1, 1, length($1) - 1)
            if (index(names, " " t " ") == 0) next
            for (i = 2; i <= NF; i++) if ($i != "|" && index(names, " " $i " ") == 0) print $i
        }' | sort -u | tr '\n' ' '
}
if [ "$JOBS" -gt 1 ]; then
    deps=$(prerequisites "$@")
    for p in $prepare; do deps=$(echo " $deps " | sed "s/ $p / /g"); done
    if [ -n "$(echo $deps)" ]; then
        # make runs them $JOBS at a time itself (one make: each file built once);
        # if that fails, once more one at a time, so that a failure is a real one
        # and its log reads in order.
        # shellcheck disable=SC2086 # a list of make targets
        run_fg build -j"$JOBS" $deps
        [ "$rc" -ne 0 ] && run_fg build $deps
        if [ "$rc" -ne 0 ]; then
            report build FAIL
            echo "suites: 0 passed, $# failed"
            write_summary "$@"
            exit 1
        fi
        report build ok
    fi
fi

if [ "$JOBS" -eq 1 ]; then
    for suite in "$@"; do is_alone "$suite" || { run_fg "$suite"; counted "$suite"; }; done
else
    running=""
    pending=""
    for suite in "$@"; do is_alone "$suite" || pending="$pending $suite"; done
    while [ -n "$pending" ] || [ -n "$running" ]; do
        n=0
        for r in $running; do n=$((n + 1)); done
        if [ -n "$pending" ] && [ "$n" -lt "$JOBS" ]; then
            pending=${pending# }
            first=${pending%% *}
            case "$pending" in *" "*) pending=${pending#* } ;; *) pending="" ;; esac
            start_bg "$first"
            running="$running $first"
            continue
        fi
        still=""
        for r in $running; do
            if [ -f "$LOG_DIR/.$r.done" ]; then
                read -r rc secs <"$LOG_DIR/.$r.done"
                rm -f "$LOG_DIR/.$r.done"
                counted "$r"
            else
                still="$still $r"
            fi
        done
        running=$still
        [ -n "$running" ] && sleep 0.2
    done
    wait
fi
for suite in "$@"; do is_alone "$suite" && { run_fg "$suite"; counted "$suite"; }; done

write_summary "$@"
[ -z "$failed_names" ] || echo "failed suites:$failed_names"
echo "suites: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
