# SPDX-License-Identifier: MIT
"""The CAN side of the daemon, on a kernel without CAN: the daemon's CAN
socket is one end of a socketpair(AF_UNIX, SOCK_SEQPACKET) it inherits
(interface = fd:N), the test holds the other end and packs and unpacks
struct can_frame records (16 bytes) with struct.

  - OutputTest: the can output's commands against the UDP stream's frames
    (plain mode: every angle; safe mode: limits, speed, and silence once
    the sensors are stale);
  - InputTest: sensor frames sent by the test become an avatar's sensors;
    unknown identifiers and wrong lengths are counted and change nothing;
  - NoCanTest: an output and a source on a CAN interface this kernel cannot
    have: one log line each, and the daemon serves everything else;
  - DbcTest: docs/avatargw.dbc read by a small DBC decoder of this file
    decodes the golden frames (tests/data/can_*.log) to their known values.

Run from the repository root: python3 -m unittest tests/e2e/test_can.py"""
import math
import os
import re
import socket
import struct
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from busutil import ROOT, Daemon, UdpFrames, free_port, until  # noqa: E402

CAN_FRAME = struct.Struct("<IB3x8s")  # struct can_frame: can_id, len, pad, data[8]
EFF = 0x80000000
DATA = os.path.join(ROOT, "tests", "data")
# the limits of the DESCRIBE, degrees: chest yaw (the head's heading: any), then the default j1..j8 of
# config/avatargw.conf for each arm
LIMITS = [(-180, 180)] + [(-30, 30), (-170, 30), (-60, 120), (-90, 90), (-90, 60), (-90, 90), (-30, 30), (-80, 80)] * 2
F_VALID, F_SAFE, F_LIMITED = 0x80, 0x40, 0x10


def centideg(rad):
    v = rad * (18000.0 / math.pi)
    if math.isnan(v):
        return -32768
    v = max(-32767.0, min(32767.0, v))
    return int(math.copysign(math.floor(abs(v) + 0.5), v))


def unpack_command(frames):
    """5 frames (RIGHT_1, RIGHT_2, LEFT_1, LEFT_2, STATUS) into a dict"""
    st = frames[4][1]
    counter, flags, sensors, ik, chest, age = struct.unpack("<BBBBhH", st)
    joints = [chest]
    for _, d in frames[:4]:
        joints += list(struct.unpack("<4h", d))
    return {"counter": counter, "flags": flags, "sensors": sensors, "ik": ik, "age": age, "joints": joints}


class CanPeer:
    """the test's end of the daemon's CAN socket: a thread reading commands"""

    def __init__(self, base=0x100):
        self.mine, self.theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.base = base
        self.commands = {}  # the output's avatar index -> list of commands
        self.pending = {}
        self.odd = []
        self.lock = threading.Lock()
        self.running = True
        self.mine.settimeout(0.1)
        self.th = threading.Thread(target=self._run, daemon=True)
        self.th.start()

    def _run(self):
        while self.running:
            try:
                rec = self.mine.recv(72)
            except socket.timeout:
                continue
            except OSError:
                return
            if not rec:
                return
            if len(rec) != CAN_FRAME.size:
                self.odd.append(rec)
                continue
            can_id, n, data = CAN_FRAME.unpack(rec)
            k, i = divmod((can_id & 0x7FF) - self.base, 8)
            with self.lock:
                p = self.pending.setdefault(k, [])
                p.append((i, data[:n]))
                if i == 0:  # STATUS closes a command
                    if [x[0] for x in p] == [1, 2, 3, 4, 0]:
                        self.commands.setdefault(k, []).append(unpack_command(p))
                    else:
                        self.odd.append(p)
                    self.pending[k] = []

    def take(self, k):
        with self.lock:
            return list(self.commands.get(k, []))

    def close(self):
        self.running = False
        self.th.join()
        self.mine.close()
        self.theirs.close()


OUT_CONF = """
[daemon]
rate = 120
[source sim]
type = sim
people = 2
[source clip]
type = replay
file = builtin:cmu_141_16.csv
start = 3.4
loop = no
[avatar a]
person = sim/p0
count = 2
[avatar clip]
person = clip
[output udp]
type = udp
port = {udp}
[output plain]
type = can
interface = fd:{fd_plain}
safe = no
[output safe]
type = can
interface = fd:{fd_safe}
avatars = a-0 clip
"""


class OutputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.udp = free_port(socket.SOCK_DGRAM)
        cls.plain, cls.safe = CanPeer(), CanPeer()
        cls.rx = UdpFrames(cls.udp)
        fds = (cls.plain.theirs.fileno(), cls.safe.theirs.fileno())
        cls.d = Daemon(cls.tmpd.name, OUT_CONF.format(udp=cls.udp, fd_plain=fds[0], fd_safe=fds[1]), pass_fds=fds)
        # the replayed clip runs out after 1.6 s: its avatar goes stale and stays so
        until(lambda: (lambda f: f and f["flags"] & 1)(cls.rx.latest(2)), 10, "the clip to end")
        time.sleep(0.5)
        cls.frames = cls.rx.snapshot()
        cls.rx.close()
        cls.status = cls.d.status()
        cls.rc = cls.d.stop()
        time.sleep(0.1)
        cls.plain.close()
        cls.safe.close()

    @classmethod
    def tearDownClass(cls):
        cls.tmpd.cleanup()
        assert cls.rc == 0, "daemon exit status %s" % cls.rc

    def by_joints(self, avatar):
        """frames by their angles in 0.01 degree (without a new sample, several frames have the same)"""
        out = {}
        for f in self.frames:
            if f["avatar"] == avatar:
                out.setdefault(tuple(centideg(j) for j in f["joints"]), []).append(f)
        return out

    def test_plain_commands_are_the_frames(self):
        """every command of plain mode is a FRAME of the UDP stream, angle for angle"""
        for k in (0, 1, 2):
            cmds = self.plain.take(k)
            self.assertGreater(len(cmds), 100)
            udp = self.by_joints(k)
            matched = 0
            for i, c in enumerate(cmds):
                self.assertEqual(c["counter"], i % 256)
                same = udp.get(tuple(c["joints"]))
                if same is None:
                    continue  # a frame sent before the UDP receiver listened, or after it stopped
                matched += 1
                want = [((f["flags"] & 0x0F) | (F_VALID if all(math.isfinite(j) for j in f["joints"]) else 0),
                         sum(s["state"] << (2 * i) for i, s in enumerate(f["sensors"])),
                         (f["ik"][0] & 1) | (f["ik"][1] & 1) << 1) for f in same]
                self.assertIn((c["flags"], c["sensors"], c["ik"]), want)
            self.assertGreater(matched, 0.9 * len(cmds), "avatar %d: %d of %d commands" % (k, matched, len(cmds)))
        self.assertEqual(self.plain.odd, [])

    def test_safe_commands(self):
        """within the limits, no faster than max_speed, nothing stale"""
        out = {o["name"]: o for o in self.status["outputs"]}["safe"]
        self.assertEqual(out["can"]["state"], "open")
        self.assertTrue(out["can"]["safe"])
        # this output publishes a-0 (its avatar 0) and clip (its avatar 1), not a-1
        self.assertEqual(self.safe.take(2), [])
        per_cmd = 90 / 120 * 100  # max_speed 90 deg/s at 120 Hz, in 0.01 degree
        for k in (0, 1):
            cmds = self.safe.take(k)
            self.assertGreater(len(cmds), 100)
            for i, c in enumerate(cmds):
                # never stale, held or unreached; always valid, marked safe
                self.assertEqual(c["flags"] & (F_VALID | F_SAFE | 0x07), F_VALID | F_SAFE)
                for j, v in enumerate(c["joints"]):
                    lo, hi = LIMITS[j]
                    self.assertTrue(lo * 100 <= v <= hi * 100, "joint %d = %d" % (j, v))
                if i:
                    step = max(abs(a - b) for a, b in zip(c["joints"], cmds[i - 1]["joints"]))
                    self.assertLessEqual(step, per_cmd + 1, "command %d" % i)
        # the clip ended: every frame since is stale. Safe mode sent none of them (no command above is
        # flagged stale), it withheld them; plain mode went on sending them, flagged.
        stale = [f for f in self.frames if f["avatar"] == 2 and f["flags"] & 1]
        self.assertGreater(len(stale), 30)
        self.assertGreaterEqual(out["can"]["withheld"], len(stale))
        self.assertGreater(len([c for c in self.plain.take(2) if c["flags"] & 0x01]), 30)
        self.assertTrue(self.plain.take(2)[-1]["flags"] & 0x01)

