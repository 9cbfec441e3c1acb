"""``rperc track`` and ``rperc demo tracking``.

- ``rperc track SEQ_DIR``: a tracker on any OTB-format folder (``img/`` and
  ``groundtruth_rect.txt``), scored against its ground truth;
- ``rperc track --all PARENT_DIR``: every OTB folder under a parent, one table row each;
- ``rperc track VIDEO --box x,y,w,h``: a video or GIF without ground truth (read with
  imageio), the boxes written with ``--csv``/``--json`` and the video with the box
  drawn with ``--video OUT.gif|OUT.mp4``;
- ``rperc demo tracking``: both colour trackers on a synthetic sequence.

``--json`` holds every frame's box, score and lost flag."""

from __future__ import annotations

import argparse
import itertools
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

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
from rperc.datasets import load_otb
from rperc.tracking import metrics
from rperc.tracking.runs import CLI_TRACKERS, TRACKERS, TrackerRun, run_tracker, scores

STRIP_FRAMES = 6


def add_commands(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "track", help="run a tracker on an OTB sequence or a video (AUC, precision, fps)"
    )
    p.add_argument(
        "sequence",
        type=Path,
        nargs="?",
        help="OTB sequence folder (img/, groundtruth_rect.txt), or a video/GIF file with --box",
    )
    p.add_argument(
        "--all",
        type=Path,
        metavar="PARENT_DIR",
        help="run on every OTB sequence folder in PARENT_DIR and print a table",
    )
    p.add_argument(
        "--box",
        type=box_type,
        metavar="X,Y,W,H",
        help="initial box of a video (0-based top-left corner, pixels)",
    )
    p.add_argument("--csv", type=Path, metavar="PATH", help="write every frame's box as CSV")
    p.add_argument(
        "--video",
        type=Path,
        metavar="PATH",
        help="write the frames with the box drawn (.gif, .mp4)",
    )
    p.add_argument(
        "--tracker",
        choices=CLI_TRACKERS,
        default="color-template",
        help="default color-template (colour + correlation-filter template)",
    )
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the particle filter")
    p.add_argument("--strip", type=Path, help="write a figure strip of annotated frames")
    p.add_argument(
        "--frames", type=count_at_least(2), default=8, help="frames in the strip (>= 2, default 8)"
    )
    add_json_option(p)
    p.set_defaults(run=track_command)


def box_type(text: str) -> tuple[float, float, float, float]:
    """An argparse type: ``x,y,w,h`` as four finite numbers with ``w, h > 0``."""
    parts = text.split(",")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected x,y,w,h (numbers), got {excerpt(text)}"
        ) from None
    if len(values) != 4 or not np.isfinite(values).all():
        raise argparse.ArgumentTypeError(f"expected 4 finite numbers x,y,w,h, got {excerpt(text)}")
    x, y, w, h = values
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"w and h must be > 0, got {excerpt(text)}")
    return (x, y, w, h)


def strip_indices(n_frames: int, count: int) -> np.ndarray:
    """``count`` distinct frame indices spread evenly from the first to the last."""
    if not 2 <= count <= n_frames:
        raise ValueError(f"--frames must be between 2 and {n_frames} (the sequence's frames)")
    return np.floor(np.linspace(0, n_frames - 1, count) + 0.5).astype(int)


def track_command(args: argparse.Namespace) -> int:
    check_output_file(args.strip, "--strip", figure=True)
    check_output_file(args.json, "--json")
    check_output_file(args.csv, "--csv")
    check_output_file(args.video, "--video")
    if args.video is not None and args.video.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"--video {args.video}: use a .gif or .mp4 file name")
    if (args.all is None) == (args.sequence is None):
        raise ValueError("give one sequence folder or video, or --all PARENT_DIR")
    if args.all is not None:
        return track_all(args)
    if args.sequence.is_file():
        return track_video(args)
    if args.box is not None:
        raise ValueError("--box is for a video file; an OTB folder starts from its first box")
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
    write_outputs(args, frames, run, {"sequence": seq.name, **s})
    return 0


VIDEO_SUFFIXES = (".gif", ".mp4")


def otb_folders(parent: Path) -> list[Path]:
    """The OTB sequence folders directly inside ``parent``, sorted by name."""
    if not parent.is_dir():
        raise ValueError(f"--all {parent}: not a folder")
    found = sorted(p for p in parent.iterdir() if (p / "groundtruth_rect.txt").is_file())
    if not found:
        raise ValueError(f"--all {parent}: no OTB sequence folder (img/, groundtruth_rect.txt)")
    return found


