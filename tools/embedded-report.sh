#!/bin/sh
# SPDX-License-Identifier: MIT
# make embedded-report: the numbers of docs/EMBEDDED.md, measured again.
#   embedded-report.sh BUILD SHARED
# Code size (arm-none-eabi-size of the smallest firmware without and with a
# solver), stack (the static bound from GCC's call graph, and the painted
# stack under QEMU), instructions (the self-test under qemu-system-arm
# -icount shift=0), accuracy of each scalar type against double on the
# shared benchmark (avatargw-ikcompare) and bit-exactness across targets
# (tests/check-embedded.sh). Prints Markdown, also kept in
# BUILD/embedded/report.md. The images are built by the make target.
set -eu
BUILD=${1:-build}
SHARED=${2:-../shared}
E=$BUILD/embedded
OUT=$E/report.md
QEMU="-nographic -monitor none -serial null -chardev stdio,id=sh0 -semihosting-config enable=on,target=native,chardev=sh0"
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT

machine() {
	case $1 in
	m0q*) echo microbit ;;
	m3q*) echo mps2-an385 ;;
	*) echo mps2-an386 ;;
	esac
}

text() { arm-none-eabi-size "$1" | awk 'NR == 2 {print $1}'; }

report() {
	echo "# IK core on microcontrollers: measurements"
	echo
	echo "$(date -u +%Y-%m-%d), $(uname -m) host; $(arm-none-eabi-gcc --version | head -n 1);" \
		"$(aarch64-linux-gnu-gcc --version | head -n 1); $(qemu-system-arm --version | head -n 1)."
	echo
	echo "## Code size (bytes of flash: text + data)"
	echo
	echo "The smallest firmware (tests/embedded/min.c: start-up, one solve of a volatile target) built"
	echo "without a solver, with the paper's Newton iteration (ik_newton) and with avatargw's solver"
	echo "(ik_solve); the difference is what the IK core adds, libgcc's helpers included. -Os,"
	echo "-ffunction-sections, --gc-sections; the second figure with -flto."
	echo
	echo "| target | scalar | no solver | + paper's Newton | + avatargw's solver | Newton adds | solver adds |"
	echo "|---|---|---|---|---|---|---|"
	for c in m0q m3q m4q m4ff; do
		case $c in
		m0q) t="Cortex-M0" s="Q5.26" ;;
		m3q) t="Cortex-M3" s="Q5.26" ;;
		m4q) t="Cortex-M4F" s="Q5.26" ;;
		m4ff) t="Cortex-M4F" s="float (+ newlib libm)" ;;
		esac
		n0=$(text "$E/min-$c-none.elf") n1=$(text "$E/min-$c-newton.elf") n2=$(text "$E/min-$c-solve.elf")
		l0=$(text "$E/min-${c}l-none.elf") l1=$(text "$E/min-${c}l-newton.elf") l2=$(text "$E/min-${c}l-solve.elf")
		echo "| $t | $s | $n0 / $l0 | $n1 / $l1 | $n2 / $l2 | $((n1 - n0)) / $((l1 - l0)) | $((n2 - n0)) / $((l2 - l0)) |"
	done
	echo
	soft=$(arm-none-eabi-nm "$E/min-m0q-solve.elf" "$E/ikt-m0q.elf" | awk '{print $NF}' |
		grep -E '^__aeabi_[fd]|^__(add|sub|mul|div|neg|fix|float|extend|trunc)[a-z]*[sd]f[0-9]?$' | sort -u | tr '\n' ' ' || true)
	echo "Soft-float helpers in the Cortex-M0 images: ${soft:-none}."
	echo "libgcc helpers in the Cortex-M0 solver image: $(arm-none-eabi-nm "$E/min-m0q-solve.elf" |
		awk '$NF ~ /^__/ {print $NF}' | grep -v -E '^__(data|bss|stack)' | sort -u | tr '\n' ' ')"
	echo
	echo "## Stack"
	echo
	echo "Static bound: the deepest call path from GCC's call graph (-fcallgraph-info=su,"
	echo "tools/stack-depth.py; libgcc's leaf helpers not counted). Measured: the stack painted before"
	echo "each solve of the self-test and scanned after it, under QEMU (largest over all solves), and the"
	echo "high-water mark of the whole self-test program."
	echo
	echo "| target | scalar | ik_solve, bound | ik_newton, bound | ik_solve/ik_newton, measured | whole self-test, measured |"
	echo "|---|---|---|---|---|---|"
	for c in m0q m3q m4q m4ff; do
		case $c in
		m0q) t="Cortex-M0" s="Q5.26" suf=_q ;;
		m3q) t="Cortex-M3" s="Q5.26" suf=_q ;;
		m4q) t="Cortex-M4F" s="Q5.26" suf=_q ;;
		m4ff) t="Cortex-M4F" s="float" suf=_f ;;
		esac
		cis=$(ls "$E/$c"/*.ci | grep -v -E '/(ikt|ikt_mcu|min-[a-z]*)\.ci$')
		b1=$(tools/stack-depth.py --indirect kin_dq_eval,kin_dq_eval_tol "ik_solve$suf" $cis | sed -n 's/.*: \([0-9]*\) bytes at most/\1/p')
		b2=$(tools/stack-depth.py --indirect kin_dq_eval,kin_dq_eval_tol "ik_newton$suf" $cis | sed -n 's/.*: \([0-9]*\) bytes at most/\1/p')
		# shellcheck disable=SC2086
		qemu-system-arm -M "$(machine $c)" $QEMU -kernel "$E/ikt-$c.elf" >"$tmp" 2>&1 || true
		m1=$(sed -n 's/^ikt: stack used by ik_solve\/ik_newton: \([0-9]*\) bytes/\1/p' "$tmp")
		m2=$(sed -n 's/^ikt: stack high-water mark of the whole program: \([0-9]*\) bytes/\1/p' "$tmp")
		echo "| $t | $s | $b1 | $b2 | $m1 | $m2 |"
	done
	echo
	echo "Deepest path of ik_solve on the Cortex-M0:"
	echo
	echo '```'
	tools/stack-depth.py --indirect kin_dq_eval,kin_dq_eval_tol ik_solve_q \
		$(ls "$E/m0q"/*.ci | grep -v -E '/(ikt|ikt_mcu|min-[a-z]*)\.ci$')
	echo '```'
	echo
	echo "## Instructions"
	echo
	echo "The self-test under qemu-system-arm -icount shift=0 (one instruction = 1 ns of virtual time;"
	echo "SysTick counts the board's clock, calibrated against a loop of known length): means over its"
	echo "benchmark rows. Instructions, not cycles."
	echo
	echo "| target | scalar | Newton iteration | warm solve (trajectory) | reset solve (random), mean / max | paper's Newton from 0 |"
	echo "|---|---|---|---|---|---|"
	for c in m0q m3q m4q m4ff; do
		case $c in
		m0q) t="Cortex-M0" s="Q5.26" ;;
		m3q) t="Cortex-M3" s="Q5.26" ;;
		m4q) t="Cortex-M4F" s="Q5.26" ;;
		m4ff) t="Cortex-M4F" s="float" ;;
		esac
		# shellcheck disable=SC2086
		qemu-system-arm -M "$(machine $c)" $QEMU -icount shift=0 -kernel "$E/ikt-$c.elf" >"$tmp" 2>&1 || true
		it=$(sed -n 's/^ikt: instructions per Newton iteration.*: mean \([0-9]*\), max.*/\1/p' "$tmp")
		wm=$(sed -n 's/^ikt: instructions per solve, trajectory, warm: mean \([0-9]*\), max.*/\1/p' "$tmp")
		rs=$(sed -n 's/^ikt: instructions per solve, random targets, reset: mean \([0-9]*\), max \([0-9]*\).*/\1 \/ \2/p' "$tmp")
		nw=$(sed -n "s/^ikt: instructions per solve, paper's Newton from q = 0: mean \([0-9]*\), max.*/\1/p" "$tmp")
		echo "| $t | $s | $it | $wm | $rs | $nw |"
	done
	echo
	echo "## Accuracy against double (x86-64, the whole benchmark)"
	echo
	for cfg in "targets reset dq" "trajectory warm dq" "trajectory reset dq" "targets reset newton-dq"; do
		# shellcheck disable=SC2086
		set -- $cfg
		echo "### $1.csv, $2, $3"
		echo
		"$BUILD/avatargw-ikcompare" --targets "$SHARED/bench/$1.csv" --mode "$2" --solver "$3" | grep '^|'
		echo
	done
	echo "## Bit-exactness"
	echo
	echo '```'
	BUILD=$BUILD tests/check-embedded.sh | grep -E '^   (Q5.26|double|float):|^check-embedded|no soft-float' | sed 's/^ *//'
	echo '```'
}

report | tee "$OUT"
echo
echo "(kept in $OUT)"
