#!/usr/bin/python3
"""Browser test of the status page: headless Chromium loads the page of a running server and the
DOM must show the overlay image loaded and one box-table row per detected box.

Server under test, one of:
  --fixture EXE                      palletd_web_fixture (a real detection, fake service)
  --daemon PALLETD --palletctl EXE --config CFG [--replay DIR]
                                     the real daemon in replay mode; palletctl trigger does the
                                     PLC handshake once so there is a result to show
--screenshot PNG also writes a screenshot of the page (the README's docs/images/status-page.png).
Exit 77 (ctest SKIP_RETURN_CODE) only when no chromium is installed.
"""
import argparse
import html.parser
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def http_json(url, timeout=5.0):
    with urllib.request.urlopen(url, timeout=timeout) as r:
        return r.status, json.loads(r.read().decode())


def wait_http(url, deadline_s=30.0):
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        try:
            return http_json(url)
        except Exception:
            time.sleep(0.1)
    raise SystemExit(f"FAIL: {url} did not answer within {deadline_s} s")


def scaled_config(path, work, scale):
    """A copy of the configuration at `path` in `work` with pipeline.detection_timeout_ms scaled
    (from the default 2000 ms) and a relative camera.replay.directory made absolute. Text edits,
    one level of nesting, as config/demo.yaml is written."""
    base = os.path.dirname(os.path.abspath(path))
    timeout = f"  detection_timeout_ms: {2000.0 * scale:.0f}"
    out, section, sub, placed = [], None, None, False
    with open(path, encoding="utf-8") as f:
        for line in f.read().splitlines():
            stripped = line.split("#", 1)[0].rstrip()
            if stripped and not line[0].isspace():
                if section == "pipeline" and not placed:
                    out.append(timeout)
                    placed = True
                section, sub = stripped.rstrip(":"), None
            elif stripped.startswith("  ") and not stripped.startswith("   ") and stripped.endswith(":"):
                sub = stripped.strip().rstrip(":")
            if section == "pipeline" and stripped.strip().startswith("detection_timeout_ms:"):
                continue
            if section == "camera" and sub == "replay" and stripped.strip().startswith("directory:"):
                value = stripped.split(":", 1)[1].strip()
                if value and not os.path.isabs(value):
                    line = line[: line.index("directory:")] + "directory: " + os.path.normpath(os.path.join(base, value))
            out.append(line)
    if not placed:
        out += (["pipeline:"] if section != "pipeline" else []) + [timeout]
    copy = os.path.join(work, "palletd.yaml")
    with open(copy, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")
    return copy


class Dom(html.parser.HTMLParser):
    """Collects body data attributes, the box table's body rows and the overlay <img>."""

    def __init__(self):
        super().__init__()
        self.body = {}
        self.img = None
        self.rows = []
        self.stack = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.body = a
        if tag == "img" and a.get("id") == "overlay":
            self.img = a
        if tag in ("table", "tbody"):
            self.stack.append((tag, a.get("id")))
        if tag == "tr" and ("table", "boxes") in self.stack and any(t == "tbody" for t, _ in self.stack):
            self.rows.append(a)

    def handle_endtag(self, tag):
        if tag in ("table", "tbody") and self.stack and self.stack[-1][0] == tag:
            self.stack.pop()


def chromium_cmd(chromium, profile, extra, url):
    return [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--disable-dev-shm-usage", "--hide-scrollbars", f"--user-data-dir={profile}",
            "--virtual-time-budget=5000", *extra, url]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fixture")
    ap.add_argument("--daemon")
    ap.add_argument("--palletctl")
    ap.add_argument("--config")
    ap.add_argument("--replay")
    ap.add_argument("--screenshot")
    # Time bounds (the daemon's detection timeout included) are multiplied by this: 1, or
    # PALLETD_TEST_TIME_SCALE (8) from tests/web/CMakeLists.txt in sanitizer builds.
    ap.add_argument("--time-scale", type=float, default=1.0)
    args = ap.parse_args()
    scale = args.time_scale

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        print("SKIP: chromium is not installed (Debian package 'chromium'; scripts/install-deps.sh)")
        return 77

    work = tempfile.mkdtemp(prefix="palletd-browser-")
    server = None
    try:
        if args.fixture:
            server = subprocess.Popen([args.fixture], stdout=subprocess.PIPE, text=True)
            line = server.stdout.readline().split()
            if len(line) != 2 or line[0] != "port":
                raise SystemExit(f"FAIL: the fixture did not report its port: {line}")
            port = int(line[1])
        else:
            if not (args.daemon and args.palletctl and args.config):
                raise SystemExit("FAIL: --fixture, or --daemon with --palletctl and --config")
            port, modbus_port = free_port(), free_port()
            config = args.config if scale == 1.0 else scaled_config(args.config, work, scale)
            cmd = [args.daemon, "--config", config, "--bind", "127.0.0.1", "--port", str(modbus_port),
                   "--web-port", str(port)]
            if args.replay:
                cmd += ["--replay", args.replay]
            server = subprocess.Popen(cmd)
            wait_http(f"http://127.0.0.1:{port}/api/status", 30.0 * scale)
            subprocess.run([args.palletctl, "trigger", "--host", "127.0.0.1", "--port", str(modbus_port),
                            "--timeout-ms", str(int(10000 * scale))],
                           check=True, timeout=60 * scale)
        base = f"http://127.0.0.1:{port}"
        wait_http(base + "/api/status", 30.0 * scale)
        status, result = http_json(base + "/api/result", 5.0 * scale)
        want = len(result["boxes"])
        print(f"server on {base}: result of trigger {result['trigger']['seq']} with {want} boxes")
        if want == 0:
            raise SystemExit("FAIL: the detection under test found no boxes")

        profile = os.path.join(work, "profile")
        dom_run = subprocess.run(chromium_cmd(chromium, profile, ["--dump-dom"], base + "/"),
                                 capture_output=True, text=True, timeout=120 * scale)
        if dom_run.returncode != 0:
            print(dom_run.stderr[-3000:])
            raise SystemExit(f"FAIL: chromium exited with {dom_run.returncode}")
        dom = Dom()
        dom.feed(dom_run.stdout)
        body = dom.body
        print("body data:", {k: v for k, v in body.items() if k.startswith("data-")})
        failures = []
        if body.get("data-connection") != "live":
            failures.append("the page did not reach /api/status")
        if body.get("data-table") != "rendered":
            failures.append("the box table was not rendered")
        if body.get("data-boxes") != str(want):
            failures.append(f"data-boxes is {body.get('data-boxes')}, want {want}")
        picks = [r.get("data-pick") for r in dom.rows if r.get("data-pick")]
        if sorted(int(p) for p in picks) != list(range(1, want + 1)):
            failures.append(f"box table rows carry picks {picks}, want 1..{want}")
        if body.get("data-overlay") != "loaded":
            failures.append(f"overlay image not loaded (data-overlay={body.get('data-overlay')})")
        size = body.get("data-overlay-size", "0x0").split("x")
        if len(size) != 2 or int(size[0]) < 100 or int(size[1]) < 100:
            failures.append(f"overlay image has size {body.get('data-overlay-size')}")
        if body.get("data-overlay-seq") != str(result["trigger"]["seq"]):
            failures.append("the overlay shown is not the one of the last result")
        if dom.img is None or "hidden" in dom.img:
            failures.append("the overlay <img> is missing or hidden")
        if failures:
            print(dom_run.stdout[:4000])
            for f in failures:
                print("FAIL:", f)
            return 1
        print(f"ok: overlay {body.get('data-overlay-size')} loaded, {want} box rows")

        if args.screenshot:
            out = os.path.abspath(args.screenshot)
            os.makedirs(os.path.dirname(out), exist_ok=True)
            shot = subprocess.run(chromium_cmd(chromium, profile + "-shot",
                                               [f"--screenshot={out}", "--window-size=1280,1500"], base + "/"),
                                  capture_output=True, text=True, timeout=120 * scale)
            if shot.returncode != 0 or not os.path.exists(out) or os.path.getsize(out) < 10000:
                print(shot.stderr[-3000:])
                print("FAIL: no screenshot written")
                return 1
            print(f"screenshot: {out} ({os.path.getsize(out)} bytes)")
        return 0
    finally:
        if server is not None:
            server.send_signal(signal.SIGTERM)
            try:
                server.wait(timeout=10 * scale)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
