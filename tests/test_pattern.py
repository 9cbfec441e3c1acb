"""The 2-D pattern tracker (seed 001 section 3) and its Fig. 8 sequence generator, from
Python: OpenCV's getRotationMatrix2D / warpAffine / transform as the oracle of the pose
and corner convention, and bad input."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from rperc import _rperc
from rperc.config import PatternConfig, PatternModelConfig
from rperc.tracking import PatternPose, PatternTracker, pattern_sequence

H, W = 160, 200
BOX = (60, 50, 64, 52)


def _patch() -> np.ndarray:
    """Rectangles, a disc and a bar of distinct grey levels, 52 x 64."""
    p = np.full((52, 64), 60, np.uint8)
    p[6:23, 8:27] = 200
    p[30:45, 34:57] = 150
    yy, xx = np.mgrid[0:52, 0:64]
    p[(xx - 18) ** 2 + (yy - 37) ** 2 <= 81] = 230
    p[4:25, 40:45] = 20
    return p


def _background() -> np.ndarray:
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    g = 120 + 30 * np.sin(0.07 * xx + 0.03 * yy) + 20 * np.cos(0.05 * yy - 0.02 * xx)
    return g.astype(np.uint8)


def _first_frame() -> np.ndarray:
    f = _background()
    x, y, w, h = BOX
    f[y : y + h, x : x + w] = _patch()
    return f


def _warp(first: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The patch of ``first`` moved by the affine ``m`` over the background."""
    mask = np.zeros_like(first)
    x, y, w, h = BOX
    mask[y : y + h, x : x + w] = 255
    moved = cv2.warpAffine(first, m, (W, H), flags=cv2.INTER_LINEAR)
    inside = cv2.warpAffine(mask, m, (W, H), flags=cv2.INTER_LINEAR) == 255
    out = _background()
    out[inside] = moved[inside]
    return out


def _opencv_pose(theta: float, scale: float, shift: tuple[float, float]) -> np.ndarray:
    """getRotationMatrix2D about the region centre (angle in degrees, CCW on screen),
    then a translation."""
    x, y, w, h = BOX
    centre = (x + (w - 1) / 2, y + (h - 1) / 2)
    m = cv2.getRotationMatrix2D(centre, math.degrees(theta), scale)
    m[:, 2] += np.asarray(shift, dtype=np.float64)
    return m


def test_corners_and_pose_follow_opencv_get_rotation_matrix_2d() -> None:
    first = _first_frame()
    tracker = PatternTracker(first, BOX, seed=3)
    x, y, w, h = BOX
    box_corners = np.array(
        [
            [x - 0.5, y - 0.5],
            [x + w - 0.5, y - 0.5],
            [x + w - 0.5, y + h - 0.5],
            [x - 0.5, y + h - 0.5],
        ]
    )
    np.testing.assert_array_equal(tracker.initial.corners_array(), box_corners)
    for k in range(1, 9):
        theta, scale, shift = math.radians(1.0 * k), 1.0 + 0.015 * k, (0.8 * k, -0.5 * k)
        m = _opencv_pose(theta, scale, shift)
        pose = tracker.update(_warp(first, m))
        assert not pose.lost
    oracle = cv2.transform(box_corners[None], m)[0]
    err = np.linalg.norm(pose.corners_array() - oracle, axis=1).max()
    assert err < 1.5, (pose, oracle)
    assert abs(math.degrees(pose.theta - theta)) < 1.0
    assert abs(pose.scale / scale - 1) < 0.02
    centre = cv2.transform(np.array([[[x + (w - 1) / 2, y + (h - 1) / 2]]]), m)[0, 0]
    assert math.hypot(pose.x - centre[0], pose.y - centre[1]) < 1.0


