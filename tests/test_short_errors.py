"""Issue 38: an error names the parameter (or the file and line) and quotes at most
about 80 characters of the input, however long the input is."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

HUGE = 5_000_000


def _cases() -> dict[str, Callable[[], Any]]:
    from rperc.datasets import load_carmen
    from rperc.linesimp import simplify
    from rperc.tracking import ColorHistogramTracker

    frame = np.zeros((20, 20, 3), np.uint8)
    return {
        "epsilon": lambda: simplify(np.zeros((3, 2)), "x" * HUGE),
        "method": lambda: simplify(np.zeros((3, 2)), 1.0, method="m" * HUGE),
        "channels": lambda: ColorHistogramTracker(frame, (1, 1, 5, 5), channels="c" * HUGE),
        "on_error": lambda: load_carmen("/dev/null", on_error="o" * HUGE),  # type: ignore[arg-type]
    }


@pytest.mark.parametrize("name", ["epsilon", "method", "channels", "on_error"])
def test_a_huge_argument_is_quoted_briefly_and_named(name):
    with pytest.raises(ValueError) as info:
        _cases()[name]()
    text = str(info.value)
    assert name in text and len(text) < 250, text[:300]
    assert "more characters" in text


@pytest.mark.parametrize("value", [2**63, -(2**63) - 1, 10**30])
def test_an_integer_beyond_64_bits_names_its_field_and_the_range(value):
    """A config integer outside a signed 64-bit integer is refused by its field with
    the range it must lie in (it said "64 bits does not fit a 64-bit integer")."""
    from rperc import _rperc

    patch = np.zeros((10, 10), np.uint8)
    with pytest.raises(ValueError, match=r"pattern_sequence\.width: .* out of range .*2\^63 - 1"):
        _rperc.pattern_sequence(patch, patch, {"width": value})


def test_a_bound_that_is_not_a_power_of_two_is_stated_as_the_largest_value():
    """``whole_number``'s message states the bound it checks: 10^6 particles is the
    most any filter takes (rperc-core's MAX_PARTICLES, which the colour+shape tracker
    accepts), and one more is refused with that number, not a wrong power of two."""
    from rperc import _rperc
    from rperc._args import whole_number
    from rperc.tracking import ColorShapeTracker

    assert _rperc.MAX_PARTICLES == 10**6
    limit = _rperc.MAX_PARTICLES + 1
    assert whole_number(10**6, "n_samples", 1, limit=limit) == 10**6
    with pytest.raises(ValueError, match=r"n_samples must be a positive integer at most 1000000"):
        whole_number(10**6 + 1, "n_samples", 1, limit=limit)
    with pytest.raises(ValueError, match=r"seed must be a non-negative integer below 2\*\*64"):
        whole_number(-1, "seed", 0, limit=2**64)
    frame = np.zeros((40, 40, 3), np.uint8)
    # The tracker's own bound now comes from the Rust config check, stated as a range.
    with pytest.raises(ValueError, match=r"'n_samples': must be in 1\.\.=1000000, got 1000001"):
        ColorShapeTracker(frame, (10, 10, 10, 10), n_samples=10**6 + 1)


def test_an_empty_matrix_of_a_huge_width_is_refused_at_once() -> None:
    # Found by the fuzz suite in an opt-level-2 build: a (0, 2**40) J (no bytes) was
    # copied column by column, 2**40 empty columns, before its shape was checked.
    from rperc.slam.monobot import unobservable_directions

    with pytest.raises(ValueError, match="square"):
        unobservable_directions(np.empty((0, 2**40)), tol=1.0)
