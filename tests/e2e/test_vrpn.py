# SPDX-License-Identifier: MIT
"""The VRPN server against our own VRPN client (vrpn_client.py, written from
the protocol description), checked report by report against the UDP stream
of the same daemon; clients that stall or send garbage are dropped while a
good client keeps receiving.

Run from the repository root: python3 -m unittest tests/e2e/test_vrpn.py"""
import math
import os
import socket
import struct
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_daemon import Daemon, free_port  # noqa: E402
import vrpn_client as vc  # noqa: E402
from wireframe import UdpListener  # noqa: E402

CONF = """
[daemon]
rate = 240
[source clip]
type = replay
file = builtin:cmu_141_16.csv
[source sim]
type = sim
people = 1
[avatar demo]
id = 0
person = clip
[avatar seven]
id = 7
person = sim/p0
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
[output vrpn]
type = vrpn
address = 127.0.0.1
port = {vport}
client_buffer = 8192
client_timeout = 1
max_clients = 6
; every test client comes from 127.0.0.1: no limit per address but max_clients
clients_per_address = 0
"""


def report_groups(events, device):
    """the tracker reports and analog of each frame, in order: [(t_us, {sensor: (p, q)}, analog or None)]"""
    out = []
    cur = None
    for _, kind, dev, sec, usec, data in events:
        if dev != device or kind not in (vc.POS_QUAT, vc.ANALOG):
            continue
        t = sec * 1000000 + usec
        if kind == vc.POS_QUAT:
            s, p, q = data
            if cur is None or cur[2] is not None or cur[0] != t or s <= max(cur[1]):
                cur = [t, {}, None]
                out.append(cur)
            cur[1][s] = (p, q)
        else:
            if cur is None or cur[0] != t or cur[2] is not None:
                cur = [t, {}, None]
                out.append(cur)
            cur[2] = data
    return out


def expected_poses(frame):
    """the 13 VRPN sensors of a FRAME: segments 0-9, then the raw sensors; quaternions x y z w"""
    poses = {}
    for s in range(13):
        pose = frame["segments"][s] if s < 10 else frame["sensors"][s - 10]
        if all(math.isfinite(v) for v in pose["p"] + pose["q"]):
            w, x, y, z = pose["q"]
            poses[s] = (tuple(pose["p"]), (x, y, z, w))
    return poses


def poll_for_reports(client, devices, n, limit=15.0):
    """reads until each device has more than n report groups (a slow machine, or the sanitizer
    build, takes longer than the nominal n/240 s); False if the server closed the connection"""
    end = time.time() + limit
    while time.time() < end:
        if not client.poll(0.1):
            return False
        if all(len(report_groups(client.events, d)) > n for d in devices):
            break
    return True


class VrpnTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.uport = free_port()
        cls.vport = free_port(socket.SOCK_STREAM)
        cls.udp = UdpListener(cls.uport)
        cls.d = Daemon(cls.tmpd.name, CONF.format(uport=cls.uport, vport=cls.vport))

    @classmethod
    def tearDownClass(cls):
        cls.udp.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def vrpn_status(self):
        return [o for o in self.d.status()["outputs"] if o["name"] == "vrpn"][0]

    def check_against_udp(self, client, device, avatar_id, min_groups):
        frames = [f for f in self.udp.snapshot() if f["avatar"] == avatar_id]
        by_time = {}
        for f in frames:
            by_time.setdefault(f["t_ns"] // 1000, []).append(f)
        groups = report_groups(client.events, device)
        self.assertGreaterEqual(len(groups), min_groups, "too few VRPN reports of %s" % device)
        matched = 0
        self.seqs = []  # per group, the seqs of the UDP frames it equals
        for t, poses, analog in groups:
            cands = by_time.get(t, [])
            self.assertTrue(cands, "%s: no UDP frame with the sample time %d us" % (device, t))
            ok = []
            for f in cands:
                exp = expected_poses(f)
                if poses != exp:
                    continue
                if analog is not None:
                    if len(analog) != 29 or tuple(analog[:17]) != tuple(f["joints"]) or any(analog[17:]):
                        continue
                ok.append(f["seq"])
            self.seqs.append(ok)
            self.assertTrue(ok, "%s: the reports at %d us equal none of the %d UDP frames of that sample"
                            % (device, t, len(cands)))
            self.assertIsNotNone(analog, "%s: no analog report with the poses at %d us" % (device, t))
            matched += 1
        return matched

    def test_tcp_client_matches_udp_stream(self):
        c = vc.Client("127.0.0.1", self.vport, ["Avatar0"], mode="tcp")
        try:
            self.assertTrue(poll_for_reports(c, ["Avatar0"], 200))
        finally:
            c.close()
        time.sleep(0.1)
        # the devices this daemon serves, with our types
        self.assertIn("Avatar0", c.server_senders.values())
        self.assertIn("Avatar7", c.server_senders.values())
        for t in (vc.POS_QUAT, vc.ANALOG, vc.BUTTON_CHANGE, vc.BUTTON_STATES, vc.PONG):
            self.assertIn(t, c.server_types.values())
        # over 200 frames' reports (about 1 s at 240 Hz), each equal to a frame of the UDP stream
        n = self.check_against_udp(c, "Avatar0", 0, 200)
        self.assertGreater(n, 200)
        # the buttons of the device at connection: 3 sensors x 32, none pressed (no buttons on a replay)
        states = c.of(vc.BUTTON_STATES, "Avatar0")
        self.assertTrue(states)
        self.assertEqual(states[0][5], (0,) * 96)
        # every report came over TCP (this client offered no UDP port)
        self.assertEqual({e[0] for e in c.of(vc.POS_QUAT)}, {"tcp"})

    def test_default_connect_with_udp_and_ping(self):
        # VRPN's default: a UDP request, the server connects back; reports come over UDP
        c = vc.Client("127.0.0.1", self.vport, ["Avatar7", "Avatar0"], mode="lob", udp=True)
        try:
            c.poll(0.3)
            c.ping("Avatar7")
            self.assertTrue(poll_for_reports(c, ["Avatar7", "Avatar0"], 150))
        finally:
            c.close()
        time.sleep(0.1)
        self.assertEqual(c.pongs, 1)
        # a ping also brings the button states (as VRPN's button servers do): two of Avatar7 by now
        self.assertGreaterEqual(len(c.of(vc.BUTTON_STATES, "Avatar7")), 2)
        # reports go over UDP once the client's UDP description has reached the server; the ones the
        # server sent before that (a loaded host may take a while to read it) come over TCP, as VRPN's
        # own server does: none of a later sample than the first over UDP
        when = {ch: sorted(e[3] + e[4] * 1e-6 for e in c.of(vc.POS_QUAT) if e[0] == ch) for ch in ("tcp", "udp")}
        self.assertGreater(len(when["udp"]), 150)
        if when["tcp"]:
            self.assertLessEqual(when["tcp"][-1], when["udp"][0], "reports over TCP after the UDP channel was up")
        self.assertGreater(self.check_against_udp(c, "Avatar7", 7, 150), 150)
        self.assertGreater(self.check_against_udp(c, "Avatar0", 0, 150), 150)

    def test_stalled_and_garbage_clients_are_dropped(self):
        before = self.vrpn_status()
        # the good client takes its reports over UDP: its small TCP buffer (8 KiB here, for the
        # stalled one to fill quickly) is not what this test is about
        good = vc.Client("127.0.0.1", self.vport, ["Avatar0"], mode="lob", udp=True)
        bad = []
        try:
            # stalls: a full handshake, then never reads (its buffers fill within the timeout)
            stalled = socket.create_connection(("127.0.0.1", self.vport))
            stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            stalled.sendall(vc.cookie())
            bad.append(stalled)
            # garbage instead of a cookie
            g1 = socket.create_connection(("127.0.0.1", self.vport))
            g1.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
            bad.append(g1)
            # a good cookie, then a message shorter than its own header
            g2 = socket.create_connection(("127.0.0.1", self.vport))
            g2.sendall(vc.cookie() + struct.pack(">IIIii", 3, 0, 0, 0, 0) + b"\0" * 4)
            bad.append(g2)
            # a good cookie, then a description whose name is longer than the message
            g3 = socket.create_connection(("127.0.0.1", self.vport))
            g3.sendall(vc.cookie() + vc.message(vc.SENDER_DESCRIPTION, 0, struct.pack(">I", 500) + b"x" * 8))
            bad.append(g3)
            # connects and says nothing
            silent = socket.create_connection(("127.0.0.1", self.vport))
            bad.append(silent)
            # the good client keeps receiving every frame meanwhile
            self.assertTrue(good.poll(2.5), "the good client was dropped")
            for s in (g1, g2, g3):
                s.settimeout(1)
                self.assertEqual(self._drain(s), b"closed")
            after = self.vrpn_status()
            self.assertGreaterEqual(after["malformed"] - before["malformed"], 3)
            # the stalled and the silent one: dropped after client_timeout (1 s)
            self.assertGreaterEqual(after["closed"] - before["closed"], 2)
            self.assertEqual(after["clients"], 1)
            self.assertEqual(self._drain(silent), b"closed")
        finally:
            good.close()
            for s in bad:
                s.close()
        # the frames the daemon published meanwhile reached the good client (all but the odd
        # datagram a loaded machine may lose)
        n = self.check_against_udp(good, "Avatar0", 0, 400)
        first, last = min(self.seqs[0]), max(self.seqs[-1])
        self.assertGreaterEqual(n, 0.98 * (last - first + 1), "the good client missed frames %d..%d" % (first, last))

    @staticmethod
    def _drain(s):
        """reads until the server closes the socket: b"closed", or b"open" after 2 s"""
        s.settimeout(2)
        try:
            while True:
                d = s.recv(65536)
                if not d:
                    return b"closed"
        except ConnectionResetError:
            return b"closed"
        except socket.timeout:
            return b"open"

    def test_clients_beyond_max_are_refused(self):
        time.sleep(0.1)  # the clients of the other tests are gone
        before = self.vrpn_status()
        clients = [vc.Client("127.0.0.1", self.vport, ["Avatar0"], mode="tcp") for _ in range(6)]
        try:
            extra = socket.create_connection(("127.0.0.1", self.vport))
            self.assertEqual(self._drain(extra), b"closed")
            extra.close()
            for c in clients:
                self.assertTrue(c.poll(0.1))
                self.assertTrue(c.of(vc.POS_QUAT, "Avatar0"))
            after = self.vrpn_status()
            self.assertEqual(after["clients"], 6)
            self.assertEqual(after["refused"] - before["refused"], 1)
        finally:
            for c in clients:
                c.close()


if __name__ == "__main__":
    unittest.main()
