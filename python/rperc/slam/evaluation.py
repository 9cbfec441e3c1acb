"""Scores of a planar SLAM run against ground truth.

- :func:`associate`: the estimate matched to a reference sampled at other times, the
  reference interpolated at the estimate's times (headings along the shorter arc), with
  every unmatched estimate counted (before, after, or inside a gap of the reference);
- :func:`align_se2`: the rigid motion (rotation and translation, no scale) that best
  moves one point set onto another, in closed form (2-D Umeyama / Horn);
- :func:`trajectory_error` / :func:`ate`: absolute trajectory error of the path
  (position RMSE, with or without SE(2) alignment) and the heading error;
- :func:`landmark_error`: landmark RMSE against surveyed landmarks matched by id,
  optionally through the path's alignment;
- :func:`pose_nees`: the robot-pose NEES of every step and the share inside the
  two-sided chi-square band;
- :func:`gps_error`: distance of the estimate to every GPS fix after one rigid
  alignment of the whole path (Victoria Park).

Poses are ``(x, y, theta)`` rows; headings are wrapped into (-pi, pi] as by
rperc-core's ``wrap_angle``. Bad input (NaN, wrong shape, empty, too few matches) is a
``ValueError`` naming the parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypedDict

import numpy as np
import numpy.typing as npt

from rperc import _rperc, pose
from rperc._args import excerpt
from rperc.datasets.timestamps import check_increasing

__all__ = [
    "Association",
    "GpsError",
    "LandmarkError",
    "NeesResult",
    "RunReference",
    "Se2Transform",
    "TrajectoryError",
    "align_se2",
    "associate",
    "ate",
    "gps_error",
    "landmark_error",
    "pose_nees",
    "trajectory_error",
    "wrap_angle",
]


def wrap_angle(angle: npt.ArrayLike) -> np.ndarray:
    """Angles wrapped into (-pi, pi], the convention of rperc-core (pi stays pi)."""
    arr = np.asarray(angle)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"angle must hold real numbers, got dtype {arr.dtype}")
    a = arr.astype(np.float64)
    if not np.isfinite(a).all():
        raise ValueError("angle must be finite (an infinite angle has no direction)")
    return pose.wrap_angle(a)


# ------------------------------------------------------------------ input checks


def _finite(values: npt.ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold numbers, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    if arr.size == 0:
        raise ValueError(f"{name} is empty")
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        raise ValueError(f"{name} holds a non-finite value at index {tuple(bad[0].tolist())}")
    return arr


def _times(values: npt.ArrayLike, name: str) -> np.ndarray:
    arr = _finite(values, name)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {arr.shape}")
    return arr


def _rows(values: npt.ArrayLike, name: str, columns: tuple[int, ...]) -> np.ndarray:
    arr = _finite(values, name)
    if arr.ndim != 2 or arr.shape[1] not in columns:
        want = " or ".join(f"(N, {c})" for c in columns)
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    return arr


def _same_length(a: np.ndarray, a_name: str, b: np.ndarray, b_name: str) -> None:
    if len(a) != len(b):
        raise ValueError(f"{a_name} has {len(a)} rows but {b_name} has {len(b)}")


# ------------------------------------------------------------------ association


@dataclass(frozen=True, repr=False)
class Association:
    """An estimate matched to a reference interpolated at the estimate's times.

    ``estimate_index`` are the rows of the original estimate that were matched (in
    their original order); ``before``, ``after`` and ``in_gap`` count the rows that
    were not, so that ``matched + before + after + in_gap == total``.
    """

    t: np.ndarray  # (M,) times of the matched estimate rows
    estimate_index: np.ndarray  # (M,) int64 rows of the original estimate
    estimate: np.ndarray  # (M, C) the matched estimate rows
    reference: np.ndarray  # (M, C) the reference interpolated at t
    total: int  # rows of the original estimate
    before: int  # earlier than the first reference sample
    after: int  # later than the last reference sample
    in_gap: int  # between two reference samples farther apart than max_gap
    max_gap: float | None

    @property
    def matched(self) -> int:
        return len(self.t)

    @property
    def unmatched(self) -> int:
        return self.total - self.matched

    def __repr__(self) -> str:
        gap = "no gap limit" if self.max_gap is None else f"gap limit {self.max_gap:g} s"
        return (
            f"Association({self.matched} of {self.total} matched; unmatched: {self.before} "
            f"before and {self.after} after the reference, {self.in_gap} in gaps; {gap})"
        )


def _interpolate(
    t_ref: np.ndarray, ref: np.ndarray, t: np.ndarray, k: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The reference at times ``t`` between samples ``k`` and ``k + 1``: linear in
    position, and for a heading column along the shorter arc, so that a turn through
    +-pi does not become a 2 pi sweep the other way. Also returns the fraction ``s``."""
    t0, t1 = t_ref[k], t_ref[k + 1]
    s = (t - t0) / (t1 - t0)
    a, b = ref[k], ref[k + 1]
    out = a + s[:, None] * (b - a)
    if ref.shape[1] == 3:
        out[:, 2] = wrap_angle(a[:, 2] + s * wrap_angle(b[:, 2] - a[:, 2]))
    return out, s


