#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# `pip install --no-build-isolation .` of the Python package (issue 34), offline, into a venv made
# with --system-site-packages (numpy, grpcio and protobuf from Debian): the checkout's files
# (tracked and new, as git lists them) are copied to WORK first, so the build starts clean and
# leaves the source tree alone. Then, from a clean environment, the venv's interpreter imports
# the package from the venv and computes a distance.
# Usage: check_pip_install.sh PYTHON SOURCE_DIR WORK_DIR
set -euo pipefail
python="$1" src="$2" work="$3"
rm -rf "$work"
mkdir -p "$work/src"
start=$(date +%s)
(cd "$src" && git ls-files -z --cached --others --exclude-standard |
   xargs -0 cp --parents -t "$work/src" 2>/dev/null || true)
[[ -f "$work/src/pyproject.toml" ]] || { echo "FAIL: the checkout was not copied"; exit 1; }

"$python" -m venv --system-site-packages "$work/venv"
echo "== pip install --no-build-isolation --no-index $work/src"
# No index, no network: every build requirement comes from the system (setuptools, wheel, CMake).
PIP_NO_INDEX=1 PIP_DISABLE_PIP_VERSION_CHECK=1 CCACHE_BASEDIR="$work/src" \
  "$work/venv/bin/pip" install --no-build-isolation --no-index "$work/src" >"$work/pip.log" 2>&1 ||
  { tail -50 "$work/pip.log"; echo "FAIL: pip install"; exit 1; }

echo "== import nearpoint from the venv, clean environment"
cd /
env -i PATH=/usr/bin:/bin HOME="$work" "$work/venv/bin/python" - "$work/venv" <<'PY'
import sys
import nearpoint
venv = sys.argv[1]
print("nearpoint", nearpoint.__version__, "from", nearpoint.__file__)
assert nearpoint.__file__.startswith(venv), f"imported from {nearpoint.__file__}, not the venv"
r = nearpoint.distance(nearpoint.box((0.5, 0.5, 0.5)), None, nearpoint.sphere(0.5),
                       (3, 0, 0, 1, 0, 0, 0))
assert abs(r.distance - 2.0) <= r.error_bound + 1e-15, r
from nearpoint import client
assert client.distance_pb.__name__ == "nearpoint.proto.nearpoint_distance_pb2"
PY
"$work/venv/bin/python" -c "import nearpoint; print(nearpoint.__version__)"
echo "OK: pip install from the checkout in $(( $(date +%s) - start )) s"
