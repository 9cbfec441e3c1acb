"""Particle-filter (CONDENSATION) tracking and its evaluation metrics.

Trackers follow OpenCV's convention::

    tracker = ColorHistogramTracker(frame, (x, y, w, h), search_radius=20)
    result = tracker.update(next_frame)      # TrackResult(box, score, lost)
    box, score, lost = result

Frames are H x W x 3 uint8 RGB arrays (``channels="bgr"`` for OpenCV's order; H x W
greyscale frames are accepted); boxes are ``(x, y, w, h)`` in pixels (top-left
corner). The GIL is released while a frame is processed.

- :class:`ColorHistogramTracker`: Birchfield-style local search over position and
  scale with elliptical colour histograms updated incrementally, histogram
  intersection (paper [000], eq. 28), model adaptation (eq. 29), a bimodal model and an
  optional perimeter-gradient term.
- :class:`ParticleColorTracker`: the CONDENSATION variant over ``(x, y, scale)`` with
  the same histogram likelihood, for clutter and fast motion.
- :class:`PatternTracker`: the 2-D pattern tracker of paper [001] (section 3): CONDENSATION
  over ``(x, y, theta, scale)`` with grey-level profiles normal to the pattern's
  contours, occlusion and scale space; :func:`pattern_sequence` generates the Fig. 8
  experiment's sequences with their ground truth.
- :class:`ColorTemplateTracker`: the default of ``rperc track``: Staple's
  merge of a correlation filter on HOG cells with the colour histograms' per-pixel
  foreground probability, DSST scale estimation, a lost flag and re-detection.
- :class:`ColorShapeTracker`: the colour+shape tracker of paper [000], section 3.3,
  CONDENSATION over the target's colour distribution weighted by an affine snake, with
  a contour per frame; :mod:`rperc.tracking.shape_sequences` generates the four
  experiments of section 3.4 with truth masks.
- :func:`opencv`: any of them behind OpenCV's ``init(frame, box)`` /
  ``update(frame) -> (ok, box)`` protocol, BGR frames.
- :func:`resample`, :func:`effective_sample_size`: the particle-filter building blocks.
- :mod:`rperc.tracking.metrics`: IoU, success curve and AUC, precision at 20 px.
- :mod:`rperc.tracking.planar`: the planar-tracking harness (corner alignment error,
  precision at 5 and 15 px, success rate, fps) running the pattern tracker against
  OpenCV's ECC, rotation/scale ``matchTemplate`` and CSRT on the same frames.

Each tracker takes one config of :mod:`rperc.config` (generated from the Rust struct,
with its defaults, tuned on OTB Girl and Couple) as ``config=`` and its fields as typed
keyword overrides; ``help(ColorHistogramConfig)`` lists them.
"""

from rperc.tracking import metrics, planar
from rperc.tracking.pattern import (
    PatternPose,
    PatternSequence,
    PatternTracker,
    pattern_sequence,
)
from rperc.tracking.trackers import (
    ColorHistogramTracker,
    ColorShapeResult,
    ColorShapeTracker,
    ColorTemplateResult,
    ColorTemplateTracker,
    OpenCVTracker,
    ParticleColorTracker,
    TrackResult,
    color_segment,
    effective_sample_size,
    opencv,
    resample,
)

__all__ = [
    "ColorHistogramTracker",
    "ColorShapeResult",
    "ColorShapeTracker",
    "ColorTemplateResult",
    "ColorTemplateTracker",
    "OpenCVTracker",
    "ParticleColorTracker",
    "PatternPose",
    "PatternSequence",
    "PatternTracker",
    "TrackResult",
    "color_segment",
    "effective_sample_size",
    "metrics",
    "opencv",
    "pattern_sequence",
    "planar",
    "resample",
]
