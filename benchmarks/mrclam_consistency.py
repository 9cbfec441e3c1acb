"""Where an MR.CLAM robot's EKF turns over-confident: per time slice, the robot's
error against Vicon, the standard deviations the filter claims, the mean robot NEES
(3 dof: 3 expected) and the landmarks sighted, for the robot's preset linearised at
first estimates and at its current estimates. Beside it, every sighting against the
Vicon geometry (true range and bearing from the Vicon pose and the surveyed
landmark, through the preset's camera biases): the share inside the 99 % gate of
the preset's detection noise. The evidence of issue 33, part 6.

    python benchmarks/mrclam_consistency.py [--robot 3] [--slice 30] [--span 0 1e9]
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from scipy.stats import chi2

from rperc.datasets import data_path, load_mrclam
from rperc.pose import wrap_angle
from rperc.slam.calibration import mrclam_window, true_range_bearing
from rperc.slam.planar import PlanarSlam, mrclam_preset, mrclam_recording, mrclam_start


def sighting_share(run: Any, preset: dict[str, Any]) -> float:
    """Share of sightings inside the 99 % gate against the Vicon geometry."""
    bias = preset["bias"]
    r, b = true_range_bearing(run)
    depth = bias["range_offset"] + bias["range_scale"] * r * np.cos(b)
    bearing = bias["bearing_offset"] + bias["bearing_scale"] * b
    nis = (run.measurement_range - depth) ** 2 / preset["range_variance"] + wrap_angle(
        run.measurement_bearing - bearing
    ) ** 2 / preset["bearing_variance"]
    return float(np.mean(nis <= chi2.ppf(0.99, 2)))


def timeline(run: Any, config: dict[str, Any], width: float) -> None:
    """Prints one line per ``width`` seconds of the run under ``config``."""
    result = PlanarSlam({**config, **mrclam_start(run)}).run(mrclam_recording(run))
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    marks = (run.landmark_id, np.c_[run.landmark_x, run.landmark_y])
    nees = result.nees(run.truth_t, truth, reference_landmarks=marks)
    t, pose, cov = result.path()
    true = np.c_[np.interp(t, run.truth_t, run.truth_x), np.interp(t, run.truth_t, run.truth_y),
                 np.interp(t, run.truth_t, np.unwrap(run.truth_theta))]  # fmt: skip
    err = pose - true
    err[:, 2] = wrap_angle(err[:, 2])
    t0 = run.odometry_t[0]
    print(f"NEES mean {nees.mean:.2f}, {100 * nees.inside:.0f} % in band; "
          f"ATE aligned {result.ate(run.truth_t, truth, align=True).rmse:.3f} m")  # fmt: skip
    print("    t s   err x     y   theta |  sd x     y   theta | NEES  | landmarks sighted")
    for start in np.arange(0.0, t[-1] - t0, width):
        k = min(np.searchsorted(t, t0 + start), len(t) - 1)
        inside = (nees.t >= t0 + start) & (nees.t < t0 + start + width)
        seen = (run.measurement_t >= t0 + start) & (run.measurement_t < t0 + start + width)
        sd = np.sqrt(np.diag(cov[k]))
        mean = nees.nees[inside].mean() if inside.any() else float("nan")
        ids = sorted(set(run.measurement_landmark[seen].tolist()))
        print(f"{start:7.0f} {err[k, 0]:+.2f} {err[k, 1]:+.2f} {err[k, 2]:+.3f} | "
              f"{sd[0]:.2f} {sd[1]:.2f} {sd[2]:.3f} | {mean:5.1f} | {ids}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", type=int, default=3)
    ap.add_argument("--slice", type=float, default=30.0, help="seconds per line")
    ap.add_argument("--span", type=float, nargs=2, default=(0.0, 1e9))
    args = ap.parse_args()
    run = mrclam_window(load_mrclam(data_path("mrclam6"), robot=args.robot), *args.span)
    preset = mrclam_preset(args.robot)
    print(f"robot {args.robot}: {100 * sighting_share(run, preset):.1f} % of "
          f"{len(run.measurement_t)} sightings inside the 99 % gate against Vicon; "
          f"{run.robot_sightings} sightings of robots left out")  # fmt: skip
    for first in (True, False):
        print(f"\nlinearised at {'first' if first else 'current'} estimates:")
        timeline(run, {**preset, "first_estimates": first}, args.slice)


if __name__ == "__main__":
    main()
