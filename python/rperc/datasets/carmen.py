"""CARMEN laser logs (``FLASER``, ``RLASER``, ``ROBOTLASER1``, ``ODOM``).

Line formats (CARMEN 0.7 / Radish):

- ``FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp``
  (``RLASER`` alike): n readings over a 180 degree field of view starting at -90
  degrees; ``x y theta`` is the laser pose (corrected by a published SLAM run in the
  Radish logs), ``odom_*`` the raw odometry.
- ``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode
  n r1..rn m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
  forward_safety side_safety turn_axis timestamp host logger_timestamp``.
- ``ODOM x y theta tv rv accel timestamp host logger_timestamp``.

Old-style FLASER lines carry no angular resolution; we use pi/n for even n (180, 360
beams: 1 and 0.5 degree steps) and pi/(n-1) for odd n (181, 361: both ends included).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rperc.datasets._text import read_lines
from rperc.datasets.errors import DatasetFormatError

# FLASER max range is not in the line; SICK LMS scanners of those logs report 81.9 m
# for "no return", which is beyond any indoor wall.
FLASER_MAX_RANGE = 81.83
SKIPPED_TYPES = frozenset({"PARAM", "SYNC"})


@dataclass(frozen=True, repr=False)
class LaserScans:
    """S scans of up to n beams each. Scans with fewer beams are NaN-padded (NaN
    readings are invalid everywhere in rperc); ``num_beams`` keeps the true count."""

    ranges: np.ndarray  # (S, n) float64
    num_beams: np.ndarray  # (S,) int
    angle_min: np.ndarray  # (S,) radians, first beam in the laser frame
    angle_increment: np.ndarray  # (S,)
    max_range: np.ndarray  # (S,)
    pose: np.ndarray  # (S, 3) laser pose x, y, theta in the world frame
    odom: np.ndarray  # (S, 3) raw odometry pose
    timestamp: np.ndarray  # (S,)
    line: np.ndarray  # (S,) line number of each scan in the file

    def __len__(self) -> int:
        return len(self.ranges)

    def angles(self, k: int) -> np.ndarray:
        """Bearings of scan ``k``'s beams in the laser frame."""
        n = int(self.num_beams[k])
        return np.asarray(self.angle_min[k] + self.angle_increment[k] * np.arange(n))

    def __repr__(self) -> str:
        beams = f"{self.ranges.shape[1]} beams" if len(self) else "no beams"
        return f"LaserScans({len(self)} scans, {beams})"


@dataclass(frozen=True, repr=False)
class Odometry:
    """Raw odometry records."""

    pose: np.ndarray  # (M, 3)
    velocity: np.ndarray  # (M, 3) tv, rv, accel
    timestamp: np.ndarray  # (M,)

    def __len__(self) -> int:
        return len(self.pose)

    def __repr__(self) -> str:
        return f"Odometry({len(self)} records)"


@dataclass(frozen=True)
class CarmenLog:
    """A parsed CARMEN log."""

    path: Path
    scans: LaserScans
    odometry: Odometry
    skipped: dict[str, int] = field(default_factory=dict)
    """Records rperc does not read, by type (``PARAM``, ``SYNC``, ``NEFF``, ...): counted,
    never silently lost."""
    first_line: dict[str, int] = field(default_factory=dict)
    """The 1-based line of the first record of each skipped type."""

    def summary(self) -> str:
        """Every count: scans, odometry records and each skipped type with its first line."""
        parts = [f"{len(self.scans)} scans", f"{len(self.odometry)} odometry records"]
        parts += [
            f"{n} {kind} skipped (first at line {self.first_line[kind]})"
            for kind, n in sorted(self.skipped.items())
        ]
        return f"{self.path.name}: " + ", ".join(parts)


def _floats(path: Path, lineno: int, fields: list[str], what: str) -> list[float]:
    try:
        values = [float(f) for f in fields]
    except ValueError as exc:
        raise DatasetFormatError(path, lineno, f"{what}: {exc}") from None
    return values


class _ScanRows:
    def __init__(self) -> None:
        self.ranges: list[list[float]] = []
        self.meta: list[tuple[float, ...]] = []
        self.lines: list[int] = []

    def add(self, ranges: list[float], meta: tuple[float, ...], lineno: int) -> None:
        self.ranges.append(ranges)
        self.meta.append(meta)
        self.lines.append(lineno)


