"""The 2-D pattern tracker (seed 001 section 3) on generated Fig. 8 sequences (section
4.1), against OpenCV's findTransformECC (Euclidean and affine) on the same frames in the
same run: accuracy by per-frame step (in sigma) and frames per second against the number
of particles.

    python benchmarks/pattern.py [--frames 40] [--size 640 480] [--particles 50 100 200 500 1000]
        [--points 25 50 100 200] [--sizes 320x240 640x480 1280x960] [--repeats 5]
        [--part all|peers|sweeps] [--seeds 3] [--kinds full-step,gain,occlusion,perspective]
        [--no-v25]

``--part peers`` runs only the peer table (issue 35): rperc in both modes (similarity
and homography), ECC affine and homography started from the previous frame, and ORB +
RANSAC against the first frame, on generated full-step sequences (3 sigma in every
parameter at once; also with a gain or an occlusion band, as ``rperc bench pattern``
has them) and perspective sequences (``--kinds``; OpenCV draws them, see
``rperc.tracking.perspective``) at 640 x 480 and 1280 x 720, held-out seeds from 10,
and on the real POT-210 video ``planar/V25_2`` (every peer from the box halving its
first true corners, and the homography mode from the corners themselves) with POT-210's
mean corner error, its RMS and precision at 5 and 15 px; fps and ratios to ECC affine
from the same run.

Speed is reported against the number of particles, the number of model points and the
frame size, each with ECC (affine) timed on the same frames in the same run and the
fitted power-law exponent of the time per frame.

The patch is cut from ``images/camera.png`` and moved over ``images/grass.png`` of the
shared data (``RPERC_DATA``); without them a synthetic patch and clutter are used.
ECC is the harness's peer (``rperc.tracking.planar.run_ecc``): Euclidean and affine,
warm-started from the previous warp and pyramid-initialised over three levels, its
exceptions caught and counted as failures (the estimate kept), timed per frame with
its float conversion and pyramid, on the same frames in the same run. The speed tables
also show affine ECC on the full-resolution frame alone (no pyramid), the cheaper
configuration a user might choose, for reference.
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

from rperc.bench.allocator import steady_allocator
from rperc.config import PatternConfig, PatternModelConfig
from rperc.datasets import data_dir, load_planar_truth
from rperc.tracking import PatternSequence, PatternTracker, pattern_sequence, planar
from rperc.tracking.perspective import perspective_sequence
from rperc.tracking.synthetic import demo_images

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
    patch, bg = demo_images(0)
    return patch, bg, "synthetic patch and block clutter"


def run_rperc(
    seq: PatternSequence,
    n_particles: int,
    max_points: int = 200,
    parallel: bool = True,
    parallel_min_work: int | None = None,
) -> tuple[np.ndarray, int, float]:
    """(estimates (n-1, 4), lost frames, seconds per update); ``parallel_min_work``
    None keeps the tracker's default."""
    base = PatternConfig()
    config = base.replace(
        n_particles=n_particles,
        pattern=base.pattern.replace(max_points=max_points),
        filter=base.filter.replace(parallel=parallel),
    )
    if parallel_min_work is not None:
        config = config.replace(parallel_min_work=parallel_min_work)
    tracker = PatternTracker(seq.frames[0], seq.region, seed=1, config=config)
    out, lost = [], 0
    t0 = time.perf_counter()
    for frame in seq.frames[1:]:
        p = tracker.update(frame)
        out.append((p.x, p.y, p.theta, p.scale))
        lost += p.lost
    return np.array(out), lost, (time.perf_counter() - t0) / (len(seq.frames) - 1)


def run_ecc(seq: PatternSequence, motion: str) -> tuple[np.ndarray, int, float]:
    """The harness's ECC (``"euclidean"`` or ``"affine"``, pyramid-initialised):
    (estimates ``(x, y, theta, scale)`` from its corners, failures, seconds per
    frame)."""
    run = planar.run_ecc(seq.frames, seq.region, motion)
    return corner_states(run.corners, seq.region), run.failures, run.seconds


