"""rperc's trackers against OpenCV's on OTB sequences, in the same run: success AUC,
precision at 20 px and frames per second (tracking only; JPEG decoding excluded).

    python benchmarks/tracking.py [--sequences Girl Couple]

OpenCV peers (when opencv-python is installed): meanShift and CamShift on a hue
back-projection (as in OpenCV's tutorial), CSRT, KCF (``detect_thresh=0``, else it
gives up after a few frames) and MIL.
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

from rperc.datasets import data_dir, load_otb
from rperc.tracking.metrics import auc, iou, precision

try:
    import cv2
except ImportError:  # pragma: no cover - optional peer
    cv2 = None

Box = tuple[float, float, float, float]
# A tracker factory: (first frame RGB, first box) -> per-frame update returning a box.
Factory = Callable[[np.ndarray, Box], Callable[[np.ndarray], Box]]


def rperc_trackers() -> dict[str, Factory]:
    out: dict[str, Factory] = {}
    try:
        from rperc.tracking import ColorHistogramTracker, ParticleColorTracker
    except ImportError:
        return out

    def colour(frame: np.ndarray, box: Box):
        t = ColorHistogramTracker(frame, box)
        return lambda f: t.update(f).box

    def particles(frame: np.ndarray, box: Box):
        t = ParticleColorTracker(frame, box, seed=0)
        return lambda f: t.update(f).box

    out["rperc colour"] = colour
    out["rperc colour PF"] = particles
    return out


def opencv_trackers() -> dict[str, Factory]:
    if cv2 is None:
        return {}

    def hue_shift(camshift: bool) -> Factory:
        def make(frame: np.ndarray, box: Box):
            x, y, w, h = (round(v) for v in box)
            hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV)
            roi = hsv[y : y + h, x : x + w]
            mask = cv2.inRange(roi, np.array((0.0, 60.0, 32.0)), np.array((180.0, 255.0, 255.0)))
            hist = cv2.calcHist([roi], [0], mask, [16], [0, 180])
            cv2.normalize(hist, hist, 0, 255, cv2.NORM_MINMAX)
            term = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1)
            state = {"win": (x, y, max(w, 1), max(h, 1))}

            def update(f: np.ndarray) -> Box:
                back = cv2.calcBackProject(
                    [cv2.cvtColor(f, cv2.COLOR_RGB2HSV)], [0], hist, [0, 180], 1
                )
                if camshift:
                    _, win = cv2.CamShift(back, state["win"], term)
                else:
                    _, win = cv2.meanShift(back, state["win"], term)
                if win[2] > 0 and win[3] > 0:
                    state["win"] = win
                return tuple(float(v) for v in state["win"])

            return update

        return make

    def tracker(create: Callable[[], object]) -> Factory:
        def make(frame: np.ndarray, box: Box):
            t = create()
            t.init(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR), tuple(round(v) for v in box))
            last = {"box": box}

            def update(f: np.ndarray) -> Box:
                ok, b = t.update(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
                if ok:
                    last["box"] = tuple(float(v) for v in b)
                return last["box"]

            return update

        return make

    def kcf():
        params = cv2.TrackerKCF_Params()
        params.detect_thresh = 0.0
        return cv2.TrackerKCF_create(params)

    return {
        "OpenCV meanShift": hue_shift(False),
        "OpenCV CamShift": hue_shift(True),
        "OpenCV CSRT": tracker(cv2.TrackerCSRT_create),
        "OpenCV KCF": tracker(kcf),
        "OpenCV MIL": tracker(cv2.TrackerMIL_create),
    }


def run(factory: Factory, frames: list[np.ndarray], first: Box) -> tuple[np.ndarray, float]:
    t0 = time.perf_counter()
    update = factory(frames[0], first)
    boxes = [first]
    for f in frames[1:]:
        boxes.append(update(f))
    return np.asarray(boxes, dtype=float), time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sequences", nargs="+", default=["Girl", "Couple"])
    args = ap.parse_args()
    root = data_dir()
    if root is None:
        sys.exit("no data folder (set RPERC_DATA)")
    trackers = rperc_trackers() | opencv_trackers()
    results: dict[str, dict[str, tuple[float, float, float]]] = {name: {} for name in trackers}
    all_overlaps: dict[str, list[np.ndarray]] = {name: [] for name in trackers}
    for seq_name in args.sequences:
        seq = load_otb(root / "otb" / seq_name)
        frames = list(seq.frames())
        first = tuple(float(v) for v in seq.boxes[0])
        for name, factory in trackers.items():
            boxes, seconds = run(factory, frames, first)
            ov = iou(boxes, seq.boxes)
            all_overlaps[name].append(ov)
            results[name][seq_name] = (auc(ov), precision(boxes, seq.boxes), len(frames) / seconds)
    best_peer = max(
        (auc(np.concatenate(all_overlaps[n])) for n in trackers if n.startswith("OpenCV")),
        default=None,
    )
    rows = []
    for name in trackers:
        row = [name]
        for seq_name in args.sequences:
            a, p, fps = results[name][seq_name]
            row += [f"{a:.3f}", f"{p:.3f}", f"{fps:8.0f}"]
        total = auc(np.concatenate(all_overlaps[name]))
        row.append(f"{total:.3f}")
        row.append(f"{np.mean([results[name][s][0] for s in args.sequences]):.3f}")
        row.append(f"{total / best_peer:.2f}x" if best_peer else "-")
        rows.append(row)
    header = ["tracker"]
    for seq_name in args.sequences:
        header += [f"{seq_name} AUC", f"{seq_name} P@20", f"{seq_name} fps"]
    header += ["AUC all frames", "mean AUC", "vs best OpenCV"]
    print_table("OTB tracking (same run, same frames)", header, rows)


if __name__ == "__main__":
    main()
