# SPDX-License-Identifier: MIT
"""The CAVE trackers: the vrpn source against the daemon's own VRPN server
(one daemon publishing a replayed clip, a second reading it back and
driving an avatar: the second's hands follow the first's published hand
poses within 1 mm), the server stopped and started again, over UDP and
over TCP only; against fake servers written here (garbage instead of a
cookie, a message of a length no VRPN peer writes, a stall in the middle
of a message, cut UDP datagrams, a flood, values no tracker reports),
each counted while the daemon runs on; the dtrack source fed frames over UDP from the published format
(poses, a Flystick's buttons and joystick, bodies appearing and
disappearing, untracked bodies, empty frames, very long lines, CRLF, cut
datagrams, hostile values, a sender that stops and starts again);
avatargw --probe.

Run from the repository root: python3 -m unittest tests/e2e/test_cave.py
(BUILD=build-san selects the sanitizer build)."""
import bisect
import math
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_daemon import DAEMON, Daemon, dump, free_port  # noqa: E402
import vrpn_client as vc  # noqa: E402
from wireframe import UdpListener  # noqa: E402

PUBLISHER = """
[daemon]
rate = 240
[source clip]
type = replay
file = builtin:cmu_141_16.csv
[avatar demo]
id = 0
person = clip
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
[output vrpn]
type = vrpn
address = 127.0.0.1
port = {vport}
"""

READER = """
[daemon]
rate = 240
stale_ms = 200
[source cave]
type = vrpn
device = {device}
udp = {udp}
sensors = 13
sensor.10 = glasses
sensor.11 = left
sensor.12 = right
[avatar demo]
head = cave/glasses
left_hand = cave/left
right_hand = cave/12
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
"""


def wait_for(what, cond, limit=20.0, step=0.05):
    """cond() until it is true, at most limit seconds; its last value"""
    end = time.time() + limit
    while True:
        v = cond()
        if v or time.time() > end:
            if not v:
                raise AssertionError("timed out waiting for " + what)
            return v
        time.sleep(step)


def source(d, name):
    return [s for s in d.status()["sources"] if s["name"] == name][0]


