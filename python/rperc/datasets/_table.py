"""Whitespace-separated numeric tables (``.dat`` files, optionally gzipped) with exact
line numbers for every record, shared by the MR.CLAM and Victoria Park readers."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
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


# The largest id a float64 column holds exactly: past it, 2^53 + 1 reads as 2^53 and
# two ids of a file can become one.
MAX_ID = 2**53


def _check_ids(path: Path, tokens: list[str], values: np.ndarray, line: np.ndarray,
               col: int, what: str) -> None:  # fmt: skip
    """Column ``col`` holds ids (``what``: "barcode"...): whole numbers in
    ``0..MAX_ID`` that the file states exactly (its text equals the float read:
    ``9007199254740993`` does not)."""
    columns = values.shape[1]
    for k, ident in enumerate(values[:, col]):
        token = tokens[k * columns + col]
        whole = math.isfinite(ident) and ident == round(ident) and 0 <= ident <= MAX_ID
        if not (whole and _states_exactly(token, ident)):
            raise DatasetFormatError(
                path, int(line[k]), f"{what} {excerpt(token)} is not a whole number in 0..2**53"
            )


def _states_exactly(token: str, value: float) -> bool:
    """Whether the number written ``token`` is exactly the float ``value`` read from
    it (float() accepts the underscores and digits Decimal does once the underscores
    are gone)."""
    try:
        return Decimal(token.replace("_", "")) == Decimal(value)
    except InvalidOperation:  # pragma: no cover - float() read it, so Decimal does
        return False


def _check_infinite(path: Path, values: np.ndarray, line: np.ndarray) -> None:
    """No value of these tables is meaningful at infinity (NaN is kept and counted)."""
    bad = np.argwhere(np.isinf(values))
    if bad.size:
        k, col = (int(i) for i in bad[0])
        raise DatasetFormatError(
            path, int(line[k]), f"column {col + 1} is infinite ({values[k, col]!r})"
        )


def non_negative(table: Table, names: dict[int, str]) -> None:
    """Refuses a negative value in the columns ``names`` maps to what they hold (a
    range, a diameter, a standard deviation); NaN passes, as everywhere."""
    for col, name in names.items():
        bad = np.flatnonzero(table.values[:, col] < 0)
        if bad.size:
            k = int(bad[0])
            value = float(table.values[k, col])
            raise DatasetFormatError(
                table.path, int(table.line[k]), f"{name} must be >= 0, got {value!r}"
            )


def _read_values(
    path: Path, columns: int, id_columns: Mapping[int, str]
) -> tuple[np.ndarray, np.ndarray]:
    """Every table's reading: its values and each row's line number, checked for the
    number of fields, numbers, no infinity and whole-number ids in ``id_columns``."""
    tokens, numbers = _records(path, _open_lines(path), columns)
    values = _to_floats(path, tokens, numbers, columns)
    line = np.asarray(numbers, dtype=np.int64)
    _check_infinite(path, values, line)
    for col, what in id_columns.items():
        _check_ids(path, tokens, values, line, col, what)
    return values, line


def read_table(
    path: str | Path,
    columns: int,
    *,
    allow_time_backwards: bool = False,
    id_columns: dict[int, str] | None = None,
) -> Table:
    """Reads a table whose first column is a time in seconds.

    Raises :class:`DatasetFormatError` (file and line) for a line with the wrong number
    of fields, a field that is not a number, an infinite value, a NaN time, an empty
    file, an ``id_columns`` value (column: what it holds) that is not a whole number
    in ``0..2**53``, and
    (unless ``allow_time_backwards``, which counts them instead) a time earlier than the
    previous record's. NaN values elsewhere are kept and counted in ``nan_rows``.
    """
    path = Path(path)
    values, line = _read_values(path, columns, id_columns or {})
    backwards = _check_time(path, values[:, 0], line, allow_time_backwards)
    nan_rows = int(np.isnan(values).any(axis=1).sum())
    return Table(path, values, line, nan_rows, backwards)


def read_id_table(
    path: str | Path, columns: int, *, id_columns: dict[int, str] | None = None
) -> Table:
    """A table whose first column is an integer id (no time order), e.g.
    ``Barcodes.dat``; ids (and the other ``id_columns``) must be whole numbers in
    ``0..2**53``, and the first column's unique. Infinite values are refused."""
    path = Path(path)
    values, line = _read_values(path, columns, {0: "id", **(id_columns or {})})
    seen: dict[float, int] = {}
    for k, ident in enumerate(values[:, 0]):
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
