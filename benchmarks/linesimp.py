"""rperc line simplification against shapely (GEOS) and the simplification package
(geo), all in the same run, with ratios.

    python benchmarks/linesimp.py [--quick]

Peers run in a subprocess on the zig-zags, where their recursion may overflow the
stack; a crash is reported, not fatal.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import best_time, fmt_seconds, print_table, time_in_subprocess

from rperc.datasets import data_dir, load_carmen, read_polylines
from rperc.linesimp import simplify, simplify_many

try:
    import shapely
except ImportError:  # pragma: no cover - optional peer
    shapely = None
try:
    from simplification.cutil import simplify_coords_idx
except ImportError:  # pragma: no cover - optional peer
    simplify_coords_idx = None


def ratio(peer: float | None, ours: float) -> str:
    return f"{peer / ours:7.1f}x" if peer else "   -"


def coastlines(rows: list[list[str]]) -> None:
    root = data_dir()
    if root is None:
        print("(no data folder: coastlines skipped)")
        return
    for name, eps in [
        ("louisiana.wkt", 1e-3),
        ("norway_main.wkt", 1e-3),
        ("norway_main.wkt", 1e-2),
    ]:
        (pts,) = read_polylines(root / "polylines" / name)
        hull = best_time(lambda pts=pts, eps=eps: simplify(pts, eps, return_indices=True))
        dp = best_time(
            lambda pts=pts, eps=eps: simplify(
                pts, eps, method="dp", metric="segment", return_indices=True
            )
        )
        geos = geo = None
        if shapely is not None:
            line = shapely.LineString(pts)
            geos = best_time(
                lambda line=line, eps=eps: shapely.simplify(line, eps, preserve_topology=False)
            )
        if simplify_coords_idx is not None:
            geo = best_time(lambda pts=pts, eps=eps: simplify_coords_idx(pts, eps))
        rows.append(
            [
                f"{name.split('.')[0]} n={len(pts)} eps={eps:g}",
                fmt_seconds(hull),
                fmt_seconds(dp),
                fmt_seconds(geos),
                fmt_seconds(geo),
                ratio(geos, min(hull, dp)),
                ratio(geo, min(hull, dp)),
            ]
        )


def zigzag(n: int) -> np.ndarray:
    k = np.arange(n, dtype=float)
    return np.c_[k, np.where(k % 2 == 0, k, -k)]


def zigzags(rows: list[list[str]], sizes: list[int]) -> None:
    for n in sizes:
        pts = zigzag(n)
        hull = best_time(lambda pts=pts: simplify(pts, 1e-9, return_indices=True), repeat=3)
        dp = (
            best_time(
                lambda pts=pts: simplify(pts, 1e-9, method="dp", return_indices=True), repeat=1
            )
            if n <= 64_000
            else None
        )
        setup = (
            "import numpy as np\n"
            f"k = np.arange({n}, dtype=float)\n"
            "pts = np.c_[k, np.where(k % 2 == 0, k, -k)]\n"
        )
        geos, geos_note = (None, "not installed")
        geo, geo_note = (None, "not installed")
        if shapely is not None:
            geos, geos_note = time_in_subprocess(
                setup + "import shapely\nline = shapely.LineString(pts)",
                "shapely.simplify(line, 1e-9, preserve_topology=False)",
                timeout=120,
            )
        if simplify_coords_idx is not None:
            geo, geo_note = time_in_subprocess(
                setup + "from simplification.cutil import simplify_coords_idx",
                "simplify_coords_idx(pts, 1e-9)",
                timeout=120,
            )
        rows.append(
            [
                f"zig-zag n={n}",
                fmt_seconds(hull),
                fmt_seconds(dp, "skipped (quadratic)"),
                fmt_seconds(geos, geos_note),
                fmt_seconds(geo, geo_note),
                ratio(geos, hull),
                ratio(geo, hull),
            ]
        )


def random_walk(rows: list[list[str]], n: int) -> None:
    pts = np.cumsum(np.random.default_rng(0).normal(size=(n, 2)), axis=0)
    hull = best_time(lambda: simplify(pts, 5.0, return_indices=True), repeat=3)
    dp = best_time(
        lambda: simplify(pts, 5.0, method="dp", metric="segment", return_indices=True), repeat=3
    )
    geos = geo = None
    if shapely is not None:
        line = shapely.LineString(pts)
        geos = best_time(lambda: shapely.simplify(line, 5.0, preserve_topology=False), repeat=3)
    if simplify_coords_idx is not None:
        geo = best_time(lambda: simplify_coords_idx(pts, 5.0), repeat=3)
    rows.append(
        [
            f"random walk n={n}",
            fmt_seconds(hull),
            fmt_seconds(dp),
            fmt_seconds(geos),
            fmt_seconds(geo),
            ratio(geos, min(hull, dp)),
            ratio(geo, min(hull, dp)),
        ]
    )
    per_point = hull / n * 1e9
    small = np.cumsum(np.random.default_rng(0).normal(size=(n // 10, 2)), axis=0)
    hull_small = best_time(lambda: simplify(small, 5.0, return_indices=True), repeat=3)
    print(
        f"random walk: {per_point:.1f} ns/point at n={n}, "
        f"{hull_small / (n // 10) * 1e9:.1f} ns/point at n={n // 10} (near-linear if equal)"
    )


def many(count: int) -> None:
    rng = np.random.default_rng(3)
    lines = [np.cumsum(rng.normal(size=(2000, 2)), axis=0) for _ in range(count)]
    one = best_time(lambda: simplify_many(lines, 2.0, return_indices=True, threads=1), repeat=3)
    two = best_time(lambda: simplify_many(lines, 2.0, return_indices=True, threads=2), repeat=3)
    loop = best_time(lambda: [simplify(p, 2.0, return_indices=True) for p in lines], repeat=3)
    geos = None
    if shapely is not None:
        geoms = shapely.linestrings(lines)
        geos = best_time(lambda: shapely.simplify(geoms, 2.0, preserve_topology=False), repeat=3)
    print(
        f"\nsimplify_many, {count} random walks of 2000 points: 1 thread {fmt_seconds(one)}, "
        f"2 threads {fmt_seconds(two)} (speed-up {one / two:.2f}x on {os.cpu_count()} cores), "
        f"Python loop of simplify {fmt_seconds(loop)}, shapely vectorised {fmt_seconds(geos)}"
        + (f" ({geos / two:.1f}x)" if geos else "")
    )


def scans(quick: bool) -> None:
    root = data_dir()
    log_path = root / "carmen" / "intel.log" if root else None
    if log_path is None or not log_path.exists():
        print("(no CARMEN log: extract_lines skipped)")
        return
    try:
        from rperc.linesimp import extract_lines
    except ImportError:
        print("(extract_lines not available)")
        return
    log = load_carmen(log_path)
    sc = log.scans
    angles = sc.angles(0)
    count = 200 if quick else len(sc)

    def run() -> None:
        for k in range(count):
            extract_lines(sc.ranges[k], angles, max_range=sc.max_range[k])

    t = best_time(run, repeat=3, min_time=0.5)
    print(
        f"\nextract_lines on intel.log ({sc.ranges.shape[1]} beams): {count / t:,.0f} scans/s "
        f"({t / count * 1e6:.1f} us/scan, Python loop included)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="smaller inputs, fewer peers")
    args = ap.parse_args()
    print(
        f"shapely {getattr(shapely, '__version__', 'absent')}, simplification "
        f"{'present' if simplify_coords_idx else 'absent'}"
    )
    rows: list[list[str]] = []
    coastlines(rows)
    random_walk(rows, 100_000 if args.quick else 1_000_000)
    zigzags(rows, [16_000] if args.quick else [16_000, 64_000, 1_000_000])
    print_table(
        "Douglas-Peucker, best of repeats (ratios: peer time / best rperc time)",
        [
            "input",
            "rperc hull",
            "rperc dp/segment",
            "shapely",
            "simplification",
            "vs shapely",
            "vs simpl.",
        ],
        rows,
    )
    many(500 if args.quick else 2000)
    scans(args.quick)


if __name__ == "__main__":
    main()
