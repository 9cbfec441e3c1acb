"""rperc.slam.evaluation against independent oracles: closed forms (linear motion,
known rigid motions), a brute-force angle search, evo's Umeyama alignment and APE
(the translation part, with and without alignment), scipy's chi-square quantiles,
NEES written with an explicit inverse, and MR.CLAM's real ground truth."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from evo.core import geometry, metrics, trajectory
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import chi2

from rperc.datasets import load_mrclam, load_victoria_park
from rperc.slam.evaluation import (
    Se2Transform,
    align_se2,
    associate,
    ate,
    gps_error,
    landmark_error,
    pose_nees,
    trajectory_error,
    wrap_angle,
)

finite = st.floats(-1e3, 1e3, allow_nan=False)


def rotation(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def move(theta: float, t: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Poses moved rigidly, written out here (not through Se2Transform)."""
    out = poses.copy()
    out[:, :2] = poses[:, :2] @ rotation(theta).T + t
    out[:, 2] = np.arctan2(np.sin(poses[:, 2] + theta), np.cos(poses[:, 2] + theta))
    return out


def random_path(rng: np.random.Generator, n: int) -> np.ndarray:
    xy = rng.normal(size=(n, 2)).cumsum(axis=0)
    return np.c_[xy, rng.uniform(-math.pi, math.pi, n)]


def evo_trajectory(t: np.ndarray, poses: np.ndarray) -> trajectory.PoseTrajectory3D:
    """evo's own trajectory type, built from positions at z = 0 and yaw quaternions."""
    n = len(poses)
    xyz = np.c_[poses[:, :2], np.zeros(n)]
    wxyz = np.c_[np.cos(poses[:, 2] / 2), np.zeros(n), np.zeros(n), np.sin(poses[:, 2] / 2)]
    return trajectory.PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=wxyz, timestamps=t)


def evo_ape_rmse(t: np.ndarray, reference: np.ndarray, estimate: np.ndarray, align: bool) -> float:
    ref, est = evo_trajectory(t, reference), evo_trajectory(t, estimate)
    if align:
        est.align(ref)  # SE(3) Umeyama, no scale: evo_ape -a
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    return float(ape.get_statistic(metrics.StatisticsType.rmse))


# ------------------------------------------------------------------ angles


@given(finite)
def test_wrap_angle_lands_in_half_open_interval_and_keeps_the_angle(a: float) -> None:
    w = float(wrap_angle(a))
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)


def test_wrap_angle_keeps_pi_and_maps_minus_pi_to_pi() -> None:
    assert float(wrap_angle(math.pi)) == math.pi
    assert float(wrap_angle(-math.pi)) == math.pi


# ------------------------------------------------------------------ association


def linear_motion(t: np.ndarray) -> np.ndarray:
    """Constant velocity and turn rate: linear in every coordinate, the heading
    crossing +-pi several times, so linear interpolation is exact."""
    return np.c_[1.0 + 0.5 * t, -2.0 + 0.25 * t, wrap_angle(3.0 + 0.9 * t)]


def test_interpolation_is_exact_on_linear_motion_through_pi() -> None:
    t_ref = np.arange(0.0, 20.0, 0.1)  # headings step 0.09 rad, through pi 3 times
    rng = np.random.default_rng(3)
    t_est = np.sort(rng.uniform(0.0, t_ref[-1], 500))
    assoc = associate(t_est, linear_motion(t_est), t_ref, linear_motion(t_ref))
    assert assoc.matched == assoc.total == 500
    truth = linear_motion(t_est)
    np.testing.assert_allclose(assoc.reference[:, :2], truth[:, :2], atol=1e-12)
    np.testing.assert_allclose(wrap_angle(assoc.reference[:, 2] - truth[:, 2]), 0.0, atol=1e-12)
    assert np.all(np.abs(assoc.reference[:, 2]) <= math.pi)


def test_interpolated_heading_takes_the_shorter_arc() -> None:
    # From 3.0 to -3.0 rad is a 0.28 rad turn through pi, not 6 rad back through 0.
    assoc = associate([0.5], [[0, 0, 0]], [0.0, 1.0], [[0, 0, 3.0], [0, 0, -3.0]])
    assert math.isclose(abs(assoc.reference[0, 2]), math.pi, abs_tol=1e-12)


