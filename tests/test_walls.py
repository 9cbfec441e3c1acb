"""Wall extraction on analytic scans: ray-cast a room with known walls, add range
noise, and recover every visible wall within bounds derived from the noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rperc.linesimp import WallSegments, extract_lines
from rperc.scansim import ray_cast, room_walls

SIGMA = 0.01


def hessian_in_sensor_frame(a: np.ndarray, b: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    """(rho, alpha) of the line through world points a, b seen from ``pose``:
    x cos(alpha) + y sin(alpha) = rho with rho >= 0."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, s], [-s, c]])
    pa, pb = rot @ (a - pose[:2]), rot @ (b - pose[:2])
    d = pb - pa
    n = np.array([-d[1], d[0]]) / np.hypot(*d)
    rho = float(n @ pa)
    if rho < 0:
        n, rho = -n, -rho
    return rho, math.atan2(n[1], n[0])


def angle_diff(a: float, b: float) -> float:
    return (a - b + math.pi) % (2 * math.pi) - math.pi


def match(found: WallSegments, rho: float, alpha: float) -> int | None:
    best, best_k = float("inf"), None
    for k in range(len(found)):
        e = np.array([found.rho[k] - rho, angle_diff(found.alpha[k], alpha)])
        d = float(e @ np.linalg.solve(found.cov[k], e))
        if d < best:
            best, best_k = d, k
    return best_k


def visible_walls(scan, min_beams: int) -> list[int]:
    ids, counts = np.unique(scan.wall[scan.wall >= 0], return_counts=True)
    return [int(i) for i, c in zip(ids, counts, strict=True) if c >= min_beams]


POSE = np.array([4.0, 2.5, 0.3])
ANGLES = np.linspace(-math.pi / 2, math.pi / 2, 361)


def test_noise_free_scan_recovers_the_walls_exactly():
    walls = room_walls()
    scan = ray_cast(walls, POSE, ANGLES)
    found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range, sigma_range=1e-6)
    for w in visible_walls(scan, min_beams=10):
        rho, alpha = hessian_in_sensor_frame(*walls[w], POSE)
        k = match(found, rho, alpha)
        assert k is not None
        assert found.rho[k] == pytest.approx(rho, abs=1e-7)
        assert angle_diff(found.alpha[k], alpha) == pytest.approx(0.0, abs=1e-7)
        # Endpoints lie on the fitted line and inside the true wall.
        for p in (found.start[k], found.end[k]):
            assert p @ [math.cos(found.alpha[k]), math.sin(found.alpha[k])] == pytest.approx(
                found.rho[k], abs=1e-9
            )


def test_noisy_scans_match_the_predicted_covariance():
    """Over many seeded scans the normalised error of each recovered wall averages 2
    (chi-square, 2 dof): the covariance is neither optimistic nor pessimistic."""
    walls = room_walls()
    rng = np.random.default_rng(42)
    nees, missed, total = [], 0, 0
    for _ in range(200):
        scan = ray_cast(walls, POSE, ANGLES, sigma_range=SIGMA, rng=rng)
        found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range, sigma_range=SIGMA)
        for w in visible_walls(scan, min_beams=20):
            total += 1
            rho, alpha = hessian_in_sensor_frame(*walls[w], POSE)
            k = match(found, rho, alpha)
            e = np.array([found.rho[k] - rho, angle_diff(found.alpha[k], alpha)])
            d = float(e @ np.linalg.solve(found.cov[k], e))
            if d > 13.8:  # chi2(2) 0.999 quantile: this wall was not found
                missed += 1
            else:
                nees.append(d)
    assert missed <= 0.01 * total
    # The mean of n chi2(2) draws has standard deviation 2/sqrt(n); allow 4 of them.
    mean = float(np.mean(nees))
    assert abs(mean - 2.0) < 4 * 2 / math.sqrt(len(nees)), mean


def test_invalid_readings_are_dropped_and_indices_point_into_the_input():
    walls = room_walls()
    scan = ray_cast(walls, POSE, ANGLES)
    ranges = scan.ranges.copy()
    ranges[::7] = np.nan
    ranges[3::11] = 0.0
    found = extract_lines(ranges, scan.angles, max_range=scan.max_range)
    assert len(found) > 0
    for idx in found.indices:
        assert np.all(np.isfinite(ranges[idx])) and np.all(ranges[idx] > 0)
        assert np.all(np.diff(idx) > 0)


