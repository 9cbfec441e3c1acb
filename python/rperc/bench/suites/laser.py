"""``rperc bench laser``: CARMEN logs through laser SLAM, with the simulated odometry
of ``rperc slam walls`` (drawn from the log's corrected path with the task's seed).
One row per log, seed and variant: ATE, loop error, final error, the robot NEES mean
and share in its 95 % band, and scans per second end to end (reading the log
included).

Methods:

- ``laser``: the laser pipeline (``rperc slam laser``: scan matching, loop closures,
  pose graph); ``laser-walls``: the same with wall landmarks in the graph;
  ``scan-matching``: its front end alone, without closures;

and wall SLAM's variants, combinable with ``+`` (``anchor+freeze``):

- ``plain``: wall-landmark EKF-SLAM (``rperc slam walls``);
- ``anchor``: the first wall is the anchor (paper [000], eqs 24-25);
- ``freeze``: walls revised more than 50 times leave the state (paper [000]'s setting);
- ``smoothed``: the run smoothed in batch; its scores replace the filter's;
- ``odometry``: dead reckoning alone, the baseline.

A settings grid may set wall SLAM's ``straightness`` and ``association`` (``nn``,
``jcbb``), and any of the laser pipeline's settings by its dotted name
(``icp.covariance_scale``, ``loops.max_radius``: the fields of
:class:`rperc.config.LaserConfig`).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, cast

from rperc.bench.tasks import Row, Setting, Task, parse_names

if TYPE_CHECKING:
    from rperc.slam.wallslam import WallsOptions

VARIANT_PARTS = ("plain", "anchor", "freeze", "smoothed", "odometry")
#: The laser pipeline's methods (each stands alone) and their ``run_laser`` variant.
LASER_METHODS = {
    "laser": "loops",
    "laser-walls": "walls",
    "scan-matching": "scan-matching",
}
DEFAULT_VARIANTS = ("laser",)
SETTINGS = ("straightness", "association")
#: What the table and the figure show first.
SHOWN = (
    "ate_rmse_m",
    "ate_rmse_causal_m",
    "loop_error_m",
    "nees_mean",
    "nees_in_band",
    "loop_closures_accepted",
    "scans_per_second",
)
PRIMARY = ("ate_rmse_m", "m")
#: The laser pipeline's scores a row holds (``LaserResult.measured()``'s names).
LASER_SCORES = (
    "scans",
    "ate_rmse_m",
    "ate_rmse_causal_m",
    "loop_error_m",
    "final_error_m",
    "nees_mean",
    "nees_in_band",
    "loop_closures_accepted",
    "loop_closures_rejected",
    "scans_per_second",
)
#: The freezing threshold of the ``freeze`` variant (paper [000] uses 50 revisions).
FREEZE_AFTER = 50
LOG_SUFFIXES = (".log", ".log.gz", ".gz")


def parse_variants(text: str) -> list[str]:
    """Comma-separated variants, each a ``+``-joined combination of
    :data:`VARIANT_PARTS`."""
    out = []
    for v in (v.strip() for v in text.split(",") if v.strip()):
        if v in LASER_METHODS:
            out.append(v)
            continue
        parts = parse_names(v.replace("+", ","), VARIANT_PARTS, "--variants")
        if "odometry" in parts and len(parts) > 1:
            raise ValueError(f"--variants {v!r}: odometry combines with nothing")
        out.append("+".join(parts))
    if not out:
        raise ValueError(f"--variants {text!r}: no variant")
    return list(dict.fromkeys(out))


def log_files(paths: Sequence[Path]) -> list[str]:
    """The CARMEN logs given, or found directly in the folders given, absolute."""
    found: list[Path] = []
    for p in paths:
        if p.is_dir():
            logs = sorted(q for q in p.iterdir() if q.is_file() and q.name.endswith(LOG_SUFFIXES))
            if not logs:
                raise ValueError(f"--logs {p}: no .log or .log.gz file in this folder")
            found += logs
        elif p.is_file():
            found.append(p)
        else:
            raise ValueError(f"--logs {p}: no such file or folder")
    return [str(p.resolve()) for p in dict.fromkeys(found)]


def walls_options(variant: str, settings: Mapping[str, Setting]) -> WallsOptions:
    """``run_walls``'s keywords for a variant and the task's settings (their values
    are checked by ``run_walls``, naming the setting)."""
    parts = set(variant.split("+"))
    unknown = set(settings) - set(SETTINGS)
    if unknown:
        raise ValueError(f"{', '.join(sorted(unknown))}: not wall SLAM settings")
    kw: WallsOptions = {
        "anchor": "anchor" in parts,
        "freeze_after": FREEZE_AFTER if "freeze" in parts else None,
        "use_walls": "odometry" not in parts,
        "smooth": "smoothed" in parts,
    }
    if "straightness" in settings:
        kw["straightness"] = cast(float, settings["straightness"])
    if "association" in settings:
        kw["association"] = cast(str, settings["association"])
    return kw


def laser_settings() -> set[str]:
    """The laser pipeline's settings by dotted name (``icp.sigma``)."""
    from rperc._config_base import dotted_fields
    from rperc.config import LaserConfig

    return set(dotted_fields(LaserConfig()))


