# SPDX-License-Identifier: MIT
"""The OSC outputs (VMC protocol, VRChat trackers) received with liblo
(build/tests/osc-recv) and checked against the UDP stream of the same daemon:
every position is the exact float of a FRAME converted to Unity's frame, and
the bone rotations, recomposed here from the VMC local transforms, point each
arm bone at its child as a T-pose-normalised rig expects.

Run from the repository root: python3 -m unittest tests/e2e/test_osc.py"""
import math
import os
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_daemon import BUILD, CTL, Daemon, free_port  # noqa: E402
from wireframe import UdpListener  # noqa: E402

RECV = os.path.join(BUILD, "tests", "osc-recv")

CONF = """
[daemon]
rate = 240
[source clip]
type = replay
file = builtin:cmu_141_16.csv
[avatar demo]
id = 4
person = clip
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
[output vmc]
type = vmc
port = {vmc}
rate = 50
torso = 0.45
[output vrchat]
type = vrchat
port = {vrc}
rate = 40
"""

BONES = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
         "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand"]
PARENT = {"Hips": "root", "Spine": "Hips", "Chest": "Spine", "UpperChest": "Chest", "Neck": "UpperChest",
          "Head": "Neck", "LeftShoulder": "UpperChest", "LeftUpperArm": "LeftShoulder",
          "LeftLowerArm": "LeftUpperArm", "LeftHand": "LeftLowerArm", "RightShoulder": "UpperChest",
          "RightUpperArm": "RightShoulder", "RightLowerArm": "RightUpperArm", "RightHand": "RightLowerArm"}


# quaternions here are (x, y, z, w), Unity's order
def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def qrot(q, v):
    x, y, z, w = q
    p = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), (-x, -y, -z, w))
    return p[:3]


def unity_pos(p):
    """avatargw (x right, y forward, z up, right-handed) -> Unity (x right, y up, z forward)"""
    return (p[0], p[2], p[1])


def qangle(a, b):
    """the angle of the rotation between a and b (atan2: well conditioned near 0, unlike acos)"""
    x, y, z, w = qmul((-a[0], -a[1], -a[2], a[3]), b)
    return 2 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


def euler_to_q(ex, ey, ez):
    """Unity's Quaternion.Euler: about z, then x, then y (fixed axes), degrees"""
    def axis(ax, deg):
        h = math.radians(deg) / 2
        return tuple(c * math.sin(h) for c in ax) + (math.cos(h),)
    return qmul(axis((0, 1, 0), ey), qmul(axis((1, 0, 0), ex), axis((0, 0, 1), ez)))


