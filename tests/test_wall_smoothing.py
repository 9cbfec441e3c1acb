"""Batch smoothing of wall SLAM (rperc.slam.smoothing): against the numpy/scipy peer
(tests/oracles/wall_smoother.py: finite-difference Jacobians, SuperLU steps and
a dense inverse), against the truth of a simulated loop (better than the filter at
every seed, and consistent over seeds), the issue's ATE goal on the real logs, and
bad input."""

from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from oracles import wall_smoother

from rperc.datasets import TimestampRepairWarning, data_dir
from rperc.datasets.carmen import load_carmen
from rperc.scansim import write_loop_log
from rperc.slam import PlanarSlam
from rperc.slam import wallslam as ws
from rperc.slam.smoothing import SmoothedRun, smooth_walls

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def loop_log(tmp_path_factory: pytest.TempPathFactory) -> object:
    return load_carmen(write_loop_log(tmp_path_factory.mktemp("loop") / "loop.log", seed=1))


@pytest.fixture(scope="module")
def loop(loop_log: object) -> ws.PreparedLog:
    """The simulated loop's walls as a real log's: with the straightness floor, so
    that the shared floor's counting is exercised."""
    return ws.prepare(loop_log, straightness=ws.STRAIGHTNESS)


def _peer() -> ModuleType:
    """The numpy/scipy peer, from tests/oracles."""
    return wall_smoother


def test_smoother_matches_the_scipy_peer(loop):
    """The same optimum, covariances and biases as the peer, with the shared
    straightness floor on (repeated sightings of a stretch counted as the filter
    counts them)."""
    ref = _peer()
    _, controls, out = ref.wallslam_run(loop, seed=3)
    sm = smooth_walls(out, controls, loop.rows, loop.t)
    peer = ref.smooth(ref.wallslam_problem(loop, controls, out))
    np.testing.assert_allclose(sm.pose[:, :2], peer["pose"][:, :2], atol=1e-5)
    np.testing.assert_allclose(np.angle(np.exp(1j * (sm.pose[:, 2] - peer["pose"][:, 2]))), 0,
                               atol=1e-6)  # fmt: skip
    np.testing.assert_allclose(sm.covariance, peer["covariance"], rtol=1e-3, atol=1e-10)
    np.testing.assert_allclose(sm.bias, peer["bias"], atol=1e-6)
    # The native result behind it is frozen, its arrays read-only.
    assert isinstance(sm.bias, tuple) and isinstance(sm.iterations, int)
    with pytest.raises(ValueError, match="read-only"):
        sm.pose[0, 0] = 0.0
    assert sm.cost == pytest.approx(peer["cost"], rel=1e-6)
    assert isinstance(sm, SmoothedRun) and "poses" in repr(sm)
    again = pickle.loads(pickle.dumps(sm))
    np.testing.assert_array_equal(again.pose, sm.pose)
    assert again.bias == sm.bias


def test_smoothing_beats_the_filter_and_is_consistent(loop_log):
    """On the simulated loop (straight walls, so no straightness floor; 1 cm range
    noise; odometry drawn with exactly the stated noise and bias), where the filter
    is already at millimetres: over 10 seeds the smoothed path's mean ATE and loop
    error are below the filter's, and its NEES mean lies within the chi-square band
    of 3 x 10 dof / 10 (99 %, two-sided)."""
    from scipy.stats import chi2

    loop = ws.prepare(loop_log)
    scores = []
    for seed in range(10):
        res = ws.run_prepared(loop, seed=seed, smooth=True)
        smoothed = res.smoothed()
        scores.append([res.metrics["ate_rmse"], smoothed.metrics["ate_rmse"],
                       res.metrics["loop_error"], smoothed.metrics["loop_error"],
                       float(np.mean(smoothed.nees))])  # fmt: skip
    filt_ate, ate, filt_loop, loop_error, nees = np.mean(scores, axis=0)
    assert ate < filt_ate and loop_error < filt_loop, scores
    lo, hi = chi2.ppf([0.005, 0.995], 30) / 10
    assert lo < nees < hi, scores


