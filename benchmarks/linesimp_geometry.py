"""Visvalingam-Whyatt and topology-preserving simplification against their peers
(the simplification package, shapely/GEOS), in the same run, with ratios and a check
that both sides kept the same vertices.

    python benchmarks/linesimp_geometry.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import best_time, fmt_seconds, print_table

from rperc.datasets import data_dir, read_polylines
from rperc.linesimp import simplify

try:
    import shapely
except ImportError:  # pragma: no cover - optional peer
    shapely = None
try:
    from simplification.cutil import simplify_coords_vw_idx
except ImportError:  # pragma: no cover - optional peer
    simplify_coords_vw_idx = None


def ratio(peer: float | None, ours: float) -> str:
    return f"{peer / ours:7.1f}x" if peer else "   -"


def coastlines() -> list[tuple[str, np.ndarray]]:
    root = data_dir()
    if root is None:
        print("(no data folder: coastlines skipped)")
        return []
    return [
        (name.split(".")[0], read_polylines(root / "polylines" / name)[0])
        for name in ("louisiana.wkt", "norway_main.wkt")
    ]


def vw_rows(quick: bool) -> list[list[str]]:
    walk = np.cumsum(np.random.default_rng(0).normal(size=(10**5 if quick else 10**6, 2)), 0)
    cases = [(n, p, a) for n, p in coastlines() for a in (1e-4, 1e-2)] + [("walk", walk, 1.0)]
    rows = []
    for name, pts, area in cases:
        ours = best_time(lambda p=pts, a=area: simplify(p, a, method="vw", return_indices=True))
        peer = same = None
        if simplify_coords_vw_idx is not None:
            peer = best_time(lambda p=pts, a=area: simplify_coords_vw_idx(p, a))
            kept = simplify(pts, area, method="vw", return_indices=True)
            same = np.array_equal(kept, np.asarray(simplify_coords_vw_idx(pts, area)))
        rows.append(
            [
                f"{name} n={len(pts)} area={area:g}",
                fmt_seconds(ours),
                fmt_seconds(peer),
                ratio(peer, ours),
                {None: "-", True: "same", False: "ties differ"}[same],
            ]
        )
    return rows


def islands(count: int, seed: int = 1):
    """A MultiPolygon of rough disjoint islands on a grid, each with a lake."""
    rng = np.random.default_rng(seed)
    polygons = []
    side = int(np.ceil(np.sqrt(count)))
    for k in range(count):
        centre = np.array([k % side, k // side]) * 30.0
        t = np.sort(rng.uniform(0, 2 * np.pi, 150))
        r = 10 * (1 + 0.15 * rng.standard_normal(150).clip(-2, 2))
        shell = centre + np.c_[r * np.cos(t), r * np.sin(t)]
        lake = centre + 3 * np.c_[np.cos(t[::5]), np.sin(t[::5])]
        polygons.append(shapely.Polygon(shell, [lake]))
    return shapely.MultiPolygon([p for p in polygons if p.is_valid])


def topology_rows(quick: bool) -> list[list[str]]:
    if shapely is None:
        return []
    cases = [(f"{n} polygon", shapely.Polygon(p), e) for n, p in coastlines() for e in (0.01, 0.1)]
    many = islands(200 if quick else 2000)
    cases.append((f"{len(many.geoms)} islands with lakes", many, 0.5))
    rows = []
    for name, geom, eps in cases:
        ours = best_time(
            lambda g=geom, e=eps: simplify(g, e, metric="segment", preserve_topology=True),
            repeat=3,
        )
        peer = best_time(
            lambda g=geom, e=eps: shapely.simplify(g, e, preserve_topology=True), repeat=3
        )
        got = simplify(geom, eps, metric="segment", preserve_topology=True)
        same = shapely.equals_exact(got, shapely.simplify(geom, eps, preserve_topology=True), 0.0)
        rows.append(
            [
                f"{name} n={shapely.get_num_coordinates(geom)} eps={eps:g}",
                fmt_seconds(ours),
                fmt_seconds(peer),
                ratio(peer, ours),
                "same" if same else "DIFFERENT",
                "valid" if got.is_valid else "INVALID",
            ]
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller inputs")
    args = parser.parse_args()
    print_table(
        "Visvalingam-Whyatt: rperc vs simplification (geo)",
        ["input", "rperc", "simplification", "peer/rperc", "kept vertices"],
        vw_rows(args.quick),
    )
    rows = topology_rows(args.quick)
    if rows:
        print_table(
            "Topology-preserving DP: rperc (geometry in and out) vs shapely",
            ["input", "rperc", "shapely", "peer/rperc", "vertices", "result"],
            rows,
        )


if __name__ == "__main__":
    main()
