# SPDX-License-Identifier: MIT
"""End-to-end tests of the daemon: the real binary on loopback, subscribed
with avatargw-dump (and raw sockets where a test needs to misbehave).

Run from the repository root: python3 -m unittest tests/e2e/test_daemon.py
(BUILD=build-san selects the sanitizer build)."""
import csv
import json
import math
import os
import signal
import socket
import struct
import subprocess
import tempfile
import time
import unittest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.path.join(ROOT, os.environ.get("BUILD", "build"))
DAEMON = os.path.join(BUILD, "avatargw")
DUMP = os.path.join(BUILD, "avatargw-dump")
CTL = os.path.join(BUILD, "avatargw-ctl")
CLIENT = os.path.join(BUILD, "examples", "glm_client")
CLIP = os.path.join(ROOT, "config", "clips", "cmu_141_16.csv")
DEG = math.pi / 180
# the default limits (config/avatargw.conf), degrees
LIMITS = [(-30, 30), (-170, 30), (-60, 120), (-90, 90), (-90, 60), (-90, 90), (-70, 70), (-30, 30)]
IK_REACHED = 0x01


def free_port(kind=socket.SOCK_DGRAM):
    s = socket.socket(socket.AF_INET, kind)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class Daemon:
    """avatargw in the background, on a configuration file of a temp dir."""

    def __init__(self, tmp, conf_text=None, demo=False, sets=(), env=None):
        self.tmp = tmp
        self.ctl = os.path.join(tmp, "control")
        self.conf = os.path.join(tmp, "avatargw.conf")
        args = [DAEMON]
        if demo:
            args.append("--demo")
        else:
            with open(self.conf, "w") as f:
                f.write(conf_text)
            args += ["-c", self.conf]
        args += ["--set", "daemon.control_socket=" + self.ctl]
        for s in sets:
            args += ["--set", s]
        self.err_path = os.path.join(tmp, "daemon.err")
        self.err = open(self.err_path, "w")
        e = dict(os.environ)
        e.update(env or {})
        self.proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=self.err, env=e)
        deadline = time.time() + 5
        while not os.path.exists(self.ctl):
            if self.proc.poll() is not None or time.time() > deadline:
                raise AssertionError("daemon did not start: " + self.stderr())
            time.sleep(0.02)

    def stderr(self):
        if not self.err.closed:
            self.err.flush()
        with open(self.err_path) as f:
            return f.read()

    def status(self):
        out = subprocess.run([CTL, "-s", self.ctl, "status", "--json"], capture_output=True, text=True,
                             timeout=5)
        if out.returncode != 0:
            raise AssertionError("avatargw-ctl failed: " + out.stderr)
        return json.loads(out.stdout)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.err.close()
        return self.proc.returncode


