"""Checks of the scalar arguments every module takes (counts, sizes, seeds, reals), so
that a bad one is a ValueError naming it rather than whatever ``int()``, ``float()``
or pyo3 would say (``cannot convert float NaN to integer``, ``int too big to
convert``), which names nothing."""

from __future__ import annotations

import math
import numbers
from typing import Any

#: The most characters of a caller's input an error message quotes.
QUOTE_LIMIT = 80


def excerpt(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to about ``limit`` characters, saying how much was left out:
    an error quotes enough of the input to find it, never the whole of a 50 MB line
    (issue 38). Only the first ``4 * limit`` characters of a string are ever read.

    >>> excerpt("x" * 1000, limit=10)
    "'xxxxxxxxx... (991 more characters)"
    >>> excerpt(3.5)
    '3.5'
    """
    if isinstance(value, str) and len(value) > limit:
        return f"{value[: 4 * limit]!r}"[:limit] + f"... ({len(value) - limit + 1} more characters)"
    text = repr(value)
    if len(text) <= limit:
        return text
    return text[:limit] + f"... ({len(text) - limit} more characters)"


def whole_number(value: object, name: str, minimum: int, limit: int = 2**63) -> int:
    """``value`` as an int, after checking it is a whole number in ``[minimum, limit)``.

    A NaN, an infinity or a non-number is refused with a message naming ``name``.
    The default ``limit`` is the first size no native integer holds."""
    number = _whole(value)
    if number is None or not minimum <= number < limit:
        what = {0: "a non-negative integer", 1: "a positive integer"}.get(
            minimum, f"an integer >= {minimum}"
        )
        # A power of two reads best as one; any other bound as the largest value allowed.
        bound = (
            f"below 2**{limit.bit_length() - 1}" if limit & (limit - 1) == 0
            else f"at most {limit - 1}"
        )  # fmt: skip
        raise ValueError(f"{name} must be {what} {bound}, got {excerpt(value)}")
    return number


def seed_number(value: object, name: str = "seed") -> int:
    """``value`` as a seed: a whole number in ``[0, 2**64)``, the native side's u64.
    Every seed is read here, so that all take the same range and a bad one (None, NaN,
    -1) is refused naming ``name``, not inside ``int()`` or pyo3 naming nothing."""
    return whole_number(value, name, 0, limit=2**64)


def _whole(value: object) -> int | None:
    """The int ``value`` stands for (``3``, ``3.0``, ``np.int64(3)``), or None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        real = float(value)
        return int(real) if math.isfinite(real) and real.is_integer() else None
    return None


def real_number(value: object, name: str) -> float:
    """``value`` as a float; a string, None or a complex is a ValueError naming
    ``name`` (``float("1")`` would quietly accept a string). NaN and infinities pass:
    the caller decides what range is valid."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {excerpt(value)}")
    return float(value)


def float_array(values: object, name: str, *, keep_float32: bool = False) -> Any:
    """``values`` (numbers, nested lists, any numeric array) as a float64 array; a
    ragged list, strings, objects, complex numbers or dates are a TypeError naming
    ``name`` (numpy's own messages, ``could not convert string to float``, name
    nothing). A float64 array comes back as it is (strided views too, no copy).

    ``keep_float32``: a native-order float32 array also comes back as it is, for
    callers whose native side reads float32 and whose results keep the input dtype."""
    import numpy as np

    try:
        arr = np.asarray(values)
    except ValueError as exc:  # ragged nesting
        raise TypeError(f"{name} must be a rectangular array of numbers: {exc}") from None
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if keep_float32 and arr.dtype == np.float32:
        return arr
    return arr.astype(np.float64, copy=False)
