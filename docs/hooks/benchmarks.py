"""mkdocs hook: the benchmarks page's tables come from the JSON summaries that
``rperc bench ... --json`` wrote (``make bench-json``), never from numbers typed by hand.

A page line ``<!-- bench: NAME -->`` becomes the table of ``$RPERC_BENCH_DIR/NAME.json``
(default ``out/bench``), with the command that wrote it and when. A summary that is
absent becomes a note saying how to make it, so a docs build without the data still
passes ``--strict`` and never shows stale numbers.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import re
from pathlib import Path
from typing import Any

MARKER = re.compile(r"^<!-- bench: ([\w-]+) -->$", re.M)
# Columns that describe a group rather than measure it.
NOT_METRICS = {"dataset", "method", "library", "runs", "errors"}


def bench_dir() -> Path:
    return Path(os.environ.get("RPERC_BENCH_DIR", "out/bench"))


def _number(v: float) -> str:
    return f"{v:.0f}" if 1000 <= abs(v) < 1e6 else f"{v:.3g}"


def _cell(stat: Any) -> str:
    if not isinstance(stat, dict) or stat.get("mean") is None:
        return "-"
    if stat.get("sd") is None:
        return _number(stat["mean"])
    return f"{_number(stat['mean'])} ± {_number(stat['sd'])}"


def _command(argv: list[str]) -> str:
    # Absolute data paths differ per machine: show them under $RPERC_DATA.
    from rperc.datasets import data_dir

    root = data_dir()
    data = str(root) if root is not None else ""
    words = [w.replace(data, "$RPERC_DATA") if data else w for w in argv]
    return "rperc " + " ".join(words)


def render(summary: dict[str, Any], written: dt.datetime) -> str:
    """One markdown table: a row per group, ``mean ± sd`` over seeds per metric."""
    groups = summary["groups"]
    metrics = [
        k
        for k in dict.fromkeys(k for g in groups for k in g)
        if k not in NOT_METRICS and any(isinstance(g.get(k), dict) for g in groups)
    ]
    head = ["dataset", "method", "library", "runs", *metrics]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for g in groups:
        runs = f"{g['runs']}" + (f" ({g['errors']} failed)" if g.get("errors") else "")
        cells = [str(g["dataset"]), str(g["method"]), str(g["library"]), runs]
        lines.append("| " + " | ".join(cells + [_cell(g.get(m)) for m in metrics]) + " |")
    stamp = written.strftime("%Y-%m-%d %H:%M UTC")
    about = (
        f"`{_command(summary['argv'])}`: {summary['runs']} runs "
        f"({summary['failed']} failed), {summary['wall_seconds']:.1f} s, "
        f"scheduler {summary['scheduler']}, written {stamp}."
    )
    return about + "\n\n" + "\n".join(lines)


def table(name: str) -> str:
    path = bench_dir() / f"{name}.json"
    if not path.is_file():
        return (
            f'!!! note "Not measured in this build"\n'
            f"    `{path}` is absent: `make bench-json` writes it (it needs the shared data)."
        )
    written = dt.datetime.fromtimestamp(path.stat().st_mtime, tz=dt.timezone.utc)
    return render(json.loads(path.read_text()), written)


# -- Demo figures ---------------------------------------------------------------------
# ``<!-- figure: NAME | caption -->`` shows ``$RPERC_DEMO_DIR/NAME`` (default
# ``out/demo``, where ``make demo`` writes), copied into the site at build time: the
# figures are made by the code, never committed.

FIGURE = re.compile(r"^<!-- figure: ([\w.-]+) \| (.+?) -->$", re.M)


def demo_dir() -> Path:
    return Path(os.environ.get("RPERC_DEMO_DIR", "out/demo"))


def on_files(files: Any, config: Any, **_: Any) -> Any:
    from mkdocs.structure.files import File

    for path in sorted(demo_dir().glob("*")):
        if path.suffix in (".png", ".gif"):
            files.append(File.generated(config, f"figures/{path.name}", abs_src_path=str(path)))
    return files


def figure(name: str, caption: str, page_src: str) -> str:
    if not (demo_dir() / name).is_file():
        return f'!!! note "{caption}"\n    `{name}` is not in `{demo_dir()}`: `make demo` draws it.'
    up = "../" * page_src.count("/")
    return f"![{caption}]({up}figures/{name})\n\n*{caption}*"


# ``<!-- demo: NAME -->`` quotes the line ``rperc demo NAME`` printed in the last
# ``make demo`` (its ``demo.json``), so the page's numbers are the run's own.
DEMO_LINE = re.compile(r"^<!-- demo: ([\w-]+) -->$", re.M)


def demo_line(name: str) -> str:
    path = demo_dir() / "demo.json"
    lines = json.loads(path.read_text()).get("summaries", {}) if path.is_file() else {}
    if name not in lines:
        return f"*`rperc demo {name}` prints its measured error here after `make demo`.*"
    return f"`rperc demo {name}` printed:\n\n> {lines[name]}"


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    markdown = MARKER.sub(lambda m: table(m.group(1)), markdown)
    markdown = DEMO_LINE.sub(lambda m: demo_line(m.group(1)), markdown)
    src = page.file.src_uri
    return FIGURE.sub(lambda m: figure(m.group(1), m.group(2), src), markdown)
