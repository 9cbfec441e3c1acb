"""Consistency of wall covariances on a real laser log: the same wall seen in two
consecutive scans, both taken to the world frame with the logged poses, must differ by
an amount its covariance explains. The NEES of that difference is chi-square with 2
degrees of freedom when the covariances are honest.

Walls are paired by geometry alone (angle, distance, overlap), never by the covariance
under test, so the gate cannot hide overconfident walls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from rperc.datasets import LaserScans
from rperc.linesimp import WallSegments, extract_lines
from rperc.pose import wrap_angle

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from rperc.config import ScanParamsOverrides

CHI2_2DOF_95 = 5.991464547107979
"""The 95 % quantile of chi-square with 2 dof."""
PAIR_MAX_ANGLE = math.radians(5.0)
PAIR_MAX_OFFSET = 0.2  # m, from one segment's midpoint to the other's line


@dataclass(frozen=True)
class NeesSummary:
    """The NEES of walls matched in consecutive scans, and its distribution."""

    nees: np.ndarray  # (P,) one per matched pair
    scans: int
    walls: int

    @property
    def mean(self) -> float:
        return float(np.mean(self.nees)) if len(self.nees) else math.nan

    @property
    def median(self) -> float:
        return float(np.median(self.nees)) if len(self.nees) else math.nan

    @property
    def within_95(self) -> float:
        """Share of pairs under chi-square's 95 % quantile (0.95 when honest)."""
        return float(np.mean(self.nees < CHI2_2DOF_95)) if len(self.nees) else math.nan

    def as_dict(self) -> dict[str, int | float | dict[str, float]]:
        return {
            "pairs": len(self.nees),
            "scans": self.scans,
            "walls": self.walls,
            "mean": self.mean,
            "median": self.median,
            "within_95": self.within_95,
            "expected": {"mean": 2.0, "median": 2 * math.log(2), "within_95": 0.95},
        }

    def __str__(self) -> str:
        return (
            f"{len(self.nees)} wall pairs: NEES mean {self.mean:.2f} (2 expected), median "
            f"{self.median:.2f} (1.39), {100 * self.within_95:.1f} % within the 95 % quantile"
        )


def _wrap(a: np.ndarray | float) -> np.ndarray:
    return wrap_angle(a)


def line_difference(a: WallSegments, i: int, b: WallSegments, j: int) -> np.ndarray:
    """``(rho, alpha)`` of wall ``j`` of ``b`` minus wall ``i`` of ``a``, taking the
    equivalent form ``(-rho, alpha + pi)`` when the normals point opposite ways."""
    d_alpha = float(_wrap(b.alpha[j] - a.alpha[i]))
    if abs(d_alpha) <= math.pi / 2:
        return np.array([b.rho[j] - a.rho[i], d_alpha])
    return np.array([b.rho[j] + a.rho[i], float(_wrap(b.alpha[j] - a.alpha[i] - math.pi))])


def pair_walls(a: WallSegments, b: WallSegments) -> list[tuple[int, int]]:
    """Each wall of ``b`` paired with the wall of ``a`` it overlaps most among those
    within ``PAIR_MAX_ANGLE`` in direction and ``PAIR_MAX_OFFSET`` from its midpoint
    (both walls in the same frame)."""
    pairs = []
    for j in range(len(b)):
        mid = 0.5 * (b.start[j] + b.end[j])
        best, best_i = 0.0, -1
        for i in range(len(a)):
            if abs(line_difference(a, i, b, j)[1]) > PAIR_MAX_ANGLE:
                continue
            n = np.array([math.cos(a.alpha[i]), math.sin(a.alpha[i])])
            if abs(mid @ n - a.rho[i]) > PAIR_MAX_OFFSET:
                continue
            t = np.array([-n[1], n[0]])
            lo_a, hi_a = sorted((a.start[i] @ t, a.end[i] @ t))
            lo_b, hi_b = sorted((b.start[j] @ t, b.end[j] @ t))
            overlap = min(hi_a, hi_b) - max(lo_a, lo_b)
            if overlap > best:
                best, best_i = overlap, i
        if best_i >= 0:
            pairs.append((best_i, j))
    return pairs


