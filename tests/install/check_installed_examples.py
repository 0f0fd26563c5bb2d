#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The installed examples work from the install prefix alone.

    check_installed_examples.py CMAKE BUILD_DIR WORK_DIR MAN_PAGES(ON|OFF)

Installs the build into WORK_DIR/prefix with `cmake --install`, starts PREFIX/bin/nearpointd on
127.0.0.1 (preloading the installed dds_scene.json, as the container does), and runs
PREFIX/bin/nearpoint on every file of PREFIX/share/nearpoint/examples from a directory outside
the source tree, so that a path naming the source tree (../tests/data/...) fails. Every installed
example must be used here: a new one without a run below fails the test. With MAN_PAGES=ON the
man pages must be installed too.
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "common"))
from nearpointd_process import NearpointdProcess  # noqa: E402


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    cmake, build, work, man_pages = sys.argv[1:]
    subprocess.run(["rm", "-rf", work], check=True)
    os.makedirs(work)
    prefix = os.path.join(work, "prefix")
    installed = subprocess.run([cmake, "--install", build, "--prefix", prefix],
                               capture_output=True, text=True)
    if installed.returncode != 0:
        fail("cmake --install: " + installed.stderr)
    bindir = os.path.join(prefix, "bin")
    examples = os.path.join(prefix, "share", "nearpoint", "examples")
    nearpoint = os.path.join(bindir, "nearpoint")
    run_dir = os.path.join(work, "elsewhere")  # not the source tree, not the prefix
    os.makedirs(run_dir)

    if man_pages == "ON":
        for page in ("nearpoint.1", "nearpointd.1"):
            if not os.path.isfile(os.path.join(prefix, "share", "man", "man1", page)):
                fail("share/man/man1/%s not installed" % page)

    used = set()

    def example(name):
        path = os.path.join(examples, name)
        if not os.path.isfile(path):
            fail("examples/%s is not installed" % name)
        used.add(name)
        return path

    def run(args, env, expect_lines=None):
        result = subprocess.run([nearpoint] + args, capture_output=True, text=True, env=env,
                                cwd=run_dir, timeout=120)
        shown = "nearpoint " + " ".join(os.path.relpath(a, prefix) if a.startswith(prefix) else a
                                        for a in args)
        if result.returncode != 0:
            fail("%s exited %d:\n%s%s" % (shown, result.returncode, result.stdout, result.stderr))
        print("ok: " + shown)
        if expect_lines is not None and len(result.stdout.splitlines()) != expect_lines:
            fail("%s printed %d lines, expected %d:\n%s"
                 % (shown, len(result.stdout.splitlines()), expect_lines, result.stdout))
        return result.stdout

    # The engine alone: one answer per line, the deliberately bad line answered with an error.
    pairs = example("pairs.jsonl")
    with open(pairs) as f:
        lines = [line for line in f if line.strip()]
    answers = [json.loads(line) for line in run(["distance", pairs], os.environ, len(lines))
               .splitlines()]
    if [a["status"] == "error" for a in answers].count(True) != 1:
        fail("pairs.jsonl: expected exactly one error answer (bad-quaternion): %s" % answers)

    nearpointd = os.path.join(bindir, "nearpointd")
    with NearpointdProcess(nearpointd, ["--scene", example("dds_scene.json")]) as server:
        env = server.client_env()
        # The mesh beside the scene file, registered alone and through the scene.
        registered = run(["register", example("cube.obj")], env, 1)
        if not registered.startswith("geom-"):
            fail("register printed no geometry id: " + registered)
        created = run(["scene", "create", example("scene.json")], env, 1)
        if not created.startswith("cell-1:"):
            fail("scene create: " + created)
        run(["query", "cell-1", "--pose", "gripper=0,0,0.3"], env)
        run(["stream", "cell-1", example("trajectory.csv")], env)
        # The scene nearpointd preloaded from the installed file, and its trajectory.
        reports = run(["stream", "dds-demo", example("dds_trajectory.jsonl"), "--json"], env)
        with open(example("dds_trajectory.jsonl")) as f:
            steps = len([line for line in f if line.strip()])
        if len(reports.splitlines()) != steps:
            fail("dds-demo: %d reports for %d steps" % (len(reports.splitlines()), steps))

    unused = set(os.listdir(examples)) - used
    if unused:
        fail("installed examples this test does not run: %s (add them here)" % sorted(unused))
    print("OK: every installed example runs from %s" % prefix)


if __name__ == "__main__":
    main()
