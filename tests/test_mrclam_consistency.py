"""MR.CLAM robots 1-3 against their Vicon truth (issue 33, part 6): why robots 2 and
3 were over-confident, and each robot's preset on the half its calibration never saw.

Oracles, all independent of the filter: the surveyed landmarks and the Vicon path
give every sighting's true range and bearing (geometry); the robot NEES against the
Vicon path is judged by scipy's chi-square quantiles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from rperc.datasets import data_dir, load_mrclam
from rperc.pose import wrap_angle
from rperc.slam.calibration import mrclam_window, true_range_bearing
from rperc.slam.planar import (
    MRCLAM_CALIBRATION_SECONDS,
    PlanarSlam,
    mrclam_preset,
    mrclam_recording,
    mrclam_start,
    variant_config,
)

ROOT = Path(__file__).resolve().parents[1]
MRCLAM = (data_dir() or ROOT / "absent") / "mrclam6"
pytestmark = pytest.mark.skipif(
    not MRCLAM.is_dir(), reason="MR.CLAM data not found (set RPERC_DATA)"
)
LOW, HIGH = chi2.ppf([0.025, 0.975], 3)


def _robot_nees(run, config: dict) -> np.ndarray:
    """The robot NEES of a run (every matched step) against Vicon."""
    result = PlanarSlam({**config, **mrclam_start(run)}).run(mrclam_recording(run))
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    marks = (run.landmark_id, np.c_[run.landmark_x, run.landmark_y])
    return result.nees(run.truth_t, truth, reference_landmarks=marks).nees


@pytest.mark.parametrize("robot", [1, 2, 3])
def test_landmark_sightings_agree_with_the_vicon_geometry(robot: int) -> None:
    """The sightings are not the cause: no other robot's barcode is read as a
    landmark, and against the true range and bearing (Vicon pose, surveyed landmark,
    the preset's camera biases) at least 95 % of each robot's sightings lie inside
    the 99 % chi-square gate of the preset's detection noise."""
    run = load_mrclam(MRCLAM, robot=robot)
    assert run.robot_sightings > 0
    assert not np.isin(run.measurement_landmark, [1, 2, 3, 4, 5]).any()
    preset = mrclam_preset(robot)
    bias = preset["bias"]
    r, b = true_range_bearing(run)
    depth = bias["range_offset"] + bias["range_scale"] * r * np.cos(b)
    bearing = bias["bearing_offset"] + bias["bearing_scale"] * b
    nis = (run.measurement_range - depth) ** 2 / preset["range_variance"] + wrap_angle(
        run.measurement_bearing - bearing
    ) ** 2 / preset["bearing_variance"]
    assert np.mean(nis <= chi2.ppf(0.99, 2)) >= 0.95


def test_robot3_over_confidence_is_the_linearisation() -> None:
    """The cause on robot 3's full run: linearised at its changing estimates, the EKF
    gains heading information no sighting holds (the error stays near 0.2 rad for
    minutes while 0.03 rad is claimed) and the NEES against Vicon leaves its band.
    With first-estimates Jacobians (the preset's) and nothing else changed, the
    NEES is inside the 95 % band at 80 % of the steps, plain and anchored."""
    run = load_mrclam(MRCLAM, robot=3)
    preset = mrclam_preset(3)
    assert preset["first_estimates"] is True
    current = _robot_nees(run, {**preset, "first_estimates": False})
    assert np.mean((current >= LOW) & (current <= HIGH)) < 0.5
    for variant in ("plain", "anchor"):
        nees = _robot_nees(run, variant_config(preset, [variant]))
        assert np.mean((nees >= LOW) & (nees <= HIGH)) >= 0.8, variant
        assert np.mean(nees) < 6.0, variant


@pytest.mark.parametrize("robot", [1, 2, 3])
@pytest.mark.parametrize("variant", ["plain", "anchor"])
def test_held_out_half_of_each_robot_is_consistent(robot: int, variant: str) -> None:
    """Each preset on the half its calibration never saw (from 444 s on): the robot
    NEES mean is below 6 (3 dof: 3 expected) and inside the 95 % band at 80 % of the
    steps."""
    run = mrclam_window(load_mrclam(MRCLAM, robot=robot), MRCLAM_CALIBRATION_SECONDS, 1e9)
    nees = _robot_nees(run, variant_config(mrclam_preset(robot), [variant]))
    assert np.mean((nees >= LOW) & (nees <= HIGH)) >= 0.8
    assert np.mean(nees) < 6.0
