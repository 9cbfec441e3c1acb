"""Calibrate the straightness floor of wall covariances on ONE log, report on another
(issue 11, part 4 diagnosis).

Every wall seen in two scans ``--separation`` apart, both taken to the world frame
with the log's corrected poses (rperc.wallcheck's pairing, by geometry only), gives a
NEES with 2 dof. The filter fuses sightings of a wall from all along the stretch where
it is seen, and the NEES of such pairs grows with their separation (on ACES with
sigma 1.48 cm, median 1.39 / 2.47 / 2.98 / 3.08 at 1 / 5 / 10 / 20 scans): the
errors of nearby scans are shared (same part of the wall, same pose error of the
reference), so consecutive scans understate them. The default separation is 10
scans (about 7 m of path), where the growth levels off.

With the fit covariance alone the NEES is far above 2 on real logs. The model added
here (rperc.slam.wallslam.straightness_covariance): each end of a seen segment lies
off the ideal straight wall by an independent perpendicular error of sigma metres,
which does not shrink with the number of readings. sigma is chosen on the calibration
log alone, as the value that brings the median pair NEES to chi-square(2)'s median
2 ln 2 (the median, since a few mispaired walls dominate the mean), then the other
log is reported with that sigma, untouched.

    python benchmarks/wall_straightness.py [--calibrate LOG] [--report LOG]  # default: ACES, Intel
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from rperc._atomic import write_text_atomically
from rperc.datasets import data_dir
from rperc.datasets.carmen import load_carmen
from rperc.linesimp import extract_lines
from rperc.slam.wallslam import straightness_covariance
from rperc.wallcheck import CHI2_2DOF_95, line_difference, pair_walls

MEDIAN_2DOF = 2 * math.log(2)


def pairs_of(path: Path, separation: int = 1) -> list[tuple[Any, int, Any, int]]:
    """Every wall pair of scans ``separation`` apart, both walls in the world frame."""
    scans = load_carmen(path).scans
    world = []
    for k in range(len(scans)):
        n = int(scans.num_beams[k])
        found = extract_lines(
            scans.ranges[k, :n], scans.angles(k), max_range=float(scans.max_range[k])
        )
        world.append(found.to_world(scans.pose[k]))
    out = []
    for a, b in zip(world, world[separation:], strict=False):
        out += [(a, i, b, j) for i, j in pair_walls(a, b)]
    return out


def pair_nees(pairs: list[tuple[Any, int, Any, int]], sigma: float) -> np.ndarray:
    def cov(w: Any, i: int) -> np.ndarray:
        q = straightness_covariance(
            w.rho[i : i + 1], w.alpha[i : i + 1], w.start[i : i + 1], w.end[i : i + 1], sigma
        )[0]
        c: np.ndarray = w.cov[i] + q
        return c

    nees = []
    for a, i, b, j in pairs:
        d = line_difference(a, i, b, j)
        nees.append(float(d @ np.linalg.solve(cov(a, i) + cov(b, j), d)))
    return np.asarray(nees)


def summary(nees: np.ndarray) -> dict[str, float]:
    return {
        "pairs": len(nees),
        "mean": float(np.mean(nees)),
        "median": float(np.median(nees)),
        "within_95": float(np.mean(nees < CHI2_2DOF_95)),
    }


def calibrate(pairs: list[tuple[Any, int, Any, int]]) -> float:
    """Bisection in log sigma (the median NEES falls as sigma grows)."""
    lo, hi = 1e-4, 0.5
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        if np.median(pair_nees(pairs, mid)) > MEDIAN_2DOF:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


def main() -> None:
    data = (data_dir() or Path("data")) / "carmen"
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calibrate", type=Path, default=data / "aces.log")
    ap.add_argument("--report", type=Path, default=data / "intel.log")
    ap.add_argument("--separation", type=int, default=10, help="scans between the pair")
    ap.add_argument("--sigma", type=float, help="report at this sigma (m), no calibration")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    cal = pairs_of(args.calibrate, args.separation)
    rep = pairs_of(args.report, args.separation)
    sigma = calibrate(cal) if args.sigma is None else args.sigma
    result = {
        "calibration_log": args.calibrate.name,
        "report_log": args.report.name,
        "separation_scans": args.separation,
        "sigma_m": sigma,
        "before": {args.calibrate.name: summary(pair_nees(cal, 0.0)),
                   args.report.name: summary(pair_nees(rep, 0.0))},
        "after": {args.calibrate.name: summary(pair_nees(cal, sigma)),
                  args.report.name: summary(pair_nees(rep, sigma))},
    }  # fmt: skip
    print(json.dumps(result, indent=2))
    if args.json:
        write_text_atomically(args.json, json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
