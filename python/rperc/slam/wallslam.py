"""Wall-landmark EKF-SLAM on a laser log: the first seed's Fig. 7 experiment.

CARMEN logs such as Intel and ACES hold the path corrected by a published SLAM run,
not raw odometry. So the experiment takes the real scans, the corrected path as the
reference, and odometry made from the corrected path's increments with seeded noise
of stated levels. Each scan step is driven as three unicycle controls (turn,
straight, turn), each held for a synthetic time equal to its effective length (1 m
of travel or 2 rad of turn = 1 s), so constant control-noise variances are noise per
effective metre:

- speed: standard deviation 5 % of the effective distance (``SPEED_SIGMA``),
- turn rate: 1 degree per effective metre (``TURN_SIGMA``),
- bias: +1 % on distance, +0.1 degree per metre of heading.

The filter's motion noise is exactly the stated noise (not tuned on any log), and
the biases are two states of its robot block (``control_bias_sd``: unknown constants
whose prior standard deviations are the stated levels), so the filter learns them
from the walls instead of taking them for noise. The filter is linearised at the
first estimates (``first_estimates``: Huang, Mourikis & Roumeliotis 2008), so it gains
no information about where the map sits or how it is turned. The
walls come from :func:`rperc.linesimp.extract_lines` with its defaults and the log's
sensor range. A real log's sightings carry the straightness floor
(:data:`STRAIGHTNESS`), and the filter is told that repeated sightings of one stretch
of a wall share it (``wall_shared_sd``). The walls are landmarks of the one planar EKF engine
(:class:`rperc.slam.PlanarSlam`'s), with paper [000]'s anchor (eqs. 24-25) and freezing
after N revisions (the text under Fig. 7) as options.

>>> import numpy as np
>>> pose = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, np.pi / 2]])
>>> controls, t = increments(pose)
>>> controls.shape, t.round(3).tolist()
((6, 3), [0.0, 1.002, 1.789])
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, cast

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._args import excerpt, float_array, real_number, seed_number, whole_number
from rperc.pose import wrap_angle
from rperc.slam.planar import PlanarSlam, SlamResult
from rperc.slam.smoothing import SmoothedRun, smooth_walls

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from rperc.config import PlanarConfigOverrides
    from rperc.datasets.carmen import CarmenLog, LaserScans
    from rperc.linesimp import WallSegments

#: A run's scores, counts, timings and settings, flat, as ``--json`` writes them.
Measured = dict[str, str | int | float | bool | None]


class WallsOptions(TypedDict, total=False):
    """Keywords of :func:`run_walls` that choose a variant of the run."""

    anchor: bool
    freeze_after: int | None
    use_walls: bool
    smooth: bool
    straightness: float
    association: str


__all__ = [
    "ASSOCIATION",
    "ASSOCIATIONS",
    "METHODS",
    "NEES_BAND",
    "SPEED_BIAS",
    "SPEED_SIGMA",
    "STRAIGHTNESS",
    "TURN_BIAS",
    "TURN_SIGMA",
    "PreparedLog",
    "WallSlamResult",
    "WallsOptions",
    "at_scans",
    "increments",
    "loop_pairs",
    "noisy_controls",
    "prepare",
    "run_prepared",
    "run_walls",
    "score",
    "wall_rows",
]

SPEED_SIGMA = 0.05  # m per effective metre
TURN_SIGMA = math.radians(1.0)  # rad per effective metre
SPEED_BIAS = 0.01  # relative
TURN_BIAS = math.radians(0.1)  # rad per effective metre
TURN_LENGTH = 0.5  # effective metres per radian turned
#: The straightness floor (m) added to every wall sighting of a real log: calibrated on
#: the ACES log alone by ``benchmarks/wall_straightness.py`` (the median NEES of walls
#: seen 10 scans apart at chi-square's median; consecutive scans share their errors
#: and gave 0.0148, too small for a filter that fuses a wall's sightings from all
#: along the corridor). Intel is the held-out log: median 1.50 (1.39 expected), 81 %
#: within the 95 % quantile.
STRAIGHTNESS = 0.0231
NEES_BAND = (0.2158, 9.3484)  # chi-square, 3 dof, two-sided 95 %
#: The data associations a run without ids can use (the engine's ``association``):
#: nearest neighbours or joint compatibility.
ASSOCIATIONS = ("nn", "jcbb")
#: Wall SLAM's association. Joint compatibility: a stretch of a wall that steps off
#: its line (a recess, a cabinet) is tested with the scan's other walls, which pin
#: the robot. In the simulated corridor with stepped sections
#: (``benchmarks/wall_corridor.py --door 0.3 --recess 0.1``, 12 seeds) the robot's
#: share in band is 62 % with nearest neighbours, 86 % with JCBB; with straight
#: sections 92 and 90 %.
ASSOCIATION = "jcbb"

#: The runs of the Fig. 7 experiment, as overrides of the filter config.
METHODS: dict[str, PlanarConfigOverrides] = {
    "odometry": {},
    "plain": {},
    "anchored_freeze50": {"anchor": True, "freeze_after": 50},
}


def increments(pose: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Each step of a path ``(S, 3)`` as three unicycle controls ``(t, v, omega)``
    (turn, drive straight, turn: the rot1-trans-rot2 odometry model, which reproduces
    any step exactly), each held for its effective length; and the ``(S,)`` scan times.
    A step shorter than 1 micrometre has no bearing and is driven straight ahead."""
    pose = np.asarray(pose, dtype=np.float64)
    d = np.diff(pose[:, :2], axis=0)
    c, s = np.cos(pose[:-1, 2]), np.sin(pose[:-1, 2])
    fwd, left = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    dist = np.hypot(fwd, left)
    rot1 = np.where(dist > 1e-6, np.arctan2(left, fwd), 0.0)
    # Backwards steps drive backwards rather than turning around.
    back = np.abs(rot1) > math.pi / 2
    rot1 = np.where(back, wrap_angle(rot1 + math.pi), rot1)
    trans = np.where(back, -dist, dist)
    rot2 = wrap_angle(np.diff(pose[:, 2]) - rot1)
    dt = np.maximum(
        np.c_[TURN_LENGTH * np.abs(rot1), np.abs(trans), TURN_LENGTH * np.abs(rot2)], 1e-3
    )
    zero = np.zeros(len(dist))
    u = np.stack(
        [np.c_[zero, rot1 / dt[:, 0]], np.c_[trans / dt[:, 1], zero], np.c_[zero, rot2 / dt[:, 2]]],
        axis=1,
    )
    ends = np.cumsum(dt.ravel())
    starts = np.r_[0.0, ends[:-1]]
    controls = np.c_[starts, u.reshape(-1, 2)]
    t_scan = np.r_[0.0, ends[2::3]]
    return controls, t_scan


