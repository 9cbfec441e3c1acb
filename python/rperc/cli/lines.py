"""``rperc lines extract``, ``rperc lines nees``, ``rperc lines simplify`` and the demos
``lines`` (Douglas-Peucker against its input) and ``walls`` (wall extraction against the
ray-cast truth)."""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rperc._atomic import write_text_atomically
from rperc._progress import progress
from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    count_at_least,
    non_negative_float,
    positive_float,
    read_carmen_log,
    write_json,
    wrote,
)
from rperc.linesimp import simplify
from rperc.pose import to_world

if TYPE_CHECKING:
    from rperc.scansim import SimulatedScan, WallCheck


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    lines = sub.add_parser("lines", help="line simplification and wall extraction")
    cmds = lines.add_subparsers(dest="lines_command", required=True, metavar="COMMAND")
    _add_extract(cmds)
    _add_nees(cmds)
    _add_simplify(cmds)


def _add_extract(cmds: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    ex = cmds.add_parser("extract", help="walls from every scan of a CARMEN log")
    ex.add_argument("log", type=Path, help="CARMEN log (FLASER / ROBOTLASER1 lines)")
    ex.add_argument("--plot", type=Path, help="write a figure of scans and walls (world frame)")
    ex.add_argument("--every", type=count_at_least(1), default=1, help="use every N-th scan")
    ex.add_argument("--sigma-range", type=positive_float, default=0.01, help="range noise, m")
    ex.add_argument(
        "--split-epsilon", type=positive_float, default=0.05, help="IEPF split tolerance, m"
    )
    ex.add_argument(
        "--min-points", type=count_at_least(2), default=6, help="fewest points per wall"
    )
    ex.add_argument("--min-length", type=positive_float, default=0.3, help="shortest wall, m")
    add_json_option(ex)
    ex.set_defaults(run=extract_command)


def _add_nees(cmds: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    ne = cmds.add_parser(
        "nees",
        help="NEES of walls seen in consecutive scans of a CARMEN log (world frame, "
        "logged poses): 2 on average when the wall covariances are honest",
    )
    ne.add_argument("log", type=Path, help="CARMEN log (FLASER / ROBOTLASER1 lines)")
    ne.add_argument("--sigma-range", type=positive_float, default=0.01, help="range noise, m")
    ne.add_argument(
        "--pose-sigma-xy", type=non_negative_float, default=0.0, help="pose sd per axis, m"
    )
    ne.add_argument(
        "--pose-sigma-theta", type=non_negative_float, default=0.0, help="heading sd, degrees"
    )
    ne.add_argument(
        "--straightness",
        type=non_negative_float,
        default=None,
        metavar="M",
        help="perpendicular error of each wall end, m, added to every wall (default: the "
        "wall SLAM's calibrated floor for real logs, rperc.slam.wallslam.STRAIGHTNESS; "
        "0 for the fit's covariance alone)",
    )
    ne.add_argument(
        "--no-model-error",
        action="store_true",
        help="covariance from the range noise alone, without the residual floor",
    )
    add_json_option(ne)
    ne.set_defaults(run=nees_command)


def _add_simplify(cmds: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
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
        check_output_file(args.output, "-o")
    check_output_file(args.plot, "--plot", figure=True)
    check_output_file(args.json, "--json")
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
        write_text_atomically(args.json, json.dumps(_summary(args, rows), indent=2) + "\n")
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


def _plot_simplification(args: argparse.Namespace, inputs: list[Any], results: list[Any]) -> None:
    """Every line and ring before and after, drawn as one polyline each way (NaN rows
    separate the parts)."""
    from matplotlib.figure import Figure

    from rperc import _geo
    from rperc.plot import robust_limits, save, set_limits
    from rperc.plot.lines import draw_polyline

    def joined(geoms: list[Any]) -> tuple[np.ndarray, int]:
        parts = [p.coords[:, :2] for g in geoms for p in _geo.linear_parts(g)]
        if not parts:
            return np.zeros((0, 2)), 0
        gaps = [np.vstack([p, np.full((1, 2), np.nan)]) for p in parts]
        return np.vstack(gaps)[:-1], sum(len(p) for p in parts)

    (before, n_in), (after, n_out) = joined(inputs), joined(results)
    fig = Figure(figsize=(7, 7), layout="constrained")
    ax = fig.add_subplot()
    draw_polyline(ax, before, after, args.epsilon)
    # A map: one unit is as long across as up (a coastline's shape otherwise
    # stretches), in the file's own coordinates, whose unit the file does not state.
    if len(before):
        set_limits(ax, robust_limits(before, include=before))
    ax.set_xlabel("x [units of the input]")
    ax.set_ylabel("y [units of the input]")
    ax.grid(alpha=0.3)
    # The legend counts points, not the NaN separators.
    lines = ax.get_lines()[-2:]
    lines[0].set_label(f"input ({n_in})")
    lines[1].set_label(f"simplified, eps={args.epsilon:g} ({n_out})")
    ax.legend(loc="best", fontsize=8)
    topology = ", preserve topology" if args.preserve_topology else ""
    ax.set_title(f"{args.file.name}: {args.method}/{args.metric}{topology}")
    print(f"wrote {save(fig, args.plot)}", file=sys.stderr)


def _walls_of_log(
    args: argparse.Namespace,
) -> tuple[dict[str, Any], np.ndarray, np.ndarray, np.ndarray]:
    """Extract the walls of every ``--every``-th scan; the counts, the world-frame
    wall segments (K, 2, 2), the world-frame readings (M, 2) and the logged laser
    trajectory (S, 2)."""
    from rperc.linesimp import extract_lines

    scans = read_carmen_log(args.log).scans
    if len(scans) == 0:
        raise ValueError(f"{args.log} holds no laser scans")
    picked = range(0, len(scans), args.every)
    segments, points = [np.zeros((0, 2, 2))], [np.zeros((0, 2))]
    walls = on_walls = valid = 0
    for k in progress(picked, desc="extracting walls", unit="scan"):
        n = int(scans.num_beams[k])
        ranges, angles = scans.ranges[k, :n], scans.angles(k)
        found = extract_lines(
            ranges,
            angles,
            max_range=float(scans.max_range[k]),
            sigma_range=args.sigma_range,
            split_epsilon=args.split_epsilon,
            min_points=args.min_points,
            min_length=args.min_length,
        )
        world = found.to_world(scans.pose[k])
        segments.append(np.stack([world.start, world.end], axis=1))
        ok = np.isfinite(ranges) & (ranges > 0) & (ranges < scans.max_range[k])
        pts = np.c_[ranges[ok] * np.cos(angles[ok]), ranges[ok] * np.sin(angles[ok])]
        points.append(to_world(scans.pose[k], pts))
        walls += len(found)
        on_walls += len(found.flat_indices)
        valid += int(ok.sum())
    counts = {
        "log": args.log,
        "scans": len(picked),
        "walls": walls,
        "walls_per_scan": walls / len(picked),
        "readings": valid,
        "readings_on_walls": on_walls / max(valid, 1),
    }
    return counts, np.concatenate(segments), np.concatenate(points), scans.pose[:, :2]


def nees_command(args: argparse.Namespace) -> int:
    from rperc.wallcheck import consecutive_wall_nees, reading_shares

    check_output_file(args.json, "--json")
    log = read_carmen_log(args.log)
    print(log.summary(), file=sys.stderr)
    sd = np.array([args.pose_sigma_xy, args.pose_sigma_xy, math.radians(args.pose_sigma_theta)])
    pose_cov = np.diag(sd**2) if sd.any() else None
    from rperc.slam.wallslam import STRAIGHTNESS

    straightness = STRAIGHTNESS if args.straightness is None else args.straightness
    result = consecutive_wall_nees(
        log.scans,
        pose_cov=pose_cov,
        straightness=straightness,
        sigma_range=args.sigma_range,
        model_error=not args.no_model_error,
    )
    print(f"{args.log.name}: {result} (straightness floor {100 * straightness:.2f} cm)")
    shares = reading_shares(log.scans, sigma_range=args.sigma_range)
    valid = max(shares["valid"], 1)
    print(
        f"{args.log.name}: of {shares['valid']} valid readings "
        + ", ".join(
            f"{100 * shares[key] / valid:.1f} % {key.replace('_', ' ')}"
            for key in ("on_walls", "short_walls", "sparse", "isolated")
        )
        + f" ({shares['invalid']} invalid)"
    )
    write_json(
        args.json,
        {
            "readings": shares,
            "log": args.log,
            "pose_sigma_xy": args.pose_sigma_xy,
            "pose_sigma_theta_deg": args.pose_sigma_theta,
            "model_error": not args.no_model_error,
            "straightness_m": straightness,
            **result.as_dict(),
        },
    )
    return 0


def extract_command(args: argparse.Namespace) -> int:
    check_output_file(args.plot, "--plot", figure=True)
    check_output_file(args.json, "--json")
    counts, segments, points, trajectory = _walls_of_log(args)
    summary = (
        f"{args.log.name}: {counts['walls']} walls from {counts['scans']} scans "
        f"({counts['walls_per_scan']:.1f} per scan), "
        f"{100 * counts['readings_on_walls']:.0f}% of the valid readings on a wall"
    )
    print(summary)
    if args.plot:
        from rperc.plot import save
        from rperc.plot.lines import world_walls_figure

        fig = world_walls_figure(points, segments, trajectory, title=f"{summary} (world frame)")
        wrote(save(fig, args.plot))
    write_json(args.json, counts)
    return 0


def chord_deviation(points: np.ndarray, kept: np.ndarray) -> tuple[float, float]:
    """The largest distance of an input point from the chord that replaced it: to the
    chord's line (what Douglas-Peucker bounds by epsilon, seed Table 2) and to the
    chord segment (what the drawn simplification shows)."""
    worst_line = worst_segment = 0.0
    for i, j in itertools.pairwise(kept):
        a, b, p = points[i], points[j], points[i + 1 : j]
        if len(p) == 0:
            continue
        d, rel = b - a, p - a
        length2 = float(d @ d)
        # A closed chord (a == b) has no line: both distances are to the point a.
        t = np.clip((rel @ d) / length2, 0.0, 1.0) if length2 > 0 else np.zeros(len(p))
        seg = np.hypot(*(rel - t[:, None] * d).T)
        line = (
            np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / math.sqrt(length2) if length2 > 0 else seg
        )
        worst_line = max(worst_line, float(line.max()))
        worst_segment = max(worst_segment, float(seg.max()))
    return worst_line, worst_segment


SPIRAL_POINTS = 2000
SPIRAL_NOISE = 0.05  # m
SPIRAL_EPSILON = 0.25  # m


def noisy_spiral(seed: int) -> np.ndarray:
    """Three turns of an Archimedean spiral (metres) with seeded Gaussian jitter."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 6 * math.pi, SPIRAL_POINTS)
    spiral: np.ndarray = np.c_[t * np.cos(t), t * np.sin(t)]
    return spiral + rng.normal(scale=SPIRAL_NOISE, size=(len(t), 2))


def demo_lines(out: Path, seed: int) -> DemoResult:
    """Douglas-Peucker (path hulls) on a seeded noisy spiral; the deviation of the
    input from the simplification against epsilon."""
    from rperc.plot import save
    from rperc.plot.lines import polyline_figure

    spiral = noisy_spiral(seed)
    epsilon = SPIRAL_EPSILON
    kept = simplify(spiral, epsilon, return_indices=True)
    line_dev, segment_dev = chord_deviation(spiral, kept)
    verdict = "within" if line_dev <= epsilon else "EXCEEDS"
    summary = (
        f"lines: noisy spiral of {len(spiral)} points simplified to {len(kept)} at epsilon "
        f"{epsilon:g} m; max deviation of an input point from its chord's line "
        f"{line_dev:.4f} m ({verdict} epsilon), from the chord segment {segment_dev:.4f} m"
    )
    title = (
        f"Douglas-Peucker with path hulls: {len(spiral)} -> {len(kept)} points, "
        f"epsilon {epsilon:g} m\nmax deviation of the input: {line_dev:.4f} m from the "
        f"chord's line, {segment_dev:.4f} m from the segment"
    )
    fig = polyline_figure([spiral], [spiral[kept]], epsilon, title=title, unit="m")
    figures = [save(fig, out / "lines.png")]
    measured = {
        "points": len(spiral),
        "kept": len(kept),
        "epsilon": epsilon,
        "max_line_deviation": line_dev,
        "max_segment_deviation": segment_dev,
        "kept_indices": kept,
    }
    return DemoResult(summary, figures, measured)


WALLS_POSE = np.array([4.0, 2.5, 0.3])
WALLS_BEAMS = 361
WALLS_SIGMA = 0.01  # range noise of the simulated scanner, m
WALLS_MIN_POINTS = 6


def room_scan(seed: int) -> tuple[np.ndarray, SimulatedScan]:
    """The demo room's walls and a seeded noisy 180-degree scan of it from WALLS_POSE."""
    from rperc.scansim import ray_cast, room_walls

    walls = room_walls()
    angles = np.linspace(-math.pi / 2, math.pi / 2, WALLS_BEAMS)
    rng = np.random.default_rng(seed)
    return walls, ray_cast(walls, WALLS_POSE, angles, sigma_range=WALLS_SIGMA, rng=rng)


def demo_walls(out: Path, seed: int) -> DemoResult:
    """Walls from a simulated 180-degree scan of a known room, matched to the ray-cast
    truth: which walls the scanner can see, which were found, and their errors."""
    from rperc.linesimp import extract_lines
    from rperc.plot import save
    from rperc.plot.lines import walls_figure
    from rperc.scansim import check_walls

    walls, scan = room_scan(seed)
    found = extract_lines(
        scan.ranges,
        scan.angles,
        max_range=scan.max_range,
        sigma_range=WALLS_SIGMA,
        min_points=WALLS_MIN_POINTS,
    )
    check = check_walls(
        walls, scan, found.indices, found.rho, found.alpha, min_points=WALLS_MIN_POINTS
    )
    summary = _walls_summary(check, len(found), len(walls))
    head, _, tail = summary.removeprefix("walls: ").partition(", max")
    fig = walls_figure(walls, scan, found, check, title=f"{head}\nmax{tail}")
    figures = [save(fig, out / "walls.png")]
    measured = {
        "beams": WALLS_BEAMS,
        "walls": len(walls),
        "visible": check.visible,
        "hidden": check.hidden,
        "missed": check.missed,
        "found_truth": check.truth,
        "d_rho_m": check.d_rho,
        "d_alpha_rad": check.d_alpha,
        "max_abs_d_rho_m": _max_abs(check.d_rho),
        "max_abs_d_alpha_rad": _max_abs(check.d_alpha),
    }
    return DemoResult(summary, figures, measured, details=[repr(found)])


def _max_abs(values: np.ndarray) -> float:
    finite = np.abs(values[np.isfinite(values)])
    return float(finite.max()) if len(finite) else math.nan


def _walls_summary(check: WallCheck, n_found: int, n_walls: int) -> str:
    spurious = int(np.count_nonzero(check.truth < 0))
    extra = f", {spurious} spurious" if spurious else ""
    return (
        f"walls: {check.found_visible} of {len(check.visible)} visible walls found in a "
        f"simulated {WALLS_BEAMS}-beam scan ({n_found} segments{extra}; "
        f"{len(check.hidden)} of {n_walls} walls not visible from the pose), "
        f"max |d rho| {1e3 * _max_abs(check.d_rho):.1f} mm, "
        f"max |d alpha| {math.degrees(_max_abs(check.d_alpha)):.2f} deg"
    )
