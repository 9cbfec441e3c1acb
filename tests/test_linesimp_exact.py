"""Exactness of rperc.linesimp.simplify (issue 16).

- The line metric (plain DP and path hulls, both tie rules) equals an exact
  Douglas-Peucker written here with Python integers, on the real coastlines and at
  extreme scales.
- ``tie="first"`` reproduces GEOS (shapely) and ``tie="last"`` geo (the
  ``simplification`` package) on the edge cases: duplicates, collinear runs, spikes,
  closed rings, epsilon 0 and epsilon equal to a vertex's distance in each peer's own
  arithmetic.
- Scaling the input and epsilon by a power of two changes nothing; the former
  infinite loop returns; unrepresentable spans are a clear error.
- numpy layouts (unaligned, packed structured fields, negative strides, Fortran order,
  non-native byte order) are read correctly or refused, never misread.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rperc.datasets import read_polylines
from rperc.linesimp import simplify

shapely = pytest.importorskip("shapely")
simplification = pytest.importorskip("simplification.cutil")

TIES = ["first", "last"]


# ---------------------------------------------------------------------------------
# Exact oracle: Douglas-Peucker with the line metric in integer arithmetic.
# ---------------------------------------------------------------------------------


def _as_integers(points: np.ndarray) -> tuple[list[tuple[int, int]], int]:
    """Every double is an integer times a power of two: scale all by the largest
    denominator so that the coordinates become exact Python integers."""
    fr = [(Fraction(float(x)), Fraction(float(y))) for x, y in points[:, :2]]
    den = max(max(x.denominator, y.denominator) for x, y in fr)
    return [(int(x * den), int(y * den)) for x, y in fr], den


def exact_dp(points: np.ndarray, eps: float, tie: str) -> list[int]:
    """Seed 000, Table 1, with the farthest vertex and the threshold test decided
    exactly: |F| / |b - a| > eps with F = (b - a) x (p - a), squared to stay in
    integers; a degenerate chord measures the distance to its end."""
    xy, den = _as_integers(points)
    e = Fraction(eps) * den
    n = len(xy)
    if n < 3:
        return list(range(n))
    keep = {0, n - 1}
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        (ax, ay), (bx, by) = xy[i], xy[j]
        dx, dy = bx - ax, by - ay
        degenerate = dx == 0 and dy == 0
        best, f = -1, -1
        for k in range(i + 1, j):
            px, py = xy[k][0] - ax, xy[k][1] - ay
            key = px * px + py * py if degenerate else abs(dx * py - dy * px)
            if key > best or (key == best and tie == "last"):
                best, f = key, k
        # Squared comparison: key^2 > e^2 L (proper chord), key > e^2 (degenerate).
        lhs = Fraction(best) if degenerate else Fraction(best * best)
        rhs = e * e * (1 if degenerate else dx * dx + dy * dy)
        if lhs > rhs:
            keep.add(f)
            stack += [(i, f), (f, j)]
    return sorted(keep)


def _line_results(points: np.ndarray, eps: float, tie: str) -> dict[str, list[int]]:
    return {
        method: simplify(points, eps, method=method, tie=tie, return_indices=True).tolist()
        for method in ("hull", "dp")
    }


@pytest.fixture(scope="module", params=["louisiana.wkt", "norway_main.wkt"])
def coastline(request, data) -> np.ndarray:
    (line,) = read_polylines(data / "polylines" / request.param)
    return line


@pytest.mark.parametrize("rel_eps", [0.0, 3e-5, 1e-3, 2e-2])
@pytest.mark.parametrize("tie", TIES)
def test_line_metric_equals_exact_oracle_on_coastlines(coastline, rel_eps, tie):
    eps = rel_eps * float(np.ptp(coastline, axis=0).max())
    expected = exact_dp(coastline, eps, tie)
    for method, got in _line_results(coastline, eps, tie).items():
        assert got == expected, method


@pytest.mark.parametrize("cells", [200, 5000])
@pytest.mark.parametrize("tie", TIES)
def test_grid_snapped_coastline_behind_a_zigzag_equals_exact_oracle(coastline, cells, tie):
    """Snapping creates duplicates and collinear runs; the zig-zag in front exhausts
    plain DP's budget at once, so path hulls decide the ties."""
    lo = coastline.min(axis=0)
    cell = float(np.ptp(coastline, axis=0).max()) / cells
    snapped = np.round((coastline - lo) / cell)
    k = np.arange(300.0)
    zigzag = np.c_[k - 300.0, np.where(k % 2 == 0, k, -k)]
    pts = np.vstack([zigzag, snapped])
    for eps in (0.0, 0.5, 1.0, 2.5):
        expected = exact_dp(pts, eps, tie)
        for method, got in _line_results(pts, eps, tie).items():
            assert got == expected, (method, eps)