def noisy_controls(controls: np.ndarray, seed: int, *, bias: bool = True) -> np.ndarray:
    """The controls with seeded white noise and, unless ``bias=False``, the stated
    bias."""
    rng = np.random.default_rng(seed)
    n = len(controls)
    k = 1.0 if bias else 0.0
    v = controls[:, 1] * (1.0 + k * SPEED_BIAS) + SPEED_SIGMA * rng.standard_normal(n)
    w = controls[:, 2] + k * TURN_BIAS + TURN_SIGMA * rng.standard_normal(n)
    out: np.ndarray = np.c_[controls[:, 0], v, w]
    return out


def straightness_covariance(
    rho: npt.ArrayLike, alpha: npt.ArrayLike, start: npt.ArrayLike, end: npt.ArrayLike, sigma: float
) -> np.ndarray:
    """The ``(K, 2, 2)`` covariance a wall's ``(rho, alpha)`` gets when each end of the
    seen segment lies off the ideal straight wall by an independent perpendicular error
    of ``sigma`` metres (a wall that is not straight at the cm level, a door frame, a
    pose that is off by cm): the line through the two ends has offset error
    ``(e1 + e2) / 2`` at the midpoint and angle error ``(e2 - e1) / L``, so at the foot
    of the perpendicular (tangent coordinate 0, the midpoint at ``m``)
    ``var(rho) = sigma^2 (1/2 + 2 m^2 / L^2)``, ``var(alpha) = 2 sigma^2 / L^2`` and
    ``cov = 2 sigma^2 m / L^2`` (``m`` along ``(-sin alpha, cos alpha)``).
    Unlike the fit's covariance it does not shrink with the number of readings. The
    engine's own function (``slam::wall::straightness_covariance``), which
    ``wall_shared_sd`` uses."""
    arrays = {k: float_array(v, k) for k, v in (("rho", rho), ("alpha", alpha))}
    ends = {k: float_array(v, k) for k, v in (("start", start), ("end", end))}
    out: np.ndarray = _rperc.wall_straightness_covariance(
        arrays["rho"], arrays["alpha"], ends["start"], ends["end"], real_number(sigma, "sigma")
    )
    return out


