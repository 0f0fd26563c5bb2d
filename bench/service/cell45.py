#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The cell45 reference scene of capacity.sh and profile.sh, written to DIR: cell45.json (10
random convex polytopes of 20-100 vertices, all 45 pairs) and cell45.jsonl (every object moving
along a smooth path, period 1000 updates). Fixed seed: the same scene and path on every run.

    bench/service/cell45.py DIR
"""
import json, math, random, sys
work = sys.argv[1]
rng = random.Random(24)
objects, geometries = [], {}
for i in range(10):
    n = rng.randint(20, 100)
    radii = [rng.uniform(0.3, 0.7) for _ in range(3)]
    points = []
    for _ in range(n):
        v = [rng.gauss(0, 1) for _ in range(3)]
        norm = math.sqrt(sum(c * c for c in v))
        points.append([round(r * c / norm, 6) for r, c in zip(radii, v)])
    geometries[f"p{i}"] = {"polytope": points}
    objects.append({"id": f"o{i}", "geometry": f"p{i}"})
json.dump({"id": "cell45", "geometries": geometries, "objects": objects},
          open(f"{work}/cell45.json", "w"))
with open(f"{work}/cell45.jsonl", "w") as out:
    for t in range(1000):
        poses = {}
        for i in range(10):
            a = 2 * math.pi * (i / 10 + t / 1000)
            angle = 2 * math.pi * t / 1000 + i
            poses[f"o{i}"] = {"rotation": [math.cos(angle / 2), 0, 0, math.sin(angle / 2)],
                              "translation": [1.6 * math.cos(a) + 0.3 * math.sin(3 * a),
                                              1.6 * math.sin(a), 0.2 * math.cos(2 * a)]}
        out.write(json.dumps({"t": t, "poses": poses}) + "\n")