def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def receive(port, seconds):
    p = subprocess.Popen([RECV, str(port), str(seconds)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    return p


def f32(x):
    """the float32 that %.9g printed (nine digits name one float32 exactly)"""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def parse(lines):
    """[(path, args)] with floats as floats"""
    out = []
    for line in lines:
        f = line.split()
        if f[0] in ("bundle", "end"):
            out.append((f[0], []))
            continue
        args = []
        for t, a in zip(f[1], f[2:]):
            args.append(f32(float(a)) if t == "f" else int(a) if t == "i" else a)
        out.append((f[0], args))
    return out


class OscTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        assert os.path.exists(RECV), "build/tests/osc-recv is not built (make test builds it)"
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.uport, cls.vmc_port, cls.vrc_port = free_port(), free_port(), free_port()
        rv = receive(cls.vmc_port, 2.0)
        rc = receive(cls.vrc_port, 2.0)
        cls.udp = UdpListener(cls.uport)
        cls.d = Daemon(cls.tmpd.name, CONF.format(uport=cls.uport, vmc=cls.vmc_port, vrc=cls.vrc_port))
        t0 = time.time()
        cls.vmc = parse(rv.communicate(timeout=10)[0].splitlines())
        cls.vrc = parse(rc.communicate(timeout=10)[0].splitlines())
        cls.elapsed = time.time() - t0
        time.sleep(0.05)
        cls.frames = cls.udp.snapshot()

    @classmethod
    def tearDownClass(cls):
        cls.udp.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def frame_with_chest(self, x, y):
        """the UDP frames whose hips, the VMC torso (0.45 m) down the chest's own axis, are at (x, y): under the
        chest when it is upright, beside it when a raised arm rolls it (floats as received, to 10 um)"""
        out = []
        for f in self.frames:
            c = f["segments"][0]
            w, qx, qy, qz = c["q"]
            z = qrot((qx, qy, qz, w), (0, 0, 1))
            if abs(c["p"][0] - 0.45 * z[0] - x) < 1e-5 and abs(c["p"][1] - 0.45 * z[1] - y) < 1e-5:
                out.append(f)
        return out

    def vmc_bundles(self):
        bundles, cur = [], None
        for path, args in self.vmc:
            if path == "bundle":
                cur = []
            elif path == "end":
                bundles.append(cur)
                cur = None
            else:
                self.assertIsNotNone(cur, "a VMC message outside a bundle: %s" % path)
                cur.append((path, args))
        return bundles

    def test_vmc_bundles(self):
        bundles = self.vmc_bundles()
        # 50 Hz for about 2 s (the daemon starts a little after the receiver)
        self.assertGreater(len(bundles), 50)
        self.assertLessEqual(len(bundles), 105)
        checked = 0
        for b in bundles:
            paths = [p for p, _ in b]
            self.assertEqual(paths[0], "/VMC/Ext/Root/Pos")
            self.assertEqual(paths[1:15], ["/VMC/Ext/Bone/Pos"] * 14)
            self.assertEqual(paths[15:], ["/VMC/Ext/OK", "/VMC/Ext/T"])
            root = b[0][1]
            self.assertEqual(root[0], "root")
            self.assertEqual(b[15][1], [1, 3, 0, 1])  # loaded, calibrated, normal mode, tracking
            bones = {args[0]: (tuple(args[1:4]), tuple(args[4:8])) for p, args in b[1:15]}
            self.assertEqual(sorted(bones), sorted(BONES))
            # the root stands on the floor under the chest: exactly the chest's x and y of a frame
            self.assertEqual(root[2], 0.0)
            cands = self.frame_with_chest(root[1], root[3])
            self.assertTrue(cands, "no UDP frame has the chest at the VMC root")
            f = cands[0]
            seg = [s["p"] for s in f["segments"]]
            # compose the locals down the hierarchy into Unity world poses
            world = {"root": (tuple(root[1:4]), tuple(root[4:8]))}
            for name in BONES:
                pp, pq = world[PARENT[name]]
                lp, lq = bones[name]
                rp = qrot(pq, lp)
                world[name] = ((pp[0] + rp[0], pp[1] + rp[1], pp[2] + rp[2]), qmul(pq, lq))
            # the joints are where the frame has them
            for name, s in (("RightUpperArm", 2), ("RightLowerArm", 3), ("RightHand", 4), ("LeftUpperArm", 6),
                            ("LeftLowerArm", 7), ("LeftHand", 8), ("Head", 1), ("Neck", 0)):
                got, want = world[name][0], unity_pos(seg[s])
                self.assertLess(math.dist(got, want), 1e-5, "%s at %s, the frame has %s" % (name, got, want))
            # the hips a torso down the chest's own axis (a raised arm rolls the chest a little)
            w, x, y, z = f["segments"][0]["q"]
            self.assertAlmostEqual(world["Hips"][0][1], seg[0][2] - 0.45 * (1 - 2 * (x * x + y * y)), places=5)
            # a T-pose rig: an arm bone's +x (right) or -x (left) points at its child joint
            for name, child, sign in (("RightUpperArm", "RightLowerArm", 1), ("RightLowerArm", "RightHand", 1),
                                      ("LeftUpperArm", "LeftLowerArm", -1), ("LeftLowerArm", "LeftHand", -1)):
                axis = qrot(world[name][1], (sign, 0, 0))
                d = normalize([c - p for c, p in zip(world[child][0], world[name][0])])
                self.assertGreater(sum(a * b for a, b in zip(axis, d)), 0.99999, "%s does not point at %s"
                                   % (name, child))
            # the body faces where the chest faces: Unity's forward (+z) is the chest frame's +y
            fwd = qrot(world["Hips"][1], (0, 0, 1))
            w, x, y, z = f["segments"][0]["q"]
            chest_fwd = (2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x))  # R(q) * (0, 1, 0)
            self.assertLess(math.dist(fwd, unity_pos(chest_fwd)), 1e-5)
            self.assertLess(abs(fwd[1]), 1e-6)  # upright
            checked += 1
        self.assertEqual(checked, len(bundles))
        # /VMC/Ext/T counts up in seconds
        ts = [b[16][1][0] for b in bundles]
        self.assertEqual(ts, sorted(ts))
        # 50 bundles a second: the median step of T (a cycle a stalled host took is skipped, not made up)
        steps = sorted(b - a for a, b in zip(ts, ts[1:]))
        self.assertAlmostEqual(steps[len(steps) // 2], 1 / 50, delta=0.1 / 50)
        self.assertGreater(steps[0], 0)

    def test_vrchat_trackers(self):
        msgs = [(p, a) for p, a in self.vrc if p not in ("bundle", "end")]
        self.assertEqual(len(msgs), len(self.vrc), "VRChat gets plain messages, not bundles")
        groups = [msgs[i:i + 8] for i in range(0, len(msgs), 8)]
        if groups and len(groups[-1]) < 8:
            groups.pop()  # the receiver stopped in the middle of one
        self.assertGreater(len(groups), 40)
        self.assertLessEqual(len(groups), 85)
        want_paths = ["/tracking/trackers/%s/%s" % (t, k) for t in ("1", "2", "3", "head")
                      for k in ("position", "rotation")]
        for g in groups:
            self.assertEqual([p for p, _ in g], want_paths)
            chest = g[0][1]
            # Unity (x, y, z) = avatargw (x, z, y): the chest is exactly a frame's chest segment
            cands = [f for f in self.frames if f["segments"][0]["p"][0] == chest[0]
                     and f["segments"][0]["p"][2] == chest[1] and f["segments"][0]["p"][1] == chest[2]]
            self.assertTrue(cands, "no UDP frame has its chest at tracker 1")
            f = cands[0]
            self.assertEqual(tuple(g[2][1]), unity_pos(f["segments"][7]["p"]))  # left elbow
            self.assertEqual(tuple(g[4][1]), unity_pos(f["segments"][3]["p"]))  # right elbow
            self.assertEqual(tuple(g[6][1]), unity_pos(f["sensors"][0]["p"]))   # head sensor
            # rotations: the chest's yaw about Unity's y, and the head's own rotation
            qc = euler_to_q(*g[1][1])
            w, x, y, z = f["segments"][0]["q"]
            self.assertLess(qangle(qc, (-x, -z, -y, w)), 1e-5)
            w, x, y, z = f["sensors"][0]["q"]
            self.assertLess(qangle(euler_to_q(*g[7][1]), (-x, -z, -y, w)), 1e-5)
            # an elbow tracker turns with the upper arm: its +x (left: -x) runs from the shoulder to the elbow
            for rot, shoulder, elbow, sign in ((g[3][1], 6, 7, -1), (g[5][1], 2, 3, 1)):
                axis = qrot(euler_to_q(*rot), (sign, 0, 0))
                d = normalize([a - b for a, b in zip(unity_pos(f["segments"][elbow]["p"]),
                                                     unity_pos(f["segments"][shoulder]["p"]))])
                self.assertGreater(sum(a * b for a, b in zip(axis, d)), 0.99999)

    def test_status_counts(self):
        outs = {o["name"]: o for o in self.d.status()["outputs"]}
        self.assertEqual(outs["vmc"]["type"], "vmc")
        self.assertGreater(outs["vmc"]["sent"], 50)
        self.assertGreater(outs["vrchat"]["sent"], 8 * 40)
        self.assertEqual(outs["vmc"]["errors"], 0)


class OscDump:
    """oscdump (Debian liblo-tools) on a UDP port: every line it prints, with the monotonic time it
    was read at (oscdump -L flushes each line)"""

    def __init__(self, port):
        self.proc = subprocess.Popen(["oscdump", "-L", str(port)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                     text=True)
        self.lines = []
        self.lock = threading.Lock()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        for line in self.proc.stdout:
            with self.lock:
                self.lines.append((time.monotonic(), line.split()))

    def snapshot(self, path=None):
        with self.lock:
            return [(t, f) for t, f in self.lines if path is None or (len(f) > 1 and f[1] == path)]

    def close(self):
        self.proc.terminate()
        self.proc.wait(timeout=5)
        self.thread.join(timeout=5)


def wait_until(cond, timeout, what):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        v = cond()
        if v:
            return v
        time.sleep(0.05)
    raise AssertionError("%s: not within %g s" % (what, timeout))


@unittest.skipUnless(shutil.which("oscdump"), "oscdump is not installed (Debian: liblo-tools)")
class OscStopTest(unittest.TestCase):
    """a replay that ends: the OSC outputs stop within a second (VMC after one bundle saying tracking 0),
    though the loop goes on publishing stale frames; a reload plays it again and they resume"""

    CONF = """
[daemon]
rate = 120
[source clip]
type = replay
file = builtin:cmu_141_16.csv
speed = 8
loop = no
[avatar ended]
person = clip
[output udp]
type = udp
address = 127.0.0.1
port = {uport}
[output vmc]
type = vmc
port = {vmc}
rate = 30
[output vrchat]
type = vrchat
port = {vrc}
rate = 30
"""

    def test_stop_and_resume(self):
        uport, vmc_port, vrc_port = free_port(), free_port(), free_port()
        vmc, vrc, udp = OscDump(vmc_port), OscDump(vrc_port), UdpListener(uport)
        with tempfile.TemporaryDirectory() as tmp:
            try:
                # oscdump is listening once it answers a datagram: poke it until it prints
                poke = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                for port, dump in ((vmc_port, vmc), (vrc_port, vrc)):
                    wait_until(lambda: poke.sendto(b"/ready\0\0,\0\0\0", ("127.0.0.1", port)) and dump.snapshot(),
                               10, "oscdump on port %d" % port)
                poke.close()
                d = Daemon(tmp, self.CONF.format(uport=uport, vmc=vmc_port, vrc=vrc_port))
                try:
                    def ended():
                        fr = udp.snapshot()
                        live = [f for f in fr if any(s["state"] == 0 for s in f["sensors"])]
                        # the clip has ended when frames with every sensor stale have come for 1.5 s
                        if live and fr[-1]["rx"] - live[-1]["rx"] > 1.5:
                            return live[-1]["rx"]
                        return None
                    end = wait_until(ended, 30, "the replay's end")
                    oks = vmc.snapshot("/VMC/Ext/OK")
                    trackers = vrc.snapshot("/tracking/trackers/1/position")
                    self.assertGreater(len(oks), 5, "VMC sent hardly anything before the end")
                    self.assertGreater(len(trackers), 5, "VRChat got hardly anything before the end")
                    self.assertEqual(oks[0][1][-1], "1")
                    # the last bundle says tracking 0 and came within a second of the last live frame
                    self.assertEqual(oks[-1][1][-1], "0", "the last VMC bundle does not say tracking 0")
                    self.assertTrue(all(f[-1] == "1" for _, f in oks[:-1]))
                    last_vmc = vmc.snapshot()[-1][0]
                    last_vrc = vrc.snapshot()[-1][0]
                    self.assertLess(last_vmc - end, 1.0)
                    self.assertLess(last_vrc - end, 1.0)
                    # the loop still publishes (stale) frames, the OSC outputs do not
                    n_udp = len(udp.snapshot())
                    n_vmc, n_vrc = len(vmc.snapshot()), len(vrc.snapshot())
                    wait_until(lambda: len(udp.snapshot()) > n_udp + 60, 10, "stale frames on UDP")
                    self.assertEqual(len(vmc.snapshot()), n_vmc, "VMC messages after the end")
                    self.assertEqual(len(vrc.snapshot()), n_vrc, "VRChat messages after the end")
                    # a reload plays the clip again: both resume by themselves, tracking 1
                    out = subprocess.run([CTL, "-s", d.ctl, "reload"], capture_output=True, text=True, timeout=10)
                    self.assertEqual(out.returncode, 0, out.stderr)
                    wait_until(lambda: len(vmc.snapshot("/VMC/Ext/OK")) > len(oks) + 5, 10, "VMC resuming")
                    wait_until(lambda: len(vrc.snapshot()) > n_vrc + 40, 10, "VRChat resuming")
                    self.assertEqual(vmc.snapshot("/VMC/Ext/OK")[len(oks)][1][-1], "1")
                finally:
                    self.assertEqual(d.stop(), 0)
            finally:
                vmc.close()
                vrc.close()
                udp.close()


if __name__ == "__main__":
    unittest.main()
