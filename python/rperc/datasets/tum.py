"""Planar trajectories in the TUM RGB-D format, the format evo (``evo_ape``,
``evo_traj``) reads: one pose per line, ``t x y z qx qy qz qw``, the orientation a
unit quaternion (Hamilton, scalar last).

A planar pose ``(x, y, theta)`` is written with ``z = 0`` and the rotation about the
z axis by ``theta``: ``(qx, qy, qz, qw) = (0, 0, sin(theta/2), cos(theta/2))``. Numbers
are written with 17 significant digits, so reading back gives the same float64 values.

Time increases strictly, row by row, in every file written or read
(:func:`rperc.datasets.timestamps.check_increasing`, the rule every trajectory writer and
reader shares): evo refuses repeated or unsorted stamps too. A file is written whole or
not at all: into a temporary file in the same folder, then renamed over the target
(``os.replace``), so a reader never sees half a file and two writers of one path leave
one of their files, never lines of both.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt

from rperc._atomic import write_atomically
from rperc.datasets._table import read_table
from rperc.datasets.errors import DatasetFormatError
from rperc.datasets.timestamps import check_increasing, first_not_increasing, step_problem

__all__ = ["read_tum", "write_tum"]


def _planar_poses(t: npt.ArrayLike, poses: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    times = np.asarray(t, dtype=np.float64)
    p = np.asarray(poses, dtype=np.float64)
    if times.ndim != 1:
        raise ValueError(f"t must be 1-D, got shape {times.shape}")
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses must have shape (N, 3) (x, y, theta), got {p.shape}")
    if len(times) != len(p):
        raise ValueError(f"t has {len(times)} rows but poses has {len(p)}")
    if len(times) == 0:
        raise ValueError("t and poses are empty: a TUM file needs at least one pose")
    bad = np.argwhere(~np.isfinite(p))
    if bad.size:
        raise ValueError(f"poses holds a non-finite value at index {tuple(bad[0].tolist())}")
    return check_increasing(times, "t"), p


def write_tum(path: str | Path, t: npt.ArrayLike, poses: npt.ArrayLike) -> None:
    """Writes planar ``poses`` ``(N, 3)`` at times ``t`` ``(N,)`` to ``path`` in the TUM
    format (``z = 0``, quaternion from the heading).

    ``t`` must be finite and increase strictly (a ``ValueError`` naming the first index
    that does not, and nothing written). The file appears whole: written to a temporary
    file in the same folder, then renamed over ``path``.
    """
    times, p = _planar_poses(t, poses)
    half = p[:, 2] / 2.0
    zeros = np.zeros(len(p))
    rows = np.column_stack(
        [times, p[:, 0], p[:, 1], zeros, zeros, zeros, np.sin(half), np.cos(half)]
    )
    header = "t x y z qx qy qz qw (rperc, planar: z = 0, yaw only)"
    _write_atomically(Path(path), rows, header)


def _write_atomically(path: Path, rows: np.ndarray, header: str) -> None:
    """Writes ``rows`` through :func:`rperc._atomic.write_atomically`."""
    write_atomically(path, lambda tmp: np.savetxt(tmp, rows, fmt="%.17g", header=header))


def _yaw(path: Path, line: int, q: np.ndarray, tolerance: float) -> float:
    """The heading of unit quaternion ``q = (qx, qy, qz, qw)``, after checking that it
    turns about z only (a planar pose)."""
    norm = math.sqrt(float(q @ q))
    if not (math.isfinite(norm) and abs(norm - 1.0) <= 1e-6):
        raise DatasetFormatError(path, line, f"quaternion norm is {norm!r}, not 1")
    qx, qy, qz, qw = (float(v) for v in q / norm)
    if max(abs(qx), abs(qy)) > tolerance:
        raise DatasetFormatError(
            path, line, f"not planar: the rotation has qx={qx!r}, qy={qy!r} (a tilt)"
        )
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    # atan2 can return -pi; rperc's headings live in (-pi, pi].
    return yaw + 2.0 * math.pi if yaw <= -math.pi else yaw


def read_tum(path: str | Path, *, planar_tolerance: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Reads a TUM trajectory as ``(t (N,), poses (N, 3))`` with headings in (-pi, pi].

    A :class:`DatasetFormatError` names the file and line of a malformed record, a NaN,
    a time that does not increase strictly (going backwards or repeating), a quaternion
    that is not of unit norm, or a pose that is not planar (``|z|``, ``|qx|`` or ``|qy|``
    above ``planar_tolerance``).
    """
    table = read_table(path, 8, allow_time_backwards=True)
    values, lines = table.values, table.line
    where = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if where.size:
        raise DatasetFormatError(table.path, int(lines[where[0]]), "non-finite value")
    k = first_not_increasing(values[:, 0])
    if k is not None:
        previous, current = float(values[k - 1, 0]), float(values[k, 0])
        raise DatasetFormatError(
            table.path,
            int(lines[k]),
            f"time {step_problem(previous, current)} (line {int(lines[k - 1])}); "
            "times must increase strictly",
        )
    off_plane = np.flatnonzero(np.abs(values[:, 3]) > planar_tolerance)
    if off_plane.size:
        k = int(off_plane[0])
        raise DatasetFormatError(
            table.path, int(lines[k]), f"not planar: z = {float(values[k, 3])!r}"
        )
    yaw = [
        _yaw(table.path, int(line), q, planar_tolerance)
        for line, q in zip(lines, values[:, 4:8], strict=True)
    ]
    poses = np.column_stack([values[:, 1], values[:, 2], yaw])
    return table.column(0), poses
