"""The monotonic-time rule (rperc.datasets.timestamps): check_increasing refuses what
does not increase strictly and names where; repair_increasing's output increases
strictly, keeps the length, keeps the longest increasing run of the input's own times,
changes nothing that already increases and is idempotent. Oracles: cases written out
by hand, and an independent quadratic longest-increasing-subsequence count."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rperc.datasets import TimeOrderError, check_increasing, repair_increasing
from rperc.datasets.timestamps import NOMINAL_PERIOD

# Times on a quarter-second grid, so runs of repeats, steps back and jumps forward are
# all common; the spacing leaves the repair room to spread scans between kept times.
grid_times = arrays(np.float64, st.integers(0, 60), elements=st.integers(-40, 40)).map(
    lambda a: a * 0.25
)
# Any finite times of a plausible magnitude (seconds since 1970 fit well inside).
any_times = arrays(np.float64, st.integers(0, 60), elements=st.floats(-1e12, 1e12, allow_nan=False))
increasing_times = arrays(
    np.float64, st.integers(0, 60), elements=st.floats(1e-3, 1e3, allow_nan=False)
).map(lambda steps: 1.2e9 + np.cumsum(steps))


def longest_increasing(t: np.ndarray) -> int:
    """The length of the longest strictly increasing subsequence, by the quadratic DP."""
    best = [1] * len(t)
    for j in range(len(t)):
        for i in range(j):
            if t[i] < t[j]:
                best[j] = max(best[j], best[i] + 1)
    return max(best, default=0)


@given(st.one_of(grid_times, any_times))
def test_repair_increases_strictly_and_keeps_the_length(t: np.ndarray) -> None:
    out, repaired = repair_increasing(t)
    assert out.shape == t.shape and out.dtype == np.float64
    assert np.all(np.isfinite(out)) and np.all(np.diff(out) > 0)
    assert repaired == int(np.count_nonzero(out != t))


@given(grid_times)
def test_repair_keeps_the_longest_increasing_run_of_original_times(t: np.ndarray) -> None:
    """Exactly the longest strictly increasing subsequence keeps its times: every
    other scan is repaired, none more."""
    out, repaired = repair_increasing(t)
    assert repaired == len(t) - longest_increasing(t)
    kept = out == t
    assert np.all(np.diff(t[kept]) > 0)


@given(grid_times)
def test_repair_keeps_the_first_of_each_run_of_repeats(t: np.ndarray) -> None:
    t = np.sort(t)  # non-decreasing: only repeats to mend
    out, _ = repair_increasing(t)
    first = np.r_[True, t[1:] != t[:-1]][: len(t)]
    np.testing.assert_array_equal(out[first], t[first])


@given(increasing_times)
def test_repair_leaves_increasing_times_alone(t: np.ndarray) -> None:
    assert np.all(np.diff(t) > 0)
    out, repaired = repair_increasing(t)
    np.testing.assert_array_equal(out, t)
    assert repaired == 0 and out is not t
    np.testing.assert_array_equal(check_increasing(t), t)


@given(st.one_of(grid_times, any_times))
def test_repair_is_idempotent(t: np.ndarray) -> None:
    once, _ = repair_increasing(t)
    twice, repaired = repair_increasing(once)
    np.testing.assert_array_equal(twice, once)
    assert repaired == 0


@pytest.mark.parametrize(
    ("t", "expected", "repaired"),
    [
        # Every time the same (orebro.log.gz): the nominal period from the first.
        ([0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 2.0, 3.0], 3),
        # Two distinct values: spread between them, then on at the median step.
        ([2.0, 2.0, 2.0, 2.0, 4.0, 4.0], [2.0, 2.5, 3.0, 3.5, 4.0, 4.5], 4),
        # A step back (intel.log): the time that steps back is repaired.
        ([1.0, 2.0, 4.0, 3.0, 6.0], [1.0, 2.0, 4.0, 5.0, 6.0], 1),
        # Times falling from the start, then one far later (the infinite corridor).
        ([-0.5, -1.0, -1.5, 10.0, 10.0], [-0.5, 3.0, 6.5, 10.0, 13.5], 3),
        # One time far ahead is repaired, not every later scan.
        ([1.0, 2.0, 1000.0, 3.0, 4.0], [1.0, 2.0, 2.5, 3.0, 4.0], 1),
        # The first scan out of line: extrapolated backwards at the median step.
        ([9.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0], 1),
        # Nothing to do.
        ([], [], 0),
        ([5.0], [5.0], 0),
    ],
)
def test_repair_written_out(t: list[float], expected: list[float], repaired: int) -> None:
    out, count = repair_increasing(t)
    np.testing.assert_array_equal(out, expected)
    assert count == repaired


def test_repeated_huge_times_still_increase() -> None:
    """At 1e17 s one float step is 16 s: the nominal 1 s step is lost to rounding, so
    each time moves up to the next float instead."""
    out, repaired = repair_increasing([1e17, 1e17, 1e17])
    assert np.all(np.diff(out) > 0) and repaired == 2 and out[0] == 1e17
    assert NOMINAL_PERIOD == 1.0
    tight = np.nextafter(1.0, 2.0)  # two kept times one float apart, three scans between
    out, _ = repair_increasing([1.0, 1.0, 1.0, 1.0, tight])
    assert np.all(np.diff(out) > 0) and out[0] == 1.0


def test_repair_refuses_what_cannot_be_repaired() -> None:
    with pytest.raises(TimeOrderError, match=r"t\[1\] is nan: times must be finite"):
        repair_increasing([0.0, math.nan, 2.0])
    with pytest.raises(ValueError, match="1-D"):
        repair_increasing([[0.0, 1.0]])
    biggest = np.finfo(np.float64).max
    with pytest.raises(TimeOrderError, match=r"t\[1\] cannot be given a time") as info:
        repair_increasing([biggest, biggest])
    assert info.value.index == 1
    # Kept times at both ends of the float range: spread without overflowing.
    out, repaired = repair_increasing([-biggest, -biggest, biggest])
    np.testing.assert_array_equal(out, [-biggest, 0.0, biggest])
    assert repaired == 1


@pytest.mark.parametrize(
    ("t", "index", "message"),
    [
        ([0.0, 0.0, 0.0], 1, r"scan time repeats at index 1: 0\.0 after 0\.0"),
        ([0.0, 2.0, 1.0], 2, r"scan time goes backwards at index 2: 1\.0 after 2\.0"),
        ([0.0, math.inf], 1, r"scan time\[1\] is inf: times must be finite"),
        ([math.nan], 0, r"scan time\[0\] is nan"),
    ],
)
def test_check_names_what_and_where(t: list[float], index: int, message: str) -> None:
    with pytest.raises(TimeOrderError, match=message) as info:
        check_increasing(t, "scan time")
    assert info.value.index == index and isinstance(info.value, ValueError)


def test_check_accepts_strictly_increasing_times() -> None:
    out = check_increasing([1, 2, 3])
    assert out.dtype == np.float64 and out.tolist() == [1.0, 2.0, 3.0]
    assert check_increasing([]).size == 0 and check_increasing([7.0]).tolist() == [7.0]
    with pytest.raises(ValueError, match="t must be 1-D"):
        check_increasing(np.zeros((2, 2)))
