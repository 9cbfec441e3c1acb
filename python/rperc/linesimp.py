"""Line simplification and wall extraction from 2-D laser scans.

Douglas-Peucker (section 2.1 of paper [000], Tables 1 and 2), with Hershberger &
Snoeyink's (1992) path hulls; Visvalingam & Whyatt's (1993) effective-area elimination;
topology-preserving Douglas-Peucker with the rules of GEOS's
TopologyPreservingSimplifier; shapely geometries in and out.

Geometries
----------
Every line and ring is simplified (all together with ``preserve_topology``) and the
geometry is rebuilt with the same type (GEOS turns a one-member MultiLineString into a
LineString; rperc does not), Z/M dimensions (M values are carried along, not turned
into Z) and SRID; points pass through. A LineString keeps both
end points, also when closed. Polygon rings and LinearRings follow GEOS:

- with ``preserve_topology=True`` they keep at least 4 coordinates and may start
  at another vertex;
- otherwise each ring is simplified from its start vertex, which then goes too
  when it lies within epsilon of the chord joining its kept neighbours (Douglas-
  Peucker methods, as GEOS's DouglasPeuckerSimplifier; VW keeps it), and a ring
  left with fewer than 4 coordinates is dropped: a hole disappears, a polygon whose
  shell collapses becomes empty and leaves a MultiPolygon or collection (which,
  unlike in GEOS, keeps its type), a lone LinearRing becomes empty. Unlike shapely,
  the result is not repaired when it self-intersects: use
  ``preserve_topology=True`` to prevent that.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, NamedTuple, cast, overload

import numpy as np
import numpy.typing as npt

from rperc import _geo, _rperc
from rperc._args import excerpt, float_array, real_number, whole_number
from rperc._config_base import native_config
from rperc.config import ScanParams, ScanParamsOverrides
from rperc.pose import to_world as pose_to_world

if TYPE_CHECKING:
    from typing_extensions import Unpack

Method = Literal["auto", "hull", "dp", "vw"]
Metric = Literal["line", "segment"]
Tie = Literal["first", "last"]

__all__ = ["WallSegments", "extract_lines", "simplify", "simplify_many"]

# Methods that run Douglas-Peucker (``auto`` resolves to one of the other two).
_DP_METHODS = ("auto", "hull", "dp")


def _float_array(values: npt.ArrayLike, name: str) -> np.ndarray:
    """A float64 or float32 array; float32 and strided arrays are kept as they are (the
    native side reads them directly, and kept rows keep the input dtype), integers and
    other floats become float64. A geometry is refused with a pointer to simplify."""
    if _geo.is_geometry(values):
        raise TypeError(
            f"{name} is a geometry; pass it to rperc.linesimp.simplify, which returns the "
            "same geometry type"
        )
    arr: np.ndarray = float_array(values, name, keep_float32=True)
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
    # real_number, not float(): float("1") passes and float(a 5 MB string) quotes it.
    eps = real_number(epsilon, "epsilon")
    if not np.isfinite(eps) or eps < 0:
        raise ValueError(f"epsilon must be finite and >= 0, got {excerpt(epsilon)}")
    return eps


@overload
def simplify(
    points: npt.ArrayLike,
    epsilon: float,
    *,
    method: Method = ...,
    metric: Metric = ...,
    tie: Tie = ...,
    preserve_topology: bool = ...,
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
    preserve_topology: bool = ...,
    return_indices: Literal[True],
) -> npt.NDArray[np.intp]: ...
@overload
def simplify(
    points: _geo.GeometryLike,
    epsilon: float,
    *,
    method: Method = ...,
    metric: Metric = ...,
    tie: Tie = ...,
    preserve_topology: bool = ...,
    return_indices: Literal[False] = ...,
) -> _geo.Geometry: ...
def simplify(
    points: npt.ArrayLike | _geo.GeometryLike,
    epsilon: float,
    *,
    method: Method = "auto",
    metric: Metric = "line",
    tie: Tie = "first",
    preserve_topology: bool = False,
    return_indices: bool = False,
) -> np.ndarray | _geo.Geometry:
    """Simplify a polyline or a geometry with Douglas-Peucker or Visvalingam-Whyatt.

    Parameters
    ----------
    points:
        (N, 2) array of vertices; an (N, 3) array carries z along (distances are
        measured in xy). Any float array-like works: float32, strided views, lists.
        Or a geometry: a shapely LineString, LinearRing, Polygon, MultiLineString,
        MultiPolygon or GeometryCollection, any object with ``__geo_interface__``, or a
        GeoJSON-like mapping; the result is then a shapely geometry of the same type
        (see *Geometries* in the module documentation). Geometries need shapely
        (``pip install shapely``).
    epsilon:
        Tolerance, >= 0: a distance in the units of the points for Douglas-Peucker, an
        *area* (units squared) for ``method="vw"``.
    method:
        ``"auto"`` (default): Douglas-Peucker, with path hulls for ``metric="line"`` and
        the plain algorithm for ``metric="segment"``. ``"hull"``: Hershberger-Snoeyink
        path hulls, O(n log n) worst case, line metric only. ``"dp"``: the plain
        algorithm of paper [000]'s Table 1, on an explicit stack (no recursion limit),
        O(n^2) worst case. ``"vw"``: Visvalingam-Whyatt, O(n log n): the vertex whose
        triangle with its two current neighbours has the smallest area goes first,
        while that area is ``<= epsilon`` (ties: the smallest index first); the same
        convention as ``simplification.cutil.simplify_coords_vw_idx`` (triangle area,
        not twice it; ``<=``, so ``epsilon=0`` drops exactly collinear and repeated
        points). End points always stay, also the closing point of a closed ring.
    metric:
        ``"line"`` (default): distance to the infinite line through the chord (seed
        Table 2). ``"segment"``: distance to the chord segment, as GEOS/shapely and the
        ``simplification`` package use; with ``method="dp"`` or ``"auto"`` the kept
        indices equal theirs (see ``tie``). ``"vw"`` takes ``"line"`` only (it measures
        areas).
    tie:
        Which of several equally far vertices splits a chord (``method="dp"``):
        ``"first"`` (default) as GEOS/shapely does, ``"last"`` as geo and the
        ``simplification`` package do. The peers differ on real data (norway at
        epsilon 0.01); either rule gives a valid simplification. Path hulls always take
        the first.
    preserve_topology:
        Douglas-Peucker that introduces no intersection, as GEOS's
        TopologyPreservingSimplifier (shapely ``preserve_topology=True``): a chord
        replaces its section only if it crosses or touches no other live segment of
        any part of the geometry and does not move another part to its other side;
        otherwise the section splits further. Closed lines and rings keep at least 4
        coordinates. With ``metric="segment"`` the result has the same vertices as
        shapely's. Methods ``"auto"`` and ``"dp"`` only. For a polygon ring the start
        vertex may go too (as in GEOS), and then the vertices dropped next to it are
        within ``2 * epsilon``, not ``epsilon``, of the result.
    return_indices:
        Return the kept indices (int array) instead of the kept rows (arrays only).

    Returns
    -------
    The kept rows of ``points`` (same dtype and columns), or their indices, in order.
    The first and last points are always kept; fewer than 3 points come back unchanged.
    For a geometry: a shapely geometry of the same type.

    Raises
    ------
    ValueError
        NaN or infinite coordinates, a negative or NaN epsilon, a wrong shape, an
        unknown method or metric, ``method="hull"`` or ``"vw"`` with
        ``metric="segment"``, ``preserve_topology`` with ``"hull"`` or ``"vw"``, or
        ``return_indices`` with a geometry.
    TypeError
        A non-numeric dtype (complex included) or a ragged nested list.
    ImportError
        A geometry without shapely installed.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import simplify
    >>> simplify(np.array([[0.0, 0.0], [1.0, 0.05], [2.0, 0.0]]), 0.1, return_indices=True)
    array([0, 2])
    >>> simplify(np.array([[0.0, 0.0], [1.0, 0.05], [2.0, 0.0]]), 0.1, metric="segment")
    array([[0., 0.],
           [2., 0.]])
    >>> import shapely
    >>> square = shapely.Polygon([(0, 0), (1, 0.01), (2, 0), (2, 2), (0, 2)])
    >>> simplify(square, 0.1, metric="segment").wkt
    'POLYGON ((0 0, 2 0, 2 2, 0 2, 0 0))'
    """
    eps = _check_epsilon(epsilon)
    if _geo.is_geometry(points):
        if return_indices:
            raise ValueError("return_indices needs an array of points, not a geometry")
        options = _Options(eps, method, metric, tie, preserve_topology)
        return _geo.map_parts(_geo.to_shapely(points), options.simplify_parts)
    arr = _as_points(cast("npt.ArrayLike", points))  # not a geometry: checked above
    if preserve_topology:
        (idx,) = _rperc.simplify_topology_indices([arr], [False], eps, method, metric, tie)
    else:
        idx = _rperc.simplify_indices(arr, eps, method, metric, tie)
    return idx if return_indices else arr[idx]


@dataclass(frozen=True)
class _Options:
    """The options of one :func:`simplify` call on a geometry."""

    epsilon: float
    method: Method
    metric: Metric
    tie: Tie
    preserve_topology: bool

    def simplify_parts(self, parts: list[_geo.Part]) -> list[np.ndarray | None]:
        """Kept coordinates of every part; ``None`` for a ring that collapsed."""
        xy = [np.ascontiguousarray(p.coords[:, :2]) for p in parts]
        if self.preserve_topology:
            rings = [p.ring for p in parts]
            per_part = _rperc.simplify_topology_indices(
                xy, rings, self.epsilon, self.method, self.metric, self.tie
            )
            return [p.coords[k] for p, k in zip(parts, per_part, strict=True)]
        try:
            many = _rperc.simplify_many_indices(
                xy, self.epsilon, self.method, self.metric, self.tie
            )
        except ValueError as exc:
            # The native message counts "polylines": here they are the geometry's parts.
            raise ValueError(
                f"{exc} (parts are the geometry's lines and rings, in order)"
            ) from None
        out: list[np.ndarray | None] = []
        for part, pts, idx in zip(parts, xy, many, strict=True):
            kept = self._ring(pts, idx) if part.ring else idx
            out.append(None if kept is None else part.coords[kept])
        return out

    def _ring(self, xy: np.ndarray, kept: npt.NDArray[np.intp]) -> npt.NDArray[np.intp] | None:
        """GEOS DouglasPeuckerSimplifier's ring rules: drop the start vertex when it is
        within epsilon of the chord joining its kept neighbours; drop the ring when
        fewer than 4 coordinates remain."""
        if self.method in _DP_METHODS and len(kept) >= 4:
            a, b = xy[kept[1]], xy[kept[-2]]
            if _chord_distance(xy[kept[0]], a, b, self.metric) <= self.epsilon:
                kept = np.append(kept[1:-1], kept[1])
        return kept if len(kept) >= 4 else None


def _chord_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, metric: Metric) -> float:
    """Distance from ``p`` to the chord ``a b`` (to ``a`` when ``a == b``)."""
    d = b - a
    length2 = float(d @ d)
    if length2 == 0.0:
        return float(np.hypot(*(p - a)))
    t = float((p - a) @ d) / length2
    if metric == "segment":
        t = min(max(t, 0.0), 1.0)
        return float(np.hypot(*(p - a - t * d)))
    return abs(float(d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0]))) / math.sqrt(length2)


def simplify_many(
    polylines: Sequence[npt.ArrayLike],
    epsilon: float,
    *,
    method: Method = "auto",
    metric: Metric = "line",
    tie: Tie = "first",
    return_indices: bool = False,
    threads: int | None = None,
) -> list[np.ndarray]:
    """Simplify many polylines in parallel (GIL released).

    Takes the same keyword arguments as :func:`simplify` (arrays only; for geometries
    call :func:`simplify`, which simplifies all parts of a geometry in parallel) and
    returns one result per input, in order. ``threads`` caps the worker threads
    (default: all cores).

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import simplify_many
    >>> flat = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    >>> peak = np.array([[0.0, 0.0], [1.0, 3.0], [2.0, 0.0]])
    >>> lines = [flat, peak]
    >>> [len(p) for p in simplify_many(lines, 0.5)]
    [2, 3]
    >>> [len(p) for p in simplify_many(lines, 1.0, method="vw")]  # peak: area 3
    [2, 3]
    """
    arrays = [_as_points(p, f"polylines[{k}]") for k, p in enumerate(polylines)]
    eps = _check_epsilon(epsilon)
    bad_threads = isinstance(threads, bool) or (threads is not None and int(threads) < 1)
    if bad_threads:
        raise ValueError(f"threads must be a positive integer or None, got {excerpt(threads)}")
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
    def __geo_interface__(self) -> dict[str, str | list[list[list[float]]]]:
        """The walls as a GeoJSON-like MultiLineString, one segment from ``start[k]`` to
        ``end[k]`` per wall, so that ``shapely.geometry.shape(walls)`` works."""
        segments = np.stack([self.start, self.end], axis=1).tolist() if len(self) else []
        return {"type": "MultiLineString", "coordinates": segments}

    @property
    def length(self) -> np.ndarray:
        return np.hypot(*(self.end - self.start).T) if len(self) else np.zeros(0)

    def to_world(self, pose: npt.ArrayLike, pose_cov: npt.ArrayLike | None = None) -> WallSegments:
        """The same walls seen from the world frame, for a sensor at ``pose = (x, y,
        theta)`` with 3 x 3 covariance ``pose_cov`` (default: the pose taken as exact).

        End points move with the rigid motion; ``(rho, alpha)`` become
        ``alpha_w = alpha + theta``, ``rho_w = rho + x cos(alpha_w) + y sin(alpha_w)``
        (flipped to ``rho_w >= 0``), and the covariance is propagated to first order,
        ``J_w C J_w^T + J_p P J_p^T`` with the Jacobians of :func:`wall_to_world_jacobians`
        (the wall's and the pose's errors are independent).
        """
        x, y, th = _pose3(pose)
        pose_cov_arr = _pose_covariance(pose_cov)
        start = pose_to_world((x, y, th), self.start)
        end = pose_to_world((x, y, th), self.end)
        rho, alpha, jac_wall, jac_pose = wall_to_world_jacobians(
            self.rho, self.alpha, np.array([x, y, th])
        )
        cov = jac_wall @ self.cov @ jac_wall.transpose(0, 2, 1)
        if pose_cov_arr is not None:
            cov = cov + jac_pose @ pose_cov_arr @ jac_pose.transpose(0, 2, 1)
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


class WorldLines(NamedTuple):
    """Lines moved to the world frame with their Jacobians (a tuple, by name too):
    ``rho`` and ``alpha`` (K,), ``d_wall`` (K, 2, 2) with respect to the sensor-frame
    ``(rho, alpha)`` and ``d_pose`` (K, 2, 3) with respect to the pose."""

    rho: np.ndarray
    alpha: np.ndarray
    d_wall: np.ndarray
    d_pose: np.ndarray


def wall_to_world_jacobians(
    rho: npt.ArrayLike, alpha: npt.ArrayLike, pose: npt.ArrayLike
) -> WorldLines:
    """World lines of sensor-frame lines ``(rho, alpha)`` seen from ``pose = (x, y,
    theta)``, and the Jacobians of ``(rho_w, alpha_w)`` with respect to ``(rho, alpha)``
    ((K, 2, 2)) and to the pose ((K, 2, 3)).

    ``alpha_w = alpha + theta`` and ``rho_w = rho + x cos(alpha_w) + y sin(alpha_w)``, so
    ``d rho_w = d rho + cos(alpha_w) dx + sin(alpha_w) dy + m (d alpha + d theta)`` with
    ``m = -x sin(alpha_w) + y cos(alpha_w)``, and ``d alpha_w = d alpha + d theta``. When
    ``rho_w < 0`` the line is written ``(-rho_w, alpha_w + pi)``: the rho row changes
    sign. ``alpha_w`` is wrapped to (-pi, pi]. The model is rperc-slam's ``wall_to_world``,
    the one the wall SLAM filter uses.
    """
    rho_arr = np.ascontiguousarray(rho, dtype=np.float64).reshape(-1)
    alpha_arr = np.ascontiguousarray(alpha, dtype=np.float64).reshape(-1)
    w = _rperc.walls_to_world(rho_arr, alpha_arr, np.array(_pose3(pose)))
    return WorldLines(w.rho, w.alpha, w.d_wall, w.d_pose)


def _pose3(pose: npt.ArrayLike) -> tuple[float, float, float]:
    arr = np.asarray(pose, dtype=np.float64)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ValueError(f"pose must be 3 finite numbers (x, y, theta), got {excerpt(arr)}")
    return float(arr[0]), float(arr[1]), float(arr[2])


def _pose_covariance(pose_cov: npt.ArrayLike | None) -> np.ndarray | None:
    if pose_cov is None:
        return None
    cov = np.asarray(pose_cov, dtype=np.float64)
    if cov.shape != (3, 3) or not np.isfinite(cov).all():
        raise ValueError(f"pose_cov must be a finite 3 x 3 matrix, got shape {cov.shape}")
    if not np.allclose(cov, cov.T, rtol=1e-9, atol=0.0):
        raise ValueError("pose_cov must be symmetric")
    if np.linalg.eigvalsh(cov).min() < -1e-12 * max(1.0, float(np.abs(cov).max())):
        raise ValueError("pose_cov must be positive semi-definite")
    return cov


def extract_lines(
    ranges: npt.ArrayLike,
    angles: npt.ArrayLike,
    config: ScanParams | Mapping[str, object] | None = None,
    **overrides: Unpack[ScanParamsOverrides],
) -> WallSegments:
    """Extract walls (line segments) from one 2-D laser scan.

    The pipeline of paper [000]'s section 2.1 (Fig. 1b): drop invalid readings, split at
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
    config:
        The settings, a :class:`rperc.config.ScanParams` (each field documented
        there, with its default) or a dict of its fields.
    **overrides:
        Fields of :class:`~rperc.config.ScanParams` to change, as keywords
        (``min_range``, ``max_range``, ``sigma_range``, ``sigma_bearing``,
        ``breakpoint_lambda``, ``split_epsilon``, ``merge_confidence``,
        ``min_points``, ``min_length``, ``model_error``).

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
        A non-numeric dtype (complex included) or a ragged nested list.

    Examples
    --------
    >>> import numpy as np
    >>> from rperc.linesimp import extract_lines
    >>> angles = np.radians(np.arange(-45.0, 46.0))
    >>> walls = extract_lines(2.0 / np.cos(angles), angles)  # the wall x = 2
    >>> len(walls), round(float(walls.rho[0]), 6), abs(float(walls.alpha[0])) < 1e-9
    (1, 2.0, True)
    """
    r = _float_array(ranges, "ranges")
    a = _float_array(angles, "angles")
    if r.ndim != 1 or a.ndim != 1:
        raise ValueError(f"ranges and angles must be 1-D, got shapes {r.shape} and {a.shape}")
    params = native_config(ScanParams, config, overrides)
    w = _rperc.extract_lines(r, a, params)
    return WallSegments(
        rho=w.rho, alpha=w.alpha, cov=w.cov, start=w.start, end=w.end,
        flat_indices=w.flat_indices, offsets=w.offsets,
    )  # fmt: skip


def _flag(value: bool, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__}")
    return bool(value)


def _count(value: int, name: str) -> int:
    return whole_number(value, name, 0)
