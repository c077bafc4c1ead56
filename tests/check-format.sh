#!/bin/sh
# SPDX-License-Identifier: MIT
# Every C and C++ file of the tree is as clang-format (.clang-format) writes it.
# Fix with: git ls-files '*.c' '*.h' '*.cpp' | xargs clang-format -i
cd "$(dirname "$0")/.." || exit 1
if ! command -v clang-format >/dev/null 2>&1; then
	echo "check-format: FAIL: clang-format is not installed (tools/install-deps.sh installs it)"
	exit 1
fi
files=$(git ls-files '*.c' '*.h' '*.cpp' 2>/dev/null || find src include tools tests -name '*.[ch]' -o -name '*.cpp')
# one clang-format for every file (a process per file takes several times as long);
# each of its complaints begins with the file's name
# shellcheck disable=SC2086
out=$(clang-format --dry-run --Werror $files 2>&1 >/dev/null)
rc=$?
bad=$(printf '%s\n' "$out" | sed -n 's/^\([^: ]*\):[0-9]*:[0-9]*: .*/\1/p' | sort -u)
[ "$rc" -ne 0 ] && [ -z "$bad" ] && bad="(clang-format: $(printf '%s\n' "$out" | head -n 1))"
if [ -n "$bad" ]; then
	echo "check-format: FAIL: not clang-format clean:" $bad
	echo "check-format: fix with: clang-format -i FILE"
	exit 1
fi
echo "check-format: $(echo "$files" | wc -w) C/C++ files are clang-format clean"
