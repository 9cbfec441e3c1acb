"""The error every dataset reader raises for a malformed file."""

from __future__ import annotations

from pathlib import Path

from rperc._args import QUOTE_LIMIT
from rperc._rperc import RpercError

#: The longest reason a message carries: a few quotes of :data:`QUOTE_LIMIT`.
REASON_LIMIT = 4 * QUOTE_LIMIT


class DatasetFormatError(RpercError, ValueError):
    """A malformed record: carries the file and 1-based line number. The reason is
    cut to :data:`REASON_LIMIT` characters whatever it quotes (a library's own message
    may embed the whole input line)."""

    def __init__(self, path: str | Path, line: int, reason: str) -> None:
        self.path = str(path)
        self.line = line
        if len(reason) > REASON_LIMIT:
            reason = reason[:REASON_LIMIT] + f"... ({len(reason) - REASON_LIMIT} more characters)"
        self.reason = reason
        super().__init__(f"{self.path}:{line}: {reason}")
