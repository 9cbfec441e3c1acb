"""Type stubs of the native extension. Use the documented wrappers in :mod:`rperc`."""

from collections.abc import Callable, Mapping
from typing import TypeAlias, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "MAX_PARTICLES",
    "CeilingWorld",
    "ColorHistogramTracker",
    "ColorShapeAnswer",
    "ColorShapeTracker",
    "ColorTemplateAnswer",
    "ColorTemplateTracker",
    "Ekf",
    "InformationSpectrum",
    "KalmanUpdate",
    "LaserRun",
    "LaserScanPoints",
    "MemoryFrames",
    "MemoryLearning",
    "MemoryReplay",
    "MonobotErrors",
    "MonobotRun",
    "MonobotSummary",
    "NumericalError",
    "ParticleColorTracker",
    "PatternAnswer",
    "PatternSequenceAnswer",
    "PatternTracker",
    "PlanarRun",
    "PlanarStatistics",
    "RpercError",
    "ScanWalls",
    "SimulatedWorld",
    "SmoothedRun",
    "TrackAnswer",
    "WorldWalls",
    "__version__",
    "ceiling_drive",
    "check_allocation",
    "color_segment",
    "config_check",
    "config_defaults",
    "config_names",
    "config_schema",
    "effective_sample_size",
    "extract_lines",
    "information_spectrum",
    "laser_run",
    "laser_scan_points",
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
    "parse_floats",
    "parse_line_floats",
    "parse_lines_floats",
    "pattern_sequence",
    "planar_sim_check",
    "planar_sim_nees",
    "planar_sim_slam_config",
    "planar_simulate",
    "planar_slam_run",
    "planar_smooth",
    "pose_path_point",
    "pose_transform_points",
    "resample",
    "simplify_indices",
    "simplify_many_indices",
    "simplify_topology_indices",
    "visual_memory_check",
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

@final
class ScanWalls:
    """The walls of one scan (:func:`extract_lines`), frozen, arrays read-only."""

    @property
    def rho(self) -> npt.NDArray[np.float64]: ...
    @property
    def alpha(self) -> npt.NDArray[np.float64]: ...
    @property
    def cov(self) -> npt.NDArray[np.float64]: ...
    @property
    def start(self) -> npt.NDArray[np.float64]: ...
    @property
    def end(self) -> npt.NDArray[np.float64]: ...
    @property
    def flat_indices(self) -> npt.NDArray[np.intp]: ...
    @property
    def offsets(self) -> npt.NDArray[np.intp]: ...

def extract_lines(
    ranges: npt.NDArray[np.floating],
    angles: npt.NDArray[np.floating],
    params: Mapping[str, object] | None = None,
) -> ScanWalls: ...

_Array: TypeAlias = npt.NDArray[np.float64]
_ArrayLike: TypeAlias = npt.NDArray[np.floating]

@final
class KalmanUpdate:
    """What one EKF update did, frozen, arrays read-only."""

    @property
    def innovation(self) -> _Array: ...
    @property
    def innovation_cov(self) -> _Array: ...
    @property
    def gain(self) -> _Array: ...
    @property
    def nis(self) -> float: ...

@final
class InformationSpectrum:
    """Eigenvalues (ascending), eigenvectors (columns) and rank, frozen."""

    @property
    def eigenvalues(self) -> _Array: ...
    @property
    def eigenvectors(self) -> _Array: ...
    @property
    def rank(self) -> int: ...

@final
class WorldWalls:
    """Walls moved to the world with their Jacobians, frozen, arrays read-only."""

    @property
    def rho(self) -> _Array: ...
    @property
    def alpha(self) -> _Array: ...
    @property
    def d_wall(self) -> _Array: ...
    @property
    def d_pose(self) -> _Array: ...

@final
class LaserScanPoints:
    """One scan's points and normals (NaN off lines), frozen, arrays read-only."""

    @property
    def points(self) -> _Array: ...
    @property
    def normals(self) -> _Array: ...

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
    ) -> KalmanUpdate: ...
    def update_range_bearing(self, j: int, z: _ArrayLike, r: _ArrayLike) -> KalmanUpdate: ...
    def add_landmark(
        self, mean: _ArrayLike, g_robot: _ArrayLike, g_z: _ArrayLike, r: _ArrayLike
    ) -> int: ...
    def add_landmark_range_bearing(self, z: _ArrayLike, r: _ArrayLike) -> int: ...

