"""One MR.CLAM robot through planar EKF-SLAM, scored as ``rperc slam mrclam`` and
``rperc bench mrclam`` report it (Vicon path and surveyed landmarks)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from rperc.slam.evaluation import RunReference
from rperc.slam.planar import (
    PlanarSlam,
    Recording,
    SlamResult,
    mrclam_recording,
    variant_config,
)

__all__ = ["mrclam_run"]


#: Seconds between the smoothed path's poses where the robot sees nothing (it has a
#: pose at every sighting as well): MR.CLAM's robots drive at most 0.5 m/s, 5 cm a
#: step, under the landmarks' own error.
SMOOTH_INTERVAL = 0.1

#: The smooth variant's ``point_correlation_time`` (s): one robot's sightings of a
#: landmark within 5 s share much of their error (against Vicon, their range errors
#: correlate 0.26-0.46 at lags under 5 s and under 0.1 beyond), so a burst of them
#: counts as about one. Chosen by leave-one-robot-out on that correlation, and
#: checked on the held-out robot's NEES (``benchmarks/mrclam_smoothing.py``; figures:
#: ``docs/decisions.md``).
SIGHTING_CORRELATION_TIME = 5.0


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
    smoother: Mapping[str, object] | None = None,
) -> tuple[SlamResult, dict[str, float], RunReference]:
    """One MR.CLAM robot through planar EKF-SLAM with ``variants`` (the ``mrclam``
    preset, ``config`` on top): the result, its scores (``rperc slam mrclam``'s) and
    the reference. ``seed`` draws the external variant's fix noise. With ``smooth``
    the scores are the smoothed run's (:func:`rperc.slam.smoothing.smooth`: every
    sighting used both ways in time, with the filter's association; ``smoother``
    overrides its :class:`rperc.config.SmootherConfig` fields, whose
    ``point_correlation_time`` is :data:`SIGHTING_CORRELATION_TIME` here), and
    ``ate_aligned_causal_m`` is the filter's and ``events`` its event count (the
    smoothed result's rows are its poses)."""
    from rperc.datasets import load_mrclam
    from rperc.slam.planar import mrclam_preset, mrclam_start

    if "smooth" in variants and {"anchor", "external"} & set(variants):
        raise ValueError(
            "the smooth variant models odometry and sightings only: combine it with "
            "plain or freeze, not with anchor or external"
        )
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
    marks = np.c_[run.landmark_x, run.landmark_y]
    if "smooth" in variants:
        options = {"point_correlation_time": SIGHTING_CORRELATION_TIME, **(smoother or {})}
        reference = (run.truth_t, truth, (run.landmark_id, marks))
        return _smoothed_scores(result, ev, reference, options)
    aligned = result.ate(run.truth_t, truth, align=True)
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


def _smoothed_scores(
    result: SlamResult,
    ev: Recording,
    reference: tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]],
    options: Mapping[str, object],
) -> tuple[SlamResult, dict[str, float], RunReference]:
    """The smooth variant: the filter's ``result`` smoothed with the smoother's
    ``options``, scored against ``reference`` (truth times, truth, landmarks) as a
    run is, with the smoothed path and map in the result (the filter's causal ATE
    kept)."""
    from rperc.slam.smoothing import pose_times, smooth

    t_truth, truth, landmarks = reference
    times = pose_times(result, ev.detections, interval=SMOOTH_INTERVAL)
    out = smooth(result, ev.controls, times, detections=ev.detections, config=options)
    causal = result.ate(t_truth, truth, align=True).rmse
    smoothed = out.to_result(result)
    aligned = smoothed.ate(t_truth, truth, align=True)
    nees = smoothed.nees(t_truth, truth)
    metrics = {
        "ate_m": smoothed.ate(t_truth, truth).rmse,
        "ate_aligned_m": aligned.rmse,
        "ate_aligned_causal_m": causal,
        "events": len(result.seconds),
        "landmark_rmse_aligned_m": smoothed.landmark_rmse(
            *landmarks, transform=aligned.transform
        ).rmse,
        "nees_mean": nees.mean,
        "nees_in_band": float(np.mean(nees.inside)),
    }
    ref: RunReference = {"truth": truth, "landmarks": landmarks[1],
                         "label": "true path (Vicon)", "nees": nees, "transform": None}  # fmt: skip
    return smoothed, metrics, ref
