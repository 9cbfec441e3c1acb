"""Streams a planar SLAM run to the rerun viewer (the optional ``[viz]`` extra:
``pip install rperc[viz]``): the robot's pose over time, the final map with each
landmark's 95 % ellipse, the true path and landmarks when known, and the robot NEES
as a time series with its band. Saved to an ``.rrd`` file, which ``rerun FILE``
opens."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from rperc._args import whole_number
from rperc._atomic import write_atomically
from rperc._extras import require
from rperc.slam.evaluation import NeesResult
from rperc.slam.planar import SlamResult

__all__ = ["ellipse_outlines", "log_run"]

# A 2-D Gaussian's 95 % region is the ellipse at this Mahalanobis radius (chi2, 2
# dof), as in the matplotlib figures.
RADIUS_95 = math.sqrt(-2.0 * math.log(0.05))


def ellipse_outlines(
    mean: npt.ArrayLike, cov: npt.ArrayLike, radius: float = RADIUS_95, points: int = 48
) -> np.ndarray:
    """Closed outlines ``(K, points + 1, 2)`` of the ellipses ``(x - m)^T C^-1 (x - m)
    = radius^2`` of ``K`` means ``(K, 2)`` with covariances ``(K, 2, 2)``."""
    m = np.asarray(mean, dtype=np.float64).reshape(-1, 2)
    c = np.asarray(cov, dtype=np.float64).reshape(-1, 2, 2)
    values, vectors = np.linalg.eigh(c)
    a = np.linspace(0.0, 2.0 * np.pi, points + 1)
    circle = np.stack([np.cos(a), np.sin(a)], axis=1)  # (P, 2)
    scale = radius * np.sqrt(np.clip(values, 0.0, None))  # (K, 2)
    # x = m + V diag(scale) u for u on the unit circle.
    out: np.ndarray = m[:, None, :] + np.einsum("kij,kj,pj->kpi", vectors, scale, circle)
    return out


def _rerun() -> Any:
    return require("rerun", "streaming to rerun")


def log_run(
    result: SlamResult,
    path: str | Path,
    *,
    truth: npt.ArrayLike | None = None,
    landmarks: npt.ArrayLike | None = None,
    nees: NeesResult | None = None,
    frames: int = 2000,
) -> Path:
    """Writes ``result`` to the rerun file ``path``: the robot (position and heading)
    at up to ``frames`` times on the ``time`` timeline, the estimated path, the final
    map with 95 % ellipses, ``truth`` ((M, >= 2) positions) and ``landmarks`` ((L, 2))
    as static references, and ``nees`` with its band as scalars."""
    # At least one frame: 0 divided the time steps by zero, and a fraction or NaN
    # gave no frames (checked before rerun is imported).
    frames = whole_number(frames, "frames", 1)
    rr = _rerun()

    def write(tmp: Path) -> None:
        rec = rr.RecordingStream("rperc_slam")
        rec.save(str(tmp))
        _log(rr, rec, result, truth, landmarks, nees, frames)
        # The file sink writes on rerun's own thread: only a disconnected stream has
        # put its last bytes in the file, so only then may it be renamed into place.
        rec.flush()
        rec.disconnect()

    # Through the one atomic writer: a reader (or a second run to the same path) sees
    # the old file or the whole new one, never a half-written recording.
    return write_atomically(path, write)


def _log(
    rr: Any,
    rec: Any,
    result: SlamResult,
    truth: npt.ArrayLike | None,
    landmarks: npt.ArrayLike | None,
    nees: NeesResult | None,
    frames: int,
) -> None:
    """Logs the run to ``rec`` (see :func:`log_run`)."""
    t, pose, _ = result.path()
    if truth is not None:
        xy = np.asarray(truth, dtype=np.float64)[:, :2]
        rec.log("world/truth/path", rr.LineStrips2D([xy], colors=[(120, 120, 120)]), static=True)
    if landmarks is not None:
        marks = np.asarray(landmarks, dtype=np.float64)
        rec.log("world/truth/landmarks", rr.Points2D(marks, colors=[(0, 0, 0)]), static=True)
    rec.log("world/estimate/path", rr.LineStrips2D([pose[:, :2]], colors=[(214, 39, 40)]),
            static=True)  # fmt: skip
    outlines = ellipse_outlines(result.landmark_mean, result.landmark_covariance)
    labels = [str(int(i)) for i in result.landmark_id]
    rec.log("world/estimate/landmarks", rr.Points2D(result.landmark_mean, labels=labels),
            static=True)  # fmt: skip
    rec.log("world/estimate/ellipses_95", rr.LineStrips2D(list(outlines)), static=True)
    step = max(1, math.ceil(len(t) / frames))
    for k in range(0, len(t), step):
        rec.set_time("time", duration=float(t[k] - t[0]))
        x, y, theta = pose[k]
        rec.log("world/estimate/robot", rr.Points2D([[x, y]], radii=[0.05]))
        heading = [[0.3 * math.cos(theta), 0.3 * math.sin(theta)]]
        rec.log("world/estimate/heading", rr.Arrows2D(vectors=heading, origins=[[x, y]]))
    if nees is not None:
        for tk, value in zip(nees.t[::step], nees.nees[::step], strict=True):
            rec.set_time("time", duration=float(tk - t[0]))
            rec.log("nees/robot", rr.Scalars([float(value)]))
            rec.log("nees/band", rr.Scalars([nees.band[0], nees.band[1]]))
