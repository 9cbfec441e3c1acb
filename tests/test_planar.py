"""The planar-tracking harness: its metrics against brute-force computations, its
corner conventions against OpenCV's own transforms, and each peer run on the same
generated frames (failures counted, not raised)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rperc.tracking import pattern_sequence, planar

cv2 = pytest.importorskip("cv2")

REGION = (40, 30, 50, 36)


def brute_alignment(est: np.ndarray, truth: np.ndarray) -> list[float]:
    out = []
    for e, t in zip(est, truth, strict=True):
        d2 = [math.hypot(e[i][0] - t[i][0], e[i][1] - t[i][1]) ** 2 for i in range(4)]
        v = math.sqrt(sum(d2) / 4)
        out.append(v if math.isfinite(v) else math.inf)
    return out


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(0, 300),
    y=st.floats(0, 200),
    theta=st.floats(-3.1, 3.1),
    s=st.floats(0.3, 3.0),
)
def test_similarity_corners_follow_get_rotation_matrix_2d(x, y, theta, s):
    # OpenCV's map rotates (CCW on screen for positive angles) and scales about a
    # centre; moving the region's centre to (x, y) afterwards is the tracker's state.
    rx, ry, w, h = REGION
    cx, cy = rx + (w - 1) / 2, ry + (h - 1) / 2
    m = cv2.getRotationMatrix2D((cx, cy), math.degrees(theta), s)
    m[:, 2] += (x - cx, y - cy)
    edges = np.array(
        [
            [rx - 0.5, ry - 0.5],
            [rx + w - 0.5, ry - 0.5],
            [rx + w - 0.5, ry + h - 0.5],
            [rx - 0.5, ry + h - 0.5],
        ]
    )
    want = cv2.transform(edges[None], m)[0]
    got = planar.similarity_corners([x, y, theta, s], REGION)[0]
    np.testing.assert_allclose(got, want, atol=1e-6)


def test_alignment_and_centre_errors_match_brute_force():
    rng = np.random.default_rng(4)
    truth = rng.uniform(0, 100, (30, 4, 2))
    est = truth + rng.normal(0, 3, truth.shape)
    est[5, 2, 0] = np.nan
    est[7] = np.inf
    got = planar.alignment_error(est, truth)
    np.testing.assert_allclose(got, brute_alignment(est, truth), rtol=1e-12)
    assert got[5] == math.inf and got[7] == math.inf
    centre = planar.center_error(est, truth)
    with pytest.warns(DeprecationWarning, match="center_error"):
        np.testing.assert_array_equal(planar.centre_error(est, truth), centre)
    for k in range(30):
        ex = sum(est[k, i, 0] for i in range(4)) / 4 - sum(truth[k, i, 0] for i in range(4)) / 4
        ey = sum(est[k, i, 1] for i in range(4)) / 4 - sum(truth[k, i, 1] for i in range(4)) / 4
        want = math.hypot(ex, ey)
        assert centre[k] == (want if math.isfinite(want) else math.inf) or math.isclose(
            centre[k], want
        )


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0, 40) | st.just(math.inf), min_size=1, max_size=40))
def test_precision_and_success_curve_count_frames(errors):
    for t in (0.0, 5.0, 15.0, 20.0):
        assert planar.precision_at(errors, t) == sum(e <= t for e in errors) / len(errors)
    curve = planar.success_curve(errors)
    assert len(curve) == len(planar.ALIGNMENT_THRESHOLDS)
    for t, p in zip(planar.ALIGNMENT_THRESHOLDS, curve, strict=True):
        assert p == sum(e <= t for e in errors) / len(errors)


def test_bad_metric_input_is_named():
    with pytest.raises(ValueError, match="errors"):
        planar.precision_at([], 5.0)
    with pytest.raises(ValueError, match="threshold"):
        planar.precision_at([1.0], math.nan)
    with pytest.raises(ValueError, match="estimated"):
        planar.alignment_error(np.zeros((3, 3, 2)), np.zeros((3, 4, 2)))


def test_ecc_corners_are_the_warped_region_edges():
    warp = np.array([[1.1, -0.2, 12.0], [0.15, 0.9, -4.0]])
    _, _, w, h = REGION
    edges = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    np.testing.assert_allclose(
        planar.ecc_corners(warp, REGION), cv2.transform(edges[None], warp)[0]
    )
    # The identity warp at the region's origin is the identity state's corners.
    rx, ry, w, h = REGION
    at_rest = planar.ecc_corners([[1, 0, rx], [0, 1, ry]], REGION)
    np.testing.assert_allclose(
        at_rest, planar.similarity_corners([rx + (w - 1) / 2, ry + (h - 1) / 2, 0, 1], REGION)[0]
    )


def test_ecc_homography_corners_and_pyramid_levels_follow_opencv():
    hom = np.array([[1.05, -0.1, 30.0], [0.08, 0.95, 12.0], [2e-4, -1e-4, 1.0]])
    _, _, w, h = REGION
    edges = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    np.testing.assert_allclose(
        planar.ecc_corners(hom, REGION), cv2.perspectiveTransform(edges[None], hom)[0]
    )
    # A level scaled by f maps f p to f H(p), for a homography and an affine warp.
    pts = np.array([[[3.0, 4.0], [50.0, -7.0], [120.0, 80.0]]])
    for warp, f in ((hom, 0.25), (hom[:2], 0.5)):
        level = planar._ecc_level(warp, f)
        full = np.vstack([warp, [0, 0, 1]]) if warp.shape == (2, 3) else warp
        at_level = np.vstack([level, [0, 0, 1]]) if level.shape == (2, 3) else level
        np.testing.assert_allclose(
            cv2.perspectiveTransform(pts * f, at_level), f * cv2.perspectiveTransform(pts, full)
        )


def test_ecc_homography_follows_small_steps():
    seq, _, _ = scene(max_step_sigmas=0.5)
    run = planar.run_ecc(seq.frames, seq.region, "homography")
    s = planar.score("small", run, planar.truth_corners(seq))
    assert s.precision_5 == 1.0 and run.failures == 0


def scene(n_frames: int = 8, **kw):
    rng = np.random.default_rng(0)
    patch = np.full((36, 50), 70.0)
    patch[6:20, 8:30] = 210
    patch[22:32, 28:46] = 150
    yy, xx = np.mgrid[0:36, 0:50]
    patch[(xx - 14) ** 2 + (yy - 27) ** 2 < 36] = 240
    bg = rng.uniform(60, 180, (20, 26)).repeat(8, 0).repeat(8, 1)
    return (
        pattern_sequence(patch, bg, n_frames=n_frames, width=200, height=150, seed=2, **kw),
        patch,
        bg,
    )


def test_every_tracker_runs_on_the_same_frames_and_is_scored():
    seq, _, _ = scene(max_step_sigmas=0.5)
    truth = planar.truth_corners(seq)
    # Frame 0's truth is the region itself.
    np.testing.assert_allclose(
        planar.similarity_corners(seq.truth[0], seq.region)[0],
        planar.ecc_corners([[1, 0, seq.region[0]], [0, 1, seq.region[1]]], seq.region),
    )
    for name, run in planar.available_trackers().items():
        result = run(seq.frames, seq.region)
        assert result.corners.shape == (len(seq.frames) - 1, 4, 2), name
        s = planar.score("small steps", result, truth)
        assert s.frames == len(seq.frames) - 1 and s.fps > 0
        assert math.isnan(s.precision_5) == result.position_only, name
    pattern = planar.score("small", planar.run_pattern(seq.frames, seq.region), truth)
    # Steps within half a sigma on a clean scene: every frame within 5 px.
    assert pattern.precision_5 == 1.0 and pattern.failures == 0


@pytest.mark.parametrize("bad", [0, 2, -1, 1.0, True])
def test_an_ecc_pre_blur_opencv_refuses_is_an_error_not_a_run_of_failures(bad):
    seq, _, _ = scene(n_frames=2, max_step_sigmas=0.5)
    with pytest.raises((ValueError, TypeError), match="gauss_filter"):
        planar.run_ecc(seq.frames, seq.region, "affine", gauss_filter=bad)


def test_ecc_exceptions_are_counted_as_failures_not_raised():
    seq, _, _ = scene(n_frames=3, max_step_sigmas=0.5)
    frames = seq.frames.copy()
    frames[1] = 0  # a flat frame: findTransformECC throws at every level
    run = planar.run_ecc(frames, seq.region, "affine")
    assert run.failures >= 1
    assert np.all(np.isfinite(run.corners))


def test_harness_cases_select_what_they_name():
    _, patch, bg = scene()
    cases = planar.harness_cases(patch, bg, n_frames=12, size=(200, 150))
    names = [c.name for c in cases]
    assert names == [
        "steps <= 1 sigma",
        "steps 2.5-3 sigma",
        "occlusion 30-40 %",
        "pattern-like clutter",
    ]
    near3, occl = cases[1], cases[2]
    steps = np.abs(np.diff(near3.sequence.truth, axis=0)) / np.array(planar.SIGMA)
    for k in np.flatnonzero(near3.select):
        assert 2.5 <= steps[k, k % 4] <= 3.0 + 1e-9
    hidden = occl.sequence.occlusion[1:]
    assert np.all((hidden[occl.select] >= 0.3) & (hidden[occl.select] <= 0.4))
    table = planar.format_table(
        [
            planar.score(
                c.name,
                planar.run_pattern(c.sequence.frames, c.sequence.region),
                planar.truth_corners(c.sequence),
                c.select if c.select.any() else None,
            )
            for c in cases[:1]
        ]
    )
    assert "rperc pattern" in table and "P@5" in table
