"""Planar EKF-SLAM on whole recordings (issue 10): rperc against the numpy EKF-SLAM of
``tests/oracles/planar_ekf.py`` (PythonRobotics style, the same models; the structured
O(n^2) form a careful numpy user writes), in the same run, with whole-run times,
ratios and accuracies, and the cost growth with the number of landmarks.

- MR.CLAM robot 1, known association: rperc with the reference's hand-set noise is
  the same EKF as the reference (the largest path difference is printed; the tests
  check 1e-6 m), and the ratio is quoted against it; rperc's calibrated preset is
  shown for accuracy. ATE after SE(2) alignment against Vicon.
- Victoria Park: rperc's preset (JCBB, 3 sightings before a landmark) against the
  reference with the same settings and the same association, which the reference
  implements itself in Python (individual gate, recursive JCBB, candidate list), so
  both times include association. rperc runs twice: compressed (the preset's default,
  the compressed EKF of Guivant & Nebot 2001) and full (``compression="off"``, the
  full EKF at every scan, the same algorithm as the reference). Printed: the
  whole-run times (rperc: median of 3 interleaved runs each; numpy: one run) and the
  ratios to the structured numpy reference (the fair peer), the RMS distance of each
  laser path to the plausible GPS fixes after one rigid alignment, the landmark
  counts and association statistics, and the largest differences between the runs
  (compressed vs full: path, landmark means and covariances). ``--vp-scans N`` runs
  only the first N scans (the headline is the whole run); ``--dense-scans N`` also
  times the dense textbook numpy EKF (O(n^3) per update) on the first N scans
  (0: skip), against rperc on the same prefix.
- Growth with the number of landmarks n: rperc's engine per event by its own clock
  (a prediction; an update with one detection), full and compressed, on a map of n
  landmarks spread over a grid of which the robot sees the nearest few; and one
  prediction and one update called from Python, rperc's ``Ekf`` and the numpy peer,
  on a dense random covariance (the Python calls carry a few microseconds of
  overhead). The slope of log time against log n, fitted over the three largest n
  (and between successive n), should be about 1 for a full prediction and 2 for a
  full update, and about 0 compressed (the active area does not grow with the map;
  ``cargo bench -p slam --features bench --bench planar`` measures the same).
- Both run on one thread by default (rperc's rayon pool and numpy's BLAS; see
  below); the machine may be shared, so each figure is a best or median of repeats,
  and ratios come from the same run.

    RPERC_DATA=../shared/data python benchmarks/planar_slam.py [--vp-scans N]
        [--skip-reference-vp] [--dense-scans N]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

# The same threads for both (set before numpy and rayon start): one by default, for
# rperc's rayon pool (its update splits P's columns over threads from a state of 384
# on) and numpy's BLAS. On this shared 2-core machine a threaded OpenBLAS
# oversubscribed the cores and the numpy update got up to 7x slower (n = 400), which
# would flatter rperc. OPENBLAS_NUM_THREADS=2 runs both on two threads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", os.environ["OPENBLAS_NUM_THREADS"])
os.environ.setdefault("MKL_NUM_THREADS", os.environ["OPENBLAS_NUM_THREADS"])
os.environ.setdefault("RAYON_NUM_THREADS", os.environ["OPENBLAS_NUM_THREADS"])

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _oracles import planar_ekf as ref
from _timing import best_time, fmt_seconds, print_table

from rperc.datasets import data_dir
from rperc.slam import PlanarSlam, evaluation
from rperc.slam.planar import (
    PRESETS,
    defaults,
    mrclam_recording,
    point_path,
    victoria_recording,
)

DATA = data_dir() or Path("data")


AGREEMENT: list[str] = []  # how closely rperc and the reference agree, per data set


def timed(fn):  # type: ignore[no-untyped-def]
    """``(result, wall seconds, CPU seconds of the process)``: on a shared machine the
    CPU time counts only the time the run was on a core, so its ratios hold better."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def fmt_times(wall: float, cpu: float) -> str:
    return f"{fmt_seconds(wall).strip()} / {fmt_seconds(cpu).strip()}"


def fmt_ratio(theirs: tuple[float, float], ours: tuple[float, float]) -> str:
    return f"{theirs[0] / ours[0]:.0f}x / {theirs[1] / ours[1]:.0f}x"


