"""The seed's Fig. 7 experiment on the CARMEN Intel and ACES logs (issue 11, part 4).

Real scans, the corrected path as the reference, and odometry made from the corrected
path's increments with seeded noise of stated levels (``rperc.slam.wallslam``: 5 % of
distance, 1 degree per metre of heading, and a bias the filter does not know: +1 % on
distance, +0.1 degree per metre). The filter's motion noise is the stated noise; the
walls come from the extractor's defaults with the straightness floor
(``wallslam.STRAIGHTNESS``, calibrated on ACES only). Runs per seed: odometry only,
plain EKF with wall landmarks, anchored (first wall) with freezing after 50 revisions
(the text under Fig. 7), and, not in the figure, anchored with consider (Schmidt)
freezing. Each run with walls is also smoothed (``rperc.slam.smoothing``: every pose,
wall and bias from all of the scans, with the filter's association), scored as
``<run>+smoothed``. Scores against the corrected path at every scan (``wallslam.score``): ATE
RMSE (not aligned), loop-closure error, final pose error, and the robot NEES (its
mean, and the share of scans inside chi-square's two-sided 95 % band for 3 dof).

    python benchmarks/wall_fig7.py --seeds 10 --json out.json [--plot fig7.png]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from rperc._atomic import write_text_atomically
from rperc.datasets import data_dir
from rperc.datasets.carmen import load_carmen
from rperc.slam import wallslam as ws

METHODS: dict[str, dict[str, Any]] = {
    **ws.METHODS,
    "anchored_consider50": {"anchor": True, "freeze_after": 50, "freeze_mode": "consider"},
}
KEYS = ("ate_rmse", "loop_error", "final_error", "nees_mean", "nees_in_band", "walls")


def run_log(path: Path, seeds: int, straightness: float, association: str) -> dict[str, Any]:
    prepared = ws.prepare(load_carmen(path), straightness=straightness)
    names = [*METHODS, *(f"{m}+smoothed" for m in METHODS if m != "odometry")]
    results: dict[str, list[dict[str, float]]] = {m: [] for m in names}
    seconds = dict.fromkeys(names, 0.0)
    first: dict[str, ws.WallSlamResult] = {}
    for seed in range(seeds):
        for name, extra in METHODS.items():
            t0 = time.perf_counter()
            walls = name != "odometry"
            res = ws.run_prepared(
                prepared, seed=seed, use_walls=walls, association=association, smooth=walls,
                **extra,
            )  # fmt: skip
            seconds[name] += time.perf_counter() - t0 - res.seconds["smooth"]
            results[name].append({**res.metrics, "walls": float(res.counts["walls"])})
            first.setdefault(name, res)
            if walls:
                smoothed = res.smoothed()
                seconds[f"{name}+smoothed"] += res.seconds["smooth"]
                results[f"{name}+smoothed"].append(
                    {**smoothed.metrics, "walls": float(res.counts["walls"])}
                )
                first.setdefault(f"{name}+smoothed", smoothed)
    summary = {
        name: {
            k: {"mean": float(np.mean(v)), "std": float(np.std(v, ddof=1)) if seeds > 1 else 0.0}
            for k in runs[0]
            for v in [[r[k] for r in runs]]
        }
        for name, runs in results.items()
    }
    ref = prepared.reference
    return {
        "log": path.name,
        "scans": len(ref),
        "path_length_m": float(np.sum(np.hypot(*np.diff(ref[:, :2], axis=0).T))),
        "wall_rows": len(prepared.rows),
        "readings_used": prepared.readings_used / max(prepared.readings_valid, 1),
        "loop_pairs": int(first["plain"].counts["loop_pairs"]),
        "extract_seconds": prepared.extract_seconds,
        "slam_seconds_per_run": {m: s / seeds for m, s in seconds.items()},
        "seeds": seeds,
        "straightness": straightness,
        "association": association,
        "summary": summary,
        "_seed0": first,
        "_prepared": prepared,
    }


def plot(results: list[dict[str, Any]], path: Path) -> None:
    from rperc.plot import save
    from rperc.plot.wallslam import wall_maps_figure

    for res in results:
        runs = [(name, res["_seed0"][name]) for name in [*ws.METHODS, "plain+smoothed"]]
        prepared = res["_prepared"]
        s = res["summary"]
        title = (
            f"{res['log']}, seed 0 shown; over {res['seeds']} seeds ATE "
            + " / ".join(f"{s[n]['ate_rmse']['mean']:.2f}" for n in ws.METHODS)
            + f" / {s['plain+smoothed']['ate_rmse']['mean']:.2f}"
            + " m (odometry / plain / anchored+freeze50 / plain smoothed)"
        )
        fig = wall_maps_figure(
            runs, title=title, reference_label="corrected path (reference)",
            sightings=(prepared.rows, prepared.t),
        )  # fmt: skip
        save(fig, path.with_name(f"{path.stem}_{Path(res['log']).stem}{path.suffix}"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    data = (data_dir() or Path("data")) / "carmen"
    ap.add_argument("--logs", nargs="+", default=[str(data / "intel.log"), str(data / "aces.log")])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--plot", type=Path, help="one figure per log, the log's name appended")
    ap.add_argument(
        "--straightness", type=float, default=ws.STRAIGHTNESS,
        help="straightness floor sigma (m) added to every wall sighting",
    )  # fmt: skip
    ap.add_argument("--association", choices=("nn", "jcbb"), default="jcbb")
    args = ap.parse_args()
    results = [run_log(Path(p), args.seeds, args.straightness, args.association) for p in args.logs]
    for res in results:
        print(
            f"{res['log']}: {res['scans']} scans, {res['path_length_m']:.0f} m, "
            f"{res['wall_rows']} walls seen, readings used {100 * res['readings_used']:.0f} %, "
            f"{res['loop_pairs']} loop-closure scans, extract {res['extract_seconds']:.2f} s"
        )
        for name, s in res["summary"].items():
            cells = ", ".join(f"{k} {s[k]['mean']:.3f}+-{s[k]['std']:.3f}" for k in KEYS)
            secs = res["slam_seconds_per_run"][name]
            print(f"  {name:30s} {cells}, {secs:.3f} s/run")
    if args.json:
        clean = [{k: v for k, v in r.items() if not k.startswith("_")} for r in results]
        write_text_atomically(args.json, json.dumps(clean, indent=2) + "\n")
    if args.plot:
        plot(results, args.plot)


if __name__ == "__main__":
    main()
