"""Type stubs of the native extension. Use the documented wrappers in :mod:`rperc`."""

from collections.abc import Callable, Mapping
from typing import Any, TypeAlias, TypedDict, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "MAX_PARTICLES",
    "CeilingWorld",
    "ColorHistogramTracker",
    "ColorShapeTracker",
    "ColorTemplateTracker",
    "Ekf",
    "NumericalError",
    "ParticleColorTracker",
    "PatternTracker",
    "RpercError",
    "__version__",
    "ceiling_defaults",
    "ceiling_drive",
    "check_allocation",
    "color_segment",
    "color_shape_defaults",
    "color_template_defaults",
    "effective_sample_size",
    "extract_lines",
    "information_spectrum",
    "laser_defaults",
    "laser_run",
    "laser_scan_points",
    "monobot_defaults",
    "monobot_monte_carlo",
    "monobot_observability_rank",
    "monobot_simulate",
    "monobot_summarize",
    "nees_bounds",
    "otb_center_error",
    "otb_groundtruth",
    "otb_iou",
    "otb_precision",
    "otb_success_curve",
    "pattern_defaults",
    "pattern_sequence",
    "planar_defaults",
    "planar_sim_check",
    "planar_sim_defaults",
    "planar_sim_nees",
    "planar_sim_slam_config",
    "planar_simulate",
    "planar_slam_run",
    "planar_smooth_walls",
    "pose_transform_points",
    "resample",
    "scan_params_defaults",
    "simplify_indices",
    "simplify_many_indices",
    "simplify_topology_indices",
    "tracker_defaults",
    "visual_memory_check",
    "visual_memory_defaults",
    "visual_memory_learn",
    "visual_memory_replay",
    "wall_straightness_covariance",
    "walls_to_world",
    "wrap_angles",
]

__version__: str
MAX_PARTICLES: int

class RpercError(Exception): ...
class NumericalError(RpercError): ...

def simplify_indices(
    points: npt.NDArray[np.floating],
    epsilon: float,
    method: str = "auto",
    metric: str = "line",
    tie: str = "first",
) -> npt.NDArray[np.intp]: ...
def simplify_many_indices(
    polylines: list[npt.NDArray[np.floating]],
    epsilon: float,
    method: str = "auto",
    metric: str = "line",
    tie: str = "first",
    threads: int | None = None,
) -> list[npt.NDArray[np.intp]]: ...
def simplify_topology_indices(
    components: list[npt.NDArray[np.floating]],
    rings: list[bool],
    epsilon: float,
    method: str = "auto",
    metric: str = "line",
    tie: str = "first",
) -> list[npt.NDArray[np.intp]]: ...
def extract_lines(
    ranges: npt.NDArray[np.floating],
    angles: npt.NDArray[np.floating],
    params: dict[str, Any] | None = None,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.intp],
    npt.NDArray[np.intp],
]: ...
def scan_params_defaults() -> dict[str, Any]: ...

_Array: TypeAlias = npt.NDArray[np.float64]
_ArrayLike: TypeAlias = npt.NDArray[np.floating]

@final
class Ekf:
    """Extended Kalman filter: robot block plus landmark blocks, full covariance."""

    def __new__(
        cls, state: _ArrayLike, covariance: _ArrayLike, robot_dim: int, landmark_dim: int
    ) -> Ekf: ...
    @property
    def state(self) -> _Array: ...
    @state.setter
    def state(self, value: _ArrayLike) -> None: ...
    @property
    def covariance(self) -> _Array: ...
    @property
    def robot_dim(self) -> int: ...
    @property
    def landmark_dim(self) -> int: ...
    @property
    def num_landmarks(self) -> int: ...
    def predict(
        self, robot_mean: _ArrayLike, fx: _ArrayLike, fv: _ArrayLike, v: _ArrayLike
    ) -> None: ...
    def update(
        self, innovation: _ArrayLike, blocks: list[tuple[int, int, _ArrayLike]], r: _ArrayLike
    ) -> tuple[_Array, _Array, float]: ...
    def update_range_bearing(
        self, j: int, z: _ArrayLike, r: _ArrayLike
    ) -> tuple[_Array, _Array, _Array, float]: ...
    def add_landmark(
        self, mean: _ArrayLike, g_robot: _ArrayLike, g_z: _ArrayLike, r: _ArrayLike
    ) -> int: ...
    def add_landmark_range_bearing(self, z: _ArrayLike, r: _ArrayLike) -> int: ...