IN_CONF = """
[daemon]
rate = 100
stale_ms = 200
[source sim]
type = sim
[source bus]
type = can
interface = fd:{fd}
sensors = 2
[avatar a]
person = sim/p0
right_hand = bus/pose0
left_hand = bus/pose1
[output udp]
type = udp
port = {udp}
"""


def q16(q):
    n = math.sqrt(sum(c * c for c in q))
    return [int(round(c / n * 32768)) if c / n < 1 else 32767 for c in q]


class InputTest(unittest.TestCase):
    POSES = [((0.3, -0.2, 1.1), (0.9, 0.1, -0.2, 0.3)), ((-0.3, -0.25, 1.0), (1.0, 0.0, 0.0, 0.0))]

    def frame(self, can_id, data):
        return CAN_FRAME.pack(can_id, len(data), data.ljust(8, b"\0"))

    def test_sensor_frames(self):
        a, b = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        udp = free_port(socket.SOCK_DGRAM)
        rx = UdpFrames(udp)
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, IN_CONF.format(fd=b.fileno(), udp=udp), pass_fds=(b.fileno(),))
            b.close()
            sent = {"good": 0, "unknown": 0, "bad_length": 0, "bad_value": 0}
            try:
                for cycle in range(60):
                    for k, (p, q) in enumerate(self.POSES):
                        a.send(self.frame(0x200 + k, struct.pack("<4h", *q16(q))))
                        a.send(self.frame(0x280 + k, struct.pack("<3h", *(int(round(v * 1000)) for v in p))))
                        sent["good"] += 2
                    # what a shared bus also carries, and what a broken sensor sends
                    a.send(self.frame(0x300, b"\x01\x02"))
                    a.send(self.frame(0x202 | EFF, bytes(8)))
                    sent["unknown"] += 2
                    if cycle % 10 == 0:
                        a.send(self.frame(0x200, bytes(6)))             # an orientation of 6 bytes
                        a.send(bytes(72))                                # a CAN FD record
                        a.send(self.frame(0x201, bytes(8)))             # a zero quaternion
                        a.send(self.frame(0x200, struct.pack("<4h", 16384, 0, 0, 0)))  # half length
                        sent["bad_length"] += 2
                        sent["bad_value"] += 2
                    time.sleep(0.01)
                total = sum(sent.values()) - 6  # the CAN FD records are no frames
                src = until(lambda: (lambda s: s if s["can"]["frames"] == total else None)(d.source("bus")), 5,
                            "every frame read")
                self.assertEqual(src["state"], "OK")
                self.assertEqual(src["can"]["unknown_id"], sent["unknown"])
                self.assertEqual(src["can"]["bad_length"], sent["bad_length"])
                self.assertEqual(src["can"]["bad_value"], sent["bad_value"])
                self.assertEqual(src["malformed"], sent["bad_length"] + sent["bad_value"])
                f = until(lambda: (lambda f: f if f and f["sensors"][2]["state"] == 0 else None)(rx.latest(0)), 3,
                          "the right hand")
                # the poses sent, nothing of the rest: right hand = pose0, left hand = pose1
                for sensor, (p, q) in zip((2, 1), self.POSES):
                    got = f["sensors"][sensor]
                    self.assertEqual(got["state"], 0)
                    for g, w in zip(got["p"], p):
                        self.assertAlmostEqual(g, w, delta=1e-6)
                    n = math.sqrt(sum(c * c for c in q))
                    for g, w in zip(got["q"], q):
                        self.assertAlmostEqual(g, w / n, delta=1e-4)
                # silence: the hands go stale, the source with them
                until(lambda: (lambda f: f and f["sensors"][2]["state"] == 1)(rx.latest(0)), 3, "stale hands")
                self.assertEqual(d.source("bus")["state"], "STALE")
            finally:
                rx.close()
                a.close()
                self.assertEqual(d.stop(), 0)


