"""The ceiling world (issue 13, part 1) against OpenCV: the camera's projection against
``cv2.projectPoints``, eq. 1 against ``cv2.findHomography`` on correspondences, and the
correction applied with ``cv2.warpPerspective`` to a tilted camera's image against the
ideal camera's own image; the drive against closed-form arcs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from rperc.navigation import CeilingWorld, defaults, drive

MOUNT = {"roll": 0.04, "pitch": -0.03, "yaw": 0.02, "offset": [0.08, -0.05, 0.3]}
SMALL = {"size": [6.0, 4.0], "n_patterns": 8, "resolution": 0.008, "seed": 2}
CLEAN = {"noise": 0.0, "blur": 0.0, "gain": [1.0, 1.0], "offset": [0.0, 0.0]}


def _euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)``, written out (the mount's documented order)."""
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))  # fmt: skip
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_projection_matches_opencv_project_points() -> None:
    world = CeilingWorld(ceiling=SMALL, camera={"mount": MOUNT})
    pose = np.array([3.0, 2.0, 0.7])
    rng = np.random.default_rng(0)
    xy = pose[:2] + rng.uniform(-1.2, 1.2, size=(50, 2))
    # Robot-frame ceiling points, then OpenCV's camera with X_C = R^T (X_R - offset).
    c, s = np.cos(pose[2]), np.sin(pose[2])
    d = xy - pose[:2]
    robot = np.c_[c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1],
                  np.full(len(d), world.camera.ceiling_height)]  # fmt: skip
    r_m = _euler(MOUNT["roll"], MOUNT["pitch"], MOUNT["yaw"])
    rvec, _ = cv2.Rodrigues(r_m.T)
    tvec = -r_m.T @ np.asarray(MOUNT["offset"])
    k = world.matrices(pose)["K"]
    expected, _ = cv2.projectPoints(robot, rvec, tvec, k, np.zeros(5))
    np.testing.assert_allclose(world.project(pose, xy), expected[:, 0, :], atol=1e-8)


def test_eq1_is_the_homography_opencv_fits_to_the_correspondences() -> None:
    tilted = CeilingWorld(ceiling=SMALL, camera={"mount": MOUNT})
    ideal = CeilingWorld(ceiling=SMALL)
    pose = np.array([2.5, 1.5, -0.4])
    xy = pose[:2] + np.random.default_rng(1).uniform(-1, 1, size=(40, 2))
    fitted, _ = cv2.findHomography(ideal.project(pose, xy), tilted.project(pose, xy), 0)
    eq1 = tilted.matrices(pose)["C_H_R"]
    # Compared where it matters, on the image: OpenCV's DLT fit is good to ~1e-6
    # relative in its entries, which is ~1e-4 px over the frame.
    u, v = np.meshgrid(np.linspace(0, 319, 9), np.linspace(0, 239, 7))
    grid = np.c_[u.ravel(), v.ravel()].reshape(-1, 1, 2)
    ours = cv2.perspectiveTransform(grid, eq1)
    theirs = cv2.perspectiveTransform(grid, fitted)
    np.testing.assert_allclose(ours, theirs, atol=1e-3)
    np.testing.assert_allclose(tilted.matrices(pose)["correction"] @ eq1, np.eye(3), atol=1e-12)