def associate(
    t_estimate: npt.ArrayLike,
    estimate: npt.ArrayLike,
    t_reference: npt.ArrayLike,
    reference: npt.ArrayLike,
    *,
    max_gap: float | None = None,
    min_matches: int = 1,
) -> Association:
    """Matches every estimate row to the reference interpolated at its time.

    ``estimate`` and ``reference`` are ``(N, 3)`` poses or ``(N, 2)`` points (the same
    for both); ``t_reference`` must increase strictly and hold at least two samples.
    An estimate time outside the reference's span, or between two reference samples
    more than ``max_gap`` seconds apart (unless it hits a sample exactly), is counted,
    not matched. Fewer than ``min_matches`` matches is a ``ValueError``.
    """
    t_est, t_ref = _times(t_estimate, "t_estimate"), _times(t_reference, "t_reference")
    est = _rows(estimate, "estimate", (2, 3))
    ref = _rows(reference, "reference", (est.shape[1],))
    _same_length(t_est, "t_estimate", est, "estimate")
    _same_length(t_ref, "t_reference", ref, "reference")
    if len(t_ref) < 2:
        raise ValueError("t_reference needs at least two samples to interpolate")
    check_increasing(t_ref, "t_reference")  # the rule every trajectory reader shares
    steps = np.diff(t_ref)
    if max_gap is not None and not (math.isfinite(max_gap) and max_gap > 0):
        raise ValueError(f"max_gap must be finite and > 0, got {excerpt(max_gap)}")
    early, late = t_est < t_ref[0], t_est > t_ref[-1]
    inside = ~(early | late)
    k = np.clip(np.searchsorted(t_ref, t_est, side="right") - 1, 0, len(t_ref) - 2)
    values, s = _interpolate(t_ref, ref, t_est, k)
    gap = np.zeros_like(inside)
    if max_gap is not None:
        gap = inside & (steps[k] > max_gap) & (s != 0.0) & (s != 1.0)
    keep = np.flatnonzero(inside & ~gap)
    if len(keep) < min_matches:
        raise ValueError(
            f"only {len(keep)} of {len(t_est)} estimate rows match the reference (need "
            f"{min_matches}): {int(early.sum())} before, {int(late.sum())} after, "
            f"{int(gap.sum())} in gaps"
        )
    return Association(
        t=t_est[keep],
        estimate=est[keep],
        estimate_index=keep.astype(np.int64),
        reference=values[keep],
        total=len(t_est),
        before=int(early.sum()),
        after=int(late.sum()),
        in_gap=int(gap.sum()),
        max_gap=None if max_gap is None else float(max_gap),
    )


# ------------------------------------------------------------------ alignment


@dataclass(frozen=True, repr=False)
class Se2Transform:
    """A planar rigid motion ``p -> R(theta) p + translation``."""

    theta: float
    translation: np.ndarray  # (2,)

    @property
    def rotation(self) -> np.ndarray:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.array([[c, -s], [s, c]])

    def matrix(self) -> np.ndarray:
        """The 3x3 homogeneous matrix."""
        m = np.eye(3)
        m[:2, :2], m[:2, 2] = self.rotation, self.translation
        return m

    def apply_points(self, points: npt.ArrayLike) -> np.ndarray:
        """``(N, 2)`` points moved by the transform."""
        p = _rows(points, "points", (2,))
        return np.asarray(p @ self.rotation.T + self.translation)

    def apply_poses(self, poses: npt.ArrayLike) -> np.ndarray:
        """``(N, 3)`` poses moved by the transform (headings turn by ``theta``)."""
        p = _rows(poses, "poses", (3,))
        out = np.empty_like(p)
        out[:, :2] = p[:, :2] @ self.rotation.T + self.translation
        out[:, 2] = wrap_angle(p[:, 2] + self.theta)
        return out

    def __repr__(self) -> str:
        tx, ty = self.translation
        return f"Se2Transform(theta={self.theta:.6g} rad, translation=({tx:.6g}, {ty:.6g}) m)"


