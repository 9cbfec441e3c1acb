"""Wall-landmark SLAM on the CARMEN logs, end to end (issue 11, part 7): read the log,
extract every scan's walls (with the straightness floor ``wallslam.STRAIGHTNESS``), run
the plain EKF with wall landmarks from noisy odometry (``wall_fig7``'s, seed 0), in
scans per second per stage; the SLAM stage against
``tests/oracles/wall_ekf``, the same filter in numpy, in the same run, which must give
the same trajectory. The peer pairs by nearest neighbours, so that is the association
timed against it; the SLAM and end-to-end rates with JCBB, ``wallslam``'s default,
are timed too.

    python benchmarks/wall_slam.py [--logs intel.log aces.log]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _oracles import wall_ekf
from _timing import print_table

from rperc import _rperc
from rperc.datasets import data_dir
from rperc.datasets.carmen import load_carmen
from rperc.slam.wallslam import (
    SPEED_SIGMA,
    STRAIGHTNESS,
    TURN_SIGMA,
    increments,
    noisy_controls,
    wall_rows,
)


def seconds(fn: object, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()  # type: ignore[operator]
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench(path: Path) -> list[str]:
    t_read, log = seconds(lambda: load_carmen(path))
    ref = log.scans.pose
    exact, t = increments(ref)
    t_extract, (walls, _, _) = seconds(lambda: wall_rows(log.scans, t, straightness=STRAIGHTNESS))
    controls = np.r_[noisy_controls(exact, 0), [[t[-1], 0.0, 0.0]]]
    config = {
        "motion": {
            "unicycle": {"speed_variance": SPEED_SIGMA**2, "turn_rate_variance": TURN_SIGMA**2}
        },
        "association": "nn",
        "initial_pose": ref[0].tolist(),
        "first_estimates": True,
        "wall_shared_sd": STRAIGHTNESS,
    }
    empty = np.zeros((0, 3))
    t_slam, out = seconds(
        lambda: _rperc.planar_slam_run(controls, empty, None, None, config, walls)
    )
    jcbb = {**config, "association": "jcbb"}
    t_jcbb, _ = seconds(lambda: _rperc.planar_slam_run(controls, empty, None, None, jcbb, walls))
    v = np.diag([SPEED_SIGMA**2, TURN_SIGMA**2])
    peer = wall_ekf.WallEkfSlam(
        ref[0], v, first_estimates=True, segment=True, shared_sd=STRAIGHTNESS
    )
    t_numpy, est_np = seconds(lambda: wall_ekf.run(controls, walls, peer), repeat=1)
    rows = out.pose[out.kind == 3]  # type: ignore[attr-defined]
    diff = float(np.max(np.abs(rows - est_np))) if rows.shape == est_np.shape else float("nan")
    n = len(ref)
    total = t_read + t_extract + t_slam
    return [
        path.name,
        str(n),
        f"{n / t_read:,.0f}",
        f"{n / t_extract:,.0f}",
        f"{n / t_slam:,.0f}",
        f"{n / total:,.0f}",
        f"{n / t_jcbb:,.0f}",
        f"{n / (t_read + t_extract + t_jcbb):,.0f}",
        f"{n / t_numpy:,.0f}",
        f"{t_numpy / t_slam:.0f}x",
        f"{diff:.1e}",
    ]


def main() -> None:
    data = (data_dir() or Path("data")) / "carmen"
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--logs", nargs="+", default=[str(data / "intel.log"), str(data / "aces.log")])
    args = ap.parse_args()
    rows = [bench(Path(p)) for p in args.logs]
    print_table(
        "wall SLAM, scans per second per stage (best of 3; numpy once)",
        [
            "log",
            "scans",
            "read",
            "extract",
            "SLAM",
            "end to end",
            "SLAM, JCBB",
            "end to end, JCBB",
            "numpy SLAM",
            "rperc/numpy",
            "max |pose diff|",
        ],
        rows,
    )


if __name__ == "__main__":
    main()
