"""Simulated 2-D laser scans by ray casting against wall segments.

Used by ``rperc demo walls`` and by the tests of wall extraction, where the walls are
known exactly: :func:`visible_walls` says which walls a scan can show (by beam count)
and :func:`check_walls` matches found walls to the true ones and measures their errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rperc._atomic import write_text_atomically
from rperc.pose import wrap_angle


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
    # Near-parallel pairs divide by a tiny denominator; they are masked out below.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
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


def beam_counts(scan: SimulatedScan, n_walls: int) -> np.ndarray:
    """How many beams of ``scan`` hit each of the ``n_walls`` walls."""
    return np.bincount(scan.wall[scan.wall >= 0], minlength=n_walls)


def visible_walls(scan: SimulatedScan, n_walls: int, min_points: int) -> np.ndarray:
    """Indices of the walls that received at least ``min_points`` beams: the walls a
    wall extractor with that ``min_points`` can find from this pose. The others are
    behind the robot, outside the field of view or hidden behind nearer walls."""
    return np.flatnonzero(beam_counts(scan, n_walls) >= min_points)


def wall_lines(walls: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every wall's infinite line in the sensor frame of ``pose``, in Hessian form
    ``x cos(alpha) + y sin(alpha) = rho`` with ``rho >= 0`` (the convention of
    :class:`rperc.linesimp.WallSegments`)."""
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    x, y, th = np.asarray(pose, dtype=float)
    c, s = np.cos(th), np.sin(th)
    to_sensor = np.array([[c, s], [-s, c]])
    a = (walls[:, 0] - (x, y)) @ to_sensor.T
    b = (walls[:, 1] - (x, y)) @ to_sensor.T
    d = b - a
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.hypot(d[:, 0], d[:, 1])[:, None]
    rho = np.einsum("ij,ij->i", normal, a)
    normal = np.where(rho[:, None] < 0, -normal, normal)
    return np.abs(rho), np.arctan2(normal[:, 1], normal[:, 0])


@dataclass(frozen=True)
class WallCheck:
    """Found walls against the ray-cast truth.

    ``truth[k]`` is the true wall of found wall ``k`` (the wall most of its readings
    hit, -1 if none); ``d_rho`` and ``d_alpha`` are its errors (found minus true, m and
    rad, alpha wrapped to (-pi, pi]). ``visible`` and ``hidden`` split the true walls by
    beam count; ``missed`` are visible walls no found wall matches."""

    truth: np.ndarray
    d_rho: np.ndarray
    d_alpha: np.ndarray
    visible: np.ndarray
    hidden: np.ndarray
    missed: np.ndarray

    @property
    def found_visible(self) -> int:
        return len(self.visible) - len(self.missed)


def check_walls(
    walls: np.ndarray,
    scan: SimulatedScan,
    found_indices: list[np.ndarray],
    found_rho: np.ndarray,
    found_alpha: np.ndarray,
    *,
    min_points: int,
) -> WallCheck:
    """Match found walls (readings ``found_indices[k]``, line ``found_rho[k]``,
    ``found_alpha[k]`` in the sensor frame) to the ray-cast truth by the wall their
    readings hit, and measure their errors."""
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    n = len(walls)
    truth = np.full(len(found_indices), -1)
    for k, idx in enumerate(found_indices):
        hits = scan.wall[np.asarray(idx, dtype=int)]
        hits = hits[hits >= 0]
        if len(hits):
            truth[k] = int(np.bincount(hits, minlength=n).argmax())
    rho, alpha = wall_lines(walls, scan.pose)
    ok = truth >= 0
    d_rho = np.where(ok, np.asarray(found_rho) - rho[truth], np.nan)
    d_alpha = np.where(ok, _wrap(np.asarray(found_alpha) - alpha[truth]), np.nan)
    visible = visible_walls(scan, n, min_points)
    hidden = np.setdiff1d(np.arange(n), visible)
    missed = np.setdiff1d(visible, truth[ok])
    return WallCheck(truth, d_rho, d_alpha, visible, hidden, missed)


def _wrap(angle: np.ndarray) -> np.ndarray:
    return wrap_angle(angle)