def test_association_counts_every_unmatched_estimate() -> None:
    t_ref = np.array([0.0, 1.0, 2.0, 5.0, 6.0])  # a 3 s gap between 2 and 5
    ref = np.zeros((5, 3))
    t_est = np.array([-1.0, -0.5, 0.0, 0.5, 2.0, 3.0, 4.0, 5.0, 6.0, 6.5, 7.0, 8.0])
    assoc = associate(t_est, np.zeros((12, 3)), t_ref, ref, max_gap=1.5)
    # 3.0 and 4.0 fall in the gap; 2.0 and 5.0 hit samples exactly and are kept.
    assert (assoc.before, assoc.after, assoc.in_gap) == (2, 3, 2)
    assert assoc.estimate_index.tolist() == [2, 3, 4, 7, 8]
    assert assoc.matched + assoc.unmatched == assoc.total == 12
    no_limit = associate(t_est, np.zeros((12, 3)), t_ref, ref)
    assert no_limit.matched == 7 and no_limit.in_gap == 0
    assert "5 of 12 matched" in repr(assoc) and "2 in gaps" in repr(assoc)


def test_association_keeps_the_estimate_order_and_works_on_points() -> None:
    t_ref = np.arange(10.0)
    ref = np.c_[t_ref, 2 * t_ref]
    t_est = np.array([7.5, 1.25, 3.0])
    assoc = associate(t_est, np.zeros((3, 2)), t_ref, ref)
    np.testing.assert_allclose(assoc.reference, [[7.5, 15.0], [1.25, 2.5], [3.0, 6.0]])
    assert assoc.estimate_index.tolist() == [0, 1, 2]


POSES = np.zeros((3, 3))
T3 = np.arange(3.0)


