# SPDX-License-Identifier: Apache-2.0
"""The nearpoint Python client: a thin, typed layer over the generated gRPC stubs.

Everything on the wire is in metres and radians; poses map an object's geometry frame to the
world frame; quaternions are (w, x, y, z). Calls that fail raise `NearpointError` carrying the
server's status code and message; a rejected *stream update* does not raise (the server keeps the
stream open) but yields a `Report` whose `error` says what was wrong.
"""

from __future__ import annotations

import itertools
import math
import os
import secrets
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Optional, Sequence, Tuple, Union

import grpc

from . import _vocabulary as vocabulary
from .proto import nearpoint_distance_pb2 as distance_pb
from .proto import nearpoint_distance_pb2_grpc as distance_grpc
from .proto import nearpoint_geometry_pb2 as geometry_pb
from .proto import nearpoint_scene_pb2 as scene_pb

Vec3 = Tuple[float, float, float]
Quat = Tuple[float, float, float, float]

#: The server address `connect` uses when given none and $NEARPOINT_TARGET is unset (nearpointd's
#: default --listen address).
DEFAULT_TARGET = "127.0.0.1:50051"
#: Seconds a unary call may take before it fails with DEADLINE_EXCEEDED.
DEFAULT_TIMEOUT = 10.0
# The largest message sent or received, bytes: nearpointd's --max-message-bytes default (16 MiB,
# model/include/nearpoint/model/scene_types.hpp), so that every report the server can send arrives.
# gRPC's own default receive limit, 4 MiB, would fail a large scene's reports with
# RESOURCE_EXHAUSTED "Received message larger than max".
DEFAULT_MAX_MESSAGE_BYTES = 16 * 1024 * 1024


class NearpointError(Exception):
    """A call the server (or the channel) refused.

    `code` is the `grpc.StatusCode` (e.g. `grpc.StatusCode.NOT_FOUND`); `message` is the server's
    own text, which names the offending field first ("scene_id: no scene 'scene-9'").
    """

    def __init__(self, code: grpc.StatusCode, message: str):
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message


def _raise_from(error: grpc.RpcError) -> NearpointError:
    return NearpointError(error.code(), error.details() or "")


# --- geometry -------------------------------------------------------------------------------

def _vec(v: Sequence[float]) -> geometry_pb.Vector3:
    if len(v) != 3:
        raise ValueError(f"expected 3 coordinates, got {len(v)}")
    return geometry_pb.Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def pose(translation: Sequence[float] = (0.0, 0.0, 0.0),
         rotation: Sequence[float] = (1.0, 0.0, 0.0, 0.0)) -> geometry_pb.Pose:
    """A pose: `translation` in metres and `rotation` as a unit quaternion (w, x, y, z).

    The server accepts quaternions within 1e-4 of unit length and normalises them.
    """
    if len(rotation) != 4:
        raise ValueError(f"rotation must be a quaternion (w, x, y, z), got {len(rotation)} values")
    w, x, y, z = (float(c) for c in rotation)
    return geometry_pb.Pose(rotation=geometry_pb.Quaternion(w=w, x=x, y=y, z=z),
                            translation=_vec(translation))


