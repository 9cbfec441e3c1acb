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


@pytest.mark.parametrize("centre", [(20, 15), (-4, 15), (38, 33), (-40, -40)])
def test_polygon_mask_of_a_polygon_partly_or_wholly_outside_the_frame(centre) -> None:
    """The mask tests only the centres in the polygon's bounding box: one that leaves the
    frame, or lies wholly outside it, must still match shapely everywhere."""
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0, 2 * np.pi, 15))
    r = rng.uniform(5, 16, 15)
    poly = np.stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)], axis=1)
    mask = polygon_mask(poly, (30, 40))
    yy, xx = np.mgrid[0:30, 0:40]
    shape = shapely.Polygon(poly)
    inside = shapely.contains_xy(shape, xx.ravel(), yy.ravel()).reshape(30, 40)
    far = shapely.distance(shape.exterior, shapely.points(xx.ravel(), yy.ravel())) > 1e-9
    assert np.array_equal(mask[far.reshape(30, 40)], inside[far.reshape(30, 40)])
    with pytest.raises(ValueError, match="non-finite"):
        polygon_mask(np.where(np.arange(15)[:, None] == 3, np.nan, poly), (30, 40))


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


_SQUARE = np.array([[10.0, 8.0], [30.0, 8.0], [30.0, 28.0], [10.0, 28.0]])


@pytest.mark.parametrize(
    "shift",
    [(1000.0, 0.0), (0.0, 1000.0), (-1000.0, 0.0), (40.0, 0.0), (1e300, 1e300)],
    ids=["right", "below", "left", "just-off", "1e300"],
)
def test_a_contour_off_the_frame_is_a_value_error_not_a_panic(shift: tuple[float, float]) -> None:
    # Issue 38: a contour right of or below the frame panicked (an RpercError "internal
    # error"), and one at 1e300 came back as a box of 1e300. The rule is the box's.
    frame = np.zeros((40, 50, 3), np.uint8)
    with pytest.raises(ValueError, match=r"contour.*not inside the 50x40 frame") as info:
        ColorShapeTracker(frame, contour=_SQUARE + np.array(shift))
    assert "internal error" not in str(info.value)


def test_a_contour_inside_the_frame_still_starts_the_tracker() -> None:
    frame = np.zeros((40, 50, 3), np.uint8)
    frame[8:29, 10:31] = (200, 40, 40)
    t = ColorShapeTracker(frame, contour=_SQUARE, seed=1)
    x, y, w, h = t.update(frame).box
    assert 8 <= x <= 12 and 6 <= y <= 10 and 16 <= w <= 24 and 16 <= h <= 24


def test_a_target_leaving_the_frame_gets_the_box_of_its_part_in_view() -> None:
    # Issue 38: the snake carried contour points past the frame's edge and the box
    # with them (2.3 px outside in a long fuzz run); the box is the part in view.
    width, height = 50, 40
    boxes = []
    for step in range(12):
        frame = np.full((height, width, 3), 90, np.uint8)
        x0 = 24 + 3 * step
        frame[10:30, x0 : x0 + 20] = (200, 40, 40)
        if step == 0:
            tracker = ColorShapeTracker(frame, (x0, 10, 20, 20), seed=3)
            continue
        x, y, w, h = tracker.update(frame).box
        assert 0 <= x and 0 <= y and x + w <= width and y + h <= height, (step, x, y, w, h)
        boxes.append((x0, x, w))
    # While the square is half out, the box still ends at the frame's right edge.
    x0, x, w = boxes[3]
    assert x + w == pytest.approx(width, abs=1.5) and x == pytest.approx(x0, abs=2.5)


@pytest.mark.parametrize(
    "field", ["contour_points", "snake_iterations", "deform_passes", "deform", "cloud_points"]
)
def test_every_size_in_the_config_has_a_named_upper_bound(field: str) -> None:
    # contour_points = 10**9 aborted the process (SIGABRT); the iteration counts hung.
    frame = np.zeros((40, 50, 3), np.uint8)
    for start in ({"box": (10, 8, 20, 20)}, {"contour": _SQUARE}):
        with pytest.raises(ValueError, match=f"'{field}': must be in"):
            ColorShapeTracker(frame, config={field: 10**9}, **start)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        # The Rust config's reader, through rperc.config.ColorShapeConfig: the type is
        # wrong, so a TypeError naming the config and the field.
        ({"seed": None}, r"^color_shape: seed: Invalid type Option value\. Expected u64"),
        ({"sigma": "abc"}, r"^color_shape: sigma: Invalid type string \"abc\"\. Expected f64"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, message):
    frame = np.zeros((40, 50, 3), np.uint8)
    with pytest.raises(TypeError, match=message):
        ColorShapeTracker(frame, (10, 8, 20, 20), **kwargs)


@pytest.mark.parametrize("canny", [[0.0, 50.0], [0.0, 0.0]])
def test_a_zero_canny_threshold_refines_instead_of_panicking(canny: list[float]) -> None:
    # Issue 38: canny = [0, 50] panicked in the edge refinement (imageproc's hysteresis
    # followed the zero-strength border off the image). The check: the red square
    # standing still keeps its box.
    frame = np.zeros((40, 50, 3), np.uint8)
    frame[8:29, 10:31] = (200, 40, 40)
    t = ColorShapeTracker(frame, contour=_SQUARE, seed=1, config={"canny": canny})
    for _ in range(2):
        x, y, w, h = t.update(frame).box
    assert 8 <= x <= 12 and 6 <= y <= 10 and 16 <= w <= 24 and 16 <= h <= 24


def test_the_tracker_keeps_the_config_it_was_given_with_its_overrides() -> None:
    from rperc.config import ColorShapeConfig

    frame = np.full((60, 80, 3), 90, np.uint8)
    frame[14:34, 20:44] = (200, 40, 40)
    t = ColorShapeTracker(frame, (20, 14, 24, 20), config={"n_samples": 40}, seed=9)
    assert t.config == ColorShapeConfig(n_samples=40, seed=9)
