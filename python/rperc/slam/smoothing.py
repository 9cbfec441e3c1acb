"""Batch smoothing of a wall-SLAM run: every scan's pose, every wall and the control
biases estimated together from all of the run's data, with the filter's data
association (``slam::planar::smooth`` in Rust: Levenberg-Marquardt over the same
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

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc._config_base import as_config
from rperc.config import SmootherConfig, SmootherConfigOverrides
from rperc.slam.planar import SlamResult

if TYPE_CHECKING:
    from typing_extensions import Unpack

__all__ = ["SmoothedRun", "smooth_walls"]


@dataclass(frozen=True, repr=False)
class SmoothedRun:
    """A smoothed wall-SLAM run: the pose ``(S, 3)`` at each of the ``S`` times with its
    marginal covariance ``(S, 3, 3)``; the walls (``wall_id``, ``wall_line`` ``(W, 2)``
    rows ``(rho, alpha)`` in the world frame with ``rho >= 0``, ``wall_covariance``
    ``(W, 2, 2)``, and ``wall_ends`` ``(W, 2, 2)``: the seen extent, its sightings'
    end points placed with the smoothed poses); the control biases ``(s, b)``; the
    iterations, the final cost (the sum of squared whitened residuals) and the
    number of residuals."""

    times: np.ndarray
    pose: np.ndarray
    covariance: np.ndarray
    wall_id: np.ndarray
    wall_line: np.ndarray
    wall_covariance: np.ndarray
    wall_ends: np.ndarray
    bias: tuple[float, float]
    iterations: int
    cost: float
    residuals: int

    def __repr__(self) -> str:
        return (
            f"SmoothedRun({len(self.pose)} poses, {len(self.wall_id)} walls, "
            f"{self.iterations} iterations, cost {self.cost:.1f} over {self.residuals} "
            f"residuals, bias ({self.bias[0]:.4g}, {self.bias[1]:.4g}))"
        )


def smooth_walls(
    result: SlamResult,
    controls: npt.ArrayLike,
    walls: npt.ArrayLike,
    times: npt.ArrayLike,
    config: SmootherConfig | Mapping[str, object] | None = None,
    **overrides: Unpack[SmootherConfigOverrides],
) -> SmoothedRun:
    """Smooths the run ``result`` of :meth:`PlanarSlam.run_arrays` given the same
    ``controls`` and ``walls`` rows: one pose at each of ``times`` (increasing; the
    first the run's first event, where the config's initial pose holds; every wall
    row's time among them), starting from the filter's pose there and its final
    walls, with its association (``result.wall_pairing``) and its config. ``config``
    (a :class:`rperc.config.SmootherConfig` or a dict of its fields) and keyword
    overrides of its fields set when it stops: after ``max_iterations`` or when a step
    lowers the cost by less than the fraction ``tolerance``."""
    options = as_config(SmootherConfig, config, overrides).to_dict()
    if result.walls is None or result.wall_pairing is None:
        raise ValueError("result has no walls: run PlanarSlam.run_arrays with walls=")
    t = np.ascontiguousarray(times, dtype=np.float64)
    if t.ndim != 1 or len(t) == 0:
        raise ValueError(f"times must be a non-empty 1-D array, got shape {t.shape}")
    rows = np.searchsorted(result.t, t, side="right") - 1
    if len(result.t) == 0 or rows.min() < 0:
        raise ValueError("times must not come before the run's first event")
    if t[0] != result.t[0]:
        # The config's initial pose is the prior of the first pose: it holds there only.
        raise ValueError(
            f"times[0] must be the run's first event time {result.t[0]!r} (where the "
            f"start prior holds), got {t[0]!r}"
        )
    out = _rperc.planar_smooth_walls(
        np.ascontiguousarray(controls, dtype=np.float64),
        t,
        np.ascontiguousarray(result.pose[rows]),
        np.ascontiguousarray(walls, dtype=np.float64),
        result.wall_pairing,
        result.walls.id.astype(np.int64),
        np.ascontiguousarray(result.walls.line),
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
        bias=out.bias,
        iterations=out.iterations,
        cost=out.cost,
        residuals=out.residuals,
    )
