#!/bin/sh
# SPDX-License-Identifier: MIT
# make bench, second part: the daemon's goals, measured on the real binary.
#   1. sample read -> datagram sent, one avatar at 240 Hz (the daemon's own
#      histogram, read with avatargw-ctl: a sim sample is read by the cycle's
#      poll, after the wake-up, so the host's wake-up delay is not in it; that
#      delay is shown beside it), p50/p99/p99.9/max, with the loop sleeping to
#      each deadline (the default) and spinning (busy_wait = yes);
#   2. RSS with one avatar (the embedded demo);
#   3. avatars one core carries at 240 Hz: the loop (one thread) runs N sim
#      avatars for a few seconds, three times; a run carries N when no cycle
#      overran and the cycle's work p99 fits in the period, and N is carried
#      when two runs of the three carry it.
# One JSON line per measurement in $BUILD/bench-daemon.jsonl, a table, and each
# goal met / not met (never a failure: wall-clock figures on a shared machine
# measure the host as much as the daemon; tools/bench-cycle.sh has the figures
# it does not change).
set -eu
BUILD=${1:-build}
OUT="$BUILD/bench-daemon.jsonl"
TMP=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$TMP"' EXIT
: >"$OUT"
# ports that are free now (other benches and tests may run on this machine): UDP for the
# subscriber, TCP for the demo's stream and viewer
free_port() { # udp|tcp
	python3 -c 'import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM if sys.argv[1] == "udp" else socket.SOCK_STREAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1])' "$1"
}
PORT=$(free_port udp)

conf() { # people rate [busy_wait]
	cat <<EOC
[daemon]
rate = $2
busy_wait = ${3:-no}
control_socket = $TMP/ctl
[source sim]
type = sim
people = $1
[avatar a]
person = sim/p0
count = $1
[output udp]
type = udp
address = 127.0.0.1
port = $PORT
EOC
}

json() { # field path in python syntax
	python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"
}

# run N people at 240 Hz for $2 seconds (after 1 s of warm-up), busy_wait $3; prints the RSS
run() {
	conf "$1" 240 "${3:-no}" >"$TMP/a.conf"
	"$BUILD/avatargw-dump" --udp "127.0.0.1:$PORT" --stats >/dev/null 2>&1 &
	dump=$!
	rm -f "$TMP/ctl"
	"$BUILD/avatargw" -c "$TMP/a.conf" 2>"$TMP/err" &
	d=$!
	# serving once its control socket exists (start-up locks and touches its memory first)
	i=0
	while [ ! -S "$TMP/ctl" ] && [ $i -lt 100 ]; do
		sleep 0.1
		i=$((i + 1))
	done
	sleep 1
	if ! "$BUILD/avatargw-ctl" -s "$TMP/ctl" status --json >"$TMP/s0.json"; then
		kill "$d" "$dump" 2>/dev/null || true
		cat "$TMP/err" >&2
		exit 1
	fi
	sleep "$2"
	"$BUILD/avatargw-ctl" -s "$TMP/ctl" status --json >"$TMP/s1.json"
	rss=$(awk '/VmRSS/ {print $2}' "/proc/$d/status")
	kill "$d" "$dump"
	wait "$d" "$dump" 2>/dev/null || true
	echo "$rss"
}

echo "machine: $(uname -srm), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; $(date -u +%Y-%m-%d)"

# 1. latency, one avatar at 240 Hz, 10 s: the loop sleeping to each deadline (the default), then spinning
for bw in no yes; do
	run 1 10 "$bw" >/dev/null
	lat=$(json '"%.1f %.1f %.1f %.1f %d %.1f %.1f" % tuple([d["avatars"][0]["latency_us"][k] for k in ("p50","p99","p999","max")] + [d["avatars"][0]["latency_us"]["n"], d["loop"]["wake_late_us"]["p50"], d["loop"]["wake_late_us"]["p99"]])' <"$TMP/s1.json")
	echo "$lat $bw" | awk '{printf "{\"set\":\"latency\",\"avatars\":1,\"rate_hz\":240,\"p50_us\":%s,\"p99_us\":%s,\"p999_us\":%s,\"max_us\":%s,\"n\":%s,\"wake_p50_us\":%s,\"wake_p99_us\":%s,\"busy_wait\":\"%s\"}\n", $1,$2,$3,$4,$5,$6,$7,$8}' >>"$OUT"
done

# 2. RSS of the demo
"$BUILD/avatargw" --demo --set "daemon.control_socket=$TMP/demo.ctl" --set "output local.port=$PORT" \
	--set "output stream.port=$(free_port tcp)" --set "output viewer.port=$(free_port tcp)" 2>/dev/null &