def align_se2(source: npt.ArrayLike, target: npt.ArrayLike) -> Se2Transform:
    """The rotation and translation (no scale) minimising ``sum |R s_i + t - d_i|^2``
    over matched points ``source`` and ``target`` (``(N, 2)``, or poses whose first two
    columns are used).

    Closed form (Umeyama 1991 without scale, in 2-D): with centred points ``a_i`` and
    ``b_i``, the optimal angle is ``atan2(sum a_i x b_i, sum a_i . b_i)`` and
    ``t = mean(d) - R mean(s)``. A ``ValueError`` when the rotation is undetermined
    (fewer than two distinct points on either side).
    """
    src = _rows(source, "source", (2, 3))[:, :2]
    dst = _rows(target, "target", (2, 3))[:, :2]
    _same_length(src, "source", dst, "target")
    src_mean, dst_mean = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - src_mean, dst - dst_mean
    dot = float(np.sum(a * b))
    cross = float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    scale = math.sqrt(float(np.sum(a * a)) * float(np.sum(b * b)))
    # |(dot, cross)| equals that scale when the sets are congruent; a tiny ratio means
    # one side has collapsed to a point and any angle fits as well as any other.
    if scale == 0.0 or math.hypot(dot, cross) <= 1e-12 * scale:
        raise ValueError(
            f"the alignment is undetermined: source or target ({len(src)} points) has "
            "fewer than two distinct points"
        )
    theta = math.atan2(cross, dot)
    c, s = math.cos(theta), math.sin(theta)
    rotation = np.array([[c, -s], [s, c]])
    return Se2Transform(theta, dst_mean - rotation @ src_mean)


# ------------------------------------------------------------------ trajectory error


def _rms(values: np.ndarray) -> float:
    """Root mean square: every RMSE and RMS this module reports."""
    return math.sqrt(float(np.mean(values**2)))


def _stats(errors: np.ndarray) -> str:
    return f"rmse {_rms(errors):.4g}, mean {errors.mean():.4g}, max {errors.max():.4g}"


def _alignment(transform: Se2Transform | None) -> str:
    """How an error was measured, for its repr."""
    return "aligned" if transform is not None else "not aligned"


@dataclass(frozen=True, repr=False)
class TrajectoryError:
    """Absolute trajectory error of a path: ``position_error`` the distance of each
    matched (and, with ``transform``, aligned) estimate to the reference, in metres;
    ``heading_error`` the signed wrapped heading difference estimate - reference."""

    association: Association
    transform: Se2Transform | None
    position_error: np.ndarray  # (M,)
    heading_error: np.ndarray  # (M,)

    @property
    def rmse(self) -> float:
        """ATE RMSE of the positions (the translation part of evo's APE)."""
        return _rms(self.position_error)

    @property
    def heading_rmse(self) -> float:
        return _rms(self.heading_error)

    @property
    def matched(self) -> int:
        return self.association.matched

    def __repr__(self) -> str:
        return (
            f"TrajectoryError({_alignment(self.transform)}, {self.matched} of "
            f"{self.association.total} poses: position [m] {_stats(self.position_error)}; "
            f"heading [rad] {_stats(np.abs(self.heading_error))})"
        )


def trajectory_error(association: Association, *, align: bool = False) -> TrajectoryError:
    """ATE of an associated pose trajectory; with ``align``, the estimate is first moved
    by the SE(2) transform (:func:`align_se2`) that best fits it onto the reference."""
    if association.estimate.shape[1] != 3:
        raise ValueError("trajectory_error needs poses (N, 3), got points (N, 2)")
    est = association.estimate
    transform = align_se2(est, association.reference) if align else None
    if transform is not None:
        est = transform.apply_poses(est)
    diff = est - association.reference
    return TrajectoryError(
        association=association,
        transform=transform,
        position_error=np.hypot(diff[:, 0], diff[:, 1]),
        heading_error=wrap_angle(diff[:, 2]),
    )


def ate(
    t_estimate: npt.ArrayLike,
    estimate: npt.ArrayLike,
    t_reference: npt.ArrayLike,
    reference: npt.ArrayLike,
    *,
    align: bool = False,
    max_gap: float | None = None,
) -> TrajectoryError:
    """:func:`associate` then :func:`trajectory_error`, for ``(N, 3)`` pose arrays.

    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> truth = np.c_[t, np.zeros(5), np.zeros(5)]
    >>> est = truth + [0.0, 0.1, 0.0]
    >>> round(ate(t, est, t, truth).rmse, 12), round(ate(t, est, t, truth, align=True).rmse, 12)
    (0.1, 0.0)
    """
    assoc = associate(
        t_estimate, estimate, t_reference, reference, max_gap=max_gap, min_matches=2 if align else 1
    )
    return trajectory_error(assoc, align=align)


