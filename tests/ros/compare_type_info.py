#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""nearpointd's DDS types against ROS 2's, as XTypes sees them.

    compare_type_info.py OURS.c PEER_GEN_DIR

OURS.c is idlc's output for nearpoint's IDL (ros/generate_dds_idl.py); PEER_GEN_DIR holds idlc's
output for rosidl's own IDL of the same .msg files (tests/ros/peer/make_types.sh). Each topic
descriptor carries its type's XTypes type information (minimal and complete type identifiers,
with those of every type it depends on) and type map (the type objects). A remote reader matches
our writer at once only if they are equal; otherwise Cyclone DDS looks the types up and decides
by assignability, which failed for DistanceReportBatch while DistanceReport's writer_guid was a
plain array (rosidl's IDL declares the typedef uint8__16). Checked: every type of ours exists in
the peer's files and both blobs are byte for byte the same. Exit 1 naming each type that differs.
"""
import pathlib
import re
import sys

BLOB = re.compile(
    r"#define (TYPE_(?:INFO|MAP)_CDR_\w+) \(unsigned char \[\]\)\{ \\\n(.*?)\n\}", re.S
)


def blobs(path: pathlib.Path) -> dict[str, str]:
    """Macro name -> its bytes as written by idlc (whitespace removed)."""
    return {m.group(1): re.sub(r"\s|\\", "", m.group(2)) for m in BLOB.finditer(path.read_text())}


def main() -> int:
    ours = blobs(pathlib.Path(sys.argv[1]))
    peer: dict[str, str] = {}
    for generated in sorted(pathlib.Path(sys.argv[2]).glob("*/msg/*.c")):
        peer.update(blobs(generated))
    if not ours:
        print(f"no type information found in {sys.argv[1]}")
        return 1
    problems = []
    for macro, data in sorted(ours.items()):
        if macro not in peer:
            problems.append(f"{macro}: not in the peer's types")
        elif peer[macro] != data:
            problems.append(f"{macro}: differs from the peer's")
    types = len({m.split("_CDR_", 1)[1] for m in ours})
    for problem in problems:
        print(problem)
    print(f"{types} types, {len(ours)} blobs compared, {len(problems)} differ")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