@pytest.mark.parametrize(
    ("args", "kwargs", "name"),
    [
        ((T3, POSES, T3, POSES * np.nan), {}, "reference"),
        (([0.0, np.nan, 2.0], POSES, T3, POSES), {}, "t_estimate"),
        ((T3, np.zeros((3, 4)), T3, POSES), {}, "estimate"),
        ((T3, POSES, T3, np.zeros((3, 2))), {}, "reference"),
        ((T3[:2], POSES, T3, POSES), {}, "t_estimate"),
        (([], np.zeros((0, 3)), T3, POSES), {}, "t_estimate"),
        ((T3, POSES, [0.0, 2.0, 1.0], POSES), {}, "t_reference"),
        ((T3, POSES, [0.0, 1.0, 1.0], POSES), {}, "t_reference"),
        ((T3[:1], POSES[:1], T3[:1], POSES[:1]), {}, "t_reference"),
        ((T3, POSES, T3, POSES), {"max_gap": 0.0}, "max_gap"),
        ((T3 + 10, POSES, T3, POSES), {}, "only 0 of 3"),
        ((T3, POSES, T3, POSES), {"min_matches": 4}, "only 3 of 3"),
    ],
)
def test_association_refuses_bad_input_by_name(args: tuple, kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        associate(*args, **kwargs)


def test_association_refuses_non_numbers() -> None:
    with pytest.raises(TypeError, match="t_estimate"):
        associate(["a", "b"], POSES[:2], T3, POSES)


# ------------------------------------------------------------------ alignment


@given(
    st.floats(-math.pi, math.pi),
    st.tuples(finite, finite),
    st.integers(2, 40),
    st.integers(0, 2**32 - 1),
)
def test_alignment_recovers_a_known_rigid_motion(
    theta: float, shift: tuple[float, float], n: int, seed: int
) -> None:
    src = np.random.default_rng(seed).uniform(-10, 10, size=(n, 2))
    dst = src @ rotation(theta).T + np.array(shift)
    fit = align_se2(src, dst)
    assert abs(float(wrap_angle(fit.theta - theta))) < 1e-9
    np.testing.assert_allclose(fit.translation, shift, atol=1e-8)
    np.testing.assert_allclose(fit.apply_points(src), dst, atol=1e-8)
    np.testing.assert_allclose(fit.matrix() @ np.r_[src[0], 1.0], np.r_[dst[0], 1.0], atol=1e-8)


def alignment_cost(theta: float, src: np.ndarray, dst: np.ndarray) -> float:
    """The best cost for a fixed angle: the translation then matches the centroids."""
    moved = src @ rotation(theta).T
    resid = moved - moved.mean(axis=0) - (dst - dst.mean(axis=0))
    return float(np.sum(resid**2))


@pytest.mark.parametrize("seed", range(5))
def test_alignment_beats_a_brute_force_angle_search(seed: int) -> None:
    rng = np.random.default_rng(seed)
    src = rng.normal(size=(30, 2)) * 3
    dst = src @ rotation(rng.uniform(-3, 3)).T + rng.normal(size=2) + rng.normal(size=(30, 2))
    fit = align_se2(src, dst)
    best = alignment_cost(fit.theta, src, dst)
    grid = np.linspace(-math.pi, math.pi, 20001)
    costs = [alignment_cost(a, src, dst) for a in grid]
    assert best <= min(costs) + 1e-9
    assert abs(float(wrap_angle(fit.theta - grid[int(np.argmin(costs))]))) < 1e-3
    moved = fit.apply_points(src)
    assert math.isclose(float(np.sum((moved - dst) ** 2)), best, rel_tol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_alignment_agrees_with_evo_umeyama(seed: int) -> None:
    rng = np.random.default_rng(seed)
    src = rng.normal(size=(25, 2)) * 4
    dst = src @ rotation(rng.uniform(-3, 3)).T + rng.normal(size=2) + 0.3 * rng.normal(size=(25, 2))
    r, t, _ = geometry.umeyama_alignment(
        np.r_[src.T, np.zeros((1, 25))], np.r_[dst.T, np.zeros((1, 25))]
    )
    fit = align_se2(src, dst)
    np.testing.assert_allclose(fit.rotation, r[:2, :2], atol=1e-10)
    np.testing.assert_allclose(fit.translation, t[:2], atol=1e-10)
    assert abs(r[2, 2] - 1.0) < 1e-10  # evo also turns about z only


def test_alignment_refuses_degenerate_and_mismatched_sets() -> None:
    with pytest.raises(ValueError, match="undetermined"):
        align_se2([[1.0, 2.0]] * 4, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 2.0]])
    with pytest.raises(ValueError, match="undetermined"):
        align_se2([[0.0, 0.0], [1.0, 0.0]], [[3.0, 3.0], [3.0, 3.0]])
    with pytest.raises(ValueError, match="target"):
        align_se2([[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0]])
    with pytest.raises(ValueError, match="source"):
        align_se2([[0.0, np.inf], [1.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]])


def test_transform_moves_poses_and_turns_headings() -> None:
    tf = Se2Transform(math.pi / 2, np.array([1.0, 0.0]))
    np.testing.assert_allclose(
        tf.apply_poses([[1.0, 0.0, 3.0]]), [[1.0, 1.0, 3.0 + math.pi / 2 - 2 * math.pi]]
    )
    assert "theta=1.5708" in repr(tf)


# ------------------------------------------------------------------ ATE


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("align", [False, True])
def test_ate_matches_evo_ape(seed: int, align: bool) -> None:
    rng = np.random.default_rng(seed)
    n = 200
    t = np.cumsum(rng.uniform(0.05, 0.2, n))
    truth = random_path(rng, n)
    est = move(rng.uniform(-0.3, 0.3), rng.normal(size=2), truth)
    est += rng.normal(scale=[0.2, 0.2, 0.05], size=(n, 3))
    ours = ate(t, est, t, truth, align=align)
    assert ours.rmse == pytest.approx(evo_ape_rmse(t, truth, est, align), rel=1e-9)
    assert ours.matched == n and (ours.transform is not None) == align


