"""Simulated 2-D laser scans by ray casting against wall segments.

Used by ``rperc demo lines`` and by the tests of wall extraction, where the walls are
known exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SimulatedScan:
    """One scan: ``ranges[k]`` along bearing ``angles[k]`` (sensor frame), the index of
    the wall each beam hit (-1 for none), and the sensor pose ``(x, y, theta)``."""

    ranges: np.ndarray
    angles: np.ndarray
    wall: np.ndarray
    pose: np.ndarray
    max_range: float


def room_walls() -> np.ndarray:
    """A 10 m x 6 m room with a 2 m x 1 m cabinet and a pillar: (W, 2, 2) segments."""
    corners = np.array([[0, 0], [10, 0], [10, 6], [0, 6]], dtype=float)
    cabinet = np.array([[6, 4], [8, 4], [8, 5], [6, 5]], dtype=float)
    pillar = np.array([[2.5, 1.5], [3.0, 1.5], [3.0, 2.0], [2.5, 2.0]], dtype=float)
    walls = []
    for poly in (corners, cabinet, pillar):
        walls += [(poly[k], poly[(k + 1) % len(poly)]) for k in range(len(poly))]
    return np.asarray(walls)


def ray_cast(
    walls: np.ndarray,
    pose: np.ndarray,
    angles: np.ndarray,
    *,
    max_range: float = 30.0,
    sigma_range: float = 0.0,
    rng: np.random.Generator | None = None,
) -> SimulatedScan:
    """Ranges from ``pose = (x, y, theta)`` along sensor-frame ``angles`` to the nearest
    of the ``walls`` ((W, 2, 2) segments). Beams that hit nothing read ``max_range``
    (invalid, as real scanners report). Gaussian noise of ``sigma_range`` is added to
    the hits."""
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    pose = np.asarray(pose, dtype=float)
    angles = np.asarray(angles, dtype=float)
    heading = pose[2] + angles
    d = np.stack([np.cos(heading), np.sin(heading)], axis=1)  # (B, 2)
    a, e = walls[:, 0], walls[:, 1] - walls[:, 0]  # (W, 2)
    # Solve pose + t d = a + s e for every beam/wall pair with Cramer's rule.
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # (B, W)
    w = a - pose[:2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[None, :, 0] * e[None, :, 1] - w[None, :, 1] * e[None, :, 0]) / denom
        s = (w[None, :, 0] * d[:, None, 1] - w[None, :, 1] * d[:, None, 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 0) & (s >= 0) & (s <= 1)
    t = np.where(hit, t, np.inf)
    wall = np.argmin(t, axis=1)
    ranges = t[np.arange(len(angles)), wall]
    wall = np.where(np.isfinite(ranges) & (ranges < max_range), wall, -1)
    if sigma_range > 0:
        rng = rng if rng is not None else np.random.default_rng()
        ranges = ranges + rng.normal(scale=sigma_range, size=ranges.shape)
    ranges = np.where(wall >= 0, ranges, max_range)
    return SimulatedScan(ranges, angles, wall, pose, max_range)
