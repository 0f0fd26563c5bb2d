#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""The Python client's robot scenes (issue 32) against a real nearpointd child process.

A planar two-link arm (shoulder and elbow about z, links 1 m and 0.8 m) carries a sphere of
radius 0.1 at its tip; a box stands beside it. Distances are checked against the analytic truth
computed here (the tip by hand-written forward kinematics, then the point's distance to the box
less the radius); the joint gradient against central differences of that truth and of the
distances the server reports; bad joint updates against their error reports.

    /usr/bin/python3 tests/python/test_python_robot.py --nearpointd build/server/nearpointd \
        --pythonpath build/client/python
"""
import argparse
import math
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "common"))
from nearpointd_process import NearpointdProcess  # noqa: E402

ARGS = None
npc = None

BOX_CENTRE = (1.5, 1.0, 0.0)
BOX_HALF = (0.2, 0.3, 0.2)
RADIUS = 0.1


def tip(shoulder, elbow):
    return (math.cos(shoulder) + 0.8 * math.cos(shoulder + elbow),
            math.sin(shoulder) + 0.8 * math.sin(shoulder + elbow), 0.0)


def truth(shoulder, elbow):
    p = tip(shoulder, elbow)
    gaps = [max(0.0, abs(p[k] - BOX_CENTRE[k]) - BOX_HALF[k]) for k in range(3)]
    return max(0.0, math.sqrt(sum(g * g for g in gaps)) - RADIUS)


class PythonRobotTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = NearpointdProcess(ARGS.nearpointd, ["--workers", "2"]).__enter__()
        # Registered before anything else can fail: tearDownClass does not run when setUpClass
        # raises, and the server would outlive the test.
        cls.addClassCleanup(cls.server.__exit__, None, None, None)
        cls.client = npc.connect(f"127.0.0.1:{cls.server.port}")
        cls.addClassCleanup(cls.client.close)
        from nearpoint.proto import nearpoint_scene_pb2 as scene_pb
        robot = scene_pb.Robot(name="planar")
        upper = robot.links.add(name="upper")
        upper.joints.add(name="shoulder", type=scene_pb.JOINT_TYPE_REVOLUTE,
                         limited=True, lower=-3.0, upper=3.0)
        fore = robot.links.add(name="fore", parent="upper", offset=npc.pose((1.0, 0.0, 0.0)))
        fore.joints.add(name="elbow", type=scene_pb.JOINT_TYPE_REVOLUTE)
        robot.attachments.add(object_id="hand", link="fore", offset=npc.pose((0.8, 0.0, 0.0)))
        hand = cls.client.register_geometry([npc.sphere(RADIUS)], name="hand")
        wall = cls.client.register_geometry([npc.box(BOX_HALF)], name="wall")
        cls.scene = cls.client.create_scene({"hand": hand, "wall": (wall, BOX_CENTRE)},
                                            robot=robot, scene_id="planar")

    def test_streamed_joints_give_the_analytic_distance_and_its_gradient(self):
        path = [{"shoulder": 0.1 * k, "elbow": 0.5 - 0.07 * k} for k in range(12)]
        reports = list(self.client.stream_joints(self.scene, path, options={"gradient": True}))
        self.assertEqual(len(reports), len(path))
        h = 1e-6
        checked = 0
        for joints, report in zip(path, reports):
            self.assertIsNone(report.error)
            pair = report.pair("hand", "wall")
            a, b = joints["shoulder"], joints["elbow"]
            self.assertAlmostEqual(pair.distance, truth(a, b), delta=1e-12)
            if truth(a, b) == 0.0:  # the path passes through the box: no gradient in contact
                self.assertTrue(pair.in_contact, pair.status)
                self.assertEqual(pair.joint_gradient, {})
                continue
            checked += 1
            expected = {"shoulder": (truth(a + h, b) - truth(a - h, b)) / (2 * h),
                        "elbow": (truth(a, b + h) - truth(a, b - h)) / (2 * h)}
            self.assertEqual(set(pair.joint_gradient), {"shoulder", "elbow"})
            for name, value in expected.items():
                self.assertAlmostEqual(pair.joint_gradient[name], value, delta=1e-6, msg=name)
        self.assertGreaterEqual(checked, 5)

    def test_gradient_equals_differences_of_reported_distances(self):
        a, b, h = 0.4, -0.2, 1e-6
        at = [{"shoulder": a, "elbow": b},
              {"shoulder": a + h}, {"shoulder": a - h}, {"shoulder": a},
              {"elbow": b + h}, {"elbow": b - h}]
        r = [rep.pair("hand", "wall") for rep in
             self.client.stream_joints(self.scene, at, options={"gradient": True})]
        self.assertAlmostEqual(r[0].joint_gradient["shoulder"],
                               (r[1].distance - r[2].distance) / (2 * h), delta=1e-6)
        self.assertAlmostEqual(r[0].joint_gradient["elbow"],
                               (r[4].distance - r[5].distance) / (2 * h), delta=1e-6)

    def test_query_base_pose_and_limits(self):
        report = self.client.query(self.scene, joints={"shoulder": 3.2, "elbow": 0.0},
                                   base_pose=npc.pose((0.0, 0.0, 5.0)))
        self.assertIsNone(report.error)
        # Lifted 5 m: the tip is 5 m above the box's plane.
        p = tip(3.2, 0.0)
        gaps = [max(0.0, abs(p[k] - BOX_CENTRE[k]) - BOX_HALF[k]) for k in range(2)] + [4.8]
        self.assertAlmostEqual(report.pair("hand", "wall").distance,
                               math.sqrt(sum(g * g for g in gaps)) - RADIUS, delta=1e-12)
        self.assertEqual([v[0] for v in report.joint_limit_violations], ["shoulder"])

    def test_bad_joint_updates_are_reported_and_the_stream_goes_on(self):
        updates = [npc.Update(sequence=1, poses={}, joints={"shoulder": 0.2}),
                   npc.Update(sequence=2, poses={}, joints={"wrist": 0.2}),
                   npc.Update(sequence=3, poses={}, joints={"elbow": float("nan")}),
                   npc.Update(sequence=4, poses={}, joints={"elbow": (0.1, 0.2)}),
                   npc.Update(sequence=5, poses={"hand": (0.0, 0.0, 0.0)}),
                   npc.Update(sequence=6, poses={}, joints={"elbow": 0.3})]
        reports = list(self.client.stream(self.scene, updates))
        self.assertEqual([r.sequence for r in reports], [1, 2, 3, 4, 5, 6])
        self.assertIsNone(reports[0].error)
        for report, field in zip(reports[1:5], ["joints.names[0]", "joints.positions[0]",
                                                "joints.positions", "poses[0].object_id"]):
            self.assertEqual(report.error.code, "INVALID_ARGUMENT")
            self.assertEqual(report.error.field, field, report.error.message)
        self.assertIsNone(reports[5].error)
        self.assertAlmostEqual(reports[5].pair("hand", "wall").distance, truth(0.2, 0.3),
                               delta=1e-12)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--nearpointd", required=True)
    parser.add_argument("--pythonpath", required=True)
    ARGS, rest = parser.parse_known_args()
    sys.path.insert(0, ARGS.pythonpath)
    from nearpoint import client as npc  # noqa: E402
    unittest.main(argv=[sys.argv[0]] + rest)
