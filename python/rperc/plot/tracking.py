"""Annotated frame strips for tracking results: each tracker's box against the truth,
and every tracker's overlap (IoU) with the truth over the whole sequence."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon, Rectangle

from rperc.tracking import metrics

TRUTH_COLOR = "lime"
TRACKER_COLORS = ("red", "deepskyblue", "yellow", "magenta")


def score_line(name: str, boxes: np.ndarray, truth: np.ndarray) -> str:
    """``name: AUC a, precision@20px p, mean IoU m`` of ``boxes`` against ``truth``."""
    overlaps = metrics.iou(boxes, truth)
    return (
        f"{name}: AUC {metrics.auc(overlaps):.3f}, "
        f"precision@20px {metrics.precision(boxes, truth):.3f}, mean IoU {overlaps.mean():.2f}"
    )


def _dash(i: int) -> str:
    return ("--", ":", "-.")[i % 3]


def _box(b: np.ndarray, colour: Any, **style: Any) -> Rectangle:
    return Rectangle((b[0], b[1]), b[2], b[3], fill=False, color=colour, **style)


def strip_figure(
    frames: Sequence[np.ndarray],
    indices: Sequence[int] | np.ndarray,
    truth: np.ndarray,
    tracks: Mapping[str, np.ndarray],
    *,
    title: str,
    truth_label: str = "ground truth",
    contours: Mapping[str, Sequence[np.ndarray]] | None = None,
) -> Figure:
    """One panel per picked frame with the truth box and each tracker's box, and below
    them every tracker's IoU with the truth over the sequence.

    ``frames[j]`` is frame ``indices[j]``; ``truth`` and each ``tracks[name]`` hold one
    ``(x, y, w, h)`` box (pixels) per frame of the whole sequence. The title gets one
    score line per tracker (AUC, precision, mean IoU against ``truth``). A tracker in
    ``contours`` (one ``(N, 2)`` polygon ``(x, y)`` per frame) also gets its contour drawn,
    dashed, in its colour.
    """
    if len(frames) != len(indices):
        raise ValueError(f"{len(frames)} frames for {len(indices)} indices")
    colours = dict(zip(tracks, TRACKER_COLORS, strict=False))
    fig = Figure(figsize=(2.4 * max(len(frames), 3), 5.2), layout="constrained")
    grid = fig.add_gridspec(2, len(frames), height_ratios=[1.3, 1])
    for j, (frame, k) in enumerate(zip(frames, indices, strict=True)):
        ax = fig.add_subplot(grid[0, j])
        ax.imshow(frame)
        # The truth wide and underneath, each tracker thinner in its own dash on top:
        # boxes that agree would otherwise hide one another.
        ax.add_patch(_box(truth[k], TRUTH_COLOR, lw=3.0, ls="-", zorder=2))
        for i, n in enumerate(tracks):
            ax.add_patch(_box(tracks[n][k], colours[n], lw=1.2, ls=_dash(i), zorder=3 + i))
        for n, polys in (contours or {}).items():
            ax.add_patch(
                Polygon(polys[k], closed=True, fill=False, color=colours[n], lw=1, ls="--")
            )
        ious = " / ".join(f"{metrics.iou(tracks[n][k], truth[k])[0]:.2f}" for n in tracks)
        ax.set_title(f"frame {k + 1}, IoU {ious}", fontsize=7)
        ax.set_xticks([])
        ax.set_yticks([])
    ax = fig.add_subplot(grid[1, :])
    for name, boxes in tracks.items():
        iou = metrics.iou(boxes, truth)
        ax.plot(np.arange(1, len(truth) + 1), iou, color=colours[name], lw=1, label=f"{name} IoU")
    for k in indices:
        ax.axvline(k + 1, color="0.8", lw=0.6, zorder=0)
    ax.set_xlabel("frame [index, 1-based]")
    ax.set_ylabel("IoU with the truth [0-1]")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    # The IoU panel's legend lists its own lines only; the boxes get the figure's.
    ax.legend(loc="lower left", fontsize=8, ncol=len(tracks))
    legend = [Line2D([], [], color=TRUTH_COLOR, lw=3, label=f"{truth_label} box")]
    legend += [
        Line2D([], [], color=colours[n], lw=1.2, ls=_dash(i), label=f"tracker {n} box")
        for i, n in enumerate(tracks)
    ]
    legend += [
        Line2D([], [], color=colours[n], lw=1, ls="--", label=f"tracker {n} contour")
        for n in contours or {}
    ]
    fig.legend(handles=legend, loc="outside lower center", fontsize=8, ncol=len(legend))
    scores = "\n".join(score_line(n, b, truth) for n, b in tracks.items())
    fig.suptitle(f"{title}\n{scores}", fontsize=9)
    return fig