def consecutive_wall_nees(
    scans: LaserScans,
    *,
    pose_cov: npt.ArrayLike | None = None,
    every: int = 1,
    straightness: float = 0.0,
    **extract: Unpack[ScanParamsOverrides],
) -> NeesSummary:
    """NEES of every wall paired between scans ``k`` and ``k + every``, both in the
    world frame through the logged poses, each pose with covariance ``pose_cov``
    (3 x 3, independent from scan to scan; None: exact). ``straightness`` (m, >= 0)
    adds :func:`rperc.slam.wallslam.straightness_covariance` to every wall, the floor
    the wall SLAM gives real walls (0: the fit's covariance alone). ``extract`` goes to
    :func:`rperc.linesimp.extract_lines` (``max_range`` defaults to the scan's)."""
    from rperc.slam.wallslam import straightness_covariance

    if not (math.isfinite(straightness) and straightness >= 0):
        raise ValueError(f"straightness must be a finite length >= 0, got {straightness}")
    nees: list[float] = []
    prev: tuple[WallSegments, np.ndarray] | None = None
    walls = used = 0
    for k in range(0, len(scans), every):
        n = int(scans.num_beams[k])
        options: ScanParamsOverrides = {"max_range": float(scans.max_range[k]), **extract}
        found = extract_lines(scans.ranges[k, :n], scans.angles(k), **options)
        world = found.to_world(scans.pose[k], pose_cov)
        cov = np.asarray(world.cov, dtype=np.float64)
        if straightness > 0 and len(world):
            cov = cov + straightness_covariance(
                world.rho, world.alpha, world.start, world.end, straightness
            )
        walls += len(found)
        used += 1
        if prev is not None:
            (before, before_cov) = prev
            for i, j in pair_walls(before, world):
                d = line_difference(before, i, world, j)
                nees.append(float(d @ np.linalg.solve(before_cov[i] + cov[j], d)))
        prev = (world, cov)
    return NeesSummary(np.asarray(nees), used, walls)


def reading_shares(scans: LaserScans, **extract: Unpack[ScanParamsOverrides]) -> dict[str, int]:
    """Where the readings of a log go, by category (counts of readings):

    - ``invalid``: NaN, at or below ``min_range`` or at or beyond ``max_range``;
    - ``on_walls``: in a wall that was kept;
    - ``short_walls``: in a line of at least ``min_points`` readings that is shorter
      than ``min_length`` (a door frame, a table leg seen broadside, a box);
    - ``sparse``: in a line of fewer than ``min_points`` readings (clutter, a corner
      seen by a few beams, readings too far apart to group);
    - ``isolated``: in no line of two readings or more (single readings between range
      jumps, a split vertex given to neither neighbour).

    Found by extracting again with the limits relaxed, so the categories come from
    the extractor's own output, not from a model of it."""
    counts = dict.fromkeys(("valid", "invalid", "on_walls", "short_walls", "sparse"), 0)
    min_range = float(extract.get("min_range", 0.0))
    for k in range(len(scans)):
        n = int(scans.num_beams[k])
        ranges, angles = scans.ranges[k, :n], scans.angles(k)
        options: ScanParamsOverrides = {"max_range": float(scans.max_range[k]), **extract}
        with np.errstate(invalid="ignore"):
            valid = (ranges > min_range) & (ranges > 0) & (ranges < options["max_range"])
        kept = extract_lines(ranges, angles, **options).flat_indices
        any_length_options: ScanParamsOverrides = {**options, "min_length": 0.0}
        any_line_options: ScanParamsOverrides = {**any_length_options, "min_points": 2}
        any_length = extract_lines(ranges, angles, **any_length_options)
        any_line = extract_lines(ranges, angles, **any_line_options)
        counts["valid"] += int(valid.sum())
        counts["invalid"] += n - int(valid.sum())
        counts["on_walls"] += len(kept)
        counts["short_walls"] += len(np.setdiff1d(any_length.flat_indices, kept))
        counts["sparse"] += len(np.setdiff1d(any_line.flat_indices, any_length.flat_indices))
    counts["isolated"] = (
        counts["valid"] - counts["on_walls"] - counts["short_walls"] - counts["sparse"]
    )
    return counts
