#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""make bench, the sites' part (docs/SITES.md): [site] over Cyclone DDS.

  1. added delay: site A's FRAME leaving its UDP output -> the same sample
     (same sample time) leaving site B's UDP output, both received by this
     program on loopback (the kernel's receive times): p50, p99, max;
  2. bandwidth per participant: two sites in two network namespaces joined
     by a veth pair (root), one avatar at 240 Hz: the bytes site A's end of
     the pair sent per second (DDS discovery, clock pings and frames), with
     and without DDS Security;
  3. three sites of 50 avatars each on loopback, 240 Hz: at one of them, the
     loop's work per cycle (p50, p99) and CPU time, and its overruns.

One JSON line per measurement in BUILD/bench-sites.jsonl, and a table."""
import json
import os
import random
import socket
import struct
import subprocess
import sys
import tempfile
import time

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
DAEMON = os.path.join(BUILD, "avatargw")
CTL = os.path.join(BUILD, "avatargw-ctl")
RATE = 240
DOMAIN = random.randint(100, 200)
TAG = "bench%d" % os.getpid()
results = []


def conf(tmp, name, people, port, extra=""):
    text = "[daemon]\nrate = %d\nlock_memory = no\ncontrol_socket = %s/%s.ctl\n" % (RATE, tmp, name)
    if people:
        text += "[source sim]\ntype = sim\npeople = %d\nsample_rate = %d\n" % (people, RATE)
        text += "[avatar p]\nperson = sim/p0\ncount = %d\n" % people
    text += "[output local]\ntype = udp\naddress = 127.0.0.1\nport = %d\n" % port
    text += "[site]\nname = %s\nsession = %s\ndomain = %d\n%s" % (name, TAG, DOMAIN, extra)
    path = os.path.join(tmp, name + ".conf")
    with open(path, "w") as f:
        f.write(text)
    return path


def start(args, tmp, name):
    p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=open(os.path.join(tmp, name + ".err"), "w"))
    ctl = os.path.join(tmp, name + ".ctl")
    t_end = time.time() + 10
    while not os.path.exists(ctl) and time.time() < t_end and p.poll() is None:
        time.sleep(0.05)
    return p


def status(tmp, name):
    out = subprocess.run([CTL, "-s", os.path.join(tmp, name + ".ctl"), "status", "--json"], capture_output=True,
                         text=True, timeout=5)
    return json.loads(out.stdout)


def stop(procs):
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def pct(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(q * len(v)))] if v else float("nan")


def udp_rx():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    s.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_TIMESTAMPNS", 35), 1)  # Linux: 35
    s.bind(("127.0.0.1", 0))
    s.setblocking(False)
    return s


def drain(s, out):
    while True:
        try:
            data, anc, _, _ = s.recvmsg(2048, 64)
        except BlockingIOError:
            return
        if len(data) < 40 or data[5] != 1:
            continue
        rx = None
        for level, kind, d in anc:
            if level == socket.SOL_SOCKET and kind == 35:  # SCM_TIMESTAMPNS
                sec, ns = struct.unpack("qq", d[:16])
                rx = sec * 1000000000 + ns
        t_ns = struct.unpack_from("<Q", data, 24)[0]
        flags = struct.unpack_from("<H", data, 8)[0]
        if rx and flags & 8:  # NEW_SAMPLE
            out.setdefault(t_ns, rx)


def bench_delay():
    with tempfile.TemporaryDirectory() as tmp:
        la, lb = udp_rx(), udp_rx()
        peers = "interface = lo\npeers = 127.0.0.1\n"
        procs = [start([DAEMON, "-c", conf(tmp, "lab-a", 1, la.getsockname()[1], peers)], tmp, "lab-a"),
                 start([DAEMON, "-c", conf(tmp, "lab-b", 0, lb.getsockname()[1], peers)], tmp, "lab-b")]
        at_a, at_b = {}, {}
        t_end = time.time() + 12
        while time.time() < t_end:
            drain(la, at_a)
            drain(lb, at_b)
            time.sleep(0.002)
        stop(procs)
        d = [(at_b[t] - at_a[t]) / 1e6 for t in at_b if t in at_a]
        d = d[len(d) // 6:]  # after discovery
        r = {"bench": "sites_added_delay_loopback", "samples": len(d), "p50_ms": pct(d, 0.5),
             "p99_ms": pct(d, 0.99), "max_ms": max(d) if d else None, "period_ms": 1000 / RATE}
        results.append(r)


def sh(*args):
    subprocess.run(list(args), check=True, capture_output=True)


def bench_bandwidth(security):
    if os.geteuid() != 0:
        results.append({"bench": "sites_bandwidth", "skipped": "not root (ip netns)"})
        return
    tag = str(os.getpid() % 100000)
    ns, veth, addr = ["bwa" + tag, "bwb" + tag], ["ba" + tag, "bb" + tag], ["10.214.77.1", "10.214.77.2"]
    with tempfile.TemporaryDirectory() as tmp:
        try:
            for n in ns:
                sh("ip", "netns", "add", n)
            sh("ip", "link", "add", veth[0], "type", "veth", "peer", "name", veth[1])
            for i in range(2):
                sh("ip", "link", "set", veth[i], "netns", ns[i])
                sh("ip", "-n", ns[i], "addr", "add", addr[i] + "/24", "dev", veth[i])
                sh("ip", "-n", ns[i], "link", "set", veth[i], "up")
                sh("ip", "-n", ns[i], "link", "set", "lo", "up")
            extra = ["", ""]
            if security:
                tool = os.path.join(ROOT, "tools", "site-security.sh")
                sh(tool, "ca", tmp + "/ca")
                for i, n in enumerate(["lab-a", "lab-b"]):
                    sh(tool, "site", tmp + "/ca", n, "%s/%s" % (tmp, n))
                    extra[i] = "security = %s/%s\n" % (tmp, n)
            procs = []
            for i, n in enumerate(["lab-a", "lab-b"]):
                c = conf(tmp, n, 1 if i == 0 else 0, 17000 + i,
                         "interface = %s\npeers = %s\n%s" % (veth[i], addr[1 - i], extra[i]))
                procs.append(start(["ip", "netns", "exec", ns[i], DAEMON, "-c", c], tmp, n))
            time.sleep(4)

            def tx():
                out = subprocess.run(["ip", "netns", "exec", ns[0], "cat",
                                      "/sys/class/net/%s/statistics/tx_bytes" % veth[0]],
                                     capture_output=True, text=True)
                return int(out.stdout)

            b0, t0, w0 = tx(), time.time(), status(tmp, "lab-a")["site"]["written"]
            time.sleep(10)
            b1, t1, w1 = tx(), time.time(), status(tmp, "lab-a")["site"]["written"]
            frames = status(tmp, "lab-b")["site"]["peers"]
            stop(procs)
            # per frame written, and at the full rate (a loaded host's loop may have written fewer)
            per_frame = (b1 - b0) / max(1, w1 - w0)
            results.append({"bench": "sites_bandwidth_240hz", "security": security,
                            "bytes_per_s": (b1 - b0) / (t1 - t0), "frames_per_s": (w1 - w0) / (t1 - t0),
                            "bytes_per_frame": per_frame, "bytes_per_s_at_240hz": per_frame * RATE,
                            "received_at_b": frames[0]["frames"] if frames else 0})
        finally:
            for n in ns:
                subprocess.run(["ip", "netns", "del", n], capture_output=True)


def bench_three_sites():
    with tempfile.TemporaryDirectory() as tmp:
        peers = "interface = lo\npeers = 127.0.0.1\nmax_remote = 128\n"
        procs = []
        for n in ["lab-a", "lab-b", "lab-c"]:
            s = udp_rx()
            procs.append(start([DAEMON, "-c", conf(tmp, n, 50, s.getsockname()[1], peers)], tmp, n))
        time.sleep(5)
        s0 = status(tmp, "lab-c")
        time.sleep(10)
        s1 = status(tmp, "lab-c")
        stop(procs)
        loop = s1["loop"]
        results.append({"bench": "sites_3x50_at_one_site", "remote_avatars":
                        sum(p["avatars"] for p in s1["site"]["peers"]),
                        "work_us_p50": loop["work_us"]["p50"], "work_us_p99": loop["work_us"]["p99"],
                        "work_cpu_us_p50": loop["work_cpu_us"]["p50"], "cycles": loop["cycles"] - s0["loop"]["cycles"],
                        "overruns": loop["overruns"] - s0["loop"]["overruns"],
                        "remote_frames": sum(p["frames"] for p in s1["site"]["peers"]),
                        "lost": sum(p["lost"] for p in s1["site"]["peers"])})


def main():
    bench_delay()
    bench_bandwidth(False)
    bench_bandwidth(True)
    bench_three_sites()
    with open(os.path.join(BUILD, "bench-sites.jsonl"), "w") as f:
        for r in results:
            f.write(json.dumps(r) + "\n")
    print("\nsites (Cyclone DDS), %d Hz:" % RATE)
    for r in results:
        print("  " + ", ".join("%s %s" % (k, ("%.3f" % v) if isinstance(v, float) else v) for k, v in r.items()))


if __name__ == "__main__":
    main()
