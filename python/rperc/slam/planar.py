"""Planar EKF-SLAM on recordings: the first seed's section 2.2 with its variants.

:class:`PlanarSlam` runs a whole recording in one native call (GIL released): a robot
``(x, y, theta)`` among point landmarks seen by range and bearing, with the EKF of
eqs. (1)-(9), known, nearest-neighbour or JCBB association, a candidate list for new
landmarks, and paper [000]'s variants, each a config field that combines with the
others:

- ``anchor=True``: the first landmark becomes the global reference (eqs. 24-25);
- ``external_fix=True``: xy fixes of an external sensor update the robot (eqs. 26-27);
- ``freeze_after=50``: landmarks revised more than 50 times leave the state (the text
  under Fig. 7); their sightings still correct the rest.

``compression="auto"`` (the default) runs the compressed EKF of Guivant & Nebot (2001)
once the map holds ``compression_min_landmarks`` (100) landmarks: while the robot sees a
local area (``active_radius`` metres around the sensor), only the robot and the
landmarks there are updated, and one global update restores the whole filter when the
area is remade; a landmark outside the area that a scan might see is first brought
into it. The results equal the full EKF's up to round-off (tested
against ``compression="off"``, the full EKF at every step); only the time changes. It
is off where it would not be exact: with ``freeze_mode="consider"`` and with walls.

>>> import numpy as np
>>> from rperc.slam import PlanarSlam
>>> controls = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])   # t, v, omega
>>> detections = np.array([[0.5, 2.0, 0.1], [1.5, 1.01, 0.199]])  # t, range, bearing
>>> ids = np.array([7, 7])
>>> result = PlanarSlam().run_arrays(controls, detections, detection_ids=ids)
>>> result.landmark_id.tolist(), result.statistics["accepted"]
([7], 1)
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

import rperc.slam.evaluation as evaluation
from rperc import _rperc
from rperc._args import excerpt, real_number, seed_number, whole_number
from rperc._config_base import as_config
from rperc.config import PlanarConfig, PlanarConfigOverrides, SimConfig
from rperc.pose import point_path as _point_path
from rperc.pose import wrap_angle

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from rperc.datasets.mrclam import MrclamRun
    from rperc.datasets.victoria_park import VictoriaPark

__all__ = [
    "MRCLAM_CALIBRATION_SECONDS",
    "MRCLAM_ROBOT_PRESETS",
    "PRESETS",
    "RECORDING_VARIANTS",
    "VARIANTS",
    "PlanarMonteCarlo",
    "PlanarSlam",
    "Recording",
    "SimulatedRun",
    "SlamResult",
    "WallMap",
    "consistency",
    "defaults",
    "monte_carlo",
    "mrclam_preset",
    "mrclam_recording",
    "mrclam_start",
    "point_path",
    "sim_defaults",
    "sim_slam_config",
    "simulate",
    "victoria_recording",
]

# MR.CLAM: each robot's camera and odometry differ (robot 2's camera reads 5 % long
# with no offset, robot 1's 1.4 % long with 4 cm; robot 3 turns 9 % short), so each
# robot has its own preset, made by one procedure for all three,
# rperc.slam.calibration.calibrate_mrclam_preset, on the first
# MRCLAM_CALIBRATION_SECONDS of that robot's run against its Vicon ground truth; the
# second halves stay held out (score them with --span 444 1e9). The camera measures
# depth r cos(b), not range. The odometry windows are the correlation_window rule's
# (robot 1: 8 s; robots 2 and 3: 4 s). The fitted variances (of single residuals)
# are then inflated by the smallest factors of MRCLAM_INFLATION_FACTORS under which
# the gate refuses no more of that half's sightings than its own 1 % (gate_inflation:
# an innovation test, no ground truth), with first-estimates Jacobians when that test
# can pass with them (robots 1 and 3; robot 2's first estimates, made after an
# odometry slip in 46 s without a sighting, fail it at every factor): robot 1 2x
# detections and 4x controls, robot 2 2x and 16x, robot 3 2x and 8x.
# tests/test_slam_calibration.py recomputes all of them.
# Victoria Park: the ACFR vehicle and laser defaults of the Rust crate, 1 m and 3
# degrees on tree centres, never tuned on the runs that report the scores.
MRCLAM_CALIBRATION_SECONDS = 444.0
MRCLAM_INFLATION_FACTORS = (1.0, 2.0, 4.0, 8.0, 16.0)


def _mrclam_preset(
    speed_variance: float,
    turn_rate_variance: float,
    range_variance: float,
    bearing_variance: float,
    bias: tuple[float, float, float, float, float, float],
    first_estimates: bool,
) -> dict[str, object]:
    """A robot's preset: control and detection variances, its biases ``(range
    offset, range scale, bearing offset, bearing scale, speed scale, turn scale)`` and
    whether the EKF is linearised at first estimates."""
    r_off, r_scale, b_off, b_scale, v_scale, w_scale = bias
    return {
        "motion": {
            "unicycle": {"speed_variance": speed_variance, "turn_rate_variance": turn_rate_variance}
        },
        "range_variance": range_variance,
        "bearing_variance": bearing_variance,
        "bias": {
            "range_offset": r_off,
            "range_scale": r_scale,
            "range_is_depth": True,
            "bearing_offset": b_off,
            "bearing_scale": b_scale,
            "control_scale": [v_scale, w_scale],
        },
        "first_estimates": first_estimates,
    }


#: Each MR.CLAM robot's calibrated preset (see above), by robot number.
MRCLAM_ROBOT_PRESETS: dict[int, dict[str, object]] = {
    1: _mrclam_preset(
        0.0261902, 0.0785342, 0.00257694, 0.000609932,
        (0.042337, 1.01402, 0.00441289, 0.982011, 0.946583, 0.952761), True,
    ),
    2: _mrclam_preset(
        0.118700, 0.539118, 0.00186397, 0.000272574,
        (-3.72451e-05, 1.05261, 0.00144134, 0.999101, 0.914067, 0.939062), False,
    ),
    3: _mrclam_preset(
        0.0389348, 0.219187, 0.00182364, 0.000102682,
        (0.0545214, 1.01117, -0.00144305, 0.996729, 0.950938, 0.911857), True,
    ),
}  # fmt: skip


def mrclam_preset(robot: int) -> dict[str, object]:
    """The preset of MR.CLAM robot ``robot``: its own calibration for robots 1-3; the
    others (4 and 5, not in rperc's corpus) get robot 1's, which they have not been
    fitted on."""
    return MRCLAM_ROBOT_PRESETS.get(robot, MRCLAM_ROBOT_PRESETS[1])


PRESETS: dict[str, dict[str, object]] = {
    # Robot 1's, as before per-robot presets: see mrclam_preset.
    "mrclam": MRCLAM_ROBOT_PRESETS[1],
    "victoria": {
        "motion": {"ackermann": {}},
        "range_variance": 1.0,
        "bearing_variance": float(np.radians(3.0) ** 2),
        "association": "jcbb",  # trees have no ids; see rperc.slam.wallslam.ASSOCIATIONS
        "candidate_sightings": 3,
        # The GPS is compared at the laser (external variant, eqs. 26-27).
        "fix_lever_arm": [3.78, 0.50],
    },
}


def defaults() -> dict[str, object]:
    """The default configuration (from the Rust crate, the one place it lives)."""
    return PlanarConfig().to_dict()


def _rows(a: npt.ArrayLike, k: int, name: str) -> npt.NDArray[np.float64]:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != k:
        raise ValueError(f"{name} must have shape (N, {k}), got {arr.shape}")
    return np.ascontiguousarray(arr)


def _integral_ids(detection_ids: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """The ids as int64; a fractional, non-finite or non-numeric id is an error (a
    cast would turn landmark 7.5 into landmark 7)."""
    arr = np.asarray(detection_ids)
    if arr.dtype.kind in "iu":
        if arr.dtype.kind == "u" and arr.size and arr.max() > np.iinfo(np.int64).max:
            raise ValueError("detection_ids must fit in int64")
        return np.ascontiguousarray(arr, dtype=np.int64)
    if arr.dtype.kind != "f":
        raise TypeError(f"detection_ids must be integers, got dtype {arr.dtype}")
    bad = np.flatnonzero(~np.isfinite(arr) | (arr != np.round(arr)))
    if len(bad):
        raise ValueError(
            f"detection_ids must be integral: {len(bad)} are not, the first at index "
            f"{bad[0]} ({arr.flat[bad[0]]!r})"
        )
    if arr.size and np.abs(arr).max() > 2**53:
        raise ValueError("detection_ids beyond 2**53 are not exact as floats")
    return np.ascontiguousarray(arr, dtype=np.int64)


@dataclass(frozen=True, repr=False)
class WallMap:
    """The walls of a run: ``line`` ``(W, 2)`` rows ``(rho, alpha)`` in the world frame,
    their 2x2 ``covariance`` (a frozen wall's at its freezing), the seen extent
    ``ends`` ``(W, 2, 2)`` (end points, kept outside the state), and per wall its id,
    revisions and whether it is frozen or the anchor."""

    id: np.ndarray
    line: np.ndarray
    covariance: np.ndarray
    ends: np.ndarray
    revisions: np.ndarray
    frozen: np.ndarray
    anchor: np.ndarray

    def __len__(self) -> int:
        return len(self.id)

    def __repr__(self) -> str:
        return (
            f"WallMap({len(self)} walls, {int(np.count_nonzero(self.frozen))} frozen, "
            f"{int(np.count_nonzero(self.anchor))} anchor)"
        )


@dataclass(frozen=True, repr=False)
class SlamResult:
    """A run: the robot after every event, the final map and the association counts.

    Rows of ``pose`` follow the events in time order (``kind``: 0 control, 1 scan,
    2 fix); ``covariance`` is the robot's 3x3 block after each event and ``seconds``
    the wall-clock time each event took.
    """

    t: np.ndarray
    kind: np.ndarray
    pose: np.ndarray
    covariance: np.ndarray
    seconds: np.ndarray
    landmark_id: np.ndarray
    landmark_mean: np.ndarray
    landmark_covariance: np.ndarray
    landmark_revisions: np.ndarray
    landmark_frozen: np.ndarray
    landmark_anchor: np.ndarray
    statistics: dict[str, int]
    anchor: tuple[float, float] | None
    config: dict[str, object] = field(default_factory=dict)
    anchor_time: float | None = None  # when the anchor was made (eqs. 24-25)
    walls: WallMap | None = None  # the wall landmarks, when the run was given walls
    #: The walls' data association: for each row of ``walls``, the id of the wall it
    #: was paired with or admitted as, -1 when left out (too vague, or ambiguous).
    wall_pairing: np.ndarray | None = None
    #: The point detections' data association: for each row of ``detections``, the id
    #: of the landmark it updated or admitted, -1 when rejected or left a candidate.
    point_pairing: np.ndarray | None = None

    def __repr__(self) -> str:
        s = self.statistics
        return (
            f"SlamResult(events={len(self.t)}, landmarks={len(self.landmark_id)}, "
            f"accepted={s['accepted']}, rejected={s['rejected']}, new={s['new']}, "
            f"seconds={float(self.seconds.sum()):.3f})"
        )

    def path(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, pose, covariance)`` with one row per distinct time: several events can
        share a time stamp (a control and a scan), and the row kept is the last, the
        robot after all of them."""
        last = np.r_[self.t[1:] != self.t[:-1], True]
        return self.t[last], self.pose[last], self.covariance[last]

    def ate(
        self, t_reference: npt.ArrayLike, reference: npt.ArrayLike, *, align: bool = False
    ) -> evaluation.TrajectoryError:
        """ATE of the path against a reference ``(M, 3)`` at ``t_reference``."""
        t, pose, _ = self.path()
        return evaluation.ate(t, pose, t_reference, reference, align=align)

    def nees(
        self,
        t_reference: npt.ArrayLike,
        reference: npt.ArrayLike,
        confidence: float = 0.95,
        *,
        reference_landmarks: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
    ) -> evaluation.NeesResult:
        """Robot-pose NEES at every matched event, with its chi-square band.

        An anchored run (eqs. 24-25) estimates the robot relative to its anchor, and its
        covariance says so: the error is then taken relative to the anchor too, which
        needs the true landmarks, ``reference_landmarks=(ids, xy)``."""
        t, pose, cov = self.path()
        ref = np.array(reference, dtype=np.float64)
        if self.anchor is not None:
            # Only from the anchoring on: before it the run is in the world frame.
            after = np.asarray(t_reference, dtype=np.float64) >= (self.anchor_time or -np.inf)
            ref[after, :2] += self._anchor_offset(reference_landmarks)
        assoc = evaluation.associate(t, pose, t_reference, ref)
        return evaluation.pose_nees(assoc, cov, confidence=confidence)

    def _anchor_offset(
        self, reference_landmarks: tuple[npt.ArrayLike, npt.ArrayLike] | None
    ) -> np.ndarray:
        """Estimated minus true position of the anchor landmark."""
        if reference_landmarks is None:
            raise ValueError(
                "an anchored run's NEES is relative to its anchor: "
                "pass reference_landmarks=(ids, xy)"
            )
        ids = np.asarray(reference_landmarks[0])
        xy = np.asarray(reference_landmarks[1], dtype=np.float64)
        anchor_id = self.landmark_id[self.landmark_anchor]
        match = np.flatnonzero(ids == anchor_id[0]) if len(anchor_id) else np.empty(0, int)
        if len(match) != 1:
            raise ValueError("reference_landmarks must hold the anchor's id exactly once")
        offset: np.ndarray = np.asarray(self.anchor) - xy[match[0]]
        return offset

    def gps_error(
        self,
        t_gps: npt.ArrayLike,
        gps: npt.ArrayLike,
        *,
        lever_arm: tuple[float, float] = (0.0, 0.0),
    ) -> evaluation.GpsError:
        """Distance to each GPS fix after one rigid alignment of the whole path.

        ``lever_arm`` is where the GPS point sits on the robot (m, forward and left of
        the pose's origin): the path compared is that point's, ``t + R(theta) arm``.
        """
        t, pose, _ = self.path()
        return evaluation.gps_error(t, point_path(pose, lever_arm), t_gps, gps)

    def landmark_rmse(
        self,
        reference_ids: npt.ArrayLike,
        reference_xy: npt.ArrayLike,
        *,
        transform: evaluation.Se2Transform | None = None,
    ) -> evaluation.LandmarkError:
        """Landmark errors against reference positions matched by id."""
        return evaluation.landmark_error(
            self.landmark_id.astype(np.int64),
            self.landmark_mean,
            reference_ids,
            reference_xy,
            transform=transform,
        )

    def to_tum(self, path: str | Path) -> Path:
        """Writes the trajectory in the TUM format (``t x y z qx qy qz qw``) for evo."""
        from rperc.datasets import write_tum

        t, pose, _ = self.path()
        write_tum(path, t, pose)
        return Path(path)

    def to_json(self) -> str:
        """The configuration, statistics and timings as JSON."""
        return json.dumps(
            {
                "config": self.config,
                "statistics": self.statistics,
                "events": len(self.t),
                "landmarks": len(self.landmark_id),
                "seconds": float(self.seconds.sum()),
            }
        )


def point_path(pose: npt.ArrayLike, offset: tuple[float, float]) -> np.ndarray:
    """The path ``(N, 2)`` of the point ``offset`` (m, forward and left) of the robot
    whose poses ``(N, 3)`` are given: ``t + R(theta) offset``
    (:func:`rperc.pose.point_path`)."""
    return _point_path(pose, offset)


@dataclass(frozen=True)
class Recording:
    """A recording as the engine reads it, each array sorted by time: ``controls``
    rows ``(t, u0, u1)``, ``detections`` rows ``(t, range, bearing)`` (equal times
    form one scan), ``detection_ids`` one int per detection (negative: unknown) or
    ``None``, ``fixes`` rows ``(t, x, y, var_x, cov_xy, var_y)`` or ``None``."""

    controls: np.ndarray
    detections: np.ndarray
    detection_ids: np.ndarray | None = None
    fixes: np.ndarray | None = None


def mrclam_start(run: MrclamRun) -> PlanarConfigOverrides:
    """The start pose of a MR.CLAM run: its ground truth at the first odometry time,
    known to 1 mm and 1 mrad (the dataset's convention: the robots start surveyed)."""
    t0 = float(run.odometry_t[0])
    x = float(np.interp(t0, run.truth_t, run.truth_x))
    y = float(np.interp(t0, run.truth_t, run.truth_y))
    heading = np.unwrap(run.truth_theta)
    theta = float(wrap_angle(np.interp(t0, run.truth_t, heading)))
    return {"initial_pose": (x, y, theta), "initial_pose_variance": (1e-6, 1e-6, 1e-6)}


def mrclam_recording(
    run: MrclamRun, *, fix_interval: float | None = None, fix_sigma: float = 0.1, seed: int = 0
) -> Recording:
    """The arrays of a :class:`rperc.datasets.MrclamRun`: odometry ``(v, omega)``,
    barcode sightings with their subject ids, and, when ``fix_interval`` is given, an
    external xy fix every ``fix_interval`` seconds made from the ground truth plus
    seeded Gaussian noise of ``fix_sigma`` metres (the issue's stand-in for a GPS)."""
    fixes = None
    if fix_interval is not None:
        fix_interval = real_number(fix_interval, "fix_interval")
        if not fix_interval > 0 or not real_number(fix_sigma, "fix_sigma") > 0:
            raise ValueError("fix_interval and fix_sigma must be > 0")
        # From the run's start (its first odometry row, where mrclam_start puts the
        # robot): MR.CLAM's Vicon starts 12 s earlier, and fixes from then would
        # start the filter 12 s early, away from its start pose.
        start = max(float(run.truth_t[0]), float(run.odometry_t[0]))
        # Checked before np.arange: 1e-9 s asked numpy for 5.5 TiB (issue 38). A fix
        # is a row of six floats, built from a few arrays as long.
        count = max(0.0, float(run.truth_t[-1]) - start) / fix_interval
        wanted = int(min(count, 2.0**100)) + 1
        _rperc.check_allocation(f"fixes every fix_interval={fix_interval:g} s", wanted, 6 * 8 * 4)
        t = np.arange(start, run.truth_t[-1], fix_interval)
        xy = np.c_[np.interp(t, run.truth_t, run.truth_x), np.interp(t, run.truth_t, run.truth_y)]
        xy += np.random.default_rng(seed).normal(scale=fix_sigma, size=xy.shape)
        var = fix_sigma**2
        fixes = np.c_[t, xy, np.full(len(t), var), np.zeros(len(t)), np.full(len(t), var)]
    return Recording(
        controls=np.c_[run.odometry_t, run.odometry_v, run.odometry_omega],
        detections=np.c_[run.measurement_t, run.measurement_range, run.measurement_bearing],
        detection_ids=run.measurement_landmark,
        fixes=fixes,
    )


def victoria_recording(park: VictoriaPark, *, gps_sigma: float | None = None) -> Recording:
    """The arrays of a :class:`rperc.datasets.VictoriaPark`: encoder speed and
    steering, tree detections (vehicle-relative bearings, no ids) and, when
    ``gps_sigma`` is given, the GPS fixes with that standard deviation."""
    fixes = None
    if gps_sigma is not None:
        var = float(gps_sigma) ** 2
        n = len(park.gps_t)
        fixes = np.c_[
            park.gps_t, park.gps_x, park.gps_y, np.full(n, var), np.zeros(n), np.full(n, var)
        ]
    return Recording(
        controls=np.c_[park.input_t, park.input_speed, park.input_steering],
        detections=np.c_[park.measurement_t, park.measurement_range, park.measurement_bearing],
        fixes=fixes,
    )


class _RowProgress:
    """The engine's ``progress(done, total)`` callback driving :func:`rperc._progress.progress`
    (a bar on a terminal, log lines elsewhere) over the rows of a run."""

    def __init__(self, total: int) -> None:
        from rperc._progress import progress

        self._rows = progress(range(total), desc="planar SLAM", total=total, unit="row")
        self._done = 0

    def __enter__(self) -> _RowProgress:
        return self

    def __call__(self, done: int, total: int) -> None:
        for _ in range(done - self._done):
            next(self._rows, None)
        self._done = max(self._done, done)

    def __exit__(self, failed: type[BaseException] | None, *exc: object) -> None:
        if failed is None:
            for _ in self._rows:  # the final line (or the bar's end)
                pass
        else:  # a failed run: no final line
            close = getattr(self._rows, "close", None)
            if close is not None:
                close()


class PlanarSlam:
    """Planar EKF-SLAM with point landmarks (see the module docs).

    ``config`` is a :class:`rperc.config.PlanarConfig` (or a dict of its fields, as
    :meth:`~rperc.config.PlanarConfig.to_dict` writes them); keyword arguments override
    its fields. Unknown or mistyped fields raise ``TypeError`` naming the field, bad
    values ``ValueError``, here, when the filter is made.
    """

    def __init__(
        self,
        config: PlanarConfig | Mapping[str, object] | None = None,
        **overrides: Unpack[PlanarConfigOverrides],
    ) -> None:
        self.config: PlanarConfig = as_config(PlanarConfig, config, overrides)

    def __repr__(self) -> str:
        return f"PlanarSlam({self.config!r})"

    def run(self, recording: Recording, *, progress: bool = False) -> SlamResult:
        """Runs over a :class:`Recording` (see :func:`mrclam_recording`,
        :func:`victoria_recording`). ``progress=True``: a bar on a terminal, log lines
        elsewhere."""
        r = recording
        return self.run_arrays(
            r.controls,
            r.detections,
            detection_ids=r.detection_ids,
            fixes=r.fixes,
            progress=progress,
        )

    def run_arrays(
        self,
        controls: npt.ArrayLike,
        detections: npt.ArrayLike,
        *,
        detection_ids: npt.ArrayLike | None = None,
        fixes: npt.ArrayLike | None = None,
        walls: npt.ArrayLike | None = None,
        progress: bool = False,
    ) -> SlamResult:
        """Runs over columnar arrays, each sorted by time: ``controls`` rows ``(t, u0,
        u1)``, ``detections`` rows ``(t, range, bearing)`` (equal times form one scan),
        ``detection_ids`` one int per detection (negative: unknown), ``fixes`` rows
        ``(t, x, y, var_x, cov_xy, var_y)``, ``walls`` rows ``(t, rho, alpha, var_rho,
        cov, var_alpha, x0, y0, x1, y1)`` (sensor frame, equal times form one scan; the
        result's ``walls`` then holds the wall map). ``progress=True``: a bar on a
        terminal, log lines elsewhere (the rows of the arrays consumed)."""
        ids = None if detection_ids is None else _integral_ids(detection_ids)
        arrays = (
            _rows(controls, 3, "controls"),
            _rows(detections, 3, "detections"),
            ids,
            None if fixes is None else _rows(fixes, 6, "fixes"),
            self.config.to_dict(),
            None if walls is None else _rows(walls, 10, "walls"),
        )
        if progress:
            total = sum(
                0 if a is None else len(a) for a in (arrays[0], arrays[1], arrays[3], arrays[5])
            )
            with _RowProgress(total) as report:
                out = _rperc.planar_slam_run(*arrays, progress=report)
        else:
            out = _rperc.planar_slam_run(*arrays)
        return _slam_result(out, self.config.to_dict(), with_walls=walls is not None)


def _slam_result(out: _rperc.PlanarRun, config: dict[str, object], with_walls: bool) -> SlamResult:
    """The typed result of a native run (its arrays are read-only)."""
    wall_map = WallMap(
        id=out.wall_id, line=out.wall_line, covariance=out.wall_covariance,
        ends=out.wall_ends, revisions=out.wall_revisions, frozen=out.wall_frozen,
        anchor=out.wall_anchor,
    )  # fmt: skip
    stats = dict(zip(out.statistics.names, out.statistics.values, strict=True))
    return SlamResult(
        t=out.t, kind=out.kind, pose=out.pose, covariance=out.covariance, seconds=out.seconds,
        landmark_id=out.landmark_id, landmark_mean=out.landmark_mean,
        landmark_covariance=out.landmark_covariance,
        landmark_revisions=out.landmark_revisions, landmark_frozen=out.landmark_frozen,
        landmark_anchor=out.landmark_anchor, statistics=stats, anchor=out.anchor,
        config=config, anchor_time=out.anchor_time,
        walls=wall_map if with_walls else None,
        wall_pairing=out.wall_pairing if with_walls else None,
        point_pairing=out.point_pairing,
    )  # fmt: skip


#: Paper [000]'s variants of a run on a recording (``rperc slam mrclam/victoria
#: --variant``), combinable: the anchor (eqs 24-25), the external sensor (eqs 26-27)
#: and landmark freezing; and ``smooth`` (MR.CLAM): the run smoothed afterwards
#: (:func:`rperc.slam.smoothing.smooth`).
RECORDING_VARIANTS = ("plain", "anchor", "external", "freeze", "smooth")


def variant_config(base: Mapping[str, object], variants: Sequence[str]) -> dict[str, object]:
    """``base`` with the filter settings of ``variants`` (names of
    :data:`RECORDING_VARIANTS`; ``freeze`` freezes a landmark after 50 sightings)."""
    cfg = dict(base)
    cfg["anchor"] = "anchor" in variants
    cfg["external_fix"] = "external" in variants
    cfg["freeze_after"] = 50 if "freeze" in variants else None
    return cfg


# --- Monte Carlo consistency in the simulated world (Bailey et al. 2006) ----------

#: Paper [000]'s variants a consistency study compares, as filter-config overrides.
#: ``external`` also needs fixes in the world: :func:`consistency` adds them.
VARIANTS: dict[str, PlanarConfigOverrides] = {
    "plain": {},
    "anchor": {"anchor": True},
    "external": {"external_fix": True},
}


def sim_defaults() -> dict[str, object]:
    """The default simulated world (from the Rust crate): a robot driving laps of a
    circle among landmarks on two rings, with the noise levels the filter assumes."""
    return SimConfig().to_dict()


@dataclass(frozen=True)
class SimulatedRun:
    """One run of the simulated world: the :class:`Recording` the filter reads, the
    true pose after every event (``truth`` rows ``t, x, y, theta``) and the true
    landmarks (landmark ``i`` has id ``i``)."""

    recording: Recording
    truth: np.ndarray
    landmarks: np.ndarray

    def truth_path(self) -> tuple[np.ndarray, np.ndarray]:
        """``(t, pose)`` with one row per distinct time (the last, as
        :meth:`SlamResult.path` keeps)."""
        t = self.truth[:, 0]
        last = np.r_[t[1:] != t[:-1], True]
        return t[last], self.truth[last, 1:]


def simulate(
    config: SimConfig | Mapping[str, object] | None = None, *, seed: int = 0, run: int = 0
) -> SimulatedRun:
    """Run ``run`` of the simulated world ``config`` (a :class:`rperc.config.SimConfig`
    or a dict of its fields) seeded by ``seed`` (the same stream the Monte Carlo's run
    ``run`` uses)."""
    seed = seed_number(seed)
    run = seed_number(run, "run")
    w = _rperc.planar_simulate(as_config(SimConfig, config).to_dict(), seed, run)
    fixes = w.fixes if len(w.fixes) else None
    rec = Recording(w.controls, w.detections, w.detection_ids, fixes)
    return SimulatedRun(recording=rec, truth=w.truth, landmarks=w.landmarks)


def sim_slam_config(
    sim: SimConfig | Mapping[str, object] | None = None, **overrides: Unpack[PlanarConfigOverrides]
) -> dict[str, object]:
    """The filter config that matches the world ``sim`` (same noise, same start), with
    ``overrides`` (e.g. ``anchor=True``) on top, as a dict of
    :class:`rperc.config.PlanarConfig`'s fields."""
    matched = _rperc.planar_sim_slam_config(as_config(SimConfig, sim).to_dict())
    return as_config(PlanarConfig, matched, overrides).to_dict()


@dataclass(frozen=True, repr=False)
class PlanarMonteCarlo:
    """Robot-pose NEES after every scan of ``runs`` seeded runs, its mean over the runs
    and the two-sided band of that mean for a consistent filter (chi-square with
    ``3 * runs`` degrees of freedom, divided by ``runs``)."""

    run_nees: np.ndarray  # (runs, steps)
    mean_nees: np.ndarray  # (steps,)
    band: tuple[float, float]
    sim: dict[str, object]
    slam: dict[str, object]

    @property
    def runs(self) -> int:
        return int(self.run_nees.shape[0])

    @property
    def in_band(self) -> float:
        """Fraction of steps whose run-averaged NEES lies inside the band."""
        lo, hi = self.band
        return float(np.mean((self.mean_nees >= lo) & (self.mean_nees <= hi)))

    def __repr__(self) -> str:
        return (
            f"PlanarMonteCarlo(runs={self.runs}, steps={len(self.mean_nees)}, mean NEES "
            f"{float(np.mean(self.mean_nees)):.2f}, band [{self.band[0]:.2f}, "
            f"{self.band[1]:.2f}], {100 * self.in_band:.0f}% of steps in band)"
        )


def _sim_run_nees(
    sim: dict[str, object], slam: dict[str, object], seed: int, run: int
) -> np.ndarray:
    """Run ``run``'s NEES series; a top-level function so process pools and Dask can
    pickle it. It draws from stream ``run`` of ``seed``, as the native batch does."""
    out: np.ndarray = _rperc.planar_sim_nees(sim, slam, seed, run, 1)[0]
    return out


def monte_carlo(
    config: SimConfig | Mapping[str, object] | None = None,
    *,
    slam: PlanarConfig | Mapping[str, object] | None = None,
    runs: int = 50,
    seed: int = 0,
    executor: Executor | None = None,
    confidence: float = 0.95,
) -> PlanarMonteCarlo:
    """Monte Carlo consistency of planar EKF-SLAM in the simulated world ``config``
    (see :func:`sim_defaults`), with the filter ``slam`` (default: the matched config
    of :func:`sim_slam_config`; pass it with your overrides for a variant).

    Without ``executor`` the runs go in parallel on all cores (rayon, GIL released).
    With any :class:`concurrent.futures.Executor` (a process pool, Dask's
    ``client.get_executor()``) each run is submitted to it. Run ``i`` is seeded from
    ``(seed, i)`` either way, so both give identical results.
    """
    sim = as_config(SimConfig, config).to_dict()
    filt = as_config(PlanarConfig, slam).to_dict() if slam is not None else sim_slam_config(sim)
    runs = whole_number(runs, "runs", 1)
    seed = seed_number(seed)
    _rperc.planar_sim_check(sim, filt, runs)  # refused before any run starts
    if executor is None:
        nees = _rperc.planar_sim_nees(sim, filt, seed, 0, runs)
    else:
        futures = [executor.submit(_sim_run_nees, sim, filt, seed, i) for i in range(runs)]
        nees = np.stack([f.result() for f in futures])
    lo, hi = _rperc.nees_bounds(3, runs, confidence)
    return PlanarMonteCarlo(
        run_nees=np.asarray(nees),
        mean_nees=np.asarray(nees).mean(axis=0),
        band=(float(lo), float(hi)),
        sim=sim,
        slam=filt,
    )


def consistency(
    config: SimConfig | Mapping[str, object] | None = None,
    *,
    variants: tuple[str, ...] = ("plain", "anchor", "external"),
    fix_every: int = 10,
    runs: int = 50,
    seed: int = 0,
    executor: Executor | None = None,
) -> dict[str, PlanarMonteCarlo]:
    """:func:`monte_carlo` of each of paper [000]'s variants in the same world and
    seeds; the external one sees an xy fix every ``fix_every`` steps."""
    out = {}
    for name in variants:
        if name not in VARIANTS:
            raise ValueError(f"unknown variant {excerpt(name)}; expected one of {list(VARIANTS)}")
        sim = as_config(SimConfig, config).to_dict()
        if name == "external":
            sim["fix_every"] = fix_every
        slam = sim_slam_config(sim, **VARIANTS[name])
        out[name] = monte_carlo(sim, slam=slam, runs=runs, seed=seed, executor=executor)
    return out