def track_all(args: argparse.Namespace) -> int:
    """One run per OTB folder under ``--all``: a table and the mean AUC and P@20."""
    if args.box is not None or args.strip or args.csv or args.video:
        raise ValueError("--all prints a table and writes --json only")
    rows = []
    for folder in otb_folders(args.all):
        seq = load_otb(folder)
        frames = [seq.frame(k) for k in range(len(seq))]
        run = run_tracker(args.tracker, frames, seq.boxes[0], args.seed)
        rows.append({"sequence": seq.name, **scores(run, seq.boxes)})
    print(f"tracker {args.tracker} on {len(rows)} sequences in {args.all}")
    print(f"{'sequence':<20} {'frames':>6} {'AUC':>6} {'P@20':>6} {'fps':>7} {'lost':>5}")
    for r in rows:
        print(
            f"{r['sequence']:<20} {r['frames']:>6d} {r['auc']:>6.3f} "
            f"{r['precision_20px']:>6.3f} {r['fps']:>7.0f} {r['lost_frames']:>5d}"
        )
    mean_auc = float(np.mean([r["auc"] for r in rows]))
    mean_p20 = float(np.mean([r["precision_20px"] for r in rows]))
    print(f"{'mean':<20} {'':>6} {mean_auc:>6.3f} {mean_p20:>6.3f}")
    summary = {"tracker": args.tracker, "mean_auc": mean_auc, "mean_precision_20px": mean_p20}
    write_json(args.json, {**summary, "sequences": rows})
    return 0


def read_video(path: Path) -> tuple[list[np.ndarray], float]:
    """The frames of a video or animated GIF as RGB arrays, and its frame rate."""
    iio = require("imageio.v3", f"reading {path}")
    frames = []
    # The file is closed (and ffmpeg's pipes with it) before the frames are tracked.
    with iio.imopen(path, "r") as video:
        meta = video.metadata()
        for frame in video.iter():
            arr = np.asarray(frame)
            if arr.ndim == 3 and arr.shape[2] == 4:
                arr = arr[:, :, :3]  # drop a GIF's alpha
            frames.append(np.ascontiguousarray(arr))
    if len(frames) < 2:
        raise ValueError(f"{path}: {len(frames)} frame(s); tracking needs at least 2")
    fps = float(meta.get("fps") or 0) or 1000.0 / float(meta.get("duration") or 40)
    return frames, fps


def track_video(args: argparse.Namespace) -> int:
    """A user's own video: no ground truth, so boxes, scores and fps only."""
    if args.box is None:
        raise ValueError(f"{args.sequence} is a file: give the initial box with --box x,y,w,h")
    if args.strip:
        raise ValueError("--strip needs ground truth (an OTB folder); use --video")
    frames, fps = read_video(args.sequence)
    run = run_tracker(args.tracker, frames, args.box, args.seed)
    rate = len(frames) / run.seconds if run.seconds > 0 else float("inf")
    print(
        f"{args.sequence.name}: {len(frames)} frames, tracker {args.tracker}: "
        f"{rate:.0f} fps, lost in {int(run.lost.sum())} frames"
    )
    measured = {
        "video": args.sequence.name,
        "tracker": run.name,
        "frames": len(frames),
        "fps": rate,
        "lost_frames": int(run.lost.sum()),
        "boxes": run.boxes,
        "scores": run.scores,
        "lost": run.lost,
    }
    if run.contours is not None:
        measured["contours"] = [np.asarray(c).tolist() for c in run.contours]
    write_outputs(args, frames, run, measured, video_fps=fps)
    return 0


def write_outputs(
    args: argparse.Namespace,
    frames: Sequence[np.ndarray],
    run: TrackerRun,
    measured: Mapping[str, object],
    video_fps: float = 25.0,
) -> None:
    """``--json`` (``measured``), ``--csv`` (one box per frame) and ``--video``."""
    write_json(args.json, measured)
    if args.csv is not None:
        write_boxes_csv(args.csv, run)
        wrote(args.csv)
    if args.video is not None:
        write_annotated(args.video, frames, run, video_fps)
        wrote(args.video)


def write_boxes_csv(path: Path, run: TrackerRun) -> None:
    """``frame,x,y,w,h,score,lost`` per frame (0-based frame index and corner)."""
    scores = run.scores if run.scores is not None else np.ones(len(run.boxes))
    lines = ["frame,x,y,w,h,score,lost"]
    for k, (b, sc, lo) in enumerate(zip(run.boxes, scores, run.lost, strict=True)):
        lines.append(f"{k},{b[0]:.2f},{b[1]:.2f},{b[2]:.2f},{b[3]:.2f},{sc:.4f},{int(lo)}")
    write_text_atomically(path, "\n".join(lines) + "\n")


