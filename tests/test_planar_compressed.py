"""The compressed EKF (Guivant & Nebot 2001, ``compression="auto"``) against the full
EKF (``compression="off"``) as the oracle, on the real recordings: the same
association decisions, and the same path, robot covariances and map to round-off.
The CLI takes the choice; bad settings are named."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rperc.cli import main
from rperc.datasets import data_dir
from rperc.slam import PlanarSlam, SlamResult
from rperc.slam.planar import PRESETS, mrclam_recording, mrclam_start, victoria_recording

DATA = data_dir()
PARK = None if DATA is None else DATA / "victoria_park"
MRCLAM = None if DATA is None else DATA / "mrclam6"
DECISIONS = ("accepted", "rejected", "new", "candidate", "frozen", "fixes_applied")


def _assert_same(full: SlamResult, compressed: SlamResult, tol: float) -> None:
    assert {k: compressed.statistics[k] for k in DECISIONS} == {
        k: full.statistics[k] for k in DECISIONS
    }
    assert full.statistics["compressions"] == 0
    assert np.array_equal(full.kind, compressed.kind)
    assert np.abs(full.pose[:, :2] - compressed.pose[:, :2]).max() < tol
    heading = np.angle(np.exp(1j * (full.pose[:, 2] - compressed.pose[:, 2])))
    assert np.abs(heading).max() < tol
    assert np.abs(full.covariance - compressed.covariance).max() < tol
    assert np.array_equal(full.landmark_id, compressed.landmark_id)
    assert np.abs(full.landmark_mean - compressed.landmark_mean).max() < tol
    assert np.abs(full.landmark_covariance - compressed.landmark_covariance).max() < tol


@pytest.mark.skipif(PARK is None or not PARK.is_dir(), reason="RPERC_DATA/victoria_park is absent")
def test_victoria_park_compressed_equals_the_full_ekf() -> None:
    from rperc.datasets import load_victoria_park

    rec = victoria_recording(load_victoria_park(PARK))
    full = PlanarSlam(PRESETS["victoria"], compression="off").run(rec)
    compressed = PlanarSlam(PRESETS["victoria"]).run(rec)
    assert compressed.statistics["compressions"] > 10
    assert compressed.statistics["activations"] > 0
    # 4 km of path, 421 landmarks, 50,960 sightings: round-off only.
    _assert_same(full, compressed, 1e-8)


@pytest.mark.skipif(MRCLAM is None or not MRCLAM.is_dir(), reason="RPERC_DATA/mrclam6 is absent")
@pytest.mark.parametrize("variant", [{}, {"anchor": True}, {"freeze_after": 50}])
def test_mrclam_compressed_by_known_ids_equals_the_full_ekf(variant: dict[str, object]) -> None:
    """The 15 landmarks of MR.CLAM are all near the robot: compressed from the first
    landmark on (the default waits for 100) with a 0.5 m active area, the filter
    activates them by their barcodes as they are seen."""
    from rperc.datasets import load_mrclam

    run = load_mrclam(MRCLAM, robot=1)
    config = {**PRESETS["mrclam"], **mrclam_start(run), **variant}
    rec = mrclam_recording(run)
    full = PlanarSlam(config, compression="off").run(rec)
    compressed = PlanarSlam(config, active_radius=0.5, compression_min_landmarks=1).run(rec)
    assert compressed.statistics["compressions"] > 0
    _assert_same(full, compressed, 1e-9)


def test_bad_compression_settings_are_named() -> None:
    controls = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
    detections = np.array([[0.5, 2.0, 0.1]])
    for bad, name in (
        ({"compression": "on"}, "compression"),
        ({"active_radius": 0.0}, "active_radius"),
        ({"active_radius": float("nan")}, "active_radius"),
        ({"compression_min_landmarks": 0}, "compression_min_landmarks"),
    ):
        with pytest.raises(ValueError, match=name):
            PlanarSlam(**bad).run_arrays(controls, detections, detection_ids=[1])
    with pytest.raises(TypeError, match="active_radius"):
        PlanarSlam(active_radius="far").run_arrays(controls, detections, detection_ids=[1])


@pytest.mark.skipif(MRCLAM is None or not MRCLAM.is_dir(), reason="RPERC_DATA/mrclam6 is absent")
def test_cli_takes_the_compression_choice(tmp_path: Path) -> None:
    figures = {}
    for choice in ("off", "auto"):
        out = tmp_path / f"{choice}.json"
        argv = ["slam", "mrclam", str(MRCLAM), "--compression", choice, "--active-radius", "0.5"]
        argv += ["--config", '{"compression_min_landmarks": 1}']
        assert main([*argv, "--json", str(out)]) == 0
        figures[choice] = json.loads(out.read_text())
    assert figures["off"]["statistics"]["compressions"] == 0
    assert figures["auto"]["statistics"]["compressions"] > 0
    assert figures["auto"]["ate_aligned_m"] == pytest.approx(
        figures["off"]["ate_aligned_m"], abs=1e-9
    )
