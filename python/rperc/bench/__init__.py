"""Score a capability over a whole corpus: every recording x method x seed x setting,
run in this process or on a Dask cluster, as one table.

    >>> from rperc import bench
    >>> result = bench.laser(["intel.log", "aces.log"], seeds=range(3))   # doctest: +SKIP
    >>> print(result.table())                                             # doctest: +SKIP
    >>> result.write("laser.csv")                                         # doctest: +SKIP

Each function plans the runs (:class:`~rperc.bench.tasks.Task`), runs them with
``scheduler`` (``"serial"``, ``"local"`` for a LocalCluster of ``workers``
processes, or ``"tcp://HOST:PORT"`` for a running Dask scheduler) and returns a
:class:`BenchResult`. The rows are the same whatever ran them, but for the time
columns (``fps``, ``scans_per_second``, ``seconds``); a run that raises becomes a
row with its ``error`` and the others go on. Workers read the data from the paths
given, so on a cluster of several machines those paths must exist on each of them.
``grid`` is a settings grid (:func:`~rperc.bench.tasks.expand_grid`): every
combination becomes rows, each setting a column.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from types import ModuleType

from rperc.bench.runner import TIME_COLUMNS, run_task, run_tasks, same_rows
from rperc.bench.suites import laser as _laser
from rperc.bench.suites import mrclam as _mrclam
from rperc.bench.suites import pattern as _pattern
from rperc.bench.suites import track as _track
from rperc.bench.table import BenchResult, summarize, write_rows
from rperc.bench.tasks import (
    Grid,
    Row,
    Setting,
    Task,
    expand_grid,
    make_tasks,
    parse_seeds,
    read_grid,
)

__all__ = [
    "TIME_COLUMNS",
    "BenchResult",
    "Row",
    "Task",
    "expand_grid",
    "laser",
    "mrclam",
    "parse_seeds",
    "pattern",
    "read_grid",
    "run_task",
    "run_tasks",
    "same_rows",
    "summarize",
    "track",
    "write_rows",
]


def _data(*parts: str) -> Path:
    from rperc.datasets import data_dir

    root = data_dir()
    if root is None:
        raise FileNotFoundError(
            "no corpus given and rperc's data folder was not found (set RPERC_DATA)"
        )
    return root.joinpath(*parts)


def _paths(given: Sequence[str | Path] | str | Path | None) -> list[Path]:
    """One path or several, as a list; empty for None (the caller then takes the data
    folder's)."""
    return [Path(given)] if isinstance(given, str | Path) else [Path(p) for p in given or []]


def _trackers(trackers: Sequence[str], known: Sequence[str]) -> list[str]:
    """The trackers asked for, each one of ``known``; none, or an unknown one, is a
    ValueError listing them."""
    names = [t for t in trackers if t in known]
    if not trackers or len(names) != len(trackers):
        raise ValueError(f"trackers: expected some of {', '.join(known)}")
    return names


def _combos(grid: Grid, allowed: Iterable[str], suite: str) -> list[dict[str, Setting]]:
    from rperc.bench.tasks import check_settings

    combos = expand_grid(grid)
    check_settings(combos, allowed, suite)
    return combos


def _seeds(seeds: Iterable[int]) -> list[int]:
    out = []
    for s in seeds:
        if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 2**63:
            raise ValueError(f"seeds must be integers in [0, 2**63), got {s!r}")
        out.append(s)
    if not out:
        raise ValueError("seeds: give at least one")
    return list(dict.fromkeys(out))


def _run(
    suite: str,
    tasks: list[Task],
    module: ModuleType,
    combos: list[dict[str, Setting]],
    scheduler: str,
    workers: int | None,
) -> BenchResult:
    rows = run_tasks(tasks, scheduler=scheduler, workers=workers, desc=f"bench {suite}")
    settings = tuple(dict.fromkeys(k for c in combos for k in c))
    return BenchResult(suite, tuple(rows), settings, tuple(module.SHOWN), tuple(module.PRIMARY))


def track(
    corpus: Sequence[str | Path] | str | Path | None = None,
    *,
    sequences: Sequence[str] | None = None,
    trackers: Sequence[str] = _track.DEFAULT_TRACKERS,
    seeds: Iterable[int] = (0,),
    grid: Grid = None,
    scheduler: str = "serial",
    workers: int | None = None,
) -> BenchResult:
    """Trackers over OTB folders (``corpus``: folders holding sequence folders, or
    sequence folders; the data folder's ``otb/`` by default). See
    :mod:`rperc.bench.suites.track`."""
    folders = _track.sequence_folders(_paths(corpus) or [_data("otb")], sequences)
    names = _trackers(trackers, _track.TRACKERS)
    combos = _combos(grid, _track.settings_taken(), "track")
    tasks = make_tasks(
        "track", folders, names, _seeds(seeds), combos, tunable=_track.RPERC_TRACKERS
    )
    return _run("track", tasks, _track, combos, scheduler, workers)


def laser(
    logs: Sequence[str | Path] | str | Path | None = None,
    *,
    variants: Sequence[str] = _laser.DEFAULT_VARIANTS,
    seeds: Iterable[int] = (0,),
    grid: Grid = None,
    scheduler: str = "serial",
    workers: int | None = None,
) -> BenchResult:
    """CARMEN logs (files, or folders of them; the data folder's ``carmen/`` by
    default) through laser SLAM. See :mod:`rperc.bench.suites.laser`."""
    files = _laser.log_files(_paths(logs) or [_data("carmen")])
    names = _laser.parse_variants(",".join(variants))
    combos = _combos(grid, {*_laser.SETTINGS, *_laser.laser_settings()}, "laser")
    tasks = make_tasks("laser", files, names, _seeds(seeds), combos, tunable=names)
    return _run("laser", tasks, _laser, combos, scheduler, workers)


def mrclam(
    directory: str | Path | None = None,
    *,
    robots: Sequence[int] = (1, 2, 3),
    variants: Sequence[str] = _mrclam.DEFAULT_VARIANTS,
    seeds: Iterable[int] = (0,),
    span: tuple[float, float] | None = None,
    fix_interval: float = 1.0,
    fix_sigma: float = 0.1,
    grid: Grid = None,
    scheduler: str = "serial",
    workers: int | None = None,
) -> BenchResult:
    """MR.CLAM robots (the data folder's ``mrclam6/`` by default) through planar
    EKF-SLAM with paper [000]'s variants. See :mod:`rperc.bench.suites.mrclam`."""
    folder = Path(directory) if directory is not None else _data("mrclam6")
    if not folder.is_dir():
        raise ValueError(f"MR.CLAM folder {folder} does not exist")
    bad = [r for r in robots if isinstance(r, bool) or r not in range(1, 6)]
    if bad or not robots:
        raise ValueError(f"robots: MR.CLAM robots are 1-5, got {list(robots)}")
    names = _mrclam.parse_variants(",".join(variants))
    combos = _combos(grid, _mrclam.settings_taken(), "mrclam")
    options: dict[str, Setting] = {
        "directory": str(folder.resolve()),
        "fix_interval": float(fix_interval),
        "fix_sigma": float(fix_sigma),
        "span_start": None if span is None else float(span[0]),
        "span_stop": None if span is None else float(span[1]),
    }
    tasks = make_tasks(
        "mrclam",
        [f"robot{r}" for r in dict.fromkeys(robots)],
        names,
        _seeds(seeds),
        combos,
        tunable=names,
        options=options,
    )
    return _run("mrclam", tasks, _mrclam, combos, scheduler, workers)


def pattern(
    *,
    steps: Sequence[float] = (1.0, 2.0, 3.0),
    conditions: Sequence[str] = ("plain",),
    trackers: Sequence[str] = _pattern.DEFAULT_TRACKERS,
    seeds: Iterable[int] = range(10),
    frames: int = 40,
    images: str | Path | None = None,
    motion: str = "similarity",
    grid: Grid = None,
    scheduler: str = "serial",
    workers: int | None = None,
) -> BenchResult:
    """The pattern tracker and its peers on generated sequences whose four
    parameters step up to each of ``steps`` sigma at once, under each of
    ``conditions`` ("plain"; "gain": a gain of 1 +- 0.2 per frame; "occlusion": up to
    30 % of the patch hidden; "perspective": the patch in perspective, drawn by
    OpenCV); ``motion`` is the rperc tracker's ("similarity" or "homography");
    ``images`` is a data
    folder holding ``images/`` (the data folder by default, generated images
    without one). See :mod:`rperc.bench.suites.pattern`."""
    bounds = _pattern.parse_steps(",".join(str(s) for s in steps))
    chosen = _pattern.parse_conditions(",".join(conditions))
    names = _trackers(trackers, _pattern.TRACKERS)
    if isinstance(frames, bool) or not isinstance(frames, int) or not 2 <= frames <= 100_000:
        raise ValueError(f"frames must be an integer in [2, 100000], got {frames!r}")
    if images is None:
        from rperc.datasets import data_dir

        images = data_dir() or ""
    combos = _combos(grid, _pattern.settings_taken(), "pattern")
    if motion not in _pattern.MOTIONS:
        raise ValueError(f"motion must be one of {', '.join(_pattern.MOTIONS)}, got {motion!r}")
    options: dict[str, Setting] = {"frames": frames, "images": str(images), "motion": motion}
    tasks = make_tasks(
        "pattern",
        [_pattern.case_name(s, c) for c in chosen for s in bounds],
        names,
        _seeds(seeds),
        combos,
        tunable=("rperc",),
        options=options,
    )
    return _run("pattern", tasks, _pattern, combos, scheduler, workers)
