"""Every loader under malformed files: small valid files written here come back
record for record through a BOM, gzip, CRLF, comments and stray whitespace; a
truncated line, a wrong column count, a non-number or an undecodable byte is a
DatasetFormatError naming the file and the exact line; nothing is dropped silently."""

from __future__ import annotations

import gzip
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rperc.datasets import DatasetFormatError

from fuzz.files import GARBAGE, Fixture, Mutation, apply
from fuzz.harness import case, examples, outcome
from fuzz.loaders import FIXTURES

LOADERS = st.sampled_from(sorted(FIXTURES))


def _run(fx: Fixture, raw: dict[str, bytes], **kwargs: Any) -> tuple[bool, Any]:
    folder = Path(tempfile.mkdtemp(prefix="rperc-fuzz-"))
    try:
        fx.write(folder, raw)
        return outcome(fx.load, folder, **kwargs)
    finally:
        shutil.rmtree(folder)


def _same_records(fx: Fixture, got: Any) -> None:
    have = fx.extract(got)
    for key, expected in fx.records.items():
        np.testing.assert_allclose(
            have[key], expected, rtol=1e-15, atol=1e-12, err_msg=f"{key} differs"
        )


@st.composite
def mutations(draw: st.DrawFn, fx: Fixture) -> Mutation:
    kind = draw(st.sampled_from(fx.benign + fx.breaking))
    candidates = sorted(name for name, lines in fx.data_lines.items() if lines)
    name = draw(st.sampled_from(candidates))
    index = draw(st.sampled_from(fx.data_lines[name]))
    return Mutation(kind, name, index, draw(GARBAGE))


@examples(300)
@given(LOADERS, st.data())
def prop_loaders_keep_every_record_or_name_the_line(loader, data):
    fx = data.draw(FIXTURES[loader])
    m = data.draw(mutations(fx))
    raw, line = apply(fx, m)
    case(f"load {loader}", mutation=m, file=raw[m.file])
    ok, got = _run(fx, raw)
    if m.kind in fx.benign:
        assert ok, f"{m.kind}: {got}"
        _same_records(fx, got)
        return
    assert not ok, f"{m.kind} accepted: {got}"
    assert isinstance(got, DatasetFormatError), f"{type(got).__name__}: {got}"
    assert Path(got.path).name == m.file and got.line == line, (str(got), line)


@examples(150)
@given(st.sampled_from(["mrclam", "victoria_park", "tum"]), st.data())
def prop_tables_refuse_or_count_what_is_wrong(loader, data):
    """An empty file, a truncated gzip stream, a NaN time or a time going backwards is
    an error naming the file (and line); NaN values elsewhere are kept, not dropped."""
    fx = data.draw(FIXTURES[loader])
    name = data.draw(st.sampled_from(sorted(fx.timed)))
    lines = fx.files[name]
    rows = fx.data_lines[name]
    kind = data.draw(st.sampled_from(["empty", "gzip_cut", "nan_time", "backwards", "nan"]))
    if kind == "backwards" and len(rows) < 2:
        kind = "nan_time"
    k = data.draw(st.sampled_from(rows[1:] if kind == "backwards" else rows))
    text = _corrupt_table(lines, rows, k, kind)
    raw = {name: text if isinstance(text, bytes) else text.encode()}
    case(f"load {loader}", kind=kind, file=name, text=raw[name])
    ok, got = _run(fx, raw)
    if kind == "nan" and loader != "tum":
        assert ok, got
        assert got.nan_rows >= 1, got
        return
    assert not ok and isinstance(got, DatasetFormatError), f"{kind}: {got!r}"
    assert Path(got.path).name == name, got
    if kind in ("nan_time", "backwards", "nan"):
        assert got.line == k + 1, (str(got), k + 1)
    if kind == "backwards" and loader != "tum":
        ok, got = _run(fx, raw, allow_time_backwards=True)
        assert ok and got.time_backwards == 1, got


def _corrupt_table(lines: list[str], rows: list[int], k: int, kind: str) -> str | bytes:
    out = list(lines)
    fields = out[k].split()
    if kind == "empty":
        return b""
    if kind == "gzip_cut":
        return gzip.compress(("\n".join(out) + "\n").encode())[:-6]
    if kind == "nan_time":
        fields[0] = "nan"
    elif kind == "backwards":
        prev = float(out[rows[rows.index(k) - 1]].split()[0])
        fields[0] = repr(prev - 1.0)
    elif kind == "nan":
        fields[-1] = "nan"  # column 1 of MR.CLAM measurements is a barcode, never NaN
    out[k] = " ".join(fields)
    return "\n".join(out) + "\n"
