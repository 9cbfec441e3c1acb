"""Figures for line simplification and wall extraction."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Wedge

from rperc.linesimp import WallSegments
from rperc.plot import Limits, outside, robust_limits, set_limits
from rperc.pose import to_world
from rperc.scansim import SimulatedScan, WallCheck

# Above this many vertices markers hide the line they sit on (a 4,688-vertex coastline
# becomes a solid band), so the simplification is drawn as a plain line.
MAX_MARKERS = 150

ESTIMATE = "tab:green"
TRUTH = "0.55"


def draw_walls(
    ax: Axes,
    start: np.ndarray,
    end: np.ndarray,
    *,
    label: str = "estimated walls",
    linewidths: float = 2.0,
    alpha: float = 1.0,
    zorder: float = 2.0,
) -> None:
    """Wall segments from ``start[k]`` to ``end[k]`` ((K, 2) arrays, metres), drawn as
    estimates."""
    segments = list(np.stack([start, end], axis=1))
    ax.add_collection(
        LineCollection(
            segments,
            colors=ESTIMATE,
            linewidths=linewidths,
            alpha=alpha,
            zorder=zorder,
            label=label,
        )
    )


def draw_scan_points(
    ax: Axes,
    points: np.ndarray,
    *,
    label: str = "scan points",
    s: float = 2.0,
    alpha: float = 1.0,
    zorder: float = 1.0,
) -> None:
    """Laser readings ``(N, 2)`` in metres, marker area ``s`` (points^2)."""
    ax.scatter(
        points[:, 0],
        points[:, 1],
        s=s,
        c="tab:blue",
        linewidths=0,
        alpha=alpha,
        zorder=zorder,
        label=label,
    )


def draw_polyline(
    ax: Axes, original: np.ndarray, kept: np.ndarray, epsilon: float, *, label: bool = True
) -> None:
    """A polyline (the input, the truth of a simplification) and its simplification
    (the estimate); vertex markers only when there are few enough to see the line."""
    ax.plot(
        original[:, 0],
        original[:, 1],
        color=TRUTH,
        lw=0.8,
        label=f"input ({len(original)} points)" if label else None,
    )
    ax.plot(
        kept[:, 0],
        kept[:, 1],
        "o-" if len(kept) <= MAX_MARKERS else "-",
        color="tab:red",
        ms=3,
        lw=1.2,
        label=f"simplified, epsilon {epsilon:g} ({len(kept)} points)" if label else None,
    )
    ax.set_aspect("equal")
    if label:
        ax.legend(loc="best", fontsize=8)


def polyline_figure(
    originals: Sequence[np.ndarray],
    simplified: Sequence[np.ndarray],
    epsilon: float,
    *,
    title: str,
    unit: str = "",
) -> Figure:
    """Inputs and their simplifications on equal axes; ``title`` carries the score
    (kept points, deviation) and ``unit`` the coordinates' unit for the axis labels."""
    fig = Figure(figsize=(7, 7), layout="constrained")
    ax = fig.add_subplot()
    for k, (line, kept) in enumerate(zip(originals, simplified, strict=True)):
        draw_polyline(ax, line, kept, epsilon, label=k == 0)
    suffix = f" [{unit}]" if unit else ""
    ax.set_xlabel(f"x{suffix}")
    ax.set_ylabel(f"y{suffix}")
    everything = np.concatenate([np.asarray(p)[:, :2] for p in originals])
    set_limits(ax, robust_limits(everything, include=everything))
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    return fig


def _draw_true_walls(ax: Axes, walls: np.ndarray, check: WallCheck) -> None:
    """Each true wall as one line whose ``gid`` is ``wall<k>:hidden``, ``:visible`` or
    ``:missed`` (tests read them back)."""
    groups: tuple[tuple[str, np.ndarray, dict[str, Any], str], ...] = (
        ("hidden", check.hidden, {"color": "0.8", "ls": "--"}, "true wall, not visible from here"),
        (
            "visible",
            np.setdiff1d(check.visible, check.missed),
            {"color": "0.45"},
            "true wall (visible)",
        ),
        ("missed", check.missed, {"color": "tab:red", "ls": ":"}, "visible true wall, NOT found"),
    )
    for kind, ids, style, label in groups:
        for n, w in enumerate(ids):
            (x0, y0), (x1, y1) = walls[w]
            ax.plot(
                [x0, x1],
                [y0, y1],
                lw=4,
                alpha=0.7,
                label=label if n == 0 else None,
                gid=f"wall{w}:{kind}",
                **style,
            )
    for w, ((x0, y0), (x1, y1)) in enumerate(walls):
        ax.annotate(
            f"W{w}",
            ((x0 + x1) / 2, (y0 + y1) / 2),
            fontsize=7,
            color="0.3",
            xytext=(3, 3),
            textcoords="offset points",
        )


