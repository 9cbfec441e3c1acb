"""The seed's Fig. 7 experiment on the CARMEN Intel and ACES logs (issue 11, part 4).

Real scans, the corrected path as the reference, and odometry made from the corrected
path's increments with seeded noise of stated levels. Each scan step is driven as
three unicycle controls (turn, straight, turn), each held for a synthetic time equal
to its effective length (1 m of travel or 2 rad of turn = 1 s), so constant
control-noise variances are noise per effective metre:

- speed: standard deviation 5 % of the effective distance (0.05 m/s),
- turn rate: 1 degree per effective metre (1 deg/s),
- bias (unknown to the filter): +1 % on distance, +0.1 degree per metre of heading.

The filter's motion noise is exactly the stated noise (not tuned on these logs); the
wall extractor runs with its defaults (sensor range from the log). Three runs per
seed: odometry only, plain EKF with wall landmarks, and anchored (first wall) with
freezing after 50 revisions (the text under Fig. 7). Scores against the corrected
path, at every scan: ATE RMSE (not aligned: every run starts at the reference's first
pose), the error at loop closures (relative displacement between two scans whose
reference positions are within 1 m after more than 10 m of path), the final pose
error, and the robot NEES.

    python benchmarks/wall_fig7.py --seeds 10 --json out.json [--plot fig7.png]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from rperc import _rperc
from rperc.datasets.carmen import load_carmen
from rperc.linesimp import extract_lines
from rperc.slam.wallslam import (
    SPEED_SIGMA,
    TURN_SIGMA,
    increments,
    loop_pairs,
    noisy_controls,
    score,
    straightness_covariance,
)


def wall_rows(log: Any, t: np.ndarray, straightness: float = 0.0) -> tuple[np.ndarray, float]:
    """Every scan's walls as rows ``(t, rho, alpha, var_rho, cov, var_alpha, x0, y0,
    x1, y1)``, and the share of valid readings the walls use."""
    scans = log.scans
    rows, used, valid = [], 0, 0
    for k in range(len(scans)):
        n = int(scans.num_beams[k])
        r = scans.ranges[k, :n]
        walls = extract_lines(r, scans.angles(k), max_range=float(scans.max_range[k]))
        valid += int(np.sum(np.isfinite(r) & (r > 0) & (r < scans.max_range[k])))
        used += len(walls.flat_indices)
        c = walls.cov
        if straightness > 0:
            c = c + straightness_covariance(
                walls.rho, walls.alpha, walls.start, walls.end, straightness
            )
        rows.append(
            np.c_[
                np.full(len(walls), t[k]),
                walls.rho,
                walls.alpha,
                c[:, 0, 0],
                c[:, 0, 1],
                c[:, 1, 1],
                walls.start,
                walls.end,
            ]
        )
    return np.concatenate(rows).reshape(-1, 10), used / max(valid, 1)


def at_scans(out: dict[str, Any], t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The robot pose and covariance after the last event at each scan time."""
    rows = np.searchsorted(out["t"], t, side="right") - 1
    return out["pose"][rows], out["covariance"][rows]


METHODS: dict[str, dict[str, Any]] = {
    "odometry": {},
    "plain": {},
    "anchored_freeze50": {"anchor": True, "freeze_after": 50},
    # Not in the figure: freezing as consider states (Schmidt) instead of the seed's
    # marginalisation, which counts a frozen wall's covariance again at every sighting.
    "anchored_consider50": {"anchor": True, "freeze_after": 50, "freeze_mode": "consider"},
}


