# SPDX-License-Identifier: Apache-2.0
# Installing nearpoint: `cmake --install BUILD [--prefix DIR]` and `cpack -G DEB` (issue 23, item 5).
#
# Two components, so that an operator's machine does not pull the -dev packages:
#   runtime — nearpointd, the nearpoint CLI, the DDS loopback configuration, the example files,
#             the ROS 2 package nearpoint_msgs (share/nearpoint/ros)
#   dev     — headers under include/nearpoint/, the static libraries, the CMake package
#             (find_package(nearpoint CONFIG) → nearpoint::core, nearpoint::model,
#             nearpoint::proto, nearpoint::client, and nearpoint::hull when CGAL is found) and nearpoint-core.pc
#   python  — the Python package `nearpoint` (engine and client) in the interpreter's
#             site-packages (client/python/CMakeLists.txt), the .deb python3-nearpoint
# `cmake --install` installs both; cpack makes one .deb per component.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(NEARPOINT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/nearpoint)

# ---- programs and data (runtime) ----
if(TARGET nearpointd)
  install(TARGETS nearpointd RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
endif()
if(TARGET nearpoint)
  install(TARGETS nearpoint RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
endif()
install(FILES ${PROJECT_SOURCE_DIR}/deploy/cyclonedds-loopback.xml
        DESTINATION ${CMAKE_INSTALL_DATADIR}/nearpoint COMPONENT runtime)
# examples/robots (the robot importers' test arm) is not installed until an installed program reads
# it: install.examples runs every installed example.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/
        DESTINATION ${CMAKE_INSTALL_DATADIR}/nearpoint/examples COMPONENT runtime
        PATTERN robots EXCLUDE)
# The DDS messages as a ROS 2 interface package, to copy into a ROS 2 workspace (nearpointd --dds).
if(NEARPOINT_WITH_DDS)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/ros/nearpoint_msgs
          DESTINATION ${CMAKE_INSTALL_DATADIR}/nearpoint/ros COMPONENT runtime)
endif()
# The JSON Schema of the reports `nearpoint query|stream --json` print (gRPC and DDS alike).
install(FILES ${PROJECT_SOURCE_DIR}/client/schema/report.schema.json
        DESTINATION ${CMAKE_INSTALL_DATADIR}/nearpoint/schema COMPONENT runtime)
# nearpoint(1) and nearpointd(1), from their --help (help2man).
include(${CMAKE_CURRENT_LIST_DIR}/NearpointManPages.cmake)

# ---- licence (both components) ----
# Apache-2.0 (LICENSE, NOTICE), the third-party notices, and a copyright file in Debian's
# machine-readable format, in each package's documentation directory: share/doc/nearpoint for the
# programs, share/doc/nearpoint-dev for the libraries (two .deb packages may not share a file).
set(_nearpoint_components runtime dev)
if(TARGET nearpoint_python)
  list(APPEND _nearpoint_components python)
endif()
foreach(_nearpoint_component IN LISTS _nearpoint_components)
  if(_nearpoint_component STREQUAL "runtime")
    set(_nearpoint_docdir ${CMAKE_INSTALL_DATADIR}/doc/nearpoint)
  elseif(_nearpoint_component STREQUAL "python")
    set(_nearpoint_docdir ${CMAKE_INSTALL_DATADIR}/doc/python3-nearpoint)
  else()
    set(_nearpoint_docdir ${CMAKE_INSTALL_DATADIR}/doc/nearpoint-dev)
  endif()
  install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/NOTICE
                ${PROJECT_SOURCE_DIR}/THIRD_PARTY_NOTICES.md
          DESTINATION ${_nearpoint_docdir} COMPONENT ${_nearpoint_component})
  install(FILES ${CMAKE_CURRENT_LIST_DIR}/debian-copyright RENAME copyright
          DESTINATION ${_nearpoint_docdir} COMPONENT ${_nearpoint_component})
