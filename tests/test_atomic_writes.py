"""Every file rperc writes appears whole (issue 38): through rperc._atomic, a failed
write leaves the old file and no temporary one, and of several writers of one path the
last wins whole (their lines used to interleave)."""

from __future__ import annotations

import ast
import multiprocessing
import os
from pathlib import Path

import numpy as np
import pytest

from rperc import _atomic
from rperc.datasets import write_tum
from rperc.datasets.polylines import write_polyline


def _write_matplotlib(path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from rperc.plot import save

    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    save(fig, path)


def _write_memory_like_json(path: Path) -> None:
    _atomic.write_text_atomically(path, '{"x": 1}\n')


WRITERS = {
    "tum": ("run.tum", lambda p: write_tum(p, [1.0, 2.0], np.zeros((2, 3)))),
    "polyline csv": ("line.csv", lambda p: write_polyline(p, np.eye(2))),
    "polyline wkt": ("line.wkt", lambda p: write_polyline(p, np.eye(2))),
    "figure png": ("fig.png", _write_matplotlib),
    "text": ("notes.json", _write_memory_like_json),
}


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch, name):
    file_name, write = WRITERS[name]
    path = tmp_path / file_name
    path.write_bytes(b"old contents\n")

    def refuse(src: object, dst: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_atomic.os, "replace", refuse)
    with pytest.raises(OSError, match="No space"):
        write(path)
    assert path.read_bytes() == b"old contents\n"
    assert os.listdir(tmp_path) == [file_name]
    monkeypatch.undo()
    write(path)
    assert path.read_bytes() != b"old contents\n" and os.listdir(tmp_path) == [file_name]


def _write_many(args: tuple[str, int]) -> None:
    path, k = args
    # Large enough that a plain write takes many system calls (and interleaves).
    body = "".join(f"{k} {j}\n" for j in range(20_000))
    for _ in range(5):
        _atomic.write_text_atomically(path, body)


def test_concurrent_writers_of_one_path_leave_one_whole_file(tmp_path):
    path = tmp_path / "shared.txt"
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(4) as pool:
        pool.map(_write_many, [(str(path), k) for k in range(4)])
    lines = path.read_text().splitlines()
    writers = {line.split()[0] for line in lines}
    assert len(writers) == 1 and len(lines) == 20_000
    assert [int(line.split()[1]) for line in lines] == list(range(20_000))
    assert os.listdir(tmp_path) == ["shared.txt"]


def test_the_written_file_keeps_its_suffix_while_written(tmp_path):
    # Writers such as imageio pick the format by the suffix of the path they get.
    seen: list[str] = []

    def write(tmp: Path) -> None:
        seen.append(tmp.suffix)
        tmp.write_bytes(b"x")

    _atomic.write_atomically(tmp_path / "clip.gif", write)
    assert seen == [".gif"] and (tmp_path / "clip.gif").read_bytes() == b"x"


# Calls that write a file, and which argument names it (None: the object the method
# is called on, as in ``path.write_text(...)``).
_FILE_WRITERS = {
    "write_text": None, "write_bytes": None, "savetxt": 0, "savefig": 0, "imwrite": 0,
    "save": 0, "to_csv": 0, "write_table": 1,
}  # fmt: skip


def _written_path(call: ast.Call) -> ast.expr | None:
    """The expression naming the file ``call`` writes, or None if it writes none."""
    f = call.func
    if isinstance(f, ast.Attribute) and f.attr in _FILE_WRITERS:
        at = _FILE_WRITERS[f.attr]
        return f.value if at is None else (call.args[at] if len(call.args) > at else None)
    is_open = (isinstance(f, ast.Name) and f.id == "open") or (
        isinstance(f, ast.Attribute) and f.attr == "open"
    )
    if not is_open:
        return None
    if isinstance(f, ast.Name):
        target, modes = call.args[0], call.args[1:]
    else:
        target, modes = f.value, list(call.args)
    mode = [k.value for k in call.keywords if k.arg == "mode"] or modes[:1]
    if mode and isinstance(mode[0], ast.Constant) and set(str(mode[0].value)) & set("wax"):
        return target
    return None


def test_every_file_rperc_or_a_benchmark_writes_goes_through_the_atomic_writer():
    # An independent reading of the sources: every file write names the temporary
    # path that rperc._atomic.write_atomically hands its callback (``tmp``), so no
    # writer (rerun's .rrd, a benchmark's JSON or CSV) puts a half file at the path.
    root = Path(__file__).resolve().parent.parent
    sources = [*(root / "python" / "rperc").rglob("*.py"), *(root / "benchmarks").glob("*.py")]
    direct = []
    for src in sources:
        for node in ast.walk(ast.parse(src.read_text(encoding="utf-8"))):
            target = _written_path(node) if isinstance(node, ast.Call) else None
            names = {n.id for n in ast.walk(target) if isinstance(n, ast.Name)} if target else set()
            if target is not None and "tmp" not in names and src.name != "_atomic.py":
                direct.append(f"{src.relative_to(root)}:{node.lineno}: {ast.unparse(node)[:60]}")
    assert direct == []


def test_a_failed_rerun_recording_keeps_the_old_file(tmp_path, monkeypatch):
    pytest.importorskip("rerun")
    from rperc.slam import PlanarSlam
    from rperc.slam.planar import sim_slam_config, simulate
    from rperc.slam.rerun_log import log_run

    world = {"steps": 50}
    result = PlanarSlam(sim_slam_config(world)).run(simulate(world, seed=1).recording)
    path = tmp_path / "run.rrd"
    path.write_bytes(b"old recording")

    def refuse(src: object, dst: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_atomic.os, "replace", refuse)
    with pytest.raises(OSError, match="No space"):
        log_run(result, path)
    assert path.read_bytes() == b"old recording" and os.listdir(tmp_path) == ["run.rrd"]
    monkeypatch.undo()
    log_run(result, path)
    assert path.read_bytes()[:4] == b"RRF2" and os.listdir(tmp_path) == ["run.rrd"]
