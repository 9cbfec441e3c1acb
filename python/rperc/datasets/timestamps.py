"""The one rule for time in rperc's trajectories: it increases strictly.

Every writer and reader of trajectories checks it with :func:`check_increasing`
(:func:`rperc.datasets.write_tum`, :func:`rperc.datasets.read_tum`); a log whose times do
not increase is mended on reading by :func:`repair_increasing`, with a
:class:`TimestampRepairWarning` (:func:`rperc.datasets.load_carmen` does so for its scans:
``orebro.log.gz`` and ``freiburg-campus.log.gz`` stamp every scan 0, the MIT infinite
corridor steps back over its first four scans and then repeats one value 1,937 times,
``intel.log`` steps back four times).

The repair (:func:`repair_increasing`), in full:

1. **Kept times.** The times kept are the largest set of the log's own times that
   increases strictly in log order: its longest strictly increasing subsequence
   (found in O(n log n)). Among equally long
   ones, the one that keeps the earliest scans, so that of a run of repeated times the
   first keeps its time and the others are repaired, and a time that steps back is the
   one repaired, not the one before it. A single time far ahead of its neighbours is
   repaired too, rather than dragging every later scan behind it.
2. **Between kept times** the repaired scans are spread evenly: scan ``k`` between kept
   scans ``a < k < b`` gets ``t[a] + (t[b] - t[a]) (k - a) / (b - a)``.
3. **Before the first or after the last kept time** the scans continue at the median step
   of the times from step 2 (the log's own scan period); when only one time is kept
   (every scan has the same time, as in ``orebro.log.gz``), at :data:`NOMINAL_PERIOD`.
4. Only when floats run out (kept times closer than the scans between them can be
   told apart) is a time moved up to the next float above its predecessor.

The result has the same length (no scan is dropped), increases strictly, equals the
input at every kept time (bar step 4), and is the input itself when that already
increases, so that repairing twice changes nothing.

Step 2 trusts the kept times. The infinite corridor's first time is -0.446 s and its
next kept one 4.29497e9 s (a small negative time through an unsigned 32-bit clock,
written with 6 digits), so its repaired scans lie 1.07e9 s apart: one per scan, in
order and strictly increasing, but not seconds.
"""

from __future__ import annotations

import bisect
import math

import numpy as np
import numpy.typing as npt

__all__ = [
    "NOMINAL_PERIOD",
    "TimeOrderError",
    "TimestampRepairWarning",
    "check_increasing",
    "first_not_increasing",
    "repair_increasing",
    "step_problem",
]

#: Seconds per scan when a log gives no step to go by (every time the same). The real
#: period cannot be known then; 1 s makes the repaired time the scan's index from the
#: first time, which anyone reading the file sees to be made up (and which float64 and
#: the TUM text format hold exactly), and it is of the order of the corrected Radish
#: logs' own periods (their median scan steps are 1.5 to 3.4 s).
NOMINAL_PERIOD = 1.0


class TimestampRepairWarning(UserWarning):
    """Times that did not increase strictly were repaired (:func:`repair_increasing`)."""


class TimeOrderError(ValueError):
    """Times that do not increase strictly (or are not finite): ``index`` is the first
    offending position."""

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.index = index


def _times(t: npt.ArrayLike, what: str) -> np.ndarray:
    times = np.asarray(t, dtype=np.float64)
    if times.ndim != 1:
        raise ValueError(f"{what} must be 1-D, got shape {times.shape}")
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        k = int(bad[0])
        raise TimeOrderError(f"{what}[{k}] is {float(times[k])!r}: times must be finite", k)
    return times


def first_not_increasing(t: np.ndarray) -> int | None:
    """The first index ``k >= 1`` with ``t[k] <= t[k - 1]``, or ``None``."""
    k = np.flatnonzero(t[1:] <= t[:-1])  # not np.diff: that can overflow
    return int(k[0]) + 1 if k.size else None


def step_problem(previous: float, current: float) -> str:
    """What is wrong with a step from ``previous`` to ``current`` that does not go up."""
    if current == previous:
        return f"repeats: {current!r} after {previous!r}"
    return f"goes backwards: {current!r} after {previous!r}"