def test_ate_of_a_rigidly_moved_path_is_zero_once_aligned() -> None:
    rng = np.random.default_rng(11)
    t = np.arange(100.0)
    truth = random_path(rng, 100)
    est = move(0.7, np.array([3.0, -4.0]), truth)
    plain = ate(t, est, t, truth)
    aligned = ate(t, est, t, truth, align=True)
    assert plain.rmse > 1.0
    assert aligned.rmse < 1e-9 and aligned.heading_rmse < 1e-9
    assert aligned.transform is not None
    assert abs(float(wrap_angle(aligned.transform.theta + 0.7))) < 1e-12
    # Without alignment, the heading error is the rotation itself at every step.
    np.testing.assert_allclose(plain.heading_error, 0.7, atol=1e-12)
    assert "aligned, 100 of 100 poses" in repr(aligned)


def test_ate_heading_error_wraps_through_pi() -> None:
    t = np.arange(3.0)
    truth = np.c_[t, t, [3.1, -3.1, 0.0]]
    est = np.c_[t, t, [-3.1, 3.1, 0.1]]
    err = ate(t, est, t, truth).heading_error
    np.testing.assert_allclose(err, [2 * math.pi - 6.2, 6.2 - 2 * math.pi, 0.1], atol=1e-12)


def test_trajectory_error_needs_poses() -> None:
    assoc = associate(T3, np.zeros((3, 2)), T3, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="poses"):
        trajectory_error(assoc)


def test_aligned_ate_needs_two_matches() -> None:
    with pytest.raises(ValueError, match="need 2"):
        ate([1.0, 9.0], np.zeros((2, 3)), [0.0, 2.0], np.zeros((2, 3)), align=True)


# ------------------------------------------------------------------ landmarks


def test_landmark_error_by_id_with_the_paths_alignment() -> None:
    rng = np.random.default_rng(5)
    ref_ids = np.arange(6, 21)
    ref = rng.uniform(-5, 5, size=(15, 2))
    t = np.arange(50.0)
    truth = random_path(rng, 50)
    theta, shift = -1.1, np.array([2.0, 0.5])
    # The estimate lives in a frame turned by theta: path and landmarks alike.
    est_path = move(theta, shift, truth)
    order = rng.permutation(15)[:12]
    noise = rng.normal(scale=0.05, size=(12, 2))
    est_marks = ref[order] @ rotation(theta).T + shift + noise
    est_ids = np.append(ref_ids[order], [99])  # one landmark nobody surveyed
    est_marks = np.vstack([est_marks, [0.0, 0.0]])
    path = ate(t, est_path, t, truth, align=True)
    lm = landmark_error(est_ids, est_marks, ref_ids, ref, transform=path.transform)
    # Written out: the noise, turned back into the reference frame, is the error.
    np.testing.assert_allclose(lm.error, np.hypot(*noise.T), atol=1e-9)
    assert lm.rmse == pytest.approx(math.sqrt(np.mean(np.sum(noise**2, axis=1))), rel=1e-9)
    assert lm.ids.tolist() == ref_ids[order].tolist()
    assert lm.unmatched_estimate_ids == (99,)
    assert sorted(lm.missing_reference_ids) == sorted(set(ref_ids) - set(ref_ids[order]))
    raw = landmark_error(est_ids, est_marks, ref_ids, ref)
    assert raw.rmse > 1.0 and raw.transform is None


def test_landmark_error_refuses_bad_ids() -> None:
    xy = np.zeros((2, 2))
    with pytest.raises(ValueError, match="estimate_ids repeats id 3"):
        landmark_error([3, 3], xy, [3, 4], xy)
    with pytest.raises(ValueError, match="no id in common"):
        landmark_error([1, 2], xy, [3, 4], xy)
    with pytest.raises(ValueError, match="reference_ids"):
        landmark_error([1, 2], xy, [1.5, 2.0], xy)
    with pytest.raises(ValueError, match="estimate"):
        landmark_error([1, 2], np.zeros((3, 2)), [1, 2], xy)


# ------------------------------------------------------------------ NEES


