"""``rperc track SEQ_DIR`` (a tracker on an OTB sequence, scored against its ground
truth) and ``rperc demo tracking`` (both trackers on a synthetic sequence)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rperc._progress import progress
from rperc.cli.demo import DemoResult
from rperc.cli.outputs import (
    add_json_option,
    check_output_file,
    count_at_least,
    seed_type,
    write_json,
    wrote,
)
from rperc.datasets import load_otb
from rperc.tracking import metrics

TRACKERS = ("color", "color-pf")
# The colour+shape tracker is offered by `rperc track` only: the tracking demo's scores
# are of the two colour trackers.
CLI_TRACKERS = (*TRACKERS, "color-shape")
STRIP_FRAMES = 6


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("track", help="run a tracker on an OTB sequence (AUC, precision, fps)")
    p.add_argument("sequence", type=Path, help="OTB sequence folder (img/, groundtruth_rect.txt)")
    p.add_argument("--tracker", choices=CLI_TRACKERS, default="color")
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the particle filter")
    p.add_argument("--strip", type=Path, help="write a figure strip of annotated frames")
    p.add_argument(
        "--frames", type=count_at_least(2), default=8, help="frames in the strip (>= 2, default 8)"
    )
    add_json_option(p)
    p.set_defaults(run=track_command)


@dataclass(frozen=True)
class TrackerRun:
    """A tracker over a whole sequence: one box per frame (frame 0 holds the initial
    box), whether the tracker flagged the target lost, and the seconds it took."""

    name: str
    boxes: np.ndarray  # (N, 4)
    lost: np.ndarray  # (N,) bool
    seconds: float
    contours: tuple[np.ndarray, ...] | None = None  # (M, 2) per frame, color-shape only


def run_tracker(
    name: str, frames: Sequence[np.ndarray] | np.ndarray, first_box: Sequence[float], seed: int
) -> TrackerRun:
    """Run tracker ``name`` from ``first_box`` over ``frames``. This is the one place
    that calls the trackers' Python API (construction and ``update``)."""
    from rperc.tracking import ColorHistogramTracker, ColorShapeTracker, ParticleColorTracker

    x, y, w, h = (float(v) for v in first_box)
    box = (x, y, w, h)
    start = time.perf_counter()
    if name == "color":
        tracker: Any = ColorHistogramTracker(frames[0], box)
    elif name == "color-pf":
        tracker = ParticleColorTracker(frames[0], box, seed=seed)
    elif name == "color-shape":
        tracker = ColorShapeTracker(frames[0], box, seed=seed)
    else:
        raise ValueError(f"unknown tracker {name!r}; expected one of {', '.join(CLI_TRACKERS)}")
    boxes: list[tuple[float, ...]] = [box]
    lost = [False]
    corners = np.array([[x, y], [x + w - 1, y], [x + w - 1, y + h - 1], [x, y + h - 1]])
    contours: list[np.ndarray] = [corners]
    for frame in progress(frames[1:], desc=f"tracking ({name})", unit="frame"):
        r = tracker.update(frame)
        boxes.append(tuple(r.box))
        lost.append(bool(r.lost))
        contours.append(getattr(r, "contour", corners))
    seconds = time.perf_counter() - start
    shapes = tuple(contours) if name == "color-shape" else None
    return TrackerRun(name, np.asarray(boxes, dtype=np.float64), np.asarray(lost), seconds, shapes)


def scores(run: TrackerRun, truth: np.ndarray) -> dict[str, Any]:
    """The OTB scores of ``run`` against ``truth`` (every frame, the first included)."""
    overlaps = metrics.iou(run.boxes, truth)
    return {
        "tracker": run.name,
        "frames": len(truth),
        "auc": metrics.auc(overlaps),
        "precision_20px": metrics.precision(run.boxes, truth),
        "mean_iou": float(overlaps.mean()),
        "lost_frames": int(run.lost.sum()),
        "fps": len(truth) / run.seconds if run.seconds > 0 else float("inf"),
        "boxes": run.boxes,
    }


def strip_indices(n_frames: int, count: int) -> np.ndarray:
    """``count`` distinct frame indices spread evenly from the first to the last."""
    if not 2 <= count <= n_frames:
        raise ValueError(f"--frames must be between 2 and {n_frames} (the sequence's frames)")
    return np.floor(np.linspace(0, n_frames - 1, count) + 0.5).astype(int)


