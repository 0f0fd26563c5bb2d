#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The edges both binaries share, through real nearpoint and nearpointd processes (standard
library only; nearpointd listens on 127.0.0.1 only):

    check_edges.py CASE --nearpoint BIN --nearpointd BIN --version X.Y.Z --examples DIR
                   [--dds] [--metrics]

CASE is one of
  version     `nearpoint --version` and `nearpointd --version` print the CMake project version;
              nearpointd's startup log names it; `nearpoint info` (text and --json) against a
              running nearpointd reports that version, the transports this process serves (gRPC
              port, TLS, DDS, metrics port) and the limits it was started with.
  exit-codes  one exit status per failure class, the same in both binaries (model/exit_codes.hpp):
              2 for a bad flag, and for a missing and a malformed scene file alike (nearpoint
              scene create, nearpointd --scene); 1 for an error the server answers; 3 for no
              server and for an address in use; the table in both --help texts.
  dds-refused `nearpointd --dds` without a DDS configuration (CYCLONEDDS_URI unset) exits 2 before
              any readiness signal: no port file, no `listening` line, DDS never started; and
              `nearpoint stream --dds` without one exits 2 as well.
  cli-text    `nearpoint scene --help` does not repeat the top-level examples; progress lines
              (with '\\r') are not written when stderr is not a terminal; "1 pair", not "1 pairs";
              both binaries call the DDS flags --dds-domain and --dds-prefix.
  load        `nearpoint load` (one stream per update and batched): every update the server
              counted (its metrics, with --metrics) is one report in the load's figures, with
              no error; an unknown scene is one error per refused update, exit 1; a server
              killed with SIGKILL under load ends the load within seconds, exit 1, naming the
              lost stream. With --dds, `nearpoint dds load` the same way, on loopback DDS.
Exits non-zero with a message on the first failure.
"""
import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

from cli_checks import check, fail

ARGS = None


def run(args, env=None, timeout=60):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout, env=env,
                          errors="replace")


def env_without_dds_config():
    return {k: v for k, v in os.environ.items()
            if k != "CYCLONEDDS_URI" and not k.startswith("NEARPOINT_")}


def env_with_loopback_dds():
    """The project's loopback Cyclone DDS configuration: never the external interface."""
    env = env_without_dds_config()
    root = os.path.dirname(os.path.abspath(ARGS.examples))
    env["CYCLONEDDS_URI"] = "file://" + os.path.join(root, "deploy", "cyclonedds-loopback.xml")
    return env


class Daemon:
    """A nearpointd child on 127.0.0.1:0, ready once its port file exists."""

    def __init__(self, scratch, extra=(), metrics=False, dds=False):
        self.port_file = os.path.join(scratch, "port")
        self.metrics_port_file = os.path.join(scratch, "metrics-port")
        for f in (self.port_file, self.metrics_port_file):
            if os.path.exists(f):
                os.remove(f)
        self.log_path = os.path.join(scratch, "nearpointd.log")
        self.log = open(self.log_path, "w")
        command = [ARGS.nearpointd, "--listen", "127.0.0.1:0", "--port-file", self.port_file,
                   *extra]
        if metrics:
            command += ["--metrics-listen", "127.0.0.1:0", "--metrics-port-file",
                        self.metrics_port_file]
        self.process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=self.log,
                                        env=env_with_loopback_dds() if dds
                                        else env_without_dds_config())
        deadline = time.monotonic() + 30
        while not os.path.exists(self.port_file):
            check(self.process.poll() is None,
                  "nearpointd exited %s at start: %s" % (self.process.returncode, self.stderr()))
            check(time.monotonic() < deadline, "nearpointd wrote no port file in 30 s")
            time.sleep(0.05)
        self.port = int(open(self.port_file).read())
        self.target = "127.0.0.1:%d" % self.port
        self.metrics_port = None
        while metrics and self.metrics_port is None:
            if os.path.exists(self.metrics_port_file):
                self.metrics_port = int(open(self.metrics_port_file).read())
            check(time.monotonic() < deadline, "nearpointd wrote no metrics port file in 30 s")
            time.sleep(0.05)

    def stderr(self):
        self.log.flush()
        return open(self.log_path).read()

    def stop(self):
        self.process.send_signal(signal.SIGTERM)
        code = self.process.wait(timeout=30)
        self.log.close()
        check(code == 0, "nearpointd exited %d on SIGTERM" % code)


