"""Every Python snippet of the README runs as written (from the repository root, where
its ``../shared/data`` paths point), so the quick start cannot rot."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

import pytest

from rperc.datasets import TimestampRepairWarning

ROOT = Path(__file__).resolve().parents[1]
SNIPPETS = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)


def test_the_readme_has_snippets():
    assert len(SNIPPETS) >= 4


@pytest.mark.parametrize("code", SNIPPETS, ids=[f"snippet{k}" for k in range(len(SNIPPETS))])
def test_readme_snippet_runs(code: str, data: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    if "../shared/data" in code and not (ROOT.parent / "shared" / "data").is_dir():
        pytest.skip("the README's data paths point at ../shared/data, absent here")
    monkeypatch.chdir(ROOT)
    # load_carmen repairs intel.log's four scan times that step back, and warns.
    repairs = 'load_carmen("../shared/data/carmen/intel.log")' in code
    warned = (
        pytest.warns(TimestampRepairWarning, match="intel.log: 4 of 910 scan times")
        if repairs
        else contextlib.nullcontext()
    )
    with contextlib.redirect_stdout(io.StringIO()), warned:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    assert os.getcwd() == str(ROOT)