def draw_box(frame: np.ndarray, box: Sequence[float], colour: Sequence[int]) -> np.ndarray:
    """A copy of ``frame`` (RGB or greyscale) with a 2-pixel outline of ``box``."""
    out = np.array(frame, dtype=np.uint8, copy=True)
    if out.ndim == 2:
        out = np.repeat(out[:, :, None], 3, axis=2)
    h, w = out.shape[:2]
    x0, y0 = round(box[0]), round(box[1])
    x1, y1 = round(box[0] + box[2]) - 1, round(box[1] + box[3]) - 1
    xs = slice(max(x0, 0), min(x1 + 1, w))
    ys = slice(max(y0, 0), min(y1 + 1, h))
    for t in range(2):
        if 0 <= y0 + t < h:
            out[y0 + t, xs] = colour
        if 0 <= y1 - t < h:
            out[y1 - t, xs] = colour
        if 0 <= x0 + t < w:
            out[ys, x0 + t] = colour
        if 0 <= x1 - t < w:
            out[ys, x1 - t] = colour
    return out


TRACKING_COLOUR, LOST_COLOUR = (255, 40, 40), (255, 220, 0)


def draw_contour(frame: np.ndarray, contour: np.ndarray, colour: Sequence[int]) -> np.ndarray:
    """A copy of ``frame`` (RGB) with the closed polygon ``contour`` ((M, 2) pixel
    centres ``(x, y)``) drawn one pixel wide."""
    from PIL import Image, ImageDraw

    im = Image.fromarray(np.asarray(frame, dtype=np.uint8)).convert("RGB")
    # PIL truncates coordinates; pixel centres are at integers, so round them.
    points = [(int(x), int(y)) for x, y in np.rint(np.asarray(contour, dtype=float))]
    ImageDraw.Draw(im).line(points + points[:1], fill=tuple(int(c) for c in colour), width=1)
    return np.asarray(im)


def write_annotated(path: Path, frames: Sequence[np.ndarray], run: TrackerRun, fps: float) -> None:
    """The frames with the tracker's box drawn, and for color-shape its contour: red
    while tracking, yellow when lost."""
    iio = require("imageio.v3", f"writing {path}")
    drawn_frames = []
    for k, (f, b, lost) in enumerate(zip(frames, run.boxes, run.lost, strict=True)):
        colour = LOST_COLOUR if lost else TRACKING_COLOUR
        out = draw_box(f, b, colour)
        if run.contours is not None:
            out = draw_contour(out, run.contours[k], colour)
        drawn_frames.append(out)
    drawn = np.stack(drawn_frames)
    if path.suffix.lower() == ".gif":
        write_atomically(path, lambda tmp: iio.imwrite(tmp, drawn, duration=1000.0 / fps, loop=0))
    else:

        def write_video(tmp: Path) -> None:
            iio.imwrite(tmp, drawn, fps=fps, codec="libx264", macro_block_size=1)

        write_atomically(path, write_video)


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
    """The colour+shape tracker against colour alone on the four experiments of paper [000]
    section 3.4 (Fig. 13), each scored on the generator's truth masks (contour) and
    their boxes: circles changing colour (RGB), a rectangle under changing light with a
    moving specular highlight, a deforming blob, and a blob among same-coloured
    distractors (opponent space). Each line also gives the frames the colour+shape
    tracker reported lost, how often it found a lost target again, and its update rate.
    One figure per experiment, and the path of the tracked colour distribution against
    the circle's true colour (Fig. 13, upper left)."""
    from rperc.plot import save
    from rperc.tracking.shape_sequences import EXPERIMENTS

    lines, figures, experiments = [], [], {}
    rectangle: dict[str, Any] = {}
    for name in EXPERIMENTS:
        run = _color_shape_run(name, frames, seed)
        figures.append(save(_color_shape_strip(run, seed), out / f"color_shape_{name}.png"))
        experiments[name] = {k: run[k] for k in ("contour_iou", "box_iou", "lost", "fps")}
        experiments[name]["reacquired"] = run["reacquired"]
        iou, box = np.mean(run["contour_iou"]), run["box_iou"]
        lines.append(
            f"{name} experiment ({len(run['seq'])} frames, seed {seed}) against its truth "
            f"masks: color-shape contour IoU {iou:.3f}, box IoU {box['color-shape']:.3f}, "
            f"lost in {sum(run['lost'])} frames, re-acquired {run['reacquired']} times, "
            f"{run['fps']:.0f} fps; color only box IoU {box['color']:.3f}"
        )
        if name == "rectangle":
            rectangle = run
        if name == "circles":
            figures.append(save(_colour_path_figure(run, seed), out / "color_shape_path.png"))
    # The rectangle first: the line the demo's tests read.
    lines.sort(key=lambda line: not line.startswith("rectangle"))
    summary = "color-shape: " + "; ".join(lines)
    measured = {
        "contour_iou": rectangle["contour_iou"],
        "box_iou": rectangle["box_iou"],
        "contours": [np.asarray(c).tolist() for c in rectangle["contours"]],
        "experiments": experiments,
    }
    return DemoResult(summary, figures, measured)


