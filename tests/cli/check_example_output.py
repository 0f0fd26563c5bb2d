#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Process-boundary checks of the real `nearpoint` binary (standard library only).

    check_example_output.py NEARPOINT example PAIRS_JSONL   the shipped example, end to end
    check_example_output.py NEARPOINT missing-file          a missing FILE exits with 2
    check_example_output.py NEARPOINT help                  --help texts exist and show an example

Exits non-zero with a message on the first failed check.
"""
import json
import math
import subprocess
import sys

from cli_checks import check, fail

SHAPE_KINDS = ("polytope", "sphere", "segment", "box", "ellipsoid", "cylinder", "cone")


def reject_constant(name):
    # json.loads accepts NaN and Infinity by default; JSON does not, and neither do we.
    raise ValueError("non-JSON constant " + name)


def run(args, stdin=None):
    return subprocess.run(args, input=stdin, capture_output=True, text=True, timeout=60)


def check_example(nearpoint, pairs_path):
    with open(pairs_path, encoding="utf-8") as f:
        input_lines = [line for line in f.read().splitlines() if line.strip()]
    inputs = []
    for line in input_lines:
        try:
            inputs.append(json.loads(line))
        except ValueError:
            inputs.append(None)  # a deliberately malformed line, if the example has one

    from_file = run([nearpoint, "distance", pairs_path])
    check(from_file.returncode == 0, "exit code %d, stderr: %s" % (from_file.returncode, from_file.stderr))
    check(from_file.stderr == "", "unexpected stderr: " + from_file.stderr)
    with open(pairs_path, encoding="utf-8") as f:
        from_stdin = run([nearpoint, "distance"], stdin=f.read())
    check(from_stdin.returncode == 0, "stdin run: exit code %d" % from_stdin.returncode)
    check(from_stdin.stdout == from_file.stdout, "stdin and FILE give different output")

    output_lines = from_file.stdout.splitlines()
    check(from_file.stdout.endswith("\n"), "the last output line has no newline")
    check(len(output_lines) == len(input_lines),
          "%d output lines for %d input lines" % (len(output_lines), len(input_lines)))

    outputs = []
    for number, line in enumerate(output_lines, 1):
        try:
            outputs.append(json.loads(line, parse_constant=reject_constant))
        except ValueError as e:
            fail("output line %d is not JSON (%s): %s" % (number, e, line))

    by_id = {}
    kinds_seen = set()
    for number, (given, out) in enumerate(zip(inputs, outputs), 1):
        where = "output line %d (%s)" % (number, output_lines[number - 1])
        expected_id = given.get("id") if isinstance(given, dict) else None
        check(out.get("id") == expected_id, where + ": id %r, expected %r" % (out.get("id"), expected_id))
        by_id[out.get("id")] = out
        status = out.get("status")
        check(status in ("separated", "intersecting", "iteration_limit", "error"), where + ": bad status")
        if isinstance(given, dict):
            for side in ("a", "b"):
                shape = given.get(side)
                if isinstance(shape, dict):
                    kinds_seen.update(kind for kind in SHAPE_KINDS if kind in shape)
        if status == "error":
            check(isinstance(out.get("message"), str) and out["message"].startswith("line %d: " % number),
                  where + ": an error needs a message starting with its line number")
            check("distance" not in out, where + ": an error line carries no distance")
            continue
        for key in ("distance", "error_bound"):
            value = out.get(key)
            check(isinstance(value, (int, float)) and math.isfinite(value) and value >= 0,
                  where + ": %s must be a finite non-negative number" % key)
        check(isinstance(out.get("iterations"), int) and out["iterations"] >= 0, where + ": iterations")
        check(isinstance(out.get("warm_started"), bool), where + ": warm_started")
        if status == "intersecting":
            check(out["distance"] == 0, where + ": intersecting with a non-zero distance")
        options = given.get("options", {})
        near_points = options.get("near_points", False)
        check(("point_a" in out) == near_points and ("point_b" in out) == near_points,
              where + ": near points present iff asked")
        if near_points and status == "separated":
            gap = math.dist(out["point_a"], out["point_b"])
            check(abs(gap - out["distance"]) <= 1e-9, where + ": |point_b - point_a| != distance")
            check(abs(math.hypot(*out["normal"]) - 1) <= 1e-9, where + ": normal is not a unit vector")
        asked_bound = options.get("penetration") == "bound"
        check(("penetration_bound" in out) == (asked_bound and status == "intersecting"),
              where + ": penetration_bound present iff asked and intersecting")
        if "penetration_bound" in out:
            check(math.isfinite(out["penetration_bound"]) and out["penetration_bound"] >= 0,
                  where + ": penetration_bound")

    check(kinds_seen == set(SHAPE_KINDS), "the example misses shape kinds: %s" % (set(SHAPE_KINDS) - kinds_seen))

    # The particular pairs the example is there to show.
    spheres = by_id["spheres"]  # radii 1 and 0.5, centres 3 apart
    check(spheres["status"] == "separated", "spheres: status")
    check(abs(spheres["distance"] - 1.5) <= spheres["error_bound"] + 1e-15, "spheres: distance != 1.5")
    check(math.dist(spheres["point_a"], [1, 0, 0]) <= 1e-12, "spheres: point_a")
    check(math.dist(spheres["point_b"], [2.5, 0, 0]) <= 1e-12, "spheres: point_b")

    touching = by_id["rounded-box-touching"]
    check(touching["status"] in ("intersecting", "separated") and touching["distance"] <= 1e-12,
          "touching pair: distance %r is not ~0" % touching["distance"])

    intersecting = by_id["cube-octahedron-intersecting"]
    check(intersecting["status"] == "intersecting", "cube-octahedron: status")
    check(0 <= intersecting["penetration_bound"] <= 0.5 + 1e-12,
          "cube-octahedron: the penetration bound must lie in [0, true depth 0.5]")

    path = [by_id["path-0"], by_id["path-1"], by_id["path-2"]]
    check([p["warm_started"] for p in path] == [False, True, True], "path: warm_started should be F, T, T")
    check(abs(path[0]["distance"] - 2.0) <= path[0]["error_bound"] + 1e-15, "path-0: distance != 2")

    errors = [out for out in outputs if out["status"] == "error"]
    check(len(errors) >= 1, "the example must show an error line")
    check(any("quaternion" in e["message"] for e in errors), "the bad-quaternion line's message")
    print("example output OK: %d lines, %d error line(s)" % (len(outputs), len(errors)))


def check_missing_file(nearpoint):
    missing = "/nonexistent/nearpoint-missing-input.jsonl"
    result = run([nearpoint, "distance", missing])
    check(result.returncode == 2, "missing file: exit code %d, expected 2" % result.returncode)
    check(result.stdout == "", "missing file: nothing may go to stdout")
    check(missing in result.stderr, "missing file: stderr must name the file: " + result.stderr)
    print("missing file OK: exit 2, " + result.stderr.strip())


def check_help(nearpoint):
    top = run([nearpoint, "--help"])
    check(top.returncode == 0, "--help exit code")
    check("distance" in top.stdout and "Example" in top.stdout, "--help lists distance with an example")
    sub = run([nearpoint, "distance", "--help"])
    check(sub.returncode == 0, "distance --help exit code")
    for needle in ("Example", "warm", "near_points", "penetration", "Exit status") + SHAPE_KINDS:
        check(needle in sub.stdout, "distance --help does not mention " + needle)
    # The example in the help must be true: run it and compare with the line printed below it.
    lines = sub.stdout.splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip().startswith("echo '"))
    command, printed = lines[at].strip(), lines[at + 1].strip()
    given = command[len("echo '"):command.index("' | nearpoint distance")]
    actual = run([nearpoint, "distance"], stdin=given + "\n")
    got, shown = json.loads(actual.stdout), json.loads(printed)
    # error_bound and iterations may change with the engine; the geometry may not.
    same = list(got) == list(shown) and all(
        got[key] == shown[key] for key in ("id", "status", "warm_started"))
    same = same and all(
        math.dist(got[key], shown[key]) <= 1e-12 if isinstance(got[key], list) else abs(got[key] - shown[key]) <= 1e-12
        for key in ("distance", "point_a", "point_b", "normal"))
    check(same, "the help's example prints %s, not %s" % (actual.stdout.strip(), printed))
    usage = run([nearpoint])
    check(usage.returncode == 2, "no subcommand: exit code %d, expected 2" % usage.returncode)
    print("help OK")


def main():
    if len(sys.argv) < 3:
        fail(__doc__)
    nearpoint, case = sys.argv[1], sys.argv[2]
    if case == "example" and len(sys.argv) == 4:
        check_example(nearpoint, sys.argv[3])
    elif case == "missing-file":
        check_missing_file(nearpoint)
    elif case == "help":
        check_help(nearpoint)
    else:
        fail(__doc__)


if __name__ == "__main__":
    main()
