"""Whitespace-separated numeric tables (``.dat`` files, optionally gzipped) with exact
line numbers for every record, shared by the MR.CLAM and Victoria Park readers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rperc._args import excerpt
from rperc.datasets._text import read_lines
from rperc.datasets.errors import DatasetFormatError


@dataclass(frozen=True)
class Table:
    """The records of one file: ``values`` (N, columns) float64 and the 1-based
    ``line`` of each record in the file."""

    path: Path
    values: np.ndarray
    line: np.ndarray
    nan_rows: int  # records holding at least one NaN (kept, not dropped)
    time_backwards: int  # records whose time is earlier than the previous record's

    def column(self, k: int) -> np.ndarray:
        """Column ``k`` as a contiguous float64 array."""
        return np.ascontiguousarray(self.values[:, k])


def _open_lines(path: Path) -> list[str]:
    """The file's lines: gzip, a BOM and undecodable bytes handled by the shared reader."""
    return read_lines(path)


def _records(path: Path, lines: list[str], columns: int) -> tuple[list[str], list[int]]:
    """The tokens of every data line (comments ``#`` and blank lines skipped), after
    checking that each line has exactly ``columns`` fields."""
    tokens: list[str] = []
    numbers: list[int] = []
    for number, text in enumerate(lines, start=1):
        fields = text.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != columns:
            got = f"got {len(fields)}: {excerpt(text.strip())}"
            raise DatasetFormatError(path, number, f"expected {columns} columns, {got}")
        tokens.extend(fields)
        numbers.append(number)
    if not numbers:
        raise DatasetFormatError(path, len(lines), "no records (empty file)")
    return tokens, numbers


def _to_floats(path: Path, tokens: list[str], numbers: list[int], columns: int) -> np.ndarray:
    """numpy converts the whole table at once; on failure the token-by-token scan names
    the line."""
    try:
        return np.array(tokens, dtype=np.float64).reshape(-1, columns)
    except ValueError:
        pass
    for k, token in enumerate(tokens):
        try:
            float(token)
        except ValueError:
            line = numbers[k // columns]
            raise DatasetFormatError(
                path, line, f"column {k % columns + 1} is not a number: {excerpt(token)}"
            ) from None
    raise AssertionError("numpy refused a table whose every token parses")  # pragma: no cover


def _check_time(path: Path, time: np.ndarray, line: np.ndarray, allow_backwards: bool) -> int:
    """Refuses a NaN time; counts (or refuses) records whose time goes backwards."""
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise DatasetFormatError(path, int(line[bad[0]]), f"time is {time[bad[0]]}")
    back = np.flatnonzero(np.diff(time) < 0) + 1
    if back.size and not allow_backwards:
        k = int(back[0])
        raise DatasetFormatError(
            path,
            int(line[k]),
            f"time goes backwards: {float(time[k])!r} after {float(time[k - 1])!r} "
            f"(line {int(line[k - 1])})",
        )
    return int(back.size)


def read_table(path: str | Path, columns: int, *, allow_time_backwards: bool = False) -> Table:
    """Reads a table whose first column is a time in seconds.

    Raises :class:`DatasetFormatError` (file and line) for a line with the wrong number
    of fields, a field that is not a number, a NaN time, an empty file, and (unless
    ``allow_time_backwards``, which counts them instead) a time earlier than the
    previous record's. NaN values elsewhere are kept and counted in ``nan_rows``.
    """
    path = Path(path)
    tokens, numbers = _records(path, _open_lines(path), columns)
    values = _to_floats(path, tokens, numbers, columns)
    line = np.asarray(numbers, dtype=np.int64)
    backwards = _check_time(path, values[:, 0], line, allow_time_backwards)
    nan_rows = int(np.isnan(values).any(axis=1).sum())
    return Table(path, values, line, nan_rows, backwards)


def read_id_table(path: str | Path, columns: int) -> Table:
    """A table whose first column is an integer id (no time order), e.g.
    ``Barcodes.dat``; ids must be whole numbers and unique."""
    path = Path(path)
    tokens, numbers = _records(path, _open_lines(path), columns)
    values = _to_floats(path, tokens, numbers, columns)
    line = np.asarray(numbers, dtype=np.int64)
    seen: dict[float, int] = {}
    for k, ident in enumerate(values[:, 0]):
        if not (math.isfinite(ident) and ident == round(ident)):
            raise DatasetFormatError(path, int(line[k]), f"id {ident!r} is not an integer")
        if ident in seen:
            raise DatasetFormatError(
                path, int(line[k]), f"id {int(ident)} repeats line {seen[ident]}"
            )
        seen[ident] = int(line[k])
    nan_rows = int(np.isnan(values).any(axis=1).sum())
    return Table(path, values, line, nan_rows, 0)


def data_file(directory: Path, name: str) -> Path:
    """``directory/name``, or ``directory/name.gz`` when only the gzipped file exists."""
    plain = directory / name
    zipped = directory / (name + ".gz")
    if not plain.exists() and zipped.exists():
        return zipped
    if not plain.exists():
        raise FileNotFoundError(f"{plain} (or {zipped.name}) does not exist")
    return plain