NOCAN_CONF = """
[source sim]
type = sim
[source bus]
type = can
interface = agwnocan0
[avatar a]
person = sim/p0
[avatar b]
person = sim/p0
left_hand = bus/pose0
[output udp]
type = udp
port = {udp}
[output arm]
type = can
interface = agwnocan0
"""


class NoCanTest(unittest.TestCase):
    def test_no_can_here(self):
        """this kernel has no CAN (a kernel with CAN has no agwnocan0): the daemon runs without them"""
        udp = free_port(socket.SOCK_DGRAM)
        rx = UdpFrames(udp)
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, NOCAN_CONF.format(udp=udp))
            try:
                until(lambda: rx.latest(1), 5, "frames over UDP")
                time.sleep(1.5)
                st = d.status()
                src = {s["name"]: s for s in st["sources"]}["bus"]
                out = {o["name"]: o for o in st["outputs"]}
                self.assertEqual(src["state"], "FAULTY")
                self.assertEqual(src["faults"], 1)
                self.assertEqual(src["can"]["state"], "disabled")
                self.assertEqual(out["arm"]["can"]["state"], "disabled")
                self.assertEqual(out["arm"]["sent"], 0)
                self.assertGreater(out["udp"]["sent"], 100)
                # avatar a needs no CAN; b's left hand is missing, the rest of b is there
                self.assertEqual(rx.latest(0)["flags"] & 1, 0)
                self.assertEqual([s["state"] for s in rx.latest(1)["sensors"]], [0, 2, 0])
                self.assertTrue(all(math.isfinite(j) for j in rx.latest(1)["joints"]))
            finally:
                rx.close()
                self.assertEqual(d.stop(), 0)
            lines = d.stderr().splitlines()
            can = [x for x in lines if "agwnocan0" in x]
            print("\n".join(can))
            self.assertEqual(len(can), 2, "one line for the source, one for the output")
            self.assertIn("source bus: agwnocan0: ", can[0])
            self.assertIn("CAN source disabled", can[0])
            self.assertIn("output arm: agwnocan0: ", can[1])
            self.assertIn("CAN output disabled, the daemon carries on without it", can[1])
            for x in can:
                self.assertTrue("no CAN support" in x or "no such CAN interface" in x, x)


def read_dbc(path):
    """the messages of a DBC file: {id: (name, dlc, {signal: (start, length, signed, factor, offset)})}"""
    msgs, cur = {}, None
    bo = re.compile(r"^BO_ (\d+) (\w+): (\d+) (\w+)\s*$")
    sg = re.compile(r"^ SG_ (\w+) : (\d+)\|(\d+)@([01])([+-]) \(([-\d.eE+]+),([-\d.eE+]+)\) "
                    r"\[([-\d.eE+]+)\|([-\d.eE+]+)\] \"([^\"]*)\" [\w,]+\s*$")
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            m = bo.match(line)
            if m:
                cur = {}
                msgs[int(m.group(1))] = (m.group(2), int(m.group(3)), cur)
                continue
            if line.startswith(" SG_"):
                m = sg.match(line)
                assert m, "not a signal line: " + line
                assert m.group(4) == "1", "little-endian (Intel) signals only: " + line
                cur[m.group(1)] = (int(m.group(2)), int(m.group(3)), m.group(5) == "-", float(m.group(6)),
                                   float(m.group(7)))
            elif not line.strip():
                cur = None
    return msgs


def dbc_decode(msg, data):
    raw = int.from_bytes(data, "little")
    out = {}
    for name, (start, length, signed, factor, offset) in msg[2].items():
        v = (raw >> start) & ((1 << length) - 1)
        if signed and v >> (length - 1):
            v -= 1 << length
        out[name] = v * factor + offset
    return out


def read_log(path):
    frames = []
    with open(path) as f:
        for line in f:
            m = re.match(r"^\((\d+)\.(\d{6})\) (\S+) ([0-9A-F]{3}|[0-9A-F]{8})#([0-9A-F]*)$", line.strip())
            assert m, line
            ident = int(m.group(4), 16) | (EFF if len(m.group(4)) == 8 else 0)
            frames.append((ident, bytes.fromhex(m.group(5))))
    return frames


