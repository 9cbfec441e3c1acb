"""Batch smoothing of a wall-SLAM run (``rperc.slam.smoothing``) against the
numpy/scipy peer (``tests/oracles/wall_smoother.py``: the same problem, scipy's sparse
finite differences and SuperLU), timed in the same run on the same filter output:
seconds per smoothing, the ratio, and how far the two optima are apart.

    python benchmarks/wall_smoother.py [--logs intel.log aces.log] [--seeds 3] [--json out.json]

Without ``--logs``, the simulated corridor loop of ``rperc demo wall-slam`` (and the
Intel and ACES logs when ``RPERC_DATA`` holds them).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from _oracles import wall_smoother as ref
from _timing import against_peer

from rperc._atomic import write_text_atomically
from rperc.datasets import data_dir
from rperc.datasets.carmen import load_carmen
from rperc.scansim import write_loop_log
from rperc.slam import wallslam as ws
from rperc.slam.smoothing import smooth_walls


def one_run(prepared: ws.PreparedLog, seed: int) -> dict[str, float]:
    res, controls, out = ref.wallslam_run(prepared, seed)
    t = prepared.t
    t0 = time.perf_counter()
    sm = smooth_walls(out, controls, prepared.rows, t)
    ours = time.perf_counter() - t0
    t0 = time.perf_counter()
    peer = ref.smooth(ref.wallslam_problem(prepared, controls, out))
    theirs = time.perf_counter() - t0
    return {
        **against_peer(ours, theirs, sm.pose, peer["pose"]),
        "iterations": sm.iterations,
        "peer_iterations": peer["iterations"],
        "filter_ate_m": res.metrics["ate_rmse"],
        "smoothed_ate_m": ws.score(sm.pose, sm.covariance, prepared.reference,
                                   ws.loop_pairs(prepared.reference))["ate_rmse"],
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--logs", nargs="*", type=Path)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    logs: list[tuple[str, Any, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        if not args.logs:
            logs.append(("simulated loop", load_carmen(write_loop_log(Path(tmp) / "l.log")), 0.0))
            data = (data_dir() or Path("data")) / "carmen"
            args.logs = [p for p in (data / "intel.log", data / "aces.log") if p.is_file()]
        logs += [(p.name, load_carmen(p), ws.STRAIGHTNESS) for p in args.logs]
        report = {}
        for name, log, straightness in logs:
            prepared = ws.prepare(log, straightness=straightness)
            runs = [one_run(prepared, seed) for seed in range(args.seeds)]
            mean = {k: float(np.mean([r[k] for r in runs])) for k in runs[0]}
            report[name] = {"scans": len(prepared.t), "seeds": args.seeds, **mean}
            print(
                f"{name}: {len(prepared.t)} scans, rperc {mean['rperc_s']:.3f} s, "
                f"peer {mean['peer_s']:.2f} s ({mean['ratio']:.0f}x), optima "
                f"{mean['max_position_gap_m']:.1e} m apart, ATE filter "
                f"{mean['filter_ate_m']:.3f} -> smoothed {mean['smoothed_ate_m']:.3f} m"
            )
    if args.json:
        write_text_atomically(args.json, json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
