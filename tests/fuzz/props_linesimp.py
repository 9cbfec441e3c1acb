"""rperc.linesimp under fuzzing: every layout and dtype behaves like the float64
C-contiguous copy, results do not depend on units (exact power-of-two scaling),
Douglas-Peucker's guarantee holds, and hostile input is a clear error."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.linesimp import extract_lines, simplify, simplify_many

from fuzz.harness import case, examples, outcome
from fuzz.strategies import EDGE_NUMBERS, HOSTILE, same_values, with_non_finite

METHODS = st.sampled_from(["auto", "hull", "dp", "vw"])
METRICS = st.sampled_from(["line", "segment"])
TIES = st.sampled_from(["first", "last"])


@st.composite
def polylines(draw: st.DrawFn, max_n: int = 40) -> np.ndarray:
    """Points on a 1/8 grid (exact under power-of-two scaling), with repeats and
    collinear runs more often than uniform floats would give."""
    n = draw(st.integers(0, max_n))
    cols = draw(st.sampled_from([2, 3]))
    ints = draw(st.lists(st.integers(-40, 40), min_size=n * cols, max_size=n * cols))
    return np.array(ints, dtype=np.float64).reshape(n, cols) / 8.0


def _indices(points: Any, eps: float, **kw: Any) -> tuple[bool, Any]:
    return outcome(simplify, points, eps, return_indices=True, **kw)


def _same_outcome(a: tuple[bool, Any], b: tuple[bool, Any]) -> None:
    assert a[0] == b[0], (a, b)
    if a[0]:
        np.testing.assert_array_equal(a[1], b[1])
    else:
        assert type(a[1]) is type(b[1]), (a, b)


@examples(120)
@given(polylines(), st.integers(0, 24).map(lambda k: k / 8), METHODS, METRICS, TIES, st.data())
def prop_simplify_any_layout_equals_float64(pts, eps, method, metric, tie, data):
    variant, reference = data.draw(same_values(pts))
    case("simplify", points=variant, epsilon=eps, method=method, metric=metric, tie=tie)
    kw = {"method": method, "metric": metric, "tie": tie}
    got = _indices(variant, eps, **kw)
    _same_outcome(got, _indices(reference, eps, **kw))
    if got[0] and len(reference):
        kept = simplify(variant, eps, **kw)
        np.testing.assert_array_equal(np.asarray(kept, dtype=np.float64), reference[got[1]])


@examples(120)
@given(polylines(), st.integers(0, 24), st.integers(-240, 240), METHODS, METRICS)
def prop_simplify_does_not_depend_on_units(pts, eps8, k, method, metric):
    """p * 2**k with epsilon * 2**k (an area: * 4**k for VW) is exact in floating point,
    so the kept indices must not change between about 1e-72 and 1e72 (and k is doubled
    for the distance methods: 1e-144 to 1e144)."""
    k = k if method == "vw" else 2 * k
    eps = eps8 / 8.0
    s = 2.0**k
    eps_s = eps * (s * s if method == "vw" else s)
    case("simplify_scaled", points=pts, epsilon=eps, scale=f"2**{k}", method=method)
    _same_outcome(
        _indices(pts * s, eps_s, method=method, metric=metric),
        _indices(pts, eps, method=method, metric=metric),
    )


def _distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, segment: bool) -> np.ndarray:
    d = b - a
    length2 = float(d @ d)
    if length2 == 0.0:
        return np.hypot(*(p - a).T)
    t = (p - a) @ d / length2
    if segment:
        t = np.clip(t, 0.0, 1.0)
    return np.hypot(*(p - a - np.outer(t, d)).T)


@examples(150)
@given(polylines(60), st.integers(0, 24).map(lambda k: k / 8), st.sampled_from(["hull", "dp"]))
def prop_douglas_peucker_guarantee(pts, eps, method):
    """Every dropped point lies within epsilon of the chord of its kept neighbours
    (brute force here), the ends stay, and path hulls keep exactly DP's indices."""
    case("simplify_dp", points=pts, epsilon=eps, method=method)
    idx = simplify(pts, eps, method=method, return_indices=True)
    if len(pts) == 0:
        return
    assert idx[0] == 0 and idx[-1] == len(pts) - 1 and np.all(np.diff(idx) > 0), idx
    xy = pts[:, :2]
    for i, j in itertools.pairwise(idx):
        if j > i + 1:
            d = _distance(xy[i + 1 : j], xy[i], xy[j], segment=False)
            assert d.max() <= eps * (1 + 1e-12) + 1e-12, (i, j, d.max())
    if method == "hull":
        np.testing.assert_array_equal(idx, simplify(pts, eps, method="dp", return_indices=True))


