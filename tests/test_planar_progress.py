"""PlanarSlam's progress report (issue 10: ``run(recording, progress=True)``): log
lines off a terminal, the same result as without it, and an exception raised by the
native engine's progress callback stops the run and comes back unchanged."""

from __future__ import annotations

import itertools
import logging

import numpy as np
import pytest

from rperc import _rperc
from rperc.slam import PlanarSlam

CONTROLS = np.c_[np.arange(1000) * 0.1, np.ones(1000), np.zeros(1000)]
DETECTIONS = np.array([[0.55, 5.0, 0.1], [10.05, 4.1, 0.5]])
IDS = np.array([3, 4])


def test_progress_logs_the_rows_and_changes_nothing(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="rperc"):
        shown = PlanarSlam().run_arrays(CONTROLS, DETECTIONS, detection_ids=IDS, progress=True)
    assert "planar SLAM: 1002/1002 (100%) row" in caplog.text
    quiet = PlanarSlam().run_arrays(CONTROLS, DETECTIONS, detection_ids=IDS)
    assert np.array_equal(shown.pose, quiet.pose)
    assert shown.statistics == quiet.statistics


def test_the_callback_is_called_about_every_percent_and_its_exception_stops_the_run() -> None:
    calls: list[tuple[int, int]] = []
    _rperc.planar_slam_run(CONTROLS, DETECTIONS, IDS, progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (1002, 1002)
    assert 90 <= len(calls) <= 110
    assert all(b[0] > a[0] for a, b in itertools.pairwise(calls))

    def stop(done: int, total: int) -> None:
        if done > total // 2:
            raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        _rperc.planar_slam_run(CONTROLS, DETECTIONS, IDS, progress=stop)
