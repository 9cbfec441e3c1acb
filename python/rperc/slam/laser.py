"""Laser SLAM on a CARMEN log: scan matching, loop closures and a pose graph.

The experiment is the one of :mod:`rperc.slam.wallslam` (the first seed's Fig. 7
set-up): the log's real scans, its corrected path as the reference, and odometry made
from the corrected path's increments with seeded noise of stated levels (5 % of the
distance, 1 degree per metre, a 1 % and 0.1 degree-per-metre bias). The pipeline is
the ``laser`` crate's (:func:`rperc._rperc.laser_run`):

- each scan is matched by point-to-line ICP against a local map of recent key scans,
  with the odometry step as a Gaussian prior, so a direction the scans cannot see (a
  featureless corridor) keeps the odometry's estimate and its variance;
- every few key scans, the key scan is matched against the key scans of an earlier
  visit nearby (a coarse-to-fine correlative search, then ICP), verified, and added
  to a sparse pose graph only when the next attempt agrees with it; closures that
  disagree with the optimised graph are removed;
- in the ``walls`` variant, each key scan's walls (split-and-merge, seed 000 section
  2.1) are paired with the walls mapped so far; a wall seen again after ten metres
  of path becomes a landmark of the graph, tying the key scans that saw it (along a
  corridor, too, where no closure is tried);
- every scan's final pose is its key scan's optimum moved by the front end's motion
  since, with the marginal covariance of the graph.

>>> from rperc.slam.laser import VARIANTS
>>> sorted(VARIANTS)
['loops', 'odometry', 'scan-matching', 'walls']
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rperc import _rperc
from rperc._args import seed_number
from rperc._config_base import as_config, dotted_fields, merged, with_dotted
from rperc.config import LaserConfig, LaserConfigOverrides, Unicycle
from rperc.slam.wallslam import SPEED_SIGMA, TURN_SIGMA

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from rperc.datasets.carmen import CarmenLog

#: The full pipeline's settings in this experiment: the crate's defaults, told the
#: simulation's stated odometry noise (the filter's motion model is the one the
#: odometry was drawn from).
_LOOPS = LaserConfig(
    motion=Unicycle(speed_variance=SPEED_SIGMA**2, turn_rate_variance=TURN_SIGMA**2)
)

#: The pipelines ``run_laser`` offers, as their settings: the full one, the full one
#: with wall landmarks, scan matching without loop closures, and the simulated
#: odometry alone (the baseline).
VARIANTS: dict[str, LaserConfig] = {
    "loops": _LOOPS,
    "walls": _LOOPS.replace(walls=_LOOPS.walls.replace(enabled=True)),
    "scan-matching": _LOOPS.replace(loops=_LOOPS.loops.replace(enabled=False)),
    # ICP refuses every match when it needs more pairs than any scan has.
    "odometry": _LOOPS.replace(
        loops=_LOOPS.loops.replace(enabled=False),
        icp=_LOOPS.icp.replace(min_inliers=1_000_000),
    ),
}


def defaults() -> dict[str, object]:
    """Deprecated: the crate's default settings as a nested dict; use
    :class:`rperc.config.LaserConfig` (``LaserConfig()``, or ``VARIANTS["loops"]``,
    the settings a run starts from)."""
    warnings.warn(
        "rperc.slam.laser.defaults() is deprecated: use rperc.config.LaserConfig() "
        "(or rperc.slam.laser.VARIANTS['loops'], the settings a run starts from)",
        DeprecationWarning,
        stacklevel=2,
    )
    return LaserConfig().to_dict()


def _variant_changes(variant: str) -> dict[str, object]:
    """The settings ``variant`` changes from the full pipeline, by dotted name."""
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
    full = dotted_fields(VARIANTS["loops"])
    return {k: v for k, v in dotted_fields(VARIANTS[variant]).items() if full[k] != v}


def run_config(
    variant: str = "loops",
    config: LaserConfig | Mapping[str, object] | None = None,
    initial_pose: tuple[float, float, float] | None = None,
    overrides: Mapping[str, object] | None = None,
) -> LaserConfig:
    """The settings of a run: ``config`` (``VARIANTS["loops"]`` when None) with the
    ``overrides`` on top, then ``variant``'s changes, and the pipeline started at
    ``initial_pose`` unless an override sets it. A plain mapping as ``config`` is the
    old spelling (deprecated): nested overrides of the variant's settings."""
    changes = _variant_changes(variant)
    over = dict(overrides or {})
    if config is not None and not isinstance(config, LaserConfig):
        warnings.warn(
            "run_laser(config=<mapping>) is deprecated: pass a rperc.config.LaserConfig "
            "(such as VARIANTS['loops'].replace(...)) or keyword overrides",
            DeprecationWarning,
            stacklevel=3,
        )
        base = VARIANTS[variant]
        if initial_pose is not None:
            base = base.replace(initial_pose=initial_pose)
        return as_config(LaserConfig, merged(base, config), over)
    if initial_pose is not None:
        over.setdefault("initial_pose", initial_pose)
    made = as_config(LaserConfig, config if config is not None else VARIANTS["loops"], over)
    return with_dotted(made, changes) if changes else made


