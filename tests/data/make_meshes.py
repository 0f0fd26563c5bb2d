#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the small meshes in this directory that tests/mesh/test_mesh_import.cpp reads.

Each mesh is built so that its convex hull is known by construction (the expectations are stated
in the test). Run from anywhere: python3 tests/data/make_meshes.py
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, text):
    with open(os.path.join(HERE, name), "w", encoding="ascii") as f:
        f.write(text)


def obj_object(name, vertices, faces, first_index):
    lines = [f"o {name}"]
    lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(first_index + i) for i in face) for face in faces]
    return lines


def box_mesh(lo, hi):
    """The 8 corners of an axis-aligned box and its 12 triangles (corner i has bit k set when
    coordinate k is at hi)."""
    corners = [tuple(hi[k] if (i >> k) & 1 else lo[k] for k in range(3)) for i in range(8)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    faces = []
    for a, b, c, d in quads:
        faces += [(a, b, c), (a, c, d)]
    return corners, faces


# cube.obj: the cube [-1, 1]^3 whose faces are each split into four triangles at the face's
# centre: 14 vertices, of which the 6 face centres lie on the boundary but are not extreme.
corners, _ = box_mesh((-1, -1, -1), (1, 1, 1))
quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
vertices = list(corners)
faces = []
for quad in quads:
    centre = tuple(sum(corners[i][k] for i in quad) / 4 for k in range(3))
    vertices.append(centre)
    c = len(vertices) - 1
    for j in range(4):
        faces.append((quad[j], quad[(j + 1) % 4], c))
write("cube.obj", "# cube [-1,1]^3, faces fanned from their centres\n" +
      "\n".join(obj_object("cube", vertices, faces, 1)) + "\n")

# star_prism.obj: a non-convex four-pointed star extruded along z in [0, 1]. Tips (+-2, 0) and
# (0, +-2), inner corners (+-0.5, +-0.5); the inner corners lie inside the tips' square
# |x| + |y| <= 2, so the hull's vertices are the 8 tips (4 at z = 0, 4 at z = 1) of 16.
ring = [(2, 0), (0.5, 0.5), (0, 2), (-0.5, 0.5), (-2, 0), (-0.5, -0.5), (0, -2), (0.5, -0.5)]
vertices = [(x, y, 0) for x, y in ring] + [(x, y, 1) for x, y in ring]
faces = [(1, 3, 5), (1, 5, 7)]                      # bottom: inner square
faces += [(7, 0, 1), (1, 2, 3), (3, 4, 5), (5, 6, 7)]  # bottom: tips
faces += [(8 + a, 8 + c, 8 + b) for a, b, c in faces]  # top, reversed
for i in range(8):
    j = (i + 1) % 8
    faces += [(i, j, 8 + j), (i, 8 + j, 8 + i)]
write("star_prism.obj", "# non-convex: a four-pointed star extruded along z\n" +
      "\n".join(obj_object("star", vertices, faces, 1)) + "\n")

# two_parts.obj: two objects. 'left' is the box [-3,-1] x [-1,1] x [-1,1]; 'right' the
# tetrahedron (1,0,0), (2,0,0), (1,1,0), (1,0,1). Merged, the hull has 11 vertices: all 8 box
# corners and the tetrahedron's (2,0,0), (1,1,0), (1,0,1); its (1,0,0) lies on the segment from
# (2,0,0) to the box's face centre (-1,0,0), inside the merged hull.
box_vertices, box_faces = box_mesh((-3, -1, -1), (-1, 1, 1))
tetra = [(1, 0, 0), (2, 0, 0), (1, 1, 0), (1, 0, 1)]
tetra_faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
lines = ["# two parts: a box and a tetrahedron"]
lines += obj_object("left", box_vertices, box_faces, 1)
lines += obj_object("right", tetra, tetra_faces, 9)
write("two_parts.obj", "\n".join(lines) + "\n")

# tetra_binary.stl: binary STL of the tetrahedron (0,0,0), (2,0,0), (0,3,0), (0,0,4); STL repeats
# each corner once per triangle (12 vertices, 4 distinct, all extreme).
tv = [(0, 0, 0), (2, 0, 0), (0, 3, 0), (0, 0, 4)]
with open(os.path.join(HERE, "tetra_binary.stl"), "wb") as f:
    f.write(b"nearpoint test tetrahedron".ljust(80, b" "))
    f.write(struct.pack("<I", len(tetra_faces)))
    for face in tetra_faces:
        f.write(struct.pack("<3f", 0, 0, 0))
        for i in face:
            f.write(struct.pack("<3f", *tv[i]))
        f.write(struct.pack("<H", 0))

# octahedron.off: |x| + |y| + |z| <= 1.5, 6 vertices, 8 faces.
ov = [(1.5, 0, 0), (-1.5, 0, 0), (0, 1.5, 0), (0, -1.5, 0), (0, 0, 1.5), (0, 0, -1.5)]
of = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
write("octahedron.off", "OFF\n# octahedron |x|+|y|+|z| <= 1.5\n6 8 0\n" +
      "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in ov) +
      "".join(f"3 {a} {b} {c}\n" for a, b, c in of))

# wedge.ply: ASCII PLY of a triangular prism (the triangle (0,0), (1,0), (0,1) extruded along z
# in [0, 0.5]) with one extra vertex strictly inside it, used by some faces as a badly made mesh
# might: 7 vertices, 6 extreme.
pv = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 0.5), (1, 0, 0.5), (0, 1, 0.5), (0.25, 0.25, 0.25)]
pf = [(0, 2, 1), (3, 4, 5), (0, 1, 6), (1, 4, 6), (4, 3, 6), (3, 0, 6), (1, 2, 5), (1, 5, 4),
      (2, 0, 3), (2, 3, 5)]
write("wedge.ply", "ply\nformat ascii 1.0\ncomment triangular prism with an interior vertex\n"
      f"element vertex {len(pv)}\nproperty float x\nproperty float y\nproperty float z\n"
      f"element face {len(pf)}\nproperty list uchar int vertex_indices\nend_header\n" +
      "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in pv) +
      "".join(f"3 {a} {b} {c}\n" for a, b, c in pf))

# nested_transform.gltf: node transforms are applied. The tetrahedron (0,0,0), (1,0,0), (0,1,0),
# (0,0,1) (as points) hangs from node 'tetra' (scale 2) under node 'carrier' (translation
# (10, 0, 0)): in the file's frame it is (10,0,0), (12,0,0), (10,2,0), (10,0,2).
import base64  # noqa: E402
import json  # noqa: E402

buf = b"".join(struct.pack("<3f", *p) for p in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)])
gltf = {
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "carrier", "translation": [10, 0, 0], "children": [1]},
              {"name": "tetra", "mesh": 0, "scale": [2, 2, 2]}],
    "meshes": [{"name": "tetra_points", "primitives": [{"attributes": {"POSITION": 0},
                                                         "mode": 0}]}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 1]}],
    "bufferViews": [{"buffer": 0, "byteLength": len(buf)}],
    "buffers": [{"byteLength": len(buf),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
}
write("nested_transform.gltf", json.dumps(gltf, indent=1) + "\n")
