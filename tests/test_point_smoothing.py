"""Batch smoothing of point-landmark SLAM (rperc.slam.smoothing.smooth with
detections): against the numpy/scipy peer (tests/oracles/wall_smoother.py with its
point terms: finite-difference Jacobians, SuperLU steps, a dense inverse), against
the truth of the simulated world (better than the filter at every seed, consistent
over seeds), the issue's MR.CLAM goal on every robot's held-out half, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from oracles import wall_smoother as peer

from rperc.config import SimConfig
from rperc.slam import PlanarSlam, evaluation
from rperc.slam.planar import sim_slam_config, simulate
from rperc.slam.smoothing import smooth

SIM = SimConfig(steps=300)


def _run(seed: int, sim: SimConfig = SIM):
    """One simulated run, its filter result, and the smoother's pose times."""
    world = simulate(sim, seed=seed)
    rec = world.recording
    result = PlanarSlam(sim_slam_config(sim)).run(rec)
    times = np.unique(np.r_[result.t[0], rec.detections[:, 0]])
    return world, result, times


def test_point_smoother_matches_the_scipy_peer():
    """The same optimum and covariances as the peer, biases of a depth camera and of
    the odometry taken off by both (the simulated detections are distorted by the
    camera model)."""
    sim = SimConfig(steps=120)
    world, _, _ = _run(4, sim)
    rec = world.recording
    bias = {"range_offset": 0.05, "range_scale": 1.02, "range_is_depth": True,
            "bearing_offset": -0.01, "bearing_scale": 0.98,
            "control_scale": [0.95, 0.9]}  # fmt: skip
    # A camera sees ahead only: the detections within 75 degrees of its axis.
    ahead = np.abs(rec.detections[:, 2]) < 1.3
    seen, ids = rec.detections[ahead], rec.detection_ids[ahead]
    b = seen[:, 2]
    measured = np.c_[
        seen[:, 0],
        bias["range_offset"] + bias["range_scale"] * seen[:, 1] * np.cos(b),
        bias["bearing_offset"] + bias["bearing_scale"] * b,
    ]
    config = {**sim_slam_config(sim), "bias": bias}
    out = PlanarSlam(config).run_arrays(rec.controls, measured, detection_ids=ids)
    assert (out.point_pairing >= 0).sum() > 100
    times = np.unique(np.r_[out.t[0], measured[:, 0]])
    sm = smooth(out, rec.controls, times, detections=measured)
    rows = np.searchsorted(out.t, times, side="right") - 1
    marks = dict(zip(out.landmark_id.tolist(), out.landmark_mean, strict=True))
    problem = peer.Problem(
        rec.controls, times, out.pose[rows], np.zeros((0, 10)), np.zeros(0, int),
        np.zeros(0, int), np.zeros((0, 2)), speed_var=sim.speed_variance,
        turn_var=sim.turn_rate_variance, bias_sd=None, start=config["initial_pose"],
        start_var=config["initial_pose_variance"],
        points=peer.Points(measured, out.point_pairing, times, marks, bias),
        point_var=(sim.range_variance, sim.bearing_variance), control_scale=(0.95, 0.9),
    )  # fmt: skip
    ref = peer.smooth(problem)
    np.testing.assert_allclose(sm.pose[:, :2], ref["pose"][:, :2], atol=1e-5)
    np.testing.assert_allclose(peer.wrap(sm.pose[:, 2] - ref["pose"][:, 2]), 0, atol=1e-6)
    np.testing.assert_allclose(sm.covariance, ref["covariance"], rtol=1e-3, atol=1e-10)
    order = np.searchsorted(sm.landmark_id, problem.pt.ids)
    np.testing.assert_allclose(sm.landmark_mean[order], ref["marks"], atol=1e-5)
    np.testing.assert_allclose(sm.landmark_covariance[order], ref["mark_cov"], rtol=1e-3,
                               atol=1e-10)  # fmt: skip


def test_smoothing_beats_the_filter_and_is_consistent():
    """Over the seeds the smoothed path's mean squared error is below the filter's
    (the smoother uses every sighting, the filter only the past ones), and its NEES
    mean lies in the chi-square band of the runs' count."""
    seeds, nees, filtered, smoothed_sq = range(8), [], 0.0, 0.0
    for seed in seeds:
        world, result, times = _run(seed)
        rec, truth = world.recording, world.truth
        # One true pose per time (the last of the events that share it).
        truth = truth[np.r_[truth[1:, 0] != truth[:-1, 0], True]]
        sm = smooth(result, rec.controls, times, detections=rec.detections)
        filtered += result.ate(truth[:, 0], truth[:, 1:]).rmse ** 2
        smoothed = sm.to_result(result)
        smoothed_sq += smoothed.ate(truth[:, 0], truth[:, 1:]).rmse ** 2
        assoc = evaluation.associate(sm.times, sm.pose, truth[:, 0], truth[:, 1:])
        nees.append(evaluation.pose_nees(assoc, sm.covariance).mean)
    assert smoothed_sq < filtered
    n = len(seeds)
    from scipy.stats import chi2

    lo, hi = chi2.ppf(0.005, 3 * n) / n, chi2.ppf(0.995, 3 * n) / n
    assert lo < np.mean(nees) < hi, nees


