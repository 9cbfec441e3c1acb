"""``rperc bench track|laser|mrclam|pattern``: one capability over a corpus x methods x
seeds x settings grid, on one core or a Dask cluster, as one table.

    rperc bench track --corpus DIR --trackers color,csrt --scheduler local
    rperc bench laser --logs DIR --seeds 0-2 --out rows.csv --json summary.json
    rperc bench mrclam --robots 1-3 --variants plain,anchor,external
    rperc bench pattern --steps 1,2,3 --seeds 0-9 --plot pattern.png

The summary (mean ± sd per dataset x method x setting) goes to stdout; ``--out``
writes one row per run, ``--json`` the summary and ``--plot`` a figure."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rperc.cli.outputs import check_output_file, count_at_least, wrote


def _seeds(text: str) -> list[int]:
    from rperc.bench.tasks import parse_seeds

    try:
        return parse_seeds(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _common(p: argparse.ArgumentParser, seeds: str) -> None:
    p.add_argument(
        "--seeds",
        type=_seeds,
        default=_seeds(seeds),
        metavar="N-M,K",
        help=f"seeds, e.g. 0-9 or 0,3 (default {seeds})",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE.json",
        help='settings grid: {"name": [values, ...]} (every combination) or a list of objects',
    )
    p.add_argument(
        "--scheduler",
        default="serial",
        metavar="serial|local|tcp://HOST:PORT",
        help="where the runs go (default serial; local starts a Dask LocalCluster; "
        "tcp:// connects to a running dask scheduler)",
    )
    p.add_argument(
        "--workers",
        type=count_at_least(1, 256),
        metavar="N",
        help="worker processes of --scheduler local (default 2)",
    )
    p.add_argument(
        "--out", type=Path, metavar="ROWS.csv|.parquet|.json", help="write one row per run"
    )
    p.add_argument("--json", type=Path, metavar="PATH", help="write the summary (mean ± sd)")
    p.add_argument("--plot", type=Path, metavar="FIG.png", help="write the summary figure")
    p.set_defaults(run=bench_command)


def _corpus(p: argparse.ArgumentParser, flag: str, metavar: str, what: str, folder: str) -> None:
    """The repeatable option that names a suite's inputs; without it the suite reads
    its ``folder`` of the data folder."""
    p.add_argument(
        flag,
        type=Path,
        action="append",
        metavar=metavar,
        help=f"{what} (repeatable; default the data folder's {folder}/)",
    )


def _methods(
    p: argparse.ArgumentParser,
    flag: str,
    defaults: Sequence[str],
    choices: Sequence[str],
    what: str = "comma-separated",
) -> None:
    """The option that picks a suite's methods (trackers, variants), comma-separated:
    the suite's defaults unless given, and every choice (or part) named in its help."""
    p.add_argument(flag, default=",".join(defaults), help=f"{what}: {', '.join(choices)}")


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from rperc.bench.suites import laser, mrclam, pattern, track

    p = sub.add_parser("bench", help="score a capability over a corpus (serial or Dask)")
    kinds = p.add_subparsers(dest="suite", required=True, metavar="SUITE")
    t = kinds.add_parser("track", help="trackers over OTB folders, OpenCV's in the same run")
    _corpus(t, "--corpus", "DIR", "a folder of OTB sequence folders, or one", "otb")
    t.add_argument("--sequences", metavar="A,B", help="only these sequences (folder names)")
    _methods(t, "--trackers", track.DEFAULT_TRACKERS, track.TRACKERS)
    _common(t, "0")
    la = kinds.add_parser("laser", help="CARMEN logs through laser SLAM")
    _corpus(la, "--logs", "FILE_OR_DIR", "a CARMEN log or a folder of them", "carmen")
    _methods(
        la,
        "--variants",
        laser.DEFAULT_VARIANTS,
        laser.VARIANT_PARTS,
        "comma-separated: laser (the default), laser-walls, scan-matching, or wall SLAM's "
        "variants with parts joined by +",
    )
    _common(la, "0")
    m = kinds.add_parser("mrclam", help="MR.CLAM robots through planar EKF-SLAM")
    m.add_argument("--directory", type=Path, help="the MR.CLAM folder (default mrclam6/)")
    m.add_argument("--robots", default="1-3", help="e.g. 1-3 or 1,3")
    _methods(
        m,
        "--variants",
        mrclam.DEFAULT_VARIANTS,
        mrclam.VARIANT_PARTS,
        "comma-separated, parts joined by +",
    )
    m.add_argument(
        "--span",
        type=float,
        nargs=2,
        metavar=("START", "STOP"),
        help="only seconds [START, STOP) of each robot's run",
    )
    _common(m, "0")
    pa = kinds.add_parser("pattern", help="the pattern tracker and OpenCV's on generated steps")
    pa.add_argument("--steps", default="1,2,3", help="step bounds in sigma, e.g. 1,2,3")
    pa.add_argument(
        "--conditions",
        default="plain",
        help="comma-separated: plain, gain (1 +- 0.2 per frame), occlusion (up to 30 %%),"
        " perspective (the patch in perspective, drawn by OpenCV)",
    )
    pa.add_argument(
        "--motion",
        choices=pattern.MOTIONS,
        default="similarity",
        help="the rperc tracker's motion model (default similarity)",
    )
    _methods(pa, "--trackers", pattern.DEFAULT_TRACKERS, pattern.TRACKERS)
    pa.add_argument(
        "--frames",
        type=count_at_least(2, 100_000),
        default=40,
        help="frames per sequence (default 40)",
    )
    _common(pa, "0-9")


