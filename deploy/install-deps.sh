#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs, from Debian 12 packages, whatever nearpoint needs that this machine lacks.
# Idempotent: packages already present are left alone, and nothing is fetched when all are there.
#
#   deploy/install-deps.sh            # build + test dependencies
#   deploy/install-deps.sh --bench    # also the benchmark peers (FCL, libccd, Bullet; coal's Boost)
#   deploy/install-deps.sh --image    # only what building nearpointd and nearpoint needs (the
#                                     # build stage of deploy/Containerfile: no tests, no tools)
set -euo pipefail

# What a Release build of nearpointd and the nearpoint CLI needs (deploy/Containerfile's build
# stage installs these alone).
build_packages=(
  # toolchain
  g++ cmake ninja-build pkg-config ccache python3
  # core: Eigen only
  libeigen3-dev
  # command-line tool; mesh import (assimp reads the files; CGAL finds the hulls, exactly)
  nlohmann-json3-dev libcli11-dev libassimp-dev libcgal-dev libgmp-dev libmpfr-dev
  # scene files in YAML (optional at build time; JSON always works)
  libyaml-cpp-dev
  # server: gRPC (nearpointd, its protos, reflection and health checking); the Python client's
  # modules are generated at configure time with grpc_python_plugin (protobuf-compiler-grpc)
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  # the Python package's engine module (client/python: pybind11 2.10 against Debian's python3)
  pybind11-dev python3-dev
  # server: the Prometheus endpoint (--metrics-listen; optional at build time)
  prometheus-cpp-dev
  # DDS bridge and client: Cyclone DDS's C library and idlc (C API; no C++ binding is packaged);
  # the DDS types are generated from the ROS 2 .msg files under ros/ by rosidl translate and
  # rosidl_parser (ros/generate_dds_idl.py); rosidl's command line imports yaml, and its .msg
  # adapter catkin_pkg and empy, none of which Debian's rosidl packages depend on (found by the
  # image build, which starts from a bare Debian)
  cyclonedds-dev cyclonedds-tools rosidl-tools python3-rosidl python3-yaml python3-empy
  python3-catkin-pkg
  # server: SHA-256 of content ids (libcrypto; gRPC's TLS links it too)
  libssl-dev
  # the man pages of nearpoint and nearpointd, made from their --help at build time (optional:
  # without it the build leaves them out, saying so)
  help2man
)
# The tests, the fuzz targets and the tools CI runs, on top of the build's.
test_packages=(
  # the fuzz targets (tests/fuzz): clang and its libFuzzer/sanitizer runtimes, in build-fuzz only
  clang libclang-rt-14-dev
  # tests: GoogleTest (CGAL, above, is also the distance oracle)
  libgtest-dev libgmock-dev
  # robot descriptions (robots/, optional at build time: no program links it yet, so the image
  # leaves it out): URDF through urdfdom, MJCF and SRDF through tinyxml2
  liburdfdom-dev libtinyxml2-dev
  # the robot importers' references (tests/robots): KDL read by kdl_parser for URDF, MuJoCo and
  # its sample models for MJCF
  liborocos-kdl-dev libkdl-parser-dev libmujoco-dev libmujoco-samples
  # Python client (client/python): Debian's /usr/bin/python3 with the runtimes matching the
  # protoc 3.21 / grpc_python_plugin 1.51 above, which generate its modules
  python3-grpcio python3-protobuf
  # gRPC's own health and reflection schemas: a test reads nearpointd's with them
  # (tests/server/check_health_reflection.py)
  grpc-proto
  # the Python package: numpy at run time; its pip route (install.pip) builds offline in a venv
  python3-numpy python3-venv python3-pip python3-setuptools python3-wheel
  # TLS tests (a throw-away CA made with openssl) and the deploy/k8s check (yamllint, PyYAML)
  openssl yamllint python3-yaml
  # the CLI's JSON reports are validated against client/schema/report.schema.json
  python3-jsonschema
  # the container image's test (deploy/test-container.sh): podman builds and runs the image
  # (buildah's engine inside; runc as the runtime, no daemon), debootstrap makes its local base
  # image, uidmap/slirp4netns/fuse-overlayfs are what podman needs beside them on Debian 12
  podman buildah runc debootstrap uidmap slirp4netns fuse-overlayfs
  # ROS 2 interfaces (ros/, the ros.interfaces_build test): colcon builds nearpoint_msgs with
  # Debian's ament and rosidl generators and introspection type supports
  # (Debian's colcon is the core alone: --base-paths, --parallel-workers and ROS package manifests
  # are the recursive-crawl, parallel-executor and ros extensions, packaged apart; found on a fresh
  # machine, where ros.interfaces_build failed without them)
  colcon python3-colcon-cmake python3-colcon-recursive-crawl python3-colcon-parallel-executor
  python3-colcon-ros python3-colcon-package-selection ament-cmake rosidl-cmake rosidl-generator-c-cpp
  librosidl-typesupport-introspection-c-cpp-dev librosidl-runtime-c-cpp-dev
  # scenes spread over replicas behind a proxy (deploy/haproxy/, deploy/sharded.sh, the
  # server.sharded test)
  haproxy
)
image=false
bench=false
for arg in "$@"; do
  case "$arg" in
    --image) image=true ;;
    # peers for bench/ (FCL, libccd, Bullet; CGAL above gives the hulls fcl::Convex needs) and
    # matplotlib for bench/run.sh's plots (Debian's /usr/bin/python3)
    --bench) bench=true ;;
    -h|--help) sed -n '3,9p' "$0"; exit 0 ;;
    *) echo "install-deps.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done
packages=("${build_packages[@]}")
if ! $image; then
  packages+=("${test_packages[@]}")
  # kubectl renders deploy/k8s (`kubectl kustomize`). Debian's is kubernetes-client; a machine
  # that already has a kubectl (e.g. Google Cloud SDK's package) keeps it: the two conflict.
  if ! command -v kubectl >/dev/null 2>&1; then packages+=(kubernetes-client); fi
fi
if $bench; then
  # coal, built from its source snapshot by bench/, needs Boost's filesystem library
  packages+=(libbenchmark-dev libfcl-dev libccd-dev libbullet-dev python3-matplotlib
    libboost-filesystem-dev)
fi

missing=()
for p in "${packages[@]}"; do
  if [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" != "install ok installed" ]; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# Refresh the package lists when they are missing or older than a day; a fresh machine has none.
lists=/var/lib/apt/lists
if [ -z "$(find "$lists" -maxdepth 1 -name '*Packages*' -mmin -1440 2>/dev/null | head -n 1)" ]; then
  $sudo apt-get update -q -o DPkg::Lock::Timeout=300
fi
$sudo apt-get install -y -q --no-install-recommends -o DPkg::Lock::Timeout=300 "${missing[@]}"
