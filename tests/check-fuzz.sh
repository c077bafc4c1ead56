#!/bin/sh
# SPDX-License-Identifier: MIT
# The fuzz harnesses' corpus run (docs/FUZZING.md): every harness of
# tests/fuzz, built with the normal compiler and flags (also under SAN=1) and
# our own driver instead of libFuzzer, runs once over every input of its
# committed corpus (tests/fuzz/corpus/NAME: hand-made seeds and every input
# that once broke it) and of the seeds made from the test data
# ($BUILD/fuzz/seeds/NAME, tools/fuzz-seeds.sh). Fails if an input breaks an
# invariant or a sanitizer fires. make test builds both first.
cd "$(dirname "$0")/.."
build=${BUILD:-build}
status=0
n=0
for src in tests/fuzz/fuzz_*.c; do
	name=$(basename "$src" .c)
	name=${name#fuzz_}
	bin="$build/fuzz/fuzz_$name"
	if [ ! -x "$bin" ]; then
		echo "!! $bin missing (make test builds it)"
		status=1
		continue
	fi
	set --
	for d in "tests/fuzz/corpus/$name" "$build/fuzz/seeds/$name"; do
		[ -d "$d" ] && set -- "$@" "$d"
	done
	if [ $# -eq 0 ]; then
		echo "!! fuzz_$name: no corpus (tests/fuzz/corpus/$name or $build/fuzz/seeds/$name)"
		status=1
		continue
	fi
	if ! "$bin" "$@"; then
		echo "!! fuzz_$name: an input of its corpus fails (above)"
		status=1
	fi
	n=$((n + 1))
done
echo "check-fuzz: $n harnesses over their corpora"
exit $status
