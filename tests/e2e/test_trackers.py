# SPDX-License-Identifier: MIT
"""End-to-end tests of the hardware drivers' tools and of the daemon with them:
avatargw-decode on the captures of tests/data (checked against the clip they
were made from, with an interpolation of its own), the daemon playing a Hydra
capture and publishing the wands' buttons and analog values, the daemon with
trackers that are not plugged in (it runs on, says so, reports FAULTY), and
avatargw --list-devices.

Run from the repository root: python3 -m unittest tests/e2e/test_trackers.py
(BUILD=build-san selects the sanitizer build)."""
import csv
import math
import os
import subprocess
import tempfile
import time
import unittest

from tests.e2e import test_daemon as td

ROOT = td.ROOT
DECODE = os.path.join(td.BUILD, "avatargw-decode")
HYDRA_CAP = os.path.join(ROOT, "tests", "data", "hydra-cmu_141_16.cap")
POLHEMUS_CAP = os.path.join(ROOT, "tests", "data", "polhemus-cmu_141_16.cap")
# where tools/gen-captures.py placed the trackers, and the clip time of each capture's start
HYDRA_PLACE = ((0.0, 0.5, 1.45), -20.0, 0.4)
POLHEMUS_PLACE = ((0.1, 0.6, 2.2), 30.0, 2.5)


def clip_rows():
    rows = []
    with open(td.CLIP) as f:
        for r in csv.DictReader(f):
            rows.append((float(r["t"]), {k: [float(r[k + "_" + a]) for a in ("x", "y", "z")]
                                         for k in ("head", "lhand", "rhand")}))
    return rows


def clip_pos(rows, role, t):
    """the clip's position at t, linear between frames"""
    for i in range(len(rows) - 1):
        t0, a = rows[i]
        t1, b = rows[i + 1]
        if t0 <= t <= t1:
            u = (t - t0) / (t1 - t0)
            return [x + u * (y - x) for x, y in zip(a[role], b[role])]
    raise ValueError("t outside the clip")


def to_world(place, p):
    (ox, oy, oz), yaw, _ = place
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    return [ox + c * p[0] - s * p[1], oy + s * p[0] + c * p[1], oz + p[2]]


def decode(args):
    return subprocess.run([DECODE] + args, capture_output=True, text=True, timeout=30)


class DecodeTest(unittest.TestCase):
    def check_capture(self, driver, path, place, roles, n_rows, tol, sets=()):
        out = decode(["--driver", driver] + [a for s in sets for a in ("--set", s)] + [path])
        self.assertEqual(out.returncode, 0, out.stderr)
        lines = out.stdout.splitlines()
        self.assertEqual(lines[0], "t,line,sensor,x,y,z,qw,qx,qy,qz,buttons,a0,a1,a2,a3")
        rows = clip_rows()
        worst = 0.0
        got = list(csv.DictReader(lines))
        self.assertEqual(len(got), n_rows)
        for r in got:
            p = to_world(place, [float(r["x"]), float(r["y"]), float(r["z"])])
            q = [float(r[k]) for k in ("qw", "qx", "qy", "qz")]
            self.assertAlmostEqual(sum(c * c for c in q), 1.0, places=6)
            want = clip_pos(rows, roles[r["sensor"]], place[2] + float(r["t"]))
            worst = max(worst, td.dist(p, want))
        self.assertLess(worst, tol, "%s: worst position error %.6f m" % (driver, worst))
        self.assertIn("0 malformed", out.stderr)
        return got

    def test_hydra_capture(self):
        got = self.check_capture("hydra", HYDRA_CAP, HYDRA_PLACE, {"left": "lhand", "right": "rhand"}, 1000, 0.9e-3)
        # the wands' inputs are there: the trigger moves, buttons change
        self.assertGreater(len({r["a2"] for r in got}), 50)
        self.assertGreater(len({r["buttons"] for r in got}), 3)

    def test_polhemus_capture(self):
        self.check_capture("polhemus", POLHEMUS_CAP, POLHEMUS_PLACE,
                           {"head": "head", "left_hand": "lhand", "right_hand": "rhand"}, 3 * 360, 1e-5,
                           sets=("model=liberty_hs",))

    def test_polhemus_sensors_set(self):
        # station 2 unused, station 3 named: the same decoder, configured like a [source]
        out = decode(["--driver", "polhemus", "--set", "sensors=h - r", POLHEMUS_CAP])
        self.assertEqual(out.returncode, 0, out.stderr)
        names = {line.split(",")[2] for line in out.stdout.splitlines()[1:]}
        self.assertEqual(names, {"h", "r"})

    def test_errors(self):
        with tempfile.TemporaryDirectory() as tmp:
            bad = os.path.join(tmp, "bad.cap")
            with open(bad, "w") as f:
                f.write("# a capture\n0.0 01 02 03\n0.004 zz 01\n")
            out = decode(["--driver", "hydra", bad])
            self.assertEqual(out.returncode, 1)
            self.assertIn("bad.cap:3:", out.stderr)
        out = decode(["--driver", "hydra", "/nonexistent.cap"])
        self.assertEqual(out.returncode, 1)
        self.assertIn("No such file", out.stderr)
        out = decode(["--driver", "vive", HYDRA_CAP])
        self.assertEqual(out.returncode, 2)
        out = decode(["--driver", "polhemus", "--set", "model=fastrak", POLHEMUS_CAP])
        self.assertEqual(out.returncode, 2)
        self.assertIn("model", out.stderr)
        # standard input
        with open(HYDRA_CAP) as f:
            out = subprocess.run([DECODE, "--driver", "hydra", "-"], stdin=f, capture_output=True, text=True,
                                 timeout=30)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertEqual(len(out.stdout.splitlines()), 1001)


