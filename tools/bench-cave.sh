#!/bin/sh
# SPDX-License-Identifier: MIT
# make bench, third part: the network trackers of CAVEs (docs/TRACKERS.md).
#   1. report arrival -> datagram sent, one avatar at 240 Hz, for a source whose reports come from a
#      device thread: a Hydra capture played (the reference: what a hardware source adds), a vrpn
#      source reading a second daemon's VRPN server, a dtrack source fed 240 frames a second; each
#      with the loop at its deadlines (the default) and woken by the sources (mode = events);
#   2. a VRPN server that vanishes and comes back: how long until the reader is FAULTY, and OK again;
#      a DTrack sender that stops and starts again, the same.
# One JSON line per measurement in $BUILD/bench-cave.jsonl, and a table.
set -eu
BUILD=${1:-build}
OUT="$BUILD/bench-cave.jsonl"
TMP=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; rm -rf "$TMP"' EXIT
: >"$OUT"
ROOT=$(cd "$(dirname "$0")/.." && pwd)
UPORT=17950
VPORT=17951
DPORT=17952

head_conf() { # mode
	printf '[daemon]\nrate = 240\nmode = %s\ncontrol_socket = %s/ctl\n' "$1" "$TMP"
	printf '[output udp]\ntype = udp\naddress = 127.0.0.1\nport = %s\n' "$UPORT"
}

publisher() {
	cat >"$TMP/pub.conf" <<EOC
[daemon]
rate = 240
control_socket = $TMP/pub.ctl
[source sim]
type = sim
[avatar p]
person = sim/p0
[output vrpn]
type = vrpn
address = 127.0.0.1
port = $VPORT
EOC
	"$BUILD/avatargw" -c "$TMP/pub.conf" 2>/dev/null &
	echo $! >"$TMP/pub.pid"
}

sender() { # seconds rate
	python3 - "$DPORT" "$1" "$2" <<'EOPY' &
import socket, sys, time
port, secs, rate = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
rot = "1 0 0 0 1 0 0 0 1"
end = time.time() + secs
fr = 0
nxt = time.time()
while time.time() < end:
    fr += 1
    body = " ".join("[%d 1.000][%d 100 1500][%s]" % (i, i * 300 - 300, rot) for i in range(3))
    s.sendto(("fr %d\nts %.6f\n6d 3 %s\n" % (fr, time.time() % 86400, body)).encode(), ("127.0.0.1", port))
    nxt += 1 / rate
    time.sleep(max(0, nxt - time.time()))
EOPY
	echo $! >"$TMP/send.pid"
}

state() { # source name -> its state
	"$BUILD/avatargw-ctl" -s "$TMP/ctl" status --json 2>/dev/null |
		python3 -c "import json,sys; print([s['state'] for s in json.load(sys.stdin)['sources'] if s['name'] == sys.argv[1]][0])" "$1" 2>/dev/null || echo none
}

# the time (s, monotonic) it takes state() to become $2
wait_state() { # source state limit_s
	python3 - "$BUILD/avatargw-ctl" "$TMP/ctl" "$1" "$2" "$3" <<'EOPY'
import json, subprocess, sys, time
ctl, sock, src, want, limit = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5])
t0 = time.monotonic()
while time.monotonic() - t0 < limit:
    out = subprocess.run([ctl, "-s", sock, "status", "--json"], capture_output=True, text=True)
    if out.returncode == 0:
        st = [s["state"] for s in json.loads(out.stdout)["sources"] if s["name"] == src][0]
        if st == want:
            print("%.3f" % (time.monotonic() - t0))
            sys.exit(0)
    time.sleep(0.01)
print("-1")
EOPY
}

reader() { # kind mode
	head_conf "$2" >"$TMP/r.conf"
	case $1 in
	hydra)
		printf '[source hydra]\ntype = hydra\ncapture = %s/tests/data/hydra-cmu_141_16.cap\n' "$ROOT" >>"$TMP/r.conf"
		printf '[avatar a]\nhead = hydra/left\nleft_hand = hydra/left\nright_hand = hydra/right\n' >>"$TMP/r.conf" ;;
	vrpn)
		printf '[source cave]\ntype = vrpn\ndevice = Avatar0@127.0.0.1:%s\nsensors = 13\n' "$VPORT" >>"$TMP/r.conf"
		printf '[avatar a]\nhead = cave/10\nleft_hand = cave/11\nright_hand = cave/12\n' >>"$TMP/r.conf" ;;
	dtrack)
		printf '[source dt]\ntype = dtrack\naddress = 127.0.0.1\nport = %s\nsensors = 3\n' "$DPORT" >>"$TMP/r.conf"
		printf '[avatar a]\nhead = dt/0\nleft_hand = dt/1\nright_hand = dt/2\n' >>"$TMP/r.conf" ;;
	esac
	rm -f "$TMP/ctl"
	"$BUILD/avatargw" -c "$TMP/r.conf" 2>"$TMP/r.err" &
	echo $! >"$TMP/r.pid"
	i=0
	while [ ! -S "$TMP/ctl" ] && [ $i -lt 100 ]; do
		sleep 0.1
		i=$((i + 1))
	done
}