# ------------------------------------------------------------------ landmarks


@dataclass(frozen=True, repr=False)
class LandmarkError:
    """Estimated landmarks against surveyed ones, matched by id."""

    ids: np.ndarray  # (K,) int64 matched ids, in the estimate's order
    estimate: np.ndarray  # (K, 2) after the transform, if any
    reference: np.ndarray  # (K, 2)
    error: np.ndarray  # (K,) distances, m
    transform: Se2Transform | None
    unmatched_estimate_ids: tuple[int, ...]  # estimated, but not surveyed
    missing_reference_ids: tuple[int, ...]  # surveyed, never estimated

    @property
    def rmse(self) -> float:
        return _rms(self.error)

    def __repr__(self) -> str:
        return (
            f"LandmarkError({_alignment(self.transform)}, {len(self.ids)} matched: "
            f"{_stats(self.error)} m; estimated but not surveyed "
            f"{list(self.unmatched_estimate_ids)}, surveyed but not estimated "
            f"{list(self.missing_reference_ids)})"
        )


def _ids(values: npt.ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.ndim != 1 or arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must be a 1-D integer array, got {arr.dtype} {arr.shape}")
    unique, counts = np.unique(arr, return_counts=True)
    if np.any(counts > 1):
        raise ValueError(f"{name} repeats id {int(unique[counts > 1][0])}")
    return arr.astype(np.int64)


def landmark_error(
    estimate_ids: npt.ArrayLike,
    estimate: npt.ArrayLike,
    reference_ids: npt.ArrayLike,
    reference: npt.ArrayLike,
    *,
    transform: Se2Transform | None = None,
) -> LandmarkError:
    """Distance of every estimated landmark (``(K, 2)``, ids ``estimate_ids``) to the
    surveyed landmark of the same id. ``transform`` (for example the path's
    :attr:`TrajectoryError.transform`) moves the estimates first, so landmarks and path
    are scored in one frame. Ids on one side only are reported, not dropped; no common
    id at all is a ``ValueError``."""
    e_ids, r_ids = _ids(estimate_ids, "estimate_ids"), _ids(reference_ids, "reference_ids")
    est = _rows(estimate, "estimate", (2,))
    ref = _rows(reference, "reference", (2,))
    _same_length(e_ids, "estimate_ids", est, "estimate")
    _same_length(r_ids, "reference_ids", ref, "reference")
    where = {int(i): k for k, i in enumerate(r_ids)}
    rows = [k for k, i in enumerate(e_ids) if int(i) in where]
    if not rows:
        raise ValueError("estimate_ids and reference_ids have no id in common")
    matched = est[rows] if transform is None else transform.apply_points(est[rows])
    truth = ref[[where[int(e_ids[k])] for k in rows]]
    estimated = set(e_ids.tolist())
    return LandmarkError(
        ids=e_ids[rows],
        estimate=matched,
        reference=truth,
        error=np.hypot(*(matched - truth).T),
        transform=transform,
        unmatched_estimate_ids=tuple(int(i) for i in e_ids if int(i) not in where),
        missing_reference_ids=tuple(int(i) for i in r_ids if int(i) not in estimated),
    )


# ------------------------------------------------------------------ NEES


@dataclass(frozen=True, repr=False)
class NeesResult:
    """Normalised estimation error squared of the robot pose at every matched step:
    ``e^T P^-1 e`` with ``e`` the pose error (heading wrapped), chi-square with 3
    degrees of freedom for a consistent filter; ``band`` its two-sided ``confidence``
    interval for one run."""

    t: np.ndarray  # (M,)
    nees: np.ndarray  # (M,)
    band: tuple[float, float]
    confidence: float

    @property
    def mean(self) -> float:
        return float(np.mean(self.nees))

    @property
    def inside(self) -> float:
        """Fraction of steps with the NEES inside the band."""
        lo, hi = self.band
        return float(np.mean((self.nees >= lo) & (self.nees <= hi)))

    @property
    def above(self) -> float:
        """Fraction above the band: the filter is over-confident there."""
        return float(np.mean(self.nees > self.band[1]))

    @property
    def below(self) -> float:
        """Fraction below the band: the filter is too cautious there."""
        return float(np.mean(self.nees < self.band[0]))

    def __repr__(self) -> str:
        lo, hi = self.band
        return (
            f"NeesResult({len(self.nees)} steps, mean {self.mean:.3g}; "
            f"{100 * self.inside:.1f}% inside the {100 * self.confidence:g}% band "
            f"[{lo:.3g}, {hi:.3g}], {100 * self.above:.1f}% above, "
            f"{100 * self.below:.1f}% below)"
        )


def _check_covariances(cov: np.ndarray) -> None:
    """Refuses a non-symmetric or non-positive-definite 3x3 covariance, naming its step."""
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), np.finfo(float).tiny)
    asym = np.abs(cov - cov.transpose(0, 2, 1)).max(axis=(1, 2)) > 1e-9 * scale
    if np.any(asym):
        raise ValueError(f"covariances[{int(np.flatnonzero(asym)[0])}] is not symmetric")
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        # The batched call does not say which matrix failed: find it.
        for k, c in enumerate(cov):
            if np.any(np.linalg.eigvalsh(c) <= 0):
                raise ValueError(f"covariances[{k}] is not positive definite") from None
        raise


