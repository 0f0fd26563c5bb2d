#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""The Python client (client/python) against a real nearpointd child process on 127.0.0.1:0.

Distances are checked against analytic truth: for axis-aligned boxes the distance is the length
of the per-axis gaps, max(0, |c_a - c_b| - (h_a + h_b)), computed here without the engine.

    /usr/bin/python3 tests/python/test_python_client.py --nearpointd build/server/nearpointd \
        --pythonpath build/client/python --example client/python/examples/two_boxes.py

The server dies with this process whatever happens (PR_SET_PDEATHSIG), and is stopped with
SIGTERM (it must drain and exit 0) at the end.
"""
import argparse
import ctypes
import math
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
import unittest

ARGS = None  # set in __main__
npc = None  # nearpoint.client, imported once the path is known
nearpoint = None


def box_distance(centre_a, half_a, centre_b, half_b):
    """Distance between two axis-aligned boxes: the length of the per-axis gaps."""
    gaps = [max(0.0, abs(centre_a[k] - centre_b[k]) - (half_a[k] + half_b[k])) for k in range(3)]
    return math.sqrt(sum(g * g for g in gaps))


def die_with_parent():
    """Runs in the child before exec: SIGKILL it when the test process dies, however it dies."""
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


class PythonClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="nearpoint_py_")
        port_file = os.path.join(cls.tmp.name, "port")
        cls.server = subprocess.Popen(
            [ARGS.nearpointd, "--listen", "127.0.0.1:0", "--port-file", port_file,
             "--log-level", "warn", "--workers", "2"],
            preexec_fn=die_with_parent)
        # The port file is written atomically once the server listens; wait for it (bounded).
        deadline = time.monotonic() + 20
        while not os.path.exists(port_file):
            if cls.server.poll() is not None or time.monotonic() > deadline:
                cls.stop_server()
                raise RuntimeError("nearpointd did not start")
            time.sleep(0.05)
        with open(port_file, encoding="ascii") as f:
            cls.target = f"127.0.0.1:{int(f.read().strip())}"
        cls.client = npc.connect(cls.target, timeout=10)

    @classmethod
    def stop_server(cls):
        if cls.server.poll() is None:
            cls.server.send_signal(signal.SIGTERM)
            try:
                cls.server.wait(timeout=15)
            except subprocess.TimeoutExpired:
                cls.server.kill()
                cls.server.wait()

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.stop_server()
        cls.tmp.cleanup()
        # SIGTERM drains the streams and exits 0; anything else is a server bug worth failing on.
        if cls.server.returncode != 0:
            raise AssertionError(f"nearpointd exited with {cls.server.returncode}")

    # --- helpers ---

    def register_box(self, half):
        return self.client.register_geometry([npc.box(half)], name=f"box {half}")

    def check_pair(self, pair, truth, what):
        """The reported distance agrees with the truth within the certified bound (plus the
        truth's own rounding), the verdict matches, and near points are consistent."""
        self.assertLessEqual(abs(pair.distance - truth), pair.error_bound + 1e-12,
                             f"{what}: distance {pair.distance!r}, truth {truth!r}")
        self.assertLess(pair.error_bound, 1e-9, what)
        if truth > 1e-9:
            self.assertEqual(pair.status, "separated", what)
        else:  # overlapping or touching: in contact either way
            self.assertTrue(pair.in_contact, f"{what}: {pair.status}")
        if pair.point_a is not None and pair.status == "separated":
            gap = math.dist(pair.point_a, pair.point_b)
            self.assertAlmostEqual(gap, pair.distance, delta=1e-12, msg=what)
            self.assertAlmostEqual(math.hypot(*pair.normal), 1.0, delta=1e-12, msg=what)

    # --- tests ---

    def test_version_is_the_servers_and_the_builds(self):
        # One version: the package's __version__ (generated from CMake's project version),
        # `nearpointd --version` and the server's GetServerInfo agree.
        printed = subprocess.run([ARGS.nearpointd, "--version"], capture_output=True, text=True,
                                 check=True).stdout.split()
        self.assertEqual(printed, ["nearpointd", nearpoint.__version__])
        self.assertRegex(nearpoint.__version__, r"^\d+\.\d+\.\d+$")
        info = self.client.server_info()
        self.assertEqual(info.version, nearpoint.__version__)
        self.assertEqual(info.limits.workers, 2)
        self.assertTrue(info.build.grpc)

    def test_example_two_boxes_prints_the_analytic_distances(self):
        env = dict(os.environ, PYTHONPATH=ARGS.pythonpath)
        run = subprocess.run([sys.executable, ARGS.example, self.target], env=env,
                             capture_output=True, text=True, timeout=60)
        self.assertEqual(run.returncode, 0, run.stderr)
        lines = run.stdout.splitlines()
        self.assertEqual(len(lines), 10, run.stdout)
        pattern = re.compile(r"seq (\d+) slab at \(([-\d.e]+), ([-\d.e]+), ([-\d.e]+)\) (\w+) "
                             r"distance ([-\d.e]+) \+- ([-\d.e+]+) warm (True|False)")
        statuses = set()
        for index, line in enumerate(lines):
            match = pattern.match(line)
            self.assertIsNotNone(match, line)
            sequence = int(match.group(1))
            centre = tuple(float(match.group(k)) for k in (2, 3, 4))
            distance, bound = float(match.group(6)), float(match.group(7))
            self.assertEqual(sequence, index + 1)
            truth = box_distance((0, 0, 0), (0.5, 0.5, 0.5), centre, (1.0, 0.25, 0.1))
            # The example prints 9 decimals.
            self.assertLessEqual(abs(distance - truth), bound + 1e-9, line)
            # Overlapping boxes: the least per-axis overlap is the depth; 0 is a touch (x = 1.5).
            overlap = min(0.5 + h - abs(c) for c, h in zip(centre, (1.0, 0.25, 0.1)))
            expected = ("separated" if truth > 0 else "intersecting" if overlap > 0
                        else "touching")
            self.assertEqual(match.group(5), expected, line)
            statuses.add(match.group(5))
        # The slab passes through, touching the cube's face on the way.
        self.assertEqual(statuses, {"separated", "touching", "intersecting"})

    def test_query_matches_analytic_box_distances(self):
        rng = random.Random(20261121)
        halves = [tuple(rng.uniform(0.2, 1.0) for _ in range(3)) for _ in range(3)]
        ids = [self.register_box(h) for h in halves]
        names = ["a", "b", "c"]
        scene = self.client.create_scene(dict(zip(names, ids)), options={"near_points": True})
        verdicts = {"separated": 0, "intersecting": 0}
        for trial in range(40):
            centres = [tuple(rng.uniform(-1.0, 1.0) for _ in range(3)) for _ in names]
            # Quarter turns about z keep the boxes axis-aligned with x and y extents swapped.
            turns = [rng.randrange(4) for _ in names]
            poses = {n: npc.pose(c, npc.rotation_about_z(t * math.pi / 2))
                     for n, c, t in zip(names, centres, turns)}
            report = self.client.query(scene, poses, sequence=trial + 1)
            self.assertEqual(report.sequence, trial + 1)
            self.assertIsNone(report.error)
            self.assertEqual([(p.object_a, p.object_b) for p in report.pairs],
                             [("a", "b"), ("a", "c"), ("b", "c")])
            placed = [(h[1], h[0], h[2]) if t % 2 else h for h, t in zip(halves, turns)]
            for pair in report.pairs:
                i, j = names.index(pair.object_a), names.index(pair.object_b)
                truth = box_distance(centres[i], placed[i], centres[j], placed[j])
                self.check_pair(pair, truth, f"trial {trial} {pair.object_a}-{pair.object_b}")
                verdicts["intersecting" if pair.in_contact else pair.status] += 1
        # The sample exercises both verdicts.
        self.assertGreater(verdicts["separated"], 30, verdicts)
        self.assertGreater(verdicts["intersecting"], 20, verdicts)

    def test_scenes_are_routable_and_carry_their_geometries(self):
        # Issue 24: behind a proxy that hashes x-nearpoint-scene, a scene's id must exist before
        # the scene does (the client picks one), and its geometries travel with it.
        crate = self.client.register_geometry([npc.box((0.5, 0.5, 0.5))], name="py crate")
        self.assertEqual(self.client.register_geometry([npc.box((0.5, 0.5, 0.5))],
                                                       name="py crate"), crate)  # content id
        self.assertTrue(crate.startswith("geom-") and len(crate) == 5 + 32, crate)
        chosen = self.client.create_scene({"a": crate, "b": (crate, (3, 0, 0))})
        self.assertTrue(chosen.startswith("s-") and len(chosen) == 18, chosen)
        # Removed from the store, the geometry still comes inline with the next scene.
        self.client.remove_geometry(crate)
        named = self.client.create_scene({"a": crate, "b": (crate, (0, 4, 0))},
                                         scene_id="py-routed")
        self.assertEqual(named, "py-routed")
        self.assertAlmostEqual(self.client.query(named).pair("a", "b").distance, 3.0,
                               delta=1e-12)
        self.assertIn(crate, [g.geometry_id for g in self.client.list_geometries()])
        # The server lists both scenes with their objects; a deleted one is gone from the list.
        listed = {s.scene_id: s for s in self.client.list_scenes()}
        self.assertIn(chosen, listed)
        self.assertEqual(listed[named].pair_count, 1)
        self.assertEqual(sorted(o.id for o in listed[named].objects), ["a", "b"])
        self.client.delete_scene(chosen)
        self.assertNotIn(chosen, [s.scene_id for s in self.client.list_scenes()])

    def test_report_mode_passes_through(self):
        """report_mode= reaches the server: "global" gives the all-pairs report's nearest pair and
        the report names its mode; a stream in "changed" mode sends every pair first, then only
        the pairs a move changed."""
        ids = [self.register_box((0.5, 0.5, 0.5)) for _ in range(3)]
        scene = self.client.create_scene({"a": (ids[0], (0, 0, 0)), "b": (ids[1], (3, 0, 0)),
                                          "c": (ids[2], (0, 10, 0))})
        everything = self.client.query(scene, {})
        self.assertEqual(everything.report_mode, "all")
        nearest = min(everything.pairs, key=lambda p: p.distance)
        best = self.client.query(scene, {}, report_mode="global")
        self.assertEqual(best.report_mode, "global")
        self.assertEqual([(p.object_a, p.object_b) for p in best.pairs],
                         [(nearest.object_a, nearest.object_b)])
        reports = list(self.client.stream(scene, [{}, {"c": (0, 11, 0)}], report_mode="changed"))
        self.assertEqual([r.report_mode for r in reports], ["changed", "changed"])
        self.assertEqual(len(reports[0].pairs), 3)
        self.assertEqual(sorted((p.object_a, p.object_b) for p in reports[1].pairs),
                         [("a", "c"), ("b", "c")])
        with self.assertRaises(ValueError):
            npc.query_options(report_mode="nearest-ish")

    def test_padding_is_subtracted_per_body(self):
        """padding=, self_padding= and bodies= reach the server: two unit cubes 3 m apart (gap
        2 m) report 2 - 0.3 - 0.2 against each other as separate bodies, 2 - 0.1 - 0.1 as one
        body (self padding), touch when the padding closes the gap exactly and intersect when it
        overlaps."""
        ids = [self.register_box((0.5, 0.5, 0.5)) for _ in range(2)]
        objects = {"a": (ids[0], (0, 0, 0)), "b": (ids[1], (3, 0, 0))}
        pads = {"a": 0.3, "b": 0.2}
        apart = self.client.create_scene(objects, padding=pads,
                                         self_padding={"a": 0.1, "b": 0.1})
        self.assertAlmostEqual(self.client.query(apart).pairs[0].distance, 1.5, places=12)
        one = self.client.create_scene(objects, padding=pads, self_padding={"a": 0.1, "b": 0.1},
                                       bodies={"a": "arm", "b": "arm"})
        self.assertAlmostEqual(self.client.query(one).pairs[0].distance, 1.8, places=12)
        wide = self.client.create_scene(objects, padding={"a": 1.5, "b": 0.5})
        # The paddings (1.5 + 0.5) close the 2 m gap exactly: contact within the bound.
        self.assertEqual(self.client.query(wide).pairs[0].status, "touching")
        deep = self.client.create_scene(objects, padding={"a": 1.5, "b": 0.75})
        self.assertEqual(self.client.query(deep).pairs[0].status, "intersecting")

    def test_depth_mode_reports_signed_distance_and_depth(self):
        """penetration="depth" reaches the server and the fields come back: unit cubes whose
        centres are 0.875 apart along x overlap by exactly 0.125 (face contact); a sphere of
        radius 0.5 whose centre is 0.375 from a cube's face overlaps it by 0.125. Each exact depth
        lies in the reported interval; without the option the fields are None; a negative
        threshold fires ENTER in depth mode."""
        cube = self.register_box((0.5, 0.5, 0.5))
        ball = self.client.register_geometry([npc.sphere(0.5)], name="ball")
        objects = {"a": (cube, (0, 0, 0)), "b": (cube, (0.875, 0.25, 0.125)),
                   "s": (ball, (0, 0, -0.875))}
        scene = self.client.create_scene(objects, pairs=[("a", "b"), ("a", "s")],
                                          options={"penetration": "depth"})
        report = self.client.query(scene)
        self.assertIsNone(report.error)
        for pair, direction in zip(report.pairs, [(1, 0, 0), (0, 0, -1)]):
            what = f"{pair.object_a}-{pair.object_b}"
            self.assertEqual(pair.status, "intersecting", what)
            self.assertTrue(pair.in_contact, what)
            self.assertLessEqual(pair.penetration_depth_lower, 0.125, what)
            self.assertGreaterEqual(pair.penetration_depth_upper, 0.125, what)
            self.assertLessEqual(pair.penetration_depth_lower, pair.penetration_depth, what)
            self.assertLessEqual(pair.penetration_depth, pair.penetration_depth_upper, what)
            self.assertLess(pair.penetration_depth_upper - pair.penetration_depth_lower, 1e-9, what)
            self.assertEqual(pair.signed_distance, -pair.penetration_depth, what)
            self.assertLessEqual(pair.signed_distance_lower, -0.125, what)
            self.assertGreaterEqual(pair.signed_distance_upper, -0.125, what)
            self.assertLess(math.dist(pair.depth_direction, direction), 1e-9, what)
            gap = [a - b for a, b in zip(pair.depth_point_a, pair.depth_point_b)]
            self.assertLess(math.dist(gap, [pair.penetration_depth * c for c in direction]), 1e-9,
                            what)
            self.assertIn(pair.depth_termination, ("closed_form", "tolerance"), what)
            self.assertIsInstance(pair.depth_iterations, int)
        plain = self.client.query(scene, options={"penetration": "none"}).pairs[0]
        self.assertEqual(plain.status, "intersecting")
        self.assertIsNone(plain.signed_distance)
        self.assertIsNone(plain.penetration_depth)
        self.assertIsNone(plain.depth_termination)
        # A negative threshold: ENTER when the cubes overlap deeper than 0.0625.
        watch = npc.threshold(-0.0625, pair=("a", "b"), name="deep")
        xs = [1.5, 0.875]
        reports = list(self.client.stream(scene, ({"b": (x, 0.25, 0.125)} for x in xs),
                                          thresholds=[watch]))
        events = [(e.sequence, e.crossing, e.threshold) for r in reports for e in r.events]
        self.assertEqual(events, [(2, "enter", "deep")])
        self.assertAlmostEqual(reports[1].events[0].distance, -0.125, places=9)

    def test_thresholds_report_enter_and_exit_events(self):
        """thresholds= reaches the server and events come back: box b (half-size 0.5, like a)
        moves along x; the gap is x - 1. ENTER below 0.2, EXIT above 0.2 + 0.1: the pass through
        the band (gaps 0.25, 0.28) fires nothing; each crossing fires once, named."""
        ids = [self.register_box((0.5, 0.5, 0.5)) for _ in range(2)]
        scene = self.client.create_scene({"a": (ids[0], (0, 0, 0)), "b": (ids[1], (3, 0, 0))})
        xs = [3.0, 1.15, 1.1, 1.25, 1.28, 1.4, 1.05, 3.0]
        watch = npc.threshold(0.2, 0.1, pair=("a", "b"), name="close")
        reports = list(self.client.stream(scene, ({"b": (x, 0, 0)} for x in xs),
                                          thresholds=[watch]))
        events = [(e.sequence, e.crossing) for r in reports for e in r.events]
        self.assertEqual(events, [(2, "enter"), (6, "exit"), (7, "enter"), (8, "exit")])
        first = reports[1].events[0]
        self.assertEqual((first.threshold, first.object_a, first.object_b), ("close", "a", "b"))
        self.assertAlmostEqual(first.distance, 0.15, places=12)
        with self.assertRaises(ValueError):
            npc.threshold(0.1, pair=("a", "b"), object_id="a")

    def test_stream_reports_in_order_with_sequences_and_warm_starts(self):
        fixed, moving = self.register_box((0.5, 0.5, 0.5)), self.register_box((0.3, 0.2, 0.1))
        scene = self.client.create_scene({"fixed": fixed, "moving": (moving, (3, 0, 0))})
        # A helix around the fixed box, sequence numbers 10, 20, 30, ...
        path = [(2.0 * math.cos(0.05 * k), 2.0 * math.sin(0.05 * k), 0.01 * k)
                for k in range(60)]
        for batch in (1, 7):  # StreamPoses, then StreamPoseBatches (60 = 8 x 7 + 4)
            with self.subTest(batch=batch):
                updates = (npc.Update(sequence=10 * (k + 1), poses={"moving": c})
                           for k, c in enumerate(path))
                reports = list(self.client.stream(scene, updates, options={"near_points": True},
                                                  timeout=60, batch=batch))
                self.assertEqual([r.sequence for r in reports], [10 * (k + 1) for k in range(60)])
                for k, report in enumerate(reports):
                    self.assertIsNone(report.error)
                    (pair,) = report.pairs
                    truth = box_distance((0, 0, 0), (0.5, 0.5, 0.5), path[k], (0.3, 0.2, 0.1))
                    self.check_pair(pair, truth, f"update {k}")
                    # The first update starts cold; the stream's cache warms every later one.
                    self.assertEqual(pair.warm_started, k > 0, f"update {k}")
                    self.assertGreater(report.server_us, 0)

    def test_rejected_update_is_a_report_and_the_stream_goes_on(self):
        cube = self.register_box((0.5, 0.5, 0.5))
        scene = self.client.create_scene({"a": cube, "b": (cube, (2, 0, 0))})
        updates = [
            npc.Update(1, {"b": (3, 0, 0)}),
            npc.Update(2, {"b": npc.pose((3, 0, 0), (2, 0, 0, 0))}),  # not a unit quaternion
            npc.Update(3, {"ghost": (1, 1, 1)}),                      # no such object
            npc.Update(4, {"b": (1.5, 0.5, 0)}),
        ]
        for batch in (1, 4):  # the bad updates in the middle of one batch, answered in place
            with self.subTest(batch=batch):
                reports = list(self.client.stream(scene, iter(updates), timeout=30, batch=batch))
                self.assertEqual([r.sequence for r in reports], [1, 2, 3, 4])
                self.check_pair(reports[0].pairs[0], 2.0, "update 1")
                self.assertEqual(reports[1].pairs, ())
                self.assertEqual(reports[1].error.code, "INVALID_ARGUMENT")
                self.assertEqual(reports[1].error.field, "poses[0].pose.rotation")
                self.assertIn("unit length", reports[1].error.message)
                self.assertEqual(reports[2].error.code, "NOT_FOUND")
                self.assertIn("ghost", reports[2].error.message)
                self.check_pair(reports[3].pairs[0], 0.5, "update 4")

    def test_a_report_larger_than_4_mib_arrives(self):
        """Guards the client's receive limit (DEFAULT_MAX_MESSAGE_BYTES, the server's send limit):
        with gRPC's default of 4 MiB, this scene's reports (~5.7 MB: 300 spheres with 40-byte ids,
        44 850 pairs) failed with RESOURCE_EXHAUSTED "Received message larger than max" although
        the server sent them; now a query and a stream update both arrive whole."""
        sphere = self.client.register_geometry([npc.sphere(1.0)], name="unit sphere")
        objects = {f"o{i}-".ljust(40, "x"): (sphere, (3.0 * (i % 20), 3.0 * (i // 20), 0))
                   for i in range(300)}
        scene = self.client.create_scene(objects)
        report = self.client.query(scene, {})
        self.assertEqual(len(report.pairs), 300 * 299 // 2)
        # The premise: with gRPC's old default the same query does not arrive.
        small = npc.connect(self.target, timeout=10, max_message_bytes=4 * 1024 * 1024)
        try:
            with self.assertRaises(npc.NearpointError) as raised:
                small.query(scene, {})
            self.assertEqual(raised.exception.code.name, "RESOURCE_EXHAUSTED")
        finally:
            small.close()
        reports = list(self.client.stream(scene, iter([npc.Update(1, {})]), timeout=60))
        self.assertEqual([r.sequence for r in reports], [1])
        self.assertEqual(len(reports[0].pairs), 300 * 299 // 2)

    def test_unknown_scene_raises_with_the_servers_message(self):
        with self.assertRaises(npc.NearpointError) as raised:
            self.client.query("scene-does-not-exist", {})
        self.assertEqual(raised.exception.code.name, "NOT_FOUND")
        self.assertIn("no scene 'scene-does-not-exist'", raised.exception.message)
        self.assertIn("scene_id", raised.exception.message)

    def test_unknown_geometry_and_bad_piece_name_the_field(self):
        cube = self.register_box((0.5, 0.5, 0.5))
        with self.assertRaises(npc.NearpointError) as raised:
            self.client.create_scene({"a": cube, "b": "geom-999999"})
        self.assertEqual(raised.exception.code.name, "NOT_FOUND")
        self.assertIn("objects[1].geometry_id", raised.exception.message)
        with self.assertRaises(npc.NearpointError) as raised:
            self.client.register_geometry([npc.sphere(-1.0)])
        self.assertEqual(raised.exception.code.name, "INVALID_ARGUMENT")
        self.assertIn("geometry.pieces[0].radius", raised.exception.message)

    def test_connect_to_a_closed_port_fails_with_unavailable(self):
        # Port 1 on loopback: nothing listens there; the attempt never leaves the machine.
        with self.assertRaises(npc.NearpointError) as raised:
            npc.connect("127.0.0.1:1", timeout=0.5)
        self.assertEqual(raised.exception.code.name, "UNAVAILABLE")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--pythonpath", required=True, help="build/client/python")
    parser.add_argument("--example", required=True, help="client/python/examples/two_boxes.py")
    ARGS, rest = parser.parse_known_args()
    sys.path.insert(0, ARGS.pythonpath)
    import nearpoint  # noqa: E402  (the path is only known now)
    from nearpoint import client as npc  # noqa: E402
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
