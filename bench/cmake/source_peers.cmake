# SPDX-License-Identifier: Apache-2.0
# The peers that Debian does not package: openGJK and coal, built from the snapshots in
# NEARPOINT_PEERS_DIR (bench/README.md, "Peers built from source": tarballs, commits, recipe).
# Each is extracted once into the build tree and compiled there as a bench-local static library.
# A missing tarball leaves that peer out with a message; the rest of the bench still builds and runs.
#
# Sets NEARPOINT_BENCH_HAVE_OPENGJK / NEARPOINT_BENCH_HAVE_COAL and defines the targets
# nearpoint_bench_opengjk / nearpoint_bench_coal when present.

# No default: the snapshots are not part of the repository, so their folder is named explicitly
# (-DNEARPOINT_PEERS_DIR=DIR, or the environment variable of the same name at first configure).
set(NEARPOINT_PEERS_DIR "$ENV{NEARPOINT_PEERS_DIR}"
    CACHE PATH "Folder with the openGJK / coal / jrl-cmakemodules snapshots (bench peers)")
set(NEARPOINT_BENCH_HAVE_OPENGJK OFF)
set(NEARPOINT_BENCH_HAVE_COAL OFF)
if(NOT NEARPOINT_PEERS_DIR)
  message(WARNING "bench peers: NEARPOINT_PEERS_DIR is not set (-DNEARPOINT_PEERS_DIR=DIR or the "
                  "environment variable): the bench runs without openGJK and coal "
                  "(bench/README.md, \"Peers built from source\", says how to make the snapshots)")
  return()
endif()
get_filename_component(_peers_dir "${NEARPOINT_PEERS_DIR}" ABSOLUTE)
if(NOT IS_DIRECTORY "${_peers_dir}")
  message(WARNING "bench peers: NEARPOINT_PEERS_DIR=${_peers_dir} is not a folder: the bench "
                  "runs without openGJK and coal")
  return()
endif()
set(_peers_build "${CMAKE_BINARY_DIR}/peers")
file(MAKE_DIRECTORY "${_peers_build}")

# Extracts `tarball` into `dest` once (a stamp file records which tarball it was).
function(_nearpoint_extract_once tarball dest)
  get_filename_component(_name "${tarball}" NAME)
  set(_stamp "${dest}/.extracted-${_name}")
  if(NOT EXISTS "${_stamp}")
    message(STATUS "bench peers: extracting ${_name}")
    file(ARCHIVE_EXTRACT INPUT "${tarball}" DESTINATION "${dest}")
    file(TOUCH "${_stamp}")
  endif()
endfunction()

# ---- openGJK (scalar, double) -------------------------------------------------------------------
file(GLOB _opengjk_tar "${_peers_dir}/openGJK-*.tar.gz")
set(NEARPOINT_BENCH_HAVE_OPENGJK OFF)
if(_opengjk_tar)
  list(GET _opengjk_tar 0 _opengjk_tar)
  _nearpoint_extract_once("${_opengjk_tar}" "${_peers_build}")
  set(_ogjk "${_peers_build}/openGJK/scalar")
  # As the recipe: -O3, C11, double; its printf calls (diagnostics on degenerate input) would be
  # noise in a timing loop, so they go to a quiet function (bench/src/opengjk_quiet.c).
  add_library(nearpoint_bench_opengjk STATIC "${_ogjk}/openGJK.c"
                                             "${CMAKE_CURRENT_SOURCE_DIR}/src/opengjk_quiet.c")
  target_include_directories(nearpoint_bench_opengjk SYSTEM PUBLIC "${_ogjk}/include")
  target_compile_options(nearpoint_bench_opengjk PRIVATE -O3 -w
                         -Dprintf=nearpoint_bench_opengjk_quiet_printf)
  set_target_properties(nearpoint_bench_opengjk PROPERTIES C_STANDARD 11 C_EXTENSIONS OFF)
  target_link_libraries(nearpoint_bench_opengjk PRIVATE m)
  set(NEARPOINT_BENCH_HAVE_OPENGJK ON)
  message(STATUS "bench peers: openGJK from ${_opengjk_tar}")
else()
  message(WARNING "bench peers: no openGJK-*.tar.gz in ${_peers_dir} (NEARPOINT_PEERS_DIR): the "
                  "bench runs without openGJK")
endif()

# ---- coal (GJK only) ----------------------------------------------------------------------------
file(GLOB _coal_tar "${_peers_dir}/coal-*.tar.gz")
file(GLOB _jrl_tar "${_peers_dir}/jrl-cmakemodules-*.tar.gz")
set(NEARPOINT_BENCH_HAVE_COAL OFF)
find_package(Boost QUIET COMPONENTS filesystem serialization chrono)
if(NOT _coal_tar OR NOT _jrl_tar)
  message(WARNING "bench peers: no coal-*.tar.gz and jrl-cmakemodules-*.tar.gz in ${_peers_dir} "
                  "(NEARPOINT_PEERS_DIR): the bench runs without coal")
