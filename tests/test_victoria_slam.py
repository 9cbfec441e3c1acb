"""Victoria Park with PlanarSlam (issue 10): the GPS lever arm and the GPS glitch screen
against closed forms, the external-sensor variant (eqs. 26-27) with a lever arm
against the exact arc of a unicycle, and, on the real data (RPERC_DATA), the JCBB run
without a map tear and the external variant applying the GPS."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import VictoriaPark, data_dir
from rperc.slam import PlanarSlam
from rperc.slam.planar import point_path

DATA = data_dir()
PARK = None if DATA is None else DATA / "victoria_park"
needs_park = pytest.mark.skipif(
    PARK is None or not PARK.is_dir(), reason="RPERC_DATA/victoria_park is absent"
)


def test_point_path_is_the_rotated_lever_arm() -> None:
    pose = np.array([[1.0, 2.0, math.pi / 2], [0.0, 0.0, 0.0], [0.0, 0.0, math.pi]])
    got = point_path(pose, (3.0, 0.5))
    assert np.allclose(got, [[0.5, 5.0], [3.0, 0.5], [-3.0, -0.5]], atol=1e-12)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        point_path(np.zeros((2, 2)), (1.0, 0.0))


def _park(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> VictoriaPark:
    empty = np.zeros(0)
    return VictoriaPark(
        measurement_t=empty,
        measurement_range=empty,
        measurement_bearing=empty,
        measurement_bearing_laser=empty,
        measurement_diameter=empty,
        input_t=empty,
        input_speed=empty,
        input_steering=empty,
        gps_t=t,
        gps_x=x,
        gps_y=y,
        nan_rows=0,
        time_backwards=0,
    )


def test_gps_screen_drops_only_a_fix_that_jumps_away_from_both_neighbours() -> None:
    # 5 m/s along x, fixes every 0.2 s; fix 5 is 141 m away (the run's glitch).
    t = np.arange(10) * 0.2
    x, y = 5.0 * t, np.zeros(10)
    y[5] = 141.0
    assert np.flatnonzero(~_park(t, x, y).gps_plausible()).tolist() == [5]
    # A genuine 3 m step (20 m/s over 0.2 s): within the default; at 10 m/s both ends
    # of the step still reach their other neighbour, so no fix is dropped.
    x2 = x.copy()
    x2[6:] += 3.0
    assert _park(t, x2, y * 0).gps_plausible().all()
    assert _park(t, x2, y * 0).gps_plausible(max_speed=10.0).all()
    with pytest.raises(ValueError, match="max_speed"):
        _park(t, x, y).gps_plausible(max_speed=0.0)


def _arc(t: np.ndarray, v: float, omega: float) -> np.ndarray:
    """The exact unicycle arc from the origin (closed form)."""
    th = omega * t
    return np.c_[v * np.sin(th) / omega, v * (1 - np.cos(th)) / omega, th]


def test_external_fix_with_a_lever_arm_measures_that_point() -> None:
    """A unicycle on a known arc (closed form) gets fixes of the point (3.78, 0.5) of
    the robot, each offset by a constant (0.3, -0.2) m, and starts with an uncertain
    position: with the right lever arm the filter's path is the true arc shifted by
    that constant; told the fixes are of the pose's origin, they sit metres from where
    the filter expects them, and its chi-square gate refuses them."""
    v, omega = 2.0, 0.1
    t = np.arange(0.0, 30.0, 0.1)
    controls = np.c_[t, np.full_like(t, v), np.full_like(t, omega)]
    t_fix = t[5::10]
    fix_xy = point_path(_arc(t_fix, v, omega), (3.78, 0.5)) + np.array([0.3, -0.2])
    n = len(t_fix)
    fixes = np.c_[t_fix, fix_xy, np.full(n, 0.01), np.zeros(n), np.full(n, 0.01)]
    config = {
        "motion": {"unicycle": {"speed_variance": 1e-6, "turn_rate_variance": 1e-8}},
        "external_fix": True,
        "initial_pose_variance": [1.0, 1.0, 1e-8],
    }
    worst, rejected = {}, {}
    for name, arm in (("right", [3.78, 0.5]), ("origin", [0.0, 0.0])):
        res = PlanarSlam(config, fix_lever_arm=arm).run_arrays(
            controls, np.zeros((0, 3)), fixes=fixes
        )
        assert res.statistics["fixes_applied"] + res.statistics["fixes_rejected"] == n
        tt, pose, _ = res.path()
        late = tt > 1.0
        expected = _arc(tt[late], v, omega)[:, :2] + np.array([0.3, -0.2])
        worst[name] = float(np.abs(pose[late, :2] - expected).max())
        rejected[name] = res.statistics["fixes_rejected"]
    assert worst["right"] < 0.02, worst
    assert rejected["right"] == 0
    assert rejected["origin"] > n // 2, rejected


def _json_run(tmp_path: Path, *argv: str) -> dict:
    out = tmp_path / "run.json"
    assert main(["slam", "victoria", str(PARK), *argv, "--json", str(out)]) == 0
    return json.loads(out.read_text())


@needs_park
def test_jcbb_run_keeps_the_map_whole_and_the_external_variant_uses_the_gps(tmp_path) -> None:
    from rperc.datasets import load_victoria_park
    from rperc.slam.planar import PRESETS, victoria_recording

    park = load_victoria_park(PARK)
    res = PlanarSlam(PRESETS["victoria"]).run(victoria_recording(park))
    # No false association tears the map: no scan moves the car by more than the
    # distance it can drive between two events (6.6 m/s x 0.2 s) plus 1 m.
    step = np.hypot(*np.diff(res.pose[:, :2], axis=0).T)
    assert step[res.kind[1:] == 1].max() < 1.0 + 6.6 * 0.2
    assert res.statistics["jcbb_truncated"] == 0
    plain = _json_run(tmp_path)
    assert plain["landmarks"] == len(res.landmark_id)
    assert plain["statistics"]["fixes_applied"] == 0 and plain["gps_fixes_implausible"] >= 1
    external = _json_run(tmp_path, "--variant", "external")
    stats = external["statistics"]
    assert stats["fixes_applied"] > 0.9 * len(park.gps_t)
    # The 141 m glitch at t = 1223.3 s is refused by the fix's chi-square gate.
    assert stats["fixes_rejected"] >= 1
