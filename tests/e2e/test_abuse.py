# SPDX-License-Identifier: MIT
"""The daemon under abuse (issue 21), each case a real daemon on loopback:

  - ControlTest: a client that dribbles its request one byte at a time holds
    neither `avatargw-ctl status`, the watchdog nor SIGTERM; more clients
    than slots are told "busy"; the control socket's directory and mode;
    avatargw-ctl refuses to talk to a socket another user listens on.
  - SecondInstanceTest: a second daemon on the same control socket, TCP
    port, Modbus port or Unix stream path refuses to start (exit 78, a clear
    message) and leaves the first one working; a socket nobody listens on
    is replaced; on exit a daemon removes only the socket it made.
  - JsonTest: `status --json` stays JSON whatever the paths contain.

Run from the repository root: python3 -m unittest tests/e2e/test_abuse.py
(BUILD=build-san selects the sanitizer build)."""
import json
import math
import select
import os
import pwd
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time
import struct
import unittest
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from busutil import CTL, DAEMON, ROOT, Daemon, UdpFrames, free_port, until, wait_port  # noqa: E402
import vrpn_client as vc  # noqa: E402

SIM = "[source sim]\ntype = sim\n[avatar a]\nperson = sim/p0\n[output u]\ntype = udp\nport = %d\n"


def sim_conf(extra=""):
    return SIM % free_port(socket.SOCK_DGRAM) + extra


def ctl(path, *args, timeout=10, env=None):
    return subprocess.run([CTL, "-s", path] + list(args), capture_output=True, text=True, timeout=timeout, env=env)


def start(conf_path, ctl_path, env=None, umask=None):
    """a daemon process (not waited for): for the ones expected to refuse"""
    return subprocess.Popen([DAEMON, "-c", conf_path, "--set", "daemon.control_socket=" + ctl_path],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=(lambda: os.umask(umask)) if umask is not None else None)


def refused(test, tmp, conf, ctl_path, *what, env=None):
    """a daemon on conf that must exit 78 within 10 s, saying each of what"""
    path = os.path.join(tmp, "second-%d.conf" % time.monotonic_ns())
    with open(path, "w") as f:
        f.write(conf)
    p = start(path, ctl_path, env=env)
    try:
        _, err = p.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        test.fail("the second daemon started (it should have refused)")
    test.assertEqual(p.returncode, 78, err)
    for w in what:
        test.assertIn(w, err)
    return err


class Dribbler(threading.Thread):
    """connects to the control socket and sends one byte every interval until told to stop or closed"""

    def __init__(self, path, interval=0.45):
        super().__init__(daemon=True)
        self.s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.s.connect(path)
        self.interval = interval
        self.closed_after = None
        self.stopping = threading.Event()
        self.t0 = time.monotonic()

    def run(self):
        while not self.stopping.is_set():
            try:
                self.s.send(b"x")
            except OSError:
                self.closed_after = time.monotonic() - self.t0
                return
            self.stopping.wait(self.interval)

    def stop(self):
        self.stopping.set()
        self.join()
        self.s.close()


