"""``rperc track-pattern SOURCE --region x,y,w,h`` (the paper [001] pattern tracker on a
video or a folder of images) and ``rperc demo pattern`` (its Fig. 8, section 4.1, on a
generated sequence, and the planar-tracking harness table against OpenCV's peers)."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rperc._args import excerpt
from rperc._atomic import write_atomically, write_text_atomically
from rperc._extras import require
from rperc._progress import progress
from rperc.cli.outputs import (
    DemoResult,
    add_json_option,
    check_output_file,
    count_at_least,
    seed_type,
    write_json,
    wrote,
)
from rperc.tracking.synthetic import demo_images

if TYPE_CHECKING:
    from rperc.datasets.pot import PlanarTruth
    from rperc.tracking.pattern import PatternPose

COMPONENTS = ("dX (px)", "dY (px)", "dtheta (deg)", "ds (%)")


def fig8_errors(estimates: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """RMS position (px), angle (deg) and relative scale (%) errors of the estimates of
    frames ``1..n`` against the truth, over frames whose swept step is within 3 sigma
    (the goals of the issue)."""
    from rperc.tracking.planar import SIGMA

    t = truth[1:]
    k = np.arange(len(t))
    step = np.abs(np.diff(truth, axis=0)[k, k % 4]) / np.array(SIGMA)[k % 4]
    sel = step <= 3.0
    pos = np.hypot(estimates[:, 0] - t[:, 0], estimates[:, 1] - t[:, 1])[sel]
    ang = np.degrees(estimates[:, 2] - t[:, 2])[sel]
    scl = 100 * (estimates[:, 3] / t[:, 3] - 1)[sel]
    rms = [float(np.sqrt(np.mean(v**2))) for v in (pos, ang, scl)]
    return {
        "frames": int(sel.sum()),
        "position_px": rms[0],
        "angle_deg": rms[1],
        "scale_pct": rms[2],
    }


def _fig8(estimates: np.ndarray, truth: np.ndarray, errors: dict[str, float], seed: int) -> Any:
    import matplotlib.pyplot as plt

    from rperc.tracking.planar import SIGMA

    units = np.array([1.0, 1.0, 180 / math.pi, 100.0])
    true_step = np.diff(truth, axis=0)
    est_step = np.diff(np.vstack([truth[:1], estimates]), axis=0)
    err = estimates - truth[1:]
    k = np.arange(len(true_step))
    fig, axes = plt.subplots(2, 4, figsize=(16, 7.5))
    for d in range(4):
        sel = k % 4 == d
        ax = axes[0, d]
        x, y = true_step[sel, d] * units[d], est_step[sel, d] * units[d]
        lim = 1.1 * max(np.abs(x).max(), np.abs(y).max(), 1e-9)
        ax.plot([-lim, lim], [-lim, lim], "k--", lw=1, label="ideal")
        ax.plot(x, y, "o", ms=4, label="estimate vs truth")
        ax.set_xlabel(f"true {COMPONENTS[d]}")
        ax.set_ylabel(f"estimated {COMPONENTS[d]}")
        ax.legend(loc="upper left", fontsize=8)
        ax = axes[1, d]
        ratio = np.abs(true_step[sel, d]) / SIGMA[d]
        ax.plot(ratio, np.abs(err[sel, d]) * units[d], "o", ms=4, label="|estimate - truth|")
        ax.axvline(3.0, color="grey", ls=":", label="3 sigma")
        ax.set_xlabel("|step| / sigma")
        ax.set_ylabel(f"error {COMPONENTS[d]}")
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(
        f"Fig. 8 reproduced (seed {seed}): within 3 sigma, RMS {errors['position_px']:.2f} px, "
        f"{errors['angle_deg']:.2f} deg, {errors['scale_pct']:.1f} % scale "
        f"({errors['frames']} frames)"
    )
    fig.tight_layout()
    return fig


def demo_pattern(out: Path, seed: int, frames: int = 60) -> DemoResult:
    """The pattern tracker on a generated Fig. 8 sequence (steps swept to 4 sigma, noise,
    moving clutter) and the planar harness (pattern tracker, ECC, matchTemplate, CSRT)
    on the four harness cases."""
    from rperc.plot import save
    from rperc.tracking import PatternTracker, pattern_sequence, planar

    patch, background = demo_images(seed)
    seq = pattern_sequence(patch, background, n_frames=frames, seed=seed, max_step_sigmas=4.0)
    tracker = PatternTracker(seq.frames[0], seq.region, seed=seed)
    poses = [tracker.update(f) for f in seq.frames[1:]]
    estimates = np.array([(p.x, p.y, p.theta, p.scale) for p in poses])
    lost = int(sum(p.lost for p in poses))
    errors = fig8_errors(estimates, seq.truth)
    figures = [save(_fig8(estimates, seq.truth, errors, seed), out / "pattern.png")]
    cases = planar.harness_cases(patch, background, n_frames=max(frames // 2, 8), seed=seed)
    scores = planar.run_harness(cases)
    table = planar.format_table(scores)
    write_text_atomically(out / "pattern_harness.txt", table + "\n")
    p5 = {s.tracker: s.precision_5 for s in scores if s.case == "steps <= 1 sigma"}
    summary = (
        f"pattern: Fig. 8 sequence ({frames} frames, seed {seed}, steps to 4 sigma), within "
        f"3 sigma RMS {errors['position_px']:.2f} px, {errors['angle_deg']:.2f} deg, "
        f"{errors['scale_pct']:.1f} % scale, lost {lost}; harness P@5 (steps <= 1 sigma): "
        + ", ".join(f"{n} {v:.2f}" for n, v in p5.items() if not math.isnan(v))
    )
    measured = {
        "errors": errors,
        "lost": lost,
        "estimates": estimates.tolist(),
        "harness": [vars(s) for s in scores],
    }
    return DemoResult(summary, figures, measured, details=table.splitlines())


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "track-pattern",
        help="track a planar pattern (paper [001]) through a video or a folder of images",
    )
    p.add_argument("source", type=Path, help="a folder of images (sorted by name) or a video")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--region", type=region_type, help="x,y,w,h in frame 0 (px)")
    where.add_argument(
        "--corners",
        type=corners_type,
        help="x1,y1,...,x4,y4: the plane's corners in frame 0 (top-left, top-right,"
        " bottom-right, bottom-left; needs --motion homography)",
    )
    p.add_argument(
        "--motion",
        choices=("similarity", "homography"),
        default="similarity",
        help="similarity (x, y, theta, scale; paper [001]) or homography (a plane in"
        " perspective); default similarity",
    )
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the particle filter")
    p.add_argument("--strip", type=Path, help="write a strip PNG of frames with the pattern drawn")
    p.add_argument(
        "--frames", type=count_at_least(2), default=6, help="frames in the strip (>= 2, default 6)"
    )
    p.add_argument(
        "--animation",
        type=Path,
        help="write every frame with the pattern drawn (.gif/.mp4, imageio)",
    )
    p.add_argument(
        "--truth",
        type=Path,
        help="a POT-210 folder with gt_corners.txt (and gt_flag.txt) to score against;"
        " default: SOURCE itself when it holds gt_corners.txt",
    )
    add_json_option(p)
    p.set_defaults(run=track_pattern_command)


def region_type(text: str) -> tuple[int, int, int, int]:
    """``x,y,w,h``: four whole non-negative pixel counts."""
    parts = text.split(",")
    if len(parts) != 4 or not all(p.strip().isdigit() for p in parts):
        raise argparse.ArgumentTypeError(
            f"--region must be x,y,w,h in whole pixels, got {excerpt(text)}"
        )
    x, y, w, h = (int(p) for p in parts)
    return (x, y, w, h)


def corners_type(text: str) -> np.ndarray:
    """``x1,y1,...,x4,y4``: eight finite numbers, the four corners."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 8 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"--corners must be eight numbers x1,y1,...,x4,y4, got {excerpt(text)}"
        )
    return np.array(values, dtype=np.float64).reshape(4, 2)