def test_smoothing_is_consistent_in_the_corridor_with_bent_walls():
    """The simulated corridor loop of ``benchmarks/wall_corridor.py`` (1 m doorways,
    walls with 2 cm bends of their own shared by every sighting of a stretch, 1 cm of
    fresh noise per end, biased odometry), whose sightings are drawn from exactly the
    noise the filter is told: over seeds 0-7 the smoothed path's robot NEES is inside
    chi-square's two-sided 95 % band at about the expected rate, its mean inside the
    99 % band of 3 x 8 dof / 8, and its ATE below the filter's at every seed."""
    import argparse
    import importlib.util

    from scipy.stats import chi2

    spec = importlib.util.spec_from_file_location("wall_corridor", BENCH / "wall_corridor.py")
    assert spec is not None and spec.loader is not None
    corridor = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(corridor)
    args = argparse.Namespace(
        sigma=0.01, range=8.0, bias=True, association="nn", max_angle_sd_now=2.0,
        first_estimates=True, bias_states=True, wall_innovation_now="segment",
        door=1.0, recess=0.0, gap_now=0.5, bend=0.02, shared=True, smooth=True,
    )  # fmt: skip
    runs = [corridor.run(seed, 0.0, 0.0, args) for seed in range(8)]
    assert all(r["smoothed_ate_rmse"] < r["ate_rmse"] for r in runs), runs
    assert float(np.mean([r["smoothed_nees_in_band"] for r in runs])) >= 0.9
    lo, hi = chi2.ppf([0.005, 0.995], 24) / 8
    assert lo < float(np.mean([r["smoothed_nees_mean"] for r in runs])) < hi


def _causal_bound() -> ModuleType:
    """``benchmarks/wall_causal_bound.py``."""
    sys.path.insert(0, str(BENCH))
    import wall_causal_bound

    return wall_causal_bound


def test_causal_optimum_is_the_batch_over_the_past(loop):
    """The causal bound's solve at scan ``k`` is the scipy peer's optimum over the
    controls up to ``k``'s time and the sightings at or before it (an independent
    truncation), and at the last scan the full smoothing; on the simulated loop the
    causal path is the filter's to millimetres."""
    cb, peer = _causal_bound(), _peer()
    _, controls, out = peer.wallslam_run(loop, seed=2)
    filtered, _ = ws.at_scans(out, loop.t)
    walls = (out.walls.id, out.walls.line)
    k = 150
    ours = cb.smooth_upto(k, controls, loop, out.wall_pairing, walls, filtered[: k + 1], out.config)
    t = loop.t
    seen = loop.rows[:, 0] <= t[k]
    truncated = np.r_[controls[controls[:, 0] <= t[k]], [[t[k], 0.0, 0.0]]]
    theirs = peer.smooth(peer.Problem(
        truncated, t[: k + 1], filtered[: k + 1], loop.rows[seen], out.wall_pairing[seen],
        out.walls.id, out.walls.line, speed_var=ws.SPEED_SIGMA**2, turn_var=ws.TURN_SIGMA**2,
        bias_sd=(ws.SPEED_BIAS, ws.TURN_BIAS), start=loop.reference[0], start_var=np.zeros(3),
        shared_sd=loop.straightness,
    ))  # fmt: skip
    np.testing.assert_allclose(ours.pose[:, :2], theirs["pose"][:, :2], atol=1e-5)
    # From the same start as smooth_walls (the filter's poses, which also place the
    # stretches the shared floor counts), the last scan's solve is the full smoothing.
    last = cb.smooth_upto(len(t) - 1, controls, loop, out.wall_pairing, walls, filtered,
                          out.config)  # fmt: skip
    full = smooth_walls(out, controls, loop.rows, t)
    np.testing.assert_allclose(last.pose[:, :2], full.pose[:, :2], atol=1e-9)
    scans, causal = cb.causal_path(controls, loop, out.wall_pairing, walls, filtered, out.config,
                                   every=60)  # fmt: skip
    assert scans[0] == 0 and scans[-1] == len(t) - 1 and np.all(np.diff(scans) > 0)
    np.testing.assert_array_equal(causal[0], loop.reference[0])
    # The EKF is the causal optimum up to its linearisation, small on this loop: the two
    # agree within 5 mm where each is about 15 mm from the truth.
    assert np.max(np.hypot(*(causal[:, :2] - filtered[scans, :2]).T)) < 0.005