def _names(text: str, choices: tuple[str, ...], option: str) -> list[str]:
    from rperc.bench.tasks import parse_names

    return parse_names(text, choices, option)


def _plan(args: argparse.Namespace, grid: Any) -> Any:
    """The suite's API call for the command line's options."""
    from rperc import bench

    common = {
        "seeds": args.seeds,
        "grid": grid,
        "scheduler": args.scheduler,
        "workers": args.workers,
    }
    if args.suite == "track":
        seqs = [s.strip() for s in args.sequences.split(",")] if args.sequences else None
        from rperc.bench.suites.track import TRACKERS as TRACK_TRACKERS

        trackers = _names(args.trackers, TRACK_TRACKERS, "--trackers")
        return bench.track(args.corpus, sequences=seqs, trackers=trackers, **common)
    if args.suite == "laser":
        return bench.laser(args.logs, variants=args.variants.split(","), **common)
    if args.suite == "mrclam":
        from rperc.bench.suites.mrclam import parse_robots

        return bench.mrclam(
            args.directory,
            robots=parse_robots(args.robots),
            variants=args.variants.split(","),
            span=tuple(args.span) if args.span else None,
            **common,
        )
    from rperc.bench.suites.pattern import TRACKERS, parse_conditions, parse_steps

    return bench.pattern(
        steps=parse_steps(args.steps),
        conditions=parse_conditions(args.conditions),
        trackers=_names(args.trackers, TRACKERS, "--trackers"),
        frames=args.frames,
        motion=args.motion,
        **common,
    )


def bench_command(args: argparse.Namespace) -> int:
    from rperc.bench.runner import check_scheduler
    from rperc.bench.table import write_summary
    from rperc.bench.tasks import read_grid

    check_output_file(args.out, "--out")
    check_output_file(args.json, "--json")
    check_output_file(args.plot, "--plot", figure=True)
    check_scheduler(args.scheduler, args.workers)
    grid = read_grid(args.config) if args.config is not None else None
    start = time.perf_counter()
    result = _plan(args, grid)
    wall = time.perf_counter() - start
    print(result.table())
    failed = result.errors()
    for r in failed[:10]:
        print(
            f"rperc: run {r['index']} ({r['dataset']}, {r['method']}, seed {r['seed']}) "
            f"failed: {r['error']}",
            file=sys.stderr,
        )
    print(
        f"rperc: {len(result.rows)} runs ({len(failed)} failed) in {wall:.1f} s "
        f"with --scheduler {args.scheduler}",
        file=sys.stderr,
    )
    if args.out is not None:
        wrote(result.write(args.out))
    if args.json is not None:
        about = {
            "suite": args.suite,
            "argv": args.argv,
            "seeds": args.seeds,
            "scheduler": args.scheduler,
            "runs": len(result.rows),
            "failed": len(failed),
            "wall_seconds": wall,
        }
        wrote(write_summary(result.summary(), args.json, about))
    if args.plot is not None:
        wrote(result.plot(args.plot))
    sys.stdout.flush()
    return 0