def run_log(
    path: Path, seeds: int, straightness: float = 0.0, association: str = "nn"
) -> dict[str, Any]:
    log = load_carmen(path)
    ref = np.asarray(log.scans.pose, dtype=float)
    exact, t = increments(ref)
    t0 = time.perf_counter()
    walls, used = wall_rows(log, t, straightness)
    extract_s = time.perf_counter() - t0
    pairs = loop_pairs(ref)
    base = {
        "motion": {
            "unicycle": {
                "speed_variance": SPEED_SIGMA**2,
                "turn_rate_variance": TURN_SIGMA**2,
            }
        },
        "association": association,
        "initial_pose": ref[0].tolist(),
    }
    results: dict[str, list[dict[str, float]]] = {m: [] for m in METHODS}
    last: dict[str, Any] = {}
    seconds: dict[str, float] = {m: 0.0 for m in METHODS}
    for seed in range(seeds):
        controls = np.r_[noisy_controls(exact, seed), [[t[-1], 0.0, 0.0]]]
        for name, extra in METHODS.items():
            rows = walls if name != "odometry" else np.zeros((0, 10))
            s0 = time.perf_counter()
            out = _rperc.planar_slam_run(
                controls, np.zeros((0, 3)), None, None, {**base, **extra}, rows
            )
            seconds[name] += time.perf_counter() - s0
            est, cov = at_scans(out, t)
            sc = score(est, cov, ref, pairs)
            sc["walls"] = len(out["wall_id"])
            sc.update({f"stat_{k}": int(v) for k, v in out["statistics"].items()})
            results[name].append(sc)
            if seed == 0:
                last[name] = (est, out)
    summary = {
        name: {
            key: {"mean": float(np.mean(v)), "std": float(np.std(v, ddof=1)) if seeds > 1 else 0.0}
            for key in runs[0]
            for v in [[r[key] for r in runs]]
        }
        for name, runs in results.items()
    }
    return {
        "log": path.name,
        "scans": len(ref),
        "path_length_m": float(np.sum(np.hypot(*np.diff(ref[:, :2], axis=0).T))),
        "wall_rows": len(walls),
        "readings_used": used,
        "loop_pairs": len(pairs),
        "extract_seconds": extract_s,
        "slam_seconds_per_run": {m: s / seeds for m, s in seconds.items()},
        "seeds": seeds,
        "summary": summary,
        "_seed0": last,
        "_ref": ref,
    }


def plot(results: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 3, figsize=(15, 5 * len(results)), squeeze=False)
    for row, res in zip(axes, results, strict=True):
        ref = res["_ref"]
        for ax, name in zip(row, list(METHODS)[:3], strict=True):
            est, out = res["_seed0"][name]
            for (x0, y0), (x1, y1) in out["wall_ends"]:
                ax.plot([x0, x1], [y0, y1], "k-", lw=0.8)
            ax.plot(ref[:, 0], ref[:, 1], color="0.7", lw=2, label="corrected path (reference)")
            ax.plot(est[:, 0], est[:, 1], "C3-", lw=1, label="estimate")
            s = res["summary"][name]
            ax.set_title(
                f"{res['log']} {name}\nATE {s['ate_rmse']['mean']:.2f} m, "
                f"loop {s['loop_error']['mean']:.2f} m (seed 0 shown)"
            )
            ax.set_aspect("equal")
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    data = Path(__import__("os").environ.get("RPERC_DATA", "data")) / "carmen"
    ap.add_argument("--logs", nargs="+", default=[str(data / "intel.log"), str(data / "aces.log")])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--plot", type=Path)
    ap.add_argument(
        "--straightness", type=float, default=0.0,
        help="straightness floor sigma (m) added to every wall sighting; calibrate it on "
        "one log with benchmarks/wall_straightness.py",
    )  # fmt: skip
    ap.add_argument("--association", choices=("nn", "jcbb"), default="nn")
    args = ap.parse_args()
    results = [run_log(Path(p), args.seeds, args.straightness, args.association) for p in args.logs]
    for res in results:
        print(
            f"{res['log']}: {res['scans']} scans, {res['path_length_m']:.0f} m, "
            f"{res['wall_rows']} walls seen, readings used {100 * res['readings_used']:.0f} %, "
            f"{res['loop_pairs']} loop-closure scans, extract {res['extract_seconds']:.2f} s"
        )
        for name, s in res["summary"].items():
            cells = ", ".join(
                f"{k} {v['mean']:.3f}+-{v['std']:.3f}"
                for k, v in s.items()
                if k
                in ("ate_rmse", "loop_error", "final_error", "nees_mean", "nees_in_band", "walls")
            )
            secs = res["slam_seconds_per_run"][name]
            print(f"  {name:18s} {cells}, {secs:.2f} s/run")
    if args.json:
        clean = [{k: v for k, v in r.items() if not k.startswith("_")} for r in results]
        args.json.write_text(json.dumps(clean, indent=2))
    if args.plot:
        plot(results, args.plot)


if __name__ == "__main__":
    main()