def test_empty_and_all_invalid_scans_give_no_walls():
    assert len(extract_lines(np.array([]), np.array([]))) == 0
    assert len(extract_lines(np.full(50, np.nan), np.linspace(-1, 1, 50))) == 0
    assert len(extract_lines(np.full(50, 30.0), np.linspace(-1, 1, 50), max_range=30.0)) == 0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"sigma_range": -0.1}, "sigma_range"),
        ({"split_epsilon": float("nan")}, "split_epsilon"),
        ({"min_points": 1}, "min_points"),
        ({"max_range": -1.0}, "max_range"),
    ],
)
def test_bad_parameters_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        extract_lines(np.ones(10), np.linspace(0, 1, 10), **kwargs)


def test_bad_arrays_raise():
    with pytest.raises(ValueError, match="length"):
        extract_lines(np.ones(10), np.linspace(0, 1, 9))
    with pytest.raises(ValueError, match="1-D"):
        extract_lines(np.ones((10, 2)), np.linspace(0, 1, 10))
    with pytest.raises(TypeError, match="dtype"):
        extract_lines(np.array(["a"] * 3), np.linspace(0, 1, 3))
    with pytest.raises(ValueError, match="angle"):
        extract_lines(np.ones(3), np.array([0.0, np.nan, 1.0]))


def test_result_repr_and_world_frame():
    walls = room_walls()
    scan = ray_cast(walls, POSE, ANGLES)
    found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range)
    assert f"{len(found)} walls" in repr(found)
    # The native result behind it is frozen: its arrays cannot be written.
    with pytest.raises(ValueError, match="read-only"):
        found.rho[0] = 0.0
    world = found.to_world(POSE)
    # Every world endpoint lies on some true wall line.
    for p in np.r_[world.start, world.end]:
        dists = []
        for a, b in walls:
            d = b - a
            dists.append(abs(d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) / np.hypot(*d))
        assert min(dists) < 1e-6


def test_world_jacobians_match_central_differences():
    """The analytic Jacobians of the sensor-to-world line transform against central
    differences of the transform itself, on random lines and poses (some flip rho)."""
    from rperc.linesimp import wall_to_world_jacobians

    rng = np.random.default_rng(4)
    h = 1e-6
    for _ in range(200):
        rho = rng.uniform(0.2, 8.0, size=1)
        alpha = rng.uniform(-math.pi, math.pi, size=1)
        pose = np.r_[rng.uniform(-10, 10, size=2), rng.uniform(-math.pi, math.pi)]
        world = wall_to_world_jacobians(rho, alpha, pose)
        r0, _, jw, jp = world
        assert world.d_wall is jw and world.d_pose is jp  # named, and still a tuple
        if r0[0] < 1e-3:
            continue  # at rho_w = 0 the flip makes the transform non-differentiable

        def diff(plus: tuple, minus: tuple) -> np.ndarray:
            return np.array(
                [
                    (plus[0][0] - minus[0][0]) / (2 * h),
                    angle_diff(plus[1][0], minus[1][0]) / (2 * h),
                ]
            )

        for i, dw in enumerate(np.eye(2)):
            plus = wall_to_world_jacobians(rho + h * dw[0], alpha + h * dw[1], pose)
            minus = wall_to_world_jacobians(rho - h * dw[0], alpha - h * dw[1], pose)
            np.testing.assert_allclose(diff(plus, minus), jw[0, :, i], atol=1e-6)
        for i, dp in enumerate(np.eye(3)):
            plus = wall_to_world_jacobians(rho, alpha, pose + h * dp)
            minus = wall_to_world_jacobians(rho, alpha, pose - h * dp)
            np.testing.assert_allclose(diff(plus, minus), jp[0, :, i], atol=1e-6)


def test_world_lines_hold_the_moved_points():
    """Closed form: two points of each sensor-frame line, moved to the world by the
    pose, lie on the returned world line (``rho_w >= 0``, ``alpha_w`` wrapped), for
    many walls at once, including ones the move flips."""
    from rperc.linesimp import wall_to_world_jacobians
    from rperc.pose import to_world

    rng = np.random.default_rng(7)
    rho, alpha = rng.uniform(0.1, 8.0, 300), rng.uniform(-math.pi, math.pi, 300)
    pose = np.array([3.0, -4.0, 2.5])
    rho_w, alpha_w, _, _ = wall_to_world_jacobians(rho, alpha, pose)
    assert np.all(rho_w >= 0) and np.all(np.abs(alpha_w) <= math.pi)
    for t in (-2.0, 3.0):
        normal, along = np.c_[np.cos(alpha), np.sin(alpha)], np.c_[-np.sin(alpha), np.cos(alpha)]
        moved = to_world(pose, rho[:, None] * normal + t * along)
        n_w = np.c_[np.cos(alpha_w), np.sin(alpha_w)]
        np.testing.assert_allclose(np.sum(moved * n_w, axis=1), rho_w, atol=1e-9)


