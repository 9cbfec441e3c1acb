"""The seed's Fig. 7 a/b: wall-SLAM maps side by side, each with its wall segments,
the estimated path and the reference path in grey."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from rperc.slam.wallslam import WallSlamResult

REFERENCE = "0.6"


def wall_maps_figure(
    runs: Sequence[tuple[str, WallSlamResult]],
    *,
    title: str = "",
    reference_label: str = "reference path",
) -> Figure:
    """One panel per ``(name, result)``: the map's wall segments (black), the
    estimated path (red) and the reference path (grey); each panel's title gives its
    ATE and loop error."""
    fig = Figure(figsize=(5.2 * len(runs), 5.0), layout="constrained")
    axes = fig.subplots(1, len(runs), squeeze=False)[0]
    for ax, (name, res) in zip(axes, runs, strict=True):
        ref = res.reference
        ax.plot(ref[:, 0], ref[:, 1], color=REFERENCE, lw=3, label=reference_label)
        ends = np.asarray(res.wall_ends).reshape(-1, 2, 2)
        if len(ends):
            ax.add_collection(LineCollection(list(ends), colors="k", linewidths=1.2))
            ax.plot([], [], "k-", lw=1.2, label=f"walls (estimate, {len(ends)})")
        ax.plot(res.pose[:, 0], res.pose[:, 1], color="tab:red", lw=1, label="path (estimate)")
        m = res.metrics
        ax.set_title(f"{name}: ATE {m['ate_rmse']:.3f} m, loop {m['loop_error']:.3f} m")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.legend(loc="upper right", fontsize=7)
    if title:
        fig.suptitle(title)
    return fig
