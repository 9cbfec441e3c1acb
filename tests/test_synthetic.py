"""rperc.tracking.synthetic: the generated sequence is reproducible and its boxes are
the true extent of the target drawn in each frame."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rperc.tracking.synthetic import LOWER_COLOUR, synthetic_sequence


def target_mask(seq, k: int) -> np.ndarray:
    """Pixels of frame k that differ from the lit background (noise-free sequences)."""
    lit = np.clip(np.rint(seq.illumination[k] * seq.background.astype(float)), 0, 255)
    return (seq.frames[k] != lit.astype(np.uint8)).any(axis=2)


@settings(max_examples=20)
@given(st.integers(0, 2**32 - 1))
def test_boxes_are_the_extent_of_the_drawn_target(seed):
    """Without the distractor discs (target-coloured background), every pixel that
    differs from the lit background is the target's."""
    seq = synthetic_sequence(30, noise=0.0, distractors=False, seed=seed)
    for k in range(len(seq)):
        rows, cols = np.nonzero(target_mask(seq, k))
        x, y, w, h = seq.boxes[k]
        # Pixel j spans [j, j + 1): the drawn extent is within one pixel of the box.
        assert abs(cols.min() - x) <= 1 and abs(cols.max() + 1 - (x + w)) <= 1
        assert abs(rows.min() - y) <= 1 and abs(rows.max() + 1 - (y + h)) <= 1
        # An ellipse fills pi / 4 of its box (up to the pixels on its rim).
        assert len(rows) == pytest.approx(np.pi / 4 * w * h, abs=2 * (w + h))


def test_distractors_change_the_background_but_not_the_truth():
    plain = synthetic_sequence(20, distractors=False, seed=4)
    busy = synthetic_sequence(20, seed=4)
    np.testing.assert_array_equal(plain.boxes, busy.boxes)
    discs = (busy.background == LOWER_COLOUR).all(axis=2) & (plain.background != LOWER_COLOUR).any(
        axis=2
    )
    assert 2 * 150 < discs.sum() < 2 * np.pi * 15**2  # two discs of radius 0.35 * 40 = 14 px


def test_same_seed_same_sequence_and_the_target_stays_inside():
    a, b = synthetic_sequence(40, seed=5), synthetic_sequence(40, seed=5)
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.boxes, b.boxes)
    c = synthetic_sequence(40, seed=6)
    assert not np.array_equal(a.boxes, c.boxes)
    assert a.frames.dtype == np.uint8 and a.frames.shape == (40, 240, 320, 3)
    x, y, w, h = a.boxes.T
    assert (x >= 0).all() and (y >= 0).all() and (x + w <= 320).all() and (y + h <= 240).all()
    centre = a.boxes[:, :2] + a.boxes[:, 2:] / 2
    # The speed does not grow for short sequences: trackers search about 10 px.
    for seq in (a, synthetic_sequence(3, seed=5)):
        centre = seq.boxes[:, :2] + seq.boxes[:, 2:] / 2
        assert np.hypot(*np.diff(centre, axis=0).T).max() < 8.0


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"frames": 1}, "frames"),
        ({"frames": 2.5}, "frames"),
        ({"seed": -1}, "seed"),
        ({"noise": -1.0}, "noise"),
        ({"noise": float("nan")}, "noise"),
        ({"target": (300, 40)}, "target"),
        ({"width": 8}, "width"),
    ],
)
def test_bad_parameters_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        synthetic_sequence(**kwargs)