echo "machine: $(uname -srm), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; $(date -u +%Y-%m-%d)"

# 1. latency, 10 s each
for mode in deadline events; do
	for kind in hydra vrpn dtrack; do
		if [ "$kind" = vrpn ]; then publisher; fi
		if [ "$kind" = dtrack ]; then sender 12 240; fi
		sleep 0.5
		reader "$kind" "$mode"
		sleep 10
		"$BUILD/avatargw-ctl" -s "$TMP/ctl" status --json >"$TMP/s.json"
		kill "$(cat "$TMP/r.pid")"
		wait "$(cat "$TMP/r.pid")" 2>/dev/null || true
		if [ "$kind" = vrpn ]; then kill "$(cat "$TMP/pub.pid")"; wait "$(cat "$TMP/pub.pid")" 2>/dev/null || true; fi
		if [ "$kind" = dtrack ]; then kill "$(cat "$TMP/send.pid")" 2>/dev/null || true; wait "$(cat "$TMP/send.pid")" 2>/dev/null || true; fi
		python3 -c "
import json, sys
d = json.load(open(sys.argv[1]))
l = d['avatars'][0]['latency_us']
print(json.dumps({'set': 'latency', 'source': sys.argv[2], 'mode': sys.argv[3], 'p50_us': l['p50'], 'p99_us': l['p99'],
                  'max_us': l['max'], 'n': l['n']}))" "$TMP/s.json" "$kind" "$mode" >>"$OUT"
	done
done

# 2. vanish and return, five times each
for try in 1 2 3 4 5; do
	publisher
	sleep 0.5
	reader vrpn deadline
	wait_state cave OK 10 >/dev/null
	kill "$(cat "$TMP/pub.pid")"
	gone=$(wait_state cave FAULTY 10)
	wait "$(cat "$TMP/pub.pid")" 2>/dev/null || true
	publisher
	back=$(wait_state cave OK 10)
	kill "$(cat "$TMP/r.pid")" "$(cat "$TMP/pub.pid")"
	wait "$(cat "$TMP/r.pid")" "$(cat "$TMP/pub.pid")" 2>/dev/null || true
	echo "{\"set\":\"vanish\",\"source\":\"vrpn\",\"faulty_s\":$gone,\"back_s\":$back}" >>"$OUT"

	sender 3 240
	reader dtrack deadline
	wait_state dt OK 10 >/dev/null
	kill "$(cat "$TMP/send.pid")"
	gone=$(wait_state dt FAULTY 10)
	sender 3 240
	back=$(wait_state dt OK 10)
	kill "$(cat "$TMP/r.pid")" "$(cat "$TMP/send.pid")" 2>/dev/null || true
	wait "$(cat "$TMP/r.pid")" 2>/dev/null || true
	echo "{\"set\":\"vanish\",\"source\":\"dtrack\",\"faulty_s\":$gone,\"back_s\":$back}" >>"$OUT"
done

printf '\n| measurement | result |\n|---|---|\n'
python3 - "$OUT" <<'EOPY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for r in rows:
    if r["set"] == "latency":
        print("| report arrival -> datagram, %s source, mode = %s | p50 %.1f us, p99 %.1f us, max %.1f us (%d frames) |"
              % (r["source"], r["mode"], r["p50_us"], r["p99_us"], r["max_us"], r["n"]))
for src in ("vrpn", "dtrack"):
    v = [r for r in rows if r["set"] == "vanish" and r["source"] == src]
    if v:
        print("| %s server gone: FAULTY after (s) | %s (goal <= 1) |" % (src, ", ".join("%.2f" % r["faulty_s"] for r in v)))
        print("| %s server back: OK after (s) | %s (goal <= 1; vrpn: the server's own start-up included) |"
              % (src, ", ".join("%.2f" % r["back_s"] for r in v)))
EOPY
