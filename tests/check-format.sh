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
bad=$(for f in $files; do clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || echo "$f"; done)
if [ -n "$bad" ]; then
	echo "check-format: FAIL: not clang-format clean:" $bad
	echo "check-format: fix with: clang-format -i FILE"
	exit 1
fi
echo "check-format: $(echo "$files" | wc -w) C/C++ files are clang-format clean"