class ControlTest(unittest.TestCase):
    def test_slow_client_holds_nothing(self):
        with tempfile.TemporaryDirectory() as tmp:
            ns = os.path.join(tmp, "notify")
            nsock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            nsock.bind(ns)
            nsock.settimeout(0.1)
            beats, listening = [], threading.Event()

            def listen():
                # WATCHDOG=1 as it arrives, with its time
                while not listening.is_set():
                    try:
                        m = nsock.recv(4096).decode()
                    except socket.timeout:
                        continue
                    if "WATCHDOG=1" in m:
                        beats.append(time.monotonic())

            env = dict(os.environ, NOTIFY_SOCKET=ns, WATCHDOG_USEC="1000000")
            conf, path = os.path.join(tmp, "a.conf"), os.path.join(tmp, "control")
            with open(conf, "w") as f:
                f.write(sim_conf())
            th = threading.Thread(target=listen, daemon=True)
            th.start()
            p = start(conf, path, env=env)
            slow = []
            try:
                until(lambda: os.path.exists(path), 10, "the control socket")
                until(lambda: beats, 10, "the first WATCHDOG=1")
                slow = [Dribbler(path) for _ in range(3)]
                for s in slow:
                    s.start()
                t_start, answered = time.monotonic(), 0
                while time.monotonic() < t_start + 4:
                    # the control thread answers others while the slow clients dribble
                    t0 = time.monotonic()
                    out = ctl(path, "status", timeout=10)
                    self.assertEqual(out.returncode, 0, out.stderr)
                    self.assertIn("avatargw: up", out.stdout)
                    self.assertLess(time.monotonic() - t0, 4.0, "status took too long")
                    answered += 1
                self.assertGreater(answered, 2)
                # the watchdog is fed every half period (0.5 s) all along: no gap near a timeout
                fed = [b for b in beats if b >= t_start - 1]
                gaps = [b - a for a, b in zip(fed, fed[1:])]
                self.assertGreater(len(gaps), 3, "watchdog pings: %r" % fed)
                self.assertLess(max(gaps), 3.0, "watchdog gaps %r" % gaps)
                # each slow client was cut off at its deadline (1 s for the request line)
                for s in slow:
                    until(lambda: s.closed_after is not None, 5, "the slow client's end")
                    self.assertLess(s.closed_after, 4.0)
                # and SIGTERM is acted on at once, slow clients or not
                more = [Dribbler(path, 0.1) for _ in range(3)]
                slow += more
                for s in more:
                    s.start()
                t0 = time.monotonic()
                p.send_signal(signal.SIGTERM)
                p.wait(timeout=5)
                self.assertLess(time.monotonic() - t0, 2.0)
                self.assertEqual(p.returncode, 0)
            finally:
                for s in slow:
                    s.stop()
                if p.poll() is None:
                    p.kill()
                p.communicate()
                listening.set()
                th.join()
                nsock.close()

    def test_more_clients_than_slots(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, sim_conf())
            try:
                silent = []
                for _ in range(12):
                    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                    s.connect(d.ctl)
                    silent.append(s)
                # the ones beyond the 8 slots are told so, at once; the 8 are closed after their second
                busy = 0
                for s in silent:
                    s.settimeout(5)
                    data = b""
                    try:
                        while True:
                            chunk = s.recv(256)
                            if not chunk:
                                break
                            data += chunk
                    except ConnectionResetError:
                        pass
                    busy += data.startswith(b"error: busy")
                    s.close()
                self.assertEqual(busy, 4)
                out = ctl(d.ctl, "status", "--json")
                self.assertEqual(out.returncode, 0, out.stderr)
                json.loads(out.stdout)
            finally:
                self.assertEqual(d.stop(), 0)

    def test_socket_mode_whatever_the_umask(self):
        with tempfile.TemporaryDirectory() as tmp:
            conf, path = os.path.join(tmp, "a.conf"), os.path.join(tmp, "control")
            with open(conf, "w") as f:
                f.write(sim_conf())
            p = start(conf, path, umask=0)
            try:
                until(lambda: os.path.exists(path), 10, "the control socket")
                self.assertEqual(stat.S_IMODE(os.lstat(path).st_mode), 0o600)
                self.assertEqual(ctl(path, "status").returncode, 0)
            finally:
                p.send_signal(signal.SIGTERM)
                p.communicate(timeout=5)
            self.assertEqual(p.returncode, 0)

    def test_world_writable_directory_refused(self):
        with tempfile.TemporaryDirectory() as tmp:
            pub = os.path.join(tmp, "pub")
            os.mkdir(pub)
            os.chmod(pub, 0o1777)
            refused(self, tmp, sim_conf(), os.path.join(pub, "control"), "writable by every user",
                    "daemon.control_socket")
            self.assertEqual(os.listdir(pub), [])

    def test_auto_outside_systemd_is_a_private_directory(self):
        with tempfile.TemporaryDirectory() as tmp:
            env = {k: v for k, v in os.environ.items() if k not in ("RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR")}
            env["TMPDIR"] = tmp
            conf = os.path.join(tmp, "a.conf")
            with open(conf, "w") as f:
                f.write(sim_conf())
            p = start(conf, "auto", env=env, umask=0)
            want = os.path.join(tmp, "avatargw-%d" % os.geteuid(), "control")
            try:
                until(lambda: os.path.exists(want), 10, "the control socket in its directory")
                st = os.lstat(os.path.dirname(want))
                self.assertTrue(stat.S_ISDIR(st.st_mode))
                self.assertEqual(stat.S_IMODE(st.st_mode), 0o700)
                self.assertEqual(st.st_uid, os.geteuid())
                self.assertEqual(stat.S_IMODE(os.lstat(want).st_mode), 0o600)
                # avatargw-ctl finds it the same way
                out = subprocess.run([CTL, "status"], capture_output=True, text=True, timeout=10, env=env)
                self.assertEqual(out.returncode, 0, out.stderr)
            finally:
                p.send_signal(signal.SIGTERM)
                p.communicate(timeout=5)
            self.assertFalse(os.path.exists(want))

    def test_auto_directory_of_another_user_refused(self):
        if os.geteuid() != 0:
            self.skipTest("SKIPPED: needs root to make a directory owned by another user")
        with tempfile.TemporaryDirectory() as tmp:
            os.chmod(tmp, 0o755)
            env = {k: v for k, v in os.environ.items() if k not in ("RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR")}
            env["TMPDIR"] = tmp
            trap = os.path.join(tmp, "avatargw-%d" % os.geteuid())
            os.mkdir(trap, 0o777)
            os.chown(trap, 65534, 65534)
            err = refused(self, tmp, sim_conf(), "auto", "belongs to user 65534", env=env)
            self.assertIn(trap, err)

    def test_ctl_refuses_an_impostor(self):
        if os.geteuid() != 0:
            self.skipTest("SKIPPED: needs root to listen as another user")
        nobody = pwd.getpwnam("nobody").pw_uid
        with tempfile.TemporaryDirectory() as tmp:
            os.chmod(tmp, 0o755)
            d = os.path.join(tmp, "d")
            os.mkdir(d)
            os.chown(d, nobody, nobody)
            path = os.path.join(d, "control")
            # another user's process answers on the path the tool is given
            code = ("import socket,sys,os\n"
                    "s=socket.socket(socket.AF_UNIX); s.bind(sys.argv[1]); os.chmod(sys.argv[1], 0o666); s.listen(4)\n"
                    "print('ready', flush=True)\n"
                    "while True:\n"
                    "    c,_=s.accept()\n"
                    "    try:\n"
                    "        c.recv(200); c.sendall(b'avatargw: up 1.0 s, fake\\n')\n"
                    "    except OSError:\n"
                    "        pass\n"
                    "    c.close()\n")
            # Debian's python3: a user's own interpreter may be in a home directory nobody cannot read
            fake = subprocess.Popen(["/usr/bin/python3", "-c", code, path], stdout=subprocess.PIPE, text=True,
                                    preexec_fn=lambda: (os.setgid(nobody), os.setuid(nobody)))
            try:
                self.assertEqual(fake.stdout.readline().strip(), "ready")
                out = ctl(path, "status")
                self.assertEqual(out.returncode, 77, out.stdout + out.stderr)
                self.assertNotIn("fake", out.stdout)
                self.assertIn("not talking to it", out.stderr)
            finally:
                fake.kill()
                fake.wait()
                fake.stdout.close()


