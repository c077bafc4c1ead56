#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs every test given, shows its output (cmocka writes its summary to
# stderr, so both streams go to stdout), and ends with one line
# "N passed, N failed" counting the individual tests:
#   - cmocka binaries: their PASSED/FAILED counts;
#   - *.py: Python unittest files ("Ran N tests", failures and errors);
#   - *.sh: one check each; exit 0 passes, 77 is a skip (said aloud), else fails.
# Exits non-zero if any test failed or anything did not finish cleanly.
passed=0
failed=0
status=0
out=$(mktemp)
trap 'rm -f "$out"' EXIT
skipped=0
# Debian's interpreter, where Debian's Python packages (python3-pymodbus) are,
# even when another python3 comes first in PATH; PYTHON overrides.
PYTHON=${PYTHON:-$(command -v /usr/bin/python3 || command -v python3)}
for t in "$@"; do
	echo "== $t"
	case "$t" in
	*.py)
		"$PYTHON" -m unittest -v "$t" >"$out" 2>&1
		rc=$?
		cat "$out"
		n=$(sed -n 's/^Ran \([0-9]*\) test.*/\1/p' "$out" | tail -n 1)
		f=$(sed -n 's/^FAILED (\(.*\))$/\1/p' "$out" | tr ',' '\n' | sed -n 's/.*\(failures\|errors\)=\([0-9]*\).*/\2/p' | awk '{s+=$1} END {print s+0}')
		s=$(grep -c "skipped '" "$out")
		passed=$((passed + ${n:-0} - f - s))
		failed=$((failed + f))
		skipped=$((skipped + s))
		if [ "$rc" -ne 0 ]; then
			status=1
			[ "$f" -eq 0 ] && failed=$((failed + 1)) && echo "!! $t exited with status $rc"
		fi
		continue
		;;
	*.sh)
		"$t" >"$out" 2>&1
		rc=$?
		cat "$out"
		if [ "$rc" -eq 0 ]; then
			passed=$((passed + 1))
		elif [ "$rc" -eq 77 ]; then
			skipped=$((skipped + 1))
			echo "-- $t SKIPPED (see above)"
		else
			failed=$((failed + 1))
			status=1
			echo "!! $t failed with status $rc"
		fi
		continue
		;;
	esac
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
[ "$skipped" -gt 0 ] && echo "tests: $skipped skipped (each said why above)"
echo "tests: $passed passed, $failed failed"
exit $status
