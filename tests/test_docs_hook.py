"""The docs build hook renders the benchmarks page from ``rperc bench --json``
summaries and shows the demo figures, or says how to make them when they are absent."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import ModuleType, SimpleNamespace

import pytest

from rperc.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def hook() -> ModuleType:
    spec = importlib.util.spec_from_file_location("docs_hook", ROOT / "docs/hooks/benchmarks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _page(src: str) -> SimpleNamespace:
    return SimpleNamespace(file=SimpleNamespace(src_uri=src))


def test_a_summary_written_by_rperc_bench_becomes_its_table(hook, tmp_path, monkeypatch):
    # A real summary, from the command, not a hand-made dict: the hook must read what
    # rperc bench writes.
    summary = tmp_path / "pattern.json"
    argv = ["bench", "pattern", "--steps", "1", "--seeds", "0-1", "--trackers", "rperc"]
    assert main([*argv, "--json", str(summary)]) == 0
    monkeypatch.setenv("RPERC_BENCH_DIR", str(tmp_path))
    page = hook.on_page_markdown("# B\n\n<!-- bench: pattern -->\n", page=_page("b.md"))
    groups = json.loads(summary.read_text())["groups"]
    rows = [line for line in page.splitlines() if line.startswith("| ") and "rperc" in line]
    assert len(rows) == len(groups) >= 1
    assert "rperc bench pattern --steps 1 --seeds 0-1" in page
    # Each cell is the summary's mean ± sd, as rounded by the hook, in column order.
    header = next(line for line in page.splitlines() if line.startswith("| dataset"))
    column = header.strip("| ").split(" | ").index("position_rms_px")
    stat = groups[0]["position_rms_px"]
    cell = rows[0].strip("| ").split(" | ")[column]
    assert cell == f"{stat['mean']:.3g} ± {stat['sd']:.3g}"


def test_an_absent_summary_is_a_note_not_a_table(hook, tmp_path, monkeypatch):
    monkeypatch.setenv("RPERC_BENCH_DIR", str(tmp_path))
    page = hook.on_page_markdown("<!-- bench: laser -->", page=_page("b.md"))
    assert page.startswith("!!! note")
    assert "make bench-json" in page and "|" not in page


def test_figures_link_to_the_demo_output_or_ask_for_make_demo(hook, tmp_path, monkeypatch):
    monkeypatch.setenv("RPERC_DEMO_DIR", str(tmp_path))
    (tmp_path / "lines.png").write_bytes(b"png")
    text = "<!-- figure: lines.png | Lines -->\n<!-- figure: walls.png | Walls -->"
    page = hook.on_page_markdown(text, page=_page("guide/p.md"))
    assert "![Lines](../figures/lines.png)" in page
    assert "`walls.png` is not in" in page and "make demo" in page


def test_a_demo_line_is_quoted_from_the_demo_json_or_asked_for(hook, tmp_path, monkeypatch):
    monkeypatch.setenv("RPERC_DEMO_DIR", str(tmp_path))
    text = "<!-- demo: lines -->"
    assert "after `make demo`" in hook.on_page_markdown(text, page=_page("p.md"))
    # The shape `rperc demo all --json` writes (tests/test_demo.py checks it there).
    (tmp_path / "demo.json").write_text(json.dumps({"summaries": {"lines": "lines: 58 kept"}}))
    assert "> lines: 58 kept" in hook.on_page_markdown(text, page=_page("p.md"))