@pytest.mark.parametrize("scale", [1e-300, 1e-84, 1e80, 1e150, 1e300])
def test_line_metric_at_extreme_scales_equals_exact_oracle(scale):
    """The issue: beyond 1e80 and below 1e-84 the line metric kept only the ends."""
    rng = np.random.default_rng(5)
    pts = np.cumsum(rng.normal(size=(300, 2)), axis=0) * scale
    eps = 2.0 * scale
    for tie in TIES:
        expected = exact_dp(pts, eps, tie)
        assert len(expected) > 10
        for method, got in _line_results(pts, eps, tie).items():
            assert got == expected, (method, tie)


# ---------------------------------------------------------------------------------
# Peers: GEOS for tie="first", geo for tie="last", with the segment metric.
# ---------------------------------------------------------------------------------

_libm = ctypes.CDLL(ctypes.util.find_library("m"))
_libm.hypot.restype = ctypes.c_double
_libm.hypot.argtypes = [ctypes.c_double, ctypes.c_double]


def geo_distance(p, a, b) -> float:
    """geo's ``line_segment_distance`` (projection parameter, then ``hypot``), with
    the C library's ``hypot`` that Rust's ``f64::hypot`` calls."""
    hypot = _libm.hypot
    if a[0] == b[0] and a[1] == b[1]:
        return hypot(a[0] - p[0], a[1] - p[1])
    dx, dy = b[0] - a[0], b[1] - a[1]
    r = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)
    if r <= 0.0:
        return hypot(a[0] - p[0], a[1] - p[1])
    if r >= 1.0:
        return hypot(b[0] - p[0], b[1] - p[1])
    s = ((a[1] - p[1]) * dx - (a[0] - p[0]) * dy) / (dx * dx + dy * dy)
    return abs(s) * hypot(dx, dy)


def geos_distance(p, a, b) -> float:
    """GEOS's point-to-segment distance, from GEOS itself."""
    seg = shapely.Point(a) if np.array_equal(a, b) else shapely.LineString([a, b])
    return float(shapely.distance(shapely.Point(p), seg))


def assert_matches_peers(pts: np.ndarray, eps: float) -> None:
    first = simplify(pts, eps, method="dp", metric="segment", tie="first", return_indices=True)
    line = shapely.LineString(pts)
    geos = np.asarray(shapely.simplify(line, eps, preserve_topology=False).coords)
    # GEOS returns coordinates; with repeated points an index map would be ambiguous.
    np.testing.assert_array_equal(pts[first], geos.reshape(-1, pts.shape[1]))
    last = simplify(pts, eps, method="dp", metric="segment", tie="last", return_indices=True)
    np.testing.assert_array_equal(last, np.asarray(simplification.simplify_coords_idx(pts, eps)))


def _edge_cases() -> dict[str, np.ndarray]:
    k = np.arange(80.0)
    convex_zigzag = np.c_[k, np.where(k % 2 == 0, 1.0, -1.0) * (k + 1) ** 2 / 80]
    tail = convex_zigzag[-1] + np.array([[3, 3], [5, 1], [7, 0], [7, 3], [7, 0], [8, 3]])
    ring = np.c_[np.cos(np.linspace(0, 2 * np.pi, 13)), np.sin(np.linspace(0, 2 * np.pi, 13))]
    ring[-1] = ring[0]
    return {
        "consecutive duplicates": np.repeat([[0.0, 0], [1, 2], [2, 2], [3, 0], [4, 1]], 3, axis=0),
        "collinear run": np.c_[np.arange(12.0), 0.5 * np.arange(12.0)],
        "collinear with a bump": np.r_[np.c_[np.arange(6.0), np.zeros(6)], [[6, 1]], [[7, 0]]],
        "back and forth on a line": np.array([[0.0, 0], [3, 0], [1, 0], [4, 0], [2, 0], [5, 0]]),
        "spike": np.array([[0.0, 0], [1, 0], [1, 3], [1, 0], [2, 0], [2, 0], [3, 0]]),
        "symmetric peaks": np.array([[0.0, 0], [1, 1], [2, 0], [3, 1], [4, 0], [5, -1], [6, 0]]),
        "all identical": np.ones((7, 2)),
        "closed ring": ring,
        "closed ring doubled ends": np.vstack([ring[:1], ring, ring[:1]]),
        "convex zigzag and tail": np.vstack([convex_zigzag, tail]),
    }