def loop_walls() -> np.ndarray:
    """A 16 m x 10 m floor around a 10 m x 4 m block: a corridor loop 3 m wide, with two
    pillars against the outer wall. (W, 2, 2) segments."""
    outer = np.array([[0, 0], [16, 0], [16, 10], [0, 10]], dtype=float)
    block = np.array([[3, 3], [13, 3], [13, 7], [3, 7]], dtype=float)
    pillar_a = np.array([[7, 0], [7.6, 0], [7.6, 0.4], [7, 0.4]], dtype=float)
    pillar_b = np.array([[9, 9.6], [9.6, 9.6], [9.6, 10], [9, 10]], dtype=float)
    walls = []
    for poly in (outer, block, pillar_a, pillar_b):
        walls += [(poly[k], poly[(k + 1) % len(poly)]) for k in range(len(poly))]
    return np.asarray(walls)


def loop_path(laps: float = 2.0, step: float = 0.25, radius: float = 1.0) -> np.ndarray:
    """Poses ``(S, 3)`` every ``step`` metres along the corridor loop of
    :func:`loop_walls`, counter-clockwise: a rectangle through the corridor's middle
    (x in [1.5, 14.5], y in [1.5, 8.5]) with corners rounded to ``radius``."""
    lo, hi = np.array([1.5, 1.5]), np.array([14.5, 8.5])
    sides = hi - lo - 2 * radius  # straight lengths along x and y
    quarter = math.pi * radius / 2
    lengths = np.array([sides[0], quarter, sides[1], quarter] * 2)
    lap = float(lengths.sum())
    s = np.arange(0.0, laps * lap, step) % lap
    bounds = np.r_[0.0, np.cumsum(lengths)]
    piece = np.searchsorted(bounds, s, side="right") - 1
    u = s - bounds[piece]
    # Start of each straight piece and its heading; arcs turn left by u / radius.
    starts = [
        (lo + np.array([radius, 0.0]), 0.0),
        (np.array([hi[0], lo[1] + radius]), math.pi / 2),
        (hi - np.array([radius, 0.0]), math.pi),
        (np.array([lo[0], hi[1] - radius]), -math.pi / 2),
    ]
    pose = np.empty((len(s), 3))
    for k, (p, u_k) in enumerate(zip(piece, u, strict=True)):
        side = p // 2
        origin, heading = starts[side]
        if p % 2 == 0:
            xy = origin + u_k * np.array([math.cos(heading), math.sin(heading)])
            th = heading
        else:
            end = origin + sides[side % 2] * np.array([math.cos(heading), math.sin(heading)])
            centre = end + radius * np.array([-math.sin(heading), math.cos(heading)])
            th = heading + u_k / radius
            xy = centre + radius * np.array([math.sin(th), -math.cos(th)])
        pose[k] = (*xy, th)
    pose[:, 2] = wrap_angle(pose[:, 2])
    return pose


def write_loop_log(
    path: str | Path, *, seed: int = 0, laps: float = 2.0, sigma_range: float = 0.01
) -> Path:
    """A CARMEN FLASER log of :func:`loop_path` in :func:`loop_walls`: 180 beams over
    180 degrees (1 degree apart, from -90), ray cast with Gaussian range noise
    ``sigma_range`` (m), the true pose in both pose fields (as the corrected logs
    carry it), 0.5 s apart. The data of ``rperc demo wall-slam``."""
    rng = np.random.default_rng(seed)
    walls = loop_walls()
    angles = -math.pi / 2 + math.pi / 180 * np.arange(180)
    lines = []
    for k, (x, y, th) in enumerate(loop_path(laps)):
        scan = ray_cast(walls, np.array([x, y, th]), angles, max_range=81.83,
                        sigma_range=sigma_range, rng=rng)  # fmt: skip
        ranges = " ".join(f"{r:.4f}" for r in scan.ranges)
        t = 0.5 * k
        pose = f"{x:.6f} {y:.6f} {th:.6f}"
        lines.append(f"FLASER 180 {ranges} {pose} {pose} {t:.1f} sim {t:.1f}")
    return write_text_atomically(path, "\n".join(lines) + "\n")