def test_corners_are_the_closed_form_similarity_of_the_pose() -> None:
    """Every answer's corners are ``centre + s R(theta) (+-w/2, +-h/2)``, ``R = [[c, s],
    [-s, c]]`` (theta counter-clockwise on screen), written out here by hand; a mask
    region's corners are its bounding box's."""
    first = _first_frame()
    x, y, w, h = BOX
    mask = np.zeros((H, W), bool)
    mask[y : y + h, x : x + w] = True
    for region in (BOX, mask):
        tracker = PatternTracker(first, region, seed=4)
        poses = [tracker.initial] + [
            tracker.update(_warp(first, _opencv_pose(math.radians(4 * k), 1 + 0.03 * k, (k, -k))))
            for k in range(1, 4)
        ]
        for pose in poses:
            c, s = math.cos(pose.theta), math.sin(pose.theta)
            expected = [
                (pose.x + pose.scale * (c * dx + s * dy), pose.y + pose.scale * (-s * dx + c * dy))
                for dx, dy in ((-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2))
            ]
            assert pose.corners.shape == (4, 2) and pose.corners.dtype == np.float64
            np.testing.assert_allclose(pose.corners, expected, rtol=0, atol=1e-9)
            with pytest.raises(ValueError, match="read-only"):
                pose.corners[0, 0] = 0.0
        assert poses[0].corners[0].tolist() == [x - 0.5, y - 0.5]


def test_rgb_and_mask_regions_track_like_grey_and_box() -> None:
    first = _first_frame()
    mask = np.zeros((H, W), bool)
    x, y, w, h = BOX
    mask[y : y + h, x : x + w] = True
    moved = np.roll(first, (2, 3), axis=(0, 1))
    grey = PatternTracker(first, BOX, seed=1).update(moved)
    rgb = PatternTracker(np.dstack([first] * 3), mask, seed=1).update(np.dstack([moved] * 3))
    for a, b in zip(
        (grey.x, grey.y, grey.theta, grey.scale), (rgb.x, rgb.y, rgb.theta, rgb.scale), strict=True
    ):
        assert a == pytest.approx(b, abs=1e-4)
    assert abs(grey.x - (x + (w - 1) / 2 + 3)) < 0.5 and abs(grey.y - (y + (h - 1) / 2 + 2)) < 0.5


def test_an_all_black_frame_is_lost_with_the_pose_kept() -> None:
    first = _first_frame()
    tracker = PatternTracker(first, BOX, seed=2)
    good = tracker.update(first)
    black = tracker.update(np.zeros_like(first))
    assert isinstance(black, PatternPose) and black.lost and not good.lost
    assert (black.x, black.y, black.theta, black.scale) == (good.x, good.y, good.theta, good.scale)
    np.testing.assert_array_equal(black.corners, good.corners)


def test_the_same_seed_gives_the_same_track() -> None:
    first = _first_frame()
    moved = np.roll(first, 4, axis=1)
    filter = PatternConfig().filter
    a = PatternTracker(
        first, BOX, seed=9, filter=filter.replace(parallel=True), parallel_min_work=0
    ).update(moved)
    b = PatternTracker(first, BOX, seed=9, filter=filter.replace(parallel=False)).update(moved)
    c = PatternTracker(first, BOX, seed=9).update(moved)
    assert a == b == c


