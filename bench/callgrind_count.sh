#!/bin/sh
# callgrind_count.sh BENCH_FIXED_BINARY [POSES] [--check]
#
# Instructions per pose of the fixed-point and the single-precision paths on
# the host build, counted with valgrind --tool=callgrind (deterministic, unlike
# wall time). Each path runs one batch of POSES poses (default 10240) in
# bench_fixed's --callgrind mode; collection is switched on only inside the
# batch function (--toggle-collect), so set-up and the program's start are not
# counted. Prints one JSON object per line (as the other benchmarks), then the
# fixed/f32 ratios. With --check, exits 1 if the point + Jacobian ratio is
# above the target 1.5 (the limit).
set -eu
bin=$1
poses=${2:-10240}
check=${3:-}
target=1.5
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if ! command -v valgrind >/dev/null 2>&1; then
    echo "callgrind_count: valgrind not found" >&2
    exit 1
fi

# count PATH FUNCTION -> total instructions executed inside FUNCTION
count() {
    if ! valgrind --tool=callgrind --callgrind-out-file="$tmp/out.$1" --toggle-collect="$2" \
        "$bin" --callgrind "$1" "$poses" >/dev/null 2>"$tmp/log.$1"; then
        cat "$tmp/log.$1" >&2
        echo "callgrind_count: $bin --callgrind $1 failed" >&2
        exit 1
    fi
    awk '/^summary:/ {print $2}' "$tmp/out.$1"
}

# emit NAME WHAT TOTAL
emit() {
    awk -v name="$1" -v what="$2" -v total="$3" -v n="$poses" 'BEGIN {
        printf "{\"bench\": \"%s\", \"what\": \"%s\", \"instructions_per_pose\": %.1f, \"poses\": %d, \"tool\": \"valgrind --tool=callgrind\"}\n", name, what, total / n, n }'
}

# ratio NAME FIXED F32 -> prints the line, leaves the ratio in $tmp/ratio.NAME
ratio() {
    awk -v name="$1" -v q="$2" -v f="$3" -v t="$target" 'BEGIN {
        r = q / f
        printf "{\"bench\": \"%s\", \"what\": \"instructions fixed / f32, same poses\", \"ratio\": %.3f, \"target_max\": %.1f, \"meets_target\": %s}\n", name, r, t, (r <= t) ? "true" : "false" }'
}

q_pj=$(count q aacmm_batch_bam_q)
f_pj=$(count f32 aacmm_batch_angles_f32)
q_p=$(count q-point aacmm_batch_bam_q)
f_p=$(count f32-point aacmm_batch_angles_f32)
q_c=$(count q-counts aacmm_batch_counts_q)
f_c=$(count f32-counts aacmm_batch_counts_f32)

emit fixed.icount_point_jacobian_q "probe point + 3x25 Jacobian, fixed point, from binary angles" "$q_pj"
emit fixed.icount_point_jacobian_f32 "probe point + 3x25 Jacobian, single, from float rad" "$f_pj"
emit fixed.icount_point_q "probe point, fixed point" "$q_p"
emit fixed.icount_point_f32 "probe point, single" "$f_p"
emit fixed.icount_counts_point_jacobian_q "32-bit counts -> point + Jacobian, fixed point" "$q_c"
emit fixed.icount_counts_point_jacobian_f32 "32-bit counts -> point + Jacobian, single" "$f_c"
ratio fixed.icount_ratio_point_jacobian "$q_pj" "$f_pj"
ratio fixed.icount_ratio_point "$q_p" "$f_p"
ratio fixed.icount_ratio_counts_point_jacobian "$q_c" "$f_c"

if [ "$check" = "--check" ]; then
    if ! awk -v q="$q_pj" -v f="$f_pj" -v t="$target" 'BEGIN { exit !(q / f <= t) }'; then
        echo "callgrind_count: fixed point + Jacobian needs more than ${target}x the f32 instructions" >&2
        exit 1
    fi
    echo "callgrind_count: fixed/f32 instructions for point + Jacobian within ${target}x"
fi