def mrclam_rows() -> list[list[str]]:
    """rperc with the reference's settings (the same EKF: the ratio is quoted against
    it), the reference, and rperc's calibrated preset (accuracy only)."""
    from rperc.datasets import load_mrclam

    run = load_mrclam(DATA / "mrclam6", robot=1)
    pose0 = ref.initial_pose(run)
    start = {"initial_pose": pose0.tolist(), "initial_pose_variance": [1e-6] * 3}
    same = {"motion": {"unicycle": {"speed_variance": 0.1**2, "turn_rate_variance": 0.2**2}},
            "range_variance": 0.1**2, "bearing_variance": 0.05**2, **start}  # fmt: skip
    rec = mrclam_recording(run)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    rows, results = [], {}
    for label, cfg in (("rperc (numpy's settings)", same),
                       ("rperc preset (calibrated)", {**PRESETS["mrclam"], **start})):  # fmt: skip
        runs = [timed(lambda cfg=cfg: PlanarSlam(cfg).run(rec)) for _ in range(5)]
        res, t = runs[0][0], (min(r[1] for r in runs), min(r[2] for r in runs))
        results[label] = (res, t)
        rows.append(["MR.CLAM r1, known", label, fmt_times(*t), "",
                     f"ATE {res.ate(run.truth_t, truth, align=True).rmse:.3f} m",
                     str(len(res.landmark_id))])  # fmt: skip
    slam = ref.PlanarEkfSlam(
        pose=pose0, pose_covariance=np.eye(3) * 1e-6,
        control_noise=np.diag([0.1**2, 0.2**2]), measurement_noise=np.diag([0.1**2, 0.05**2]),
        structured=True,
    )  # fmt: skip
    theirs, *t_theirs = timed(lambda: ref.run_mrclam(run, slam))
    ate_ref = evaluation.ate(theirs.t, theirs.poses, run.truth_t, truth, align=True).rmse
    ours, t_ours = results["rperc (numpy's settings)"]
    rows.insert(1, ["MR.CLAM r1, known", "numpy (structured)", fmt_times(*t_theirs),
                    fmt_ratio(t_theirs, t_ours), f"ATE {ate_ref:.3f} m",
                    str(len(theirs.landmarks))])  # fmt: skip
    gap = np.linalg.norm(ours.pose[ours.kind == 0, :2] - theirs.poses[:, :2], axis=1)
    AGREEMENT.append(
        f"MR.CLAM: rperc with numpy's settings and numpy differ by at most {gap.max():.2e} m "
        "over the run; rperc: best of 5 runs, numpy: one run."
    )
    return rows


