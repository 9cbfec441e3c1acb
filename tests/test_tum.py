"""TUM trajectory files: round trips, evo reading our files and we reading evo's,
malformed files named by line, and evo_ape (the command line tool, run on files we
wrote) agreeing with our ATE with and without alignment. Time increases strictly in
every file written or read; files are written whole (concurrent writers and readers);
``rperc slam walls --tum`` on logs whose scan times do not increase writes one row per
scan, in log order, that we and evo accept."""

from __future__ import annotations

import gzip
import hashlib
import json
import math
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from evo.core import trajectory
from evo.tools import file_interface
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rperc.cli import main
from rperc.datasets import (
    DatasetFormatError,
    TimestampRepairWarning,
    load_carmen,
    load_mrclam,
    read_tum,
    write_tum,
)
from rperc.slam.evaluation import ate

coordinate = st.floats(-1e6, 1e6, allow_nan=False)


@st.composite
def planar_trajectories(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(1, 30))
    # Times increase strictly (write_tum refuses anything else): steps well above the
    # float spacing at 2e9 s.
    steps = draw(arrays(np.float64, n, elements=st.floats(1e-3, 100.0)))
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
        ("# header\n" + GOOD + "0.5 0 0 0 0 0 0 1\n", 3, "time goes backwards: 0.5 after 1.0"),
        (GOOD + "1.0 0 0 0 0 0 0 1\n", 2, r"time repeats: 1\.0 after 1\.0 \(line 1\)"),
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


@pytest.mark.parametrize(
    ("t", "message"),
    [
        ([0.0, 0.0, 0.0], r"t repeats at index 1: 0\.0 after 0\.0"),
        ([0.0, 2.0, 1.0], r"t goes backwards at index 2: 1\.0 after 2\.0"),
        ([0.0, math.inf, 5.0], r"t\[1\] is inf"),
    ],
)
def test_write_refuses_times_that_do_not_increase(tmp_path: Path, t: list, message: str) -> None:
    """Nothing is written, not even over an older file, and no temporary file stays."""
    path = tmp_path / "x.tum"
    path.write_text("old\n")
    with pytest.raises(ValueError, match=message):
        write_tum(path, t, np.zeros((3, 3)))
    assert path.read_text() == "old\n" and os.listdir(tmp_path) == ["x.tum"]


# ------------------------------------------------------------------ atomic writes

WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from rperc.datasets import write_tum

    k, path, own, repeats = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
    rng = np.random.default_rng(k)
    n = 4000 + 1000 * k  # files of different lengths: a mix shows
    t = 100.0 * k + np.cumsum(rng.uniform(0.01, 0.1, n))
    poses = np.c_[rng.normal(size=(n, 2)), rng.uniform(-3, 3, n)]
    write_tum(own, t, poses)
    for _ in range(repeats):
        write_tum(path, t, poses)
    """
)


def test_concurrent_writers_leave_one_whole_file(tmp_path: Path) -> None:
    """Four processes write their own trajectory to one path, over and over, while
    this one reads it: every read, and the final file, is exactly one writer's whole
    file (compared byte for byte with the copy each wrote alone), and no temporary
    file is left behind."""
    shared = tmp_path / "shared.tum"
    own = [tmp_path / f"own{k}.tum" for k in range(4)]
    writers = [
        subprocess.Popen([sys.executable, "-c", WRITER, str(k), str(shared), str(own[k]), "8"])
        for k in range(4)
    ]
    seen: set[str] = set()
    reads = 0
    deadline = time.monotonic() + 120
    while any(w.poll() is None for w in writers) and time.monotonic() < deadline:
        try:
            seen.add(hashlib.sha256(shared.read_bytes()).hexdigest())
            reads += 1
        except FileNotFoundError:
            pass
    assert [w.wait(timeout=60) for w in writers] == [0, 0, 0, 0]
    whole = {hashlib.sha256(p.read_bytes()).hexdigest() for p in own}
    assert len(whole) == 4
    final = hashlib.sha256(shared.read_bytes()).hexdigest()
    assert final in whole
    assert seen <= whole, f"{len(seen - whole)} of {reads} reads saw a mixed or partial file"
    assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in [shared, *own])
    read_tum(shared)


def test_a_failed_write_keeps_the_old_file(tmp_path: Path, monkeypatch) -> None:
    """An error while the new file is written (here: the disk refuses to sync) leaves
    the old file as it was and removes the temporary one."""
    from rperc import _atomic

    path = tmp_path / "keep.tum"
    write_tum(path, [1.0, 2.0], np.zeros((2, 3)))
    before = path.read_bytes()

    def refuse(fd: int) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_atomic.os, "fsync", refuse)
    with pytest.raises(OSError, match="No space"):
        write_tum(path, [1.0, 2.0, 3.0], np.ones((3, 3)))
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["keep.tum"]


def test_written_file_has_the_permissions_open_gives(tmp_path: Path) -> None:
    """The temporary file is created like any new file (the umask applies), so the
    renamed result is not left private to its owner as mkstemp's would be."""
    write_tum(tmp_path / "a.tum", [1.0], [[0.0, 0.0, 0.0]])
    (tmp_path / "b.txt").write_text("x")
    assert (tmp_path / "a.tum").stat().st_mode == (tmp_path / "b.txt").stat().st_mode


