"""rperc.tracking: resamplers against filterpy, the trackers' Python contract, and
the colour trackers scored on real OTB video against OpenCV's CamShift."""

from __future__ import annotations

import numpy as np
import pytest

from rperc.datasets import load_otb
from rperc.tracking import (
    ColorHistogramTracker,
    ParticleColorTracker,
    effective_sample_size,
    metrics,
    resample,
)

WEIGHTS = np.array([0.05, 0.3, 0.0, 0.15, 0.4, 0.1])


def mean_counts(draw, reps: int) -> np.ndarray:
    return np.mean([np.bincount(draw(s) % len(WEIGHTS), minlength=6) for s in range(reps)], axis=0)


@pytest.mark.parametrize("method", ["multinomial", "systematic", "stratified", "residual"])
def test_resamplers_have_the_expected_counts(method):
    """Mean counts over seeded draws equal N w, within 4.5 standard errors of the
    multinomial's (the largest) variance N w (1 - w) / reps."""
    n, reps = 48, 400
    ours = mean_counts(lambda s: resample(WEIGHTS, n, method, seed=s), reps)
    expected = n * WEIGHTS
    se = np.sqrt(n * WEIGHTS * (1 - WEIGHTS) / reps)
    assert np.all(np.abs(ours - expected) <= 4.5 * se + 1e-12), (ours, expected)
    assert ours[2] == 0  # a zero weight is never drawn
    if method in ("systematic", "residual"):  # floor(N w) copies are guaranteed
        counts = np.bincount(resample(WEIGHTS, n, method, seed=3), minlength=6)
        assert np.all(counts >= np.floor(expected))
    if method == "systematic":
        assert np.all(counts <= np.ceil(expected))


@pytest.mark.parametrize("method", ["multinomial", "systematic", "stratified"])
def test_resamplers_agree_with_filterpy(method):
    """filterpy draws as many particles as weights: 8 copies of each weight (w / 8)
    give 48 particles whose index modulo 6 has the same expected counts as ours.
    (filterpy's residual_resample subtracts the copies from w instead of N w, so its
    residual draws are wrong; it is left out.)"""
    resampling = pytest.importorskip("filterpy.monte_carlo")
    n, reps = 48, 400
    tiled = np.tile(WEIGHTS, 8) / 8
    state = np.random.get_state()
    np.random.seed(1)
    theirs = mean_counts(lambda _: getattr(resampling, f"{method}_resample")(tiled), reps)
    np.random.set_state(state)
    ours = mean_counts(lambda s: resample(WEIGHTS, n, method, seed=s), reps)
    se = np.sqrt(n * WEIGHTS * (1 - WEIGHTS) / reps)
    assert np.all(np.abs(ours - theirs) <= 4.5 * np.sqrt(2) * se + 1e-12), (ours, theirs)


def test_effective_sample_size_and_bad_weights():
    assert effective_sample_size(np.full(10, 0.1)) == pytest.approx(10.0)
    assert effective_sample_size(np.array([1.0, 0.0, 0.0])) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        resample(np.array([0.5, np.nan]), 4)
    with pytest.raises(ValueError, match="resampler"):
        resample(WEIGHTS, 4, "magic")


def synthetic_frames(count: int = 12) -> tuple[list[np.ndarray], list[tuple[float, ...]]]:
    """A red disc moving right over a textured background, with its true boxes."""
    rng = np.random.default_rng(0)
    background = rng.integers(0, 120, size=(96, 128, 3), dtype=np.uint8)
    yy, xx = np.mgrid[0:96, 0:128]
    frames, boxes = [], []
    for k in range(count):
        cx, cy = 30 + 3 * k, 48
        f = background.copy()
        f[(xx - cx) ** 2 + (yy - cy) ** 2 <= 10**2] = (230, 40, 40)
        frames.append(f)
        boxes.append((cx - 10.0, cy - 10.0, 20.0, 20.0))
    return frames, boxes


@pytest.mark.parametrize("cls", [ColorHistogramTracker, ParticleColorTracker])
def test_trackers_follow_a_known_track(cls):
    frames, boxes = synthetic_frames()
    t = cls(frames[0], boxes[0])
    for f, b in zip(frames[1:], boxes[1:], strict=True):
        box, score, lost = t.update(f)
        assert not lost and 0.0 <= score <= 1.0
        assert metrics.center_error(box, b)[0] < 4.0


