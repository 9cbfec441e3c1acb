"""``rperc demo NAME`` and ``rperc demo all``: each capability on data rperc generates
itself, checked against the truth of that data.

A demo is a function ``run(out, seed, **options) -> DemoResult`` that writes its
figures into the folder ``out`` and returns one summary line (what was checked and the
measured error), the figures it wrote and its measured figures for ``--json``. To add a
capability, write its demo next to its command and append one :class:`Demo` to
:func:`registry`: it then has its own ``rperc demo NAME`` and runs in ``rperc demo all``
(and so in ``make demo``).

``demo all`` runs the demos in worker processes (``--jobs``, one per core): each worker
finds its demo by name in :func:`registry` and sends its :class:`DemoResult` back, so
a result must pickle. A script that calls ``rperc.cli.main(["demo", "all"])`` needs the
``if __name__ == "__main__":`` guard, as every program that starts processes does (or
``--jobs 1``, which runs everything in the calling process).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    count_at_least,
    prepare_output_folder,
    seed_type,
    write_json,
    wrote,
)


@dataclass(frozen=True)
class Option:
    """A demo-specific option: ``--flag`` passed to the demo as keyword ``dest``."""

    flag: str
    dest: str
    type: Callable[[str], object]
    default: object
    help: str


@dataclass(frozen=True)
class Demo:
    name: str
    help: str
    run: Callable[..., DemoResult]
    options: tuple[Option, ...] = ()
    #: Older spellings, still accepted for one release with a note on stderr.
    deprecated: tuple[str, ...] = ()
    #: About how long it runs on one core, seconds: ``demo all --jobs`` starts the
    #: longest first, so that no long demo is left to run alone at the end.
    seconds: float = 1.0

    def defaults(self) -> dict[str, object]:
        return {o.dest: o.default for o in self.options}


def _count(name: str, least: int, default: int, what: str, most: int | None = None) -> Option:
    """``--NAME N``, a count from ``least`` (to ``most``), passed to the demo as keyword
    ``NAME``. Its help is made from ``default``, so that the two cannot disagree."""
    return Option(
        f"--{name}", name, count_at_least(least, most), default, f"{what} (default {default})"
    )


@functools.cache
def registry() -> tuple[Demo, ...]:
    """Every demo, in the order ``demo all`` runs them. (Built on first use, so that
    ``rperc --help`` does not import every command module and its plotting.)"""
    from rperc.cli.laserslam import demo_laser_slam
    from rperc.cli.lines import demo_lines, demo_walls
    from rperc.cli.navigation import demo_visual_memory
    from rperc.cli.pattern import demo_pattern
    from rperc.cli.slam import demo_monobot
    from rperc.cli.slamrun import demo_slam
    from rperc.cli.track import demo_color_shape, demo_tracking
    from rperc.cli.wallslam import demo_wall_slam

    return (
        Demo("lines", "Douglas-Peucker on a noisy spiral, deviation vs epsilon", demo_lines),
        Demo("walls", "walls from a simulated laser scan vs the ray-cast truth", demo_walls),
        Demo(
            "monobot",
            "EKF-SLAM observability study (Figs. 3-6, Monte Carlo)",
            demo_monobot,
            (_count("runs", 2, 100, "Monte Carlo runs"),),
            seconds=3.0,
        ),
        Demo(
            "slam",
            "planar EKF-SLAM variants in a simulated world: maps, paths, Monte Carlo NEES",
            demo_slam,
            (_count("runs", 2, 20, "Monte Carlo runs"),),
        ),
        Demo(
            "wall-slam",
            "wall-landmark SLAM on a simulated corridor loop: Fig. 7's maps side by side",
            demo_wall_slam,
            deprecated=("wall_slam",),
            seconds=2.0,
        ),
        Demo(
            "laser-slam",
            "laser SLAM on a simulated corridor loop, with and without wall landmarks",
            demo_laser_slam,
            seconds=2.0,
        ),
        Demo(
            "tracking",
            "color trackers on a synthetic sequence vs its known boxes",
            demo_tracking,
            # 1000 frames of 320 x 240 RGB are 230 MB: a bound well above any use.
            (_count("frames", 2, 150, "frames", most=1000),),
            seconds=2.0,
        ),
        Demo(
            "color-shape",
            "colour+shape tracker vs colour alone: the four experiments of Fig. 13, colour path",
            demo_color_shape,
            (_count("frames", 2, 60, "frames", most=1000),),
            deprecated=("color_shape",),
            seconds=5.0,
        ),
        Demo(
            "pattern",
            "pattern tracker: Fig. 8 on a generated sequence, harness vs ECC/matchTemplate/CSRT",
            demo_pattern,
            # 640 x 480 grey frames: 1000 of them are 300 MB.
            (_count("frames", 9, 60, "frames", most=1000),),
            seconds=9.0,
        ),
        Demo(
            "visual-memory",
            "ceiling mosaic, key images and visual servoing (Fig. 9) vs the world's truth",
            demo_visual_memory,
            (_count("starts", 1, 10, "replays", most=1000),),
            seconds=17.0,
        ),
    )


def _common_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="folder for the figures")
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the generated data")
    add_json_option(p)


def add_demos(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    demo = sub.add_parser("demo", help="run the demos on data rperc generates itself")
    demos = demo.add_subparsers(dest="demo", required=True, metavar="DEMO")
    for d in registry():
        p = demos.add_parser(d.name, help=d.help, aliases=list(d.deprecated))
        _common_options(p)
        for o in d.options:
            p.add_argument(o.flag, dest=o.dest, type=o.type, default=o.default, help=o.help)
        p.set_defaults(run=_run_one, demo_entry=d)
    p = demos.add_parser("all", help="every demo above, one figure and one summary line each")
    _common_options(p)
    p.add_argument(
        "--jobs",
        type=count_at_least(1, 64),
        default=min(os.cpu_count() or 1, 64),
        help="demos run at once, each in its own process (default: one per core; 1 runs"
        " them one after another in this process)",
    )
    p.set_defaults(run=run_all)


def _timed(d: Demo, out: Path, seed: int, options: dict[str, Any]) -> tuple[DemoResult, float]:
    start = time.perf_counter()
    result = d.run(out, seed, **options)
    return result, time.perf_counter() - start


def _run(d: Demo, out: Path, seed: int, options: dict[str, Any]) -> tuple[DemoResult, float]:
    result, seconds = _timed(d, out, seed, options)
    for path in result.figures:
        wrote(path)
    return result, seconds


def _timed_by_name(name: str, out: Path, seed: int) -> tuple[DemoResult, float]:
    """One demo with its defaults, in a worker process: it is found there by name (a
    demo's function is not sent across)."""
    (d,) = (d for d in registry() if d.name == name)
    return _timed(d, out, seed, d.defaults())


def _outputs(args: argparse.Namespace) -> Path:
    """The ``--out`` folder, made, and the ``--json`` file, checked, before any demo
    runs. The folder first: ``--json`` may point into it."""
    out = prepare_output_folder(args.out, "--out")
    check_output_file(args.json, "--json")
    return out


def _run_one(args: argparse.Namespace) -> int:
    d: Demo = args.demo_entry
    if args.demo != d.name:
        print(
            f"rperc demo {args.demo}: deprecated name, use 'rperc demo {d.name}'", file=sys.stderr
        )
    out = _outputs(args)
    result, seconds = _run(d, out, args.seed, {o.dest: getattr(args, o.dest) for o in d.options})
    print(result.summary)
    for line in result.details:
        print(line)
    write_json(args.json, {**result.measured, "seconds": seconds})
    return 0


def run_all(args: argparse.Namespace) -> int:
    out = _outputs(args)
    from rperc._extras import MissingExtraError

    measured: dict[str, Any] = {}
    summaries: dict[str, str] = {}
    missing: list[str] = []
    start = time.perf_counter()
    with _outcomes(out, args.seed, args.jobs) as outcomes:
        for d, outcome in zip(registry(), outcomes, strict=True):
            try:
                result, seconds = outcome()
            except MissingExtraError as exc:
                # A bare install (pip install .) still runs every demo that needs
                # nothing more, and names what each other one needs, in one line,
                # exiting 2.
                print(f"rperc: demo {d.name} not run: {exc}", file=sys.stderr)
                missing.append(d.name)
                continue
            for path in result.figures:
                wrote(path)
            print(result.summary, flush=True)
            measured[d.name] = {**result.measured, "seconds": seconds}
            summaries[d.name] = result.summary
    total = time.perf_counter() - start
    ran = len(registry()) - len(missing)
    print(f"rperc demo all: {ran} demos in {total:.1f} s", file=sys.stderr)
    # The printed lines too: the docs' papers page quotes them beside the figures.
    write_json(args.json, {"demos": measured, "summaries": summaries, "seconds": total})
    return 2 if missing else 0


Outcome = Callable[[], tuple[DemoResult, float]]


@contextlib.contextmanager
def _outcomes(out: Path, seed: int, jobs: int) -> Iterator[list[Outcome]]:
    """Each demo's outcome, in the registry's order: a call that returns its result or
    raises what it raised. With ``jobs`` > 1 the demos run in that many worker
    processes, longest first; the results are still read in order, so the summary
    lines and the JSON are the same as one after another."""
    if jobs == 1:
        yield [functools.partial(_timed, d, out, seed, d.defaults()) for d in registry()]
        return
    # spawn, not fork: the parent may already hold rayon's and BLAS's threads.
    pool = ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"))
    try:
        longest_first = sorted(registry(), key=lambda d: -d.seconds)
        futures = {d.name: pool.submit(_timed_by_name, d.name, out, seed) for d in longest_first}
        yield [functools.partial(_result, futures[d.name]) for d in registry()]
    finally:
        # On Ctrl-C or an error the demos not yet started are cancelled (the workers
        # had the signal too, and stop their own).
        pool.shutdown(wait=True, cancel_futures=True)


def _result(future: Future[tuple[DemoResult, float]]) -> tuple[DemoResult, float]:
    """A worker's answer; a worker that died (killed, out of memory, or a script
    without the ``__main__`` guard) is a one-line error, not a pool's traceback."""
    try:
        return future.result()
    except BrokenProcessPool as exc:
        from rperc import RpercError

        raise RpercError(f"a demo worker process ended abruptly ({exc}); try --jobs 1") from None
