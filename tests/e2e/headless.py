# SPDX-License-Identifier: MIT
"""Headless Chromium driven over the DevTools protocol, with the standard
library only: --remote-debugging-pipe gives the protocol on file descriptors
3 (to the browser) and 4 (from it), one JSON message per NUL-terminated
record, so no WebSocket client is needed.

WebGL comes from SwiftShader (--use-angle=swiftshader
--enable-unsafe-swiftshader), so it works without a GPU; webgl=False starts
the browser with WebGL disabled. The console's errors and warnings, uncaught
exceptions and failed loads are kept in .console.

Also a command that reads the viewer's state as a test does (docs/VIEWER.md):

    python3 tests/e2e/headless.py http://127.0.0.1:7780/ [--wait 'window.avatargwStats.frames > 30']
        [--eval EXPRESSION] [--screenshot FILE.png] [--no-webgl]

prints the JSON of the expression (by default #stats) once the wait
expression is true (by default: frames received and pictures drawn)."""
import argparse
import base64
import json
import os
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time


def chromium_path():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


class Chromium:
    def __init__(self, profile_dir, width=1280, height=800, webgl=True, args=()):
        """webgl: True (SwiftShader), False (disabled) or None (as args say)"""
        exe = chromium_path()
        if not exe:
            raise RuntimeError("chromium is not installed (Debian: apt install chromium)")
        to_r, self.to_w = os.pipe()
        self.from_r, from_w = os.pipe()

        def child_fds():
            # the browser reads commands on fd 3 and writes answers on fd 4 (via high numbers:
            # the pipe's own descriptors may be 3 or 4)
            a, b = os.dup(to_r), os.dup(from_w)
            a2, b2 = os.dup2(a, 100), os.dup2(b, 101)
            os.dup2(a2, 3)
            os.dup2(b2, 4)

        if webgl is None:
            gl = []  # whatever the flags in args say
        elif webgl:
            gl = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
        else:
            gl = ["--disable-webgl", "--disable-3d-apis"]
        args = [exe, "--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--no-first-run",
                "--no-default-browser-check", "--disable-extensions", "--remote-debugging-pipe",
                "--user-data-dir=" + profile_dir, "--window-size=%d,%d" % (width, height)] + gl + list(args) + ["about:blank"]
        self.console = []  # (kind, text): console errors and warnings, exceptions, failed loads
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, preexec_fn=child_fds, pass_fds=(3, 4))
        os.close(to_r)
        os.close(from_w)
        self.buf = b""
        self.next_id = 0
        self.session = None
        targets = self.call("Target.getTargets")["targetInfos"]
        page = [t for t in targets if t["type"] == "page"][0]
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
        self.call("Page.enable")
        self.call("Runtime.enable")
        self.call("Log.enable")

    def _read_message(self, deadline):
        while b"\0" not in self.buf:
            left = deadline - time.time()
            if left <= 0 or not select.select([self.from_r], [], [], left)[0]:
                raise TimeoutError("no answer from chromium")
            chunk = os.read(self.from_r, 65536)
            if not chunk:
                raise RuntimeError("chromium closed the debugging pipe")
            self.buf += chunk
        raw, self.buf = self.buf.split(b"\0", 1)
        return json.loads(raw)

    def call(self, method, timeout=10, **params):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params}
        if self.session and not method.startswith(("Target.", "Browser.")):
            msg["sessionId"] = self.session
        os.write(self.to_w, json.dumps(msg).encode() + b"\0")
        deadline = time.time() + timeout
        while True:
            m = self._read_message(deadline)
            self._event(m)
            if m.get("id") == self.next_id:
                if "error" in m:
                    raise RuntimeError("%s: %s" % (method, m["error"]))
                return m.get("result", {})

    def _event(self, m):
        method, p = m.get("method"), m.get("params", {})
        if method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "warning", "assert"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
            self.console.append(("console." + p["type"], text))
        elif method == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            self.console.append(("exception", d.get("exception", {}).get("description") or d.get("text", "")))
        elif method == "Log.entryAdded" and p.get("entry", {}).get("level") in ("error", "warning"):
            e = p["entry"]
            self.console.append(("log." + e["level"], "%s %s" % (e.get("text", ""), e.get("url", ""))))

    def pump(self, seconds=0.05):
        """reads the events that came meanwhile (call() reads them too)"""
        self.call("Runtime.evaluate", expression="0", timeout=max(5, seconds))

    def errors(self):
        """what the console, the page's exceptions and failed loads said, warnings left out"""
        self.pump()
        return [c for c in self.console if c[0] in ("console.error", "console.assert", "exception", "log.error")]

    def evaluate(self, expression, timeout=20):
        r = self.call("Runtime.evaluate", timeout=timeout, expression=expression, returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError("page error: %s" % r["exceptionDetails"])
        return r["result"].get("value")

    def screenshot(self, path):
        data = self.call("Page.captureScreenshot", format="png")["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self):
        try:
            self.call("Browser.close", timeout=5)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self.to_w)
        os.close(self.from_r)


def png_rgb(path):
    """(width, height, [row of (r, g, b)]) of an 8-bit RGB or RGBA PNG, decoded with zlib"""
    import zlib
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, w = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or ctype not in (2, 6) or interlace:
                raise ValueError("unsupported PNG: depth %d, colour type %d" % (depth, ctype))
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        ftype, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, rows


def main():
    ap = argparse.ArgumentParser(description="read the avatargw viewer's state in headless Chromium")
    ap.add_argument("url")
    ap.add_argument("--wait", default="window.avatargwStats && avatargwStats.frames > 10 && avatargwStats.renders > 10",
                    help="a JavaScript expression to wait for (default: frames received and drawn)")
    ap.add_argument("--eval", default="document.getElementById('stats').textContent",
                    help="what to print (default: #stats, the JSON of window.avatargwStats)")
    ap.add_argument("--timeout", type=float, default=20)
    ap.add_argument("--screenshot")
    ap.add_argument("--no-webgl", action="store_true")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as profile:
        b = Chromium(profile, webgl=not a.no_webgl)
        try:
            b.call("Page.navigate", url=a.url)
            deadline = time.time() + a.timeout
            # (the expression may read what the page has not made yet: an error counts as not yet)
            while not b.evaluate("(() => { try { return !!(%s); } catch (e) { return false; } })()" % a.wait):
                if time.time() > deadline:
                    print("headless: not true within %g s: %s" % (a.timeout, a.wait), file=sys.stderr)
                    return 1
                time.sleep(0.2)
            if a.screenshot:
                b.screenshot(a.screenshot)
            v = b.evaluate(a.eval)
            print(v if isinstance(v, str) else json.dumps(v))
            for kind, text in b.errors():
                print("headless: %s: %s" % (kind, text), file=sys.stderr)
        finally:
            b.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
