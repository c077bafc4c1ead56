#!/bin/sh
# SPDX-License-Identifier: MIT
# The layers of src/ include one way only (docs/HACKING.md): each folder may
# include the folders listed for it and nothing above. The IK core (src/ik,
# include/ik) is pure: it includes nothing of the daemon's.
cd "$(dirname "$0")/.." || exit 1
status=0
# folder: the folders it may include (besides itself, include/avatargw and include/ik)
allowed() {
	case $1 in
	base) echo "" ;;
	config) echo "base" ;;
	wire) echo "base config" ;;
	record) echo "base config wire" ;;
	trackers) echo "base config wire record" ;;
	frames) echo "base config wire trackers" ;;
	publish) echo "base config wire frames" ;;
	sites) echo "base config wire frames publish" ;;
	daemon) echo "base config wire record trackers frames publish sites" ;;
	ik) echo "" ;;
	*) echo "?" ;;
	esac
}
for dir in src/*/; do
	layer=$(basename "$dir")
	ok=$(allowed "$layer")
	if [ "$ok" = "?" ]; then
		echo "check-layers: FAIL: src/$layer is no layer of docs/HACKING.md (add it to tests/check-layers.sh and the doc)"
		status=1
		continue
	fi
	for f in "$dir"*.[ch]; do
		[ -e "$f" ] || continue
		for inc in $(sed -n 's/^#include "\([a-z_]*\)\/.*/\1/p' "$f" | sort -u); do
			[ "$inc" = "$layer" ] && continue
			[ "$inc" = avatargw ] && continue
			[ "$inc" = ik ] && [ "$layer" != ik ] && continue
			case " $ok " in
			*" $inc "*) ;;
			*)
				echo "check-layers: FAIL: $f includes $inc/ (src/$layer may include: ${ok:-nothing})"
				status=1
				;;
			esac
		done
	done
done
# the IK core's public headers include only each other
if grep -l '#include "' include/ik/*.h | xargs grep -h '#include "' | grep -v '#include "ik/' >/dev/null; then
	echo "check-layers: FAIL: include/ik includes something outside the IK core:"
	grep -n '#include "' include/ik/*.h | grep -v '#include "ik/'
	status=1
fi
[ $status -eq 0 ] && echo "check-layers: every include of src/ goes down the layers (base, config, wire, record, trackers, frames, publish, daemon; ik pure)"
exit $status
