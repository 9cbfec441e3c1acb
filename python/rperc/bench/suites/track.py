"""``rperc bench track``: trackers over OTB sequence folders, rperc's and OpenCV's in
the same run. One row per sequence, tracker and seed: success AUC, precision at 20 px,
mean IoU, frames flagged lost, frames and fps.

rperc's trackers run through :func:`rperc.cli.track.run_tracker` and are scored by
:func:`rperc.cli.track.scores`, exactly as ``rperc track`` does. The OpenCV peers get
the same frames, converted to BGR before the clock starts, with OpenCV held to one
thread (the comparison is single-threaded), and the same scoring. Every tracker is
timed from its construction on the first frame to its last update; decoding is not
timed.
"""

from __future__ import annotations

import contextlib
import inspect
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rperc._extras import require
from rperc.bench.tasks import Row, Task

#: rperc's trackers (the settings grid applies to them) and the OpenCV peers.
RPERC_TRACKERS = ("color-template", "color", "color-pf", "color-shape")
OPENCV_TRACKERS = ("csrt", "kcf", "mil", "meanshift", "camshift")
TRACKERS = (*RPERC_TRACKERS, *OPENCV_TRACKERS)
DEFAULT_TRACKERS = ("color-template", "color", "color-pf", "csrt", "kcf")

#: What the table and the figure show first.
SHOWN = ("auc", "precision_20px", "fps")
PRIMARY = ("auc", "")

Box = tuple[float, float, float, float]


def settings_taken() -> set[str]:
    """The keywords of rperc's tracker constructors: what a settings grid may set."""
    import dataclasses

    from rperc.config import (
        ColorHistogramConfig,
        ColorShapeConfig,
        ColorTemplateConfig,
        ParticleColorConfig,
    )
    from rperc.tracking import (
        ColorHistogramTracker,
        ColorShapeTracker,
        ColorTemplateTracker,
        ParticleColorTracker,
    )
    from rperc.tracking.trackers import _APPEARANCE_KEYWORDS, _FILTER_KEYWORDS

    names: set[str] = set()
    for cls in (
        ColorTemplateTracker,
        ColorHistogramTracker,
        ParticleColorTracker,
        ColorShapeTracker,
    ):
        params = inspect.signature(cls.__init__).parameters
        names |= {n for n, p in params.items() if p.kind is p.KEYWORD_ONLY}
    # Each tracker takes its config's fields as keyword overrides; the histogram
    # trackers still take their parts' old flat keywords (deprecated).
    for config in (
        ColorTemplateConfig,
        ColorShapeConfig,
        ColorHistogramConfig,
        ParticleColorConfig,
    ):
        names |= {f.name for f in dataclasses.fields(config)}
    names |= set(_APPEARANCE_KEYWORDS) | set(_FILTER_KEYWORDS)
    return names - {"seed", "config"}


def sequence_folders(corpora: Sequence[Path], names: Sequence[str] | None) -> list[str]:
    """The OTB folders (``img/`` and ``groundtruth_rect.txt``) in or given by
    ``corpora``, absolute, sorted by name; only ``names`` when given (each must be
    found)."""
    found: dict[str, Path] = {}
    for root in corpora:
        if (root / "groundtruth_rect.txt").is_file():
            found.setdefault(root.name, root.resolve())
            continue
        if not root.is_dir():
            raise ValueError(f"--corpus {root}: not a folder")
        for p in sorted(root.iterdir()):
            if (p / "groundtruth_rect.txt").is_file():
                found.setdefault(p.name, p.resolve())
    if names:
        missing = [n for n in names if n not in found]
        if missing:
            raise ValueError(f"--sequences: {', '.join(missing)} not found in the corpus")
        found = {n: found[n] for n in names}
    if not found:
        raise ValueError("no OTB sequence folder (img/, groundtruth_rect.txt) in the corpus")
    return [str(found[n]) for n in sorted(found)]


