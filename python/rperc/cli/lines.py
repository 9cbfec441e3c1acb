"""``rperc demo lines``, ``rperc lines extract`` and ``rperc lines simplify``."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from rperc.datasets import load_carmen
from rperc.linesimp import simplify


def add_demo(demos: argparse._SubParsersAction) -> None:
    p = demos.add_parser("lines", help="simulated laser scan -> walls; a simplified polyline")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="folder for the PNGs")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated noise")
    p.set_defaults(run=demo_lines)


def add_commands(sub: argparse._SubParsersAction) -> None:
    lines = sub.add_parser("lines", help="line simplification and wall extraction")
    cmds = lines.add_subparsers(dest="lines_command", required=True, metavar="COMMAND")

    ex = cmds.add_parser("extract", help="walls from every scan of a CARMEN log")
    ex.add_argument("log", type=Path, help="CARMEN log (FLASER / ROBOTLASER1 lines)")
    ex.add_argument("--plot", type=Path, help="write a PNG of scans and walls in the world frame")
    ex.add_argument("--every", type=int, default=1, help="use every N-th scan (default 1)")
    ex.add_argument("--sigma-range", type=float, default=0.01, help="range noise, m")
    ex.add_argument("--split-epsilon", type=float, default=0.05, help="IEPF split tolerance, m")
    ex.add_argument("--min-points", type=int, default=6, help="fewest points per wall")
    ex.add_argument("--min-length", type=float, default=0.3, help="shortest wall, m")
    ex.set_defaults(run=extract_command)

    si = cmds.add_parser(
        "simplify", help="simplify the lines and polygons of a WKT, GeoJSON or CSV file"
    )
    si.add_argument(
        "file",
        type=Path,
        help="WKT (.wkt/.txt, one geometry per line, EWKT allowed), GeoJSON (.geojson/.json) "
        "or CSV (.csv, x,y[,z] rows, blank lines between polylines)",
    )
    si.add_argument(
        "--epsilon",
        type=float,
        required=True,
        help="tolerance: a distance (units of the data), an area for --method vw",
    )
    si.add_argument("--method", choices=["auto", "hull", "dp", "vw"], default="auto")
    si.add_argument("--metric", choices=["line", "segment"], default="line")
    si.add_argument("--tie", choices=["first", "last"], default="first")
    si.add_argument(
        "--preserve-topology",
        action="store_true",
        help="never create intersections (GEOS's TopologyPreservingSimplifier rules)",
    )
    si.add_argument(
        "-o",
        "--output",
        type=Path,
        help="write .wkt, .geojson/.json or .csv, chosen by the suffix (default: WKT on stdout)",
    )
    si.add_argument("--plot", type=Path, help="write a PNG of input and result")
    si.add_argument(
        "--json", type=Path, help="write a JSON summary: options and point counts per geometry"
    )
    si.set_defaults(run=simplify_command)


def _to_world(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return pts @ np.array([[c, s], [-s, c]]) + pose[:2]


def simplify_command(args: argparse.Namespace) -> int:
    from rperc import _geo
    from rperc.datasets.polylines import (
        format_of,
        read_geometries,
        wkt_line,
        write_geometries,
    )

    if args.output is not None:
        format_of(args.output)  # an unknown suffix fails before any work
    shapely = _geo.shapely_module()
    inputs = read_geometries(args.file)
    results = [
        simplify(
            g,
            args.epsilon,
            method=args.method,
            metric=args.metric,
            tie=args.tie,
            preserve_topology=args.preserve_topology,
        )
        for g in inputs
    ]
    rows = []
    for k, (before, after) in enumerate(zip(inputs, results, strict=True)):
        n_in, n_out = (int(shapely.get_num_coordinates(g)) for g in (before, after))
        rows.append({"index": k, "type": before.geom_type, "points_in": n_in, "points_out": n_out})
        print(f"geometry {k} ({before.geom_type}): {n_in} -> {n_out} points", file=sys.stderr)
    if args.output:
        print(f"wrote {write_geometries(args.output, results)}", file=sys.stderr)
    else:
        for geom in results:
            print(wkt_line(geom))
    if args.plot:
        _plot_simplification(args, inputs, results)
    if args.json:
        args.json.write_text(json.dumps(_summary(args, rows), indent=2) + "\n", encoding="utf-8")
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


def _summary(args: argparse.Namespace, rows: list[dict[str, object]]) -> dict[str, object]:
    """The machine-readable record of one ``lines simplify`` run."""
    if args.preserve_topology or (args.method == "auto" and args.metric == "segment"):
        runs = "dp"
    else:
        runs = "hull" if args.method == "auto" else args.method
    return {
        "command": "lines simplify",
        "input": str(args.file),
        "output": None if args.output is None else str(args.output),
        "epsilon": args.epsilon,
        "method": args.method,
        "method_run": runs,
        "metric": args.metric,
        "tie": args.tie,
        "preserve_topology": args.preserve_topology,
        "points_in": sum(int(str(r["points_in"])) for r in rows),
        "points_out": sum(int(str(r["points_out"])) for r in rows),
        "geometries": rows,
    }


def _plot_simplification(args: argparse.Namespace, inputs: list, results: list) -> None:
    """Every line and ring before and after, drawn as one polyline each way (NaN rows
    separate the parts)."""
    from rperc import _geo
    from rperc.plot import plt, save
    from rperc.plot.lines import draw_polyline

    def joined(geoms: list) -> tuple[np.ndarray, int]:
        parts = [p.coords[:, :2] for g in geoms for p in _geo.linear_parts(g)]
        if not parts:
            return np.zeros((0, 2)), 0
        gaps = [np.vstack([p, np.full((1, 2), np.nan)]) for p in parts]
        return np.vstack(gaps)[:-1], sum(len(p) for p in parts)

    (before, n_in), (after, n_out) = joined(inputs), joined(results)
    fig, ax = plt.subplots(figsize=(7, 7))
    draw_polyline(ax, before, after, args.epsilon)
    # The legend counts points, not the NaN separators.
    lines = ax.get_lines()[-2:]
    lines[0].set_label(f"input ({n_in})")
    lines[1].set_label(f"simplified, eps={args.epsilon:g} ({n_out})")
    ax.legend(loc="best", fontsize=8)
    topology = ", preserve topology" if args.preserve_topology else ""
    ax.set_title(f"{args.file.name}: {args.method}/{args.metric}{topology}")
    print(f"wrote {save(fig, args.plot)}", file=sys.stderr)


def extract_command(args: argparse.Namespace) -> int:
    from rperc.linesimp import extract_lines

    if args.every < 1:
        raise ValueError("--every must be >= 1")
    log = load_carmen(args.log)
    scans = log.scans
    if len(scans) == 0:
        raise ValueError(f"{args.log} holds no laser scans")
    picked = range(0, len(scans), args.every)
    world_walls, world_points = [], []
    count = 0
    for k in tqdm(picked, desc="extracting walls", unit="scan", disable=None):
        n = int(scans.num_beams[k])
        ranges, angles = scans.ranges[k, :n], scans.angles(k)
        walls = extract_lines(
            ranges,
            angles,
            max_range=float(scans.max_range[k]),
            sigma_range=args.sigma_range,
            split_epsilon=args.split_epsilon,
            min_points=args.min_points,
            min_length=args.min_length,
        )
        count += len(walls)
        pose = scans.pose[k]
        if len(walls):
            world_walls.append(
                np.stack([_to_world(pose, walls.start), _to_world(pose, walls.end)], 1)
            )
        ok = np.isfinite(ranges) & (ranges > 0) & (ranges < scans.max_range[k])
        pts = np.c_[ranges[ok] * np.cos(angles[ok]), ranges[ok] * np.sin(angles[ok])]
        world_points.append(_to_world(pose, pts))
    print(
        f"{args.log.name}: {len(picked)} scans, {count} walls "
        f"({count / max(len(picked), 1):.1f} per scan)"
    )
    if args.plot:
        from rperc.plot import plt, save
        from rperc.plot.lines import draw_scan_points, draw_walls

        fig, ax = plt.subplots(figsize=(10, 10))
        pts = np.concatenate(world_points)
        draw_scan_points(ax, pts[:: max(1, len(pts) // 200_000)], s=0.5, alpha=0.4)
        if world_walls:
            segs = np.concatenate(world_walls)
            draw_walls(ax, segs[:, 0], segs[:, 1], linewidths=0.6, alpha=0.7)
        ax.plot(scans.pose[:, 0], scans.pose[:, 1], color="tab:red", lw=1, label="trajectory")
        ax.set_aspect("equal")
        ax.autoscale()
        ax.legend(loc="upper right", markerscale=8)
        ax.set_title(f"{args.log.name}: {count} walls from {len(picked)} scans (world frame)")
        print(f"wrote {save(fig, args.plot)}")
    return 0


def demo_lines(args: argparse.Namespace) -> int:
    from rperc.linesimp import extract_lines
    from rperc.plot import plt, save
    from rperc.plot.lines import draw_polyline, draw_scan_points, draw_walls
    from rperc.scansim import ray_cast, room_walls

    rng = np.random.default_rng(args.seed)
    walls = room_walls()
    pose = np.array([4.0, 2.5, 0.3])
    angles = np.linspace(-math.pi / 2, math.pi / 2, 361)
    scan = ray_cast(walls, pose, angles, max_range=30.0, sigma_range=0.01, rng=rng)
    found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range, sigma_range=0.01)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(14, 6))
    for a, b in walls:
        ax1.plot([a[0], b[0]], [a[1], b[1]], color="0.75", lw=5, solid_capstyle="butt")
    ax1.plot([], [], color="0.75", lw=5, label="true walls")
    ok = scan.wall >= 0
    pts = np.c_[scan.ranges[ok] * np.cos(angles[ok]), scan.ranges[ok] * np.sin(angles[ok])]
    draw_scan_points(ax1, _to_world(pose, pts), s=6)
    draw_walls(ax1, _to_world(pose, found.start), _to_world(pose, found.end))
    ax1.plot(*pose[:2], "k^", ms=9, label="laser")
    ax1.set_aspect("equal")
    ax1.legend(loc="upper left", fontsize=8)
    ax1.set_title(f"simulated 361-beam scan, sigma 1 cm: {len(found)} walls")

    t = np.linspace(0, 6 * math.pi, 2000)
    polyline = np.c_[t * np.cos(t), t * np.sin(t)] + rng.normal(scale=0.05, size=(len(t), 2))
    kept = simplify(polyline, 0.25)
    draw_polyline(ax2, polyline, kept, 0.25)
    ax2.set_title("Douglas-Peucker with path hulls")
    out = save(fig, args.out / "lines.png")

    print(f"{len(found)} walls extracted from a simulated scan of a room with {len(walls)} walls:")
    print(found)
    print(f"spiral of {len(polyline)} points simplified to {len(kept)} at epsilon 0.25")
    print(f"wrote {out}")
    return 0