def corner_states(corners: np.ndarray, region: tuple[int, int, int, int]) -> np.ndarray:
    """``(x, y, theta, scale)`` of warped region corners ``(n, 4, 2)``: the centre is
    their mean (an affine map keeps centroids), theta the turn of the top edge
    (counter-clockwise on screen), scale the square root of the area ratio."""
    _, _, w, h = region
    c = np.asarray(corners, dtype=np.float64)
    top = c[:, 1] - c[:, 0]
    d1, d2 = c[:, 2] - c[:, 0], c[:, 3] - c[:, 1]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return np.column_stack(
        [
            c[:, :, 0].mean(1),
            c[:, :, 1].mean(1),
            -np.arctan2(top[:, 1], top[:, 0]),
            np.sqrt(area / (w * h)),
        ]
    )


def run_ecc_single(seq: PatternSequence) -> float:
    """Seconds per frame of affine ECC on the full-resolution frame alone (no
    pyramid), warm-started from the previous warp, exceptions caught."""
    x, y, w, h = seq.region
    template = seq.frames[0][y : y + h, x : x + w].astype(np.float32)
    warp = np.array([[1, 0, x], [0, 1, y]], np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4)
    t0 = time.perf_counter()
    for frame in seq.frames[1:]:
        try:
            _, warp = cv2.findTransformECC(
                template,
                frame.astype(np.float32),
                warp,
                cv2.MOTION_AFFINE,
                criteria,
                None,
                planar.ECC_GAUSS_FILTER,
            )
        except cv2.error:
            pass
    return (time.perf_counter() - t0) / (len(seq.frames) - 1)


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


PEERS = {
    "rperc similarity": lambda f, r: planar.run_pattern(f, r, seed=1),
    "rperc homography": lambda f, r: planar.run_pattern(f, r, seed=1, motion="homography"),
    "ECC affine": lambda f, r: planar.run_ecc(f, r, "affine"),
    "ECC homography": lambda f, r: planar.run_ecc(f, r, "homography"),
    "ORB + RANSAC": planar.run_orb,
}


def peer_runs(
    frames: np.ndarray, region: tuple[int, int, int, int], repeats: int
) -> dict[str, list[planar.PlanarRun]]:
    """Every peer on the same frames, alternated ``repeats`` times so that the
    machine's load falls on all of them alike."""
    runs: dict[str, list[planar.PlanarRun]] = {k: [] for k in PEERS}
    for _ in range(repeats):
        for name, run in PEERS.items():
            runs[name].append(run(frames, region))
    return runs


def peer_rows(
    label: str, runs: dict[str, list[planar.PlanarRun]], truth: np.ndarray, visible: np.ndarray
) -> list[list[str]]:
    """One row per peer: POT-210's numbers (of the first run: every run gives the same
    corners), failures, the median fps and its ratio to ECC affine's."""
    fps = {k: float(np.median([r.fps for r in v])) for k, v in runs.items()}
    rows = []
    for name, rs in runs.items():
        s = planar.pot_score(rs[0].corners, truth, visible)
        # POT-210's alignment error per frame, its RMS over the visible frames.
        err = np.mean(np.linalg.norm(rs[0].corners - truth, axis=2), axis=1)[visible]
        rows.append(
            [
                label,
                name,
                str(s.frames),
                f"{s.mean_corner_error_px:.2f}",
                f"{float(np.sqrt(np.mean(err**2))):.2f}",
                f"{s.precision_at_5:.2f}",
                f"{s.precision_at_15:.2f}",
                str(rs[0].failures),
                f"{fps[name]:.0f}",
                f"{fps[name] / fps['ECC affine']:.2f}",
            ]
        )
    return rows


PEER_HEADER = [
    "sequence",
    "method",
    "frames",
    "mean corner px",
    "corner RMS px",
    "p@5",
    "p@15",
    "failures",
    "fps",
    "x ECC affine",
]


