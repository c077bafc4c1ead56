#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Turns a motion-capture clip into raw tracker captures, byte for byte as
the devices send them (docs/TRACKERS.md, ../shared/protocols/trackers.md):

  - a Razer Hydra: 52-byte HID reports at 250 Hz, the wands at the clip's
    left and right hands, with buttons, joysticks and triggers that change
    over time, the position in mm and the quaternion w x y z as int16 /
    32768 in the base's frame (z down, quaternion y and z negated as the
    device sends them), and the base's hemisphere ambiguity: a wand on the
    far side of the base's z = 0 plane is reported at -p;
  - a Polhemus Liberty HS: continuous binary frames at 240 Hz, one bulk
    transfer per frame holding one 41-byte record per station (O*,2,7,9,0:
    position in cm, quaternion w x y z, frame count, space), head on
    station 1, left hand on 2, right hand on 3, the source's z down.

The trackers are placed in the clip's world as a [source] section would
place them (origin, yaw); the captures start with comment lines saying so.
Poses between the clip's frames are interpolated (positions linearly,
orientations by slerp), as tests/test_hydra.c and tests/test_polhemus.c do
when they check the decoded poses against the clip.

usage: tools/gen-captures.py [--clip CSV] [--out DIR]
Writes DIR/hydra-CLIP.cap and DIR/polhemus-CLIP.cap (default: the repository's
config/clips/cmu_141_16.csv into tests/data). Plain python3, no numpy.
"""
import argparse
import csv
import math
import os
import struct

# where each tracker is, in the clip's world (z up, the person faces +y)
HYDRA = {"origin": (0.0, 0.5, 1.45), "yaw_deg": -20.0, "start": 0.4, "seconds": 2.0}
POLHEMUS = {"origin": (0.1, 0.6, 2.2), "yaw_deg": 30.0, "start": 2.5, "seconds": 1.5}
HYDRA_RATE = 250.0
POLHEMUS_RATE = 240.0


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


def qnorm(q):
    n = math.sqrt(sum(c * c for c in q))
    return tuple(c / n for c in q)


def qrot(q, v):
    r = qmul(qmul(q, (0.0,) + tuple(v)), qconj(q))
    return r[1:]


def slerp(a, b, u):
    d = sum(x * y for x, y in zip(a, b))
    if d < 0:
        b = tuple(-c for c in b)
        d = -d
    if d > 0.9995:
        return qnorm(tuple(x + u * (y - x) for x, y in zip(a, b)))
    th = math.acos(d)
    s = math.sin(th)
    wa, wb = math.sin((1 - u) * th) / s, math.sin(u * th) / s
    return tuple(wa * x + wb * y for x, y in zip(a, b))


def load_clip(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            row = {"t": float(r["t"])}
            for role in ("head", "lhand", "rhand"):
                row[role] = (tuple(float(r[role + "_" + k]) for k in "xyz"),
                             qnorm(tuple(float(r[role + "_q" + k]) for k in "wxyz")))
            rows.append(row)
    return rows


def pose_at(rows, role, t):
    """the clip's pose of a role at time t: linear / slerp between frames"""
    lo, hi = 0, len(rows) - 1
    while lo < hi - 1:
        mid = (lo + hi) // 2
        if rows[mid]["t"] <= t:
            lo = mid
        else:
            hi = mid
    a, b = rows[lo], rows[hi]
    u = 0.0 if b["t"] == a["t"] else min(max((t - a["t"]) / (b["t"] - a["t"]), 0.0), 1.0)
    pa, qa = a[role]
    pb, qb = b[role]
    return tuple(x + u * (y - x) for x, y in zip(pa, pb)), slerp(qa, qb, u)


def to_tracker(place, p, q):
    """world pose -> the source's tracker frame (inverse of origin + yaw)"""
    yaw = math.radians(place["yaw_deg"])
    r_inv = (math.cos(-yaw / 2), 0.0, 0.0, math.sin(-yaw / 2))
    d = tuple(x - o for x, o in zip(p, place["origin"]))
    return qrot(r_inv, d), qmul(r_inv, q)


# Rx(180): the device frames have z down, the tracker frames z up
FLIP = (0.0, 1.0, 0.0, 0.0)


def to_device(p, q):
    """tracker frame -> device frame (z down): p' = (x, -y, -z), q' = Rx(180)^-1 q"""
    return (p[0], -p[1], -p[2]), qmul(qconj(FLIP), q)


def i16(v):
    return max(-32768, min(32767, int(round(v))))


