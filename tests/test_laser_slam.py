"""Laser SLAM (issue 33): scan matching, loop closures and the pose graph on a
simulated corridor loop with known truth, the command's outputs (TUM read back by
evo, the JSON keys), the bench row against the command, and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rperc.cli import main
from rperc.config import LaserConfig
from rperc.datasets.carmen import load_carmen
from rperc.slam.laser import VARIANTS, defaults, from_settings, load_and_run, run_config

#: The scores issue 33 asks the JSON (and a bench row) to hold.
SCORES = (
    "ate_rmse_m",
    "ate_rmse_causal_m",
    "nees_mean",
    "nees_in_band",
    "loop_closures_accepted",
    "loop_closures_rejected",
)


@pytest.fixture(scope="module")
def loop_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two laps of the simulated corridor loop (1 cm range noise), the true path as
    the log's corrected poses."""
    from rperc.scansim import write_loop_log

    return write_loop_log(tmp_path_factory.mktemp("laser") / "loop.log", seed=1, laps=2.0)


def _truth_ate(pose: np.ndarray, truth: np.ndarray) -> float:
    """ATE written out here, not taken from the code under test."""
    d = pose[:, :2] - truth[:, :2]
    return float(np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2)))


def _robot_nees(pose: np.ndarray, truth: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """Each scan's robot NEES after the first (whose pose is given), written out here,
    not taken from the code under test."""
    err = pose[1:] - truth[1:]
    err[:, 2] = np.angle(np.exp(1j * err[:, 2]))
    return np.einsum("ni,nij,nj->n", err, np.linalg.inv(covariance[1:]), err)


def test_each_stage_beats_the_one_before_against_the_truth(loop_log: Path) -> None:
    """Over six odometry draws, scan matching removes most of the odometry's drift
    (over four fifths) and the loop closures most of what is left (over half; the
    front end leaves them less since its far wall points have normals), and every
    seed's final path is within 5 cm of the simulated truth (the oracle; 1 cm range
    noise)."""
    from rperc.datasets.carmen import load_carmen

    truth = np.asarray(load_carmen(loop_log).scans.pose)
    ate: dict[str, list[float]] = {v: [] for v in VARIANTS}
    for seed in range(6):
        for v in VARIANTS:
            r = load_and_run(loop_log, seed=seed, variant=v)
            ate[v].append(_truth_ate(r.pose, truth))
            assert r.metrics["ate_rmse_m"] == pytest.approx(ate[v][-1], rel=1e-12)
            if v == "loops":
                assert r.counts["loop_closures_accepted"] >= 2
    mean = {v: float(np.mean(a)) for v, a in ate.items()}
    assert mean["scan-matching"] < 0.2 * mean["odometry"], ate
    assert mean["loops"] < 0.5 * mean["scan-matching"], ate
    assert max(ate["loops"]) < 0.05, ate


def test_final_covariance_is_not_overconfident_in_simulation(loop_log: Path) -> None:
    """The robot NEES of the final path against the truth, over four odometry draws,
    stays under the 3-dof band's top (9.35) on average: the graph's marginals are
    not overconfident."""
    from rperc.datasets.carmen import load_carmen

    truth = np.asarray(load_carmen(loop_log).scans.pose)
    nees = []
    for seed in range(4):
        r = load_and_run(loop_log, seed=seed)
        nees.append(_robot_nees(r.pose, truth, r.covariance))
    mean = float(np.mean(np.concatenate(nees)))
    assert mean < 3.0 * 1.5, mean


def _off_the_nearest_wall(walls: np.ndarray, true_walls: np.ndarray) -> np.ndarray:
    """For each wall ``(W, 4)``, how far its ends lie from the line of the true wall
    nearest its middle, written out here."""
    a, b = true_walls[:, :2], true_walls[:, 2:]
    ab = b - a
    mid = (walls[:, :2] + walls[:, 2:]) / 2
    t = np.einsum("pwi,wi->pw", mid[:, None, :] - a, ab) / np.einsum("wi,wi->w", ab, ab)
    foot = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    k = np.argmin(np.linalg.norm(mid[:, None, :] - foot, axis=2), axis=1)
    normal = np.c_[-ab[k, 1], ab[k, 0]] / np.linalg.norm(ab[k], axis=1)[:, None]
    ends = np.stack([walls[:, :2], walls[:, 2:]], axis=1) - a[k][:, None, :]
    return np.abs(np.einsum("wei,wi->we", ends, normal))


def test_wall_landmarks_lie_on_the_true_walls_and_keep_the_covariance_honest(
    loop_log: Path,
) -> None:
    """The ``walls`` variant maps the simulated corridor's walls: every mapped wall's
    ends lie within 5 cm of the line of the true wall (the simulator's) nearest it
    (a landmark is a line; its drawn extent is only where it was seen from poses
    of their time), the final path stays
    within 5 cm of the truth, and the robot NEES against the truth stays under the
    3-dof band's top on average over four draws."""
    from rperc.scansim import loop_walls

    truth = np.asarray(load_carmen(loop_log).scans.pose)
    true_walls = loop_walls().reshape(-1, 4)
    nees = []
    for seed in range(4):
        r = load_and_run(loop_log, seed=seed, variant="walls")
        assert r.walls.shape[1] == 4 and len(r.walls) >= 4
        assert r.counts["wall_landmarks"] == len(r.walls)
        assert r.counts["wall_sightings"] >= 2 * len(r.walls)
        assert np.max(_off_the_nearest_wall(r.walls, true_walls)) < 0.05
        assert _truth_ate(r.pose, truth) < 0.05
        nees.append(_robot_nees(r.pose, truth, r.covariance))
    assert float(np.mean(np.concatenate(nees))) < 3.0 * 1.5
    # The default pipeline maps no walls.
    assert len(load_and_run(loop_log, seed=0).walls) == 0


def test_command_writes_tum_json_and_map(loop_log: Path, tmp_path: Path) -> None:
    tum, out, png = tmp_path / "run.tum", tmp_path / "run.json", tmp_path / "map.png"
    argv = ["slam", "laser", str(loop_log), "--seed", "2", "--tum", str(tum), "--json", str(out)]
    assert main([*argv, "--plot", str(png)]) == 0
    measured = json.loads(out.read_text())
    for key in (
        *SCORES,
        "scans_per_second",
    ):
        assert key in measured, key
    # The simulated loop's log has no max-range PARAM: its readings' own range.
    scans = load_carmen(loop_log).scans
    assert measured["max_range_m"] == float(np.max(scans.max_range))
    assert measured["max_range_param_set_aside"] is False
    from evo.tools import file_interface

    from rperc.datasets import read_tum

    t, poses = read_tum(tum)
    assert len(t) == len(scans.pose) and np.all(np.diff(t) > 0)
    traj = file_interface.read_tum_trajectory_file(str(tum))
    assert traj.num_poses == len(t)
    # The TUM rows are the final estimate, in log order: their ATE is the JSON's.
    assert _truth_ate(poses, np.asarray(scans.pose)) == pytest.approx(
        measured["ate_rmse_m"], rel=1e-6
    )
    assert png.stat().st_size > 20_000


def test_bench_row_equals_the_command(loop_log: Path, tmp_path: Path) -> None:
    from rperc import bench

    out = tmp_path / "run.json"
    assert main(["slam", "laser", str(loop_log), "--seed", "3", "--json", str(out)]) == 0
    single = json.loads(out.read_text())
    (row,) = bench.laser(loop_log, variants=["laser"], seeds=[3]).rows
    for key in SCORES:
        assert row[key] == single[key], key


def test_a_settings_grid_reaches_the_pipeline(loop_log: Path) -> None:
    from rperc import bench

    result = bench.laser(
        loop_log, variants=["laser"], seeds=[0], grid={"loops.enabled": [False, True]}
    )
    off, on = result.rows
    assert off["loops.enabled"] is False and off["loop_closures_accepted"] == 0
    assert on["loop_closures_accepted"] > 0
    with pytest.raises(ValueError, match="unknown setting"):
        bench.laser(loop_log, variants=["laser"], grid={"icp.sigmaa": [0.1]})


@pytest.mark.parametrize(
    ("config", "error", "match"),
    [
        ({"icp": {"sigma": -1.0}}, ValueError, "sigma"),
        ({"icp": {"sigmaa": 1.0}}, TypeError, "sigmaa"),
        ({"loops": {"coarse_step": 1e-6}}, ValueError, "coarse_step"),
        ({"local_map": {"cell": 0.1}}, ValueError, "cell"),
        ({"scan": {"max_flatness": float("nan")}}, ValueError, "max_flatness"),
        ({"chain_inflation": 0.5}, ValueError, "chain_inflation"),
        ({"local_map": {"search_share": float("nan")}}, ValueError, "search_share"),
        ({"local_map": {"search_share": 1.5}}, ValueError, "search_share"),
        ({"local_map": {"search_starts": 0}}, ValueError, "search_starts"),
        ({"local_map": {"search_reach": -0.1}}, ValueError, "search_reach"),
        ({"local_map": {"search_step": float("inf")}}, ValueError, "search_step"),
        ({"local_map": {"search_rms": 0.0}}, ValueError, "search_rms"),
        ({"loops": {"inflation": 0.5}}, ValueError, "inflation"),
        ({"loops": {"inflation": float("inf")}}, ValueError, "inflation"),
        ({"walls": {"straightness": float("nan")}}, ValueError, "straightness"),
        ({"walls": {"max_gap": 6.0}}, ValueError, "max_gap"),
        ({"walls": {"gate": 1.0}}, ValueError, "gate"),
        ({"walls": {"every_path": 0.0}}, ValueError, "every_path"),
    ],
)
def test_bad_settings_name_the_field(loop_log: Path, config: dict, error: type, match: str) -> None:
    """Typed keyword overrides (each part a replaced copy of the run's), and the
    deprecated nested mapping: the same error, naming the field."""
    base = VARIANTS["loops"]
    with pytest.raises(error, match=match):
        typed = {
            k: getattr(base, k).replace(**v) if isinstance(v, dict) else v
            for k, v in config.items()
        }
        load_and_run(loop_log, **typed)
    with pytest.warns(DeprecationWarning, match="LaserConfig"), pytest.raises(error, match=match):
        load_and_run(loop_log, config=config)


def test_bad_variant_and_the_deprecated_defaults() -> None:
    with pytest.raises(ValueError, match="variant"):
        load_and_run("unused.log", variant="teleport")
    with pytest.warns(DeprecationWarning, match="LaserConfig"):
        d = defaults()
    assert d == LaserConfig().to_dict()


def test_a_variant_changes_only_its_own_settings_of_any_config() -> None:
    """A variant's changes are made on top of the config given (not the other way
    round), and nothing else of it changes; the run starts where it is told."""
    start = (1.0, 2.0, 0.5)
    given = LaserConfig(chain_inflation=2.0)
    made = run_config("odometry", given, start)
    assert made.loops == given.loops.replace(enabled=False)
    assert made.icp == given.icp.replace(min_inliers=1_000_000)
    assert made.motion == given.motion  # LaserConfig's own, not the experiment's
    assert made.replace(loops=given.loops, icp=given.icp) == given.replace(initial_pose=start)
    assert run_config("loops", None, start) == VARIANTS["loops"].replace(initial_pose=start)
    # An override of the start wins over the reference's.
    assert run_config("loops", None, start, {"initial_pose": (0.0, 0.0, 0.0)}) == VARIANTS["loops"]


def test_settings_from_json_and_the_deprecated_mapping_give_the_same_config() -> None:
    """The CLI's and the bench's JSON settings (nested, or dotted) and the old mapping
    spelling of ``config=``: one config, with the run's odometry noise kept where a
    part is only partly given."""
    nested = {"icp": {"sigma": 0.02}, "motion": {"speed_variance": 0.5}}
    config, start = from_settings(nested)
    assert start == {}
    assert from_settings({"icp.sigma": 0.02, "motion.speed_variance": 0.5})[0] == config
    loops = VARIANTS["loops"]
    assert config == loops.replace(
        icp=loops.icp.replace(sigma=0.02), motion=loops.motion.replace(speed_variance=0.5)
    )
    pose = (3.0, 4.0, 0.1)
    typed = run_config("scan-matching", config, pose)
    with pytest.warns(DeprecationWarning):
        assert run_config("scan-matching", nested, pose) == typed
    moved, start = from_settings({"initial_pose": [1.0, 2.0, 3.0]})
    assert start == {"initial_pose": (1.0, 2.0, 3.0)}
    assert run_config("loops", moved, pose, start).initial_pose == (1.0, 2.0, 3.0)


def test_the_native_result_is_typed_frozen_and_read_only(loop_log: Path) -> None:
    """The seam's result: named fields whose shapes agree with the log, arrays that
    cannot be written, no attribute that can be set, and rejection counts that add up
    to the total (each closure is rejected for one reason)."""
    from rperc import _rperc
    from rperc.datasets.carmen import load_carmen
    from rperc.slam.wallslam import increments

    sc = load_carmen(loop_log).scans
    controls, t = increments(np.asarray(sc.pose))
    controls = np.r_[controls, [[t[-1], 0.0, 0.0]]]
    f64 = np.float64
    run = _rperc.laser_run(
        np.asarray(sc.ranges, dtype=f64), np.asarray(sc.num_beams, dtype=np.int64),
        np.asarray(sc.angle_min, dtype=f64), np.asarray(sc.angle_increment, dtype=f64),
        np.asarray(sc.max_range, dtype=f64), controls, t,
        {"initial_pose": np.asarray(sc.pose)[0].tolist()},
    )  # fmt: skip
    s = len(t)
    assert isinstance(run, _rperc.LaserRun)
    assert run.pose.shape == run.causal_pose.shape == (s, 3)
    assert run.covariance.shape == (s, 3, 3)
    assert run.matched.shape == run.inliers.shape == run.rms.shape == (s,)
    assert run.closures.dtype == np.int64 and run.closures.shape == (len(run.closure_chi2), 2)
    assert set(run.closures.ravel()) <= set(run.keys.tolist())
    assert sum(run.rejected) == run.closures_rejected
    assert len(run.rejection_reasons) == len(run.rejected) == 5
    with pytest.raises(ValueError, match="read-only"):
        run.pose[0, 0] = 1.0
    with pytest.raises(AttributeError):
        run.pose = np.zeros((s, 3))  # type: ignore[misc]
    assert f"{s} scans" in repr(run)


def test_the_deprecated_nested_helper_still_nests_dotted_settings() -> None:
    from rperc.bench.suites.laser import nested

    with pytest.warns(DeprecationWarning, match="from_settings"):
        out = nested({"icp.sigma": 0.02, "loops.enabled": False, "chain_inflation": 2.0})
    assert out == {"icp": {"sigma": 0.02}, "loops": {"enabled": False}, "chain_inflation": 2.0}


def test_robot_nees_is_honest_on_the_real_logs(data: Path) -> None:
    """On the corpus's CARMEN logs (odometry seed 0), the robot NEES mean of the final
    path against the log's corrected path is at most 6 (3 expected for 3 dof) on at
    least seven logs of every nine (issue 33's bar), and never under 1 (a covariance so
    loose it says nothing). The NEES is computed here from the returned covariances, not taken from
    the run's own score. fhw is the known exception (NEES about 20)."""
    logs = sorted((data / "carmen").glob("*.log*"))
    if not logs:
        pytest.skip("no CARMEN logs in the data folder")
    means = {}
    for log in logs:
        r = load_and_run(log, seed=0)
        means[log.name] = float(np.mean(_robot_nees(r.pose, r.reference, r.covariance)))
    honest = [name for name, m in means.items() if m <= 6.0]
    assert len(honest) * 9 >= len(means) * 7, means
    assert min(means.values()) > 1.0, means
