"""``rperc bench laser``: CARMEN logs through laser SLAM, with the simulated odometry
of ``rperc slam walls`` (drawn from the log's corrected path with the task's seed).
One row per log, seed and variant: ATE, loop error, final error, the robot NEES mean
and share in its 95 % band, and scans per second end to end (reading the log
included).

Variants, combinable with ``+`` (``anchor+freeze``):

- ``plain``: wall-landmark EKF-SLAM (``rperc slam walls``);
- ``anchor``: the first wall is the anchor (seed 000 eqs 24-25);
- ``freeze``: walls revised more than 50 times leave the state (the seed's setting);
- ``smoothed``: the run smoothed in batch; its scores replace the filter's;
- ``odometry``: dead reckoning alone, the baseline.

A settings grid may set ``straightness`` and ``association`` (``nn``, ``jcbb``).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rperc.bench.tasks import Task, parse_names

VARIANT_PARTS = ("plain", "anchor", "freeze", "smoothed", "odometry")
DEFAULT_VARIANTS = ("plain",)
SETTINGS = ("straightness", "association")
#: What the table and the figure show first.
SHOWN = (
    "ate_rmse_m",
    "loop_error_m",
    "final_error_m",
    "nees_mean",
    "nees_in_band",
    "scans_per_second",
)
PRIMARY = ("ate_rmse_m", "m")
#: The freezing threshold of the ``freeze`` variant (seed 000 uses 50 revisions).
FREEZE_AFTER = 50
LOG_SUFFIXES = (".log", ".log.gz", ".gz")


def parse_variants(text: str) -> list[str]:
    """Comma-separated variants, each a ``+``-joined combination of
    :data:`VARIANT_PARTS`."""
    out = []
    for v in (v.strip() for v in text.split(",") if v.strip()):
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


def walls_options(variant: str, settings: dict[str, Any]) -> dict[str, Any]:
    """``run_walls``'s keywords for a variant and the task's settings."""
    parts = set(variant.split("+"))
    kw: dict[str, Any] = {
        "anchor": "anchor" in parts,
        "freeze_after": FREEZE_AFTER if "freeze" in parts else None,
        "use_walls": "odometry" not in parts,
        "smooth": "smoothed" in parts,
    }
    unknown = set(settings) - set(SETTINGS)
    if unknown:
        raise ValueError(f"unknown laser setting(s) {', '.join(sorted(unknown))}")
    return kw | settings


def run(task: Task) -> dict[str, Any]:
    """One variant over one log with the task's seed: the scores of ``rperc slam
    walls`` (for ``smoothed``, of the smoothed path)."""
    from rperc.cli.wallslam import measured
    from rperc.datasets import TimestampRepairWarning
    from rperc.datasets.carmen import load_carmen
    from rperc.slam.wallslam import STRAIGHTNESS, run_walls

    start = time.perf_counter()
    with warnings.catch_warnings():
        # Wall SLAM takes its odometry and times from the corrected path, never the
        # scan times, so their repair (intel.log's four steps back) changes no score.
        warnings.simplefilter("ignore", TimestampRepairWarning)
        log = load_carmen(task.dataset)
    kw = {"straightness": STRAIGHTNESS} | walls_options(task.method, task.kwargs)
    result = run_walls(log, seed=task.seed, **kw)
    seconds = time.perf_counter() - start
    m = measured(result.smoothed() if kw["smooth"] else result)
    return {
        "library": "rperc",
        "dataset": Path(task.dataset).name,
        "scans": m["scans"],
        **{k: m[k] for k in SHOWN if k != "scans_per_second"},
        "walls": m["walls"],
        "scans_per_second": m["scans"] / seconds,
    }
