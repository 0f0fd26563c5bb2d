#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes PROGRAM's man page from its --help with help2man, at build time.

    man_page.py HELP2MAN PROGRAM VERSION NAME_LINE SEE_ALSO OUTPUT

help2man turns the top-level --help into NAME, SYNOPSIS, DESCRIPTION and the options. A CLI11
program with subcommands says little at the top, so every subcommand's --help (found by walking
the "Subcommands:" lists, nested ones too) goes into a COMMANDS section through help2man's
--include, verbatim. The environment is cleared of NEARPOINT_* so that defaults shown in a help
text (a --target taken from $NEARPOINT_TARGET) are the program's, not the build machine's.
"""
import os
import subprocess
import sys
import tempfile


def help_text(program, path, env):
    result = subprocess.run([program, *path, "--help"], capture_output=True, text=True, env=env,
                            timeout=60)
    if result.returncode != 0:
        sys.exit("man_page.py: %s %s --help exited %d: %s"
                 % (program, " ".join(path), result.returncode, result.stderr.strip()))
    return result.stdout


def subcommands(text):
    """The names listed under CLI11's "Subcommands:" heading."""
    names, inside = [], False
    for line in text.splitlines():
        if line.strip().lower() == "subcommands:":
            inside = True
            continue
        if inside:
            if not line.startswith("  ") or not line.strip():
                break
            names.append(line.split()[0])
    return names


def roff_verbatim(text):
    """Text shown as is in a .nf block: backslashes escaped, control characters neutralised."""
    out = []
    for line in text.rstrip("\n").splitlines():
        line = line.replace("\\", "\\e")
        if line.startswith((".", "'")):
            line = "\\&" + line
        out.append(line)
    return "\n".join(out)


def main():
    if len(sys.argv) != 7:
        sys.exit(__doc__)
    help2man, program, version, name_line, see_also, output = sys.argv[1:]
    env = {k: v for k, v in os.environ.items() if not k.startswith("NEARPOINT_")}
    env["COLUMNS"] = "100"
    prog = os.path.basename(program)

    sections = []
    pending = [[name] for name in subcommands(help_text(program, [], env))]
    while pending:
        path = pending.pop(0)
        text = help_text(program, path, env)
        sections.append('.SS "%s %s"\n.nf\n%s\n.fi\n' % (prog, " ".join(path), roff_verbatim(text)))
        pending[0:0] = [path + [name] for name in subcommands(text)]

    include = ""
    if sections:
        include += "[COMMANDS]\nEach command's own --help:\n" + "".join(sections)
    include += "[SEE ALSO]\n" + ", ".join("\\fB%s\\fR(1)" % n for n in see_also.split(",") if n)
    include += "\n"

    # The project's version (CMake's project(VERSION)), given rather than probed, so that the page
    # does not depend on how each binary words its --version.
    args = [help2man, "--no-info", "--name", name_line, "--version-string", version,
            "--output", output]
    with tempfile.NamedTemporaryFile("w", suffix=".h2m", delete=False) as f:
        f.write(include)
        include_path = f.name
    try:
        result = subprocess.run(args + ["--include", include_path, program], env=env,
                                capture_output=True, text=True, timeout=120)
    finally:
        os.unlink(include_path)
    if result.returncode != 0:
        sys.exit("man_page.py: help2man failed for %s: %s" % (program, result.stderr.strip()))


if __name__ == "__main__":
    main()
