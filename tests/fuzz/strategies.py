"""Hypothesis strategies shared by the properties: numbers at every scale, arrays in
every memory layout (with the float64 C-contiguous copy they must behave like), hostile
arrays of any dtype and shape, and parameters at and beyond their limits."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

SCALES = st.sampled_from([1.0, 1e-300, 1e-150, 1e-20, 1e-3, 1e3, 1e20, 1e150, 1e300])
NON_FINITE = st.sampled_from([np.nan, np.inf, -np.inf])
HUGE_INTS = st.sampled_from([-(2**63), -(2**62), -1, 2**31, 2**40, 2**62, 2**63 - 1, 2**64])

# Parameters at and beyond their limits, for any numeric argument.
EDGE_NUMBERS = st.one_of(
    st.sampled_from([0, 1, -1, 0.0, -0.0, 1e-320, 1e300, -1e300]),
    NON_FINITE,
    HUGE_INTS,
    st.sampled_from([True, None, "1", [1.0], np.float32(1.5), np.int8(-3), 1 + 1j]),
)


def values(n: int, scale: float = 1.0) -> st.SearchStrategy[np.ndarray]:
    """``n`` finite float64 values of magnitude up to ``scale``."""
    return hnp.arrays(np.float64, n, elements=st.floats(-1e3, 1e3, allow_nan=False)).map(
        lambda a: a * (scale / 1e3)
    )


def with_non_finite(arr: np.ndarray) -> st.SearchStrategy[np.ndarray]:
    """``arr`` with some entries made NaN or infinite (at least one when non-empty)."""
    if arr.size == 0:
        return st.just(arr)
    flat = arr.reshape(-1)
    return st.lists(
        st.tuples(st.integers(0, flat.size - 1), NON_FINITE), min_size=1, max_size=3
    ).map(lambda hits: _poke(arr, hits))


def _poke(arr: np.ndarray, hits: list[tuple[int, float]]) -> np.ndarray:
    out = arr.astype(np.float64).copy()
    for k, v in hits:
        out.reshape(-1)[k] = v
    return out


LAYOUTS = ("c", "fortran", "strided", "reversed", "unaligned", "big_endian", "list")


def relayout(arr: np.ndarray, layout: str) -> Any:
    """The same values as ``arr`` (same dtype) in another memory layout."""
    if layout == "fortran":
        return np.asfortranarray(arr)
    if layout == "strided":
        wide = np.repeat(arr, 2, axis=0)
        return wide[::2]
    if layout == "reversed":
        return np.ascontiguousarray(arr[::-1])[::-1]
    if layout == "unaligned":
        raw = b"\0" + np.ascontiguousarray(arr).tobytes()
        return np.frombuffer(raw, dtype=arr.dtype, offset=1).reshape(arr.shape)
    if layout == "big_endian":
        return arr.astype(arr.dtype.newbyteorder(">"))
    if layout == "list" and arr.size:  # an empty list has no columns to keep
        return arr.tolist()
    return np.ascontiguousarray(arr)


FLOAT_DTYPES = st.sampled_from([np.float64, np.float32, np.float16])
NUMERIC_DTYPES = st.sampled_from(
    [np.float64, np.float32, np.float16, np.int8, np.int32, np.int64, np.uint8, np.uint64]
)


@st.composite
def same_values(draw: st.DrawFn, arr: np.ndarray) -> tuple[Any, np.ndarray]:
    """``(variant, reference)``: ``arr`` cast to some numeric dtype and laid out some
    way, and the float64 C-contiguous array of exactly the variant's values."""
    dtype = draw(NUMERIC_DTYPES)
    with np.errstate(all="ignore"):
        cast = arr.astype(dtype)
    reference = np.ascontiguousarray(cast.astype(np.float64))
    if not np.isfinite(reference).all():  # float16 overflow: keep the float64 values
        cast, reference = arr, np.ascontiguousarray(arr)
    return relayout(cast, draw(st.sampled_from(LAYOUTS))), reference


def _structured() -> np.ndarray:
    return np.zeros(3, dtype=[("x", "f8"), ("y", "f8")])


# Arrays no numeric routine should accept silently, or should accept and handle.
HOSTILE = st.one_of(
    st.builds(lambda: np.float64(1.0).reshape(())),
    st.sampled_from([(0,), (0, 2), (0, 3), (1, 0), (0, 0), (2, 0), (0, 2**40)]).map(
        lambda s: np.zeros(s)
    ),
    hnp.arrays(
        st.sampled_from([np.complex128, np.bool_, np.int16, np.uint32, np.float16]),
        hnp.array_shapes(min_dims=0, max_dims=3, max_side=5),
    ),
    st.builds(lambda: np.array([[1.0, 2.0], ["a", None]], dtype=object)),
    st.builds(lambda: np.array([[1.0, 2.0], [3.0, 4.0]], dtype=object)),
    st.builds(_structured),
    st.builds(lambda: np.array(["1", "2"])),
    st.builds(lambda: np.array(["2024-01-01"], dtype="datetime64[D]")),
    st.just([[1.0, 2.0], [3.0]]),  # ragged
    st.just("not an array"),
    st.just(None),
)