d=$!
sleep 2
rss=$(awk '/VmRSS/ {print $2}' "/proc/$d/status")
hwm=$(awk '/VmHWM/ {print $2}' "/proc/$d/status")
kill "$d"
wait "$d" 2>/dev/null || true
echo "{\"set\":\"rss\",\"avatars\":1,\"rss_kib\":$rss,\"hwm_kib\":$hwm}" >>"$OUT"

# 3. capacity: N avatars at 240 Hz, 4 s each, three times (a shared or virtual machine's speed
#    drifts by tens of percent from minute to minute: N is carried when two of the three runs carry it)
for n in 250 500 750 1000 1250 1500; do
for try in 1 2 3; do
	rss=$(run "$n" 4)
	c0=$(json 'd["loop"]["cycles"]' <"$TMP/s0.json")
	o0=$(json 'd["loop"]["overruns"]' <"$TMP/s0.json")
	c1=$(json 'd["loop"]["cycles"]' <"$TMP/s1.json")
	o1=$(json 'd["loop"]["overruns"]' <"$TMP/s1.json")
	w=$(json '"%.1f %.1f %.1f %.1f" % (d["loop"]["work_us"]["p50"], d["loop"]["work_us"]["p99"], d["loop"]["work_cpu_us"]["p50"], d["loop"]["work_cpu_us"]["p99"])' <"$TMP/s1.json")
	echo "$n $((c1 - c0)) $((o1 - o0)) $w $rss $try" | awk '{printf "{\"set\":\"capacity\",\"avatars\":%s,\"rate_hz\":240,\"cycles\":%s,\"overruns\":%s,\"work_p50_us\":%s,\"work_p99_us\":%s,\"cpu_p50_us\":%s,\"cpu_p99_us\":%s,\"period_us\":4166.7,\"rss_kib\":%s,\"try\":%s}\n", $1,$2,$3,$4,$5,$6,$7,$8,$9}' >>"$OUT"
done
done

printf '\n| measurement | result |\n|---|---|\n'
python3 - "$OUT" <<'EOPY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for r in rows:
    if r["set"] == "latency":
        print("| sample read -> datagram sent, 1 avatar, 240 Hz, busy_wait = %s | p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us (%d frames; goal p99 <= 50 us); the wake-up's lateness apart: p50 %.1f us, p99 %.1f us |"
              % (r["busy_wait"], r["p50_us"], r["p99_us"], r["p999_us"], r["max_us"], r["n"], r["wake_p50_us"], r["wake_p99_us"]))
    elif r["set"] == "rss":
        print("| RSS, demo (1 avatar) | %d KiB (peak %d KiB; goal <= 8192 KiB) |" % (r["rss_kib"], r["hwm_kib"]))
best = 0
cap = {}
for r in rows:
    if r["set"] == "capacity":
        cap.setdefault(r["avatars"], []).append(r)
for n in sorted(cap):
    runs = []
    carried = 0
    for r in cap[n]:
        ok = r["overruns"] == 0 and r["work_p99_us"] < r["period_us"]
        carried += ok
        runs.append("p50 %.0f, p99 %.0f us (%.2f us per avatar), %d overruns in %d cycles%s"
                    % (r["work_p50_us"], r["work_p99_us"], r["cpu_p50_us"] / r["avatars"], r["overruns"],
                       r["cycles"], "" if ok else " *"))
    ok = 2 * carried > len(cap[n])
    best = n if ok else best
    print("| %d avatars at 240 Hz | work of 4167 us per cycle: %s; RSS %d KiB; carried in %d of %d runs: %s |"
          % (n, "; ".join(runs), cap[n][-1]["rss_kib"], carried, len(cap[n]), "carried" if ok else "NOT carried"))
print("| avatars one core carries at 240 Hz (two runs of three) | %d (goal >= 1000) |" % best)
print()
def goal(text, ok):
    print("goal: %s: %s" % (text, "met" if ok else "not met"))
for r in rows:
    if r["set"] == "latency":
        goal("loop latency read -> sent p99 <= 50 us, 1 avatar, busy_wait = %s (%.1f us)" % (r["busy_wait"], r["p99_us"]),
             r["p99_us"] <= 50)
    elif r["set"] == "rss":
        goal("RSS <= 8 MiB, demo (%d KiB)" % r["rss_kib"], r["rss_kib"] <= 8192)
goal("wall clock: >= 1000 avatars carried by one core at 240 Hz (%d)" % best, best >= 1000)
EOPY
