"""Every file rperc writes appears whole: it is written under a new name
beside its path (the same folder, so the same file system), flushed to disk, then
renamed over the path. A reader sees the old file or the new one, never half of one,
and of several processes writing one path the last to finish wins whole (four
``rperc slam walls --tum`` runs to one path interleaved their lines before)."""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path


def write_atomically(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Calls ``write(tmp)`` with a fresh path beside ``path`` (its suffix kept, for
    writers that pick a format by it), then renames ``tmp`` over ``path``; on any
    error (Ctrl-C too) the temporary file is removed and ``path`` left as it was."""
    path = Path(path)
    tmp = _fresh(path)
    try:
        write(tmp)
        _sync(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_text_atomically(path: str | Path, text: str) -> Path:
    """:func:`write_atomically` of UTF-8 ``text`` (newlines written as given)."""
    return write_atomically(path, lambda tmp: tmp.write_text(text, encoding="utf-8", newline=""))


def _fresh(path: Path) -> Path:
    """A name beside ``path`` that no file has, reserved by creating it (``O_EXCL``,
    with the mode ``open`` would give, so the umask applies)."""
    while True:
        tmp = path.with_name(f".{path.stem}.{os.getpid()}.{secrets.token_hex(6)}{path.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp
        except FileExistsError:  # pragma: no cover - 48 random bits collided
            continue


def _sync(tmp: Path) -> None:
    """Flushes the file to disk before the rename, so a crash leaves the old file or
    the whole new one."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
