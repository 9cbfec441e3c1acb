"""One data default: ``rperc.datasets.data_dir()`` is ``$RPERC_DATA``, else
``../shared/data`` beside the repository, and nothing else reads the variable, so a
test, a demo or a benchmark cannot find the data where another does not."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rperc.datasets import data_dir, data_path

ROOT = Path(__file__).resolve().parents[1]


def test_the_environment_variable_wins(tmp_path, monkeypatch):
    monkeypatch.setenv("RPERC_DATA", str(tmp_path))
    assert data_dir() == tmp_path


def test_without_it_the_folder_beside_the_repository(monkeypatch, tmp_path):
    monkeypatch.delenv("RPERC_DATA", raising=False)
    monkeypatch.chdir(tmp_path)  # not found through the working directory
    beside = ROOT.parent / "shared" / "data"
    if beside.is_dir():
        assert data_dir() == beside
    else:
        assert data_dir() is None
        with pytest.raises(FileNotFoundError, match="RPERC_DATA"):
            data_path("carmen")


def test_nothing_else_reads_the_variable():
    reads = re.compile(r"environ(\.get)?\(?\[?\s*['\"]RPERC_DATA|getenv\(\s*['\"]RPERC_DATA")
    readers = [
        str(p.relative_to(ROOT))
        for folder in ("python", "tests", "benchmarks", "docs")
        for p in (ROOT / folder).rglob("*.py")
        if reads.search(p.read_text())
    ]
    assert readers == ["python/rperc/datasets/_paths.py"]
