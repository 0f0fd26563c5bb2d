#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# `cmake --install` of the Python package (issue 34): the python component into a fresh prefix, at
# the interpreter's own site-packages path under it (so that under /usr or /usr/local it is on
# sys.path), then imported from there by the interpreter in a clean environment, the engine and
# the client both.
# Usage: check_python_install.sh CMAKE BUILD_DIR PYTHON SITE_DIR WORK_DIR
set -euo pipefail
cmake_bin="$1" build="$2" python="$3" site="$4" work="$5"
rm -rf "$work"
mkdir -p "$work"
prefix="$work/prefix"
"$cmake_bin" --install "$build" --prefix "$prefix" --component python >"$work/install.log"
for f in nearpoint/__init__.py nearpoint/client.py nearpoint/_version.py nearpoint/_engine.pyi \
         nearpoint/py.typed nearpoint/proto/nearpoint_distance_pb2.py nearpoint_client/__init__.py; do
  [[ -f "$prefix/$site/$f" ]] || { echo "FAIL: $site/$f not installed"; exit 1; }
done
ls "$prefix/$site"/nearpoint/_engine.*.so >/dev/null || { echo "FAIL: no extension module"; exit 1; }
if find "$prefix/$site" -name __pycache__ | grep -q .; then
  echo "FAIL: __pycache__ installed"; exit 1
fi

cd /
# The same relative path under /usr/local (cmake --install's default prefix) or /usr is one of
# the interpreter's own directories.
env -i PATH=/usr/bin:/bin "$python" -c "
import sys
assert '/usr/local/$site' in sys.path or '/usr/$site' in sys.path, ('$site', sys.path)"
env -i PATH=/usr/bin:/bin PYTHONPATH="$prefix/$site" "$python" - "$prefix" <<'PY'
import sys
import nearpoint
import nearpoint_client
from nearpoint import client
prefix = sys.argv[1]
for module in (nearpoint, client, nearpoint._engine):
    assert module.__file__.startswith(prefix), f"{module.__name__} from {module.__file__}"
r = nearpoint.distance(nearpoint.capsule((0, 0, -1), (0, 0, 1), 0.5), None, nearpoint.sphere(0.5),
                       (3, 0, 0, 1, 0, 0, 0), near_points=True)
assert abs(r.distance - 2.0) <= r.error_bound + 1e-15, r
assert nearpoint_client.connect is client.connect
print("nearpoint", nearpoint.__version__, "from", nearpoint.__file__)
PY
env -i PATH=/usr/bin:/bin PYTHONPATH="$prefix/$site" "$python" -c \
  "import nearpoint; print(nearpoint.__version__)"
echo "OK: cmake --install of the Python package, imported from $prefix/$site"
