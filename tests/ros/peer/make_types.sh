#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The types of tests/ros/peer (a plain Cyclone DDS participant standing in for a ROS 2 node),
# made the way ROS 2 makes them and independently of nearpoint's own generator
# (ros/generate_dds_idl.py): Debian's `rosidl translate` turns each .msg file into rosidl's IDL,
# kept file by file with its includes and annotations; the only change is the name mangling
# rmw_cyclonedds applies to a ROS 2 type (module pkg::msg gains a module dds_, every message
# struct Name becomes Name_), done here with sed; idlc compiles each file.
#   make_types.sh REPO_DIR OUT_DIR   -> OUT_DIR/ros_peer_types.c (#includes every generated .c)
set -euo pipefail
repo=$1
out=$2
rm -rf "$out/idl" "$out/gen"
mkdir -p "$out/idl" "$out/gen"
for dir in "$repo"/ros/standard/* "$repo"/ros/nearpoint_msgs; do
  package=$(basename "$dir")
  (cd "$dir" && rosidl translate --to idl -o "$out/rosidl/$package" "$package" \
     $(ls msg/*.msg | sed "s|^|$dir:|") >/dev/null)
  for idl in "$out/rosidl/$package"/msg/*.idl; do
    mkdir -p "$out/idl/$package/msg"
    # module msg { ... };  ->  module msg { module dds_ { ... }; };  (any "};" closes the
    # innermost module, so the extra one goes at the end); struct Name -> Name_; every
    # reference pkg::msg::Name -> pkg::msg::dds_::Name_. rosidl's files have no include guards
    # (its generators read each file alone); idlc reads the includes, so guards are added.
    guard=$(echo "${package}_$(basename "$idl" .idl)_IDL" | tr '[:lower:]' '[:upper:]')
    {
      echo "#ifndef $guard"
      echo "#define $guard"
      sed -E -e 's/^(\s*)module msg \{/\1module msg { module dds_ {/' \
             -e 's/^(\s*)struct ([A-Za-z0-9]+) \{/\1struct \2_ {/' \
             -e 's/\b([a-z_]+)::msg::([A-Za-z0-9]+)\b/\1::msg::dds_::\2_/g' "$idl"
      echo "};"
      echo "#endif"
    } > "$out/idl/$package/msg/$(basename "$idl")"
  done
done
: > "$out/ros_peer_types.c.tmp"
for idl in "$out"/idl/*/msg/*.idl; do
  rel=${idl#"$out/idl/"}
  mkdir -p "$out/gen/$(dirname "$rel")"
  # idlc skips rosidl's @verbatim comments, warning about each: only its errors are shown.
  idlc -x final -I "$out/idl" -o "$out/gen/$(dirname "$rel")" "$idl" 2>&1 |
    { grep -v -e "@verbatim is currently not supported" -e "Explicit defaults are not supported" >&2 || true; }
  test -f "$out/gen/$(dirname "$rel")/$(basename "$rel" .idl).c"
  echo "#include \"$(dirname "$rel")/$(basename "$rel" .idl).c\"" >> "$out/ros_peer_types.c.tmp"
done
mv "$out/ros_peer_types.c.tmp" "$out/ros_peer_types.c"