def test_strided_frames_give_the_same_track():
    frames, boxes = synthetic_frames(6)
    a = ColorHistogramTracker(frames[0], boxes[0])
    wide = []
    for f in frames:  # strided views holding the same pixels
        big = np.zeros((f.shape[0], 2 * f.shape[1], 3), np.uint8)
        big[:, ::2] = f
        wide.append(big[:, ::2])
    assert not wide[0].flags.c_contiguous
    b = ColorHistogramTracker(wide[0], boxes[0])
    for fa, fb in zip(frames[1:], wide[1:], strict=True):
        assert a.update(fa) == b.update(fb)
    a2 = ColorHistogramTracker(frames[0], boxes[0])
    b2 = ColorHistogramTracker(frames[0][:, :, :].copy(order="F"), boxes[0])
    for f in frames[1:]:
        assert a2.update(f) == b2.update(np.asfortranarray(f))


def test_bad_frames_boxes_and_parameters_raise():
    frames, boxes = synthetic_frames(2)
    f = frames[0]
    with pytest.raises(TypeError, match="uint8"):
        ColorHistogramTracker(f.astype(np.float32), boxes[0])
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        ColorHistogramTracker(np.zeros((96, 128, 4), np.uint8), boxes[0])
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        ColorHistogramTracker(np.zeros((96,), np.uint8), boxes[0])
    with pytest.raises(ValueError):
        ColorHistogramTracker(f, (500.0, 10.0, 20.0, 20.0))  # outside the frame
    with pytest.raises(ValueError):
        ColorHistogramTracker(f, (10.0, 10.0, 0.0, 20.0))  # empty box
    with pytest.raises(TypeError, match="color_histogram: serch_radius: Unknown field"):
        ColorHistogramTracker(f, boxes[0], serch_radius=5)  # type: ignore[call-arg]
    with pytest.raises(ValueError, match="color_space"):
        ColorHistogramTracker(f, boxes[0], appearance={"color_space": "lab"})  # type: ignore[typeddict-item]
    with pytest.raises(ValueError, match="n_particles"):
        ParticleColorTracker(f, boxes[0], n_particles=0)
    t = ColorHistogramTracker(f, boxes[0])
    with pytest.raises(ValueError, match="size changed"):
        t.update(np.zeros((50, 50, 3), np.uint8))


@pytest.fixture(scope="module")
def otb(data):
    out = {}
    for name in ("Girl", "Couple"):
        seq = load_otb(data / "otb" / name)
        out[name] = (seq, [seq.frame(k) for k in range(len(seq))])
    return out


def run_tracker(make, seq, frames) -> np.ndarray:
    first = tuple(float(v) for v in seq.boxes[0])
    t = make(frames[0], first)
    boxes = [first] + [t.update(f).box for f in frames[1:]]
    return metrics.iou(np.asarray(boxes), seq.boxes)


def test_colour_trackers_beat_camshift_on_girl_and_couple(otb):
    """The issue's target: AUC >= 0.45 on Girl and Couple together (all frames
    pooled), clearly above OpenCV's CamShift on the same frames."""
    ours = {
        "local search": lambda f, b: ColorHistogramTracker(f, b),
        "particles": lambda f, b: ParticleColorTracker(f, b, seed=0),
    }
    for name, make in ours.items():
        overlaps = np.concatenate([run_tracker(make, *otb[s]) for s in ("Girl", "Couple")])
        assert metrics.auc(overlaps) >= 0.45, name
    cv2 = pytest.importorskip("cv2")

    def camshift(seq, frames):
        x, y, w, h = (round(v) for v in seq.boxes[0])
        hsv = cv2.cvtColor(frames[0], cv2.COLOR_RGB2HSV)
        roi = hsv[y : y + h, x : x + w]
        mask = cv2.inRange(roi, np.array((0.0, 60.0, 32.0)), np.array((180.0, 255.0, 255.0)))
        hist = cv2.calcHist([roi], [0], mask, [16], [0, 180])
        cv2.normalize(hist, hist, 0, 255, cv2.NORM_MINMAX)
        win, boxes = (x, y, w, h), [tuple(seq.boxes[0])]
        for f in frames[1:]:
            back = cv2.calcBackProject([cv2.cvtColor(f, cv2.COLOR_RGB2HSV)], [0], hist, [0, 180], 1)
            _, new = cv2.CamShift(
                back, win, (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1)
            )
            win = new if new[2] > 0 and new[3] > 0 else win
            boxes.append(tuple(float(v) for v in win))
        return metrics.iou(np.asarray(boxes), seq.boxes)

    theirs = metrics.auc(np.concatenate([camshift(*otb[s]) for s in ("Girl", "Couple")]))
    mine = metrics.auc(
        np.concatenate([run_tracker(ours["local search"], *otb[s]) for s in ("Girl", "Couple")])
    )
    assert mine > theirs + 0.2