endforeach()

# ---- libraries and headers (dev) ----
# The engine: Eigen only. Static libraries carry their private dependencies as link-only entries
# of the exported interface, so the warnings target (compile options only, never propagated to a
# consumer) is exported too.
set_target_properties(nearpoint_core PROPERTIES EXPORT_NAME core)
set_target_properties(nearpoint_warnings PROPERTIES EXPORT_NAME warnings_internal)
install(TARGETS nearpoint_core nearpoint_warnings EXPORT nearpoint-core-targets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/include/nearpoint
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
install(FILES ${PROJECT_BINARY_DIR}/generated/include/nearpoint/version.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nearpoint COMPONENT dev)
install(EXPORT nearpoint-core-targets NAMESPACE nearpoint:: DESTINATION ${NEARPOINT_INSTALL_CMAKEDIR}
        COMPONENT dev)

# The hull library (CGAL, GMP, MPFR): its own export file, loaded only where CGAL is found, so
# that a consumer of the engine alone never needs CGAL.
if(TARGET nearpoint_hull)
  set_target_properties(nearpoint_hull PROPERTIES EXPORT_NAME hull)
  install(TARGETS nearpoint_hull EXPORT nearpoint-hull-targets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
          INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/hull/include/nearpoint
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
  install(EXPORT nearpoint-hull-targets NAMESPACE nearpoint::
          DESTINATION ${NEARPOINT_INSTALL_CMAKEDIR} COMPONENT dev)
  set(NEARPOINT_INSTALLED_HULL ON)
else()
  set(NEARPOINT_INSTALLED_HULL OFF)
endif()

# The wire library and the C++ client (gRPC, protobuf). The generated headers include each other
# flat ("nearpoint_geometry.pb.h"), so their directory is on the include path.
if(TARGET nearpoint_proto AND TARGET nearpoint_client)
  set_target_properties(nearpoint_proto PROPERTIES EXPORT_NAME proto)
  set_target_properties(nearpoint_client PROPERTIES EXPORT_NAME client)
  set_target_properties(nearpoint_model PROPERTIES EXPORT_NAME model)
  # Linked privately by the client (the model ↔ protobuf conversion): exported for its link line.
  set_target_properties(nearpoint_proto_convert PROPERTIES EXPORT_NAME proto_convert)
  target_include_directories(nearpoint_proto
    PUBLIC $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/nearpoint/proto>)
  install(TARGETS nearpoint_model nearpoint_proto nearpoint_proto_convert nearpoint_client
          EXPORT nearpoint-client-targets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
          INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(DIRECTORY ${PROJECT_BINARY_DIR}/proto/
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nearpoint/proto COMPONENT dev
          FILES_MATCHING PATTERN "*.pb.h" PATTERN "CMakeFiles" EXCLUDE)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/client/include/nearpoint
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
  # The scene model (header-only): the plain request and report structs of the client's API.
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/model/include/nearpoint
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
  # The protocol for clients in other languages.
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/proto/nearpoint
          DESTINATION ${CMAKE_INSTALL_DATADIR}/nearpoint/proto COMPONENT dev
          FILES_MATCHING PATTERN "*.proto")
  install(EXPORT nearpoint-client-targets NAMESPACE nearpoint::
          DESTINATION ${NEARPOINT_INSTALL_CMAKEDIR} COMPONENT dev)
  set(NEARPOINT_INSTALLED_CLIENT ON)
else()
  set(NEARPOINT_INSTALLED_CLIENT OFF)
endif()

# The package's licence, for consumers that collect them: nearpoint_LICENSE in
# nearpoint-config.cmake, and the NEARPOINT_LICENSE property on every exported target.
set(NEARPOINT_LICENSE "Apache-2.0")
foreach(_nearpoint_target nearpoint_core nearpoint_hull nearpoint_model nearpoint_proto
                          nearpoint_proto_convert nearpoint_client)
  if(TARGET ${_nearpoint_target})
    set_property(TARGET ${_nearpoint_target} PROPERTY NEARPOINT_LICENSE ${NEARPOINT_LICENSE})
    set_property(TARGET ${_nearpoint_target} APPEND PROPERTY EXPORT_PROPERTIES NEARPOINT_LICENSE)
  endif()
endforeach()
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/nearpoint-config.cmake.in
  ${PROJECT_BINARY_DIR}/nearpoint-config.cmake INSTALL_DESTINATION ${NEARPOINT_INSTALL_CMAKEDIR})
# 0.x: a minor version may break the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/nearpoint-config-version.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/nearpoint-config.cmake
              ${PROJECT_BINARY_DIR}/nearpoint-config-version.cmake
        DESTINATION ${NEARPOINT_INSTALL_CMAKEDIR} COMPONENT dev)

