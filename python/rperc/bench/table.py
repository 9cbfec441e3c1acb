"""A benchmark's rows as a table: the mean and sample standard deviation per dataset
x method x setting (over seeds), the rows written as CSV, Parquet or JSON, a printed
table and a figure of the methods side by side per dataset."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np

from rperc._atomic import write_atomically, write_text_atomically
from rperc.bench.tasks import Row, Setting


class Stat(TypedDict):
    """A metric over a group's runs: the mean and the sample standard deviation of its
    finite values (None when there are too few) and how many there were."""

    mean: float | None
    sd: float | None
    n: int


#: A summary line: the group's dataset, method, settings, library, runs and errors,
#: and a :class:`Stat` per metric column (JSON-shaped, as ``--json`` writes it).
Group = dict[str, Setting | Stat]

#: Columns that identify a run rather than measure it.
ID_COLUMNS = ("index", "dataset", "method", "library", "seed", "error")


def _is_number(v: object) -> bool:
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)


def columns(rows: Sequence[Row]) -> list[str]:
    """Every column in the rows, in the order first seen."""
    out: dict[str, None] = {}
    for r in rows:
        out.update(dict.fromkeys(r))
    return list(out)


def metric_columns(rows: Sequence[Row], settings: Sequence[str]) -> list[str]:
    """The numeric columns that measure something (not ids, not settings)."""
    skip = set(ID_COLUMNS) | set(settings)
    return [c for c in columns(rows) if c not in skip and any(_is_number(r.get(c)) for r in rows)]


def group_key(row: Row, settings: Sequence[str]) -> tuple[Setting, ...]:
    """What a summary line is of: the dataset, the method and the settings."""
    return (row["dataset"], row["method"], *(row.get(s) for s in settings))


def summarize(rows: Sequence[Row], settings: Sequence[str] = ()) -> list[Group]:
    """Per dataset x method x setting: the number of runs and of error rows, and for
    each metric the mean and the sample standard deviation (``ddof=1``; ``None`` with
    fewer than two values) over the runs that gave a finite value."""
    groups: dict[tuple[Setting, ...], list[Row]] = {}
    for r in rows:
        groups.setdefault(group_key(r, settings), []).append(r)
    metrics = metric_columns(rows, settings)
    out = []
    for key, members in groups.items():
        entry: Group = {"dataset": key[0], "method": key[1]}
        entry.update(zip(settings, key[2:], strict=True))
        entry["library"] = members[0].get("library", "")
        entry["runs"] = len(members)
        entry["errors"] = sum(1 for m in members if m.get("error"))
        for c in metrics:
            values = np.array([_float(m.get(c)) for m in members if _is_number(m.get(c))])
            values = values[np.isfinite(values)]
            mean = float(values.mean()) if len(values) else None
            sd = float(values.std(ddof=1)) if len(values) > 1 else None
            entry[c] = {"mean": mean, "sd": sd, "n": len(values)}
        out.append(entry)
    return out


def _float(v: object) -> float:
    assert isinstance(v, int | float | np.integer | np.floating)  # _is_number said so
    return float(v)


def _plain(v: object) -> object:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_rows(rows: Sequence[Row], path: str | Path) -> Path:
    """One row per run, every column (settings included) its own: ``.csv``, ``.json``
    (a list of objects) or ``.parquet`` (needs pyarrow)."""
    p = Path(path)
    cols = columns(rows)
    suffix = p.suffix.lower()
    if suffix == ".csv":

        def write_csv(tmp: Path) -> None:
            with tmp.open("w", encoding="utf-8", newline="") as f:
                w = csv.DictWriter(f, fieldnames=cols, restval="", lineterminator="\n")
                w.writeheader()
                for r in rows:
                    w.writerow({k: "" if _plain(v) is None else _plain(v) for k, v in r.items()})

        return write_atomically(p, write_csv)
    if suffix == ".json":
        text = json.dumps([{k: _plain(v) for k, v in r.items()} for r in rows], indent=1)
        return write_text_atomically(p, text + "\n")
    if suffix == ".parquet":
        try:
            import pyarrow as pa  # type: ignore[import-untyped,unused-ignore]
            import pyarrow.parquet as pq  # type: ignore[import-untyped,unused-ignore]
        except ImportError:
            raise ValueError(f"--out {p}: Parquet needs pyarrow (pip install pyarrow)") from None
        table = pa.Table.from_pylist([{c: _plain(r.get(c)) for c in cols} for r in rows])
        return write_atomically(p, lambda tmp: pq.write_table(table, tmp))
    raise ValueError(f"--out {p}: use a .csv, .json or .parquet file name")


def write_summary(summary: Sequence[Group], path: str | Path, about: Mapping[str, object]) -> Path:
    """The summary as JSON: ``about`` (the command, seeds, scheduler) and the groups."""
    p = Path(path)
    text = json.dumps({**about, "groups": [_plain_tree(g) for g in summary]}, indent=1)
    return write_text_atomically(p, text + "\n")


def _plain_tree(v: object) -> object:
    if isinstance(v, Mapping):
        return {k: _plain_tree(x) for k, x in v.items()}
    return _plain(v)


def _number(v: float) -> str:
    """Three significant digits, without an exponent below a million."""
    return f"{v:.0f}" if 1000 <= abs(v) < 1e6 else f"{v:.3g}"


def _cell(stat: Setting | Stat) -> str:
    if not isinstance(stat, dict) or stat["mean"] is None:
        return "-"
    if stat["sd"] is None:
        return _number(stat["mean"])
    return f"{_number(stat['mean'])} ± {_number(stat['sd'])}"


def format_summary(
    summary: Sequence[Group], shown: Sequence[str], settings: Sequence[str] = ()
) -> str:
    """A text table: one line per group, ``mean ± sd`` of each ``shown`` metric."""
    header = ["dataset", "method", *settings, "library", "runs", *shown]
    body = []
    for g in summary:
        cells = [str(g["dataset"]), str(g["method"]), *(str(g.get(s)) for s in settings)]
        cells += [
            str(g["library"]),
            f"{g['runs']}" + (f" ({g['errors']} failed)" if g["errors"] else ""),
        ]
        cells += [_cell(g.get(m)) for m in shown]
        body.append(cells)
    widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]
    lines = [
        "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
        for r in [header, *body]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def method_means(
    summary: Sequence[Group], metric: str, settings: Sequence[str] = ()
) -> dict[str, float]:
    """Per method (and setting), the mean over datasets of each dataset's mean."""
    acc: dict[str, list[float]] = {}
    for g in summary:
        stat = g.get(metric)
        if isinstance(stat, dict) and stat["mean"] is not None:
            acc.setdefault(label(g, settings), []).append(stat["mean"])
    return {k: float(np.mean(v)) for k, v in acc.items()}


