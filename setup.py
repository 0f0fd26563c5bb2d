# SPDX-License-Identifier: Apache-2.0
"""Builds the Python package `nearpoint` with CMake, for pip (pyproject.toml).

The package is what the CMake target `nearpoint_python` makes in <build>/client/python/nearpoint
(the engine's extension module, the client, its generated protobuf modules): this runs that
build in setuptools' temporary directory, for the running interpreter, and copies the package
into the wheel. Nothing is downloaded: CMake finds the dependencies deploy/install-deps.sh
installs (Debian 12 has no scikit-build-core, hence a build_ext of our own). Environment:
NEARPOINT_CMAKE_ARGS adds configure arguments; CMAKE_BUILD_PARALLEL_LEVEL sets the build's jobs.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


def version():
    # project(nearpoint VERSION ...) in CMakeLists.txt: the one place the version is written.
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(nearpoint VERSION ([0-9][0-9.]*)", text).group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = Path(self.build_temp).resolve() / "cmake"
        configure = [
            "cmake", "-S", str(ROOT), "-B", str(build), "-G", "Ninja",
            "-DCMAKE_BUILD_TYPE=Release",
            f"-DNEARPOINT_PYTHON={sys.executable}",
            # Only what the package needs: no tests, no DDS bridge, no benchmarks.
            "-DNEARPOINT_BUILD_TESTS=OFF", "-DNEARPOINT_WITH_DDS=OFF",
        ] + shlex.split(os.environ.get("NEARPOINT_CMAKE_ARGS", ""))
        subprocess.check_call(configure)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.check_call(["cmake", "--build", str(build), "--target", "nearpoint_python",
                               "-j", jobs])
        package = build / "client" / "python" / "nearpoint"
        dest = Path(self.get_ext_fullpath(ext.name)).parent  # <build_lib>/nearpoint
        shutil.copytree(package, dest, dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns("__pycache__"))
        built = Path(self.get_ext_fullpath(ext.name))
        if not built.exists():
            raise RuntimeError(f"the CMake build made no {built.name} (interpreter mismatch?)")


setup(
    version=version(),
    packages=[],
    py_modules=[],
    ext_modules=[Extension("nearpoint._engine", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own build tree, away from a CMake build directory named build/.
    options={"build": {"build_base": "build-pip"}},
    zip_safe=False,
)
