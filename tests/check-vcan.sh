#!/bin/sh
# SPDX-License-Identifier: MIT
# check-vcan.sh - the CAN output and source on a real SocketCAN interface,
# with can-utils as the peer. Needs a vcan interface: $AVATARGW_VCAN, an
# existing vcan0, or one this script may create (root, vcan module). Where
# there is none (a kernel without CAN, like the CI's), it says so and exits
# 77 (skipped); the same code paths are tested over a socketpair by
# test_can and tests/e2e/test_can.py.
#
#  1. the daemon's can output (plain mode) on the interface: candump -L sees
#     each command's five frames in order, the STATUS counter counting up;
#  2. a daemon with a can source on it: canplayer replays
#     tests/data/can_sensors.log (the golden sensor frames) and cansend adds
#     one: the source counts them as test_can expects (3 poses, 3 unknown,
#     2 of a wrong length, 3 bad values).
set -u
me=check-vcan
build=${BUILD:-build}
bin=$build/avatargw
ctl=$build/avatargw-ctl

skip() {
	echo "$me: SKIPPED: $*"
	exit 77
}

[ -x "$bin" ] || { echo "$me: $bin not found: build it first"; exit 1; }
for t in candump cansend canplayer ip; do
	command -v "$t" >/dev/null 2>&1 || skip "$t not installed (can-utils, iproute2)"
done

created=""
iface=${AVATARGW_VCAN:-}
if [ -z "$iface" ]; then
	if [ -e /sys/class/net/vcan0 ]; then
		iface=vcan0
	elif ip link add dev agwvcan0 type vcan 2>/dev/null; then
		iface=agwvcan0
		created=$iface
	else
		why=$(ip link add dev agwvcan0 type vcan 2>&1)
		skip "no vcan interface here and none can be made (ip link add type vcan: $why); this kernel (\
$(uname -r)) probably has no CAN. The CAN code is tested over a socketpair instead (test_can, tests/e2e/test_can.py)."
	fi
fi
ip link set "$iface" up 2>/dev/null || true
[ -e "/sys/class/net/$iface" ] || skip "$iface does not exist"

tmp=$(mktemp -d)
pid=""
cleanup() {
	[ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
	[ -n "$created" ] && ip link del "$created" 2>/dev/null
	rm -rf "$tmp"
}
trap cleanup EXIT INT TERM

start_daemon() { # CONF
	rm -f "$tmp/ctl"
	"$bin" -c "$1" 2>"$tmp/daemon.err" &
	pid=$!
	i=0
	while [ ! -S "$tmp/ctl" ] && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
	[ -S "$tmp/ctl" ] || { echo "$me: the daemon did not start:"; cat "$tmp/daemon.err"; exit 1; }
}

stop_daemon() {
	kill "$pid"
	wait "$pid"
	rc=$?
	pid=""
	if [ "$rc" -ne 0 ]; then
		echo "$me: the daemon exited with $rc:"
		cat "$tmp/daemon.err"
		status=1
	fi
}

status=0
cat >"$tmp/out.conf" <<EOF
[daemon]
rate = 100
control_socket = $tmp/ctl
[source sim]
type = sim
people = 2
[avatar a]
person = sim/p0
count = 2
[output arm]
type = can
interface = $iface
safe = no
EOF
cat >"$tmp/in.conf" <<EOF
[daemon]
control_socket = $tmp/ctl
[source bus]
type = can
interface = $iface
sensors = 2
EOF

# 1. commands in order: 101 102 103 104 100 for avatar 0, the counter +1 each time
candump -L "$iface,100:7F0" >"$tmp/dump.log" 2>"$tmp/candump.err" &
dpid=$!
sleep 0.2
start_daemon "$tmp/out.conf"
sleep 1
kill "$dpid" 2>/dev/null
wait "$dpid" 2>/dev/null
stop_daemon
if ! awk '
	function hex(s,   i, v) { v = 0; for (i = 1; i <= length(s); i++) v = v * 16 + index("0123456789ABCDEF", substr(s, i, 1)) - 1; return v }
	{ split($3, a, "#"); id = a[1]; data = a[2] }
	id ~ /^10[0-4]$/ && started { seq = seq " " id }
	id == "100" {
		c = hex(substr(data, 1, 2))
		if (started && seq != " 101 102 103 104 100") bad = "frames" seq
		if (started && c != (last + 1) % 256) bad = "counter " c " after " last
		last = c; started = 1; seq = ""; n++
	}
	END { if (bad) { print "check-vcan: out of order: " bad; exit 1 } if (n < 3) { print "check-vcan: " n " commands"; exit 1 } }
' "$tmp/dump.log"; then
	echo "$me: candump -L $iface did not see the output's commands in order:"
	head -20 "$tmp/dump.log"
	status=1
else
	echo "$me: candump -L saw $(wc -l <"$tmp/dump.log") frames of the can output, in order"
fi

# 2. the golden sensor frames, replayed into a can source
start_daemon "$tmp/in.conf"
before=$("$ctl" -s "$tmp/ctl" status --json)
canplayer -I tests/data/can_sensors.log "$iface=vcan0" 2>"$tmp/canplayer.err" || {
	echo "$me: canplayer failed: $(cat "$tmp/canplayer.err")"
	status=1
}
cansend "$iface" 201#0000000000007F00 2>/dev/null # far from unit length: a bad value
sleep 0.3
after=$("$ctl" -s "$tmp/ctl" status --json)
stop_daemon
if ! python3 - "$before" "$after" <<'EOF'
import json, sys
b = {s["name"]: s for s in json.loads(sys.argv[1])["sources"]}["bus"]
a = {s["name"]: s for s in json.loads(sys.argv[2])["sources"]}["bus"]
d = {k: a["can"][k] - b["can"][k] for k in ("frames", "unknown_id", "bad_length", "bad_value")}
want = {"frames": 13, "unknown_id": 3, "bad_length": 2, "bad_value": 3}
ok = d == want and a["samples"] - b["samples"] == 3 and a["malformed"] - b["malformed"] == 5
print("check-vcan: the can source counted %s, %d poses, %d malformed%s" % (
    d, a["samples"] - b["samples"], a["malformed"] - b["malformed"], "" if ok else " (want %s, 3, 5)" % want))
sys.exit(0 if ok else 1)
EOF
then
	status=1
fi

[ "$status" -eq 0 ] && echo "$me: OK on $iface"
exit "$status"
