"""Progress of long loops: a tqdm bar on a terminal, log lines everywhere else.

A bar is the right thing on an interactive terminal; in CI logs, pipes and notebooks
redirected to files it is noise (one carriage-return update per item). There the
loop reports through the ``rperc`` logger at INFO level instead, at most once every
``interval`` seconds, plus one final line with the count and the elapsed time.
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

logger = logging.getLogger("rperc")

__all__ = ["logger", "progress", "quiet"]

# Set inside a batch of runs (``rperc bench``): the batch reports its own progress,
# and a bar or log line per run would bury it.
_QUIET = contextvars.ContextVar("rperc_progress_quiet", default=False)


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """No progress is reported by the loops run inside this block."""
    token = _QUIET.set(True)
    try:
        yield
    finally:
        _QUIET.reset(token)


def progress(
    iterable: Iterable[T],
    *,
    desc: str,
    total: int | None = None,
    unit: str = "it",
    interval: float = 5.0,
    clock: Callable[[], float] = time.monotonic,
) -> Iterator[T]:
    """Yield the items of ``iterable`` while reporting progress.

    ``total`` defaults to ``len(iterable)`` when it has one. ``interval`` (seconds)
    spaces the log lines; ``clock`` is there so tests can drive time.
    """
    if _QUIET.get():
        yield from iterable
        return
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    if _stderr_is_terminal():
        from tqdm import tqdm  # type: ignore[import-untyped,unused-ignore]

        yield from tqdm(iterable, desc=desc, total=total, unit=unit, leave=False)
        return
    yield from _logged(iterable, desc, total, unit, interval, clock)


def _stderr_is_terminal() -> bool:
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # a closed stream
        return False


def _logged(
    iterable: Iterable[T],
    desc: str,
    total: int | None,
    unit: str,
    interval: float,
    clock: Callable[[], float],
) -> Iterator[T]:
    start = last = clock()
    done = 0
    for item in iterable:
        yield item
        done += 1
        now = clock()
        if now - last >= interval:
            last = now
            logger.info("%s: %s %s, %.0f s", desc, _count(done, total), unit, now - start)
    logger.info("%s: %s %s in %.1f s", desc, _count(done, total), unit, clock() - start)


def _count(done: int, total: int | None) -> str:
    if total is None:
        return str(done)
    percent = 100.0 * done / total if total else 100.0
    return f"{done}/{total} ({percent:.0f}%)"