def monobot_simulate(
    model: str, seed: int, run: int = 0, config: dict[str, Any] | None = None
) -> dict[str, Any]: ...
def monobot_monte_carlo(
    model: str, runs: int, seed: int, config: dict[str, Any] | None = None
) -> tuple[_Array, _Array, _Array, _Array]: ...
def monobot_defaults() -> dict[str, Any]: ...
def planar_defaults() -> dict[str, Any]: ...
def planar_sim_defaults() -> dict[str, Any]: ...
def planar_simulate(sim: dict[str, Any] | None, seed: int, run: int = 0) -> dict[str, Any]: ...
def planar_sim_slam_config(sim: dict[str, Any] | None = None) -> dict[str, Any]: ...
def planar_sim_check(
    sim: dict[str, Any] | None, slam: dict[str, Any] | None, runs: int
) -> None: ...
def planar_sim_nees(
    sim: dict[str, Any] | None, slam: dict[str, Any] | None, seed: int, first: int, runs: int
) -> _Array: ...
def planar_slam_run(
    controls: npt.NDArray[np.float64],
    detections: npt.NDArray[np.float64],
    detection_ids: npt.NDArray[np.int64] | None = None,
    fixes: npt.NDArray[np.float64] | None = None,
    config: dict[str, Any] | None = None,
    walls: npt.NDArray[np.float64] | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> dict[str, Any]: ...
def wall_straightness_covariance(
    rho: _ArrayLike, alpha: _ArrayLike, start: _ArrayLike, end: _ArrayLike, sigma: float
) -> _Array: ...
def planar_smooth_walls(
    controls: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64],
    poses: npt.NDArray[np.float64],
    walls: npt.NDArray[np.float64],
    pairing: npt.NDArray[np.int64],
    map_id: npt.NDArray[np.int64],
    map_line: npt.NDArray[np.float64],
    config: dict[str, Any] | None = None,
    options: dict[str, Any] | None = None,
) -> dict[str, Any]: ...
def monobot_summarize(
    nees: _ArrayLike,
    robot_error: _ArrayLike,
    landmark_error: _ArrayLike,
    first_observation_error: _ArrayLike,
    confidence: float = 0.95,
) -> dict[str, Any]: ...
def monobot_observability_rank(model: str, landmarks: int) -> int: ...
def information_spectrum(j: _ArrayLike, tol: float) -> tuple[_Array, _Array, int]: ...
def nees_bounds(dof: int, runs: int, confidence: float) -> tuple[float, float]: ...

_Box: TypeAlias = tuple[float, float, float, float]

@final
class ColorHistogramTracker:
    """Colour-histogram tracker with local search (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        config: dict[str, Any] | None = None,
    ) -> ColorHistogramTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> tuple[_Box, float, bool]: ...
    @property
    def scale(self) -> float: ...
    @property
    def search_radius(self) -> int: ...
    @property
    def lost_frames(self) -> int: ...

@final
class ColorTemplateTracker:
    """Colour + correlation-filter template tracker (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        seed: int = 0,
        config: dict[str, Any] | None = None,
    ) -> ColorTemplateTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> tuple[_Box, float, bool]: ...
    @property
    def scale(self) -> float: ...
    @property
    def lost_frames(self) -> int: ...

def color_template_defaults() -> dict[str, Any]: ...

@final
class ParticleColorTracker:
    """CONDENSATION colour tracker over (x, y, scale) (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        seed: int = 0,
        config: dict[str, Any] | None = None,
    ) -> ParticleColorTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> tuple[_Box, float, bool]: ...
    @property
    def ess(self) -> float: ...

@final
class ColorShapeTracker:
    """CONDENSATION over colour distributions with an affine snake (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike | None = None,
        contour: _ArrayLike | None = None,
        config: dict[str, Any] | None = None,
    ) -> ColorShapeTracker: ...
    def update(
        self, frame: npt.NDArray[np.uint8]
    ) -> tuple[npt.NDArray[np.float64], _Box, list[float], float, bool, float]: ...

def color_shape_defaults() -> dict[str, Any]: ...
def color_segment(
    frame: npt.NDArray[np.uint8],
    colours: npt.NDArray[np.float64],
    color_space: str,
    bins: tuple[int, int, int],
    radius: int,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]: ...

_PatternAnswer: TypeAlias = tuple[
    float, float, float, float, float, float, bool, npt.NDArray[np.float64]
]

