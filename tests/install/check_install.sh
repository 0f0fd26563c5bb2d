#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The installed package from a consumer's side (issue 23, item 5): installs this build into a
# fresh temporary prefix, then builds tests/install/consumer against it with find_package
# (nearpoint::core; nearpoint::client and nearpoint::proto when the build has them) and builds the
# engine example again with pkg-config alone, and runs both programs.
# Usage: check_install.sh CMAKE BUILD_DIR SOURCE_DIR WORK_DIR WITH_CLIENT(ON|OFF)
set -euo pipefail
cmake_bin="$1" build="$2" src="$3" work="$4" with_client="$5"
consumer="$src/tests/install/consumer"
rm -rf "$work"
mkdir -p "$work"
prefix="$work/prefix"

echo "== cmake --install $build --prefix $prefix"
"$cmake_bin" --install "$build" --prefix "$prefix" >"$work/install.log"
for f in include/nearpoint/distance.hpp include/nearpoint/version.hpp \
         lib/cmake/nearpoint/nearpoint-config.cmake \
         lib/pkgconfig/nearpoint-core.pc bin/nearpointd; do
  [[ -e "$prefix/$f" ]] || { echo "FAIL: $f not installed"; exit 1; }
done
# The headers are public ones only: nothing from src/ directories.
if grep -q "^NEARPOINT_WITH_DDS:BOOL=ON" "$build/CMakeCache.txt"; then
  for f in package.xml CMakeLists.txt msg/PoseUpdate.msg msg/DistanceReport.msg; do
    [[ -e "$prefix/share/nearpoint/ros/nearpoint_msgs/$f" ]] ||
      { echo "FAIL: share/nearpoint/ros/nearpoint_msgs/$f not installed"; exit 1; }
  done
fi
if find "$prefix/include" -name '*_internal.hpp' | grep -q .; then
  echo "FAIL: internal headers installed"; exit 1
fi

echo "== find_package(nearpoint CONFIG) from $consumer"
# The registry and the system prefixes are left out, so only the fresh install can be found.
"$cmake_bin" -S "$consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF \
  -DCONSUMER_WITH_CLIENT="$with_client" >"$work/configure.log" ||
  { cat "$work/configure.log"; exit 1; }
grep -q "consumer: nearpoint .* from $prefix/" "$work/configure.log" ||
  { echo "FAIL: nearpoint was not found in $prefix"; cat "$work/configure.log"; exit 1; }
"$cmake_bin" --build "$work/consumer" -j 2
"$work/consumer/core_distance"
if [[ "$with_client" == ON ]]; then
  "$work/consumer/client_offline"
fi

echo "== pkg-config nearpoint-core"
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
# shellcheck disable=SC2046  # the flags are meant to split
c++ -std=c++20 -O1 "$consumer/core_distance.cpp" -o "$work/core_distance_pc" \
  $(pkg-config --cflags --libs nearpoint-core)
"$work/core_distance_pc"
echo "OK: installed package usable through CMake and pkg-config"