def dump(args, count, timeout=10):
    """frames (and DESCRIBEs) from avatargw-dump, each with its arrival time"""
    p = subprocess.Popen([DUMP] + args + ["--count", str(count), "--timeout", "5"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, bufsize=1)
    out = []
    t_end = time.time() + timeout
    for line in p.stdout:
        out.append((time.monotonic(), json.loads(line)))
        if time.time() > t_end:
            break
    p.wait(timeout=5)
    err = p.stderr.read()
    p.stdout.close()
    p.stderr.close()
    if p.returncode != 0:
        raise AssertionError("avatargw-dump exited %d: %s" % (p.returncode, err))
    return out


def assert_frame_rate(tc, frames, rate, on_time_share=0.75):
    """the frames leave one period apart, by the kernel's receive times (loopback delivers in the
    sender's time, so neither this process nor the dump's scheduling shows); a cycle the host took
    the CPU from is skipped, not made up (DAEMON.md), so the intervals are judged, not the count
    over the whole capture: the median one is the period, and on_time_share of them are within half
    a period of it"""
    rx = [m["rx_ns"] for m in frames]
    iv = sorted(b - a for a, b in zip(rx, rx[1:]))
    period = 1e9 / rate
    got = 1e9 / iv[len(iv) // 2]
    tc.assertAlmostEqual(got, rate, delta=rate * 0.03, msg="frame rate %.1f Hz (median interval)" % got)
    on_time = sum(1 for x in iv if 0.5 * period < x < 1.5 * period)
    tc.assertGreater(on_time, on_time_share * len(iv), "%d of %d intervals within half a period of it" % (on_time, len(iv)))
    # the whole capture: at most a quarter of its cycles skipped, and none made up
    overall = (len(rx) - 1) / ((rx[-1] - rx[0]) / 1e9)
    tc.assertGreater(overall, 0.75 * rate)
    tc.assertLess(overall, 1.03 * rate)


def load_clip():
    rows = []
    with open(CLIP) as f:
        for r in csv.DictReader(f):
            rows.append({k: [float(r[k + "_" + a]) for a in ("x", "y", "z")] for k in ("head", "lhand", "rhand")})
    return rows


def read_text(path):
    with open(path) as f:
        return f.read()


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


SIM_CONF = """
[daemon]
rate = {rate}
[source sim]
type = sim
people = 2
[avatar a]
person = sim/p0
count = 2
shoulder = {shoulder}
[output udp]
type = udp
address = 127.0.0.1
port = {port}
[output tcp]
type = tcp
address = 127.0.0.1
port = {tport}
client_buffer = 4096
"""


class DemoTest(unittest.TestCase):
    """the embedded demo, replaying the CMU clip, checked frame by frame"""

    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.port = free_port()
        cls.tport = free_port(socket.SOCK_STREAM)
        cls.d = Daemon(cls.tmpd.name, demo=True, sets=["output local.port=%d" % cls.port,
                                                       "output stream.port=%d" % cls.tport,
                                                       "output viewer.port=%d" % free_port(socket.SOCK_STREAM)])
        cls.frames = dump(["--udp", "127.0.0.1:%d" % cls.port, "--describe"], 720)

    @classmethod
    def tearDownClass(cls):
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def only(self, kind):
        return [(t, m) for t, m in self.frames if m["type"] == kind]

    def test_rate(self):
        """240 frames a second (assert_frame_rate)"""
        fr = self.only("frame")
        self.assertGreaterEqual(len(fr), 700)
        assert_frame_rate(self, [m for _, m in fr], 240)

    def test_sequence_continuity(self):
        fr = [m for _, m in self.only("frame")]
        gaps = [(a["seq"], b["seq"]) for a, b in zip(fr, fr[1:]) if b["seq"] != a["seq"] + 1]
        self.assertEqual(gaps, [])
        self.assertEqual(len({m["source"] for m in fr}), 1)

    def test_describe_at_1hz(self):
        ds = self.only("describe")
        # one a second: 720 frames at 240 Hz are 3 s of samples (longer where a loaded host skipped cycles)
        fr = [m for _, m in self.only("frame")]
        span = (fr[-1]["t_ns"] - fr[0]["t_ns"]) / 1e9
        self.assertGreaterEqual(len(ds), int(span) - 1, "%d DESCRIBEs in %.2f s" % (len(ds), span))
        self.assertLessEqual(len(ds), int(span) + 2, "%d DESCRIBEs in %.2f s" % (len(ds), span))
        d = ds[0][1]
        self.assertEqual(d["avatar"], 0)
        self.assertEqual(len(d["joints"]), 17)

    def test_hands_match_replayed_sensors(self):
        rows = load_clip()
        checked = 0
        for _, m in self.only("frame"):
            sens = {s["name"]: s for s in m["sensors"]}
            # the published sensors are rows of the clip
            head = sens["head"]["p"]
            row = min(rows, key=lambda r: dist(r["head"], head))
            self.assertLess(dist(row["head"], head), 1e-5)
            self.assertLess(dist(row["rhand"], sens["right_hand"]["p"]), 1e-5)
            self.assertLess(dist(row["lhand"], sens["left_hand"]["p"]), 1e-5)
            for side, seg, key in (("right", "r_hand", "rhand"), ("left", "l_hand", "lhand")):
                arm = [a for a in m["arms"] if a["side"] == side][0]
                if arm["ik_flags"] & IK_REACHED:
                    e = dist(m["segments"][seg]["p"], row[key])
                    self.assertLess(e, 1e-3, "%s hand %.2f mm from its sensor, seq %d" % (side, e * 1e3, m["seq"]))
                    checked += 1
        # the demo body reaches the whole clip: every arm of every frame was checked
        self.assertEqual(checked, 2 * len(self.only("frame")))

    def test_angles_inside_limits_and_finite(self):
        for _, m in self.only("frame"):
            for name, v in m["joints"].items():
                self.assertIsNotNone(v, "%s is NaN in seq %d" % (name, m["seq"]))
                self.assertTrue(math.isfinite(v))
                if name == "chest_yaw":
                    continue
                j = int(name[2:] and ["girdle", "sh_abd", "sh_flex", "sh_rot", "elbow", "pronation", "wr_flex",
                                      "wr_dev"].index(name[2:]))
                lo, hi = LIMITS[j]
                self.assertGreaterEqual(v, lo * DEG - 1e-6, name)
                self.assertLessEqual(v, hi * DEG + 1e-6, name)
            for seg in m["segments"].values():
                for x in seg["p"] + seg["q"]:
                    self.assertIsNotNone(x)

    def test_describe_limits_match(self):
        d = self.only("describe")[0][1]
        joints = d["joints"]
        names = list(joints) if isinstance(joints, dict) else [j["name"] for j in joints]
        self.assertEqual(names[0], "chest_yaw")

    def test_ctl_status(self):
        st = self.d.status()
        self.assertEqual(st["sources"][0]["state"], "OK")
        self.assertEqual(st["avatars"][0]["state"], "OK")
        self.assertGreater(st["avatars"][0]["latency_us"]["n"], 100)
        self.assertEqual(st["avatars"][0]["nan_blocked"], 0)
        txt = subprocess.run([CTL, "-s", self.d.ctl, "status"], capture_output=True, text=True).stdout
        self.assertIn("AVATAR", txt)
        self.assertIn("demo", txt)

    def test_loop_takes_no_page_faults(self):
        """the loop thread's memory is resident and locked before it runs: in the steady
        state its minor and major page-fault counts stay still (/proc/PID/task/TID/stat)"""
        def faults():
            for tid in os.listdir("/proc/%d/task" % self.d.proc.pid):
                with open("/proc/%d/task/%s/comm" % (self.d.proc.pid, tid)) as f:
                    if f.read().strip() != "avatargw-loop":
                        continue
                with open("/proc/%d/task/%s/stat" % (self.d.proc.pid, tid)) as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                # after the comm: state(0) ... minflt(7) cminflt(8) majflt(9)
                return int(fields[7]), int(fields[9])
            self.fail("no avatargw-loop thread")
        before = faults()
        time.sleep(1.0)
        after = faults()
        self.assertEqual(before, after, "page faults in the loop thread (minor, major): %s -> %s" % (before, after))

    def test_tcp_stream(self):
        fr = dump(["--tcp", "127.0.0.1:%d" % self.tport], 100)
        seqs = [m["seq"] for _, m in fr if m["type"] == "frame"]
        self.assertEqual(len(seqs), 100)
        self.assertEqual(seqs, list(range(seqs[0], seqs[0] + 100)))

    def test_glm_client_agrees(self):
        self.assertTrue(os.path.exists(CLIENT), "the GLM example client is not built (make all builds it)")
        out = subprocess.run([CLIENT, "--port", str(self.port), "--count", "240"], capture_output=True,
                             text=True, timeout=20)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)


class ConfigErrorTest(unittest.TestCase):
    def run_conf(self, text):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "bad.conf")
            with open(path, "w") as f:
                f.write(text)
            p = subprocess.run([DAEMON, "-c", path], capture_output=True, text=True, timeout=10)
            return p, path

    def test_unknown_key(self):
        p, path = self.run_conf("[daemon]\nrate = 240\nspeed = 2\n")
        self.assertEqual(p.returncode, 78)
        self.assertIn("%s:3:" % path, p.stderr)
        self.assertIn("speed", p.stderr)

    def test_out_of_range(self):
        p, path = self.run_conf("[daemon]\n\nrate = 0.5\n")
        self.assertEqual(p.returncode, 78)
        self.assertIn("%s:3: [daemon] rate" % path, p.stderr)

    def test_missing_file(self):
        p = subprocess.run([DAEMON, "-c", "/nonexistent/avatargw.conf"], capture_output=True, text=True)
        self.assertEqual(p.returncode, 78)
        self.assertIn("/nonexistent/avatargw.conf", p.stderr)

    def test_bad_sensor(self):
        p, path = self.run_conf("[source s]\ntype = sim\n[avatar a]\nhead = s/p0.head\nleft_hand = s/p0.left_hand\n"
                                "right_hand = s/p7.right_hand\n")
        self.assertEqual(p.returncode, 78)
        self.assertIn("%s:6: [avatar a] right_hand" % path, p.stderr)


