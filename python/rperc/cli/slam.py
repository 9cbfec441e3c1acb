"""``rperc demo monobot``: the seed paper's Figures 3 to 6 and its Monte Carlo study."""

from __future__ import annotations

import argparse
from pathlib import Path

from rperc.slam import monobot


def add_demo(demos: argparse._SubParsersAction) -> None:
    p = demos.add_parser("monobot", help="EKF-SLAM observability study (Figs. 3-6, Monte Carlo)")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="folder for the PNGs")
    p.add_argument("--runs", type=int, default=100, help="Monte Carlo runs (default 100)")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(run=demo_monobot)


def demo_monobot(args: argparse.Namespace) -> int:
    from rperc.plot import save
    from rperc.plot.monobot import fisher_figure, monte_carlo_figure, run_figure

    out: Path = args.out
    fig3 = [
        monobot.simulate(
            model="relative", seed=args.seed, **monobot.MonobotConfig.unit_noise(n).kwargs()
        )
        for n in (1, 2, 5, 10, 20)
    ]
    written = [save(fisher_figure(fig3), out / "monobot_fig3_fisher.png")]
    print("Fig. 3, J[0,0] after 100 iterations (P0 = V = W = 1):")
    for run in fig3:
        print(f"  {run.config.landmarks:2d} landmarks: {run.fisher_00[-1]:8.2f}")

    print("\nOne run per model (Figs. 4-6), 1 landmark:")
    for number, model in zip((4, 5, 6), ("relative", "anchor", "external"), strict=True):
        run = monobot.simulate(model=model, landmarks=1, seed=args.seed)
        J = monobot.fisher_information(run)
        null = monobot.unobservable_directions(J)
        print(f"  {run}")
        print(
            f"    rank J = {len(J) - null.shape[1]}, "
            f"unobservable directions: {null.T.round(4).tolist()}, "
            f"observability-matrix rank {monobot.observability_rank(model=model, landmarks=1)}"
        )
        written.append(save(run_figure(run), out / f"monobot_fig{number}_{model}.png"))

    print(f"\nMonte Carlo over {args.runs} runs:")
    results = []
    for model in ("relative", "anchor", "external"):
        for n, p0 in ((1, 1e-2), (10, 1e-2)):
            mc = monobot.monte_carlo(
                model=model, landmarks=n, runs=args.runs, seed=args.seed, initial_variance=p0
            )
            print(f"  {mc}")
            if n == 1:
                results.append(mc)
    written.append(save(monte_carlo_figure(results), out / "monobot_monte_carlo.png"))
    for path in written:
        print(f"wrote {path}")
    return 0
