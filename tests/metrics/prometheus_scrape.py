#!/usr/bin/python3
"""A real Prometheus scrapes a running palletd; the counters move after Modbus triggers.

usage: prometheus_scrape.py --palletd EXE --prometheus EXE --frames DIR --monitoring DIR --work DIR

Starts palletd (config/demo.yaml, replay of DIR, Modbus, status page and metrics server on free
loopback ports) and Prometheus (Debian's package, loopback, scraping every second), triggers
twice over Modbus TCP (pymodbus), then asks Prometheus's HTTP API for palletd_triggers_total,
palletd_results_total and the detection histogram. Also checks that /metrics refuses a foreign
Host header and that every palletd_* metric the files in docs/monitoring use is one palletd
exports. Exit status 0 = pass. Both processes are ended by PID.
"""
import argparse
import json
import os
import pathlib
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.parse
import urllib.request

from pymodbus.client import ModbusTcpClient

READY, BUSY, TRIGGER_ACK, RESULT_READY = 1, 2, 4, 8
HISTOGRAM_SUFFIXES = ("_bucket", "_sum", "_count")


def fail(message):
    raise SystemExit("FAIL: " + message)


def free_ports(count):
    """Distinct loopback ports free now (each socket stays bound until all are picked)."""
    sockets = [socket.socket(socket.AF_INET, socket.SOCK_STREAM) for _ in range(count)]
    try:
        for s in sockets:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()


def http_get(url, host=None, timeout=5):
    request = urllib.request.Request(url)
    if host:
        request.add_header("Host", host)
    with urllib.request.urlopen(request, timeout=timeout) as response:
        return response.status, response.read().decode()


def wait_for(what, probe, timeout_s):
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        try:
            value = probe()
            if value:
                return value
        except (OSError, urllib.error.URLError, ValueError, KeyError, IndexError) as e:
            last = e
        time.sleep(0.2)
    fail(f"timed out waiting for {what} (last error: {last})")


def trigger(client, request_id):
    """One handshake: Trigger with recipe 1, wait for ResultReady, acknowledge."""
    def status():
        rsp = client.read_holding_registers(100, 1, slave=1)
        if rsp.isError():
            fail(f"read status: {rsp}")
        return rsp.registers[0]

    def wait(mask, want, what):
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            if status() & mask == want:
                return
            time.sleep(0.01)
        fail(f"timed out waiting for {what} (status word {status():#06x})")

    wait(READY | BUSY, READY, "Ready")
    client.write_registers(0, [1, 1, request_id], slave=1)
    wait(RESULT_READY, RESULT_READY, "ResultReady")
    client.write_registers(0, [2], slave=1)  # ResultAck, Trigger low
    wait(RESULT_READY, 0, "ResultReady dropped")


def query(prometheus_port, expression):
    url = f"http://127.0.0.1:{prometheus_port}/api/v1/query?" + urllib.parse.urlencode({"query": expression})
    _, body = http_get(url)
    data = json.loads(body)
    if data.get("status") != "success":
        raise ValueError(body)
    result = data["data"]["result"]
    return float(result[0]["value"][1]) if result else None


def start_prometheus(exe, config, work, processes, attempts=3):
    """Starts Prometheus on a port picked just before; another one when that port was taken in
    between (by another test's server: its /-/ready is no Prometheus's). Returns the port."""
    for attempt in range(attempts):
        port = free_ports(1)[0]
        log = open(work / f"prometheus.{attempt}.log", "w")
        process = subprocess.Popen(
            [exe, f"--config.file={config}", f"--storage.tsdb.path={work / 'tsdb'}",
             f"--web.listen-address=127.0.0.1:{port}", "--log.level=warn"],
            stdout=log, stderr=subprocess.STDOUT)
        processes.append(process)

        def ready():
            if process.poll() is not None:
                raise ProcessLookupError(f"Prometheus exited with {process.returncode}")
            return http_get(f"http://127.0.0.1:{port}/-/ready")[0] == 200

        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if ready():
                    return port
            except urllib.error.HTTPError:
                break  # another server answers on this port
            except ProcessLookupError:
                break  # the port was taken when Prometheus bound it
            except (OSError, urllib.error.URLError):
                pass
            time.sleep(0.2)
        process.terminate()
        process.wait(timeout=20)
        processes.remove(process)
    fail(f"Prometheus did not come up on a free port in {attempts} attempts (logs in {work})")


def exported_families(metrics_text):
    return {m.group(1) for m in re.finditer(r"^# TYPE (\w+) (\w+)$", metrics_text, re.M)}


