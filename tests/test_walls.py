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
    world = found.to_world(POSE)
    # Every world endpoint lies on some true wall line.
    for p in np.r_[world.start, world.end]:
        dists = []
        for a, b in walls:
            d = b - a
            dists.append(abs(d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) / np.hypot(*d))
        assert min(dists) < 1e-6