class ReloadTest(unittest.TestCase):
    def test_good_then_bad_reload(self):
        with tempfile.TemporaryDirectory() as tmp:
            port, tport = free_port(), free_port(socket.SOCK_STREAM)
            d = Daemon(tmp, SIM_CONF.format(rate=240, shoulder=0.17, port=port, tport=tport))
            try:
                before = dump(["--udp", "127.0.0.1:%d" % port, "--describe"], 240)
                rev0 = [m for _, m in before if m["type"] == "frame"][-1]["rev"]
                # a good change: a new body (DESCRIBE revision +1), sequence numbers go on
                with open(d.conf, "w") as f:
                    f.write(SIM_CONF.format(rate=240, shoulder=0.2, port=port, tport=tport))
                p = subprocess.Popen([DUMP, "--udp", "127.0.0.1:%d" % port, "--describe", "--count", "480",
                                      "--timeout", "5"], stdout=subprocess.PIPE, text=True)
                time.sleep(0.5)
                d.proc.send_signal(signal.SIGHUP)
                out, _ = p.communicate(timeout=10)
                msgs = [json.loads(l) for l in out.splitlines()]
                fr = [m for m in msgs if m["type"] == "frame" and m["avatar"] == 0]
                gaps = [(a["seq"], b["seq"]) for a, b in zip(fr, fr[1:]) if b["seq"] != a["seq"] + 1]
                self.assertLessEqual(len(gaps), 0, gaps)
                self.assertEqual(fr[-1]["rev"], rev0 + 1)
                ds = [m for m in msgs if m["type"] == "describe" and m["avatar"] == 0 and m["rev"] == rev0 + 1]
                self.assertTrue(ds, "no DESCRIBE of the new revision")
                self.assertAlmostEqual(ds[0]["dims"][0], 0.2, places=6)
                self.assertEqual(d.status()["reloads"], 1)
                # a bad change: rejected with its error, the running configuration stays
                with open(d.conf, "w") as f:
                    f.write(SIM_CONF.format(rate=240, shoulder=5, port=port, tport=tport))
                d.proc.send_signal(signal.SIGHUP)
                time.sleep(0.5)
                self.assertIsNone(d.proc.poll())
                self.assertIn("reload rejected", d.stderr())
                self.assertIn("%s:10: [avatar a] shoulder" % d.conf, d.stderr())
                st = d.status()
                self.assertEqual(st["reload_failures"], 1)
                after = dump(["--udp", "127.0.0.1:%d" % port], 100)
                self.assertEqual(len(after), 100)
            finally:
                self.assertEqual(d.stop(), 0)