def wall_rows(
    scans: LaserScans, t: np.ndarray, *, show_progress: bool = False, straightness: float = 0.0
) -> tuple[np.ndarray, int, int]:
    """Every scan's walls as rows ``(t, rho, alpha, var_rho, cov, var_alpha, x0, y0, x1,
    y1)`` (sensor frame), the readings the walls use and the valid readings. A
    positive ``straightness`` (m) adds :func:`straightness_covariance`."""
    from rperc._progress import progress
    from rperc.linesimp import extract_lines

    parts: list[WallSegments] = []
    scan: list[int] = []
    used = 0
    steps = range(len(scans))
    it = progress(steps, desc="walls: extract", unit="scan") if show_progress else steps
    for k in it:
        n = int(scans.num_beams[k])
        walls = extract_lines(
            scans.ranges[k, :n], scans.angles(k), max_range=float(scans.max_range[k])
        )
        used += len(walls.flat_indices)
        parts.append(walls)
        scan += [k] * len(walls)
    valid = _valid_readings(scans)
    if not scan:
        return np.zeros((0, 10)), used, valid
    # One pass over all the walls (a numpy call per scan cost more than the extraction).
    rho = np.concatenate([w.rho for w in parts])
    alpha = np.concatenate([w.alpha for w in parts])
    start = np.concatenate([w.start for w in parts]).reshape(-1, 2)
    end = np.concatenate([w.end for w in parts]).reshape(-1, 2)
    c = np.concatenate([w.cov for w in parts]).reshape(-1, 2, 2)
    if straightness > 0:
        c = c + straightness_covariance(rho, alpha, start, end, straightness)
    rows = np.column_stack(
        [t[np.asarray(scan)], rho, alpha, c[:, 0, 0], c[:, 0, 1], c[:, 1, 1], start, end]
    )
    return rows, used, valid


def _valid_readings(scans: LaserScans) -> int:
    """Readings that are finite, positive and under their scan's maximum range."""
    r = np.asarray(scans.ranges, dtype=np.float64)
    beam = np.arange(r.shape[1])[None, :] < np.asarray(scans.num_beams)[:, None]
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r > 0) & (r < np.asarray(scans.max_range, dtype=np.float64)[:, None])
    return int(np.count_nonzero(ok & beam))


def loop_pairs(ref: np.ndarray, radius: float = 1.0, min_path: float = 10.0) -> np.ndarray:
    """Loop closures ``(i, j)``: for each scan ``j``, the nearest earlier scan ``i``
    within ``radius`` metres after more than ``min_path`` metres of path."""
    path = np.r_[0.0, np.cumsum(np.hypot(*np.diff(ref[:, :2], axis=0).T))]
    pairs = []
    for j in range(len(ref)):
        earlier = np.nonzero(path[j] - path > min_path)[0]
        if len(earlier) == 0:
            continue
        dist = np.hypot(*(ref[earlier, :2] - ref[j, :2]).T)
        i = int(np.argmin(dist))
        if dist[i] < radius:
            pairs.append((earlier[i], j))
    return np.array(pairs, dtype=int).reshape(-1, 2)


