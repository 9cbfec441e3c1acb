"""How far the wall-SLAM filter's causal path is from the best causal estimate that
its sightings allow. For each scan ``k``, the batch optimum over the data up to ``k``
(the smoother of ``rperc.slam.smoothing``, with the filter's data association) gives
the pose at ``k``. No estimator that sees only the past can do better with the same
sightings, association and noise models; the EKF's linearisation is all it can lose
on top. The full smoothing (every sighting, both ways in time) is scored alongside.
The score is against the log's corrected path, with the noisy odometry of
``rperc.slam.wallslam`` (seeds as in ``wall_fig7.py``).

    python benchmarks/wall_causal_bound.py [--logs intel.log aces.log] [--seeds 10]
        [--every 1] [--oracle] [--vague] [--json out.json]

Each scan's solve costs about as much as a full smoothing of the run so far, so the
whole is quadratic in the scans: about 35 s a seed on Intel's 910 scans. Ctrl-C stops
it between iterations of a solve.

``--oracle`` runs both again with an oracle association: the sightings grouped by
their lines placed with the corrected path (``oracle_pairing``), the vague ones too
with ``--vague``. It is built from the reference, so it is a diagnosis (what a better
association could reach), not an estimator. ``--every N`` solves at every N-th scan
only and scores those scans (a quick look; the figures in the README use 1).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from _oracles import wall_smoother

from rperc import _rperc
from rperc._atomic import write_text_atomically
from rperc.datasets import data_dir
from rperc.datasets.carmen import load_carmen
from rperc.pose import to_frame, to_world
from rperc.slam import wallslam as ws

#: Oracle grouping: a sighting joins a group whose line is within this angle (deg),
#: whose line both its ends are within this distance of (m), and whose extent it
#: meets within this gap (m, the filter's default ``wall_overlap_gap``).
ORACLE_ANGLE_DEG, ORACLE_OFFSET, ORACLE_GAP = 3.0, 0.10, 0.5


def _ends_in_world(pose: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A sighting's segment end points placed with ``pose``."""
    a, b = to_world(pose, row[6:10].reshape(2, 2))
    return a, b


def _line(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The world line ``(rho >= 0, alpha)`` through two points."""
    d = b - a
    n = np.array([-d[1], d[0]]) / np.hypot(*d)
    rho = float(n @ a)
    if rho < 0:
        n, rho = -n, -rho
    return np.array([rho, math.atan2(n[1], n[0])])


def _placement(group: dict[str, Any], a: np.ndarray, b: np.ndarray) -> tuple[float, float] | None:
    """Where segment ``a b`` lies along ``group``'s line, or
    ``None`` when it is not on it (``ORACLE_*``)."""
    d = (b - a) / np.hypot(*(b - a))
    if abs(d @ group["normal"]) > math.sin(math.radians(ORACLE_ANGLE_DEG)):
        return None
    off = [abs((p - group["at"]) @ group["normal"]) for p in (a, b)]
    lo, hi = sorted(float((p - group["at"]) @ group["dir"]) for p in (a, b))
    if max(off) > ORACLE_OFFSET or max(lo, group["lo"]) - min(hi, group["hi"]) > ORACLE_GAP:
        return None
    return lo, hi


def oracle_pairing(prepared: ws.PreparedLog, *, vague: bool = False) -> np.ndarray:
    """Each sighting's group (-1 when left out): greedy, in time order, the first group
    whose line the sighting placed with the reference path lies on (``ORACLE_*``), or
    a new group. Vague sightings (angle sd over the filter's 2-degree limit) are left
    out unless ``vague``."""
    rows, ref = prepared.rows, prepared.reference
    scan = np.searchsorted(prepared.t, rows[:, 0])
    use = vague | (rows[:, 5] <= math.radians(2.0) ** 2)
    groups: list[dict[str, Any]] = []
    pairing = np.full(len(rows), -1, dtype=np.int64)
    for i in np.flatnonzero(use):
        a, b = _ends_in_world(ref[scan[i]], rows[i])
        for j, group in enumerate(groups):
            span = _placement(group, a, b)
            if span is not None:
                group["lo"], group["hi"] = min(group["lo"], span[0]), max(group["hi"], span[1])
                pairing[i] = j
                break
        else:
            d = (b - a) / np.hypot(*(b - a))
            half = float(np.hypot(*(b - a))) / 2
            groups.append({"normal": np.array([-d[1], d[0]]), "dir": d, "at": (a + b) / 2,
                           "lo": -half, "hi": half})  # fmt: skip
            pairing[i] = len(groups) - 1
    return pairing


def starting_lines(prepared: ws.PreparedLog, pairing: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Each group's first sighting as a world line placed with ``poses`` (one per scan)."""
    rows = prepared.rows
    scan = np.searchsorted(prepared.t, rows[:, 0])
    ids = np.unique(pairing[pairing >= 0])
    first = [int(np.flatnonzero(pairing == i)[0]) for i in ids]
    return np.array([_line(*_ends_in_world(poses[scan[f]], rows[f])) for f in first]).reshape(-1, 2)


def smooth_upto(
    k: int, controls: np.ndarray, prepared: ws.PreparedLog, pairing: np.ndarray,
    walls: tuple[np.ndarray, np.ndarray], start: np.ndarray, config: dict[str, Any],
    tolerance: float = 1e-9,
) -> _rperc.SmoothedRun:  # fmt: skip
    """The smoother over the data up to scan ``k`` (the controls until its time, the
    sightings at or before it), from the poses ``start`` (``k + 1`` rows); ``walls``
    are every group's ids and starting lines, of which those seen so far are used.
    ``tolerance`` is the smoother's (a step lowering the cost by less stops it)."""
    t, rows = prepared.t, prepared.rows
    seen = rows[:, 0] <= t[k]
    pair = pairing[seen]
    ids, lines = walls
    keep = np.isin(ids, pair[pair >= 0])
    c = np.r_[controls[controls[:, 0] < t[k]], [[t[k], 0.0, 0.0]]]
    out = _rperc.planar_smooth(
        c, np.ascontiguousarray(t[: k + 1]), np.ascontiguousarray(start),
        np.ascontiguousarray(rows[seen]), np.ascontiguousarray(pair, dtype=np.int64),
        np.ascontiguousarray(ids[keep], dtype=np.int64), np.ascontiguousarray(lines[keep]),
        np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)),
        config, {"max_iterations": 100, "tolerance": tolerance},
    )  # fmt: skip
    return out