def test_oracle_pairing_groups_sightings_of_one_wall(loop):
    """The causal bound's oracle association on the simulated loop, whose reference is
    the truth: every sighting it keeps lies within ``ORACLE_OFFSET`` of its group's
    first sighting's line at both ends when placed with the truth (written out here
    in numpy), and the vague ones are left out unless asked for."""
    cb = _causal_bound()
    pairing = cb.oracle_pairing(loop)
    rows, ref = loop.rows, loop.reference
    vague = rows[:, 5] > math.radians(2.0) ** 2
    assert np.all(pairing[vague] == -1) and np.all(pairing[~vague] >= 0)
    assert np.all(cb.oracle_pairing(loop, vague=True) >= 0)
    pose = ref[np.searchsorted(loop.t, rows[:, 0])]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    x, y = rows[:, [6, 8]], rows[:, [7, 9]]
    ends = [pose[:, :2] + np.c_[c * x[:, k] - s * y[:, k], s * x[:, k] + c * y[:, k]]
            for k in (0, 1)]  # fmt: skip
    for g in np.unique(pairing[pairing >= 0]):
        members = np.flatnonzero(pairing == g)
        a, b = ends[0][members[0]], ends[1][members[0]]
        n = np.array([-(b - a)[1], (b - a)[0]]) / np.hypot(*(b - a))
        for end in ends:
            assert np.all(np.abs((end[members] - a) @ n) <= cb.ORACLE_OFFSET + 1e-12), g


@pytest.mark.parametrize(("log", "repaired"), [("intel", 4), ("aces", 0)])
def test_smoothing_reaches_the_issue_goal_on_the_real_logs(log, repaired):
    """Issue 11's goal, ATE <= 0.3 m, by the smoothed path over 10 odometry seeds
    (the filter's own causal path misses it on ACES). Intel's four scan times that
    step back are repaired on reading (the run does not use scan times)."""
    root = data_dir()
    path = None if root is None else Path(root) / "carmen" / f"{log}.log"
    if path is None or not path.is_file():
        pytest.skip(f"RPERC_DATA/carmen/{log}.log is absent")
    if repaired:
        with pytest.warns(TimestampRepairWarning, match=f"{repaired} of"):
            carmen = load_carmen(path)
    else:
        carmen = load_carmen(path)
    prepared = ws.prepare(carmen, straightness=ws.STRAIGHTNESS)
    ates = [ws.run_prepared(prepared, seed=s, smooth=True).smoothed().metrics["ate_rmse"]
            for s in range(10)]  # fmt: skip
    assert float(np.mean(ates)) <= 0.3, ates


def test_bad_input_is_named(loop):
    res, controls, out = _peer().wallslam_run(loop, seed=0)
    t = loop.t
    config = {k: v for k, v in res.config.items() if k != "straightness"}
    no_walls = PlanarSlam(config).run_arrays(controls, np.zeros((0, 3)))
    with pytest.raises(ValueError, match="no walls"):
        smooth_walls(no_walls, controls, loop.rows, t)
    with pytest.raises(ValueError, match="before the run's first event"):
        smooth_walls(out, controls, loop.rows, t - 1.0)
    with pytest.raises(ValueError, match="times"):
        smooth_walls(out, controls, loop.rows, t[::-1].copy())
    with pytest.raises(ValueError, match="start prior"):
        smooth_walls(out, controls, loop.rows, t[1:].copy())
    with pytest.raises(ValueError, match="row"):
        smooth_walls(out, controls, loop.rows, np.r_[t[0], t[1:] + 1e-3])
    bad = loop.rows.copy()
    bad[0, 3] = math.nan
    with pytest.raises(ValueError, match="walls"):
        smooth_walls(out, controls, bad, t)
    with pytest.raises(ValueError, match="max_iterations"):
        smooth_walls(out, controls, loop.rows, t, max_iterations=0)
    with pytest.raises(ValueError, match="tolerance"):
        smooth_walls(out, controls, loop.rows, t, tolerance=-1.0)