def _draw_robot(ax: Axes, scan: SimulatedScan, radius: float) -> None:
    x, y, th = scan.pose
    lo, hi = float(scan.angles.min()), float(scan.angles.max())
    fov = math.degrees(hi - lo)
    ax.add_patch(
        Wedge(
            (x, y),
            radius,
            math.degrees(th + lo),
            math.degrees(th + hi),
            color="tab:orange",
            alpha=0.08,
            label=f"field of view ({fov:.0f} deg)",
        )
    )
    ax.plot(x, y, "ko", ms=6, label="robot (arrow: heading)")
    ax.annotate(
        "",
        (x + 0.8 * math.cos(th), y + 0.8 * math.sin(th)),
        (x, y),
        arrowprops={"arrowstyle": "->", "lw": 1.8, "color": "k"},
    )


def _error_table(ax: Axes, found: WallSegments, check: WallCheck, scan: SimulatedScan) -> None:
    ax.axis("off")
    rows = []
    for k in range(len(found)):
        sd = np.sqrt(np.diag(found.cov[k]))
        w = int(check.truth[k])
        rows.append(
            [
                f"W{w}" if w >= 0 else "none",
                str(len(found.indices[k])),
                f"{1e3 * check.d_rho[k]:+.1f}",
                f"{1e3 * sd[0]:.1f}",
                f"{math.degrees(check.d_alpha[k]):+.2f}",
                f"{math.degrees(sd[1]):.2f}",
            ]
        )
    header = [
        "true wall",
        "points",
        "d rho\n[mm]",
        "sd rho\n[mm]",
        "d alpha\n[deg]",
        "sd alpha\n[deg]",
    ]
    if rows:
        table = ax.table(cellText=rows, colLabels=header, loc="upper center", cellLoc="center")
        table.auto_set_font_size(False)
        table.set_fontsize(8)
        table.scale(1.0, 1.6)
    hidden = ", ".join(f"W{w}" for w in check.hidden) or "none"
    note = (
        "error = estimate - ray-cast truth (sensor frame);\n"
        "sd from the estimated covariance.\n\n"
        f"not visible from here: {hidden}\n"
        f"(fewer beams than min_points)\n"
        f"beams that hit a wall: {int(np.count_nonzero(scan.wall >= 0))} of {len(scan.wall)}"
    )
    ax.text(0.0, 0.02, note, transform=ax.transAxes, fontsize=8, va="bottom", family="monospace")


def walls_figure(
    walls: np.ndarray,
    scan: SimulatedScan,
    found: WallSegments,
    check: WallCheck,
    *,
    title: str,
) -> Figure:
    """A simulated scan, the walls found in it (estimates, world frame) against the
    true walls split into visible and not visible from the robot's pose, the robot with
    its heading and field of view, and a table of each found wall's error."""
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    fig = Figure(figsize=(14, 6), layout="constrained")
    ax, side = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2.3, 1]})
    _draw_true_walls(ax, walls, check)
    hit = scan.wall >= 0
    pts = np.c_[
        scan.ranges[hit] * np.cos(scan.angles[hit]), scan.ranges[hit] * np.sin(scan.angles[hit])
    ]
    world = found.to_world(scan.pose)
    draw_walls(ax, world.start, world.end, label="estimated walls", linewidths=1.5, zorder=3)
    draw_scan_points(ax, to_world(scan.pose, pts), s=3, label="scan points (simulated)", zorder=4)
    limits = robust_limits(walls.reshape(-1, 2), include=walls.reshape(-1, 2), margin=0.04)
    span = max(limits[0][1] - limits[0][0], limits[1][1] - limits[1][0])
    _draw_robot(ax, scan, radius=2 * span)
    set_limits(ax, limits)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.1), ncol=3, fontsize=8)
    ax.set_title(title, fontsize=10)
    _error_table(side, found, check, scan)
    side.set_title("each found wall against the truth", fontsize=10)
    return fig


def world_walls_figure(
    points: np.ndarray,
    segments: np.ndarray,
    trajectory: np.ndarray,
    *,
    title: str,
    max_points: int = 200_000,
) -> Figure:
    """Scan points and extracted walls of a whole log in the world frame, with the
    logged trajectory. The axis limits come from the bulk of the points and the
    trajectory (:func:`robust_limits`), not from stray returns tens of metres out."""
    fig = Figure(figsize=(10, 10), layout="constrained")
    ax = fig.add_subplot()
    limits: Limits = robust_limits(points, include=trajectory)
    stray = outside(points, limits)
    shown = points[:: max(1, len(points) // max_points)]
    draw_scan_points(ax, shown, s=0.5, alpha=0.4, label="scan points (logged)")
    if len(segments):
        draw_walls(ax, segments[:, 0], segments[:, 1], linewidths=0.6, alpha=0.8)
    ax.plot(
        trajectory[:, 0],
        trajectory[:, 1],
        color="tab:red",
        lw=1,
        label="trajectory (logged, SLAM-corrected)",
    )
    if stray:
        ax.plot([], [], " ", label=f"{stray} stray readings outside the shown area")
    set_limits(ax, limits)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, loc="upper right", markerscale=8, fontsize=8)
    ax.set_title(title, fontsize=10)
    return fig


__all__ = [
    "draw_polyline",
    "draw_scan_points",
    "draw_walls",
    "polyline_figure",
    "walls_figure",
    "world_walls_figure",
]
