"""The colour+shape and pattern trackers under fuzzing (issue 38): hostile contours
(off the frame, at 1e300, degenerate), boxes and every config field at and beyond its
limits. Each example gives a clear error naming the parameter, or an answer that passes
its own check: finite, a box inside the frame, a score in [0, 1]."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc import _rperc
from rperc.tracking import ColorShapeTracker, PatternTracker

from fuzz.harness import case, config_fields, examples, nested_config, outcome
from fuzz.strategies import EDGE_NUMBERS

HEIGHT, WIDTH = 48, 64
# Sizes far beyond any limit: 10**9 aborted the process or hung before issue 38.
SIZES = st.sampled_from([0, 1, 7, 8, 64, 65, 10**4, 10**9, 2**62])
FIELD_VALUES = st.one_of(EDGE_NUMBERS, SIZES, st.just([1, 2, 3]), st.just("x"))


def _target_frame() -> np.ndarray:
    """A red square on grey, with an edge texture the pattern tracker can hold."""
    frame = np.full((HEIGHT, WIDTH, 3), 90, np.uint8)
    frame[14:34, 20:44] = (200, 40, 40)
    frame[20:26, 26:34] = (30, 30, 30)
    return frame


SHAPE_FIELDS = sorted(config_fields(_rperc.config_defaults("color_shape")))
PATTERN_FIELDS = sorted(config_fields(_rperc.config_defaults("pattern")))

CONTOURS = st.one_of(
    st.lists(st.tuples(st.floats(-20, 90), st.floats(-20, 70)), min_size=0, max_size=7),
    st.builds(
        lambda shift, scale: (
            np.array([[20, 14], [43, 14], [43, 33], [20, 33.0]]) * scale + shift
        ).tolist(),
        st.sampled_from([0.0, 64.0, -64.0, 1e300, -1e300, np.nan, np.inf]),
        st.sampled_from([1.0, 0.0, 1e-300, 1e300]),
    ),
)


def _check_shape_answer(tracker: ColorShapeTracker) -> None:
    ok, got = outcome(tracker.update, np.roll(_target_frame(), 2, axis=1))
    if not ok:
        return
    x, y, w, h = got.box
    assert np.isfinite(got.contour).all() and np.isfinite(got.box).all(), got
    # The box is the part of the contour in view, whatever the contour does.
    assert 0 <= x and 0 <= y and x + w <= WIDTH and y + h <= HEIGHT, got.box
    assert 0.0 <= got.score <= 1.0, got


@examples(60)
@given(CONTOURS)
def prop_color_shape_contours(contour):
    case("ColorShapeTracker", contour=contour)
    ok, tracker = outcome(ColorShapeTracker, _target_frame(), contour=np.asarray(contour))
    if not ok:
        assert "contour" in str(tracker), tracker
        return
    _check_shape_answer(tracker)


@examples(80)
@given(st.sampled_from(SHAPE_FIELDS), FIELD_VALUES)
def prop_color_shape_config_fields(field, value):
    config = nested_config(field, value)
    case("ColorShapeTracker", box=(20, 14, 24, 20), config=config)
    ok, tracker = outcome(ColorShapeTracker, _target_frame(), (20, 14, 24, 20), config=config)
    if not ok:
        assert field.split(".")[-1] in str(tracker), f"{field}={value!r}: {tracker}"
        return
    _check_shape_answer(tracker)


@examples(80)
@given(st.sampled_from(PATTERN_FIELDS), FIELD_VALUES)
def prop_pattern_config_fields(field, value):
    """Every field of the pattern tracker's config, through the native constructor
    (the typed wrapper's keywords reach the same config)."""
    config = _rperc.config_defaults("pattern")
    node = config
    *parents, leaf = field.split(".")
    for p in parents:
        node = node[p]
    node[leaf] = value
    grey = _target_frame()[:, :, 0].copy()
    case("PatternTracker", region=(18, 12, 28, 24), config=config)
    ok, tracker = outcome(_rperc.PatternTracker, grey, (18, 12, 28, 24), 1, config)
    if not ok:
        # A pair is refused by either name (canny_high=0 is below canny_low); a
        # valid setting may leave the region without usable points.
        names = (leaf, leaf.rsplit("_", 1)[0], "region")
        assert any(n in str(tracker) for n in names), f"{field}={value!r}: {tracker}"
        return
    ok, pose = outcome(tracker.update, np.roll(grey, 2, axis=1))
    if ok:
        assert np.isfinite([pose.x, pose.y, pose.theta, pose.scale]).all(), pose


@examples(60)
@given(
    st.one_of(st.tuples(*[st.integers(-70, 90)] * 4), st.lists(EDGE_NUMBERS, max_size=5)),
    st.one_of(st.integers(0, 2**64 - 1), EDGE_NUMBERS),
    st.one_of(st.lists(st.floats(-1, 10), min_size=4, max_size=4), EDGE_NUMBERS, st.just("abc")),
)
def prop_pattern_regions_seeds_and_sigmas(region, seed, sigma):
    grey = _target_frame()[:, :, 0].copy()
    case("PatternTracker", region=region, seed=seed, sigma=sigma)
    ok, tracker = outcome(PatternTracker, grey, region, seed=seed, sigma=sigma)
    if not ok:
        assert any(n in str(tracker) for n in ("region", "seed", "sigma")), tracker
        return
    ok, pose = outcome(tracker.update, np.roll(grey, 1, axis=0))
    if ok:
        assert np.isfinite([pose.x, pose.y, pose.theta, pose.scale]).all(), pose
        assert 0.0 <= pose.score <= 1.0, pose
