"""Figures of planar SLAM runs: the path against ground truth, the map with 2-sigma
ellipses, and the robot's NEES against its chi-square band."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection
from matplotlib.figure import Figure

from rperc.plot import Limits, outside, robust_limits, set_limits
from rperc.slam.evaluation import Se2Transform
from rperc.slam.planar import SlamResult

TRUTH = "0.45"
COLORS = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange")
# A 2-D Gaussian's 95 % region is the ellipse at this Mahalanobis radius (chi2, 2 dof).
SIGMA2_RADIUS = math.sqrt(-2.0 * math.log(0.05))


def _ellipses(ax: Axes, mean: np.ndarray, cov: np.ndarray, colour: str) -> None:
    """95 % ellipses of (K, 2) means with (K, 2, 2) covariances."""
    if len(mean) == 0:
        return
    values, vectors = np.linalg.eigh(cov)
    values = np.clip(values, 0.0, None)
    angles = np.degrees(np.arctan2(vectors[:, 1, 1], vectors[:, 0, 1]))
    widths = 2 * SIGMA2_RADIUS * np.sqrt(values[:, 1])
    heights = 2 * SIGMA2_RADIUS * np.sqrt(values[:, 0])
    ax.add_collection(
        EllipseCollection(
            widths,
            heights,
            angles,
            units="xy",
            offsets=mean,
            offset_transform=ax.transData,
            facecolors="none",
            edgecolors=colour,
            linewidths=0.8,
        )
    )


def map_figure(
    runs: Sequence[tuple[str, SlamResult]],
    truth: npt.ArrayLike | None = None,
    landmarks: npt.ArrayLike | None = None,
    *,
    title: str = "",
    truth_label: str = "true path",
    transform: Se2Transform | None = None,
) -> Figure:
    """Each run's path and map (95 % ellipses), against the true path and landmarks.
    ``truth`` is (M, >= 2) positions, ``landmarks`` (L, 2). ``transform`` moves the
    estimates into the truth's frame (an alignment), covariances rotated with them."""
    fig = Figure(figsize=(7.5, 6.5))
    draw_map(fig.add_subplot(), runs, truth, landmarks, title=title, truth_label=truth_label,
             transform=transform)  # fmt: skip
    return fig


def draw_map(
    ax: Axes,
    runs: Sequence[tuple[str, SlamResult]],
    truth: npt.ArrayLike | None = None,
    landmarks: npt.ArrayLike | None = None,
    *,
    title: str = "",
    truth_label: str = "true path",
    transform: Se2Transform | None = None,
    colours: Sequence[str] = COLORS,
) -> None:
    """:func:`map_figure`'s drawing, into ``ax``."""
    rot = np.eye(2) if transform is None else transform.rotation
    move = (lambda p: p) if transform is None else transform.apply_points
    shown = [move(r.pose[:, :2]) for _, r in runs] + [move(r.landmark_mean) for _, r in runs]
    if truth is not None:
        path = np.asarray(truth, dtype=np.float64)[:, :2]
        ax.plot(path[:, 0], path[:, 1], color=TRUTH, lw=1.0, label=truth_label)
        shown.append(path)
    if landmarks is not None:
        marks = np.asarray(landmarks, dtype=np.float64)
        ax.plot(marks[:, 0], marks[:, 1], "k+", ms=9, label="true landmarks")
        shown.append(marks)
    for (name, r), colour in zip(runs, colours, strict=False):
        path, marks = move(r.pose[:, :2]), move(r.landmark_mean)
        ax.plot(path[:, 0], path[:, 1], color=colour, lw=0.8, label=f"estimate: {name}")
        ax.plot(*marks.T, "o", ms=3, color=colour, label=f"map: {name} (95 % ellipses)")
        _ellipses(ax, marks, rot @ r.landmark_covariance @ rot.T, colour)
    # The truth (path and landmarks) is always in view; stray estimates may be cut.
    kept = [np.asarray(a, dtype=np.float64)[:, :2] for a in (truth, landmarks) if a is not None]
    everything = np.concatenate(shown)
    truths = np.concatenate(kept) if kept else None
    bulk = robust_limits(everything, include=truths, percentiles=(0.5, 99.5))
    # The map's edge landmarks lie just past the bulk's percentiles (Victoria Park's
    # were cut): all within half the bulk's size stay in view, far strays do not.
    near = everything[_within(everything, bulk, reach=0.5)]
    limits = robust_limits(near, include=np.concatenate([near, *kept]))
    set_limits(ax, limits)
    cut = outside(everything, limits)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title + (f" ({cut} stray estimates beyond the frame)" if cut else ""), fontsize=9)
    ax.legend(fontsize=7, loc="best")


