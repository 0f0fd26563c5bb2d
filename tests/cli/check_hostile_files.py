#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Hostile input through the real binaries (issue 21, item 13; standard library only).

    check_hostile_files.py NEARPOINT NEARPOINTD SCRATCH_DIR

- `nearpoint distance`: a line whose id is nested 100,000 deep gets an error line and the next
  line is still answered (it overflowed the stack and killed the process).
- `nearpoint scene create FILE` and `nearpointd --scene FILE`, for a JSON scene with a "group"
  nested 100,000 deep, a JSON scene holding 1e999, a YAML alias that contains itself, a 600-byte
  YAML "billion laughs" and YAML nested 100,000 deep: each exits with a non-zero status (not a
  signal) and a short message naming the file, instead of crashing, aborting on an uncaught
  exception or growing past 6 GB.

Children run with a 2 GiB address-space limit and a timeout, so a regression fails here instead of
exhausting the machine. nearpointd listens on 127.0.0.1 only; `scene create` targets 127.0.0.1:1
but fails on the file before any connection. Exits non-zero with a message on the first failure.
"""
import json
import os
import resource
import subprocess
import sys

from cli_checks import check, fail

LIMIT_BYTES = 2 << 30
SPHERES = '"a": {"sphere": {}, "radius": 1}, "b": {"sphere": {}, "radius": 0.5, "pose": {"translation": [3, 0, 0]}}'


def address_sanitized(binary):
    """Whether `binary` was built with ASan, whose shadow memory alone exceeds any address-space
    limit: such a binary gets ASan's own resident-memory limit instead."""
    with open(binary, "rb") as f:
        return b"__asan_init" in f.read()


SANITIZED = False


def limit_memory():
    if not SANITIZED:
        resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))


def run(args, stdin=None):
    env = None
    if SANITIZED:
        env = dict(os.environ)
        env["ASAN_OPTIONS"] = (env.get("ASAN_OPTIONS", "") + ":hard_rss_limit_mb=%d"
                               % (LIMIT_BYTES >> 20)).lstrip(":")
    return subprocess.run(args, input=stdin, capture_output=True, text=True, timeout=60,
                          preexec_fn=limit_memory, errors="replace", env=env)


def check_distance(nearpoint):
    deep_id = '{"id": ' + "[" * 100000 + "]" * 100000 + ", " + SPHERES + "}"
    result = run([nearpoint, "distance"], stdin=deep_id + "\n{" + SPHERES + "}\n")
    check(result.returncode == 0, "distance: exit status %d, stderr: %s"
          % (result.returncode, result.stderr[:300]))
    lines = result.stdout.splitlines()
    check(len(lines) == 2, "distance: %d output lines for 2 input lines" % len(lines))
    first, second = json.loads(lines[0]), json.loads(lines[1])
    check(first["status"] == "error" and "nesting deeper than 64 levels" in first["message"],
          "distance: the nested line's answer is " + lines[0][:300])
    check(len(lines[0]) < 400, "distance: the error line is %d bytes long" % len(lines[0]))
    check(second["status"] == "separated", "distance: the next line's answer is " + lines[1][:300])
    print("distance OK")


def hostile_scenes(scratch):
    box = '{"geometries": {"g": {"box": [1, 1, 1]}},\n"objects": [{"id": "a", "geometry": "g",\n'
    laughs = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n"
    for level in range(1, 10):
        alias = "*a%d" % (level - 1)
        laughs += "a%d: &a%d [%s]\n" % (level, level, ", ".join([alias] * 10))
    files = {
        "nested-group.json": box + '"group": ' + "[" * 100000 + "1" + "]" * 100000 + "}]}",
        "huge-number.json": box + '"pose": {"translation": [1e999, 0, 0]}}]}',
        "self-alias.yaml": "id: x\na: &a [*a]\n",
        "billion-laughs.yaml": laughs,
        "nested.yaml": "id: x\ngroup: " + "[" * 100000 + "1" + "]" * 100000 + "\n",
    }
    paths = []
    for name, text in files.items():
        path = os.path.join(scratch, "hostile-%d-%s" % (os.getpid(), name))
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        paths.append(path)
    return paths


def check_refused(what, result, path):
    output = result.stdout + result.stderr
    check(result.returncode > 0, "%s %s: exit status %d (negative: killed by a signal); output: %s"
          % (what, os.path.basename(path), result.returncode, output[:300]))
    check(path in output, "%s %s: the message does not name the file: %s"
          % (what, os.path.basename(path), output[:300]))
    check("terminate called" not in output, "%s %s: an uncaught exception: %s"
          % (what, os.path.basename(path), output[:300]))
    check(len(output) < 1500, "%s %s: %d bytes of output (a dumped value?)"
          % (what, os.path.basename(path), len(output)))


def check_scenes(nearpoint, nearpointd, scratch):
    paths = hostile_scenes(scratch)
    try:
        for path in paths:
            check_refused("nearpoint scene create",
                          run([nearpoint, "scene", "create", path, "--target", "127.0.0.1:1"]), path)
            check_refused("nearpointd --scene",
                          run([nearpointd, "--listen", "127.0.0.1:0", "--scene", path]), path)
    finally:
        for path in paths:
            os.remove(path)
    print("scene files OK")


def main():
    if len(sys.argv) != 4:
        fail(__doc__)
    nearpoint, nearpointd, scratch = sys.argv[1:]
    global SANITIZED
    SANITIZED = address_sanitized(nearpoint) or address_sanitized(nearpointd)
    check_distance(nearpoint)
    check_scenes(nearpoint, nearpointd, scratch)


if __name__ == "__main__":
    main()
