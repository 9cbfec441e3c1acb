"""CARMEN laser logs (``FLASER``, ``RLASER``, ``ROBOTLASER1``, ``RAWLASER1``, ``ODOM``,
``PARAM``).

Line formats (CARMEN 0.7 / Radish):

- ``FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp``
  (``RLASER`` alike, the rear laser): n readings over the field of view starting at
  -fov/2; ``x y theta`` is the laser pose (corrected by a published SLAM run in the
  Radish logs), ``odom_*`` the raw odometry.
- ``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode
  n r1..rn m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
  forward_safety side_safety turn_axis timestamp host logger_timestamp``.
- ``RAWLASER1 type start_angle fov resolution max_range accuracy remission_mode
  n r1..rn m e1..em timestamp host logger_timestamp``: no pose in the line; the pose
  is the odometry interpolated at the scan's timestamp (NaN outside the odometry's
  time span, counted in the summary).
- ``ODOM x y theta tv rv accel timestamp host logger_timestamp``.
- ``PARAM name value host timestamp``: read into :attr:`CarmenLog.params`. The laser
  lines that follow use ``robot_front_laser_max`` / ``robot_rear_laser_max`` (m),
  ``laser_front_laser_fov`` / ``laser_rear_laser_fov`` (degrees) and
  ``laser_front_laser_resolution`` / ``laser_rear_laser_resolution`` (degrees), the
  names CARMEN's ini files and MRPT's reader use, for FLASER and RLASER lines.

Old-style FLASER and RLASER lines carry no maximum range either. Without a max-range
parameter, the reader looks for the scanner's no-return marker in the readings
(:func:`infer_no_return`): a scanner measures in small steps, so far readings spread
over many values, and only a saturated "no return" makes many readings share the
largest value exactly (the ACES log writes 50.0 m 620 times, and its next largest
values occur once each). The marker becomes those scans' maximum range, so its
readings are invalid (no return), not walls 50 m away; the log's
:attr:`CarmenLog.no_return` and summary say so. Without such a marker the maximum
range is the SICK default of 81.83 m.

A max-range PARAM (``robot_front_laser_max``) is CARMEN's robot setting, what its
navigation uses, and need not be the scanner's reach: edmonton's says 10 m while a
quarter of its readings are walls 11-40 m away, over 976 distinct values.
When readings beyond a PARAM spread over at least :data:`NO_RETURN_MIN_COUNT`
distinct values more than :data:`NO_RETURN_BAND` past it (a scanner's saturation
clusters just above its limit, as the Freiburg logs' 81.91 m above their 80.99 m
PARAM), the readings win: the maximum range is inferred as without a PARAM, with a
:class:`MaxRangeWarning`, and counted in :attr:`CarmenLog.max_range_contradicted`;
``load_carmen(path, max_range="param")`` keeps the PARAM.

Old-style FLASER lines carry no angular resolution: without a resolution parameter we
use fov/n for even n (180, 360 beams: 1 and 0.5 degree steps over 180 degrees) and
fov/(n-1) for odd n (181, 361: both ends included).

Scan times that do not increase strictly (``orebro.log.gz`` stamps every scan 0, the
infinite corridor repeats one value after its first four scans, ``intel.log`` steps back
four times) are repaired by :func:`rperc.datasets.timestamps.repair_increasing` (the rule
every trajectory writer and reader shares), with one
:class:`~rperc.datasets.timestamps.TimestampRepairWarning` naming the file and the count:
``scans.timestamp`` is strictly increasing, with one time per scan in log order;
``scans.timestamp_raw`` keeps the times as written, and :attr:`CarmenLog.times_repaired`
and the summary say how many changed. Odometry times are kept as written.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np

from rperc import _rperc
from rperc._args import excerpt
from rperc.datasets._text import decode_lines
from rperc.datasets.errors import DatasetFormatError
from rperc.datasets.timestamps import TimeOrderError, TimestampRepairWarning, repair_increasing
from rperc.pose import wrap_angle

# FLASER max range is not in the line; SICK LMS scanners of those logs report 81.9 m
# for "no return", which is beyond any indoor wall.
FLASER_MAX_RANGE = 81.83
_log = logging.getLogger(__name__)
FLASER_FOV = math.pi
SKIPPED_TYPES = frozenset({"SYNC"})
#: :func:`infer_no_return`: at least this many readings must share the largest value,
NO_RETURN_MIN_COUNT = 20
#: and it must occur this many times as often as any other value within
#: ``NO_RETURN_BAND`` (relative) below it.
NO_RETURN_DOMINANCE = 10
NO_RETURN_BAND = 0.1
#: The laser geometry PARAMs: what each is, and its valid range ``(low, high]``.
_GEOMETRY_PARAMS = {
    name: rule
    for side in ("front", "rear")
    for name, rule in (
        (f"robot_{side}_laser_max", ("a maximum range (m)", 0.0, math.inf)),
        (f"laser_{side}_laser_fov", ("a field of view (degrees)", 0.0, 360.0)),
        (f"laser_{side}_laser_resolution", ("a resolution (degrees)", 0.0, 360.0)),
    )
}
_LASER_PARAMS = {
    "FLASER": ("robot_front_laser_max", "laser_front_laser_fov", "laser_front_laser_resolution"),
    "RLASER": ("robot_rear_laser_max", "laser_rear_laser_fov", "laser_rear_laser_resolution"),
}


@dataclass(frozen=True, repr=False)
class LaserScans:
    """S scans of up to n beams each. Scans with fewer beams are NaN-padded (NaN
    readings are invalid everywhere in rperc); ``num_beams`` keeps the true count.
    Readings the file gives as NaN, infinite or negative are stored as NaN and counted
    per scan in ``invalid``. ``timestamp`` increases strictly when read by
    :func:`load_carmen` (repaired where the file's do not); ``timestamp_raw`` holds the
    times as written (``timestamp`` itself when not given)."""

    ranges: np.ndarray  # (S, n) float64
    num_beams: np.ndarray  # (S,) int
    angle_min: np.ndarray  # (S,) radians, first beam in the laser frame
    angle_increment: np.ndarray  # (S,)
    max_range: np.ndarray  # (S,)
    pose: np.ndarray  # (S, 3) laser pose x, y, theta in the world frame
    odom: np.ndarray  # (S, 3) raw odometry pose
    timestamp: np.ndarray  # (S,)
    line: np.ndarray  # (S,) line number of each scan in the file
    invalid: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    """(S,) readings of each scan that were NaN, infinite or negative in the file."""
    kind: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype="<U11"))
    """(S,) the record type of each scan (``FLASER``, ``RAWLASER1``, ...)."""
    timestamp_raw: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(S,) each scan's time as the file writes it, before any repair."""

    def __post_init__(self) -> None:
        if self.timestamp_raw.size == 0 and self.timestamp.size:
            object.__setattr__(self, "timestamp_raw", self.timestamp)
        elif self.timestamp_raw.shape != self.timestamp.shape:
            raise ValueError(
                f"timestamp_raw has shape {self.timestamp_raw.shape}, "
                f"timestamp {self.timestamp.shape}"
            )

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
class SkippedLine:
    """A malformed line that ``on_error="skip"`` left out, and why."""

    line: int
    reason: str


class MaxRangeWarning(UserWarning):
    """A max-range PARAM that the log's readings contradict was set aside (see the
    module docs)."""


@dataclass(frozen=True)
class MaxRangeContradiction:
    """A laser type's max-range PARAM that its readings contradict."""

    param: float
    """The PARAM's value, m."""
    readings: int
    """Readings more than ``NO_RETURN_BAND`` beyond it."""
    distinct: int
    """Their distinct values."""
    farthest: float
    """The farthest of them, m."""


@dataclass(frozen=True)
class CarmenLog:
    """A parsed CARMEN log."""

    path: Path
    scans: LaserScans
    odometry: Odometry
    skipped: dict[str, int] = field(default_factory=dict)
    """Records rperc does not read, by type (``SYNC``, ``NEFF``, ...): counted, never
    silently lost. ``PARAM`` lines are counted here too (and read into ``params``)."""
    first_line: dict[str, int] = field(default_factory=dict)
    """The 1-based line of the first record of each skipped type."""
    params: dict[str, str] = field(default_factory=dict)
    """``PARAM`` name to value (the last one read when a name repeats)."""
    errors: tuple[SkippedLine, ...] = ()
    """Malformed lines left out by ``on_error="skip"``, in file order."""
    scans_without_pose: int = 0
    """RAWLASER1 scans outside the odometry's time span (their pose is NaN)."""
    comments: int = 0
    """Lines starting with ``#`` (CARMEN's header comments): counted, not records."""
    no_return: dict[str, tuple[float, int]] = field(default_factory=dict)
    """Per laser type without a max-range ``PARAM``: the no-return marker found in its
    readings (:func:`infer_no_return`) and how many readings carry it; that marker is
    those scans' ``max_range``."""
    times_repaired: int = 0
    """Scans whose time did not increase and was repaired (``scans.timestamp`` differs
    from ``scans.timestamp_raw`` there)."""
    max_range_contradicted: dict[str, MaxRangeContradiction] = field(default_factory=dict)
    """Per laser type: the max-range PARAM its readings contradict, set aside (see the
    module docs); empty with ``max_range="param"``."""

    def summary(self) -> str:
        """Every count: scans by type, invalid readings, odometry records, PARAM lines,
        malformed lines skipped, and each record type not read with its first line."""
        kinds = Counter(self.scans.kind.tolist())
        by_kind = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
        bad = int(self.scans.invalid.sum())
        parts = [f"{len(self.scans)} scans" + (f" ({by_kind})" if by_kind else "")]
        parts.append(
            f"{bad} invalid readings (NaN, inf or negative) in "
            f"{int(np.count_nonzero(self.scans.invalid))} scans"
        )
        if self.scans_without_pose:
            parts.append(f"{self.scans_without_pose} RAWLASER1 scans without a pose")
        if self.times_repaired:
            first = int(np.argmax(self.scans.timestamp != self.scans.timestamp_raw))
            parts.append(
                f"{self.times_repaired} scan times repaired to increase strictly "
                f"(first at line {int(self.scans.line[first])})"
            )
        parts += [
            f"{kind} max-range PARAM {c.param:g} m set aside ({c.readings} readings beyond it, "
            f"{c.distinct} distinct values up to {c.farthest:g} m)"
            for kind, c in sorted(self.max_range_contradicted.items())
        ]
        parts += [
            f"{kind} no-return marker {value:g} m inferred ({count} readings, no max-range PARAM)"
            for kind, (value, count) in sorted(self.no_return.items())
        ]
        parts.append(f"{len(self.odometry)} odometry records")
        parts.append(f"{self.comments} comment lines")
        parts.append(f"{len(self.errors)} malformed lines skipped")
        if self.errors:
            parts[-1] += f" (first at line {self.errors[0].line}: {self.errors[0].reason})"
        parts += [
            f"{n} {kind} skipped (first at line {self.first_line[kind]})"
            for kind, n in sorted(self.skipped.items())
            if kind != "PARAM"
        ]
        if "PARAM" in self.skipped:
            n = self.skipped["PARAM"]
            parts.append(f"{n} PARAM read (first at line {self.first_line['PARAM']})")
        return f"{self.path.name}: " + ", ".join(parts)


def _float_array(path: Path, lineno: int, fields: list[str], what: str) -> np.ndarray:
    """A scan's readings. Rust reads plain decimals several times faster than
    ``float()`` (a scan line holds hundreds); anything else (digit separators, a bad
    token) takes ``float()``'s path, which names the bad token."""
    fast = _rperc.parse_floats(fields)
    if fast is not None:
        return fast
    return np.asarray(_floats(path, lineno, fields, what), dtype=np.float64)


def _floats(path: Path, lineno: int, fields: list[str], what: str) -> list[float]:
    try:
        values = list(map(float, fields))
    except ValueError:
        bad = next(f for f in fields if not _parses(f))
        raise DatasetFormatError(path, lineno, f"{what}: not a number: {excerpt(bad)}") from None
    return values


def _parses(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _finite(path: Path, lineno: int, values: list[float], what: str) -> list[float]:
    """Poses and timestamps must be finite: a NaN pose would put walls nowhere."""
    if not all(map(math.isfinite, values)):
        raise DatasetFormatError(path, lineno, f"{what} not finite: {values}")
    return values


def _int(path: Path, lineno: int, tok: list[str], k: int, what: str) -> int:
    try:
        return int(tok[k])
    except (ValueError, IndexError):
        got = excerpt(tok[k]) if k < len(tok) else "nothing"
        raise DatasetFormatError(path, lineno, f"{tok[0]} {what}: got {got}") from None


class _ScanRows:
    def __init__(self) -> None:
        self.ranges: list[np.ndarray] = []
        self.meta: list[tuple[float, ...]] = []
        self.lines: list[int] = []
        self.kinds: list[str] = []

    def add(self, kind: str, ranges: np.ndarray, meta: tuple[float, ...], lineno: int) -> None:
        self.ranges.append(np.asarray(ranges, dtype=np.float64))
        self.meta.append(meta)
        self.lines.append(lineno)
        self.kinds.append(kind)


def _flaser_geometry(kind: str, n: int, params: dict[str, str]) -> tuple[float, float, float]:
    """``(angle_min, step, max_range)`` of an old-style line from the PARAMs read so far
    (``max_range`` NaN without a max-range PARAM: inferred once all lines are read)."""
    max_name, fov_name, res_name = _LASER_PARAMS[kind]

    def value(name: str, default: float) -> float:
        return float(params.get(name, default))  # checked by _parse_param

    max_range = value(max_name, math.nan)
    fov = math.radians(value(fov_name, 180.0))
    if res_name in params:
        step = math.radians(value(res_name, 1.0))
    else:
        step = fov / n if n % 2 == 0 or n == 1 else fov / (n - 1)
    return -fov / 2, step, max_range


def _parse_flaser(
    path: Path, lineno: int, tok: list[str], rows: _ScanRows, params: dict[str, str]
) -> None:
    n = _int(path, lineno, tok, 1, "without a beam count")
    if n <= 0:
        raise DatasetFormatError(path, lineno, f"beam count must be positive, got {n}")
    expected = 2 + n + 9
    if len(tok) != expected:
        raise DatasetFormatError(
            path, lineno, f"{tok[0]} with {n} beams needs {expected} fields, got {len(tok)}"
        )
    ranges = _float_array(path, lineno, tok[2 : 2 + n], "ranges")
    pose = _floats(path, lineno, tok[2 + n : 2 + n + 7], "poses")
    _add_flaser(path, lineno, tok[0], ranges, pose, rows, params)


def _read_flaser_line(
    path: Path, lineno: int, raw: str, rows: _ScanRows, params: dict[str, str]
) -> bool:
    """Reads a well-formed FLASER or RLASER line without splitting it into Python
    strings (Rust reads its numbers from the line); False, with nothing read, for any
    line that is not plainly well formed, which :func:`_parse_flaser` then reads and
    whose fault it names."""
    head = raw.split(maxsplit=2)
    # A count with more digits than a line could hold readings for (more than nine)
    # is the checked path's to name: int() and the native reader both refuse huge ones.
    count = head[1] if len(head) == 3 else ""
    if not (count.isascii() and count.isdigit() and len(count) <= 9):
        return False
    n = int(count)
    fast = _rperc.parse_line_floats(raw, 2, n + 7) if 0 < n <= len(raw) else None
    if fast is None or fast[0] != n + 11:
        return False
    values = fast[1]
    _add_flaser(path, lineno, head[0], values[:n], values[n:].tolist(), rows, params)
    return True


def _add_flaser(
    path: Path,
    lineno: int,
    kind: str,
    ranges: np.ndarray,
    pose: list[float],
    rows: _ScanRows,
    params: dict[str, str],
) -> None:
    """An old-style line's scan, its poses checked and its geometry from the PARAMs."""
    _finite(path, lineno, pose, "pose")
    start, step, max_range = _flaser_geometry(kind, len(ranges), params)
    _within_a_turn(path, lineno, kind, len(ranges), step)
    rows.add(kind, ranges, (start, step, max_range, *pose), lineno)


def _laser_config(path: Path, lineno: int, tok: list[str]) -> tuple[int, int, list[float]]:
    """Beam and remission counts and ``start fov res max_range`` of a CARMEN 0.7 line."""
    n = _int(path, lineno, tok, 8, "beam count")
    m = _int(path, lineno, tok, 9 + n, "remission count") if n >= 0 else -1
    if n <= 0 or m < 0:
        raise DatasetFormatError(path, lineno, f"{tok[0]} with bad counts ({n} beams, {m})")
    config = _finite(path, lineno, _floats(path, lineno, tok[2:6], "laser config"), "config")
    turn = 2 * math.pi
    _in_range(path, lineno, f"{tok[0]} fov", config[1], "a field of view (rad)", 0.0, turn)
    _in_range(path, lineno, f"{tok[0]} resolution", config[2], "a resolution (rad)", 0.0, turn)
    _in_range(path, lineno, f"{tok[0]} max range", config[3], "a maximum range (m)", 0.0, math.inf)
    return n, m, config


def _within_a_turn(path: Path, lineno: int, kind: str, n: int, step: float) -> None:
    """The beams must fit in one turn: a resolution that sweeps them past 360 degrees
    (from a PARAM or the line) would put two beams in one direction."""
    if step * (n - 1) > 2 * math.pi + 1e-9:
        deg = math.degrees(step)
        raise DatasetFormatError(
            path, lineno, f"{kind} with {n} beams {deg:g} degrees apart spans more than a turn"
        )


def _laser_ranges(
    path: Path, lineno: int, tok: list[str], trailing: int
) -> tuple[np.ndarray, tuple[float, float, float], int]:
    """What ROBOTLASER1 and RAWLASER1 lines share: the laser config and the ranges,
    checked, before ``trailing`` fields that follow the remissions. Returns the
    ranges, ``(start, res, max_range)`` and where the trailing fields begin."""
    n, m, (start, _fov, res, max_range) = _laser_config(path, lineno, tok)
    _within_a_turn(path, lineno, tok[0], n, res)
    expected = 10 + n + m + trailing
    if len(tok) != expected:
        raise DatasetFormatError(
            path,
            lineno,
            f"{tok[0]} with {n} beams and {m} remissions needs {expected} fields, got {len(tok)}",
        )
    ranges = _float_array(path, lineno, tok[9 : 9 + n], "ranges")
    return ranges, (start, res, max_range), 10 + n + m


def _parse_robotlaser(path: Path, lineno: int, tok: list[str], rows: _ScanRows) -> None:
    ranges, geometry, at = _laser_ranges(path, lineno, tok, 14)
    tail = _floats(path, lineno, tok[at : at + 12], "poses")
    lx, ly, lth, rx, ry, rth = _finite(path, lineno, tail[:6], "pose")
    ts = _finite(path, lineno, tail[11:12], "timestamp")[0]
    rows.add(tok[0], ranges, (*geometry, lx, ly, lth, rx, ry, rth, ts), lineno)


def _parse_rawlaser(path: Path, lineno: int, tok: list[str], rows: _ScanRows) -> None:
    ranges, geometry, at = _laser_ranges(path, lineno, tok, 3)
    ts = _finite(path, lineno, _floats(path, lineno, tok[at : at + 1], "time"), "ts")[0]
    nan = math.nan  # the pose comes from the odometry once all of it is read
    rows.add(tok[0], ranges, (*geometry, nan, nan, nan, nan, nan, nan, ts), lineno)


def _odom_values(path: Path, lineno: int, raw: str) -> list[float]:
    """One ODOM line's seven values, or a DatasetFormatError naming the line."""
    tok = raw.split()
    if len(tok) != 10:
        raise DatasetFormatError(path, lineno, f"ODOM needs 10 fields, got {len(tok)}")
    values = _floats(path, lineno, tok[1:8], "ODOM values")
    _finite(path, lineno, values[:3], "pose")
    return values


class _OdomRows:
    """The ODOM lines, read as numbers in one batch once the file is read: ODOM lines
    outnumber scans ten to one, and a split and parse per line was most of reading a
    log. A line that does not read is found again by :func:`_odom_values`, so its error
    is the per-line one, and no error is reported out of file order."""

    def __init__(self) -> None:
        self.raws: list[str] = []
        self.lines: list[int] = []

    def add(self, lineno: int, raw: str) -> None:
        self.raws.append(raw)
        self.lines.append(lineno)

    def check_before(self, path: Path, lineno: int) -> None:
        """Raises the error of the first bad ODOM line before line ``lineno``."""
        for raw, at in zip(self.raws, self.lines, strict=True):
            if at >= lineno:
                return
            _odom_values(path, at, raw)

    def stack(self, path: Path, errors: list[SkippedLine] | None) -> np.ndarray:
        """The ``(N, 7)`` values; a bad line raises, or with ``errors`` is left out and
        listed there."""
        fast = _rperc.parse_lines_floats(self.raws, 1, 7)
        if fast is not None:
            fields, arr = fast
            if (fields == 10).all() and np.isfinite(arr[:, :3]).all():
                return arr
        rows = []
        for raw, at in zip(self.raws, self.lines, strict=True):
            try:
                rows.append(_odom_values(path, at, raw))
            except DatasetFormatError as exc:
                if errors is None:
                    raise
                errors.append(SkippedLine(exc.line, exc.reason))
        return np.asarray(rows, dtype=np.float64).reshape(len(rows), 7)


def _parse_param(path: Path, lineno: int, tok: list[str], params: dict[str, str]) -> None:
    if len(tok) < 3:
        raise DatasetFormatError(path, lineno, "PARAM needs a name and a value")
    if tok[1] in _GEOMETRY_PARAMS:
        # Checked where it is written: a resolution of 0 or NaN or a negative maximum
        # range used to be taken as it was (or silently replaced by the default when
        # it did not parse) by every laser line after it (issue 38).
        what, low, high = _GEOMETRY_PARAMS[tok[1]]
        value = _floats(path, lineno, tok[2:3], tok[1])[0]
        _in_range(path, lineno, f"PARAM {tok[1]}", value, what, low, high)
    params[tok[1]] = tok[2]


def _in_range(
    path: Path, lineno: int, name: str, value: float, what: str, low: float, high: float
) -> float:
    """``value`` when finite and in ``(low, high]``, else a DatasetFormatError naming
    ``name``: the one range check of a laser's geometry, from a PARAM or a line."""
    if not (math.isfinite(value) and low < value <= high):
        raise DatasetFormatError(
            path, lineno, f"{name} is {value!r}; {what} must be in ({low:g}, {high:g}]"
        )
    return value


def load_carmen(
    path: str | Path,
    *,
    strict: bool = False,
    on_error: Literal["raise", "skip"] = "raise",
    max_range: Literal["auto", "param"] = "auto",
) -> CarmenLog:
    """Read a CARMEN log (plain or gzip, with or without a UTF-8 byte-order mark).

    A malformed record (wrong field count, as a truncated last line has; a number that
    does not parse; a NaN or infinite pose) or a byte that is not UTF-8 raises
    :class:`DatasetFormatError` (a ``ValueError``) naming the file and line; with
    ``on_error="skip"`` the line is left out instead, and listed in
    :attr:`CarmenLog.errors`. A missing file is ``FileNotFoundError`` either way.
    Readings that are NaN, infinite or negative are kept as invalid (NaN) readings and
    counted per scan in ``scans.invalid``. Record types rperc does not read are counted
    with their first line in :attr:`CarmenLog.skipped` and :attr:`CarmenLog.first_line`;
    with ``strict=True`` an unknown type (anything but the known ones and ``SYNC``) is
    an error. Type names are matched as written: ``flaser`` is not ``FLASER``.
    Scan times that do not increase strictly are repaired (see the module docs) with a
    :class:`~rperc.datasets.timestamps.TimestampRepairWarning`. A max-range PARAM that
    the readings contradict is set aside with a :class:`MaxRangeWarning` (see the
    module docs); ``max_range="param"`` keeps every PARAM as written.
    """
    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip', got {excerpt(on_error)}")
    if max_range not in ("auto", "param"):
        raise ValueError(f"max_range must be 'auto' or 'param', got {excerpt(max_range)}")
    path = Path(path)
    rows, odom, params = _ScanRows(), _OdomRows(), dict[str, str]()
    skipped: Counter[str] = Counter()
    first_line: dict[str, int] = {}
    errors: list[SkippedLine] = []
    comments = 0
    for lineno, raw in enumerate(decode_lines(path), start=1):
        # Most lines are ODOM: kept as they are, read in one batch at the end.
        if raw.__class__ is str and raw.startswith("ODOM "):
            odom.add(lineno, raw)
            continue
        try:
            kind = _read_record(path, lineno, raw, rows, odom, params, strict)
        except DatasetFormatError as exc:
            if on_error == "raise":
                odom.check_before(path, lineno)
                raise
            errors.append(SkippedLine(exc.line, exc.reason))
            continue
        if kind == COMMENT:
            comments += 1
        elif kind is not None:
            skipped[kind] += 1
            first_line.setdefault(kind, lineno)
    odometry = _stack_odometry(odom.stack(path, errors if on_error == "skip" else None))
    errors.sort(key=lambda e: e.line)
    contradicted = _set_aside_contradicted(path, rows) if max_range == "auto" else {}
    no_return = _default_max_range(rows)
    scans, no_pose = _stack_scans(rows, odometry)
    scans, repaired = _repair_times(path, scans)
    return CarmenLog(
        path, scans, odometry, dict(skipped), first_line, params, tuple(errors), no_pose,
        comments, no_return, repaired, contradicted,
    )  # fmt: skip


def load_carmen_logged(path: str | Path) -> CarmenLog:
    """:func:`load_carmen` for a run over logs (``rperc bench``, the laser pipeline's
    loader): a repair of the scan times and a max-range PARAM set aside are told as
    ``logging`` lines (``rperc.datasets.carmen``) instead of Python warnings; the log
    counts both (:attr:`CarmenLog.times_repaired`,
    :attr:`CarmenLog.max_range_contradicted`)."""
    log = _load_untold(path)
    if log.times_repaired:
        _log.info("%s: %d scan times repaired", log.path.name, log.times_repaired)
    for kind, c in log.max_range_contradicted.items():
        _log.warning(
            "%s: %s max-range PARAM %g m set aside: %d readings beyond it, %d distinct "
            "values up to %g m", log.path.name, kind, c.param, c.readings, c.distinct,
            c.farthest,
        )  # fmt: skip
    return log


def _load_untold(path: str | Path) -> CarmenLog:
    """:func:`load_carmen` without its two warnings, for a caller that tells what they
    say its own way, from the log's counts (:attr:`CarmenLog.times_repaired`,
    :attr:`CarmenLog.max_range_contradicted`). Every other warning goes through."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TimestampRepairWarning)
        warnings.simplefilter("ignore", MaxRangeWarning)
        return load_carmen(path)


def _repair_times(path: Path, scans: LaserScans) -> tuple[LaserScans, int]:
    """The scans with strictly increasing times, and how many were repaired (warned)."""
    try:
        times, repaired = repair_increasing(scans.timestamp)
    except TimeOrderError as exc:  # only times near the largest float
        raise DatasetFormatError(path, int(scans.line[exc.index]), str(exc)) from None
    if not repaired:
        return scans, 0
    first = int(np.argmax(times != scans.timestamp))
    warnings.warn(
        f"{path}: {repaired} of {len(scans)} scan times did not increase strictly (first "
        f"at line {int(scans.line[first])}) and were repaired; the file's times are in "
        "scans.timestamp_raw",
        TimestampRepairWarning,
        stacklevel=3,
    )
    return replace(scans, timestamp=times, timestamp_raw=scans.timestamp), repaired


def infer_no_return(ranges: np.ndarray) -> tuple[float, int] | None:
    """The no-return marker of a scanner's readings, with its count, or ``None``.

    A laser scanner measures range in small steps (1 cm for the SICK LMS), so far
    readings spread over many distinct values; a reading that saturates ("no return")
    is written as one fixed value. So the largest finite reading is the marker when at
    least :data:`NO_RETURN_MIN_COUNT` readings share it exactly and it occurs at least
    :data:`NO_RETURN_DOMINANCE` times as often as any other value within
    :data:`NO_RETURN_BAND` (relative) below it, and the readings below it take at least
    :data:`NO_RETURN_MIN_COUNT` distinct values (a scan of one repeated value shows no
    saturation).

    >>> r = np.r_[np.linspace(0.5, 49.9, 5000), np.full(50, 50.0)]
    >>> infer_no_return(r)
    (50.0, 50)
    >>> infer_no_return(np.linspace(0.5, 49.9, 5000)) is None
    True
    """
    r = np.asarray(ranges, dtype=np.float64).ravel()
    r = r[np.isfinite(r) & (r > 0)]
    if len(r) == 0:
        return None
    top = float(r.max())
    count = int(np.count_nonzero(r == top))
    near = r[(r >= top * (1 - NO_RETURN_BAND)) & (r < top)]
    _, counts = np.unique(near, return_counts=True)
    rival = int(counts.max()) if len(counts) else 0
    spread = _distinct_at_least(r[r < top], NO_RETURN_MIN_COUNT)
    if spread and count >= NO_RETURN_MIN_COUNT and count >= NO_RETURN_DOMINANCE * max(rival, 1):
        return top, count
    return None


def _distinct_at_least(values: np.ndarray, k: int) -> bool:
    """Whether ``values`` hold at least ``k`` distinct numbers: a short head of a log's
    readings usually does, which spares sorting all of them."""
    return len(np.unique(values[: 64 * k])) >= k or len(np.unique(values)) >= k


def _set_aside_contradicted(path: Path, rows: _ScanRows) -> dict[str, MaxRangeContradiction]:
    """Sets aside (to NaN, inferred later as without a PARAM) each max-range PARAM of
    the old-style lines (FLASER, RLASER: the others carry their own) that the readings
    under it contradict: finite readings more than :data:`NO_RETURN_BAND` beyond it
    taking at least :data:`NO_RETURN_MIN_COUNT` distinct values. Each PARAM value is
    judged on its own scans (a PARAM can change mid-log). Warns for each; returns per
    laser type the contradiction with the most readings."""
    found: dict[str, MaxRangeContradiction] = {}
    groups: dict[tuple[str, float], list[int]] = {}
    for k, m in enumerate(rows.meta):
        if rows.kinds[k] in _LASER_PARAMS and not math.isnan(m[2]):
            groups.setdefault((rows.kinds[k], m[2]), []).append(k)
    for (kind, limit), mine in sorted(groups.items()):
        beyond = np.concatenate([_beyond(rows.ranges[k], limit) for k in mine])
        distinct = len(np.unique(beyond))
        if distinct < NO_RETURN_MIN_COUNT:
            continue
        c = MaxRangeContradiction(limit, len(beyond), distinct, float(beyond.max()))
        if kind not in found or c.readings > found[kind].readings:
            found[kind] = c
        for k in mine:
            rows.meta[k] = (*rows.meta[k][:2], math.nan, *rows.meta[k][3:])
        warnings.warn(
            f"{path}: {kind}'s max-range PARAM {limit:g} m is contradicted by "
            f"{len(beyond)} readings beyond it ({distinct} distinct values up to "
            f"{c.farthest:g} m): the scanner's range is inferred from the readings "
            f"instead (load_carmen(..., max_range='param') keeps the PARAM)",
            MaxRangeWarning,
            stacklevel=3,
        )
    return found


def _beyond(ranges: np.ndarray, limit: float) -> np.ndarray:
    """The finite readings more than :data:`NO_RETURN_BAND` beyond ``limit`` (NaN, inf
    and negative ones are invalid readings, not far walls)."""
    with np.errstate(invalid="ignore"):
        far = np.isfinite(ranges) & (ranges > limit * (1 + NO_RETURN_BAND))
    out: np.ndarray = ranges[far]
    return out


def _default_max_range(rows: _ScanRows) -> dict[str, tuple[float, int]]:
    """Fills in the maximum range of the old-style lines read without a max-range
    PARAM (NaN so far): per laser type, the no-return marker of their readings when
    there is one (:func:`infer_no_return`), else :data:`FLASER_MAX_RANGE`. Returns the
    markers found."""
    found: dict[str, tuple[float, int]] = {}
    unknown = [k for k, m in enumerate(rows.meta) if math.isnan(m[2])]
    for kind in sorted({rows.kinds[k] for k in unknown}):
        mine = [k for k in unknown if rows.kinds[k] == kind]
        marker = infer_no_return(np.concatenate([rows.ranges[k] for k in mine]))
        if marker is not None:
            found[kind] = marker
        max_range = marker[0] if marker is not None else FLASER_MAX_RANGE
        for k in mine:
            m = rows.meta[k]
            rows.meta[k] = (*m[:2], max_range, *m[3:])
    return found


# What _read_record returns for a comment line (no record type starts with '#').
COMMENT = "#"


def _read_record(
    path: Path,
    lineno: int,
    raw: str | DatasetFormatError,
    rows: _ScanRows,
    odom: _OdomRows,
    params: dict[str, str],
    strict: bool,
) -> str | None:
    """Parses one line into ``rows``, ``odom`` or ``params``; returns the type of a
    record that is only counted (PARAM too), :data:`COMMENT` for a comment, else None."""
    if isinstance(raw, DatasetFormatError):
        raise raw
    old_style = raw.startswith(("FLASER ", "RLASER "))
    if old_style and _read_flaser_line(path, lineno, raw, rows, params):
        return None
    tok = raw.split()
    if not tok:
        return None
    if tok[0].startswith("#"):
        return COMMENT
    kind = tok[0]
    if kind == "ODOM":
        odom.add(lineno, raw)
    elif kind in ("FLASER", "RLASER"):
        _parse_flaser(path, lineno, tok, rows, params)
    elif kind == "ROBOTLASER1":
        _parse_robotlaser(path, lineno, tok, rows)
    elif kind == "RAWLASER1":
        _parse_rawlaser(path, lineno, tok, rows)
    elif kind == "PARAM":
        _parse_param(path, lineno, tok, params)
        return kind
    else:
        if strict and kind not in SKIPPED_TYPES:
            raise DatasetFormatError(path, lineno, f"unknown record type {excerpt(kind)}")
        return kind
    return None


def _stack_scans(rows: _ScanRows, odometry: Odometry) -> tuple[LaserScans, int]:
    """The scans as arrays, and how many RAWLASER1 scans got no pose."""
    count = len(rows.ranges)
    width = max((len(r) for r in rows.ranges), default=0)
    ranges = np.full((count, width), np.nan)
    for k, r in enumerate(rows.ranges):
        ranges[k, : len(r)] = r
    # A row's cells past its own beams are padding, not invalid readings.
    beams = np.array([len(r) for r in rows.ranges], dtype=np.int64).reshape(count)
    bad = ~np.isfinite(ranges) | (ranges < 0)
    invalid = np.count_nonzero(bad & (np.arange(width) < beams[:, None]), axis=1).astype(np.int64)
    ranges[bad] = np.nan
    meta = np.asarray(rows.meta, dtype=np.float64).reshape(count, 10)
    kind = np.asarray(rows.kinds, dtype="<U11").reshape(count)
    raw = kind == "RAWLASER1"
    no_pose = 0
    if raw.any():
        pose = _interpolate_odometry(odometry, meta[raw, 9])
        meta[raw, 3:6] = pose
        meta[raw, 6:9] = pose
        no_pose = int(np.count_nonzero(np.isnan(pose[:, 0])))
    scans = LaserScans(
        ranges=ranges,
        num_beams=beams,
        angle_min=meta[:, 0].copy(),
        angle_increment=meta[:, 1].copy(),
        max_range=meta[:, 2].copy(),
        pose=meta[:, 3:6].copy(),
        odom=meta[:, 6:9].copy(),
        timestamp=meta[:, 9].copy(),
        line=np.asarray(rows.lines, dtype=np.int64),
        invalid=invalid,
        kind=kind,
    )
    return scans, no_pose


def _interpolate_odometry(odometry: Odometry, times: np.ndarray) -> np.ndarray:
    """Odometry poses at ``times``, linear between records (heading along the shorter
    arc); NaN outside the records' time span, where there is nothing to interpolate."""
    out = np.full((len(times), 3), np.nan)
    t = odometry.timestamp
    if len(t) == 0:
        return out
    order = np.argsort(t, kind="stable")
    t, pose = t[order], odometry.pose[order]
    inside = (times >= t[0]) & (times <= t[-1])
    q = times[inside]
    hi = np.clip(np.searchsorted(t, q, side="left"), 1, max(len(t) - 1, 1))
    lo = hi - 1 if len(t) > 1 else hi
    span = t[hi] - t[lo]
    w = np.divide(q - t[lo], span, out=np.zeros_like(q), where=span > 0)
    dth = wrap_angle(pose[hi, 2] - pose[lo, 2])
    xy = pose[lo, :2] + w[:, None] * (pose[hi, :2] - pose[lo, :2])
    th = wrap_angle(pose[lo, 2] + w * dth)
    out[inside] = np.c_[xy, th]
    return out


def _stack_odometry(arr: np.ndarray) -> Odometry:
    return Odometry(
        pose=arr[:, 0:3].copy(), velocity=arr[:, 3:6].copy(), timestamp=arr[:, 6].copy()
    )
