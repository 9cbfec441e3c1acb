"""The colour + template tracker's lost rule and re-detection, chosen by
leave-one-sequence-out over the OTB dev sequences: for each held-out sequence, the
setting of the grid with the best objective pooled over the other sequences is scored
on it. The objective is the F1 of ``lost`` against the frames whose IoU with the truth
is 0 (``--objective f1``, ties: the higher mean AUC) or the mean AUC (``--objective
auc``, ties: the higher F1). Prints each sequence's held-out precision, recall and AUC,
the pooled held-out figures, and every setting's in-sample figures.

    RAYON_NUM_THREADS=1 python benchmarks/template_lost.py [--corpus DIR]
        [--grid lost_contrast_ratio=none,-0.2,-0.1,0,0.1,0.2 lost_color_ratio=0.7,0.8,0.9]
        [--objective f1|auc] [--json OUT]

A grid value ``none`` is the field's ``None`` (``lost_contrast_ratio``: test off).

The rule changes the track as well as the flag (a lost frame teaches nothing and
starts re-detection), so every setting is a full run of every sequence.
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


def run(frames: list[np.ndarray], truth: np.ndarray, settings: dict) -> dict:
    """One track: its IoU per frame (the first excluded) and lost flags, and its AUC."""
    t = ColorTemplateTracker(frames[0], truth[0], **settings)
    boxes, lost = [tuple(truth[0])], []
    for f in frames[1:]:
        r = t.update(f)
        boxes.append(r.box)
        lost.append(r.lost)
    overlaps = metrics.iou(np.asarray(boxes), truth)
    return {"zero": overlaps[1:] == 0, "lost": np.asarray(lost), "auc": metrics.auc(overlaps)}


def counts(runs: list[dict]) -> tuple[int, int, int]:
    """Frames flagged lost with IoU 0, frames flagged, frames with IoU 0."""
    hits = sum(int((r["lost"] & r["zero"]).sum()) for r in runs)
    return hits, sum(int(r["lost"].sum()) for r in runs), sum(int(r["zero"].sum()) for r in runs)


def f1(runs: list[dict]) -> float:
    hits, flagged, zero = counts(runs)
    return 2 * hits / (flagged + zero) if flagged + zero else 0.0


def ratio(a: int, b: int) -> str:
    return f"{a / b:.2f} ({a}/{b})" if b else f"- (0/{b})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--corpus", type=Path, default=None)
    ap.add_argument(
        "--grid",
        nargs="+",
        default=[
            "lost_contrast_ratio=none,-0.2,-0.1,0,0.1,0.2",
            "lost_color_ratio=0.7,0.8,0.9",
        ],
        help="name=v1,v2,... per parameter (none: the field's None); every combination is run",
    )
    ap.add_argument("--objective", choices=("f1", "auc"), default="f1")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    root = args.corpus or (data_dir() / "otb")
    axes = {k: [_value(x) for x in v.split(",")] for k, v in (g.split("=", 1) for g in args.grid)}
    print(f"grid: {' x '.join(axes)}; objective {args.objective}")
    grid: list[Setting] = list(itertools.product(*axes.values()))
    names = sorted(p.name for p in root.iterdir() if (p / "groundtruth_rect.txt").is_file())
    results: dict[tuple[str, Setting], dict] = {}
    for name in names:
        seq = load_otb(root / name)
        frames = [seq.frame(k) for k in range(len(seq))]
        for g in grid:
            results[(name, g)] = run(frames, seq.boxes, dict(zip(axes, g, strict=True)))
        print(f"ran {name}", flush=True)
    report(names, grid, results, args.objective, args.json)


def _value(text: str) -> float | None:
    return None if text.strip().lower() == "none" else float(text)


def score(runs: list[dict], objective: str) -> tuple[float, float]:
    """The objective first, the other score to break ties."""
    auc = float(np.mean([r["auc"] for r in runs]))
    return (f1(runs), auc) if objective == "f1" else (auc, f1(runs))


def report(
    names: list[str], grid: list[Setting], results: dict, objective: str, out: Path | None
) -> None:
    print("\nin-sample, every setting: F1, precision, recall, mean AUC")
    for g in grid:
        runs = [results[(n, g)] for n in names]
        hits, flagged, zero = counts(runs)
        mean_auc = np.mean([r["auc"] for r in runs])
        print(
            f"  {g}: F1 {f1(runs):.3f}  P {ratio(hits, flagged)}  R {ratio(hits, zero)}  "
            f"AUC {mean_auc:.3f}"
        )
    print("\nleave-one-sequence-out: held-out sequence, setting chosen on the others, P, R, AUC")
    held: list[dict] = []
    rows = []
    for name in names:
        others = [n for n in names if n != name]

        def key(g: Setting, others: list[str] = others) -> tuple[float, float]:
            return score([results[(n, g)] for n in others], objective)

        chosen = max(grid, key=key)
        r = results[(name, chosen)]
        held.append(r)
        hits, flagged, zero = counts([r])
        rows.append(
            {
                "sequence": name,
                "chosen": chosen,
                "hits": hits,
                "flagged": flagged,
                "zero": zero,
                "auc": r["auc"],
            }
        )
        print(
            f"  {name:13s} {chosen}  P {ratio(hits, flagged):16s} R {ratio(hits, zero):16s} "
            f"AUC {r['auc']:.3f}"
        )
    hits, flagged, zero = counts(held)
    mean_auc = float(np.mean([r["auc"] for r in held]))
    print(
        f"  pooled held-out: P {ratio(hits, flagged)}  R {ratio(hits, zero)}  F1 {f1(held):.3f}"
        f"  mean AUC {mean_auc:.3f}"
    )
    best = max(grid, key=lambda g: score([results[(n, g)] for n in names], objective))
    print(f"  chosen on all {len(names)}: {best}")
    if out is not None:
        write_text_atomically(out, json.dumps({"held_out": rows, "all": best}, indent=1) + "\n")


if __name__ == "__main__":
    main()
