"""The laser-SLAM peer of benchmarks/laser_peer.py (small_gicp ICP, gtsam iSAM2 loops)
on a short simulated loop: its odometry is rperc's own, to 1e-9; its ATE is the RMSE
of its own returned path, computed here in numpy; scan matching beats dead reckoning
by far; and the command line writes its rows and table. Skipped without the
``laser-peer`` extra."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from rperc.datasets.carmen import load_carmen
from rperc.scansim import write_loop_log
from rperc.slam.wallslam import run_walls

pytest.importorskip("small_gicp")
pytest.importorskip("gtsam")


def load_peer() -> ModuleType:
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "laser_peer.py"
    spec = importlib.util.spec_from_file_location("laser_peer", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve annotations through it
    spec.loader.exec_module(module)
    return module


peer = load_peer()


@pytest.fixture(scope="module")
def loop_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path: Path = write_loop_log(tmp_path_factory.mktemp("peer") / "loop.log", seed=3, laps=1.2)
    return path


@pytest.fixture(scope="module")
def runs(loop_log: Path) -> dict[str, dict]:
    return {
        "icp": peer.run_peer(loop_log, 5, loops=False),
        "icp+loops": peer.run_peer(loop_log, 5, loops=True),
    }


def rmse_xy(path: np.ndarray, reference: np.ndarray) -> float:
    d = np.asarray(path)[:, :2] - np.asarray(reference)[:, :2]
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


@pytest.mark.parametrize("seed", [0, 5])
def test_odometry_is_rperc_dead_reckoning(loop_log: Path, seed: int) -> None:
    """The peer's dead-reckoned pose at every scan is rperc's own odometry-only run's."""
    log = load_carmen(loop_log)
    ours, _ = peer.odometry(np.asarray(log.scans.pose), seed)
    theirs = run_walls(log, seed=seed, use_walls=False).pose
    assert ours.shape == theirs.shape
    np.testing.assert_allclose(ours[:, :2], theirs[:, :2], rtol=0, atol=1e-9)
    heading = np.angle(np.exp(1j * (ours[:, 2] - theirs[:, 2])))
    assert np.max(np.abs(heading)) < 1e-9


@pytest.mark.parametrize("variant", ["icp", "icp+loops"])
def test_ate_is_the_rmse_of_the_returned_path(
    runs: dict[str, dict], loop_log: Path, variant: str
) -> None:
    r = runs[variant]
    reference = np.asarray(load_carmen(loop_log).scans.pose)
    assert r["variant"] == variant and r["seed"] == 5 and r["log"] == "loop.log"
    assert r["path"].shape == (len(reference), 3) == (r["scans"], 3)
    assert r["ate_rmse_m"] == pytest.approx(rmse_xy(r["path"], reference), rel=1e-12)
    final = float(np.hypot(*(r["path"][-1, :2] - reference[-1, :2])))
    assert r["final_error_m"] == pytest.approx(final, rel=1e-12)
    # Every run starts at the reference's first pose.
    np.testing.assert_allclose(r["path"][0], reference[0], atol=1e-6)
    assert r["scans_per_second"] > 0


@pytest.mark.parametrize("variant", ["icp", "icp+loops"])
def test_scan_matching_beats_dead_reckoning(
    runs: dict[str, dict], loop_log: Path, variant: str
) -> None:
    r = runs[variant]
    reference = np.asarray(load_carmen(loop_log).scans.pose)
    odometry_ate = rmse_xy(r["odometry"], reference)
    assert r["odometry_ate_rmse_m"] == pytest.approx(odometry_ate, rel=1e-12)
    assert r["ate_rmse_m"] < 0.25 * odometry_ate


def test_loops_close_on_the_second_lap(runs: dict[str, dict]) -> None:
    """1.2 laps revisit the start: the loop variant finds loops, ICP alone never does."""
    assert runs["icp"]["loop_closures"] == 0
    assert runs["icp+loops"]["loop_closures"] >= 1


def test_unknown_setting_is_refused(loop_log: Path) -> None:
    with pytest.raises(TypeError):
        peer.run_peer(loop_log, 0, loops=False, no_such_setting=1)


def test_command_line_writes_rows_and_table(
    loop_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rows.json"
    argv = ["--logs", str(loop_log), "--seeds", "1-2", "--variants", "icp", "--json", str(out)]
    assert peer.main(argv) == 0
    rows = json.loads(out.read_text())
    assert [(r["seed"], r["variant"]) for r in rows] == [(1, "icp"), (2, "icp")]
    assert "path" not in rows[0]
    table = capsys.readouterr().out
    assert "loop.log" in table and "odometry ATE m" in table


def test_seed_ranges() -> None:
    assert peer.seed_list("0-2") == [0, 1, 2]
    assert peer.seed_list("0-1,5") == [0, 1, 5]


def test_scans_without_returns_keep_the_odometry(loop_log: Path) -> None:
    """A stretch of scans with no returns (longer than the local map) is driven on
    odometry alone, and matching resumes after it."""
    log = load_carmen(loop_log)
    reference = np.asarray(log.scans.pose)
    odo, cov = peer.odometry(reference, 0)
    run = peer.Peer(log, odo, cov, peer.Settings(), None)
    blind = range(20, 20 + peer.LOCAL_MAP_SCANS + 5)
    for k in blind:
        run.points[k] = np.zeros((0, 2))
    path = run.run()
    assert run.rejected >= len(blind)
    steps = [peer.between(path[k - 1], path[k]) for k in blind]
    np.testing.assert_allclose(steps, [peer.between(odo[k - 1], odo[k]) for k in blind])
    assert rmse_xy(path, reference) < rmse_xy(odo, reference)


def test_missing_package_names_the_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "gtsam", None)  # import gtsam raises ImportError
    assert peer.main(["--logs", "nowhere.log"]) == 2
    err = capsys.readouterr().err.strip()
    assert "rperc[laser-peer]" in err and "gtsam" in err and "\n" not in err