def case_version(scratch):
    for binary, name in ((ARGS.nearpoint, "nearpoint"), (ARGS.nearpointd, "nearpointd")):
        result = run([binary, "--version"])
        check(result.returncode == 0, "%s --version: exit %d" % (name, result.returncode))
        check(result.stdout.strip() == "%s %s" % (name, ARGS.version),
              "%s --version printed %r, expected the CMake version %s"
              % (name, result.stdout.strip(), ARGS.version))
    daemon = Daemon(scratch, ["--max-scenes", "7", "--max-streams", "5", "--workers", "1"],
                    metrics=ARGS.metrics)
    try:
        log = daemon.stderr()
        listening = [line for line in log.splitlines() if "event=listening" in line]
        check(len(listening) == 1 and ("version=" + ARGS.version) in listening[0],
              "the listening line does not name version %s: %s" % (ARGS.version, log))
        text = run([ARGS.nearpoint, "info", "--target", daemon.target])
        check(text.returncode == 0, "info: exit %d: %s" % (text.returncode, text.stderr))
        check(text.stdout.startswith("nearpointd %s at %s\n" % (ARGS.version, daemon.target)),
              "info's first line: %r" % text.stdout.splitlines()[:1])
        for expected in ("7 scenes", "5 streams", "(port %d)" % daemon.port, "TLS off",
                         "1 worker thread\n"):
            check(expected in text.stdout, "info text lacks %r:\n%s" % (expected, text.stdout))
        result = run([ARGS.nearpoint, "info", "--json", "--target", daemon.target])
        check(result.returncode == 0, "info --json: exit %d: %s" % (result.returncode,
                                                                    result.stderr))
        info = json.loads(result.stdout)
        check(info["version"] == ARGS.version, "info --json version %r" % info["version"])
        check(info["build"] == {"grpc": True, "dds": ARGS.dds, "metrics": ARGS.metrics},
              "info --json build %r" % info["build"])
        grpc = info["transports"]["grpc"]
        check(grpc["port"] == daemon.port and grpc["listen"] == "127.0.0.1:0"
              and grpc["tls"] == "off" and grpc["token_required"] is False,
              "info --json grpc %r (port file %d)" % (grpc, daemon.port))
        check(info["transports"]["dds"] == {"enabled": False},
              "info --json dds %r" % info["transports"]["dds"])
        metrics = info["transports"]["metrics"]
        if ARGS.metrics:
            check(metrics["enabled"] and
                  metrics["port"] == int(open(daemon.metrics_port_file).read()),
                  "info --json metrics %r" % metrics)
        else:
            check(metrics == {"enabled": False}, "info --json metrics %r" % metrics)
        limits = info["limits"]
        check(limits["max_scenes"] == 7 and limits["max_streams"] == 5 and limits["workers"] == 1,
              "info --json limits %r" % limits)
        for key in ("max_geometries", "max_vertices_per_geometry", "max_pairs_per_scene",
                    "max_message_bytes", "max_in_flight_per_stream"):
            check(isinstance(limits.get(key), int) and limits[key] > 0,
                  "info --json limits.%s: %r" % (key, limits.get(key)))
    finally:
        daemon.stop()
    print("version OK: %s everywhere" % ARGS.version)