@dataclass(frozen=True, repr=False)
class LaserResult:
    """One run over a log: every scan's final pose ``(S, 3)`` and covariance ``(S, 3,
    3)``, the online (causal) path, the reference, the scans' timestamps, the loop
    closures kept (pairs of scan indices), the wall landmarks ``(W, 4)`` (world
    segments ``x0, y0, x1, y1``), the scores and the timings."""

    log: str
    variant: str
    seed: int
    timestamp: np.ndarray
    pose: np.ndarray
    covariance: np.ndarray
    causal_pose: np.ndarray
    reference: np.ndarray
    closures: np.ndarray
    matched: np.ndarray
    walls: np.ndarray
    metrics: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    def measured(self) -> dict[str, str | int | float]:
        """Every score, count and timing, as ``rperc slam laser --json`` writes them."""
        total = sum(self.seconds.values())
        return {
            "log": self.log,
            "variant": self.variant,
            "seed": self.seed,
            **self.metrics,
            **self.counts,
            **{f"seconds_{k}": v for k, v in self.seconds.items()},
            "scans_per_second": len(self.pose) / total if total > 0 else math.inf,
        }

    def to_tum(self, path: str | Path) -> Path:
        """Writes the final estimate of every scan's pose, in log order, at the scans'
        (repaired, strictly increasing) timestamps in the TUM format."""
        from rperc.datasets import write_tum

        write_tum(path, self.timestamp, self.pose)
        return Path(path)

    def __repr__(self) -> str:
        m = self.metrics
        return (
            f"LaserResult({self.log}, {self.variant}, seed {self.seed}: {len(self.pose)} scans, "
            f"ATE {m['ate_rmse_m']:.3f} m (causal {m['ate_rmse_causal_m']:.3f} m), "
            f"NEES mean {m['nees_mean']:.2f}, {self.counts['loop_closures_accepted']} closures)"
        )


def _scores(result: _rperc.LaserRun, ref: np.ndarray) -> dict[str, float]:
    """ATE of the final and the causal path, loop and final errors and the robot NEES
    against the reference (the wall-SLAM experiment's scores)."""
    from rperc.slam.wallslam import loop_pairs, score

    final = score(result.pose, result.covariance, ref, loop_pairs(ref))
    causal = np.sqrt(np.mean(np.sum((result.causal_pose[:, :2] - ref[:, :2]) ** 2, axis=1)))
    return {
        "ate_rmse_m": final["ate_rmse"],
        "ate_rmse_causal_m": float(causal),
        "loop_error_m": final["loop_error"],
        "final_error_m": final["final_error"],
        "nees_mean": final["nees_mean"],
        "nees_median": final["nees_median"],
        "nees_in_band": final["nees_in_band"],
    }


def from_settings(settings: Mapping[str, object]) -> tuple[LaserConfig, LaserConfigOverrides]:
    """Settings read from JSON (nested by part, or by dotted name: ``icp.sigma``) on
    top of ``VARIANTS["loops"]``: the ``config=`` of :func:`run_laser` and the keyword
    overrides that keep an ``initial_pose`` the settings set (a config's own start is
    the reference's first pose)."""
    config = merged(VARIANTS["loops"], settings)
    start = "initial_pose" in settings
    return config, ({"initial_pose": config.initial_pose} if start else {})