def test_the_correction_turns_the_tilted_image_into_the_ideal_one() -> None:
    """The seed's section 2.1: after the eq. 1 correction the image is what the camera
    would see with C_T_R = I. OpenCV warps the tilted camera's frame; the ideal camera
    renders its own; they agree up to resampling blur where both see the ceiling."""
    tilted = CeilingWorld(ceiling=SMALL, camera={"mount": MOUNT}, render=CLEAN)
    ideal = CeilingWorld(ceiling=SMALL, render=CLEAN)
    pose = np.array([3.0, 2.0, 0.3])
    real = tilted.render(pose)[0]
    want = ideal.render(pose)[0].astype(np.float64)
    h, w = real.shape
    corrected = cv2.warpPerspective(real, tilted.matrices(pose)["correction"], (w, h),
                                    flags=cv2.INTER_LINEAR, borderValue=0)  # fmt: skip
    valid = cv2.warpPerspective(np.ones_like(real), tilted.matrices(pose)["correction"], (w, h),
                                flags=cv2.INTER_NEAREST, borderValue=0) > 0  # fmt: skip
    valid = cv2.erode(valid.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert valid.mean() > 0.6
    diff = np.abs(corrected.astype(np.float64) - want)[valid]
    # Without the correction the frames disagree badly (the oracle would be blind).
    raw = np.abs(real.astype(np.float64) - want)[valid]
    assert np.median(diff) < 3.0 and np.mean(diff) < 6.0, (np.median(diff), np.mean(diff))
    assert np.mean(raw) > 3 * np.mean(diff)


def test_rendering_is_reproducible_and_batches_equal_single_frames() -> None:
    world = CeilingWorld(ceiling=SMALL, render={"occluder_probability": 0.5, "seed": 4})
    poses = np.c_[np.linspace(2, 4, 5), np.full(5, 2.0), np.linspace(0, 1, 5)]
    batch = world.render_truth(poses, first_frame=3)
    for k, pose in enumerate(poses):
        np.testing.assert_array_equal(world.render(pose, first_frame=3 + k)[0], batch.frames[k])
    assert batch.frames.dtype == np.uint8 and batch.frames.shape == (5, 240, 320)
    assert batch.lighting.shape == (5, 2) and batch.occluders.shape == (5, 3)
    assert "Rendering(frames=5" in repr(batch)
    other = CeilingWorld(ceiling=SMALL, render={"occluder_probability": 0.5, "seed": 5})
    assert not np.array_equal(other.render(poses).astype(int), batch.frames.astype(int))


def test_patterns_and_texture_are_the_truth_the_images_show() -> None:
    world = CeilingWorld(ceiling=SMALL)
    assert world.pattern_kinds[:4] == ("light", "vent", "sign", "detector")
    tex = world.texture()
    assert tex.dtype == np.float32
    assert tex.shape == (round(4.0 / 0.008) + 1, round(6.0 / 0.008) + 1)
    # A light's centre is its bright diffuser, not the tile's grey.
    i = world.pattern_kinds.index("light")
    cx, cy = world.pattern_centres[i] / world.resolution
    assert tex[round(cy), round(cx)] > 225


def test_drive_closed_form_and_drift() -> None:
    exact = {"speed_scale_error": 0.0, "turn_scale_error": 0.0, "speed_sigma": 0.0,
             "turn_sigma": 0.0}  # fmt: skip
    n, dt = 80, 0.1
    omega = 2 * np.pi / (n * dt)
    run = drive([1.0, 1.0, 0.0], np.tile([0.5 * omega, omega], (n, 1)), dt, exact)
    # Radius 0.5 m, centre (1, 1.5): every pose on the circle, back at the start.
    np.testing.assert_allclose(np.hypot(run.truth[:, 0] - 1, run.truth[:, 1] - 1.5), 0.5,
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(run.truth[-1, :2], [1.0, 1.0], atol=1e-9)
    np.testing.assert_array_equal(run.truth, run.odometry)
    noisy = drive([0, 0, 0], np.tile([0.3, 0.0], (100, 1)), 0.1)
    assert noisy.odometry[-1, 0] != pytest.approx(noisy.truth[-1, 0], abs=1e-3)
    assert "final_drift" in repr(noisy)


def test_bad_input_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="fx"):
        CeilingWorld(ceiling=SMALL, camera={"fx": 0.0})
    with pytest.raises(ValueError, match="mount"):
        CeilingWorld(ceiling=SMALL, camera={"mount": {"roll": 1.3}})
    with pytest.raises(TypeError, match="colour"):
        CeilingWorld(ceiling={**SMALL, "colour": 3})
    with pytest.raises(ValueError, match="n_patterns"):
        CeilingWorld(ceiling={"size": [2.0, 2.0], "n_patterns": 50})
    # Billions of patterns: refused when the ceiling is full, not by reserving 85 GB
    # (the fuzz suite's find: the process aborted).
    with pytest.raises(ValueError, match="n_patterns"):
        CeilingWorld(ceiling={"size": [3.0, 2.0], "resolution": 0.02, "n_patterns": 2**31})
    # Issue 38: 2^33 x 2^33 pixels wrapped the image size and aborted at the render.
    for camera in ({"width": 2**33, "height": 2**33}, {"height": 2**40}):
        with pytest.raises(ValueError, match=r"'(width|height)': must be in 16\.\.=32768"):
            CeilingWorld(ceiling=SMALL, camera=camera).render(np.zeros(3))
    world = CeilingWorld(ceiling=SMALL)
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        world.render(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="non-finite"):
        world.render(np.array([[1.0, np.nan, 0.0]]))
    with pytest.raises(ValueError, match="dt"):
        drive([0, 0, 0], [[1.0, 0.0]], 0.0)
    with pytest.raises(ValueError, match="commands"):
        drive([0, 0, 0], np.zeros((0, 2)), 0.1)
    with pytest.warns(DeprecationWarning, match="rperc.config"):
        old = defaults()
    assert set(old) == {"ceiling", "camera", "render", "odometry", "learn", "replay"}


def test_the_world_takes_typed_configs_and_dicts_alike() -> None:
    # Issue 36: the generated configs and dicts of their fields make one world; it
    # keeps its configs typed, and pickles as them.
    import pickle

    from rperc.config import CeilingCameraConfig, CeilingConfig, CeilingRenderConfig

    typed = CeilingWorld(
        ceiling=CeilingConfig.from_dict(SMALL),
        camera=CeilingCameraConfig(width=160, height=120, cx=79.5, cy=59.5),
        render=CeilingRenderConfig(seed=3),
    )
    plain = CeilingWorld(
        ceiling=SMALL, camera={"width": 160, "height": 120, "cx": 79.5, "cy": 59.5},
        render={"seed": 3},
    )  # fmt: skip
    assert typed.camera == plain.camera and typed.image_shape == (120, 160)
    pose = np.array([[1.5, 1.0, 0.2]])
    np.testing.assert_array_equal(typed.render(pose), plain.render(pose))
    again = pickle.loads(pickle.dumps(typed))
    assert again.ceiling_config == typed.ceiling_config
    np.testing.assert_array_equal(again.render(pose), typed.render(pose))
