#!/bin/sh
# SPDX-License-Identifier: MIT
# Checks the man pages in docs/man:
#
#   1. the key reference of avatargw.conf.5 (between its BEGIN KEYS and END
#      KEYS lines) is what tools/man-keys.sh makes of the daemon's current
#      key table, so that a key added or changed in src/config/config.c
#      without `tools/man-keys.sh --update` is caught;
#   2. both pages render without a warning (when man-db and groff are
#      installed; otherwise this part is skipped and said so).
#
# usage: tools/check-man.sh [-b BINARY]
#   BINARY defaults to $BUILD/avatargw (BUILD as make sets it for tests, else build);
#   it must be built beforehand.
# Exit status: 0 all good, 1 a page is stale or renders with warnings,
# 2 the check could not run (no daemon binary, no marker lines).
set -u

root=$(cd "$(dirname "$0")/.." && pwd)
case ${BUILD:-build} in
/*) bin=${BUILD}/avatargw ;;
*) bin=$root/${BUILD:-build}/avatargw ;;
esac
if [ "${1:-}" = "-b" ] && [ $# -ge 2 ]; then
	bin=$2
elif [ $# -gt 0 ]; then
	echo "usage: tools/check-man.sh [-b BINARY]" >&2
	exit 2
fi
page=$root/docs/man/avatargw.conf.5
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
status=0

if ! "$root/tools/man-keys.sh" -b "$bin" >"$tmp/fresh" 2>"$tmp/err"; then
	cat "$tmp/err" >&2
	echo "check-man: could not generate the key reference" >&2
	exit 2
fi
awk '
	/^\.\\" END KEYS/ { inside = 0; found++ }
	inside { print }
	/^\.\\" BEGIN KEYS/ { inside = 1; found++ }
	END { exit found == 2 ? 0 : 1 }
' "$page" >"$tmp/committed" || {
	echo "check-man: $page has no BEGIN KEYS / END KEYS comment lines" >&2
	exit 2
}
if diff -u "$tmp/committed" "$tmp/fresh" >"$tmp/diff"; then
	echo "check-man: docs/man/avatargw.conf.5 describes every key of $(basename "$bin") --keys"
else
	sed -e "s|$tmp/committed|docs/man/avatargw.conf.5 (committed)|" -e "s|$tmp/fresh|generated from $bin|" "$tmp/diff"
	echo "check-man: FAIL: the key reference in docs/man/avatargw.conf.5 is stale: run tools/man-keys.sh --update and commit it"
	status=1
fi

if command -v man >/dev/null 2>&1 && command -v groff >/dev/null 2>&1; then
	for p in "$root/docs/man/avatargw.8" "$root/docs/man/avatargw.conf.5"; do
		if ! MANWIDTH=80 man --warnings -l "$p" >/dev/null 2>"$tmp/warn" || [ -s "$tmp/warn" ]; then
			cat "$tmp/warn"
			echo "check-man: FAIL: $(basename "$p") does not render cleanly (MANWIDTH=80 man --warnings -l $p)"
			status=1
		else
			echo "check-man: $(basename "$p") renders without warnings"
		fi
	done
else
	echo "check-man: rendering not checked: man (man-db) or groff (groff-base) is not installed"
fi
exit $status