# ----------------------------------- rperc slam walls --tum on logs that repeat times


def flaser_times(path: Path) -> list[float]:
    """Each FLASER line's time as the file writes it, in file order (read directly)."""
    with gzip.open(path, "rt") if path.suffix == ".gz" else path.open() as f:
        return [float(line.split()[-3]) for line in f if line.startswith("FLASER ")]


def check_walls_tum(tmp_path: Path, log_path: Path, repaired: int, capsys) -> None:
    """``rperc slam walls LOG --tum``: a note on stderr names the repair; the file has
    one row per scan, at the log's repaired times, in log order (its path scores the
    JSON's ATE against the log's poses row by row); read_tum and evo accept it."""
    tum, js = tmp_path / "out.tum", tmp_path / "out.json"
    assert main(["slam", "walls", str(log_path), "--tum", str(tum), "--json", str(js)]) == 0
    err = capsys.readouterr().err
    scans = len(flaser_times(log_path))
    assert f"note: {log_path.name}: {repaired} of {scans} scan times did not increase" in err
    with pytest.warns(TimestampRepairWarning, match=f"{repaired} of {scans} scan times"):
        log = load_carmen(log_path)
    t, poses = read_tum(tum)
    assert len(t) == scans and np.all(np.diff(t) > 0)
    np.testing.assert_array_equal(t, log.scans.timestamp)
    kept = log.scans.timestamp_raw == t
    np.testing.assert_array_equal(t[kept], np.asarray(flaser_times(log_path))[kept])
    err_xy = poses[:, :2] - log.scans.pose[:, :2]
    ate = math.sqrt(float(np.mean(np.sum(err_xy**2, axis=1))))
    assert ate == pytest.approx(json.loads(js.read_text())["ate_rmse_m"], rel=1e-9)
    traj = file_interface.read_tum_trajectory_file(tum)
    valid, details = traj.check()
    assert valid, details
    assert traj.num_poses == scans
    np.testing.assert_array_equal(traj.timestamps, t)


def test_slam_walls_tum_on_orebro(data: Path, tmp_path: Path, capsys) -> None:
    """orebro.log.gz stamps all 237 scans 0."""
    check_walls_tum(tmp_path, data / "carmen" / "orebro.log.gz", 236, capsys)


def test_slam_walls_tum_on_a_log_with_repeated_and_backward_times(tmp_path: Path, capsys) -> None:
    """A simulated loop log whose scans share times three by three, with one time
    that steps back."""
    from rperc.scansim import write_loop_log

    path = write_loop_log(tmp_path / "loop.log", seed=3, laps=1.2)
    lines = path.read_text().splitlines()
    times = [0.5 * (k // 3) for k in range(len(lines))]
    times[10] = 0.25
    out = []
    for line, t in zip(lines, times, strict=True):
        tok = line.split()
        tok[-3] = tok[-1] = f"{t:g}"
        out.append(" ".join(tok))
    path.write_text("\n".join(out) + "\n")
    repaired = len(lines) - len(set(times[:10] + times[11:]))
    check_walls_tum(tmp_path, path, repaired, capsys)


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