def v25_2(repeats: int) -> list[list[str]]:
    """The peers on POT-210's V25_2 (grey, 1280 x 720), the region the box whose
    edges halve the first frame's true corners; scored on the visible frames."""
    root = data_dir()
    folder = None if root is None else root / "planar" / "V25_2"
    if folder is None or not folder.is_dir():
        print("# planar/V25_2 not found in RPERC_DATA: skipped")
        return []
    truth = load_planar_truth(folder)
    files = sorted(folder.glob("*.jpg"))
    frames = np.stack([cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files])
    q = truth.corners[0]
    left, right = (q[0, 0] + q[3, 0]) / 2, (q[1, 0] + q[2, 0]) / 2
    top, bottom = (q[0, 1] + q[1, 1]) / 2, (q[2, 1] + q[3, 1]) / 2
    x, y = round(left + 0.5), round(top + 0.5)
    region = (x, y, round(right + 0.5) - x, round(bottom + 0.5) - y)
    print(f"# V25_2: {len(frames)} frames, region {region}")
    runs = peer_runs(frames, region, repeats)
    rows = peer_rows("V25_2 (real)", runs, truth.corners[1:], truth.visible[1:])
    # The homography mode from the first frame's true corners, as POT-210 gives them.
    quad = {
        "rperc homography": [
            planar.run_pattern(frames, q, seed=1, motion="homography") for _ in range(repeats)
        ]
    }
    # ECC affine's runs only for the fps ratio: its row is the box's, above.
    quad["ECC affine"] = runs["ECC affine"]
    rows += peer_rows("V25_2 (real), from its corners", quad, truth.corners[1:], truth.visible[1:])
    return rows[:-1]


#: The generated cases of the peer table (``--kinds``): what each adds to steps of 3
#: sigma in all four parameters at once (``perspective``: OpenCV draws the patch in
#: perspective instead, see :func:`perspective_sequence`). Gain and occlusion as in
#: ``rperc bench pattern``: a gain in 1 +- 0.2 per frame, a band hiding up to 30 %.
KINDS: dict[str, dict[str, object]] = {
    "full-step": {},
    "gain": {"gain": (0.8, 1.2)},
    "occlusion": {"max_occlusion": 0.3},
    "perspective": {},
}


def generated(
    kind: str, patch: np.ndarray, bg: np.ndarray, size: tuple[int, int], seed: int, frames: int
) -> tuple[np.ndarray, tuple[int, int, int, int], np.ndarray]:
    """A generated case of :data:`KINDS`: its frames, first region and true corners
    of frames 1..n."""
    if kind == "perspective":
        seq = perspective_sequence(patch, bg, n_frames=frames, size=size, seed=seed)
        return seq.frames, seq.region, seq.corners[1:]
    steps = pattern_sequence(
        patch,
        bg,
        n_frames=frames,
        width=size[0],
        height=size[1],
        seed=seed,
        max_step_sigmas=3.0,
        other_step_sigmas=3.0,
        **KINDS[kind],  # type: ignore[arg-type]
    )
    return steps.frames, steps.region, planar.truth_corners(steps)


def peers(patch: np.ndarray, bg: np.ndarray, args: argparse.Namespace) -> None:
    """The issue 35 peer table: the generated cases of ``args.kinds`` at 640 x 480
    and 1280 x 720 (``args.seeds`` held-out seeds each, from 10: seeds 0-9 tuned the
    defaults), then V25_2."""
    rows: list[list[str]] = []
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        raise SystemExit(f"--kinds {args.kinds!r}: expected some of {', '.join(KINDS)}")
    # Seconds per frame of each peer, summed over a case's seeds (first run of each).
    spent: dict[str, dict[str, list[float]]] = {}
    for size in ((640, 480), (1280, 720)):
        for seed in range(10, 10 + args.seeds):
            for kind in kinds:
                frames, region, truth = generated(kind, patch, bg, size, seed, args.frames)
                runs = peer_runs(frames, region, args.repeats)
                case = f"{size[0]}x{size[1]} {kind.replace('-', ' ')}"
                rows += peer_rows(f"{case}, seed {seed}", runs, truth, np.ones(len(truth), bool))
                for name, rs in runs.items():
                    spent.setdefault(case, {}).setdefault(name, []).append(
                        float(np.median([r.seconds for r in rs]))
                    )
    if not args.no_v25:
        rows += v25_2(args.repeats)
    print_table(
        f"peers in the same run (fps: median of {args.repeats} alternated runs)",
        PEER_HEADER,
        rows,
    )
    print_throughput(spent)