@pytest.mark.parametrize(
    ("kwargs", "error", "needle"),
    [
        ({"region": (190, 10, 40, 40)}, ValueError, "region"),
        ({"region": (60, 50, 4, 4)}, ValueError, "region"),
        ({"region": (-1, 50, 64, 52)}, ValueError, "region"),
        ({"region": (60.5, 50, 64, 52)}, ValueError, "region"),
        ({"region": np.zeros((3, 3), bool)}, ValueError, "region"),
        ({"n_particles": 0}, ValueError, "n_particles"),
        # Issue 38: sizes a caller sets are bounded before anything is allocated (10**13
        # particles died in the allocator; a spacing of 1e-9 px asked for 10^9 model
        # points per pixel of contour).
        ({"n_particles": 10**13}, ValueError, "'n_particles': must be in 1..=1000000"),
        ({"pattern": {"max_points": 10**13}}, ValueError, "'max_points': must be in"),
        ({"pattern": {"point_spacing": 1e-9}}, ValueError, "'point_spacing'"),
        ({"pattern": {"point_spacing": math.inf}}, ValueError, "'point_spacing'"),
        ({"sigma": (5, 5, math.nan, 0.1)}, ValueError, "sigma"),
        ({"sigma": (5, 5, 0.1)}, ValueError, "sigma"),
        ({"refine_first_step": 0.0}, ValueError, "refine_first_step"),
        ({"refine_first_step": math.nan}, ValueError, "refine_first_step"),
        ({"pattern": {"deviation": "cubic"}}, ValueError, "deviation"),
        ({"motion": "affine"}, ValueError, "motion"),
        ({"n_particle": 10}, TypeError, "n_particle"),
        ({"refine_fine_rounds": -1}, ValueError, "refine_fine_rounds"),
        ({"newton_steps": -1}, ValueError, "newton_steps"),
        ({"newton_steps": 10**6}, ValueError, "newton_steps"),
        ({"parallel_min_work": -1}, ValueError, "parallel_min_work"),
        ({"second_look": 1.5}, ValueError, "second_look"),
        ({"second_look": math.nan}, ValueError, "second_look"),
        ({"frame": np.zeros((H, W), np.float32)}, TypeError, "uint8"),
        ({"frame": np.zeros((H, W, 4), np.uint8)}, ValueError, "shape"),
        ({"frame": np.full((H, W), 128, np.uint8)}, ValueError, "region"),
    ],
)
def test_bad_input_is_refused_by_name(kwargs: dict, error: type, needle: str) -> None:
    args = {"frame": _first_frame(), "region": BOX, **kwargs}
    frame, region = args.pop("frame"), args.pop("region")
    with pytest.raises(error, match=needle):
        PatternTracker(frame, region, **args)


def test_a_frame_of_another_size_is_refused() -> None:
    tracker = PatternTracker(_first_frame(), BOX)
    with pytest.raises(ValueError, match="frame size changed"):
        tracker.update(np.zeros((H, W + 1), np.uint8))


def test_the_generated_sequence_starts_on_its_region_and_is_seeded() -> None:
    patch, bg = _patch(), _background()
    seq = pattern_sequence(patch, bg, n_frames=5, width=W, height=H, noise=0.0, seed=4)
    assert seq.frames.shape == (5, H, W) and seq.frames.dtype == np.uint8
    assert seq.truth.shape == (5, 4) and seq.occlusion.shape == (5,)
    x, y, w, h = seq.region
    np.testing.assert_array_equal(seq.frames[0, y : y + h, x : x + w], patch)
    assert tuple(seq.truth[0]) == (x + (w - 1) / 2, y + (h - 1) / 2, 0.0, 1.0)
    again = pattern_sequence(patch, bg, n_frames=5, width=W, height=H, noise=0.0, seed=4)
    np.testing.assert_array_equal(seq.frames, again.frames)
    with pytest.raises(ValueError, match="max_occlusion"):
        pattern_sequence(patch, bg, n_frames=2, width=W, height=H, max_occlusion=2.0)
    with pytest.raises(ValueError, match="patch"):
        pattern_sequence(patch, bg, n_frames=2, width=40, height=40)