class VrpnLoopbackTest(unittest.TestCase):
    """a daemon's VRPN server read back by a second daemon's vrpn source"""

    @classmethod
    def setUpClass(cls):
        cls.tmp_a = tempfile.TemporaryDirectory()
        cls.tmp_b = tempfile.TemporaryDirectory()
        cls.tmp_c = tempfile.TemporaryDirectory()
        cls.ua, cls.ub, cls.uc = free_port(), free_port(), free_port()
        cls.vport = free_port(socket.SOCK_STREAM)
        cls.la, cls.lb, cls.lc = UdpListener(cls.ua), UdpListener(cls.ub), UdpListener(cls.uc)
        cls.a = cls.start_publisher()
        # VRPN's usual way (the server calls back, reports over UDP), and TCP only
        cls.b = Daemon(cls.tmp_b.name, READER.format(device="Avatar0@127.0.0.1:%d" % cls.vport, udp="yes",
                                                     uport=cls.ub))
        cls.c = Daemon(cls.tmp_c.name, READER.format(device="Avatar0@tcp://127.0.0.1:%d" % cls.vport, udp="no",
                                                     uport=cls.uc))

    @classmethod
    def start_publisher(cls):
        return Daemon(cls.tmp_a.name, PUBLISHER.format(uport=cls.ua, vport=cls.vport))

    @classmethod
    def tearDownClass(cls):
        for lst in (cls.la, cls.lb, cls.lc):
            lst.close()
        rcs = [d.stop() for d in (cls.a, cls.b, cls.c)]
        for t in (cls.tmp_a, cls.tmp_b, cls.tmp_c):
            t.cleanup()
        assert rcs == [0, 0, 0], "daemon exit statuses %s" % rcs

    def follow(self, listener, name):
        """each of the reader's published sensors is one of the publisher's published poses of that sensor,
        within 1 mm"""
        def ok_frames(lst):
            return len([f for f in lst.snapshot() if all(s["state"] == 0 for s in f["sensors"])])
        # both streams: a loaded host may start one daemon later than the other
        wait_for(name + " frames with OK sensors", lambda: ok_frames(listener) > 300 and ok_frames(self.la) > 300)
        pub = sorted((f["t_ns"], tuple(tuple(s["p"]) for s in f["sensors"])) for f in self.la.snapshot()
                     if all(s["state"] == 0 for s in f["sensors"]))
        got = [f for f in listener.snapshot() if all(s["state"] == 0 for s in f["sensors"])][-300:]
        self.assertGreater(len(pub), 300)
        times = [t for t, _ in pub]
        worst = 0.0
        distinct = set()
        for f in got:
            mine = [tuple(s["p"]) for s in f["sensors"]]
            # the publisher's frames of the sample times around this one (the reader's clock estimate
            # differs by the least delay, well under 100 ms)
            lo = bisect.bisect_left(times, f["t_ns"] - 100000000)
            hi = bisect.bisect_right(times, f["t_ns"] + 100000000)
            self.assertLess(lo, hi, "%s: no published frame near the sample time %d" % (name, f["t_ns"]))
            # sensor by sensor: VRPN sends each channel's report alone, so a reader's cycle may take the head
            # of one published frame and a hand of the next (a frame's movement apart, 8 mm on fast motion)
            for i, a in enumerate(mine):
                worst = max(worst, min(math.dist(a, r[i]) for _, r in pub[lo:hi]))
            distinct.add(tuple(mine))
        self.assertLess(worst, 0.001, "%s: a sensor is %.4f m from every pose the publisher published for it" % (name, worst))
        # they move: not one pose held
        self.assertGreater(len(distinct), 50)
        return worst

    def test_hands_follow_over_udp(self):
        self.follow(self.lb, "udp")
        st = source(self.b, "cave")
        self.assertGreater(st["udp_messages"], 100)
        self.assertEqual(st["malformed"], 0)

    def test_hands_follow_over_tcp_only(self):
        self.follow(self.lc, "tcp")
        st = source(self.c, "cave")
        self.assertEqual(st["udp_messages"], 0)
        self.assertGreater(st["tcp_messages"], 100)
        self.assertEqual(st["malformed"], 0)

    def test_zz_server_restart(self):
        """the publisher stopped: the readers go FAULTY (their sensors MISSING) and run on; started again:
        they are back without a reload"""
        wait_for("both readers OK", lambda: source(self.b, "cave")["state"] == "OK" and
                 source(self.c, "cave")["state"] == "OK")
        before = {d: source(d, "cave")["reconnects"] for d in (self.b, self.c)}
        self.a.stop()
        t0 = time.time()
        wait_for("readers FAULTY", lambda: source(self.b, "cave")["state"] == "FAULTY" and
                 source(self.c, "cave")["state"] == "FAULTY", limit=10)
        gone = time.time() - t0
        n = len(self.lb.snapshot())
        time.sleep(0.3)
        # the reader's loop runs on: frames keep coming, the sensors MISSING (state 2)
        later = self.lb.snapshot()[n:]
        self.assertGreater(len(later), 20)
        self.assertTrue(all(s["state"] == 2 for s in later[-1]["sensors"]))
        type(self).a = self.start_publisher()
        t0 = time.time()
        wait_for("readers OK again", lambda: source(self.b, "cave")["state"] == "OK" and
                 source(self.c, "cave")["state"] == "OK", limit=15)
        back = time.time() - t0
        for d in (self.b, self.c):
            self.assertGreater(source(d, "cave")["reconnects"], before[d])
        print("\n  VRPN server gone: readers FAULTY after %.2f s; started again: OK after %.2f s (the server's own "
              "start-up included)" % (gone, back), file=sys.stderr)


# ---- fake VRPN servers -----------------------------------------------------------------

