"""One EKF-SLAM update (range-bearing to one 2-D point landmark) at growing map sizes:
rperc against a numpy dense-Joseph EKF (the textbook form of filterpy and
PythonRobotics) and a numpy sparse-Joseph EKF, in the same run, with ratios, the
fitted growth exponent and the memory-bandwidth floor (reading and writing the
covariance once).

    python benchmarks/ekf_update.py [--sizes 10 100 500 1000 2000]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import best_time, fmt_seconds, print_table


def problem(n: int, seed: int = 0):
    """A planar robot (x, y, theta) plus n landmarks with a random SPD covariance."""
    rng = np.random.default_rng(seed)
    d = 3 + 2 * n
    x = rng.normal(size=d) * 5
    a = rng.normal(size=(d, min(d, 40)))
    P = a @ a.T / 40 + np.eye(d) * 0.5
    R = np.diag([0.01, 0.001])
    return x, P, R


def range_bearing(x: np.ndarray, j: int):
    """Innovation-ready prediction and the two Jacobian blocks (robot, landmark j)."""
    lx, ly = x[3 + 2 * j], x[4 + 2 * j]
    dx, dy = lx - x[0], ly - x[1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    z = np.array([r, np.arctan2(dy, dx) - x[2]])
    Hr = np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])
    Hl = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
    return z, Hr, Hl


def dense_joseph(x, P, R, z_meas, j):
    z, Hr, Hl = range_bearing(x, j)
    d = len(x)
    H = np.zeros((2, d))
    H[:, :3], H[:, 3 + 2 * j : 5 + 2 * j] = Hr, Hl
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    IKH = np.eye(d) - K @ H
    return x + K @ (z_meas - z), IKH @ P @ IKH.T + K @ R @ K.T


def sparse_joseph(x, P, R, z_meas, j):
    z, Hr, Hl = range_bearing(x, j)
    cols = np.r_[0:3, 3 + 2 * j : 5 + 2 * j]
    Hs = np.hstack([Hr, Hl])
    PHt = P[:, cols] @ Hs.T
    S = Hs @ PHt[cols] + R
    K = np.linalg.solve(S, PHt.T).T
    KS = K @ S
    # Joseph form expanded with the sparse H: P - K PHt^T - PHt K^T + K S K^T.
    P_new = P - K @ PHt.T - PHt @ K.T + KS @ K.T
    return x + K @ (z_meas - z), P_new


def bandwidth() -> float:
    """Bytes per second of a large read-and-write copy on this machine."""
    src = np.ones(32 * 1024 * 1024 // 8)
    dst = np.empty_like(src)
    t = best_time(lambda: np.copyto(dst, src), repeat=5)
    return 2 * src.nbytes / t


def rperc_update():
    try:
        from rperc.slam import Ekf
    except ImportError:
        return None

    def make(x, P, R, z_meas, j):
        ekf = Ekf(x, P, robot_dim=3, landmark_dim=2)
        return lambda: ekf.update_range_bearing(j, z_meas, R)

    return make


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", nargs="+", type=int, default=[10, 100, 500, 1000, 2000])
    args = ap.parse_args()
    bw = bandwidth()
    print(f"memory bandwidth (copy): {bw / 1e9:.1f} GB/s")
    make_rperc = rperc_update()
    rows, ours = [], []
    for n in args.sizes:
        x, P, R = problem(n)
        j = n // 2
        z_meas = range_bearing(x, j)[0] + np.array([0.05, 0.01])
        d = len(x)
        # Both numpy forms must agree before they are timed.
        xa, Pa = dense_joseph(x, P, R, z_meas, j)
        xb, Pb = sparse_joseph(x, P, R, z_meas, j)
        assert np.allclose(Pa, Pb, atol=1e-9) and np.allclose(xa, xb, atol=1e-9)
        dense = (
            best_time(lambda x=x, P=P, R=R, z=z_meas, j=j: dense_joseph(x, P, R, z, j), repeat=3)
            if n <= 1000
            else None
        )
        sparse = best_time(
            lambda x=x, P=P, R=R, z=z_meas, j=j: sparse_joseph(x, P, R, z, j), repeat=5
        )
        floor = 2 * 8 * d * d / bw
        t = None
        if make_rperc is not None:
            # Each call updates the filter in place; the covariance stays well-conditioned
            # over repeats because every update is a proper measurement update.
            t = best_time(make_rperc(x, P, R, z_meas, j), repeat=5)
            ours.append((d, t))
        rows.append(
            [
                f"{n} landmarks (d={d})",
                fmt_seconds(t, "-"),
                fmt_seconds(dense, "skipped (O(n^3))"),
                fmt_seconds(sparse),
                fmt_seconds(floor),
                f"{dense / t:7.1f}x" if (t and dense) else "-",
                f"{sparse / t:7.1f}x" if t else "-",
                f"{t / floor:5.2f}" if t else "-",
            ]
        )
    print_table(
        "EKF update, best of repeats",
        [
            "map",
            "rperc",
            "numpy dense Joseph",
            "numpy sparse Joseph",
            "bandwidth floor",
            "vs dense",
            "vs sparse",
            "rperc / floor",
        ],
        rows,
    )
    if len(ours) >= 3:
        big = [(d, t) for d, t in ours if d >= 200] or ours
        slope = np.polyfit(np.log([d for d, _ in big]), np.log([t for _, t in big]), 1)[0]
        print(f"\nfitted growth exponent of rperc's update time in the state size: {slope:.2f}")


if __name__ == "__main__":
    main()
