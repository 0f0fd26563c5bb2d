#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""nearpoint_stream_demo against a real nearpointd on 127.0.0.1.

    check_stream_demo.py STREAM_DEMO NEARPOINTD

The demo finds the server through $NEARPOINT_TARGET (no --target), streams --updates 12, prints
one line per report and ends OK; the server's log shows the scene it created deleted again. Its
--help works, and a bad --updates is refused, naming the flag, before any call.
"""
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "common"))
from nearpointd_process import NearpointdProcess, loopback_env  # noqa: E402


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def main():
    demo, nearpointd = sys.argv[1:3]
    shown = subprocess.run([demo, "--help"], capture_output=True, text=True, timeout=30)
    if shown.returncode != 0 or "NEARPOINT_TARGET" not in shown.stdout:
        fail("--help: exit %d\n%s" % (shown.returncode, shown.stdout))
    refused = subprocess.run([demo, "--updates", "0"], capture_output=True, text=True, timeout=30,
                             env=dict(loopback_env(), NEARPOINT_TARGET="127.0.0.1:1"))
    if refused.returncode == 0 or "--updates" not in refused.stderr:
        fail("--updates 0 accepted: exit %d, %s" % (refused.returncode, refused.stderr))

    with NearpointdProcess(nearpointd) as server:
        ran = subprocess.run([demo, "--updates", "12"], capture_output=True, text=True,
                             env=server.client_env(), timeout=120)
        log = server.log()
    if ran.returncode != 0:
        fail("exit %d\n%s%s" % (ran.returncode, ran.stdout, ran.stderr))
    reports = [line for line in ran.stdout.splitlines() if line.startswith("seq ")]
    if len(reports) != 12 or "stream ended: OK" not in ran.stdout:
        fail("expected 12 reports and 'stream ended: OK':\n" + ran.stdout)
    created = re.findall(r"event=scene_created.*?scene=(\S+)", log)
    deleted = re.findall(r"event=scene_deleted.*?scene=(\S+)", log)
    if len(created) != 1 or created != deleted:
        fail("scenes created %s, deleted %s; server log:\n%s" % (created, deleted, log))
    print("ok: 12 reports through $NEARPOINT_TARGET, scene %s deleted" % created[0])


if __name__ == "__main__":
    main()
