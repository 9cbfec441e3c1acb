"""The monobot figures of paper [000]: Fig. 3 (Fisher information), Figs. 4 to 6
(one run per measurement model) and the Monte Carlo study.

Positions and errors are in metres (the monobot moves along a line); the Fisher
information of a position is in 1/m^2; Kalman gains and the NEES have no unit.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rperc.slam.monobot import MonobotResult, MonteCarloResult

MODEL_TITLES = {
    "relative": "relative measurements, H = [-1, I] (Fig. 4)",
    "anchor": "global reference at the origin, eq. (20) (Fig. 5)",
    "external": "external sensor on the robot, eq. (23) (Fig. 6)",
}


def fisher_figure(runs: Sequence[MonobotResult]) -> Figure:
    """Fig. 3: the first entry of the total Fisher information over time."""
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for run in runs:
        steps = np.arange(1, len(run.fisher_00) + 1)
        ax.plot(
            steps,
            run.fisher_00,
            label=f"{run.config.landmarks} landmarks (final {run.fisher_00[-1]:.2f})",
        )
    ax.set_xlabel("iteration k [steps]")
    ax.set_ylabel(r"$J_{00} = \sum\sum \varsigma_{ij}$  [1/m$^2$]")
    last = [run.fisher_00[-1] for run in runs]
    ax.set_title(
        "Fig. 3: first entry of the total Fisher information, P0 = V = W = 1\n"
        f"after {len(runs[0].fisher_00)} steps: {min(last):.2f} to {max(last):.2f} 1/m$^2$",
        fontsize=10,
    )
    ax.legend(title="computed from each run", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _band(ax: Axes, k: np.ndarray, centre: np.ndarray, half: np.ndarray, color: str) -> None:
    ax.plot(k, centre + half, ":", color=color)
    ax.plot(k, centre - half, ":", color=color)


def _estimates_panel(ax: Axes, run: MonobotResult, k: np.ndarray) -> None:
    off = run.measurement.shape[1] - run.config.landmarks
    ax.plot(k, run.truth[:, 0], color="k", lw=1.5, label="robot, truth")
    ax.plot(k, run.estimate[:, 0], color="tab:blue", label="robot, estimate")
    _band(ax, k, run.estimate[:, 0], run.bounds[:, 0], "tab:blue")
    ax.plot(
        k[1:],
        run.estimate[1:, 0] + run.measurement[:, off],
        color="tab:orange",
        alpha=0.35,
        lw=0.8,
        label="robot estimate + measurement",
    )
    ax.plot(k, run.truth[:, 1], color="tab:brown", lw=1.5, ls="--", label="landmark, truth")
    ax.plot(k, run.estimate[:, 1], color="tab:red", label="landmark, estimate")
    _band(ax, k, run.estimate[:, 1], run.bounds[:, 1], "tab:red")
    ax.plot([], [], ":", color="0.3", label="estimate +- 2 sigma")
    _labels(ax, "position [m]", "estimates against the truth")


def _error_panels(vehicle: Axes, landmarks: Axes, run: MonobotResult, k: np.ndarray) -> None:
    vehicle.plot(k, run.error[:, 0], color="tab:blue", label="estimate - truth")
    _around_zero(vehicle, k, run.bounds[:, 0], "tab:blue", "+- 2 sigma (filter)")
    _labels(vehicle, "robot error [m]", "vehicle error")
    for i in range(1, run.estimate.shape[1]):
        landmarks.plot(k, run.error[:, i], lw=1, label=f"landmark {i}" if i <= 5 else None)
    _around_zero(landmarks, k, run.bounds[:, 1], "k", "+- 2 sigma (landmark 1)")
    _labels(landmarks, "landmark error, estimate - truth [m]", "landmark errors")


def _around_zero(ax: Axes, k: np.ndarray, bound: np.ndarray, color: str, label: str) -> None:
    """An error panel's 2-sigma band around zero, with its legend entry and the zero
    line the errors should straddle."""
    _band(ax, k, np.zeros_like(k, dtype=float), bound, color)
    ax.plot([], [], ":", color=color, label=label)
    ax.axhline(0, color="0.5", lw=0.5)


def _labels(ax: Axes, ylabel: str, title: str) -> None:
    """The y label, title and legend of a panel of a run's figure."""
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)


