# SPDX-License-Identifier: MIT
"""A VRPN client written from the protocol description (docs/VRPN.md), for the
tests: the cookie handshake, sender and type descriptions both ways, the two
ways of connecting (straight to the server's TCP port, or VRPN's default: a
UDP request after which the server connects back), the UDP low-latency
channel, ping/pong, and the tracker, analog and button messages.

It shares no code with the daemon: everything below is read off the wire
format (big-endian, a 24-byte header of length, seconds, microseconds,
sender and type, payloads padded to 8 bytes)."""
import select
import socket
import struct
import time

MAGIC = b"vrpn: ver. 07.35"
COOKIE_LEN = 24
HEADER_LEN = 24
SENDER_DESCRIPTION, TYPE_DESCRIPTION, UDP_DESCRIPTION = -1, -2, -3

POS_QUAT = "vrpn_Tracker Pos_Quat"
ANALOG = "vrpn_Analog Channel"
BUTTON_CHANGE = "vrpn_Button Change"
BUTTON_STATES = "vrpn_Button States"
PING = "vrpn_Base ping_message"
PONG = "vrpn_Base pong_message"
OUR_TYPES = [PING, PONG, POS_QUAT, ANALOG, BUTTON_CHANGE, BUTTON_STATES, "vrpn_Base text_message"]


def pad8(n):
    return (n + 7) & ~7


def message(type_id, sender, payload=b"", t=None):
    t = time.time() if t is None else t
    sec = int(t)
    usec = int((t - sec) * 1e6)
    head = struct.pack(">IIIii", HEADER_LEN + len(payload), sec, usec, sender, type_id) + b"\0" * 4
    return head + payload + b"\0" * (pad8(len(payload)) - len(payload))


def description(kind, ident, name):
    raw = name.encode() + b"\0"
    return message(kind, ident, struct.pack(">I", len(raw)) + raw)


def cookie(log_mode=0):
    c = MAGIC + b"  " + str(log_mode).encode()
    return c + b"\0" * (COOKIE_LEN - len(c))


def split_messages(buf):
    """whole messages at the front of buf: [(type, sender, sec, usec, payload)], rest"""
    out = []
    while len(buf) >= HEADER_LEN:
        length, sec, usec, sender, type_id = struct.unpack(">IIIii", buf[:20])
        if length < HEADER_LEN:
            raise ValueError("bad message length %d" % length)
        total = HEADER_LEN + pad8(length - HEADER_LEN)
        if len(buf) < total:
            break
        out.append((type_id, sender, sec, usec, buf[HEADER_LEN:length]))
        buf = buf[total:]
    return out, buf


class Client:
    """One connection to a VRPN server, for the devices named.

    mode "tcp": connect to the server's TCP port ("Avatar0@tcp://host").
    mode "lob": VRPN's default ("Avatar0@host"): listen on a TCP port, send the
    server "<address> <port>" over UDP until it connects to us.
    udp: offer a UDP port for the low-latency reports."""

    def __init__(self, host, port, devices, mode="tcp", udp=False, timeout=5.0):
        self.devices = list(devices)
        self.events = []       # (channel, kind, device, sec, usec, data)
        self.server_types = {}   # its ids -> names
        self.server_senders = {}
        self.pongs = 0
        self.buf = b""
        self.udp = None
        self.connect_mode = mode
        if mode == "tcp":
            self.sock = socket.create_connection((host, port), timeout=timeout)
        else:
            lst = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            lst.bind(("127.0.0.1", 0))
            lst.listen(1)
            lob = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            request = ("127.0.0.1 %d" % lst.getsockname()[1]).encode() + b"\0"
            deadline = time.time() + timeout
            self.sock = None
            while self.sock is None:
                if time.time() > deadline:
                    raise AssertionError("the server did not connect back")
                lob.sendto(request, (host, port))
                r, _, _ = select.select([lst], [], [], 0.5)
                if r:
                    self.sock, _ = lst.accept()
            lst.close()
            lob.close()
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock.settimeout(timeout)
        self.sock.sendall(cookie())
        theirs = self._read_exact(COOKIE_LEN)
        if not theirs.startswith(b"vrpn: ver. 07."):
            raise AssertionError("bad cookie from the server: %r" % theirs)
        self.server_cookie = theirs
        out = b""
        self.my_types = {name: i for i, name in enumerate(OUR_TYPES)}
        self.my_senders = {name: i for i, name in enumerate(self.devices)}
        if udp:
            self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.udp.bind(("127.0.0.1", 0))
            out += message(UDP_DESCRIPTION, self.udp.getsockname()[1], b"127.0.0.1\0")
        for name, i in self.my_types.items():
            out += description(TYPE_DESCRIPTION, i, name)
        for name, i in self.my_senders.items():
            out += description(SENDER_DESCRIPTION, i, name)
        self.sock.sendall(out)
        self.sock.setblocking(False)

    def _read_exact(self, n):
        data = b""
        while len(data) < n:
            chunk = self.sock.recv(n - len(data))
            if not chunk:
                raise AssertionError("the server closed the connection")
            data += chunk
        return data

    def ping(self, device):
        self.sock.sendall(message(self.my_types[PING], self.my_senders[device]))

    def close(self):
        self.sock.close()
        if self.udp:
            self.udp.close()

    def _handle(self, channel, msgs):
        for type_id, sender, sec, usec, pl in msgs:
            if type_id == TYPE_DESCRIPTION or type_id == SENDER_DESCRIPTION:
                n = struct.unpack(">I", pl[:4])[0]
                name = pl[4:4 + n].rstrip(b"\0").decode()
                (self.server_types if type_id == TYPE_DESCRIPTION else self.server_senders)[sender] = name
                continue
            if type_id < 0:
                continue
            kind = self.server_types.get(type_id)
            device = self.server_senders.get(sender)
            if kind is None or device is None:
                raise AssertionError("message of undescribed type %d / sender %d" % (type_id, sender))
            if kind == POS_QUAT:
                s, _ = struct.unpack(">ii", pl[:8])
                v = struct.unpack(">7d", pl[8:64])
                data = (s, v[0:3], v[3:7])  # sensor, position, quaternion x y z w
            elif kind == ANALOG:
                count = struct.unpack(">d", pl[:8])[0]
                data = struct.unpack(">%dd" % int(count), pl[8:8 + 8 * int(count)])
            elif kind == BUTTON_CHANGE:
                data = struct.unpack(">ii", pl[:8])
            elif kind == BUTTON_STATES:
                count = struct.unpack(">i", pl[:4])[0]
                data = struct.unpack(">%di" % count, pl[4:4 + 4 * count])
            elif kind == PONG:
                self.pongs += 1
                data = None
            else:
                data = pl
            self.events.append((channel, kind, device, sec, usec, data))

    def poll(self, duration):
        """reads for duration seconds; returns False if the server closed the connection"""
        end = time.time() + duration
        socks = [self.sock] + ([self.udp] if self.udp else [])
        while True:
            left = end - time.time()
            if left <= 0:
                return True
            r, _, _ = select.select(socks, [], [], left)
            for s in r:
                if s is self.udp:
                    dgram = s.recv(65536)
                    msgs, rest = split_messages(dgram)
                    if rest:
                        raise AssertionError("a UDP datagram with a partial message")
                    self._handle("udp", msgs)
                    continue
                try:
                    chunk = s.recv(65536)
                except BlockingIOError:
                    continue
                if not chunk:
                    return False
                msgs, self.buf = split_messages(self.buf + chunk)
                self._handle("tcp", msgs)

    def of(self, kind, device=None):
        return [e for e in self.events if e[1] == kind and (device is None or e[2] == device)]
