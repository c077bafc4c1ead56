# SPDX-License-Identifier: MIT
"""FRAME messages of the avatargw protocol (docs/PROTOCOL.md) decoded with
struct, for tests that compare another output with the UDP stream: the
values stay the exact float32 numbers that were sent."""
import socket
import struct
import threading
import time

SEGMENTS = ["chest", "head", "r_shoulder", "r_elbow", "r_wrist", "r_hand", "l_shoulder", "l_elbow", "l_wrist",
            "l_hand"]
SENSORS = ["head", "left_hand", "right_hand"]


def decode_frame(buf):
    magic, version, mtype, hlen, plen, flags, source, seq, rev, t_ns, avatar = struct.unpack_from(
        "<IBBHHHIIIQH", buf, 0)
    if magic != 0x57475641 or version != 1 or mtype != 1:
        return None
    p = hlen
    sensors = []
    for i in range(3):
        state, _, age = struct.unpack_from("<BBH", buf, p)
        v = struct.unpack_from("<7f", buf, p + 4)
        sensors.append({"state": state, "age": age, "p": v[0:3], "q": v[3:7]})
        p += 32
    p += 16  # arms
    joints = struct.unpack_from("<17f", buf, p)
    p += 68
    segments = []
    for i in range(10):
        v = struct.unpack_from("<7f", buf, p)
        segments.append({"p": v[0:3], "q": v[3:7]})  # q: w x y z
        p += 28
    return {"avatar": avatar, "seq": seq, "rev": rev, "flags": flags, "source": source, "t_ns": t_ns,
            "sensors": sensors, "joints": joints, "segments": segments}


class UdpListener:
    """collects the FRAMEs sent to a UDP port, in a thread"""

    def __init__(self, port):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", port))
        self.sock.settimeout(0.2)
        self.frames = []
        self.lock = threading.Lock()
        self.stop_flag = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stop_flag:
            try:
                data = self.sock.recv(2048)
            except socket.timeout:
                continue
            f = decode_frame(data)
            if f:
                f["rx"] = time.monotonic()
                with self.lock:
                    self.frames.append(f)

    def snapshot(self):
        with self.lock:
            return list(self.frames)

    def close(self):
        self.stop_flag = True
        self.thread.join()
        self.sock.close()
