#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""nearpointd's Prometheus endpoint (issue 23, item 2) across the process boundary: a real
nearpointd with --metrics-listen 127.0.0.1:0 serves a streamed trajectory and queries from the
Python client, then /metrics is scraped over HTTP and its counters must match what was sent.
Bad --metrics-listen values must stop the server at start naming the flag.

    test_metrics.py --nearpointd build/server/nearpointd --pythonpath build/client/python
"""
import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

FAILURES = []


def check(condition, what):
    print(("ok   " if condition else "FAIL ") + what, flush=True)
    if not condition:
        FAILURES.append(what)


def wait_for_file(path, process, seconds=20.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if process.poll() is not None:
            return None
        if os.path.exists(path):
            text = open(path).read().strip()
            if text:
                return int(text)
        time.sleep(0.05)
    return None


def scrape(port):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10) as response:
        check(response.status == 200, "GET /metrics answers 200")
        body = response.read().decode()
    samples = {}
    for line in body.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        name, value = line.rsplit(" ", 1)
        samples[name] = float(value)
    return samples


def value(samples, name):
    return samples.get(name, -1.0)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--pythonpath", required=True)
    args = parser.parse_args()
    sys.path.insert(0, args.pythonpath)
    from nearpoint import client as npc

    # Bad configuration stops the server at start (exit 2) with a message naming the flag.
    for bad, why, expect in (("nonsense", "not HOST:PORT", "not HOST:PORT"),
                             ("127.0.0.1:99999", "port out of range", "not HOST:PORT"),
                             ("0.0.0.0:0", "non-loopback without --insecure", "--insecure")):
        run = subprocess.run([args.nearpointd, "--listen", "127.0.0.1:0", "--metrics-listen", bad],
                             capture_output=True, text=True, timeout=30)
        check(run.returncode == 2 and "--metrics-listen" in run.stderr and expect in run.stderr,
              f"--metrics-listen {bad} ({why}): exit 2 naming the flag (got {run.returncode}: "
              f"{run.stderr.strip()[-200:]})")

    with tempfile.TemporaryDirectory() as directory:
        port_file = os.path.join(directory, "port")
        metrics_port_file = os.path.join(directory, "metrics-port")
        server = subprocess.Popen(
            [args.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file,
             "--metrics-listen", "127.0.0.1:0", "--metrics-port-file", metrics_port_file,
             "--workers", "2"], stderr=subprocess.PIPE, text=True)
        try:
            port = wait_for_file(port_file, server)
            metrics_port = wait_for_file(metrics_port_file, server)
            check(port is not None and metrics_port is not None, "nearpointd started, both ports")
            if port is None or metrics_port is None:
                return
            before = scrape(metrics_port)
            check(value(before, 'nearpoint_updates_total{status="ok"}') == 0, "no updates yet")

            updates = 12
            with npc.connect(f"127.0.0.1:{port}") as client:
                cube = client.register_geometry([npc.box((0.5, 0.5, 0.5))], name="cube")
                slab = client.register_geometry([npc.box((1.0, 0.25, 0.1))], name="slab")
                scene = client.create_scene({"cube": cube, "slab": (slab, (4.0, 0.5, 0.3))})
                path = [(4.0 - 0.25 * k, 0.5, 0.3) for k in range(updates)]
                reports = list(client.stream(scene, ({"slab": c} for c in path)))
                check(len(reports) == updates, f"{updates} reports streamed")
                client.query(scene, {"slab": (3.0, 0.5, 0.3)})
                try:
                    client.query("no-such-scene")
                    check(False, "a query of an unknown scene fails")
                except npc.NearpointError:
                    pass

            # The stream's end reaches the server asynchronously: wait (bounded) for the gauge.
            deadline = time.monotonic() + 10
            while True:
                after = scrape(metrics_port)
                if value(after, "nearpoint_streams_active") == 0 or time.monotonic() > deadline:
                    break
                time.sleep(0.1)
            v = lambda name: value(after, name)  # noqa: E731
            ok_updates = v('nearpoint_updates_total{status="ok"}')
            check(ok_updates == updates, f"updates_total ok == {updates} (got {ok_updates})")
            check(v('nearpoint_reports_total{kind="stream"}') == updates, "stream reports counted")
            check(v('nearpoint_reports_total{kind="query"}') == 1, "one query report")
            check(v('nearpoint_queries_total{status="ok"}') == 1, "queries ok == 1")
            check(v('nearpoint_queries_total{status="not_found"}') == 1, "queries not_found == 1")
            check(any(k.startswith("nearpoint_grpc_errors_total{") and 'code="NOT_FOUND"' in k
                      and val == 1 for k, val in after.items()), "one NOT_FOUND gRPC error")
            check(v('nearpoint_report_latency_seconds_count{kind="stream"}') == updates,
                  "latency histogram: one observation per stream report")
            check(v('nearpoint_report_latency_seconds_sum{kind="stream"}') > 0, "latency > 0")
            evaluated = v('nearpoint_pairs_total{outcome="evaluated"}')
            pairs = evaluated + v('nearpoint_pairs_total{outcome="pruned"}') + \
                v('nearpoint_pairs_total{outcome="unmoved"}')
            check(pairs == updates + 1, f"pairs evaluated+pruned+unmoved == {updates + 1} "
                  f"(one pair per report; got {pairs})")
            check(evaluated > 0, "pairs evaluated > 0")
            check(v("nearpoint_gjk_iterations_count") == evaluated,
                  "iterations histogram: one observation per evaluated pair")
            check(v('nearpoint_gjk_iterations_bucket{le="+Inf"}') == evaluated, "+Inf bucket")
            check(v("nearpoint_warm_start_hits_total") > 0, "warm-start hits > 0")
            check(v("nearpoint_geometry_seconds_total") > 0, "geometry time > 0")
            check(v("nearpoint_scenes") == 1, "scenes gauge == 1")
            check(v("nearpoint_geometries") == 2, "geometries gauge == 2")
            check(v("nearpoint_streams_active") == 0, "streams gauge back to 0")
            check(v("nearpoint_coalesced_updates_total") == 0, "no coalescing under BLOCK")
            check(not any(re.search(r'(scene|object|geometry)_id=|geom-', k) for k in after),
                  "no scene/object/geometry ids in labels")
        finally:
            server.send_signal(signal.SIGTERM)
            try:
                code = server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                code = server.wait()
            check(code == 0, f"SIGTERM: exit 0 (got {code})")
            log = server.stderr.read()
            check(re.search(r"event=metrics_listening .*port=\d+", log) is not None,
                  "the log line names the bound metrics port")


if __name__ == "__main__":
    main()
    print(f"{len(FAILURES)} failure(s)")
    sys.exit(1 if FAILURES else 0)
