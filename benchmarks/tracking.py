"""rperc's trackers against OpenCV's on OTB sequences and the seeded challenge
sequences, in the same run: success AUC, precision at 20 px and frames per second
(tracking only; JPEG decoding excluded), the lost flag's precision and recall against
the frames where IoU = 0, and the particle trackers' mean effective sample size.

    python benchmarks/tracking.py [--sequences Girl Couple] [--challenge-seed 7]
                                  [--shape-seed 200]

Sequences: the OTB folders named (Girl, Couple), the four challenge sequences of
``benchmarks/challenges.py`` (fast, scale, occlusion, distractors) and the four
experiments of seed 000 s3.4 from ``rperc.tracking.shape_sequences`` (circles,
rectangle, nonrigid, clutter; scored on the boxes of their truth masks). Every tracker
starts from the first truth box.

What was tuned on what: the colour trackers' defaults on the challenge sequences of
seeds 0-2 and on Couple (their appearance defaults, older, on Girl and Couple); the
pyramid search was checked on seeds 0-1 and Couple. The colour+shape defaults on shape
seeds 3 and 100 of an earlier generator, and on Couple while looking for why it failed
on real video (Girl was looked at too, once, for the same reason). Held out: challenge
seed 7, shape seed 200 and, for the colour trackers, Girl. "before" rows run the colour
trackers with the issue-14 terms switched off (the previous defaults).

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

from rperc.bench.allocator import steady_allocator
from rperc.datasets import data_dir, load_otb
from rperc.tracking.metrics import auc, iou, precision
from rperc.tracking.shape_sequences import EXPERIMENTS, shape_sequence

from challenges import CHALLENGES, challenge_sequence

try:
    import cv2
except ImportError:  # pragma: no cover - optional peer
    cv2 = None

Box = tuple[float, float, float, float]
# What one update gives: the box, whether the tracker says the target is lost, and the
# particle set's ESS (None for other trackers).
Step = tuple[Box, bool, float | None]
# A tracker factory: (first frame RGB, first box) -> per-frame update.
Factory = Callable[[np.ndarray, Box], Callable[[np.ndarray], Step]]

# The issue-14 terms off: the colour trackers as they were before.
BEFORE_COLOUR = {
    "velocity_gain": 0.0,
    "lost_ratio": 0.0,
    "lost_contrast": -1.0,
    "ring_weight": 0.0,
    "scale_prior": 0.0,
}
BEFORE_PARTICLE = {"mix_fraction": 0.0}


def rperc_trackers() -> dict[str, Factory]:
    out: dict[str, Factory] = {}
    try:
        from rperc.tracking import ColorHistogramTracker, ColorShapeTracker, ParticleColorTracker
    except ImportError:
        return out

    def colour(**params: float) -> Factory:
        def make(frame: np.ndarray, box: Box):
            t = ColorHistogramTracker(frame, box, **params)

            def update(f: np.ndarray) -> Step:
                r = t.update(f)
                return r.box, r.lost, None

            return update

        return make

    def particles(**params: float) -> Factory:
        def make(frame: np.ndarray, box: Box):
            t = ParticleColorTracker(frame, box, seed=0, **params)

            def update(f: np.ndarray) -> Step:
                r = t.update(f)
                return r.box, r.lost, t.ess

            return update

        return make

    def shape(frame: np.ndarray, box: Box):
        t = ColorShapeTracker(frame, box, seed=0)

        def update(f: np.ndarray) -> Step:
            r = t.update(f)
            return r.box, r.lost, r.ess

        return update

    out["rperc colour"] = colour()
    out["rperc colour (before)"] = colour(**BEFORE_COLOUR)
    out["rperc colour PF"] = particles()
    out["rperc colour PF (before)"] = particles(**BEFORE_PARTICLE)
    out["rperc colour+shape"] = shape
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

            def update(f: np.ndarray) -> Step:
                back = cv2.calcBackProject(
                    [cv2.cvtColor(f, cv2.COLOR_RGB2HSV)], [0], hist, [0, 180], 1
                )
                if camshift:
                    _, win = cv2.CamShift(back, state["win"], term)
                else:
                    _, win = cv2.meanShift(back, state["win"], term)
                if win[2] > 0 and win[3] > 0:
                    state["win"] = win
                return tuple(float(v) for v in state["win"]), False, None

            return update

        return make

    def tracker(create: Callable[[], object]) -> Factory:
        def make(frame: np.ndarray, box: Box):
            t = create()
            t.init(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR), tuple(round(v) for v in box))
            last = {"box": box}

            def update(f: np.ndarray) -> Step:
                ok, b = t.update(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
                if ok:
                    last["box"] = tuple(float(v) for v in b)
                return last["box"], not ok, None

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


# Per (tracker, sequence): AUC, P@20, fps, lost precision, lost recall, mean ESS.
Row = tuple[float, float, float, float, float, float]


def run(factory: Factory, frames: list[np.ndarray], truth: np.ndarray) -> Row:
    first = tuple(float(v) for v in truth[0])
    t0 = time.perf_counter()
    update = factory(frames[0], first)
    steps = [update(f) for f in frames[1:]]
    seconds = time.perf_counter() - t0
    boxes = np.asarray([first] + [b for b, _, _ in steps], dtype=float)
    overlaps = iou(boxes, truth)
    zero = overlaps[1:] == 0
    lost = np.array([lo for _, lo, _ in steps])
    hits = int((lost & zero).sum())
    lost_precision = hits / lost.sum() if lost.any() else float("nan")
    lost_recall = hits / zero.sum() if zero.any() else float("nan")
    ess = [e for _, _, e in steps if e is not None]
    mean_ess = float(np.mean(ess)) if ess else float("nan")
    fps = len(frames) / seconds
    return (auc(overlaps), precision(boxes, truth), fps, lost_precision, lost_recall, mean_ess)


def mask_boxes(masks: np.ndarray) -> np.ndarray:
    """The (x, y, w, h) box of each truth mask."""
    out = []
    for m in masks:
        ys, xs = np.nonzero(m)
        out.append((xs.min(), ys.min(), np.ptp(xs) + 1, np.ptp(ys) + 1))
    return np.asarray(out, dtype=float)


def sequences(
    names: list[str], challenge_seed: int, shape_seed: int
) -> dict[str, tuple[list, np.ndarray]]:
    root = data_dir()
    out: dict[str, tuple[list, np.ndarray]] = {}
    for name in names:
        if root is None:
            sys.exit("no data folder (set RPERC_DATA)")
        seq = load_otb(root / "otb" / name)
        out[name] = (list(seq.frames()), seq.boxes)
    for kind in CHALLENGES:
        syn = challenge_sequence(kind, frames=150, seed=challenge_seed)
        out[syn.name] = (list(syn.frames), syn.boxes)
    for name in EXPERIMENTS:
        shp = shape_sequence(name, frames=150, seed=shape_seed)
        out[f"{name}-{shape_seed}"] = (list(shp.frames), mask_boxes(shp.masks))
    return out


def fmt(v: float, digits: int = 3) -> str:
    return "-" if not np.isfinite(v) else f"{v:.{digits}f}"


def main() -> None:
    # Peers and rperc timed with the same allocator behaviour (rperc.bench.allocator).
    steady_allocator()
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sequences", nargs="+", default=["Girl", "Couple"])
    ap.add_argument("--challenge-seed", type=int, default=7)
    ap.add_argument("--shape-seed", type=int, default=200)
    ap.add_argument(
        "--cv-threads",
        type=int,
        default=None,
        help="OpenCV's thread count (cv2.setNumThreads); rperc's is RAYON_NUM_THREADS",
    )
    ap.add_argument("--only", nargs="+", default=None, help="run only the trackers of these names")
    args = ap.parse_args()
    if cv2 is not None and args.cv_threads is not None:
        cv2.setNumThreads(args.cv_threads)
    trackers = rperc_trackers() | opencv_trackers()
    if args.only is not None:
        unknown = sorted(set(args.only) - set(trackers))
        if unknown:
            ap.error(f"--only: no tracker named {', '.join(unknown)}; one of {', '.join(trackers)}")
        trackers = {k: v for k, v in trackers.items() if k in args.only}
    missing = [n for n in ("CSRT", "KCF", "MIL") if f"OpenCV {n}" not in trackers]
    seqs = sequences(args.sequences, args.challenge_seed, args.shape_seed)
    results = {
        (name, seq): run(factory, frames, truth)
        for seq, (frames, truth) in seqs.items()
        for name, factory in trackers.items()
    }
    rows = [
        [
            name,
            seq,
            *(fmt(v) for v in r[:2]),
            fmt(r[2], 0),
            *(fmt(v, 2) for v in r[3:5]),
            fmt(r[5], 1),
        ]
        for (name, seq), r in results.items()
    ]
    header = ["tracker", "sequence", "AUC", "P@20", "fps", "lost prec", "lost rec", "ESS"]
    print_table("tracking, every tracker on every sequence (same run)", header, rows)
    summary(trackers, seqs, results, args.sequences)
    print(f"\nOpenCV trackers missing from this cv2: {', '.join(missing) or 'none'}")


def summary(trackers, seqs, results, otb: list[str]) -> None:
    """Mean AUC and P@20 over the OTB and the challenge sequences, mean fps and the
    speed ratio to CSRT."""
    synthetic = [s for s in seqs if s not in otb]
    csrt_fps = (
        np.mean([results[("OpenCV CSRT", s)][2] for s in seqs])
        if "OpenCV CSRT" in trackers
        else float("nan")
    )
    rows = []
    for name in trackers:

        def mean(group: list[str], k: int, name: str = name) -> float:
            return float(np.mean([results[(name, s)][k] for s in group]))

        fps = mean(list(seqs), 2)
        rows.append(
            [
                name,
                fmt(mean(otb, 0)),
                fmt(mean(otb, 1)),
                fmt(mean(synthetic, 0)),
                fmt(mean(synthetic, 1)),
                fmt(fps, 0),
                fmt(fps / csrt_fps, 1) + "x",
            ]
        )
    header = [
        "tracker",
        "OTB AUC",
        "OTB P@20",
        "synthetic AUC",
        "synthetic P@20",
        "fps",
        "speed vs CSRT",
    ]
    print_table(f"means: OTB {', '.join(otb)}; synthetic {', '.join(synthetic)}", header, rows)


if __name__ == "__main__":
    main()
