"""Douglas-Peucker line simplification and wall extraction from 2-D laser scans.

Section 2.1 of the seed paper (Tables 1 and 2) and Hershberger & Snoeyink (1992).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal, overload

import numpy as np
import numpy.typing as npt

from rperc import _rperc

Method = Literal["hull", "dp"]
Metric = Literal["line", "segment"]
Tie = Literal["first", "last"]

__all__ = ["simplify", "simplify_many"]


def _as_points(points: npt.ArrayLike, name: str = "points") -> np.ndarray:
    """An (N, 2) or (N, 3) float array; float32 and strided arrays are kept as they are
    (the native side reads them directly), integers are converted to float64."""
    arr = np.asarray(points)
    if arr.dtype.kind in "iub":
        arr = arr.astype(np.float64)
    elif arr.dtype.kind != "f":
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    elif arr.dtype not in (np.float64, np.float32):
        arr = arr.astype(np.float64)
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
