#!/bin/sh
# SPDX-License-Identifier: MIT
# make bench: the IK benchmark on the shared targets, every solver and mode,
# one JSON line per configuration (the middle of 3 runs by median time, kept
# in $BUILD/bench.jsonl) and a summary table.
set -eu
BUILD=${1:-build}
SHARED=${2:-../shared}
BENCH="$BUILD/avatargw-ikbench"
OUT="$BUILD/bench.jsonl"
T="$SHARED/bench/targets.csv"
J="$SHARED/bench/trajectory.csv"

for f in "$T" "$J"; do
	[ -r "$f" ] || { echo "bench: $f not found (set SHARED=path/to/shared)" >&2; exit 1; }
done
echo "machine: $(uname -srm), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; $(date -u +%Y-%m-%d)"
: >"$OUT"
# each configuration runs 3 times; the run with the middle median time is kept
run() {
	set_name=$1
	shift
	line=$(for i in 1 2 3; do "$BENCH" --quiet "$@"; done |
		awk -F'"median_us":' '{split($2, a, ","); print a[1], $0}' | sort -n | sed -n 2p | cut -d' ' -f2-)
	echo "$line" | sed "s/^{/{\"set\":\"$set_name\",/" >>"$OUT"
}
run random --targets "$T" --mode reset --solver dq
run random --targets "$T" --mode reset --solver matrix
run random --targets "$T" --mode reset --solver newton-dq
run random --targets "$T" --mode reset --solver newton-matrix
run trajectory --targets "$J" --mode warm --solver dq
run trajectory --targets "$J" --mode warm --solver matrix
run trajectory --targets "$J" --mode warm --solver newton-dq
run trajectory --targets "$J" --mode warm --solver newton-matrix
run trajectory --targets "$J" --mode reset --solver dq
run trajectory --targets "$J" --mode reset --solver newton-dq

printf '\n| set | mode | solver | strict %% | in-limits %% | jumps | Newton iters | median us | p99 us | max us |\n'
printf '|---|---|---|---|---|---|---|---|---|---|\n'
sed -e 's/[{}"]//g' -e 's/,/ /g' "$OUT" | awk '{
	for (i = 1; i <= NF; i++) { split($i, kv, ":"); v[kv[1]] = kv[2] }
	printf "| %s | %s | %s | %.2f | %.2f | %s | %.2f | %.2f | %.2f | %.1f |\n",
		v["set"], v["mode"], v["solver"], 100 * v["strict"], 100 * v["in_limits"], v["jumps"],
		v["iters_mean"], v["median_us"], v["p99_us"], v["max_us"]
}'
echo
echo "dual quaternions vs matrices (median time, matrix / dq):"
sed -e 's/[{}"]//g' -e 's/,/ /g' "$OUT" | awk '{
	for (i = 1; i <= NF; i++) { split($i, kv, ":"); v[kv[1]] = kv[2] }
	key = v["set"] "/" v["mode"]; s = v["solver"]; sub(/^newton-/, "paper Newton ", s)
	t[key, s] = v["median_us"]; keys[key] = 1
} END {
	for (k in keys) {
		if ((k, "dq") in t && (k, "matrix") in t)
			printf "  %s avatargw solver: %.2f\n", k, t[k, "matrix"] / t[k, "dq"]
		if ((k, "paper Newton dq") in t && (k, "paper Newton matrix") in t)
			printf "  %s paper Newton:    %.2f\n", k, t[k, "paper Newton matrix"] / t[k, "paper Newton dq"]
	}
}'
echo
echo "json lines: $OUT"
tail -n 1 "$OUT"
