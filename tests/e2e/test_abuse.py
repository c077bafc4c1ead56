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
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from busutil import CTL, DAEMON, Daemon, free_port, until, wait_port  # noqa: E402
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
            nsock.settimeout(0.2)
            env = dict(os.environ, NOTIFY_SOCKET=ns, WATCHDOG_USEC="1000000")
            d = Daemon(tmp, sim_conf())
            # Daemon() takes no env: this one is started by hand on the same files
            d.stop()
            p = start(d.conf, d.ctl, env=env)
            try:
                until(lambda: os.path.exists(d.ctl), 10, "the control socket")
                slow = [Dribbler(d.ctl) for _ in range(3)]
                for s in slow:
                    s.start()
                beats, t_end, last = [], time.monotonic() + 4, time.monotonic()
                answered = 0
                while time.monotonic() < t_end:
                    # the control thread answers others while the slow clients dribble
                    t0 = time.monotonic()
                    out = ctl(d.ctl, "status", timeout=10)
                    self.assertEqual(out.returncode, 0, out.stderr)
                    self.assertIn("avatargw: up", out.stdout)
                    answered += 1
                    try:
                        while True:
                            m = nsock.recv(4096).decode()
                            if "WATCHDOG=1" in m:
                                beats.append(time.monotonic())
                    except socket.timeout:
                        pass
                    self.assertLess(time.monotonic() - t0, 4.0, "status took too long")
                self.assertGreater(answered, 2)
                # the watchdog is fed every half period (0.5 s): no gap near the 1 s timeout
                beats = [last] + beats
                gaps = [b - a for a, b in zip(beats, beats[1:])]
                self.assertGreater(len(gaps), 3, "watchdog pings: %r" % beats)
                self.assertLess(max(gaps), 2.0, "watchdog gaps %r" % gaps)
                # each slow client was cut off at its deadline (1 s for the request line)
                for s in slow:
                    until(lambda: s.closed_after is not None, 5, "the slow client's end")
                    self.assertLess(s.closed_after, 4.0)
                # and SIGTERM is acted on at once, slow clients or not
                more = [Dribbler(d.ctl, 0.1) for _ in range(3)]
                for s in more:
                    s.start()
                t0 = time.monotonic()
                p.send_signal(signal.SIGTERM)
                p.wait(timeout=5)
                self.assertLess(time.monotonic() - t0, 2.0)
                self.assertEqual(p.returncode, 0)
                for s in slow + more:
                    s.stop()
            finally:
                if p.poll() is None:
                    p.kill()
                p.communicate()
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
