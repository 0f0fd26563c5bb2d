#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The CLI against a real nearpointd on 127.0.0.1:0: managing scenes and geometries, cleaning up
the scenes a command creates for itself, and one report schema for every JSON report.

    check_scene_lifecycle.py CASE --nearpoint BIN --nearpointd BIN --schema FILE --work DIR

CASE:
  manage   `scene list|show|delete`, `geometry list|show|remove`, text and --json, and unknown ids
           (exit 1 naming NOT_FOUND and the id).
  cleanup  after `query FILE`, `stream FILE`, `load` (demo scene and a file), `demo --target`,
           the server holds exactly the scenes it held before (`scene list --json`); with
           --keep-scene the scene stays and its id is printed; a stream interrupted by SIGINT and
           a load interrupted by SIGTERM exit 130 / 143 and leave no scene behind.
  schema   `query --json`, `stream --json` over gRPC and `stream --dds --json` (Cyclone DDS on
           the loopback configuration, CYCLONEDDS_URI, domain 121) validate against the one schema
           (python3-jsonschema), error reports included; and the validator rejects a report whose
           pair lacks its error bound, so that the check can fail.
Exits non-zero with a message on the first failure; the server is killed however the script ends.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import time

from cli_checks import check, fail

DDS_DOMAIN = 121  # tests/dds/dds_test_support.hpp reserves 101-130 for the tests, one each


class Server:
    """nearpointd on 127.0.0.1:0 (its port read from --port-file), killed on exit."""

    def __init__(self, binary, work, extra=()):
        self.port_file = os.path.join(work, "port-%d" % time.monotonic_ns())
        self.log = open(os.path.join(work, "nearpointd.log"), "a")
        self.process = subprocess.Popen(
            [binary, "--listen", "127.0.0.1:0", "--port-file", self.port_file, "--workers", "2",
             *extra], stdout=self.log, stderr=self.log)
        deadline = time.monotonic() + 30
        self.port = None
        while time.monotonic() < deadline and self.process.poll() is None:
            if os.path.exists(self.port_file):
                text = open(self.port_file).read().strip()
                if text:
                    self.port = int(text)
                    break
            time.sleep(0.05)
        check(self.port is not None, "nearpointd did not start (see %s)" % self.log.name)
        self.target = "127.0.0.1:%d" % self.port

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.process.kill()
        self.process.wait()
        self.log.close()


def run(args, cli, timeout=120, expect=None):
    result = subprocess.run([cli, *args], capture_output=True, text=True, timeout=timeout)
    if expect is not None:
        check(result.returncode == expect,
              "nearpoint %s: exit %d, expected %d\nstdout: %s\nstderr: %s"
              % (" ".join(args), result.returncode, expect, result.stdout[-2000:],
                 result.stderr[-2000:]))
    return result


def scene_ids(cli, target):
    result = run(["scene", "list", "--json", "--target", target], cli, expect=0)
    listed = json.loads(result.stdout)
    check(isinstance(listed, list), "scene list --json prints an array: " + result.stdout)
    return sorted(s["scene_id"] for s in listed)


def write_scene(path, scene_id=None):
    scene = {"geometries": {"cube": {"box": [0.5, 0.5, 0.5]},
                            "ball": {"sphere": {}, "radius": 0.25}},
             "objects": [{"id": "arm", "geometry": "cube"},
                         {"id": "post", "geometry": "cube", "pose": {"translation": [3, 0, 0]}},
                         {"id": "bob", "geometry": "ball", "pose": {"translation": [0, 4, 0]}}],
             "options": {"penetration": "bound"}}
    if scene_id:
        scene["id"] = scene_id
    with open(path, "w") as f:
        json.dump(scene, f)


def write_trajectory(path, steps, obj="arm"):
    """`obj` slides along x from 0 to 3: it touches post (1 m away at rest) on the way."""
    with open(path, "w") as f:
        for k in range(steps):
            x = 3.0 * k / max(1, steps - 1)
            f.write(json.dumps({"t": 0.01 * k, "poses": {
                obj: {"rotation": [1, 0, 0, 0], "translation": [x, 0, 0]}}}) + "\n")


# ---- manage ----

