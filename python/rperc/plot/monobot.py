"""The monobot figures of the seed paper: Fig. 3 (Fisher information), Figs. 4 to 6
(one run per measurement model) and the Monte Carlo study."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from rperc.plot import plt
from rperc.slam.monobot import MonobotResult, MonteCarloResult

MODEL_TITLES = {
    "relative": "relative measurements, H = [-1, I] (Fig. 4)",
    "anchor": "global reference at the origin, eq. (20) (Fig. 5)",
    "external": "external sensor on the robot, eq. (23) (Fig. 6)",
}


def fisher_figure(runs: Sequence[MonobotResult]) -> Figure:
    """Fig. 3: the first entry of the total Fisher information over time."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for run in runs:
        steps = np.arange(1, len(run.fisher_00) + 1)
        ax.plot(steps, run.fisher_00, label=f"{run.config.landmarks} landmarks")
    ax.set_xlabel("iteration k")
    ax.set_ylabel(r"$J_{00} = \sum\sum \varsigma_{ij}$")
    ax.set_title("Fig. 3: first entry of the total Fisher information, P0 = V = W = 1")
    ax.legend()
    ax.grid(alpha=0.3)
    return fig


def run_figure(run: MonobotResult) -> Figure:
    """Figs. 4 to 6: state with 2-sigma bounds, vehicle error, landmark errors, gains."""
    k = np.arange(len(run.estimate))
    fig, axes = plt.subplots(1, 4, figsize=(18, 4))
    ax = axes[0]
    ax.plot(k, run.truth[:, 0], color="k", lw=1.5, label="true robot")
    ax.plot(k, run.estimate[:, 0], color="tab:blue", label="robot estimate")
    ax.plot(k, run.estimate[:, 0] + run.bounds[:, 0], ":", color="tab:blue")
    ax.plot(k, run.estimate[:, 0] - run.bounds[:, 0], ":", color="tab:blue")
    n = run.config.landmarks
    off = run.measurement.shape[1] - n
    ax.plot(
        k[1:],
        run.estimate[1:, 0] + run.measurement[:, off],
        color="tab:orange",
        alpha=0.35,
        lw=0.8,
        label="robot + measurement",
    )
    ax.plot(k, run.estimate[:, 1], color="tab:red", label="landmark estimate")
    ax.plot(k, run.estimate[:, 1] + run.bounds[:, 1], ":", color="tab:red")
    ax.plot(k, run.estimate[:, 1] - run.bounds[:, 1], ":", color="tab:red")
    ax.set_title("estimates, 2-sigma bounds")
    ax.legend(fontsize=7)
    ax = axes[1]
    ax.plot(k, run.error[:, 0], color="tab:blue")
    ax.plot(k, run.bounds[:, 0], ":", color="tab:blue")
    ax.plot(k, -run.bounds[:, 0], ":", color="tab:blue")
    ax.axhline(0, color="0.5", lw=0.5)
    ax.set_title("vehicle error")
    ax = axes[2]
    for i in range(1, run.estimate.shape[1]):
        ax.plot(k, run.error[:, i], lw=1)
    ax.plot(k, run.bounds[:, 1], ":", color="k")
    ax.plot(k, -run.bounds[:, 1], ":", color="k")
    ax.axhline(0, color="0.5", lw=0.5)
    ax.set_title("landmark errors")
    ax = axes[3]
    ax.plot(k[1:], run.gain[:, 0, off], color="k", label="vehicle gain")
    ax.plot(k[1:], run.gain[:, 1, off], color="tab:gray", label="landmark gain")
    ax.set_title("Kalman gains (first landmark's measurement)")
    ax.legend(fontsize=7)
    for ax in axes:
        ax.set_xlabel("iteration k")
        ax.grid(alpha=0.3)
    fig.suptitle(f"monobot, {MODEL_TITLES.get(run.model, run.model)}, {n} landmark(s)")
    fig.tight_layout()
    return fig


def monte_carlo_figure(results: Sequence[MonteCarloResult]) -> Figure:
    """Final vs first-observation landmark error per run, and the run-averaged NEES
    against its 95 % band, for each Monte Carlo."""
    fig, axes = plt.subplots(2, len(results), figsize=(4.5 * len(results), 8), squeeze=False)
    for col, mc in enumerate(results):
        ax = axes[0, col]
        ax.scatter(mc.first_observation_error.ravel(), mc.final_landmark_error.ravel(), s=6)
        ax.set_xlabel("landmark error at the first observation (m)")
        ax.set_ylabel("final landmark error (m)")
        ax.set_title(
            f"{mc.model}, {mc.config.landmarks} landmark(s)\n"
            f"slope {mc.sensitivity:.3f}, corr {mc.correlation:.2f}, "
            f"mean {mc.landmark_error_mean[-1]:+.4f}",
            fontsize=9,
        )
        ax.grid(alpha=0.3)
        ax = axes[1, col]
        ax.plot(mc.nees, label="run-averaged NEES")
        lo, hi = mc.nees_band
        ax.axhspan(lo, hi, color="tab:green", alpha=0.2, label="95% band")
        ax.set_xlabel("iteration k")
        ax.set_title(f"{100 * mc.nees_in_band:.0f}% of steps in band ({mc.runs} runs)", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
