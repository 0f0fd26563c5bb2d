#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""The DDS IDL of nearpoint's ROS 2 topics, generated from the .msg files under ros/.

    generate_dds_idl.py --output FILE.idl PACKAGE_DIR...

Each package's .msg files are translated by Debian's `rosidl translate --to idl` (the step every
ROS 2 build runs first), parsed by rosidl_parser, and written as one IDL file in the form
ROS 2's rmw_cyclonedds puts on the wire: every message `pkg/msg/Name` becomes the struct
`pkg::msg::dds_::Name_` (the DDS type name ROS 2 matches on), its fields in .msg order, with no
key, no @optional and no annotations, so that idlc (with final extensibility) makes keyless
types serialised as plain XCDR1. The structs come in dependency order. The bridge's types are
therefore the .msg files themselves: they cannot drift apart.

A fixed-size array is declared through the typedef rosidl's IDL gives it (`uint8[16] guid`
becomes `typedef uint8 uint8__16[16];` beside the struct and `uint8__16 guid;`), not as a plain
array: the wire bytes are the same, but the typedef is part of the type's XTypes identity
(its TypeIdentifier, and an alias in the TypeObject), and a peer whose types idlc made from
rosidl's IDL matches a writer only when those agree.
"""
import argparse
import pathlib
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ElementTree

from rosidl_parser import definition
from rosidl_parser.parser import parse_idl_file


def package_name(package_dir: pathlib.Path) -> str:
    name = ElementTree.parse(package_dir / "package.xml").getroot().findtext("name")
    if not name:
        sys.exit(f"generate_dds_idl.py: {package_dir}/package.xml names no package")
    return name.strip()


def translate(package_dir: pathlib.Path, out_dir: pathlib.Path) -> list[pathlib.Path]:
    """The rosidl IDL of the package's messages, by `rosidl translate`."""
    name = package_name(package_dir)
    messages = sorted(p.relative_to(package_dir) for p in (package_dir / "msg").glob("*.msg"))
    if not messages:
        sys.exit(f"generate_dds_idl.py: {package_dir}/msg holds no .msg file")
    target = out_dir / name
    subprocess.run(
        ["rosidl", "translate", "--to", "idl", "-o", str(target), name]
        + [f"{package_dir}:{m}" for m in messages],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return [target / m.with_suffix(".idl") for m in messages]


def dds_name(namespaced: definition.NamespacedType) -> str:
    return "::".join(list(namespaced.namespaces) + ["dds_", namespaced.name + "_"])


def scalar(t) -> str:
    if isinstance(t, definition.BasicType):
        return t.typename
    if isinstance(t, definition.NamespacedType):
        return dds_name(t)
    if isinstance(t, definition.UnboundedString):
        return "string"
    if isinstance(t, definition.BoundedString):
        return f"string<{t.maximum_size}>"
    if isinstance(t, definition.UnboundedWString):
        return "wstring"
    if isinstance(t, definition.BoundedWString):
        return f"wstring<{t.maximum_size}>"
    raise SystemExit(f"generate_dds_idl.py: unsupported type {t!r}")


def array_typedefs(t: definition.Array) -> list[tuple[str, str]]:
    """The typedefs rosidl's IDL declares for an array member, as (name, declaration), the
    array's own last; the name and spelling are rosidl_adapter's (resource/struct.idl.em)."""
    value = t.value_type
    if isinstance(value, definition.NamespacedType):
        # rosidl: typedef pkg::msg::Name pkg__msg__Name; (pkg::msg::Name is pkg::msg::dds_::Name_
        # on the wire, as everywhere else in this file).
        base = "__".join(list(value.namespaces) + [value.name])
        out = [(base, f"typedef {dds_name(value)} {base};")]
    else:
        base = scalar(value)
        out = []
    name = f"{base.replace('<', '__').replace('>', '')}__{t.size}"
    out.append((name, f"typedef {base} {name}[{t.size}];"))
    return out


def member(m: definition.Member) -> str:
    t = m.type
    if isinstance(t, definition.Array):
        return f"{array_typedefs(t)[-1][0]} {m.name};"
    if isinstance(t, definition.BoundedSequence):
        return f"sequence<{scalar(t.value_type)}, {t.maximum_size}> {m.name};"
    if isinstance(t, definition.UnboundedSequence):
        return f"sequence<{scalar(t.value_type)}> {m.name};"
    return f"{scalar(t)} {m.name};"


def dependencies(message: definition.Message) -> list[tuple]:
    out = []
    for m in message.structure.members:
        t = m.type
        if isinstance(t, definition.AbstractNestedType):
            t = t.value_type
        if isinstance(t, definition.NamespacedType):
            out.append(tuple(t.namespaces) + (t.name,))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", required=True, type=pathlib.Path)
    parser.add_argument("packages", nargs="+", type=pathlib.Path)
    args = parser.parse_args()

    messages: dict[tuple, definition.Message] = {}
    sources: list[str] = []
    with tempfile.TemporaryDirectory() as scratch:
        for package_dir in args.packages:
            package_dir = package_dir.resolve()
            for idl in translate(package_dir, pathlib.Path(scratch)):
                base = pathlib.Path(scratch)
                tree = parse_idl_file(definition.IdlLocator(base, idl.relative_to(base)))
                for message in tree.content.get_elements_of_type(definition.Message):
                    if message.constants:
                        sys.exit(f"generate_dds_idl.py: {idl}: constants are not supported")
                    t = message.structure.namespaced_type
                    messages[tuple(t.namespaces) + (t.name,)] = message
                    sources.append("/".join(list(t.namespaces) + [t.name]))

    ordered: list[tuple] = []
    visiting: set[tuple] = set()

    def visit(key: tuple) -> None:
        if key in ordered:
            return
        if key not in messages:
            sys.exit(f"generate_dds_idl.py: {'/'.join(key)} is used but no package given defines it")
        if key in visiting:
            sys.exit(f"generate_dds_idl.py: {'/'.join(key)} contains itself")
        visiting.add(key)
        for dependency in dependencies(messages[key]):
            visit(dependency)
        ordered.append(key)

    for key in sorted(messages):
        visit(key)

    lines = [
        "// Generated by ros/generate_dds_idl.py from the .msg files of "
        + ", ".join(sorted({k[0] for k in ordered}))
        + " (via rosidl translate); do not edit.",
        "// Each ROS 2 message pkg/msg/Name is the keyless struct pkg::msg::dds_::Name_, as on",
        "// ROS 2's rmw_cyclonedds.",
        "",
    ]
    declared: dict[tuple, str] = {}  # (module..., typedef name) -> its declaration
    for key in ordered:
        message = messages[key]
        namespaces = list(message.structure.namespaced_type.namespaces) + ["dds_"]
        lines.append(" ".join(f"module {n} {{" for n in namespaces))
        # Once per module: rosidl declares a typedef in every message that uses it, each file
        # compiled alone; here every message shares one file.
        for m in message.structure.members:
            if not isinstance(m.type, definition.Array):
                continue
            for name, declaration in array_typedefs(m.type):
                scoped = tuple(namespaces) + (name,)
                if scoped not in declared:
                    declared[scoped] = declaration
                    lines.append(declaration)
                elif declared[scoped] != declaration:
                    sys.exit(f"generate_dds_idl.py: {'::'.join(scoped)} declared twice, differently")
        lines.append(f"struct {key[-1]}_ {{")
        lines.extend("  " + member(m) for m in message.structure.members)
        lines.append("};")
        lines.append(" ".join("};" for _ in namespaces))
        lines.append("")
    text = "\n".join(lines)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    if not args.output.exists() or args.output.read_text() != text:
        args.output.write_text(text)


if __name__ == "__main__":
    main()