def pose_nees(
    association: Association, covariances: npt.ArrayLike, *, confidence: float = 0.95
) -> NeesResult:
    """NEES of the robot pose at every matched step. ``covariances`` are the filter's
    ``(N, 3, 3)`` robot covariances for ALL rows of the original estimate (the
    association picks the matched ones); the band comes from rperc-core's chi-square
    quantiles (``nees_bounds(3, 1, confidence)``)."""
    if association.estimate.shape[1] != 3:
        raise ValueError("pose_nees needs poses (N, 3), got points (N, 2)")
    cov = _finite(covariances, "covariances")
    if cov.shape != (association.total, 3, 3):
        raise ValueError(
            f"covariances must have shape ({association.total}, 3, 3), got {cov.shape}"
        )
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {excerpt(confidence)}")
    cov = cov[association.estimate_index]
    _check_covariances(cov)
    err = association.estimate - association.reference
    err[:, 2] = wrap_angle(err[:, 2])
    solved = np.linalg.solve(cov, err[:, :, None])[:, :, 0]
    return NeesResult(
        t=association.t,
        nees=np.einsum("ij,ij->i", err, solved),
        band=_rperc.nees_bounds(3, 1, float(confidence)),
        confidence=float(confidence),
    )


# ------------------------------------------------------------------ GPS


@dataclass(frozen=True, repr=False)
class GpsError:
    """Distance of the estimated path to every matched GPS fix, after one rigid
    alignment (``transform``, estimate -> GPS frame) fitted on all matched fixes."""

    association: Association  # the GPS fixes (as "estimate") against the path
    transform: Se2Transform
    distance: np.ndarray  # (M,) m

    @property
    def rms(self) -> float:
        return _rms(self.distance)

    def __repr__(self) -> str:
        a = self.association
        return (
            f"GpsError({a.matched} of {a.total} fixes: distance {_stats(self.distance)} m; "
            f"unmatched {a.before} before and {a.after} after the path, {a.in_gap} in gaps)"
        )


def gps_error(
    t_estimate: npt.ArrayLike,
    estimate: npt.ArrayLike,
    t_gps: npt.ArrayLike,
    gps: npt.ArrayLike,
    *,
    max_gap: float | None = None,
) -> GpsError:
    """The estimate (``(N, 3)`` poses or ``(N, 2)`` points, times strictly increasing)
    interpolated at each GPS fix time, moved by the single SE(2) transform that best
    fits it onto the fixes, and its distance to each fix. Fixes outside the path's span
    are counted in :attr:`GpsError.association`."""
    path = _rows(estimate, "estimate", (2, 3))[:, :2]
    _same_length(_times(t_estimate, "t_estimate"), "t_estimate", path, "estimate")
    _same_length(_times(t_gps, "t_gps"), "t_gps", _rows(gps, "gps", (2,)), "gps")
    # The sparse fixes play the "estimate" role: the dense path is interpolated at them.
    assoc = associate(t_gps, gps, t_estimate, path, max_gap=max_gap, min_matches=2)
    transform = align_se2(assoc.reference, assoc.estimate)
    moved = transform.apply_points(assoc.reference)
    return GpsError(assoc, transform, np.hypot(*(moved - assoc.estimate).T))


class RunReference(TypedDict):
    """What a run on a recording is scored against, as the ``rperc slam`` commands
    draw it: the reference path ``truth`` (rows ``x, y, theta`` or ``x, y``), the
    reference ``landmarks`` ``(L, 2)`` if any, the path's legend ``label``, the run's
    ``nees`` against it if computed, and the alignment ``transform`` if drawn aligned."""

    truth: np.ndarray
    landmarks: np.ndarray | None
    label: str
    nees: NeesResult | None
    transform: Se2Transform | None