def run(task: Task) -> Row:
    """One tracker over one sequence: its scores (the columns of ``rperc track``)."""
    from rperc.datasets import load_otb
    from rperc.tracking.runs import TrackerRun, run_tracker, scores

    seq = load_otb(task.dataset)
    frames = [seq.frame(k) for k in range(len(seq))]
    if task.method in RPERC_TRACKERS:
        from rperc import __version__

        result = run_tracker(task.method, frames, seq.boxes[0], task.seed, task.kwargs)
        library = f"rperc {__version__}"
    elif task.method in OPENCV_TRACKERS:
        if task.settings:
            raise ValueError(f"the OpenCV peer {task.method} takes no settings")
        boxes, lost, seconds, library = run_opencv(task.method, frames, seq.boxes[0])
        result = TrackerRun(task.method, boxes, lost, seconds)
    else:
        raise ValueError(f"unknown tracker {task.method!r}; expected one of {', '.join(TRACKERS)}")
    s = scores(result, seq.boxes)
    return {
        "library": library,
        "dataset": seq.name,
        **{k: s[k] for k in ("frames", "auc", "precision_20px", "mean_iou", "lost_frames", "fps")},
    }


def _cv2() -> Any:
    cv2 = require("cv2", "the OpenCV peers")
    return cv2


@contextlib.contextmanager
def _one_thread(cv2: Any) -> Iterator[None]:
    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def _factories(
    cv2: Any,
) -> dict[str, Callable[[np.ndarray, Box], Callable[[np.ndarray], tuple[Box, bool]]]]:
    def tracker(create: Callable[[], Any]) -> Any:
        def make(frame: np.ndarray, box: Box) -> Callable[[np.ndarray], tuple[Box, bool]]:
            t = create()
            t.init(frame, tuple(round(v) for v in box))
            last = {"box": box}

            def update(f: np.ndarray) -> tuple[Box, bool]:
                ok, b = t.update(f)
                if ok:
                    last["box"] = tuple(float(v) for v in b)  # type: ignore[assignment]
                return last["box"], not ok

            return update

        return make

    def kcf() -> Any:
        params = cv2.TrackerKCF_Params()
        params.detect_thresh = 0.0  # else it gives up after a few frames
        return cv2.TrackerKCF_create(params)

    return {
        "csrt": tracker(cv2.TrackerCSRT_create),
        "kcf": tracker(kcf),
        "mil": tracker(cv2.TrackerMIL_create),
        "meanshift": _hue_shift(cv2, camshift=False),
        "camshift": _hue_shift(cv2, camshift=True),
    }


def _hue_shift(cv2: Any, camshift: bool) -> Any:
    """meanShift or CamShift on a hue back-projection, as in OpenCV's tutorial."""

    def make(frame: np.ndarray, box: Box) -> Callable[[np.ndarray], tuple[Box, bool]]:
        x, y, w, h = (round(v) for v in box)
        hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
        roi = hsv[max(y, 0) : y + h, max(x, 0) : x + w]
        mask = cv2.inRange(roi, np.array((0.0, 60.0, 32.0)), np.array((180.0, 255.0, 255.0)))
        hist = cv2.calcHist([roi], [0], mask, [16], [0, 180])
        cv2.normalize(hist, hist, 0, 255, cv2.NORM_MINMAX)
        term = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1)
        state = {"win": (x, y, max(w, 1), max(h, 1))}

        def update(f: np.ndarray) -> tuple[Box, bool]:
            back = cv2.calcBackProject([cv2.cvtColor(f, cv2.COLOR_BGR2HSV)], [0], hist, [0, 180], 1)
            shift = cv2.CamShift if camshift else cv2.meanShift
            _, win = shift(back, state["win"], term)
            if win[2] > 0 and win[3] > 0:
                state["win"] = win
            return tuple(float(v) for v in state["win"]), False  # type: ignore[return-value]

        return update

    return make


def run_opencv(
    name: str, frames: Sequence[np.ndarray], first_box: Sequence[float]
) -> tuple[np.ndarray, np.ndarray, float, str]:
    """An OpenCV tracker over RGB ``frames``: boxes (the first is ``first_box``), lost
    flags, seconds (construction to last update, one thread) and the library."""
    import time

    cv2 = _cv2()
    bgr = [np.ascontiguousarray(f[:, :, ::-1]) for f in frames]
    box: Box = tuple(float(v) for v in first_box)  # type: ignore[assignment]
    make = _factories(cv2)[name]
    with _one_thread(cv2):
        start = time.perf_counter()
        update = make(bgr[0], box)
        steps = [update(f) for f in bgr[1:]]
        seconds = time.perf_counter() - start
    boxes = np.array([box] + [b for b, _ in steps], dtype=np.float64)
    lost = np.array([False] + [lo for _, lo in steps])
    return boxes, lost, seconds, f"OpenCV {cv2.__version__}"
