#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds ros/nearpoint_msgs, and the standard interface packages it depends on (ros/standard),
# with colcon and Debian's rosidl and ament, as a ROS 2 workspace would: rosidl parses every
# .msg file and generates the C and C++ types and their introspection type supports, so a .msg
# file that is not a valid ROS 2 interface fails this test.
#   build_interfaces.sh SOURCE_DIR WORK_DIR
set -euo pipefail
source_dir=$1
work=$2
# ament's CMake helpers run `python3` and need Debian's modules (ament_package, catkin_pkg),
# which another python3 earlier on PATH (pyenv) lacks.
export PATH=/usr/bin:$PATH
rm -rf "$work"
mkdir -p "$work"
cd "$work"
colcon --log-base "$work/log" build --base-paths "$source_dir/ros" --build-base "$work/build" \
  --install-base "$work/install" --parallel-workers 2 --event-handlers console_direct- \
  --cmake-args -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=/usr/bin/python3
# The five packages, and nearpoint_msgs' introspection type support, the layout ROS 2's
# rmw_cyclonedds serialises by.
for package in builtin_interfaces std_msgs geometry_msgs sensor_msgs nearpoint_msgs; do
  test -f "$work/install/$package/share/$package/package.xml" ||
    { echo "build_interfaces.sh: $package was not installed" >&2; exit 1; }
done
ls "$work"/install/nearpoint_msgs/lib/libnearpoint_msgs__rosidl_typesupport_introspection_c.so \
  >/dev/null
for message in PoseUpdate DistanceReport ThresholdEvent PoseUpdateBatch DistanceReportBatch; do
  test -f "$work/install/nearpoint_msgs/share/nearpoint_msgs/msg/$message.idl" ||
    { echo "build_interfaces.sh: no $message.idl" >&2; exit 1; }
done
echo "build_interfaces.sh: nearpoint_msgs and its dependencies built"