@final
class MonobotRun:
    """One monobot run (:func:`monobot_simulate`), frozen, arrays read-only."""

    @property
    def truth(self) -> _Array: ...
    @property
    def estimate(self) -> _Array: ...
    @property
    def std(self) -> _Array: ...
    @property
    def initial_measurement(self) -> _Array: ...
    @property
    def measurement(self) -> _Array: ...
    @property
    def innovation(self) -> _Array: ...
    @property
    def innovation_cov(self) -> _Array: ...
    @property
    def gain(self) -> _Array: ...
    @property
    def predicted_cov(self) -> _Array: ...
    @property
    def nees(self) -> _Array: ...
    @property
    def fisher(self) -> _Array: ...
    @property
    def fisher_00(self) -> _Array: ...
    @property
    def first_observation_error(self) -> _Array: ...

@final
class MonobotErrors:
    """Stacked Monte Carlo run errors (:func:`monobot_monte_carlo`), frozen."""

    @property
    def nees(self) -> _Array: ...
    @property
    def robot_error(self) -> _Array: ...
    @property
    def landmark_error(self) -> _Array: ...
    @property
    def first_observation_error(self) -> _Array: ...

@final
class MonobotSummary:
    """Monte Carlo summary statistics (:func:`monobot_summarize`), frozen."""

    @property
    def runs(self) -> int: ...
    @property
    def nees(self) -> _Array: ...
    @property
    def nees_band(self) -> tuple[float, float]: ...
    @property
    def nees_in_band(self) -> float: ...
    @property
    def landmark_error_mean(self) -> _Array: ...
    @property
    def landmark_error_std(self) -> _Array: ...
    @property
    def robot_error_mean(self) -> _Array: ...
    @property
    def robot_error_std(self) -> _Array: ...
    @property
    def final_landmark_error(self) -> _Array: ...
    @property
    def first_observation_error(self) -> _Array: ...
    @property
    def sensitivity(self) -> float: ...
    @property
    def correlation(self) -> float: ...

def monobot_simulate(
    model: str, seed: int, run: int = 0, config: Mapping[str, object] | None = None
) -> MonobotRun: ...
def monobot_monte_carlo(
    model: str, runs: int, seed: int, config: Mapping[str, object] | None = None
) -> MonobotErrors: ...
def config_schema(name: str) -> str: ...
def config_defaults(name: str) -> dict[str, object]: ...
def config_check(name: str, config: Mapping[str, object]) -> None: ...
def config_names() -> list[str]: ...

@final
class SimulatedWorld:
    """One simulated recording (:func:`planar_simulate`), frozen, arrays read-only."""

    @property
    def controls(self) -> _Array: ...
    @property
    def detections(self) -> _Array: ...
    @property
    def detection_ids(self) -> npt.NDArray[np.int64]: ...
    @property
    def fixes(self) -> _Array: ...
    @property
    def truth(self) -> _Array: ...
    @property
    def landmarks(self) -> _Array: ...

def planar_simulate(
    sim: Mapping[str, object] | None, seed: int, run: int = 0
) -> SimulatedWorld: ...
def planar_sim_slam_config(sim: Mapping[str, object] | None = None) -> dict[str, object]: ...
def planar_sim_check(
    sim: Mapping[str, object] | None, slam: Mapping[str, object] | None, runs: int
) -> None: ...
def planar_sim_nees(
    sim: Mapping[str, object] | None,
    slam: Mapping[str, object] | None,
    seed: int,
    first: int,
    runs: int,
) -> _Array: ...

@final
class PlanarStatistics:
    """A planar run's association counts, by name."""

    names: tuple[str, ...]
    @property
    def values(self) -> tuple[int, ...]: ...