def print_throughput(spent: dict[str, dict[str, list[float]]]) -> None:
    """Each case's fps over all its seeds, frames over time (every sequence has as
    many frames), and the ratio to ECC affine's: ECC's speed varies with the sequence
    (its iterations), so a median of per-seed ratios over a few seeds can flatter
    either side."""
    rows = []
    for case, peers_spent in spent.items():
        fps = {name: len(s) / sum(s) for name, s in peers_spent.items()}
        for name, value in fps.items():
            ratio = value / fps["ECC affine"]
            rows.append([case, name, str(len(peers_spent[name])), f"{value:.0f}", f"{ratio:.2f}"])
    print_table(
        "throughput over the seeds (frames over time)",
        ["case", "method", "seeds", "fps", "x ECC affine"],
        rows,
    )


def main() -> None:
    # Peers and rperc timed with the same allocator behaviour (rperc.bench.allocator).
    steady_allocator()
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--size", type=int, nargs=2, default=(640, 480))
    ap.add_argument("--particles", type=int, nargs="+", default=[50, 100, 200, 500, 1000])
    ap.add_argument("--points", type=int, nargs="+", default=[25, 50, 100, 200])
    ap.add_argument("--sizes", nargs="+", default=["320x240", "640x480", "1280x960"])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--part", choices=("all", "peers", "sweeps"), default="all")
    ap.add_argument("--seeds", type=int, default=3, help="generated seeds of the peer table")
    ap.add_argument(
        "--kinds",
        default="full-step,perspective",
        help="generated sequences of the peer table: some of full-step, gain, occlusion,"
        " perspective (comma-separated)",
    )
    ap.add_argument("--no-v25", action="store_true", help="leave V25_2 out of the peer table")
    args = ap.parse_args()
    patch, bg, source = images()
    print(
        f"# {source}, {args.size[0]}x{args.size[1]}, {args.frames} frames,"
        " sigma = 5 px, 5 px, 3 deg, 0.1"
    )
    if args.part != "sweeps":
        if cv2 is None:
            print("# OpenCV is not installed: no peer table")
        else:
            peers(patch, bg, args)
    if args.part == "peers":
        return
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
    for label, extra in kinds.items():
        w, h = args.size
        seq = pattern_sequence(patch, bg, n_frames=args.frames, width=w, height=h, seed=3, **extra)  # type: ignore[arg-type]
        est, lost, _ = run_rperc(seq, 200)
        acc_rows += accuracy_rows(f"rperc 200 ({label}, lost {lost})", seq, est)
        if cv2 is not None:
            for motion in ("euclidean", "affine"):
                est_e, fail, _ = run_ecc(seq, motion)
                acc_rows += accuracy_rows(f"ECC {motion} ({label}, failed {fail})", seq, est_e)
    header = ["tracker", "step/sigma", "frames", "pos RMS px", "angle RMS deg", "scale RMS %"]
    print_table("accuracy against the swept step", header, acc_rows)
    w, h = args.size
    seq = pattern_sequence(
        patch, bg, n_frames=args.frames, width=w, height=h, seed=3, max_step_sigmas=1.0
    )
    speed_headline(seq, args.repeats)
    sweep_particles(seq, args.particles)
    sweep_points(seq, args.points)
    sweep_sizes(patch, bg, args)


def ecc_seconds(seq: PatternSequence) -> float:
    """Seconds per frame of the harness's affine ECC (pyramid-initialised); NaN
    without OpenCV."""
    return run_ecc(seq, "affine")[2] if cv2 is not None else math.nan


