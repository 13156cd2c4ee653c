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
    args = ap.parse_args()

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
            cmd = [args.daemon, "--config", args.config, "--bind", "127.0.0.1", "--port", str(modbus_port),
                   "--web-port", str(port)]
            if args.replay:
                cmd += ["--replay", args.replay]
            server = subprocess.Popen(cmd)
            wait_http(f"http://127.0.0.1:{port}/api/status")
            subprocess.run([args.palletctl, "trigger", "--host", "127.0.0.1", "--port", str(modbus_port)],
                           check=True, timeout=60)
        base = f"http://127.0.0.1:{port}"
        wait_http(base + "/api/status")
        status, result = http_json(base + "/api/result")
        want = len(result["boxes"])
        print(f"server on {base}: result of trigger {result['trigger']['seq']} with {want} boxes")
        if want == 0:
            raise SystemExit("FAIL: the detection under test found no boxes")

        profile = os.path.join(work, "profile")
        dom_run = subprocess.run(chromium_cmd(chromium, profile, ["--dump-dom"], base + "/"),
                                 capture_output=True, text=True, timeout=120)
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
                                  capture_output=True, text=True, timeout=120)
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
                server.wait(timeout=10)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