def rotation_about_z(angle: float) -> Quat:
    """The unit quaternion (w, x, y, z) of a rotation by `angle` radians about the z axis."""
    return (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


def _piece(radius: float, offset: Optional[geometry_pb.Pose], **shape) -> geometry_pb.Piece:
    piece = geometry_pb.Piece(radius=float(radius), **shape)
    if offset is not None:
        piece.offset.CopyFrom(offset)
    return piece


def box(half_extents: Sequence[float], radius: float = 0.0,
        offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The box [-h, h] (half extents h, metres), rounded by `radius`, placed by `offset`."""
    return _piece(radius, offset, box=geometry_pb.Box(half_extents=_vec(half_extents)))


def polytope(vertices: Iterable[Sequence[float]], radius: float = 0.0,
             offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The convex hull of `vertices` (metres; interior points and duplicates are fine)."""
    return _piece(radius, offset,
                  polytope=geometry_pb.Polytope(vertices=[_vec(v) for v in vertices]))


def sphere(radius: float, offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """A sphere of `radius` metres about the piece origin (a point rounded by the radius)."""
    return _piece(radius, offset, point=geometry_pb.PointShape())


def capsule(a: Sequence[float], b: Sequence[float], radius: float,
            offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The segment from `a` to `b` rounded by `radius` (radius 0: the bare segment)."""
    return _piece(radius, offset, segment=geometry_pb.Segment(a=_vec(a), b=_vec(b)))


def cylinder(radius: float, half_height: float, rounding: float = 0.0,
             offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The solid cylinder about the z axis from z = -half_height to +half_height."""
    return _piece(rounding, offset,
                  cylinder=geometry_pb.Cylinder(radius=radius, half_height=half_height))


def cone(radius: float, half_height: float, rounding: float = 0.0,
         offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The solid cone about z: base disc of `radius` at z = -half_height, apex at +half_height."""
    return _piece(rounding, offset, cone=geometry_pb.Cone(radius=radius, half_height=half_height))


def ellipsoid(radii: Sequence[float], rounding: float = 0.0,
              offset: Optional[geometry_pb.Pose] = None) -> geometry_pb.Piece:
    """The solid ellipsoid with semi-axes `radii` = (rx, ry, rz) along x, y, z."""
    return _piece(rounding, offset, ellipsoid=geometry_pb.Ellipsoid(radii=_vec(radii)))


# --- the API enums' spellings ----------------------------------------------------------------


def _numbers_by_spelling(enum) -> dict:
    """A generated protobuf enum's numbers by how the CLI and the scene files spell its values.

    The spellings are model/vocabulary.hpp's table (written out by the build as
    nearpoint_vocabulary, keyed by enumerator name), the numbers the generated enum's own
    (EnumTypeWrapper.Value, which fails at import if the two ever name different enumerators).
    """
    return {spelling: enum.Value(name)
            for name, spelling in vocabulary.SPELLINGS[enum.DESCRIPTOR.name].items()}


def _spellings_by_number(enum) -> dict:
    return {number: spelling for spelling, number in _numbers_by_spelling(enum).items()}


# --- reports --------------------------------------------------------------------------------

_STATUS_NAMES = _spellings_by_number(distance_pb.PairStatus)
_CROSSING_NAMES = _spellings_by_number(distance_pb.ThresholdCrossing)
_DEPTH_TERMINATION_NAMES = _spellings_by_number(distance_pb.DepthTermination)


def _tuple(v: geometry_pb.Vector3) -> Vec3:
    return (v.x, v.y, v.z)


@dataclass(frozen=True)
class PairDistance:
    """One pair of a report. Distances in metres; points and normal in the world frame.

    `status` is "separated", "intersecting" (overlap proven, distance 0), "touching" (contact
    within the bound: the signed distance's interval contains 0; distance 0), "beyond_cutoff"
    (only `distance_lower_bound` is meaningful), "iteration_limit" or "engine_error" (see
    `message`). `in_contact` is true for "intersecting" and "touching".
    `point_a`, `point_b` and `normal` (unit, A towards B) are None unless near points were asked
    for; `penetration_bound` is None unless asked for and the pair is in contact.

    With penetration="depth" (separated, intersecting and touching pairs): `signed_distance`
    (the distance when apart, -depth when overlapping) within [`signed_distance_lower`,
    `signed_distance_upper`], certified; `penetration_depth` (>= 0) within
    [`penetration_depth_lower`, `penetration_depth_upper`]; witness points `depth_point_a`,
    `depth_point_b` and the unit `depth_direction` (A towards B; depth_point_a - depth_point_b =
    penetration_depth * depth_direction; None for a separated pair without near points);
    `depth_termination` ("closed_form", "tolerance", "iteration_limit", "degenerate") and
    `depth_iterations`. Otherwise all None.
    """

    object_a: str
    object_b: str
    status: str
    distance: float
    distance_lower_bound: float
    error_bound: float
    iterations: int
    warm_started: bool
    point_a: Optional[Vec3]
    point_b: Optional[Vec3]
    normal: Optional[Vec3]
    penetration_bound: Optional[float]
    message: str
    signed_distance: Optional[float] = None
    signed_distance_lower: Optional[float] = None
    signed_distance_upper: Optional[float] = None
    penetration_depth: Optional[float] = None
    penetration_depth_lower: Optional[float] = None
    penetration_depth_upper: Optional[float] = None
    depth_point_a: Optional[Vec3] = None
    depth_point_b: Optional[Vec3] = None
    depth_direction: Optional[Vec3] = None
    depth_termination: Optional[str] = None
    depth_iterations: Optional[int] = None
    # Robot scenes with gradients: d distance / d q by joint name (a float; a tuple for ball
    # and free joints) for the joints that move one of the two objects.
    joint_gradient: Mapping[str, Union[float, Tuple[float, ...]]] = None

    @property
    def in_contact(self) -> bool:
        """Intersecting or touching: what every "is it a collision" test should ask."""
        return self.status in ("intersecting", "touching")

    @staticmethod
    def from_proto(p: distance_pb.PairDistance) -> "PairDistance":
        near = p.has_near_points
        signed = p.has_signed_distance
        depth = p.has_penetration_depth
        witnessed = depth and (p.depth_direction.x, p.depth_direction.y,
                               p.depth_direction.z) != (0.0, 0.0, 0.0)
        return PairDistance(
            object_a=p.object_a, object_b=p.object_b,
            status=_STATUS_NAMES.get(p.status, "unspecified"),
            distance=p.distance, distance_lower_bound=p.distance_lower_bound,
            error_bound=p.error_bound, iterations=p.iterations, warm_started=p.warm_started,
            point_a=_tuple(p.point_a) if near else None,
            point_b=_tuple(p.point_b) if near else None,
            normal=_tuple(p.normal) if near else None,
            penetration_bound=p.penetration_bound if p.has_penetration_bound else None,
            message=p.message,
            signed_distance=p.signed_distance if signed else None,
            signed_distance_lower=p.signed_distance_lower if signed else None,
            signed_distance_upper=p.signed_distance_upper if signed else None,
            penetration_depth=p.penetration_depth if depth else None,
            penetration_depth_lower=p.penetration_depth_lower if depth else None,
            penetration_depth_upper=p.penetration_depth_upper if depth else None,
            depth_point_a=_tuple(p.depth_point_a) if witnessed else None,
            depth_point_b=_tuple(p.depth_point_b) if witnessed else None,
            depth_direction=_tuple(p.depth_direction) if witnessed else None,
            depth_termination=(_DEPTH_TERMINATION_NAMES.get(p.depth_termination, "unknown")
                               if depth else None),
            depth_iterations=p.depth_iterations if depth else None,
            joint_gradient=_joint_gradient(p.joint_gradient))


def _joint_gradient(entries) -> dict:
    """JointDerivative messages → {joint: value} (a tuple for multi-coordinate joints)."""
    out = {}
    for d in entries:
        if d.joint in out:
            previous = out[d.joint]
            out[d.joint] = (previous if isinstance(previous, tuple) else (previous,)) + (d.value,)
        else:
            out[d.joint] = d.value
    return out


@dataclass(frozen=True)
class UpdateError:
    """Why a stream update was rejected: a status code name ("INVALID_ARGUMENT", "NOT_FOUND",
    ...), the offending field as a path into the update ("poses[0].pose.rotation") and the
    server's message."""

    code: str
    field: str
    message: str


@dataclass(frozen=True)
class ThresholdEvent:
    """A watched pair crossed a threshold: `crossing` is "enter" (closer than the threshold's
    distance) or "exit" (farther than distance + hysteresis); `distance` the distance that
    crossed (metres; 0 when intersecting, the proven lower bound when beyond the cutoff);
    `sequence` the update whose poses crossed (an absorbed one's when the server coalesced)."""

    threshold: str
    threshold_index: int
    object_a: str
    object_b: str
    crossing: str
    distance: float
    sequence: int

    @staticmethod
    def from_proto(e: distance_pb.ThresholdEvent) -> "ThresholdEvent":
        return ThresholdEvent(threshold=e.threshold, threshold_index=e.threshold_index,
                              object_a=e.object_a, object_b=e.object_b,
                              crossing=_CROSSING_NAMES.get(e.crossing, "enter"),
                              distance=e.distance, sequence=e.sequence)


def threshold(distance: float, hysteresis: float = 0.0, *, pair: Optional[Tuple[str, str]] = None,
              object_id: Optional[str] = None, groups: int = 0,
              name: str = "") -> scene_pb.Threshold:
    """A watched distance for `Client.stream(thresholds=...)`: reports carry an "enter" event
    when a watched pair comes closer than `distance` (metres) and an "exit" event when it gets
    farther than `distance + hysteresis`. Watches `pair` (two object ids), or `object_id`'s
    pairs, or every selected pair; `groups` (SceneObject.group bits) narrows them further.
    With the stream's penetration="depth" the signed distance is compared, and `distance` may be
    zero or negative (an overlap deeper than -distance); otherwise it must be > 0."""
    if pair is not None and object_id is not None:
        raise ValueError("give pair or object_id, not both")
    message = scene_pb.Threshold(name=name, distance=distance, hysteresis=hysteresis,
                                 groups=groups)
    if pair is not None:
        message.object_a, message.object_b = pair
    elif object_id is not None:
        message.object_a = object_id
    return message


@dataclass(frozen=True)
class Report:
    """The answer to one query or stream update: its `sequence` number and one `PairDistance`
    per selected pair of the scene, in the scene's pair order — or, for a rejected update, an
    `error` and no pairs. `server_us` is the server-side time from reading the update to handing
    over the report (microseconds); `raw` is the `DistanceReport` message itself."""

    sequence: int
    pairs: Tuple[PairDistance, ...]
    error: Optional[UpdateError]
    server_us: float
    coalesced_updates: int
    raw: distance_pb.DistanceReport
    # The mode that chose `pairs`: "all", "within-cutoff", "nearest", "global" or "changed".
    report_mode: str = "all"
    # Threshold crossings (streams with thresholds), oldest update first.
    events: Tuple[ThresholdEvent, ...] = ()
    # Robot scenes: (joint, position, lower, upper) of each joint outside its limits.
    joint_limit_violations: Tuple[Tuple[str, float, float, float], ...] = ()

    @staticmethod
    def from_proto(r: distance_pb.DistanceReport) -> "Report":
        error = None
        if r.HasField("error"):
            error = UpdateError(code=distance_pb.ErrorCode.Name(r.error.code)
                                .removeprefix("ERROR_CODE_"),
                                field=r.error.field, message=r.error.message)
        return Report(sequence=r.sequence,
                      pairs=tuple(PairDistance.from_proto(p) for p in r.pairs),
                      error=error, server_us=r.timing.server_us,
                      coalesced_updates=r.coalesced_updates, raw=r,
                      report_mode=_REPORT_MODE_NAMES.get(r.report_mode, "all"),
                      events=tuple(ThresholdEvent.from_proto(e) for e in r.events),
                      joint_limit_violations=tuple((v.joint, v.position, v.lower, v.upper)
                                                   for v in r.joint_limit_violations))

    def pair(self, object_a: str, object_b: str) -> PairDistance:
        """The entry for the pair (object_a, object_b), in either order; KeyError if absent."""
        for p in self.pairs:
            if {p.object_a, p.object_b} == {object_a, object_b}:
                return p
        raise KeyError(f"no pair ({object_a}, {object_b}) in the report")


# --- scenes and options ---------------------------------------------------------------------

_PENETRATION = _numbers_by_spelling(scene_pb.PenetrationMode)

# ReportMode by the CLI's names (nearpoint query/stream --mode).
_REPORT_MODE = _numbers_by_spelling(scene_pb.ReportMode)
_REPORT_MODE_NAMES = _spellings_by_number(scene_pb.ReportMode)


def query_options(epsilon: Optional[float] = None, near_points: Optional[bool] = None,
                  penetration: Optional[str] = None, gradient: Optional[bool] = None,
                  distance_cutoff: Optional[float] = None, warm_start: Optional[bool] = None,
                  max_iterations: Optional[int] = None, report_mode: Optional[str] = None,
                  change_tolerance: Optional[float] = None) -> scene_pb.QueryOptions:
    """Query options; every argument left as None inherits (update → scene → server defaults).

    `penetration` is "none", "bound" (a certified lower bound on the penetration depth) or
    "depth" (the signed distance and the penetration depth with certified intervals; thresholds
    may then be <= 0: the signed distance is compared).
    `report_mode` chooses which pairs a report holds: "all", "within-cutoff", "nearest" (each
    object's nearest pair), "global" (the one nearest pair) or "changed" (pairs whose status, or
    distance by more than `change_tolerance` metres, changed since the stream's previous report).
    """
    options = scene_pb.QueryOptions()
    if epsilon is not None:
        options.epsilon = epsilon
    if near_points is not None:
        options.near_points = near_points
    if penetration is not None:
        if penetration not in _PENETRATION:
            raise ValueError(f"penetration must be one of {sorted(_PENETRATION)}, "
                             f"got {penetration!r}")
        options.penetration = _PENETRATION[penetration]
    if gradient is not None:
        options.gradient = gradient
    if distance_cutoff is not None:
        options.distance_cutoff = distance_cutoff
    if warm_start is not None:
        options.warm_start = warm_start
    if max_iterations is not None:
        options.max_iterations = max_iterations
    if report_mode is not None:
        if report_mode not in _REPORT_MODE:
            raise ValueError(f"report_mode must be one of {sorted(_REPORT_MODE)}, "
                             f"got {report_mode!r}")
        options.report_mode = _REPORT_MODE[report_mode]
    if change_tolerance is not None:
        options.change_tolerance = change_tolerance
    return options


OptionsArg = Union[None, Mapping[str, object], scene_pb.QueryOptions]
PoseArg = Union[geometry_pb.Pose, Sequence[float]]


def _options(options: OptionsArg,
             report_mode: Optional[str] = None) -> Optional[scene_pb.QueryOptions]:
    """The options as a message; `report_mode`, when given, overrides theirs."""
    if options is not None and not isinstance(options, scene_pb.QueryOptions):
        options = query_options(**options)
    if report_mode is None:
        return options
    merged = scene_pb.QueryOptions()
    if options is not None:
        merged.CopyFrom(options)
    merged.MergeFrom(query_options(report_mode=report_mode))
    return merged


def _pose(value: PoseArg) -> geometry_pb.Pose:
    """A Pose message, or a bare (x, y, z) translation."""
    if isinstance(value, geometry_pb.Pose):
        return value
    return pose(translation=value)


def _object_poses(poses: Mapping[str, PoseArg]) -> list:
    return [distance_pb.ObjectPose(object_id=object_id, pose=_pose(p))
            for object_id, p in poses.items()]


@dataclass(frozen=True)
class Update:
    """One stream update with an explicit sequence number (strictly increasing) and options.
    `stream` also accepts bare pose mappings, numbered 1, 2, 3, ..."""

    sequence: int
    poses: Mapping[str, PoseArg]
    options: OptionsArg = None
    # Robot scenes: joint positions by name (a float, or a sequence for ball and free joints)
    # and the robot's base pose; joints not named keep their positions.
    joints: Optional[Mapping[str, Union[float, Sequence[float]]]] = None
    base_pose: Optional[PoseArg] = None


def _joint_positions(joints: Optional[Mapping[str, Union[float, Sequence[float]]]],
                     base_pose: Optional[PoseArg] = None) -> distance_pb.JointPositions:
    message = distance_pb.JointPositions()
    for name, value in (joints or {}).items():
        message.names.append(name)
        if isinstance(value, (int, float)):
            message.positions.append(float(value))
        else:
            message.positions.extend(float(v) for v in value)
    if base_pose is not None:
        message.base_pose.CopyFrom(_pose(base_pose))
    return message


_FLOW_CONTROL = _numbers_by_spelling(distance_pb.FlowControl)


#: The routing header of every call about one scene (create, delete, query, stream): a proxy
#: that hashes it (deploy/haproxy/) sends them all to the replica holding the scene.
SCENE_ROUTING_HEADER = "x-nearpoint-scene"


def _routing(scene_id: str):
    return ((SCENE_ROUTING_HEADER, scene_id),) if scene_id else None


class Client:
    """A connection to nearpointd. Use `connect()` to make one; close it (or use `with`)."""

    def __init__(self, channel: grpc.Channel, timeout: float = DEFAULT_TIMEOUT):
        self._channel = channel
        self._stub = distance_grpc.DistanceServiceStub(channel)
        self.timeout = timeout
        # Geometries registered through this client, by id: sent inline with the scenes that use
        # them, so that a scene is whole on whichever replica its routing header leads to.
        self._geometries = {}

    def close(self) -> None:
        """Closes the channel; open streams end with CANCELLED."""
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _call(self, method, request, scene_id: str = ""):
        try:
            return method(request, timeout=self.timeout, metadata=_routing(scene_id))
        except grpc.RpcError as error:
            raise _raise_from(error) from None

    def register_geometry(self, pieces: Sequence[geometry_pb.Piece], name: str = "") -> str:
        """Stores a geometry, the union of `pieces` (made with `box`, `polytope`, `sphere`, ...),
        and returns its id ("geom-" and 32 hex digits, derived from the content: the same
        geometry registered again gets the same id). Invalid pieces raise INVALID_ARGUMENT naming
        the field ("geometry.pieces[0].radius: ...")."""
        geometry = geometry_pb.Geometry(name=name, pieces=list(pieces))
        request = distance_pb.RegisterGeometryRequest(geometry=geometry)
        geometry_id = self._call(self._stub.RegisterGeometry, request).geometry.geometry_id
        self._geometries[geometry_id] = geometry
        return geometry_id

    def server_info(self):
        """The server's `ServerInfo` message: version, build options, transports and limits."""
        return self._call(self._stub.GetServerInfo, distance_pb.GetServerInfoRequest())

    def list_geometries(self) -> list:
        """Every stored geometry as a `GeometryInfo` message (id, name, counts, bounding sphere)."""
        response = self._call(self._stub.ListGeometries, distance_pb.ListGeometriesRequest())
        return list(response.geometries)

    def remove_geometry(self, geometry_id: str) -> None:
        """Removes a geometry from the store (scenes using it keep working)."""
        self._call(self._stub.RemoveGeometry,
                   distance_pb.RemoveGeometryRequest(geometry_id=geometry_id))

    def create_scene(self, objects: Mapping[str, Union[str, Tuple[str, PoseArg]]],
                     pairs: Optional[Sequence[Tuple[str, str]]] = None,
                     options: OptionsArg = None, name: str = "",
                     scene_id: Optional[str] = None, *,
                     padding: Optional[Mapping[str, float]] = None,
                     self_padding: Optional[Mapping[str, float]] = None,
                     bodies: Optional[Mapping[str, str]] = None,
                     robot: Optional[scene_pb.Robot] = None) -> str:
        """Creates a scene and returns its id: `scene_id`, or when it is None one chosen here
        ("s-" and 16 random hex digits), so that the call carries the routing header
        x-nearpoint-scene like every later call about the scene. Geometries registered through
        this client are sent along (CreateSceneRequest.geometries), so that the scene is whole on
        the replica that holds it behind a sharding proxy.

        `objects` maps each object id to a geometry id, or to (geometry id, initial pose); a pose
        is a `pose(...)` or a bare (x, y, z) translation. `pairs` lists the pairs to evaluate, in
        report order (default: all pairs, i < j in the order of `objects`). `options` are the
        scene's default query options: a `query_options(...)` or a dict of its arguments,
        e.g. {"near_points": True}.

        Padding as MoveIt's link padding: `padding` maps object ids to metres by which they are
        inflated against objects of other bodies, `self_padding` within their own body, and
        `bodies` maps object ids to a body (robot) id; reports then hold the padded distances.

        `robot` (a `Robot` message: links, joints, and the objects the links carry) makes an
        articulated scene: updates then give joint positions (`Update.joints`,
        `stream_joints`, `query(joints=...)`). `nearpoint scene create robot.urdf` builds one
        from URDF or MJCF.
        """
        if scene_id is None:
            scene_id = "s-" + secrets.token_hex(8)
        request = scene_pb.CreateSceneRequest(name=name, scene_id=scene_id)
        for object_id, spec in objects.items():
            geometry_id, initial = (spec, None) if isinstance(spec, str) else spec
            entry = request.objects.add(id=object_id, geometry_id=geometry_id)
            if geometry_id in self._geometries:
                request.geometries[geometry_id].CopyFrom(self._geometries[geometry_id])
            if initial is not None:
                entry.pose.CopyFrom(_pose(initial))
            entry.padding = (padding or {}).get(object_id, 0.0)
            entry.self_padding = (self_padding or {}).get(object_id, 0.0)
            entry.body = (bodies or {}).get(object_id, "")
        if robot is not None:
            request.robot.CopyFrom(robot)
        if pairs is not None:
            for a, b in pairs:
                request.pair_selection.listed_pairs.pairs.add(object_a=a, object_b=b)
        scene_options = _options(options)
        if scene_options is not None:
            request.default_options.CopyFrom(scene_options)
        return self._call(self._stub.CreateScene, request, scene_id).scene_id

    def list_scenes(self) -> list:
        """Every live scene on the server as a `SceneSummary` message (scene id, name, pair count
        and the objects as created), as `nearpoint scene list` shows them."""
        return list(self._call(self._stub.ListScenes, scene_pb.ListScenesRequest()).scenes)

    def delete_scene(self, scene_id: str) -> None:
        """Deletes a scene; its open streams get NOT_FOUND error reports afterwards."""
        self._call(self._stub.DeleteScene, scene_pb.DeleteSceneRequest(scene_id=scene_id),
                   scene_id)

    def query(self, scene_id: str, poses: Mapping[str, PoseArg] = None,
              options: OptionsArg = None, sequence: int = 0,
              report_mode: Optional[str] = None,
              joints: Optional[Mapping[str, Union[float, Sequence[float]]]] = None,
              base_pose: Optional[PoseArg] = None) -> Report:
        """Distances for the scene with the given object poses (others at their initial pose).
        An unknown scene raises NOT_FOUND, a bad pose INVALID_ARGUMENT naming the field.
        `report_mode` ("all", "within-cutoff", "nearest", "global", "changed") overrides the
        options' and the scene's. Robot scenes: `joints` by name (others at their reference
        positions) and `base_pose` place the robot's links."""
        request = distance_pb.QueryRequest(scene_id=scene_id, sequence=sequence,
                                           poses=_object_poses(poses or {}))
        if joints is not None or base_pose is not None:
            request.joints.CopyFrom(_joint_positions(joints, base_pose))
        query_opts = _options(options, report_mode)
        if query_opts is not None:
            request.options.CopyFrom(query_opts)
        return Report.from_proto(self._call(self._stub.Query, request, scene_id))

    def stream(self, scene_id: str, updates: Iterable[Union[Update, Mapping[str, PoseArg]]],
               options: OptionsArg = None, flow_control: str = "block",
               timeout: Optional[float] = None,
               report_mode: Optional[str] = None,
               thresholds: Sequence[scene_pb.Threshold] = (),
               batch: int = 1) -> Iterator[Report]:
        """Streams pose updates to the scene and yields one `Report` per update, in order.

        `updates` is any iterable (it may be a generator that runs as long as the robot moves) of
        `Update`s or of bare {object id: pose} mappings, numbered 1, 2, 3, ... . `options` apply
        to every bare update. The server keeps warm-start caches for the stream's lifetime.
        A rejected update yields a report with `error` set and the stream goes on; a failure of
        the stream itself (server gone, `timeout` seconds exceeded) raises `NearpointError`.
        `flow_control`: "block" (every update answered) or "coalesce" (the server merges updates
        that arrive while it is busy; only the first update's choice counts).
        `report_mode` (see `query_options`) applies to every bare update, overriding `options`'.
        `thresholds` (see `threshold`) are sent with the first update; each report's `events`
        then carries the crossings (the options' distance_cutoff must be at least each
        threshold's distance + hysteresis).
        `batch` > 1 sends that many consecutive updates per message (StreamPoseBatches: fewer
        gRPC messages for fast streams, the same reports); a batch goes out once it is full or
        `updates` ends.
        """
        if flow_control not in _FLOW_CONTROL:
            raise ValueError(f"flow_control must be one of {sorted(_FLOW_CONTROL)}")
        if batch < 1:
            raise ValueError("batch must be at least 1")
        default_options = _options(options, report_mode)

        def requests():
            counter = itertools.count(1)
            for index, item in enumerate(updates):
                joints = None
                if isinstance(item, Update):
                    sequence, poses, update_options = item.sequence, item.poses, item.options
                    if item.joints is not None or item.base_pose is not None:
                        joints = _joint_positions(item.joints, item.base_pose)
                else:
                    sequence, poses, update_options = next(counter), item, None
                message = distance_pb.PoseUpdate(scene_id=scene_id, sequence=sequence,
                                                 poses=_object_poses(poses))
                if joints is not None:
                    message.joints.CopyFrom(joints)
                if index == 0:
                    message.flow_control = _FLOW_CONTROL[flow_control]
                    message.thresholds.extend(thresholds)
                chosen = _options(update_options) if update_options is not None \
                    else default_options
                if chosen is not None:
                    message.options.CopyFrom(chosen)
                yield message

        def batches():
            pending = distance_pb.PoseUpdateBatch()
            for message in requests():
                pending.updates.append(message)
                if len(pending.updates) == batch:
                    yield pending
                    pending = distance_pb.PoseUpdateBatch()
            if pending.updates:
                yield pending

        if batch == 1:
            responses = self._stub.StreamPoses(requests(), timeout=timeout,
                                               metadata=_routing(scene_id))
            reports = responses
        else:
            responses = self._stub.StreamPoseBatches(batches(), timeout=timeout,
                                                     metadata=_routing(scene_id))
            reports = (report for message in responses for report in message.reports)
        try:
            for response in reports:
                yield Report.from_proto(response)
        except grpc.RpcError as error:
            raise _raise_from(error) from None
        finally:
            responses.cancel()  # the caller stopped early: end the call, not leave it open

    def stream_joints(self, scene_id: str,
                      positions: Iterable[Mapping[str, Union[float, Sequence[float]]]],
                      options: OptionsArg = None, **kwargs) -> Iterator[Report]:
        """`stream` for a robot scene: each item of `positions` maps joint names to positions
        (radians, metres; ball and free joints a sequence), numbered 1, 2, 3, ...; joints not
        named keep theirs. With gradients on (options={"gradient": True}), each pair's
        `joint_gradient` holds d distance / d q by joint. Other arguments as for `stream`."""
        updates = (Update(sequence=i, poses={}, options=options, joints=item)
                   for i, item in enumerate(positions, start=1))
        return self.stream(scene_id, updates, options=options, **kwargs)


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as error:
        raise NearpointError(grpc.StatusCode.INVALID_ARGUMENT,
                             f"cannot read '{path}': {error.strerror}") from None


def connect(target: Optional[str] = None, timeout: float = DEFAULT_TIMEOUT,
            max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES, *,
            tls: bool = False, tls_ca: Optional[str] = None, tls_cert: Optional[str] = None,
            tls_key: Optional[str] = None, token: Optional[str] = None,
            token_file: Optional[str] = None, tls_server_name: Optional[str] = None) -> Client:
    """Connects to nearpointd at `target` ("host:port"; default: $NEARPOINT_TARGET, else
    DEFAULT_TARGET, as the nearpoint CLI), waiting up to `timeout` seconds for the
    channel to be ready (NearpointError UNAVAILABLE otherwise). `timeout` is also each unary
    call's deadline. `max_message_bytes` bounds the messages sent and received; the default is
    the server's.

    Plain-text channel unless TLS is asked for (nearpointd --tls-cert): `tls=True`, or any of
    `tls_ca` (PEM file of the CA that signed the server's certificate; default: the system's
    roots), `tls_cert` and `tls_key` (PEM files: this client's certificate for mutual TLS), or a
    bearer token (`token`, or `token_file`, surrounding whitespace dropped), which gRPC sends as
    `authorization: Bearer <token>` over TLS only. `tls_server_name`: the name the server's
    certificate must carry when it is not the target's host."""
    if target is None:
        target = os.environ.get("NEARPOINT_TARGET") or DEFAULT_TARGET
    if (tls_cert is None) != (tls_key is None):
        raise NearpointError(grpc.StatusCode.INVALID_ARGUMENT,
                             "a client certificate and its key go together (tls_cert, tls_key)")
    if token_file is not None:
        token = _read(token_file).decode("ascii", errors="replace").strip()
        if not token:
            raise NearpointError(grpc.StatusCode.INVALID_ARGUMENT,
                                 f"the token file '{token_file}' is empty")
    options = [
        ("grpc.max_receive_message_length", max_message_bytes),
        ("grpc.max_send_message_length", max_message_bytes),
    ]
    if tls or tls_ca or tls_cert or token:
        credentials = grpc.ssl_channel_credentials(
            root_certificates=_read(tls_ca) if tls_ca else None,
            private_key=_read(tls_key) if tls_key else None,
            certificate_chain=_read(tls_cert) if tls_cert else None)
        if token:
            credentials = grpc.composite_channel_credentials(
                credentials, grpc.access_token_call_credentials(token))
        if tls_server_name:
            options.append(("grpc.ssl_target_name_override", tls_server_name))
        channel = grpc.secure_channel(target, credentials, options=options)
    else:
        channel = grpc.insecure_channel(target, options=options)
    try:
        grpc.channel_ready_future(channel).result(timeout=timeout)
    except grpc.FutureTimeoutError:
        channel.close()
        raise NearpointError(grpc.StatusCode.UNAVAILABLE,
                             f"no server at {target} within {timeout} s") from None
    return Client(channel, timeout=timeout)