def free_port():
    """A port nothing listens on (bound, then closed)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def expect_exit(what, result, code):
    check(result.returncode == code, "%s: exit %d, expected %d; stderr: %s"
          % (what, result.returncode, code, result.stderr.strip()[:400]))


def case_exit_codes(scratch):
    missing = os.path.join(scratch, "no-such-scene.json")
    malformed = os.path.join(scratch, "malformed.json")
    with open(malformed, "w") as f:
        f.write('{"geometries": {"g": {"box": [1, 1, 1]}}, "objects": [')
    nowhere = "127.0.0.1:%d" % free_port()
    env = env_without_dds_config()
    # 2: usage, bad configuration, bad input — a missing file and a malformed one alike.
    expect_exit("nearpoint --no-such-flag", run([ARGS.nearpoint, "--no-such-flag"]), 2)
    expect_exit("nearpointd --no-such-flag", run([ARGS.nearpointd, "--no-such-flag"]), 2)
    expect_exit("nearpointd --workers -3", run([ARGS.nearpointd, "--workers", "-3"]), 2)
    for path, kind in ((missing, "missing"), (malformed, "malformed")):
        expect_exit("nearpoint scene create (%s file)" % kind,
                    run([ARGS.nearpoint, "scene", "create", path, "--target", nowhere]), 2)
        result = run([ARGS.nearpointd, "--listen", "127.0.0.1:0", "--scene", path], env=env)
        expect_exit("nearpointd --scene (%s file)" % kind, result, 2)
        check("listening" not in result.stderr,
              "nearpointd --scene (%s file) logged listening" % kind)
    # 3: unavailable — no server answers; the address is in use.
    expect_exit("nearpoint info (no server)",
                run([ARGS.nearpoint, "info", "--target", nowhere, "--timeout-ms", "2000"]), 3)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        result = run([ARGS.nearpointd, "--listen", "127.0.0.1:%d" % taken.getsockname()[1]],
                     env=env)
        expect_exit("nearpointd on an address in use", result, 3)
    # 1: the server answered with an error.
    daemon = Daemon(scratch)
    try:
        expect_exit("nearpoint query (unknown scene)",
                    run([ARGS.nearpoint, "query", "no-such-scene", "--target", daemon.target]), 1)
    finally:
        daemon.stop()
    # The table, in both binaries' --help.
    for binary in (ARGS.nearpoint, ARGS.nearpointd):
        result = run([binary, "--help"])
        expect_exit(os.path.basename(binary) + " --help", result, 0)
        check("Exit status (nearpoint and nearpointd alike): 0 success" in result.stdout and
              "3 unavailable" in result.stdout,
              "%s --help lacks the exit-status table:\n%s" % (binary, result.stdout[-600:]))
    print("exit codes OK: 2 usage/bad input, 1 server error, 3 unavailable, in both binaries")


def case_dds_refused(scratch):
    if not ARGS.dds:
        print("dds-refused: this build has no DDS")
        return
    port_file = os.path.join(scratch, "dds-port")
    if os.path.exists(port_file):
        os.remove(port_file)
    # No CYCLONEDDS_URI: nearpointd must refuse before DDS (or anything else) starts.
    result = run([ARGS.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file, "--dds"],
                 env=env_without_dds_config())
    expect_exit("nearpointd --dds without CYCLONEDDS_URI", result, 2)
    check(not os.path.exists(port_file), "nearpointd --dds refused but wrote its port file")
    check("listening" not in result.stderr, "nearpointd --dds refused but logged listening: "
          + result.stderr)
    check("CYCLONEDDS_URI" in result.stderr and "dds_participant" not in result.stderr,
          "the refusal does not name CYCLONEDDS_URI: " + result.stderr)
    # A configuration file that is not there is the same class.
    missing_env = dict(env_without_dds_config())
    missing_env["CYCLONEDDS_URI"] = "file://" + os.path.join(scratch, "no-such-config.xml")
    result = run([ARGS.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file, "--dds"],
                 env=missing_env)
    expect_exit("nearpointd --dds with a missing configuration file", result, 2)
    check(not os.path.exists(port_file) and "listening" not in result.stderr,
          "nearpointd --dds (missing file) signalled readiness")
    result = run([ARGS.nearpoint, "stream", "--dds", "--dds-domain", "7", "dds-demo",
                  os.path.join(ARGS.examples, "dds_trajectory.jsonl")],
                 env=env_without_dds_config())
    expect_exit("nearpoint stream --dds without CYCLONEDDS_URI", result, 2)
    print("dds-refused OK: exit 2, no port file, no listening")


def case_cli_text(scratch):
    top = run([ARGS.nearpoint, "--help"]).stdout
    check("  nearpoint demo\n" in top, "the top-level help lost its examples")
    scene = run([ARGS.nearpoint, "scene", "--help"])
    expect_exit("nearpoint scene --help", scene, 0)
    check("nearpoint distance examples/pairs.jsonl" not in scene.stdout,
          "nearpoint scene --help repeats the top-level examples:\n" + scene.stdout)
    if ARGS.dds:
        for binary in (ARGS.nearpointd, ARGS.nearpoint):
            args = [binary, "--help"] if binary == ARGS.nearpointd else [binary, "stream",
                                                                       "--help"]
            text = run(args).stdout
            check("--dds-domain" in text and "--dds-prefix" in text,
                  "%s lacks --dds-domain/--dds-prefix" % " ".join(args))
    one_pair = os.path.join(scratch, "one-pair.json")
    with open(one_pair, "w") as f:
        json.dump({"geometries": {"ball": {"sphere": {}, "radius": 0.5}},
                   "objects": [{"id": "a", "geometry": "ball"},
                               {"id": "b", "geometry": "ball",
                                "pose": {"translation": [3, 0, 0]}}]}, f)
    trajectory = os.path.join(scratch, "one-step.csv")
    with open(trajectory, "w") as f:
        f.write("t,object,tx,ty,tz,qw,qx,qy,qz\n")
        for k in range(40):
            f.write("%.2f,b,%.3f,0,0,1,0,0,0\n" % (k * 0.05, 3 - 0.05 * k))
    daemon = Daemon(scratch)
    try:
        query = run([ARGS.nearpoint, "query", one_pair, "--target", daemon.target])
        expect_exit("nearpoint query (one pair)", query, 0)
        check(": 1 pair, " in query.stdout and "1 pairs" not in query.stdout,
              "query of one pair: " + query.stdout)
        stream = run([ARGS.nearpoint, "stream", one_pair, trajectory, "--target", daemon.target])
        expect_exit("nearpoint stream", stream, 0)
        check("\r" not in stream.stderr, "stream wrote \\r progress into a pipe: %r"
              % stream.stderr[:200])
        check(" 40 reports for 40 updates" in stream.stdout, "stream summary: " + stream.stdout)
        load = run([ARGS.nearpoint, "load", one_pair, trajectory, "--duration", "0.6",
                    "--streams", "1", "--target", daemon.target])
        expect_exit("nearpoint load", load, 0)
        check("\r" not in load.stderr, "load wrote \\r progress into a pipe: %r"
              % load.stderr[:200])
        check(": 1 stream × " in load.stdout, "load summary: " + load.stdout)
    finally:
        daemon.stop()
    print("cli-text OK")


def scrape(port):
    """The Prometheus samples of nearpointd's /metrics, by name with labels."""
    with urllib.request.urlopen("http://127.0.0.1:%d/metrics" % port, timeout=10) as response:
        body = response.read().decode()
    samples = {}
    for line in body.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        name, number = line.rsplit(" ", 1)
        samples[name] = float(number)
    return samples


