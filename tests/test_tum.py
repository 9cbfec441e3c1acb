"""TUM trajectory files: round trips, evo reading our files and we reading evo's,
malformed files named by line, and evo_ape (the command line tool, run on files we
wrote) agreeing with our ATE with and without alignment."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from evo.core import trajectory
from evo.tools import file_interface
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rperc.datasets import DatasetFormatError, load_mrclam, read_tum, write_tum
from rperc.slam.evaluation import ate

coordinate = st.floats(-1e6, 1e6, allow_nan=False)


@st.composite
def planar_trajectories(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(1, 30))
    steps = draw(arrays(np.float64, n, elements=st.floats(0.0, 100.0)))
    t = draw(st.floats(0.0, 2e9)) + np.cumsum(steps)
    xy = draw(arrays(np.float64, (n, 2), elements=coordinate))
    theta = draw(arrays(np.float64, n, elements=st.floats(-math.pi, math.pi)))
    return t, np.c_[xy, theta]


@given(planar_trajectories())
def test_round_trip_keeps_times_positions_and_headings(
    tmp_path_factory: pytest.TempPathFactory, traj: tuple[np.ndarray, np.ndarray]
) -> None:
    t, poses = traj
    path = tmp_path_factory.mktemp("tum") / "traj.txt"
    write_tum(path, t, poses)
    t2, poses2 = read_tum(path)
    assert np.array_equal(t2, t) and np.array_equal(poses2[:, :2], poses[:, :2])
    turn = np.angle(np.exp(1j * (poses2[:, 2] - poses[:, 2])))
    assert np.all(np.abs(turn) < 1e-12)
    assert np.all((poses2[:, 2] > -math.pi) & (poses2[:, 2] <= math.pi))


def test_evo_reads_our_file(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.01, 0.1, 50)) + 1.2e9
    poses = np.c_[rng.normal(size=(50, 2)) * 10, rng.uniform(-math.pi, math.pi, 50)]
    write_tum(tmp_path / "ours.txt", t, poses)
    traj = file_interface.read_tum_trajectory_file(tmp_path / "ours.txt")
    np.testing.assert_array_equal(traj.timestamps, t)
    np.testing.assert_allclose(traj.positions_xyz, np.c_[poses[:, :2], np.zeros(50)], atol=0)
    # evo's 4x4 poses: the rotation block is a turn by theta about z.
    for pose, se3 in zip(poses, traj.poses_se3, strict=True):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        np.testing.assert_allclose(se3[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-15)


def test_we_read_evos_file(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    theta = rng.uniform(-math.pi, math.pi, 20)
    xyz = np.c_[rng.normal(size=(20, 2)), np.zeros(20)]
    wxyz = np.c_[np.cos(theta / 2), np.zeros(20), np.zeros(20), np.sin(theta / 2)]
    t = np.arange(20.0) * 0.5
    traj = trajectory.PoseTrajectory3D(xyz, wxyz, t)
    file_interface.write_tum_trajectory_file(tmp_path / "evo.txt", traj)
    t2, poses = read_tum(tmp_path / "evo.txt")
    np.testing.assert_allclose(t2, t)
    np.testing.assert_allclose(poses[:, :2], xyz[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (poses[:, 2] - theta))), 0.0, atol=1e-9)


GOOD = "1.0 0 0 0 0 0 0 1\n"


@pytest.mark.parametrize(
    ("text", "line", "reason"),
    [
        (GOOD + "2.0 0 0 0 0 0 0\n", 2, "expected 8 columns"),
        (GOOD + "2.0 0 x 0 0 0 0 1\n", 2, "not a number"),
        (GOOD + "2.0 0 nan 0 0 0 0 1\n", 2, "non-finite"),
        ("# header\n" + GOOD + "0.5 0 0 0 0 0 0 1\n", 3, "time goes backwards"),
        (GOOD + "2.0 0 0 0.5 0 0 0 1\n", 2, "not planar: z"),
        (GOOD + "2.0 0 0 0 0.6 0 0 0.8\n", 2, "not planar: the rotation"),
        (GOOD + "2.0 0 0 0 0 0 0 2\n", 2, "quaternion norm"),
        ("# only a comment\n", 1, "empty"),
    ],
)
def test_malformed_files_name_the_line(tmp_path: Path, text: str, line: int, reason: str) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(DatasetFormatError, match=reason) as info:
        read_tum(path)
    assert info.value.line == line and info.value.path == str(path)


@pytest.mark.parametrize(
    ("t", "poses", "name"),
    [
        ([0.0], [[0.0, 0.0]], "poses"),
        ([0.0, 1.0], [[0.0, 0.0, 0.0]], "t has 2 rows"),
        ([], np.zeros((0, 3)), "empty"),
        ([0.0], [[np.nan, 0.0, 0.0]], "poses"),
        ([[0.0]], [[0.0, 0.0, 0.0]], "t must be 1-D"),
    ],
)
def test_write_refuses_bad_arrays(tmp_path: Path, t: list, poses: list, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        write_tum(tmp_path / "x.txt", t, poses)
    assert not (tmp_path / "x.txt").exists()


# ------------------------------------------------------------------ evo_ape on our files


def evo_ape_cli(tmp_path: Path, ref: Path, est: Path, align: bool) -> float:
    """Runs evo_ape (evo's own entry point, in a fresh interpreter) and reads the RMSE
    from its saved results. HOME points into tmp_path: evo writes its settings there."""
    out = tmp_path / f"ape_{align}.zip"
    args = ["tum", str(ref), str(est), "--save_results", str(out), "--no_warnings"]
    code = (
        "import sys; from evo.cli.entry_points import ape; "
        f"sys.argv = ['evo_ape', *{args!r}, *{['-a'] if align else []!r}]; sys.exit(ape())"
    )
    env = {**os.environ, "HOME": str(tmp_path), "MPLBACKEND": "Agg"}
    subprocess.run([sys.executable, "-c", code], check=True, env=env, capture_output=True)
    return float(file_interface.load_res_file(out).stats["rmse"])


def perturbed(rng: np.random.Generator, truth: np.ndarray) -> np.ndarray:
    theta, shift = rng.uniform(-0.2, 0.2), rng.normal(size=2)
    c, s = math.cos(theta), math.sin(theta)
    est = truth.copy()
    est[:, :2] = truth[:, :2] @ np.array([[c, -s], [s, c]]).T + shift
    est[:, 2] += theta
    est[:, :2] += np.cumsum(rng.normal(scale=5e-3, size=(len(truth), 2)), axis=0)
    est += rng.normal(scale=[0.05, 0.05, 0.02], size=est.shape)
    est[:, 2] = np.angle(np.exp(1j * est[:, 2]))
    return est


@pytest.mark.parametrize("align", [False, True])
def test_evo_ape_on_our_files_matches_our_ate(tmp_path: Path, align: bool) -> None:
    rng = np.random.default_rng(4)
    n = 300
    t = 1000.0 + np.cumsum(rng.uniform(0.05, 0.15, n))
    truth = np.c_[np.cumsum(rng.normal(size=(n, 2)), axis=0), rng.uniform(-3, 3, n)]
    est = perturbed(rng, truth)
    write_tum(tmp_path / "ref.txt", t, truth)
    write_tum(tmp_path / "est.txt", t, est)
    ours = ate(t, est, t, truth, align=align).rmse
    theirs = evo_ape_cli(tmp_path, tmp_path / "ref.txt", tmp_path / "est.txt", align)
    assert ours == pytest.approx(theirs, rel=1e-9)


@pytest.mark.parametrize("align", [False, True])
def test_evo_ape_on_mrclam_ground_truth_matches_our_ate(
    data: Path, tmp_path: Path, align: bool
) -> None:
    folder = data / "mrclam6"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    run = load_mrclam(folder, robot=1)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    est = perturbed(np.random.default_rng(2), truth)
    write_tum(tmp_path / "ref.txt", run.truth_t, truth)
    write_tum(tmp_path / "est.txt", run.truth_t, est)
    ours = ate(run.truth_t, est, run.truth_t, truth, align=align).rmse
    theirs = evo_ape_cli(tmp_path, tmp_path / "ref.txt", tmp_path / "est.txt", align)
    assert ours == pytest.approx(theirs, rel=1e-9)