def case_manage(args):
    cli = args.nearpoint
    with Server(args.nearpointd, args.work) as server:
        t = ["--target", server.target]
        check(scene_ids(cli, server.target) == [], "a new server lists no scenes")
        out = run(["scene", "list", *t], cli, expect=0).stdout
        check("no scenes" in out, "scene list on an empty server says so: " + out)

        scene_file = os.path.join(args.work, "managed.json")
        write_scene(scene_file, "managed-1")
        run(["scene", "create", scene_file, *t], cli, expect=0)
        check(scene_ids(cli, server.target) == ["managed-1"], "scene list shows the new scene")
        out = run(["scene", "list", *t], cli, expect=0).stdout
        check("managed-1" in out and "SCENE" in out, "scene list prints a table: " + out)

        shown = json.loads(run(["scene", "show", "managed-1", "--json", *t], cli,
                               expect=0).stdout)
        check(shown["scene_id"] == "managed-1" and shown["pair_count"] == 3
              and [o["id"] for o in shown["objects"]] == ["arm", "post", "bob"],
              "scene show --json: id, 3 pairs, the objects in order: %s" % shown)
        check(shown["objects"][1]["pose"]["translation"] == [3, 0, 0],
              "scene show --json: post's initial translation: %s" % shown["objects"][1])
        out = run(["scene", "show", "managed-1", *t], cli, expect=0).stdout
        check("3 objects, 3 pairs" in out and "post" in out, "scene show text: " + out)

        for verb in (["scene", "show", "no-such-scene"], ["scene", "delete", "no-such-scene"]):
            result = run([*verb, *t], cli, expect=1)
            check("NOT_FOUND" in result.stderr and "no-such-scene" in result.stderr,
                  "%s: names NOT_FOUND and the id: %s" % (" ".join(verb), result.stderr))

        geometries = json.loads(run(["geometry", "list", "--json", *t], cli, expect=0).stdout)
        check(sorted(g["name"] for g in geometries) == ["ball", "cube"],
              "geometry list --json: the scene's two geometries: %s" % geometries)
        cube = next(g for g in geometries if g["name"] == "cube")
        check(cube["geometry_id"] in {o["geometry_id"] for o in shown["objects"]},
              "the scene's objects name the listed geometry ids")
        out = run(["geometry", "list", *t], cli, expect=0).stdout
        check(cube["geometry_id"] in out and "VERTICES" in out, "geometry list text: " + out)
        one = json.loads(run(["geometry", "show", cube["geometry_id"], "--json", *t], cli,
                             expect=0).stdout)
        check(one == cube, "geometry show --json equals its list entry: %s" % one)
        out = run(["geometry", "show", cube["geometry_id"], *t], cli, expect=0).stdout
        check(cube["geometry_id"] in out and "pieces          1" in out,
              "geometry show text: the id and one piece: " + out)
        for verb in (["geometry", "show", "geom-unknown"], ["geometry", "remove", "geom-unknown"]):
            result = run([*verb, *t], cli, expect=1)
            check("NOT_FOUND" in result.stderr and "geom-unknown" in result.stderr,
                  "%s: names NOT_FOUND and the id: %s" % (" ".join(verb), result.stderr))

        out = run(["geometry", "remove", cube["geometry_id"], *t], cli, expect=0).stdout
        check("removed geometry " + cube["geometry_id"] in out, "geometry remove: " + out)
        remaining = json.loads(run(["geometry", "list", "--json", *t], cli, expect=0).stdout)
        check([g["name"] for g in remaining] == ["ball"], "the removed geometry is gone")
        # Scenes that use a removed geometry keep working.
        run(["query", "managed-1", "--json", *t], cli, expect=0)
        out = run(["scene", "delete", "managed-1", *t], cli, expect=0).stdout
        check("deleted scene managed-1" in out, "scene delete: " + out)
        check(scene_ids(cli, server.target) == [], "the deleted scene is no longer listed")
        run(["scene", "delete", "managed-1", *t], cli, expect=1)


# ---- cleanup ----