def track_command(args: argparse.Namespace) -> int:
    check_output_file(args.strip, "--strip", figure=True)
    check_output_file(args.json, "--json")
    seq = load_otb(args.sequence)
    picks = strip_indices(len(seq), args.frames) if args.strip else None
    frames = [seq.frame(k) for k in progress(range(len(seq)), desc="decoding", unit="frame")]
    run = run_tracker(args.tracker, frames, seq.boxes[0], args.seed)
    s = scores(run, seq.boxes)
    print(
        f"{seq.name}: {len(seq)} frames, tracker {args.tracker}: "
        f"AUC {s['auc']:.3f}, precision@20px {s['precision_20px']:.3f}, "
        f"{s['fps']:.0f} fps, lost in {s['lost_frames']} frames"
    )
    if picks is not None:
        from rperc.plot import save
        from rperc.plot.tracking import strip_figure

        fig = strip_figure(
            [frames[k] for k in picks],
            picks,
            seq.boxes,
            {args.tracker: run.boxes},
            title=f"{seq.name} (OTB), {len(seq)} frames",
            truth_label="ground truth (OTB)",
            contours={args.tracker: run.contours} if run.contours else None,
        )
        wrote(save(fig, args.strip))
    write_json(args.json, {"sequence": seq.name, **s})
    return 0


def demo_tracking(out: Path, seed: int, frames: int = 150) -> DemoResult:
    """Both colour trackers on a seeded synthetic sequence whose boxes are known."""
    from rperc.plot import save
    from rperc.plot.tracking import strip_figure
    from rperc.tracking.synthetic import synthetic_sequence

    seq = synthetic_sequence(frames, seed=seed)
    runs = [run_tracker(name, seq.frames, seq.boxes[0], seed) for name in TRACKERS]
    measured = {run.name: scores(run, seq.boxes) for run in runs}
    picks = strip_indices(len(seq), STRIP_FRAMES)
    height, width = seq.frames.shape[1:3]
    fig = strip_figure(
        [seq.frames[k] for k in picks],
        picks,
        seq.boxes,
        {run.name: run.boxes for run in runs},
        title=f"synthetic sequence, seed {seed}, {len(seq)} frames of {width} x {height} px",
        truth_label="truth (generator)",
    )
    figures = [save(fig, out / "tracking.png")]
    summary = (
        f"tracking: {len(seq)}-frame synthetic sequence (seed {seed}) against its known boxes: "
        + "; ".join(
            f"{n} AUC {m['auc']:.3f}, precision@20px {m['precision_20px']:.3f}, "
            f"mean IoU {m['mean_iou']:.3f}"
            for n, m in measured.items()
        )
    )
    return DemoResult(summary, figures, {"sequence": seq.name, "trackers": measured})


def demo_color_shape(out: Path, seed: int, frames: int = 60) -> DemoResult:
    """The colour+shape tracker against colour alone on experiment 2 of seed 000 section
    3.4 (a rectangle under changing light with a moving specular highlight), scored on
    the generator's truth masks (contour) and their boxes."""
    from rperc.plot import save
    from rperc.plot.tracking import strip_figure
    from rperc.tracking import ColorHistogramTracker, ColorShapeTracker
    from rperc.tracking.shape_sequences import shape_sequence

    seq = shape_sequence("rectangle", frames=frames, seed=seed)
    shape = seq.masks.shape[1:]
    truth = np.array([_mask_box(m) for m in seq.masks])
    cs = ColorShapeTracker(seq.frames[0], contour=seq.outline, color_space=seq.color_space)
    co = ColorHistogramTracker(seq.frames[0], tuple(truth[0]), color_space=seq.color_space)
    contours, cs_boxes, co_boxes = [seq.outline], [truth[0]], [truth[0]]
    for frame in seq.frames[1:]:
        r = cs.update(frame)
        contours.append(r.contour)
        cs_boxes.append(np.asarray(r.box))
        co_boxes.append(np.asarray(co.update(frame).box))
    contour_iou = [
        metrics.mask_iou(metrics.polygon_mask(c, shape), m)
        for c, m in zip(contours[1:], seq.masks[1:], strict=True)
    ]
    tracks = {"color-shape": np.asarray(cs_boxes), "color": np.asarray(co_boxes)}
    box_iou = {n: float(metrics.iou(b[1:], truth[1:]).mean()) for n, b in tracks.items()}
    picks = strip_indices(len(seq), STRIP_FRAMES)
    fig = strip_figure(
        [seq.frames[k] for k in picks],
        picks,
        truth,
        tracks,
        title=f"rectangle under changing light, seed {seed}, {len(seq)} frames; "
        f"color-shape contour IoU {np.mean(contour_iou):.3f}",
        truth_label="truth (generator)",
        contours={"color-shape": contours},
    )
    figures = [save(fig, out / "color_shape.png")]
    summary = (
        f"color_shape: rectangle experiment ({len(seq)} frames, seed {seed}) against its "
        f"truth masks: color-shape contour IoU {np.mean(contour_iou):.3f}, box IoU "
        f"{box_iou['color-shape']:.3f}; color only box IoU {box_iou['color']:.3f}"
    )
    measured = {
        "contour_iou": contour_iou,
        "box_iou": box_iou,
        "contours": [np.asarray(c).tolist() for c in contours],
    }
    return DemoResult(summary, figures, measured)


def _mask_box(mask: np.ndarray) -> tuple[float, float, float, float]:
    ys, xs = np.nonzero(mask)
    return (float(xs.min()), float(ys.min()), float(np.ptp(xs) + 1), float(np.ptp(ys) + 1))