def check_monitoring_names(monitoring_dir, families):
    """Every palletd_* name in the alert rules and the dashboard is a metric palletd exports."""
    used = set()
    for path in pathlib.Path(monitoring_dir).rglob("*"):
        if path.suffix in (".yml", ".yaml", ".json") and path.is_file():
            if path.suffix == ".json":
                json.loads(path.read_text())  # the dashboard and the target files must parse
            used |= {(path.name, name) for name in re.findall(r"\bpalletd_[a-z0-9_]+", path.read_text())}
    if not used:
        fail(f"no palletd_* metric named in {monitoring_dir}")
    for file_name, name in sorted(used):
        base = name
        for suffix in HISTOGRAM_SUFFIXES:
            if name.endswith(suffix) and name[: -len(suffix)] in families:
                base = name[: -len(suffix)]
        if base not in families and name != "palletd_cells":  # job name in the scrape config
            fail(f"{file_name} uses {name}, which palletd does not export")


def main():
    ap = argparse.ArgumentParser()
    for arg in ("--palletd", "--prometheus", "--frames", "--monitoring", "--work"):
        ap.add_argument(arg, required=True)
    args = ap.parse_args()
    work = pathlib.Path(args.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    source_dir = pathlib.Path(__file__).resolve().parents[2]
    modbus_port, web_port, metrics_port = free_ports(3)

    processes = []
    try:
        palletd_log = open(work / "palletd.log", "w")
        processes.append(subprocess.Popen(
            [args.palletd, "--config", str(source_dir / "config" / "demo.yaml"), "--replay", args.frames,
             "--port", str(modbus_port), "--web-port", str(web_port), "--metrics-port", str(metrics_port)],
            stdout=palletd_log, stderr=subprocess.STDOUT))
        metrics_url = f"http://127.0.0.1:{metrics_port}/metrics"
        wait_for("palletd's /metrics", lambda: http_get(metrics_url)[0] == 200, 30)

        # The metrics server keeps the status page's host rules, and serves nothing else.
        try:
            http_get(metrics_url, host="attacker.example")
            fail("/metrics answered a request for a foreign host name")
        except urllib.error.HTTPError as e:
            if e.code != 403:
                fail(f"foreign host: HTTP {e.code}, expected 403")
        try:
            http_get(f"http://127.0.0.1:{metrics_port}/api/status")
            fail("the metrics server served the status API")
        except urllib.error.HTTPError as e:
            if e.code != 404:
                fail(f"/api/status on the metrics server: HTTP {e.code}, expected 404")
        # The status page serves the same text.
        status, page_text = http_get(f"http://127.0.0.1:{web_port}/metrics")
        if status != 200 or "palletd_triggers_total" not in page_text:
            fail("the status page's /metrics lacks palletd_triggers_total")

        config = work / "prometheus.yml"
        config.write_text(
            "global:\n  scrape_interval: 1s\n  evaluation_interval: 1s\n"
            "scrape_configs:\n  - job_name: palletd\n    static_configs:\n"
            f"      - targets: ['127.0.0.1:{metrics_port}']\n        labels: {{cell: test}}\n")
        prometheus_port = start_prometheus(args.prometheus, config, work, processes)
        wait_for("a first scrape of palletd_triggers_total",
                 lambda: query(prometheus_port, "palletd_triggers_total") is not None, 60)
        before = query(prometheus_port, "palletd_triggers_total")
        if query(prometheus_port, 'up{job="palletd"}') != 1.0:
            fail("Prometheus does not see palletd up")

        client = ModbusTcpClient("127.0.0.1", port=modbus_port, timeout=5)
        if not client.connect():
            fail("cannot connect to palletd's Modbus port")
        for request_id in (11, 12):
            trigger(client, request_id)
        client.close()

        wait_for("palletd_triggers_total to rise by 2 in Prometheus",
                 lambda: (query(prometheus_port, "palletd_triggers_total") or 0) >= before + 2, 60)
        results = query(prometheus_port, 'sum(palletd_results_total{cell="test"})')
        if results is None or results < 2:
            fail(f"sum(palletd_results_total) = {results}, expected >= 2")
        detections = query(prometheus_port, "palletd_detection_seconds_count")
        if detections is None or detections < 2:
            fail(f"palletd_detection_seconds_count = {detections}, expected >= 2")
        camera = query(prometheus_port, "palletd_camera_ok")
        if camera != 1.0:
            fail(f"palletd_camera_ok = {camera}, expected 1 (replay)")

        check_monitoring_names(args.monitoring, exported_families(http_get(metrics_url)[1]))
        print(f"ok: triggers {before:.0f} -> {query(prometheus_port, 'palletd_triggers_total'):.0f}, "
              f"results {results:.0f}, detections {detections:.0f}")
    finally:
        for p in reversed(processes):
            p.terminate()
        for p in reversed(processes):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


if __name__ == "__main__":
    sys.exit(main())