def updates_counted(daemon):
    """nearpointd's update counters by status, once every stream has ended (bounded wait)."""
    deadline = time.monotonic() + 10
    while True:
        samples = scrape(daemon.metrics_port)
        if samples.get("nearpoint_streams_active", 0) == 0 or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    prefix = 'nearpoint_updates_total{status="'
    return {k[len(prefix):-2]: v for k, v in samples.items() if k.startswith(prefix)}


def refused(counted):
    """Updates nearpointd answered with an error, whatever the code."""
    return sum(v for k, v in counted.items() if k != "ok")


def case_load(scratch):
    daemon = Daemon(scratch, ["--workers", "1"], metrics=ARGS.metrics)
    try:
        before = updates_counted(daemon) if ARGS.metrics else {}
        for flags in (["--streams", "3", "--window", "4"],
                      ["--streams", "2", "--window", "16", "--batch", "8"]):
            result = run([ARGS.nearpoint, "load", "--target", daemon.target, "--duration", "0.6",
                          "--json", *flags])
            expect_exit("nearpoint load " + " ".join(flags), result, 0)
            summary = json.loads(result.stdout)
            check(summary["errors"] == 0 and summary["reports"] > 100,
                  "load %s: %r" % (flags, summary))
            latency = summary["latency_us"]
            check(0 < latency["p50"] <= latency["p99"] <= latency["max"],
                  "load %s: latency percentiles out of order: %r" % (flags, latency))
            check(summary["geometry_us_per_report"] > 0, "no geometry time: %r" % summary)
            if ARGS.metrics:
                after = updates_counted(daemon)
                served = after.get("ok", 0) - before.get("ok", 0)
                check(served == summary["reports"],
                      "load %s: nearpointd answered %d updates, the load counted %d reports"
                      % (flags, served, summary["reports"]))
                check(refused(after) == refused(before),
                      "load %s: nearpointd refused updates: %r" % (flags, after))
                before = after

        trajectory = os.path.join(scratch, "one-step.jsonl")
        with open(trajectory, "w") as f:
            f.write('{"t": 0, "poses": {"o0": {"translation": [0, 0, 0]}}}\n')
        result = run([ARGS.nearpoint, "load", "no-such-scene", trajectory, "--target",
                      daemon.target, "--duration", "0.3", "--json"])
        expect_exit("nearpoint load on an unknown scene", result, 1)
        summary = json.loads(result.stdout)
        check(summary["errors"] > 0 and summary["reports"] == 0, "unknown scene: %r" % summary)
        check("NOT_FOUND" in result.stderr and "no-such-scene" in result.stderr,
              "unknown scene: the error does not say which: %s" % result.stderr)
        if ARGS.metrics:
            after = updates_counted(daemon)
            check(refused(after) - refused(before) == summary["errors"],
                  "nearpointd refused %d updates, the load counted %d errors"
                  % (refused(after) - refused(before), summary["errors"]))
    finally:
        daemon.stop()

    # A server that dies under load: the load ends soon, exit 1, and says the stream was lost.
    doomed = Daemon(scratch, ["--workers", "1"])
    load = subprocess.Popen([ARGS.nearpoint, "load", "--target", doomed.target, "--streams", "2",
                             "--window", "4", "--duration", "30", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    doomed.process.kill()
    doomed.process.wait(timeout=30)
    doomed.log.close()
    started = time.monotonic()
    try:
        out, err = load.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        load.kill()
        fail("nearpoint load still ran 20 s after its server was killed")
    check(load.returncode == 1, "load after SIGKILL of its server: exit %d, expected 1; %s"
          % (load.returncode, err.strip()[-400:]))
    check("stream failed" in err and "UNAVAILABLE" in err,
          "load after SIGKILL: the error does not name the lost stream: %s" % err.strip()[-400:])
    check(time.monotonic() - started < 20, "the load took too long to notice")
    if ARGS.dds:
        dds_load(scratch)


def dds_load(scratch):
    """`nearpoint dds load` on the DDS example scene: every update nearpointd counted is one report
    of the load's, with no error (the reports read from their bytes, client/src/dds_report_view)."""
    domain = "118"  # tests/dds/dds_test_support.hpp keeps the list
    scene = os.path.join(ARGS.examples, "dds_scene.json")
    daemon = Daemon(scratch, ["--workers", "1", "--dds", "--dds-domain", domain, "--scene", scene],
                    metrics=ARGS.metrics, dds=True)
    try:
        before = updates_counted(daemon) if ARGS.metrics else {}
        for flags in (["--window", "4"], ["--window", "16", "--batch", "8"]):
            result = run([ARGS.nearpoint, "dds", "load", "dds-demo",
                          os.path.join(ARGS.examples, "dds_trajectory.jsonl"), "--dds-domain",
                          domain, "--duration", "0.6", "--json", *flags],
                         env=env_with_loopback_dds())
            expect_exit("nearpoint dds load " + " ".join(flags), result, 0)
            summary = json.loads(result.stdout)
            check(summary["errors"] == 0 and summary["reports"] > 50,
                  "dds load %s: %r" % (flags, summary))
            check(summary["geometry_us_total"] > 0 and summary["server_us_total"] > 0,
                  "dds load %s: no server timing read: %r" % (flags, summary))
            if ARGS.metrics:
                after = updates_counted(daemon)
                served = after.get("ok", 0) - before.get("ok", 0)
                check(served == summary["reports"] + summary["merged"],
                      "dds load %s: nearpointd answered %d updates, the load counted %d reports "
                      "and %d merged" % (flags, served, summary["reports"], summary["merged"]))
                before = after
    finally:
        daemon.stop()


def main():
    global ARGS
    parser = argparse.ArgumentParser()
    parser.add_argument("case",
                        choices=["version", "exit-codes", "dds-refused", "cli-text", "load"])
    parser.add_argument("--nearpoint", required=True)
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--version", required=True)
    parser.add_argument("--examples", required=True)
    parser.add_argument("--dds", action="store_true")
    parser.add_argument("--metrics", action="store_true")
    ARGS = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="nearpoint-edges-") as scratch:
        {"version": case_version, "exit-codes": case_exit_codes, "dds-refused": case_dds_refused,
         "cli-text": case_cli_text, "load": case_load}[ARGS.case](scratch)


if __name__ == "__main__":
    main()
