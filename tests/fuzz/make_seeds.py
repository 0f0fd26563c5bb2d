#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the seed corpus of tests/fuzz (run from anywhere; rewrites corpus/*/seed-*).

Seeds are small, meaningful inputs: the shipped examples (examples/), the scene files' shapes, and
the paper's Section VII family (random polytopes of a few vertices), encoded in each target's
input format. Findings live beside them under other names and are never rewritten here.

  tests/fuzz/make_seeds.py   # Debian's /usr/bin/python3 with python3-protobuf, and protoc
                             # (both in deploy/install-deps.sh)
"""
import json
import math
import pathlib
import random
import struct
import subprocess
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent


def write(target, name, data):
    d = HERE / "corpus" / target
    d.mkdir(parents=True, exist_ok=True)
    (d / ("seed-" + name)).write_bytes(data if isinstance(data, bytes) else data.encode())


# ---- engine (fuzz_engine.cpp's byte layout) ----

class Engine:
    """Encodes values as fixed point (tag 40: 16-bit mantissa / 4096, times 2^scale in the target):
    a seed's geometry is written at unit scale and magnified by 2^scale, |scale| <= 32."""

    def __init__(self, use_float=False, scale=0, flags=2, ext=None, ext_args=b""):
        # ext: the extended layout (first byte bit 1 and flags bit 7, then this byte and the
        # parameters it asks for, `ext_args`): see run() in fuzz_engine.cpp.
        kind = (1 if use_float else 0) | (2 if ext is not None else 0)
        self.out = bytearray([kind, scale & 0xFF, flags | (128 if ext is not None else 0)])
        if ext is not None:
            self.out.append(ext)
            self.out += ext_args
        self.scale = scale
        self.rotation = 0

    def placement(self, rotation=0, far=None, degenerate=None):
        """A body's placement byte (extended layout only): rotation 0 quaternion, 1 signed
        permutation, 2/3 those perturbed; far = (k-byte, (int8, int8, int8)): local coordinates
        offset by (m/128)*2^k, cancelled by the pose; degenerate: the repeat byte."""
        mode = rotation | (4 if far else 0) | (8 if degenerate is not None else 0)
        self.out.append(mode)
        if far:
            self.out.append(far[0])
            self.out += bytes(m & 0xFF for m in far[1])
        if degenerate is not None:
            self.out.append(degenerate)
        self.rotation = rotation

    def value(self, v):
        m = round(v * 4096)
        assert -32768 <= m <= 32767, v
        self.out += bytes([40]) + struct.pack("<h", m)

    def vec(self, v):
        for c in v:
            self.value(c)

    def extent(self, v):
        self.out.append(1)  # not raw: |v|
        self.value(v)

    def pose(self, quat=(1, 0, 0, 0), t=(0, 0, 0), perm=0, perturb=None):
        if self.rotation & 1:
            self.out.append(perm)  # signed permutation code
        else:
            n = max(abs(c) for c in quat) or 1
            self.out += bytes((round(c / n * 100) & 0xFF) for c in quat)
        if self.rotation & 2:  # (delta byte, nine int8 entries of M)
            self.out.append(perturb[0])
            self.out += bytes(m & 0xFF for m in perturb[1])
        self.out.append(1)  # the common scale
        self.vec(t)

    def shape(self, kind, *params, radius=0.0):
        kinds = ["point", "segment", "box", "polytope", "cylinder", "cone", "ellipsoid"]
        self.out.append(kinds.index(kind))
        if kind == "segment":
            self.vec(params[0]); self.vec(params[1])
        elif kind in ("box", "ellipsoid"):
            for c in params[0]:
                self.extent(c)
        elif kind == "polytope":
            self.out.append(len(params[0]))
            for v in params[0]:
                self.vec(v)
        elif kind in ("cylinder", "cone"):
            self.extent(params[0]); self.extent(params[1])
        if radius:
            self.out.append(1); self.extent(radius)
        else:
            self.out.append(0)

    def tail(self, angle=10, axis=2, shift=(0.5, 0.25, 0)):
        self.vec((1, 0.5, 0.25)); self.vec((0, 1, 0))  # extra bracket directions
        self.out += bytes([angle & 0xFF, axis])
        self.vec(shift)  # magnified by 2^(scale - 8) in the target
        return bytes(self.out)


