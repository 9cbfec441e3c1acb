"""The 2-D pattern tracker (seed 001 section 3) on generated Fig. 8 sequences (section
4.1), against OpenCV's findTransformECC (Euclidean and affine) on the same frames in the
same run: accuracy by per-frame step (in sigma) and frames per second against the number
of particles.

    python benchmarks/pattern.py [--frames 40] [--size 640 480] [--particles 50 100 200 500 1000]
        [--points 25 50 100 200] [--sizes 320x240 640x480 1280x960]

Speed is reported against the number of particles, the number of model points and the
frame size, each with ECC (affine) timed on the same frames in the same run and the
fitted power-law exponent of the time per frame.

The patch is cut from ``images/camera.png`` and moved over ``images/grass.png`` of the
shared data (``RPERC_DATA``); without them a synthetic patch and clutter are used.
ECC (Euclidean motion, started from the previous estimate) throws when it does not
converge: the exception is caught, counted as a failure, and the estimate kept.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import print_table

from rperc.datasets import data_dir
from rperc.tracking import PatternSequence, PatternTracker, pattern_sequence

try:
    import cv2
except ImportError:  # pragma: no cover - optional peer
    cv2 = None

SIGMA = (5.0, 5.0, math.radians(3.0), 0.1)


def images() -> tuple[np.ndarray, np.ndarray, str]:
    """(patch, background, where from)."""
    root = data_dir()
    if cv2 is not None and root is not None and (root / "images").is_dir():
        camera = cv2.imread(str(root / "images" / "camera.png"), cv2.IMREAD_GRAYSCALE)
        grass = cv2.imread(str(root / "images" / "grass.png"), cv2.IMREAD_GRAYSCALE)
        if camera is not None and grass is not None:
            return camera[60:160, 200:300], grass, "camera.png over grass.png"
    rng = np.random.default_rng(0)
    patch = np.full((100, 100), 60.0)
    patch[10:45, 15:60] = 200
    patch[55:90, 40:85] = 140
    yy, xx = np.mgrid[0:100, 0:100]
    patch[(xx - 30) ** 2 + (yy - 70) ** 2 < 225] = 230
    bg = rng.uniform(40, 200, (32, 32)).repeat(16, 0).repeat(16, 1)
    return patch, bg, "synthetic patch and block clutter"


def run_rperc(
    seq: PatternSequence, n_particles: int, max_points: int = 200
) -> tuple[np.ndarray, int, float]:
    """(estimates (n-1, 4), lost frames, seconds per update)."""
    tracker = PatternTracker(
        seq.frames[0], seq.region, n_particles=n_particles, seed=1, max_points=max_points
    )
    out, lost = [], 0
    t0 = time.perf_counter()
    for frame in seq.frames[1:]:
        p = tracker.update(frame)
        out.append((p.x, p.y, p.theta, p.scale))
        lost += p.lost
    return np.array(out), lost, (time.perf_counter() - t0) / (len(seq.frames) - 1)


def run_ecc(seq: PatternSequence, motion: int) -> tuple[np.ndarray, int, float]:
    """ECC on the region's template (``cv2.MOTION_EUCLIDEAN`` or ``MOTION_AFFINE``),
    warm-started from the previous warp; (estimates, failures, seconds per frame)."""
    x, y, w, h = seq.region
    template = seq.frames[0][y : y + h, x : x + w].astype(np.float32)
    # Warp maps template coordinates into the frame.
    warp = np.array([[1, 0, x], [0, 1, y]], np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4)
    c = np.array([(w - 1) / 2, (h - 1) / 2, 1.0])
    out, failures = [], 0
    t0 = time.perf_counter()
    for frame in seq.frames[1:]:
        try:
            _, new = cv2.findTransformECC(
                template, frame.astype(np.float32), warp.copy(), motion, criteria, None, 5
            )
            warp = new
        except cv2.error:
            failures += 1
        cx, cy = warp @ c
        # Template x axis mapped by [[cos, -sin], [sin, cos]]: theta CCW on screen is -atan2.
        theta = -math.atan2(float(warp[1, 0]), float(warp[0, 0]))
        scale = math.sqrt(abs(float(np.linalg.det(warp[:, :2]))))
        out.append((cx, cy, theta, scale))
    return np.array(out), failures, (time.perf_counter() - t0) / (len(seq.frames) - 1)


def accuracy_rows(name: str, seq: PatternSequence, est: np.ndarray) -> list[list[str]]:
    """RMS errors grouped by the swept component's step in sigma: <=1, 1-2, 2-3, 3-4."""
    truth = seq.truth[1:]
    steps = np.diff(seq.truth, axis=0) / np.array(SIGMA)
    swept = np.arange(len(truth)) % 4
    ratio = np.abs(steps[np.arange(len(truth)), swept])
    pos = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1])
    ang = np.degrees(np.abs(est[:, 2] - truth[:, 2]))
    scale = np.abs(est[:, 3] / truth[:, 3] - 1)
    rows = []
    for lo in range(4):
        sel = (ratio > lo) & (ratio <= lo + 1)
        if not sel.any():
            continue
        rms = [float(np.sqrt(np.mean(v[sel] ** 2))) for v in (pos, ang, scale)]
        rows.append(
            [
                name,
                f"{lo}-{lo + 1}",
                str(int(sel.sum())),
                f"{rms[0]:.2f}",
                f"{rms[1]:.2f}",
                f"{100 * rms[2]:.1f}",
            ]
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--size", type=int, nargs=2, default=(640, 480))
    ap.add_argument("--particles", type=int, nargs="+", default=[50, 100, 200, 500, 1000])
    ap.add_argument("--points", type=int, nargs="+", default=[25, 50, 100, 200])
    ap.add_argument("--sizes", nargs="+", default=["320x240", "640x480", "1280x960"])
    args = ap.parse_args()
    patch, bg, source = images()
    print(
        f"# {source}, {args.size[0]}x{args.size[1]}, {args.frames} frames,"
        " sigma = 5 px, 5 px, 3 deg, 0.1"
    )
    kinds = {
        "steps <= 4 sigma": {"max_step_sigmas": 4.0},
        "3 sigma, 30 % occlusion, gain/offset": {
            "max_step_sigmas": 3.0,
            "max_occlusion": 0.3,
            "gain": (0.8, 1.2),
            "offset": (-20.0, 20.0),
        },
    }
    acc_rows: list[list[str]] = []
    speed_rows: list[list[str]] = []
    for label, extra in kinds.items():
        seq = pattern_sequence(
            patch, bg, n_frames=args.frames, size=tuple(args.size), seed=3, **extra
        )  # type: ignore[arg-type]
        est, lost, dt = run_rperc(seq, 200)
        acc_rows += accuracy_rows(f"rperc 200 ({label}, lost {lost})", seq, est)
        if cv2 is not None:
            for name, motion in (
                ("Euclidean", cv2.MOTION_EUCLIDEAN),
                ("affine", cv2.MOTION_AFFINE),
            ):
                est_e, fail, _ = run_ecc(seq, motion)
                acc_rows += accuracy_rows(f"ECC {name} ({label}, failed {fail})", seq, est_e)
    header = ["tracker", "step/sigma", "frames", "pos RMS px", "angle RMS deg", "scale RMS %"]
    print_table("accuracy against the swept step", header, acc_rows)
    seq = pattern_sequence(
        patch, bg, n_frames=args.frames, size=tuple(args.size), seed=3, max_step_sigmas=1.0
    )
    ecc_fps = None
    if cv2 is not None:
        _, _, dt_e = run_ecc(seq, cv2.MOTION_AFFINE)
        ecc_fps = 1 / dt_e
        speed_rows.append(["cv2.findTransformECC (affine)", "-", f"{ecc_fps:.1f}", "1.00"])
    times = []
    for n in args.particles:
        _, _, dt = run_rperc(seq, n)
        times.append(dt)
        ratio = f"{(1 / dt) / ecc_fps:.2f}" if ecc_fps else "-"
        speed_rows.append(["rperc PatternTracker", str(n), f"{1 / dt:.1f}", ratio])
    print_table(
        "frames per second against particles (steps <= 1 sigma)",
        ["tracker", "particles", "fps", "x ECC"],
        speed_rows,
    )
    print(f"scaling: time per frame ~ particles^{slope(args.particles, times):.2f}")
    sweep_points(seq, args.points, ecc_fps)
    sweep_sizes(patch, bg, args)


def slope(x: list[int], t: list[float]) -> float:
    """The exponent of a power law fitted to ``t`` against ``x`` (log-log least squares)."""
    if len(x) < 2:
        return math.nan
    return float(np.polyfit(np.log(x), np.log(t), 1)[0])


def sweep_points(seq: PatternSequence, points: list[int], ecc_fps: float | None) -> None:
    """fps against the model's largest number of points (200 particles)."""
    rows, used, times = [], [], []
    for m in points:
        n_points = PatternTracker(seq.frames[0], seq.region, max_points=m).n_points
        _, _, dt = run_rperc(seq, 200, max_points=m)
        used.append(n_points)
        times.append(dt)
        ratio = f"{(1 / dt) / ecc_fps:.2f}" if ecc_fps else "-"
        rows.append([str(m), str(n_points), f"{1 / dt:.1f}", ratio])
    print_table(
        "frames per second against model points (200 particles)",
        ["max_points", "points", "fps", "x ECC"],
        rows,
    )
    print(f"scaling: time per frame ~ points^{slope(used, times):.2f}")


def sweep_sizes(patch: np.ndarray, bg: np.ndarray, args: argparse.Namespace) -> None:
    """fps against the frame size (200 particles), ECC affine on the same frames."""
    rows = []
    for size in args.sizes:
        w, h = (int(v) for v in size.split("x"))
        seq = pattern_sequence(
            patch, bg, n_frames=args.frames, size=(w, h), seed=3, max_step_sigmas=1.0
        )
        _, _, dt = run_rperc(seq, 200)
        if cv2 is not None:
            _, _, dt_e = run_ecc(seq, cv2.MOTION_AFFINE)
            ecc = f"{1 / dt_e:.1f}"
            ratio = f"{dt_e / dt:.2f}"
        else:
            ecc, ratio = "-", "-"
        rows.append([size, f"{1 / dt:.1f}", ecc, ratio])
    print_table(
        "frames per second against frame size (200 particles)",
        ["size", "rperc fps", "ECC affine fps", "x ECC"],
        rows,
    )


if __name__ == "__main__":
    main()
