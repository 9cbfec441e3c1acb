"""Polylines from WKT (``LINESTRING``, ``POLYGON``, ``MULTILINESTRING``) or CSV files."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from rperc.datasets.errors import DatasetFormatError

_WKT_HEAD = re.compile(r"^\s*(LINESTRING|POLYGON|MULTILINESTRING)\s*(Z|M|ZM)?\s*\(", re.I)


def _wkt_rings(path: Path, lineno: int, body: str) -> list[np.ndarray]:
    """Coordinate lists between the innermost parentheses."""
    rings = []
    for chunk in re.findall(r"\(([^()]*)\)", body):
        rows = []
        for pair in chunk.split(","):
            parts = pair.split()
            try:
                rows.append([float(v) for v in parts])
            except ValueError:
                raise DatasetFormatError(path, lineno, f"bad coordinate {pair.strip()!r}") from None
        dims = {len(r) for r in rows}
        if len(dims) != 1 or dims.pop() not in (2, 3, 4):
            raise DatasetFormatError(path, lineno, "coordinates must all have 2 or 3 values")
        rings.append(np.asarray(rows, dtype=np.float64)[:, :3])
    if not rings:
        raise DatasetFormatError(path, lineno, "geometry without coordinates")
    return rings


def read_polylines(path: str | Path) -> list[np.ndarray]:
    """All polylines in a file, each an (N, 2) or (N, 3) float64 array.

    ``.wkt``/``.txt`` files hold one WKT geometry per line (POLYGON rings become closed
    polylines); ``.csv`` files hold ``x,y[,z]`` rows (a header line is allowed, blank
    lines separate polylines).
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    if path.suffix.lower() == ".csv":
        return _read_csv(path, text)
    out: list[np.ndarray] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if not _WKT_HEAD.match(line):
            raise DatasetFormatError(path, lineno, f"not a LINESTRING/POLYGON WKT: {line[:40]!r}")
        out.extend(_wkt_rings(path, lineno, line[line.index("(") :]))
    if not out:
        raise DatasetFormatError(path, 1, "no geometry in file")
    return out


def _read_csv(path: Path, text: str) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    rows: list[list[float]] = []
    width = None
    for lineno, line in enumerate(text.splitlines(), start=1):
        fields = [f.strip() for f in line.split(",")] if line.strip() else []
        if not fields:
            if rows:
                out.append(np.asarray(rows))
                rows, width = [], None
            continue
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if lineno == 1:  # header
                continue
            raise DatasetFormatError(path, lineno, f"bad CSV row {line.strip()!r}") from None
        if len(values) not in (2, 3) or (width is not None and len(values) != width):
            raise DatasetFormatError(
                path, lineno, f"rows must have 2 or 3 values, got {len(values)}"
            )
        width = len(values)
        rows.append(values)
    if rows:
        out.append(np.asarray(rows))
    if not out:
        raise DatasetFormatError(path, 1, "no points in file")
    return out


def write_polyline(path: str | Path, points: np.ndarray) -> None:
    """Write one polyline as WKT (``.wkt``) or CSV (anything else)."""
    path = Path(path)
    pts = np.asarray(points, dtype=np.float64)
    if path.suffix.lower() == ".wkt":
        head = "LINESTRING Z" if pts.shape[1] == 3 else "LINESTRING"
        coords = ",".join(" ".join(repr(float(v)) for v in row) for row in pts)
        path.write_text(f"{head}({coords})\n", encoding="utf-8")
    else:
        header = "x,y,z" if pts.shape[1] == 3 else "x,y"
        np.savetxt(path, pts, delimiter=",", header=header, comments="", fmt="%.17g")