def _inside(run: MonobotResult) -> float:
    """Fraction of (step, state entry) pairs whose error is within the 2-sigma bound."""
    return float(np.mean(np.abs(run.error) <= run.bounds))


def run_figure(run: MonobotResult) -> Figure:
    """Figs. 4 to 6: state with 2-sigma bounds, vehicle error, landmark errors, gains."""
    k = np.arange(len(run.estimate))
    fig = Figure(figsize=(18, 4.4), layout="constrained")
    axes = fig.subplots(1, 4)
    _estimates_panel(axes[0], run, k)
    _error_panels(axes[1], axes[2], run, k)
    off = run.measurement.shape[1] - run.config.landmarks
    ax = axes[3]
    ax.plot(k[1:], run.gain[:, 0, off], color="k", label="vehicle gain")
    ax.plot(k[1:], run.gain[:, 1, off], color="tab:gray", label="landmark gain")
    _labels(ax, "Kalman gain [-]", "Kalman gains (first landmark's measurement)")
    for ax in axes:
        ax.set_xlabel("iteration k [steps]")
        ax.grid(alpha=0.3)
    e = run.error[-1]
    n = run.config.landmarks
    fig.suptitle(
        f"monobot, {MODEL_TITLES.get(run.model, run.model)}, {n} landmark(s): "
        f"final robot error {e[0]:+.4f} m, landmark error {np.mean(e[1:]):+.4f} m, "
        f"{100 * _inside(run):.0f}% of errors inside 2 sigma",
        fontsize=10,
    )
    return fig


def _monte_carlo_scatter(ax: Axes, mc: MonteCarloResult) -> None:
    x = mc.first_observation_error.ravel()
    y = mc.final_landmark_error.ravel()
    ax.scatter(x, y, s=6, label="one run (errors = estimate - truth)")
    xs = np.linspace(x.min(), x.max(), 2)
    intercept = float(np.mean(y) - mc.sensitivity * np.mean(x))
    ax.plot(xs, intercept + mc.sensitivity * xs, color="tab:red", lw=1, label="least-squares fit")
    ax.set_xlabel("landmark error at the first observation [m]")
    ax.set_ylabel("final landmark error [m]")
    ax.set_title(
        f"{mc.model}, {mc.config.landmarks} landmark(s)\n"
        f"slope {mc.sensitivity:.3f}, corr {mc.correlation:.2f}, "
        f"final error {mc.landmark_error_mean[-1]:+.4f} +- {mc.landmark_error_std[-1]:.4f} m",
        fontsize=9,
    )
    ax.legend(fontsize=7)


def monte_carlo_figure(results: Sequence[MonteCarloResult]) -> Figure:
    """Final vs first-observation landmark error per run, and the run-averaged NEES
    against its 95 % band, for each Monte Carlo."""
    fig = Figure(figsize=(4.8 * len(results), 8.5), layout="constrained")
    axes = fig.subplots(2, len(results), squeeze=False)
    for col, mc in enumerate(results):
        _monte_carlo_scatter(axes[0, col], mc)
        ax = axes[1, col]
        ax.plot(mc.nees, label="run-averaged NEES (estimate vs truth)")
        lo, hi = mc.nees_band
        ax.axhspan(lo, hi, color="tab:green", alpha=0.2, label="95% band (consistent filter)")
        ax.set_xlabel("iteration k [steps]")
        ax.set_ylabel("NEES [-]")
        ax.set_title(f"{100 * mc.nees_in_band:.0f}% of steps in band ({mc.runs} runs)", fontsize=9)
        ax.legend(fontsize=7)
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    return fig