def check_published(tc, frames, limit=100.0):
    """every number a frame publishes for a sensor that is not MISSING is finite, within limit metres of the
    origin, its rotation a unit quaternion; every joint angle finite unless all are NaN (no solution)"""
    for f in frames:
        for s in f["sensors"]:
            if s["state"] == "MISSING":
                continue
            for v in s["p"] + s["q"]:
                tc.assertTrue(v is not None and math.isfinite(v), "a non-finite sensor value published: %r" % (f,))
            tc.assertLessEqual(math.sqrt(sum(v * v for v in s["p"])), limit * 1.0001, "beyond max_distance: %r" % s)
            tc.assertAlmostEqual(math.sqrt(sum(v * v for v in s["q"])), 1.0, delta=1e-3)
        # avatargw-dump prints a number that is not finite as null: the joints are all numbers, or all null
        # (no posture yet); so is every segment, but the head's, which is the head sensor's (NaN when MISSING)
        joints = list(f["joints"].values())
        if any(v is not None for v in joints):
            tc.assertTrue(all(v is not None for v in joints), "a non-finite joint published: %r" % (f,))
            for name, seg in f["segments"].items():
                vals = seg["p"] + seg["q"]
                if name == "head" and f["sensors"][0]["state"] == "MISSING":
                    tc.assertTrue(all(v is None for v in vals), "a MISSING head's segment published: %r" % (f,))
                else:
                    tc.assertTrue(all(v is not None for v in vals), "a non-finite segment published: %r" % (f,))


class FakeServer:
    """a TCP server speaking (or not) VRPN, one behaviour per instance; each connection in a thread"""

    def __init__(self, behaviour):
        self.behaviour = behaviour
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port = self.sock.getsockname()[1]
        self.stop = False
        self.go = threading.Event()  # for a behaviour that waits for the test
        self.connections = 0
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        self.sock.settimeout(0.2)
        while not self.stop:
            try:
                conn, _ = self.sock.accept()
            except (socket.timeout, OSError):
                continue
            self.connections += 1
            threading.Thread(target=self.serve, args=(conn,), daemon=True).start()

    def serve(self, conn):
        try:
            self.behaviour(self, conn)
        except OSError:
            pass
        finally:
            conn.close()

    def close(self):
        self.stop = True
        self.thread.join()
        self.sock.close()

    @staticmethod
    def read_cookie_and_udp(conn, udp=False):
        """the client's cookie, then (udp) its messages until its UDP description: (host, port) or None"""
        conn.settimeout(2)
        buf = b""
        while len(buf) < vc.COOKIE_LEN:
            buf += conn.recv(4096)
        buf = buf[vc.COOKIE_LEN:]
        if not udp:
            return None
        end = time.time() + 1
        while time.time() < end:
            msgs, rest = vc.split_messages(buf)
            for t, s, _, _, pl in msgs:
                if t == vc.UDP_DESCRIPTION:
                    return pl.split(b"\0")[0].decode(), s
            try:
                buf = rest + conn.recv(4096)
            except socket.timeout:
                return None
        return None

    @staticmethod
    def describe(conn):
        conn.sendall(vc.description(vc.SENDER_DESCRIPTION, 0, "Tracker0") +
                     vc.description(vc.TYPE_DESCRIPTION, 0, vc.POS_QUAT) +
                     vc.description(vc.TYPE_DESCRIPTION, 1, vc.BUTTON_STATES) +
                     vc.description(vc.TYPE_DESCRIPTION, 2, vc.ANALOG))


def pos_quat(ch, p, xyzw, t=None):
    return vc.message(0, 0, struct.pack(">ii3d4d", ch, 0, *p, *xyzw), t)


def garbage_cookie(srv, conn):
    conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")
    time.sleep(0.5)


def good_then_bad(srv, conn):
    conn.sendall(vc.cookie())
    srv.read_cookie_and_udp(conn)
    srv.describe(conn)
    # four buttons (1 and 3 pressed), two analog channels
    conn.sendall(vc.message(1, 0, struct.pack(">i4i", 4, 0, 1, 0, 1)) +
                 vc.message(2, 0, struct.pack(">3d", 2, 0.5, -0.25)))
    for i in range(40):
        conn.sendall(pos_quat(0, (0.1 * i / 40, 0.2, 1.5), (0, 0, 0, 1)))
        time.sleep(0.01)
    # a length no VRPN peer writes
    conn.sendall(struct.pack(">IIIii", 5, 0, 0, 0, 0) + b"\0" * 4)
    time.sleep(0.5)


