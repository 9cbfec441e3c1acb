"""Every ``python`` and ``sh`` code block of the README and of the documentation site
runs as written, so neither can rot.

The blocks of one page run in order in one fresh folder, as a reader following the
page would: the Python blocks share one namespace, the shell blocks run in bash with
``-e`` and the ``rperc`` command of this environment. The folder sits beside a
``shared/data`` link to :func:`rperc.datasets.data_dir`, so ``../shared/data/...``
reads as it does from the repository root. Without the data folder, the blocks that
read it (and those that say they continue one) are left out, the others still run,
and the page is reported skipped, saying how many blocks were left out. Blocks fenced
as ``sh ci`` are the set-up commands that ``.ci/run`` itself runs (``make demo``,
``make check``).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from rperc.datasets import data_dir

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```", re.S | re.M)
# What reads the shared data: a path beside the repository, or the data folder's API.
NEEDS_DATA = ("../shared/data", "data_path(", "data_dir(")
RUNS = {"python", "sh"}


def blocks(page: Path) -> list[tuple[str, str]]:
    """The page's fenced blocks as ``(info, code)``, in order."""
    return [(m.group(1).strip(), m.group(2)) for m in FENCE.finditer(page.read_text())]


def runnable(page: Path) -> list[tuple[str, str]]:
    return [(info, code) for info, code in blocks(page) if info in RUNS]


def test_every_block_is_run_or_says_why_not() -> None:
    # A block in another language would escape this test: only text, the CI's own
    # set-up commands and static files (toml, json, yaml) may be shown unrun.
    allowed = RUNS | {"sh ci", "text", "toml", "json", "yaml"}
    for page in PAGES:
        for info, _ in blocks(page):
            assert info in allowed, f"{page.name}: a ```{info} block is neither run nor text"


def test_the_pages_have_examples() -> None:
    assert sum(len(runnable(p)) for p in PAGES) >= 20


def _run_sh(code: str, cwd: Path) -> None:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", code],
        cwd=cwd,
        env={**env, "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, f"{code}\nexit {done.returncode}\n{done.stderr[-2000:]}"


def _run_python(code: str, namespace: dict[str, object], name: str) -> None:
    # A page's example may warn (a log's repaired timestamps): that is the reader's
    # output, not a failure; an exception is.
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        exec(compile(code, name, "exec"), namespace)


def _page_id(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize(
    "page", [p for p in PAGES if runnable(p)], ids=[_page_id(p) for p in PAGES if runnable(p)]
)
def test_page_examples_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    todo = runnable(page)
    root = data_dir()
    have_data = root is not None and root.is_dir()
    if have_data:
        assert root is not None
        (tmp_path / "shared").mkdir()
        (tmp_path / "shared" / "data").symlink_to(root.resolve())
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict[str, object] = {"__name__": "docs"}
    skipped = 0
    previous_skipped = False
    for k, (info, code) in enumerate(todo):
        # Without the data the other blocks still run, so each must stand alone of the
        # blocks that read it, unless it opens by saying it continues the one above.
        continues = code.lstrip().lower().startswith("# continues")
        if not have_data and (
            any(marker in code for marker in NEEDS_DATA) or (continues and previous_skipped)
        ):
            skipped += 1
            previous_skipped = True
            continue
        previous_skipped = False
        if info == "sh":
            _run_sh(code, work)
        else:
            _run_python(code, namespace, f"{_page_id(page)}, block {k}")
    if skipped:
        pytest.skip(f"{skipped} of {len(todo)} blocks read the shared data: set RPERC_DATA")
