# SPDX-License-Identifier: MIT
"""What the bus tests (test_modbus.py, test_can.py) share: the daemon on a
temporary configuration (with inherited descriptors, for CAN over a
socketpair), a UDP receiver that decodes FRAME messages with struct
(docs/PROTOCOL.md), and pymodbus importable on a machine without
python3-serial-asyncio."""
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import types

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.path.join(ROOT, os.environ.get("BUILD", "build"))
DAEMON = os.path.join(BUILD, "avatargw")
CTL = os.path.join(BUILD, "avatargw-ctl")


def import_pymodbus():
    """python3-pymodbus 3.0.0 imports its serial transport even for TCP; that
    comes from python3-serial-asyncio, a Recommends (tools/install-deps.sh
    installs it). These tests use TCP only: without the package, an empty
    module stands in for it."""
    try:
        import serial_asyncio  # noqa: F401
    except ImportError:
        m = types.ModuleType("serial_asyncio")
        m.create_serial_connection = None
        sys.modules["serial_asyncio"] = m


def free_port(kind=socket.SOCK_STREAM):
    s = socket.socket(socket.AF_INET, kind)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def wait_port(port, timeout=10):
    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return
        except OSError:
            time.sleep(0.05)
    raise AssertionError("nothing listens on port %d" % port)


def until(pred, timeout, what):
    """polls pred() until it is true; fails naming what was awaited"""
    deadline = time.time() + timeout
    while True:
        v = pred()
        if v:
            return v
        if time.time() > deadline:
            raise AssertionError("timed out waiting for " + what)
        time.sleep(0.05)


class Daemon:
    """avatargw on conf_text in tmp; pass_fds are inherited (interface = fd:N)"""

    def __init__(self, tmp, conf_text, pass_fds=()):
        self.ctl = os.path.join(tmp, "control")
        self.conf = os.path.join(tmp, "avatargw.conf")
        with open(self.conf, "w") as f:
            f.write(conf_text)
        self.err_path = os.path.join(tmp, "daemon.err")
        self.err = open(self.err_path, "w")
        self.proc = subprocess.Popen([DAEMON, "-c", self.conf, "--set", "daemon.control_socket=" + self.ctl],
                                     stdout=subprocess.DEVNULL, stderr=self.err, pass_fds=tuple(pass_fds))
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
        out = subprocess.run([CTL, "-s", self.ctl, "status", "--json"], capture_output=True, text=True, timeout=5)
        if out.returncode != 0:
            raise AssertionError("avatargw-ctl failed: " + out.stderr)
        return json.loads(out.stdout)

    def source(self, name):
        return [s for s in self.status()["sources"] if s["name"] == name][0]

    def output(self, name):
        return [o for o in self.status()["outputs"] if o["name"] == name][0]

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


def parse_frame(d):
    """a FRAME datagram (docs/PROTOCOL.md) as a dict, or None for other messages"""
    if len(d) < 40 or d[0:4] != b"AVGW" or d[5] != 1:
        return None
    flags, source, seq = struct.unpack_from("<HII", d, 10)
    t_ns, avatar = struct.unpack_from("<QH", d, 24)
    sensors = []
    for i in range(3):
        state, age = struct.unpack_from("<BxH", d, 40 + 32 * i)
        v = struct.unpack_from("<7f", d, 44 + 32 * i)
        sensors.append({"state": state, "age_100us": age, "p": v[0:3], "q": v[3:7]})
    arms = [struct.unpack_from("<H", d, 136 + 8 * a)[0] for a in range(2)]
    joints = struct.unpack_from("<17f", d, 152)
    return {"flags": flags, "source": source, "seq": seq, "t_ns": t_ns, "avatar": avatar, "sensors": sensors,
            "ik": arms, "joints": joints}


class UdpFrames:
    """receives FRAME datagrams on a port in a thread, with their arrival times"""

    def __init__(self, port):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.settimeout(0.1)
        self.frames = []
        self.lock = threading.Lock()
        self.running = True
        self.th = threading.Thread(target=self._run, daemon=True)
        self.th.start()

    def _run(self):
        while self.running:
            try:
                d = self.sock.recv(2048)
            except socket.timeout:
                continue
            f = parse_frame(d)
            if f:
                f["arrival"] = time.monotonic()
                with self.lock:
                    self.frames.append(f)

    def snapshot(self):
        with self.lock:
            return list(self.frames)

    def latest(self, avatar):
        with self.lock:
            for f in reversed(self.frames):
                if f["avatar"] == avatar:
                    return f
        return None

    def clear(self):
        with self.lock:
            self.frames = []

    def close(self):
        self.running = False
        self.th.join()
        self.sock.close()