class SlowSubscriberTest(unittest.TestCase):
    def test_stalled_and_vanished_subscribers_do_not_block(self):
        with tempfile.TemporaryDirectory() as tmp:
            port, tport = free_port(), free_port(socket.SOCK_STREAM)
            d = Daemon(tmp, SIM_CONF.format(rate=240, shoulder=0.17, port=port, tport=tport))
            try:
                stalled = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
                stalled.connect(("127.0.0.1", tport))
                gone = socket.create_connection(("127.0.0.1", tport))
                time.sleep(0.2)
                gone.close()
                fr = dump(["--udp", "127.0.0.1:%d" % port], 960)  # 2 avatars, 2 s
                seqs = {}
                for _, m in fr:
                    seqs.setdefault(m["avatar"], []).append(m["seq"])
                for a, s in seqs.items():
                    self.assertEqual(s, list(range(s[0], s[0] + len(s))), "avatar %d lost frames" % a)
                st = d.status()
                tcp = [o for o in st["outputs"] if o["name"] == "tcp"][0]
                self.assertGreater(tcp["dropped"], 0)
                self.assertEqual(tcp["clients"], 1)  # the stalled one stays, the gone one was retired
                self.assertEqual(tcp["closed"], 1)
                # the loop went on with the stalled reader there: a send that waited on it would wait
                # for good (it never reads), so the cycles would stop. How many cycles a loaded host
                # takes from the loop is the host's (seen: 20 overruns in 523 cycles with a sanitizer
                # build beside), so the bound is half the rate, and the frames above came without a gap
                cycles = st["loop"]["cycles"]
                self.assertGreaterEqual(cycles, 0.5 * 240 * st["uptime_s"] - 240,
                                        "%d cycles in %.1f s" % (cycles, st["uptime_s"]))
                c0 = cycles
                time.sleep(0.5)
                self.assertGreater(d.status()["loop"]["cycles"], c0, "the loop stopped")
                # a new reader still gets a clean stream
                fr = dump(["--tcp", "127.0.0.1:%d" % tport], 50)
                self.assertEqual(len(fr), 50)
                stalled.close()
            finally:
                self.assertEqual(d.stop(), 0)


class SignalTest(unittest.TestCase):
    def test_sigterm_and_notify(self):
        with tempfile.TemporaryDirectory() as tmp:
            ns = os.path.join(tmp, "notify")
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            sock.bind(ns)
            sock.settimeout(3)
            port, tport = free_port(), free_port(socket.SOCK_STREAM)
            d = Daemon(tmp, SIM_CONF.format(rate=240, shoulder=0.17, port=port, tport=tport),
                       env={"NOTIFY_SOCKET": ns, "WATCHDOG_USEC": "200000"})
            got = []

            def until(what):
                t_end = time.time() + 3
                while time.time() < t_end:
                    m = sock.recv(4096).decode()
                    got.append(m)
                    if what in m:
                        return m
                raise AssertionError("no %s in %r" % (what, got))

            until("READY=1")
            until("WATCHDOG=1")
            self.assertIn("STATUS=", "".join(got))
            d.proc.send_signal(signal.SIGHUP)
            until("RELOADING=1")
            until("READY=1")
            t0 = time.monotonic()
            d.proc.send_signal(signal.SIGTERM)
            d.proc.wait(timeout=5)
            took = time.monotonic() - t0
            until("STOPPING=1")
            self.assertEqual(d.proc.returncode, 0)
            self.assertLess(took, 1.0)
            self.assertFalse(os.path.exists(d.ctl), "control socket left behind")
            d.stop()
            sock.close()

    def test_sigint(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, demo=True, sets=["output local.port=%d" % free_port(),
                                             "output stream.port=%d" % free_port(socket.SOCK_STREAM),
                                             "output viewer.port=%d" % free_port(socket.SOCK_STREAM)])
            d.proc.send_signal(signal.SIGINT)
            self.assertEqual(d.proc.wait(timeout=2), 0)
            d.stop()


class MulticastTest(unittest.TestCase):
    def test_multicast(self):
        group, port = "239.255.77.70", free_port()
        probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            probe.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                             struct.pack("4s4s", socket.inet_aton(group), socket.inet_aton("0.0.0.0")))
        except OSError as e:
            self.skipTest("SKIPPED: this host cannot join IPv4 multicast groups (%s)" % e)
        finally:
            probe.close()
        conf = ("[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n"
                "[output m]\ntype = multicast\naddress = %s\nport = %d\n" % (group, port))
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, conf)
            try:
                fr = dump(["--udp", "%s:%d" % (group, port)], 100)
                self.assertEqual(len(fr), 100)
            finally:
                self.assertEqual(d.stop(), 0)


class CoalescedTest(unittest.TestCase):
    def test_runs_of_frames_split_back(self):
        """40 avatars: the daemon sends runs of FRAMEs as one segmented buffer, avatargw-dump takes
        them coalesced (UDP_GRO) and splits them: every frame once, in order, exactly --count"""
        port = free_port()
        conf = ("[source s]\ntype = sim\npeople = 40\n[avatar a]\nperson = s/p0\ncount = 40\n"
                "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n" % port)
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, conf)
            try:
                fr = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port], 2000)]
                self.assertEqual(len(fr), 2000)
                by = {}
                for m in fr:
                    by.setdefault(m["avatar"], []).append(m["seq"])
                self.assertEqual(len(by), 40)
                for k, seqs in by.items():
                    self.assertEqual(seqs, list(range(seqs[0], seqs[0] + len(seqs))), "avatar %d" % k)
                st = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port, "--stats"], 4000)]
                final = [m for m in st if m.get("final")]
                self.assertEqual(len(final), 40)
                self.assertGreater(final[0]["coalesced"], 40, final[0])
                self.assertEqual(final[0]["malformed"], 0)
                self.assertEqual(d.status()["outputs"][0].get("gso_off", 0), 0)
            finally:
                self.assertEqual(d.stop(), 0)


