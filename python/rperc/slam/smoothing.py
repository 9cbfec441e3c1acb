"""Batch smoothing of a SLAM run with walls, point landmarks or both: the poses, the
map and the control biases estimated together from all of the run's data, with the
filter's data association (``slam::planar::smooth`` in Rust: Levenberg-Marquardt over the same
models, term for term, as the EKF's).

The EKF's trajectory is causal: the drift of a long first loop stays in it after the
loop closes. The smoothed trajectory uses each sighting both ways in time. Its
covariances are the inverse of the Gauss-Newton information at the optimum.

>>> import numpy as np
>>> from rperc.slam import PlanarSlam
>>> from rperc.slam.smoothing import smooth_walls
>>> controls = np.array([[0.0, 1.0, 0.0], [2.0, 0.0, 0.0]])  # t, v, omega
>>> wall = [2.0, np.pi / 2, 1e-4, 0.0, 1e-4, -1.0, 2.0, 1.0, 2.0]  # 2 m to the left
>>> walls = np.array([[1.0, *wall], [2.0, *wall]])
>>> result = PlanarSlam(association="nn").run_arrays(controls, np.zeros((0, 3)), walls=walls)
>>> smoothed = smooth_walls(result, controls, walls, times=np.array([0.0, 1.0, 2.0]))
>>> bool(np.all(np.abs(smoothed.pose[:, 1]) < 1e-6))  # the wall holds y at 0
True
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._config_base import as_config
from rperc.config import SmootherConfig, SmootherConfigOverrides
from rperc.slam.planar import SlamResult

if TYPE_CHECKING:
    from typing_extensions import Unpack

__all__ = ["SmoothedRun", "pose_times", "smooth", "smooth_walls"]


@dataclass(frozen=True, repr=False)
class SmoothedRun:
    """A smoothed SLAM run: the pose ``(S, 3)`` at each of the ``S`` times with its
    marginal covariance ``(S, 3, 3)``; the walls (``wall_id``, ``wall_line`` ``(W, 2)``
    rows ``(rho, alpha)`` in the world frame with ``rho >= 0``, ``wall_covariance``
    ``(W, 2, 2)``, and ``wall_ends`` ``(W, 2, 2)``: the seen extent, its sightings'
    end points placed with the smoothed poses); the point landmarks (``landmark_id``,
    ``landmark_mean`` ``(L, 2)``, ``landmark_covariance`` ``(L, 2, 2)``); the control
    biases ``(s, b)``; the iterations, the final cost (the sum of squared whitened
    residuals, Huber's where set), the number of residuals and the seconds the
    smoothing took."""

    times: np.ndarray
    pose: np.ndarray
    covariance: np.ndarray
    wall_id: np.ndarray
    wall_line: np.ndarray
    wall_covariance: np.ndarray
    wall_ends: np.ndarray
    landmark_id: np.ndarray
    landmark_mean: np.ndarray
    landmark_covariance: np.ndarray
    bias: tuple[float, float]
    iterations: int
    cost: float
    residuals: int
    seconds: float = 0.0  # the smoothing's wall-clock time

    def __repr__(self) -> str:
        return (
            f"SmoothedRun({len(self.pose)} poses, {len(self.wall_id)} walls, "
            f"{len(self.landmark_id)} landmarks, {self.iterations} iterations, cost "
            f"{self.cost:.1f} over {self.residuals} residuals, bias ({self.bias[0]:.4g}, "
            f"{self.bias[1]:.4g}))"
        )

    def to_result(self, filtered: SlamResult) -> SlamResult:
        """The filter's run ``filtered`` (the one smoothed) with this path and point
        map: one row per smoothed pose (``kind`` 0 on every row: a smoothed pose is
        no event; ``seconds`` the filter's and the smoothing's time shared equally
        over the rows, so that their sum is the whole run's), the landmarks' means
        and covariances smoothed. The statistics, the config and the
        association stay the filter's, so its ``ate``, ``nees`` and
        ``landmark_rmse`` score the smoothed run."""
        if filtered.walls is not None and len(filtered.walls.id):
            # Its WallMap's revisions and freezing have no smoothed counterpart.
            raise ValueError(
                "to_result carries point maps only: read a run's smoothed walls from "
                "this SmoothedRun's wall_* fields"
            )
        order = np.searchsorted(self.landmark_id, filtered.landmark_id)
        if len(self.landmark_id) != len(filtered.landmark_id) or not np.array_equal(
            self.landmark_id[np.minimum(order, len(order) - 1)], filtered.landmark_id
        ):
            raise ValueError("filtered must be the run smoothed: its landmarks differ")
        total = float(np.sum(filtered.seconds)) + self.seconds
        return replace(
            filtered,
            t=self.times,
            kind=np.zeros(len(self.times), np.uint8),
            pose=self.pose,
            covariance=self.covariance,
            seconds=np.full(len(self.times), total / max(len(self.times), 1)),
            landmark_mean=self.landmark_mean[order],
            landmark_covariance=self.landmark_covariance[order],
        )


def smooth_walls(
    result: SlamResult,
    controls: npt.ArrayLike,
    walls: npt.ArrayLike,
    times: npt.ArrayLike,
    config: SmootherConfig | Mapping[str, object] | None = None,
    **overrides: Unpack[SmootherConfigOverrides],
) -> SmoothedRun:
    """:func:`smooth` of a wall-SLAM run: ``smooth(result, controls, times,
    walls=walls, ...)``."""
    return smooth(result, controls, times, walls=walls, config=config, **overrides)


def smooth(
    result: SlamResult,
    controls: npt.ArrayLike,
    times: npt.ArrayLike,
    *,
    walls: npt.ArrayLike | None = None,
    detections: npt.ArrayLike | None = None,
    config: SmootherConfig | Mapping[str, object] | None = None,
    **overrides: Unpack[SmootherConfigOverrides],
) -> SmoothedRun:
    """Smooths the run ``result`` of :meth:`PlanarSlam.run_arrays` given the same
    ``controls``, ``walls`` and ``detections`` rows: one pose at each of ``times``
    (increasing; the first the run's first event, where the config's initial pose
    holds; every wall and detection row's time among them), starting from the
    filter's pose there and its final map, with its association
    (``result.wall_pairing``, ``result.point_pairing``: a detection the filter's gate
    refused stays out) and its config. ``config`` (a :class:`rperc.config.SmootherConfig`
    or a dict of its fields) and keyword overrides of its fields set when it stops
    (after ``max_iterations`` or when a step lowers the cost by less than the fraction
    ``tolerance``) and Huber's threshold on the point sightings (``point_huber``).
    External fixes are not modelled: they only shape the starting point."""
    options = as_config(SmootherConfig, config, overrides).to_dict()
    if result.anchor is not None:
        raise ValueError(
            "an anchored run (eqs. 24-25) is in its anchor's frame, which the smoother "
            "does not model: smooth a run without anchor="
        )
    t = _node_times(result, times)
    rows = np.searchsorted(result.t, t, side="right") - 1
    wall_rows, pairing, map_id, map_line = _wall_inputs(result, walls)
    points, point_pairing = _point_inputs(result, detections)
    start = time.perf_counter()
    out = _rperc.planar_smooth(
        np.ascontiguousarray(controls, dtype=np.float64),
        t,
        np.ascontiguousarray(result.pose[rows]),
        wall_rows,
        pairing,
        map_id,
        map_line,
        points,
        point_pairing,
        result.landmark_id.astype(np.int64),
        np.ascontiguousarray(result.landmark_mean, dtype=np.float64).reshape(-1, 2),
        result.config or None,
        options,
    )
    return SmoothedRun(
        times=t,
        pose=out.pose,
        covariance=out.covariance,
        wall_id=out.wall_id,
        wall_line=out.wall_line,
        wall_covariance=out.wall_covariance,
        wall_ends=out.wall_ends,
        landmark_id=out.landmark_id,
        landmark_mean=out.landmark_mean,
        landmark_covariance=out.landmark_covariance,
        bias=out.bias,
        iterations=out.iterations,
        cost=out.cost,
        residuals=out.residuals,
        seconds=time.perf_counter() - start,
    )


def pose_times(
    result: SlamResult, rows: npt.ArrayLike, *, interval: float | None = None
) -> np.ndarray:
    """The times :func:`smooth` needs a pose at: the run's first event and every time
    of ``rows`` (detection or wall rows, time first) from it on; with ``interval``,
    also one every ``interval`` seconds over the run, so that the smoothed path is
    drawn where nothing was seen too (a grid too large for memory is a
    ``MemoryError`` naming it, before anything is allocated)."""
    from rperc._args import real_number

    if len(result.t) == 0:
        raise ValueError("the run has no event")
    t0, t1 = float(result.t[0]), float(result.t[-1])
    table = np.asarray(rows, dtype=np.float64)
    if table.ndim != 2 or table.shape[1] == 0:
        raise ValueError(f"rows must be a 2-D table, time first, got shape {table.shape}")
    seen = table[:, 0]
    if not np.all(np.isfinite(seen)):
        raise ValueError("rows' times must be finite")
    grid = np.zeros(0)
    if interval is not None:
        step = real_number(interval, "interval")
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"interval must be finite and > 0, got {interval!r}")
        count = (t1 - t0) / step
        _rperc.check_allocation(
            f"poses every interval={step:g} s", int(min(count, 2.0**100)) + 1, 8 * 60
        )
        grid = np.arange(t0, t1, step)
    return np.unique(np.r_[t0, seen[seen >= t0], grid])


def _node_times(result: SlamResult, times: npt.ArrayLike) -> np.ndarray:
    """``times`` as float64, checked: non-empty, 1-D, from the run's first event."""
    t = np.ascontiguousarray(times, dtype=np.float64)
    if t.ndim != 1 or len(t) == 0:
        raise ValueError(f"times must be a non-empty 1-D array, got shape {t.shape}")
    if len(result.t) == 0 or t.min() < result.t[0]:
        raise ValueError("times must not come before the run's first event")
    if t[0] != result.t[0]:
        # The config's initial pose is the prior of the first pose: it holds there only.
        raise ValueError(
            f"times[0] must be the run's first event time {result.t[0]!r} (where the "
            f"start prior holds), got {t[0]!r}"
        )
    return t


def _wall_inputs(
    result: SlamResult, walls: npt.ArrayLike | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The wall rows, their pairing and the final wall map (all empty without walls)."""
    if walls is None:
        return np.zeros((0, 10)), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2))
    if result.walls is None or result.wall_pairing is None:
        raise ValueError("result has no walls: run PlanarSlam.run_arrays with walls=")
    return (
        np.ascontiguousarray(walls, dtype=np.float64),
        result.wall_pairing,
        result.walls.id.astype(np.int64),
        np.ascontiguousarray(result.walls.line),
    )


def _point_inputs(
    result: SlamResult, detections: npt.ArrayLike | None
) -> tuple[np.ndarray, np.ndarray]:
    """The point rows and the filter's pairing of each (-1: not used)."""
    if detections is None:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    rows = np.ascontiguousarray(detections, dtype=np.float64)
    pairing = result.point_pairing
    if pairing is None or rows.ndim != 2 or len(pairing) != len(rows):
        raise ValueError(
            f"detections must be the run's own {0 if pairing is None else len(pairing)} "
            f"detection rows, got shape {rows.shape}"
        )
    return rows, pairing