def load_frames(source: Path) -> list[np.ndarray]:
    """Frames of a folder of images (sorted by name, as uint8 grey or RGB) or of a video
    (through imageio, when installed)."""
    if source.is_dir():
        files = sorted(f for f in source.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        if len(files) < 2:
            raise ValueError(f"{source} holds {len(files)} images; tracking needs at least 2")
        from PIL import Image

        frames = []
        for f in files:
            with Image.open(f) as im:
                frames.append(np.asarray(im.convert("L" if im.mode in ("L", "I;16") else "RGB")))
        return frames
    if not source.exists():
        raise ValueError(f"{source} does not exist")
    iio = require("imageio.v3", f"reading the video {source}")
    frames = [
        np.ascontiguousarray(np.asarray(f, dtype=np.uint8)[..., :3]) for f in iio.imiter(source)
    ]
    if len(frames) < 2:
        raise ValueError(f"{source} has {len(frames)} frames; tracking needs at least 2")
    return frames


def _quad_strip(
    frames: list[np.ndarray], picks: np.ndarray, quads: np.ndarray, poses: list[Any], title: str
) -> Any:
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon

    fig = Figure(figsize=(2.4 * max(len(picks), 3), 5.2), layout="constrained")
    grid = fig.add_gridspec(2, len(picks), height_ratios=[1.3, 1])
    for j, k in enumerate(picks):
        ax = fig.add_subplot(grid[0, j])
        ax.imshow(frames[k], cmap="gray" if frames[k].ndim == 2 else None)
        ax.add_patch(
            Polygon(quads[k], closed=True, fill=False, color="tab:red", lw=1.5, label="estimate")
        )
        ax.set_title(f"frame {k + 1}, score {poses[k].score:.2f}", fontsize=7)
        ax.set_xticks([])
        ax.set_yticks([])
    ax = fig.add_subplot(grid[1, :])
    n = np.arange(1, len(poses) + 1)
    ax.plot(n, [p.score for p in poses], label="score (eq. 6 per point)")
    ax.plot(n, [p.occluded_fraction for p in poses], label="occluded fraction")
    ax.set_xlabel("frame")
    ax.set_ylabel("score / fraction (0-1)")
    ax.legend(loc="lower left", fontsize=8)
    fig.suptitle(title)
    return fig


def _draw_quad(frame: np.ndarray, quad: np.ndarray) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.fromarray(frame).convert("RGB")
    ImageDraw.Draw(im).polygon([tuple(p) for p in quad.tolist()], outline=(255, 0, 0))
    return np.asarray(im)


def load_truth(truth_folder: Path | None, source: Path) -> PlanarTruth | None:
    """The POT-210 ground truth of ``--truth``, else of SOURCE when it holds
    ``gt_corners.txt``, else None; read before tracking so a bad file fails at once."""
    from rperc.datasets import load_planar_truth

    folder = truth_folder
    if folder is None and source.is_dir() and (source / "gt_corners.txt").is_file():
        folder = source
    return None if folder is None else load_planar_truth(folder)


def pot_metrics(truth: PlanarTruth | None, quads: np.ndarray) -> dict[str, float]:
    """POT-210's numbers for the tracked corners ``(n, 4, 2)`` against ``truth``
    (frame 0 is the given region, not scored); nothing without a truth."""
    from rperc.tracking.planar import pot_score

    if truth is None:
        return {}
    if len(truth.corners) != len(quads):
        raise ValueError(
            f"the ground truth has {len(truth.corners)} frames, the source {len(quads)}"
        )
    s = pot_score(quads[1:], truth.corners[1:], truth.visible[1:])
    return {
        "scored_frames": s.frames,
        "mean_corner_error_px": s.mean_corner_error_px,
        "precision_at_5": s.precision_at_5,
        "precision_at_15": s.precision_at_15,
    }


def track_pattern_command(args: argparse.Namespace) -> int:
    from rperc.cli.track import strip_indices
    from rperc.tracking import PatternTracker

    _check_outputs(args)
    frames = load_frames(args.source)
    truth = load_truth(args.truth, args.source)
    if truth is not None and len(truth.corners) != len(frames):
        raise ValueError(
            f"the ground truth has {len(truth.corners)} frames, the source {len(frames)}"
        )
    picks = strip_indices(len(frames), args.frames) if args.strip else None
    region = args.region if args.corners is None else args.corners
    tracker = PatternTracker(frames[0], region, seed=args.seed, motion=args.motion)
    start = time.perf_counter()
    poses = [tracker.initial] + [
        tracker.update(f) for f in progress(frames[1:], desc="tracking", unit="frame")
    ]
    seconds = time.perf_counter() - start
    quads = np.array([p.corners_array() for p in poses])
    lost = sum(p.lost for p in poses)
    fps = (len(frames) - 1) / seconds if seconds > 0 else math.inf
    score = float(np.mean([p.score for p in poses[1:]]))
    metrics = pot_metrics(truth, quads)
    print(
        f"{args.source.name}: {len(frames)} frames, {tracker.n_points} model points, "
        f"lost in {lost} frames, mean score {score:.3f}, {fps:.0f} fps"
    )
    if metrics:
        print(
            f"against the truth ({metrics['scored_frames']} visible frames): mean corner "
            f"error {metrics['mean_corner_error_px']:.2f} px, precision at 5 px "
            f"{metrics['precision_at_5']:.2f}, at 15 px {metrics['precision_at_15']:.2f}"
        )
    if picks is not None:
        from rperc.plot import save

        title = (
            f"{args.source.name}: pattern tracker (paper [001]), {len(frames)} frames, lost {lost}"
        )
        wrote(save(_quad_strip(frames, picks, quads, poses, title), args.strip))
    if args.animation is not None:
        _write_animation(args.animation, frames, quads)
    write_json(
        args.json,
        {
            "source": str(args.source),
            "frames": len(frames),
            "motion": args.motion,
            "fps": fps,
            "lost_frames": int(lost),
            **metrics,
            "poses": [_pose_json(p) for p in poses],
        },
    )
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuses unwritable outputs, and an animation that is not a GIF or MP4 or has no
    imageio, before any frame is read."""
    check_output_file(args.strip, "--strip", figure=True)
    check_output_file(args.json, "--json")
    check_output_file(args.animation, "--animation")
    if args.animation is not None:
        if args.animation.suffix.lower() not in (".gif", ".mp4"):
            raise ValueError(f"--animation {args.animation} must end in .gif or .mp4")
        require("imageio.v3", "--animation")


def _write_animation(path: Path, frames: Sequence[np.ndarray], quads: np.ndarray) -> None:
    """Every frame with its tracked quadrilateral drawn, as a GIF or MP4 (imageio)."""
    import imageio.v3 as iio  # type: ignore[import-not-found,unused-ignore]

    drawn = [_draw_quad(f, q) for f, q in zip(frames, quads, strict=True)]
    write_atomically(path, lambda tmp: iio.imwrite(tmp, drawn))
    wrote(path)


def _pose_json(p: PatternPose) -> dict[str, object]:
    """One frame's pose as ``--json`` writes it."""
    return {
        "x": p.x,
        "y": p.y,
        "theta": p.theta,
        "scale": p.scale,
        "score": p.score,
        "occluded_fraction": p.occluded_fraction,
        "lost": p.lost,
        "corners": p.corners.tolist(),
        "homography": p.homography.tolist(),
    }
