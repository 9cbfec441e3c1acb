"""The colour + template tracker's lost rule and re-detection, chosen by
leave-one-sequence-out over the OTB dev sequences: for each held-out sequence, the
setting of the grid with the best objective pooled over the other sequences is scored
on it. Objectives: the F1 of ``lost`` against the frames whose IoU with the truth is 0
(``f1``, ties: the higher mean AUC); the mean AUC (``auc``, ties: the higher F1); or
the F1 among the settings whose mean AUC over the other sequences is within
``--auc-slack`` of the best there (``f1-auc``: a better flag that costs no track).
Prints each sequence's held-out precision, recall and AUC, the pooled held-out
figures, and every setting's in-sample figures.

    RAYON_NUM_THREADS=1 python benchmarks/template_lost.py [--corpus DIR]
        [--grid lost_contrast_ratio=none,-0.3 found_contrast_ratio=0 ...]
        [--objective f1|auc|f1-auc] [--auc-slack 0.005] [--runs OUT.json]
        [--from-runs IN.json] [--json OUT]

A grid value ``none`` is the field's ``None`` (``lost_contrast_ratio``: test off).
The rule changes the track as well as the flag (a lost frame teaches nothing and
starts re-detection), so every setting is a full run of every sequence. ``--runs``
saves every run's counts, ``--from-runs`` reports from them again without running.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from rperc._atomic import write_text_atomically
from rperc.datasets import data_dir, load_otb
from rperc.tracking import ColorTemplateTracker, metrics

Setting = tuple[float | None, ...]
#: One run's counts: frames flagged lost with IoU 0, frames flagged, frames with IoU 0
#: (the first frame excluded), and the track's success AUC.
Run = dict[str, float]


def run(frames: list[np.ndarray], truth: np.ndarray, settings: dict) -> Run:
    """One track's counts (see :data:`Run`)."""
    t = ColorTemplateTracker(frames[0], truth[0], **settings)
    boxes, lost = [tuple(truth[0])], []
    for f in frames[1:]:
        r = t.update(f)
        boxes.append(r.box)
        lost.append(r.lost)
    overlaps = metrics.iou(np.asarray(boxes), truth)
    zero, flagged = overlaps[1:] == 0, np.asarray(lost)
    return {
        "hits": int((zero & flagged).sum()),
        "flagged": int(flagged.sum()),
        "zero": int(zero.sum()),
        "auc": float(metrics.auc(overlaps)),
    }


def counts(runs: list[Run]) -> tuple[int, int, int]:
    """Frames flagged lost with IoU 0, frames flagged, frames with IoU 0."""
    return tuple(int(sum(r[k] for r in runs)) for k in ("hits", "flagged", "zero"))  # type: ignore[return-value]


def f1(runs: list[Run]) -> float:
    hits, flagged, zero = counts(runs)
    return 2 * hits / (flagged + zero) if flagged + zero else 0.0


def mean_auc(runs: list[Run]) -> float:
    return float(np.mean([r["auc"] for r in runs]))


def ratio(a: int, b: int) -> str:
    return f"{a / b:.2f} ({a}/{b})" if b else f"- (0/{b})"


