"""Text files as every reader sees them: gzip read transparently (by its magic bytes,
whatever the suffix), a UTF-8 byte-order mark dropped, and undecodable bytes reported
with their file, line and byte offset instead of a bare UnicodeDecodeError."""

from __future__ import annotations

import gzip
import zlib
from pathlib import Path

from rperc.datasets.errors import DatasetFormatError

_GZIP_MAGIC = b"\x1f\x8b"
_BOM = b"\xef\xbb\xbf"


#: Bytes looked at before a file is read whole: a text file holds no NUL among them.
SNIFF_BYTES = 1 << 16


def read_bytes(path: Path) -> bytes:
    """The file's bytes, gunzipped when it is a gzip stream. A file whose first
    :data:`SNIFF_BYTES` (after gunzipping) hold a NUL byte is refused at once as not
    text, before the rest is read: a 2 GB binary file was read for 26 s before a
    MemoryError (issue 38)."""
    with path.open("rb") as f:
        head = f.read(SNIFF_BYTES)
        zipped = head.startswith(_GZIP_MAGIC)
        _refuse_binary(path, _gunzip_head(path, head) if zipped else head)
        raw = head + f.read()
    if not zipped:
        return raw
    try:
        return gzip.decompress(raw)
    except (EOFError, OSError, zlib.error) as exc:
        raise DatasetFormatError(path, 0, f"corrupt or truncated gzip stream: {exc}") from None


def _gunzip_head(path: Path, head: bytes) -> bytes:
    """The first bytes of a gzip stream's contents (at most :data:`SNIFF_BYTES`)."""
    try:
        return zlib.decompressobj(16 + zlib.MAX_WBITS).decompress(head, SNIFF_BYTES)
    except zlib.error as exc:
        raise DatasetFormatError(path, 0, f"corrupt gzip stream: {exc}") from None


def _refuse_binary(path: Path, head: bytes) -> None:
    """A DatasetFormatError naming the line of the first NUL byte in ``head``."""
    at = head.find(b"\0")
    if at >= 0:
        line = head.count(b"\n", 0, at) + 1
        raise DatasetFormatError(
            path, line, f"not a text file: a NUL byte at byte {at} (binary data?)"
        )


def _text_bytes(path: Path) -> bytes:
    """:func:`read_bytes` with a UTF-8 byte-order mark dropped: the bytes both decoders
    below read."""
    raw = read_bytes(path)
    return raw[len(_BOM) :] if raw.startswith(_BOM) else raw


def read_text(path: str | Path) -> str:
    """The file as text (UTF-8, BOM dropped); a byte that is not UTF-8 is a
    :class:`DatasetFormatError` naming its line and its offset in that line."""
    path = Path(path)
    raw = _text_bytes(path)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        start = raw.rfind(b"\n", 0, exc.start) + 1
        byte = raw[exc.start]
        raise DatasetFormatError(
            path, line, f"byte {exc.start - start} of the line (0x{byte:02x}) is not UTF-8"
        ) from None


def split_lines(text: str) -> list[str]:
    """``text`` split at ``\\n``, ``\\r\\n`` and ``\\r`` only. ``str.splitlines`` also
    splits at form feeds, ``\\x1c``-``\\x1e``, NEL and the Unicode line separators, which
    would cut a record (or a comment) in two and shift every later line number away
    from what an editor shows."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if lines[-1] == "":
        lines.pop()  # the newline that ends the last line starts no new one
    return lines


def read_lines(path: str | Path) -> list[str]:
    """:func:`read_text` split into lines by :func:`split_lines`."""
    return split_lines(read_text(path))


def decode_lines(path: str | Path) -> list[str | DatasetFormatError]:
    """The file's lines like :func:`read_lines`, except that a line holding a byte that
    is not UTF-8 comes back as the :class:`DatasetFormatError` naming it (line and
    byte offset) instead of aborting the read, so a reader can skip it and go on."""
    path = Path(path)
    raw = _text_bytes(path)
    try:
        return list(split_lines(raw.decode("utf-8")))
    except UnicodeDecodeError:
        pass  # rare: decode line by line to find every bad line
    lines: list[str | DatasetFormatError] = []
    chunks = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
    if chunks[-1] == b"":
        chunks.pop()
    for lineno, chunk in enumerate(chunks, start=1):
        try:
            lines.append(chunk.decode("utf-8"))
        except UnicodeDecodeError as exc:
            byte = chunk[exc.start]
            reason = f"byte {exc.start} of the line (0x{byte:02x}) is not UTF-8"
            lines.append(DatasetFormatError(path, lineno, reason))
    return lines