def engine_pair(name, a, pose_a, b, pose_b, **kw):
    e = Engine(**kw)
    e.shape(*a[0], **a[1]); e.pose(*pose_a)
    e.shape(*b[0], **b[1]); e.pose(*pose_b)
    write("engine", name, e.tail())


def paper_polytope(rng, n):
    # Section VII: vertices uniform in a cube, then the polytope placed at random.
    return [tuple(rng.uniform(-1, 1) for _ in range(3)) for _ in range(n)]


def engine_seeds():
    tetra = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    q45z = (0.9238795325112867, 0, 0, 0.3826834323650898)
    engine_pair("box-tetrahedron", (("box", (1, 0.5, 0.25)), {}), ((1, 0, 0, 0), (0, 0, 0)),
                (("polytope", tetra), {}), (q45z, (2, 1, 0.5)))
    engine_pair("spheres", (("point",), {"radius": 1}), (), (("point",), {"radius": 0.5}),
                ((1, 0, 0, 0), (3, 0, 0)))
    engine_pair("capsule-ellipsoid", (("segment", (-1, 0, 0), (1, 0, 0)), {"radius": 0.25}), (),
                (("ellipsoid", (1, 0.5, 0.5)), {}), ((0.7071, 0.7071, 0, 0), (0, 2, 0)))
    engine_pair("cylinder-cone", (("cylinder", 0.5, 1), {}), (), (("cone", 0.5, 1), {}),
                ((1, 0, 0, 0.2), (0.9, 0.3, 0.1)), flags=2 | 4)
    engine_pair("touching-boxes", (("box", (1, 1, 1)), {}), (), (("box", (1, 1, 1)), {}),
                ((1, 0, 0, 0), (2, 0, 0)), flags=2 | 8)
    engine_pair("intersecting-boxes-penetration", (("box", (1, 1, 1)), {}), (),
                (("box", (1, 1, 1)), {"radius": 0.1}), ((1, 0.1, 0.2, 0), (1.5, 0.2, 0)),
                flags=2 | 4)
    engine_pair("box-tetrahedron-float", (("box", (1, 0.5, 0.25)), {}), (),
                (("polytope", tetra), {}), (q45z, (2, 1, 0.5)), use_float=True)
    engine_pair("far-scale", (("box", (1, 1, 1)), {}), ((1, 0, 0, 0), (3, 0, 0)),
                (("box", (1, 1, 1)), {}), ((1, 0, 0, 0.1), (5.5, 0, 0)), scale=30)
    engine_pair("tiny-scale", (("box", (1, 1, 1)), {}), (), (("box", (1, 1, 1)), {}),
                ((1, 0, 0, 0), (3, 0, 0)), scale=-30)
    engine_pair("johnson-single-point", (("polytope", tetra), {}), (),
                (("cylinder", 0.3, 0.5), {"radius": 0.05}), ((1, 1, 0, 0), (0.5, 0.5, 1.2)),
                flags=2 | 16 | 32)
    rng = random.Random(1988)
    for i in range(4):
        n = 4 + 2 * i
        a, b = paper_polytope(rng, n), paper_polytope(rng, n)
        q = tuple(rng.uniform(-1, 1) for _ in range(4))
        t = tuple(rng.uniform(-3, 3) for _ in range(3))
        engine_pair(f"paper-family-{n}", (("polytope", a), {}), (), (("polytope", b), {}), (q, t),
                    flags=2 | (64 if i % 2 else 0), use_float=bool(i == 3))
    # The extended layout: the classes an outside fuzzer with an exact reference found
    # (tests/data/engine-findings/README.md), one seed each.
    seg = ("segment", (-7.75, -7.9, -0.25), (-3.625, -0.25, -7.9))
    # A degenerate segment 2^663 (~1e200) from its local origin, cancelled exactly by a
    # permutation pose, 9 units from a small one (the default options: today's engine answers it;
    # the fuzzer's mutations turn on Johnson, the single-point start and origin_shift off).
    e = Engine(flags=2, ext=16)
    e.placement(rotation=1, far=(128 | 78, (-16, -64, -128)))  # k = 127 + 78*873//127 = 663
    e.shape("segment", (0, 0, 0), (0, 0, 0)); e.pose(perm=8, t=(0, 0, 0))
    e.placement(rotation=1)
    e.shape(*seg); e.pose(perm=8, t=(0.5, 0.5, 0.5))
    write("engine", "ext-far-cancel-degenerate-segment", e.tail())
    # origin_shift off at ordinary magnitudes, Johnson's subalgorithm with the single-point start.
    e = Engine(flags=2 | 16 | 32, ext=1 | 16)
    e.placement()
    e.shape("polytope", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)])
    e.pose((0.9, 0.1, 0.2, 0.3), (0, 0, 0))
    e.placement()
    e.shape("box", (0.5, 0.5, 0.5)); e.pose((1, 0, 0, 0), (3, 1, 0.5))
    write("engine", "ext-origin-shift-off", e.tail())
    # A polytope modelled 2^40 from its origin, placed back by its pose (origin shift on).
    e = Engine(flags=2, ext=16)
    e.placement(far=(60, (100, -50, 30)))  # k = 10 + 60//2 = 40
    e.shape("polytope", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)])
    e.pose((0.9, 0.1, 0.2, 0.3), (0, 0, 0))
    e.placement()
    e.shape("box", (0.5, 0.5, 0.5)); e.pose((1, 0, 0, 0), (3, 1, 0.5))
    write("engine", "ext-far-polytope", e.tail())
    # A yes/no query (cutoff 0) on separated polytopes: the beyond_cutoff interval.
    e = Engine(flags=2, ext=2)
    e.shape("polytope", tetra); e.pose()
    e.shape("polytope", tetra); e.pose((1, 0, 0, 0.2), (4, 1, 0))
    write("engine", "ext-beyond-cutoff-0", e.tail())
    # A small positive cutoff (byte 40/256 of the unit scale).
    e = Engine(flags=2 | 16, ext=6, ext_args=bytes([40]))
    e.shape("box", (1, 1, 1)); e.pose()
    e.shape("segment", (0, 0, 0), (1, 1, 0), radius=0.25); e.pose((1, 0, 0, 0), (2.5, 0, 0))
    write("engine", "ext-small-cutoff", e.tail())
    # Float, a point and a degenerate segment 2^23 (~8e6) from its origin, cancelled by a
    # permutation; the perturbed pose then rotates it a little.
    e = Engine(use_float=True, flags=2, ext=1 | 16)
    e.placement(rotation=1)
    e.shape("point"); e.pose(perm=8)
    e.placement(rotation=1, far=(128 | 3, (30, -4, 120)), degenerate=1)  # k = 20 + 3 = 23
    e.shape("segment", (0, 0, 0), (0.5, 0, 0)); e.pose(perm=8, t=(7.5, 7.5, 7.5))
    write("engine", "ext-float-moderate-offset", e.tail())
    # A near-orthonormal rotation (perturbed by 2^-23) on B's polytope.
    e = Engine(flags=2 | 4, ext=16)
    e.placement()
    e.shape("box", (1, 0.5, 0.25)); e.pose((0.9, 0.3, 0.1, 0))
    e.placement(rotation=2)
    e.shape("polytope", tetra); e.pose(q45z, (1.5, 0.5, 0.25), perturb=(3, (1, 2, 3, -4, 5, -6, 7, -8, 9)))
    write("engine", "ext-near-orthonormal", e.tail())
    # Tiny shapes: the scale 2^-(50 + 200*561//255) = 2^-490 (~1e-148).
    e = Engine(flags=2, ext=32, ext_args=bytes([200]))
    e.shape("segment", (0, 0, 0), (1, 0, 0)); e.pose()
    e.shape("polytope", tetra); e.pose((1, 0, 0, 0.3), (0.5, 1.5, 0))
    write("engine", "ext-tiny-scale", e.tail())
    # Compounds: a gripper of three boxes over a table (examples/scene.json).
    e = Engine(flags=1 | 2)
    e.out.append(3)
    for t in ((0, -0.06, 0), (0, 0.06, 0)):
        e.shape("box", (0.1, 0.02, 0.08)); e.pose((1, 0, 0, 0), t)
    e.shape("box", (0.12, 0.1, 0.02)); e.pose((1, 0, 0, 0), (0, 0, 0.1))
    e.pose((1, 0, 0, 0), (0, 0, 0.5))
    e.out.append(1)
    e.shape("box", (1.0, 0.6, 0.02)); e.pose()
    e.pose()
    write("engine", "compound-gripper-table", e.tail())