def test_config_errors_name_the_field():
    """The generic keyword path names the field, nested ones included, and tells a
    wrong type or unknown field (TypeError) from a bad value (ValueError)."""
    from rperc import _rperc

    frame = np.full((60, 80, 3), 90, np.uint8)
    box = [22.0, 22.0, 16.0, 16.0]
    cases = [
        ({"search_radius": -1}, ValueError, "search_radius"),
        ({"appearance": {"bins": [8, 8]}}, ValueError, r"appearance\.bins"),
        ({"appearance": {"color_space": "lab"}}, ValueError, r"appearance\.color_space.*'hsv'"),
        ({"serch_radius": 3}, TypeError, "serch_radius"),
        ({"search_radius": "x"}, TypeError, "search_radius"),
    ]
    for config, exc, message in cases:
        with pytest.raises(exc, match=message):
            _rperc.ColorHistogramTracker(frame, box, config)
    with pytest.raises(ValueError, match=r"filter\.resampler"):
        _rperc.ParticleColorTracker(frame, box, 0, {"filter": {"resampler": "magic"}})
    # Non-finite values survive the path (max_range may be infinite) and reach validate().
    with pytest.raises(ValueError, match="sigma_range"):
        _rperc.extract_lines(np.ones(5), np.linspace(0, 0.1, 5), {"sigma_range": np.nan})


@pytest.mark.parametrize("method", ["multinomial", "systematic", "stratified", "residual"])
def test_weights_near_the_largest_float_resample_like_their_scaled_down_copy(method):
    # Issue 38: weights of 1e308 overflowed the sum and every particle went to the last
    # index. Scaling the weights changes nothing (same seed, same draws).
    huge = WEIGHTS / WEIGHTS.max() * np.finfo(float).max
    want = resample(WEIGHTS, 600, method, seed=4)
    assert np.array_equal(resample(huge, 600, method, seed=4), want)
    # Equal weights: systematic resampling keeps each particle once.
    assert len(set(resample(np.full(10, 1e308), 10, "systematic", seed=4).tolist())) == 10
    assert effective_sample_size(huge) == pytest.approx(effective_sample_size(WEIGHTS))


def test_the_histogram_trackers_take_a_config_and_typed_overrides():
    # Issue 36: one config path; the old flat keywords of the appearance and filter
    # parts still work, with a DeprecationWarning naming where each field lives now,
    # and keep the part's other fields.
    from rperc.config import AppearanceParams, ColorHistogramConfig, ParticleColorConfig

    frames, boxes = synthetic_frames(3)
    with pytest.warns(DeprecationWarning, match=r"color_space= -> appearance\.color_space"):
        old = ColorHistogramTracker(frames[0], boxes[0], color_space="rgb", search_radius=5)  # type: ignore[call-arg]
    typed = ColorHistogramConfig(search_radius=5, appearance=AppearanceParams(color_space="rgb"))
    new = ColorHistogramTracker(frames[0], boxes[0], config=typed)
    plain = ColorHistogramTracker(
        frames[0], boxes[0], config={"appearance": {"color_space": "rgb"}}, search_radius=5
    )
    assert old.config == new.config == plain.config == typed
    for f in frames[1:]:
        assert old.update(f) == new.update(f) == plain.update(f)
    with pytest.warns(DeprecationWarning, match=r"resampler= -> filter\.resampler"):
        pf = ParticleColorTracker(frames[0], boxes[0], resampler="residual", bins=(8, 8, 8))  # type: ignore[call-arg]
    base = ParticleColorConfig()
    assert pf.config == base.replace(
        appearance=base.appearance.replace(bins=(8, 8, 8)),
        filter=base.filter.replace(resampler="residual"),
    )


def test_a_deprecated_tracker_keyword_is_reported_at_the_callers_line():
    # The warning names the line that passed the old keyword, not a line of rperc's
    # (the config helper sits between the constructor and the warning).
    frames, boxes = synthetic_frames(2)
    with pytest.warns(DeprecationWarning) as caught:
        ColorHistogramTracker(frames[0], boxes[0], color_space="rgb")  # type: ignore[call-arg]
    assert [w.filename for w in caught] == [__file__]