def check_increasing(t: npt.ArrayLike, what: str = "t") -> np.ndarray:
    """``t`` as a float64 array, after checking that it is 1-D, finite and strictly
    increasing; otherwise :class:`TimeOrderError` (a ``ValueError``) naming ``what``, the
    first offending index and the values there.

    >>> check_increasing([0.0, 0.5, 2.0])
    array([0. , 0.5, 2. ])
    >>> check_increasing([0.0, 2.0, 1.0], "t")
    Traceback (most recent call last):
    ...
    rperc.datasets.timestamps.TimeOrderError: t goes backwards at index 2: 1.0 after 2.0 (times must increase strictly)
    """  # noqa: E501
    times = _times(t, what)
    k = first_not_increasing(times)
    if k is not None:
        previous, current = float(times[k - 1]), float(times[k])
        problem = step_problem(previous, current).replace(":", f" at index {k}:", 1)
        raise TimeOrderError(f"{what} {problem} (times must increase strictly)", k)
    return times


def _kept(t: np.ndarray) -> np.ndarray:
    """The indices of the longest strictly increasing subsequence of ``t``; of equally
    long ones, the lexicographically smallest index sequence."""
    n = len(t)
    # longest[i]: the longest strictly increasing subsequence starting at i. Read
    # backwards and negated, such a subsequence increases strictly and ends at i.
    longest = np.empty(n, dtype=np.int64)
    tails: list[float] = []
    for i in range(n - 1, -1, -1):
        v = -float(t[i])
        pos = bisect.bisect_left(tails, v)
        if pos == len(tails):
            tails.append(v)
        else:
            tails[pos] = v
        longest[i] = pos + 1
    need = int(longest.max())
    kept: list[int] = []
    for i in range(n):
        # The earliest scan that can still start a longest chain after the last kept.
        if longest[i] == need and (not kept or t[i] > t[kept[-1]]):
            kept.append(i)
            need -= 1
            if need == 0:
                break
    return np.asarray(kept, dtype=np.int64)


def _spread(times: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Step 2 of the rule: the times from the first kept scan to the last, the kept
    ones as they are and the others evenly between their kept neighbours: ``t[a] + w
    (t[b] - t[a])`` with ``w = (k - a) / (b - a)``, or where the difference overflows
    (times of opposite sign near the largest float) ``(1 - w) t[a] + w t[b]``."""
    k = np.arange(kept[0], kept[-1] + 1)
    at = np.searchsorted(kept, k, side="right") - 1
    a, b = kept[at], kept[np.minimum(at + 1, len(kept) - 1)]
    w = (k - a) / np.maximum(b - a, 1)
    with np.errstate(over="ignore", invalid="ignore"):
        gap = times[b] - times[a]
        out = np.where(np.isfinite(gap), times[a] + w * gap, times[a] * (1.0 - w) + times[b] * w)
    out[kept - kept[0]] = times[kept]
    return np.asarray(out, dtype=np.float64)


def repair_increasing(t: npt.ArrayLike) -> tuple[np.ndarray, int]:
    """Times made strictly increasing by the rule in the module docs, and how many
    changed. ``t`` must be 1-D and finite (:class:`TimeOrderError` otherwise, as for
    times so near the largest float that they cannot be made to increase); a ``t``
    that already increases strictly comes back unchanged (a copy), with 0.

    >>> repair_increasing([0.0, 0.0, 0.0])
    (array([0., 1., 2.]), 2)
    >>> repair_increasing([10.0, 10.0, 10.0, 13.0, 13.0])
    (array([10., 11., 12., 13., 14.]), 3)
    >>> repair_increasing([1.0, 2.0, 4.0, 3.0, 6.0])
    (array([1., 2., 4., 5., 6.]), 1)
    """
    times = _times(t, "t")
    n = len(times)
    if first_not_increasing(times) is None:
        return times.copy(), 0
    kept = _kept(times)
    first, last = int(kept[0]), int(kept[-1])
    out = times.copy()
    with np.errstate(over="ignore", invalid="ignore"):  # told below, if it happens
        out[first : last + 1] = _spread(times, kept)
        inner = np.diff(out[first : last + 1])
        step = float(np.median(inner)) if inner.size else NOMINAL_PERIOD
        if not (math.isfinite(step) and step > 0):
            step = NOMINAL_PERIOD
        out[:first] = times[first] - step * np.arange(first, 0, -1, dtype=np.float64)
        out[last + 1 :] = times[last] + step * np.arange(1, n - last, dtype=np.float64)
    start = first_not_increasing(out)
    if start is not None:  # floats ran out: the next float up, scan by scan
        for k in range(start, n):
            if out[k] <= out[k - 1]:
                out[k] = math.nextafter(float(out[k - 1]), math.inf)
    bad = np.flatnonzero(~np.isfinite(out))
    if bad.size:
        raise TimeOrderError(
            f"t[{int(bad[0])}] cannot be given a time: the times are too near the largest "
            "float (about 1.8e308) to be made to increase",
            int(bad[0]),
        )
    return out, int(np.count_nonzero(out != times))