def _value(text: str) -> float | None:
    """``none`` is None, a whole number an int (for count fields), else a float."""
    text = text.strip().lower()
    if text == "none":
        return None
    return int(text) if text.lstrip("-").isdigit() else float(text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--corpus", type=Path, default=None)
    ap.add_argument(
        "--grid",
        nargs="+",
        default=[
            "lost_contrast_ratio=none,-0.3",
            "found_contrast_ratio=0",
            "lost_color_ratio=0.7,0.75,0.8,0.85",
            "lost_level_decay=0.97,0.98,0.99,0.995",
        ],
        help="name=v1,v2,... per parameter (none: the field's None); every combination is run",
    )
    ap.add_argument("--objective", choices=("f1", "auc", "f1-auc"), default="f1-auc")
    ap.add_argument("--auc-slack", type=float, default=0.005)
    ap.add_argument("--runs", type=Path, default=None, help="save every run's counts here")
    ap.add_argument("--from-runs", type=Path, default=None, help="report from saved counts")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    if args.from_runs is not None:
        saved = json.loads(args.from_runs.read_text())
        axes, names = saved["axes"], saved["names"]
        results = {(r["sequence"], tuple(r["setting"])): r["run"] for r in saved["runs"]}
    else:
        axes = {
            k: [_value(x) for x in v.split(",")] for k, v in (g.split("=", 1) for g in args.grid)
        }
        names, results = run_grid(args.corpus or (data_dir() / "otb"), axes)
        if args.runs is not None:
            rows = [{"sequence": n, "setting": list(g), "run": r} for (n, g), r in results.items()]
            payload = {"axes": axes, "names": names, "runs": rows}
            write_text_atomically(args.runs, json.dumps(payload) + "\n")
    print(f"grid: {' x '.join(axes)}; objective {args.objective}")
    grid: list[Setting] = list(itertools.product(*axes.values()))
    chooser = Chooser(args.objective, args.auc_slack, grid, results)
    report(names, chooser, args.json)


def run_grid(root: Path, axes: dict) -> tuple[list[str], dict[tuple[str, Setting], Run]]:
    """Every setting of the grid on every sequence of ``root``."""
    grid: list[Setting] = list(itertools.product(*axes.values()))
    names = sorted(p.name for p in root.iterdir() if (p / "groundtruth_rect.txt").is_file())
    results: dict[tuple[str, Setting], Run] = {}
    for name in names:
        seq = load_otb(root / name)
        frames = [seq.frame(k) for k in range(len(seq))]
        for g in grid:
            results[(name, g)] = run(frames, seq.boxes, dict(zip(axes, g, strict=True)))
        print(f"ran {name}", flush=True)
    return names, results


class Chooser:
    """The setting an objective picks on a set of sequences."""

    def __init__(self, objective: str, slack: float, grid: list[Setting], results: dict):
        self.objective, self.slack, self.grid, self.results = objective, slack, grid, results

    def runs(self, g: Setting, names: list[str]) -> list[Run]:
        return [self.results[(n, g)] for n in names]

    def choose(self, names: list[str]) -> Setting:
        grid = self.grid
        if self.objective == "f1-auc":
            best = max(mean_auc(self.runs(g, names)) for g in grid)
            grid = [g for g in grid if mean_auc(self.runs(g, names)) >= best - self.slack]

        def key(g: Setting) -> tuple[float, float]:
            runs = self.runs(g, names)
            return (
                (mean_auc(runs), f1(runs))
                if self.objective == "auc"
                else (f1(runs), mean_auc(runs))
            )

        return max(grid, key=key)


def report(names: list[str], chooser: Chooser, out: Path | None) -> None:
    print("\nin-sample, every setting: F1, precision, recall, mean AUC")
    for g in chooser.grid:
        runs = chooser.runs(g, names)
        hits, flagged, zero = counts(runs)
        print(
            f"  {g}: F1 {f1(runs):.3f}  P {ratio(hits, flagged)}  R {ratio(hits, zero)}  "
            f"AUC {mean_auc(runs):.3f}"
        )
    print("\nleave-one-sequence-out: held-out sequence, setting chosen on the others, P, R, AUC")
    held: list[Run] = []
    rows = []
    for name in names:
        chosen = chooser.choose([n for n in names if n != name])
        r = chooser.results[(name, chosen)]
        held.append(r)
        hits, flagged, zero = counts([r])
        rows.append({"sequence": name, "chosen": chosen, **r})
        print(
            f"  {name:13s} {chosen}  P {ratio(hits, flagged):16s} R {ratio(hits, zero):16s} "
            f"AUC {r['auc']:.3f}"
        )
    hits, flagged, zero = counts(held)
    print(
        f"  pooled held-out: P {ratio(hits, flagged)}  R {ratio(hits, zero)}  F1 {f1(held):.3f}"
        f"  mean AUC {mean_auc(held):.3f}"
    )
    best = chooser.choose(names)
    print(f"  chosen on all {len(names)}: {best}")
    if out is not None:
        write_text_atomically(out, json.dumps({"held_out": rows, "all": best}, indent=1) + "\n")


if __name__ == "__main__":
    main()