def _step(previous: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``previous`` moved by the relative pose from ``a`` to ``b``."""
    moved = to_world(previous, to_frame(a, b[:2]))[0]
    return np.array([moved[0], moved[1], previous[2] + b[2] - a[2]])


def causal_path(
    controls: np.ndarray, prepared: ws.PreparedLog, pairing: np.ndarray,
    walls: tuple[np.ndarray, np.ndarray], filtered: np.ndarray, config: dict[str, Any],
    every: int = 1, tolerance: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The scans solved (every ``every``-th and the last) and the causal pose at each:
    the optimum over the data up to it. Each solve starts from the previous optimum,
    with the filter's last step appended."""
    scans = np.unique(np.r_[np.arange(every, len(prepared.t), every), len(prepared.t) - 1])
    poses = [filtered[0]]
    prev = filtered[:1]
    for k in scans:
        start = np.r_[prev, filtered[len(prev) : k + 1]]
        for j in range(len(prev), k + 1):  # the filter's steps, from the last optimum
            start[j] = _step(start[j - 1], filtered[j - 1], filtered[j])
        prev = smooth_upto(int(k), controls, prepared, pairing, walls, start, config,
                           tolerance).pose  # fmt: skip
        poses.append(prev[-1])
    return np.r_[0, scans], np.array(poses)


def ate(est: np.ndarray, ref: np.ndarray) -> float:
    """Position RMSE, not aligned (every run starts at the reference's first pose)."""
    return float(np.sqrt(np.mean(np.sum((est[:, :2] - ref[:, :2]) ** 2, axis=1))))


def one_seed(prepared: ws.PreparedLog, seed: int, args: argparse.Namespace) -> dict[str, float]:
    """Filter, causal optimum and full smoothing of one seed (and with the oracle)."""
    _, controls, out = wall_smoother.wallslam_run(prepared, seed)
    filtered, _ = ws.at_scans(out, prepared.t)
    ref = prepared.reference
    row: dict[str, float] = {}
    associations = [("filter", out.wall_pairing, (out.walls.id, out.walls.line))]
    if args.oracle:
        pairing = oracle_pairing(prepared, vague=args.vague)
        ids = np.unique(pairing[pairing >= 0])
        associations.append(("oracle", pairing, (ids, starting_lines(prepared, pairing, filtered))))
    for name, pairing, walls in associations:
        t0 = time.perf_counter()
        scans, causal = causal_path(controls, prepared, pairing, walls, filtered, out.config,
                                    args.every)  # fmt: skip
        row[f"{name}_causal_s"] = time.perf_counter() - t0
        row[f"{name}_causal_ate_m"] = ate(causal, ref[scans])
        full = smooth_upto(len(ref) - 1, controls, prepared, pairing, walls, filtered, out.config)
        row[f"{name}_smoothed_ate_m"] = ate(full.pose, ref)
        nees = ws.pose_nees(full.pose, full.covariance, ref)
        row[f"{name}_smoothed_nees"] = float(np.mean(nees))
    row["ekf_ate_m"] = ate(filtered[scans], ref[scans])
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    data = (data_dir() or Path("data")) / "carmen"
    ap.add_argument("--logs", nargs="+", type=Path, default=[data / "intel.log", data / "aces.log"])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--every", type=int, default=1, help="solve at every N-th scan")
    ap.add_argument("--oracle", action="store_true", help="also the reference-grouped association")
    ap.add_argument("--vague", action="store_true", help="the oracle groups vague sightings too")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    if args.every < 1 or args.seeds < 1:
        ap.error("--every and --seeds must be >= 1")
    report = {}
    for path in args.logs:
        prepared = ws.prepare(load_carmen(path), straightness=ws.STRAIGHTNESS)
        rows = [one_seed(prepared, seed, args) for seed in range(args.seeds)]
        for seed, r in enumerate(rows):
            print(path.name, seed, "  ".join(f"{k} {v:.3f}" for k, v in r.items()))
        mean = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
        report[path.name] = {"seeds": args.seeds, "every": args.every, "mean": mean, "runs": rows}
        print(f"{path.name} mean over {args.seeds} seeds: "
              + "  ".join(f"{k} {v:.3f}" for k, v in mean.items()))  # fmt: skip
    if args.json:
        write_text_atomically(args.json, json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
