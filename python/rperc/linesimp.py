"""Douglas-Peucker line simplification and wall extraction from 2-D laser scans.

Section 2.1 of the seed paper (Tables 1 and 2) and Hershberger & Snoeyink (1992).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
import numpy.typing as npt

from rperc import _rperc
from rperc.pose import to_world as pose_to_world

Method = Literal["hull", "dp"]
Metric = Literal["line", "segment"]
Tie = Literal["first", "last"]

__all__ = ["WallSegments", "extract_lines", "simplify", "simplify_many"]


def _float_array(values: npt.ArrayLike, name: str) -> np.ndarray:
    """A float64 or float32 array; float32 and strided arrays are kept as they are (the
    native side reads them directly), integers and other floats become float64."""
    arr = np.asarray(values)
    if arr.dtype.kind in "iub":
        return arr.astype(np.float64)
    if arr.dtype.kind != "f":
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if arr.dtype not in (np.float64, np.float32):
        return arr.astype(np.float64)
    return arr


def _as_points(points: npt.ArrayLike, name: str = "points") -> np.ndarray:
    """An (N, 2) or (N, 3) float array."""
    arr = _float_array(points, name)
    if arr.ndim == 2 and arr.shape[0] == 0 and arr.shape[1] in (2, 3):
        return arr
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (N, 2) or (N, 3), got {arr.shape}")
    return arr


def _check_epsilon(epsilon: float) -> float:
    eps = float(epsilon)
    if not np.isfinite(eps) or eps < 0:
        raise ValueError(f"epsilon must be finite and >= 0, got {epsilon!r}")
    return eps


@overload
def simplify(
    points: npt.ArrayLike,
    epsilon: float,
    *,
    method: Method = ...,
    metric: Metric = ...,
    tie: Tie = ...,
    return_indices: Literal[False] = ...,
) -> np.ndarray: ...
@overload
def simplify(
    points: npt.ArrayLike,
    epsilon: float,
    *,
    method: Method = ...,
    metric: Metric = ...,
    tie: Tie = ...,
    return_indices: Literal[True],
) -> npt.NDArray[np.intp]: ...
def simplify(
    points: npt.ArrayLike,
    epsilon: float,
    *,
    method: Method = "hull",
    metric: Metric = "line",
    tie: Tie = "first",
    return_indices: bool = False,
) -> np.ndarray:
    """Simplify a polyline with Douglas-Peucker.

    Parameters
    ----------
    points:
        (N, 2) array of vertices; an (N, 3) array carries z along (distances are
        measured in xy). Any float array-like works: float32, strided views, lists.
    epsilon:
        Tolerance, >= 0, in the units of the points.
    method:
        ``"hull"`` (default): Hershberger-Snoeyink path hulls, O(n log n) worst case,
        line metric only. ``"dp"``: the plain algorithm of the seed's Table 1, run on an
        explicit stack (no recursion limit), O(n^2) worst case.
    metric:
        ``"line"`` (default): distance to the infinite line through the chord (seed
        Table 2). ``"segment"``: distance to the chord segment, as GEOS/shapely and the
        ``simplification`` package use; with ``method="dp"`` the kept indices equal
        theirs (see ``tie``).
    tie:
        Which of several equally far vertices splits a chord (``method="dp"``):
        ``"first"`` (default) as GEOS/shapely does, ``"last"`` as geo and the
        ``simplification`` package do. The peers differ on real data (norway at
        epsilon 0.01); either rule gives a valid simplification. Path hulls always take
        the first.
    return_indices:
        Return the kept indices (int array) instead of the kept rows.

    Returns
    -------
    The kept rows of ``points`` (same dtype and columns), or their indices, in order.
    The first and last points are always kept; fewer than 2 points come back unchanged.

    Raises
    ------
    ValueError
        NaN or infinite coordinates, a negative or NaN epsilon, a wrong shape, an
        unknown method or metric, or ``method="hull"`` with ``metric="segment"``.
    TypeError
        A non-numeric dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import simplify
    >>> simplify(np.array([[0.0, 0.0], [1.0, 0.05], [2.0, 0.0]]), 0.1, return_indices=True)
    array([0, 2])
    """
    arr = _as_points(points)
    eps = _check_epsilon(epsilon)
    idx = _rperc.simplify_indices(arr, eps, method, metric, tie)
    return idx if return_indices else arr[idx]


def simplify_many(
    polylines: Sequence[npt.ArrayLike],
    epsilon: float,
    *,
    method: Method = "hull",
    metric: Metric = "line",
    tie: Tie = "first",
    return_indices: bool = False,
    threads: int | None = None,
) -> list[np.ndarray]:
    """Simplify many polylines in parallel (GIL released).

    Takes the same keyword arguments as :func:`simplify` and returns one result per
    input, in order. ``threads`` caps the worker threads (default: all cores).

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import simplify_many
    >>> flat = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    >>> peak = np.array([[0.0, 0.0], [1.0, 3.0], [2.0, 0.0]])
    >>> lines = [flat, peak]
    >>> [len(p) for p in simplify_many(lines, 0.5)]
    [2, 3]
    """
    arrays = [_as_points(p, f"polylines[{k}]") for k, p in enumerate(polylines)]
    eps = _check_epsilon(epsilon)
    indices = _rperc.simplify_many_indices(arrays, eps, method, metric, tie, threads)
    if return_indices:
        return indices
    return [a[i] for a, i in zip(arrays, indices, strict=True)]


@dataclass(frozen=True, repr=False)
class WallSegments:
    """The walls of one scan, in the frame of the scan's angles.

    Each wall ``k`` is the line ``x cos(alpha[k]) + y sin(alpha[k]) = rho[k]``
    (``rho >= 0``, ``alpha`` in (-pi, pi]) with covariance ``cov[k]`` of
    ``(rho, alpha)``, between the end points ``start[k]`` and ``end[k]`` (the first
    and last fitted readings projected onto the line), fitted on the readings
    ``indices[k]`` of the input scan.
    """

    rho: np.ndarray  # (K,)
    alpha: np.ndarray  # (K,)
    cov: np.ndarray  # (K, 2, 2)
    start: np.ndarray  # (K, 2)
    end: np.ndarray  # (K, 2)
    flat_indices: np.ndarray  # (M,) all fitted readings, wall after wall
    offsets: np.ndarray  # (K + 1,) wall k holds flat_indices[offsets[k]:offsets[k + 1]]

    def __len__(self) -> int:
        return len(self.rho)

    @property
    def indices(self) -> list[np.ndarray]:
        """Indices of each wall's readings in the input scan (views, not copies)."""
        return [
            self.flat_indices[a:b] for a, b in zip(self.offsets[:-1], self.offsets[1:], strict=True)
        ]

    @property
    def length(self) -> np.ndarray:
        return np.hypot(*(self.end - self.start).T) if len(self) else np.zeros(0)

    def to_world(self, pose: npt.ArrayLike) -> WallSegments:
        """The same walls seen from the world frame, for a sensor at ``pose = (x, y,
        theta)``: end points move, ``(rho, alpha)`` and the covariance transform with
        the rigid motion (to first order, taking the pose as exact)."""
        x, y, th = np.asarray(pose, dtype=np.float64)
        start = pose_to_world((x, y, th), self.start)
        end = pose_to_world((x, y, th), self.end)
        alpha = self.alpha + th
        rho = self.rho + x * np.cos(alpha) + y * np.sin(alpha)
        # d rho_w / d alpha_s = -x sin(alpha_w) + y cos(alpha_w); d alpha_w / d alpha_s = 1.
        jac = np.zeros((len(self), 2, 2))
        jac[:, 0, 0] = 1.0
        jac[:, 0, 1] = -x * np.sin(alpha) + y * np.cos(alpha)
        jac[:, 1, 1] = 1.0
        flip = rho < 0
        rho = np.where(flip, -rho, rho)
        alpha = np.where(flip, alpha + np.pi, alpha)
        jac[flip, 0, :] *= -1
        alpha = (alpha + np.pi) % (2 * np.pi) - np.pi
        alpha = np.where(alpha == -np.pi, np.pi, alpha)
        cov = jac @ self.cov @ jac.transpose(0, 2, 1)
        return WallSegments(rho, alpha, cov, start, end, self.flat_indices, self.offsets)

    def __repr__(self) -> str:
        lines = [f"WallSegments({len(self)} walls)"]
        for k in range(len(self)):
            sd = np.sqrt(np.diag(self.cov[k]))
            lines.append(
                f"  rho={self.rho[k]:7.3f} m +- {sd[0]:.3f}, "
                f"alpha={math.degrees(self.alpha[k]):7.2f} deg +- {math.degrees(sd[1]):.2f}, "
                f"length {self.length[k]:5.2f} m, {self.offsets[k + 1] - self.offsets[k]} points"
            )
        return "\n".join(lines)


