"""Figures of the visual memory (paper [001], Fig. 9): key images with their tracked
models, the mosaic against the true patterns, and the learnt path against the replays
and the truth."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.gridspec import SubplotSpec

from rperc._atomic import write_atomically
from rperc.plot import robust_limits, save, set_limits

if TYPE_CHECKING:
    from rperc.navigation import CeilingWorld, Evaluation, Learning, ReplayResult

__all__ = ["replay_strip", "visual_memory_figure"]


def _corners(state: Sequence[float], size: tuple[float, float]) -> np.ndarray:
    """A model's window corners at tracker state ``(x, y, theta, s)`` (the tracker's
    convention: theta counter-clockwise on screen)."""
    x, y, theta, s = (float(v) for v in state)
    hw, hh = 0.5 * size[0], 0.5 * size[1]
    c, sn = np.cos(theta), np.sin(theta)
    offsets = np.array([[-hw, -hh], [hw, -hh], [hw, hh], [-hw, hh], [-hw, -hh]])
    u = x + s * (c * offsets[:, 0] + sn * offsets[:, 1])
    v = y + s * (-sn * offsets[:, 0] + c * offsets[:, 1])
    return np.column_stack([u, v]).astype(np.float64)


def _to_real(homography: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Ideal-image points ``(n, 2)`` in the real image through a 3x3 homography."""
    h = np.column_stack([points, np.ones(len(points))]) @ homography.T
    out: np.ndarray = h[:, :2] / h[:, 2:3]
    return out


def _key_images(fig: Figure, spec: SubplotSpec, world: CeilingWorld, learning: Learning) -> None:
    keys = learning.memory.key_images
    picks = np.unique(np.linspace(0, len(keys) - 1, min(4, len(keys))).round().astype(int))
    sizes = [m["model"]["size"] for m in learning.memory._data["models"]]
    inner = spec.subgridspec(2, 2, wspace=0.05, hspace=0.15)
    for n, k in enumerate(picks):
        ax = fig.add_subplot(inner[n // 2, n % 2])
        key = keys[k]
        frame = world.render(learning.frames.truth[key["frame"]], first_frame=key["frame"])[0]
        ax.imshow(frame, cmap="gray", vmin=0, vmax=255)
        # Tracker states live in the ideal image (eq. 1); the frame shown is the real
        # camera's, so the boxes go through C_H_R (ideal to real pixels).
        ideal_to_real = world.matrices()["C_H_R"]
        for m in key["models"]:
            box = _to_real(ideal_to_real, _corners(m["state"], sizes[m["id"]]))
            centre = _to_real(ideal_to_real, np.array([m["state"][:2]], dtype=np.float64))[0]
            ax.plot(box[:, 0], box[:, 1], color="tab:orange", lw=1.2)
            ax.text(centre[0], centre[1], str(m["id"]), color="yellow", fontsize=7,
                    ha="center", va="center")  # fmt: skip
        ax.set_title(f"key image {k} (frame {key['frame']})", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])


def _mosaic(ax: Axes, world: CeilingWorld, learning: Learning) -> None:
    tex = world.texture()
    res = world.resolution
    extent = (0.0, (tex.shape[1] - 1) * res, 0.0, (tex.shape[0] - 1) * res)
    ax.imshow(tex, cmap="gray", vmin=0, vmax=255, origin="lower", extent=extent, alpha=0.5)
    est = learning.to_world(learning.memory.model_poses)
    true_frames = _true_model_frames(learning)
    ax.plot(true_frames[:, 0], true_frames[:, 1], "o", mfc="none", mec="k", ms=9,
            label="model frames, truth")  # fmt: skip
    ax.plot(est[:, 0], est[:, 1], "+", color="tab:red", ms=9, mew=2,
            label="mosaic (eq. 3), estimate")  # fmt: skip
    for p in est:
        ax.arrow(p[0], p[1], 0.3 * np.cos(p[2]), 0.3 * np.sin(p[2]), color="tab:red",
                 width=0.01, head_width=0.08, length_includes_head=True)  # fmt: skip
    robots = learning.to_world(learning.memory.key_poses)
    ax.plot(robots[:, 0], robots[:, 1], "^", color="0.4", ms=6, label="robot at key images (eq. 2)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper right", fontsize=7)


def _true_model_frames(learning: Learning) -> np.ndarray:
    from rperc.navigation.memory import _pose, _se2

    truth = learning.frames.truth
    rows = [
        _pose(_se2(truth[k]) @ _se2(learning.camera_to_model(c)))
        for k, c in zip(learning.memory.model_created, learning.memory.model_centers, strict=True)
    ]
    return np.array(rows).reshape(-1, 3)


def _paths(ax: Axes, learning: Learning, runs: list[ReplayResult]) -> None:
    learnt = learning.frames.truth
    ax.plot(learnt[:, 0], learnt[:, 1], color="k", lw=2.5, label="learnt path A-B, truth")
    for n, r in enumerate(runs):
        t = r.frames.truth
        ax.plot(t[:, 0], t[:, 1], color="tab:blue", lw=0.8, alpha=0.6,
                label="replays, truth" if n == 0 else None)  # fmt: skip
        est = learning.to_world(r.frames.pose)
        ax.plot(est[:, 0], est[:, 1], color="tab:orange", lw=0.6, ls="--", alpha=0.6,
                label="replays, estimate (eq. 2)" if n == 0 else None)  # fmt: skip
    ax.plot(*learnt[0, :2], "s", color="tab:green", ms=8, label="A")
    ax.plot(*learnt[-1, :2], "*", color="tab:red", ms=12, label="B")
    pts = np.concatenate([learnt[:, :2]] + [r.frames.truth[:, :2] for r in runs])
    set_limits(ax, robust_limits(pts, margin=0.1))
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=7)


