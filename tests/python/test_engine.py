#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""The engine's Python bindings (nearpoint._engine, issue 34) against the C++ engine and the exact
oracle.

  - bit for bit: the same inputs through the bindings (single call, batch on 1 and 2 threads,
    warm caches carried over calls) and through tests/python/engine_reference.cpp, which calls the
    engine directly; every field of every result compared by its 64 bits;
  - the exact oracle: a sample of the paper's Section VII experiment with CGAL's exact distances
    (dumped by engine_reference), within each result's certified error bound;
  - bad input swept: wrong shapes, dtypes, layouts, NaN and infinity, wrong types, at every entry
    point — each must raise TypeError or ValueError with a message, never crash;
  - the API: poses, compounds, hulls, caches, broadcasting.

    /usr/bin/python3 tests/python/test_engine.py --pythonpath build/client/python \
        --reference build/tests/engine_reference
"""
import argparse
import math
import os
import random
import subprocess
import sys
import tempfile
import unittest
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_cases as cases  # noqa: E402

ARGS = None
npt = None  # nearpoint, imported once the path is known

ALL_ON = {"near_points": True, "gradient": True, "penetration_bound": True,
          "penetration_depth": True}


# engine_reference without the sanitizer runtime that sanitizer builds preload into python3 (see
# tests/CMakeLists.txt): the program links its own, and two runtimes in one process refuse to start.
REFERENCE_ENV = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def reference(path):
    out = subprocess.run([ARGS.reference, "results", path], check=True, capture_output=True,
                         text=True, env=REFERENCE_ENV).stdout
    return [[cases.canon(tok) for tok in line.split()] for line in out.splitlines()]


def random_pairs(rng, specs, count, pose_kind):
    pairs = []
    for _ in range(count):
        ra, rb = cases.random_row7(rng), cases.random_row7(rng)
        if pose_kind == "m":
            ra, rb = cases.matrix_of(ra), cases.matrix_of(rb)
        pairs.append((rng.randrange(len(specs)), rng.randrange(len(specs)), np.asarray(ra),
                      np.asarray(rb)))
    return pairs


class BitForBit(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="nearpoint_engine_")
        self.rng = random.Random(34)
        kinds = ["box", "sphere", "capsule", "cylinder", "cone", "ellipsoid", "polytope"]
        self.specs = [cases.random_spec(self.rng, k, rounded) for k in kinds
                      for rounded in (False, True)] + [cases.random_spec(self.rng, "polytope")
                                                       for _ in range(4)]
        self.shapes = [s.make(npt) for s in self.specs]

    def tearDown(self):
        self.tmp.cleanup()

    def check_single(self, options, pose_kind, count=400, cache_rows=0):
        pairs = random_pairs(self.rng, self.specs, count, pose_kind)
        path = os.path.join(self.tmp.name, "cases.txt")
        cases.write_cases(path, options, self.specs, pairs, cache_rows)
        expected = reference(path)
        self.assertEqual(len(expected), count)
        cache = npt.Cache() if cache_rows else None
        statuses = set()
        for (ia, ib, pa, pb), want in zip(pairs, expected):
            pose_a = npt.Pose(pa) if pose_kind == "m" else npt.Pose.from_quaternion(pa[3:], pa[:3])
            r = npt.distance(self.shapes[ia], pose_a, self.shapes[ib], pb, cache=cache, **options)
            statuses.add(r.status)
            self.assertEqual(cases.result_tokens(r), want, f"pair {self.specs[ia].kind} "
                             f"{self.specs[ib].kind} at {pa.tolist()}, {pb.tolist()}")
        # The sample is a real mix: the comparison covers every verdict's fields.
        self.assertTrue({npt.Status.separated, npt.Status.intersecting} <= statuses, statuses)

    def test_single_all_fields_matrix_poses(self):
        self.check_single(ALL_ON, "m")

    def test_single_all_fields_quaternion_poses(self):
        self.check_single(ALL_ON, "q")

    def test_single_defaults(self):
        self.check_single({}, "q")

    def test_single_warm_start_carried(self):
        # One cache through a trajectory of small moves: the warm starts must take the very
        # same path as in C++.
        self.check_single({"near_points": True}, "q", count=200, cache_rows=1)

    def test_batch_matches_engine(self):
        n, steps = 300, 3
        a, b = self.shapes[12], self.shapes[3]  # a polytope and a rounded capsule
        rows_a = np.array([cases.random_row7(self.rng, 1.0) for _ in range(n)])
        trajectory = []
        rows_b = np.array([cases.random_row7(self.rng, 1.0) for _ in range(n)])
        for step in range(steps):
            moved = rows_b.copy()
            moved[:, :3] += 0.05 * step
            trajectory.append(moved)
        pairs = [(12, 3, rows_a[i], trajectory[s][i]) for s in range(steps) for i in range(n)]
        path = os.path.join(self.tmp.name, "batch.txt")
        cases.write_cases(path, ALL_ON, self.specs, pairs, cache_rows=n)
        expected = reference(path)
        for threads in (1, 2):
            cache = npt.Cache()
            got = []
            for s in range(steps):
                res = npt.distance_batch(a, rows_a, b, trajectory[s], threads=threads,
                                         cache=cache, **ALL_ON)
                got.append(res)
            self.assertEqual(cache.rows, n)
            self.assertTrue(got[-1].warm_started.any())
            for s in range(steps):
                res = got[s]
                for i in range(n):
                    want = expected[s * n + i]
                    # status distance error_bound ... iterations at 5, termination 8, warm 9
                    self.assertEqual(cases.canon(int(res.status[i])), want[0])
                    self.assertEqual(cases.canon(res.distance[i]), want[1])
                    self.assertEqual(cases.canon(res.error_bound[i]), want[2])
                    self.assertEqual(cases.canon(int(res.iterations[i])), want[5])
                    self.assertEqual(cases.canon(int(res.termination[i])), want[8])
                    self.assertEqual(cases.canon(int(res.warm_started[i])), want[9])
                    k = 12 + 3 * int(want[11][1:])
                    tail = want[k:]
                    cols = ([*res.point_a[i], *res.point_b[i], *res.normal[i]], tail[0:9])
                    self.assertEqual([cases.canon(v) for v in cols[0]], cols[1])
                    sd = [res.signed_distance[i], res.signed_distance_lower[i],
                          res.signed_distance_upper[i]]
                    self.assertEqual([cases.canon(v) for v in sd], tail[10:13])
                    grads = [*res.gradient_a[i], *res.gradient_b[i]]
                    if tail[-1] != "-":
                        self.assertEqual([cases.canon(v) for v in grads], tail[-12:])

    def test_batch_matrix_rows_equal_single_calls(self):
        n = 200
        mats = np.array([cases.matrix_of(cases.random_row7(self.rng, 1.5)) for _ in range(n)])
        shapes_b = [self.shapes[self.rng.randrange(len(self.shapes))] for _ in range(n)]
        res = npt.distance_batch(self.shapes[0], mats, shapes_b, npt.Pose(), threads=2,
                                 near_points=True)
        for i in range(n):
            r = npt.distance(self.shapes[0], mats[i], shapes_b[i], None, near_points=True)
            self.assertEqual(cases.canon(res.distance[i]), cases.canon(r.distance))
            self.assertEqual(int(res.status[i]), int(r.status))
            if r.point_a is not None:
                np.testing.assert_array_equal(res.point_a[i], r.point_a)


class Oracle(unittest.TestCase):
    """The paper's experiment (a sample) against CGAL's exact distances."""

    @classmethod
    def setUpClass(cls):
        out = subprocess.run([ARGS.reference, "paper", str(ARGS.paper_draws)], check=True,
                             env=REFERENCE_ENV,
                             capture_output=True, text=True).stdout
        cls.polytopes, cls.examples = {}, []
        for line in out.splitlines():
            tok = line.split()
            if tok[0] == "polytope":
                v = np.array([float.fromhex(t) for t in tok[3:]]).reshape(-1, 3)
                cls.polytopes[int(tok[1])] = npt.polytope(v)
            else:
                nums = [float.fromhex(t) for t in tok[4:28]]
                mats = []
                for k in (0, 12):
                    m = np.eye(4)
                    m[:3, :3] = np.array(nums[k:k + 9]).reshape(3, 3)
                    m[:3, 3] = nums[k + 9:k + 12]
                    mats.append(m)
                cls.examples.append((tok[1], int(tok[2]), int(tok[3]), mats[0], mats[1],
                                     float.fromhex(tok[28]), tok[29] == "1"))

    def check(self, kind, d, bound, status, exact, intersecting):
        self.assertLessEqual(abs(d - exact), max(1e-12, bound), (kind, d, exact, bound))
        if kind == "separated":
            self.assertEqual(status, npt.Status.separated)
        elif kind == "intersecting":
            self.assertTrue(intersecting)
            self.assertIn(status, (npt.Status.intersecting, npt.Status.touching))
        else:
            self.assertNotEqual(status, npt.Status.invalid_input)

    def test_single_calls(self):
        self.assertEqual(len(self.examples), 60 * ARGS.paper_draws)
        for kind, pa, pb, ma, mb, exact, intersecting in self.examples:
            r = npt.distance(self.polytopes[pa], ma, self.polytopes[pb], mb, near_points=True)
            self.check(kind, r.distance, r.error_bound, r.status, exact, intersecting)
            if r.status == npt.Status.separated:
                gap = np.linalg.norm(r.point_b - r.point_a)
                self.assertLessEqual(abs(gap - exact), max(1e-11, 2 * r.error_bound))

    def test_batch(self):
        # One batch per polytope pair: shapes broadcast, (N, 4, 4) pose arrays.
        groups = {}
        for e in self.examples:
            groups.setdefault((e[1], e[2]), []).append(e)
        for (pa, pb), rows in groups.items():
            ma = np.ascontiguousarray([e[3] for e in rows])
            mb = np.ascontiguousarray([e[4] for e in rows])
            res = npt.distance_batch(self.polytopes[pa], ma, self.polytopes[pb], mb, threads=2)
            for i, e in enumerate(rows):
                self.check(e[0], res.distance[i], res.error_bound[i], res.status[i], e[5], e[6])


class BadInput(unittest.TestCase):
    """Every refusal is TypeError or ValueError with a message; nothing crashes."""

    def refuse(self, call, *kinds):
        with self.assertRaises(kinds or (TypeError, ValueError)) as caught:
            call()
        self.assertTrue(str(caught.exception), "an exception without a message")
        return str(caught.exception)

    def test_arrays(self):
        good = np.random.default_rng(1).uniform(-1, 1, (10, 3))
        self.assertIn("float64", self.refuse(lambda: npt.polytope(good.astype(np.float32)),
                                             TypeError))
        self.refuse(lambda: npt.polytope(good.astype(np.int64)), TypeError)
        self.refuse(lambda: npt.polytope(good.astype(">f8")), TypeError)
        self.refuse(lambda: npt.polytope(good.astype(object)), TypeError)
        self.assertIn("C-contiguous", self.refuse(lambda: npt.polytope(good[::2]), ValueError))
        self.refuse(lambda: npt.polytope(np.asfortranarray(good)), ValueError)
        self.assertIn("(N, 3)", self.refuse(lambda: npt.polytope(good[:, :2].copy()), ValueError))
        self.refuse(lambda: npt.polytope(good.ravel()), ValueError)
        self.refuse(lambda: npt.polytope(np.zeros((0, 3))), ValueError)
        for bad in (np.nan, np.inf, -np.inf):
            v = good.copy()
            v[3, 1] = bad
            self.refuse(lambda: npt.polytope(v), ValueError)
        self.refuse(lambda: npt.polytope("cube"), TypeError)
        self.refuse(lambda: npt.polytope([[1, 2], [3]]), TypeError, ValueError)

    def test_shapes(self):
        self.refuse(lambda: npt.box((1, 1)), ValueError)
        self.refuse(lambda: npt.box((1, -1, 1)), ValueError)
        self.refuse(lambda: npt.box((1, math.nan, 1)), ValueError)
        self.refuse(lambda: npt.box((1, 1, 1), -0.1), ValueError)
        self.refuse(lambda: npt.box((1, 1, 1), math.nan), ValueError)
        self.refuse(lambda: npt.sphere(-1), ValueError)
        self.refuse(lambda: npt.sphere(math.inf), ValueError)
        self.refuse(lambda: npt.sphere("one"), TypeError)
        self.refuse(lambda: npt.cylinder(math.nan, 1), ValueError)
        self.refuse(lambda: npt.cone(1, -1), ValueError)
        self.refuse(lambda: npt.ellipsoid((1, -1, 1)), ValueError)
        self.refuse(lambda: npt.capsule((0, 0, 0), (0, 0, np.inf), 1), ValueError)
        self.refuse(lambda: npt.hull(np.full((4, 3), np.nan)), ValueError)
        self.refuse(lambda: npt.hull(np.zeros((0, 3))), ValueError)
        self.refuse(lambda: npt.mesh_hull(np.zeros((3, 3)), [[0, 1, 5]]), ValueError)
        self.refuse(lambda: npt.mesh_hull(np.zeros((3, 3)), [[0.0, 1.0, 2.0]]), TypeError)
        self.refuse(lambda: npt.polytope(np.eye(3), faces=[[0, 1, 7]]), ValueError)
        self.refuse(lambda: npt.Compound([]), ValueError)
        self.refuse(lambda: npt.Compound([(npt.sphere(1), "here")]), TypeError)
        self.refuse(lambda: npt.Compound([42]), TypeError)

    def test_poses(self):
        self.refuse(lambda: npt.Pose(np.eye(3)), ValueError)
        m = np.eye(4)
        m[3, 0] = 1
        self.assertIn("last row", self.refuse(lambda: npt.Pose(m), ValueError))
        m = np.eye(4)
        m[0, 3] = np.nan
        self.refuse(lambda: npt.Pose(m), ValueError)
        self.refuse(lambda: npt.Pose(np.eye(4, dtype=np.float32)), TypeError)
        self.refuse(lambda: npt.Pose(np.eye(8)[::2, ::2]), ValueError)
        self.assertIn("unit length",
                      self.refuse(lambda: npt.Pose.from_quaternion((0, 0, 0, 0)), ValueError))
        self.refuse(lambda: npt.Pose.from_quaternion((1, 0, 0)), ValueError)
        self.refuse(lambda: npt.Pose.from_rotation(np.eye(3), (0, math.inf, 0)), ValueError)
        self.refuse(lambda: npt.Pose.from_rotation(np.ones((3, 3)) * np.nan), ValueError)

    def test_distance(self):
        a, b = npt.box((1, 1, 1)), npt.sphere(1)
        far = (5, 0, 0, 1, 0, 0, 0)
        self.assertIn("rotation", self.refuse(
            lambda: npt.distance(a, npt.Pose.from_rotation(np.ones((3, 3))), b, far),
            ValueError))
        self.refuse(lambda: npt.distance(a, None, b, (5, 0, 0, 2, 0, 0, 0)), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, (5, 0, 0)), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, (5, 0, np.nan, 1, 0, 0, 0)), ValueError)
        self.refuse(lambda: npt.distance(a, None, "ball", far), TypeError)
        self.refuse(lambda: npt.distance(a, None, b, far, near_point=True), TypeError)
        self.refuse(lambda: npt.distance(a, None, b, far, epsilon=2.0), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, far, epsilon=math.nan), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, far, max_iterations=0), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, far, subalgorithm="simplex"), ValueError)
        self.refuse(lambda: npt.distance(a, None, b, far, cache="warm"), TypeError)
        self.refuse(lambda: npt.distance(a, None, b, far, threads=2), TypeError)
        huge = npt.Pose.from_translation((1e308, 0, 0))
        self.refuse(lambda: npt.distance(npt.sphere(1e307), None, b, huge), ValueError)

    def test_batch(self):
        a, b = npt.box((1, 1, 1)), npt.sphere(1)
        rows = np.zeros((8, 7))
        rows[:, 0] = np.arange(8)
        rows[:, 3] = 1
        self.refuse(lambda: npt.distance_batch(a, rows, b, rows[:5]), ValueError)
        self.refuse(lambda: npt.distance_batch(a, rows[:0], b, rows), ValueError)
        self.refuse(lambda: npt.distance_batch(a, rows[:, :6].copy(), b, None), ValueError)
        self.refuse(lambda: npt.distance_batch(a, rows[::2], b, None), ValueError)
        self.refuse(lambda: npt.distance_batch(a, rows.astype(np.float32), b, None), TypeError)
        self.refuse(lambda: npt.distance_batch([a] * 3, rows, b, None), ValueError)
        self.refuse(lambda: npt.distance_batch([], rows, b, None), ValueError)
        self.refuse(lambda: npt.distance_batch([a, "x"], None, b, None), TypeError)
        self.refuse(lambda: npt.distance_batch(a, rows, b, None, threads=-1), ValueError)
        self.refuse(lambda: npt.distance_batch(a, rows, b, None, errors="ignore"), ValueError)
        bad = rows.copy()
        bad[5, 4] = np.nan
        self.assertIn("row 5", self.refuse(lambda: npt.distance_batch(a, bad, b, None,
                                                                      threads=2), ValueError))
        res = npt.distance_batch(a, bad, b, None, errors="status", near_points=True)
        self.assertEqual(res.status[5], npt.Status.invalid_input)
        self.assertTrue(np.isnan(res.point_a[5]).all())
        self.assertTrue((np.delete(res.status, 5) != npt.Status.invalid_input).all())
        mats = np.tile(np.eye(4), (4, 1, 1))
        mats[2, 3, 3] = 2
        self.assertIn("row 2", self.refuse(lambda: npt.distance_batch(a, mats, b, None),
                                           ValueError))

    def test_random_sweep(self):
        """Random arrays of random shapes, dtypes and layouts into every entry point."""
        rng = np.random.default_rng(34)
        dtypes = [np.float64, np.float32, np.int32, np.int64, np.complex128, np.bool_, object]
        calls = [
            lambda x: npt.polytope(x),
            lambda x: npt.hull(x),
            lambda x: npt.box(x),
            lambda x: npt.ellipsoid(x),
            lambda x: npt.Pose(x),
            lambda x: npt.Pose.from_quaternion(x),
            lambda x: npt.Pose.from_rotation(x),
            lambda x: npt.distance(npt.sphere(1), x, npt.sphere(1), None),
            lambda x: npt.distance_batch(npt.sphere(1), x, npt.box((1, 1, 1)), None, threads=2),
            lambda x: npt.convex_hull(x),
            lambda x: npt.Pose().apply(x),
        ]
        outcomes = {"ok": 0, "refused": 0}
        for trial in range(3000):
            if rng.random() < 0.5:  # a shape some entry point takes
                shapes = [(3,), (4,), (7,), (3, 3), (4, 4), (9, 3), (5, 7), (5, 4, 4)]
                shape = shapes[int(rng.integers(len(shapes)))]
            else:
                ndim = int(rng.integers(0, 4))
                shape = tuple(int(rng.choice([0, 1, 2, 3, 4, 7, 9])) for _ in range(ndim))
            x = np.asarray(rng.normal(size=shape) * 10.0 ** float(rng.integers(-3, 300)))
            if x.size and rng.random() < 0.3:
                x.flat[int(rng.integers(x.size))] = rng.choice([np.nan, np.inf, -np.inf])
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if rng.random() < 0.5:
                    x = x.astype(dtypes[int(rng.integers(len(dtypes)))])
            if isinstance(x, np.ndarray) and x.ndim and rng.random() < 0.2:
                x = x[::-1]
            if rng.random() < 0.1:
                x = x.tolist()
            try:
                calls[trial % len(calls)](x)
                outcomes["ok"] += 1
            except (TypeError, ValueError) as e:
                self.assertTrue(str(e))
                outcomes["refused"] += 1
        self.assertGreater(outcomes["refused"], 1000, outcomes)
        self.assertGreater(outcomes["ok"], 50, outcomes)


class Api(unittest.TestCase):
    def test_version(self):
        self.assertRegex(npt.__version__, r"^\d+\.\d+\.\d+")

    def test_boxes_analytic(self):
        a = npt.box((0.5, 0.5, 0.5))
        b = npt.box((0.25, 0.25, 0.25), rounding=0.1)
        r = npt.distance(a, npt.Pose(), b, npt.Pose.from_translation((2, 0, 0)),
                         near_points=True, gradient=True)
        self.assertAlmostEqual(r.distance, 2 - 0.5 - 0.35, delta=max(r.error_bound, 1e-15))
        np.testing.assert_allclose(r.normal, [1, 0, 0])
        np.testing.assert_allclose(r.gradient_b[:3], [1, 0, 0], atol=1e-12)
        self.assertIsNone(r.depth)
        d = npt.distance(a, None, b, (0.2, 0, 0, 1, 0, 0, 0), penetration_depth=True)
        self.assertEqual(d.status, npt.Status.intersecting)
        lo, hi = d.depth_interval
        self.assertTrue(lo <= 0.5 + 0.35 - 0.2 <= hi, (lo, hi))  # B pushed out along +x
        self.assertEqual(d.signed_distance, -d.depth)

    def test_poses_agree(self):
        q = np.array(cases.random_quaternion(random.Random(3)))
        t = np.array([0.5, -2, 3])
        p = npt.Pose.from_quaternion(q, t)
        np.testing.assert_allclose(npt.Pose(p.matrix).matrix, p.matrix, rtol=0, atol=0)
        np.testing.assert_allclose(npt.Pose.from_rotation(p.rotation, t).matrix, p.matrix,
                                   atol=0)
        np.testing.assert_allclose(p.rotation @ p.rotation.T, np.eye(3), atol=1e-15)
        np.testing.assert_allclose((p @ p.inverse()).matrix, np.eye(4), atol=1e-15)
        np.testing.assert_allclose(p.apply(np.zeros((2, 3))), [t, t])
        s = npt.sphere(0.1)
        r1 = npt.distance(s, p, s, None)
        r2 = npt.distance(s, np.concatenate([t, q]), s, None)
        self.assertEqual(r1.distance, r2.distance)

    def test_compound_is_least_over_pieces(self):
        rng = random.Random(5)
        pieces = [(cases.random_spec(rng).make(npt), cases.random_row7(rng, 1.0))
                  for _ in range(4)]
        arm = npt.Compound(pieces)
        self.assertEqual(len(arm), 4)
        other = npt.ellipsoid((0.3, 0.5, 0.2))
        for _ in range(30):
            pa = npt.Pose.from_quaternion(cases.random_quaternion(rng), (0, 0, 0))
            pb = cases.random_row7(rng, 4.0)
            r = npt.distance(arm, pa, other, pb, near_points=True)
            singles = [npt.distance(shape, pa @ npt.Pose.from_quaternion(off[3:], off[:3]),
                                    other, pb) for shape, off in pieces]
            best = min(s.distance for s in singles)
            self.assertTrue(r.compound)
            self.assertLessEqual(abs(r.distance - best),
                                 r.error_bound + max(s.error_bound for s in singles) + 1e-12)
            self.assertIn(r.piece_a, range(4))
        rows = np.array([cases.random_row7(rng, 4.0) for _ in range(50)])
        batch = npt.distance_batch(arm, None, other, rows, cache=npt.Cache(), threads=2)
        for i in range(50):
            r = npt.distance(arm, None, other, rows[i])
            self.assertEqual(batch.distance[i], r.distance)
            self.assertEqual(batch.piece_a[i], r.piece_a)

    def test_cache_warm_starts(self):
        a, b = npt.polytope(np.random.default_rng(2).uniform(-1, 1, (30, 3))), npt.box((1, 1, 1))
        cache = npt.Cache()
        first = npt.distance(a, None, b, (4, 0, 0, 1, 0, 0, 0), cache=cache)
        second = npt.distance(a, None, b, (4.01, 0, 0, 1, 0, 0, 0), cache=cache)
        self.assertFalse(first.warm_started)
        self.assertTrue(second.warm_started)
        self.assertTrue(cache.simplex(0))
        cache.reset()
        self.assertEqual(cache.entries, 0)

    def test_hulls(self):
        rng = np.random.default_rng(7)
        pts = rng.uniform(-1, 1, (200, 3))
        h = npt.convex_hull(pts)
        self.assertEqual(h["dimension"], 3)
        shape = npt.hull(pts)
        self.assertEqual(len(shape.vertices), len(h["vertices"]))
        cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        tris = np.array([[0, 1, 2], [4, 5, 6], [3, 7, 1]])
        m = npt.mesh_hull(np.vstack([cube, [[9, 9, 9]]]), tris)  # vertex 8 unused
        r = npt.distance(m, None, npt.sphere(0.5), (3, 0, 0, 1, 0, 0, 0))
        self.assertAlmostEqual(r.distance, 1.5, delta=1e-12)
        p = npt.polytope(cube)
        self.assertEqual(npt.distance(p, None, npt.sphere(0.5), (3, 0, 0, 1, 0, 0, 0)).distance,
                         r.distance)

    def test_batch_shapes(self):
        a, b = npt.box((1, 1, 1)), npt.sphere(0.5)
        rows = np.zeros((6, 7))
        rows[:, 0] = np.arange(6) + 2
        rows[:, 3] = 1
        res = npt.distance_batch(a, None, b, rows)
        np.testing.assert_allclose(res.distance, np.arange(6) + 0.5, atol=1e-12)
        self.assertEqual(len(res), 6)
        empty = npt.distance_batch(a, None, b, np.zeros((0, 7)))
        self.assertEqual(len(empty), 0)
        one = npt.distance_batch(a, None, b, rows[0])
        self.assertEqual(len(one), 1)
        self.assertEqual(str(one.status[0] == npt.Status.separated), "True")
        self.assertEqual(str(npt.Status.touching), "touching")
        many = npt.distance_batch([a, b] * 3, None, b, rows, threads=0)
        self.assertEqual(many.status.dtype, np.uint8)
        self.assertTrue((many.status == npt.Status.separated).all())
        for threads in (1, 2, 3, 16):
            t = npt.distance_batch(a, None, b, rows, threads=threads, near_points=True)
            np.testing.assert_array_equal(t.distance, res.distance)

    def test_client_in_namespace(self):
        try:
            import grpc  # noqa: F401
        except ImportError:
            self.skipTest("grpcio is not installed")
        from nearpoint import client
        self.assertTrue(client.distance_pb.__name__.startswith("nearpoint.proto."))
        self.assertNotIn("nearpoint_geometry_pb2", sys.modules)
        old = os.environ.get("NEARPOINT_TARGET")
        os.environ["NEARPOINT_TARGET"] = "127.0.0.1:1"
        try:
            with self.assertRaises(client.NearpointError) as caught:
                client.connect(timeout=0.2)
            self.assertIn("127.0.0.1:1", str(caught.exception))
        finally:
            if old is None:
                del os.environ["NEARPOINT_TARGET"]
            else:
                os.environ["NEARPOINT_TARGET"] = old


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--pythonpath", required=True, help="build/client/python")
    parser.add_argument("--reference", required=True, help="build/tests/engine_reference")
    parser.add_argument("--paper-draws", type=int, default=5,
                        help="pose draws per pair and case of the paper's experiment (100: all)")
    ARGS, rest = parser.parse_known_args()
    sys.path.insert(0, ARGS.pythonpath)
    import nearpoint as npt  # noqa: E402
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
