"""A tracker run over a whole sequence and its OTB scores: the one place that calls
the box trackers' Python API (construction and ``update``), shared by ``rperc
track``, its demo and ``rperc bench track``."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypedDict, cast

import numpy as np

from rperc._args import excerpt
from rperc._progress import progress
from rperc.tracking import metrics

if TYPE_CHECKING:
    from rperc.config import (
        ColorHistogramConfigOverrides,
        ColorShapeConfigOverrides,
        ColorTemplateConfigOverrides,
        ParticleColorConfigOverrides,
    )

__all__ = ["CLI_TRACKERS", "TRACKERS", "TrackerRun", "run_tracker", "scores"]

TRACKERS = ("color", "color-pf")
# The colour+shape tracker is offered by `rperc track` only: the tracking demo's scores
# are of the two colour trackers.
CLI_TRACKERS = ("color-template", *TRACKERS, "color-shape")


@dataclass(frozen=True)
class TrackerRun:
    """A tracker over a whole sequence: one box per frame (frame 0 holds the initial
    box), whether the tracker flagged the target lost, and the seconds it took."""

    name: str
    boxes: np.ndarray  # (N, 4)
    lost: np.ndarray  # (N,) bool
    seconds: float
    contours: tuple[np.ndarray, ...] | None = None  # (M, 2) per frame, color-shape only
    scores: np.ndarray | None = None  # (N,) the tracker's score (1 for the first frame)


def run_tracker(
    name: str,
    frames: Sequence[np.ndarray] | np.ndarray,
    first_box: Sequence[float],
    seed: int,
    settings: Mapping[str, object] | None = None,
) -> TrackerRun:
    """Run tracker ``name`` from ``first_box`` over ``frames``, ``settings`` passed to
    its constructor as keywords (``rperc bench`` sweeps them; the tracker's config
    checks them, naming a bad one). This is the one place that calls the trackers'
    Python API (construction and ``update``)."""
    from rperc.tracking import (
        ColorHistogramTracker,
        ColorShapeTracker,
        ColorTemplateTracker,
        ParticleColorTracker,
    )

    x, y, w, h = (float(v) for v in first_box)
    box = (x, y, w, h)
    kw = dict(settings or {})
    start = time.perf_counter()
    if name == "color-template":
        tracker: Any = ColorTemplateTracker(
            frames[0], box, seed=seed, **cast("ColorTemplateConfigOverrides", kw)
        )
    elif name == "color":
        tracker = ColorHistogramTracker(frames[0], box, **cast("ColorHistogramConfigOverrides", kw))
    elif name == "color-pf":
        tracker = ParticleColorTracker(
            frames[0], box, seed=seed, **cast("ParticleColorConfigOverrides", kw)
        )
    elif name == "color-shape":
        # seed is a field of the color-shape config (a keyword override like the rest).
        shape = cast("ColorShapeConfigOverrides", {**kw, "seed": seed})
        tracker = ColorShapeTracker(frames[0], box, **shape)
    else:
        raise ValueError(
            f"unknown tracker {excerpt(name)}; expected one of {', '.join(CLI_TRACKERS)}"
        )
    boxes: list[tuple[float, ...]] = [box]
    scores = [1.0]
    lost = [False]
    corners = np.array([[x, y], [x + w - 1, y], [x + w - 1, y + h - 1], [x, y + h - 1]])
    contours: list[np.ndarray] = [corners]
    for frame in progress(frames[1:], desc=f"tracking ({name})", unit="frame"):
        r = tracker.update(frame)
        boxes.append(tuple(r.box))
        scores.append(float(r.score))
        lost.append(bool(r.lost))
        contours.append(getattr(r, "contour", corners))
    seconds = time.perf_counter() - start
    shapes = tuple(contours) if name == "color-shape" else None
    return TrackerRun(
        name,
        np.asarray(boxes, dtype=np.float64),
        np.asarray(lost),
        seconds,
        shapes,
        np.asarray(scores, dtype=np.float64),
    )


class TrackerScores(TypedDict):
    """A run's OTB scores (:func:`scores`): area under the success curve, precision at
    20 px, mean IoU, lost frames and frames per second, with the per-frame boxes,
    tracker scores, lost flags and IoU they come from."""

    tracker: str
    frames: int
    auc: float
    precision_20px: float
    mean_iou: float
    lost_frames: int
    fps: float
    boxes: np.ndarray
    scores: np.ndarray | None
    lost: np.ndarray
    iou: np.ndarray


def scores(run: TrackerRun, truth: np.ndarray) -> TrackerScores:
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
        "scores": run.scores,
        "lost": run.lost,
        "iou": overlaps,
    }
