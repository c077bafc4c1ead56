#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs every test binary given, shows its output (cmocka writes its summary
# to stderr, so both streams go to stdout), and ends with one line
# "N passed, N failed" counting the individual tests of all binaries.
# Exits non-zero if any test failed or any binary did not finish cleanly.
passed=0
failed=0
status=0
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for t in "$@"; do
	echo "== $t"
	"$t" >"$out" 2>&1
	rc=$?
	cat "$out"
	p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$out" | awk '{s+=$1} END {print s+0}')
	f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' "$out" | awk '{s+=$1} END {print s+0}')
	passed=$((passed + p))
	failed=$((failed + f))
	if [ "$rc" -ne 0 ]; then
		status=1
		if [ "$f" -eq 0 ]; then
			echo "!! $t exited with status $rc"
			failed=$((failed + 1))
		fi
	fi
done
echo "tests: $passed passed, $failed failed"
exit $status
