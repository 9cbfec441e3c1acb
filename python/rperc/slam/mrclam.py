"""One MR.CLAM robot through planar EKF-SLAM, scored as ``rperc slam mrclam`` and
``rperc bench mrclam`` report it (Vicon path and surveyed landmarks)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from rperc.slam.evaluation import RunReference
from rperc.slam.planar import PlanarSlam, SlamResult, mrclam_recording, variant_config

__all__ = ["mrclam_run"]


def mrclam_run(
    directory: str | Path,
    *,
    robot: int,
    variants: tuple[str, ...] = ("plain",),
    seed: int = 0,
    fix_interval: float = 1.0,
    fix_sigma: float = 0.1,
    span: tuple[float, float] | None = None,
    config: Mapping[str, object] | None = None,
) -> tuple[SlamResult, dict[str, float], RunReference]:
    """One MR.CLAM robot through planar EKF-SLAM with ``variants`` (the ``mrclam``
    preset, ``config`` on top): the result, its scores (``rperc slam mrclam``'s) and
    the reference. ``seed`` draws the external variant's fix noise."""
    from rperc.datasets import load_mrclam
    from rperc.slam.planar import mrclam_preset, mrclam_start

    run = load_mrclam(directory, robot=robot)
    if span is not None:
        from rperc.slam.calibration import mrclam_window

        run = mrclam_window(run, *span)
    cfg = {**mrclam_preset(robot), **mrclam_start(run), **(config or {})}
    cfg = variant_config(cfg, variants)
    # Fixes only for the external variant: even ignored, each would split a prediction.
    interval = fix_interval if "external" in variants else None
    ev = mrclam_recording(run, fix_interval=interval, fix_sigma=fix_sigma, seed=seed)
    result = PlanarSlam(cfg).run(ev, progress=True)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    aligned = result.ate(run.truth_t, truth, align=True)
    marks = np.c_[run.landmark_x, run.landmark_y]
    nees = result.nees(run.truth_t, truth, reference_landmarks=(run.landmark_id, marks))
    metrics = {
        "ate_m": result.ate(run.truth_t, truth).rmse,
        "ate_aligned_m": aligned.rmse,
        "landmark_rmse_aligned_m": result.landmark_rmse(
            run.landmark_id, marks, transform=aligned.transform
        ).rmse,
        "nees_mean": nees.mean,
        "nees_in_band": float(np.mean(nees.inside)),
    }
    ref: RunReference = {"truth": truth, "landmarks": marks, "label": "true path (Vicon)",
                         "nees": nees, "transform": None}  # fmt: skip
    return result, metrics, ref