@pytest.mark.parametrize(
    ("rho", "alpha", "pose", "match"),
    [
        ([1.0, np.nan], [0.0, 0.0], [0, 0, 0], "finite"),
        ([1.0], [0.0, 1.0], [0, 0, 0], "same length"),
        ([1.0], [0.0], [0, 0], "pose"),
        ([1.0], [0.0], [0, np.inf, 0], "pose"),
    ],
)
def test_world_lines_refuse_bad_input(rho, alpha, pose, match):
    from rperc.linesimp import wall_to_world_jacobians

    with pytest.raises(ValueError, match=match):
        wall_to_world_jacobians(rho, alpha, pose)


def world_wall_nees(runs: int, pose_cov: np.ndarray, use_cov: bool, seed: int) -> np.ndarray:
    """NEES of world walls computed from a noisy pose estimate (drawn from
    ``pose_cov``) against the true world walls, over ``runs`` random poses."""
    walls = room_walls()
    rng = np.random.default_rng(seed)
    chol = np.linalg.cholesky(pose_cov)
    nees = []
    for _ in range(runs):
        pose = np.array([rng.uniform(1, 9), rng.uniform(1, 5), rng.uniform(-math.pi, math.pi)])
        scan = ray_cast(walls, pose, ANGLES, sigma_range=SIGMA, rng=rng)
        found = extract_lines(scan.ranges, scan.angles, max_range=scan.max_range)
        estimate = pose + chol @ rng.normal(size=3)
        world = found.to_world(estimate, pose_cov if use_cov else None)
        for k, idx in enumerate(found.indices):
            hits = scan.wall[idx]
            true = int(np.bincount(hits[hits >= 0], minlength=len(walls)).argmax())
            rho, alpha = hessian_in_sensor_frame(*walls[true], np.zeros(3))
            e = np.array([world.rho[k] - rho, angle_diff(world.alpha[k], alpha)])
            if abs(e[1]) > math.pi / 2:  # the same line written (-rho, alpha + pi)
                e = np.array([world.rho[k] + rho, angle_diff(world.alpha[k], alpha + math.pi)])
            nees.append(float(e @ np.linalg.solve(world.cov[k], e)))
    return np.asarray(nees)


def test_world_walls_with_pose_noise_are_consistent():
    """Monte Carlo with a brute-force oracle (the true walls): the world-wall NEES
    must follow chi-square with 2 dof, mean within its 4-sigma band over the walls and
    the 95 % quantile exceeded 5 % of the time. Without the pose covariance the same
    walls are far too confident."""
    pose_cov = np.diag([0.03**2, 0.02**2, math.radians(1.0) ** 2])
    pose_cov[0, 1] = pose_cov[1, 0] = 0.5 * 0.03 * 0.02
    v = world_wall_nees(200, pose_cov, use_cov=True, seed=12)
    assert abs(v.mean() - 2.0) < 4 * 2 / math.sqrt(len(v)), (v.mean(), len(v))
    above = np.mean(v > 5.991)
    assert abs(above - 0.05) < 4 * math.sqrt(0.05 * 0.95 / len(v)), above
    assert world_wall_nees(50, pose_cov, use_cov=False, seed=13).mean() > 10 * 2.0