class DaemonTest(unittest.TestCase):
    def test_hydra_capture_published_with_inputs(self):
        port = td.free_port()
        conf = ("[daemon]\nrate = 240\n"
                "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
                "[source hydra]\ntype = hydra\ncapture = %s\norigin = 0 0.5 1.45\nyaw = -20\n"
                "[avatar a]\nhead = clip/head\nleft_hand = hydra/left\nright_hand = hydra/right\n"
                "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n") % (HYDRA_CAP, port)
        with tempfile.TemporaryDirectory() as tmp:
            d = td.Daemon(tmp, conf)
            try:
                frames = [f for _, f in td.dump(["--udp", "127.0.0.1:%d" % port], 100) if f["type"] == "frame"]
                status = d.status()
            finally:
                self.assertEqual(d.stop(), 0)
        with_inputs = [f for f in frames if "INPUTS" in f["flags"]]
        self.assertGreater(len(with_inputs), 90)
        for f in with_inputs:
            self.assertEqual([i["sensor"] for i in f["inputs"]], ["left_hand", "right_hand"])
            for i in f["inputs"]:
                self.assertIsInstance(i["buttons"], int)
                self.assertEqual(len(i["analog"]), 4)
                self.assertTrue(all(-1 <= a <= 1 for a in i["analog"]))
        triggers = {f["inputs"][0]["analog"][2] for f in with_inputs}
        self.assertGreater(len(triggers), 10)
        src = {s["name"]: s for s in status["sources"]}
        self.assertEqual(src["hydra"]["driver"], "hydra")
        self.assertIn("playing capture", src["hydra"]["device"])
        self.assertEqual(src["hydra"]["malformed"], 0)

    def test_absent_trackers(self):
        """nothing plugged in: the daemon runs, serves the other sources, says what it waits for"""
        port = td.free_port()
        conf = ("[daemon]\nrate = 100\n"
                "[source sim]\ntype = sim\n"
                "[source hydra]\ntype = hydra\n"
                "[source polhemus]\ntype = polhemus\nmodel = patriot\n"
                "[avatar p]\nperson = sim/p0\n"
                "[avatar h]\nhead = sim/p0.head\nleft_hand = hydra/left\nright_hand = polhemus/right_hand\n"
                "[output u]\ntype = udp\naddress = 127.0.0.1\nport = %d\n") % port
        with tempfile.TemporaryDirectory() as tmp:
            d = td.Daemon(tmp, conf)
            try:
                frames = [f for _, f in td.dump(["--udp", "127.0.0.1:%d" % port], 100) if f["type"] == "frame"]
                time.sleep(1.2)  # the control thread logs what the device threads noted, once a second
                status = d.status()
                err = d.stderr()
            finally:
                self.assertEqual(d.stop(), 0)
        src = {s["name"]: s for s in status["sources"]}
        self.assertEqual(src["sim"]["state"], "OK")
        self.assertEqual(src["hydra"]["state"], "FAULTY")
        self.assertEqual(src["polhemus"]["state"], "FAULTY")
        self.assertIn("no Razer Hydra", src["hydra"]["device"])
        self.assertIn("no Polhemus", src["polhemus"]["device"])
        self.assertIn("no Razer Hydra (1532:0300) found", err)
        self.assertIn("no Polhemus found (model = patriot, device = auto)", err)
        by_avatar = {}
        for f in frames:
            by_avatar.setdefault(f["avatar"], []).append(f)
        # the simulated person is tracked; the other avatar's hands are MISSING, its frames flagged
        self.assertTrue(all(s["state"] == "OK" for s in by_avatar[0][-1]["sensors"]))
        last = by_avatar[1][-1]
        self.assertEqual([s["state"] for s in last["sensors"]], ["OK", "MISSING", "MISSING"])
        self.assertIn("STALE", last["flags"])
        self.assertEqual(last["sensors"][1]["p"], [None, None, None])

    def test_list_devices(self):
        out = subprocess.run([td.DAEMON, "--list-devices"], capture_output=True, text=True, timeout=30)
        self.assertEqual(out.returncode, 0, out.stderr)
        # on a machine without trackers it says so; with one, it prints its section
        self.assertTrue("no supported tracker found" in out.stdout or "[source " in out.stdout, out.stdout)


if __name__ == "__main__":
    unittest.main()