def interrupt(cli, args_list, sig, started_marker):
    """Starts `nearpoint args…`, waits until `started_marker(stdout so far)` or 20 s, sends `sig`
    and returns (exit status, stdout, stderr)."""
    process = subprocess.Popen([cli, *args_list], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    lines = []
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        lines.append(line)
        if started_marker(lines):
            break
    check(process.poll() is None, "nearpoint %s ended before it could be interrupted" % args_list)
    process.send_signal(sig)
    # Read on through the same buffered reader (communicate() would skip what it holds already);
    # stderr carries a line or two, so reading it last cannot block the child.
    timer = __import__("threading").Timer(60, process.kill)
    timer.start()
    out = process.stdout.read()
    err = process.stderr.read()
    process.wait()
    timer.cancel()
    check(process.returncode != -signal.SIGKILL,
          "nearpoint %s did not end within 60 s of signal %d" % (args_list, sig))
    return process.returncode, "".join(lines) + out, err


def case_cleanup(args):
    cli = args.nearpoint
    scene_file = os.path.join(args.work, "cleanup.json")
    write_scene(scene_file)  # no id: the client picks a fresh one each run
    trajectory = os.path.join(args.work, "cleanup.jsonl")
    write_trajectory(trajectory, 50)
    long_trajectory = os.path.join(args.work, "long.jsonl")
    write_trajectory(long_trajectory, 200000)
    with Server(args.nearpointd, args.work) as server:
        t = ["--target", server.target]
        # A scene of someone else's that must survive everything below.
        write_scene(os.path.join(args.work, "resident.json"), "resident")
        run(["scene", "create", os.path.join(args.work, "resident.json"), *t], cli, expect=0)
        before = scene_ids(cli, server.target)
        check(before == ["resident"], "the resident scene is listed: %s" % before)

        def unchanged(what):
            after = scene_ids(cli, server.target)
            check(after == before, "after %s the server holds %s, before %s" % (what, after, before))

        run(["query", scene_file, "--json", *t], cli, expect=0)
        unchanged("query FILE")
        run(["stream", scene_file, trajectory, "--json", *t], cli, expect=0)
        unchanged("stream FILE")
        run(["stream", scene_file, trajectory, *t], cli, expect=0)
        unchanged("stream FILE (text)")
        run(["load", "--streams", "2", "--duration", "0.3", *t], cli, expect=0)
        unchanged("load (the demo scene)")
        run(["load", scene_file, trajectory, "--streams", "1", "--duration", "0.3", *t], cli,
            expect=0)
        unchanged("load FILE")
        run(["demo", "--steps", "20", "--json", "--plot", "-", *t], cli, expect=0)
        unchanged("demo --target")
        # A scene file naming a scene the server already holds (created again idempotently): the
        # scene was not created for this command, so it stays.
        run(["query", os.path.join(args.work, "resident.json"), *t], cli, expect=0)
        unchanged("query on a file naming an existing scene")
        # A scene given by id belongs to someone else: kept.
        run(["stream", "resident", trajectory, "--json", *t], cli, expect=0)
        unchanged("stream on a scene id")

        kept = run(["query", scene_file, "--keep-scene", *t], cli, expect=0)
        after = scene_ids(cli, server.target)
        check(len(after) == 2, "query --keep-scene keeps its scene: %s" % after)
        new_id = next(s for s in after if s != "resident")
        check("kept scene " + new_id in kept.stderr,
              "query --keep-scene prints the kept id %s: %s" % (new_id, kept.stderr))
        run(["scene", "delete", new_id, *t], cli, expect=0)
        unchanged("deleting the kept scene")

        # Ctrl-C in the middle of a stream: the updates in flight are answered, the scene goes.
        code, out, err = interrupt(
            cli, ["stream", scene_file, long_trajectory, "--json", "--window", "4", *t],
            signal.SIGINT, lambda lines: len(lines) >= 20)
        check(code == 130, "stream interrupted by SIGINT exits 130, got %d: %s" % (code, err))
        bad = [line for line in out.splitlines() if not line.startswith("{")]
        check(not bad, "the interrupted stream printed only JSON lines: %r" % bad[:3])
        reports = [json.loads(line) for line in out.splitlines() if line.strip()]
        check(20 <= len(reports) < 200000, "the interrupted stream printed %d reports"
              % len(reports))
        check([r["sequence"] for r in reports] == list(range(1, len(reports) + 1)),
              "every update sent before the interrupt is answered, in order")
        check("interrupted" in err, "the interrupted stream says so: " + err)
        unchanged("stream FILE interrupted by SIGINT")

        # load prints nothing on stdout until it ends: wait for its scene to appear instead.
        process = subprocess.Popen([cli, "load", scene_file, trajectory, "--duration", "60",
                                    "--streams", "1", *t], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and len(scene_ids(cli, server.target)) < 2:
            time.sleep(0.05)
        check(len(scene_ids(cli, server.target)) == 2, "load created its scene")
        time.sleep(0.2)
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=60)
        check(process.returncode == 143,
              "load interrupted by SIGTERM exits 143, got %d: %s" % (process.returncode, err))
        unchanged("load FILE interrupted by SIGTERM")


# ---- schema ----

def validator(schema_path):
    try:
        import jsonschema
    except ImportError:
        fail("python3-jsonschema is missing (deploy/install-deps.sh installs it)")
    with open(schema_path) as f:
        schema = json.load(f)
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def validate_all(v, reports, what):
    check(reports, "%s printed no reports" % what)
    for report in reports:
        errors = sorted(v.iter_errors(report), key=str)
        check(not errors, "%s: a report does not match the schema: %s\n%s"
              % (what, "; ".join(e.message for e in errors[:3]), json.dumps(report)[:1500]))


def json_lines(text):
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def dds_domain_flag(cli):
    """The client's DDS domain flag (--dds-domain, or --domain before the rename)."""
    help_text = run(["stream", "--help"], cli).stdout
    return "--dds-domain" if "--dds-domain" in help_text else "--domain"


def case_schema(args):
    cli = args.nearpoint
    v = validator(args.schema)
    scene_file = os.path.join(args.work, "schema.json")
    write_scene(scene_file, "schema-1")
    anonymous_file = os.path.join(args.work, "schema-anonymous.json")
    write_scene(anonymous_file)
    trajectory = os.path.join(args.work, "schema.jsonl")
    write_trajectory(trajectory, 40)
    bad_trajectory = os.path.join(args.work, "schema-bad.jsonl")
    write_trajectory(bad_trajectory, 3, obj="ghost")
    dds_uri = os.environ.get("CYCLONEDDS_URI", "")
    check("cyclonedds-loopback.xml" in dds_uri,
          "CYCLONEDDS_URI must name deploy/cyclonedds-loopback.xml, got %r" % dds_uri)
    prefix = "rt/nearpoint_schema_%d/" % os.getpid()
    with Server(args.nearpointd, args.work,
                ["--scene", scene_file, "--dds", "--dds-domain", str(DDS_DOMAIN),
                 "--dds-prefix", prefix]) as server:
        t = ["--target", server.target]
        # query: a scene id and a scene file, near points on.
        reports = [json.loads(run(["query", "schema-1", "--json", "--near-points",
                                   "--pose", "arm=2.5,0,0", *t], cli, expect=0).stdout),
                   json.loads(run(["query", anonymous_file, "--json", *t], cli,
                                  expect=0).stdout)]
        validate_all(v, reports, "query --json")

        check(any(p["status"] in ("intersecting", "touching") for p in reports[0]["pairs"]),
              "the query at arm=2.5 intersects post")
        # gRPC stream, ok reports (with near points and penetration bounds) and error reports.
        grpc = json_lines(run(["stream", "schema-1", trajectory, "--json", "--near-points", *t],
                              cli, expect=0).stdout)
        check(len(grpc) == 40, "40 gRPC reports for 40 updates, got %d" % len(grpc))
        validate_all(v, grpc, "stream --json (gRPC)")
        check(any("penetration_bound" in p for r in grpc for p in r["pairs"]),
              "some gRPC report carries a penetration bound")
        grpc_errors = json_lines(run(["stream", "schema-1", bad_trajectory, "--json", *t], cli,
                                     expect=1).stdout)
        check(grpc_errors and all(r["status"] == "error" for r in grpc_errors),
              "updates naming an unknown object get error reports")
        validate_all(v, grpc_errors, "stream --json (gRPC error reports)")
        # DDS stream, the same trajectory: the same schema, and the same keys as over gRPC.
        domain = dds_domain_flag(cli)
        prefix_flag = "--dds-prefix" if domain == "--dds-domain" else "--prefix"
        dds = json_lines(run(["stream", "--dds", "schema-1", trajectory, "--json",
                              "--near-points", domain, str(DDS_DOMAIN), prefix_flag, prefix],
                             cli, expect=0, timeout=180).stdout)
        check(len(dds) == 40, "40 DDS reports for 40 updates, got %d" % len(dds))
        validate_all(v, dds, "stream --dds --json")
        for a, b in zip(grpc, dds):
            check(set(a) == set(b), "gRPC and DDS reports have the same keys: %s vs %s"
                  % (sorted(a), sorted(b)))
            for pa, pb in zip(a["pairs"], b["pairs"]):
                check(set(pa) == set(pb), "gRPC and DDS pairs have the same keys: %s vs %s"
                      % (sorted(pa), sorted(pb)))
        # --penetration depth over both transports: the signed distance and the depth on every
        # verdict, the same keys over gRPC and DDS, the schema; a negative threshold fires ENTER
        # with the (negative) signed distance once a pair overlaps deeper than it.
        depth_flags = ["--penetration", "depth", "--threshold=-0.000001,name=deep"]
        grpc_depth = json_lines(run(["stream", "schema-1", trajectory, "--json", *depth_flags, *t],
                                    cli, expect=0).stdout)
        dds_depth = json_lines(run(["stream", "--dds", "schema-1", trajectory, "--json",
                                    *depth_flags, domain, str(DDS_DOMAIN), prefix_flag, prefix],
                                   cli, expect=0, timeout=180).stdout)
        for name, reports in (("gRPC", grpc_depth), ("DDS", dds_depth)):
            check(len(reports) == 40, "40 %s depth reports, got %d" % (name, len(reports)))
            validate_all(v, reports, "stream --penetration depth --json (%s)" % name)
            pairs = [p for r in reports for p in r["pairs"] if p["status"] != "beyond_cutoff"]
            check(pairs and all("signed_distance" in p and "penetration_depth" in p for p in pairs),
                  name + ": every evaluated pair carries the signed distance and the depth")
            for p in pairs:
                check(p["signed_distance_lower"] <= p["signed_distance"] <= p["signed_distance_upper"],
                      name + ": signed distance outside its interval: %s" % p)
            deep = [p for p in pairs if p["signed_distance"] < -1e-6]
            check(deep, name + ": the trajectory overlaps somewhere (signed distance < 0)")
            events = [e for r in reports for e in r["events"]]
            check(any(e["crossing"] == "enter" and e["distance"] < 0 for e in events),
                  name + ": the negative threshold fired ENTER: %s" % events)
        for a, b in zip(grpc_depth, dds_depth):
            for pa, pb in zip(a["pairs"], b["pairs"]):
                check(set(pa) == set(pb), "gRPC and DDS depth pairs have the same keys: %s vs %s"
                      % (sorted(pa), sorted(pb)))
        dds_errors = json_lines(run(["stream", "--dds", "no-such-scene", bad_trajectory, "--json",
                                     domain, str(DDS_DOMAIN), prefix_flag, prefix],
                                    cli, expect=1, timeout=180).stdout)
        check(dds_errors and all(r["status"] == "error" for r in dds_errors),
              "DDS updates for an unknown scene get error reports")
        validate_all(v, dds_errors, "stream --dds --json (error reports)")
        check(dds_errors[0]["error"]["code"] == "not_found", "unknown scene: not_found")

    # The check can fail: the validator rejects a report whose pair lacks its error bound, one
    # whose timing key is spelled with a micro sign, and an error report without its error.
    broken = json.loads(json.dumps(grpc[0]))
    del broken["pairs"][0]["error_bound"]
    check(not v.is_valid(broken), "the schema rejects a pair without error_bound")
    broken = json.loads(json.dumps(dds[0]))
    broken["server_\u00b5s"] = broken.pop("server_us")
    check(not v.is_valid(broken), "the schema rejects server_\u00b5s for server_us")
    broken = json.loads(json.dumps(grpc_errors[0]))
    del broken["error"]
    check(not v.is_valid(broken), "the schema rejects an error report without its error")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("case", choices=["manage", "cleanup", "schema"])
    parser.add_argument("--nearpoint", required=True)
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--schema")
    parser.add_argument("--work", required=True)
    args = parser.parse_args()
    args.work = os.path.join(args.work, "scene_lifecycle_" + args.case)
    os.makedirs(args.work, exist_ok=True)
    {"manage": case_manage, "cleanup": case_cleanup, "schema": case_schema}[args.case](args)
    print("ok: " + args.case)


if __name__ == "__main__":
    main()
