# SPDX-License-Identifier: Apache-2.0
"""nearpoint_client: talk to nearpointd, the nearpoint distance server, from Python.

    import nearpoint_client as npc
    with npc.connect("127.0.0.1:50051") as client:
        cube = client.register_geometry([npc.box((0.5, 0.5, 0.5))], name="cube")
        scene = client.create_scene({"a": cube, "b": (cube, (3, 0, 0))})
        print(client.query(scene).pairs[0].distance)          # 2.0
        for report in client.stream(scene, ({"b": (3 - 0.1 * k, 0, 0)} for k in range(5))):
            print(report.sequence, report.pairs[0].distance)

Needs grpcio and protobuf (Debian: python3-grpcio, python3-protobuf) and the modules generated
from proto/nearpoint/v1 by the CMake target `nearpoint_python`, which puts them and this package
in build/client/python (add that directory to PYTHONPATH).
"""

from ._version import __version__
from .client import (
    DEFAULT_MAX_MESSAGE_BYTES,
    DEFAULT_TIMEOUT,
    Client,
    NearpointError,
    PairDistance,
    Report,
    ThresholdEvent,
    Update,
    UpdateError,
    box,
    capsule,
    cone,
    connect,
    cylinder,
    ellipsoid,
    polytope,
    pose,
    query_options,
    rotation_about_z,
    sphere,
    threshold,
)

__all__ = [
    "__version__",
    "DEFAULT_MAX_MESSAGE_BYTES", "DEFAULT_TIMEOUT", "Client", "NearpointError", "PairDistance", "Report", "ThresholdEvent",
    "Update",
    "UpdateError", "box", "capsule", "cone", "connect", "cylinder", "ellipsoid", "polytope",
    "pose", "query_options", "rotation_about_z", "sphere", "threshold",
]
