"""The colour trackers on the difficulties of issue 14, part 2, against the truth of
seeded synthetic sequences (never against our own output), and the API as a new user
tries it: box types, boxes overhanging the frame, greyscale and BGR frames, black
frames, OpenCV's tracker protocol (checked by running OpenCV's own trackers through
the same code)."""

from __future__ import annotations

import numpy as np
import pytest

from rperc.tracking import ColorHistogramTracker, ParticleColorTracker, metrics, opencv

from challenges import CHALLENGES, challenge_sequence

H, W = 120, 240


def textured(seed: int = 0) -> np.ndarray:
    """Blue-green-grey blocky texture, away from the red target's colours."""
    rng = np.random.default_rng(seed)
    blocks = rng.integers(20, 140, size=(H // 4, W // 4, 3))
    blocks[..., 0] //= 3  # little red
    return np.kron(blocks, np.ones((4, 4, 1))).astype(np.uint8)


def with_disc(background: np.ndarray, cx: float, cy: float, r: float = 9.0) -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W] + 0.5
    f = background.copy()
    f[(xx - cx) ** 2 + (yy - cy) ** 2 <= r * r] = (230, 40, 40)
    return f


def disc_box(cx: float, cy: float, r: float = 9.0) -> tuple[float, float, float, float]:
    return (cx - r, cy - r, 2 * r, 2 * r)


def centre(box) -> np.ndarray:
    return np.array([box[0] + box[2] / 2, box[1] + box[3] / 2])


# --- search radius and fast motion ------------------------------------------------


def fast_track(**params) -> tuple[list[float], list[int]]:
    """A disc speeding up to 24 px per frame: centre errors and search radii."""
    bg = textured()
    xs = list(np.cumsum([14.0, 3, 6, 10, 14, 18, 22, 24, 24]))
    t = ColorHistogramTracker(with_disc(bg, xs[0], 60), disc_box(xs[0], 60), **params)
    errors, radii = [], []
    for x in xs[1:]:
        r = t.update(with_disc(bg, x, 60))
        errors.append(float(np.hypot(*(centre(r.box) - (x, 60)))))
        radii.append(t.search_radius)
    return errors, radii


def test_the_search_radius_follows_the_speed_and_fast_motion_is_tracked():
    errors, radii = fast_track()
    assert max(errors) <= 2.0, errors
    # Still target: radius 10; after moves of 24 px it has grown past 24.
    assert radii[-1] > 24, radii
    # The same tracker with a fixed +-10 px window loses it (so the test can fail);
    # without the pyramid, whose refinement reaches a pixel or two past the window.
    fixed, _ = fast_track(velocity_gain=0.0, max_search_radius=10, lost_ratio=0.0, pyramid=False)
    assert max(fixed) > 9.0, fixed


def test_a_still_target_keeps_the_base_radius():
    bg = textured()
    t = ColorHistogramTracker(with_disc(bg, 60, 60), disc_box(60, 60))
    for _ in range(3):
        t.update(with_disc(bg, 60, 60))
    assert t.search_radius == 10


# --- lost flag ---------------------------------------------------------------------


def test_lost_fires_while_the_target_is_gone_and_it_is_found_again_far_away():
    """Frames 4-8 have no target; it comes back 50 px from where it vanished. Lost must
    be set on exactly the frames without it (precision and recall 1), the box must stay
    put meanwhile, and the widening search must find it again."""
    bg = textured(1)
    t = ColorHistogramTracker(with_disc(bg, 50, 60), disc_box(50, 60))
    present = [True] * 4 + [False] * 5 + [True] * 6
    lost, boxes = [], []
    for k, here in enumerate(present):
        cx = 50.0 if k < 4 else 100.0
        r = t.update(with_disc(bg, cx, 60) if here else bg)
        lost.append(r.lost)
        boxes.append(r.box)
    gone = ~np.asarray(present)
    lost_arr = np.asarray(lost)
    assert np.all(lost_arr[gone]), lost  # recall
    assert not np.any(lost_arr[:4]), lost  # no false alarm while it is there
    for k in range(4, 9):
        assert boxes[k] == boxes[3]  # the box stays where it was last seen
    found = [metrics.iou(np.array([b]), np.array([disc_box(100, 60)]))[0] for b in boxes[9:]]
    assert found[-1] > 0.7 and not lost_arr[-1], (found, lost)


def test_an_all_black_frame_is_lost_and_keeps_the_box():
    bg = textured(2)
    for kind in (ColorHistogramTracker, ParticleColorTracker):
        t = kind(with_disc(bg, 80, 60), disc_box(80, 60))
        before = t.update(with_disc(bg, 82, 60))
        r = t.update(np.zeros((H, W, 3), np.uint8))
        assert r.lost, kind
        np.testing.assert_allclose(r.box, before.box, atol=1e-9, err_msg=kind.__name__)
        after = t.update(with_disc(bg, 84, 60))
        assert np.hypot(*(centre(after.box) - (84, 60))) < 3.0, (kind, after)


def lost_precision_recall(kind: str, seed: int) -> tuple[int, int, int]:
    seq = challenge_sequence(kind, frames=90, seed=seed)  # type: ignore[arg-type]
    t = ColorHistogramTracker(seq.frames[0], seq.boxes[0])
    results = [t.update(f) for f in seq.frames[1:]]
    boxes = np.array([r.box for r in results])
    zero = metrics.iou(boxes, seq.boxes[1:]) == 0
    lost = np.array([r.lost for r in results])
    return int((lost & zero).sum()), int(lost.sum()), int(zero.sum())


def test_lost_has_full_recall_of_the_frames_with_no_overlap_on_the_challenges():
    hits = flagged = failures = 0
    for kind in CHALLENGES:
        h, f, z = lost_precision_recall(kind, seed=5)
        hits, flagged, failures = hits + h, flagged + f, failures + z
    # Every frame where the box misses the target entirely is flagged.
    assert hits == failures, (hits, flagged, failures)


# --- scale --------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [3, 4])
def test_the_box_follows_a_target_that_doubles_and_shrinks(seed):
    seq = challenge_sequence("scale", frames=120, seed=seed)
    t = ColorHistogramTracker(seq.frames[0], seq.boxes[0])
    boxes = np.array([seq.boxes[0]] + [t.update(f).box for f in seq.frames[1:]])
    ratio = np.sqrt(boxes[:, 2] * boxes[:, 3] / (seq.boxes[:, 2] * seq.boxes[:, 3]))
    truth_scale = seq.boxes[:, 2] / seq.boxes[0, 2]
    assert truth_scale.max() > 1.9 and truth_scale.min() < 0.65  # the generator's swing
    assert 0.75 < ratio.min() and ratio.max() < 1.33, (ratio.min(), ratio.max())


def edge_ring_scales(**params) -> list[float]:
    """A still disc of radius 12 inside a thin white circle of radius 17 or 20 (a strong
    edge just outside the target, as a door frame around a head): the scale after 40
    noisy frames, for 3 seeds and both radii."""
    yy, xx = np.mgrid[0:H, 0:W] + 0.5
    scales = []
    for radius in (17, 20):
        for seed in range(3):
            rng = np.random.default_rng(seed)
            bg = textured(seed)
            d = np.hypot(xx - 100, yy - 60)
            bg[(d > radius - 1.5) & (d < radius + 1.5)] = (250, 250, 250)
            frame = with_disc(bg, 100, 60, r=12).astype(np.int16)
            t = ColorHistogramTracker(frame.astype(np.uint8), disc_box(100, 60, r=12), **params)
            for _ in range(40):
                noisy = frame + rng.integers(-10, 11, (H, W, 3))
                t.update(np.clip(noisy, 0, 255).astype(np.uint8))
            scales.append(t.scale)
    return scales


def test_a_strong_edge_around_the_target_does_not_pull_the_box_out():
    """The true scale is 1 throughout (the generator's disc never changes)."""
    for pyramid in (True, False):
        held = edge_ring_scales(pyramid=pyramid)
        assert all(0.9 < s < 1.1 for s in held), (pyramid, held)
    # Without the scale prior and the ring term the perimeter gradient drags the box
    # out to the white circle (so the test can fail); at full resolution, where the
    # gradient pulls hardest (the half-resolution search drags it to 1.17).
    drifted = edge_ring_scales(scale_prior=0.0, ring_weight=0.0, pyramid=False)
    assert max(drifted) > 1.2, drifted


def test_an_oversized_box_does_not_grow_on_a_target_of_constant_size():
    """A still disc under 60 frames of noise: the box must not drift in size. (A guard
    only: the tracker without the ring and prior terms passes it too.)"""
    bg = textured(3)
    rng = np.random.default_rng(0)
    t = ColorHistogramTracker(with_disc(bg, 100, 60, r=14), disc_box(100, 60, r=14))
    for _ in range(60):
        noisy = with_disc(bg, 100, 60, r=14).astype(np.int16) + rng.integers(-12, 13, (H, W, 3))
        t.update(np.clip(noisy, 0, 255).astype(np.uint8))
    assert 0.85 < t.scale < 1.15, t.scale


# --- API -----------------------------------------------------------------------------


def test_box_as_tuple_list_or_array_gives_the_same_track():
    bg = textured()
    f0, f1 = with_disc(bg, 60, 60), with_disc(bg, 63, 61)
    box = disc_box(60, 60)
    answers = [
        ColorHistogramTracker(f0, b).update(f1)
        for b in (box, list(box), np.array(box), np.array(box, np.float32).reshape(1, 4))
    ]
    assert all(a == answers[0] for a in answers)


def test_a_box_partly_outside_the_frame_is_clipped_with_a_warning():
    bg = textured()
    f0 = with_disc(bg, 8, 60)
    with pytest.warns(UserWarning, match="partly outside"):
        t = ColorHistogramTracker(f0, (-6.0, 50.0, 24.0, 20.0))
    # The clipped box is the box's intersection with [0, W] x [0, H].
    assert t.update(f0).box is not None
    with pytest.warns(UserWarning, match=r"clipped to \(0\.0, 50\.0, 18\.0, 20\.0\)"):
        ColorHistogramTracker(f0, (-6.0, 50.0, 24.0, 20.0))
    with pytest.warns(UserWarning, match=r"clipped to \(230\.0, 100\.0, 10\.0, 20\.0\)"):
        ColorHistogramTracker(f0, (230.0, 100.0, 30.0, 40.0))


@pytest.mark.parametrize("box", [(10, 10, 0, 20), (10, 10, 20, 0), (10, 10, -5, 20)])
def test_a_box_of_zero_size_is_a_clear_error(box):
    with pytest.raises(ValueError, match="zero or negative size"):
        ColorHistogramTracker(textured(), box)


def test_a_box_wholly_outside_or_frames_changing_size_are_clear_errors():
    with pytest.raises(ValueError, match="inside the 240 x 120 frame"):
        ColorHistogramTracker(textured(), (300, 10, 20, 20))
    t = ColorHistogramTracker(textured(), (10, 10, 20, 20))
    with pytest.raises(ValueError, match=r"frame size changed from 240x120 to 100x120"):
        t.update(textured()[:, :100])


def test_greyscale_frames_track_as_their_grey_rgb_copies():
    bg = textured()
    grey = [with_disc(bg, 60 + 3 * k, 60).mean(axis=2).astype(np.uint8) for k in range(5)]
    box = disc_box(60, 60)
    a = ColorHistogramTracker(grey[0], box)
    b = ColorHistogramTracker(np.repeat(grey[0][:, :, None], 3, axis=2), box)
    c = ColorHistogramTracker(grey[0][:, :, None], box)
    for g in grey[1:]:
        ra, rb, rc = a.update(g), b.update(np.stack([g, g, g], axis=2)), c.update(g[:, :, None])
        assert ra == rb == rc


@pytest.mark.parametrize("kind", [ColorHistogramTracker, ParticleColorTracker])
def test_bgr_frames_track_as_their_rgb_originals(kind):
    bg = textured()
    rgb = [with_disc(bg, 60 + 3 * k, 60) for k in range(5)]
    a = kind(rgb[0], disc_box(60, 60))
    b = kind(np.ascontiguousarray(rgb[0][:, :, ::-1]), disc_box(60, 60), channels="bgr")
    for f in rgb[1:]:
        assert a.update(f) == b.update(np.ascontiguousarray(f[:, :, ::-1]))
    with pytest.raises(ValueError, match="channels"):
        kind(rgb[0], disc_box(60, 60), channels="hsv")


# --- OpenCV's tracker protocol ----------------------------------------------------------


def opencv_style_loop(tracker, frames_bgr, box) -> list[tuple[bool, tuple]]:
    """How OpenCV's tutorials drive a tracker: init, then update and draw the box."""
    import cv2

    tracker.init(frames_bgr[0], box)
    out = []
    for frame in frames_bgr[1:]:
        ok, bbox = tracker.update(frame)
        if ok:
            p1 = (bbox[0], bbox[1])
            p2 = (bbox[0] + bbox[2], bbox[1] + bbox[3])
            cv2.rectangle(frame, p1, p2, (255, 0, 0), 2, 1)
        out.append((ok, tuple(bbox)))
    return out


def test_the_opencv_adapter_runs_where_an_opencv_tracker_runs():
    cv2 = pytest.importorskip("cv2")
    seq = challenge_sequence("distractors", frames=20, seed=1)
    bgr = [np.ascontiguousarray(f[:, :, ::-1]) for f in seq.frames]
    box = tuple(round(float(v)) for v in seq.boxes[0])
    theirs = opencv_style_loop(cv2.TrackerCSRT_create(), [f.copy() for f in bgr], box)
    ours = opencv_style_loop(opencv("color"), [f.copy() for f in bgr], box)
    assert len(ours) == len(theirs)
    for (ok_a, b_a), (ok_b, b_b) in zip(ours, theirs, strict=True):
        assert type(ok_a) is type(ok_b) is bool
        assert len(b_a) == len(b_b) == 4
        assert all(isinstance(v, int) for v in b_a) and all(isinstance(v, int) for v in b_b)
    boxes = np.array([b for _, b in ours], dtype=float)
    assert metrics.iou(boxes, seq.boxes[1:]).mean() > 0.6
    # init returns what OpenCV's returns (None in OpenCV 4.5+).
    assert opencv("color").init(bgr[0], box) == cv2.TrackerKCF_create().init(bgr[0], box)


def test_the_opencv_adapter_takes_names_or_classes_and_refuses_update_before_init():
    t = opencv(ParticleColorTracker, seed=3, n_particles=50)
    with pytest.raises(RuntimeError, match="init"):
        t.update(textured())
    with pytest.raises(ValueError, match="tracker must be one of"):
        opencv("csrt")
    bg = textured()
    rgb = with_disc(bg, 60, 60)
    t = opencv("color-pf", channels="rgb", seed=3)
    t.init(rgb, disc_box(60, 60))
    ok, box = t.update(with_disc(bg, 62, 60))
    assert ok and abs(box[0] + box[2] / 2 - 62) <= 3


# --- the particle tracker's proposal ------------------------------------------------


def particle_errors(**params) -> tuple[list[float], list[float]]:
    """The accelerating disc of ``fast_track`` under the particle tracker: centre errors
    and the effective sample size after each step."""
    bg = textured()
    xs = list(np.cumsum([14.0, 3, 6, 10, 14, 18, 22, 24, 24]))
    t = ParticleColorTracker(with_disc(bg, xs[0], 60), disc_box(xs[0], 60), seed=2, **params)
    errors, ess = [], []
    for x in xs[1:]:
        r = t.update(with_disc(bg, x, 60))
        errors.append(float(np.hypot(*(centre(r.box) - (x, 60)))))
        ess.append(t.ess)
    return errors, ess


def test_the_mixture_proposal_keeps_the_particles_on_a_fast_target():
    errors, ess = particle_errors()
    assert max(errors) < 4.0, errors
    assert min(ess) >= 1.0 and max(ess) <= 200.0
    # Plain CONDENSATION (the random walk alone) falls behind at 24 px per frame.
    plain, _ = particle_errors(mix_fraction=0.0)
    assert max(plain) > 9.0, plain


def test_mix_fraction_is_checked():
    with pytest.raises(ValueError, match="mix_fraction"):
        ParticleColorTracker(textured(), disc_box(60, 60), mix_fraction=1.5)
    with pytest.raises(ValueError, match="max_search_radius"):
        ParticleColorTracker(textured(), disc_box(60, 60), search_radius=20, max_search_radius=10)
