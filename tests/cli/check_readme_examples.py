#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The README's runnable examples print what the README shows.

    check_readme_examples.py README BIN_DIR... [--nearpointd PATH]

A fenced ```sh block right after the line `<!-- test: run -->` is run, in document order, by
bash (-e -o pipefail) from the README's directory, with every BIN_DIR first on PATH (so
`nearpoint` is the build's), against one nearpointd started here on 127.0.0.1
(NEARPOINT_TARGET points at it; Cyclone DDS on loopback). If a fenced block follows it directly,
that is the block's expected standard output; without one the block must just succeed.

Comparison, line by line after normalising both sides (things that vary between runs):
  - durations ("711 µs", "0.138 s", "4.246e+04 µs", "3 ms") become "<time> UNIT";
  - server-chosen scene ids (s-<hex>) become "s-<id>", ports after 127.0.0.1: become "<port>";
  - error bounds ("± 4.7e-15", "error_bound":1.01e-14) become "<bound>": they move in the last
    bits with the engine and the target CPU, and tests/oracle holds them to the truth;
  - in the README, "…" stands for any text within a line and a line "..." for any lines.
Everything else (distances, near points, content ids, counts, words) must match exactly.
"""
import argparse
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "common"))
from nearpointd_process import NearpointdProcess, loopback_env  # noqa: E402

MARKER = "<!-- test: run -->"
FENCE = re.compile(r"^(```+|~~~+)\s*([\w+-]*)\s*$")
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
NORMALISE = [
    (re.compile(r"(±\s*)" + NUMBER), r"\1<bound>"),
    (re.compile(r'("error_bound":\s*)' + NUMBER), r"\1<bound>"),
    (re.compile(NUMBER + r"(\s*)(µs|us|ms|s)\b"), r"<time>\1\2"),
    (re.compile(r"\bs-[0-9a-f]{6,}\b"), "s-<id>"),
    (re.compile(r"(127\.0\.0\.1|localhost):\d+"), r"\1:<port>"),
]


def normalise(line):
    for pattern, replacement in NORMALISE:
        line = pattern.sub(replacement, line)
    return line.rstrip()


def fences(lines, start):
    """(language, body lines, index after the closing fence) of the block opening at `start`."""
    opening = FENCE.match(lines[start])
    if not opening:
        return None
    fence = opening.group(1)
    for end in range(start + 1, len(lines)):
        if lines[end].strip() == fence:
            return opening.group(2), lines[start + 1:end], end + 1
    raise SystemExit("README line %d: unclosed fence" % (start + 1))


def examples(readme_lines):
    """[(line number, commands, expected lines or None)] for every marked block."""
    found = []
    for i, line in enumerate(readme_lines):
        if line.strip() != MARKER:
            continue
        j = i + 1
        block = fences(readme_lines, j) if j < len(readme_lines) else None
        if block is None or block[0] not in ("sh", "bash", "shell"):
            raise SystemExit("README line %d: %s must be followed by a ```sh block"
                             % (i + 1, MARKER))
        _, commands, after = block
        expected = None
        if after < len(readme_lines) and FENCE.match(readme_lines[after]):
            language, expected, _ = fences(readme_lines, after)
            if language in ("sh", "bash", "shell"):
                expected = None  # the next commands, not an output
        found.append((j + 1, "\n".join(commands), expected))
    return found


def line_matches(expected, actual):
    parts = [re.escape(part) for part in normalise(expected).split("…")]
    return re.fullmatch(".*".join(parts), normalise(actual)) is not None


def matches(expected, actual):
    """Whether the lines `actual` are shown by `expected` ("..." lines match any lines)."""
    if not expected:
        return not actual
    if expected[0].strip() == "...":
        return any(matches(expected[1:], actual[k:]) for k in range(len(actual) + 1))
    return bool(actual) and line_matches(expected[0], actual[0]) and matches(expected[1:],
                                                                              actual[1:])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("readme")
    parser.add_argument("bin_dirs", nargs="+")
    parser.add_argument("--nearpointd", required=True)
    args = parser.parse_args()
    with open(args.readme, encoding="utf-8") as f:
        readme_lines = f.read().splitlines()
    blocks = examples(readme_lines)
    if not blocks:
        print("FAIL: no block in %s is marked %s" % (args.readme, MARKER), file=sys.stderr)
        return 1
    failures = 0
    with NearpointdProcess(args.nearpointd) as server:
        env = server.client_env(loopback_env())
        env["PATH"] = os.pathsep.join([os.path.abspath(d) for d in args.bin_dirs] +
                                      [env.get("PATH", "")])
        for line_number, commands, expected in blocks:
            result = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", commands],
                                    capture_output=True, text=True, env=env, timeout=300,
                                    cwd=os.path.dirname(os.path.abspath(args.readme)))
            where = "README line %d" % line_number
            if result.returncode != 0:
                print("FAIL: %s: exit %d\n%s\n--- stderr:\n%s" % (where, result.returncode,
                                                                  commands, result.stderr))
                failures += 1
            elif expected is not None and not matches(expected, result.stdout.splitlines()):
                print("FAIL: %s: the output is not the README's\n--- README shows:\n%s\n"
                      "--- the commands print:\n%s" % (where, "\n".join(expected),
                                                       result.stdout.rstrip()))
                failures += 1
            else:
                print("ok: %s (%s)" % (where, "output checked" if expected is not None
                                       else "ran"))
    print("%d of %d README examples as shown" % (len(blocks) - failures, len(blocks)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