def random_covariances(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.normal(size=(n, 3, 3)) * [0.3, 0.3, 0.05]
    return a @ a.transpose(0, 2, 1) + np.diag([1e-3, 1e-3, 1e-4])


def test_pose_nees_matches_an_explicit_inverse_and_scipy_band() -> None:
    rng = np.random.default_rng(7)
    n = 60
    t = np.arange(float(n))
    truth = random_path(rng, n)
    est = truth + rng.normal(scale=[0.2, 0.2, 0.1], size=(n, 3))
    est[:, 2] = wrap_angle(est[:, 2])
    cov = random_covariances(rng, n)
    res = pose_nees(associate(t, est, t, truth), cov)
    for k in range(n):
        e = est[k] - truth[k]
        e[2] = math.atan2(math.sin(e[2]), math.cos(e[2]))
        assert res.nees[k] == pytest.approx(e @ np.linalg.inv(cov[k]) @ e, rel=1e-9)
    np.testing.assert_allclose(res.band, chi2.ppf([0.025, 0.975], 3), rtol=1e-9)
    assert res.inside + res.above + res.below == pytest.approx(1.0)


def test_pose_nees_of_a_consistent_estimate_is_chi_square() -> None:
    rng = np.random.default_rng(8)
    n = 4000
    t = np.arange(float(n))
    truth = random_path(rng, n)
    cov = random_covariances(rng, n)
    noise = np.einsum("kij,kj->ki", np.linalg.cholesky(cov), rng.normal(size=(n, 3)))
    res = pose_nees(associate(t, truth + noise, t, truth), cov, confidence=0.95)
    # 95% of chi-square(3) draws inside: binomial sd sqrt(.95 .05 / 4000) = 0.0034.
    assert abs(res.inside - 0.95) < 4 * 0.0034
    assert abs(res.mean - 3.0) < 4 * math.sqrt(6.0 / n)
    assert "inside the 95% band" in repr(res)


def test_pose_nees_uses_only_matched_steps() -> None:
    t_ref = np.arange(10.0)
    truth = np.zeros((10, 3))
    t_est = np.array([-1.0, 2.0, 20.0])
    cov = np.stack([np.eye(3) * 4.0, np.eye(3), np.eye(3)])
    res = pose_nees(associate(t_est, np.ones((3, 3)), t_ref, truth), cov)
    assert res.t.tolist() == [2.0] and res.nees.tolist() == [pytest.approx(3.0)]


def test_pose_nees_refuses_bad_covariances_by_step() -> None:
    assoc = associate(T3, POSES, T3, POSES)
    cov = np.stack([np.eye(3)] * 3)
    bad = cov.copy()
    bad[1, 0, 1] = 0.5
    with pytest.raises(ValueError, match=r"covariances\[1\] is not symmetric"):
        pose_nees(assoc, bad)
    bad = cov.copy()
    bad[2, 2, 2] = -1.0
    with pytest.raises(ValueError, match=r"covariances\[2\] is not positive definite"):
        pose_nees(assoc, bad)
    with pytest.raises(ValueError, match="shape"):
        pose_nees(assoc, cov[:2])
    with pytest.raises(ValueError, match="covariances"):
        pose_nees(assoc, cov * np.nan)
    with pytest.raises(ValueError, match="confidence"):
        pose_nees(assoc, cov, confidence=1.0)


# ------------------------------------------------------------------ GPS


def test_gps_error_after_one_rigid_alignment() -> None:
    rng = np.random.default_rng(9)
    t = np.arange(0.0, 100.0, 0.1)
    truth = linear_motion(t)
    truth[:, 1] += np.sin(t / 5)  # bend the path so that the rotation is determined
    theta, shift = 0.4, np.array([-30.0, 12.0])
    est = move(theta, shift, truth)
    t_gps = np.r_[-5.0, np.arange(0.3, 90.0, 1.7), 150.0]
    k = np.clip(np.searchsorted(t, t_gps), 0, len(t) - 1)
    gps = truth[k, :2].copy()
    gps += rng.normal(scale=0.5, size=gps.shape)
    res = gps_error(t, est, t_gps, gps)
    assert (res.association.before, res.association.after) == (1, 1)
    # Oracle: evo's Umeyama on the estimate interpolated at the fixes (written here).
    inner = res.association.estimate_index
    at = np.stack([np.interp(t_gps[inner], t, est[:, c]) for c in (0, 1)], axis=1)
    r, tr, _ = geometry.umeyama_alignment(
        np.r_[at.T, np.zeros((1, len(at)))], np.r_[gps[inner].T, np.zeros((1, len(at)))]
    )
    expected = np.linalg.norm(at @ r[:2, :2].T + tr[:2] - gps[inner], axis=1)
    np.testing.assert_allclose(res.distance, expected, atol=1e-9)
    assert res.rms == pytest.approx(math.sqrt(np.mean(expected**2)), rel=1e-9)
    assert abs(float(wrap_angle(res.transform.theta + theta))) < 0.05


def test_gps_error_refuses_bad_fixes_by_name() -> None:
    with pytest.raises(ValueError, match="gps"):
        gps_error(T3, POSES, T3, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="t_gps"):
        gps_error(T3, POSES, T3[:2], np.zeros((3, 2)))


# ------------------------------------------------------------------ real data


@pytest.fixture(scope="module")
def mrclam_dir(data: Path) -> Path:
    folder = data / "mrclam6"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    return folder


@pytest.mark.parametrize("align", [False, True])
def test_mrclam_ground_truth_perturbed_ate_matches_evo(mrclam_dir: Path, align: bool) -> None:
    run = load_mrclam(mrclam_dir, robot=1)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    rng = np.random.default_rng(1)
    est = move(0.05, np.array([0.3, -0.2]), truth)
    # A slow drift plus white noise, as a dead-reckoned path would carry.
    est[:, :2] += np.cumsum(rng.normal(scale=2e-3, size=(len(truth), 2)), axis=0)
    est += rng.normal(scale=[0.02, 0.02, 0.01], size=est.shape)
    ours = ate(run.truth_t, est, run.truth_t, truth, align=align)
    assert ours.matched == len(truth)
    assert ours.rmse == pytest.approx(evo_ape_rmse(run.truth_t, truth, est, align), rel=1e-9)


def test_mrclam_odometry_times_against_ground_truth_are_all_accounted_for(
    mrclam_dir: Path,
) -> None:
    run = load_mrclam(mrclam_dir, robot=1)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    t = run.odometry_t
    assoc = associate(t, np.zeros((len(t), 3)), run.truth_t, truth, max_gap=0.25)
    assert assoc.before == int(np.sum(t < run.truth_t[0]))
    assert assoc.after == int(np.sum(t > run.truth_t[-1])) > 0  # odometry outlasts Vicon
    gaps = np.flatnonzero(np.diff(run.truth_t) > 0.25)
    in_gap = sum(int(np.sum((t > run.truth_t[g]) & (t < run.truth_t[g + 1]))) for g in gaps)
    assert assoc.in_gap == in_gap
    assert assoc.matched + assoc.before + assoc.after + assoc.in_gap == len(t)


def test_victoria_park_gps_against_itself_moved(data: Path) -> None:
    folder = data / "victoria_park"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    vp = load_victoria_park(folder)
    gps = np.c_[vp.gps_x, vp.gps_y]
    moved = gps @ rotation(2.0).T + [100.0, -50.0]
    res = gps_error(vp.gps_t, moved, vp.gps_t, gps)
    assert res.association.matched == len(gps)
    assert res.rms < 1e-9


# ------------------------------------------------------------------ properties


@given(st.integers(0, 2**32 - 1), st.floats(-math.pi, math.pi), st.tuples(finite, finite))
def test_aligned_ate_is_optimal_and_blind_to_a_rigid_motion(
    seed: int, theta: float, shift: tuple[float, float]
) -> None:
    rng = np.random.default_rng(seed)
    t = np.arange(20.0)
    truth = random_path(rng, 20)
    est = truth + rng.normal(scale=0.3, size=(20, 3))
    aligned = ate(t, est, t, truth, align=True)
    # Optimal: no worse than no alignment; blind: moving the estimate changes nothing.
    assert aligned.rmse <= ate(t, est, t, truth).rmse + 1e-12
    moved = ate(t, move(theta, np.array(shift), est), t, truth, align=True)
    assert moved.rmse == pytest.approx(aligned.rmse, rel=1e-6, abs=1e-9)
