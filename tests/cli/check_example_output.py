#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Process-boundary checks of the real `nearpoint` binary (standard library only).

    check_example_output.py NEARPOINT example PAIRS_JSONL   the shipped example, end to end
    check_example_output.py NEARPOINT missing-file          a missing FILE exits with 2
    check_example_output.py NEARPOINT help                  --help texts exist and show an example
    check_example_output.py NEARPOINT depth                 "penetration": "depth" lines, analytic

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
        check(status in ("separated", "intersecting", "touching", "iteration_limit", "error"),
              where + ": bad status")
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
        if status in ("intersecting", "touching"):
            check(out["distance"] == 0, where + ": %s with a non-zero distance" % status)
        options = given.get("options", {})
        near_points = options.get("near_points", False)
        check(("point_a" in out) == near_points and ("point_b" in out) == near_points,
              where + ": near points present iff asked")
        if near_points and status == "separated":
            gap = math.dist(out["point_a"], out["point_b"])
            check(abs(gap - out["distance"]) <= 1e-9, where + ": |point_b - point_a| != distance")
            check(abs(math.hypot(*out["normal"]) - 1) <= 1e-9, where + ": normal is not a unit vector")
        asked_bound = options.get("penetration") == "bound"
        in_contact = status in ("intersecting", "touching")
        check(("penetration_bound" in out) == (asked_bound and in_contact),
              where + ": penetration_bound present iff asked and in contact")
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
    check(touching["status"] in ("intersecting", "touching", "separated") and touching["distance"] <= 1e-12,
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


DEPTH_KEYS = ("signed_distance", "signed_distance_lower", "signed_distance_upper",
              "penetration_depth", "penetration_depth_lower", "penetration_depth_upper")


def check_depth(nearpoint):
    """`"penetration": "depth"` through the real binary: pairs whose depth is exact in double
    (dyadic sizes and offsets), each within the printed certified interval."""
    lines = [
        # spheres r 0.5 and 0.25, centres 0.625 apart: depth 0.125 along +x
        {"id": "spheres", "a": {"sphere": {}, "radius": 0.5},
         "b": {"sphere": {}, "radius": 0.25, "pose": {"translation": [0.625, 0, 0]}},
         "options": {"penetration": "depth"}, "depth": 0.125, "direction": [1, 0, 0]},
        # boxes half 0.5 and 0.25, face overlap 0.125 along x (0.625 along y, 0.6875 along z)
        {"id": "boxes", "a": {"box": [0.5, 0.5, 0.5]},
         "b": {"box": [0.25, 0.25, 0.25], "pose": {"translation": [0.625, 0.125, 0.0625]}},
         "options": {"penetration": "depth"}, "depth": 0.125, "direction": [1, 0, 0]},
        # sphere r 0.5 whose centre is 0.375 below a box's face z = -0.5: depth 0.125 along -z
        {"id": "sphere-box", "a": {"box": [0.5, 0.5, 0.5]},
         "b": {"sphere": {}, "radius": 0.5, "pose": {"translation": [0, 0, -0.875]}},
         "options": {"penetration": "depth"}, "depth": 0.125, "direction": [0, 0, -1]},
        # separated spheres 1.5 apart, with near points: the depth 0, witnesses the near points
        {"id": "apart", "a": {"sphere": {}, "radius": 1},
         "b": {"sphere": {}, "radius": 0.5, "pose": {"translation": [3, 0, 0]}},
         "options": {"penetration": "depth", "near_points": True}, "distance": 1.5},
        # without "depth": no depth keys
        {"id": "plain", "a": {"sphere": {}, "radius": 0.5},
         "b": {"sphere": {}, "radius": 0.25, "pose": {"translation": [0.625, 0, 0]}}},
    ]
    expected = {line["id"]: line for line in lines}
    given = "".join(json.dumps({k: v for k, v in line.items() if k in ("id", "a", "b", "options")}) + "\n"
                    for line in lines)
    result = run([nearpoint, "distance"], stdin=given)
    check(result.returncode == 0, "depth: exit code %d, stderr %s" % (result.returncode, result.stderr))
    outputs = [json.loads(line, parse_constant=reject_constant) for line in result.stdout.splitlines()]
    check(len(outputs) == len(lines), "depth: %d output lines for %d" % (len(outputs), len(lines)))
    for out in outputs:
        want = expected[out["id"]]
        where = "depth line %s (%s)" % (out["id"], json.dumps(out))
        if out["id"] == "plain":
            check(out["status"] == "intersecting", where + ": status")
            check(not any(key in out for key in DEPTH_KEYS), where + ": depth keys without depth")
            continue
        for key in DEPTH_KEYS + ("depth_termination", "depth_iterations"):
            check(key in out, where + ": missing " + key)
        check(out["depth_termination"] in ("closed_form", "tolerance", "iteration_limit", "degenerate"),
              where + ": depth_termination")
        lower, upper = out["penetration_depth_lower"], out["penetration_depth_upper"]
        s_lower, s_upper = out["signed_distance_lower"], out["signed_distance_upper"]
        if "depth" in want:
            depth = want["depth"]
            check(out["status"] == "intersecting", where + ": status")
            check(lower <= depth <= upper, where + ": the interval misses the exact depth %r" % depth)
            check(lower <= out["penetration_depth"] <= upper, where + ": estimate outside its interval")
            check(upper - lower <= 1e-9, where + ": interval wider than 1e-9")
            check(s_lower <= -depth <= s_upper < 0, where + ": signed interval")
            check(out["signed_distance"] == -out["penetration_depth"], where + ": signed != -depth")
            direction = out["depth_direction"]
            check(math.dist(direction, want["direction"]) <= 1e-9, where + ": direction")
            gap = [a - b for a, b in zip(out["depth_point_a"], out["depth_point_b"])]
            check(math.dist(gap, [out["penetration_depth"] * c for c in direction]) <= 1e-9,
                  where + ": depth_point_a - depth_point_b != depth * direction")
        else:
            check(out["status"] == "separated", where + ": status")
            check(out["penetration_depth"] == 0 and lower == 0 and upper == 0, where + ": depth 0")
            check(0 <= s_lower <= want["distance"] <= s_upper, where + ": signed interval")
            check(abs(out["signed_distance"] - out["distance"]) <= 1e-15, where + ": signed != distance")
            check(math.dist(out["depth_point_a"], out["point_a"]) == 0, where + ": witness a")
    print("depth lines OK: %d" % len(outputs))


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
    elif case == "depth":
        check_depth(nearpoint)
    else:
        fail(__doc__)


if __name__ == "__main__":
    main()