class DbcTest(unittest.TestCase):
    """docs/avatargw.dbc against the golden frames, decoded by the DBC's own definitions"""
    NAMES = ["chest_yaw", "r_girdle", "r_sh_abd", "r_sh_flex", "r_sh_rot", "r_elbow", "r_pronation", "r_wr_flex",
             "r_wr_dev", "l_girdle", "l_sh_abd", "l_sh_flex", "l_sh_rot", "l_elbow", "l_pronation", "l_wr_flex",
             "l_wr_dev"]

    def setUp(self):
        self.dbc = read_dbc(os.path.join(ROOT, "docs", "avatargw.dbc"))

    def test_layout(self):
        self.assertEqual(sorted(self.dbc), [256, 257, 258, 259, 260, 512, 640])
        names = []
        for i in range(5):
            name, dlc, sigs = self.dbc[256 + i]
            self.assertEqual(dlc, 8)
            for s, (start, length, signed, factor, offset) in sigs.items():
                self.assertLessEqual(start + length, 64, s)
                if s in self.NAMES:
                    names.append(s)
                    self.assertEqual((length, signed, factor, offset), (16, True, 0.01, 0.0), s)
        self.assertEqual(sorted(names), sorted(self.NAMES))

    def test_golden_joint_frames(self):
        frames = read_log(os.path.join(DATA, "can_joints.log"))
        cmds = []
        with open(os.path.join(DATA, "can_joints.txt")) as f:
            for line in f:
                if not line.startswith("#"):
                    cmds.append(line.split())
        self.assertEqual(len(frames), 5 * len(cmds))
        for n, c in enumerate(cmds):
            ext, id0, counter, flags, sensors, ik, age = (int(v, 0) for v in c[:7])
            deg = [float(v) for v in c[7:]]
            got = {}
            for ident, data in frames[5 * n:5 * n + 5]:
                self.assertEqual(bool(ident & EFF), bool(ext))
                msg = self.dbc[256 + (ident & ~EFF) - id0]
                self.assertEqual(len(data), msg[1])
                got.update(dbc_decode(msg, data))
            with self.subTest(command=n):
                self.assertEqual(got["counter"], counter)
                for bit, name in enumerate(["stale", "unreached", "held", "new_sample", "limited", None, "safe",
                                            "valid"]):
                    if name:
                        self.assertEqual(got[name], (flags >> bit) & 1, name)
                self.assertEqual([got["head_state"], got["left_hand_state"], got["right_hand_state"]],
                                 [(sensors >> (2 * i)) & 3 for i in range(3)])
                self.assertEqual([got["right_reached"], got["left_reached"]], [ik & 1, ik >> 1 & 1])
                self.assertEqual(got["age"], age)
                for name, want in zip(self.NAMES, deg):
                    if math.isnan(want):
                        self.assertAlmostEqual(got[name], -327.68, delta=1e-9)  # the "unknown" value
                    else:
                        self.assertAlmostEqual(got[name], max(-327.67, min(327.67, want)), delta=0.005 + 1e-9, msg=name)

    def test_golden_sensor_frames(self):
        frames = read_log(os.path.join(DATA, "can_sensors.log"))
        with open(os.path.join(DATA, "can_sensors.txt")) as f:
            what = [line.split() for line in f if not line.startswith("#")]
        checked = 0
        for (ident, data), w in zip(frames, what):
            if w[0] not in ("ori", "pos") or int(w[1]) != 0:
                continue
            msg = self.dbc[512 if w[0] == "ori" else 640]
            got = dbc_decode(msg, data[:msg[1]])
            keys = ["qw", "qx", "qy", "qz"] if w[0] == "ori" else ["x", "y", "z"]
            for k, v in zip(keys, w[2:]):
                self.assertAlmostEqual(got[k], float(v), delta=1e-4)
            checked += 1
        self.assertEqual(checked, 3)


if __name__ == "__main__":
    unittest.main()