# pkg-config for the engine; prefix relative to the .pc file, so an installed tree can be moved.
file(RELATIVE_PATH NEARPOINT_PC_TO_PREFIX
     /root/${CMAKE_INSTALL_LIBDIR}/pkgconfig /root)
configure_file(${CMAKE_CURRENT_LIST_DIR}/nearpoint-core.pc.in
               ${PROJECT_BINARY_DIR}/nearpoint-core.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/nearpoint-core.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)

# ---- cpack -G DEB (run in the build directory) ----
set(CPACK_PACKAGE_NAME nearpoint)
set(CPACK_PACKAGE_VENDOR "nearpoint")
set(CPACK_PACKAGE_CONTACT "nearpoint maintainers <nearpoint@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "GJK distance engine and distance service (gRPC, DDS)")
# Licence: Apache-2.0 for nearpoint's own code. A .deb has no licence field; its
# /usr/share/doc/<package>/copyright (installed above) is where Debian looks.
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_RPM_PACKAGE_LICENSE "Apache-2.0")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
# The programs without their debug information (a RelWithDebInfo nearpointd is ~10x larger);
# static libraries are left as they are.
set(CPACK_STRIP_FILES ON)
set(CPACK_COMPONENTS_ALL ${_nearpoint_components})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
# runtime: the shared libraries nearpointd and nearpoint link, found by dpkg-shlibdeps.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME nearpoint)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
# dev: static libraries and headers; a consumer compiles against Eigen, gRPC and protobuf.
set(CPACK_DEBIAN_DEV_PACKAGE_NAME nearpoint-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(_nearpoint_dev_depends "libeigen3-dev (>= 3.4)")
if(NEARPOINT_INSTALLED_CLIENT)
  string(APPEND _nearpoint_dev_depends ", libgrpc++-dev, libprotobuf-dev")
endif()
if(NEARPOINT_INSTALLED_HULL)
  # nearpoint::hull is loaded only when CGAL is found: suggested, not required.
  set(CPACK_DEBIAN_DEV_PACKAGE_SUGGESTS "libcgal-dev")
endif()
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "${_nearpoint_dev_depends}")
# python: the package for Debian's python3 (the extension module is built for its minor version);
# dpkg-shlibdeps adds what the module links (libstdc++, GMP and MPFR for the hulls).
if(TARGET nearpoint_python)
  set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-nearpoint)
  set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
  set(CPACK_DEBIAN_PYTHON_PACKAGE_SHLIBDEPS ON)
  math(EXPR _nearpoint_python_next "${NEARPOINT_PYTHON_MINOR} + 1")
  set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS
      "python3 (>= 3.${NEARPOINT_PYTHON_MINOR}), python3 (<< 3.${_nearpoint_python_next}), python3-numpy, python3-grpcio, python3-protobuf")
  set(CPACK_COMPONENT_PYTHON_DESCRIPTION
      "nearpoint for Python: the distance engine in-process (numpy) and the nearpointd client")
endif()
include(CPack)
