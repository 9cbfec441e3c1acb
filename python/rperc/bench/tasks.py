"""What one benchmark run is (a :class:`Task`), and how a corpus x methods x seeds x
settings grid becomes the list of them.

A task carries only small values: the dataset as a path (the worker reads it), the
method's name, the seed and the settings. Its index is its place in the list, so
rows come back in the same order whatever ran them, and a task's randomness comes from
its own seed only: the rows are the same on one core or a cluster.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: A setting's value: what JSON holds and a CSV column can show.
Setting = bool | int | float | str | None
#: A run's row: column name -> a setting's kind of value (a score, a name, a flag).
Row = dict[str, Setting]
#: A settings grid as given: names and values (or lists of values), or a list of
#: combinations; read from JSON, so its values are checked when it is expanded.
Grid = Mapping[str, object] | Sequence[Mapping[str, object]] | None

#: At most this many tasks in one grid: beyond it a typo in a range ("0-99999") would
#: queue days of work before the first row.
MAX_TASKS = 100_000


@dataclass(frozen=True)
class Task:
    """One run: ``method`` on ``dataset`` (a path or a generated case's name) with
    ``seed`` and ``settings`` (keyword overrides of the method), the ``index``-th of
    its benchmark. ``suite`` names the capability (``track``, ``laser``, ...)."""

    suite: str
    index: int
    dataset: str
    method: str
    seed: int
    settings: tuple[tuple[str, Setting], ...] = ()
    options: tuple[tuple[str, Setting], ...] = field(default=(), compare=True)

    @property
    def kwargs(self) -> dict[str, Setting]:
        """The settings as keyword arguments."""
        return dict(self.settings)

    @property
    def opts(self) -> dict[str, Setting]:
        """The suite's fixed options (the same for every task of a run)."""
        return dict(self.options)

    def number(self, name: str) -> float | None:
        """Option ``name`` as a number (``None`` when it is unset)."""
        value = self.opts.get(name)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"option {name!r} must be a number, got {value!r}")
        return float(value)

    def text(self, name: str) -> str:
        """Option ``name`` as text (empty when it is unset)."""
        value = self.opts.get(name)
        return "" if value is None else str(value)


def parse_seeds(text: str) -> list[int]:
    """``"0-9"``, ``"0,2,5"`` or ``"0-2,7"`` as a sorted list of distinct seeds."""
    seeds: set[int] = set()
    for part in (p.strip() for p in text.split(",")):
        if not part:
            raise ValueError(f"seeds {text!r}: an empty item (expected e.g. 0-9 or 0,2,5)")
        lo, sep, hi = part.partition("-")
        try:
            first, last = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ValueError(f"seeds {text!r}: {part!r} is not N or N-M") from None
        if first < 0 or last < first or last >= 2**63:
            raise ValueError(f"seeds {text!r}: {part!r} must be 0 <= N <= M < 2**63")
        if last - first >= MAX_TASKS:
            raise ValueError(f"seeds {text!r}: more than {MAX_TASKS} seeds")
        seeds.update(range(first, last + 1))
    return sorted(seeds)


def parse_names(text: str, choices: Sequence[str], what: str) -> list[str]:
    """A comma-separated list of names, each one of ``choices``, in the order given."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in choices]
    if not names or unknown:
        raise ValueError(
            f"{what} {text!r}: expected a comma-separated list of {', '.join(choices)}"
        )
    return list(dict.fromkeys(names))


def _setting(name: str, value: object) -> Setting:
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"setting {name!r}: {value} is not finite")
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise ValueError(f"setting {name!r}: {value!r} is not a number, string, boolean or null")


def expand_grid(grid: Grid) -> list[dict[str, Setting]]:
    """The settings combinations of a grid: ``{"a": [1, 2], "b": "x"}`` gives every
    combination of the listed values (a single value is a list of one); a list of
    objects gives exactly those combinations. ``None`` or ``{}`` is one empty
    combination (the defaults)."""
    if grid is None:
        return [{}]
    if isinstance(grid, Mapping):
        names = list(grid)
        values = [v if isinstance(v, list) else [v] for v in grid.values()]
        for name, vs in zip(names, values, strict=True):
            if not vs:
                raise ValueError(f"setting {name!r} lists no values")
        combos = [dict(zip(names, c, strict=True)) for c in itertools.product(*values)]
    elif isinstance(grid, Sequence) and not isinstance(grid, str):
        if not all(isinstance(c, Mapping) for c in grid):
            raise ValueError("a settings grid list must hold objects (one per combination)")
        combos = [dict(c) for c in grid]
    else:
        raise ValueError("a settings grid is a JSON object of lists or a list of objects")
    if len(combos) > MAX_TASKS:
        raise ValueError(f"the settings grid has {len(combos)} combinations (> {MAX_TASKS})")
    return [{str(k): _setting(str(k), v) for k, v in c.items()} for c in combos] or [{}]


def read_grid(path: str | Path) -> list[dict[str, Setting]]:
    """The settings grid of a JSON file (see :func:`expand_grid`)."""
    p = Path(path)
    try:
        grid = json.loads(p.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{p}:{exc.lineno}: not JSON ({exc.msg})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{p}: not a text file") from None
    return expand_grid(grid)


def check_settings(
    combos: Iterable[Mapping[str, Setting]], allowed: Iterable[str], suite: str
) -> None:
    """Refuse, before any run, a setting the suite's methods do not take."""
    known = set(allowed)
    for combo in combos:
        unknown = sorted(set(combo) - known)
        if unknown:
            raise ValueError(
                f"bench {suite}: unknown setting(s) {', '.join(unknown)}; "
                f"this suite takes {', '.join(sorted(known)) or 'none'}"
            )


def make_tasks(
    suite: str,
    datasets: Sequence[str],
    methods: Sequence[str],
    seeds: Sequence[int],
    combos: Sequence[Mapping[str, Setting]],
    *,
    tunable: Iterable[str] = (),
    options: Mapping[str, Setting] | None = None,
) -> list[Task]:
    """Every dataset x seed x method x setting, in that nesting order: the methods
    take turns seed by seed, so that a slow spell of the machine (another process, a
    virtual machine's neighbour) falls on all of them alike rather than on the one
    whose runs it met. Methods not in ``tunable`` (peers) take no settings: they run
    once per dataset and seed."""
    tune = set(tunable)
    opts = tuple(sorted((options or {}).items()))
    tasks: list[Task] = []
    for dataset in datasets:
        for seed in seeds:
            for method in methods:
                for combo in combos if method in tune else [{}]:
                    settings = tuple(sorted(combo.items()))
                    tasks.append(Task(suite, len(tasks), dataset, method, seed, settings, opts))
                    if len(tasks) > MAX_TASKS:
                        raise ValueError(f"bench {suite}: more than {MAX_TASKS} runs")
    return tasks
