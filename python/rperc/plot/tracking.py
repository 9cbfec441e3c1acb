"""Annotated frame strips for tracking results."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from rperc.plot import plt


def strip_figure(
    frames: Sequence[np.ndarray], boxes: np.ndarray, truth: np.ndarray, indices: Sequence[int]
) -> Figure:
    """One panel per frame: the tracker's box (red) and the ground truth (green)."""
    fig, axes = plt.subplots(1, len(frames), figsize=(2.6 * len(frames), 2.6))
    for ax, frame, box, gt, k in zip(
        np.atleast_1d(axes), frames, boxes, truth, indices, strict=True
    ):
        ax.imshow(frame)
        for b, color in ((gt, "tab:green"), (box, "tab:red")):
            ax.add_patch(Rectangle((b[0], b[1]), b[2], b[3], fill=False, color=color, lw=1.5))
        ax.set_title(f"frame {k + 1}", fontsize=8)
        ax.axis("off")
    fig.tight_layout()
    return fig
