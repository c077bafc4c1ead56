#!/bin/sh
# SPDX-License-Identifier: MIT
# fuzz-seeds.sh BUILD OUT - writes the fuzz harnesses' seeds made from the
# tree's own data into OUT/NAME/ (docs/FUZZING.md): the configurations of
# config/ and the [ini] examples of docs/, the captures and candump logs of
# tests/data, and the CMU clip. The same tree gives the same files (no
# clock, no randomness). The hand-made seeds and the inputs that once broke
# a harness are committed in tests/fuzz/corpus/NAME/ instead.
set -eu
[ $# -eq 2 ] || { echo "usage: $0 BUILD OUT" >&2; exit 2; }
out=$2
cd "$(dirname "$0")/.."
rm -rf "$out"
mkdir -p "$out"
PYTHON=${PYTHON:-$(command -v /usr/bin/python3 || command -v python3)}
"$PYTHON" - "$out" <<'PY'
import glob, os, re, struct, sys

out = sys.argv[1]


def put(name, fname, data):
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, fname), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def read(path):
    with open(path, "rb") as f:
        return f.read()


# configurations: whole files, the [ini] blocks of the docs, and a file with drop-ins
confs = {os.path.basename(p): read(p) for p in sorted(glob.glob("config/*.conf"))}
for n, t in confs.items():
    put("config", n, t)
blocks = []
for p in sorted(glob.glob("docs/*.md")):
    text = read(p).decode()
    for i, m in enumerate(re.finditer(r"```ini\n(.*?)```", text, re.S)):
        blocks.append(m.group(1))
        put("config", "%s-%d.conf" % (os.path.basename(p)[:-3], i), m.group(1))
put("config", "dropins.conf", confs["demo.conf"].decode() + "\n%%\n" + "\n%%\n".join(blocks[:3]))


# captures: the text (chunks of 40 reports, with and without timestamps), and the codecs' form
def reports(path):
    rows = []
    for line in read(path).decode().splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        tok = s.split()
        t = tok[0] if "." in tok[0] else None
        hexs = "".join(tok[1:] if t else tok)
        rows.append((t, bytes.fromhex(hexs)))
    return rows


for path, name, variants in (("tests/data/hydra-cmu_141_16.cap", "hydra", (0,)),
                             ("tests/data/polhemus-cmu_141_16.cap", "polhemus", (0, 2, 7))):
    rows = reports(path)
    base = os.path.basename(path)[:-4]
    for k, start in enumerate(range(0, min(len(rows), 400), 40)):
        chunk = rows[start:start + 40]
        timed = "".join("%s %s\n" % (t, r.hex()) if t else "%s\n" % r.hex(" ") for t, r in chunk)
        put("capture", "%s-%d.cap" % (base, k), timed)
        put("capture", "%s-%d-untimed.cap" % (base, k), "".join("%s\n" % r.hex() for t, r in chunk))
        for v in variants:
            body = b"".join(struct.pack("<H", len(r)) + r for t, r in chunk)
            put(name, "%s-%d-v%d" % (base, k, v), bytes([v]) + body)
    # a reset (a reopened device) in the middle, and transfers cut at other places
    stream = b"".join(r for t, r in rows[:40])
    cut = b"".join(struct.pack("<H", len(stream[i:i + 29])) + stream[i:i + 29] for i in range(0, len(stream), 29))
    put(name, "%s-recut" % base, bytes([variants[-1]]) + cut[:600] + b"\xff\xff" + cut[600:])

# the CMU clip: a sensor CSV for the replay source, in each way of playing it
clip = read("config/clips/cmu_141_16.csv").decode().splitlines(True)
for mode in (0, 1, 2, 3, 4, 5, 8, 12, 16, 7):
    put("replay", "clip-%02x" % mode, bytes([mode]) + "".join(clip[:60]).encode())
put("replay", "clip-bad-rows", b"\x04" + "".join(clip[:5] + ["0.5,1,2\n", "x\n"] + clip[5:20]).encode())

# candump -L logs, with the sensor map of their test (byte 0 = 0) and others
for p in sorted(glob.glob("tests/data/can_*.log")):
    text = read(p)
    base = os.path.basename(p)[:-4]
    for v in (0x00, 0x05, 0x20, 0x10):
        put("can", "%s-%02x" % (base, v), bytes([v]) + text)
PY
echo "fuzz-seeds: $(find "$out" -type f | wc -l) seeds in $out"