def _within(points: np.ndarray, limits: Limits, *, reach: float) -> np.ndarray:
    """Which finite ``points`` lie within ``limits`` grown by ``reach`` times their
    larger side on every edge."""
    (x0, x1), (y0, y1) = limits
    pad = reach * max(x1 - x0, y1 - y0)
    x, y = points[:, 0], points[:, 1]
    ok = np.isfinite(points).all(axis=1)
    inside: np.ndarray = ok & (x >= x0 - pad) & (x <= x1 + pad) & (y >= y0 - pad) & (y <= y1 + pad)
    return inside


def nees_figure(
    series: Sequence[tuple[str, npt.ArrayLike, npt.ArrayLike]],
    band: tuple[float, float],
    *,
    title: str = "",
) -> Figure:
    """Robot-pose NEES against time for each ``(name, t, nees)``, with the band."""
    fig = Figure(figsize=(8, 3.8))
    ax = fig.add_subplot()
    for (name, t, nees), colour in zip(series, COLORS, strict=False):
        ax.semilogy(np.asarray(t), np.asarray(nees), color=colour, lw=0.6, label=name)
    ax.axhspan(band[0], band[1], color="0.85", zorder=0, label="95 % band (3 dof)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("robot NEES")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    return fig


def variants_figure(
    runs: Sequence[tuple[str, SlamResult, str]],
    truth: npt.ArrayLike,
    landmarks: npt.ArrayLike,
    nees: Sequence[tuple[str, npt.ArrayLike]],
    band: tuple[float, float],
    *,
    title: str = "",
    dt: float = 1.0,
) -> Figure:
    """Paper [000]'s variants side by side: one map per ``(name, result, score)`` with
    the true path and landmarks, and below them the run-averaged robot NEES of each
    variant (one value per step of ``dt`` seconds) against its band."""
    fig = Figure(figsize=(5.0 * len(runs), 9.0))
    grid = fig.add_gridspec(2, len(runs), height_ratios=(2.2, 1.0))
    for k, ((name, result, score), colour) in enumerate(zip(runs, COLORS, strict=False)):
        draw_map(fig.add_subplot(grid[0, k]), [(name, result)], truth, landmarks,
                 title=f"{name}: {score}", colours=(colour,))  # fmt: skip
    ax = fig.add_subplot(grid[1, :])
    for (name, series), colour in zip(nees, COLORS, strict=False):
        values = np.asarray(series, dtype=np.float64)
        ax.semilogy(dt * np.arange(1, len(values) + 1), values, color=colour, lw=0.8, label=name)
    ax.axhspan(band[0], band[1], color="0.85", zorder=0, label="95 % band of the mean (3 dof)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("run-averaged robot NEES")
    ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(title, fontsize=10)
    return fig


def smoothing_figure(
    filtered: SlamResult,
    smoothed: SlamResult,
    t_truth: npt.ArrayLike,
    truth: npt.ArrayLike,
    landmarks: npt.ArrayLike,
    *,
    title: str = "",
) -> Figure:
    """A run and the same run smoothed (:func:`rperc.slam.smoothing.smooth`): both
    maps over the true path and landmarks, and below them each path's position error
    against the truth over time."""
    fig = Figure(figsize=(9.0, 9.0))
    grid = fig.add_gridspec(2, 1, height_ratios=(2.2, 1.0))
    runs = [("filter (causal)", filtered), ("smoothed", smoothed)]
    draw_map(fig.add_subplot(grid[0]), runs, truth, landmarks, title="estimate vs truth")
    ax = fig.add_subplot(grid[1])
    ref_t = np.asarray(t_truth, dtype=np.float64)
    ref = np.asarray(truth, dtype=np.float64)
    for (name, result), colour in zip(runs, COLORS, strict=False):
        t, pose, _ = result.path()
        x, y = np.interp(t, ref_t, ref[:, 0]), np.interp(t, ref_t, ref[:, 1])
        ax.plot(t - ref_t[0], np.hypot(pose[:, 0] - x, pose[:, 1] - y), color=colour, lw=0.8,
                label=f"position error: {name}")  # fmt: skip
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position error (m)")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(title, fontsize=10)
    return fig