@final
class PlanarRun:
    """What :func:`planar_slam_run` returns, frozen, arrays read-only: the robot
    after every event, the point and wall maps, the wall pairing, the association
    counts and the anchor."""

    @property
    def t(self) -> npt.NDArray[np.float64]: ...
    @property
    def kind(self) -> npt.NDArray[np.uint8]: ...
    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def seconds(self) -> npt.NDArray[np.float64]: ...
    @property
    def landmark_id(self) -> npt.NDArray[np.uint64]: ...
    @property
    def landmark_mean(self) -> npt.NDArray[np.float64]: ...
    @property
    def landmark_covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def landmark_revisions(self) -> npt.NDArray[np.uint32]: ...
    @property
    def landmark_frozen(self) -> npt.NDArray[np.bool_]: ...
    @property
    def landmark_anchor(self) -> npt.NDArray[np.bool_]: ...
    @property
    def wall_id(self) -> npt.NDArray[np.uint64]: ...
    @property
    def wall_line(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_ends(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_revisions(self) -> npt.NDArray[np.uint32]: ...
    @property
    def wall_frozen(self) -> npt.NDArray[np.bool_]: ...
    @property
    def wall_anchor(self) -> npt.NDArray[np.bool_]: ...
    @property
    def wall_pairing(self) -> npt.NDArray[np.int64]: ...
    @property
    def point_pairing(self) -> npt.NDArray[np.int64]: ...
    @property
    def statistics(self) -> PlanarStatistics: ...
    @property
    def anchor(self) -> tuple[float, float] | None: ...
    @property
    def anchor_time(self) -> float | None: ...

def planar_slam_run(
    controls: npt.NDArray[np.float64],
    detections: npt.NDArray[np.float64],
    detection_ids: npt.NDArray[np.int64] | None = None,
    fixes: npt.NDArray[np.float64] | None = None,
    config: Mapping[str, object] | None = None,
    walls: npt.NDArray[np.float64] | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> PlanarRun: ...
def wall_straightness_covariance(
    rho: _ArrayLike, alpha: _ArrayLike, start: _ArrayLike, end: _ArrayLike, sigma: float
) -> _Array: ...

@final
class SmoothedRun:
    """What :func:`planar_smooth` returns, frozen, arrays read-only."""

    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_id(self) -> npt.NDArray[np.int64]: ...
    @property
    def wall_line(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_ends(self) -> npt.NDArray[np.float64]: ...
    @property
    def landmark_id(self) -> npt.NDArray[np.int64]: ...
    @property
    def landmark_mean(self) -> npt.NDArray[np.float64]: ...
    @property
    def landmark_covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def bias(self) -> tuple[float, float]: ...
    @property
    def iterations(self) -> int: ...
    @property
    def cost(self) -> float: ...
    @property
    def residuals(self) -> int: ...

def planar_smooth(
    controls: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64],
    poses: npt.NDArray[np.float64],
    walls: npt.NDArray[np.float64],
    pairing: npt.NDArray[np.int64],
    map_id: npt.NDArray[np.int64],
    map_line: npt.NDArray[np.float64],
    points: npt.NDArray[np.float64],
    point_pairing: npt.NDArray[np.int64],
    landmark_id: npt.NDArray[np.int64],
    landmark_mean: npt.NDArray[np.float64],
    config: Mapping[str, object] | None = None,
    options: Mapping[str, object] | None = None,
) -> SmoothedRun: ...
def monobot_summarize(
    nees: _ArrayLike,
    robot_error: _ArrayLike,
    landmark_error: _ArrayLike,
    first_observation_error: _ArrayLike,
    confidence: float = 0.95,
) -> MonobotSummary: ...
def monobot_observability_rank(model: str, landmarks: int) -> int: ...
def information_spectrum(j: _ArrayLike, tol: float) -> InformationSpectrum: ...
def nees_bounds(dof: int, runs: int, confidence: float) -> tuple[float, float]: ...

_Box: TypeAlias = tuple[float, float, float, float]

@final
class TrackAnswer:
    """One colour-histogram tracker answer, frozen."""

    @property
    def box(self) -> _Box: ...
    @property
    def score(self) -> float: ...
    @property
    def lost(self) -> bool: ...

@final
class ColorHistogramTracker:
    """Colour-histogram tracker with local search (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        config: Mapping[str, object] | None = None,
    ) -> ColorHistogramTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> TrackAnswer: ...
    @property
    def scale(self) -> float: ...
    @property
    def search_radius(self) -> int: ...
    @property
    def lost_frames(self) -> int: ...

@final
class ColorTemplateAnswer:
    """One colour + template answer with the signals of its lost flag, frozen."""

    @property
    def box(self) -> _Box: ...
    @property
    def score(self) -> float: ...
    @property
    def lost(self) -> bool: ...
    @property
    def peak(self) -> float: ...
    @property
    def psr(self) -> float: ...
    @property
    def apce(self) -> float: ...
    @property
    def color_score(self) -> float: ...
    @property
    def contrast(self) -> float: ...

@final
class ColorTemplateTracker:
    """Colour + correlation-filter template tracker (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        seed: int = 0,
        config: Mapping[str, object] | None = None,
    ) -> ColorTemplateTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> ColorTemplateAnswer: ...
    @property
    def scale(self) -> float: ...
    @property
    def lost_frames(self) -> int: ...

@final
class ParticleColorTracker:
    """CONDENSATION colour tracker over (x, y, scale) (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        bbox: _Box | list[float] | _ArrayLike,
        seed: int = 0,
        config: Mapping[str, object] | None = None,
    ) -> ParticleColorTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> TrackAnswer: ...
    @property
    def ess(self) -> float: ...

@final
class ColorShapeAnswer:
    """One colour+shape tracker answer, frozen; the contour is read-only."""

    @property
    def contour(self) -> npt.NDArray[np.float64]: ...
    @property
    def box(self) -> _Box: ...
    @property
    def distribution(self) -> tuple[float, float, float, float, float, float, float, float]: ...
    @property
    def score(self) -> float: ...
    @property
    def lost(self) -> bool: ...
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
        config: Mapping[str, object] | None = None,
    ) -> ColorShapeTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> ColorShapeAnswer: ...

def color_segment(
    frame: npt.NDArray[np.uint8],
    colours: npt.NDArray[np.float64],
    color_space: str,
    bins: tuple[int, int, int],
    radius: int,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]: ...

@final
class PatternAnswer:
    """One pattern-tracker answer, frozen; its arrays are read-only."""

    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def theta(self) -> float: ...
    @property
    def scale(self) -> float: ...
    @property
    def score(self) -> float: ...
    @property
    def occluded_fraction(self) -> float: ...
    @property
    def lost(self) -> bool: ...
    @property
    def corners(self) -> npt.NDArray[np.float64]: ...
    @property
    def homography(self) -> npt.NDArray[np.float64]: ...

@final
class PatternTracker:
    """CONDENSATION pattern tracker over (x, y, theta, s) or the plane's homography
    (see rperc.tracking)."""

    def __new__(
        cls,
        frame: npt.NDArray[np.uint8],
        region: tuple[int, int, int, int] | npt.NDArray[np.bool_] | npt.NDArray[np.float64],
        seed: int = 0,
        config: Mapping[str, object] | None = None,
    ) -> PatternTracker: ...
    def update(self, frame: npt.NDArray[np.uint8]) -> PatternAnswer: ...
    @property
    def last(self) -> PatternAnswer: ...
    @property
    def n_points(self) -> int: ...
    @property
    def model_offsets(self) -> npt.NDArray[np.float64]: ...

@final
class PatternSequenceAnswer:
    """A generated Fig. 8 sequence, frozen."""

    @property
    def frames(self) -> npt.NDArray[np.uint8]: ...
    @property
    def truth(self) -> _Array: ...
    @property
    def occlusion(self) -> _Array: ...
    @property
    def illumination(self) -> _Array: ...
    @property
    def region(self) -> tuple[int, int, int, int]: ...

def pattern_sequence(
    patch: _ArrayLike, background: _ArrayLike, config: Mapping[str, object] | None = None
) -> PatternSequenceAnswer: ...
def resample(
    weights: _ArrayLike, n: int, method: str = "systematic", seed: int = 0
) -> npt.NDArray[np.intp]: ...
def effective_sample_size(weights: _ArrayLike) -> float: ...
def otb_iou(a: _ArrayLike, b: _ArrayLike) -> _Array: ...
def otb_center_error(a: _ArrayLike, b: _ArrayLike) -> _Array: ...
def otb_success_curve(overlaps: _ArrayLike) -> _Array: ...
def otb_precision(errors: _ArrayLike, threshold: float) -> float: ...
def otb_groundtruth(text: str, name: str) -> _Array: ...
def pose_transform_points(
    pose: _ArrayLike, points: _ArrayLike, inverse: bool = False
) -> _Array: ...
def pose_path_point(poses: _ArrayLike, offset: _ArrayLike) -> _Array: ...
def wrap_angles(angles: _ArrayLike) -> _Array: ...
def walls_to_world(rho: _ArrayLike, alpha: _ArrayLike, pose: _ArrayLike) -> WorldWalls: ...

@final
class CeilingWorld:
    def __new__(
        cls,
        ceiling: Mapping[str, object] | None = None,
        camera: Mapping[str, object] | None = None,
        render: Mapping[str, object] | None = None,
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

def check_allocation(name: str, count: int, bytes_each: int) -> None: ...
def ceiling_drive(
    start: npt.NDArray[np.float64],
    commands: npt.NDArray[np.float64],
    dt: float,
    noise: Mapping[str, object] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

@final
class MemoryFrames:
    """Per-frame arrays of a visual-memory run, frozen, read-only."""

    @property
    def truth(self) -> _Array: ...
    @property
    def pose(self) -> _Array: ...
    @property
    def lost(self) -> npt.NDArray[np.bool_]: ...
    @property
    def tracked(self) -> npt.NDArray[np.int64]: ...
    @property
    def seconds(self) -> _Array: ...
    @property
    def covariance(self) -> _Array: ...

@final
class MemoryLearning:
    """A learning run: the memory (JSON) and its frames, frozen."""

    @property
    def memory(self) -> str: ...
    @property
    def frames(self) -> MemoryFrames: ...

@final
class MemoryReplay:
    """A replay: its outcome, the key image followed at each frame and the frames."""

    @property
    def outcome(self) -> str: ...
    @property
    def key_index(self) -> npt.NDArray[np.int64]: ...
    @property
    def frames(self) -> MemoryFrames: ...

def visual_memory_learn(
    world: CeilingWorld,
    start: npt.NDArray[np.float64],
    commands: npt.NDArray[np.float64],
    dt: float,
    config: Mapping[str, object] | None = None,
    seed: int = 0,
) -> MemoryLearning: ...
def visual_memory_replay(
    world: CeilingWorld,
    memory: str,
    start: npt.NDArray[np.float64],
    config: Mapping[str, object] | None = None,
    seed: int = 0,
) -> MemoryReplay: ...
def visual_memory_check(memory: str) -> None: ...

@final
class LaserRun:
    """What :func:`laser_run` returns, frozen: every scan's final pose ``(S, 3)`` and
    covariance ``(S, 3, 3)``, the online path, the front end's match statistics, the
    key scans, the accepted loop closures ``(K, 2)`` (scan indices) with their
    chi-square in the final graph, and the rejected closures by reason. Its arrays
    are read-only."""

    rejection_reasons: tuple[str, str, str, str, str]
    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def causal_pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def matched(self) -> npt.NDArray[np.bool_]: ...
    @property
    def inliers(self) -> npt.NDArray[np.int64]: ...
    @property
    def rms(self) -> npt.NDArray[np.float64]: ...
    @property
    def keys(self) -> npt.NDArray[np.int64]: ...
    @property
    def closures(self) -> npt.NDArray[np.int64]: ...
    @property
    def closure_chi2(self) -> npt.NDArray[np.float64]: ...
    @property
    def closure_attempts(self) -> int: ...
    @property
    def closures_rejected(self) -> int: ...
    @property
    def walls(self) -> npt.NDArray[np.float64]: ...
    @property
    def wall_factors(self) -> int: ...
    @property
    def wall_factors_pruned(self) -> int: ...
    @property
    def rejected(self) -> tuple[int, int, int, int, int]: ...

def laser_run(
    ranges: npt.NDArray[np.float64],
    counts: npt.NDArray[np.int64],
    angle_min: npt.NDArray[np.float64],
    angle_increment: npt.NDArray[np.float64],
    max_range: npt.NDArray[np.float64],
    controls: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64],
    config: Mapping[str, object] | None = None,
) -> LaserRun: ...
def parse_floats(tokens: list[str]) -> npt.NDArray[np.float64] | None:
    """The tokens as floats, or None when one is not a plain decimal number."""

def parse_line_floats(
    line: str, first: int, count: int
) -> tuple[int, npt.NDArray[np.float64]] | None:
    """The line's field count and ``count`` of its fields from ``first`` on as floats,
    or None (a non-ASCII byte, white space only ``str.split`` splits at, such as the
    vertical tab and 0x1c-0x1f, too few fields, or a field that is not a plain
    number)."""

def parse_lines_floats(
    lines: list[str], first: int, count: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]] | None:
    """:func:`parse_line_floats` over every line: the field counts and the
    ``(len(lines), count)`` table, or None when any line does not read."""

def laser_scan_points(
    ranges: _ArrayLike,
    angle_min: float,
    angle_increment: float,
    max_range: float,
    config: Mapping[str, object] | None = None,
) -> LaserScanPoints: ...
