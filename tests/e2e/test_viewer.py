# SPDX-License-Identifier: MIT
"""The websocket output and the browser viewer, on the embedded demo: the
page, its icon and Debian's three.js over HTTP, the JSON frames checked
against the UDP stream of the same daemon, a stalled browser that loses
frames without slowing anyone, and the page itself in headless Chromium
(SwiftShader's WebGL, over the DevTools protocol), which must draw the body
with no console error (screenshots are kept in build/artefacts/), show two
avatars when there are two and follow the one clicked, turn a stopped
replay grey, survive a restart of the daemon, and say so when it has no
WebGL.

Run from the repository root: python3 -m unittest tests/e2e/test_viewer.py"""
import contextlib
import json
import signal
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from headless import Chromium, png_rgb  # noqa: E402
from test_daemon import BUILD, Daemon, free_port  # noqa: E402
from wireframe import UdpListener  # noqa: E402
from wsclient import WsClient  # noqa: E402

AVATAR_RGB = (0x4F, 0xC3, 0xF7)  # the first colour of the page's palette


@contextlib.contextmanager
def viewer_page(test, conf):
    """a daemon on conf (its viewer on {port}) and a headless Chromium on its page: (daemon, browser); the
    browser closed and the daemon stopped (and its exit status checked) after"""
    with tempfile.TemporaryDirectory() as tmp, tempfile.TemporaryDirectory() as profile:
        port = free_port(socket.SOCK_STREAM)
        d = Daemon(tmp, conf.format(port=port))
        try:
            b = Chromium(profile)
            try:
                b.call("Page.navigate", url="http://127.0.0.1:%d/" % port)
                yield d, b
            finally:
                b.close()
        finally:
            test.assertEqual(d.stop(), 0)


def close_to(a, b):
    """a (from JSON, %.7g, None for NaN) against b (a float32 of the UDP FRAME)"""
    if a is None or b is None or not math.isfinite(b):
        return (a is None) == (b is None or not math.isfinite(b))
    return abs(a - b) <= 1e-6 * max(1.0, abs(b))


ARTEFACTS = os.path.join(BUILD, "artefacts")
# a loaded 2-core host draws a few pictures a second with SwiftShader: the waits are long, and end early
PAGE_TIMEOUT = 40


def wait_for(browser, cond, timeout=PAGE_TIMEOUT):
    deadline = time.time() + timeout
    st = None
    while time.time() < deadline:
        try:
            st = json.loads(browser.evaluate("JSON.stringify(window.avatargwStats || null)") or "null")
        except TimeoutError:
            continue  # a starved browser answers late: ask again until the deadline
        if st and cond(st):
            return st
        time.sleep(0.2)
    raise AssertionError("the page did not get there in %g s: %s" % (timeout, st))


def artefact(name):
    os.makedirs(ARTEFACTS, exist_ok=True)
    return os.path.join(ARTEFACTS, name)


def no_errors(test, browser, allow=()):
    """the page's console said no error, no exception was thrown, no load failed (allow: substrings of
    errors that are expected, such as the failed connections while the daemon is down)"""
    errs = [e for e in browser.errors() if not any(a in e[1] for a in allow)]
    test.assertEqual(errs, [], "the page's console: %s" % errs)
    test.assertEqual(browser.evaluate("window.avatargwStats.errors"), [])


def avatar_pixels(path):
    """pixels of the first avatar's colour in the 3D view (the panel of cards, 360 px on the right, left out)"""
    w, _, rows = png_rgb(path)
    return sum(1 for r in rows for p in r[:w - 360] if all(abs(c - a) < 40 for c, a in zip(p, AVATAR_RGB)))


class ViewerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmpd = tempfile.TemporaryDirectory()
        cls.uport, cls.tport, cls.vport = free_port(), free_port(socket.SOCK_STREAM), free_port(socket.SOCK_STREAM)
        cls.udp = UdpListener(cls.uport)
        cls.d = Daemon(cls.tmpd.name, demo=True, sets=["output local.port=%d" % cls.uport,
                                                       "output stream.port=%d" % cls.tport,
                                                       "output viewer.port=%d" % cls.vport])
        cls.base = "http://127.0.0.1:%d" % cls.vport

    @classmethod
    def tearDownClass(cls):
        cls.udp.close()
        rc = cls.d.stop()
        cls.tmpd.cleanup()
        assert rc == 0, "daemon exit status %s" % rc

    def viewer_status(self):
        return [o for o in self.d.status()["outputs"] if o["name"] == "viewer"][0]

    def get(self, path):
        with urllib.request.urlopen(self.base + path, timeout=5) as r:
            return r.status, r.headers.get("content-type", ""), r.read()

    def test_http(self):
        st, ct, body = self.get("/")
        self.assertEqual(st, 200)
        self.assertIn("text/html", ct)
        self.assertIn(b"viewer.js", body)
        st, ct, body = self.get("/viewer.js")
        self.assertIn("javascript", ct)
        self.assertIn(b"/three/build/three.module.js", body)
        # three.js from Debian's libjs-three, and OrbitControls importing it by a relative path
        st, ct, body = self.get("/three/build/three.module.js")
        self.assertIn("javascript", ct)
        with open("/usr/share/javascript/three/build/three.module.js", "rb") as f:
            self.assertEqual(body, f.read())
        st, ct, body = self.get("/three/examples/jsm/controls/OrbitControls.js")
        self.assertIn(b'from "../../../build/three.module.js"', body)
        # the icon every browser asks for
        st, ct, body = self.get("/favicon.ico")
        self.assertEqual(st, 200)
        self.assertIn("icon", ct)
        self.assertEqual(body[:4], b"\0\0\1\0")  # an ICO file
        with self.assertRaises(urllib.error.HTTPError) as e:
            self.get("/no-such-file.js")
        self.assertEqual(e.exception.code, 404)
        # nothing outside the two directories
        s = socket.create_connection(("127.0.0.1", self.vport), timeout=5)
        s.sendall(b"GET /three/../../../../etc/passwd HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        reply = b""
        while True:
            chunk = s.recv(65536)
            if not chunk:
                break
            reply += chunk
        s.close()
        self.assertNotIn(b"root:", reply)

    def test_json_frames_match_udp(self):
        ws = WsClient("127.0.0.1", self.vport)
        msgs = []
        t0 = time.time()
        try:
            while time.time() - t0 < 1.5:
                m = ws.recv_text(1.0)
                if m:
                    msgs.append(json.loads(m))
        finally:
            ws.close()
        time.sleep(0.05)
        rate = len(msgs) / 1.5
        self.assertGreater(rate, 20)  # the demo's viewer runs at the default 30 Hz
        self.assertLess(rate, 40)
        frames = {f["seq"]: f for f in self.udp.snapshot() if f["avatar"] == 0}
        ks = []
        for m in msgs:
            self.assertEqual(m["type"], "frames")
            self.assertEqual(len(m["avatars"]), 1)
            a = m["avatars"][0]
            self.assertEqual((a["id"], a["name"]), (0, "demo"))
            ks.append(a["k"])
            f = frames.get(a["seq"])
            self.assertIsNotNone(f, "seq %d is not in the UDP stream" % a["seq"])
            self.assertEqual(a["flags"], f["flags"])
            self.assertAlmostEqual(a["t"], f["t_ns"] * 1e-6, delta=1e-3)
            for s in range(10):
                for x, y in zip(a["segments"][s], f["segments"][s]["p"] + f["segments"][s]["q"]):
                    self.assertTrue(close_to(x, y), "segment %d: %s vs %s" % (s, x, y))
            for s in range(3):
                self.assertEqual(a["sensors"][s]["state"], f["sensors"][s]["state"])
                for x, y in zip(a["sensors"][s]["pose"], f["sensors"][s]["p"] + f["sensors"][s]["q"]):
                    self.assertTrue(close_to(x, y))
            for x, y in zip(a["joints"], f["joints"]):
                self.assertTrue(close_to(x, y))
            # the body's lengths from the DESCRIBE: the demo's shoulder, upper arm and forearm
            self.assertEqual(len(a["dims"]), 4)
            self.assertEqual(len(a["head_offset"]), 3)
            self.assertTrue(0.1 < a["dims"][0] < 0.3 and 0.2 < a["dims"][1] < 0.4 and 0.15 < a["dims"][2] < 0.35,
                            a["dims"])
            # the daemon's own latency, sample to sending: small on one host
            self.assertGreaterEqual(a["srv_ms"], 0)
            self.assertLess(a["srv_ms"], 200)
        # a reader that keeps up misses nothing: one record per text, numbered without gaps
        self.assertEqual(ks, list(range(ks[0], ks[0] + len(ks))))

    def test_stalled_browser_loses_frames_alone(self):
        before = self.viewer_status()
        stalled = WsClient("127.0.0.1", self.vport, rcvbuf=2048)  # upgrades, then never reads
        good = WsClient("127.0.0.1", self.vport)
        ks = []
        t0 = time.time()
        try:
            while time.time() - t0 < 3.0:
                m = good.recv_text(1.0)
                if m:
                    ks.append(json.loads(m)["avatars"][0]["k"])
            st = self.viewer_status()
        finally:
            stalled.close()
            good.close()
        self.assertGreater(len(ks), 3.0 * 20)
        self.assertEqual(ks, list(range(ks[0], ks[0] + len(ks))), "the good browser lost frames")
        self.assertGreater(st["dropped"], before["dropped"], "the stalled browser never fell behind")
        self.assertEqual(st["clients"], 2)
        # the loop did not feel it: the UDP stream has no gap
        seqs = [f["seq"] for f in self.udp.snapshot() if f["avatar"] == 0 and f["rx"] > time.monotonic() - 3.5]
        self.assertEqual(seqs, list(range(seqs[0], seqs[0] + len(seqs))))

    def test_page_in_chromium(self):
        with tempfile.TemporaryDirectory() as profile:
            b = Chromium(profile)
            try:
                b.call("Page.navigate", url=self.base + "/")
                st = wait_for(b, lambda s: s["frames"] >= 15 and s["renders"] >= 10 and s["bodies"] == 1
                              and s["list"] and s["list"][0]["columns"] >= 4)
                shot = artefact("viewer.png")
                b.screenshot(shot)
                cards = b.evaluate("document.getElementById('avatars').innerText")
                dom = b.evaluate("document.getElementById('stats').textContent")
                status = b.evaluate("document.getElementById('status').textContent")
                no_errors(self, b)
            finally:
                b.close()
        self.assertTrue(st["connected"])
        self.assertTrue(st["webgl"], "no WebGL in headless Chromium with SwiftShader")
        self.assertIsNone(st["webglError"])
        self.assertEqual(st["avatars"], 1)
        # the body: neck, and per arm the clavicle, upper arm, forearm and hand; a head, a trunk, joints, legs
        self.assertEqual(st["bonesDrawn"], 9)
        self.assertGreaterEqual(st["meshes"], 20)
        self.assertEqual(st["sensorsDrawn"], 3)
        self.assertEqual(st["staleAvatars"], 0)
        self.assertEqual(st["offSensors"], 0)  # the demo's hands are where their sensors are
        # the arm bones, drawn from the DESCRIBE's lengths along their segments' axes, meet the next joints
        self.assertLess(st["boneMismatch"], 0.002)
        av = st["list"][0]
        self.assertEqual((av["name"], av["grey"], av["sensors"]), ("demo", False, ["OK"] * 3))
        # the daemon publishes at 240 Hz, the output sends 30 texts a second, the page draws no more than that
        self.assertGreater(av["rate"], 100, av)  # 240 Hz, less on a starved host (bursts, cycles lost)
        self.assertLess(av["outRate"], 33, av)
        self.assertLessEqual(av["shown"], av["outRate"], av)
        self.assertLessEqual(av["shown"], 30 * 1.05, av)
        self.assertGreater(av["shown"], 0, av)
        self.assertIn("demo", cards)
        self.assertIn("connected to", status)
        self.assertIn('"avatars":1', dom)      # the same numbers in the page's #stats
        # the body is on the picture, in its colour
        self.assertGreater(avatar_pixels(shot), 500, "the avatar is not on %s" % shot)

    def test_page_without_webgl(self):
        """a browser without WebGL: the page says so (and the connection does not overwrite it)"""
        with tempfile.TemporaryDirectory() as profile:
            b = Chromium(profile, webgl=False)
            try:
                b.call("Page.navigate", url=self.base + "/")
                st = wait_for(b, lambda s: s["frames"] >= 10 and s["connected"] and s["list"])
                b.screenshot(artefact("viewer-nogl.png"))
                gl = b.evaluate("document.getElementById('glstatus').textContent")
                banner = b.evaluate("getComputedStyle(document.getElementById('nogl')).display + ' ' + "
                                    "document.getElementById('nogl').textContent")
                status = b.evaluate("document.getElementById('status').textContent")
                dom = json.loads(b.evaluate("document.getElementById('stats').textContent"))
                cards = b.evaluate("document.getElementById('avatars').innerText")
                no_errors(self, b)
            finally:
                b.close()
        self.assertFalse(st["webgl"])
        self.assertIn("WebGL is not available", st["webglError"])
        self.assertIn("no 3D view", gl)
        self.assertTrue(banner.startswith("block No 3D view"), banner)
        self.assertIn("connected to", status)
        self.assertEqual((dom["webgl"], dom["webglError"]), (False, st["webglError"]))
        self.assertEqual(st["renders"], 0)
        self.assertIn("demo", cards)  # the numbers still come

    def test_stats_from_the_command_line(self):
        """docs/VIEWER.md's way of reading #stats from a shell (chromium --dump-dom reads it too early)"""
        out = subprocess.run([sys.executable, os.path.join(os.path.dirname(__file__), "headless.py"),
                              self.base + "/", "--timeout", str(PAGE_TIMEOUT)],
                             capture_output=True, text=True, timeout=PAGE_TIMEOUT + 30)
        self.assertEqual(out.returncode, 0, out.stderr)
        st = json.loads(out.stdout)
        self.assertGreater(st["frames"], 10)
        self.assertTrue(st["connected"])
        self.assertEqual(out.stderr, "")  # no console error either


class ViewerStaleTest(unittest.TestCase):
    """a replay that ends: its sensors go stale, the page turns the avatar grey"""

    CONF = """
[daemon]
rate = 120
[source clip]
type = replay
file = builtin:cmu_141_16.csv
speed = 100
loop = no
[avatar ended]
person = clip
[output viewer]
type = websocket
address = 127.0.0.1
port = {port}
rate = 20
"""

    def test_stale_avatar_is_grey(self):
        with viewer_page(self, self.CONF) as (d, b):
            st = wait_for(b, lambda s: s["frames"] >= 5 and s["staleAvatars"] == 1 and s["renders"] >= 5
                          and s["bodies"] == 1 and s["list"] and s["list"][0]["columns"] >= 2)
            shot = artefact("viewer-stale.png")
            b.screenshot(shot)
            cards = b.evaluate("document.getElementById('avatars').innerText")
            no_errors(self, b)
        self.assertEqual(st["greySensors"], 3)
        self.assertEqual(st["bonesDrawn"], 9)
        av = st["list"][0]
        self.assertTrue(av["grey"])
        self.assertEqual(av["sensors"], ["STALE"] * 3)
        self.assertEqual(av["strip"], [1, 1, 1])  # the plots' newest column: three amber sensors
        self.assertIn("stale", cards)
        self.assertEqual(avatar_pixels(shot), 0, "a stale avatar is drawn in colour")


class ViewerDropoutTest(unittest.TestCase):
    """the hands' tracker stops, the head's goes on: the card says which sensors are stale, and the
    plots' strip shows the head OK and the hands STALE since they stopped"""

    CONF = """
[daemon]
rate = 120
[source headclip]
type = replay
file = builtin:cmu_141_16.csv
speed = 2
[source handclip]
type = replay
file = builtin:cmu_141_16.csv
speed = 2
loop = no
[avatar dropout]
head = headclip/head
left_hand = handclip/left_hand
right_hand = handclip/right_hand
[output viewer]
type = websocket
address = 127.0.0.1
port = {port}
"""

    def test_hands_drop_out(self):
        with viewer_page(self, self.CONF) as (d, b):
            st = wait_for(b, lambda s: s["list"] and s["list"][0]["sensors"] == ["OK", "STALE", "STALE"]
                          and s["list"][0]["strip"] == [0, 1, 1] and s["bodies"] == 1, PAGE_TIMEOUT + 20)
            # a second more of the dropout on the strip, for the picture
            wait_for(b, lambda s: s["list"][0]["columns"] >= st["list"][0]["columns"] + 4)
            b.screenshot(artefact("viewer-dropout.png"))
            card = b.evaluate("document.querySelector('#avatars .card .state').textContent")
            no_errors(self, b)
        self.assertEqual(card, "stale: L hand, R hand")
        self.assertEqual(st["greySensors"], 2)
        self.assertEqual(st["staleAvatars"], 1)


class ViewerTwoTest(unittest.TestCase):
    """two people: two bodies side by side with their names, and a click on one follows it; bob's
    arms are too short for his sensors, and his hands are drawn off them"""

    CONF = """
[daemon]
rate = 120
[source sim]
type = sim
people = 2
spacing = 1.2
[avatar alice]
person = sim/p0
[avatar bob]
person = sim/p1
upper_arm = 0.06
forearm = 0.05
[output viewer]
type = websocket
address = 127.0.0.1
port = {port}
"""

    def test_two_avatars_and_follow(self):
        with viewer_page(self, self.CONF) as (d, b):
            st = wait_for(b, lambda s: s["avatars"] == 2 and s["bodies"] == 2 and s["renders"] >= 10
                          and len(s["list"]) == 2 and all(a["name"] for a in s["list"])
                          and s["offSensors"] == 2 and sorted(a["off"] for a in s["list"]) == [0, 2])
            b.screenshot(artefact("viewer-two.png"))
            cards = b.evaluate("document.getElementById('avatars').innerText")
            ids = {a["name"]: a["id"] for a in st["list"]}
            # both are on the picture, apart
            pa = b.evaluate("window.avatargwProject(%d)" % ids["alice"])
            pb = b.evaluate("window.avatargwProject(%d)" % ids["bob"])
            # a click on bob's body follows bob (the camera may still be moving to frame them both:
            # click where he is now, again until the page follows someone)
            deadline = time.time() + PAGE_TIMEOUT
            followed_bob = None
            while followed_bob is None and time.time() < deadline:
                p = b.evaluate("window.avatargwProject(%d)" % ids["bob"])
                for kind in ("mousePressed", "mouseReleased"):
                    b.call("Input.dispatchMouseEvent", type=kind, x=p[0], y=p[1], button="left", clickCount=1)
                t = time.time()
                while followed_bob is None and time.time() < t + 2:
                    followed_bob = b.evaluate("window.avatargwStats.following")
                    time.sleep(0.1)
            # a click on alice's card follows her
            b.evaluate("document.querySelectorAll('#avatars .card')[%d].click()"
                       % [a["name"] for a in st["list"]].index("alice"))
            followed_alice = wait_for(b, lambda s: s["following"] == ids["alice"], 10)["following"]
            b.evaluate("document.getElementById('frameall').click()")
            unfollowed = wait_for(b, lambda s: s["following"] is None, 10)
            no_errors(self, b)
        self.assertEqual(sorted(ids), ["alice", "bob"])
        self.assertEqual({a["name"]: a["off"] for a in st["list"]}, {"alice": 0, "bob": 2})
        self.assertLess(st["boneMismatch"], 0.002)  # bob's short bones too
        self.assertIn("alice", cards)
        self.assertIn("bob", cards)
        self.assertEqual(st["bonesDrawn"], 18)
        self.assertEqual(st["sensorsDrawn"], 6)
        self.assertEqual(st["staleAvatars"], 0)
        self.assertIsNotNone(pa)
        self.assertIsNotNone(pb)
        self.assertGreater(math.dist(pa, pb), 100, "the two bodies are not apart on the picture: %s %s" % (pa, pb))
        for p in (pa, pb):
            self.assertTrue(0 < p[0] < 1280 and 0 < p[1] < 800, "a body out of the picture at %s" % (p,))
        self.assertEqual(followed_bob, ids["bob"])
        self.assertEqual(followed_alice, ids["alice"])
        self.assertIsNone(unfollowed["following"])


class ViewerRestartTest(unittest.TestCase):
    """the daemon stops and starts again on the same port: the page says the connection is lost,
    greys the body, reconnects by itself and draws the new daemon's frames"""

    CONF = """
[daemon]
rate = 120
[source sim]
type = sim
[avatar solo]
person = sim/p0
[output viewer]
type = websocket
address = 127.0.0.1
port = {port}
"""

    def test_restart_is_survived(self):
        with tempfile.TemporaryDirectory() as tmp, tempfile.TemporaryDirectory() as profile:
            port = free_port(socket.SOCK_STREAM)
            conf = self.CONF.format(port=port)
            d = Daemon(tmp, conf)
            b = Chromium(profile)
            try:
                b.call("Page.navigate", url="http://127.0.0.1:%d/" % port)
                wait_for(b, lambda s: s["connected"] and s["frames"] >= 10 and s["bodies"] == 1
                         and s["staleAvatars"] == 0)
                self.assertEqual(d.stop(), 0)
                d = None
                lost = wait_for(b, lambda s: not s["connected"] and s["staleAvatars"] == 1
                                and s["list"][0]["noFrames"])
                status = b.evaluate("document.getElementById('status').textContent")
                self.assertIn("connection lost", status)
                frames = lost["frames"]
                d = Daemon(tmp, conf)
                back = wait_for(b, lambda s: s["connected"] and s["connections"] >= 2 and s["frames"] > frames + 10
                                and s["staleAvatars"] == 0 and s["list"][0]["rate"] is not None)
                status = b.evaluate("document.getElementById('status').textContent")
                # while the daemon was down, Chromium logged the refused connections: nothing else
                no_errors(self, b, allow=("WebSocket connection to",))
            finally:
                b.close()
                if d:
                    self.assertEqual(d.stop(), 0)
        self.assertEqual(lost["disconnects"], 1)
        self.assertIn("connected to", status)
        self.assertEqual(back["avatars"], 1)
        self.assertGreater(back["list"][0]["rate"], 100)  # the windows started afresh: no nonsense rate


class ViewerReloadTest(unittest.TestCase):
    """a reload keeps the port and the browsers, and serves the new configuration"""

    CONF = """
[daemon]
rate = 120
[source sim]
type = sim
people = 2
[avatar a]
person = sim/p0
count = 2
[output viewer]
type = websocket
address = 127.0.0.1
port = {port}
avatars = {which}
[output cave]
type = vrpn
address = 127.0.0.1
port = {vport}
"""

    def test_reload_keeps_browsers(self):
        with tempfile.TemporaryDirectory() as tmp:
            port, vport = free_port(socket.SOCK_STREAM), free_port(socket.SOCK_STREAM)
            d = Daemon(tmp, self.CONF.format(port=port, vport=vport, which="a-0"))
            ws = None
            try:
                ws = WsClient("127.0.0.1", port)
                ids = set()
                t0 = time.time()
                while time.time() - t0 < 0.5:
                    m = ws.recv_text(1.0)
                    ids |= {a["id"] for a in json.loads(m)["avatars"]} if m else set()
                self.assertEqual(ids, {0})
                with open(d.conf, "w") as f:
                    f.write(self.CONF.format(port=port, vport=vport, which="a-1"))
                d.proc.send_signal(signal.SIGHUP)
                deadline = time.time() + 5
                while d.status()["reloads"] < 1 and time.time() < deadline:
                    time.sleep(0.05)
                self.assertEqual(d.status()["reloads"], 1, d.stderr())
                # the same connection now carries the other avatar
                ids = set()
                t0 = time.time()
                while time.time() - t0 < 0.7:
                    m = ws.recv_text(1.0)
                    if m:
                        ids = {a["id"] for a in json.loads(m)["avatars"]}
                self.assertEqual(ids, {1})
                viewer = [o for o in d.status()["outputs"] if o["name"] == "viewer"][0]
                self.assertEqual(viewer["clients"], 1)
            finally:
                if ws:
                    ws.close()
                self.assertEqual(d.stop(), 0)


if __name__ == "__main__":
    unittest.main()
