"""rperc.linesimp.simplify / simplify_many against shapely, the simplification package,
an independent Douglas-Peucker written in the test, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rperc
from rperc.datasets import read_polylines
from rperc.linesimp import simplify, simplify_many

from reference import douglas_peucker, is_valid

shapely = pytest.importorskip("shapely")
simplification = pytest.importorskip("simplification.cutil")

EPSILONS = [1e-5, 1e-4, 1e-3, 3e-3, 0.01, 0.03, 0.1, 0.5]


@pytest.fixture(scope="module", params=["louisiana.wkt", "norway_main.wkt"])
def coastline(request, data) -> np.ndarray:
    (line,) = read_polylines(data / "polylines" / request.param)
    return line


def shapely_indices(points: np.ndarray, eps: float) -> np.ndarray:
    kept = np.asarray(
        shapely.simplify(shapely.LineString(points), eps, preserve_topology=False).coords
    )
    # Map kept coordinates back to indices, walking forward (repeated points exist).
    out, k = [], 0
    for row in kept:
        while not np.array_equal(points[k], row):
            k += 1
        out.append(k)
        k += 1
    return np.asarray(out)


@pytest.mark.parametrize("eps", EPSILONS)
def test_segment_dp_equals_shapely_on_coastlines(coastline, eps):
    ours = simplify(coastline, eps, method="dp", metric="segment", return_indices=True)
    np.testing.assert_array_equal(ours, shapely_indices(coastline, eps))


@pytest.mark.parametrize("eps", EPSILONS)
def test_segment_dp_last_tie_equals_simplification_on_coastlines(coastline, eps):
    ours = simplify(coastline, eps, method="dp", metric="segment", tie="last", return_indices=True)
    theirs = np.asarray(simplification.simplify_coords_idx(coastline, eps), dtype=np.intp)
    np.testing.assert_array_equal(ours, theirs)


def test_the_peers_really_disagree_on_ties(data):
    """Why ``tie`` exists: on norway at 0.01 GEOS and geo keep different vertices."""
    (line,) = read_polylines(data / "polylines" / "norway_main.wkt")
    a = shapely_indices(line, 0.01)
    b = np.asarray(simplification.simplify_coords_idx(line, 0.01))
    assert not np.array_equal(a, b)


@pytest.mark.parametrize("eps", EPSILONS)
def test_hull_equals_dp_line_metric_on_coastlines(coastline, eps):
    hull = simplify(coastline, eps, return_indices=True)
    dp = simplify(coastline, eps, method="dp", return_indices=True)
    np.testing.assert_array_equal(hull, dp)
    assert is_valid(coastline, hull, eps)


@given(st.integers(0, 2**32 - 1), st.integers(3, 400), st.floats(0.0, 3.0))
def test_segment_dp_equals_shapely_on_random_walks(seed, n, eps):
    pts = np.cumsum(np.random.default_rng(seed).normal(size=(n, 2)), axis=0)
    ours = simplify(pts, eps, method="dp", metric="segment", return_indices=True)
    np.testing.assert_array_equal(ours, shapely_indices(pts, eps))


def _shapes(draw_kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    t = np.linspace(0, 1, n)
    if draw_kind == "walk":
        return np.cumsum(rng.normal(size=(n, 2)), axis=0)
    if draw_kind == "circle":
        # Jitter breaks the mirror symmetry, whose near-ties round differently.
        circle = np.c_[np.cos(2 * np.pi * t), np.sin(2 * np.pi * t)] * 10
        return circle + rng.normal(scale=1e-3, size=circle.shape)
    if draw_kind == "spiral":
        return np.c_[t * np.cos(20 * t), t * np.sin(20 * t)] * 10
    if draw_kind == "zigzag":
        k = np.arange(n, dtype=float)
        return np.c_[k, np.where(k % 2 == 0, k, -k)]
    if draw_kind == "lattice":  # many exact ties and duplicates
        return np.cumsum(rng.integers(-1, 2, size=(n, 2)), axis=0).astype(float)
    raise AssertionError(draw_kind)


@given(
    st.sampled_from(["walk", "circle", "spiral", "zigzag", "lattice"]),
    st.integers(0, 2**32 - 1),
    st.integers(3, 300),
    st.floats(0.0, 5.0),
)
def test_hull_and_dp_against_independent_reference(kind, seed, n, eps):
    pts = _shapes(kind, n, np.random.default_rng(seed))
    hull = simplify(pts, eps, return_indices=True)
    dp = simplify(pts, eps, method="dp", return_indices=True)
    assert is_valid(pts, hull, eps) and is_valid(pts, dp, eps)
    if kind != "lattice":  # generic inputs: the farthest point is unique
        assert dp.tolist() == douglas_peucker(pts, eps)
        assert hull.tolist() == dp.tolist()


def test_closed_ring_and_identical_points():
    ring = np.c_[np.cos(np.linspace(0, 2 * np.pi, 50)), np.sin(np.linspace(0, 2 * np.pi, 50))]
    ring[-1] = ring[0]
    for method in ("hull", "dp"):
        kept = simplify(ring, 0.1, method=method, return_indices=True)
        assert kept.tolist() == douglas_peucker(ring, 0.1)
        same = simplify(np.ones((20, 2)), 0.0, method=method, return_indices=True)
        assert same.tolist() == [0, 19]


def test_collinear_and_duplicates_drop_to_the_ends():
    pts = np.repeat(np.c_[np.arange(10.0), 2 * np.arange(10.0)], 3, axis=0)
    for method in ("hull", "dp"):
        assert simplify(pts, 1e-9, method=method, return_indices=True).tolist() == [0, len(pts) - 1]


def test_deep_zigzag_does_not_crash():
    k = np.arange(64_000, dtype=float)
    zz = np.c_[k, np.where(k % 2 == 0, k, -k)]
    for method in ("hull", "dp"):
        assert len(simplify(zz, 1e-9, method=method, return_indices=True)) == len(zz)


def test_points_come_back_with_their_dtype_and_z():
    pts = np.c_[np.arange(5.0), [0, 0.01, 0, 5, 0], np.arange(5.0) * 10]
    out = simplify(pts, 0.1)
    np.testing.assert_array_equal(out, pts[[0, 2, 3, 4]])
    out32 = simplify(pts.astype(np.float32), 0.1)
    assert out32.dtype == np.float32 and out32.shape == (4, 3)


def test_strided_float32_int_and_list_inputs_agree():
    pts = np.cumsum(np.random.default_rng(1).normal(size=(500, 2)), axis=0)
    expect = simplify(pts, 0.7, return_indices=True)
    wide = np.zeros((500, 5))
    wide[:, 1], wide[:, 3] = pts[:, 0], pts[:, 1]
    strided = wide[:, 1::2]
    assert not strided.flags.c_contiguous
    np.testing.assert_array_equal(simplify(strided, 0.7, return_indices=True), expect)
    np.testing.assert_array_equal(
        simplify(np.asfortranarray(pts), 0.7, return_indices=True), expect
    )
    np.testing.assert_array_equal(simplify(pts.tolist(), 0.7, return_indices=True), expect)
    f32 = pts.astype(np.float32)
    np.testing.assert_array_equal(
        simplify(f32, 0.7, return_indices=True),
        simplify(f32.astype(np.float64), 0.7, return_indices=True),
    )
    ints = np.array([[0, 0], [1, 5], [2, 0]])
    assert simplify(ints, 1.0, return_indices=True).tolist() == [0, 1, 2]


@pytest.mark.parametrize("n", [0, 1, 2])
def test_fewer_than_three_points_come_back_unchanged(n):
    pts = np.arange(2 * n, dtype=float).reshape(n, 2)
    np.testing.assert_array_equal(simplify(pts, 1.0), pts)


@pytest.mark.parametrize(
    ("points", "eps", "kwargs", "exc", "message"),
    [
        ([[0, 0], [1, np.nan], [2, 0]], 0.1, {}, ValueError, "point 1"),
        ([[0, 0], [1, np.inf], [2, 0]], 0.1, {}, ValueError, "non-finite"),
        ([[0, 0], [1, 1], [2, 0]], -1.0, {}, ValueError, "epsilon"),
        ([[0, 0], [1, 1], [2, 0]], float("nan"), {}, ValueError, "epsilon"),
        ([0.0, 1.0, 2.0], 0.1, {}, ValueError, "shape"),
        (np.zeros((3, 4)), 0.1, {}, ValueError, "shape"),
        (np.array([["a", "b"], ["c", "d"]]), 0.1, {}, TypeError, "dtype"),
        ([[0, 0], [1, 1], [2, 0]], 0.1, {"method": "fast"}, ValueError, "method"),
        ([[0, 0], [1, 1], [2, 0]], 0.1, {"metric": "area"}, ValueError, "metric"),
        ([[0, 0], [1, 1], [2, 0]], 0.1, {"metric": "segment"}, ValueError, "hull"),
        ([[0, 0], [1, 1], [2, 0]], 0.1, {"method": "dp", "tie": "middle"}, ValueError, "tie"),
    ],
)
def test_bad_input_raises_a_clear_error(points, eps, kwargs, exc, message):
    with pytest.raises(exc, match=message):
        simplify(points, eps, **kwargs)


def test_native_layer_checks_dtype_and_shape_itself():
    """The bridge refuses what the Python wrapper would have converted."""
    from rperc import _rperc

    with pytest.raises(TypeError, match="float64 or float32"):
        _rperc.simplify_indices(np.zeros((3, 2), dtype=np.int32), 0.1)
    with pytest.raises(TypeError, match="numpy array"):
        _rperc.simplify_indices([[0.0, 0.0]], 0.1)
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        _rperc.simplify_indices(np.zeros((3, 7)), 0.1)


def test_error_hierarchy():
    assert issubclass(rperc.NumericalError, rperc.RpercError)
    assert issubclass(rperc.RpercError, Exception)


def test_simplify_many_matches_simplify_and_reports_the_bad_polyline():
    rng = np.random.default_rng(7)
    lines = [np.cumsum(rng.normal(size=(int(n), 2)), axis=0) for n in rng.integers(0, 300, 50)]
    for threads in (None, 1, 2):
        many = simplify_many(lines, 0.8, return_indices=True, threads=threads)
        for line, kept in zip(lines, many, strict=True):
            np.testing.assert_array_equal(kept, simplify(line, 0.8, return_indices=True))
    pts = simplify_many(lines[:3], 0.8, method="dp", metric="segment")
    np.testing.assert_array_equal(pts[1], simplify(lines[1], 0.8, method="dp", metric="segment"))
    bad = [*lines[:3], np.array([[0.0, 0.0], [np.nan, 1.0], [2.0, 2.0]])]
    with pytest.raises(ValueError, match=r"polylines\[3\]"):
        simplify_many(bad, 0.8)
    with pytest.raises(ValueError, match="threads"):
        simplify_many(lines, 0.8, threads=0)