# ---- requests (fuzz_requests.cpp: records of op, u16 length, serialized request) ----

def request_seeds():
    with tempfile.TemporaryDirectory() as tmp:
        proto_dir = ROOT / "proto" / "nearpoint" / "v1"
        subprocess.run(["protoc", f"-I{proto_dir}", f"--python_out={tmp}"] +
                       [str(p) for p in sorted(proto_dir.glob("*.proto"))], check=True)
        sys.path.insert(0, tmp)
        import nearpoint_geometry_pb2 as g
        import nearpoint_scene_pb2 as s
        import nearpoint_distance_pb2 as d

        def record(op, message):
            data = message.SerializeToString()
            return bytes([op]) + struct.pack("<H", len(data)) + data

        def geometry_request(name, build):
            req = d.RegisterGeometryRequest()
            req.geometry.name = name
            build(req.geometry)
            return record(0, req)

        def box_geometry(geom):
            p = geom.pieces.add()
            p.box.half_extents.x, p.box.half_extents.y, p.box.half_extents.z = 0.5, 0.5, 0.5

        def capsule_geometry(geom):
            p = geom.pieces.add()
            p.segment.a.z, p.segment.b.z = -0.5, 0.5
            p.radius = 0.2

        def gripper_geometry(geom):
            for t in (-0.06, 0.06):
                p = geom.pieces.add()
                p.box.half_extents.x, p.box.half_extents.y, p.box.half_extents.z = 0.1, 0.02, 0.08
                p.offset.translation.y = t
            p = geom.pieces.add()
            for v in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]:
                q = p.polytope.vertices.add()
                q.x, q.y, q.z = v
            p.offset.translation.z = 0.1
            p.offset.rotation.w, p.offset.rotation.z = 0.9238795325112867, 0.3826834323650898

        def scene(objects, options=None, selection=None):
            req = s.CreateSceneRequest()
            req.name = "seed"
            for oid, gid, t in objects:
                o = req.objects.add()
                o.id, o.geometry_id = oid, gid
                o.pose.translation.x, o.pose.translation.y, o.pose.translation.z = t
            if options:
                options(req.default_options)
            if selection:
                selection(req.pair_selection)
            return record(1, req)

        def poses(msg, moves):
            for oid, t in moves:
                p = msg.poses.add()
                p.object_id = oid
                p.pose.translation.x, p.pose.translation.y, p.pose.translation.z = t
                p.pose.rotation.w = 1

        def query(scene_id, moves, sequence=1, options=None):
            req = d.QueryRequest()
            req.scene_id, req.sequence = scene_id, sequence
            poses(req, moves)
            if options:
                options(req.options)
            return record(2, req)

        def update(scene_id, sequence, moves, coalesce=False):
            req = d.PoseUpdate()
            req.scene_id, req.sequence = scene_id, sequence
            poses(req, moves)
            if coalesce:
                req.flow_control = d.FLOW_CONTROL_COALESCE
            return record(3, req)

        def near(o):
            o.near_points = True
            o.penetration = s.PENETRATION_MODE_BOUND

        base = (geometry_request("cube", box_geometry) + geometry_request("post", capsule_geometry) +
                scene([("mover", "geom-1", (0, -2, 0)), ("post", "geom-2", (0, 0, 0))], near))
        write("requests", "register-scene-query", base + query("scene-1", [("mover", (0, -1, 0))]))
        write("requests", "stream-warm",
              base + update("scene-1", 1, [("mover", (0, -1.5, 0))]) +
              update("scene-1", 2, [("mover", (0, -1.4, 0))]) +
              update("scene-1", 3, [("mover", (0.1, -0.3, 0))]))
        write("requests", "stream-coalesce-delete",
              base + update("scene-1", 1, [("mover", (0, -1.5, 0))], coalesce=True) +
              record(5, s.DeleteSceneRequest(scene_id="scene-1")) +
              update("scene-1", 2, [("mover", (0, -1.4, 0))]) +
              record(4, d.RemoveGeometryRequest(geometry_id="geom-1")))

        def cutoff(o):
            o.distance_cutoff = 0.5
            o.gradient = True

        def listed(sel):
            pr = sel.listed_pairs.pairs.add()
            pr.object_a, pr.object_b = "gripper", "table"

        write("requests", "compound-listed-cutoff",
              geometry_request("gripper", gripper_geometry) + geometry_request("table", box_geometry) +
              geometry_request("post", capsule_geometry) +
              scene([("gripper", "geom-1", (0, 0, 0.5)), ("table", "geom-2", (0, 0, 0)),
                     ("post", "geom-3", (0.6, 0.3, 0))], None, listed) +
              query("scene-1", [("gripper", (0, 0, 0.7))], 7, cutoff))
        write("requests", "errors",
              geometry_request("empty", lambda geom: None) +
              scene([("a", "geom-9", (0, 0, 0))]) + query("scene-4", []) +
              update("nope", 1, []) + record(5, s.DeleteSceneRequest(scene_id="scene-1")))
        pose_update_wire_seeds(d, s)