@final
class PatternTracker:
    """CONDENSATION pattern tracker over (x, y, theta, s) (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        region: tuple[int, int, int, int] | npt.NDArray[np.bool_],
        seed: int = 0,
        config: dict[str, Any] | None = None,
    ) -> PatternTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> _PatternAnswer: ...
    @property
    def last(self) -> _PatternAnswer: ...
    @property
    def n_points(self) -> int: ...

def pattern_sequence(
    patch: _ArrayLike, background: _ArrayLike, config: dict[str, Any] | None = None
) -> tuple[npt.NDArray[np.uint8], _Array, _Array, _Array, tuple[int, int, int, int]]: ...
def pattern_defaults() -> tuple[dict[str, Any], dict[str, Any]]: ...
def resample(
    weights: _ArrayLike, n: int, method: str = "systematic", seed: int = 0
) -> npt.NDArray[np.intp]: ...
def effective_sample_size(weights: _ArrayLike) -> float: ...
def tracker_defaults() -> tuple[dict[str, Any], dict[str, Any]]: ...
def otb_iou(a: _ArrayLike, b: _ArrayLike) -> _Array: ...
def otb_center_error(a: _ArrayLike, b: _ArrayLike) -> _Array: ...
def otb_success_curve(overlaps: _ArrayLike) -> _Array: ...
def otb_precision(errors: _ArrayLike, threshold: float) -> float: ...
def otb_groundtruth(text: str, name: str) -> _Array: ...
def pose_transform_points(
    pose: _ArrayLike, points: _ArrayLike, inverse: bool = False
) -> _Array: ...
def wrap_angles(angles: _ArrayLike) -> _Array: ...
def walls_to_world(
    rho: _ArrayLike, alpha: _ArrayLike, pose: _ArrayLike
) -> tuple[_Array, _Array, _Array, _Array]: ...

@final
class CeilingWorld:
    def __new__(
        cls,
        ceiling: dict[str, Any] | None = None,
        camera: dict[str, Any] | None = None,
        render: dict[str, Any] | None = None,
    ) -> CeilingWorld: ...
    def render(
        self, poses: npt.NDArray[np.float64], first_frame: int = 0
    ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def project(
        self, pose: npt.NDArray[np.float64], xy: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]: ...
    def matrices(self, pose: npt.NDArray[np.float64]) -> list[npt.NDArray[np.float64]]: ...
    def texture(self) -> npt.NDArray[np.float32]: ...
    @property
    def resolution(self) -> float: ...
    def patterns(
        self,
    ) -> tuple[list[str], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def configs(self) -> tuple[dict[str, Any], dict[str, Any]]: ...

def check_allocation(name: str, count: int, bytes_each: int) -> None: ...
def ceiling_drive(
    start: npt.NDArray[np.float64],
    commands: npt.NDArray[np.float64],
    dt: float,
    noise: dict[str, Any] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def ceiling_defaults() -> tuple[dict[str, Any], dict[str, Any], dict[str, Any], dict[str, Any]]: ...

_Frames: TypeAlias = tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
]

def visual_memory_learn(
    world: CeilingWorld,
    start: npt.NDArray[np.float64],
    commands: npt.NDArray[np.float64],
    dt: float,
    config: dict[str, Any] | None = None,
    seed: int = 0,
) -> tuple[str, _Frames]: ...
def visual_memory_replay(
    world: CeilingWorld,
    memory: str,
    start: npt.NDArray[np.float64],
    config: dict[str, Any] | None = None,
    seed: int = 0,
) -> tuple[str, npt.NDArray[np.float64], _Frames]: ...
def visual_memory_defaults() -> tuple[dict[str, Any], dict[str, Any]]: ...
def visual_memory_check(memory: str) -> None: ...

class _LaserRunOutput(TypedDict):
    """What :func:`laser_run` returns: every scan's final pose ``(S, 3)`` and
    covariance ``(S, 3, 3)``, the online path, the front end's match statistics, the
    key scans and the loop closures."""

    pose: npt.NDArray[np.float64]
    covariance: npt.NDArray[np.float64]
    causal_pose: npt.NDArray[np.float64]
    matched: npt.NDArray[np.bool_]
    inliers: npt.NDArray[np.int64]
    rms: npt.NDArray[np.float64]
    keys: npt.NDArray[np.int64]
    closures: npt.NDArray[np.float64]
    closure_chi2: npt.NDArray[np.float64]
    closures_rejected: int
    closure_attempts: int
    rejections: dict[str, int]

def laser_defaults() -> dict[str, Any]: ...
def laser_run(
    ranges: npt.NDArray[np.float64],
    counts: npt.NDArray[np.int64],
    angle_min: npt.NDArray[np.float64],
    angle_increment: npt.NDArray[np.float64],
    max_range: npt.NDArray[np.float64],
    controls: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64],
    config: Mapping[str, Any] | None = None,
) -> _LaserRunOutput: ...
def laser_scan_points(
    ranges: _ArrayLike,
    angle_min: float,
    angle_increment: float,
    max_range: float,
    config: Mapping[str, Any] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