def stall(srv, conn):
    conn.sendall(vc.cookie())
    srv.read_cookie_and_udp(conn)
    srv.describe(conn)
    for i in range(20):
        conn.sendall(pos_quat(0, (0, 0, 1), (0, 0, 0, 1)))
        time.sleep(0.01)
    # half a message, then nothing: the client must not wait for the rest forever
    conn.sendall(pos_quat(0, (0, 0, 1), (0, 0, 0, 1))[:30])
    end = time.time() + 30
    conn.settimeout(0.2)
    while time.time() < end and not srv.stop:
        try:
            if not conn.recv(4096):
                return  # the client gave up on us
        except socket.timeout:
            pass


def udp_cut(srv, conn):
    conn.sendall(vc.cookie())
    where = srv.read_cookie_and_udp(conn, udp=True)
    srv.describe(conn)
    if where is None:
        return
    u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        for i in range(100):
            good = pos_quat(0, (0, 0.01 * i, 1), (0, 0, 0, 1))
            u.sendto(good + good, where)  # two messages in one datagram
            if i % 10 == 5:
                u.sendto(good + good[:40], where)  # the second cut
            time.sleep(0.01)
        # the connection stays up a while: what was counted is read back
        time.sleep(3)
    finally:
        u.close()


def flood(srv, conn):
    conn.sendall(vc.cookie())
    srv.read_cookie_and_udp(conn)
    srv.describe(conn)
    burst = b"".join(pos_quat(i % 3, (0, 0, 1), (0, 0, 0, 1)) for i in range(500))
    end = time.time() + 2
    conn.settimeout(2)
    while time.time() < end:
        conn.sendall(burst)
    time.sleep(3)