# ---- pose_update_wire (fuzz_pose_update_wire.cpp: a byte, even PoseUpdate / odd batch, then
# the message), written by Python's protobuf ----

def pose_update_wire_seeds(d, scene_pb2):
    def update(sequence, poses, scene="cell45"):
        u = d.PoseUpdate(scene_id=scene, sequence=sequence)
        for i, (t, q) in enumerate(poses):
            p = u.poses.add(object_id=f"obj-{i}")
            if t is not None:
                p.pose.translation.x, p.pose.translation.y, p.pose.translation.z = t
            if q is not None:
                p.pose.rotation.w, p.pose.rotation.x, p.pose.rotation.y, p.pose.rotation.z = q
        return u

    rng = random.Random(36)

    def moves(n):
        out = []
        for _ in range(n):
            q = [rng.gauss(0, 1) for _ in range(4)]
            norm = math.sqrt(sum(c * c for c in q))
            out.append(([rng.uniform(-2, 2) for _ in range(3)], [c / norm for c in q]))
        return out

    write("pose_update_wire", "update", b"\x00" + update(7, moves(10)).SerializeToString())
    write("pose_update_wire", "update-parts-left-out",
          b"\x00" + update(1 << 40, [(None, (0, 0, 0, 1)), ((1, 0, 0), None), (None, None)])
          .SerializeToString())
    batch = d.PoseUpdateBatch()
    for k in range(8):
        batch.updates.append(update(100 + k, moves(10)))
    write("pose_update_wire", "batch-of-8", b"\x01" + batch.SerializeToString())
    # Options and flow control, as clients send them on every update (read); thresholds, as on a
    # stream's first update, and an unknown field (left to protobuf).
    first = update(1, moves(2))
    first.options.near_points = True
    first.options.report_mode = scene_pb2.REPORT_MODE_CHANGED
    first.options.epsilon = 1e-12
    first.flow_control = d.FLOW_CONTROL_COALESCE
    write("pose_update_wire", "update-with-options", b"\x00" + first.SerializeToString())
    first.thresholds.add(name="near", distance=0.1)
    write("pose_update_wire", "update-with-threshold", b"\x00" + first.SerializeToString())
    write("pose_update_wire", "update-unknown-field",
          b"\x00" + update(2, moves(1)).SerializeToString() + b"\x98\x06\x01")
    # Two messages back to back: protobuf merges them.
    write("pose_update_wire", "concatenated",
          b"\x00" + update(3, moves(2)).SerializeToString() +
          update(4, moves(3), scene="other").SerializeToString())