def nested(settings: Mapping[str, object]) -> dict[str, object]:
    """Deprecated (the suite now sets dotted settings on a ``LaserConfig``, see
    :func:`rperc.slam.laser.from_settings`): dotted settings (``{"icp.sigma": 0.02}``)
    as a nested dict."""
    warnings.warn(
        "rperc.bench.suites.laser.nested is deprecated: use rperc.slam.laser.from_settings",
        DeprecationWarning,
        stacklevel=2,
    )
    out: dict[str, object] = {}
    for name, value in settings.items():
        *path, leaf = name.split(".")
        node = out
        for part in path:
            inner = node.setdefault(part, {})
            if not isinstance(inner, dict):
                raise ValueError(f"{name}: {part} is a setting, not a part")
            node = inner
        node[leaf] = value
    return out


def run_laser_task(task: Task) -> Row:
    """The laser pipeline over one log: ``rperc slam laser``'s scores."""
    from rperc.slam.laser import from_settings, load_and_run

    wall = set(task.kwargs) & set(SETTINGS)
    if wall:
        raise ValueError(f"{', '.join(sorted(wall))}: wall SLAM settings, not the laser pipeline's")
    config, start = from_settings(task.kwargs)
    result = load_and_run(
        task.dataset, seed=task.seed, variant=LASER_METHODS[task.method], config=config, **start
    )
    m = result.measured()
    return {
        "library": "rperc",
        "dataset": Path(task.dataset).name,
        **{k: m[k] for k in LASER_SCORES},
    }


def run(task: Task) -> Row:
    """One variant over one log with the task's seed: the scores of ``rperc slam
    walls`` (for ``smoothed``, of the smoothed path), or of ``rperc slam laser``."""
    if task.method in LASER_METHODS:
        return run_laser_task(task)
    from rperc.datasets.carmen import load_carmen_logged
    from rperc.slam.wallslam import STRAIGHTNESS, run_walls

    start = time.perf_counter()
    # Wall SLAM takes its odometry and times from the corrected path, never the scan
    # times, so their repair (intel.log's four steps back) changes no score.
    log = load_carmen_logged(task.dataset)
    kw: WallsOptions = {"straightness": STRAIGHTNESS, **walls_options(task.method, task.kwargs)}
    result = run_walls(log, seed=task.seed, **kw)
    seconds = time.perf_counter() - start
    m = (result.smoothed() if kw["smooth"] else result).measured()
    return {
        "library": "rperc",
        "dataset": Path(task.dataset).name,
        "scans": m["scans"],
        **{
            k: m[k]
            for k in ("ate_rmse_m", "loop_error_m", "final_error_m", "nees_mean", "nees_in_band")
        },
        "walls": m["walls"],
        "scans_per_second": result.counts["scans"] / seconds,
    }