class EventModeTest(unittest.TestCase):
    def test_sources_wake_the_loop(self):
        """mode = events: the loop sleeps until a source has samples (sim at 100 Hz, replay at 50 Hz
        here), a cycle per wake-up, no busy loop, the frames at the sources' rates"""
        port = free_port()
        conf = ("[daemon]\nmode = events\n"
                "[source s]\ntype = sim\nsample_rate = 100\n"
                "[source r]\ntype = replay\nfile = builtin:cmu_141_16.csv\nsample_rate = 50\n"
                "[avatar a]\nperson = s/p0\n[avatar b]\nid = 1\nperson = r\n"
                "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n" % port)
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, conf)
            try:
                st0 = d.status()
                fr = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port], 600)]
                st1 = d.status()
                dt = st1["uptime_s"] - st0["uptime_s"]
                cycles = st1["loop"]["cycles"] - st0["loop"]["cycles"]
                self.assertGreater(dt, 1.0)
                # a cycle per wake-up of either source (some wake-ups coincide), never a busy loop
                self.assertLess(cycles, (100 + 50) * dt * 1.3 + 20, "%d cycles in %.2f s" % (cycles, dt))
                self.assertGreater(cycles, 100 * dt * 0.7, "%d cycles in %.2f s" % (cycles, dt))
                # every cycle publishes both avatars, and the cycles come at the sources' rates
                self.assertEqual(len([m for m in fr if m["avatar"] == 0]), 300)
            finally:
                self.assertEqual(d.stop(), 0)


class BusyWaitTest(unittest.TestCase):
    def test_spins_at_rate_and_stops(self):
        """busy_wait = yes: the loop thread never sleeps (its CPU time keeps up with the clock), the
        cycles still come at the rate (where the host gives it a CPU) and none is made up, and
        SIGTERM ends it within a second"""
        port = free_port()
        conf = ("[daemon]\nrate = 200\nbusy_wait = yes\n[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n"
                "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n" % port)
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, conf)
            try:
                d.status()  # answered once the loop thread runs (the control socket exists before it)
                loop = [t for t in os.listdir("/proc/%d/task" % d.proc.pid)
                        if read_text("/proc/%d/task/%s/comm" % (d.proc.pid, t)).strip() == "avatargw-loop"]
                self.assertEqual(len(loop), 1)
                stat = "/proc/%d/task/%s/stat" % (d.proc.pid, loop[0])
                tick = os.sysconf("SC_CLK_TCK")

                def cpu_s():
                    f = read_text(stat).rsplit(")", 1)[1].split()
                    return (int(f[11]) + int(f[12])) / tick  # utime + stime

                c0, st0, w0 = cpu_s(), d.status(), time.monotonic()
                fr = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port], 300)]
                c1, st1, w1 = cpu_s(), d.status(), time.monotonic()
                self.assertEqual(len(fr), 300)
                # a sleeping loop at this rate takes a few per cent of a CPU; a spinning one all the
                # host gives it: nearly all of one CPU here, a share of it on a host that other work
                # loads (measured: 97 % beside one CPU-bound process on two cores, 45 to 51 % beside
                # three, 32 % beside five)
                share = (c1 - c0) / (w1 - w0)
                self.assertGreater(share, 0.15, "the loop slept: %.2f s of CPU in %.2f s" % (c1 - c0, w1 - w0))
                # the cycles come at the rate (a cycle a stalled host took is skipped: assert_frame_rate).
                # A thread that never sleeps is the one the kernel preempts for whole time slices when
                # other work wants its CPU (a sleeping one wakes with priority): its frames come in
                # bursts, so only a third of the intervals must be on time; and given less than three
                # quarters of a CPU it cannot keep the rate (the cycles due while it waits for its
                # slice come late), so then only that none is made up is judged
                if share >= 0.75:
                    assert_frame_rate(self, [m for m in fr if m["type"] == "frame"], 200, on_time_share=1 / 3)
                else:
                    print("busy_wait: the host gave the spinning loop %.0f %% of a CPU: its frame rate is "
                          "not judged, only that no cycle is made up" % (100 * share))
                cycles = st1["loop"]["cycles"] - st0["loop"]["cycles"]
                dt = st1["uptime_s"] - st0["uptime_s"]
                self.assertLess(cycles / dt, 1.03 * 200, "cycles made up")
                t0 = time.monotonic()
                d.proc.send_signal(signal.SIGTERM)
                self.assertEqual(d.proc.wait(timeout=2), 0)
                self.assertLess(time.monotonic() - t0, 1.0)
            finally:
                d.stop()


def qmul(a, b):
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1], a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


def qrot(q, v):
    w, x, y, z = q
    r = qmul(qmul(q, (0, v[0], v[1], v[2])), (w, -x, -y, -z))
    return r[1:]