# ---- jsonl and scene files: the shipped examples ----

def text_seeds():
    pairs = (ROOT / "examples" / "pairs.jsonl").read_text()
    write("jsonl", "examples-pairs", pairs)
    for i, line in enumerate(pairs.splitlines()):
        write("jsonl", f"examples-pairs-{i + 1}", line + "\n")
    warm = "".join(json.dumps({"id": k, "a": {"box": [1, 1, 1]},
                               "b": {"sphere": {}, "radius": 0.5,
                                     "pose": {"translation": [3 - 0.5 * k, 0.1 * k, 0]}},
                               "options": {"warm": True, "near_points": True,
                                           "penetration": "bound"}}) + "\n" for k in range(5))
    write("jsonl", "warm-chain", warm)
    depth = "".join(json.dumps({"id": k, "a": {"box": [1, 1, 1]},
                                "b": {"sphere": {}, "radius": 0.5,
                                      "pose": {"translation": [2 - 0.5 * k, 0.1 * k, 0]}},
                                "options": {"near_points": k % 2 == 0,
                                            "penetration": "depth"}}) + "\n" for k in range(5))
    write("jsonl", "depth", depth)
    write("jsonl", "errors",
          '{"id": [1, {"x": null}], "a": {"box": [1, 1]}, "b": {"sphere": {}}}\n\n'
          '{"a": {"polytope": []}, "b": {"cone": {"radius": -1, "half_height": 1}}}\r\n'
          'not json\n[1, 2]\n{"a": {"sphere": {}}, "b": {"sphere": {}}, "colour": 1}\n'
          '{"a": {"sphere": {}}, "b": {"sphere": {}, "pose": {"rotation": [2, 0, 0, 0]}}}\n')

    def scene_seed(name, text, yaml=False):
        write("scene_file", name, ("Y" if yaml else "J") + text)

    scene_seed("examples-scene", (ROOT / "examples" / "scene.json").read_text())
    scene_seed("examples-dds-scene", (ROOT / "examples" / "dds_scene.json").read_text())
    no_mesh = json.loads((ROOT / "examples" / "scene.json").read_text())
    del no_mesh["geometries"]["cube"]
    no_mesh["objects"] = [o for o in no_mesh["objects"] if o["geometry"] != "cube"]
    no_mesh["pairs"] = {"listed": [["gripper", "table"], ["gripper", "post"]]}
    no_mesh["options"].update({"distance_cutoff": 2.0, "gradient": True, "max_iterations": 64,
                               "warm_start": False, "epsilon": 1e-20})
    scene_seed("gripper-listed", json.dumps(no_mesh, indent=1))
    scene_seed("yaml-scene", """\
id: cell-2
name: a YAML scene with an anchor
geometries:
  box: &unit {box: [0.5, 0.5, 0.5]}
  also_box: *unit
  rod: {segment: [[0, 0, 0], [0, 0, 1]], radius: 0.05}
  cone: {cone: {radius: 0.3, half_height: 0.4}, pose: {rotation: [1, 0, 0, 0], translation: [0, 0, 0.1]}}
  blob: [{ellipsoid: [0.2, 0.3, 0.4]}, {sphere: {}, radius: 0.1, pose: {translation: [0.5, 0, 0]}}]
objects:
  - {id: a, geometry: box}
  - {id: b, geometry: also_box, pose: {translation: [2, 0, 0]}, group: 2, mask: 1}
  - {id: c, geometry: rod, pose: {translation: [0, 2, 0]}}
  - {id: d, geometry: cone, pose: {translation: [0, -2, 0]}}
  - {id: e, geometry: blob, pose: {translation: [-2, 0, 0]}}
pairs: {excluded: [[a, b]]}
options: {near_points: true, penetration: bound}
""", yaml=True)


