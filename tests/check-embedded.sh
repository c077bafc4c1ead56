#!/bin/sh
# SPDX-License-Identifier: MIT
# The IK core's self-test (tests/embedded/ikt.c) on every target of
# docs/EMBEDDED.md: this machine (Q5.26, double, float), aarch64 Linux under
# qemu-user (Q5.26, double, float), Cortex-M0, M3 and M4F under
# qemu-system-arm with semihosting (Q5.26; float on the M4F). Each run must
# pass, and the Q5.26 results must be bit-identical everywhere (one hash of
# every solution). `make test` builds the images (tools/embedded.mk).
#
# Where the cross tools are missing the check says which and is skipped
# (exit 77), after running what it can. In CI (AVATARGW_CI=1, set by .ci/run,
# whose install step brings the tools) a missing tool is a failure.
set -u
BUILD=${BUILD:-build}
EMB=$BUILD/embedded
QEMU_ARM=${QEMU_ARM:-qemu-system-arm}
QEMU_A64=${QEMU_A64:-qemu-aarch64}
A64_SYSROOT=${A64_SYSROOT:-/usr/aarch64-linux-gnu}
ARM_CC=${ARM_CC:-arm-none-eabi-gcc}
A64_CC=${A64_CC:-aarch64-linux-gnu-gcc}
out=$(mktemp)
hashes=$(mktemp)
trap 'rm -f "$out" "$hashes"' EXIT
status=0
missing=""

have() { command -v "$1" >/dev/null 2>&1; }

# run NAME COMMAND...: the self-test's output, its verdict, its hash line
run() {
	name=$1
	shift
	echo "-- $name: $*"
	timeout 120 "$@" >"$out" 2>&1
	rc=$?
	sed 's/^/   /' "$out"
	if [ "$rc" -ne 0 ] || ! grep -q '^ikt: PASS$' "$out"; then
		echo "!! $name: the self-test failed (exit status $rc)"
		status=1
	fi
	sed -n "s/^ikt: hash \([^ ]*\) \([0-9a-f]\{8\}\)$/\1 \2 $name/p" "$out" >>"$hashes"
}

qemu_m() {
	run "$1 $2" "$QEMU_ARM" -M "$2" -nographic -monitor none -serial null \
		-chardev stdio,id=sh0 -semihosting-config enable=on,target=native,chardev=sh0 -kernel "$EMB/ikt-$1.elf"
}

for t in q d f; do
	run "host$t" "$EMB/ikt-host$t"
done

if have "$A64_CC" && have "$QEMU_A64" && [ -d "$A64_SYSROOT/lib" ]; then
	for t in q d f; do
		run "aarch64 $t" "$QEMU_A64" -L "$A64_SYSROOT" "$EMB/ikt-a64$t"
	done
else
	missing="$missing aarch64 ($A64_CC, $QEMU_A64, $A64_SYSROOT: gcc-aarch64-linux-gnu, libc6-dev-arm64-cross, qemu-user)"
fi

if have "$ARM_CC" && have "$QEMU_ARM"; then
	qemu_m m0q microbit
	qemu_m m3q mps2-an385
	qemu_m m4q mps2-an386
	qemu_m m4ff mps2-an386
	# the fixed-point Cortex-M0 image links no floating-point helper (it has no FPU)
	if [ -r "$EMB/ikt-m0q.elf" ]; then
		soft=$(arm-none-eabi-nm "$EMB/ikt-m0q.elf" | awk '{print $NF}' |
			grep -E '^__aeabi_[fd]|^__(add|sub|mul|div|neg|fix|float|extend|trunc)[a-z]*[sd]f[0-9]?$' | tr '\n' ' ')
		if [ -n "$soft" ]; then
			echo "!! cortex-m0, Q5.26: soft-float helpers linked: $soft"
			status=1
		else
			echo "-- cortex-m0, Q5.26: no soft-float helper linked"
		fi
	fi
else
	missing="$missing cortex-m ($ARM_CC, $QEMU_ARM: gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm)"
fi

# bit-exactness: one hash per scalar type, wherever it ran
echo "-- results by scalar type (hash of every solution):"
for type in $(awk '{print $1}' "$hashes" | sort -u); do
	n=$(awk -v t="$type" '$1 == t {print $2}' "$hashes" | sort -u | wc -l)
	where=$(awk -v t="$type" '$1 == t {name = $0; sub(/^[^ ]+ [^ ]+ /, "", name); printf "%s%s %s", sep, name, $2; sep = ", "}' "$hashes")
	if [ "$n" -eq 1 ]; then
		echo "   $type: identical on $where"
	elif [ "$type" = "Q5.26" ]; then
		echo "!! $type: results differ between targets: $where"
		status=1
	else
		# floating point may round differently on another FPU or libm; only fixed point promises bits
		echo "   $type: differs between targets (allowed): $where"
	fi
done
grep -q '^Q5.26 ' "$hashes" || { echo "!! no Q5.26 result"; status=1; }

if [ "$status" -ne 0 ]; then
	exit 1
fi
if [ -n "$missing" ]; then
	if [ "${AVATARGW_CI:-0}" = 1 ]; then
		echo "!! AVATARGW_CI=1 but tools are missing:$missing"
		exit 1
	fi
	echo "check-embedded: skipped in part, tools missing:$missing (tools/install-deps.sh installs them)"
	exit 77
fi
echo "check-embedded: every target passed; Q5.26 bit-identical everywhere"
exit 0
