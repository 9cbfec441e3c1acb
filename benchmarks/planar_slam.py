"""Planar EKF-SLAM on whole recordings (issue 10): rperc against the numpy EKF-SLAM of
``reference_planar_ekf.py`` (PythonRobotics style, the same models; the structured
O(n^2) form a careful numpy user writes), in the same run, with whole-run times,
ratios and accuracies, and the cost growth with the number of landmarks.

- MR.CLAM robot 1, known association: both filters are the same EKF (the tests check
  that their paths agree to 1e-6 m); ATE after SE(2) alignment against Vicon.
- Victoria Park: the reference associates by nearest neighbour and starts a landmark
  at once; rperc runs its preset (JCBB, 3 sightings before a landmark) and, as the
  like-for-like peer, nearest neighbour with one sighting. Accuracy: RMS distance of
  the laser's path to the plausible GPS fixes after one rigid alignment.
- Growth: one prediction and one range-bearing update (called from Python, so a few
  microseconds of call overhead are included) on a state of n landmarks with a dense
  random covariance; the slope of log time against log n should be about 1 for the
  prediction and 2 for the update (``cargo bench -p slam --bench planar`` measures the
  same without the Python call).

    RPERC_DATA=../shared/data python benchmarks/planar_slam.py [--skip-reference-vp]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import reference_planar_ekf as ref
from _timing import best_time, fmt_seconds, print_table

from rperc.slam import PlanarSlam, evaluation
from rperc.slam.planar import PRESETS, mrclam_recording, point_path, victoria_recording

DATA = Path(os.environ.get("RPERC_DATA", Path(__file__).parents[1] / ".." / "shared" / "data"))


def timed(fn):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def mrclam_rows() -> list[list[str]]:
    from rperc.datasets import load_mrclam

    run = load_mrclam(DATA / "mrclam6", robot=1)
    pose0 = ref.initial_pose(run)
    cfg = {
        **PRESETS["mrclam"],
        "initial_pose": pose0.tolist(),
        "initial_pose_variance": [1e-6] * 3,
    }
    rec = mrclam_recording(run)
    runs = [timed(lambda: PlanarSlam(cfg).run(rec)) for _ in range(5)]
    ours, t_ours = runs[0][0], min(r[1] for r in runs)
    slam = ref.PlanarEkfSlam(
        pose=pose0, pose_covariance=np.eye(3) * 1e-6,
        control_noise=np.diag([0.1**2, 0.2**2]), measurement_noise=np.diag([0.1**2, 0.05**2]),
        structured=True,
    )  # fmt: skip
    theirs = ref.run_mrclam(run, slam)
    truth = np.c_[run.truth_x, run.truth_y, run.truth_theta]
    ate_ours = ours.ate(run.truth_t, truth, align=True).rmse
    ate_ref = evaluation.ate(theirs.t, theirs.poses, run.truth_t, truth, align=True).rmse
    return [
        ["MR.CLAM r1, known", "rperc", fmt_seconds(t_ours), "", f"ATE {ate_ours:.3f} m",
         str(len(ours.landmark_id))],
        ["MR.CLAM r1, known", "numpy (structured)", fmt_seconds(theirs.seconds),
         f"{theirs.seconds / t_ours:.0f}x", f"ATE {ate_ref:.3f} m", str(len(theirs.landmarks))],
    ]  # fmt: skip


def victoria_rows(with_reference: bool) -> list[list[str]]:
    from rperc.datasets import load_victoria_park
    from rperc.datasets.victoria_park import LASER_MOUNT

    park = load_victoria_park(DATA / "victoria_park")
    keep = park.gps_plausible()
    t_gps, gps = park.gps_t[keep], np.c_[park.gps_x, park.gps_y][keep]

    def gps_rms(t: np.ndarray, pose: np.ndarray) -> float:
        return evaluation.gps_error(t, point_path(pose, LASER_MOUNT), t_gps, gps).rms

    rec = victoria_recording(park)
    rows, t_nn = [], None
    for name, over in (
        ("jcbb, k=3 (preset)", {}),
        ("nn, k=1", {"association": "nn", "candidate_sightings": 1}),
    ):
        cfg = {**PRESETS["victoria"], **over}
        # Best of three whole runs (the machine may be shared).
        runs = [timed(lambda cfg=cfg: PlanarSlam(cfg).run(rec)) for _ in range(3)]
        res, t = runs[0][0], min(r[1] for r in runs)
        tt, pose, _ = res.path()
        s = res.statistics
        rows.append([f"Victoria Park, {name}", "rperc", fmt_seconds(t), "",
                     f"GPS {gps_rms(tt, pose):.2f} m", str(len(res.landmark_id)),
                     f"acc {s['accepted']} rej {s['rejected']} new {s['new']}"])  # fmt: skip
        t_nn = t
    if with_reference and t_nn is not None:
        motion = PRESETS["victoria"]["motion"]["ackermann"]
        slam = ref.PlanarEkfSlam(
            pose=np.zeros(3), pose_covariance=np.zeros((3, 3)),
            control_noise=np.diag([motion.get("speed_variance", 0.2),
                                   motion.get("steering_variance", 0.025)]),
            measurement_noise=np.diag([PRESETS["victoria"]["range_variance"],
                                       PRESETS["victoria"]["bearing_variance"]]),
            vehicle=ref.Ackermann(), structured=True,
        )  # fmt: skip
        theirs = ref.run_victoria_park(park, slam)
        st = theirs.stats
        rows.append(["Victoria Park, nn, k=1", "numpy (structured)", fmt_seconds(theirs.seconds),
                     f"{theirs.seconds / t_nn:.0f}x vs rperc nn",
                     f"GPS {gps_rms(theirs.t, theirs.poses):.2f} m", str(len(theirs.landmarks)),
                     f"acc {st.accepted} rej {st.rejected} new {st.new}"])  # fmt: skip
    return rows


def costs(n: int, rng: np.random.Generator) -> tuple[float, float, float]:
    """Best-of-repeats seconds of rperc's prediction and range-bearing update, and the
    numpy peer's update, on a state of ``n`` landmarks with a dense random ``P``."""
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
    t_pred = best_time(lambda: ekf.predict(x[:3], fx, fv, v), repeat=5, min_time=0.05)
    t_up = best_time(lambda: ekf.update_range_bearing(n // 2, z, r), repeat=5, min_time=0.1)
    t_np = best_time(lambda: peer.update([(n // 2, z)]), repeat=3, min_time=0.1)
    return t_pred, t_up, t_np


def growth(sizes: list[int]) -> None:
    """Per-call cost against the map size, with the fitted exponents."""
    rows: list[list[str]] = []
    logs: dict[str, list[float]] = {"rperc predict": [], "rperc update": [], "numpy update": []}
    rng = np.random.default_rng(0)
    for n in sizes:
        t_pred, t_up, t_np = costs(n, rng)
        for key, val in zip(logs, (t_pred, t_up, t_np), strict=True):
            logs[key].append(val)
        rows.append([str(n), fmt_seconds(t_pred), fmt_seconds(t_up), fmt_seconds(t_np),
                     f"{t_np / t_up:.1f}x"])  # fmt: skip
    print_table("cost per call against landmarks n (random dense P)",
                ["n", "rperc predict", "rperc update", "numpy update", "ratio"], rows)  # fmt: skip
    big = [i for i, n in enumerate(sizes) if n >= 200]
    for key, vals in logs.items():
        slope = np.polyfit(np.log(np.array(sizes)[big]), np.log(np.array(vals)[big]), 1)[0]
        print(f"  {key}: time ~ n^{slope:.2f} (fit over n >= 200)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-reference-vp", action="store_true",
                        help="skip the numpy run on Victoria Park (about a minute)")  # fmt: skip
    parser.add_argument("--sizes", type=int, nargs="+", default=[50, 100, 200, 400, 800, 1600])
    args = parser.parse_args()
    rows = []
    if (DATA / "mrclam6").is_dir():
        rows += mrclam_rows()
    if (DATA / "victoria_park").is_dir():
        rows += victoria_rows(not args.skip_reference_vp)
    if rows:
        print_table("whole runs (same process, wall time)",
                    ["run", "filter", "time", "numpy / rperc", "accuracy", "landmarks",
                     "association"], [r + [""] * (7 - len(r)) for r in rows])  # fmt: skip
    else:
        print(f"no data under {DATA}: set RPERC_DATA")
    growth(args.sizes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
