"""Figures for line simplification and wall extraction."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection


def draw_walls(ax: Axes, start: np.ndarray, end: np.ndarray, **kwargs) -> None:
    """Wall segments from ``start[k]`` to ``end[k]`` ((K, 2) arrays)."""
    style = {"colors": "tab:green", "linewidths": 2.0, "label": "extracted walls"} | kwargs
    ax.add_collection(LineCollection(np.stack([start, end], axis=1), **style))


def draw_scan_points(ax: Axes, points: np.ndarray, **kwargs) -> None:
    style = {"s": 2, "c": "tab:blue", "label": "scan points", "linewidths": 0} | kwargs
    ax.scatter(points[:, 0], points[:, 1], **style)


def draw_polyline(ax: Axes, original: np.ndarray, kept: np.ndarray, epsilon: float) -> None:
    """A polyline and its simplification."""
    ax.plot(original[:, 0], original[:, 1], color="0.6", lw=0.8, label=f"input ({len(original)})")
    ax.plot(
        kept[:, 0],
        kept[:, 1],
        "o-",
        color="tab:red",
        ms=3,
        lw=1.2,
        label=f"simplified, eps={epsilon:g} ({len(kept)})",
    )
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize=8)
