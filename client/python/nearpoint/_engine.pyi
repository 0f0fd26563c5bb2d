# SPDX-License-Identifier: Apache-2.0
# Type stubs of nearpoint._engine (client/python/src/engine.cpp), the engine's bindings.
from enum import IntEnum
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = Union[npt.NDArray[np.float64], Sequence[float], Sequence[Sequence[float]]]
PoseLike = Union["Pose", npt.NDArray[np.float64], Sequence[float], Sequence[Sequence[float]], None]

class Status(IntEnum):
    separated = 0
    intersecting = 1
    iteration_limit = 2
    invalid_input = 3
    touching = 4

class Termination(IntEnum):
    origin_enclosed = 0
    tolerance = 1
    repeated_support = 2
    roundoff_floor = 3
    numerical_limit = 4
    beyond_cutoff = 5
    iteration_limit = 6
    contact = 7

class DepthTermination(IntEnum):
    closed_form = 0
    tolerance = 1
    iteration_limit = 2
    degenerate = 3

class FinishedBy(IntEnum):
    distance_subalgorithm = 0
    backup_procedure = 1

class Pose:
    def __init__(self, matrix: Optional[ArrayLike] = ...) -> None: ...
    @staticmethod
    def identity() -> Pose: ...
    @staticmethod
    def from_matrix(matrix: ArrayLike) -> Pose: ...
    @staticmethod
    def from_quaternion(quaternion: ArrayLike, translation: ArrayLike = ...) -> Pose: ...
    @staticmethod
    def from_rotation(rotation: ArrayLike, translation: ArrayLike = ...) -> Pose: ...
    @staticmethod
    def from_translation(translation: ArrayLike) -> Pose: ...
    @property
    def rotation(self) -> npt.NDArray[np.float64]: ...
    @property
    def translation(self) -> npt.NDArray[np.float64]: ...
    @property
    def matrix(self) -> npt.NDArray[np.float64]: ...
    def inverse(self) -> Pose: ...
    def __matmul__(self, child: Pose) -> Pose: ...
    def apply(self, points: ArrayLike) -> npt.NDArray[np.float64]: ...

class Shape:
    @property
    def kind(self) -> str: ...
    @property
    def rounding(self) -> float: ...
    @property
    def center(self) -> npt.NDArray[np.float64]: ...
    @property
    def extent(self) -> float: ...
    @property
    def vertices(self) -> Optional[npt.NDArray[np.float64]]: ...
    def support(self, direction: ArrayLike) -> Tuple[npt.NDArray[np.float64], int]: ...

class Compound:
    def __init__(self, pieces: Sequence[Union[Shape, Tuple[Shape, PoseLike]]]) -> None: ...
    def __len__(self) -> int: ...

class Cache:
    def __init__(self) -> None: ...
    def reset(self) -> None: ...
    @property
    def rows(self) -> int: ...
    @property
    def entries(self) -> int: ...
    def simplex(self, entry: int = ...) -> List[Tuple[int, int]]: ...

class Result:
    status: Status
    distance: float
    error_bound: float
    gap: float
    diameter_bound: float
    iterations: int
    support_calls: int
    subalgorithm_runs: int
    termination: Termination
    warm_started: bool
    finished_by: FinishedBy
    simplex: List[Tuple[int, int, float]]
    has_near_points: bool
    point_a: Optional[npt.NDArray[np.float64]]
    point_b: Optional[npt.NDArray[np.float64]]
    normal: Optional[npt.NDArray[np.float64]]
    has_penetration_bound: bool
    penetration_bound: Optional[float]
    has_signed_distance: bool
    signed_distance: Optional[float]
    signed_distance_interval: Optional[Tuple[float, float]]
    has_penetration_depth: bool
    depth: Optional[float]
    depth_interval: Optional[Tuple[float, float]]
    depth_point_a: Optional[npt.NDArray[np.float64]]
    depth_point_b: Optional[npt.NDArray[np.float64]]
    depth_direction: Optional[npt.NDArray[np.float64]]
    depth_termination: Optional[DepthTermination]
    depth_iterations: int
    has_gradient: bool
    gradient_a: Optional[npt.NDArray[np.float64]]
    gradient_b: Optional[npt.NDArray[np.float64]]
    converged: bool
    in_contact: bool
    beyond_cutoff: bool
    depth_converged: bool
    compound: bool
    piece_a: int
    piece_b: int
    pairs_evaluated: int
    pairs_pruned: int
    pairs_stopped_at_best: int
    total_support_calls: int
    total_subalgorithm_runs: int

def box(half_extents: ArrayLike, rounding: float = ...) -> Shape: ...
def sphere(radius: float) -> Shape: ...
def point() -> Shape: ...
def capsule(a: ArrayLike, b: ArrayLike, radius: float) -> Shape: ...
def segment(a: ArrayLike, b: ArrayLike) -> Shape: ...
def cylinder(radius: float, half_height: float, rounding: float = ...) -> Shape: ...
def cone(radius: float, half_height: float, rounding: float = ...) -> Shape: ...
def ellipsoid(radii: ArrayLike, rounding: float = ...) -> Shape: ...
def polytope(vertices: ArrayLike, rounding: float = ...,
             faces: Optional[Sequence[Sequence[int]]] = ...) -> Shape: ...
def hull(points: ArrayLike, rounding: float = ...) -> Shape: ...
def convex_hull(points: ArrayLike) -> Dict[str, Any]: ...
def distance(a: Union[Shape, Compound], pose_a: PoseLike, b: Union[Shape, Compound],
             pose_b: PoseLike, *, cache: Optional[Cache] = ..., near_points: bool = ...,
             penetration_bound: bool = ..., gradient: bool = ..., penetration_depth: bool = ...,
             epsilon: float = ..., max_iterations: int = ..., distance_cutoff: float = ...,
             depth_tolerance: float = ..., depth_max_iterations: int = ...,
             origin_shift: bool = ..., subalgorithm: str = ..., cold_start: str = ...) -> Result: ...
def distance_batch(a: Any, poses_a: Any, b: Any, poses_b: Any, **kwargs: Any) -> Dict[str, Any]: ...
