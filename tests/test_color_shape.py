"""The colour+shape tracker (seed 000 section 3.3) and its experiment sequences."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from rperc import RpercError
from rperc.tracking import ColorShapeTracker
from rperc.tracking.metrics import mask_iou, polygon_mask
from rperc.tracking.shape_sequences import EXPERIMENTS, shape_sequence


def test_polygon_mask_matches_shapely_point_in_polygon() -> None:
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 2 * np.pi, 12))
    r = rng.uniform(6, 14, 12)
    poly = np.stack([20 + r * np.cos(t), 15 + r * np.sin(t)], axis=1)
    mask = polygon_mask(poly, (30, 40))
    shape = shapely.Polygon(poly)
    yy, xx = np.mgrid[0:30, 0:40]
    # Oracle: shapely's point-in-polygon, pixel centre by pixel centre, away from the
    # boundary where the two may break ties differently.
    inside = shapely.contains_xy(shape, xx.ravel(), yy.ravel()).reshape(30, 40)
    far = shapely.distance(shape.exterior, shapely.points(xx.ravel(), yy.ravel())) > 1e-9
    far = far.reshape(30, 40)
    assert np.array_equal(mask[far], inside[far])


def test_mask_iou_matches_shapely_areas_for_rasterised_squares() -> None:
    a = np.zeros((20, 20), bool)
    b = np.zeros((20, 20), bool)
    a[2:10, 2:12] = True
    b[5:15, 6:16] = True
    # Pixel j covers [j, j + 1): the masks are unions of unit squares.
    sa, sb = shapely.box(2, 2, 12, 10), shapely.box(6, 5, 16, 15)
    want = sa.intersection(sb).area / sa.union(sb).area
    assert mask_iou(a, b) == pytest.approx(want, abs=1e-12)
    with pytest.raises(ValueError, match="shape"):
        mask_iou(a, b[:5])


@pytest.mark.parametrize("name", EXPERIMENTS)
def test_sequences_are_seeded_and_masks_match_outline(name: str) -> None:
    s1 = shape_sequence(name, frames=3, seed=4)
    s2 = shape_sequence(name, frames=3, seed=4)
    assert np.array_equal(s1.frames, s2.frames)
    first = polygon_mask(s1.outline, s1.masks.shape[1:])
    # The outline is the truth of frame 0, up to rasterisation along the boundary.
    assert mask_iou(first, s1.masks[0]) > 0.85


def test_tracks_a_deforming_blob_with_its_contour() -> None:
    seq = shape_sequence("nonrigid", frames=25, seed=11)
    tracker = ColorShapeTracker(seq.frames[0], contour=seq.outline, color_space="opponent")
    ious = []
    for k in range(1, len(seq)):
        r = tracker.update(seq.frames[k])
        assert r.contour.shape == (48, 2)
        ious.append(mask_iou(polygon_mask(r.contour, seq.masks.shape[1:]), seq.masks[k]))
    # The target is an affine snake on a non-affine outline: most of it, not all.
    assert min(ious) > 0.75, ious


def test_same_seed_same_track() -> None:
    seq = shape_sequence("rectangle", frames=6, seed=2)
    runs = []
    for _ in range(2):
        t = ColorShapeTracker(seq.frames[0], contour=seq.outline, seed=9)
        runs.append([t.update(f).contour for f in seq.frames[1:]])
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a, b)


def test_bad_input_is_refused_clearly() -> None:
    frame = np.zeros((40, 50, 3), np.uint8)
    with pytest.raises(ValueError, match="box"):
        ColorShapeTracker(frame)
    with pytest.raises(ValueError, match="contour"):
        ColorShapeTracker(frame, contour=np.zeros((4, 3)))
    with pytest.raises((ValueError, RpercError), match="color_space"):
        ColorShapeTracker(frame, (5, 5, 10, 10), color_space="hsv")  # type: ignore[arg-type]
    t = ColorShapeTracker(frame, (5, 5, 10, 10))
    with pytest.raises((ValueError, RpercError), match="frame size"):
        t.update(np.zeros((41, 50, 3), np.uint8))