elseif(NOT Boost_FOUND)
  message(WARNING "bench peers: coal's configuration needs Boost (libboost-filesystem-dev "
                  "libboost-serialization-dev libboost-chrono-dev): the bench runs without coal")
else()
  list(GET _coal_tar 0 _coal_tar)
  list(GET _jrl_tar 0 _jrl_tar)
  _nearpoint_extract_once("${_coal_tar}" "${_peers_build}")
  _nearpoint_extract_once("${_jrl_tar}" "${_peers_build}")  # fills coal/cmake (its submodule)
  set(_coal "${_peers_build}/coal")
  set(_coal_build "${_peers_build}/coal-build")
  # coal's own configuration, once, with the recipe's options: it generates the headers that its
  # sources include (coal/config.hh, deprecated.hh, warning.hh). Only the sources the bench calls
  # are compiled (below): the GJK solver, the Minkowski difference and support functions, the
  # Convex shape, and the specialised sphere–sphere / capsule–capsule / sphere–capsule /
  # box–sphere routines. The recipe's whole library (74 files, 25–30 min on 2 cores) is not needed.
  if(NOT EXISTS "${_coal_build}/include/coal/config.hh")
    message(STATUS "bench peers: configuring coal (headers only)")
    execute_process(
      COMMAND "${CMAKE_COMMAND}" -S "${_coal}" -B "${_coal_build}" -G Ninja
              -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O2 -DNDEBUG"
              -DBUILD_PYTHON_INTERFACE=OFF -DBUILD_TESTING=OFF -DINSTALL_DOCUMENTATION=OFF
              -DCOAL_HAS_QHULL=OFF
      OUTPUT_FILE "${_peers_build}/coal-configure.log" ERROR_FILE "${_peers_build}/coal-configure.log"
      RESULT_VARIABLE _coal_rc)
    if(NOT _coal_rc EQUAL 0)
      message(WARNING "bench peers: coal's configuration failed (${_peers_build}/coal-configure.log)")
    endif()
  endif()
  if(EXISTS "${_coal_build}/include/coal/config.hh")
    add_library(nearpoint_bench_coal STATIC
      "${_coal}/src/narrowphase/gjk.cpp"
      "${_coal}/src/narrowphase/minkowski_difference.cpp"
      "${_coal}/src/narrowphase/support_functions.cpp"
      "${_coal}/src/shape/convex.cpp"
      "${_coal}/src/shape/geometric_shapes.cpp"
      "${_coal}/src/math/transform.cpp"
      "${_coal}/src/shape/geometric_shapes_utility.cpp"
      "${_coal}/src/BVH/BV_fitter.cpp"
      "${_coal}/src/BVH/BVH_utility.cpp"
      "${_coal}/src/BVH/BVH_model.cpp"
      "${_coal}/src/BVH/BV_splitter.cpp"
      "${_coal}/src/BV/AABB.cpp"
      "${_coal}/src/BV/OBB.cpp"
      "${_coal}/src/BV/RSS.cpp"
      "${_coal}/src/BV/kIOS.cpp"
      "${_coal}/src/BV/OBBRSS.cpp"
      "${_coal}/src/BV/kDOP.cpp"
      "${_coal}/src/intersect.cpp"
      "${_coal}/src/collision_data.cpp"
      "${_coal}/src/distance/sphere_sphere.cpp"
      "${_coal}/src/distance/capsule_capsule.cpp"
      "${_coal}/src/distance/sphere_capsule.cpp"
      "${_coal}/src/distance/box_sphere.cpp")
    target_include_directories(nearpoint_bench_coal SYSTEM PUBLIC "${_coal}/include"
                                                                  "${_coal_build}/include")
    # The recipe's flags (-O2 -DNDEBUG, C++17 as coal's build uses); warnings are coal's business.
    target_compile_options(nearpoint_bench_coal PRIVATE -O2 -w)
    target_compile_definitions(nearpoint_bench_coal PUBLIC NDEBUG)
    set_target_properties(nearpoint_bench_coal PROPERTIES CXX_STANDARD 17 CXX_EXTENSIONS ON)
    target_link_libraries(nearpoint_bench_coal PUBLIC Eigen3::Eigen Boost::filesystem
                          Boost::serialization Boost::chrono)
    set(NEARPOINT_BENCH_HAVE_COAL ON)
    message(STATUS "bench peers: coal from ${_coal_tar}")
  endif()
endif()
