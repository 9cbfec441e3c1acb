"""``rperc slam laser LOG``: laser SLAM (scan matching, loop closures, a pose graph)
on a CARMEN log, from odometry made from its corrected path with seeded noise (the
experiment of ``rperc slam walls``; see :mod:`rperc.slam.laser`)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    print_measured,
    read_carmen_log,
    seed_type,
    write_json,
    wrote,
)
from rperc.slam.laser import VARIANTS, from_settings, run_laser


def add_laser_command(kinds: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    w = kinds.add_parser("laser", help="CARMEN log: scan matching, loop closures, pose graph")
    w.add_argument("log", type=Path, help="CARMEN log (.log or .gz) whose poses are corrected")
    w.add_argument("--seed", type=seed_type, default=0, help="the odometry noise draw")
    w.add_argument(
        "--variant",
        choices=tuple(VARIANTS),
        default="loops",
        help="loops (the default), walls (loops with wall landmarks), scan-matching (no closures) "
        "or odometry",
    )
    w.add_argument(
        "--config",
        type=json.loads,
        default={},
        metavar="JSON",
        help='settings overrides, nested by part, e.g. \'{"icp": {"sigma": 0.02}}\'',
    )
    w.add_argument("--tum", type=Path, help="write every scan's final pose (TUM format, for evo)")
    w.add_argument("--plot", type=Path, help="write the map figure")
    add_json_option(w)
    w.set_defaults(run=laser_command)


def laser_command(args: argparse.Namespace) -> int:
    for path, option, figure in (
        (args.tum, "--tum", False),
        (args.plot, "--plot", True),
        (args.json, "--json", False),
    ):
        check_output_file(path, option, figure=figure)
    if not isinstance(args.config, dict):
        raise ValueError("--config must be a JSON object")
    t0 = time.perf_counter()
    log = read_carmen_log(args.log)
    read_s = time.perf_counter() - t0
    config, start = from_settings(args.config)
    result = run_laser(
        log, seed=args.seed, variant=args.variant, config=config, read_seconds=read_s, **start
    )
    # The range the scans were read with, and whether the log's PARAM was set aside
    # (rperc.datasets.carmen: the readings contradicted it).
    measured = {
        **result.measured(),
        "max_range_m": float(np.max(log.scans.max_range)) if len(log.scans) else math.nan,
        "max_range_param_set_aside": bool(log.max_range_contradicted),
    }
    print_measured(measured)
    if args.tum is not None:
        wrote(result.to_tum(args.tum))
    if args.plot is not None:
        from rperc.plot import save
        from rperc.plot.laser import laser_map_figure, scan_cloud

        fig = laser_map_figure(result, scan_cloud(log, result.pose))
        wrote(save(fig, args.plot))
    write_json(args.json, measured)
    sys.stdout.flush()
    return 0


def demo_laser_slam(out: Path, seed: int) -> DemoResult:
    """Laser SLAM on the simulated corridor loop (two laps, 1 cm range noise) from one
    noisy odometry draw: the default pipeline and the ``walls`` variant, scored
    against the simulator's true path; the figure is the ``walls`` run's map, its
    wall landmarks drawn as estimated."""
    import tempfile

    from rperc.datasets.carmen import load_carmen
    from rperc.plot import save
    from rperc.plot.laser import laser_map_figure, scan_cloud
    from rperc.scansim import write_loop_log

    with tempfile.TemporaryDirectory() as tmp:
        log = load_carmen(write_loop_log(Path(tmp) / "loop.log", seed=seed))
    runs = {v: run_laser(log, seed=seed, variant=v) for v in ("loops", "walls")}
    plain, walls = runs["loops"].metrics, runs["walls"].metrics
    title = (
        f"laser SLAM, simulated corridor loop, odometry seed {seed}: "
        f"ATE {walls['ate_rmse_m']:.3f} m with wall landmarks "
        f"({plain['ate_rmse_m']:.3f} m without), "
        f"NEES mean {walls['nees_mean']:.2f}"
    )
    fig = laser_map_figure(runs["walls"], scan_cloud(log, runs["walls"].pose), title=title)
    path = save(fig, out / "laser_slam.png")
    summary = (
        f"laser-slam: simulated corridor loop, {len(log.scans)} scans, ATE "
        f"{plain['ate_rmse_m']:.3f} / {walls['ate_rmse_m']:.3f} m (default / wall landmarks), "
        f"robot NEES mean {plain['nees_mean']:.2f} / {walls['nees_mean']:.2f} (3 expected), "
        f"{runs['walls'].counts['wall_landmarks']} walls, "
        f"{runs['loops'].counts['loop_closures_accepted']} closures"
    )
    return DemoResult(summary, [path], {"seed": seed, **{v: r.measured() for v, r in runs.items()}})
