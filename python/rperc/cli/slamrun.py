"""``rperc slam mrclam DIR`` and ``rperc slam victoria DIR``: planar EKF-SLAM on a
recording, scored against its ground truth (MR.CLAM: Vicon path and surveyed
landmarks; Victoria Park: GPS), with paper [000]'s variants combinable."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    positive_float,
    print_measured,
    seed_type,
    write_json,
    wrote,
)
from rperc.config import SimConfig
from rperc.slam import PlanarSlam, SlamResult
from rperc.slam.evaluation import RunReference
from rperc.slam.mrclam import mrclam_run
from rperc.slam.planar import PRESETS, RECORDING_VARIANTS, variant_config, victoria_recording
from rperc.slam.wallslam import ASSOCIATIONS

if TYPE_CHECKING:
    from rperc.config import SimConfigOverrides


def _variants(text: str) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    unknown = [v for v in names if v not in RECORDING_VARIANTS]
    if not names or unknown:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated list of {', '.join(RECORDING_VARIANTS)}, got {text!r}"
        )
    return names


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "slam", help="planar EKF-SLAM on MR.CLAM or Victoria Park; laser or wall SLAM on CARMEN"
    )
    kinds = p.add_subparsers(dest="dataset", required=True, metavar="DATASET")
    m = kinds.add_parser("mrclam", help="MR.CLAM: one robot, known association (barcodes)")
    m.add_argument("directory", type=Path, help="MR.CLAM dataset folder")
    m.add_argument("--robot", type=int, choices=range(1, 6), default=1)
    m.add_argument(
        "--fix-interval", type=positive_float, default=1.0,
        help="external variant: seconds between xy fixes made from the ground truth",
    )  # fmt: skip
    m.add_argument("--fix-sigma", type=positive_float, default=0.1, help="their noise (m)")
    m.add_argument("--seed", type=seed_type, default=0, help="the draw of the fixes' noise")
    m.add_argument(
        "--span", type=float, nargs=2, metavar=("START", "STOP"),
        help="only seconds [START, STOP) after the first odometry row (the mrclam preset "
        "is calibrated on robot 1's first 444 s: report on what follows or on robots 2-5)",
    )  # fmt: skip
    v = kinds.add_parser("victoria", help="Victoria Park: trees, no ids, GPS")
    v.add_argument("directory", type=Path, help="Victoria Park folder")
    v.add_argument(
        "--association", choices=ASSOCIATIONS, default=PRESETS["victoria"]["association"]
    )
    v.add_argument("--gps-sigma", type=positive_float, default=2.0, help="external variant (m)")
    for q in (m, v):
        q.add_argument(
            "--variant", type=_variants, default=("plain",),
            help="comma-separated, combinable: plain, anchor, external, freeze; smooth "
            "(MR.CLAM: the run smoothed afterwards, every sighting used both ways in time)",
        )  # fmt: skip
        q.add_argument(
            "--compression", choices=("auto", "off"), default="auto",
            help="the compressed EKF of Guivant & Nebot (auto: wherever it is exact; the "
            "results equal the full EKF's up to round-off) or the full EKF at every step",
        )  # fmt: skip
        q.add_argument(
            "--active-radius", type=positive_float, default=None, metavar="M",
            help="the compressed filter's active area around the sensor (m)",
        )  # fmt: skip
        q.add_argument("--config", type=json.loads, default={}, help="JSON config overrides")
        q.add_argument("--tum", type=Path, help="write the estimated path (TUM format, for evo)")
        q.add_argument("--plot", type=Path, help="write the map figure")
        q.add_argument(
            "--rerun", type=Path, metavar="FILE.rrd",
            help="write the run for the rerun viewer (needs pip install rperc[viz])",
        )  # fmt: skip
        add_json_option(q)
        q.set_defaults(run=slam_command)
    from rperc.cli.laserslam import add_laser_command
    from rperc.cli.wallslam import add_walls_command

    add_walls_command(kinds)
    add_laser_command(kinds)


def _speed(args: argparse.Namespace) -> dict[str, Any]:
    """The speed settings from the command line (they leave the results unchanged)."""
    cfg: dict[str, Any] = {"compression": args.compression}
    if args.active_radius is not None:
        cfg["active_radius"] = args.active_radius
    return cfg


def _mrclam(args: argparse.Namespace) -> tuple[SlamResult, dict[str, float], RunReference]:
    return mrclam_run(
        args.directory, robot=args.robot, variants=args.variant, seed=args.seed,
        fix_interval=args.fix_interval, fix_sigma=args.fix_sigma, span=args.span,
        config={**_speed(args), **args.config},
    )  # fmt: skip


def _victoria(args: argparse.Namespace) -> tuple[SlamResult, dict[str, float], RunReference]:
    from rperc.datasets import load_victoria_park
    from rperc.datasets.victoria_park import LASER_MOUNT

    if "smooth" in args.variant:
        raise ValueError(
            "--variant smooth: the smoother models the unicycle with its sensor at the "
            "robot's origin (MR.CLAM), not Victoria Park's Ackermann vehicle"
        )

    park = load_victoria_park(args.directory)
    cfg = {**PRESETS["victoria"], "association": args.association, **_speed(args), **args.config}
    cfg = variant_config(cfg, args.variant)
    ev = victoria_recording(park, gps_sigma=args.gps_sigma if "external" in args.variant else None)
    result = PlanarSlam(cfg).run(ev, progress=True)
    # Scored at the laser (the point Guivant and Nebot's filter estimates; a GPS lever
    # arm fitted on the first half of the run alone lands within 0.25 m of it), against
    # the fixes that are not receiver glitches.
    keep = park.gps_plausible()
    t_gps, gps = park.gps_t[keep], np.c_[park.gps_x, park.gps_y][keep]
    err = result.gps_error(t_gps, gps, lever_arm=LASER_MOUNT)
    axle = result.gps_error(t_gps, gps)
    metrics = {
        "gps_rms_aligned_m": err.rms,
        "gps_rms_aligned_rear_axle_m": axle.rms,
        "gps_fixes": len(err.distance),
        "gps_fixes_implausible": int(np.count_nonzero(~keep)),
    }
    ref: RunReference = {"truth": gps, "landmarks": None, "label": "GPS fixes",
                         "transform": err.transform, "nees": None}  # fmt: skip
    return result, metrics, ref


def slam_command(args: argparse.Namespace) -> int:
    for path, option, figure in ((args.tum, "--tum", False), (args.plot, "--plot", True)):
        check_output_file(path, option, figure=figure)
    check_output_file(args.json, "--json")
    check_output_file(args.rerun, "--rerun")
    if args.rerun is not None:
        import importlib.util

        if importlib.util.find_spec("rerun") is None:
            raise ValueError("--rerun needs the viz extra: pip install rperc[viz]")
    run = _mrclam if args.dataset == "mrclam" else _victoria
    result, scores, ref = run(args)
    events = scores.get("events", len(result.seconds))
    variant = "+".join(args.variant)
    metrics: dict[str, object] = {
        **scores,
        "variant": variant,
        "landmarks": len(result.landmark_id),
        "statistics": result.statistics,
        "seconds_total": float(result.seconds.sum()),
        # A smoothed run's rows are its poses: the filter's event count is in scores.
        "seconds_per_event": float(result.seconds.sum()) / max(int(events), 1),
    }
    shown = {k: v for k, v in metrics.items() if k != "statistics"}
    print_measured(shown)
    print("association: " + " ".join(f"{k}={v}" for k, v in result.statistics.items()))
    if args.tum is not None:
        wrote(result.to_tum(args.tum))
    if args.plot is not None:
        from rperc.plot import save
        from rperc.plot.slam import map_figure

        score = ", ".join(f"{k} {v:.3g}" for k, v in shown.items() if k.endswith("_m"))
        title = f"{args.dataset} ({variant}): {score}"
        fig = map_figure(
            [(variant, result)], ref["truth"], ref["landmarks"], title=title,
            truth_label=ref["label"], transform=ref["transform"],
        )  # fmt: skip
        wrote(save(fig, args.plot))
    if args.rerun is not None:
        from rperc.slam.rerun_log import log_run

        # GPS fixes are points, not a path: only the map's truth is drawn for them.
        truth = ref["truth"] if args.dataset == "mrclam" else None
        wrote(
            log_run(result, args.rerun, truth=truth, landmarks=ref["landmarks"], nees=ref["nees"])
        )
    write_json(args.json, metrics)
    sys.stdout.flush()
    return 0


# The demo world: the Rust crate's drifting world (heading noise 0.05 rad^2/s^2 per
# step, 12 landmarks seen within 4.5 m), where Bailey et al.'s long-run inconsistency
# shows; the external variant sees an xy fix every 10 steps (1 s).
DEMO_WORLD: SimConfigOverrides = {
    "steps": 1500,
    "turn_rate_variance": 0.05,
    "bearing_variance": 1e-3,
    "landmarks": 12,
    "max_range": 4.5,
}
DEMO_FIX_EVERY = 10


def demo_slam(out: Path, seed: int, runs: int = 20) -> DemoResult:
    """Planar EKF-SLAM's variants (plain, anchor, external) in the simulated world:
    one seeded run each for the maps, and a Monte Carlo for the NEES."""
    from rperc.plot import save
    from rperc.plot.slam import variants_figure
    from rperc.slam.planar import (
        VARIANTS,
        consistency,
        sim_slam_config,
        simulate,
    )

    mc = consistency(DEMO_WORLD, runs=runs, seed=seed, fix_every=DEMO_FIX_EVERY)
    maps, measured = [], {}
    for name, over in VARIANTS.items():
        world = {**DEMO_WORLD, "fix_every": DEMO_FIX_EVERY} if name == "external" else DEMO_WORLD
        sim = simulate(world, seed=seed, run=0)
        result = PlanarSlam(sim_slam_config(world, **over)).run(sim.recording)
        t, pose = sim.truth_path()
        ate = result.ate(t, pose).rmse
        ids = np.arange(len(sim.landmarks))
        lm = result.landmark_rmse(ids, sim.landmarks).rmse
        m = mc[name]
        measured[name] = {
            "ate_m": ate,
            "landmark_rmse_m": lm,
            "mean_nees": float(np.mean(m.mean_nees)),
            "nees_in_band": m.in_band,
            "band": list(m.band),
        }
        maps.append((name, result, f"ATE {ate:.3f} m, landmarks {lm:.3f} m (run 0)"))
    band = mc["plain"].band
    nees_text = ", ".join(
        f"{n} {mc[n].mean_nees.mean():.2f} ({100 * mc[n].in_band:.0f}% in band)" for n in VARIANTS
    )
    title = (
        f"planar EKF-SLAM, simulated world, {DEMO_WORLD['steps']} steps: estimate vs truth; "
        f"{runs}-run mean robot NEES {nees_text}, band [{band[0]:.2f}, {band[1]:.2f}]"
    )
    series = [(n, mc[n].mean_nees) for n in VARIANTS]
    dt = SimConfig().dt
    fig = variants_figure(maps, sim.truth[:, 1:3], sim.landmarks, series, band, title=title, dt=dt)
    path = save(fig, out / "slam_variants.png")
    smoothed_path, smoothed = _demo_smoothing(out, seed, runs, band)
    summary = (
        "slam: simulated world, ATE "
        + " / ".join(f"{measured[n]['ate_m']:.3f}" for n in VARIANTS)
        + f" m (plain / anchor / external, run 0); {runs}-run mean robot NEES {nees_text}, "
        + f"band [{band[0]:.2f}, {band[1]:.2f}]; smoothed ATE {smoothed['ate_m']:.3f} m, "
        + f"mean NEES {smoothed['mean_nees']:.2f}"
    )
    extra = {"smoothed": smoothed}
    return DemoResult(
        summary, [path, smoothed_path], {"runs": runs, "seed": seed, **measured, **extra}
    )


def _demo_smoothing(
    out: Path, seed: int, runs: int, band: tuple[float, float]
) -> tuple[Path, dict[str, float]]:
    """The plain filter's runs smoothed: run 0's maps and errors in a figure, and the
    smoothed robot NEES averaged over ``runs`` runs and their poses."""
    from rperc.plot import save
    from rperc.plot.slam import smoothing_figure
    from rperc.slam.evaluation import associate, pose_nees
    from rperc.slam.planar import sim_slam_config, simulate
    from rperc.slam.smoothing import pose_times, smooth

    nees = []
    for run in range(runs):
        sim = simulate(DEMO_WORLD, seed=seed, run=run)
        rec = sim.recording
        result = PlanarSlam(sim_slam_config(DEMO_WORLD)).run(rec)
        times = pose_times(result, rec.detections)
        smoothed = smooth(result, rec.controls, times, detections=rec.detections).to_result(result)
        t, pose = sim.truth_path()
        nees.append(pose_nees(associate(*smoothed.path()[:2], t, pose), smoothed.path()[2]).mean)
        if run == 0:
            first = (result, smoothed, t, pose, sim.landmarks)
    result, smoothed, t, pose, marks = first
    ate = (result.ate(t, pose).rmse, smoothed.ate(t, pose).rmse)
    measured = {"filter_ate_m": ate[0], "ate_m": ate[1], "mean_nees": float(np.mean(nees))}
    title = (
        f"planar EKF-SLAM smoothed, simulated world, {DEMO_WORLD['steps']} steps:\n"
        f"ATE filter {ate[0]:.3f} m -> smoothed {ate[1]:.3f} m (run 0); smoothed robot "
        f"NEES {measured['mean_nees']:.2f} over {runs} runs\n(the filter's per-step band "
        f"of a {runs}-run mean: [{band[0]:.2f}, {band[1]:.2f}])"
    )
    fig = smoothing_figure(result, smoothed, t, pose, marks, title=title)
    return save(fig, out / "slam_smoothed.png"), measured