def held_pose_daemon(tmp, head, qhead, lhand, ql, rhand, qr, avatar_keys=""):
    """a daemon at 120 Hz replaying one pose held for 2 s (sensors: position, quaternion) to a UDP output;
    returns the daemon and the output's port"""
    cols = ["frame", "t"] + ["%s_%s" % (w, k) for w in ("head", "lhand", "rhand")
                             for k in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    clip = os.path.join(tmp, "pose.csv")
    with open(clip, "w") as f:
        f.write(",".join(cols) + "\n")
        for i in range(120):
            row = [i, i / 60] + list(head) + list(qhead) + list(lhand) + list(ql) + list(rhand) + list(qr)
            f.write(",".join("%.6f" % v if isinstance(v, float) else str(v) for v in row) + "\n")
    port = free_port()
    conf = ("[daemon]\nrate = 120\n[source rp]\ntype = replay\nfile = %s\n[avatar a]\nperson = rp\n%s"
            "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n" % (clip, avatar_keys, port))
    return Daemon(tmp, conf), port


class BowTest(unittest.TestCase):
    """a person bowing 70 degrees at the waist, the arms hanging along the trunk, face up: from an upright
    chest, moved toward them as far as it goes, the hands stay 9 mm off their sensors against the
    shoulders' limits (measured with avatargw-eval without AVATAR_BOW; swept back 10 degrees behind the
    trunk, as this test once had them, the upright chest now reaches them within a millimetre). Through
    the whole daemon the chest is published bowed, the hands on their sensors, and the GLM client
    rebuilds every segment from the chest and the joints"""

    def test_bowed_chest_published(self):
        # the default body (config/avatargw.conf)
        S, A, F, head_off = 0.1732, 0.2886, 0.1955, (0.008, -0.0386, 0.0967)
        yaw, pitch, sweep = 20 * DEG, 70 * DEG, 0 * DEG
        qy = (math.cos(yaw / 2), 0, 0, math.sin(yaw / 2))
        qc = qmul(qy, (math.cos(pitch / 2), -math.sin(pitch / 2), 0, 0))  # pitched forward about its x axis
        head = (0.3, 0.2, 1.45)
        hoff = qrot(qc, head_off)
        chest = tuple(h - o for h, o in zip(head, hoff))
        # the arms down the trunk (swept back by `sweep`), a little out, the elbows a little bent; hand y down the
        # trunk
        qh = qmul(qc, (math.cos(-math.pi / 4), math.sin(-math.pi / 4), 0, 0))
        hands = {}
        reach = (A + F) * 0.97
        for side, sx in (("l", -1), ("r", 1)):
            v = qrot(qc, (sx * (S + 0.03), -reach * math.sin(sweep), -reach * math.cos(sweep)))
            hands[side] = tuple(c + d for c, d in zip(chest, v))
        with tempfile.TemporaryDirectory() as tmp:
            d, port = held_pose_daemon(tmp, head, qy, hands["l"], qh, hands["r"], qh)
            try:
                fr = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port], 40) if m["type"] == "frame"]
                self.assertGreater(len(fr), 30)
                first = True
                for i, m in enumerate(fr):
                    seg = m["segments"]
                    z = qrot(seg["chest"]["q"], (0, 0, 1))
                    bow = math.degrees(math.acos(max(-1, min(1, z[2]))))
                    if first and bow < 1:
                        # the first solve, from the rest posture with the whole search, may find the hands within
                        # a millimetre upright (J2 to -170 degrees; published until the next sample): a bow is
                        # tried for a hand off by more; the next solve, tracked with the short search, bows
                        for s in ("r", "l"):
                            self.assertLess(math.dist(seg[s + "_hand"]["p"], hands[s]), 1e-3)
                        self.assertLess(i, 5)
                        continue
                    first = False
                    self.assertGreater(bow, 55, "the chest is not bowed: %.1f degrees (frame %d)" % (bow, i))
                    self.assertLess(bow, 76)
                    # its heading is still chest_yaw
                    w, x, y, zq = seg["chest"]["q"]
                    n = math.hypot(w, zq)
                    cy = 2 * math.atan2(zq / n, w / n)
                    self.assertAlmostEqual(math.remainder(cy - m["joints"]["chest_yaw"], 2 * math.pi), 0, delta=1e-4)
                    # both hands on their sensors
                    self.assertLess(math.dist(seg["r_hand"]["p"], hands["r"]), 1e-3)
                    self.assertLess(math.dist(seg["l_hand"]["p"], hands["l"]), 1e-3)
                out = subprocess.run([CLIENT, "--port", str(port), "--count", "60"], capture_output=True, text=True,
                                     timeout=20)
                self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
            finally:
                d.stop()


class RestPronationTest(unittest.TestCase):
    """the rest_pronation key reaches the avatar: a right arm hanging nearly straight, the hand's thumb turned 20
    degrees inward from forward, is the same to the sensors whether the upper arm or the forearm made the turn. The
    avatar told the forearm rests supinated (+20) gives the forearm less of it than the default (-30) does, so it
    publishes the pronation higher and the elbow elsewhere, both hands on their sensors"""

    def run_daemon(self, rest):
        S, A, F, head_off = 0.1732, 0.2886, 0.1955, (0.008, -0.0386, 0.0967)
        head, qh = (0.0, 0.0, 1.6), (1.0, 0.0, 0.0, 0.0)
        chest = tuple(h - o for h, o in zip(head, head_off))
        hands = {"r": (chest[0] + S, chest[1] + 0.08, chest[2] - 0.95 * (A + F)),
                 "l": (chest[0] - S, chest[1] + 0.08, chest[2] - 0.95 * (A + F))}
        down = (math.cos(-math.pi / 4), math.sin(-math.pi / 4), 0, 0)  # the hand's y down, its z (thumb) forward
        roll = 20 * DEG
        qr = qmul((math.cos(roll / 2), 0, 0, math.sin(roll / 2)), down)  # the right thumb turned inward
        ql = qmul((math.cos(-roll / 2), 0, 0, math.sin(-roll / 2)), down)  # the left, mirrored
        with tempfile.TemporaryDirectory() as tmp:
            d, port = held_pose_daemon(tmp, head, qh, hands["l"], ql, hands["r"], qr, "rest_pronation = %g\n" % rest)
            try:
                fr = [m for _, m in dump(["--udp", "127.0.0.1:%d" % port], 30) if m["type"] == "frame"]
            finally:
                d.stop()
        self.assertGreater(len(fr), 20)
        for m in fr:
            for s in ("r", "l"):
                self.assertLess(math.dist(m["segments"][s + "_hand"]["p"], hands[s]), 1e-3)
            # the left arm is the right one's mirror image
            self.assertAlmostEqual(m["joints"]["l_pronation"], m["joints"]["r_pronation"], delta=1e-3)
        last = fr[-1]
        return last["joints"]["r_pronation"], last["segments"]["r_elbow"]["p"]

    def test_rest_pronation_key(self):
        j6_default, elbow_default = self.run_daemon(-30)
        j6_supine, elbow_supine = self.run_daemon(20)
        self.assertGreater(j6_supine - j6_default, 10 * DEG, "pronation %.1f and %.1f degrees" % (
            j6_default / DEG, j6_supine / DEG))
        self.assertGreater(math.dist(elbow_default, elbow_supine), 0.005)