def test_bad_input_is_named():
    world, result, times = _run(1, SimConfig(steps=60))
    rec = world.recording
    with pytest.raises(ValueError, match="detection rows"):
        smooth(result, rec.controls, times, detections=rec.detections[1:])
    with pytest.raises(ValueError, match="not one of the poses' times"):
        smooth(result, rec.controls, times[::2], detections=rec.detections)
    sm = smooth(result, rec.controls, times, detections=rec.detections)
    other = PlanarSlam(sim_slam_config(SimConfig(steps=60))).run(
        _run(2, SimConfig(steps=5))[0].recording
    )
    with pytest.raises(ValueError, match="landmarks differ"):
        sm.to_result(other)
    with pytest.raises(ValueError, match="point_huber"):
        smooth(result, rec.controls, times, detections=rec.detections, point_huber=0.0)
    anchored = PlanarSlam({**sim_slam_config(SimConfig(steps=60)), "anchor": True})
    with pytest.raises(ValueError, match="anchor"):
        smooth(anchored.run(rec), rec.controls, times, detections=rec.detections)


@pytest.mark.parametrize("span", [(444.0, 1e9), (0.0, 1e9)], ids=["held-out-half", "whole-run"])
@pytest.mark.parametrize("robot", [1, 2, 3])
def test_mrclam_goal(data, robot, span):
    """Issue 33's MR.CLAM goal, plain aligned ATE at most 0.25 m on every robot, on
    the half no preset was fitted on and on the whole run, below the filter's; the
    smoothed covariance is not over-confident (robot NEES mean at most 6, the laser
    issue's bound for 3 dof)."""
    from rperc.slam.mrclam import mrclam_run

    _, m, _ = mrclam_run(data / "mrclam6", robot=robot, variants=("smooth",), span=span)
    assert m["ate_aligned_m"] <= 0.25
    assert m["ate_aligned_m"] < m["ate_aligned_causal_m"]
    assert m["nees_mean"] <= 6.0


def test_smooth_refuses_what_it_does_not_model(tmp_path, capsys):
    """The smoother has no anchor frame and no fixes: combining them is an error
    (exit 2), not a silently different run."""
    from rperc.cli import main

    assert main(["slam", "mrclam", str(tmp_path), "--variant", "smooth,external"]) == 2
    assert "not with anchor or external" in capsys.readouterr().err


@pytest.mark.parametrize("association", ["known", "nn", "jcbb"])
@pytest.mark.parametrize("compression", ["auto", "off"])
def test_point_pairing_has_one_entry_per_detection(association, compression):
    """Every detection gets its pairing, whatever the association and the compressed
    filter: those paired are the accepted ones plus those that admitted a landmark,
    and each names a landmark of the map."""
    sim = SimConfig(steps=200)
    world = simulate(sim, seed=5)
    rec = world.recording
    config = {**sim_slam_config(sim), "association": association, "compression": compression,
              "freeze_after": 30}  # fmt: skip
    out = PlanarSlam(config).run(rec)
    pairing = out.point_pairing
    assert pairing is not None and len(pairing) == len(rec.detections)
    assert (pairing >= 0).sum() == out.statistics["accepted"] + out.statistics["new"]
    assert set(pairing[pairing >= 0].tolist()) <= set(out.landmark_id.tolist())


def test_bench_refuses_smooth_with_anchor_or_external_when_parsing():
    from rperc.bench.suites.mrclam import parse_variants

    assert parse_variants("plain,smooth,freeze+smooth") == ["plain", "smooth", "freeze+smooth"]
    for bad in ("smooth+external", "anchor+smooth"):
        with pytest.raises(ValueError, match="not with anchor or external"):
            parse_variants(bad)


def test_pose_times_are_the_first_event_and_every_sighting_and_refuse_bad_input():
    """Against set arithmetic: the run's first event, every sighting time from it on,
    and with an interval the grid from it (each checked independently); a grid too
    large for memory, a zero interval, a 1-D table or a NaN time are named errors."""
    from rperc.slam.smoothing import pose_times

    world, result, _ = _run(1, SimConfig(steps=60))
    rows = world.recording.detections
    t0 = float(result.t[0])
    expected = sorted({t0} | {float(t) for t in rows[:, 0] if t >= t0})
    np.testing.assert_array_equal(pose_times(result, rows), expected)
    with_grid = pose_times(result, rows, interval=0.25)
    assert set(expected) <= set(with_grid.tolist())
    assert np.all(np.diff(with_grid) > 0) and np.max(np.diff(with_grid)) <= 0.25 + 1e-12
    with pytest.raises(MemoryError, match="interval"):
        pose_times(result, rows, interval=1e-15)
    with pytest.raises(ValueError, match="interval"):
        pose_times(result, rows, interval=0.0)
    with pytest.raises(ValueError, match="2-D"):
        pose_times(result, rows[:, 0])
    bad = rows.copy()
    bad[2, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        pose_times(result, bad)