def extract_lines(
    ranges: npt.ArrayLike,
    angles: npt.ArrayLike,
    *,
    min_range: float = 0.0,
    max_range: float = math.inf,
    sigma_range: float = 0.01,
    sigma_bearing: float = 0.0,
    breakpoint_lambda: float = math.radians(10.0),
    split_epsilon: float = 0.05,
    merge_confidence: float = 0.99,
    min_points: int = 6,
    min_length: float = 0.3,
) -> WallSegments:
    """Extract walls (line segments) from one 2-D laser scan.

    The pipeline of the seed's section 2.1 (Fig. 1b): drop invalid readings, split at
    range discontinuities (Borges & Aldon's adaptive breakpoint detector), split each
    run by iterative end-point fit (Douglas-Peucker with path hulls), fit each piece
    by total least squares in Hessian form, propagate the range and bearing noise to a
    2 x 2 covariance of ``(rho, alpha)``, merge neighbours that pass a chi-square
    test, project the end points onto the lines and drop short or sparse walls.

    Parameters
    ----------
    ranges, angles:
        1-D arrays of equal length: reading ``k`` measures ``ranges[k]`` metres along
        bearing ``angles[k]`` radians, in the sensor frame, bearings increasing.
    min_range, max_range:
        Readings ``<= min_range`` (0 included), ``>= max_range`` (no return) or NaN
        are invalid and skipped.
    sigma_range, sigma_bearing:
        Standard deviations of the range (m) and bearing (rad) noise.
    breakpoint_lambda:
        Smallest beam incidence angle (rad) on one surface, the breakpoint
        detector's lambda; bearing gaps wider than it always split.
    split_epsilon:
        Iterative end-point fit splits at points farther than this from the chord (m).
    merge_confidence:
        Neighbouring lines merge when the Mahalanobis distance of their difference is
        below the chi-square (2 dof) quantile of this confidence, in (0, 1).
    min_points, min_length:
        Walls with fewer readings (>= 2) or shorter than this (m) are dropped.

    Returns
    -------
    WallSegments
        Arrays ``rho``, ``alpha``, ``cov``, ``start``, ``end`` and each wall's
        ``indices`` into the input.

    Raises
    ------
    ValueError
        Lengths differ, an array is not 1-D, a bearing is NaN, or a parameter is out
        of range (the message names it).
    TypeError
        A non-numeric dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import extract_lines
    >>> angles = np.radians(np.arange(-45.0, 46.0))
    >>> walls = extract_lines(2.0 / np.cos(angles), angles)  # the wall x = 2
    >>> len(walls), round(float(walls.rho[0]), 6), round(float(walls.alpha[0]), 6)
    (1, 2.0, 0.0)
    """
    r = _float_array(ranges, "ranges")
    a = _float_array(angles, "angles")
    if r.ndim != 1 or a.ndim != 1:
        raise ValueError(f"ranges and angles must be 1-D, got shapes {r.shape} and {a.shape}")
    params = {
        "min_range": float(min_range),
        "max_range": float(max_range),
        "sigma_range": float(sigma_range),
        "sigma_bearing": float(sigma_bearing),
        "breakpoint_lambda": float(breakpoint_lambda),
        "split_epsilon": float(split_epsilon),
        "merge_confidence": float(merge_confidence),
        "min_points": _count(min_points, "min_points"),
        "min_length": float(min_length),
    }
    rho, alpha, cov, start, end, flat, offsets = _rperc.extract_lines(r, a, params)
    return WallSegments(rho, alpha, cov, start, end, flat, offsets)


def _count(value: int, name: str) -> int:
    if isinstance(value, bool) or int(value) != value or value < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
    return int(value)
