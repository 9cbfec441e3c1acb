"""The error every dataset reader raises for a malformed file."""

from __future__ import annotations

from pathlib import Path

from rperc._rperc import RpercError


class DatasetFormatError(RpercError, ValueError):
    """A malformed record: carries the file and 1-based line number."""

    def __init__(self, path: str | Path, line: int, reason: str) -> None:
        self.path = str(path)
        self.line = line
        self.reason = reason
        super().__init__(f"{self.path}:{line}: {reason}")
