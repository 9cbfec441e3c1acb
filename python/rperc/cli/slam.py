"""``rperc demo monobot``: paper [000]'s Figures 3 to 6 and its Monte Carlo study."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rperc._progress import progress
from rperc.cli.outputs import DemoResult
from rperc.slam import monobot

MODELS: tuple[monobot.Model, ...] = ("relative", "anchor", "external")
FIG3_LANDMARKS = (1, 2, 5, 10, 20)


def _fisher_figure(out: Path, seed: int, details: list[str]) -> Path:
    from rperc.plot import save
    from rperc.plot.monobot import fisher_figure

    fig3 = [
        monobot.simulate(model="relative", seed=seed, config=monobot.unit_noise(n))
        for n in progress(FIG3_LANDMARKS, desc="monobot Fig. 3", unit="run")
    ]
    details.append("Fig. 3, J[0,0] after 100 iterations (P0 = V = W = 1):")
    details += [f"  {run.config.landmarks:2d} landmarks: {run.fisher_00[-1]:8.2f}" for run in fig3]
    return save(fisher_figure(fig3), out / "monobot_fig3_fisher.png")


def _observability(out: Path, seed: int, details: list[str]) -> tuple[list[Path], dict[str, Any]]:
    """Figs. 4 to 6: one run per model; the rank and null space of its Fisher
    information (eq. 14) and the rank of the observability matrix."""
    from rperc.plot import save
    from rperc.plot.monobot import run_figure

    details.append("\nOne run per model (Figs. 4-6), 1 landmark:")
    figures: list[Path] = []
    measured: dict[str, Any] = {}
    for number, model in zip((4, 5, 6), MODELS, strict=True):
        run = monobot.simulate(model=model, landmarks=1, seed=seed)
        J = monobot.fisher_information(run)
        null = monobot.unobservable_directions(J)
        measured[model] = {
            "fisher_rank": len(J) - null.shape[1],
            "state_dim": len(J),
            "unobservable_directions": null.T,
            "observability_rank": monobot.observability_rank(model=model, landmarks=1),
            "final_error_m": run.error[-1],
        }
        details.append(f"  {run}")
        details.append(
            f"    rank J = {len(J) - null.shape[1]}, "
            f"unobservable directions: {null.T.round(4).tolist()}, "
            f"observability-matrix rank {measured[model]['observability_rank']}"
        )
        figures.append(save(run_figure(run), out / f"monobot_fig{number}_{model}.png"))
    return figures, measured


def _monte_carlo(
    out: Path, seed: int, runs: int, details: list[str]
) -> tuple[Path, dict[str, Any]]:
    from rperc.plot import save
    from rperc.plot.monobot import monte_carlo_figure

    details.append(f"\nMonte Carlo over {runs} runs:")
    shown: list[monobot.MonteCarloResult] = []
    measured: dict[str, Any] = {}
    for model in MODELS:
        for n, p0 in ((1, 1e-2), (10, 1e-2)):
            mc = monobot.monte_carlo(
                model=model,
                landmarks=n,
                runs=runs,
                seed=seed,
                initial_variance=p0,
                progress=True,
            )
            details.append(f"  {mc}")
            measured[f"{model}_{n}"] = {
                "final_landmark_error_mean_m": mc.landmark_error_mean[-1],
                "final_landmark_error_std_m": mc.landmark_error_std[-1],
                "nees_in_band": mc.nees_in_band,
                "sensitivity": mc.sensitivity,
            }
            if n == 1:
                shown.append(mc)
    return save(monte_carlo_figure(shown), out / "monobot_monte_carlo.png"), measured


def demo_monobot(out: Path, seed: int, runs: int = 100) -> DemoResult:
    details: list[str] = []
    figures = [_fisher_figure(out, seed, details)]
    run_figures, observability = _observability(out, seed, details)
    figures += run_figures
    mc_figure, mc = _monte_carlo(out, seed, runs, details)
    figures.append(mc_figure)
    ranks = ", ".join(
        f"{m} {observability[m]['fisher_rank']}/{observability[m]['state_dim']}" for m in MODELS
    )
    null = np.asarray(observability["relative"]["unobservable_directions"])
    direction = ", ".join(f"{v:+.2f}" for v in (null[0] if len(null) else []))
    summary = (
        f"monobot: rank of the Fisher information {ranks} "
        f"(relative unobservable along ({direction})); {runs}-run Monte Carlo, 1 landmark: "
        "final landmark error sd "
        + " / ".join(f"{1e3 * mc[f'{m}_1']['final_landmark_error_std_m']:.1f}" for m in MODELS)
        + " mm, NEES in its 95% band "
        + " / ".join(f"{100 * mc[f'{m}_1']['nees_in_band']:.0f}" for m in MODELS)
        + "% of steps (relative / anchor / external)"
    )
    measured = {"runs": runs, "observability": observability, "monte_carlo": mc}
    return DemoResult(summary, figures, measured, details)
