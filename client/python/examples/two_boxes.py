#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Two boxes: a fixed cube and a flat box sliding past it; one line per streamed report.

    PYTHONPATH=build/client/python /usr/bin/python3 client/python/examples/two_boxes.py [HOST:PORT]
"""
import sys

from nearpoint import client as npc

target = sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1:50051"
with npc.connect(target) as client:
    cube = client.register_geometry([npc.box((0.5, 0.5, 0.5))], name="cube")
    slab = client.register_geometry([npc.box((1.0, 0.25, 0.1))], name="slab")
    scene = client.create_scene({"cube": cube, "slab": (slab, (4.0, 0.5, 0.3))},
                                options={"near_points": True})
    path = [(4.0 - 0.5 * k, 0.5, 0.3) for k in range(10)]  # the slab's centre, metres
    for report in client.stream(scene, ({"slab": centre} for centre in path)):
        pair = report.pair("cube", "slab")
        x, y, z = path[report.sequence - 1]
        print(f"seq {report.sequence} slab at ({x:g}, {y:g}, {z:g}) {pair.status} "
              f"distance {pair.distance:.9f} +- {pair.error_bound:.1e} "
              f"warm {pair.warm_started} server {report.server_us:.0f} us")
