"""Particle-filter (CONDENSATION) tracking and its evaluation metrics.

Trackers follow OpenCV's convention::

    tracker = ColorHistogramTracker(frame, (x, y, w, h), **params)
    box, score, lost = tracker.update(next_frame)

Frames are H x W x 3 uint8 RGB arrays; boxes are ``(x, y, w, h)`` in pixels (top-left
corner). The GIL is released while a frame is processed.

- :class:`ColorHistogramTracker`: Birchfield-style local search over position and
  scale with elliptical colour histograms updated incrementally, histogram
  intersection (seed eq. 28), model adaptation (eq. 29), a bimodal model and an
  optional perimeter-gradient term.
- :class:`ParticleColorTracker`: the CONDENSATION variant over ``(x, y, scale)`` with
  the same histogram likelihood, for clutter and fast motion.
- :func:`resample`, :func:`effective_sample_size`: the particle-filter building blocks.
- :mod:`rperc.tracking.metrics`: IoU, success curve and AUC, precision at 20 px.

Parameters (keyword arguments; defaults tuned on OTB Girl and Couple):

- both: ``color_space`` (``"hsv"``, ``"opponent"`` -- the seed's (B-G, G-R, R+G+B) --,
  ``"rg"``, ``"rgb"``), ``bins`` (3 ints), ``model`` (``"bimodal"`` or ``"single"``),
  ``upper_fraction``, ``adaptation_rate``, ``adaptation_threshold``,
  ``gradient_weight``, ``lost_threshold``, ``min_scale``, ``max_scale``, ``parallel``;
- local search: ``search_radius``, ``scale_step``, ``momentum``;
- particles: ``n_particles``, ``position_noise``, ``scale_noise``, ``sigma``,
  ``resampler`` (``"systematic"``, ``"multinomial"``, ``"stratified"``,
  ``"residual"``), ``resample_below`` (an ESS fraction), ``chunk_size``.
"""

from rperc._rperc import (
    ColorHistogramTracker,
    ParticleColorTracker,
    effective_sample_size,
    resample,
)
from rperc.tracking import metrics

__all__ = [
    "ColorHistogramTracker",
    "ParticleColorTracker",
    "effective_sample_size",
    "metrics",
    "resample",
]
