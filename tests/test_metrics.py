"""OTB metrics on hand-computed cases."""

from __future__ import annotations

import numpy as np
import pytest

from rperc.tracking.metrics import (
    SUCCESS_THRESHOLDS,
    auc,
    center_error,
    iou,
    precision,
    success_curve,
)


def test_iou_hand_computed():
    # Two 2x2 boxes overlapping in a 1x2 strip: 2 / (4 + 4 - 2) = 1/3.
    assert iou([0, 0, 2, 2], [1, 0, 2, 2])[0] == pytest.approx(1 / 3)
    # Identical boxes, disjoint boxes, touching boxes, containment 1x1 in 2x2.
    got = iou(
        [[5, 5, 3, 4], [0, 0, 1, 1], [0, 0, 1, 1], [0, 0, 2, 2]],
        [[5, 5, 3, 4], [3, 3, 1, 1], [1, 0, 1, 1], [0.5, 0.5, 1, 1]],
    )
    np.testing.assert_allclose(got, [1.0, 0.0, 0.0, 0.25])


def test_lost_or_degenerate_boxes_score_zero():
    got = iou(
        [[0, 0, 0, 0], [0, 0, np.nan, 1], [0, 0, 2, 2]], [[0, 0, 2, 2], [0, 0, 2, 2], [0, 0, -1, 2]]
    )
    np.testing.assert_array_equal(got, [0.0, 0.0, 0.0])


def test_success_curve_and_auc_by_hand():
    overlaps = np.array([0.0, 0.5, 1.0, 0.26])
    curve = success_curve(overlaps)
    assert len(SUCCESS_THRESHOLDS) == 21
    # threshold 0: three overlaps are > 0; threshold 0.25: 0.5, 1.0, 0.26; 0.5: only 1.0
    assert curve[0] == 0.75 and curve[5] == 0.75 and curve[10] == 0.25 and curve[20] == 0.0
    # AUC = mean over the 21 thresholds, counted by hand:
    # 0.26 exceeds the thresholds 0..0.25 (6 of them), 0.5 exceeds 0..0.45 (10),
    # 1.0 exceeds 0..0.95 (20), 0.0 exceeds none.
    assert auc(overlaps) == pytest.approx((6 + 10 + 20) / (21 * 4))


def test_precision_by_hand():
    truth = np.array([[0, 0, 10, 10]] * 3, dtype=float)
    pred = np.array([[3, 4, 10, 10], [12, 16, 10, 10], [30, 0, 10, 10]], dtype=float)
    np.testing.assert_allclose(center_error(pred, truth), [5.0, 20.0, 30.0])
    assert precision(pred, truth) == pytest.approx(2 / 3)  # 20 px counts as a hit
    assert precision(pred, truth, threshold=4.9) == 0.0


def test_bad_shapes_raise():
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        iou([[0, 0, 1]], [[0, 0, 1]])
    with pytest.raises(ValueError, match="as many boxes"):
        iou(np.zeros((2, 4)), np.zeros((3, 4)))
    # One box against five is not broadcast (it used to return 1.0 silently).
    with pytest.raises(ValueError, match="as many boxes"):
        iou(np.zeros((1, 4)) + 1, np.ones((5, 4)))
