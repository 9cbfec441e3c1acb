"""Laser SLAM's map: the scans placed with the final estimate, the estimated and the
online paths against the reference, and the loop closures kept."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from rperc.plot.wallslam import REFERENCE, reference_limits
from rperc.pose import to_world
from rperc.slam.laser import LaserResult

#: Every how many scans the map draws a scan's points.
SCAN_STRIDE = 5


def scan_cloud(log: object, pose: np.ndarray, stride: int = SCAN_STRIDE) -> np.ndarray:
    """Points ``(K, 2)`` of every ``stride``-th scan of ``log``, placed with ``pose``."""
    from rperc import _rperc

    sc = log.scans  # type: ignore[attr-defined]
    clouds = []
    for k in range(0, len(pose), stride):
        n = int(sc.num_beams[k])
        found = _rperc.laser_scan_points(
            sc.ranges[k, :n],
            float(sc.angle_min[k]),
            float(sc.angle_increment[k]),
            float(sc.max_range[k]),
        )
        clouds.append(to_world(pose[k], found.points))
    return np.concatenate(clouds) if clouds else np.zeros((0, 2))


def laser_map_figure(
    result: LaserResult, cloud: np.ndarray | None = None, title: str = ""
) -> Figure:
    """One panel: ``cloud`` (scan points on the final path), the reference path in
    grey, the final estimate, the online path, and each closure kept as a segment
    between the two scans it joins, and the wall landmarks (``walls`` variant) as
    estimated; limits from the reference, so a diverged
    estimate cannot set them."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 8))
    ref, est = result.reference, result.pose
    if cloud is not None and len(cloud):
        ax.plot(cloud[:, 0], cloud[:, 1], ",", color="k", alpha=0.4)
        ax.plot([], [], "k.", ms=2, label="scans on the final path (every 5th)")
    ax.plot(ref[:, 0], ref[:, 1], color=REFERENCE, lw=3, label="corrected path (reference)")
    ax.plot(
        result.causal_pose[:, 0],
        result.causal_pose[:, 1],
        color="tab:blue",
        lw=0.8,
        ls="--",
        label=f"online path (ATE {result.metrics['ate_rmse_causal_m']:.3f} m)",
    )
    ax.plot(
        est[:, 0],
        est[:, 1],
        color="tab:red",
        lw=1,
        label=f"final estimate (ATE {result.metrics['ate_rmse_m']:.3f} m)",
    )
    if len(result.closures):
        segs = [est[[a, b], :2] for a, b in result.closures]
        ax.add_collection(LineCollection(segs, colors="tab:green", linewidths=0.8))
        ax.plot([], [], color="tab:green", lw=0.8, label=f"loop closures ({len(segs)})")
    if len(result.walls):
        walls = list(result.walls.reshape(-1, 2, 2))
        ax.add_collection(LineCollection(walls, colors="tab:orange", linewidths=1.5))
        label = f"wall landmarks, estimate ({len(walls)})"
        ax.plot([], [], color="tab:orange", lw=1.5, label=label)
    (x0, x1), (y0, y1) = reference_limits(ref)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=8)
    m = result.metrics
    ax.set_title(
        title
        or (
            f"laser SLAM, {result.log} ({len(est)} scans), odometry seed {result.seed}: "
            f"ATE {m['ate_rmse_m']:.3f} m, NEES mean {m['nees_mean']:.2f}"
        ),
        fontsize=10,
    )
    fig.tight_layout()
    return fig
