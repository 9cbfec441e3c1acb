"""rperc line simplification against shapely (GEOS) and the simplification package
(geo), all in the same run, with ratios.

    python benchmarks/linesimp.py [--quick]

Worst cases: three families on which plain Douglas-Peucker splits one vertex off per
level (quadratic time, recursion as deep as the input), after Hershberger & Snoeyink's
analysis of DP's worst case. All three are simple chains:

- zig-zag: V_k = (k, (-1)^k k), integers; every chord's farthest vertex is the one
  next to its far end;
- shrinking zig-zag: V_k = (k, (-1)^k (n - k)); the farthest vertex is the one next to
  the near end (the mirror case: path hulls roll back the other half);
- convex zig-zag: V_k = (k/n, (-1)^k (k/n)^2); the peaks lie on two parabolas, so every
  vertex is a corner of the hull (binary searches on large hulls, non-integer data).

They run at n = 10^3 .. 10^6 with epsilon 1e-9 of the extent (everything is kept).
Peers run in a subprocess with a timeout, so a stack overflow or a hang is reported,
not fatal. Growth exponents are least-squares slopes of log time against log n over
n >= 10^4 (over every size that ran, for peers that crash beyond 10^4). Memory per
point is the peak resident-set growth of a subprocess during one call at n = 10^6,
divided by n.
"""

from __future__ import annotations

import argparse
import os
import subprocess
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


FAMILIES = {
    "zig-zag": ("k = np.arange(n, dtype=float)\npts = np.c_[k, np.where(k % 2 == 0, k, -k)]\n"),
    "shrinking zig-zag": (
        "k = np.arange(n, dtype=float)\npts = np.c_[k, np.where(k % 2 == 0, n - k, k - n)]\n"
    ),
    "convex zig-zag": (
        "t = np.arange(n, dtype=float) / n\n"
        "pts = np.c_[t, np.where(np.arange(n) % 2 == 0, t * t, -t * t)]\n"
    ),
}


def family(name: str, n: int) -> np.ndarray:
    scope: dict = {"np": np, "n": n}
    exec(FAMILIES[name], scope)  # the same code the peer subprocesses run
    return scope["pts"]


def tolerance(pts: np.ndarray) -> float:
    return 1e-9 * float(np.ptp(pts, axis=0).max())


def peer_times(name: str, n: int, eps: float, timeout: float) -> dict[str, tuple]:
    setup = f"import numpy as np\nn = {n}\n" + FAMILIES[name]
    out: dict[str, tuple] = {"shapely": (None, "not installed"), "simpl.": (None, "not installed")}
    if shapely is not None:
        out["shapely"] = time_in_subprocess(
            setup + "import shapely\nline = shapely.LineString(pts)",
            f"shapely.simplify(line, {eps!r}, preserve_topology=False)",
            timeout=timeout,
        )
    if simplify_coords_idx is not None:
        out["simpl."] = time_in_subprocess(
            setup + "from simplification.cutil import simplify_coords_idx",
            f"simplify_coords_idx(pts, {eps!r})",
            timeout=timeout,
        )
    return out


def growth(ns: list[int], ts: list[float | None]) -> str:
    """Least-squares slope of log time on log n over the sizes n >= 1e4 that ran (or
    over all that ran when fewer than two of those did), with the range used."""
    pairs = [(n, t) for n, t in zip(ns, ts, strict=True) if t]
    big = [p for p in pairs if p[0] >= 10_000]
    pairs = big if len(big) >= 2 else pairs
    if len(pairs) < 2:
        return "-"
    x, y = np.log([p[0] for p in pairs]), np.log([p[1] for p in pairs])
    return f"n^{np.polyfit(x, y, 1)[0]:.2f} ({pairs[0][0]:.0e}..{pairs[-1][0]:.0e})"


def worst_cases(sizes: list[int], dp_max: int, timeout: float) -> None:
    rows, exps = [], []
    for name in FAMILIES:
        times: dict[str, list[float | None]] = {k: [] for k in ("hull", "dp", "shapely", "simpl.")}
        for n in sizes:
            pts = family(name, n)
            eps = tolerance(pts)
            hull = best_time(lambda pts=pts, eps=eps: simplify(pts, eps, return_indices=True))
            dp = None
            if n <= dp_max:
                dp = best_time(
                    lambda pts=pts, eps=eps: simplify(pts, eps, method="dp", return_indices=True),
                    repeat=1,
                    min_time=0.0,
                )
            peers = peer_times(name, n, eps, timeout)
            for key, t in (("hull", hull), ("dp", dp)):
                times[key].append(t)
            for key in ("shapely", "simpl."):
                times[key].append(peers[key][0])
            rows.append(
                [
                    f"{name} n={n:.0e}",
                    fmt_seconds(hull),
                    fmt_seconds(dp, "skipped (quadratic)"),
                    fmt_seconds(*peers["shapely"]),
                    fmt_seconds(*peers["simpl."]),
                    ratio(peers["shapely"][0], hull),
                    ratio(peers["simpl."][0], hull),
                ]
            )
        exps.append([name, *(growth(sizes, times[k]) for k in ("hull", "dp", "shapely", "simpl."))])
    print_table(
        "Worst cases for plain DP (ratios: peer time / rperc hull time)",
        ["input", "rperc hull", "rperc dp", "shapely", "simplification", "vs shapely", "vs simpl."],
        rows,
    )
    print_table(
        "Growth of time with n (least-squares exponent, over the sizes shown)",
        ["family", "rperc hull", "rperc dp", "shapely", "simplification"],
        exps,
    )


MEMORY = """
import numpy as np
from rperc.linesimp import simplify
n = {n}
{setup}
def status(key):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key))
simplify(pts[:1000], 0.0)  # load everything first
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # reset the peak resident set to the current one
before = status("VmRSS:")
idx = simplify(pts, {eps!r}, method={method!r}, return_indices=True)
print((status("VmHWM:") - before) / n, len(idx))
"""


def memory(n: int) -> None:
    print(f"\n## Peak memory during one call, n = {n:.0e} (input excluded)")
    walk = "pts = np.cumsum(np.random.default_rng(0).normal(size=(n, 2)), axis=0)\n"
    for label, setup, eps, method in [
        ("zig-zag (all kept), hull", FAMILIES["zig-zag"], 1e-9, "hull"),
        ("convex zig-zag (all kept), hull", FAMILIES["convex zig-zag"], 0.0, "hull"),
        ("random walk eps=5 (1.4% kept), hull", walk, 5.0, "hull"),
        ("random walk eps=5, dp", walk, 5.0, "dp"),
    ]:
        code = MEMORY.format(n=n, setup=setup, eps=eps, method=method)
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if out.returncode != 0:
            print(f"{label}: failed ({out.stderr.strip().splitlines()[-1:]})")
            continue
        per_point, kept = out.stdout.split()
        print(f"{label:38s} {float(per_point):6.1f} B/point ({int(kept):,} kept)")


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
    if args.quick:
        worst_cases([1_000, 10_000, 30_000], dp_max=30_000, timeout=60)
    else:
        worst_cases([1_000, 10_000, 100_000, 1_000_000], dp_max=100_000, timeout=120)
    memory(100_000 if args.quick else 1_000_000)
    many(500 if args.quick else 2000)
    scans(args.quick)


if __name__ == "__main__":
    main()
