#!/bin/sh
# SPDX-License-Identifier: MIT
# Checks the installed systemd files of avatargw without installing anything
# on this machine:
#
#   1. `make install DESTDIR=<temp> PREFIX=/usr` stages an install;
#   2. `systemd-analyze verify` on the staged unit, with ExecStart pointed at
#      the staged daemon (verify insists the program exists) and MANPATH at
#      the staged man pages (verify also looks up Documentation=): it must
#      print nothing;
#   3. `systemd-analyze security --offline=yes`: the overall exposure must be
#      at most 2.0 (docs/SERVICE.md records the score and why each remaining
#      item is there);
#   4. the staged sysusers.d file parses (systemd-sysusers --dry-run), and the
#      udev rules too where `udevadm verify` exists (systemd 253 and later).
#
# usage: tests/service/verify-unit.sh [MAKEVAR=VALUE]...   (passed to make install, e.g. SAN=1;
# under `make test` the make variables of the outer make reach it through MAKEFLAGS)
# Exit status: 0 passed, 1 failed, 77 skipped (systemd-analyze not installed;
# Debian package: systemd).
set -u

MAX_EXPOSURE=20 # tenths: 2.0

root=$(cd "$(dirname "$0")/../.." && pwd)
if ! command -v systemd-analyze >/dev/null 2>&1; then
	echo "SKIPPED: systemd-analyze not installed"
	exit 77
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
stage=$tmp/stage
status=0
fail() {
	echo "verify-unit: FAIL: $*"
	status=1
}

# ---- 1. stage ------------------------------------------------------------------
if ! make -C "$root" --no-print-directory install DESTDIR="$stage" PREFIX=/usr "$@" >"$tmp/install.log" 2>&1; then
	cat "$tmp/install.log"
	echo "verify-unit: FAIL: make install DESTDIR=$stage PREFIX=/usr"
	exit 1
fi
unit=$stage/usr/lib/systemd/system/avatargw.service
for f in "$unit" "$stage/usr/sbin/avatargw" "$stage/usr/lib/sysusers.d/avatargw.conf" \
	"$stage/usr/lib/udev/rules.d/60-avatargw.rules" "$stage/usr/share/man/man8/avatargw.8" \
	"$stage/usr/share/man/man5/avatargw.conf.5" "$stage/etc/avatargw/avatargw.conf"; do
	[ -e "$f" ] || fail "make install did not install ${f#"$stage"}"
done
[ -f "$unit" ] || exit 1
echo "verify-unit: staged an install in $stage"
if grep -q '@[a-z]*dir@' "$unit"; then
	fail "placeholders left in the installed unit: $(grep '@[a-z]*dir@' "$unit")"
fi
if ! grep -q '^ExecStart=/usr/sbin/avatargw ' "$unit"; then
	fail "the installed unit does not start /usr/sbin/avatargw: $(grep '^ExecStart=' "$unit")"
fi
# settings that would break the daemon or open the devices to everyone
if grep -E '^[[:space:]]*(RestrictRealtime=(yes|true|on|1)|PrivateDevices=(yes|true|on|1))' "$unit"; then
	fail "RestrictRealtime= or PrivateDevices= is on: SCHED_FIFO or the trackers would break"
fi
if grep -v '^[[:space:]]*#' "$stage/usr/lib/udev/rules.d/60-avatargw.rules" | grep -E 'MODE="0?666"|uaccess'; then
	fail "60-avatargw.rules gives access to everyone or to the seat user: use GROUP=\"avatargw\", MODE=\"0660\""
fi

# ---- 2. verify -------------------------------------------------------------------
mkdir -p "$tmp/unit"
copy=$tmp/unit/avatargw.service
sed "s|^ExecStart=/usr/sbin/avatargw|ExecStart=$stage/usr/sbin/avatargw|" "$unit" >"$copy"
if command -v man >/dev/null 2>&1; then
	out=$(MANPATH=$stage/usr/share/man systemd-analyze verify "$copy" 2>&1)
	rc=$?
else
	echo "verify-unit: man is not installed: Documentation= not checked (--man=no)"
	out=$(systemd-analyze verify --man=no "$copy" 2>&1)
	rc=$?
fi
if [ "$rc" -ne 0 ] || [ -n "$out" ]; then
	printf '%s\n' "$out"
	fail "systemd-analyze verify (exit status $rc)"
else
	echo "verify-unit: systemd-analyze verify: no complaint"
fi

# ---- 3. security -----------------------------------------------------------------
if ! systemd-analyze security --help 2>&1 | grep -q -- '--offline'; then
	echo "verify-unit: this systemd-analyze cannot rate a unit file offline (systemd 250 or later can): exposure not checked"
else
	opt=
	if systemd-analyze security --help 2>&1 | grep -q -- '--threshold'; then
		opt=--threshold=$MAX_EXPOSURE
	fi
	out=$(systemd-analyze security --offline=yes $opt --no-pager "$copy" 2>&1)
	rc=$?
	# the items that still count (marked ✗, or - in a non-UTF-8 locale)
	printf '%s\n' "$out" | grep -E '^(✗|- )' | sed 's/^/  /'
	line=$(printf '%s\n' "$out" | grep 'Overall exposure level')
	level=$(printf '%s\n' "$line" | sed -n 's/.*: \([0-9][0-9]*\)\.\([0-9]\).*/\1\2/p')
	if [ -z "$level" ]; then
		printf '%s\n' "$out"
		fail "no overall exposure level in the output of systemd-analyze security"
	elif [ "$level" -gt "$MAX_EXPOSURE" ] || { [ -n "$opt" ] && [ "$rc" -ne 0 ]; }; then
		fail "exposure ${line#*: } is above $((MAX_EXPOSURE / 10)).$((MAX_EXPOSURE % 10))"
	else
		echo "verify-unit: systemd-analyze security: exposure ${line#*: } (at most $((MAX_EXPOSURE / 10)).$((MAX_EXPOSURE % 10)))"
	fi
fi

# ---- 4. sysusers and udev --------------------------------------------------------
if command -v systemd-sysusers >/dev/null 2>&1; then
	mkdir -p "$tmp/sysroot"
	if out=$(systemd-sysusers --dry-run --root="$tmp/sysroot" "$stage/usr/lib/sysusers.d/avatargw.conf" 2>&1) &&
		printf '%s\n' "$out" | grep -q "Creating user 'avatargw'"; then
		echo "verify-unit: sysusers.d file creates the user avatargw"
	else
		printf '%s\n' "$out"
		fail "systemd-sysusers --dry-run on avatargw.conf"
	fi
fi
if udevadm verify --help >/dev/null 2>&1; then
	if ! udevadm verify "$stage/usr/lib/udev/rules.d/60-avatargw.rules"; then
		fail "udevadm verify 60-avatargw.rules"
	fi
else
	echo "verify-unit: udev rules not checked (udevadm verify needs systemd 253 or later)"
fi

if [ "$status" -eq 0 ]; then
	echo "verify-unit: PASS"
else
	echo "verify-unit: FAIL"
fi
exit $status
