"""``rperc slam walls LOG``: wall-landmark EKF-SLAM on a CARMEN log from odometry
made from its corrected path with seeded noise (paper [000]'s Fig. 7 experiment, see
:mod:`rperc.slam.wallslam`), and ``rperc demo wall-slam`` on a simulated loop."""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    count_at_least,
    non_negative_float,
    print_measured,
    read_carmen_log,
    seed_type,
    write_json,
    wrote,
)
from rperc.slam.wallslam import (
    ASSOCIATION,
    ASSOCIATIONS,
    STRAIGHTNESS,
    WallSlamResult,
    WallsOptions,
    run_walls,
)

if TYPE_CHECKING:
    from rperc.config import PlanarConfigOverrides
    from rperc.datasets.carmen import CarmenLog


def add_walls_command(kinds: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    w = kinds.add_parser("walls", help="CARMEN log: walls as landmarks, odometry from its path")
    w.add_argument("log", type=Path, help="CARMEN log (.log or .gz) whose poses are corrected")
    w.add_argument("--anchor", action="store_true", help="the first wall is the anchor")
    w.add_argument(
        "--freeze", type=count_at_least(1), metavar="N",
        help="walls revised more than N times leave the state (the seed uses 50)",
    )  # fmt: skip
    w.add_argument(
        "--straightness", type=non_negative_float, default=STRAIGHTNESS, metavar="SIGMA",
        help=f"straightness floor (m) added to every wall sighting (default {STRAIGHTNESS}, "
        "calibrated on ACES by benchmarks/wall_straightness.py; 0 turns it off)",
    )  # fmt: skip
    w.add_argument(
        "--association", choices=ASSOCIATIONS, default=ASSOCIATION,
        help=f"data association: nearest neighbours or joint compatibility (default "
        f"{ASSOCIATION})",
    )  # fmt: skip
    w.add_argument("--seed", type=seed_type, default=0, help="the odometry noise draw")
    w.add_argument(
        "--smooth", action="store_true",
        help="also smooth the run (every pose, wall and bias from all of the scans, with "
        "the filter's association): smoothed_* metrics, and a second map in --plot",
    )  # fmt: skip
    w.add_argument("--tum", type=Path, help="write the estimated path (TUM format, for evo)")
    w.add_argument(
        "--smoothed-tum", type=Path, metavar="PATH",
        help="write the smoothed path (TUM format; needs --smooth)",
    )  # fmt: skip
    w.add_argument("--plot", type=Path, help="write the map figure")
    add_json_option(w)
    w.set_defaults(run=walls_command)


def walls_command(args: argparse.Namespace) -> int:
    for path, option, figure in (
        (args.tum, "--tum", False), (args.plot, "--plot", True), (args.json, "--json", False),
        (args.smoothed_tum, "--smoothed-tum", False),
    ):  # fmt: skip
        check_output_file(path, option, figure=figure)
    if args.smoothed_tum is not None and not args.smooth:
        print("error: --smoothed-tum needs --smooth", file=sys.stderr)
        return 2
    log = read_carmen_log(args.log)
    result = run_walls(
        log, seed=args.seed, anchor=args.anchor, freeze_after=args.freeze,
        show_progress=True, straightness=args.straightness, association=args.association,
        smooth=args.smooth,
    )  # fmt: skip
    metrics = result.measured()
    print_measured(metrics)
    if args.tum is not None:
        wrote(result.to_tum(args.tum))
    if args.smoothed_tum is not None:
        wrote(result.smoothed().to_tum(args.smoothed_tum))
    if args.plot is not None:
        from rperc.plot import save
        from rperc.plot.wallslam import wall_maps_figure

        name = "anchored" if args.anchor else "plain"
        name += f", frozen after {args.freeze}" if args.freeze else ""
        runs = [(name, result)]
        if result.smoothing is not None:
            runs.append((f"{name}, smoothed", result.smoothed()))
        fig = wall_maps_figure(
            runs, title=f"{result.log}, odometry seed {args.seed}: estimate vs "
            "the log's corrected path", reference_label="corrected path (reference)",
        )  # fmt: skip
        wrote(save(fig, args.plot))
    write_json(args.json, metrics)
    sys.stdout.flush()
    return 0


DEMO_RUNS: dict[str, WallsOptions] = {
    "odometry": {"use_walls": False},
    "plain": {},
    "anchored+freeze50": {"anchor": True, "freeze_after": 50},
}


def demo_wall_slam(out: Path, seed: int) -> DemoResult:
    """Fig. 7 on a simulated corridor loop (two laps, 1 cm range noise): odometry
    alone, plain wall SLAM and anchored with freezing, from one noisy odometry draw;
    and, when the data folder holds it, the same on the Intel log against its
    corrected path (``wall_slam_fig7_intel.png``)."""
    from rperc.datasets.carmen import load_carmen
    from rperc.scansim import loop_walls, write_loop_log

    with tempfile.TemporaryDirectory() as tmp:
        log = load_carmen(write_loop_log(Path(tmp) / "loop.log", seed=seed))
    runs, path = _fig7(
        log, seed, 0.0, out / "wall_slam_fig7.png", "simulated corridor loop", loop_walls()
    )
    ates = " / ".join(f"{r.metrics['ate_rmse']:.3f}" for r in runs.values())
    loops = " / ".join(f"{r.metrics['loop_error']:.3f}" for r in runs.values())
    plain = runs["plain"]
    summary = (
        f"wall-slam: simulated corridor loop, {len(plain.pose)} scans, ATE {ates} m, "
        f"loop error {loops} m (odometry / plain / anchored+freeze50 / plain smoothed), "
        "plain robot NEES "
        f"mean {plain.metrics['nees_mean']:.2f} (3 expected), {len(plain.wall_id)} walls"
    )
    measured_runs: dict[str, object] = {"seed": seed, **{n: r.measured() for n, r in runs.items()}}
    paths = [path]
    intel = _intel_log()
    if intel is not None:
        real, real_path = _fig7(
            read_carmen_log(intel), seed, STRAIGHTNESS, out / "wall_slam_fig7_intel.png",
            "intel.log",
        )  # fmt: skip
        paths.append(real_path)
        summary += "; intel.log (corrected path as reference): " + ", ".join(
            f"{n} {r.metrics['ate_rmse']:.3f} m" for n, r in real.items()
        )
        measured_runs["intel"] = {n: r.measured() for n, r in real.items()}
    return DemoResult(summary, paths, measured_runs)


def _intel_log() -> Path | None:
    """The Intel log in the data folder, if there is one."""
    from rperc.datasets._paths import data_dir

    root = data_dir()
    path = None if root is None else root / "carmen" / "intel.log"
    return path if path is not None and path.is_file() else None


def _fig7(
    log: CarmenLog,
    seed: int,
    straightness: float,
    path: Path,
    what: str,
    true_walls: Any = None,
) -> tuple[dict[str, WallSlamResult], Path]:
    """The three Fig. 7 runs over one log and their figure (with the true walls when
    the world is simulated)."""
    from rperc.plot import save
    from rperc.plot.wallslam import wall_maps_figure
    from rperc.slam.wallslam import prepare, run_prepared

    prepared = prepare(log, straightness=straightness)
    runs = {
        name: run_prepared(
            prepared,
            seed=seed,
            smooth=name == "plain",
            use_walls=kw.get("use_walls", True),
            **_overrides(kw),
        )
        for name, kw in DEMO_RUNS.items()
    }
    # The batch smoothing of the plain run: every pose from all of the scans.
    runs["plain, smoothed"] = runs["plain"].smoothed()
    ates = " / ".join(f"{r.metrics['ate_rmse']:.3f}" for r in runs.values())
    reference = "true path" if straightness == 0.0 else "corrected path (reference)"
    title = (
        f"wall SLAM, {what} ({len(prepared.t)} scans), odometry seed {seed}: "
        f"ATE {ates} m (odometry / plain / anchored+freeze50 / plain smoothed)"
    )
    fig = wall_maps_figure(
        list(runs.items()), title=title, reference_label=reference,
        sightings=(prepared.rows, prepared.t), true_walls=true_walls,
    )  # fmt: skip
    return runs, save(fig, path)


def _overrides(kw: WallsOptions) -> PlanarConfigOverrides:
    """A DEMO_RUNS entry's filter settings, as run_prepared's keywords."""
    planar: PlanarConfigOverrides = {}
    if "anchor" in kw:
        planar["anchor"] = kw["anchor"]
    if "freeze_after" in kw:
        planar["freeze_after"] = kw["freeze_after"]
    return planar
