"""POT-210's metrics (issue 35): the mean corner error against hand-computed and
brute-force values, precision over the visible frames only, and the ground-truth
reader on the real V25_2 files and on malformed ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rperc.datasets import DatasetFormatError, data_dir, load_planar_truth
from rperc.tracking import planar

SQUARE = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])


def test_corner_error_by_hand():
    truth = np.stack([SQUARE] * 3)
    est = truth.copy()
    est[0] += (3.0, 4.0)  # every corner 5 px off
    est[1, 2] += (6.0, 8.0)  # one corner 10 px off: mean 2.5 (RMS would be 5)
    est[2, 1, 0] = np.nan  # a failure
    got = planar.corner_error(est, truth)
    assert got.tolist() == [5.0, 2.5, math.inf]
    assert planar.alignment_error(est, truth)[1] == pytest.approx(5.0)


def test_corner_error_matches_brute_force():
    rng = np.random.default_rng(7)
    truth = rng.uniform(0, 500, (40, 4, 2))
    est = truth + rng.normal(0, 6, truth.shape)
    want = [
        sum(math.hypot(e[i][0] - t[i][0], e[i][1] - t[i][1]) for i in range(4)) / 4
        for e, t in zip(est.tolist(), truth.tolist(), strict=True)
    ]
    np.testing.assert_allclose(planar.corner_error(est, truth), want, rtol=1e-12)


def test_pot_score_counts_visible_frames_only():
    truth = np.stack([SQUARE] * 5)
    est = truth.copy()
    est[:, :, 0] += np.array([0.0, 5.0, 100.0, 15.5, 0.0])[:, None]  # errors, frame by frame
    est[4] = np.inf  # a failure
    visible = np.array([True, True, False, True, False])
    s = planar.pot_score(est, truth, visible)
    # Visible: 0, 5 and 15.5 px; 100 px (occluded) and the failure (out of view) ignored.
    assert s.frames == 3
    assert s.mean_corner_error_px == pytest.approx(20.5 / 3)
    assert s.precision_at_5 == pytest.approx(2 / 3)  # 5 px counts: "within" is <=
    assert s.precision_at_15 == pytest.approx(2 / 3)
    # Whatever the hidden frames hold, the score does not move.
    est[2] = -1e9
    assert planar.pot_score(est, truth, visible) == s


def test_pot_score_refuses_bad_masks():
    truth = np.stack([SQUARE] * 2)
    with pytest.raises(ValueError, match="boolean mask"):
        planar.pot_score(truth, truth, [1, 0])
    with pytest.raises(ValueError, match="boolean mask"):
        planar.pot_score(truth, truth, [True])
    with pytest.raises(ValueError, match="no visible frame"):
        planar.pot_score(truth, truth, [False, False])
    with pytest.raises(ValueError, match="estimated"):
        planar.corner_error(np.zeros((2, 3, 2)), truth)


def test_reader_on_v25_2():
    root = data_dir()
    folder = None if root is None else root / "planar" / "V25_2"
    if folder is None or not folder.is_dir():
        pytest.skip("the POT-210 sequence planar/V25_2 is not in RPERC_DATA")
    truth = load_planar_truth(folder)
    assert truth.corners.shape == (50, 4, 2) and truth.flags.shape == (50,)
    # The README's first line: 441.000 172.000 742.700 177.500 738.000 572.800 ...
    assert truth.corners[0].tolist() == [
        [441.0, 172.0],
        [742.7, 177.5],
        [738.0, 572.8],
        [438.3, 574.8],
    ]
    assert truth.visible.all()


def test_reader_names_the_bad_line(tmp_path):
    (tmp_path / "gt_corners.txt").write_text("1 2 3 4 5 6 7 8\n1 2 3 4 5 6 7\n")
    with pytest.raises(DatasetFormatError, match=r"gt_corners.txt.*2"):
        load_planar_truth(tmp_path)
    (tmp_path / "gt_corners.txt").write_text("1 2 3 4 5 6 7 8\n1 2 3 nan 5 6 7 8\n")
    with pytest.raises(DatasetFormatError, match="finite"):
        load_planar_truth(tmp_path)
    (tmp_path / "gt_corners.txt").write_text("1 2 3 4 5 6 7 8\n" * 2)
    assert load_planar_truth(tmp_path).visible.all()  # no flag file: all visible
    (tmp_path / "gt_flag.txt").write_text("0\n3\n")
    with pytest.raises(DatasetFormatError, match=r"gt_flag.txt.*2"):
        load_planar_truth(tmp_path)
    (tmp_path / "gt_flag.txt").write_text("0\n")
    with pytest.raises(DatasetFormatError, match="1 flags for 2 frames"):
        load_planar_truth(tmp_path)
    (tmp_path / "gt_flag.txt").write_text("0\n1\n")
    assert load_planar_truth(tmp_path).visible.tolist() == [True, False]
