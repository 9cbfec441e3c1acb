"""Small valid data files written by the tests, and the ways a file goes bad.

A :class:`Fixture` is a folder of files (each a list of lines) and, per file, the
records a loader must return (exact float64 values, written with ``repr`` so they
read back bit for bit). :func:`mutate` turns one line of one file bad, or changes the
file's encoding in a way a reader must see through."""

from __future__ import annotations

import gzip
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

# Changes every reader must see through: the same records come back.
BENIGN = ["none", "bom", "gzip", "crlf", "comment", "blank_end", "spaces"]
# Changes that must raise DatasetFormatError naming the file and the mutated line.
BREAKING = ["truncate", "extra_column", "garbage", "undecodable"]
# Not a number anywhere: Python's float() takes "nan", "inf", "1_0" and "٣" (Arabic 3).
GARBAGE = st.sampled_from(["abc", "1.2.3", "--1", "0x10", "1e", "1,5", "NULL", "1e5x", "½"])
# Separators str.splitlines() breaks lines on but an editor and the Rust parser do not.
ODD_SEPARATORS = "\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"


@dataclass
class Fixture:
    files: dict[str, list[str]]  # name -> lines
    records: dict[str, np.ndarray]  # what the loader must return, by kind of record
    data_lines: dict[str, list[int]]  # name -> 0-based indices of the data lines
    load: Callable[[Path], Any]
    extract: Callable[[Any], dict[str, np.ndarray]]
    benign: tuple[str, ...] = tuple(BENIGN)
    breaking: tuple[str, ...] = tuple(BREAKING)
    timed: tuple[str, ...] = field(default=())  # files whose column 0 is a time

    def write(self, folder: Path, raw: dict[str, bytes]) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        for name, lines in self.files.items():
            data = raw.get(name)
            if data is None:
                data = ("\n".join(lines) + "\n").encode()
            (folder / name).write_bytes(data)


def number_rows(n: int, cols: int, time: bool, ids: bool = False) -> st.SearchStrategy[Any]:
    """(n, cols) finite values; column 0 increasing times or unique integer ids."""
    body = hnp.arrays(np.float64, (n, cols), elements=st.floats(-1e6, 1e6, allow_subnormal=False))

    def shape(a: np.ndarray) -> np.ndarray:
        if time:
            a[:, 0] = 1e9 + np.cumsum(np.abs(a[:, 0]) + 0.5)
        if ids:
            a[:, 0] = np.arange(1, n + 1) + 5
        return a

    return body.map(shape)


def line_of(row: np.ndarray, sep: str = " ") -> str:
    return sep.join(repr(float(v)) for v in row)


@dataclass(frozen=True)
class Mutation:
    kind: str
    file: str
    index: int  # 0-based line index the mutation hits (breaking kinds)
    token: str = "abc"


def apply(fx: Fixture, m: Mutation) -> tuple[dict[str, bytes], int]:
    """The mutated bytes of ``m.file`` and the 1-based line a reader must blame."""
    lines = list(fx.files[m.file])
    line = lines[m.index] if lines else ""
    fields = line.split()
    if m.kind == "truncate":
        lines[m.index] = " ".join(fields[:-1])
    elif m.kind == "extra_column":
        lines[m.index] = line + " 1.5"
    elif m.kind == "garbage":
        fields[len(fields) // 2] = m.token
        lines[m.index] = " ".join(fields)
    elif m.kind == "comment":
        lines.insert(m.index, f"# a note{ODD_SEPARATORS}with odd separators")
    elif m.kind == "spaces":
        lines[m.index] = " \t " + line.replace(" ", " \t  ") + " \t"
    text = "\n".join(lines) + "\n"
    if m.kind == "blank_end":
        text += "\n  \n\n"
    if m.kind == "crlf":
        text = text.replace("\n", "\r\n")
    data = text.encode()
    if m.kind == "undecodable":
        start = sum(len(s) + 1 for s in lines[: m.index])
        data = data[: start + 1] + b"\xff\xfe" + data[start + 1 :]
    if m.kind == "bom":
        data = b"\xef\xbb\xbf" + data
    if m.kind == "gzip":
        data = gzip.compress(data)
    return {m.file: data}, m.index + 1