def speed_headline(seq: PatternSequence, repeats: int) -> None:
    """rperc at 200 particles (defaults: the pool only for enough work, which 200
    particles are not; forced onto both cores; one thread) against ECC on the same
    frames, alternated ``repeats`` times so that the machine's load falls on all of
    them; the median of each."""
    runs: dict[str, list[float]] = {}
    for _ in range(repeats):
        timed = {
            "rperc PatternTracker, 200 particles": run_rperc(seq, 200)[2],
            "rperc PatternTracker, 200 particles, forced onto the pool": run_rperc(
                seq, 200, parallel_min_work=0
            )[2],
            "rperc PatternTracker, 200 particles, 1 thread": run_rperc(seq, 200, parallel=False)[2],
        }
        if cv2 is not None:
            timed["ECC affine (pyramid, the harness's)"] = run_ecc(seq, "affine")[2]
            timed["ECC euclidean (pyramid)"] = run_ecc(seq, "euclidean")[2]
            timed["ECC affine, full frame only"] = run_ecc_single(seq)
        for k, v in timed.items():
            runs.setdefault(k, []).append(v)
    median = {k: float(np.median(v)) for k, v in runs.items()}
    ecc = median.get("ECC affine (pyramid, the harness's)", math.nan)
    rows = [[k, f"{1 / v:.1f}", f"{ecc / v:.2f}"] for k, v in median.items()]
    print_table(
        f"frames per second, median of {repeats} alternated runs (steps <= 1 sigma)",
        ["tracker", "fps", "x ECC affine (pyramid)"],
        rows,
    )


def sweep_particles(seq: PatternSequence, particles: list[int]) -> None:
    """fps against the number of particles, each next to an ECC run."""
    rows, times = [], []
    for n in particles:
        dt = run_rperc(seq, n)[2]
        dt_e = ecc_seconds(seq)
        times.append(dt)
        rows.append([str(n), f"{1 / dt:.1f}", f"{1 / dt_e:.1f}", f"{dt_e / dt:.2f}"])
    print_table(
        "frames per second against particles (steps <= 1 sigma)",
        ["particles", "rperc fps", "ECC affine fps", "x ECC"],
        rows,
    )
    print(f"scaling: time per frame ~ particles^{slope(particles, times):.2f}")
    print(f"local slopes: {local_slopes(particles, times)}")


def slope(x: list[int], t: list[float]) -> float:
    """The exponent of a power law fitted to ``t`` against ``x`` (log-log least squares)."""
    if len(x) < 2:
        return math.nan
    return float(np.polyfit(np.log(x), np.log(t), 1)[0])


def local_slopes(x: list[int], t: list[float]) -> str:
    """The exponents between successive sizes (a call's fixed cost hides the growth
    at small sizes)."""
    pairs = zip(zip(x, t, strict=True), zip(x[1:], t[1:], strict=True), strict=False)
    return ", ".join(
        f"{a}-{b}: {math.log(tb / ta) / math.log(b / a):.2f}" for (a, ta), (b, tb) in pairs
    )


def sweep_points(seq: PatternSequence, points: list[int]) -> None:
    """fps against the model's largest number of points (200 particles), each next to
    an ECC run."""
    rows, used, times = [], [], []
    for m in points:
        n_points = PatternTracker(
            seq.frames[0], seq.region, pattern=PatternModelConfig(max_points=m)
        ).n_points
        _, _, dt = run_rperc(seq, 200, max_points=m)
        dt_e = ecc_seconds(seq)
        used.append(n_points)
        times.append(dt)
        rows.append([str(m), str(n_points), f"{1 / dt:.1f}", f"{dt_e / dt:.2f}"])
    print_table(
        "frames per second against model points (200 particles)",
        ["max_points", "points", "fps", "x ECC"],
        rows,
    )
    print(f"scaling: time per frame ~ points^{slope(used, times):.2f}")
    print(f"local slopes: {local_slopes(used, times)}")


def sweep_sizes(patch: np.ndarray, bg: np.ndarray, args: argparse.Namespace) -> None:
    """fps against the frame size (200 particles), ECC affine on the same frames."""
    rows, pixels, times = [], [], []
    for size in args.sizes:
        w, h = (int(v) for v in size.split("x"))
        seq = pattern_sequence(
            patch, bg, n_frames=args.frames, width=w, height=h, seed=3, max_step_sigmas=1.0
        )
        _, _, dt = run_rperc(seq, 200)
        dt_e = ecc_seconds(seq)
        pixels.append(w * h)
        times.append(dt)
        rows.append([size, f"{1 / dt:.1f}", f"{1 / dt_e:.1f}", f"{dt_e / dt:.2f}"])
    print_table(
        "frames per second against frame size (200 particles)",
        ["size", "rperc fps", "ECC affine fps", "x ECC"],
        rows,
    )
    print(f"scaling: time per frame ~ pixels^{slope(pixels, times):.2f}")


if __name__ == "__main__":
    main()
