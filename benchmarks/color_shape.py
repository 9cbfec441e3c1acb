"""The colour+shape tracker on the four experiments of seed 000 section 3.4 (seeded
synthetic sequences with truth masks), against colour alone and OpenCV CSRT, in the
same run: contour IoU against the truth mask, box IoU against the mask's box for every
tracker, lost frames, and frames per second (tracking only; frames are generated
before timing starts).

    python benchmarks/color_shape.py [--frames 150] [--seeds 200 201 202 203 204]

The seed draws each sequence's colours, sizes, paths, distractors and noise. The
colour+shape defaults were developed on seeds 3 and 100 of an earlier generator whose
paths did not depend on the seed; seeds 200-204 of this one were first run after the
defaults were fixed, so the reported scores come from sequences nobody tuned on. All
trackers start from frame 0's truth: the colour+shape tracker from the target's outline,
the others from its box. Threads: rayon's pool (set RAYON_NUM_THREADS to change it).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import print_table

from rperc.bench.allocator import steady_allocator
from rperc.config import AppearanceParams
from rperc.tracking import ColorHistogramTracker, ColorShapeTracker
from rperc.tracking.metrics import iou, mask_iou, polygon_mask
from rperc.tracking.shape_sequences import EXPERIMENTS, ShapeSequence, shape_sequence

try:
    import cv2
except ImportError:  # pragma: no cover - optional peer
    cv2 = None

Box = tuple[float, float, float, float]


def mask_box(mask: np.ndarray) -> Box:
    ys, xs = np.nonzero(mask)
    return (float(xs.min()), float(ys.min()), float(np.ptp(xs) + 1), float(np.ptp(ys) + 1))


def run_color_shape(seq: ShapeSequence) -> tuple[list[float], list[Box], int, float]:
    t0 = time.perf_counter()
    tracker = ColorShapeTracker(seq.frames[0], contour=seq.outline, color_space=seq.color_space)
    ious, boxes, lost = [], [], 0
    elapsed = 0.0
    for k in range(1, len(seq)):
        t0 = time.perf_counter()
        r = tracker.update(seq.frames[k])
        elapsed += time.perf_counter() - t0
        ious.append(mask_iou(polygon_mask(r.contour, seq.masks.shape[1:]), seq.masks[k]))
        boxes.append(r.box)
        lost += r.lost
    return ious, boxes, lost, elapsed


def run_box_tracker(
    seq: ShapeSequence, make: Callable[[np.ndarray, Box], Callable[[np.ndarray], Box]]
) -> tuple[list[Box], float]:
    update = make(seq.frames[0], mask_box(seq.masks[0]))
    boxes, elapsed = [], 0.0
    for k in range(1, len(seq)):
        t0 = time.perf_counter()
        boxes.append(update(seq.frames[k]))
        elapsed += time.perf_counter() - t0
    return boxes, elapsed


def colour_only(space: str) -> Callable[[np.ndarray, Box], Callable[[np.ndarray], Box]]:
    def make(frame: np.ndarray, box: Box) -> Callable[[np.ndarray], Box]:
        t = ColorHistogramTracker(frame, box, appearance=AppearanceParams(color_space=space))  # type: ignore[arg-type]
        return lambda f: t.update(f).box

    return make


def csrt(frame: np.ndarray, box: Box) -> Callable[[np.ndarray], Box]:
    t = cv2.TrackerCSRT_create()
    t.init(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR), tuple(round(v) for v in box))
    last = {"box": box}

    def update(f: np.ndarray) -> Box:
        ok, b = t.update(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
        if ok:
            last["box"] = tuple(float(v) for v in b)  # type: ignore[assignment]
        return last["box"]

    return update


def box_iou(boxes: list[Box], seq: ShapeSequence) -> float:
    truth = np.array([mask_box(m) for m in seq.masks[1:]])
    return float(np.mean(iou(np.asarray(boxes, float), truth)))


def main() -> None:
    # Peers and rperc timed with the same allocator behaviour (rperc.bench.allocator).
    steady_allocator()
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--seeds", type=int, nargs="+", default=[200, 201, 202, 203, 204])
    args = ap.parse_args()
    rows, speed = [], {"colour+shape": 0.0, "colour only": 0.0, "OpenCV CSRT": 0.0}
    n_frames = 0
    for name in EXPERIMENTS:
        acc: dict[str, list[float]] = {k: [] for k in ("cs", "csb", "co", "csrt", "lost")}
        for seed in args.seeds:
            seq = shape_sequence(name, frames=args.frames, seed=seed)
            ious, boxes, lost, el = run_color_shape(seq)
            acc["cs"].append(float(np.mean(ious)))
            acc["csb"].append(box_iou(boxes, seq))
            acc["lost"].append(lost)
            speed["colour+shape"] += el
            b, el = run_box_tracker(seq, colour_only(seq.color_space))
            acc["co"].append(box_iou(b, seq))
            speed["colour only"] += el
            if cv2 is not None:
                b, el = run_box_tracker(seq, csrt)
                acc["csrt"].append(box_iou(b, seq))
                speed["OpenCV CSRT"] += el
            n_frames += len(seq) - 1
        rows.append(
            [
                name,
                f"{np.mean(acc['cs']):.3f}",
                f"{np.mean(acc['csb']):.3f}",
                f"{np.mean(acc['co']):.3f}",
                f"{np.mean(acc['csrt']):.3f}" if acc["csrt"] else "n/a",
                f"{np.mean(acc['lost']):.1f} / {args.frames - 1}",
            ]
        )
    header = [
        "experiment",
        "colour+shape contour IoU",
        "colour+shape box IoU",
        "colour only box IoU",
        "CSRT box IoU",
        "lost (colour+shape)",
    ]
    print_table(f"seed 000 s3.4, seeds {args.seeds}, {args.frames} frames", header, rows)
    fps = {k: n_frames / v for k, v in speed.items() if v > 0}
    base = fps["colour+shape"]
    srows = [[k, f"{v:.0f}", f"{v / base:.2f}"] for k, v in fps.items()]
    print_table(
        "speed, 320 x 240, 100 samples", ["tracker", "frames / s", "ratio to colour+shape"], srows
    )


if __name__ == "__main__":
    main()
