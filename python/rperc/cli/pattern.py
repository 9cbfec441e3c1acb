"""``rperc demo pattern``: the seed 001 pattern tracker's Fig. 8 (section 4.1) on a
generated sequence, and the planar-tracking harness table against OpenCV's peers."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from rperc.cli.demo import DemoResult

COMPONENTS = ("dX (px)", "dY (px)", "dtheta (deg)", "ds (%)")


def demo_images(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A patch with rectangles and a disc, and blocky clutter (generated, no data)."""
    rng = np.random.default_rng(seed)
    patch = np.full((100, 100), 60.0)
    patch[10:45, 15:60] = 200
    patch[55:90, 40:85] = 140
    yy, xx = np.mgrid[0:100, 0:100]
    patch[(xx - 30) ** 2 + (yy - 70) ** 2 < 225] = 230
    background = rng.uniform(40, 200, (32, 32)).repeat(16, 0).repeat(16, 1)
    return patch, background


def fig8_errors(estimates: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """RMS position (px), angle (deg) and relative scale (%) errors of the estimates of
    frames ``1..n`` against the truth, over frames whose swept step is within 3 sigma
    (the goals of the issue)."""
    from rperc.tracking.planar import SIGMA

    t = truth[1:]
    k = np.arange(len(t))
    step = np.abs(np.diff(truth, axis=0)[k, k % 4]) / np.array(SIGMA)[k % 4]
    sel = step <= 3.0
    pos = np.hypot(estimates[:, 0] - t[:, 0], estimates[:, 1] - t[:, 1])[sel]
    ang = np.degrees(estimates[:, 2] - t[:, 2])[sel]
    scl = 100 * (estimates[:, 3] / t[:, 3] - 1)[sel]
    rms = [float(np.sqrt(np.mean(v**2))) for v in (pos, ang, scl)]
    return {
        "frames": int(sel.sum()),
        "position_px": rms[0],
        "angle_deg": rms[1],
        "scale_pct": rms[2],
    }


def _fig8(estimates: np.ndarray, truth: np.ndarray, errors: dict[str, float], seed: int) -> Any:
    import matplotlib.pyplot as plt

    from rperc.tracking.planar import SIGMA

    units = np.array([1.0, 1.0, 180 / math.pi, 100.0])
    true_step = np.diff(truth, axis=0)
    est_step = np.diff(np.vstack([truth[:1], estimates]), axis=0)
    err = estimates - truth[1:]
    k = np.arange(len(true_step))
    fig, axes = plt.subplots(2, 4, figsize=(16, 7.5))
    for d in range(4):
        sel = k % 4 == d
        ax = axes[0, d]
        x, y = true_step[sel, d] * units[d], est_step[sel, d] * units[d]
        lim = 1.1 * max(np.abs(x).max(), np.abs(y).max(), 1e-9)
        ax.plot([-lim, lim], [-lim, lim], "k--", lw=1, label="ideal")
        ax.plot(x, y, "o", ms=4, label="estimate vs truth")
        ax.set_xlabel(f"true {COMPONENTS[d]}")
        ax.set_ylabel(f"estimated {COMPONENTS[d]}")
        ax.legend(loc="upper left", fontsize=8)
        ax = axes[1, d]
        ratio = np.abs(true_step[sel, d]) / SIGMA[d]
        ax.plot(ratio, np.abs(err[sel, d]) * units[d], "o", ms=4, label="|estimate - truth|")
        ax.axvline(3.0, color="grey", ls=":", label="3 sigma")
        ax.set_xlabel("|step| / sigma")
        ax.set_ylabel(f"error {COMPONENTS[d]}")
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(
        f"Fig. 8 reproduced (seed {seed}): within 3 sigma, RMS {errors['position_px']:.2f} px, "
        f"{errors['angle_deg']:.2f} deg, {errors['scale_pct']:.1f} % scale "
        f"({errors['frames']} frames)"
    )
    fig.tight_layout()
    return fig


def demo_pattern(out: Path, seed: int, frames: int = 60) -> DemoResult:
    """The pattern tracker on a generated Fig. 8 sequence (steps swept to 4 sigma, noise,
    moving clutter) and the planar harness (pattern tracker, ECC, matchTemplate, CSRT)
    on the four harness cases."""
    from rperc.plot import save
    from rperc.tracking import PatternTracker, pattern_sequence, planar

    patch, background = demo_images(seed)
    seq = pattern_sequence(patch, background, n_frames=frames, seed=seed, max_step_sigmas=4.0)
    tracker = PatternTracker(seq.frames[0], seq.region, seed=seed)
    poses = [tracker.update(f) for f in seq.frames[1:]]
    estimates = np.array([(p.x, p.y, p.theta, p.scale) for p in poses])
    lost = int(sum(p.lost for p in poses))
    errors = fig8_errors(estimates, seq.truth)
    figures = [save(_fig8(estimates, seq.truth, errors, seed), out / "pattern.png")]
    cases = planar.harness_cases(patch, background, n_frames=max(frames // 2, 8), seed=seed)
    scores = planar.run_harness(cases)
    table = planar.format_table(scores)
    (out / "pattern_harness.txt").write_text(table + "\n")
    p5 = {s.tracker: s.precision_5 for s in scores if s.case == "steps <= 1 sigma"}
    summary = (
        f"pattern: Fig. 8 sequence ({frames} frames, seed {seed}, steps to 4 sigma), within "
        f"3 sigma RMS {errors['position_px']:.2f} px, {errors['angle_deg']:.2f} deg, "
        f"{errors['scale_pct']:.1f} % scale, lost {lost}; harness P@5 (steps <= 1 sigma): "
        + ", ".join(f"{n} {v:.2f}" for n, v in p5.items() if not math.isnan(v))
    )
    measured = {
        "errors": errors,
        "lost": lost,
        "estimates": estimates.tolist(),
        "harness": [vars(s) for s in scores],
    }
    return DemoResult(summary, figures, measured, details=table.splitlines())