class SecondInstanceTest(unittest.TestCase):
    def test_same_control_socket(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = Daemon(tmp, sim_conf())
            try:
                refused(self, tmp, sim_conf(), d.ctl, "listens on this socket", d.ctl)
                # the first one still has its socket and answers on it
                self.assertEqual(ctl(d.ctl, "status").returncode, 0)
            finally:
                self.assertEqual(d.stop(), 0)
            self.assertFalse(os.path.exists(d.ctl))

    def test_socket_nobody_listens_on_is_replaced(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "control")
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.bind(path)
            s.close()  # what a run killed with -9 leaves
            d = Daemon(tmp, sim_conf())
            try:
                until(lambda: ctl(d.ctl, "status").returncode == 0, 10, "the daemon on the old socket's path")
            finally:
                self.assertEqual(d.stop(), 0)

    def test_removes_only_its_own_socket(self):
        with tempfile.TemporaryDirectory() as tmp:
            stream = os.path.join(tmp, "stream")
            d = Daemon(tmp, sim_conf("[output s]\ntype = unix\npath = %s\n" % stream))
            other = []
            try:
                # someone removes our sockets and puts their own there
                for path in (d.ctl, stream):
                    os.unlink(path)
                    o = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                    o.bind(path)
                    o.listen(1)
                    other.append(o)
            finally:
                self.assertEqual(d.stop(), 0)
            self.assertTrue(os.path.exists(d.ctl), "the daemon removed a socket it did not make")
            self.assertTrue(os.path.exists(stream), "the daemon removed a socket it did not make")
            for o in other:
                o.close()

    def second_on(self, kind):
        """a daemon with a TCP, a Modbus and a Unix stream output; a second one with the same output of kind"""
        with tempfile.TemporaryDirectory() as tmp:
            tcp, mb, stream = free_port(), free_port(), os.path.join(tmp, "stream")
            outs = {"tcp": ("[output t]\ntype = tcp\nport = %d\n" % tcp, "port %d" % tcp),
                    "modbus": ("[output m]\ntype = modbus\nport = %d\n" % mb, "port %d" % mb),
                    "unix": ("[output s]\ntype = unix\npath = %s\n" % stream, stream)}
            d = Daemon(tmp, sim_conf("".join(o for o, _ in outs.values())))
            try:
                wait_port(tcp)
                wait_port(mb)
                # its own control socket: only the output is shared
                err = refused(self, tmp, sim_conf(outs[kind][0]), os.path.join(tmp, "ctl2"), outs[kind][1])
                self.assertRegex(err, "in use|listens")
                # the first one still serves every one of them
                for port in (tcp, mb):
                    socket.create_connection(("127.0.0.1", port), timeout=2).close()
                u = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                u.connect(stream)
                u.settimeout(5)
                self.assertGreater(len(u.recv(4096)), 0)
                u.close()
                if kind == "modbus":
                    # every request goes to the first daemon (none to a second one sharing the port)
                    before = d.output("m")["modbus"]["requests"]
                    for i in range(20):
                        c = socket.create_connection(("127.0.0.1", mb), timeout=2)
                        c.sendall(bytes([0, i, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1]))
                        c.settimeout(3)
                        self.assertEqual(len(c.recv(64)), 11)
                        c.close()
                    until(lambda: d.output("m")["modbus"]["requests"] == before + 20, 5, "20 requests answered")
            finally:
                self.assertEqual(d.stop(), 0)

    def test_same_tcp_port(self):
        self.second_on("tcp")

    def test_same_modbus_port(self):
        self.second_on("modbus")

    def test_same_unix_stream_path(self):
        self.second_on("unix")

    def test_port_in_use_by_another_program(self):
        with tempfile.TemporaryDirectory() as tmp:
            squat = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            squat.bind(("127.0.0.1", 0))
            squat.listen(1)
            port = squat.getsockname()[1]
            try:
                for out in ("[output t]\ntype = tcp\nport = %d\n", "[output m]\ntype = modbus\nport = %d\n"):
                    err = refused(self, tmp, sim_conf(out % port), os.path.join(tmp, "ctl"), "port %d" % port)
                    self.assertIn("in use", err)
            finally:
                squat.close()


def bound(proto, port):
    """the local addresses (hex, as /proc/net shows them) of this host's sockets on port"""
    out = set()
    for name in (proto, proto + "6"):
        with open("/proc/net/" + name) as f:
            for line in f.readlines()[1:]:
                addr, p = line.split()[1].split(":")
                if int(p, 16) == port:
                    out.add(addr)
    return out


class VrpnTest(unittest.TestCase):
    def test_default_address_is_loopback(self):
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output v]\ntype = vrpn\nport = %d\n" % port))
            try:
                wait_port(port)
                self.assertEqual(bound("tcp", port), {"0100007F"})
                self.assertEqual(bound("udp", port), {"0100007F"})
            finally:
                self.assertEqual(d.stop(), 0)

    def test_udp_only_to_the_connections_address(self):
        """a client at 127.0.0.2 names 127.0.0.1 in its UDP announcement: the reports go to 127.0.0.2"""
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output v]\ntype = vrpn\nport = %d\n" % port))
            socks = []
            try:
                wait_port(port)
                named = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                named.bind(("127.0.0.1", 0))
                udp_port = named.getsockname()[1]
                peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                peer.bind(("127.0.0.2", udp_port))
                c = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                c.bind(("127.0.0.2", 0))
                c.connect(("127.0.0.1", port))
                socks = [named, peer, c]
                c.sendall(vc.cookie())
                c.sendall(vc.message(vc.UDP_DESCRIPTION, udp_port, b"127.0.0.1\0") +
                          vc.description(vc.SENDER_DESCRIPTION, 0, "Avatar0"))
                peer.settimeout(5)
                data = peer.recv(65536)
                self.assertGreater(len(data), 24)
                named.settimeout(0.5)
                with self.assertRaises(socket.timeout):
                    named.recv(65536)
            finally:
                for s_ in socks:
                    s_.close()
                self.assertEqual(d.stop(), 0)

    def test_call_back_only_to_the_requests_address(self):
        """a request from 127.0.0.2 naming 127.0.0.1: the server connects to 127.0.0.2"""
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output v]\ntype = vrpn\nport = %d\n" % port))
            socks = []
            try:
                wait_port(port)
                named = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                named.bind(("127.0.0.1", 0))
                cb_port = named.getsockname()[1]
                named.listen(1)
                real = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                real.bind(("127.0.0.2", cb_port))
                real.listen(1)
                lob = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                lob.bind(("127.0.0.2", 0))
                socks = [named, real, lob]
                real.settimeout(0.5)
                conn = None
                for _ in range(10):
                    lob.sendto(b"127.0.0.1 %d\0" % cb_port, ("127.0.0.1", port))
                    try:
                        conn, _ = real.accept()
                        break
                    except socket.timeout:
                        pass
                self.assertIsNotNone(conn, "no call back to the request's address")
                socks.append(conn)
                named.settimeout(0.5)
                with self.assertRaises(socket.timeout):
                    named.accept()
            finally:
                for s_ in socks:
                    s_.close()
                self.assertEqual(d.stop(), 0)