def run_laser(
    log: CarmenLog,
    *,
    seed: int = 0,
    variant: str = "loops",
    config: LaserConfig | Mapping[str, object] | None = None,
    read_seconds: float = 0.0,
    **overrides: Unpack[LaserConfigOverrides],
) -> LaserResult:
    """Laser SLAM over a :class:`rperc.datasets.CarmenLog` from odometry drawn with
    ``seed``. ``variant`` is one of :data:`VARIANTS`. ``config`` is a
    :class:`rperc.config.LaserConfig` (``VARIANTS["loops"]``, the crate's defaults
    told the simulated odometry's noise, when None); keyword arguments override its
    fields, and the variant's changes (no loop closures, ...) are made on top. The
    pipeline starts at the reference's first pose unless ``initial_pose=`` is given.
    ``read_seconds`` (the time spent reading the log) is counted in the end-to-end
    speed."""
    from rperc.slam.wallslam import increments, noisy_controls

    seed = seed_number(seed)
    _variant_changes(variant)
    t0 = time.perf_counter()
    sc = log.scans
    ref = np.asarray(sc.pose, dtype=np.float64)
    if len(ref) < 2:
        raise ValueError(f"{log.path}: laser SLAM needs at least 2 scans, got {len(ref)}")
    exact, t = increments(ref)
    controls = np.r_[noisy_controls(exact, seed), [[t[-1], 0.0, 0.0]]]
    start = (float(ref[0, 0]), float(ref[0, 1]), float(ref[0, 2]))
    settings = run_config(variant, config, start, overrides).to_dict()
    prepare_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = _rperc.laser_run(
        np.asarray(sc.ranges, dtype=np.float64),
        np.asarray(sc.num_beams, dtype=np.int64),
        np.asarray(sc.angle_min, dtype=np.float64),
        np.asarray(sc.angle_increment, dtype=np.float64),
        np.asarray(sc.max_range, dtype=np.float64),
        controls,
        t,
        settings,
    )
    slam_s = time.perf_counter() - t0
    rejected = zip(out.rejection_reasons, out.rejected, strict=True)
    counts = {
        "scans": len(ref),
        "key_scans": len(out.keys),
        "scans_matched": int(np.count_nonzero(out.matched)),
        "loop_closures_accepted": len(out.closures),
        "loop_closures_rejected": out.closures_rejected,
        "loop_closure_attempts": out.closure_attempts,
        **{f"loop_closures_rejected_{why}": n for why, n in rejected},
        "wall_landmarks": len(out.walls),
        "wall_sightings": out.wall_factors,
        "wall_sightings_pruned": out.wall_factors_pruned,
    }
    return LaserResult(
        log=Path(log.path).name,
        variant=variant,
        seed=seed,
        timestamp=np.asarray(sc.timestamp, dtype=np.float64),
        pose=out.pose,
        covariance=out.covariance,
        causal_pose=out.causal_pose,
        reference=ref,
        closures=out.closures,
        matched=out.matched,
        walls=out.walls,
        metrics=_scores(out, ref),
        counts=counts,
        seconds={"read": read_seconds, "prepare": prepare_s, "slam": slam_s},
    )


def load_and_run(
    path: str | Path,
    *,
    seed: int = 0,
    variant: str = "loops",
    config: LaserConfig | Mapping[str, object] | None = None,
    **overrides: Unpack[LaserConfigOverrides],
) -> LaserResult:
    """Reads a CARMEN log (:func:`rperc.datasets.carmen.load_carmen_logged`: its
    warnings as log lines) and runs :func:`run_laser` on it, the reading timed too."""
    from rperc.datasets.carmen import load_carmen_logged

    _variant_changes(variant)
    t0 = time.perf_counter()
    log = load_carmen_logged(path)
    read_s = time.perf_counter() - t0
    return run_laser(
        log, seed=seed, variant=variant, config=config, read_seconds=read_s, **overrides
    )
