"""``rperc track SEQ_DIR``: run a tracker on an OTB sequence and score it."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from rperc.datasets import load_otb
from rperc.tracking import metrics

TRACKERS = ("colour", "colour-pf")


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("track", help="run a tracker on an OTB sequence (AUC, precision, fps)")
    p.add_argument("sequence", type=Path, help="OTB sequence folder (img/, groundtruth_rect.txt)")
    p.add_argument("--tracker", choices=TRACKERS, default="colour")
    p.add_argument("--seed", type=int, default=0, help="seed of the particle filter")
    p.add_argument("--strip", type=Path, help="write a PNG strip of annotated frames")
    p.add_argument("--frames", type=int, default=8, help="frames in the strip (default 8)")
    p.set_defaults(run=track_command)


def make_tracker(name: str, frame: np.ndarray, box: tuple[float, ...], seed: int):
    from rperc.tracking import ColorHistogramTracker, ParticleColorTracker

    if name == "colour":
        return ColorHistogramTracker(frame, box)
    return ParticleColorTracker(frame, box, seed=seed)


def track_command(args: argparse.Namespace) -> int:
    seq = load_otb(args.sequence)
    frames = [
        seq.frame(k) for k in tqdm(range(len(seq)), desc="decoding", unit="frame", disable=None)
    ]
    first = tuple(float(v) for v in seq.boxes[0])
    boxes = [first]
    lost_count = 0
    t0 = time.perf_counter()
    tracker = make_tracker(args.tracker, frames[0], first, args.seed)
    for frame in tqdm(frames[1:], desc=f"tracking ({args.tracker})", unit="frame", disable=None):
        box, _score, lost = tracker.update(frame)
        boxes.append(tuple(box))
        lost_count += bool(lost)
    seconds = time.perf_counter() - t0
    pred = np.asarray(boxes)
    overlaps = metrics.iou(pred, seq.boxes)
    auc = metrics.auc(overlaps)
    precision = metrics.precision(pred, seq.boxes)
    print(
        f"{seq.name}: {len(seq)} frames, tracker {args.tracker}: "
        f"AUC {auc:.3f}, precision@20px {precision:.3f}, "
        f"{len(frames) / seconds:.0f} fps, lost in {lost_count} frames"
    )
    if args.strip:
        from rperc.plot import save
        from rperc.plot.tracking import strip_figure

        picks = np.linspace(0, len(frames) - 1, max(args.frames, 2)).round().astype(int)
        fig = strip_figure([frames[k] for k in picks], pred[picks], seq.boxes[picks], picks)
        print(f"wrote {save(fig, args.strip)}")
    return 0