CLIP = os.path.join(ROOT, "config", "clips", "cmu_141_16.csv")
ROLES = ("head", "lhand", "rhand")
AXES = ("x", "y", "z", "qw", "qx", "qy", "qz")


def clip_pose_rows(n):
    """n rows of the clip's first n frames: frame, t, then x y z qw qx qy qz of head, lhand, rhand"""
    rows = []
    with open(CLIP) as f:
        head = f.readline().strip().split(",")
        idx = [head.index("%s_%s" % (r, a)) for r in ROLES for a in AXES]
        for i, line in enumerate(f):
            if i == n:
                break
            v = line.strip().split(",")
            rows.append([float(v[k]) for k in idx])
    return rows


class HostileTest(unittest.TestCase):
    """hostile values in each kind of source: never a NaN (but a missing sensor's) or an infinity on the
    wire, nothing beyond max_distance, the values counted as malformed"""

    def check_frames(self, frames, limit=100.0):
        """every frame finite where the protocol says so; returns how many had a STALE sensor"""
        self.assertGreater(len(frames), 20, "too few frames")
        stale = 0
        for f in frames:
            for s in f["sensors"]:
                if s["state"] == 2:
                    continue  # MISSING: NaN by the protocol's rule
                stale += s["state"] == 1
                for v in s["p"] + s["q"]:
                    self.assertTrue(math.isfinite(v), "a non-finite sensor value published: %r" % (f,))
                self.assertLessEqual(math.sqrt(sum(v * v for v in s["p"])), limit * 1.0001,
                                     "a sensor beyond max_distance published: %r" % (s,))
                self.assertAlmostEqual(math.sqrt(sum(v * v for v in s["q"])), 1.0, delta=1e-3)
            j = f["joints"]
            if not all(math.isnan(v) for v in j):
                for v in j:
                    self.assertTrue(math.isfinite(v), "a non-finite joint published: %r" % (f,))
        return stale

    def run_daemon(self, tmp, conf, seconds, pass_fds=(), during=None):
        """the daemon on conf for seconds (during(d) is called meanwhile); its frames and last status"""
        udp = free_port(socket.SOCK_DGRAM)
        rx = UdpFrames(udp)
        d = Daemon(tmp, conf + "[output hostile_u]\ntype = udp\nport = %d\n" % udp, pass_fds=pass_fds)
        try:
            if during:
                during(d)
            t_end = time.monotonic() + seconds
            while time.monotonic() < t_end:
                time.sleep(0.05)
            st = d.status()
        finally:
            rx.close()
            self.assertEqual(d.stop(), 0)
        return rx.snapshot(), st

    def test_replay_csv(self):
        rows = clip_pose_rows(300)
        with tempfile.TemporaryDirectory() as tmp:
            clip = os.path.join(tmp, "hostile.csv")
            with open(clip, "w") as f:
                f.write(",".join(["frame", "t"] + ["%s_%s" % (r, a) for r in ROLES for a in AXES]) + "\n")
                for i, r in enumerate(rows):
                    r = list(r)
                    if 60 <= i < 120:
                        r[7 * 2 + 1] = "1e39"  # rhand y: finite as a double, infinite as a float
                    elif 120 <= i < 180:
                        r[7 * 1 + 0] = "-3e38"  # lhand x: a float, 3e38 m away
                    elif 180 <= i < 200:
                        r[7 * 2 + 2] = "150"  # rhand z: 150 m up
                    f.write(",".join(["%d" % i, "%.6f" % (i / 60)] + [str(v) for v in r]) + "\n")
            conf = ("[daemon]\nrate = 120\nstale_ms = 100\n[source rp]\ntype = replay\nfile = %s\n"
                    "[avatar a]\nperson = rp\n" % clip)
            frames, st = self.run_daemon(tmp, conf, 4.5)
            stale = self.check_frames(frames)
            self.assertGreater(stale, 10, "the hands were never STALE while their samples were refused")
            src = [x for x in st["sources"] if x["name"] == "rp"][0]
            self.assertGreaterEqual(src["malformed"], 140)
            # the posture stayed: frames went on all along
            self.assertEqual([a["nan_blocked"] for a in st["avatars"]], [0])

    def test_replay_recording(self):
        with tempfile.TemporaryDirectory() as tmp:
            rec = os.path.join(tmp, "rec")
            d = Daemon(tmp, sim_conf("[daemon]\nrecord_dir = %s\n" % rec))
            try:
                until(lambda: d.status()["recorder"]["records"] > 2400, 20, "three seconds recorded")
            finally:
                self.assertEqual(d.stop(), 0)
            files = sorted(os.listdir(rec))
            path = os.path.join(rec, files[0])
            with open(path, "rb") as f:
                data = bytearray(f.read())
            # the right hand's samples (sensor 2 of source 0, sim's p0.right_hand) in the middle: hostile
            samples, pos = [], 32
            while pos + 12 <= len(data):
                self.assertEqual(bytes(data[pos:pos + 4]), b"\xa5REC")
                word = struct.unpack_from("<I", data, pos + 4)[0]
                n = word >> 8
                if word & 0xFF == 2 and struct.unpack_from("<HH", data, pos + 8) == (0, 2):
                    samples.append(pos)
                pos += 12 + n
            bad = samples[len(samples) // 3: 2 * len(samples) // 3]
            for k, at in enumerate(bad):
                pl = at + 8
                if k % 3 == 0:
                    struct.pack_into("<f", data, pl + 28, float("inf"))  # y
                elif k % 3 == 1:
                    struct.pack_into("<f", data, pl + 24, 1e30)  # x, far beyond any room
                else:
                    struct.pack_into("<4f", data, pl + 36, 0.0, 0.0, 0.0, 0.0)  # no rotation at all
                n = struct.unpack_from("<I", data, at + 4)[0] >> 8
                struct.pack_into("<I", data, at + 8 + n, zlib.crc32(bytes(data[at + 4:at + 8 + n])))
            hostile = os.path.join(tmp, "hostile.agwrec")
            with open(hostile, "wb") as f:
                f.write(data)
            conf = ("[daemon]\nrate = 120\nstale_ms = 100\n[source rp]\ntype = replay\nfile = %s\n"
                    "[avatar a]\nperson = rp/sim.p0\n" % hostile)
            frames, st = self.run_daemon(os.path.join(tmp, "rec"), conf, 3.0)
            stale = self.check_frames(frames)
            self.assertGreater(stale, 10, "the right hand was never STALE while its samples were refused")
            src = [x for x in st["sources"] if x["name"] == "rp"][0]
            self.assertGreaterEqual(src["malformed"], len(bad) // 2)  # those played in the time

    def test_modbus(self):
        peer = os.path.join(os.path.dirname(os.path.abspath(__file__)), "modbus_peer.py")
        port = free_port()

        def f32(v):
            return list(struct.unpack(">HH", struct.pack(">f", v)))

        # pose0: x = FLT_MAX (7F7F FFFF) times a scale of 10; pose1: 1000 km; pose2: a quaternion of length 3
        quat = f32(0.0) * 3 + f32(1.0)  # x y z w
        regs = ([0x7F7F, 0xFFFF] + f32(0.0) * 2 + quat + [0] * 6 +
                f32(1e6) + f32(0.0) * 2 + quat + [0] * 6 +
                f32(0.5) * 3 + f32(0.0) * 3 + f32(3.0) + [0] * 6)
        p = subprocess.Popen([sys.executable, peer, str(port), "i:100=" + ",".join(str(v) for v in regs)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            wait_port(port)
            conf = ("[daemon]\nrate = 120\n[source sim]\ntype = sim\n"
                    "[source dev]\ntype = modbus\naddress = 127.0.0.1\nport = %d\nregister_type = input\n"
                    "sensors = 3\nsensor_stride = 20\nposition_register = 100\nposition_format = float32\n"
                    "position_scale = 10\norientation_register = 106\norientation_format = float32\n"
                    "orientation_scale = 1\norientation = quat_xyzw\npoll_rate = 50\n"
                    "[avatar a]\nperson = sim/p0\nleft_hand = dev/pose0\n"
                    "[avatar b]\nid = 1\nperson = sim/p0\nleft_hand = dev/pose1\nright_hand = dev/pose2\n" % port)
            with tempfile.TemporaryDirectory() as tmp:
                frames, st = self.run_daemon(tmp, conf, 2.0)
            self.check_frames(frames)
            # the hostile sensors never got a sample in: MISSING throughout
            for f in frames:
                if f["avatar"] == 0:
                    self.assertEqual(f["sensors"][1]["state"], 2)
                else:
                    self.assertEqual([s["state"] for s in f["sensors"][1:]], [2, 2])
            src = [x for x in st["sources"] if x["name"] == "dev"][0]
            self.assertGreater(src["malformed"], 10)
        finally:
            p.kill()
            p.wait()

    def test_can(self):
        frame = struct.Struct("<IB3x8s")
        mine, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        conf = ("[daemon]\nrate = 120\nstale_ms = 100\n[source sim]\ntype = sim\n"
                "[source imu]\ntype = can\ninterface = fd:%d\nsensors = 1\norientation_id = 0x200\n"
                "position_id = 0x280\nquaternion_scale = 16384\nposition_scale = 0.01\n"
                "[avatar a]\nperson = sim/p0\nright_hand = imu/pose0\n" % theirs.fileno())

        def send(can_id, data):
            mine.send(frame.pack(can_id, len(data), data))

        def feed(d):
            quat = struct.pack("<4h", 16384, 0, 0, 0)
            # a good pose, then positions of 327 m (int16 at 0.01 m) for a second, then good again
            for _ in range(20):
                send(0x200, quat)
                send(0x280, struct.pack("<3h", 30, 40, 100))
                time.sleep(0.01)
            t_end = time.monotonic() + 1.0
            while time.monotonic() < t_end:
                send(0x280, struct.pack("<3h", 32767, -32768, 32767))
                time.sleep(0.01)

        with tempfile.TemporaryDirectory() as tmp:
            try:
                frames, st = self.run_daemon(tmp, conf, 0.2, pass_fds=(theirs.fileno(),), during=feed)
            finally:
                mine.close()
                theirs.close()
        stale = self.check_frames(frames)
        self.assertGreater(stale, 10, "the hand was never STALE while its samples were refused")
        # what was published for it is its last good pose
        for f in frames:
            s = f["sensors"][2]
            if s["state"] != 2:
                for got, want in zip(s["p"], (0.3, 0.4, 1.0)):
                    self.assertAlmostEqual(got, want, delta=1e-6)
        src = [x for x in st["sources"] if x["name"] == "imu"][0]
        self.assertGreater(src["malformed"], 20)

    def capture_run(self, driver, lines, extra="", limit=100.0):
        with tempfile.TemporaryDirectory() as tmp:
            cap = os.path.join(tmp, "hostile.cap")
            with open(cap, "w") as f:
                f.write("\n".join(lines) + "\n")
            conf = ("[daemon]\nrate = 120\nstale_ms = 100\n[source sim]\ntype = sim\n"
                    "[source dev]\ntype = %s\ncapture = %s\n%s"
                    "[avatar a]\nperson = sim/p0\n%s" % (driver, cap, extra,
                                                           "left_hand = dev/left\nright_hand = dev/right\n"
                                                           if driver == "hydra" else
                                                           "right_hand = dev/right_hand\n"))
            frames, st = self.run_daemon(tmp, conf, 3.0)
        self.check_frames(frames, limit)
        src = [x for x in st["sources"] if x["name"] == "dev"][0]
        self.assertGreater(src["malformed"], 10)
        return frames

    def test_hydra_capture(self):
        with open(os.path.join(ROOT, "tests", "data", "hydra-cmu_141_16.cap")) as f:
            lines = [ln.strip() for ln in f if ln.strip() and not ln.startswith("#")]
        out = []
        for i, ln in enumerate(lines[:600]):
            t, hexes = ln.split(" ", 1)
            b = bytearray(bytes.fromhex(hexes.replace(" ", "")))
            if 200 <= i < 400:
                w = 8 + 22 * (i % 2)
                if i % 4 < 2:
                    struct.pack_into("<4h", b, w + 6, 0, 0, 0, 0)  # no rotation
                else:
                    struct.pack_into("<3h", b, w, 32767, -32768, 32767)  # 57 m in one report
            out.append(t + " " + " ".join("%02x" % c for c in b))
        self.capture_run("hydra", out, "origin = 0 0.5 1.45\nyaw = -20\n")

    def test_polhemus_capture(self):
        with open(os.path.join(ROOT, "tests", "data", "polhemus-cmu_141_16.cap")) as f:
            lines = [ln.strip() for ln in f if ln.strip() and not ln.startswith("#")]
        out = []
        for i, ln in enumerate(lines[:720]):
            b = bytearray(bytes.fromhex(ln))
            if 240 <= i < 480:
                # station 3 (the right hand, the third 41-byte record): x infinite, NaN, 1e30 cm, 9999 cm
                at = 2 * 41 + 8
                v = (float("inf"), float("nan"), 1e30, 9999.0)[i % 4]
                struct.pack_into("<f", b, at, v)
            out.append(b.hex())
        self.capture_run("polhemus", out, "model = liberty_hs\norigin = 0.1 0.6 2.2\nyaw = 30\n"
                         "max_distance = 50\n", limit=50.0)


def connect_from(src, port, timeout=3):
    """a TCP connection to 127.0.0.1:port from the loopback address src (127.0.0.2 is another host)"""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind((src, 0))
    s.settimeout(timeout)
    s.connect(("127.0.0.1", port))
    return s


def mb_read(s, tid=1):
    """one Modbus request (input register 0) and its answer's length, 0 if the connection was closed"""
    try:
        s.sendall(bytes([0, tid & 0xFF, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1]))
        return len(s.recv(64))
    except (ConnectionResetError, BrokenPipeError, socket.timeout):
        return 0


def is_closed(s, timeout):
    """true if the peer closes s within timeout (what it sends before is read and dropped)"""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s.settimeout(max(0.01, end - time.monotonic()))
        try:
            if not s.recv(65536):
                return True
        except socket.timeout:
            return False
        except ConnectionResetError:
            return True
    return False


class SlotsTest(unittest.TestCase):
    """connection slots: idle or broken clients do not lock others out"""

    def test_modbus_idle_clients(self):
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output m]\ntype = modbus\nport = %d\n" % port))
            idle = []
            try:
                wait_port(port)
                until(lambda: d.output("m")["clients"] == 0, 5, "wait_port's connection gone")
                # one host opens 8 silent connections: it gets its share (4), and a fifth of its own
                # connections only ever replaces one of its others
                for _ in range(8):
                    idle.append(connect_from("127.0.0.2", port))
                until(lambda: d.output("m")["clients"] == 4, 5, "four clients of 127.0.0.2")
                time.sleep(0.3)
                self.assertEqual(d.output("m")["clients"], 4)
                # a second host fills the other slots
                for _ in range(4):
                    idle.append(connect_from("127.0.0.3", port))
                until(lambda: d.output("m")["clients"] == 8, 5, "eight clients")
                # a real client still gets in once they have been idle a second, and is served
                time.sleep(1.2)
                c = connect_from("127.0.0.1", port)
                idle.append(c)
                self.assertEqual(mb_read(c), 11, "a client locked out by idle connections")
                o = d.output("m")
                self.assertEqual(o["clients"], 8)
                self.assertGreaterEqual(o["modbus"]["evicted"], 1)
            finally:
                for s_ in idle:
                    s_.close()
                self.assertEqual(d.stop(), 0)

    def test_vrpn_clients_that_only_read(self):
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output v]\ntype = vrpn\nport = %d\n" % port))
            readers, stop = [], threading.Event()

            def drain():
                while not stop.is_set():
                    r, _, _ = select.select(readers, [], [], 0.05)
                    for s_ in r:
                        try:
                            s_.recv(65536)
                        except OSError:
                            pass

            th = threading.Thread(target=drain, daemon=True)
            try:
                wait_port(port)
                until(lambda: d.output("v")["clients"] == 0, 5, "wait_port's connection gone")
                # two hosts, four clients each that shake hands and then read everything, forever
                for src in ("127.0.0.2", "127.0.0.3"):
                    for _ in range(4):
                        s_ = connect_from(src, port)
                        s_.sendall(vc.cookie())
                        s_.setblocking(False)
                        readers.append(s_)
                th.start()
                until(lambda: d.output("v")["clients"] == 8, 5, "eight readers")
                # a fifth from one of them: it takes one of its own host's slots, no one else's
                time.sleep(1.2)
                extra = connect_from("127.0.0.2", port)
                extra.close()
                # a real client gets in and receives reports
                c = vc.Client("127.0.0.1", port, ["Avatar0"], mode="tcp")
                try:
                    self.assertTrue(c.poll(1.0), "the new client was closed")
                    self.assertTrue(c.of(vc.POS_QUAT, "Avatar0"), "no reports for the new client")
                finally:
                    c.close()
            finally:
                stop.set()
                if th.is_alive():
                    th.join()
                for s_ in readers:
                    s_.close()
                self.assertEqual(d.stop(), 0)

    def test_stream_subscribers_that_stopped_reading(self):
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, sim_conf("[output t]\ntype = tcp\nport = %d\nmax_clients = 2\nclient_buffer = 4096\n"
                                     % port))
            stuck = []
            try:
                wait_port(port)
                until(lambda: d.output("t")["clients"] == 0, 5, "wait_port's connection gone")
                for src in ("127.0.0.2", "127.0.0.3"):
                    s_ = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                    s_.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
                    s_.bind((src, 0))
                    s_.connect(("127.0.0.1", port))
                    stuck.append(s_)  # never read: their sockets fill, then take nothing more
                until(lambda: d.output("t")["dropped"] > 200, 10, "the two subscribers stalled")
                time.sleep(1.2)
                c = connect_from("127.0.0.1", port)
                stuck.append(c)
                got = b""
                while len(got) < 8:
                    chunk = c.recv(4096)
                    self.assertTrue(chunk, "the new subscriber was closed")
                    got += chunk
                self.assertEqual(d.output("t")["clients"], 2)
            finally:
                for s_ in stuck:
                    s_.close()
                self.assertEqual(d.stop(), 0)

    def ws_conf(self, port):
        return sim_conf("[output w]\ntype = websocket\nport = %d\nmax_clients = 2\nidle_timeout = 2\n"
                        "client_timeout = 2\n" % port)

    def test_websocket_broken_clients(self):
        from wsclient import WsClient
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, self.ws_conf(port))
            try:
                wait_port(port)
                cases = {
                    "unmasked frame": b"\x81\x05hello",
                    "2^62 bytes announced": b"\x82\xff" + struct.pack(">Q", 1 << 62) + b"\0\0\0\0",
                    "endless fragments": b"\x01\x81\0\0\0\0a" + b"\x00\x81\0\0\0\0a" * 50,
                    "a masked text": b"\x81\x85\x01\x02\x03\x04" + bytes(a ^ b for a, b in zip(b"hello", b"\x01\x02\x03\x04\x01")),
                }
                for what, data in cases.items():
                    w = WsClient("127.0.0.1", port)
                    w.sock.sendall(data)
                    # closed at once (it sends data), or within the idle timeout (2 s) when it says nothing
                    self.assertTrue(is_closed(w.sock, 6), "%s: the connection stays" % what)
                    w.close()
                # and the slots are free again: two browsers get frames
                ws = [WsClient("127.0.0.1", port) for _ in range(2)]
                for w in ws:
                    self.assertIsNotNone(w.recv_text(3))
                    w.close()
            finally:
                self.assertEqual(d.stop(), 0)

    def test_websocket_slots(self):
        from wsclient import WsClient
        with tempfile.TemporaryDirectory() as tmp:
            port = free_port()
            d = Daemon(tmp, self.ws_conf(port))
            try:
                wait_port(port)
                # a connection that never finishes its HTTP request goes after client_timeout (2 s)
                half = socket.create_connection(("127.0.0.1", port))
                half.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n")
                self.assertTrue(is_closed(half, 8), "a half request holds its connection")
                half.close()
                # two browsers that answer no ping fill the slots; after a second a third takes the slot
                # of the one idle the longest
                a, b = WsClient("127.0.0.1", port), WsClient("127.0.0.1", port)
                time.sleep(1.2)
                c = WsClient("127.0.0.1", port)
                self.assertIsNotNone(c.recv_text(3), "the new browser gets no frame")
                self.assertTrue(is_closed(a.sock, 3), "the browser idle the longest stays")
                for w in (a, b, c):
                    w.close()
            finally:
                self.assertEqual(d.stop(), 0)


class JsonTest(unittest.TestCase):
    def test_status_json_with_quotes_and_backslashes(self):
        with tempfile.TemporaryDirectory() as tmp:
            odd = os.path.join(tmp, 'a "quoted" \\dir\\ \t')
            os.mkdir(odd)
            rec = os.path.join(odd, 'rec"\\')
            d = Daemon(odd, sim_conf("[daemon]\nrecord_dir = %s\n" % rec))
            try:
                st = until(lambda: (lambda s: s if s["recorder"]["file"] else None)(d.status()), 10,
                           "a recording file")
                self.assertEqual(st["config"], d.conf)
                self.assertEqual(st["recorder"]["dir"], rec)
                self.assertTrue(st["recorder"]["file"].startswith(rec + "/"), st["recorder"]["file"])
            finally:
                self.assertEqual(d.stop(), 0)


if __name__ == "__main__":
    unittest.main()