class Cdr:
    """XCDR1, little endian, as Cyclone DDS writes nearpoint_msgs samples: each primitive aligned
    to its size from the payload's start; strings as a uint32 length counting their NUL."""

    def __init__(self):
        self.out = bytearray()

    def put(self, fmt, *values):
        for code, value in zip(fmt, values):  # one at a time: each aligned to its own size
            self.out += bytes(-len(self.out) % struct.calcsize(code))
            self.out += struct.pack("<" + code, value)

    def string(self, text):
        data = text.encode() + b"\0"
        self.put("I", len(data))
        self.out += data


def cdr_report(c, sequence, pairs, status=0, message="", events=0):
    c.put("iI", 1733380000, 5)
    c.string("world")  # header
    c.string("cell45")
    c.string("load-1")
    c.out += bytes(range(16))  # writer_guid
    c.put("Q", sequence)
    c.put("I", status)
    c.string("poses[0]" if status else "")
    c.string(message)
    c.put("I", pairs)
    for k in range(pairs):
        c.string(f"o{k}")
        c.string(f"o{k + 1}")
        c.put("B", 1)
        c.put("ddd", 0.5, 0.49, 1e-9)
        c.put("IIII", 3, 1, 0, 0)
        c.put("BB", 1, 1)
        c.put("d" * 9, *([0.25] * 9))
        c.put("B", 0)
        c.put("d", 0.0)
        c.put("B", 0)
        c.put("d" * 12, *([0.0] * 12))
        c.string("")
        c.put("B", 0)
        c.put("ddd", 0.0, 0.0, 0.0)
        c.put("B", 0)
        c.put("ddd", 0.0, 0.0, 0.0)
        c.put("d" * 9, *([0.0] * 9))
        c.put("B", 0)
        c.put("I", 0)
    c.put("dddd", 30.5, 1.0, 20.0, 12.5)  # timing
    c.put("IQ", 0, 0)  # coalesced
    c.put("III", pairs, 0, 0)  # counts
    c.put("B", 1)  # report_mode
    c.put("I", events)
    for _ in range(events):
        c.put("iI", 0, 0)
        c.string("")
        c.string("cell45")
        c.string("load-1")
        c.string("near")
        c.put("I", 0)
        c.string("o0")
        c.string("o1")
        c.put("B", 1)
        c.put("d", 0.1)
        c.put("Q", sequence)


def dds_report_view_seeds():
    header = b"\x00\x01\x00\x00"  # CDR little endian, no options
    for name, pairs, status, events in (("empty", 0, 0, 0), ("two-pairs", 2, 0, 0),
                                        ("rejected", 0, 3, 0), ("events", 1, 0, 2)):
        c = Cdr()
        cdr_report(c, 7, pairs, status, "poses[0]: not a unit quaternion" if status else "", events)
        write("dds_report_view", name, b"\x00" + header + bytes(c.out))
    c = Cdr()
    c.put("I", 3)
    for k in range(3):
        cdr_report(c, 10 + k, k, 0, "", k % 2)
    write("dds_report_view", "batch-of-3", b"\x01" + header + bytes(c.out))


if __name__ == "__main__":
    engine_seeds()
    request_seeds()
    text_seeds()
    dds_report_view_seeds()
    for d in sorted((HERE / "corpus").iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} inputs")