def label(group: Group, settings: Sequence[str]) -> str:
    """A group's method and settings as one legend label."""
    extra = ", ".join(f"{s}={group.get(s)}" for s in settings)
    return f"{group['method']} ({extra})" if extra else str(group["method"])


def plot_summary(
    summary: Sequence[Group],
    metric: str,
    unit: str,
    path: str | Path,
    settings: Sequence[str] = (),
    title: str = "",
) -> Path:
    """Per dataset, the methods side by side: bars of the mean of ``metric`` with the
    standard deviation over seeds as error bars; the mean over datasets per method in
    the legend."""
    import matplotlib.pyplot as plt

    from rperc.plot import save

    datasets = list(dict.fromkeys(str(g["dataset"]) for g in summary))
    methods = list(dict.fromkeys(label(g, settings) for g in summary))
    means = method_means(summary, metric, settings)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(datasets) * max(len(methods), 2) / 2), 4.5))
    width = 0.8 / max(len(methods), 1)
    x = np.arange(len(datasets))
    bar_heights: list[np.ndarray] = []
    for j, m in enumerate(methods):
        ys, es = np.full(len(datasets), np.nan), np.zeros(len(datasets))
        for g in summary:
            stat = g.get(metric)
            if label(g, settings) == m and isinstance(stat, dict) and stat["mean"] is not None:
                i = datasets.index(str(g["dataset"]))
                ys[i], es[i] = stat["mean"], stat["sd"] or 0.0
        bar_heights.append(ys)
        mean = f" (mean {means[m]:.3g})" if m in means else ""
        ax.bar(
            x + (j - (len(methods) - 1) / 2) * width, ys, width, yerr=es, capsize=2, label=m + mean
        )
    ax.set_xticks(x, [Path(d).name for d in datasets], rotation=30, ha="right")
    ylabel = f"{metric} ({unit})" if unit else metric
    heights = [float(h) for ys in bar_heights for h in ys if np.isfinite(h)]
    positive = [h for h in heights if h > 0]
    # Methods an order of magnitude apart (odometry against SLAM): a log axis keeps
    # the small bars readable instead of letting the largest set the scale.
    if positive and max(positive) > 20 * min(positive):
        ax.set_yscale("log")
        ylabel += ", log scale"
    ax.set_ylabel(ylabel)
    ax.set_xlabel("dataset")
    ax.legend(
        fontsize=8,
        title="method (mean over datasets)\nbars: mean ± sd over seeds",
        title_fontsize=8,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
    )
    ax.set_title(title or f"{metric} per dataset")
    fig.tight_layout()
    return save(fig, path)


@dataclass(frozen=True)
class BenchResult:
    """A benchmark's rows (one per run, in task order) and what to show of them:
    ``settings`` are the setting columns, ``shown`` the metrics the table prints and
    ``primary`` the figure's metric and its unit."""

    suite: str
    rows: tuple[Row, ...]
    settings: tuple[str, ...] = ()
    shown: tuple[str, ...] = ()
    primary: tuple[str, str] = ("", "")

    def summary(self) -> list[Group]:
        """Mean and sample sd per dataset x method x setting (:func:`summarize`)."""
        return summarize(self.rows, self.settings)

    def errors(self) -> list[Row]:
        """The rows of runs that raised."""
        return [r for r in self.rows if r.get("error")]

    def table(self) -> str:
        """The summary as text, then the mean over datasets of the primary metric."""
        summary = self.summary()
        text = format_summary(summary, self.shown, self.settings)
        metric = self.primary[0]
        means = method_means(summary, metric, self.settings)
        if means:
            text += f"\nmean {metric} over datasets: " + ", ".join(
                f"{k} {v:.4g}" for k, v in means.items()
            )
        return text

    def write(self, path: str | Path) -> Path:
        """The rows as CSV, JSON or Parquet (:func:`write_rows`)."""
        return write_rows(self.rows, path)

    def plot(self, path: str | Path) -> Path:
        """The primary metric per dataset, methods side by side (:func:`plot_summary`)."""
        metric, unit = self.primary
        means = method_means(self.summary(), metric, self.settings)
        score = ", ".join(f"{k} {v:.3g}" for k, v in means.items())
        title = f"rperc bench {self.suite}: {metric} per dataset (mean over datasets: {score})"
        return plot_summary(self.summary(), metric, unit, path, self.settings, title)

    def __repr__(self) -> str:
        return (
            f"BenchResult({self.suite}: {len(self.rows)} runs, {len(self.errors())} failed, "
            f"settings={list(self.settings)})"
        )
