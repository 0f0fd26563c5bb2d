#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The man pages made at build time (cmake/man_page.py) say what the programs' --help says.

    check_man_pages.py MAN_DIR PROGRAM...

For each PROGRAM: MAN_DIR/<name>.1 exists, has a NAME line and a COMMANDS subsection per
subcommand (nested ones too), and names every long option that PROGRAM's and its subcommands'
--help list; `man -l --warnings` formats it without a warning. The lists come from the programs
at test time, so a new flag or command that the page lacks fails here.
"""
import os
import re
import shutil
import subprocess
import sys

OPTION = re.compile(r"^\s+(?:-\w,)?(--[a-z][a-z0-9-]*)")


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def help_text(program, path):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NEARPOINT_")}
    result = subprocess.run([program, *path, "--help"], capture_output=True, text=True, env=env,
                            timeout=60)
    if result.returncode != 0:
        fail("%s %s --help exited %d" % (program, " ".join(path), result.returncode))
    return result.stdout


def subcommands(text):
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


def check(man_dir, program):
    name = os.path.basename(program)
    page_path = os.path.join(man_dir, name + ".1")
    if not os.path.isfile(page_path):
        fail("%s not generated" % page_path)
    with open(page_path, encoding="utf-8") as f:
        raw = f.read()
    page = raw.replace("\\-", "-").replace("\\e", "\\")
    if not re.search(r'^\.TH "?%s"? "?1"?' % name.upper(), raw, re.M):
        fail("%s: no .TH %s 1 header" % (page_path, name.upper()))
    if not re.search(r"^\.SH NAME\n%s - \S" % re.escape(name), page, re.M):
        fail("%s: no NAME line" % page_path)

    options, commands = set(), []
    pending = [[]]
    while pending:
        path = pending.pop(0)
        text = help_text(program, path)
        if path:
            commands.append(" ".join(path))
        options.update(m.group(1) for line in text.splitlines() if (m := OPTION.match(line)))
        pending.extend(path + [sub] for sub in subcommands(text))
    missing = sorted(o for o in options if o not in page)
    if missing:
        fail("%s lacks options its --help lists: %s" % (page_path, missing))
    for command in commands:
        if '.SS "%s %s"' % (name, command) not in page:
            fail("%s has no section for '%s %s'" % (page_path, name, command))
    if shutil.which("man"):
        rendered = subprocess.run(["man", "--warnings", "-l", page_path], capture_output=True,
                                  text=True, env=dict(os.environ, MANPAGER="cat", MANWIDTH="100"))
        if rendered.returncode != 0 or rendered.stderr.strip():
            fail("man -l %s: exit %d, %s" % (page_path, rendered.returncode, rendered.stderr))
    print("ok: %s: %d options, %d commands" % (page_path, len(options), len(commands)))


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    for program in sys.argv[2:]:
        check(sys.argv[1], program)


if __name__ == "__main__":
    main()