def read_until(proc, err, done, timeout=20):
    """proc's stderr appended to err until done(err), within timeout seconds; returns err"""
    import select
    deadline = time.monotonic() + timeout
    while not done(err):
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([proc.stderr], [], [], left)[0]:
            raise AssertionError("nothing more after %.0f s: %s" % (timeout, err.decode()))
        b = os.read(proc.stderr.fileno(), 4096)
        if not b:
            raise AssertionError("ended early: %s" % err.decode())
        err += b
    return err


class CalibrateTest(unittest.TestCase):
    """avatargw-ctl calibrate against a person who holds the standard poses: a replayed CSV, stepped
    from pose to pose; the fitted body, written as a drop-in, is what the configuration then says"""

    S, A, F = 0.19, 0.31, 0.27
    HEAD = (0.012, -0.035, 0.105)  # the head sensor from the chain origin: right, forward, up
    ORIGIN, YAW = (0.6, -0.4, 1.38), 35 * DEG  # where the person stands, which way they face
    POSES = ("initial", "down", "forward")

    def hand(self, pose, side):
        x = self.S if side == "r" else -self.S
        return {"initial": (x, self.F, -self.A), "down": (x, 0, -(self.A + self.F)),
                "forward": (x, self.A + self.F, 0)}[pose]

    def world(self, p):
        c, s = math.cos(self.YAW), math.sin(self.YAW)
        return (self.ORIGIN[0] + c * p[0] - s * p[1], self.ORIGIN[1] + s * p[0] + c * p[1], self.ORIGIN[2] + p[2])

    def write_clip(self, path):
        """two rounds of the three poses, a row each"""
        qw, qz = math.cos(self.YAW / 2), math.sin(self.YAW / 2)
        cols = ["frame", "t"] + ["%s_%s" % (w, k) for w in ("head", "lhand", "rhand")
                                 for k in ("x", "y", "z", "qw", "qx", "qy", "qz")]
        with open(path, "w") as f:
            f.write(",".join(cols) + "\n")
            for i, pose in enumerate(self.POSES * 2):
                row = [i, i / 60]
                for p in (self.HEAD, self.hand(pose, "l"), self.hand(pose, "r")):
                    row += list(self.world(p)) + [qw, 0, 0, qz]
                f.write(",".join("%.6f" % v if isinstance(v, float) else str(v) for v in row) + "\n")

    def test_calibrate_writes_the_body(self):
        port = free_port()
        with tempfile.TemporaryDirectory() as tmp:
            clip = os.path.join(tmp, "poses.csv")
            self.write_clip(clip)
            # the hand sensor 5 cm beyond the wrist, as configured: the fit's forearm is F - 5 cm
            conf = ("[daemon]\nrate = 120\nstale_ms = 60000\n[source rp]\ntype = replay\nfile = %s\nstep = yes\n"
                    "[avatar tester]\nperson = rp\nhand = 0.05\n[output u]\ntype = udp\naddress = 127.0.0.1\n"
                    "port = %d\n" % (clip, port))
            d = Daemon(tmp, conf)
            try:
                # the sensors, as the loop has them: the first row
                out = subprocess.run([CTL, "-s", d.ctl, "sensors", "tester"], capture_output=True, text=True, timeout=5)
                self.assertEqual(out.returncode, 0, out.stderr)
                got = json.loads(out.stdout)
                self.assertEqual([x["role"] for x in got["sensors"]], ["head", "left_hand", "right_hand"])
                self.assertTrue(all(x["state"] == "ok" for x in got["sensors"]))
                self.assertLess(math.dist(got["sensors"][0]["p"], self.world(self.HEAD)), 1e-5)
                self.assertLess(math.dist(got["sensors"][2]["p"], self.world(self.hand("initial", "r"))), 1e-5)
                # a name that is not an avatar's: refused, and the exit status says so
                out = subprocess.run([CTL, "-s", d.ctl, "sensors", "nobody"], capture_output=True, text=True, timeout=5)
                self.assertEqual(out.returncode, 65)
                self.assertIn("no avatar 'nobody'", out.stderr)
                # the calibration: Enter at each pose, the replay stepped to the next between them
                dropin = os.path.join(tmp, "conf.d", "60-tester.conf")
                os.mkdir(os.path.dirname(dropin))
                cal = subprocess.Popen([CTL, "-s", d.ctl, "calibrate", "tester", "--samples", "5", "--write", dropin],
                                       stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
                err = b""
                for k in range(6):
                    # its prompt: the pose before has been read
                    err = read_until(cal, err, lambda e: ("[%d/6]" % (k + 1)).encode() in e)
                    self.assertIn(self.POSES[k % 3].encode() + b":", err.rsplit(b"[", 1)[1])
                    self.assertNotIn(b"moved", err)
                    if k:
                        # the person takes the next pose: the replay's next row, in the loop before Enter
                        subprocess.run([CTL, "-s", d.ctl, "step", "1"], check=True, capture_output=True, timeout=5)
                        want = self.world(self.hand(self.POSES[k % 3], "r"))
                        for _ in range(100):
                            out = subprocess.run([CTL, "-s", d.ctl, "sensors", "tester"], capture_output=True,
                                                 text=True, timeout=5)
                            if math.dist(json.loads(out.stdout)["sensors"][2]["p"], want) < 1e-5:
                                break
                        else:
                            self.fail("the replay did not step to pose %d" % k)
                    cal.stdin.write(b"\n")
                    cal.stdin.flush()
                out_text, rest = cal.communicate(timeout=20)
                err += rest
                self.assertEqual(cal.returncode, 0, err.decode())
                text = out_text.decode()
                self.assertIn("[avatar tester]", text)
                # no --hand: the configured hand length is the fit's and is left alone
                self.assertNotIn("hand =", text)
                self.assertEqual(got["hand"], 0.05)
                with open(dropin) as f:
                    self.assertEqual(f.read(), text)
                # the drop-in is what the configuration now says, to a tenth of a millimetre
                chk = subprocess.run([DAEMON, "--check-config", "-c", d.conf], capture_output=True, text=True,
                                     timeout=10)
                self.assertEqual(chk.returncode, 0, chk.stderr)
                sect = chk.stdout.split("[avatar tester]", 1)[1]
                vals = {}
                for line in sect.splitlines()[1:8]:
                    k, v = line.split(";")[0].split("=")
                    vals[k.strip()] = [float(x) for x in v.split()]
                self.assertAlmostEqual(vals["shoulder"][0], self.S, delta=1e-4)
                self.assertAlmostEqual(vals["upper_arm"][0], self.A, delta=1e-4)
                self.assertAlmostEqual(vals["forearm"][0], self.F - 0.05, delta=1e-4)
                self.assertAlmostEqual(vals["hand"][0], 0.05, delta=1e-4)
                for got_h, want_h in zip(vals["head_offset"], self.HEAD):
                    self.assertAlmostEqual(got_h, want_h, delta=1e-4)
                # and the daemon takes it in
                out = subprocess.run([CTL, "-s", d.ctl, "reload"], capture_output=True, text=True, timeout=5)
                self.assertEqual(out.returncode, 0, out.stderr)
            finally:
                d.stop()

    def test_a_pose_not_held_is_asked_again(self):
        with tempfile.TemporaryDirectory() as tmp:
            clip = os.path.join(tmp, "poses.csv")
            self.write_clip(clip)
            conf = ("[daemon]\nrate = 120\nstale_ms = 60000\n[source rp]\ntype = replay\nfile = %s\nstep = yes\n"
                    "[avatar tester]\nperson = rp\n" % clip)
            d = Daemon(tmp, conf)
            try:
                # 100 readings take 2 s: the person moves (the replay steps) while they are taken
                cal = subprocess.Popen([CTL, "-s", d.ctl, "calibrate", "tester", "--samples", "100"],
                                       stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
                err = read_until(cal, b"", lambda e: b"[1/6]" in e)
                cal.stdin.write(b"\n")
                cal.stdin.flush()
                time.sleep(0.5)  # inside the 2 s of readings, well after the first
                subprocess.run([CTL, "-s", d.ctl, "step", "1"], check=True, capture_output=True, timeout=5)
                err = read_until(cal, err, lambda e: e.count(b"[1/6]") >= 2)
                # the right hand went from the initial pose to hanging (38 cm): far beyond the 2 cm allowed
                moved = float(err.split(b"moved by ", 1)[1].split(b" cm", 1)[0])
                self.assertGreater(moved, 5)
                # the person gives up: no body written
                out, rest = cal.communicate(b"", timeout=10)
                self.assertEqual(cal.returncode, 1)
                self.assertIn(b"calibration abandoned", rest)
                self.assertEqual(out, b"")
            finally:
                d.stop()

    def test_avatars_of_one_section_are_not_written(self):
        """count = 2: the two avatars share one body, so a calibration of one is printed, not written"""
        conf = ("[daemon]\nrate = 120\n[source sim]\ntype = sim\npeople = 2\n"
                "[avatar crowd]\ncount = 2\nperson = sim/p0\n")
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, conf)
            try:
                out = subprocess.run([CTL, "-s", d.ctl, "sensors", "crowd-1"], capture_output=True, text=True, timeout=5)
                got = json.loads(out.stdout)
                self.assertEqual((got["avatar"], got["section"], got["section_avatars"]), ("crowd-1", "crowd", 2))
                dropin = os.path.join(tmp, "60-crowd.conf")
                cal = subprocess.run([CTL, "-s", d.ctl, "calibrate", "crowd-1", "--write", dropin], input=b"",
                                     capture_output=True, timeout=10)
                self.assertEqual(cal.returncode, 1)  # no poses: abandoned
                self.assertIn(b"share one body: not written", cal.stderr)
                self.assertFalse(os.path.exists(dropin))
            finally:
                d.stop()


if __name__ == "__main__":
    unittest.main()
