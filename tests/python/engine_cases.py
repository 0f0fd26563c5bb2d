# SPDX-License-Identifier: Apache-2.0
"""Random engine inputs for the Python engine's tests and benchmark (issue 34), each both as a
nearpoint object and as text for tests/python/engine_reference.cpp (hex floats: exact), so that
the C++ engine sees exactly the doubles the bindings get."""
import math
import random

import numpy as np


def hexs(values):
    return " ".join(float(v).hex() for v in values)


class Spec:
    """One shape: `make(nearpoint)` builds it, `text` is its `shape` line's tail."""

    def __init__(self, kind, *args):
        self.kind, self.args = kind, args

    def make(self, npt):
        k, a = self.kind, self.args
        if k == "box":
            return npt.box(a[0], a[1])
        if k == "sphere":
            return npt.sphere(a[0])
        if k == "capsule":
            return npt.capsule(a[0], a[1], a[2])
        if k == "cylinder":
            return npt.cylinder(a[0], a[1], a[2])
        if k == "cone":
            return npt.cone(a[0], a[1], a[2])
        if k == "ellipsoid":
            return npt.ellipsoid(a[0], a[1])
        if k == "polytope":
            return npt.polytope(np.asarray(a[0], dtype=np.float64), a[1])
        raise ValueError(k)

    @property
    def text(self):
        k, a = self.kind, self.args
        if k == "box":
            return f"box {hexs(a[0])} {hexs([a[1]])}"
        if k == "sphere":
            return f"sphere {hexs([a[0]])}"
        if k == "capsule":
            return f"capsule {hexs(a[0])} {hexs(a[1])} {hexs([a[2]])}"
        if k in ("cylinder", "cone"):
            return f"{k} {hexs(a)}"
        if k == "ellipsoid":
            return f"ellipsoid {hexs(a[0])} {hexs([a[1]])}"
        if k == "polytope":
            pts = a[0]
            head = f"polytope {hexs([a[1]])} {float(len(pts)).hex()} "
            return head + " ".join(hexs(p) for p in pts)
        raise ValueError(k)


def random_spec(rng, kind=None, rounded=None):
    kind = kind or rng.choice(["box", "sphere", "capsule", "cylinder", "cone", "ellipsoid",
                               "polytope", "polytope"])
    r = rng.uniform(0.01, 0.3) if (rounded if rounded is not None else rng.random() < 0.3) else 0.0
    size = lambda: rng.uniform(0.2, 1.5)  # noqa: E731
    if kind == "box":
        return Spec("box", [size(), size(), size()], r)
    if kind == "sphere":
        return Spec("sphere", size())
    if kind == "capsule":
        h = size()
        return Spec("capsule", [0.0, 0.0, -h], [0.0, 0.0, h], size() * 0.5)
    if kind in ("cylinder", "cone"):
        return Spec(kind, size(), size(), r)
    if kind == "ellipsoid":
        return Spec("ellipsoid", [size(), size(), size()], r)
    n = rng.randint(4, 40)
    pts = [[rng.uniform(-1, 1) for _ in range(3)] for _ in range(n)]
    return Spec("polytope", pts, r)


def random_quaternion(rng):
    q = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


def random_row7(rng, spread=3.0):
    """(tx, ty, tz, qw, qx, qy, qz): shapes of size ~1 within `spread`, so pairs are separated,
    touching or overlapping in a mix."""
    return [rng.uniform(-spread, spread) for _ in range(3)] + random_quaternion(rng)


def matrix_of(row7):
    """A 4×4 matrix from a (7,) row, computed in numpy (a rotation orthonormal to ~1e-16)."""
    t, (w, x, y, z) = row7[:3], row7[3:]
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = t
    return m


def pose_text(pose):
    """`m` + 16 numbers for a (4, 4) array, `q` + 7 for a (7,) row."""
    arr = np.asarray(pose, dtype=np.float64)
    return ("m " if arr.shape == (4, 4) else "q ") + hexs(arr.ravel())


def write_cases(path, options, specs, pairs, cache_rows=0):
    """pairs: (index_a, index_b, pose_a, pose_b) with poses as (4, 4) or (7,) arrays."""
    with open(path, "w") as f:
        words = [k for k, on in options.items() if on]
        cache = f" cache {cache_rows}" if cache_rows else ""
        f.write("options " + " ".join(words) + cache + "\n")
        for s in specs:
            f.write("shape " + s.text + "\n")
        for ia, ib, pa, pb in pairs:
            f.write(f"pair {ia} {ib} {pose_text(pa)} {pose_text(pb)}\n")


def result_tokens(r):
    """The bindings' Result in engine_reference's field order (floats exact, absent fields '-')."""
    t = [int(r.status), r.distance, r.error_bound, r.gap, r.diameter_bound, r.iterations,
         r.support_calls, r.subalgorithm_runs, int(r.termination), int(r.warm_started),
         int(r.finished_by), len(r.simplex)]
    for ia, ib, w in r.simplex:
        t += [ia, ib, w]
    for v in (r.point_a, r.point_b, r.normal):
        t += list(v) if v is not None else ["-"] * 3
    t.append(r.penetration_bound if r.has_penetration_bound else "-")
    if r.has_signed_distance:
        t += [r.signed_distance, *r.signed_distance_interval]
    else:
        t += ["-"] * 3
    pd = r.has_penetration_depth
    t += [r.depth, *r.depth_interval] if pd else ["-"] * 3
    for v in (r.depth_point_a, r.depth_point_b, r.depth_direction):
        t += list(v) if pd else ["-"] * 3
    t.append(int(r.depth_termination) if pd else "-")
    t.append(r.depth_iterations)
    for g in (r.gradient_a, r.gradient_b):
        t += list(g) if r.has_gradient else ["-"] * 6
    return [canon(x) for x in t]


def canon(x):
    """A token compared bit for bit: floats by their 64 bits, ints as ints, '-' as itself."""
    if isinstance(x, str):
        if x == "-":
            return x
        if "0x" in x or "inf" in x or "nan" in x:
            return "f" + np.float64(float.fromhex(x)).tobytes().hex()
        return "i" + str(int(x))
    if isinstance(x, (float, np.floating)):
        return "f" + np.float64(x).tobytes().hex()
    return "i" + str(int(x))