def test_generated_frames_equal_opencv_warp_affine_of_the_patch() -> None:
    """Each frame against OpenCV: the patch warped by ``getRotationMatrix2D`` (bilinear,
    edge pixels repeated) over the background where a warped mask of the patch's pixels
    (nearest neighbour) is set: the patch covers its pixels' area, scaled, as frame 0
    covers its region."""
    patch, bg = _patch(), _background()
    seq = pattern_sequence(
        patch, bg, n_frames=12, width=W, height=H, noise=0.0, background_speed=0.0, seed=7
    )
    ph, pw = patch.shape
    ones = np.ones_like(patch)
    for k, (frame, (tx, ty, theta, s)) in enumerate(zip(seq.frames, seq.truth, strict=True)):
        m = cv2.getRotationMatrix2D(((pw - 1) / 2, (ph - 1) / 2), math.degrees(theta), s)
        m[:, 2] += (tx - (pw - 1) / 2, ty - (ph - 1) / 2)
        moved = cv2.warpAffine(
            patch, m, (W, H), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
        inside = cv2.warpAffine(ones, m, (W, H), flags=cv2.INTER_NEAREST) > 0
        oracle = np.where(inside, moved, bg).astype(np.float64)
        ours = frame.astype(np.float64)
        ours_inside = np.abs(ours - oracle) <= 3
        # The footprints may differ only on pixels whose centre lies on its edge
        # (OpenCV's fixed-point coordinates round those either way); a patch cut at its
        # outer pixel centres differs on 100-180 pixels here.
        assert np.count_nonzero(~ours_inside) <= 10, k
        # Inside, the bilinear levels agree up to OpenCV's 1/32-pixel weights.
        both = ours_inside & inside
        assert np.mean(np.abs(ours - oracle)[both]) < 0.5, k


def test_a_real_patch_over_real_clutter_is_tracked(data) -> None:  # type: ignore[no-untyped-def]
    images = data / "images"
    camera = cv2.imread(str(images / "camera.png"), cv2.IMREAD_GRAYSCALE)
    grass = cv2.imread(str(images / "grass.png"), cv2.IMREAD_GRAYSCALE)
    if camera is None or grass is None:
        pytest.skip("images/camera.png or images/grass.png missing")
    patch = camera[60:160, 200:300]
    seq = pattern_sequence(
        patch,
        grass,
        n_frames=24,
        width=320,
        height=240,
        max_step_sigmas=2.0,
        max_occlusion=0.3,
        seed=1,
    )
    tracker = PatternTracker(seq.frames[0], seq.region, seed=1)
    errors = []
    for frame, truth in zip(seq.frames[1:], seq.truth[1:], strict=True):
        pose = tracker.update(frame)
        assert not pose.lost
        errors.append(math.hypot(pose.x - truth[0], pose.y - truth[1]))
    assert float(np.sqrt(np.mean(np.square(errors)))) < 1.0


@pytest.mark.parametrize(
    ("seed", "gain", "occlusion"), [(11, 0.0, 0.0), (12, 0.2, 0.0), (13, 0.0, 0.3)]
)
def test_full_three_sigma_steps_keep_the_goals(data, seed, gain, occlusion) -> None:  # type: ignore[no-untyped-def]
    """Issue 35: steps up to 3 sigma in all four parameters at once (the seed's 200
    particles strayed by more than 5 px on most such sequences), plain, with a gain of
    1 +- 0.2 per frame, and with up to 30 % of the patch hidden. The goals: RMS within
    1.5 px, 1.5 degrees and 3 % of the generator's truth, never lost. Seeds 11-13 were
    not used to choose a default (seeds 0-9 were)."""
    images = data / "images"
    camera = cv2.imread(str(images / "camera.png"), cv2.IMREAD_GRAYSCALE)
    grass = cv2.imread(str(images / "grass.png"), cv2.IMREAD_GRAYSCALE)
    if camera is None or grass is None:
        pytest.skip("images/camera.png or images/grass.png missing")
    seq = pattern_sequence(
        camera[60:160, 200:300],
        grass,
        n_frames=40,
        width=640,
        height=480,
        max_step_sigmas=3.0,
        other_step_sigmas=3.0,
        gain=(1 - gain, 1 + gain),
        max_occlusion=occlusion,
        seed=seed,
    )
    tracker = PatternTracker(seq.frames[0], seq.region, seed=seed)
    errors = []
    for frame, truth in zip(seq.frames[1:], seq.truth[1:], strict=True):
        pose = tracker.update(frame)
        assert not pose.lost
        errors.append(
            (
                math.hypot(pose.x - truth[0], pose.y - truth[1]),
                math.degrees(pose.theta - truth[2]),
                pose.scale / truth[3] - 1,
            )
        )
    rms = np.sqrt(np.mean(np.square(errors), axis=0))
    assert rms[0] <= 1.5 and rms[1] <= 1.5 and rms[2] <= 0.03, rms


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seed": None}, r"^seed must be a non-negative integer below 2\*\*64, got None"),
        ({"seed": float("nan")}, r"^seed must be a non-negative integer below 2\*\*64, got nan"),
        ({"sigma": "abc"}, r"^pattern: sigma: Invalid type string"),
        ({"refine_steps": 10**9}, r"'refine_steps': must be at most 64, got 1000000000"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, message):
    # Issue 38: seed=None or nan and sigma='abc' failed inside int() or numpy with
    # messages that named nothing; refine_steps=10**9 never returned.
    frame = np.full((120, 160), 90, np.uint8)
    frame[40:70, 50:90] = 200
    with pytest.raises((ValueError, TypeError), match=message):
        PatternTracker(frame, (45, 35, 50, 40), **kwargs)


@pytest.mark.parametrize(
    "levels",
    [[1.0 + k / 10 for k in range(100_000)], [1.0, 1e300], [1.0, math.inf]],
    ids=["100000 levels", "scale 1e300", "scale inf"],
)
def test_the_scale_levels_are_bounded_up_front(levels: list[float]) -> None:
    # Each level blurs its own copy of the frame with a kernel growing with its scale:
    # a huge count or scale must be refused by name before anything is built.
    from rperc import _rperc

    with pytest.raises(ValueError, match="scale_levels"):
        _rperc.PatternTracker(_first_frame(), BOX, 0, {"pattern": {"scale_levels": levels}})


def test_sequence_frames_too_large_to_count_are_refused() -> None:
    # width * height overflowed the native size (2^33 squared) and passed the check.
    from rperc import _rperc

    patch, bg = _patch().astype(np.float64), _background().astype(np.float64)
    for size in (2**33, 2**40, 2**62):
        config = {"width": size, "height": size, "n_frames": 1}
        with pytest.raises(MemoryError, match="'n_frames'"):
            _rperc.pattern_sequence(patch, bg, config)


@pytest.mark.parametrize(("low", "high"), [(0.0, 60.0), (0.0, 0.0)])
def test_zero_canny_thresholds_learn_and_track(low: float, high: float) -> None:
    # A threshold of 0 made imageproc's hysteresis walk off the image (a panic). The
    # check: on the unchanged first frame the pose stays at the region's centre.
    model = PatternModelConfig(canny_low=low, canny_high=high)
    tracker = PatternTracker(_first_frame(), BOX, pattern=model, seed=1)
    pose = tracker.update(_first_frame())
    x, y, w, h = BOX
    assert not pose.lost
    assert abs(pose.x - (x + (w - 1) / 2)) < 1.0 and abs(pose.y - (y + (h - 1) / 2)) < 1.0


def test_the_config_and_its_keyword_overrides_are_one_path() -> None:
    # Issue 36: a PatternConfig, a dict of its fields and keyword overrides give one
    # config; the old keywords of nested fields still work, with a DeprecationWarning
    # naming where the field lives now.
    frame = _first_frame()
    typed = PatternTracker(frame, BOX, config=PatternConfig(n_particles=80, motion="homography"))
    plain = PatternTracker(frame, BOX, config={"n_particles": 80}, motion="homography")
    assert typed.config == plain.config
    assert (
        typed.config.filter.chunk_size == _rperc.config_defaults("pattern")["filter"]["chunk_size"]
    )
    with pytest.warns(DeprecationWarning, match=r"likelihood_sigma= -> pattern\.sigma"):
        old = PatternTracker(frame, BOX, likelihood_sigma=2.0, parallel=False)  # type: ignore[call-arg]
    base = PatternConfig()
    assert old.config == base.replace(
        pattern=base.pattern.replace(sigma=2.0), filter=base.filter.replace(parallel=False)
    )
    with pytest.warns(DeprecationWarning, match="canny_low"):
        PatternTracker(frame, BOX, config=PatternConfig(n_particles=80), canny_low=20.0)  # type: ignore[call-arg]
    with pytest.warns(DeprecationWarning, match="width=w, height=h"):
        seq = pattern_sequence(_patch(), _background(), n_frames=2, size=(W, H))  # type: ignore[call-arg]
    assert seq.frames.shape == (2, H, W)


def test_answers_are_frozen_with_read_only_arrays() -> None:
    tracker = _rperc.PatternTracker(_first_frame(), BOX, 0, None)
    answer = tracker.update(_first_frame())
    with pytest.raises(AttributeError):
        answer.x = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        answer.corners[0, 0] = 1.0
    seq = _rperc.pattern_sequence(
        _patch().astype(float), _background().astype(float), {"n_frames": 2}
    )
    assert seq.region == tuple(int(v) for v in seq.region) and seq.frames.shape[0] == 2


def _similarity_quad(
    size: tuple[int, int], centre: tuple[float, float], angle: float
) -> np.ndarray:
    """The corners (top-left, top-right, bottom-right, bottom-left, outer pixel edges) of
    a ``size`` patch turned by ``angle`` about ``centre``, at scale 1."""
    w, h = size
    rel = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    c, s = math.cos(angle), math.sin(angle)
    return rel @ np.array([[c, s], [-s, c]]) + np.array(centre)


@pytest.mark.parametrize("images", [0, 1, 2])
def test_a_hidden_target_is_lost_then_found_where_it_reappears(images: int) -> None:
    """Similarity mode: hidden for three frames, the pattern is reported lost (the
    gains of the profiles clutter matches by chance spread), and when it reappears
    about 190 px away the whole-frame search finds it at once. OpenCV draws every
    frame; its corners are the oracle."""
    from rperc.tracking.perspective import patch_corners
    from rperc.tracking.synthetic import demo_images

    patch, bg = demo_images(images)
    patch = patch.astype(np.float32)
    h, w = patch.shape
    still = np.pad(bg.astype(np.float32), ((0, 480), (0, 640)), mode="symmetric")[:480, :640]
    source = patch_corners(w, h).astype(np.float32)
    rng = np.random.default_rng(images)

    def draw(corners: np.ndarray | None) -> np.ndarray:
        frame = still.copy()
        if corners is not None:
            hom = cv2.getPerspectiveTransform(source, corners.astype(np.float32))
            flags, border = cv2.INTER_LINEAR, cv2.BORDER_TRANSPARENT
            cv2.warpPerspective(patch, hom, (640, 480), dst=frame, flags=flags, borderMode=border)
        frame = frame + rng.normal(0.0, 2.0, frame.shape)
        return np.clip(np.rint(frame), 0, 255).astype(np.uint8)

    start = _similarity_quad((w, h), (300.0, 240.0), 0.0)
    x0, y0 = start.min(axis=0)
    tracker = PatternTracker(draw(start), (round(x0 + 0.5), round(y0 + 0.5), w, h), seed=1)
    for k in range(1, 6):
        corners = _similarity_quad((w, h), (300.0 + 2 * k, 240.0 - k), 0.01 * k)
        assert not tracker.update(draw(corners)).lost
    assert all(tracker.update(draw(None)).lost for _ in range(3))
    errors = []
    for k in range(4):
        corners = _similarity_quad((w, h), (130.0 + 2 * k, 330.0 - k), 0.05)
        pose = tracker.update(draw(corners))
        assert not pose.lost, k
        errors.append(float(np.mean(np.linalg.norm(pose.corners - corners, axis=1))))
    assert max(errors) <= 2.0, errors
