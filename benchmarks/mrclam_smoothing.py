"""The MR.CLAM smooth variant's ``point_correlation_time``, chosen by
leave-one-robot-out with two rules, each scored on the held-out robot:

- ``correlation``: from the other robots' first 444 s (the calibration span), against
  Vicon and the surveyed landmarks, the lower edge of the first lag bin at which
  consecutive sightings of one landmark have range errors correlated under 0.2;
- ``nees``: the smallest time of the grid with which every span of the other robots
  (first 444 s, the rest, the whole run) has a robot NEES mean of at most 3 (the
  chi-square mean for 3 dof: not over-confident).

Prints the pooled correlations by lag, every run (ATE aligned, NEES), each fold's
choices and their held-out scores, and the choices over all robots.

    python benchmarks/mrclam_smoothing.py [--data DIR] [--grid 0,0.5,1,2,5,10,20] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from rperc._atomic import write_text_atomically
from rperc.datasets import data_path, load_mrclam
from rperc.slam.calibration import mrclam_window
from rperc.slam.mrclam import mrclam_run
from rperc.slam.planar import mrclam_preset

ROBOTS = (1, 2, 3)
SPANS = ((0.0, 444.0), (444.0, 1e9), (0.0, 1e9))
LAGS = ((0.0, 0.5), (0.5, 2.0), (2.0, 5.0), (5.0, 20.0), (20.0, np.inf))


def sighting_errors(directory: Path, robot: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, landmark ids and ``(range, bearing)`` errors of the robot's sightings in
    its first 444 s, biases taken off as the preset does, against the truth."""
    run = mrclam_window(load_mrclam(directory, robot=robot), 0.0, 444.0)
    b = mrclam_preset(robot)["bias"]
    assert isinstance(b, dict)
    marks = dict(zip(run.landmark_id.tolist(), np.c_[run.landmark_x, run.landmark_y], strict=True))
    t, ids = run.measurement_t, run.measurement_landmark
    keep = np.isin(ids, list(marks)) & (t >= run.truth_t[0]) & (t <= run.truth_t[-1])
    t, ids = t[keep], ids[keep]
    bearing = (run.measurement_bearing[keep] - b["bearing_offset"]) / b["bearing_scale"]
    depth = (run.measurement_range[keep] - b["range_offset"]) / b["range_scale"]
    rng = depth / np.cos(bearing)
    x, y = (np.interp(t, run.truth_t, v) for v in (run.truth_x, run.truth_y))
    th = np.interp(t, run.truth_t, np.unwrap(run.truth_theta))
    d = np.array([marks[i] for i in ids]) - np.c_[x, y]
    e = np.c_[rng - np.hypot(d[:, 0], d[:, 1]), bearing - np.arctan2(d[:, 1], d[:, 0]) + th]
    e[:, 1] = (e[:, 1] + np.pi) % (2 * np.pi) - np.pi
    return t, ids, e


def lag_correlations(directory: Path, robots: tuple[int, ...]) -> list[dict[str, float]]:
    """Correlation of consecutive same-landmark sighting errors, by lag, pooled over
    ``robots``' first 444 s."""
    pairs: dict[tuple[float, float], list[np.ndarray]] = {lag: [] for lag in LAGS}
    for robot in robots:
        t, ids, e = sighting_errors(directory, robot)
        sane = (np.abs(e[:, 0]) < 0.5) & (np.abs(e[:, 1]) < 0.2)  # a wrong barcode read
        for i in np.unique(ids):
            s = np.flatnonzero((ids == i) & sane)
            gap = t[s[1:]] - t[s[:-1]]
            for lo, hi in LAGS:
                on = (gap >= lo) & (gap < hi)
                pairs[(lo, hi)].append(np.c_[e[s[:-1]][on], e[s[1:]][on]])
    out = []
    for (lo, hi), chunks in pairs.items():
        p = np.concatenate(chunks)
        out.append({"lag_from_s": lo, "lag_to_s": hi, "pairs": len(p),
                    "range": float(np.corrcoef(p[:, 0], p[:, 2])[0, 1]),
                    "bearing": float(np.corrcoef(p[:, 1], p[:, 3])[0, 1])})  # fmt: skip
    return out


def by_correlation(lags: list[dict[str, float]]) -> float:
    """The lower edge of the first lag bin whose range errors correlate under 0.2."""
    return next((c["lag_from_s"] for c in lags if c["range"] < 0.2), lags[-1]["lag_from_s"])


def choose(runs: list[dict], robots: set[int], grid: list[float]) -> float:
    """The smallest time whose runs on ``robots`` all have NEES mean <= 3."""
    for tau in grid:
        mine = [r for r in runs if r["robot"] in robots and r["tau"] == tau]
        if all(r["nees_mean"] <= 3.0 for r in mine):
            return tau
    return grid[-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="MR.CLAM folder")
    ap.add_argument("--grid", default="0,0.5,1,2,5,10,20")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    directory = args.data or data_path("mrclam6")
    grid = sorted(float(v) for v in args.grid.split(","))
    lags = lag_correlations(directory, ROBOTS)
    for c in lags:
        print(f"lag [{c['lag_from_s']:g}, {c['lag_to_s']:g}) s: {c['pairs']:5d} pairs, "
              f"correlation range {c['range']:+.2f} bearing {c['bearing']:+.2f}")  # fmt: skip
    runs = []
    for robot in ROBOTS:
        for span in SPANS:
            for tau in grid:
                _, m, _ = mrclam_run(directory, robot=robot, variants=("smooth",), span=span,
                                     smoother={"point_correlation_time": tau})  # fmt: skip
                runs.append({"robot": robot, "span": list(span), "tau": tau, **m})
                print(f"robot {robot} span {span[0]:g}-{span[1]:g} s tau {tau:g}: ATE aligned "
                      f"{m['ate_aligned_m']:.3f} m (filter {m['ate_aligned_causal_m']:.3f}), "
                      f"NEES {m['nees_mean']:.2f}")  # fmt: skip
    folds = []
    for held in ROBOTS:
        others = tuple(r for r in ROBOTS if r != held)
        rules = {
            "correlation": by_correlation(lag_correlations(directory, others)),
            "nees": choose(runs, set(others), grid),
        }
        for rule, tau in rules.items():
            # The correlation rule's time need not be on the grid: the nearest is scored.
            on_grid = min(grid, key=lambda g: abs(g - tau))
            scored = [r for r in runs if r["robot"] == held and r["tau"] == on_grid]
            folds.append({"held_out": held, "rule": rule, "tau": tau, "runs": scored})
            for r in scored:
                print(f"held out robot {held}, {rule} rule: tau {tau:g}, span "
                      f"{r['span'][0]:g}-{r['span'][1]:g} s: ATE aligned "
                      f"{r['ate_aligned_m']:.3f} m, NEES {r['nees_mean']:.2f}")  # fmt: skip
    chosen = {"correlation": by_correlation(lags), "nees": choose(runs, set(ROBOTS), grid)}
    print(f"over all robots: point_correlation_time {chosen} s")
    if args.json:
        doc = {"lags": lags, "runs": runs, "folds": folds, "chosen": chosen}
        write_text_atomically(args.json, json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