def _parse_flaser(path: Path, lineno: int, tok: list[str], rows: _ScanRows) -> None:
    if len(tok) < 2:
        raise DatasetFormatError(path, lineno, f"{tok[0]} without a beam count")
    try:
        n = int(tok[1])
    except ValueError:
        raise DatasetFormatError(path, lineno, f"bad beam count {tok[1]!r}") from None
    if n <= 0:
        raise DatasetFormatError(path, lineno, f"beam count must be positive, got {n}")
    expected = 2 + n + 9
    if len(tok) != expected:
        raise DatasetFormatError(
            path, lineno, f"{tok[0]} with {n} beams needs {expected} fields, got {len(tok)}"
        )
    ranges = _floats(path, lineno, tok[2 : 2 + n], "ranges")
    x, y, th, ox, oy, oth, ts = _floats(path, lineno, tok[2 + n : 2 + n + 7], "poses")
    step = math.pi / n if n % 2 == 0 else math.pi / (n - 1)
    rows.add(ranges, (-math.pi / 2, step, FLASER_MAX_RANGE, x, y, th, ox, oy, oth, ts), lineno)


def _parse_robotlaser(path: Path, lineno: int, tok: list[str], rows: _ScanRows) -> None:
    try:
        n = int(tok[8])
        m = int(tok[9 + n])
    except (ValueError, IndexError):
        raise DatasetFormatError(path, lineno, "ROBOTLASER1 with bad counts") from None
    expected = 10 + n + m + 14
    if len(tok) != expected or n <= 0 or m < 0:
        raise DatasetFormatError(
            path,
            lineno,
            f"ROBOTLASER1 with {n} beams and {m} remissions needs {expected} fields, "
            f"got {len(tok)}",
        )
    start, _fov, res, max_range = _floats(path, lineno, tok[2:6], "laser config")
    ranges = _floats(path, lineno, tok[9 : 9 + n], "ranges")
    tail = _floats(path, lineno, tok[10 + n + m : 10 + n + m + 12], "poses")
    lx, ly, lth, rx, ry, rth = tail[:6]
    ts = tail[11]
    rows.add(ranges, (start, res, max_range, lx, ly, lth, rx, ry, rth, ts), lineno)


def load_carmen(path: str | Path, *, strict: bool = False) -> CarmenLog:
    """Read a CARMEN log (plain or gzip, with or without a UTF-8 byte-order mark).

    Raises :class:`DatasetFormatError` (a ``ValueError``) naming the file and line for a
    malformed record or a byte that is not UTF-8, and ``FileNotFoundError`` when the
    file is absent. Record types rperc does not read are counted with their first line
    in :attr:`CarmenLog.skipped` and :attr:`CarmenLog.first_line`; with ``strict=True``
    an unknown type (anything but the known ones and ``PARAM``/``SYNC``) is an error.
    Type names are matched as written: ``flaser`` is not ``FLASER``.
    """
    path = Path(path)
    rows = _ScanRows()
    odom: list[list[float]] = []
    skipped: Counter[str] = Counter()
    first_line: dict[str, int] = {}
    for lineno, raw in enumerate(read_lines(path), start=1):
        tok = raw.split()
        if not tok or tok[0].startswith("#"):
            continue
        kind = tok[0]
        if kind in ("FLASER", "RLASER"):
            _parse_flaser(path, lineno, tok, rows)
        elif kind == "ROBOTLASER1":
            _parse_robotlaser(path, lineno, tok, rows)
        elif kind == "ODOM":
            if len(tok) != 10:
                raise DatasetFormatError(path, lineno, f"ODOM needs 10 fields, got {len(tok)}")
            odom.append(_floats(path, lineno, tok[1:8], "ODOM values"))
        else:
            if strict and kind not in SKIPPED_TYPES:
                raise DatasetFormatError(path, lineno, f"unknown record type {kind!r}")
            skipped[kind] += 1
            first_line.setdefault(kind, lineno)
    scans, odometry = _stack_scans(rows), _stack_odometry(odom)
    return CarmenLog(path, scans, odometry, dict(skipped), first_line)


def _stack_scans(rows: _ScanRows) -> LaserScans:
    count = len(rows.ranges)
    width = max((len(r) for r in rows.ranges), default=0)
    ranges = np.full((count, width), np.nan)
    for k, r in enumerate(rows.ranges):
        ranges[k, : len(r)] = r
    meta = np.asarray(rows.meta, dtype=np.float64).reshape(count, 10)
    return LaserScans(
        ranges=ranges,
        num_beams=np.array([len(r) for r in rows.ranges], dtype=np.int64),
        angle_min=meta[:, 0].copy(),
        angle_increment=meta[:, 1].copy(),
        max_range=meta[:, 2].copy(),
        pose=meta[:, 3:6].copy(),
        odom=meta[:, 6:9].copy(),
        timestamp=meta[:, 9].copy(),
        line=np.asarray(rows.lines, dtype=np.int64),
    )


def _stack_odometry(odom: list[list[float]]) -> Odometry:
    arr = np.asarray(odom, dtype=np.float64).reshape(len(odom), 7)
    return Odometry(
        pose=arr[:, 0:3].copy(), velocity=arr[:, 3:6].copy(), timestamp=arr[:, 6].copy()
    )
