# SPDX-License-Identifier: MIT
"""The Modbus side of the daemon against an independent peer, python3-pymodbus:

  - ServerTest: the daemon's Modbus TCP server (output type modbus) read with
    pymodbus while the same frames arrive over UDP: every register of the map
    (docs/MODBUS.md) against the FRAME of the same sequence number, the floats
    unpacked with struct in each of the four word orders; bad requests
    (raw MBAP frames) answered with the right exception and counted; broken
    headers closing the connection; silent and dribbling clients that do not
    hold the server; the writable scratch area; a reload that keeps clients.
  - SourceTest: the modbus source polling a pymodbus server (a Universal
    Robots style tool pose in int16, a tracker's float32 poses in word order
    CDAB) into an avatar's sensors; the server killed (FAULTY, sensors
    missing) and started again (OK); a register map the device refuses.

Run from the repository root: python3 -m unittest tests/e2e/test_modbus.py
(Debian's python3, where python3-pymodbus is; BUILD=build-san selects the
sanitizer build)."""
import math
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from busutil import DAEMON, Daemon, UdpFrames, free_port, import_pymodbus, until, wait_port  # noqa: E402

import_pymodbus()
from pymodbus.client import ModbusTcpClient  # noqa: E402

PEER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "modbus_peer.py")
ORDERS = ("abcd", "cdab", "badc", "dcba")
BLOCK = 66
VALID = 0x0100


def regs_bytes(r0, r1, order):
    """the four bytes A B C D (big endian) of a 32-bit value held in two registers"""
    b = struct.pack(">HH", r0, r1)
    return {"abcd": b, "cdab": b[2:4] + b[0:2], "badc": bytes([b[1], b[0], b[3], b[2]]), "dcba": b[::-1]}[order]


def f32(r, i, order):
    return struct.unpack(">f", regs_bytes(r[i], r[i + 1], order))[0]


def u32(r, i, order):
    return struct.unpack(">I", regs_bytes(r[i], r[i + 1], order))[0]


def centideg(rad):
    """what the map holds: 0.01 degree, rounded half away from zero"""
    v = rad * (18000.0 / math.pi)
    return int(math.copysign(math.floor(abs(v) + 0.5), v))


def s16(v):
    return v - 65536 if v >= 32768 else v


def mbap(tid, pdu, unit=1, proto=0, length=None):
    return struct.pack(">HHHB", tid, proto, len(pdu) + 1 if length is None else length, unit) + pdu


def recv_exactly(s, n, timeout=3):
    s.settimeout(timeout)
    out = b""
    while len(out) < n:
        d = s.recv(n - len(out))
        if not d:
            return out
        out += d
    return out


def closed_by_peer(s, timeout):
    """true if the daemon closes s within timeout (what it sends before is read and dropped)"""
    s.settimeout(timeout)
    try:
        while True:
            if not s.recv(512):
                return True
    except socket.timeout:
        return False
    except ConnectionResetError:
        return True


SERVER_CONF = """
[daemon]
rate = 120
[source sim]
type = sim
people = 2
[avatar a]
person = sim/p0
count = 2
[output udp]
type = udp
port = {udp}
[output abcd]
type = modbus
port = {p0}
[output cdab]
type = modbus
port = {p1}
word_order = cdab
register_base = 1000
register_stride = 200
[output badc]
type = modbus
port = {p2}
word_order = badc
[output dcba]
type = modbus
port = {p3}
word_order = dcba
avatars = a
[output strict]
type = modbus
port = {p4}
max_clients = 2
idle_timeout = 1
writable_registers = 4
"""


class ServerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.udp = free_port(socket.SOCK_DGRAM)
        cls.ports = [free_port() for _ in range(5)]
        cls.rx = UdpFrames(cls.udp)
        cls.d = Daemon(cls.tmpd.name, SERVER_CONF.format(udp=cls.udp, p0=cls.ports[0], p1=cls.ports[1],
                                                         p2=cls.ports[2], p3=cls.ports[3], p4=cls.ports[4]))
        for p in cls.ports:
            wait_port(p)
        until(lambda: cls.rx.latest(1), 5, "UDP frames")

    @classmethod
    def tearDownClass(cls):
        cls.rx.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def client(self, port):
        c = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
        self.assertTrue(c.connect())
        self.addCleanup(c.close)
        return c

    def check_block(self, r, f, order):
        """one block read over Modbus against the FRAME of the same sequence number"""
        self.assertEqual(len(r), BLOCK)
        self.assertEqual(r[0], 1, "map version")
        self.assertEqual(r[1], f["avatar"])
        self.assertEqual(r[2], f["seq"] & 0xFFFF)
        self.assertEqual(u32(r, 3, order), (f["t_ns"] // 1000000) & 0xFFFFFFFF)
        self.assertLess(r[5], 2000, "age of the block in ms")
        valid = all(math.isfinite(j) for j in f["joints"])
        self.assertEqual(r[6], (f["flags"] & 0x0F) | (VALID if valid else 0))
        self.assertEqual(r[7], sum(s["state"] << (2 * i) for i, s in enumerate(f["sensors"])))
        self.assertEqual(r[8], f["ik"][0])
        self.assertEqual(r[9], f["ik"][1])
        self.assertEqual(r[10], 17)
        self.assertTrue(valid)
        for j, rad in enumerate(f["joints"]):
            self.assertEqual(s16(r[12 + j]), centideg(rad), "joint %d int16" % j)
            # float32 over the registers, bit for bit the datagram's
            self.assertEqual(f32(r, 32 + 2 * j, order), rad, "joint %d float32 %s" % (j, order))
        self.assertEqual(r[29:32], [0, 0, 0])

    def test_registers_match_udp_in_every_word_order(self):
        outputs = [(self.ports[0], "abcd", 0, 100, (0, 1)), (self.ports[1], "cdab", 1000, 200, (0, 1)),
                   (self.ports[2], "badc", 0, 100, (0, 1)), (self.ports[3], "dcba", 0, 100, (0,))]
        reads = []
        for port, order, base, stride, avatars in outputs:
            c = self.client(port)
            for i in range(8):
                for k in avatars:
                    rr = c.read_input_registers(base + k * stride, BLOCK, slave=1)
                    self.assertFalse(rr.isError(), str(rr))
                    reads.append((order, k, rr.registers))
                time.sleep(0.02)
        time.sleep(0.2)
        frames = {(f["avatar"], f["seq"] & 0xFFFF): f for f in self.rx.snapshot()}
        for order, k, r in reads:
            self.assertEqual(r[1], k)
            f = frames.get((k, r[2]))
            self.assertIsNotNone(f, "frame %d of avatar %d not seen over UDP" % (r[2], k))
            with self.subTest(order=order, avatar=k, seq=r[2]):
                self.check_block(r, f, order)
        self.assertEqual(len(reads), 8 * 7)

    def test_one_request_is_one_frame(self):
        """a read across both avatars' blocks: each block from one frame (its int16 and float32 angles agree)"""
        c = self.client(self.ports[0])
        for _ in range(20):
            r = c.read_input_registers(60, 106, slave=1).registers  # end of avatar 0, gap, all of avatar 1
            self.assertEqual(r[6:40], [0] * 34, "the gap between blocks reads 0")
            b1 = r[40:106]
            self.assertEqual(b1[0], 1)
            self.assertEqual(b1[1], 1)
            for j in range(17):
                self.assertEqual(s16(b1[12 + j]), centideg(f32(b1, 32 + 2 * j, "abcd")))

    def test_layout_limits(self):
        c = self.client(self.ports[1])  # base 1000, stride 200, 2 avatars: 1000-1065 and 1200-1265
        self.assertFalse(c.read_input_registers(1000, 125, slave=1).isError())
        self.assertFalse(c.read_input_registers(1141, 125, slave=1).isError())
        for addr, count in ((999, 1), (1266, 1), (1142, 125), (0, 10)):
            rr = c.read_input_registers(addr, count, slave=1)
            self.assertTrue(rr.isError(), "%d+%d" % (addr, count))
            self.assertEqual(rr.exception_code, 2)
        # the unit identifier is echoed, whatever it is
        self.assertFalse(c.read_input_registers(1000, 1, slave=200).isError())

    def test_bad_requests_get_the_right_exception(self):
        before = self.d.output("badc")["modbus"]
        cases = [
            (b"\x04\x00\x00\x00\x00", 3),          # read 0 registers
            (b"\x04\x00\x00\x00\x7e", 3),          # read 126 registers
            (b"\x04\x00\xa6\x00\x01", 2),          # beyond the last block (0-65, 100-165)
            (b"\x04\x00\xa0\x00\x0a", 2),          # across its end
            (b"\x04\x00\x00\x00\x01\x00", 3),      # a PDU one byte too long: malformed
            (b"\x04\x00\x00", 3),                  # two bytes short: malformed
            (b"\x01\x00\x00\x00\x01", 1),          # coils: none here
            (b"\x02\x00\x00\x00\x01", 1),          # discrete inputs: none
            (b"\x03\x00\x00\x00\x01", 1),          # holding registers: none (writable_registers = 0)
            (b"\x05\x00\x00\xff\x00", 1),          # write a coil
            (b"\x06\x00\x00\x00\x01", 1),          # write a register: writes are off
            (b"\x10\x00\x00\x00\x01\x02\x00\x01", 1),  # write registers
            (b"\x17\x00\x00\x00\x01\x00\x00\x00\x01\x02\x00\x01", 1),  # read/write registers
            (b"\x2b\x0e\x01\x00", 1),              # read device identification
            (b"\x08\x00\x00\x12\x34", 1),          # diagnostics
        ]
        s = socket.create_connection(("127.0.0.1", self.ports[2]), timeout=3)
        try:
            for tid, (pdu, code) in enumerate(cases, start=100):
                s.sendall(mbap(tid, pdu, unit=7))
                rsp = recv_exactly(s, 9)
                with self.subTest(pdu=pdu.hex()):
                    self.assertEqual(len(rsp), 9, "no exception response")
                    t, proto, length, unit, fc, ex = struct.unpack(">HHHBBB", rsp)
                    self.assertEqual((t, proto, length, unit), (tid, 0, 3, 7))
                    self.assertEqual(fc, pdu[0] | 0x80)
                    self.assertEqual(ex, code)
            # the connection still serves
            s.sendall(mbap(1, b"\x04\x00\x00\x00\x02"))
            rsp = recv_exactly(s, 13)
            self.assertEqual(rsp[7:9], b"\x04\x04")
            self.assertEqual(struct.unpack(">H", rsp[9:11])[0], 1)
        finally:
            s.close()
        after = until(lambda: (lambda m: m if m["requests"] > before["requests"] else None)(
            self.d.output("badc")["modbus"]), 3, "the counters")
        self.assertEqual(after["illegal_function"] - before["illegal_function"], 9)
        self.assertEqual(after["illegal_address"] - before["illegal_address"], 2)
        self.assertEqual(after["illegal_value"] - before["illegal_value"], 4)
        self.assertEqual(after["malformed"] - before["malformed"], 2)
        self.assertEqual(after["writes_refused"] - before["writes_refused"], 4)
        self.assertEqual(after["writes"], 0)
        # pymodbus sees the same
        c = self.client(self.ports[2])
        rr = c.write_register(0, 5, slave=1)
        self.assertTrue(rr.isError())
        self.assertEqual(rr.exception_code, 1)
        rr = c.read_input_registers(166, 1, slave=1)
        self.assertEqual(rr.exception_code, 2)

    def test_broken_headers_close_the_connection(self):
        before = self.d.output("abcd")["modbus"]["malformed"]
        for frame in (mbap(1, b"\x04\x00\x00\x00\x01", proto=1),         # not Modbus
                      mbap(1, b"\x04\x00\x00\x00\x01", length=1),        # no function code
                      mbap(1, b"\x04\x00\x00\x00\x01", length=300)):     # longer than any request
            s = socket.create_connection(("127.0.0.1", self.ports[0]), timeout=3)
            s.sendall(frame)
            self.assertTrue(closed_by_peer(s, 3), frame.hex())
            s.close()
        until(lambda: self.d.output("abcd")["modbus"]["malformed"] == before + 3, 3, "malformed == +3")
        # others carry on
        self.assertFalse(self.client(self.ports[0]).read_input_registers(0, 1, slave=1).isError())

    def test_silent_clients_do_not_hold_the_server(self):
        # a client that never speaks and one that stops in the middle of a request
        silent = socket.create_connection(("127.0.0.1", self.ports[0]))
        dribble = socket.create_connection(("127.0.0.1", self.ports[0]))
        dribble.sendall(mbap(9, b"\x04\x00\x00\x00\x01")[:5])
        self.addCleanup(silent.close)
        self.addCleanup(dribble.close)
        c = self.client(self.ports[0])
        for _ in range(10):
            rr = c.read_input_registers(0, BLOCK, slave=1)
            self.assertFalse(rr.isError())
        # half a request is given a second, then the connection goes
        self.assertTrue(closed_by_peer(dribble, 4))

    def test_idle_clients_are_closed_and_slots_freed(self):
        """max_clients = 2, idle_timeout = 1 s: two silent clients take every slot, for a second"""
        before = self.d.output("strict")
        a = socket.create_connection(("127.0.0.1", self.ports[4]))
        b = socket.create_connection(("127.0.0.1", self.ports[4]))
        self.addCleanup(a.close)
        self.addCleanup(b.close)
        until(lambda: self.d.output("strict")["clients"] == 2, 3, "two clients")
        third = socket.create_connection(("127.0.0.1", self.ports[4]))
        self.assertTrue(closed_by_peer(third, 3), "a third client is refused")
        third.close()
        self.assertTrue(closed_by_peer(a, 4))
        self.assertTrue(closed_by_peer(b, 4))
        after = until(lambda: (lambda o: o if o["clients"] == 0 else None)(self.d.output("strict")), 3, "no clients")
        self.assertGreaterEqual(after["refused"] - before["refused"], 1)
        self.assertEqual(after["modbus"]["idle_closed"] - before["modbus"]["idle_closed"], 2)
        self.assertFalse(self.client(self.ports[4]).read_input_registers(0, 1, slave=1).isError())

    def test_writable_scratch_registers(self):
        c = self.client(self.ports[4])
        self.assertFalse(c.write_registers(0, [11, 22, 33, 44], slave=1).isError())
        self.assertEqual(c.read_holding_registers(0, 4, slave=1).registers, [11, 22, 33, 44])
        self.assertFalse(c.write_register(2, 0xBEEF, slave=1).isError())
        self.assertEqual(c.read_holding_registers(2, 1, slave=1).registers, [0xBEEF])
        for rr in (c.write_register(4, 1, slave=1), c.read_holding_registers(3, 2, slave=1),
                   c.write_registers(3, [1, 2], slave=1)):
            self.assertTrue(rr.isError())
            self.assertEqual(rr.exception_code, 2)
        # coils are still no part of it
        self.assertEqual(c.write_coil(0, True, slave=1).exception_code, 1)
        # the map itself is read-only whatever the scratch area
        self.assertEqual(c.read_input_registers(0, 1, slave=1).registers, [1])
        self.assertEqual(self.d.output("strict")["modbus"]["writes"], 2)


class ReloadTest(unittest.TestCase):
    def test_reload_keeps_clients_and_applies_new_settings(self):
        with tempfile.TemporaryDirectory() as tmp:
            port, udp = free_port(), free_port(socket.SOCK_DGRAM)
            conf = ("[source sim]\ntype = sim\n[avatar a]\nperson = sim/p0\n[output udp]\ntype = udp\nport = %d\n"
                    "[output plc]\ntype = modbus\nport = %d\nword_order = %s\n")
            d = Daemon(tmp, conf % (udp, port, "abcd"))
            try:
                wait_port(port)
                c = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
                self.assertTrue(c.connect())
                # the map version reads 0 until the avatar's first frame
                until(lambda: c.read_input_registers(0, 1, slave=1).registers == [1], 5, "the first frame")
                # (the table's columns follow the server thread's counters at the next cycle)
                # (wait_port's connection was the first: this client is the second)
                before = until(lambda: (lambda o: o if o["clients"] == 1 and o["accepted"] == 2 else None)(
                    d.output("plc")), 3, "the client")
                # the same settings: the server and its client carry on, the same connection
                d.proc.send_signal(signal.SIGHUP)
                until(lambda: d.status()["reloads"] == 1, 5, "the reload")
                self.assertFalse(c.read_input_registers(0, 66, slave=1).isError())
                after = until(lambda: (lambda o: o if o["sent"] > before["sent"] else None)(d.output("plc")), 3,
                              "the answer counted")
                self.assertEqual(after["accepted"], before["accepted"])
                self.assertEqual(after["clients"], 1)
                self.assertEqual(after["modbus"]["requests"], before["modbus"]["requests"] + 1)
                # another word order: a new server on the same port (the old one closes)
                with open(d.conf, "w") as f:
                    f.write(conf % (udp, port, "dcba"))
                d.proc.send_signal(signal.SIGHUP)
                until(lambda: d.status()["reloads"] == 2, 5, "the second reload")
                c.close()
                c = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
                self.assertTrue(c.connect())
                r = until(lambda: (lambda rr: None if rr.isError() or rr.registers[0] != 1 else rr.registers)(
                    c.read_input_registers(0, 66, slave=1)), 5, "a block from the new server")
                self.assertEqual(r[6] & 0x0100, 0x0100)
                for j in range(17):
                    self.assertEqual(s16(r[12 + j]), centideg(f32(r, 32 + 2 * j, "dcba")))
                c.close()
            finally:
                self.assertEqual(d.stop(), 0)


SOURCE_CONF = """
[daemon]
rate = 100
stale_ms = 300
[source sim]
type = sim
[source robot]
type = modbus
address = 127.0.0.1
port = {port}
position_register = 400
orientation_register = 403
position_scale = 0.0001
poll_rate = 50
timeout_ms = 200
[source tracker]
type = modbus
address = 127.0.0.1
port = {port}
register_type = input
sensors = 2
sensor_stride = 20
position_register = 100
position_format = float32
position_scale = 1
orientation_register = 106
orientation_format = float32
orientation_scale = 1
orientation = quat_xyzw
word_order = cdab
[source wrong]
type = modbus
address = 127.0.0.1
port = {port}
position_register = 2000
orientation = none
[avatar a]
person = sim/p0
right_hand = robot/pose0
left_hand = tracker/pose1
[output udp]
type = udp
port = {udp}
"""


def f32_regs(v, order):
    """two registers holding the float v in a word order"""
    b = struct.pack(">f", v)
    w = regs_bytes(*struct.unpack(">HH", b), order)  # the permutation is its own inverse
    return list(struct.unpack(">HH", w))


def rotvec_quat(rx, ry, rz):
    a = math.sqrt(rx * rx + ry * ry + rz * rz)
    s = math.sin(a / 2) / a
    return (math.cos(a / 2), rx * s, ry * s, rz * s)


class SourceTest(unittest.TestCase):
    # Universal Robots style: x y z in 0.1 mm, rx ry rz in mrad, int16 (negative as two's complement)
    UR = [4123, -2500, 3000, 100, -1200, 2000]
    TRACKER_P = (1.5, -0.5, 0.25)
    TRACKER_Q = (0.1, -0.3, 0.5, 0.806225774829855)  # x y z w

    def start_peer(self):
        args = [sys.executable, PEER, str(self.port), "h:400=" + ",".join(str(v) for v in self.UR)]
        regs = []
        for v in self.TRACKER_P + self.TRACKER_Q:
            regs += f32_regs(v, "cdab")
        # pose0 of the tracker: a zero quaternion (malformed); pose1, 20 registers on, the real one
        args.append("i:100=" + ",".join(str(v) for v in f32_regs(1.0, "cdab") * 3 + [0] * 8))
        args.append("i:120=" + ",".join(str(v) for v in regs))
        p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_port(self.port)
        return p

    def setUp(self):
        self.tmpd = tempfile.TemporaryDirectory()
        self.port, self.udp = free_port(), free_port(socket.SOCK_DGRAM)
        self.peer = self.start_peer()
        self.rx = UdpFrames(self.udp)
        self.d = Daemon(self.tmpd.name, SOURCE_CONF.format(port=self.port, udp=self.udp))

    def tearDown(self):
        self.rx.close()
        if self.peer.poll() is None:
            self.peer.kill()
            self.peer.wait()
        rc = self.d.stop()
        self.tmpd.cleanup()
        self.assertEqual(rc, 0)

    def hands_ok(self):
        f = self.rx.latest(0)
        return f if f and f["sensors"][2]["state"] == 0 and f["sensors"][1]["state"] == 0 else None

    def check_poses(self, f):
        rh, lh = f["sensors"][2], f["sensors"][1]
        for got, want in zip(rh["p"], (0.4123, -0.25, 0.3)):
            self.assertAlmostEqual(got, want, delta=1e-6)
        q = rotvec_quat(0.1, -1.2, 2.0)
        sign = 1 if sum(a * b for a, b in zip(rh["q"], q)) > 0 else -1
        for got, want in zip(rh["q"], q):
            self.assertAlmostEqual(got, sign * want, delta=1e-6)
        for got, want in zip(lh["p"], self.TRACKER_P):
            self.assertAlmostEqual(got, want, delta=1e-6)
        x, y, z, w = self.TRACKER_Q
        n = math.sqrt(x * x + y * y + z * z + w * w)
        for got, want in zip(lh["q"], (w / n, x / n, y / n, z / n)):
            self.assertAlmostEqual(got, want, delta=1e-6)

    def test_poses_outage_and_recovery(self):
        f = until(self.hands_ok, 10, "both hands from the Modbus device")
        self.check_poses(f)
        st = self.d.status()
        src = {s["name"]: s for s in st["sources"]}
        self.assertEqual(src["robot"]["state"], "OK")
        self.assertEqual(src["robot"]["modbus"]["link"], "up")
        self.assertEqual(src["robot"]["modbus"]["reads_per_poll"], 1)  # 400-405 in one request
        self.assertEqual(src["tracker"]["modbus"]["reads_per_poll"], 2)  # 100-113 and 120-133, not adjacent
        self.assertGreater(src["tracker"]["malformed"], 0)  # pose0's zero quaternion, every poll
        self.assertGreater(src["robot"]["samples"], 0)
        # the device disappears: FAULTY, the hands MISSING, the daemon runs on
        self.peer.kill()
        self.peer.wait()
        until(lambda: self.d.source("robot")["state"] == "FAULTY", 5, "robot FAULTY")
        until(lambda: (lambda f: f and f["sensors"][2]["state"] == 2)(self.rx.latest(0)), 5, "right hand MISSING")
        f = self.rx.latest(0)
        self.assertTrue(all(math.isnan(v) for v in f["sensors"][2]["p"]))
        time.sleep(1.0)
        down = self.d.source("robot")
        self.assertEqual(down["state"], "FAULTY")
        self.assertEqual(down["faults"], 1)
        self.assertEqual(down["modbus"]["link"], "down")
        self.assertGreaterEqual(down["modbus"]["losses"], 1)
        # it comes back: OK again, on its own
        self.peer = self.start_peer()
        until(lambda: self.d.source("robot")["state"] == "OK", 10, "robot OK again")
        self.rx.clear()
        f = until(self.hands_ok, 5, "both hands again")
        self.check_poses(f)
        up = self.d.source("robot")
        self.assertGreaterEqual(up["modbus"]["connects"], 2)
        self.assertEqual(up["faults"], 1)
        err = self.d.stderr()
        self.assertIn("source robot: Modbus 127.0.0.1:%d: answering again" % self.port, err)

    def test_a_map_the_device_refuses(self):
        until(self.hands_ok, 10, "the hands")
        w = until(lambda: (lambda s: s if s["modbus"]["exceptions"] > 0 else None)(self.d.source("wrong")), 5,
                  "exceptions")
        self.assertEqual(w["state"], "FAULTY")
        self.assertEqual(w["samples"], 0)
        self.assertEqual(w["modbus"]["link"], "down")
        self.assertIn("Illegal data address", w["modbus"]["last_error"])
        self.assertEqual(w["modbus"]["losses"], 0)  # the connection stays


class ConfigTest(unittest.TestCase):
    def check(self, text, want):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "x.conf")
            with open(path, "w") as f:
                f.write(text)
            out = subprocess.run([DAEMON, "-c", path, "--check-config"], capture_output=True, text=True)
            self.assertEqual(out.returncode, 78, out.stdout)
            self.assertIn(want, out.stderr)

    def test_errors(self):
        self.check("[output plc]\ntype = modbus\n", "x.conf:2: [output plc] port: missing")
        self.check("[source r]\ntype = modbus\n", "[source r] address: missing")
        self.check("[source r]\ntype = modbus\naddress = h\nunit_id = 250\n", "unit_id: 250 is reserved")
        self.check("[source r]\ntype = modbus\naddress = h\nsensors = 2\n", "sensor_stride: missing")
        self.check("[source r]\ntype = modbus\naddress = h\nposition_register = 3\n", "overlap")
        self.check("[source r]\ntype = modbus\naddress = h\nposition_register = 65534\n", "beyond register 65535")
        self.check("[output plc]\ntype = modbus\nport = 1502\nregister_stride = 60\n", "register_stride: 60 is out")
        self.check("[output plc]\ntype = modbus\nport = 1502\nword_order = abdc\n", "is not one of: abcd")


if __name__ == "__main__":
    unittest.main()