def victoria_rows(with_reference: bool, scans: int | None, dense_scans: int) -> list[list[str]]:
    """rperc's Victoria Park preset, compressed and full, against the numpy reference
    with the same settings and association (JCBB, 3 sightings before a landmark), the
    whole run or its first ``scans`` scans; prints how closely they agree."""
    from rperc.datasets import load_victoria_park
    from rperc.datasets.victoria_park import LASER_MOUNT

    park = load_victoria_park(DATA / "victoria_park")
    keep = park.gps_plausible()  # screened on the whole run, by the GPS alone
    t_gps, gps = park.gps_t[keep], np.c_[park.gps_x, park.gps_y][keep]
    if scans is not None:
        park = ref.first_scans(park, scans)

    def gps_rms(t: np.ndarray, pose: np.ndarray) -> float:
        return evaluation.gps_error(t, point_path(pose, LASER_MOUNT), t_gps, gps).rms

    configs = {"rperc compressed": PRESETS["victoria"],
               "rperc full": {**PRESETS["victoria"], "compression": "off"}}  # fmt: skip
    name = f"Victoria Park{'' if scans is None else f' ({scans} scans)'}, jcbb, k=3"
    rec = victoria_recording(park)
    # Three whole runs of each, interleaved (the machine may be shared): medians quoted.
    runs: dict[str, list[tuple[Any, float, float]]] = {label: [] for label in configs}
    for _ in range(3):
        for label, cfg in configs.items():
            runs[label].append(timed(lambda cfg=cfg: PlanarSlam(cfg).run(rec)))
    ours = {label: (r[0][0], (float(np.median([x[1] for x in r])),
                              float(np.median([x[2] for x in r]))))
            for label, r in runs.items()}  # fmt: skip
    theirs, t_theirs = None, (0.0, 0.0)
    if with_reference:
        slam = ref.ackermann_filter({**defaults(), **PRESETS["victoria"]})
        theirs, *t = timed(lambda: ref.run_victoria_park(park, slam))
        t_theirs = (t[0], t[1])
    rows = []
    for label, (res, t_ours) in ours.items():
        s = res.statistics
        counts = f"acc {s['accepted']} rej {s['rejected']} new {s['new']} cand {s['candidate']}"
        ratio = fmt_ratio(t_theirs, t_ours) if theirs is not None else ""
        rows.append([name, label, fmt_times(*t_ours), ratio,
                     f"GPS {gps_rms(*res.path()[:2]):.3f} m", str(len(res.landmark_id)),
                     counts])  # fmt: skip
    compressed, full = ours["rperc compressed"][0], ours["rperc full"][0]
    AGREEMENT.append(
        f"{name}: compressed vs full rperc: paths differ by at most "
        f"{path_gap(compressed, full):.2e} m, landmarks by {landmark_gap(compressed, full):.2e} "
        f"(means, m; covariances, m^2), statistics "
        f"{'equal' if same_counts(compressed.statistics, full.statistics) else 'DIFFERENT'}; "
        f"the compressed run made {compressed.statistics['compressions']} active areas "
        f"(a global update each) and activated {compressed.statistics['activations']} passive "
        f"landmarks. rperc: medians of 3 runs (wall / CPU: "
        + "; ".join(
            f"{k}: {', '.join(f'{x[1]:.2f}/{x[2]:.2f}' for x in v)} s" for k, v in runs.items()
        )
        + ")."
    )
    if theirs is not None:
        st = theirs.stats
        counts = f"acc {st.accepted} rej {st.rejected} new {st.new} cand {st.candidate}"
        rows.append([name, "numpy (structured)", fmt_times(*t_theirs), "1x",
                     f"GPS {gps_rms(theirs.t, theirs.poses):.3f} m", str(len(theirs.landmarks)),
                     counts])  # fmt: skip
        # rperc's pose right after each control event is the reference's pose at that
        # control's time (both have predicted to it, and neither has seen a scan at it).
        gap = np.linalg.norm(
            compressed.pose[compressed.kind == 0, :2] - theirs.poses[:, :2], axis=1
        )
        AGREEMENT.append(
            f"{name}: same association in rperc and numpy (rperc's engine; the reference's "
            f"own Python port), timed whole runs including association. rperc compressed and "
            f"numpy paths differ by at most {gap.max():.2e} m over {len(gap)} control times; "
            f"landmarks {len(compressed.landmark_id)} vs {len(theirs.landmarks)}; statistics "
            f"{'equal' if same_statistics(compressed.statistics, st) else 'DIFFERENT'}; JCBB "
            f"out of nodes in {compressed.statistics['jcbb_truncated']} vs {st.truncated} "
            "scans; numpy: one run."
        )
    if dense_scans > 0:
        rows += dense_rows(park, dense_scans)
    return rows


def dense_rows(park: Any, scans: int) -> list[list[str]]:
    """The dense textbook numpy EKF (full ``H``, ``I - K H``: O(n^3) per update) on the
    first ``scans`` scans, against rperc compressed and full on the same prefix."""
    prefix = ref.first_scans(park, scans)
    rec = victoria_recording(prefix)
    name = f"Victoria Park ({scans} scans), jcbb, k=3"
    slam = ref.ackermann_filter({**defaults(), **PRESETS["victoria"]})
    slam.structured = False
    dense, *t_dense = timed(lambda: ref.run_victoria_park(prefix, slam))
    rows = []
    for label, cfg in (("rperc compressed", PRESETS["victoria"]),
                       ("rperc full", {**PRESETS["victoria"], "compression": "off"})):  # fmt: skip
        runs = [timed(lambda cfg=cfg: PlanarSlam(cfg).run(rec)) for _ in range(3)]
        t = (min(r[1] for r in runs), min(r[2] for r in runs))
        ratio = f"{fmt_ratio((t_dense[0], t_dense[1]), t)} (dense)"
        rows.append([name, label, fmt_times(*t), ratio, "", str(len(runs[0][0].landmark_id))])
    rows.append([name, "numpy (dense)", fmt_times(*t_dense), "1x", "", str(len(dense.landmarks))])
    return rows