def _color_shape_run(name: str, frames: int, seed: int) -> dict[str, Any]:
    """Both trackers over one experiment: contours, boxes, distributions and scores."""
    from rperc.config import AppearanceParams
    from rperc.tracking import ColorHistogramTracker, ColorShapeTracker
    from rperc.tracking.shape_sequences import shape_sequence

    seq = shape_sequence(name, frames=frames, seed=seed)  # type: ignore[arg-type]
    truth = np.array([_mask_box(m) for m in seq.masks])
    cs = ColorShapeTracker(seq.frames[0], contour=seq.outline, color_space=seq.color_space)
    co = ColorHistogramTracker(
        seq.frames[0], tuple(truth[0]), appearance=AppearanceParams(color_space=seq.color_space)
    )
    contours, cs_boxes, co_boxes, dists = [seq.outline], [truth[0]], [truth[0]], []
    lost, update_seconds = [], 0.0
    for frame in seq.frames[1:]:
        start = time.perf_counter()
        r = cs.update(frame)
        update_seconds += time.perf_counter() - start
        lost.append(r.lost)
        contours.append(r.contour)
        cs_boxes.append(np.asarray(r.box))
        co_boxes.append(np.asarray(co.update(frame).box))
        dists.append(r.distribution)
    shape = seq.masks.shape[1:]
    contour_iou = [
        metrics.mask_iou(metrics.polygon_mask(c, shape), m)
        for c, m in zip(contours[1:], seq.masks[1:], strict=True)
    ]
    tracks = {"color-shape": np.asarray(cs_boxes), "color": np.asarray(co_boxes)}
    box_iou = {n: float(metrics.iou(b[1:], truth[1:]).mean()) for n, b in tracks.items()}
    return {
        "seq": seq,
        "truth": truth,
        "tracks": tracks,
        "contours": contours,
        "distributions": np.asarray(dists),
        "contour_iou": contour_iou,
        "box_iou": box_iou,
        "lost": lost,
        # Frames where a lost target is found again (lost, then not).
        "reacquired": sum(a and not b for a, b in itertools.pairwise(lost)),
        "fps": (len(seq) - 1) / update_seconds,
    }


def _color_shape_strip(run: dict[str, Any], seed: int) -> Any:
    from rperc.plot.tracking import strip_figure

    seq = run["seq"]
    picks = strip_indices(len(seq), STRIP_FRAMES)
    return strip_figure(
        [seq.frames[k] for k in picks],
        picks,
        run["truth"],
        run["tracks"],
        title=f"{seq.name} ({seq.color_space}), seed {seed}, {len(seq)} frames; "
        f"color-shape contour IoU {np.mean(run['contour_iou']):.3f}",
        truth_label="truth (generator)",
        contours={"color-shape": run["contours"]},
    )


def _colour_path_figure(run: dict[str, Any], seed: int) -> Any:
    """Fig. 13 (upper left): the tracked colour distribution's centroid against the
    target's true mean colour, frame by frame, in RGB units of [0, 1)."""
    from matplotlib.figure import Figure

    seq, est = run["seq"], run["distributions"][:, :3]
    pairs = zip(seq.frames[1:], seq.masks[1:], strict=True)
    truth = np.array([f[m].mean(axis=0) / 256.0 for f, m in pairs])
    err = np.linalg.norm(est - truth, axis=1)
    fig = Figure(figsize=(10, 3.6), layout="constrained")
    axes = [(0, 1, "R", "G"), (0, 2, "R", "B"), (1, 2, "G", "B")]
    for j, (a, b, la, lb) in enumerate(axes):
        ax = fig.add_subplot(1, 3, j + 1)
        ax.plot(truth[:, a], truth[:, b], "k-", lw=1.5, label="truth (mean colour in mask)")
        ax.plot(est[:, a], est[:, b], "r--", lw=1.2, label="estimate (distribution centroid)")
        ax.plot(truth[0, a], truth[0, b], "ko", ms=4)
        ax.set_xlabel(f"{la} (fraction of 256)")
        ax.set_ylabel(f"{lb} (fraction of 256)")
        if j == 0:
            ax.legend(fontsize=7)
    fig.suptitle(
        f"colour path of the tracked circle (paper [000], Fig. 13), seed {seed}, "
        f"{len(seq)} frames; centroid error mean {err.mean():.3f}, max {err.max():.3f}"
    )
    return fig


def _mask_box(mask: np.ndarray) -> tuple[float, float, float, float]:
    ys, xs = np.nonzero(mask)
    return (float(xs.min()), float(ys.min()), float(np.ptp(xs) + 1), float(np.ptp(ys) + 1))
