"""Paper [000]'s Fig. 7 a/b: wall-SLAM maps side by side, each with its wall segments,
the estimated path and the reference path in grey."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from rperc.slam.wallslam import WallSlamResult

REFERENCE = "0.6"
TRUE_WALL = "#9be39b"


def sighted_walls(rows: np.ndarray, t: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Every wall sighting ``rows`` (``wallslam.wall_rows``: time, line, covariance,
    sensor-frame ends) placed with the pose of its scan (scan times ``t``, poses
    ``(S, 3)``): the map a path draws with no filter, ``(K, 2, 2)``."""
    k = np.clip(np.searchsorted(t, rows[:, 0]), 0, len(pose) - 1)
    c, s = np.cos(pose[k, 2]), np.sin(pose[k, 2])
    ends = rows[:, 6:10].reshape(-1, 2, 2)
    x = pose[k, 0, None] + c[:, None] * ends[:, :, 0] - s[:, None] * ends[:, :, 1]
    y = pose[k, 1, None] + s[:, None] * ends[:, :, 0] + c[:, None] * ends[:, :, 1]
    out: np.ndarray = np.stack([x, y], axis=-1)
    return out


def reference_limits(ref: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    """Limits around the reference path (10 % margin), the same for every panel, so
    that a diverged estimate does not set them."""
    lo, hi = ref[:, :2].min(axis=0), ref[:, :2].max(axis=0)
    pad = 0.1 * float(np.max(hi - lo)) + 1.0
    return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


def _panel(
    ax: Axes,
    name: str,
    res: WallSlamResult,
    sightings: tuple[np.ndarray, np.ndarray] | None,
    label: str,
    true_walls: np.ndarray | None = None,
) -> None:
    ref = res.reference
    ax.plot(ref[:, 0], ref[:, 1], color=REFERENCE, lw=3, label=label)
    if true_walls is not None:
        # Wide and pale underneath, so the estimated walls drawn on them stay visible.
        ax.add_collection(
            LineCollection(list(true_walls), colors=TRUE_WALL, linewidths=4, zorder=1)
        )
        ax.plot([], [], color=TRUE_WALL, lw=4, label="walls (truth)")
    ends = np.asarray(res.wall_ends).reshape(-1, 2, 2)
    if len(ends):
        ax.add_collection(LineCollection(list(ends), colors="k", linewidths=1.2))
        ax.plot([], [], "k-", lw=1.2, label=f"walls (estimate, {len(ends)})")
    elif sightings is not None and len(sightings):
        seen = sighted_walls(sightings[0], sightings[1], res.pose)
        ax.add_collection(LineCollection(list(seen), colors="k", linewidths=0.3, alpha=0.5))
        ax.plot([], [], "k-", lw=0.5, alpha=0.5, label="wall sightings on this path")
    ax.plot(res.pose[:, 0], res.pose[:, 1], color="tab:red", lw=1, label="path (estimate)")
    (x0, x1), (y0, y1) = reference_limits(ref)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    out = np.any(
        (res.pose[:, 0] < x0)
        | (res.pose[:, 0] > x1)
        | (res.pose[:, 1] < y0)
        | (res.pose[:, 1] > y1)
    )
    m = res.metrics
    ax.set_title(
        f"{name}: ATE {m['ate_rmse']:.3f} m, loop {m['loop_error']:.3f} m"
        + (" (leaves the frame)" if out else "")
    )
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper right", fontsize=7)


def wall_maps_figure(
    runs: Sequence[tuple[str, WallSlamResult]],
    *,
    title: str = "",
    reference_label: str = "reference path",
    sightings: tuple[np.ndarray, np.ndarray] | None = None,
    true_walls: npt.ArrayLike | None = None,
) -> Figure:
    """One panel per ``(name, result)``: the map's wall segments (black), the
    estimated path (red) and the reference path (grey), all panels framed alike by
    the reference path; each panel's title gives its ATE and loop error. A run with
    no wall map (odometry alone) shows, given ``sightings`` (wall rows and scan
    times, ``wallslam.PreparedLog.rows`` and ``.t``), every sighting placed with its
    path: the map odometry draws. ``true_walls`` (``(n, 2, 2)`` end points), when
    known, are drawn under every panel."""
    fig = Figure(figsize=(5.2 * len(runs), 5.0), layout="constrained")
    axes = fig.subplots(1, len(runs), squeeze=False)[0]
    for ax, (name, res) in zip(axes, runs, strict=True):
        truth = None if true_walls is None else np.asarray(true_walls, float).reshape(-1, 2, 2)
        _panel(ax, name, res, sightings, reference_label, truth)
    if title:
        fig.suptitle(title)
    return fig