def test_pose_covariance_is_checked():
    found = extract_lines(2.0 / np.cos(ANGLES[100:260]), ANGLES[100:260])
    with pytest.raises(ValueError, match="3 x 3"):
        found.to_world(POSE, np.eye(2))
    with pytest.raises(ValueError, match="symmetric"):
        found.to_world(POSE, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="semi-definite"):
        found.to_world(POSE, np.diag([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="pose"):
        found.to_world([0.0, np.nan, 0.0])
    # A zero pose covariance changes nothing.
    np.testing.assert_allclose(found.to_world(POSE, np.zeros((3, 3))).cov, found.to_world(POSE).cov)


def model_error_nees(
    model_error: bool, sigma_true: float, wave: float, quantum: float, seed: int
) -> np.ndarray:
    """NEES of sensor-frame walls against the true walls, on scans with model error
    the extractor is not told of: range noise ``sigma_true`` (it assumes SIGMA), walls
    bent by a sine of amplitude ``wave`` (m, 1.5 m period, random phase per wall), and
    ranges rounded to ``quantum`` (m; 0 for none), as the CARMEN logs are (1 cm)."""
    walls = room_walls()
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * math.pi, len(walls))
    nees = []
    for _ in range(300):
        pose = np.array([rng.uniform(0.5, 9.5), rng.uniform(0.5, 5.5), rng.uniform(-3, 3)])
        scan = ray_cast(walls, pose, ANGLES[::2], rng=rng)
        r, hit, heading = scan.ranges.copy(), scan.wall >= 0, pose[2] + scan.angles
        beam = np.c_[np.cos(heading), np.sin(heading)]
        for j in np.unique(scan.wall[hit]):
            on = scan.wall == j
            d = walls[j][1] - walls[j][0]
            t, n = d / np.hypot(*d), np.array([-d[1], d[0]]) / np.hypot(*d)
            s = (pose[:2] + r[on, None] * beam[on]) @ t
            r[on] += wave * np.sin(2 * math.pi * s / 1.5 + phase[j]) / np.abs(beam[on] @ n)
        r[hit] += rng.normal(scale=sigma_true, size=int(hit.sum()))
        if quantum:
            r[hit] = np.round(r[hit] / quantum) * quantum
        found = extract_lines(
            r, scan.angles, max_range=scan.max_range, sigma_range=SIGMA, model_error=model_error
        )
        for k, idx in enumerate(found.indices):
            hits = scan.wall[idx]
            true = int(np.bincount(hits[hits >= 0], minlength=len(walls)).argmax())
            rho, alpha = hessian_in_sensor_frame(*walls[true], pose)
            e = np.array([found.rho[k] - rho, angle_diff(found.alpha[k], alpha)])
            nees.append(float(e @ np.linalg.solve(found.cov[k], e)))
    return np.asarray(nees)


def test_model_error_floor_on_simulated_rooms():
    """The calibration data of the model-error floor (ScanParams::model_error): rooms
    whose scans break the noise model in the ways real ones do. Oracle: the true walls.
    Share of NEES within the chi-square (2 dof) 95 % quantile, for 1 cm quantisation
    with the right sigma it is inside the 4-sigma band around 95 %; for wavy walls and
    for noise twice its sigma the floor is not enough to reach the band (short walls
    split by the noise stay overconfident) but it must raise the share by more than
    3 standard errors of a share."""
    band = 4 * math.sqrt(0.05 * 0.95 / 1000)

    def within(v: np.ndarray) -> float:
        return float(np.mean(v < 5.991))

    quantised = model_error_nees(True, SIGMA, 0.0, 0.01, seed=21)
    assert abs(within(quantised) - 0.95) < band, within(quantised)
    for sigma_true, wave in [(SIGMA, 0.005), (2 * SIGMA, 0.0)]:
        off = within(model_error_nees(False, sigma_true, wave, 0.01, seed=22))
        on = within(model_error_nees(True, sigma_true, wave, 0.01, seed=22))
        assert on - off > 3 * math.sqrt(0.1 * 0.9 / 1000), (sigma_true, wave, off, on)


def cluttered_room(rng: np.random.Generator, boxes: int) -> np.ndarray:
    """The room plus ``boxes`` small square obstacles (0.05 to 0.3 m: chair legs, bins)."""
    out = [room_walls()]
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) / 2
    for _ in range(boxes):
        sq = rng.uniform([0.5, 0.5], [9.5, 5.5]) + rng.uniform(0.05, 0.3) * corners
        out.append(np.array([(sq[i], sq[(i + 1) % 4]) for i in range(4)]))
    return np.concatenate(out)


def test_wall_readings_go_to_the_right_wall_in_a_cluttered_room():
    """Oracle: the ray caster's label of each beam. Of the readings that hit a room
    wall (not clutter), at least 95 % must end up in a found wall whose readings hit
    mostly that same wall (issue 11, part 2)."""
    rng = np.random.default_rng(1)
    n_room = len(room_walls())
    angles = np.radians(np.arange(-90.0, 90.0))
    total = right = 0
    for _ in range(200):
        walls = cluttered_room(rng, 8)
        pose = np.array([rng.uniform(0.5, 9.5), rng.uniform(0.5, 5.5), rng.uniform(-3, 3)])
        scan = ray_cast(walls, pose, angles, sigma_range=SIGMA, rng=rng)
        found = extract_lines(scan.ranges, angles, max_range=scan.max_range)
        label = np.full(len(angles), -1)
        for idx in found.indices:
            hits = scan.wall[idx]
            label[idx] = np.bincount(hits[hits >= 0], minlength=len(walls)).argmax()
        on_wall = (scan.wall >= 0) & (scan.wall < n_room)
        total += int(on_wall.sum())
        right += int((on_wall & (label == scan.wall)).sum())
    assert right / total >= 0.95, right / total