def hostile(srv, conn):
    """channel 0 good throughout; channel 1 good, then values no tracker reports (non-finite, beyond float32,
    500 m away, rotations that are not rotations) among good ones; channel 2 good, then only hostile"""
    conn.sendall(vc.cookie())
    srv.read_cookie_and_udp(conn)
    srv.describe(conn)
    srv.go.wait(120)  # the test is reading the frames
    inf, nan = float("inf"), float("nan")
    bad = [((inf, 0, 1), (0, 0, 0, 1)), ((0, nan, 1), (0, 0, 0, 1)), ((0, 0, 1e300), (0, 0, 0, 1)),
           ((500, 0, 1), (0, 0, 0, 1)), ((0, 0, 1), (0, 0, 0, 0)), ((0, 0, 1), (0, 3, 0, 0)),
           ((0, 0, 1), (nan, 0, 0, 1)), ((0, 0, 1), (0, 0, 0, 1e300))]
    for i in range(300):
        msg = pos_quat(0, (0.1, 0.2, 1.6), (0, 0, 0, 1))
        if i < 20 or i % 2:
            msg += pos_quat(1, (-0.3, 0.1, 1.1), (0, 0, 0, 1))
        else:
            msg += pos_quat(1, *bad[(i // 2) % len(bad)])
        msg += pos_quat(2, *(((0.3, 0.1, 1.1), (0, 0, 0, 1)) if i < 20 else bad[i % len(bad)]))
        conn.sendall(msg)
        time.sleep(0.01)
    srv.hostile_done = True
    time.sleep(30)


FAKE_CONF_HEAD = """
[daemon]
rate = 240
stale_ms = 200
[source sim]
type = sim
[avatar simmed]
person = sim/p0
[avatar fake]
head = good/0
left_hand = good/0
right_hand = good/0
[avatar hostile]
head = hostile/0
left_hand = hostile/1
right_hand = hostile/2
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
"""

FAKE_SOURCE = """
[source {name}]
type = vrpn
device = Tracker0@tcp://127.0.0.1:{port}
udp = {udp}
sensors = 3
buttons.0 = 0 4
analog.0 = 0 2
"""


class VrpnFakeServerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.servers = {"cookie": FakeServer(garbage_cookie), "good": FakeServer(good_then_bad),
                       "stall": FakeServer(stall), "cut": FakeServer(udp_cut), "flood": FakeServer(flood),
                       "hostile": FakeServer(hostile)}
        cls.uport = free_port()
        conf = FAKE_CONF_HEAD.format(uport=cls.uport)
        for name, srv in cls.servers.items():
            conf += FAKE_SOURCE.format(name=name, port=srv.port, udp="yes" if name == "cut" else "no")
        cls.d = Daemon(cls.tmpd.name, conf)

    @classmethod
    def tearDownClass(cls):
        for s in cls.servers.values():
            s.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def test_garbage_cookie(self):
        st = wait_for("two refused cookies", lambda: (lambda s: s if s["malformed"] >= 2 else None)(
            source(self.d, "cookie")))
        self.assertEqual(st["state"], "FAULTY")
        self.assertEqual(st["samples"], 0)
        self.assertIn("cookie", st["device"])
        self.assertGreaterEqual(self.servers["cookie"].connections, 2)  # it keeps trying

    def test_bad_length_after_good_reports(self):
        # malformed is counted by the source's thread, samples by the loop when it next polls: wait for both
        # (every good report before the bad message is taken, none lost with it)
        wait_for("the bad message counted and the 40 reports before it taken",
                 lambda: (lambda s: s if s["malformed"] >= 1 and s["samples"] >= 40 else None)(
                     source(self.d, "good")))
        wait_for("a new connection", lambda: self.servers["good"].connections >= 2)
        # the buttons and joystick reached the avatar's inputs
        frames = dump(["--udp", "127.0.0.1:%d" % self.uport], 400, timeout=20)
        ins = [i for _, m in frames if m["type"] == "frame" and m["avatar"] == 1 and "inputs" in m
               for i in m["inputs"] if i["sensor"] == "head"]
        self.assertTrue(ins, "no inputs published")
        self.assertEqual(ins[-1]["buttons"], 0b1010)
        self.assertAlmostEqual(ins[-1]["analog"][0], 0.5, places=6)
        self.assertAlmostEqual(ins[-1]["analog"][1], -0.25, places=6)

    def test_stall_mid_message(self):
        wait_for("the stall noticed and the 20 reports before it taken",
                 lambda: (lambda s: s if s["stalls"] >= 1 and s["samples"] >= 20 else None)(source(self.d, "stall")))
        wait_for("a new connection", lambda: self.servers["stall"].connections >= 2)
        self.assertLoopRuns()

    def test_cut_datagrams(self):
        wait_for("cut datagrams counted and the whole messages taken",
                 lambda: (lambda s: s if s["malformed"] >= 5 and s["udp_messages"] > 100 and s["samples"] > 100
                          else None)(source(self.d, "cut")))

    def test_flood(self):
        wait_for("the flood read", lambda: source(self.d, "flood")["samples"] > 10000, limit=30)
        self.assertLoopRuns()

    def test_hostile_values(self):
        """values no tracker reports are counted as malformed and never published: the sensor keeps its last
        good pose (STALE when only hostile values come), every published number finite, within max_distance,
        every rotation a unit quaternion"""
        srv = self.servers["hostile"]
        srv.go.set()  # (a connection the client gave up on meanwhile fails; the newest one sends)
        seen = []
        end = time.time() + 60
        while time.time() < end:
            done = getattr(srv, "hostile_done", False)
            seen += [m for _, m in dump(["--udp", "127.0.0.1:%d" % self.uport], 150, timeout=10)
                     if m["type"] == "frame" and m["avatar"] == 2]
            if done:
                break
        self.assertTrue(getattr(srv, "hostile_done", False), "the hostile server never finished")
        st = wait_for("the hostile reports counted", lambda: (lambda s: s if s["malformed"] >= 250 else None)(
            source(self.d, "hostile")))
        self.assertGreater(len(seen), 50, "too few frames of the hostile source's avatar")
        check_published(self, seen)
        # the right hand had only hostile values after its first 20 reports: whenever published, its one good
        # pose, and STALE while the hostile values came (a connection the client dropped afterwards, for want
        # of pongs, makes it MISSING; the next one sends the sequence again)
        right = [f["sensors"][2] for f in seen if f["sensors"][2]["state"] != "MISSING"]
        for r in right:
            self.assertEqual([round(v, 5) for v in r["p"]], [0.3, 0.1, 1.1], r)
        self.assertIn("STALE", [r["state"] for r in right])
        self.assertGreater(st["samples"], 300)

    def assertLoopRuns(self):
        """the loop was never held by the source: it keeps making cycles and the simulated avatar stays OK
        (a loaded host may take cycles from it, which are skipped, not made up: only a loop that makes
        none in a second was held)"""
        st = self.d.status()
        av = [a for a in st["avatars"] if a["name"] == "simmed"][0]
        self.assertEqual(av["state"], "OK")
        c0 = st["loop"]["cycles"]
        time.sleep(1.0)
        c1 = self.d.status()["loop"]["cycles"]
        self.assertGreater(c1 - c0, 10, "the loop made %d cycles in a second" % (c1 - c0))


# ---- DTrack -------------------------------------------------------------------------------

DTRACK_CONF = """
[daemon]
rate = 240
stale_ms = 150
[source dt]
type = dtrack
address = 127.0.0.1
port = {dport}
sensors = 3
flysticks = 1
sensor.0 = glasses
sensor.f0 = stick
timeout_ms = 400
[avatar cave]
head = dt/glasses
left_hand = dt/1
right_hand = dt/stick
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
"""

IDENT = "1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000"


def frame(fr, bodies, stick=None, eol="\n", untracked=()):
    """a DTrack frame: bodies {id: (x, y, z) mm}; stick (buttons, jx, jy, (x, y, z)) or None"""
    ts = time.time() % 86400
    lines = ["fr %d" % fr, "ts %.6f" % ts, "6dcal %d" % (len(bodies) + 1)]
    parts = []
    for i, p in sorted(bodies.items()):
        q = -1.0 if i in untracked else 1.0
        parts.append("[%d %.3f][%.3f %.3f %.3f][%s]" % (i, q, p[0], p[1], p[2], IDENT))
    lines.append("6d %d %s" % (len(parts), " ".join(parts)))
    if stick is not None:
        b, jx, jy, p = stick
        lines.append("6df2 1 1 [0 1.000 6 2][%.3f %.3f %.3f][%s][%d %.3f %.3f]" % (p[0], p[1], p[2], IDENT, b, jx, jy))
    return (eol.join(lines) + eol).encode()


class DtrackTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.dport = free_port()
        cls.uport = free_port()
        cls.d = Daemon(cls.tmpd.name, DTRACK_CONF.format(dport=cls.dport, uport=cls.uport))
        cls.tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        cls.fr = 0

    @classmethod
    def tearDownClass(cls):
        cls.tx.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def send(self, data):
        self.tx.sendto(data, ("127.0.0.1", self.dport))

    def stream(self, seconds, make, rate=60):
        """sends make(k) rate times a second in a thread; returns the thread"""
        def run():
            end = time.time() + seconds
            k = 0
            while time.time() < end:
                self.send(make(k))
                k += 1
                time.sleep(1.0 / rate)
        t = threading.Thread(target=run, daemon=True)
        t.start()
        return t

    def frames(self, n):
        return [m for _, m in dump(["--udp", "127.0.0.1:%d" % self.uport], n, timeout=20) if m["type"] == "frame"]

    def test_poses_and_flystick(self):
        def make(k):
            type(self).fr += 1
            return frame(self.fr, {0: (100, 200, 1700), 1: (-300, 100, 1000 + k % 10)},
                         stick=(0b101, -0.5, 1.0, (300, 100, 1100)))
        malformed = self.d.status()["sources"][0]["malformed"]
        t = self.stream(3, make)
        got = [f for f in self.frames(200) if all(s["state"] == "OK" for s in f["sensors"])]
        t.join()
        self.assertGreater(len(got), 50)
        f = got[-1]
        head, left, right = f["sensors"]
        self.assertEqual([round(v, 4) for v in head["p"]], [0.1, 0.2, 1.7])
        self.assertAlmostEqual(left["p"][0], -0.3, places=5)
        self.assertEqual([round(v, 4) for v in right["p"]], [0.3, 0.1, 1.1])
        self.assertEqual(head["q"], [1, 0, 0, 0])
        ins = {i["sensor"]: i for i in f["inputs"]}
        self.assertEqual(list(ins), ["right_hand"])
        self.assertEqual(ins["right_hand"]["buttons"], 0b101)
        self.assertAlmostEqual(ins["right_hand"]["analog"][0], -0.5, places=6)
        self.assertAlmostEqual(ins["right_hand"]["analog"][1], 1.0, places=6)
        self.assertEqual(self.d.status()["sources"][0]["malformed"], malformed)

    def test_hostile_values(self):
        """positions and rotations no tracker reports (nan, inf, beyond float32, 200 m away, a matrix that is
        not a rotation) are counted as malformed and never published; the body keeps its last good pose"""
        st0 = self.d.status()["sources"][0]
        bad_pos = ["nan 0 1700", "0 inf 1700", "1e42 0 1700", "200000 0 1700", "0 0 -inf"]
        zero = " ".join(["0.0"] * 9)
        twice = " ".join(["2.0" if i in (0, 4, 8) else "0.0" for i in range(9)])

        def make(k):
            type(self).fr += 1
            good = k < 20
            p0 = "100 200 1700" if good or k % 2 else bad_pos[k % len(bad_pos)]
            m1 = IDENT if good else (zero, twice, "nan " + IDENT[9:])[k % 3]
            lines = ["fr %d" % self.fr, "6d 2 [0 1.000][%s][%s] [1 1.000][-300 100 1000][%s]" % (p0, IDENT, m1)]
            return ("\n".join(lines) + "\n").encode()
        t = self.stream(3, make)
        got = self.frames(400)
        t.join()
        st = wait_for("the hostile bodies counted", lambda: (lambda s: s if s["malformed"] - st0["malformed"] >= 100
                                                              else None)(self.d.status()["sources"][0]))
        check_published(self, got)
        heads = [f["sensors"][0] for f in got if f["sensors"][0]["state"] != "MISSING"]
        self.assertTrue(heads)
        for h in heads:
            self.assertEqual([round(v, 4) for v in h["p"]], [0.1, 0.2, 1.7])
        lefts = [f["sensors"][1] for f in got if f["sensors"][1]["state"] != "MISSING"]
        self.assertIn("STALE", [s_["state"] for s_ in lefts], "the left hand had only hostile rotations")
        self.assertGreater(st["samples"], st0["samples"])

    def test_odd_frames(self):
        """bodies appearing, disappearing and untracked go STALE, never frozen OK; empty frames, CRLF, very
        long lines pass; cut datagrams are counted; the daemon runs on"""
        st0 = self.d.status()["sources"][0]

        def make(k):
            type(self).fr += 1
            phase = (k // 30) % 3
            if phase == 0:
                return frame(self.fr, {0: (0, 0, 1700), 1: (-300, 0, 1000)}, stick=(0, 0, 0, (300, 0, 1000)),
                             eol="\r\n")
            if phase == 1:
                # body 1 is not in the frame any more; the glasses are untracked
                return frame(self.fr, {0: (0, 0, 1700)}, stick=(0, 0, 0, (300, 0, 1000)), untracked=(0,))
            # a very long line: 40 bodies, most not taken
            return frame(self.fr, {i: (i, 0, 1000) for i in range(40)}, stick=(0, 0, 0, (300, 0, 1000)))
        t = self.stream(4.5, make)
        # empty frames and cut ones between
        for k in range(20):
            self.send(b"")
            self.send(frame(999999, {0: (0, 0, 1)})[:-25])
            time.sleep(0.05)
        got = self.frames(700)
        t.join()
        states = [tuple(s["state"] for s in f["sensors"]) for f in got]
        # all three OK, then the head and left hand STALE while the right hand (the stick) stays OK
        self.assertIn(("OK", "OK", "OK"), states)
        self.assertIn(("STALE", "STALE", "OK"), states)
        st = self.d.status()["sources"][0]
        self.assertGreaterEqual(st["malformed"] - st0["malformed"], 20)
        self.assertGreater(st["datagrams"], st0["datagrams"] + 100)

    def test_zz_sender_stops(self):
        """no frame for timeout_ms: FAULTY (sensors MISSING); frames again: OK"""
        def make(k):
            type(self).fr += 1
            return frame(self.fr, {0: (0, 0, 1700), 1: (0, 0, 1000)}, stick=(0, 0, 0, (0, 0, 1000)))
        t = self.stream(1.0, make)
        wait_for("dt OK", lambda: self.d.status()["sources"][0]["state"] == "OK")
        t.join()
        t0 = time.time()
        wait_for("dt FAULTY", lambda: self.d.status()["sources"][0]["state"] == "FAULTY", limit=10)
        gone = time.time() - t0
        t = self.stream(2.0, make)
        t0 = time.time()
        wait_for("dt OK again", lambda: self.d.status()["sources"][0]["state"] == "OK", limit=10)
        back = time.time() - t0
        t.join()
        self.assertGreaterEqual(self.d.status()["sources"][0]["reconnects"], 1)
        print("\n  DTrack sender stopped: FAULTY after %.2f s; started again: OK after %.2f s" % (gone, back),
              file=sys.stderr)


class ProbeTest(unittest.TestCase):
    def test_probe_dtrack(self):
        port = free_port()
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        p = subprocess.Popen([DAEMON, "--probe", "dtrack://127.0.0.1:%d" % port], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
        try:
            end = time.time() + 1.8
            fr = 0
            time.sleep(0.2)
            while time.time() < end:
                fr += 1
                # y-up: the glasses 1.7 m up along y
                tx.sendto(frame(fr, {0: (0, 1700, 0), 2: (200, 1000, 300)}, stick=(1, 0, 0, (0, 1100, 300))),
                          ("127.0.0.1", port))
                time.sleep(1 / 60)
            out, err = p.communicate(timeout=10)
        finally:
            tx.close()
        self.assertEqual(p.returncode, 0, err)
        self.assertIn("type = dtrack", out)
        self.assertIn("port = %d" % port, out)
        self.assertIn("sensors = 3", out)
        self.assertIn("flysticks = 1", out)
        self.assertIn("\naxes = y-up", out)  # guessed from the heights, not commented
        lines = [ln for ln in out.splitlines() if ln.startswith(("0 ", "2 ", "f0 "))]
        self.assertEqual(len(lines), 3, out)

    def test_probe_vrpn_our_server(self):
        """a daemon's VRPN server probed both ways (called back with UDP reports, and TCP): its 13 tracker
        channels listed with their rates, and the configuration lines that read them"""
        vport, uport = free_port(socket.SOCK_STREAM), free_port()
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, PUBLISHER.format(uport=uport, vport=vport))
            try:
                for url, how in (("vrpn://Avatar0@127.0.0.1:%d" % vport, "called back"),
                                 ("vrpn://Avatar0@tcp://127.0.0.1:%d" % vport, "we connected")):
                    out = subprocess.run([DAEMON, "--probe", url], capture_output=True, text=True, timeout=30)
                    self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
                    self.assertIn(how, out.stdout)
                    self.assertIn("type = vrpn", out.stdout)
                    self.assertIn("device = %s" % url[len("vrpn://"):], out.stdout)
                    self.assertIn("sensors = 13", out.stdout)
                    rows = [ln.split() for ln in out.stdout.splitlines() if ln[:1].isdigit()]
                    self.assertEqual([int(r[0]) for r in rows], list(range(13)), out.stdout)
                    # every channel reported, about as often as the publisher's frames (240 Hz; a loaded host less)
                    for r in rows:
                        self.assertGreater(float(r[2]), 30, out.stdout)
            finally:
                self.assertEqual(d.stop(), 0)

    def test_probe_vrpn_nothing(self):
        port = free_port(socket.SOCK_STREAM)
        out = subprocess.run([DAEMON, "--probe", "vrpn://Tracker0@tcp://127.0.0.1:%d" % port], capture_output=True,
                             text=True, timeout=20)
        self.assertEqual(out.returncode, 1)
        self.assertIn("nothing received", out.stdout)

    def test_probe_bad_url(self):
        out = subprocess.run([DAEMON, "--probe", "http://x"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 64)


if __name__ == "__main__":
    unittest.main()
