"""Particle-filter (CONDENSATION) tracking and its evaluation metrics."""

from rperc.tracking import metrics

__all__ = ["metrics"]