@pytest.mark.parametrize("name", list(_edge_cases()))
def test_tie_rules_reproduce_their_peer_on_edge_cases(name):
    pts = _edge_cases()[name]
    a, b = pts[0], pts[-1]
    eps_list = [0.0, 0.3, 1.0]
    for k in range(1, len(pts) - 1, max(1, len(pts) // 8)):
        # Epsilon exactly at a vertex's distance, in each peer's arithmetic.
        eps_list += [geos_distance(pts[k], a, b), geo_distance(pts[k], a, b)]
    for eps in eps_list:
        assert_matches_peers(pts, eps)


@given(
    st.lists(st.tuples(st.integers(-2, 2), st.integers(-2, 2)), min_size=2, max_size=60),
    st.lists(st.integers(1, 3), min_size=60, max_size=60),
    st.sampled_from([1.0, 0.1, 0.37, 2.0**-30]),
    st.integers(0, 10**6),
)
def test_tie_rules_reproduce_their_peer_on_lattice_walks(steps, reps, unit, pick):
    pts = np.cumsum(np.array(steps, dtype=float), axis=0) * unit
    pts = np.repeat(pts, reps[: len(pts)], axis=0)  # consecutive duplicates
    k = 1 + pick % max(1, len(pts) - 2)
    k = min(k, len(pts) - 1)
    a, b = pts[0], pts[-1]
    for eps in (0.0, unit, geos_distance(pts[k], a, b), geo_distance(pts[k], a, b)):
        assert_matches_peers(pts, eps)


@pytest.mark.parametrize("scale", [1e-150, 1e-100, 1e100, 1e150])
def test_segment_metric_matches_peers_wherever_they_work(scale):
    """GEOS and geo work from about 1e-160 to 1e153; rperc gives their answer there."""
    rng = np.random.default_rng(11)
    pts = np.cumsum(rng.normal(size=(400, 2)), axis=0) * scale
    for rel in (0.0, 0.5, 3.0):
        assert_matches_peers(pts, rel * scale)


def test_geo_keeps_everything_at_epsilon_zero_and_so_does_tie_last():
    pts = np.c_[np.arange(10.0), np.zeros(10)]
    last = simplify(pts, 0.0, method="dp", metric="segment", tie="last", return_indices=True)
    assert last.tolist() == list(simplification.simplify_coords_idx(pts, 0.0)) == list(range(10))
    # The line metric is rperc's own: there the tie rule only picks among equals.
    for method in ("hull", "dp"):
        line = simplify(pts, 0.0, method=method, tie="last", return_indices=True)
        assert line.tolist() == [0, 9]


# ---------------------------------------------------------------------------------
# Scale, overflow and termination.
# ---------------------------------------------------------------------------------

CONFIGS = [
    {"method": "hull", "metric": "line", "tie": "first"},
    {"method": "hull", "metric": "line", "tie": "last"},
    {"method": "dp", "metric": "line", "tie": "first"},
    {"method": "dp", "metric": "line", "tie": "last"},
    {"method": "dp", "metric": "segment", "tie": "first"},
    {"method": "dp", "metric": "segment", "tie": "last"},
]


@given(
    st.integers(0, 2**32 - 1),
    st.integers(3, 300),
    st.one_of(st.just(0.0), st.floats(1e-6, 3.0)),  # scaled exactly, never subnormal
    st.sampled_from([-500, -333, -1, 1, 250, 500]),
)
def test_power_of_two_scaling_changes_nothing(seed, n, eps, k):
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(size=(n, 2)), axis=0)
    if seed % 2:
        pts = np.round(pts)  # lattice: exact ties
    s = 2.0**k
    for cfg in CONFIGS:
        base = simplify(pts, eps, return_indices=True, **cfg)
        np.testing.assert_array_equal(simplify(pts * s, eps * s, return_indices=True, **cfg), base)


def test_former_infinite_loop_returns_and_keeps_the_far_point():
    """Run in a subprocess: the old code never returned and ignored SIGINT."""
    code = (
        "import json, numpy as np\n"
        "from rperc.linesimp import simplify\n"
        "p = np.array([[0.0, 0.0], [1e300, 1.0001e300], [1e150, 1e150]])\n"
        "cfgs = " + repr(CONFIGS) + "\n"
        "print(json.dumps([simplify(p, 1.0, return_indices=True, **c).tolist() for c in cfgs]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout) == [[0, 1, 2]] * len(CONFIGS)
    pts = np.array([[0.0, 0.0], [1e300, 1.0001e300], [1e150, 1e150]])
    with np.errstate(over="ignore"):  # GEOS's squares overflow; its answer is still right
        assert_matches_peers(pts, 1.0)


def test_unrepresentable_spans_are_a_value_error():
    pts = np.array([[-1e308, 0.0], [0.0, 1.0], [1e308, 0.0]])
    for cfg in CONFIGS:
        with pytest.raises(ValueError, match="points"):
            simplify(pts, 1.0, **cfg)


# ---------------------------------------------------------------------------------
# numpy layouts (the bridge reads the buffer; the lead fixes it).
# ---------------------------------------------------------------------------------


def _walk(n: int = 300) -> np.ndarray:
    return np.cumsum(np.random.default_rng(2).normal(size=(n, 2)), axis=0)


LAYOUT_WORDS = ("align", "layout", "byte", "order", "stride", "struct", "contiguous", "dtype")


def _read_correctly_or_refuse(arr: np.ndarray, reference: np.ndarray) -> None:
    """Same indices as for a plain copy, or a clear TypeError/ValueError that names
    points and the layout (not, say, garbage coordinates refused as out of range)."""
    try:
        got = simplify(arr, 1.0, return_indices=True)
    except (TypeError, ValueError) as err:
        msg = str(err)
        assert "points" in msg and any(w in msg for w in LAYOUT_WORDS), msg
        return
    np.testing.assert_array_equal(got, simplify(reference, 1.0, return_indices=True))


def _unaligned(pts: np.ndarray) -> np.ndarray:
    buf = bytearray(pts.nbytes + 1)
    buf[1:] = pts.tobytes()
    arr = np.frombuffer(buf, dtype=pts.dtype, offset=1).reshape(pts.shape)
    assert arr.flags.c_contiguous and not arr.flags.aligned
    return arr


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_unaligned_c_contiguous_array(dtype):
    pts = _walk().astype(dtype)
    _read_correctly_or_refuse(_unaligned(pts), pts.copy())


@pytest.mark.parametrize("dtype", ["<f8", "<f4"])
def test_field_of_a_packed_structured_array(dtype):
    pts = _walk()
    rec = np.zeros(len(pts), dtype=np.dtype([("tag", "u1"), ("xy", dtype, (2,))], align=False))
    rec["xy"] = pts
    field = rec["xy"]
    assert not field.flags.aligned
    _read_correctly_or_refuse(field, field.copy())


@pytest.mark.parametrize(
    "view",
    [
        lambda p: p[::-1],  # negative stride
        lambda p: np.asfortranarray(p),
        lambda p: p.astype(">f8"),  # non-native byte order (the wrapper converts it)
        lambda p: np.c_[p, np.zeros(len(p)), p][:, ::2][:, :2],  # strided columns
    ],
)
def test_other_layouts_are_read_correctly(view):
    pts = _walk()
    arr = view(pts)
    _read_correctly_or_refuse(arr, np.ascontiguousarray(arr, dtype=np.float64))


def test_bridge_reads_non_native_byte_order():
    from rperc import _rperc

    pts = _walk()
    np.testing.assert_array_equal(
        _rperc.simplify_indices(pts.astype(">f8"), 1.0), _rperc.simplify_indices(pts, 1.0)
    )