def visual_memory_figure(
    world: CeilingWorld, learning: Learning, evaluation: Evaluation, runs: list[ReplayResult]
) -> Figure:
    """Fig. 9 with truth: key images (left), the mosaic (centre), paths (right)."""
    m = evaluation
    fig = Figure(figsize=(16, 5.6), layout="constrained")
    spec = fig.add_gridspec(1, 3, width_ratios=[1.0, 1.3, 1.1])
    _key_images(fig, spec[0], world, learning)
    ax = fig.add_subplot(spec[1])
    _mosaic(ax, world, learning)
    ax.set_title(f"mosaic: {learning.memory.n_models} models, error {m.mosaic_error_cm:.2f} cm "
                 f"{m.mosaic_error_deg:.2f} deg RMS", fontsize=9)  # fmt: skip
    ax = fig.add_subplot(spec[2])
    _paths(ax, learning, runs)
    ax.set_title(
        f"{m.starts} replays: B reached {100 * m.success_rate:.0f} %, median final error "
        f"{m.final_error_cm:.1f} cm\nlocalisation {m.localization_error_cm:.2f} cm "
        f"{m.localization_error_deg:.2f} deg RMS, {m.hz:.0f} Hz",
        fontsize=9,
    )
    return fig


def _world_to_image(world: CeilingWorld, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """World points ``(n, 2+)`` in the real camera's pixels with the robot at ``pose``."""
    out: np.ndarray = world.project(pose, np.ascontiguousarray(points[:, :2]))
    return out


def replay_marks(
    world: CeilingWorld, learning: Learning, run: ReplayResult, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """Frame ``k`` of a replay: where the models truly are in its image (the true
    pattern frames seen from the true pose), and where the robot's estimate puts them
    (the mosaic's models seen from the estimated pose, eq. 2); ``(0, 2)`` when the
    robot has no estimate. The two agree when the localisation does."""
    truth = _world_to_image(world, run.frames.truth[k], _true_model_frames(learning))
    est_robot = learning.to_world(run.frames.pose[k])[0]
    if not np.isfinite(est_robot).all():
        return truth, np.empty((0, 2))
    models = learning.to_world(learning.memory.model_poses)
    return truth, _world_to_image(world, est_robot, models)


def _position_error_cm(learning: Learning, run: ReplayResult, k: int) -> float:
    est = learning.to_world(run.frames.pose[k])[0]
    return float(100 * np.hypot(*(est[:2] - run.frames.truth[k, :2])))


def replay_strip(
    world: CeilingWorld, learning: Learning, run: ReplayResult, out: Path, frames: int = 8
) -> list[Path]:
    """Eight frames of one replay side by side, each with the models' true image
    positions (circles) and where the robot's estimate puts them (crosses), titled with
    the position error (``replay_strip.png``); and the whole replay so marked as
    ``replay.gif`` when imageio is installed."""
    truth = run.frames.truth
    picks = np.unique(np.linspace(0, len(truth) - 1, frames).round().astype(int))
    images = world.render(truth[picks])
    fig = Figure(figsize=(2.2 * len(picks), 2.5), layout="constrained")
    for n, (k, img) in enumerate(zip(picks, images, strict=True)):
        ax = fig.add_subplot(1, len(picks), n + 1)
        ax.imshow(img, cmap="gray", vmin=0, vmax=255)
        true_px, est_px = replay_marks(world, learning, run, int(k))
        ax.plot(true_px[:, 0], true_px[:, 1], "o", mfc="none", mec="lime", ms=9, mew=1.5,
                label="models, truth")  # fmt: skip
        ax.plot(est_px[:, 0], est_px[:, 1], "+", color="red", ms=9, mew=1.5,
                label="models, estimate (eq. 2)")  # fmt: skip
        ax.set_xlim(-0.5, img.shape[1] - 0.5)
        ax.set_ylim(img.shape[0] - 0.5, -0.5)
        error = _position_error_cm(learning, run, int(k))
        ax.set_title(f"frame {k}, key {run.key_index[k]}, {run.frames.tracked[k]} tracked\n"
                     f"position error {error:.1f} cm", fontsize=7)  # fmt: skip
        ax.set_xticks([])
        ax.set_yticks([])
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=7)
    written = [save(fig, out / "replay_strip.png")]
    try:
        import imageio.v3 as iio
    except ImportError:
        return written
    step = max(1, len(truth) // 60)
    shown = world.render(truth[::step])
    ks = range(0, len(truth), step)
    clip = [_marked(world, learning, run, k, f) for k, f in zip(ks, shown, strict=True)]
    path = out / "replay.gif"
    write_atomically(path, lambda tmp: iio.imwrite(tmp, np.stack(clip), duration=100, loop=0))
    written.append(path)
    return written


def _marked(
    world: CeilingWorld, learning: Learning, run: ReplayResult, k: int, frame: np.ndarray
) -> np.ndarray:
    """An animation frame in colour: a green ring where each model truly is, a red
    cross where the robot's estimate puts it."""
    rgb = np.repeat(frame[:, :, None], 3, axis=2)
    h, w = frame.shape
    true_px, est_px = replay_marks(world, learning, run, k)
    ring = [(dx, dy) for dx in range(-6, 7) for dy in range(-6, 7) if 25 <= dx * dx + dy * dy <= 36]
    cross = [(d, 0) for d in range(-6, 7)] + [(0, d) for d in range(-6, 7)]
    for points, offsets, colour in ((true_px, ring, (0, 255, 0)), (est_px, cross, (255, 0, 0))):
        for x, y in np.rint(points).astype(int):
            for dx, dy in offsets:
                if 0 <= x + dx < w and 0 <= y + dy < h:
                    rgb[y + dy, x + dx] = colour
    return rgb
