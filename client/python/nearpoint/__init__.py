# SPDX-License-Identifier: Apache-2.0
"""nearpoint: certified distances between convex shapes (GJK), in-process, and a client of
nearpointd, the distance server.

The engine (the C++ library, bound with numpy)::

    import numpy as np, nearpoint as npt
    box = npt.box((0.5, 0.5, 0.5))
    ball = npt.sphere(0.25)
    r = npt.distance(box, npt.Pose(), ball, npt.Pose.from_translation((2, 0, 0)), near_points=True)
    r.distance, r.error_bound, r.status, r.point_a, r.point_b      # 1.25, ..., Status.separated

    poses = np.zeros((1000, 7)); poses[:, 0] = np.linspace(0, 3, 1000); poses[:, 3] = 1
    rows = npt.distance_batch(box, npt.Pose(), ball, poses, threads=2)   # arrays of 1000 rows
    rows.distance, rows.status

The client (needs grpcio and protobuf; $NEARPOINT_TARGET, else 127.0.0.1:50051)::

    from nearpoint import client
    with client.connect() as c:
        cube = c.register_geometry([client.box((0.5, 0.5, 0.5))], name="cube")
        scene = c.create_scene({"a": cube, "b": (cube, (3, 0, 0))})
        print(c.query(scene).pairs[0].distance)            # 2.0

Poses are given as a `Pose`, a 4x4 homogeneous matrix, or a row (tx, ty, tz, qw, qx, qy, qz);
quaternions are (w, x, y, z). Bad input raises ValueError or TypeError with the engine's reason.
"""

from __future__ import annotations

import importlib
from typing import Any, Optional

import numpy as _np

# The engine is a C++ extension; the client is plain Python. A client-only user must still be
# able to import the package when the extension cannot load (a sanitizer build's extension needs
# its runtime preloaded into the interpreter): then the engine's names raise ImportError with
# the loader's reason on first use, instead of the whole package failing to import.
_engine_error: Optional[ImportError] = None
try:
    from ._engine import (
        Cache,
        Compound,
        DepthTermination,
        FinishedBy,
        Pose,
        Result,
        Shape,
        Status,
        Termination,
        box,
        capsule,
        cone,
        cylinder,
        distance,
        ellipsoid,
        point,
        polytope,
        segment,
        sphere,
    )
    from ._engine import distance_batch as _distance_batch
except ImportError as error:  # pragma: no cover (exercised by the TSan stage's client tests)
    _engine_error = error

from ._version import __version__

try:  # the hulls need the build's CGAL (nearpoint::hull); present in every packaged build
    from ._engine import convex_hull, hull
except ImportError:  # pragma: no cover
    pass


class BatchResult:
    """The results of `distance_batch`, one row per pair, as numpy arrays.

    Always: status (uint8, compare with `Status`), distance, error_bound, iterations,
    termination (uint8, `Termination`), warm_started (uint8). With near_points: point_a,
    point_b, normal (N, 3). With penetration_bound: penetration_bound. With penetration_depth:
    signed_distance, signed_distance_lower, signed_distance_upper, depth, depth_lower,
    depth_upper (N,), depth_direction, depth_point_a, depth_point_b (N, 3). With gradient:
    gradient_a, gradient_b (N, 6). With a Compound: piece_a, piece_b (int32). Values a row does
    not have (near points of an invalid row, a depth when separated) are NaN.
    """

    def __init__(self, arrays: dict):
        self.__dict__.update(arrays)

    def __len__(self) -> int:
        return len(self.distance)

    def columns(self) -> list:
        """The names of the arrays this result holds."""
        return list(self.__dict__)

    def __repr__(self) -> str:
        return f"BatchResult({len(self)} rows: {', '.join(self.__dict__)})"


def distance_batch(a, poses_a, b, poses_b, *, threads: int = 1, cache: Optional[Cache] = None,
                   errors: str = "raise", **options: Any) -> BatchResult:
    """N distance queries in one call, computed in C++ with the GIL released.

    `a` and `b`: a Shape or Compound (used for every row) or a sequence of N of them.
    `poses_a` and `poses_b`: a Pose, a (4, 4) matrix or a (7,) row (every row), or an (N, 4, 4)
    array of matrices or an (N, 7) array of (tx, ty, tz, qw, qx, qy, qz) rows: float64 and
    C-contiguous. Inputs with one row are broadcast against those with N.

    `threads`: worker threads (0: one per core), at most one per 64 rows (starting a thread
    costs more than a few dozen queries); rows are split into equal contiguous blocks.
    `cache`: a `Cache` holding one warm start per row, read and updated: pass the same Cache with
    the next poses of a trajectory. `errors`: "raise" (ValueError naming the first invalid row)
    or "status" (invalid rows keep Status.invalid_input in `status`). Other keywords are the
    options of `distance`. Returns a `BatchResult`.
    """
    _require_engine("distance_batch")
    return BatchResult(_distance_batch(a, poses_a, b, poses_b, threads=threads, cache=cache,
                                       errors=errors, **options))


def mesh_hull(vertices, triangles, rounding: float = 0.0) -> Shape:
    """The convex hull of a triangle mesh: of the `vertices` (N, 3) its `triangles` (M, 3,
    integer indices) use. Unused vertices are left out; indices are checked."""
    _require_engine("mesh_hull")
    tri = _np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise ValueError(f"triangles: expected an (M, 3) array of indices, got shape {tri.shape}")
    if not _np.issubdtype(tri.dtype, _np.integer):
        raise TypeError(f"triangles: expected integer indices, got dtype {tri.dtype}")
    verts = vertices if isinstance(vertices, _np.ndarray) else _np.asarray(vertices, _np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3:
        raise ValueError(f"vertices: expected an (N, 3) array, got shape {verts.shape}")
    if tri.min() < 0 or tri.max() >= len(verts):
        raise ValueError(f"triangles: an index is outside [0, {len(verts)})")
    used = verts[_np.unique(tri)]
    return hull(_np.ascontiguousarray(used), rounding)  # noqa: F821 (present with the hulls)


def _require_engine(name: str) -> None:
    if _engine_error is not None:
        raise ImportError(f"nearpoint.{name}: the engine extension did not load: {_engine_error}")


def __getattr__(name: str):
    # nearpoint.client on first use, so that the engine alone needs neither grpcio nor protobuf.
    if name == "client":
        return importlib.import_module(".client", __name__)
    if name in __all__:
        _require_engine(name)
    raise AttributeError(f"module 'nearpoint' has no attribute '{name}'")


__all__ = [
    "__version__", "BatchResult", "Cache", "Compound", "DepthTermination", "FinishedBy", "Pose",
    "Result", "Shape", "Status", "Termination", "box", "capsule", "cone", "convex_hull",
    "cylinder", "distance", "distance_batch", "ellipsoid", "hull", "mesh_hull", "point",
    "polytope", "segment", "sphere",
]