def hydra_report(seq, t, wands):
    """one 52-byte report; wands: [(p_base_mm, q_raw, buttons, joy_x, joy_y, trigger)] left, right"""
    b = bytearray(52)
    b[0:7] = bytes((0x01, 0x00, 0x34, 0x00, 0x02, 0x00, 0x01))
    b[7] = seq & 0xff
    for w, (p, q, buttons, jx, jy, trig) in enumerate(wands):
        off = 8 + 22 * w
        struct.pack_into("<3h", b, off, *(i16(c) for c in p))
        struct.pack_into("<4h", b, off + 6, *(i16(c * 32768.0) for c in q))
        b[off + 14] = buttons
        struct.pack_into("<2h", b, off + 15, i16(jx * 32768.0), i16(jy * 32768.0))
        b[off + 19] = max(0, min(255, int(round(trig * 255.0))))
    # bytes 28-29 of block A read 02 and a copy of the sequence number in captures of real devices
    b[28] = 0x02
    b[29] = seq & 0xff
    return bytes(b)


def hydra_inputs(w, t):
    """made-up but varying inputs: device button byte (bit 7 set, as on real wands), joystick, trigger"""
    step = int(t * 4)  # a new button combination every 0.25 s
    raw = 0x80 | ((step * (3 if w == 0 else 5)) & 0x7f)
    jx = 0.8 * math.sin(2 * math.pi * 0.5 * t + w)
    jy = 0.6 * math.cos(2 * math.pi * 0.7 * t + w)
    trig = 0.5 + 0.5 * math.sin(2 * math.pi * 0.9 * t + 2 * w)
    return raw, jx, jy, trig


def gen_hydra(rows, name):
    place = HYDRA
    n = int(place["seconds"] * HYDRA_RATE)
    lines = [
        "# Razer Hydra capture generated by tools/gen-captures.py from %s" % name,
        "# motion reports of interface 0 at 250 Hz: seconds since the first report, then 52 bytes",
        "# base at origin = %g %g %g, yaw = %g (the [source] keys); clip time %g s at the first report"
        % (place["origin"] + (place["yaw_deg"], place["start"])),
    ]
    flips = 0
    prev_mirror = [None, None]
    for k in range(n):
        t = place["start"] + k / HYDRA_RATE
        wands = []
        for w, role in enumerate(("lhand", "rhand")):
            p, q = pose_at(rows, role, t)
            pt, qt = to_tracker(place, p, q)
            pb, qb = to_device(pt, qt)
            # the base reports the mirror image on the far side of its z = 0 plane
            mirror = pb[2] > 0
            if prev_mirror[w] is not None and mirror != prev_mirror[w]:
                flips += 1
            prev_mirror[w] = mirror
            pmm = tuple((-c if mirror else c) * 1000.0 for c in pb)
            qraw = (qb[0], qb[1], -qb[2], -qb[3])
            raw, jx, jy, trig = hydra_inputs(w, t - place["start"])
            wands.append((pmm, qraw, raw, jx, jy, trig))
        rep = hydra_report((0x40 + k) & 0xff, t, wands)
        lines.append("%.6f %s" % (k / HYDRA_RATE, " ".join("%02x" % c for c in rep)))
    return lines, n, flips


def polhemus_record(station, frame, p_cm, q):
    payload = struct.pack("<3f4fI", *p_cm, *q, frame) + b" "
    return b"LY" + bytes((station, ord("C"), ord(" "), 0)) + struct.pack("<H", len(payload)) + payload


def gen_polhemus(rows, name):
    place = POLHEMUS
    n = int(place["seconds"] * POLHEMUS_RATE)
    lines = [
        "# Polhemus Liberty HS capture generated by tools/gen-captures.py from %s" % name,
        "# one bulk IN transfer per line (no timestamps: 240 Hz, one frame per transfer); output list O*,2,7,9,0",
        "# stations 1 head, 2 left hand, 3 right hand; source at origin = %g %g %g, yaw = %g; "
        "clip time %g s at the first frame" % (place["origin"] + (place["yaw_deg"], place["start"])),
    ]
    for k in range(n):
        t = place["start"] + k / POLHEMUS_RATE
        xfer = b""
        for station, role in enumerate(("head", "lhand", "rhand"), start=1):
            p, q = pose_at(rows, role, t)
            pt, qt = to_tracker(place, p, q)
            pp, qp = to_device(pt, qt)
            xfer += polhemus_record(station, 1000 + k, tuple(c * 100.0 for c in pp), qp)
        lines.append(xfer.hex())
    return lines, n


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clip", default=os.path.join(root, "config/clips/cmu_141_16.csv"))
    ap.add_argument("--out", default=os.path.join(root, "tests/data"))
    a = ap.parse_args()
    rows = load_clip(a.clip)
    name = os.path.splitext(os.path.basename(a.clip))[0]
    os.makedirs(a.out, exist_ok=True)
    hl, hn, flips = gen_hydra(rows, name)
    with open(os.path.join(a.out, "hydra-%s.cap" % name), "w") as f:
        f.write("\n".join(hl) + "\n")
    pl, pn = gen_polhemus(rows, name)
    with open(os.path.join(a.out, "polhemus-%s.cap" % name), "w") as f:
        f.write("\n".join(pl) + "\n")
    print("gen-captures: %d Hydra reports (%d hemisphere crossings), %d Polhemus frames" % (hn, flips, pn))


if __name__ == "__main__":
    main()
