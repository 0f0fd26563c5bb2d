# SPDX-License-Identifier: Apache-2.0
# The rosidl generators of the interface packages under ros/standard (build tests only): a ROS 2
# distribution bundles them as rosidl_default_generators; Debian 12 packages the C and C++
# generators and the introspection type supports (what rmw_cyclonedds serialises with) alone.
find_package(rosidl_default_generators QUIET)
if(NOT rosidl_default_generators_FOUND)
  find_package(rosidl_cmake REQUIRED)
  find_package(rosidl_generator_c REQUIRED)
  find_package(rosidl_generator_cpp REQUIRED)
  find_package(rosidl_typesupport_introspection_c REQUIRED)
  find_package(rosidl_typesupport_introspection_cpp REQUIRED)
endif()
