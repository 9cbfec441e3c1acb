"""Consecutive-scan wall NEES (rperc.wallcheck) on a simulated log whose poses and
noise are known: the NEES must follow chi-square with 2 dof there, so the pairing and
the difference are right and what the real logs show is about their covariances."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import LaserScans
from rperc.scansim import ray_cast, room_walls
from rperc.slam.wallslam import STRAIGHTNESS
from rperc.wallcheck import consecutive_wall_nees, line_difference, pair_walls

ANGLES = -math.pi / 2 + math.pi / 180 * np.arange(180)


def simulated_scans(
    count: int, sigma_range: float, pose_sd: np.ndarray, seed: int
) -> tuple[LaserScans, np.ndarray]:
    """A slow walk through the room: scans from the true poses, logged poses with
    Gaussian errors of standard deviations ``pose_sd`` (independent per scan)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * math.pi, count)
    true = np.c_[5 + 3 * np.cos(t), 3 + 1.5 * np.sin(t), t + math.pi / 2]
    ranges = np.array(
        [ray_cast(room_walls(), p, ANGLES, sigma_range=sigma_range, rng=rng).ranges for p in true]
    )
    logged = true + rng.normal(size=true.shape) * pose_sd
    n = np.full(count, len(ANGLES))
    scans = LaserScans(
        ranges=ranges,
        num_beams=n,
        angle_min=np.full(count, ANGLES[0]),
        angle_increment=np.full(count, ANGLES[1] - ANGLES[0]),
        max_range=np.full(count, 30.0),
        pose=logged,
        odom=logged,
        timestamp=t,
        line=np.arange(count),
    )
    return scans, true


def test_consecutive_nees_follows_chi_square_when_the_model_holds():
    pose_sd = np.array([0.02, 0.02, math.radians(0.5)])
    scans, _ = simulated_scans(150, 0.01, pose_sd, seed=3)
    result = consecutive_wall_nees(scans, pose_cov=np.diag(pose_sd**2))
    n = len(result.nees)
    assert n > 300
    # Pairs share walls, so they are not independent: a 6-sigma band on the mean.
    assert abs(result.mean - 2.0) < 6 * 2 / math.sqrt(n), result
    assert abs(result.within_95 - 0.95) < 6 * math.sqrt(0.05 * 0.95 / n), result
    # The logged poses are off by 0.5 degree: treating them as exact is overconfident.
    assert consecutive_wall_nees(scans).mean > 5 * 2.0


def test_straightness_adds_its_covariance_to_both_walls_of_a_pair():
    # Oracle: each pair's NEES written out with the segment-end model's closed form
    # (var rho = s^2 (1/2 + 2 m^2/L^2), var alpha = 2 s^2/L^2, cov = 2 s^2 m/L^2).
    from rperc.linesimp import extract_lines

    pose_sd = np.array([0.02, 0.02, math.radians(0.5)])
    scans, _ = simulated_scans(12, 0.01, pose_sd, seed=5)
    sigma = 0.03
    world = [
        extract_lines(scans.ranges[k], ANGLES, max_range=30.0).to_world(scans.pose[k])
        for k in range(len(scans))
    ]

    def floor(w, i):
        n = np.array([math.cos(w.alpha[i]), math.sin(w.alpha[i])])
        m = 0.5 * (w.start[i] + w.end[i]) @ np.array([-n[1], n[0]])
        length2 = float(np.sum((w.end[i] - w.start[i]) ** 2))
        return sigma**2 * np.array(
            [[0.5 + 2 * m**2 / length2, 2 * m / length2], [2 * m / length2, 2 / length2]]
        )

    expected = []
    for a, b in itertools.pairwise(world):
        for i, j in pair_walls(a, b):
            d = line_difference(a, i, b, j)
            c = a.cov[i] + floor(a, i) + b.cov[j] + floor(b, j)
            expected.append(d @ np.linalg.solve(c, d))
    got = consecutive_wall_nees(scans, straightness=sigma, max_range=30.0)
    assert len(expected) > 20
    np.testing.assert_allclose(got.nees, expected, rtol=1e-9)
    assert got.mean < consecutive_wall_nees(scans, max_range=30.0).mean
    with pytest.raises(ValueError, match="straightness"):
        consecutive_wall_nees(scans, straightness=-0.01)


def test_pairing_uses_geometry_only():
    scans, _ = simulated_scans(2, 0.0, np.zeros(3), seed=1)
    from rperc.linesimp import extract_lines

    a = extract_lines(scans.ranges[0], ANGLES, max_range=30.0).to_world(scans.pose[0])
    pairs = pair_walls(a, a)
    assert pairs == [(k, k) for k in range(len(a))]  # every wall pairs with itself
    for i, j in pairs:
        np.testing.assert_allclose(line_difference(a, i, a, j), 0.0, atol=1e-12)


def test_cli_lines_nees_writes_what_it_prints(tmp_path, capsys):
    scans, _ = simulated_scans(12, 0.01, np.zeros(3), seed=2)
    rows = []
    for k in range(len(scans)):
        x, y, th = scans.pose[k]
        r = " ".join(f"{v:.5f}" for v in scans.ranges[k])
        rows.append(f"FLASER 180 {r} {x} {y} {th} {x} {y} {th} {k}.0 sim {k}.0")
    log = tmp_path / "sim.log"
    log.write_text("\n".join(rows) + "\n")
    js = tmp_path / "n.json"
    argv = ["lines", "nees", str(log), "--pose-sigma-theta", "0.1", "--json", str(js)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    measured = json.loads(js.read_text())
    assert f"{measured['pairs']} wall pairs" in out and measured["scans"] == 12
    assert measured["pose_sigma_theta_deg"] == 0.1 and measured["model_error"] is True
    # Real logs get the wall SLAM's straightness floor unless told otherwise.
    assert measured["straightness_m"] == STRAIGHTNESS
    assert main([*argv[:-2], "--straightness", "0", "--json", str(js)]) == 0
    assert json.loads(js.read_text())["straightness_m"] == 0.0


def test_reading_shares_add_up_and_match_the_extractor():
    from rperc.linesimp import extract_lines
    from rperc.wallcheck import reading_shares

    scans, _ = simulated_scans(5, 0.01, np.zeros(3), seed=4)
    scans.ranges[0, :3] = np.nan  # three invalid readings
    shares = reading_shares(scans)
    parts = ("on_walls", "short_walls", "sparse", "isolated")
    assert sum(shares[k] for k in parts) == shares["valid"]
    assert shares["valid"] + shares["invalid"] == 5 * 180 and shares["invalid"] >= 3
    on_walls = sum(
        len(extract_lines(scans.ranges[k], ANGLES, max_range=30.0).flat_indices) for k in range(5)
    )
    assert shares["on_walls"] == on_walls
