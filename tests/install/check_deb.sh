#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# cpack -G DEB on this build (issue 23, item 5): the runtime package holds nearpointd and the CLI
# and depends on the shared libraries they link; the -dev package holds the headers, the CMake
# package and the pkg-config file, and depends on the -dev packages a consumer compiles against.
# Usage: check_deb.sh CPACK BUILD_DIR WORK_DIR
set -euo pipefail
cpack_bin="$1" build="$2" work="$3"
rm -rf "$work"
mkdir -p "$work"
"$cpack_bin" -G DEB --config "$build/CPackConfig.cmake" -B "$work" >"$work/cpack.log" ||
  { cat "$work/cpack.log"; exit 1; }
runtime=$(ls "$work"/nearpoint_*.deb)
dev=$(ls "$work"/nearpoint-dev_*.deb)

fail() { echo "FAIL: $*"; exit 1; }
contents() { dpkg-deb -c "$1" | awk '{print $6}'; }
contents "$runtime" | grep -qx './usr/bin/nearpointd' || fail "nearpointd not in $runtime"
contents "$runtime" | grep -qx './usr/bin/nearpoint' || fail "the CLI not in $runtime"
# The examples with the mesh scene.json names, and the man pages when the build made them.
for file in share/nearpoint/examples/scene.json share/nearpoint/examples/cube.obj; do
  contents "$runtime" | grep -qx "./usr/$file" || fail "/usr/$file not in $runtime"
done
for page in nearpoint nearpointd; do
  if [[ -f "$build/man/$page.1" ]]; then
    contents "$runtime" | grep -qx "./usr/share/man/man1/$page.1" || fail "$page.1 not in $runtime"
  fi
done
contents "$dev" | grep -qx './usr/include/nearpoint/distance.hpp' || fail "headers not in $dev"
contents "$dev" | grep -q '/usr/lib/.*cmake/nearpoint/nearpoint-config.cmake' ||
  fail "CMake package not in $dev"
# The licence: each package carries LICENSE, NOTICE and a machine-readable copyright file.
for pair in "$runtime:nearpoint" "$dev:nearpoint-dev"; do
  deb="${pair%%:*}" doc="./usr/share/doc/${pair##*:}"
  for file in copyright LICENSE NOTICE THIRD_PARTY_NOTICES.md; do
    contents "$deb" | grep -qx "$doc/$file" || fail "$doc/$file not in $deb"
  done
done
# One version: the packages' is what the packaged nearpointd prints (project(VERSION) for both).
version=$("$build/server/nearpointd" --version | awk '{print $2}')
for deb in "$runtime" "$dev"; do
  [[ "$(dpkg-deb -f "$deb" Version)" == "$version" ]] ||
    fail "$deb has Version $(dpkg-deb -f "$deb" Version), nearpointd --version says $version"
done
depends=$(dpkg-deb -f "$runtime" Depends)
echo "nearpoint Depends: $depends"
for lib in libgrpc++ libprotobuf libc6; do
  grep -q "$lib" <<<"$depends" || fail "$runtime does not depend on $lib"
done
dev_depends=$(dpkg-deb -f "$dev" Depends)
echo "nearpoint-dev Depends: $dev_depends"
grep -q 'libeigen3-dev' <<<"$dev_depends" || fail "$dev does not depend on libeigen3-dev"
echo "OK: $(basename "$runtime") $(du -h "$runtime" | cut -f1), $(basename "$dev") $(du -h "$dev" | cut -f1)"
