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
# python3-nearpoint (when the build has the Python package): the package in Debian's python3
# directories, depending on the interpreter, numpy, the gRPC runtime and what its module links;
# unpacked (not installed: no root) and imported from there in a clean environment.
python_deb=$(ls "$work"/python3-nearpoint_*.deb 2>/dev/null || true)
if [[ -d "$build/client/python/nearpoint" ]]; then
  [[ -n "$python_deb" ]] || fail "the build has the Python package but cpack made no python3-nearpoint"
  contents "$python_deb" | grep -q '^./usr/lib/python3[.0-9]*/dist-packages/nearpoint/__init__.py$' ||
    fail "nearpoint/__init__.py not in $python_deb"
  contents "$python_deb" | grep -q '/dist-packages/nearpoint/_engine\..*\.so$' ||
    fail "the extension module not in $python_deb"
  for file in copyright LICENSE NOTICE THIRD_PARTY_NOTICES.md; do
    contents "$python_deb" | grep -qx "./usr/share/doc/python3-nearpoint/$file" ||
      fail "/usr/share/doc/python3-nearpoint/$file not in $python_deb"
  done
  [[ "$(dpkg-deb -f "$python_deb" Version)" == "$version" ]] || fail "$python_deb: Version"
  python_depends=$(dpkg-deb -f "$python_deb" Depends)
  echo "python3-nearpoint Depends: $python_depends"
  for dep in 'python3 (>=' python3-numpy python3-grpcio python3-protobuf libstdc++6 libgmp; do
    grep -qF "$dep" <<<"$python_depends" || fail "$python_deb does not depend on $dep"
  done
  dpkg-deb -x "$python_deb" "$work/python-root"
  site=$(cd "$work/python-root" && ls -d usr/lib/python3*/dist-packages)
  printed=$(cd / && env -i PATH=/usr/bin:/bin PYTHONPATH="$work/python-root/$site" /usr/bin/python3 \
    -c "import nearpoint, nearpoint.client; print(nearpoint.__version__); assert nearpoint.__file__.startswith('$work/python-root')")
  [[ "$printed" == "$version" ]] || fail "the packaged nearpoint says version '$printed'"
  /usr/bin/python3 -c "import sys; assert '/$site' in sys.path, sys.path" ||
    fail "/$site is not on Debian's python3 path"
fi
echo "OK: $(basename "$runtime") $(du -h "$runtime" | cut -f1), $(basename "$dev") $(du -h "$dev" | cut -f1)${python_deb:+, $(basename "$python_deb") $(du -h "$python_deb" | cut -f1)}"
