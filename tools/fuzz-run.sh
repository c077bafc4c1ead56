#!/bin/sh
# SPDX-License-Identifier: MIT
# fuzz-run.sh FUZZ_BUILD SEEDS NAME... - runs each harness FUZZ_BUILD/fuzz_NAME
# under libFuzzer for FUZZ_TIME seconds (default 60) from its seeds
# (tests/fuzz/corpus/NAME, SEEDS/NAME and what earlier runs found in
# FUZZ_BUILD/corpus/NAME, where new inputs go). A failing input is written
# to FUZZ_BUILD/crash/NAME/; the run goes on with the other harnesses, and
# the script exits 1 if any failed. FUZZ_FLAGS adds libFuzzer options.
set -u
[ $# -ge 3 ] || { echo "usage: $0 FUZZ_BUILD SEEDS NAME..." >&2; exit 2; }
fb=$1
seeds=$2
shift 2
time=${FUZZ_TIME:-60}
failed=""
total=0
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# UBSan stops at the first report (-fno-sanitize-recover), with a stack
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
for n in "$@"; do
	mkdir -p "$fb/corpus/$n" "$fb/crash/$n"
	dirs="$fb/corpus/$n"
	for d in "tests/fuzz/corpus/$n" "$seeds/$n"; do
		[ -d "$d" ] && dirs="$dirs $d"
	done
	echo "== fuzz_$n: $time s"
	# shellcheck disable=SC2086
	"$fb/fuzz_$n" -max_total_time="$time" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
		-artifact_prefix="$fb/crash/$n/" ${FUZZ_FLAGS:-} $dirs >"$log" 2>&1
	rc=$?
	execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
	cov=$(grep -E '^#[0-9]+.*(DONE|pulse|NEW|REDUCE)' "$log" | tail -n 1 | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
	total=$((total + ${execs:-0}))
	if [ "$rc" -ne 0 ]; then
		failed="$failed $n"
		tail -n 60 "$log"
		echo "!! fuzz_$n failed (exit $rc); the input: $(ls -t "$fb/crash/$n" | head -n 1 | sed "s|^|$fb/crash/$n/|")"
	else
		echo "fuzz_$n: ${execs:-?} executions, coverage ${cov:-?} edges, no failure"
	fi
done
echo "fuzz: $total executions in all${failed:+; FAILED:$failed}"
[ -z "$failed" ]
