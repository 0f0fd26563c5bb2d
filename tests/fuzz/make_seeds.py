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

    def __init__(self, use_float=False, scale=0, flags=2):
        self.out = bytearray([1 if use_float else 0, scale & 0xFF, flags])
        self.scale = scale

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

    def pose(self, quat=(1, 0, 0, 0), t=(0, 0, 0)):
        n = max(abs(c) for c in quat) or 1
        self.out += bytes((round(c / n * 100) & 0xFF) for c in quat)
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


if __name__ == "__main__":
    engine_seeds()
    request_seeds()
    text_seeds()
    for d in sorted((HERE / "corpus").iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} inputs")