def path_gap(a: Any, b: Any) -> float:
    """The largest distance between two runs' robot positions, event by event."""
    return float(np.max(np.linalg.norm(a.pose[:, :2] - b.pose[:, :2], axis=1)))


def landmark_gap(a: Any, b: Any) -> float:
    """The largest difference between two runs' landmark means and covariances."""
    if not np.array_equal(a.landmark_id, b.landmark_id):
        return float("inf")
    return float(max(np.abs(a.landmark_mean - b.landmark_mean).max(),
                     np.abs(a.landmark_covariance - b.landmark_covariance).max()))  # fmt: skip


def same_counts(a: dict[str, int], b: dict[str, int]) -> bool:
    """The association statistics agree (how the filter computed them aside)."""
    return all(a[k] == b[k] for k in ("accepted", "rejected", "new", "candidate", "frozen"))


def same_statistics(ours: dict[str, int], theirs: ref.AssociationStats) -> bool:
    keys = ("accepted", "rejected", "new", "candidate")
    return all(ours[k] == getattr(theirs, k) for k in keys)


def costs(n: int, rng: np.random.Generator) -> dict[str, float]:
    """Best-of-repeats seconds of one prediction and one range-bearing update called
    from Python, rperc's ``Ekf`` and the numpy peer, on a state of ``n`` landmarks
    with a dense random ``P``."""
    from rperc.slam import Ekf

    d = 3 + 2 * n
    x = rng.normal(size=d) * 20
    a = rng.normal(size=(d, 8))
    p = a @ a.T * 0.05 + np.eye(d) * 0.5
    ekf = Ekf(x, p, robot_dim=3, landmark_dim=2)
    z, r = np.array([10.0, 0.3]), np.diag([0.01, 0.001])
    fx, fv, v = np.eye(3), np.ones((3, 2)) * 0.01, np.diag([0.01, 0.001])
    peer = ref.PlanarEkfSlam(x[:3], p[:3, :3], v, r, structured=True)
    peer.x, peer.P = x.copy(), p.copy()
    # Best of repeats: the machine may be shared, and the minimum is the cost.
    return {
        "Ekf.predict": best_time(lambda: ekf.predict(x[:3], fx, fv, v), repeat=5, min_time=0.05),
        "Ekf.update": best_time(
            lambda: ekf.update_range_bearing(n // 2, z, r), repeat=5, min_time=0.1
        ),
        "numpy predict": best_time(lambda: peer.predict(0.5, 0.1, 0.01), repeat=3, min_time=0.05),
        "numpy update": best_time(lambda: peer.update([(n // 2, z)]), repeat=3, min_time=0.1),
    }


def engine_costs(n: int, rng: np.random.Generator, events: int = 400) -> dict[str, float]:
    """Least seconds per event (the least, as for a best of repeats) of rperc's SLAM
    engine by its own clock (native, no Python call), full and compressed, with ``n``
    landmarks mapped: a control event (one prediction) and a scan of one known
    landmark at a control's time (one update, no prediction). The landmarks lie on a
    jittered 5 m grid centred on the robot, which stands still (zero controls), maps
    them all from its first scan, then sees its 20 nearest in turn: the compressed
    filter's active area (15 m) stays the same whatever the map's size."""
    side = int(np.ceil(np.sqrt(n + 1)))
    grid = np.argwhere(np.ones((side, side))) - (side - 1) / 2
    grid = grid[np.argsort(np.hypot(*grid.T))][1 : n + 1]  # the robot's cell stays free
    xy = 5.0 * grid + rng.uniform(-1.0, 1.0, grid.shape)
    ranges, bearings = np.hypot(*xy.T), np.arctan2(xy[:, 1], xy[:, 0])
    t = 1.0 + 0.01 * np.arange(events)
    controls = np.c_[np.r_[0.0, t], np.zeros((events + 1, 2))]
    seen = np.arange(events // 2) % min(n, 20)  # a scan at every other control time
    detections = np.r_[np.c_[np.zeros(n), ranges, bearings],
                       np.c_[t[1::2][: len(seen)], ranges[seen], bearings[seen]]]  # fmt: skip
    ids = np.r_[np.arange(n), seen]
    out = {}
    for label, compression in (("full", "off"), ("compressed", "auto")):
        slam = PlanarSlam(association="known", compression=compression, active_radius=15.0)
        res = slam.run_arrays(controls, detections, detection_ids=ids)
        later = res.t > 0  # after the map is made
        out[f"engine predict ({label})"] = float(np.min(res.seconds[later & (res.kind == 0)]))
        out[f"engine update ({label})"] = float(np.min(res.seconds[later & (res.kind == 1)]))
    return out


def growth(sizes: list[int]) -> None:
    """Cost against the map size, with the fitted exponents."""
    rows: list[list[str]] = []
    logs: dict[str, list[float]] = {}
    rng = np.random.default_rng(0)
    for n in sizes:
        c = {**engine_costs(n, rng), **costs(n, rng)}
        for key, val in c.items():
            logs.setdefault(key, []).append(val)
        rows.append([str(n), *(fmt_seconds(c[k]) for k in c),
                     f"{c['numpy update'] / c['Ekf.update']:.1f}x"])  # fmt: skip
    print_table("cost against landmarks n: rperc's engine per event (its own clock), and one "
                "call from Python (random dense P)",
                ["n", *logs, "numpy / Ekf update"], rows)  # fmt: skip
    # A call's fixed cost (microseconds) hides the growth at small n: the exponent is
    # fitted over the three largest sizes, and the local ones show the trend.
    log_n = np.log(np.array(sizes, dtype=float))
    for key, vals in logs.items():
        log_t = np.log(np.array(vals))
        slope = np.polyfit(log_n[-3:], log_t[-3:], 1)[0]
        local = ", ".join(f"{v:.2f}" for v in np.diff(log_t) / np.diff(log_n))
        print(f"  {key}: time ~ n^{slope:.2f} (fit over n >= {sizes[-3]}); "
              f"between successive n: {local}")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--skip-reference-vp",
        action="store_true",
        help="skip the numpy run on Victoria Park (minutes)",
    )
    parser.add_argument("--vp-scans", type=int, default=None, metavar="N",
                        help="Victoria Park: its first N scans only (default: all)")  # fmt: skip
    parser.add_argument(
        "--dense-scans", type=int, default=300, metavar="N",
        help="Victoria Park: dense numpy EKF on the first N scans (0: skip)",
    )  # fmt: skip
    parser.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        default=[50, 100, 200, 400, 800, 1600],
        help="landmark counts for the growth (at least three, increasing)",
    )
    args = parser.parse_args()
    if len(args.sizes) < 3 or sorted(set(args.sizes)) != args.sizes:
        parser.error("--sizes needs at least three increasing sizes")
    if args.vp_scans is not None and args.vp_scans < 1:
        parser.error("--vp-scans must be >= 1")
    if args.dense_scans < 0:
        parser.error("--dense-scans must be >= 0")
    env = os.environ
    print(f"threads: rperc RAYON_NUM_THREADS={env['RAYON_NUM_THREADS']}, numpy "
          f"OPENBLAS_NUM_THREADS={env['OPENBLAS_NUM_THREADS']}")  # fmt: skip
    rows = []
    if (DATA / "mrclam6").is_dir():
        rows += mrclam_rows()
    if (DATA / "victoria_park").is_dir():
        rows += victoria_rows(not args.skip_reference_vp, args.vp_scans, args.dense_scans)
    if rows:
        print_table("whole runs (same process; wall / CPU seconds)",
                    ["run", "filter", "time (wall / CPU)", "numpy / rperc (wall / CPU)",
                     "accuracy", "landmarks", "association"],
                    [r + [""] * (7 - len(r)) for r in rows])  # fmt: skip
        for line in AGREEMENT:
            print(f"  {line}")
    else:
        print(f"no data under {DATA}: set RPERC_DATA")
    growth(args.sizes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