@examples(150)
@given(
    st.one_of(HOSTILE, polylines(8).flatmap(with_non_finite)),
    st.one_of(st.just(0.5), EDGE_NUMBERS),
    METHODS,
    st.booleans(),
)
def prop_simplify_hostile_input_is_a_clear_error(points, eps, method, topology):
    case("simplify", points=points, epsilon=eps, method=method, preserve_topology=topology)
    ok, got = outcome(simplify, points, eps, method=method, preserve_topology=topology)
    if ok and isinstance(points, np.ndarray) and points.dtype.kind == "f":
        assert np.isfinite(np.asarray(got, dtype=np.float64)).all() or not np.isfinite(points).all()
    if ok:
        assert np.isfinite(float(eps)) and float(eps) >= 0, f"epsilon {eps!r} accepted"


@examples(60)
@given(
    st.lists(polylines(20), max_size=6),
    st.sampled_from([None, 1, 2, 3, 64, 10**6, 2**62]),
    METHODS,
    st.data(),
)
def prop_simplify_many_equals_one_by_one(lines, threads, method, data):
    pairs = [data.draw(same_values(p)) for p in lines]
    variants = [v for v, _ in pairs]
    case("simplify_many", polylines=variants, threads=threads, method=method)
    ok, got = outcome(
        simplify_many, variants, 0.5, method=method, threads=threads, return_indices=True
    )
    if not ok:
        assert "threads" in str(got) or "segment" in str(got), got
        return
    assert len(got) == len(lines)
    for (_, ref), idx in zip(pairs, got, strict=True):
        np.testing.assert_array_equal(idx, simplify(ref, 0.5, method=method, return_indices=True))


EXTRACT_PARAMS = [
    "min_range",
    "max_range",
    "sigma_range",
    "sigma_bearing",
    "breakpoint_lambda",
    "split_epsilon",
    "merge_confidence",
    "min_points",
    "min_length",
]


@st.composite
def scans(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    """A room-like scan: bearings increasing, ranges on walls with noise, dropouts."""
    n = draw(st.integers(0, 120))
    angles = np.linspace(-np.pi / 2, np.pi / 2, n)
    wall = draw(st.floats(0.5, 20.0))
    ranges = wall / np.maximum(np.cos(angles), 0.05)
    holes = draw(st.lists(st.integers(0, max(n - 1, 0)), max_size=5)) if n else []
    ranges[holes] = draw(st.sampled_from([0.0, np.nan, np.inf, 1e300, -1.0]))
    return ranges, angles


@examples(120)
@given(scans(), st.data())
def prop_extract_lines_any_layout_is_finite_and_equal(scan, data):
    ranges, angles = scan
    (r, r_ref), (a, a_ref) = data.draw(same_values(ranges)), data.draw(same_values(angles))
    case("extract_lines", ranges=r, angles=a)
    ok, walls = outcome(extract_lines, r, a)
    ok_ref, ref = outcome(extract_lines, r_ref, a_ref)
    assert ok == ok_ref, (walls, ref)
    if not ok:
        return
    for name in ("rho", "alpha", "cov", "start", "end"):
        got = getattr(walls, name)
        assert np.isfinite(got).all(), name
        np.testing.assert_array_equal(got, getattr(ref, name))
    assert walls.offsets[0] == 0 and walls.offsets[-1] == len(walls.flat_indices)
    assert np.all((walls.flat_indices >= 0) & (walls.flat_indices < len(r_ref)))


@examples(150)
@given(scans(), st.sampled_from(EXTRACT_PARAMS), EDGE_NUMBERS)
def prop_extract_lines_bad_parameter_is_named(scan, name, value):
    ranges, angles = scan
    case("extract_lines", ranges=ranges, angles=angles, **{name: value})
    ok, got = outcome(extract_lines, ranges, angles, **{name: value})
    if ok:
        for field in ("rho", "alpha", "cov", "start", "end"):
            assert np.isfinite(getattr(got, field)).all(), (field, name, value)
    else:
        assert name in str(got), f"{name}={value!r}: {type(got).__name__}: {got}"
