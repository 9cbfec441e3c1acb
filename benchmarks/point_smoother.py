"""Batch smoothing of a point-landmark SLAM run (``rperc.slam.smoothing.smooth`` with
detections) against the numpy/scipy peer (``tests/oracles/wall_smoother.py`` with its
point terms: the same problem, scipy's sparse finite differences and SuperLU), timed
in the same run on the same filter output: seconds per smoothing, the ratio, how far
the two optima are apart, and the filter's and the smoothed ATE against the truth.

    python benchmarks/point_smoother.py [--seeds 3] [--steps 600] [--json out.json]

The simulated world of ``rperc.slam.planar.simulate`` (a circle among two rings of
landmarks), a pose at every scan.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from _oracles import wall_smoother as ref
from _timing import against_peer

from rperc._atomic import write_text_atomically
from rperc.config import SimConfig
from rperc.slam import PlanarSlam
from rperc.slam.planar import sim_slam_config, simulate
from rperc.slam.smoothing import pose_times, smooth


def one_run(sim: SimConfig, seed: int) -> dict[str, float]:
    world = simulate(sim, seed=seed)
    rec, truth = world.recording, world.truth
    truth = truth[np.r_[truth[1:, 0] != truth[:-1, 0], True]]
    config = sim_slam_config(sim)
    out = PlanarSlam(config).run(rec)
    times = pose_times(out, rec.detections)
    t0 = time.perf_counter()
    sm = smooth(out, rec.controls, times, detections=rec.detections)
    ours = time.perf_counter() - t0
    rows = np.searchsorted(out.t, times, side="right") - 1
    marks = dict(zip(out.landmark_id.tolist(), out.landmark_mean, strict=True))
    t0 = time.perf_counter()
    problem = ref.Problem(
        rec.controls, times, out.pose[rows], np.zeros((0, 10)), np.zeros(0, int),
        np.zeros(0, int), np.zeros((0, 2)), speed_var=sim.speed_variance,
        turn_var=sim.turn_rate_variance, bias_sd=None, start=config["initial_pose"],
        start_var=config["initial_pose_variance"],
        points=ref.Points(rec.detections, out.point_pairing, times, marks, None),
        point_var=(sim.range_variance, sim.bearing_variance),
    )  # fmt: skip
    peer = ref.smooth(problem)
    theirs = time.perf_counter() - t0
    return {
        **against_peer(ours, theirs, sm.pose, peer["pose"]),
        "filter_ate_m": out.ate(truth[:, 0], truth[:, 1:]).rmse,
        "smoothed_ate_m": sm.to_result(out).ate(truth[:, 0], truth[:, 1:]).rmse,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    sim = SimConfig(steps=args.steps)
    runs = [one_run(sim, seed) for seed in range(args.seeds)]
    mean = {k: float(np.mean([r[k] for r in runs])) for k in runs[0]}
    print(
        f"simulated world, {args.steps} steps, {args.seeds} seeds: rperc {mean['rperc_s']:.4f} s, "
        f"peer {mean['peer_s']:.2f} s ({mean['ratio']:.0f}x), optima "
        f"{mean['max_position_gap_m']:.1e} m apart, ATE filter {mean['filter_ate_m']:.3f} -> "
        f"smoothed {mean['smoothed_ate_m']:.3f} m"
    )
    if args.json:
        write_text_atomically(args.json, json.dumps({"seeds": args.seeds, **mean}, indent=2) + "\n")


if __name__ == "__main__":
    main()