def pose_nees(est: np.ndarray, cov: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The robot NEES at every scan but the first (whose covariance is the start's)."""
    err = est - ref
    err[:, 2] = wrap_angle(err[:, 2])
    nees: np.ndarray = np.einsum("ni,nij,nj->n", err[1:], np.linalg.pinv(cov[1:]), err[1:])
    return nees


def score(est: np.ndarray, cov: np.ndarray, ref: np.ndarray, pairs: np.ndarray) -> dict[str, float]:
    """ATE RMSE (not aligned: every run starts at the reference's first pose), mean
    loop-closure error (the relative displacement of each pair against the
    reference's), final pose error and the robot NEES against the reference."""
    err = est - ref
    err[:, 2] = wrap_angle(err[:, 2])
    pos = np.hypot(err[:, 0], err[:, 1])
    nees = pose_nees(est, cov, ref)
    if len(pairs):
        d_est = est[pairs[:, 1], :2] - est[pairs[:, 0], :2]
        d_ref = ref[pairs[:, 1], :2] - ref[pairs[:, 0], :2]
        loop = float(np.mean(np.hypot(*(d_est - d_ref).T)))
    else:
        loop = math.nan
    return {
        "ate_rmse": float(np.sqrt(np.mean(pos**2))),
        "loop_error": loop,
        "final_error": float(pos[-1]),
        "final_heading_error_deg": float(np.degrees(abs(err[-1, 2]))),
        "nees_mean": float(np.mean(nees)) if len(nees) else math.nan,
        "nees_median": float(np.median(nees)) if len(nees) else math.nan,
        "nees_in_band": float(np.mean((nees >= NEES_BAND[0]) & (nees <= NEES_BAND[1])))
        if len(nees)
        else math.nan,
    }


#: The scores in metres, written with an ``_m`` suffix by ``measured()``.
_METRES = ("ate_rmse", "loop_error", "final_error")


@dataclass(frozen=True, repr=False)
class WallSlamResult:
    """One wall-SLAM run over a log, at each of its ``S`` scans: the estimated pose
    ``(S, 3)`` and covariance ``(S, 3, 3)``, the reference (the log's corrected path),
    the robot NEES against it (``nees[k]`` for scan ``k + 1``); the map: walls
    ``(rho, alpha)`` in the world frame with their 2x2 covariance, end points
    ``(W, 2, 2)``, revisions and flags; the scores, counts and timings."""

    log: str
    timestamp: np.ndarray
    pose: np.ndarray
    covariance: np.ndarray
    reference: np.ndarray
    nees: np.ndarray
    wall_id: np.ndarray
    wall_line: np.ndarray
    wall_covariance: np.ndarray
    wall_ends: np.ndarray
    wall_revisions: np.ndarray
    wall_frozen: np.ndarray
    wall_anchor: np.ndarray
    metrics: dict[str, float]
    counts: dict[str, int]
    seconds: dict[str, float]
    config: dict[str, object] = field(default_factory=dict)
    #: The batch smoothing of the run (``run_prepared(smooth=True)``), or ``None``.
    smoothing: SmoothedRun | None = None

    def smoothed(self) -> WallSlamResult:
        """The run with the smoothed trajectory, walls (with their extents seen from
        the smoothed poses) and scores in place of the filter's."""
        sm = self.smoothing
        if sm is None:
            raise ValueError("the run was not smoothed: run_prepared(..., smooth=True)")
        order = np.minimum(np.searchsorted(sm.wall_id, self.wall_id), len(sm.wall_id) - 1)
        if not np.array_equal(sm.wall_id[order], self.wall_id):
            raise ValueError("the smoothing's walls are not the run's")
        line, cov, ends = sm.wall_line[order], sm.wall_covariance[order], sm.wall_ends[order]
        pairs = loop_pairs(self.reference)
        return replace(
            self, pose=sm.pose, covariance=sm.covariance,
            nees=pose_nees(sm.pose, sm.covariance, self.reference),
            wall_line=line, wall_covariance=cov, wall_ends=ends,
            metrics=score(sm.pose, sm.covariance, self.reference, pairs), smoothing=None,
        )  # fmt: skip

    def __repr__(self) -> str:
        m = self.metrics
        return (
            f"WallSlamResult({self.log}: scans={len(self.pose)}, walls={len(self.wall_id)}, "
            f"ATE {m['ate_rmse']:.3f} m, loop {m['loop_error']:.3f} m, "
            f"NEES mean {m['nees_mean']:.2f}, seconds={sum(self.seconds.values()):.3f})"
        )

    def _setting(self, name: str) -> str | int | float | bool | None:
        value = self.config.get(name)
        return value if value is None or isinstance(value, str | int | float) else str(value)

    def measured(self) -> Measured:
        """Every metric, count and timing of the run, flat (``rperc slam walls --json``
        and ``rperc bench laser`` write it)."""
        return {
            "log": self.log,
            "anchor": bool(self.config.get("anchor")),
            "freeze_after": self._setting("freeze_after"),
            "straightness_m": self._setting("straightness"),
            "association": self._setting("association"),
            **{f"{k}_m" if k in _METRES else k: v for k, v in self.metrics.items()},
            **self.counts,
            "readings_used_share": self.counts["readings_used"]
            / max(self.counts["readings_valid"], 1),
            **{f"seconds_{k}": v for k, v in self.seconds.items()},
            **self._smoothed_measured(),
        }  # fmt: skip

    def _smoothed_measured(self) -> Measured:
        """The smoothed run's scores (``smoothed_``), its biases and iterations."""
        sm = self.smoothing
        if sm is None:
            return {}
        return {
            **{f"smoothed_{k}_m" if k in _METRES else f"smoothed_{k}": v
               for k, v in self.smoothed().metrics.items()},
            "smoothed_speed_bias": sm.bias[0], "smoothed_turn_bias_rad_per_m": sm.bias[1],
            "smoothed_iterations": sm.iterations,
        }  # fmt: skip

    def to_tum(self, path: str | Path) -> Path:
        """Writes the estimated trajectory at the scans' timestamps in the TUM format
        (``t x y z qx qy qz qw``) for evo."""
        from rperc.datasets import write_tum

        write_tum(path, self.timestamp, self.pose)
        return Path(path)


def at_scans(out: SlamResult, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The robot pose and covariance after the last event at each scan time."""
    rows = np.searchsorted(out.t, t, side="right") - 1
    return out.pose[rows], out.covariance[rows]


@dataclass(frozen=True, repr=False)
class PreparedLog:
    """What every run over one log shares: the reference path, the exact odometry
    increments and scan times, the wall sightings and the share of readings used."""

    log: CarmenLog
    reference: np.ndarray
    exact: np.ndarray
    t: np.ndarray
    rows: np.ndarray
    readings_used: int
    readings_valid: int
    extract_seconds: float
    straightness: float

    def __repr__(self) -> str:
        return (
            f"PreparedLog({Path(self.log.path).name}: {len(self.t)} scans, {len(self.rows)} walls)"
        )


def prepare(
    log: CarmenLog, *, straightness: float = 0.0, show_progress: bool = False
) -> PreparedLog:
    """The reference, odometry increments and wall sightings of a
    :class:`rperc.datasets.CarmenLog` (walls extracted once for every run over it)."""
    if not (math.isfinite(straightness) and straightness >= 0):
        raise ValueError(f"straightness must be finite and >= 0, got {excerpt(straightness)}")
    ref = np.asarray(log.scans.pose, dtype=np.float64)
    if len(ref) < 2 or not np.all(np.isfinite(ref)):
        raise ValueError(f"{log.path}: needs at least 2 scans, each with a finite pose")
    exact, t = increments(ref)
    t0 = time.perf_counter()
    rows, used, valid = wall_rows(
        log.scans, t, show_progress=show_progress, straightness=straightness
    )
    return PreparedLog(
        log, ref, exact, t, rows, used, valid, time.perf_counter() - t0, straightness
    )


def run_walls(
    log: CarmenLog,
    *,
    seed: int = 0,
    anchor: bool = False,
    freeze_after: int | None = None,
    use_walls: bool = True,
    show_progress: bool = False,
    straightness: float = 0.0,
    association: str = ASSOCIATION,
    smooth: bool = False,
) -> WallSlamResult:
    """Wall SLAM over a :class:`rperc.datasets.CarmenLog` from odometry drawn with
    ``seed`` (see the module docs); ``use_walls=False`` is odometry alone;
    ``straightness`` (m) adds :func:`straightness_covariance` to every sighting (0,
    the default, suits simulated straight walls; :data:`STRAIGHTNESS` real logs);
    ``association`` is the engine's (one of :data:`ASSOCIATIONS`, default
    :data:`ASSOCIATION`);
    ``smooth=True`` also smooths the run (:meth:`WallSlamResult.smoothed`)."""
    prepared = prepare(log, straightness=straightness, show_progress=show_progress)
    # The association is checked by the crate when the filter is made, naming it.
    overrides = cast("PlanarConfigOverrides", {"association": association, "anchor": anchor})
    if freeze_after is not None:
        overrides["freeze_after"] = whole_number(freeze_after, "freeze_after", 1)
    return run_prepared(prepared, seed=seed, use_walls=use_walls, smooth=smooth, **overrides)


def run_prepared(
    prepared: PreparedLog,
    *,
    seed: int = 0,
    use_walls: bool = True,
    smooth: bool = False,
    **overrides: Unpack[PlanarConfigOverrides],
) -> WallSlamResult:
    """One run over a :func:`prepare`d log: odometry drawn with ``seed``, the filter
    config's stated noise and start with ``overrides`` (e.g. ``anchor=True``,
    ``freeze_after=50``, ``association="nn"``) on top. ``smooth=True`` also smooths
    the run (:func:`rperc.slam.smoothing.smooth_walls`, one pose per scan): see
    :meth:`WallSlamResult.smoothed`."""
    seed = seed_number(seed)
    ref, t = prepared.reference, prepared.t
    rows = prepared.rows if use_walls else np.zeros((0, 10))
    config: dict[str, object] = {
        "motion": {
            "unicycle": {"speed_variance": SPEED_SIGMA**2, "turn_rate_variance": TURN_SIGMA**2}
        },
        "association": ASSOCIATION,
        "initial_pose": ref[0].tolist(),
        # The biases are unknown constants of the stated size: estimated as states.
        "control_bias_sd": [SPEED_BIAS, TURN_BIAS],
        # Linearised at the first estimates, the map's frame stays unobservable (on
        # ACES the robot NEES mean fell from 410 to 4.7, 10 seeds).
        "first_estimates": True,
        # The floor is a wall's own bends: repeated sightings of one stretch share it.
        "wall_shared_sd": prepared.straightness,
        **overrides,
    }
    controls = np.r_[noisy_controls(prepared.exact, seed), [[t[-1], 0.0, 0.0]]]
    t0 = time.perf_counter()
    out = PlanarSlam(config).run_arrays(controls, np.zeros((0, 3)), walls=rows)
    walls = out.walls
    assert walls is not None  # run with walls=, so the result has them
    slam_s = time.perf_counter() - t0
    est, cov = at_scans(out, t)
    smoothing, smooth_s = None, 0.0
    if smooth and use_walls:
        t0 = time.perf_counter()
        smoothing = smooth_walls(out, controls, rows, t)
        smooth_s = time.perf_counter() - t0
    pairs = loop_pairs(ref)
    counts = {
        "scans": len(ref),
        "wall_sightings": len(rows),
        "walls": len(walls),
        "walls_frozen": int(np.count_nonzero(walls.frozen)),
        "loop_pairs": len(pairs),
        "readings_valid": prepared.readings_valid if use_walls else 0,
        "readings_used": prepared.readings_used if use_walls else 0,
        **{k: v for k, v in out.statistics.items() if k.startswith("walls_")},
    }
    log = prepared.log
    return WallSlamResult(
        log=Path(log.path).name,
        timestamp=np.asarray(log.scans.timestamp, dtype=np.float64),
        pose=est, covariance=cov, reference=ref, nees=pose_nees(est, cov, ref),
        wall_id=walls.id, wall_line=walls.line,
        wall_covariance=walls.covariance, wall_ends=walls.ends,
        wall_revisions=walls.revisions, wall_frozen=walls.frozen,
        wall_anchor=walls.anchor,
        metrics=score(est, cov, ref, pairs),
        counts=counts,
        seconds={
            "extract": prepared.extract_seconds if use_walls else 0.0, "slam": slam_s,
            "smooth": smooth_s,
        },
        config={**config, "straightness": prepared.straightness},
        smoothing=smoothing,
    )  # fmt: skip
